//! A structure-exploiting interior-point method for the shared-error LP of stage 3
//! (`relax.rs`, paper eqs 1, 28-30), whose cost per iteration is linear in the record.
//!
//! The LP has a few global variables (the free θ) and many local ones grouped in **blocks**:
//! one block per uncertain sample `δ_s` holding `δ_s` and its products `w = θ_k δ_s`. Every
//! variable has a box (θ: the current box; `δ`: its propagated box; `w`: the product of the
//! two). The inequalities (McCormick envelopes) each touch one block and one θ; the equalities
//! (one per equation `t`) touch θ and the blocks of the samples `t - L .. t`, so in time order
//! they form a band of width `L = max(na, nb)`; the unit gain is one more equality in θ alone.
//!
//! Mehrotra's predictor-corrector method on the variables scaled to `[0, 1]`. Each Newton
//! system is solved by block elimination: the blocks' small dense Hessians are factored, the
//! equality multipliers' Schur complement `M = E_y H_y⁻¹ E_yᵀ` is banded (bandwidth `L`) and
//! factored as a band, and what remains is a dense system in θ (and the gain multiplier).
//! So one iteration costs `O(N (b² + L² + L·nθ + nθ²))` for `N` samples, blocks of size `b`,
//! `nθ` free parameters, instead of a general sparse factorisation.
//!
//! **Guarantee, whatever the iterations did.** No bound is read from the iterates' objective.
//! From the final dual point (inequality multipliers clamped at 0, equality multipliers free)
//! weak duality over the variables' boxes gives, for every feasible point,
//! `c·z >= -λ·h' - μ·f - |μ|·pad + Σ_j min(r_j l_j, r_j u_j)`, `r = c + Gᵀλ + Eᵀμ`, with the
//! inequality right-hand sides `h'` relaxed by [`ROW_PAD`], each equality allowed its pad, and
//! every sum carried with a rigorous bound of its rounding error. The true `(θ, δ, θδ)` satisfies
//! every row and lies in the boxes, so the bound holds at the truth: an inaccurate or stopped
//! solve gives a looser bound, never a wrong one. A lower bound above the objective variable's
//! box proves the LP empty, and so does a positive bound of the zero objective (Farkas over the
//! boxes): a run whose iterates diverge (the multipliers growing along such a ray) is certified
//! at each such iteration and ends at the first proof, and a round's warm start proves it for
//! every objective at once ([`Prepared::warm_start`]).
//!
//! The method's files: this module (the LP in block form, its scaling, the objectives and the
//! certificate), `mehrotra.rs` (the predictor-corrector iterations and the block elimination
//! of each Newton system) and `linalg.rs` (the small dense and banded Cholesky factors and the
//! sparse rows they read).
mod linalg;
mod mehrotra;

use crate::interval::Interval;
use crate::lp::ROW_PAD;
use linalg::Csr;
use mehrotra::Ipm;

/// A sparse row over the global variable index (θ first, then the local variables).
pub type SparseRow = Vec<(usize, f64)>;

/// The shared-error LP in block form (see the module doc).
#[derive(Debug, Clone, Default)]
pub struct BlockLp {
    /// Global variables (the free θ), indices `0..nt`.
    pub nt: usize,
    /// Box of every variable (original units).
    pub boxes: Vec<Interval>,
    /// Local variables of each block: `[start, end)` in the global index; blocks are
    /// contiguous and in order, starting at `nt`.
    pub blocks: Vec<(usize, usize)>,
    /// Inequalities `g·z <= h` (each within one block and θ), grouped by block:
    /// `ineq_of[b]` is their range in `ineq`.
    pub ineq: Vec<(SparseRow, f64)>,
    /// The range in [`Self::ineq`] of each block's inequalities.
    pub ineq_of: Vec<(usize, usize)>,
    /// Equalities `e·z = f` with their allowed pad, in time order (banded in the blocks).
    pub eq: Vec<(SparseRow, f64, f64)>,
    /// Equalities in θ alone (the unit gain), with their pad.
    pub theta_eq: Vec<(SparseRow, f64, f64)>,
}

