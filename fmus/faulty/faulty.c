/* faulty.c: a test fixture, not a plant. A first-order lag y_t = a y_{t-1} + (1 - a) u_t that,
 * from the communication point `fail_at` on (negative: never), fails as `fail_kind` selects:
 * 1 doStep returns fmi2Error (with a logged message), 2 the output is NaN, 3 the output is +Inf
 * (both with status fmi2OK, so the host itself must notice). */
#define MODEL_GUID "{8c4e810f-3df3-4a00-8276-176fa3c9f004}"
#define N_REAL 5
#define N_STATE 1

enum { VR_U, VR_Y, VR_A, VR_FAIL_AT, VR_FAIL_KIND };
static const int VAR_KIND[N_REAL] = {1, 2, 0, 0, 0};

#include "fmu_frame.h"

static void model_defaults(double *r) {
    r[VR_U] = 0.0;
    r[VR_Y] = 0.0;
    r[VR_A] = 0.5;
    r[VR_FAIL_AT] = -1.0;
    r[VR_FAIL_KIND] = 1.0;
}

static fmi2Status model_initialize(ModelInstance *m) {
    double k = m->r[VR_FAIL_KIND];
    if (!frame_require(m, k == 1.0 || k == 2.0 || k == 3.0, "fail_kind", "must be 1, 2 or 3"))
        return fmi2Error;
    m->s[0] = 0.0;
    m->r[VR_Y] = 0.0;
    return fmi2OK;
}

static fmi2Status model_step(ModelInstance *m, double t, double h) {
    (void)h;
    double a = m->r[VR_A];
    double y = a * m->s[0] + (1.0 - a) * m->r[VR_U];
    if (m->r[VR_FAIL_AT] >= 0.0 && t >= m->r[VR_FAIL_AT]) {
        int kind = (int)m->r[VR_FAIL_KIND];
        if (kind == 1) {
            frame_log_error(m, "injected failure of `y` at t = %g", t);
            return fmi2Error;
        }
        y = kind == 2 ? NAN : INFINITY;
    }
    m->s[0] = y;
    m->r[VR_Y] = y;
    return fmi2OK;
}
