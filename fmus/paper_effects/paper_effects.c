/* paper_effects.c: the paper's Section 6 plant (paper_core.h) with an effect that the usual
 * spec does not declare, selected by the parameter `effect`:
 *   0  none:                      y_t = w_t
 *   1  constant sensor offset:    y_t = w_t + offset
 *   2  drifting sensor offset:    y_t = w_t + offset + drift * t/h   (t/h = sample index)
 *   3  one-sample transport delay y_t = w_{t-1}, y_0 = 0
 * Outputs: y (what the sensor reports), w (true backlash output), x (inner signal). One
 * communication step is one sample. */
#define MODEL_GUID "{8c4e810f-3df3-4a00-8276-176fa3c9f003}"
#define N_REAL 16
#define N_STATE 6

enum {
    VR_U, VR_Y, VR_W, VR_X, VR_A1, VR_A2, VR_B0, VR_B1, VR_B2, VR_ML, VR_CL, VR_MR, VR_CR,
    VR_EFFECT, VR_OFFSET, VR_DRIFT
};
static const int VAR_KIND[N_REAL] = {1, 2, 2, 2, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0};

#include "fmu_frame.h"
#include "paper_core.h"

static void model_defaults(double *r) {
    memset(r, 0, sizeof(double) * N_REAL);
    r[VR_A1] = 0.5;
    r[VR_A2] = 0.7;
    r[VR_B0] = 0.0;
    r[VR_B1] = 1.4;
    r[VR_B2] = 0.8;
    r[VR_ML] = 0.248;
    r[VR_CL] = 0.0698;
    r[VR_MR] = 0.252;
    r[VR_CR] = 0.0349;
    r[VR_EFFECT] = 0.0;
    r[VR_OFFSET] = 0.01;
    r[VR_DRIFT] = 1.0e-5;
}

static fmi2Status model_initialize(ModelInstance *m) {
    double e = m->r[VR_EFFECT];
    if (!frame_require(m, m->r[VR_ML] > 0.0, "m_l", "must be > 0")) return fmi2Error;
    if (!frame_require(m, m->r[VR_MR] > 0.0, "m_r", "must be > 0")) return fmi2Error;
    if (!frame_require(m, m->r[VR_CL] >= 0.0, "c_l", "must be >= 0")) return fmi2Error;
    if (!frame_require(m, m->r[VR_CR] >= 0.0, "c_r", "must be >= 0")) return fmi2Error;
    if (!frame_require(m, e == 0.0 || e == 1.0 || e == 2.0 || e == 3.0, "effect",
                       "must be 0 (none), 1 (offset), 2 (drift) or 3 (delay)"))
        return fmi2Error;
    memset(m->s, 0, sizeof m->s);
    m->r[VR_W] = 0.0;
    m->r[VR_X] = 0.0;
    m->r[VR_Y] = (e == 1.0 || e == 2.0) ? m->r[VR_OFFSET] : 0.0;
    return fmi2OK;
}

static fmi2Status model_step(ModelInstance *m, double t, double h) {
    (void)h;
    PaperParams p = {m->r[VR_A1], m->r[VR_A2], m->r[VR_B0], m->r[VR_B1], m->r[VR_B2],
                     m->r[VR_ML], m->r[VR_CL], m->r[VR_MR], m->r[VR_CR]};
    PaperState *s = (PaperState *)m->s;
    double *w_delayed = &m->s[5];
    double x, w, y;
    paper_step(&p, s, m->r[VR_U], &x, &w);
    switch ((int)m->r[VR_EFFECT]) {
    case 1: y = w + m->r[VR_OFFSET]; break;
    case 2: y = w + (m->r[VR_OFFSET] + m->r[VR_DRIFT] * (double)m->steps); break;
    case 3: y = *w_delayed; break;
    default: y = w; break;
    }
    *w_delayed = w;
    if (!isfinite(y) || !isfinite(x)) {
        frame_log_error(m, "non-finite output `y` at t = %g (x = %g)", t, x);
        return fmi2Error;
    }
    m->r[VR_X] = x;
    m->r[VR_W] = w;
    m->r[VR_Y] = y;
    return fmi2OK;
}