/// What one run of [`Prepared::minimise_at`] found.
#[derive(Debug, Clone)]
pub struct Solved {
    /// The guaranteed bound.
    pub bound: Bound,
    /// The last primal iterate (original units, inside the boxes; θ first): an approximate
    /// optimiser, for searches that need one.
    pub point: Vec<f64>,
    /// How much the bound leans on each equality (`BlockLp::eq` order): the magnitude of its
    /// final multiplier, in original units. Near 0 for an equation the optimum does not need;
    /// a hint for choosing equations, never part of a bound.
    pub eq_weight: Vec<f64>,
    /// Newton steps the run took (at most the cap, [`MAX_ITER`]).
    pub iterations: usize,
}

/// The outcome of one bound.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Bound {
    /// A guaranteed lower bound of `min c·z` (`None` when the certificate is not finite).
    Value(Option<f64>),
    /// The LP is empty (proven by the certificate).
    Infeasible,
}

/// `(k + 2) ε`: relative rounding error bound of a sum of `k` products.
fn gamma(k: usize) -> f64 {
    (k as f64 + 2.0) * f64::EPSILON
}

/// The scaled problem and the elimination structure, shared by all objectives.
pub struct Prepared<'a> {
    lp: &'a BlockLp,
    n: usize,
    /// Scaled coordinates: `z = lo + w ẑ` (`w` the box widths).
    w: Vec<f64>,
    /// Scaled inequalities `ĝ ẑ <= ĥ` and their row scales (`ĝ = g∘w / ρ`).
    g: Csr,
    h: Vec<f64>,
    rho_g: Vec<f64>,
    /// Scaled equalities.
    e: Csr,
    f: Vec<f64>,
    rho_e: Vec<f64>,
    te: Csr,
    tf: Vec<f64>,
    rho_te: Vec<f64>,
    /// Per block: the θ's its inequalities touch.
    theta_of: Vec<Vec<usize>>,
    /// Per block `b`: the equalities touching it, `eq_items[eq_ptr[b]..eq_ptr[b + 1]]`, each
    /// (equality, k) with its entries `eq_ent.row(k)` (local offset, coef).
    eq_ptr: Vec<usize>,
    eq_items: Vec<(usize, usize)>,
    eq_ent: Csr,
    /// Per equality: its θ entries.
    e_theta: Csr,
    band: usize,
}

