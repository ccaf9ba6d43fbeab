/* paper.c: the paper's Section 6 plant as an FMI 2.0 co-simulation FMU. One communication step
 * is one sample: doStep(t, h) reads the input u_t and sets the outputs w_t (backlash output) and
 * x_t (inner signal). The linear coefficients and backlash parameters are FMU parameters whose
 * defaults are the paper's values (see paper_core.h for the arithmetic). */
#define MODEL_GUID "{8c4e810f-3df3-4a00-8276-176fa3c9f001}"
#define N_REAL 12
#define N_STATE 5

enum { VR_U, VR_W, VR_X, VR_A1, VR_A2, VR_B0, VR_B1, VR_B2, VR_ML, VR_CL, VR_MR, VR_CR };
static const int VAR_KIND[N_REAL] = {1, 2, 2, 0, 0, 0, 0, 0, 0, 0, 0, 0};

#include "fmu_frame.h"
#include "paper_core.h"

static void model_defaults(double *r) {
    r[VR_U] = 0.0;
    r[VR_W] = 0.0;
    r[VR_X] = 0.0;
    r[VR_A1] = 0.5;
    r[VR_A2] = 0.7;
    r[VR_B0] = 0.0;
    r[VR_B1] = 1.4;
    r[VR_B2] = 0.8;
    r[VR_ML] = 0.248;
    r[VR_CL] = 0.0698;
    r[VR_MR] = 0.252;
    r[VR_CR] = 0.0349;
}

static PaperParams params(const ModelInstance *m) {
    PaperParams p = {m->r[VR_A1], m->r[VR_A2], m->r[VR_B0], m->r[VR_B1], m->r[VR_B2],
                     m->r[VR_ML], m->r[VR_CL], m->r[VR_MR], m->r[VR_CR]};
    return p;
}

static fmi2Status model_initialize(ModelInstance *m) {
    if (!frame_require(m, m->r[VR_ML] > 0.0, "m_l", "must be > 0")) return fmi2Error;
    if (!frame_require(m, m->r[VR_MR] > 0.0, "m_r", "must be > 0")) return fmi2Error;
    if (!frame_require(m, m->r[VR_CL] >= 0.0, "c_l", "must be >= 0")) return fmi2Error;
    if (!frame_require(m, m->r[VR_CR] >= 0.0, "c_r", "must be >= 0")) return fmi2Error;
    memset(m->s, 0, sizeof m->s);
    m->r[VR_W] = 0.0;
    m->r[VR_X] = 0.0;
    return fmi2OK;
}

static fmi2Status model_step(ModelInstance *m, double t, double h) {
    (void)h;
    PaperParams p = params(m);
    PaperState *s = (PaperState *)m->s;
    double x, w;
    paper_step(&p, s, m->r[VR_U], &x, &w);
    if (!isfinite(x) || !isfinite(w)) {
        frame_log_error(m, "non-finite output `w` at t = %g (x = %g)", t, x);
        return fmi2Error;
    }
    m->r[VR_X] = x;
    m->r[VR_W] = w;
    return fmi2OK;
}
