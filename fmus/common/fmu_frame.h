/* fmu_frame.h: the FMI 2.0 co-simulation frame shared by smid's plant FMUs.
 *
 * It implements every fmi2 function (Model-Exchange ones as stubs returning fmi2Error) for a
 * plant whose variables are all Reals with value reference = index into `r[]`. A plant's C file
 * defines, BEFORE including this header:
 *
 *   #define MODEL_GUID "{...}"           the guid of its modelDescription.xml
 *   #define N_REAL     <count>           number of Real variables (value references 0..N_REAL-1)
 *   #define N_STATE    <count>           number of internal state doubles (>= 1)
 *   static const int VAR_KIND[N_REAL];   KIND_PARAMETER, KIND_INPUT or KIND_OUTPUT per variable
 *
 * and, AFTER including it, the three model functions declared below:
 *
 *   model_defaults(r)        start values of every variable (called at instantiation and reset)
 *   model_initialize(m)      check parameters, put the plant at rest, compute initial outputs
 *   model_step(m, t, h)      advance the plant from t to t + h with the current inputs
 *
 * Both of the latter return fmi2OK, or fmi2Error after calling frame_log_error(m, ...) with a
 * message naming the variable and the time. The frame refuses to set outputs, refuses to set
 * parameters after initialization, rejects non-finite input values, and refuses calls after an
 * error (the instance must be reset or freed).
 *
 * Built as one translation unit per FMU with -ffp-contract=off so that the arithmetic is the
 * same, operation for operation, as smid's host-side Rust simulator.
 */
#ifndef SMID_FMU_FRAME_H
#define SMID_FMU_FRAME_H

#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi2Functions.h"

#define KIND_PARAMETER 0
#define KIND_INPUT 1
#define KIND_OUTPUT 2

enum Phase { PHASE_INSTANTIATED, PHASE_INIT, PHASE_STEP, PHASE_TERMINATED, PHASE_ERROR };

typedef struct {
    double r[N_REAL];
    double s[N_STATE];
    double time;
    long steps;
    enum Phase phase;
    char *name;
    fmi2Boolean logging_on;
    fmi2CallbackLogger logger;
    fmi2CallbackAllocateMemory alloc;
    fmi2CallbackFreeMemory free_mem;
    fmi2ComponentEnvironment env;
} ModelInstance;

static void model_defaults(double *r);
static fmi2Status model_initialize(ModelInstance *m);
static fmi2Status model_step(ModelInstance *m, double t, double h);

/* Log an error through the master's logger (always, as FMI 2.0 requires for errors). */
static void frame_log_error(ModelInstance *m, const char *fmt, ...) {
    char buf[512];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(buf, sizeof buf, fmt, ap);
    va_end(ap);
    if (m->logger) m->logger(m->env, m->name, fmi2Error, "logStatusError", "%s", buf);
}

static fmi2Status frame_fail(ModelInstance *m, fmi2Status st) {
    if (st == fmi2Error || st == fmi2Fatal) m->phase = PHASE_ERROR;
    return st;
}

const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }
const char *fmi2GetVersion(void) { return fmi2Version; }

fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean loggingOn, size_t nCategories,
                               const fmi2String categories[]) {
    (void)nCategories;
    (void)categories;
    if (!c) return fmi2Error;
    ((ModelInstance *)c)->logging_on = loggingOn;
    return fmi2OK;
}