impl<'a> Prepared<'a> {
    /// Scale and index `lp`; `None` when a box is not finite (the caller falls back).
    pub fn new(lp: &'a BlockLp) -> Option<Self> {
        let nt = lp.nt;
        let n = lp.boxes.len();
        if lp
            .boxes
            .iter()
            .any(|b| !(b.lo.is_finite() && b.hi.is_finite() && b.lo <= b.hi))
        {
            return None;
        }
        let lo: Vec<f64> = lp.boxes.iter().map(|b| b.lo).collect();
        let w: Vec<f64> = lp
            .boxes
            .iter()
            .map(|b| {
                let d = b.hi - b.lo;
                if d > 0.0 {
                    d
                } else {
                    1e-300_f64.max(1e-12 * b.lo.abs())
                }
            })
            .collect();
        let scale = |rows: &[(SparseRow, f64, f64)], pad_h: bool| {
            let mut g: Vec<SparseRow> = Vec::with_capacity(rows.len());
            let mut h = Vec::with_capacity(rows.len());
            let mut rho = Vec::with_capacity(rows.len());
            for (row, rhs, _) in rows {
                let shift: f64 = row.iter().map(|&(j, v)| v * lo[j]).sum();
                let r = row
                    .iter()
                    .map(|&(j, v)| (v * w[j]).abs())
                    .fold(0.0f64, f64::max)
                    .max(1e-300);
                let rhs = if pad_h {
                    rhs + ROW_PAD * (1.0 + rhs.abs())
                } else {
                    *rhs
                };
                g.push(row.iter().map(|&(j, v)| (j, v * w[j] / r)).collect());
                h.push((rhs - shift) / r);
                rho.push(r);
            }
            (g, h, rho)
        };
        let ineq: Vec<(SparseRow, f64, f64)> =
            lp.ineq.iter().map(|(r, h)| (r.clone(), *h, 0.0)).collect();
        let (g, h, rho_g) = scale(&ineq, true);
        let (e, f, rho_e) = scale(&lp.eq, false);
        let (te, tf, rho_te) = scale(&lp.theta_eq, false);
        let nb = lp.blocks.len();
        let mut block_of: Vec<usize> = vec![usize::MAX; n];
        for (b, &(s, t)) in lp.blocks.iter().enumerate() {
            for v in block_of.iter_mut().take(t).skip(s) {
                *v = b;
            }
        }
        let mut theta_of = vec![Vec::new(); nb];
        for b in 0..nb {
            let (r0, r1) = lp.ineq_of[b];
            for row in &g[r0..r1] {
                for &(j, _) in row {
                    if j < nt && !theta_of[b].contains(&j) {
                        theta_of[b].push(j);
                    }
                }
            }
        }
        let mut eq_of: Vec<Vec<(usize, Vec<(usize, f64)>)>> = vec![Vec::new(); nb];
        let mut e_theta = Vec::with_capacity(e.len());
        let mut band = 0;
        let mut first_eq = vec![usize::MAX; nb];
        for (r, row) in e.iter().enumerate() {
            let mut th = Vec::new();
            for &(j, v) in row {
                if j < nt {
                    th.push((j, v));
                    continue;
                }
                let b = block_of[j];
                if b == usize::MAX {
                    return None;
                }
                let off = j - lp.blocks[b].0;
                match eq_of[b].last_mut() {
                    Some((rr, ent)) if *rr == r => ent.push((off, v)),
                    _ => {
                        eq_of[b].push((r, vec![(off, v)]));
                        if first_eq[b] == usize::MAX {
                            first_eq[b] = r;
                        }
                        band = band.max(r - first_eq[b]);
                    }
                }
            }
            e_theta.push(th);
        }
        // Every equality needs a local variable (else M is singular): fall back otherwise.
        let mut touched = vec![false; e.len()];
        for list in &eq_of {
            for (r, _) in list {
                touched[*r] = true;
            }
        }
        if touched.iter().any(|t| !t) {
            return None;
        }
        let mut ents: Vec<SparseRow> = Vec::new();
        let mut eq_ptr = Vec::with_capacity(nb + 1);
        let mut eq_items = Vec::new();
        eq_ptr.push(0);
        for list in eq_of {
            for (r, ent) in list {
                eq_items.push((r, ents.len()));
                ents.push(ent);
            }
            eq_ptr.push(eq_items.len());
        }
        let (g, e, te) = (Csr::from_rows(g), Csr::from_rows(e), Csr::from_rows(te));
        let eq_ent = Csr::from_rows(ents);
        Some(Prepared {
            lp,
            n,
            w,
            g,
            h,
            rho_g,
            e,
            f,
            rho_e,
            te,
            tf,
            rho_te,
            theta_of,
            eq_ptr,
            eq_items,
            eq_ent,
            e_theta: Csr::from_rows(e_theta),
            band,
        })
    }

    /// Scaled objective of `c` (sparse, original units) and its scale `κ`.
    fn objective(&self, c: &[(usize, f64)]) -> (Vec<f64>, f64) {
        let mut q = vec![0.0; self.n];
        let kappa = c
            .iter()
            .map(|&(j, v)| (v * self.w[j]).abs())
            .fold(0.0f64, f64::max)
            .max(1e-300);
        for &(j, v) in c {
            q[j] += v * self.w[j] / kappa;
        }
        (q, kappa)
    }

    /// A guaranteed lower bound of `min c·z` over the LP (rows and boxes), `c` sparse.
    pub fn minimise(&self, c: &[(usize, f64)]) -> Bound {
        self.minimise_at(c, None).bound
    }

