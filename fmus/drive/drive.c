/* drive.c: a continuous-time position drive as an FMI 2.0 co-simulation FMU.
 *
 * A motor (inertia J_m, viscous b_m, Coulomb Fc_m) is held on the reference n*u by a PD servo
 * (Kp, Kd) acting on the motor angle. It drives a load (inertia J_l, viscous b_l, Coulomb Fc_l)
 * through a gearbox of ratio n with backlash: in load-side units the gear output x = theta_m/n
 * meets the load only when |x - theta_l| > beta, through a contact of stiffness k_c and damping
 * d_c that can push but never pull. Coulomb friction is regularised, F tanh(omega/w_s). The
 * four states are integrated inside doStep with classical Runge-Kutta 4 at a fixed internal
 * step (h / ceil(h / h_int)). The load angle is read by a multi-turn absolute encoder of
 * `encoder_bits` bits per revolution, rounding to the nearest count: y = q round(theta_l / q),
 * q = 2 pi / 2^encoder_bits.
 *
 * Input u: reference of the gear-output angle (rad, load side). Outputs: y (encoder reading),
 * theta_l (true load angle), x (gear output angle theta_m / n). Starts at rest at zero. */
#define MODEL_GUID "{8c4e810f-3df3-4a00-8276-176fa3c9f002}"
#define N_REAL 19
#define N_STATE 4

enum {
    VR_U, VR_Y, VR_THETA_L, VR_X, VR_N, VR_JM, VR_JL, VR_BETA, VR_KC, VR_DC, VR_BM, VR_BL,
    VR_FCM, VR_FCL, VR_WS, VR_KP, VR_KD, VR_BITS, VR_HINT
};
static const int VAR_KIND[N_REAL] = {1, 2, 2, 2, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0};

#include "fmu_frame.h"

static void model_defaults(double *r) {
    memset(r, 0, sizeof(double) * N_REAL);
    r[VR_N] = 10.0;
    r[VR_JM] = 1.0e-4;
    r[VR_JL] = 1.0e-2;
    r[VR_BETA] = 0.05;
    r[VR_KC] = 1000.0;
    r[VR_DC] = 3.0;
    r[VR_BM] = 1.0e-3;
    r[VR_BL] = 0.5;
    r[VR_FCM] = 2.0e-3;
    r[VR_FCL] = 0.05;
    r[VR_WS] = 0.05;
    r[VR_KP] = 0.1;
    r[VR_KD] = 4.4e-3;
    r[VR_BITS] = 16.0;
    r[VR_HINT] = 1.0e-4;
}

static double encoder(const double *r, double theta) {
    double q = 2.0 * M_PI / pow(2.0, r[VR_BITS]);
    return q * floor(theta / q + 0.5);
}

static fmi2Status model_initialize(ModelInstance *m) {
    const double *r = m->r;
    static const int positive[] = {VR_N, VR_JM, VR_JL, VR_KC, VR_WS, VR_KP, VR_HINT};
    static const char *names[] = {"n", "J_m", "J_l", "k_c", "w_s", "Kp", "h_int"};
    for (size_t i = 0; i < sizeof positive / sizeof positive[0]; i++)
        if (!frame_require(m, r[positive[i]] > 0.0, names[i], "must be > 0")) return fmi2Error;
    static const int nonneg[] = {VR_BETA, VR_DC, VR_BM, VR_BL, VR_FCM, VR_FCL, VR_KD};
    static const char *nn_names[] = {"beta", "d_c", "b_m", "b_l", "Fc_m", "Fc_l", "Kd"};
    for (size_t i = 0; i < sizeof nonneg / sizeof nonneg[0]; i++)
        if (!frame_require(m, r[nonneg[i]] >= 0.0, nn_names[i], "must be >= 0")) return fmi2Error;
    if (!frame_require(m, r[VR_BITS] >= 1.0 && r[VR_BITS] <= 52.0 && r[VR_BITS] == floor(r[VR_BITS]),
                       "encoder_bits", "must be an integer in 1..52"))
        return fmi2Error;
    memset(m->s, 0, sizeof m->s);
    m->r[VR_Y] = encoder(r, 0.0);
    m->r[VR_THETA_L] = 0.0;
    m->r[VR_X] = 0.0;
    return fmi2OK;
}

/* Derivatives of (theta_m, omega_m, theta_l, omega_l) for the reference u. */
static void deriv(const double *r, double u, const double *s, double *d) {
    double n = r[VR_N], beta = r[VR_BETA];
    double th_m = s[0], om_m = s[1], th_l = s[2], om_l = s[3];
    double delta = th_m / n - th_l, ddelta = om_m / n - om_l;
    double tc = 0.0; /* contact torque on the load (load side) */
    if (delta > beta) {
        tc = r[VR_KC] * (delta - beta) + r[VR_DC] * ddelta;
        if (tc < 0.0) tc = 0.0;
    } else if (delta < -beta) {
        tc = r[VR_KC] * (delta + beta) + r[VR_DC] * ddelta;
        if (tc > 0.0) tc = 0.0;
    }
    double servo = r[VR_KP] * (n * u - th_m) - r[VR_KD] * om_m;
    double fm = r[VR_BM] * om_m + r[VR_FCM] * tanh(om_m / r[VR_WS]);
    double fl = r[VR_BL] * om_l + r[VR_FCL] * tanh(om_l / r[VR_WS]);
    d[0] = om_m;
    d[1] = (servo - fm - tc / n) / r[VR_JM];
    d[2] = om_l;
    d[3] = (tc - fl) / r[VR_JL];
}

static fmi2Status model_step(ModelInstance *m, double t, double h) {
    const double *r = m->r;
    double u = r[VR_U];
    double *s = m->s;
    long n_sub = (long)ceil(h / r[VR_HINT]);
    if (n_sub < 1) n_sub = 1;
    if (n_sub > 100000000L) {
        frame_log_error(m, "step %g at t = %g needs more than 1e8 internal steps of h_int = %g", h,
                        t, r[VR_HINT]);
        return fmi2Error;
    }
    double dt = h / (double)n_sub;
    for (long i = 0; i < n_sub; i++) {
        double k1[4], k2[4], k3[4], k4[4], tmp[4];
        deriv(r, u, s, k1);
        for (int j = 0; j < 4; j++) tmp[j] = s[j] + 0.5 * dt * k1[j];
        deriv(r, u, tmp, k2);
        for (int j = 0; j < 4; j++) tmp[j] = s[j] + 0.5 * dt * k2[j];
        deriv(r, u, tmp, k3);
        for (int j = 0; j < 4; j++) tmp[j] = s[j] + dt * k3[j];
        deriv(r, u, tmp, k4);
        for (int j = 0; j < 4; j++) s[j] += dt / 6.0 * (k1[j] + 2.0 * k2[j] + 2.0 * k3[j] + k4[j]);
    }
    for (int j = 0; j < 4; j++) {
        if (!isfinite(s[j])) {
            frame_log_error(m, "state %d became non-finite at t = %g (unstable parameters?)", j,
                            t + h);
            return fmi2Error;
        }
    }
    m->r[VR_THETA_L] = s[2];
    m->r[VR_X] = s[0] / r[VR_N];
    m->r[VR_Y] = encoder(r, s[2]);
    return fmi2OK;
}