fmi2Component fmi2Instantiate(fmi2String instanceName, fmi2Type fmuType, fmi2String fmuGUID,
                              fmi2String fmuResourceLocation,
                              const fmi2CallbackFunctions *functions, fmi2Boolean visible,
                              fmi2Boolean loggingOn) {
    (void)fmuResourceLocation;
    (void)visible;
    if (!functions || !functions->allocateMemory || !functions->freeMemory) return NULL;
    const char *name = instanceName ? instanceName : "fmu";
    if (fmuType != fmi2CoSimulation) {
        if (functions->logger)
            functions->logger(functions->componentEnvironment, name, fmi2Error, "logStatusError",
                              "%s", "only co-simulation is supported");
        return NULL;
    }
    if (!fmuGUID || strcmp(fmuGUID, MODEL_GUID) != 0) {
        if (functions->logger)
            functions->logger(functions->componentEnvironment, name, fmi2Error, "logStatusError",
                              "%s", "GUID does not match modelDescription.xml");
        return NULL;
    }
    ModelInstance *m = (ModelInstance *)functions->allocateMemory(1, sizeof(ModelInstance));
    if (!m) return NULL;
    memset(m, 0, sizeof *m);
    m->name = (char *)functions->allocateMemory(strlen(name) + 1, 1);
    if (!m->name) {
        functions->freeMemory(m);
        return NULL;
    }
    strcpy(m->name, name);
    m->logger = functions->logger;
    m->alloc = functions->allocateMemory;
    m->free_mem = functions->freeMemory;
    m->env = functions->componentEnvironment;
    m->logging_on = loggingOn;
    model_defaults(m->r);
    m->phase = PHASE_INSTANTIATED;
    return m;
}

void fmi2FreeInstance(fmi2Component c) {
    ModelInstance *m = (ModelInstance *)c;
    if (!m) return;
    fmi2CallbackFreeMemory f = m->free_mem;
    f(m->name);
    f(m);
}

fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean toleranceDefined, fmi2Real tolerance,
                               fmi2Real startTime, fmi2Boolean stopTimeDefined,
                               fmi2Real stopTime) {
    (void)toleranceDefined;
    (void)tolerance;
    (void)stopTimeDefined;
    (void)stopTime;
    ModelInstance *m = (ModelInstance *)c;
    if (!m || m->phase != PHASE_INSTANTIATED) return fmi2Error;
    m->time = startTime;
    return fmi2OK;
}

fmi2Status fmi2EnterInitializationMode(fmi2Component c) {
    ModelInstance *m = (ModelInstance *)c;
    if (!m || m->phase != PHASE_INSTANTIATED) return fmi2Error;
    m->phase = PHASE_INIT;
    return fmi2OK;
}

fmi2Status fmi2ExitInitializationMode(fmi2Component c) {
    ModelInstance *m = (ModelInstance *)c;
    if (!m || m->phase != PHASE_INIT) return fmi2Error;
    m->steps = 0;
    fmi2Status st = model_initialize(m);
    if (st != fmi2OK) return frame_fail(m, st);
    m->phase = PHASE_STEP;
    return fmi2OK;
}

fmi2Status fmi2Terminate(fmi2Component c) {
    ModelInstance *m = (ModelInstance *)c;
    if (!m) return fmi2Error;
    m->phase = PHASE_TERMINATED;
    return fmi2OK;
}

fmi2Status fmi2Reset(fmi2Component c) {
    ModelInstance *m = (ModelInstance *)c;
    if (!m) return fmi2Error;
    model_defaults(m->r);
    memset(m->s, 0, sizeof m->s);
    m->time = 0.0;
    m->steps = 0;
    m->phase = PHASE_INSTANTIATED;
    return fmi2OK;
}

fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                       fmi2Real value[]) {
    ModelInstance *m = (ModelInstance *)c;
    if (!m || m->phase == PHASE_ERROR) return fmi2Error;
    for (size_t i = 0; i < nvr; i++) {
        if (vr[i] >= N_REAL) {
            frame_log_error(m, "fmi2GetReal: unknown value reference %u", (unsigned)vr[i]);
            return fmi2Error;
        }
        value[i] = m->r[vr[i]];
    }
    return fmi2OK;
}

fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                       const fmi2Real value[]) {
    ModelInstance *m = (ModelInstance *)c;
    if (!m || m->phase == PHASE_ERROR || m->phase == PHASE_TERMINATED) return fmi2Error;
    for (size_t i = 0; i < nvr; i++) {
        if (vr[i] >= N_REAL) {
            frame_log_error(m, "fmi2SetReal: unknown value reference %u", (unsigned)vr[i]);
            return fmi2Error;
        }
        int kind = VAR_KIND[vr[i]];
        if (kind == KIND_OUTPUT) {
            frame_log_error(m, "fmi2SetReal: value reference %u is an output", (unsigned)vr[i]);
            return fmi2Error;
        }
        if (kind == KIND_PARAMETER && m->phase == PHASE_STEP) {
            frame_log_error(m, "fmi2SetReal: parameter %u is fixed after initialization",
                            (unsigned)vr[i]);
            return fmi2Error;
        }
        if (!isfinite(value[i])) {
            frame_log_error(m, "fmi2SetReal: non-finite value for value reference %u at t = %g",
                            (unsigned)vr[i], m->time);
            return fmi2Error;
        }
        m->r[vr[i]] = value[i];
    }
    return fmi2OK;
}

fmi2Status fmi2GetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                          fmi2Integer value[]) {
    (void)vr;
    (void)value;
    return (c && nvr == 0) ? fmi2OK : fmi2Error;
}
fmi2Status fmi2GetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                          fmi2Boolean value[]) {
    (void)vr;
    (void)value;
    return (c && nvr == 0) ? fmi2OK : fmi2Error;
}
fmi2Status fmi2GetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                         fmi2String value[]) {
    (void)vr;
    (void)value;
    return (c && nvr == 0) ? fmi2OK : fmi2Error;
}
fmi2Status fmi2SetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                          const fmi2Integer value[]) {
    (void)vr;
    (void)value;
    return (c && nvr == 0) ? fmi2OK : fmi2Error;
}
fmi2Status fmi2SetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                          const fmi2Boolean value[]) {
    (void)vr;
    (void)value;
    return (c && nvr == 0) ? fmi2OK : fmi2Error;
}
fmi2Status fmi2SetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                         const fmi2String value[]) {
    (void)vr;
    (void)value;
    return (c && nvr == 0) ? fmi2OK : fmi2Error;
}

/* FMU state: not supported (canGetAndSetFMUstate="false"). */
fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate *s) {
    (void)c;
    (void)s;
    return fmi2Error;
}
fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate s) {
    (void)c;
    (void)s;
    return fmi2Error;
}
fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate *s) {
    (void)c;
    (void)s;
    return fmi2Error;
}
fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate s, size_t *n) {
    (void)c;
    (void)s;
    (void)n;
    return fmi2Error;
}
fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate s, fmi2Byte b[], size_t n) {
    (void)c;
    (void)s;
    (void)b;
    (void)n;
    return fmi2Error;
}
fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte b[], size_t n,
                                   fmi2FMUstate *s) {
    (void)c;
    (void)b;
    (void)n;
    (void)s;
    return fmi2Error;
}
fmi2Status fmi2GetDirectionalDerivative(fmi2Component c, const fmi2ValueReference u[], size_t nu,
                                        const fmi2ValueReference z[], size_t nz,
                                        const fmi2Real dv[], fmi2Real dz[]) {
    (void)c;
    (void)u;
    (void)nu;
    (void)z;
    (void)nz;
    (void)dv;
    (void)dz;
    return fmi2Error;
}