    /// A well-centred interior point of this LP (the zero objective's path at a moderate
    /// barrier), from which every objective's run starts: fewer iterations than a cold start.
    ///
    /// Its run also looks for a proof that the LP is empty: the certificate of the zero
    /// objective (the weak-duality bound of the module doc) is a guaranteed lower bound of `0`
    /// over the feasible points, so a positive one proves there are none (Farkas over the boxes). When the rows
    /// contradict each other the iterates' multipliers grow along such a ray, and the run
    /// stops at the first iterate that proves it instead of spending its iteration cap:
    /// [`Warm::Empty`], which answers every objective of the round at once.
    pub fn warm_start(&self) -> Warm {
        self.warm_start_to(2e-2)
    }

    /// [`Self::warm_start`] with the zero objective's run stopped once the barrier parameter
    /// falls below `stop` (0: run to the end, the certificate then within 1e-11 of 0 on a
    /// non-empty LP).
    pub fn warm_start_to(&self, stop: f64) -> Warm {
        let mut ipm = Ipm::new(self, &vec![0.0; self.n]);
        ipm.stop_at = Some(stop);
        let cert = |lam: &[f64], mu: &[f64], tmu: &[f64]| -> Option<f64> {
            let (lam, mu, tmu) = self.unscaled(1.0, lam, mu, tmu);
            certificate(self.lp, &[], &lam, &mu, &tmu)
        };
        let (v, _) = ipm.run_mut(&cert, 0.0, 1.0, Some(empty_above(0.0)));
        if v.is_some_and(|v| v > empty_above(0.0)) {
            return Warm::Empty(ipm.iterations);
        }
        let ok = ipm.z.iter().all(|v| v.is_finite() && *v > 0.0 && *v < 1.0)
            && ipm
                .s
                .iter()
                .chain(&ipm.lam)
                .all(|v| v.is_finite() && *v > 0.0);
        if !ok {
            return Warm::Cold;
        }
        Warm::Start(Start {
            z: ipm.z,
            zl: ipm.zl,
            zu: ipm.zu,
            s: ipm.s,
            lam: ipm.lam,
            mu: ipm.mu,
            tmu: ipm.tmu,
        })
    }

    /// A scaled dual point in the original rows' units, for [`certificate`]: `λ = κ λ̂ / ρ`
    /// (clamped at 0), `μ = κ μ̂ / ρ`.
    fn unscaled(
        &self,
        kappa: f64,
        lam: &[f64],
        mu: &[f64],
        tmu: &[f64],
    ) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
        let lam = lam
            .iter()
            .zip(&self.rho_g)
            .map(|(l, r)| (kappa * l / r).max(0.0))
            .collect();
        let mu = mu
            .iter()
            .zip(&self.rho_e)
            .map(|(m, r)| kappa * m / r)
            .collect();
        let tmu = tmu
            .iter()
            .zip(&self.rho_te)
            .map(|(m, r)| kappa * m / r)
            .collect();
        (lam, mu, tmu)
    }

    /// [`Self::minimise`], with the last primal iterate and the equalities' weights (see
    /// [`Solved`]).
    pub fn minimise_at(&self, c: &[(usize, f64)], start: Option<&Start>) -> Solved {
        let (q, kappa) = self.objective(c);
        // The certificate of a scaled dual point, in the original rows: λ = κ λ̂ / ρ.
        let cert = |lam: &[f64], mu: &[f64], tmu: &[f64]| -> Option<f64> {
            let (lam, mu, tmu) = self.unscaled(kappa, lam, mu, tmu);
            certificate(self.lp, c, &lam, &mu, &tmu)
        };
        // The primal objective in original units, c·z = c·lo + κ q·ẑ, for the stopping test.
        let offset: f64 = c.iter().map(|&(j, v)| v * self.lp.boxes[j].lo).sum();
        let mut ipm = Ipm::new(self, &q);
        if let Some(st) = start {
            ipm.z.clone_from(&st.z);
            ipm.zl.clone_from(&st.zl);
            ipm.zu.clone_from(&st.zu);
            ipm.s.clone_from(&st.s);
            ipm.mu.clone_from(&st.mu);
            ipm.tmu.clone_from(&st.tmu);
            // The multipliers of the zero objective, scaled to this one's magnitude.
            ipm.lam.clone_from(&st.lam);
        }
        // Above the objective's own maximum over the boxes: the LP is empty.
        let top: f64 = c
            .iter()
            .map(|&(j, v)| {
                let b = self.lp.boxes[j];
                (v * b.lo).max(v * b.hi)
            })
            .sum();
        let empty_above = empty_above(top);
        let (v, zt) = ipm.run_mut(&cert, offset, kappa, Some(empty_above));
        let point: Vec<f64> = zt
            .iter()
            .enumerate()
            .map(|(j, &x)| {
                let b = self.lp.boxes[j];
                (b.lo + self.w[j] * x).clamp(b.lo, b.hi)
            })
            .collect();
        let bound = match v {
            Some(v) if v > empty_above => Bound::Infeasible,
            v => Bound::Value(v),
        };
        let eq_weight = ipm
            .mu
            .iter()
            .zip(&self.rho_e)
            .map(|(m, r)| (kappa * m / r).abs())
            .collect();
        Solved {
            bound,
            point,
            eq_weight,
            iterations: ipm.iterations,
        }
    }
}

