/* paper_core.h: one sample of the paper's Section 6 plant, a second-order linear block
 *   x_t = -a1 x_{t-1} - a2 x_{t-2} + b0 u_t + b1 u_{t-1} + b2 u_{t-2}
 * followed by the output backlash of eq (2)
 *   w_t = m_l (x_t + c_l)  if x_t <= w_{t-1}/m_l - c_l
 *         m_r (x_t - c_r)  if x_t >= w_{t-1}/m_r + c_r
 *         w_{t-1}          otherwise,
 * with exactly the operations, in the same order, of smid's host simulator
 * (smid-core LinearSim::step and smid-output-backlash Backlash::map), so that the results agree
 * bit for bit when compiled with -ffp-contract=off. */
#ifndef SMID_PAPER_CORE_H
#define SMID_PAPER_CORE_H

typedef struct {
    double a1, a2, b0, b1, b2, m_l, c_l, m_r, c_r;
} PaperParams;

/* State: x_{t-1}, x_{t-2}, u_{t-1}, u_{t-2}, w_{t-1}; all zero at rest. */
typedef struct {
    double x1, x2, u1, u2, w1;
} PaperState;

static double paper_backlash(const PaperParams *p, double w_prev, double x) {
    double z_l = w_prev / p->m_l - p->c_l;
    double z_r = w_prev / p->m_r + p->c_r;
    if (x <= z_l) return p->m_l * (x + p->c_l);
    if (x >= z_r) return p->m_r * (x - p->c_r);
    return w_prev;
}

/* Feed u_t; returns x_t in *x and w_t in *w. */
static void paper_step(const PaperParams *p, PaperState *s, double u, double *x, double *w) {
    double v = 0.0;
    v += p->b0 * u;
    v += p->b1 * s->u1;
    v += p->b2 * s->u2;
    v -= p->a1 * s->x1;
    v -= p->a2 * s->x2;
    s->u2 = s->u1;
    s->u1 = u;
    s->x2 = s->x1;
    s->x1 = v;
    *x = v;
    *w = paper_backlash(p, s->w1, v);
    s->w1 = *w;
}

#endif