/* Model Exchange: not supported; stubs so that every fmi2 symbol is exported. */
fmi2Status fmi2EnterEventMode(fmi2Component c) {
    (void)c;
    return fmi2Error;
}
fmi2Status fmi2NewDiscreteStates(fmi2Component c, fmi2EventInfo *e) {
    (void)c;
    (void)e;
    return fmi2Error;
}
fmi2Status fmi2EnterContinuousTimeMode(fmi2Component c) {
    (void)c;
    return fmi2Error;
}
fmi2Status fmi2CompletedIntegratorStep(fmi2Component c, fmi2Boolean noSet, fmi2Boolean *enter,
                                       fmi2Boolean *term) {
    (void)c;
    (void)noSet;
    (void)enter;
    (void)term;
    return fmi2Error;
}
fmi2Status fmi2SetTime(fmi2Component c, fmi2Real t) {
    (void)c;
    (void)t;
    return fmi2Error;
}
fmi2Status fmi2SetContinuousStates(fmi2Component c, const fmi2Real x[], size_t n) {
    (void)c;
    (void)x;
    (void)n;
    return fmi2Error;
}
fmi2Status fmi2GetDerivatives(fmi2Component c, fmi2Real d[], size_t n) {
    (void)c;
    (void)d;
    (void)n;
    return fmi2Error;
}
fmi2Status fmi2GetEventIndicators(fmi2Component c, fmi2Real e[], size_t n) {
    (void)c;
    (void)e;
    (void)n;
    return fmi2Error;
}
fmi2Status fmi2GetContinuousStates(fmi2Component c, fmi2Real x[], size_t n) {
    (void)c;
    (void)x;
    (void)n;
    return fmi2Error;
}
fmi2Status fmi2GetNominalsOfContinuousStates(fmi2Component c, fmi2Real x[], size_t n) {
    (void)c;
    (void)x;
    (void)n;
    return fmi2Error;
}

/* Co-Simulation. */
fmi2Status fmi2SetRealInputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t n,
                                       const fmi2Integer order[], const fmi2Real value[]) {
    (void)c;
    (void)vr;
    (void)n;
    (void)order;
    (void)value;
    return fmi2Error;
}
fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t n,
                                        const fmi2Integer order[], fmi2Real value[]) {
    (void)c;
    (void)vr;
    (void)n;
    (void)order;
    (void)value;
    return fmi2Error;
}

fmi2Status fmi2DoStep(fmi2Component c, fmi2Real currentCommunicationPoint,
                      fmi2Real communicationStepSize, fmi2Boolean noSetFMUStatePriorToCurrentPoint) {
    (void)noSetFMUStatePriorToCurrentPoint;
    ModelInstance *m = (ModelInstance *)c;
    if (!m) return fmi2Error;
    if (m->phase != PHASE_STEP) {
        frame_log_error(m, "fmi2DoStep at t = %g: not in step mode", currentCommunicationPoint);
        return fmi2Error;
    }
    if (!(communicationStepSize > 0.0) || !isfinite(communicationStepSize)) {
        frame_log_error(m, "fmi2DoStep at t = %g: invalid step size %g", currentCommunicationPoint,
                        communicationStepSize);
        return frame_fail(m, fmi2Error);
    }
    fmi2Status st = model_step(m, currentCommunicationPoint, communicationStepSize);
    if (st != fmi2OK) return frame_fail(m, st);
    m->steps += 1;
    m->time = currentCommunicationPoint + communicationStepSize;
    return fmi2OK;
}

fmi2Status fmi2CancelStep(fmi2Component c) {
    (void)c;
    return fmi2Error;
}
fmi2Status fmi2GetStatus(fmi2Component c, const fmi2StatusKind s, fmi2Status *value) {
    (void)c;
    (void)s;
    (void)value;
    return fmi2Discard;
}
fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind s, fmi2Real *value) {
    ModelInstance *m = (ModelInstance *)c;
    if (!m || s != fmi2LastSuccessfulTime) return fmi2Discard;
    *value = m->time;
    return fmi2OK;
}
fmi2Status fmi2GetIntegerStatus(fmi2Component c, const fmi2StatusKind s, fmi2Integer *value) {
    (void)c;
    (void)s;
    (void)value;
    return fmi2Discard;
}
fmi2Status fmi2GetBooleanStatus(fmi2Component c, const fmi2StatusKind s, fmi2Boolean *value) {
    (void)c;
    (void)s;
    (void)value;
    return fmi2Discard;
}
fmi2Status fmi2GetStringStatus(fmi2Component c, const fmi2StatusKind s, fmi2String *value) {
    (void)c;
    (void)s;
    (void)value;
    return fmi2Discard;
}

/* Shared parameter checks for model_initialize. */
static int frame_require(ModelInstance *m, int ok, const char *var, const char *what) {
    if (!ok) frame_log_error(m, "parameter `%s` %s (at t = %g)", var, what, m->time);
    return ok;
}

#endif