/// Weak duality over the boxes (see the module doc), with rounding bounded rigorously.
fn certificate(
    lp: &BlockLp,
    c: &[(usize, f64)],
    lam: &[f64],
    mu: &[f64],
    tmu: &[f64],
) -> Option<f64> {
    let n = lp.boxes.len();
    let mut r = vec![0.0; n];
    let mut mag = vec![0.0; n];
    let mut cnt = vec![1usize; n];
    for &(j, v) in c {
        r[j] += v;
        mag[j] += v.abs();
    }
    // The terms of the bound, summed pairwise at the end: the rounding error of a pairwise sum
    // of K terms is at most γ(⌈log2 K⌉)·Σ|x| (Higham, eq. 4.6), against γ(K)·Σ|x| in a running
    // sum, which at N = 1e5 is larger than the result pad and would stop the iterations early.
    let mut xs: Vec<f64> = Vec::with_capacity(lp.ineq.len() + 2 * lp.eq.len() + n);
    let mut add_row = |row: &SparseRow, y: f64, r: &mut Vec<f64>, mag: &mut Vec<f64>| {
        for &(j, v) in row {
            r[j] += y * v;
            mag[j] += (y * v).abs();
            cnt[j] += 1;
        }
    };
    for ((row, h), &y) in lp.ineq.iter().zip(lam) {
        if y == 0.0 {
            continue;
        }
        add_row(row, y, &mut r, &mut mag);
        let hp = h + ROW_PAD * (1.0 + h.abs());
        xs.push(-(y * hp));
    }
    for (rows, ys) in [(&lp.eq, mu), (&lp.theta_eq, tmu)] {
        for ((row, f, pad), &y) in rows.iter().zip(ys) {
            if y == 0.0 {
                continue;
            }
            add_row(row, y, &mut r, &mut mag);
            // f ranges over [f - pad, f + pad]: the worst end.
            xs.push(-(y * f));
            xs.push(-(y.abs() * pad));
        }
    }
    for j in 0..n {
        let e = gamma(cnt[j]) * mag[j];
        let b = lp.boxes[j];
        // min over r_j ∈ [r - e, r + e], z_j ∈ [lo, hi].
        let m = [
            (r[j] - e) * b.lo,
            (r[j] - e) * b.hi,
            (r[j] + e) * b.lo,
            (r[j] + e) * b.hi,
        ]
        .into_iter()
        .fold(f64::INFINITY, f64::min);
        xs.push(m);
    }
    let total = pairwise(&xs);
    for x in xs.iter_mut() {
        *x = x.abs();
    }
    let tmag = pairwise(&xs);
    // Each term carries one rounding (≤ u|x|); the sum ≤ γ(depth)·Σ|x|; the computed Σ|x| is
    // itself low by at most that factor (hence 2·), and the last subtraction one more ε.
    let depth = pairwise_depth(xs.len());
    let v = total - 2.0 * gamma(depth + 1) * tmag - 2.0 * f64::EPSILON * total.abs();
    v.is_finite().then_some(v)
}

/// Length of the runs a pairwise sum adds one after the other.
const PAIRWISE_BASE: usize = 16;

/// An upper bound of the additions any term of a [`pairwise`] sum of `len` terms goes
/// through (`PAIRWISE_BASE - 1` in its run, one per level above): its rounding error is at
/// most `gamma(pairwise_depth(len))·Σ|x|`.
fn pairwise_depth(len: usize) -> usize {
    PAIRWISE_BASE
        + (len / PAIRWISE_BASE + 1)
            .next_power_of_two()
            .trailing_zeros() as usize
}

/// Pairwise (recursive halving) sum: rounding error at most `γ(PAIRWISE_BASE - 1 + ⌈log2(K /
/// PAIRWISE_BASE)⌉)·Σ|x|`.
fn pairwise(xs: &[f64]) -> f64 {
    if xs.len() <= PAIRWISE_BASE {
        return xs.iter().sum();
    }
    let (a, b) = xs.split_at(xs.len() / 2);
    pairwise(a) + pairwise(b)
}

/// An interior point to start from (scaled variables, slacks and multipliers): the same LP's
/// path at a moderate barrier, shared by all objectives of one round.
#[derive(Debug, Clone)]
pub struct Start {
    z: Vec<f64>,
    zl: Vec<f64>,
    zu: Vec<f64>,
    s: Vec<f64>,
    lam: Vec<f64>,
    mu: Vec<f64>,
    tmu: Vec<f64>,
}

/// A certified lower bound of `min c·z` above this proves the LP empty, where `top` is the
/// objective's own maximum over the boxes (0 for the zero objective: a Farkas proof). The
/// margin only makes the proof harder to give.
fn empty_above(top: f64) -> f64 {
    top + 1e-12 * (1.0 + top.abs())
}

/// How a round's warm start ended ([`Prepared::warm_start`]).
#[derive(Debug, Clone)]
pub enum Warm {
    /// A well-centred interior point to start every objective from.
    Start(Start),
    /// The LP is proven empty, after this many Newton steps.
    Empty(usize),
    /// Neither: each objective starts cold.
    Cold,
}

impl Warm {
    /// The start point, if any.
    pub fn start(&self) -> Option<&Start> {
        match self {
            Warm::Start(s) => Some(s),
            _ => None,
        }
    }
}

/// Maximum interior-point iterations per bound.
pub const MAX_ITER: usize = 80;

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// The sum of `xs` to about twice the working precision (Neumaier's compensated sum).
    fn accurate_sum(xs: &[f64]) -> f64 {
        let (mut s, mut c) = (0.0f64, 0.0f64);
        for &x in xs {
            let t = s + x;
            c += if s.abs() >= x.abs() {
                (s - t) + x
            } else {
                (x - t) + s
            };
            s = t;
        }
        s + c
    }

    proptest! {
        #![proptest_config(ProptestConfig { cases: 64, .. ProptestConfig::default() })]
        /// The certificate's rounding bound for its pairwise sums holds, with cancellation and
        /// magnitudes over 12 decades, at every length up to three levels of halving.
        #[test]
        fn pairwise_sum_is_within_its_rounding_bound(
            xs in prop::collection::vec((-1.0f64..1.0, -6i32..6), 0..300usize),
        ) {
            let xs: Vec<f64> = xs.iter().map(|&(m, e)| m * 10f64.powi(e)).collect();
            let mag: f64 = xs.iter().map(|x| x.abs()).sum();
            let err = (pairwise(&xs) - accurate_sum(&xs)).abs();
            prop_assert!(err <= gamma(pairwise_depth(xs.len())) * mag, "{err} for {} terms", xs.len());
        }
    }

    /// The additions the deepest term of [`pairwise`] goes through, by the same splitting.
    fn additions(len: usize) -> usize {
        if len <= PAIRWISE_BASE {
            len.saturating_sub(1)
        } else {
            1 + additions(len / 2).max(additions(len - len / 2))
        }
    }

    #[test]
    fn pairwise_depth_covers_the_deepest_term() {
        for len in (0..5000).chain([65_535, 65_536, 65_537, 1_000_000, 3_333_333]) {
            assert!(
                pairwise_depth(len) >= additions(len),
                "{len} terms: depth {} < {} additions",
                pairwise_depth(len),
                additions(len)
            );
        }
    }
}
