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
use crate::interval::Interval;
use crate::lp::ROW_PAD;

/// A sparse row over the global variable index (θ first, then the local variables).
pub(crate) type SparseRow = Vec<(usize, f64)>;

/// The shared-error LP in block form (see the module doc).
#[derive(Debug, Clone, Default)]
pub(crate) struct BlockLp {
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
    pub ineq_of: Vec<(usize, usize)>,
    /// Equalities `e·z = f` with their allowed pad, in time order (banded in the blocks).
    pub eq: Vec<(SparseRow, f64, f64)>,
    /// Equalities in θ alone (the unit gain), with their pad.
    pub theta_eq: Vec<(SparseRow, f64, f64)>,
}

/// What one run of [`Prepared::minimise_at`] found.
#[derive(Debug, Clone)]
pub(crate) struct Solved {
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
pub(crate) enum Bound {
    /// A guaranteed lower bound of `min c·z` (`None` when the certificate is not finite).
    Value(Option<f64>),
    /// The LP is empty (proven by the certificate).
    Infeasible,
}

/// `(k + 2) ε`: relative rounding error bound of a sum of `k` products.
fn gamma(k: usize) -> f64 {
    (k as f64 + 2.0) * f64::EPSILON
}

/// Dense Cholesky in place (lower triangle, row-major `n × n`), the diagonal stored as its
/// reciprocal; `false` if not positive.
fn chol(a: &mut [f64], n: usize) -> bool {
    for j in 0..n {
        let mut d = a[j * n + j];
        for k in 0..j {
            d -= a[j * n + k] * a[j * n + k];
        }
        if !(d > 0.0) {
            return false;
        }
        let inv = 1.0 / d.sqrt();
        a[j * n + j] = inv;
        for i in j + 1..n {
            let mut s = a[i * n + j];
            for k in 0..j {
                s -= a[i * n + k] * a[j * n + k];
            }
            a[i * n + j] = s * inv;
        }
    }
    true
}

/// Solve `L Lᵀ x = b` in place with a factor from [`chol`] (blocks are small: the common sizes
/// get their own copy with the size a constant, so the loops unroll; same arithmetic).
fn chol_solve(l: &[f64], n: usize, b: &mut [f64]) {
    match n {
        1 => chol_solve_inline(l, 1, b),
        2 => chol_solve_inline(l, 2, b),
        3 => chol_solve_inline(l, 3, b),
        4 => chol_solve_inline(l, 4, b),
        5 => chol_solve_inline(l, 5, b),
        6 => chol_solve_inline(l, 6, b),
        _ => chol_solve_inline(l, n, b),
    }
}

#[inline(always)]
fn chol_solve_inline(l: &[f64], n: usize, b: &mut [f64]) {
    let (l, b) = (&l[..n * n], &mut b[..n]);
    for i in 0..n {
        let mut s = b[i];
        for k in 0..i {
            s -= l[i * n + k] * b[k];
        }
        b[i] = s * l[i * n + i];
    }
    for i in (0..n).rev() {
        let mut s = b[i];
        for k in i + 1..n {
            s -= l[k * n + i] * b[k];
        }
        b[i] = s * l[i * n + i];
    }
}

/// A symmetric band matrix, lower band stored per row: `band[r * (w + 1) + k] = M[r][r - k]`.
struct Band {
    n: usize,
    w: usize,
    a: Vec<f64>,
}

impl Band {
    fn at(&mut self, r: usize, c: usize) -> &mut f64 {
        let (r, c) = if r >= c { (r, c) } else { (c, r) };
        &mut self.a[r * (self.w + 1) + (r - c)]
    }
    /// Cholesky in place, the diagonal stored as its reciprocal; `false` if not positive
    /// definite.
    fn factor(&mut self) -> bool {
        let w = self.w;
        let s = w + 1;
        for j in 0..self.n {
            let k0 = j.saturating_sub(w);
            let mut d = self.a[j * s];
            for k in k0..j {
                let l = self.a[j * s + (j - k)];
                d -= l * l;
            }
            if !(d > 0.0) {
                return false;
            }
            let inv = 1.0 / d.sqrt();
            self.a[j * s] = inv;
            for i in j + 1..(j + w + 1).min(self.n) {
                let mut v = self.a[i * s + (i - j)];
                let k0 = i.saturating_sub(w);
                for k in k0..j {
                    v -= self.a[i * s + (i - k)] * self.a[j * s + (j - k)];
                }
                self.a[i * s + (i - j)] = v * inv;
            }
        }
        true
    }
    fn solve(&self, b: &mut [f64]) {
        let (w, s) = (self.w, self.w + 1);
        let b = &mut b[..self.n];
        for i in 0..self.n {
            let mut v = b[i];
            for k in i.saturating_sub(w)..i {
                v -= self.a[i * s + (i - k)] * b[k];
            }
            b[i] = v * self.a[i * s];
        }
        for i in (0..self.n).rev() {
            let mut v = b[i];
            for k in i + 1..(i + w + 1).min(self.n) {
                v -= self.a[k * s + (k - i)] * b[k];
            }
            b[i] = v * self.a[i * s];
        }
    }
}

/// Rows stored flat: row `i` is `ent[ptr[i]..ptr[i + 1]]`.
#[derive(Debug, Clone, Default)]
struct Csr {
    ptr: Vec<usize>,
    ent: Vec<(usize, f64)>,
}

impl Csr {
    fn from_rows(rows: Vec<SparseRow>) -> Self {
        let mut c = Csr {
            ptr: Vec::with_capacity(rows.len() + 1),
            ent: Vec::with_capacity(rows.iter().map(|r| r.len()).sum()),
        };
        c.ptr.push(0);
        for r in rows {
            c.ent.extend(r);
            c.ptr.push(c.ent.len());
        }
        c
    }
    fn len(&self) -> usize {
        self.ptr.len() - 1
    }
    fn row(&self, i: usize) -> &[(usize, f64)] {
        &self.ent[self.ptr[i]..self.ptr[i + 1]]
    }
    fn iter(&self) -> impl Iterator<Item = &[(usize, f64)]> {
        (0..self.len()).map(move |i| self.row(i))
    }
}

/// The scaled problem and the elimination structure, shared by all objectives.
pub(crate) struct Prepared<'a> {
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
    pub(crate) fn new(lp: &'a BlockLp) -> Option<Self> {
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
    pub(crate) fn minimise(&self, c: &[(usize, f64)]) -> Bound {
        self.minimise_at(c, None).bound
    }

    /// A well-centred interior point of this LP (the zero objective's path at a moderate
    /// barrier), from which every objective's run starts: fewer iterations than a cold start.
    ///
    /// Its run also looks for a proof that the LP is empty: the certificate of the zero
    /// objective (see [`certificate`]) is a guaranteed lower bound of `0` over the feasible
    /// points, so a positive one proves there are none (Farkas over the boxes). When the rows
    /// contradict each other the iterates' multipliers grow along such a ray, and the run
    /// stops at the first iterate that proves it instead of spending its iteration cap:
    /// [`Warm::Empty`], which answers every objective of the round at once.
    pub(crate) fn warm_start(&self) -> Warm {
        self.warm_start_to(2e-2)
    }

    /// [`Self::warm_start`] with the zero objective's run stopped once the barrier parameter
    /// falls below `stop` (0: run to the end, the certificate then within 1e-11 of 0 on a
    /// non-empty LP).
    pub(crate) fn warm_start_to(&self, stop: f64) -> Warm {
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
    pub(crate) fn minimise_at(&self, c: &[(usize, f64)], start: Option<&Start>) -> Solved {
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
pub(crate) struct Start {
    z: Vec<f64>,
    zl: Vec<f64>,
    zu: Vec<f64>,
    s: Vec<f64>,
    lam: Vec<f64>,
    mu: Vec<f64>,
    tmu: Vec<f64>,
}

/// One Mehrotra run on the scaled problem.
struct Ipm<'p, 'a> {
    p: &'p Prepared<'a>,
    q: Vec<f64>,
    z: Vec<f64>,
    zl: Vec<f64>,
    zu: Vec<f64>,
    s: Vec<f64>,
    lam: Vec<f64>,
    mu: Vec<f64>,
    tmu: Vec<f64>,
    // Factorisation workspace.
    hb: Vec<f64>,
    hb_off: Vec<usize>,
    yb: Vec<f64>,
    yb_off: Vec<usize>,
    m: Band,
    bmat: Vec<f64>,
    zmat: Vec<f64>,
    small_lu: Option<nalgebra::LU<f64, nalgebra::Dyn, nalgebra::Dyn>>,
    /// The diagonal box terms of the current Hessian.
    dbox: Vec<f64>,
    /// Steps of iterative refinement per Newton solve (more near the end).
    refine: usize,
    /// Stop (without certifying) once the complementarity falls below this: a warm start.
    stop_at: Option<f64>,
    /// Newton steps of the last run.
    iterations: usize,
    pool: Pool,
}

/// Reused work vectors: an iteration needs a few dozen vectors as long as the record, and
/// fresh ones every time cost page faults (14 % of the time at N = 1e5).
#[derive(Default)]
struct Pool(std::cell::RefCell<Vec<Vec<f64>>>);

impl Pool {
    /// A vector of `len` values from `it` (reusing a pooled allocation when one fits).
    fn filled(&self, len: usize, it: impl Iterator<Item = f64>) -> Vec<f64> {
        let mut pool = self.0.borrow_mut();
        let pick = pool
            .iter()
            .enumerate()
            .filter(|(_, v)| v.capacity() >= len && v.capacity() <= 2 * len.max(16))
            .min_by_key(|(_, v)| v.capacity())
            .map(|(i, _)| i);
        let mut v = pick.map(|i| pool.swap_remove(i)).unwrap_or_default();
        drop(pool);
        v.clear();
        v.extend(it);
        debug_assert_eq!(v.len(), len);
        v
    }
    fn zeros(&self, len: usize) -> Vec<f64> {
        self.filled(len, std::iter::repeat_n(0.0, len))
    }
    fn copy(&self, src: &[f64]) -> Vec<f64> {
        self.filled(src.len(), src.iter().copied())
    }
    /// Give `v` back (every vector given back is one taken, so the pool holds at most the
    /// vectors one iteration has alive at once).
    fn put(&self, v: Vec<f64>) {
        self.0.borrow_mut().push(v);
    }
}

/// A Newton direction: the scaled variables, the inequality slacks and multipliers, the box
/// multipliers, the equality and gain multipliers.
struct Dir {
    dz: Vec<f64>,
    ds: Vec<f64>,
    dl: Vec<f64>,
    dzl: Vec<f64>,
    dzu: Vec<f64>,
    dmu: Vec<f64>,
    dtmu: Vec<f64>,
}

impl Dir {
    /// Give the record-long vectors back to `pool`.
    fn recycle(self, pool: &Pool) {
        for v in [self.dz, self.ds, self.dl, self.dzl, self.dzu, self.dmu] {
            pool.put(v);
        }
    }
}

/// A certified lower bound of `min c·z` above this proves the LP empty, where `top` is the
/// objective's own maximum over the boxes (0 for the zero objective: a Farkas proof). The
/// margin only makes the proof harder to give.
fn empty_above(top: f64) -> f64 {
    top + 1e-12 * (1.0 + top.abs())
}

/// How a round's warm start ended ([`Prepared::warm_start`]).
#[derive(Debug, Clone)]
pub(crate) enum Warm {
    /// A well-centred interior point to start every objective from.
    Start(Start),
    /// The LP is proven empty, after this many Newton steps.
    Empty(usize),
    /// Neither: each objective starts cold.
    Cold,
}

impl Warm {
    /// The start point, if any.
    pub(crate) fn start(&self) -> Option<&Start> {
        match self {
            Warm::Start(s) => Some(s),
            _ => None,
        }
    }
}

/// Maximum interior-point iterations per bound.
pub(crate) const MAX_ITER: usize = 80;

impl<'p, 'a> Ipm<'p, 'a> {
    fn new(p: &'p Prepared<'a>, q: &[f64]) -> Self {
        let n = p.n;
        let nt = p.lp.nt;
        // Start at the box centres, products at the product of the centres (inside their
        // envelopes), every slack at least 0.1.
        let mut z = vec![0.5; n];
        let s: Vec<f64> =
            p.g.iter()
                .zip(&p.h)
                .map(|(row, h)| {
                    let gz: f64 = row.iter().map(|&(j, v)| v * z[j]).sum();
                    (h - gz).max(0.1)
                })
                .collect();
        for v in z.iter_mut() {
            *v = v.clamp(0.05, 0.95);
        }
        let mut hb_off = Vec::with_capacity(p.lp.blocks.len() + 1);
        let mut yb_off = Vec::with_capacity(p.lp.blocks.len() + 1);
        let (mut a, mut b) = (0, 0);
        for (bi, &(s0, s1)) in p.lp.blocks.iter().enumerate() {
            hb_off.push(a);
            yb_off.push(b);
            let bs = s1 - s0;
            a += bs * bs;
            b += bs * p.theta_of[bi].len();
        }
        hb_off.push(a);
        yb_off.push(b);
        let neq = p.e.len();
        let nte = p.te.len();
        Ipm {
            p,
            q: q.to_vec(),
            z,
            zl: vec![1.0; n],
            zu: vec![1.0; n],
            lam: vec![1.0; s.len()],
            s,
            mu: vec![0.0; neq],
            tmu: vec![0.0; nte],
            hb: vec![0.0; a],
            hb_off,
            yb: vec![0.0; b],
            yb_off,
            m: Band {
                n: neq,
                w: p.band,
                a: vec![0.0; neq * (p.band + 1)],
            },
            bmat: vec![0.0; neq * nt],
            zmat: vec![0.0; neq * nt],
            small_lu: None,
            dbox: vec![0.0; n],
            refine: 0,
            stop_at: None,
            iterations: 0,
            pool: Pool::default(),
        }
    }

    /// Factor the Newton system, regularising more each time a factorisation breaks down
    /// (refinement against the unregularised system corrects the directions).
    fn factor(&mut self) -> bool {
        (0..5).any(|k| self.factor_reg(1e-13 * 100f64.powi(k)))
    }

    /// Factor the Newton system for the current scaling `d = λ/s` and box terms, with relative
    /// regularisation `reg` of the band (and a thousandth of it on the blocks).
    fn factor_reg(&mut self, reg: f64) -> bool {
        let p = self.p;
        let lp = p.lp;
        let nt = lp.nt;
        let neq = p.e.len();
        let nte = p.te.len();
        for j in 0..p.n {
            self.dbox[j] = self.zl[j] / self.z[j] + self.zu[j] / (1.0 - self.z[j]) + 1e-14;
        }
        let mut htt = vec![0.0; nt * nt];
        for j in 0..nt {
            htt[j * nt + j] = self.dbox[j];
        }
        self.m.a.iter_mut().for_each(|v| *v = 0.0);
        self.bmat.iter_mut().for_each(|v| *v = 0.0);
        for r in 0..neq {
            for &(j, v) in p.e_theta.row(r) {
                self.bmat[r * nt + j] += v;
            }
        }
        let maxb = lp.blocks.iter().map(|&(a, b)| b - a).max().unwrap_or(0);
        let maxt = p.theta_of.iter().map(|t| t.len()).max().unwrap_or(0);
        let maxe = (0..lp.blocks.len())
            .map(|b| p.eq_ptr[b + 1] - p.eq_ptr[b])
            .max()
            .unwrap_or(0);
        let mut col = vec![0.0; maxb];
        let mut y = vec![0.0; maxb * maxt];
        let mut ev = vec![0.0; maxe * maxb];
        let mut hv = vec![0.0; maxe * maxb];
        for (bi, &(s0, s1)) in lp.blocks.iter().enumerate() {
            let bs = s1 - s0;
            let th = &p.theta_of[bi];
            let nth = th.len();
            let hoff = self.hb_off[bi];
            let yoff = self.yb_off[bi];
            let hb = &mut self.hb[hoff..hoff + bs * bs];
            hb.iter_mut().for_each(|v| *v = 0.0);
            for k in 0..bs {
                hb[k * bs + k] = self.dbox[s0 + k];
            }
            let hbt = &mut self.yb[yoff..yoff + bs * nth];
            hbt.iter_mut().for_each(|v| *v = 0.0);
            let (r0, r1) = lp.ineq_of[bi];
            for i in r0..r1 {
                let d = self.lam[i] / self.s[i];
                let row = p.g.row(i);
                for &(ja, va) in row {
                    if ja < nt {
                        htt[ja * nt + ja] += d * va * va;
                        continue;
                    }
                    let ka = ja - s0;
                    for &(jb, vb) in row {
                        let dv = d * va * vb;
                        if jb >= nt {
                            hb[ka * bs + (jb - s0)] += dv;
                        } else {
                            let t = th.iter().position(|&k| k == jb).unwrap_or(0);
                            hbt[ka * nth + t] += dv;
                        }
                    }
                }
            }
            let hmax = (0..bs).map(|k| hb[k * bs + k]).fold(0.0f64, f64::max);
            for k in 0..bs {
                hb[k * bs + k] += 1e-3 * reg * hmax;
            }
            if !chol(hb, bs) {
                return false;
            }
            // Y = H_b⁻¹ H_bθ (column by column), P -= H_θb Y.
            for t in 0..nth {
                for k in 0..bs {
                    col[k] = hbt[k * nth + t];
                }
                chol_solve(hb, bs, &mut col[..bs]);
                for k in 0..bs {
                    y[k * nth + t] = col[k];
                }
            }
            for (ta, &ka) in th.iter().enumerate() {
                for (tb, &kb) in th.iter().enumerate() {
                    let mut s = 0.0;
                    for k in 0..bs {
                        s += hbt[k * nth + ta] * y[k * nth + tb];
                    }
                    htt[ka * nt + kb] -= s;
                }
            }
            // Equalities touching the block: M += e H⁻¹ eᵀ, B -= e Y.
            let items = &p.eq_items[p.eq_ptr[bi]..p.eq_ptr[bi + 1]];
            for (a, &(_, k)) in items.iter().enumerate() {
                let v = &mut ev[a * bs..(a + 1) * bs];
                v.iter_mut().for_each(|x| *x = 0.0);
                for &(off, c) in p.eq_ent.row(k) {
                    v[off] += c;
                }
                let w = &mut hv[a * bs..(a + 1) * bs];
                w.copy_from_slice(v);
                chol_solve(hb, bs, w);
            }
            for (a, &(ra, _)) in items.iter().enumerate() {
                let va = &ev[a * bs..(a + 1) * bs];
                for (b, &(rb, _)) in items.iter().enumerate().take(a + 1) {
                    let wb = &hv[b * bs..(b + 1) * bs];
                    let s: f64 = va.iter().zip(wb).map(|(u, v)| u * v).sum();
                    *self.m.at(ra, rb) += s;
                }
                for (t, &k) in th.iter().enumerate() {
                    let mut s = 0.0;
                    for kk in 0..bs {
                        s += va[kk] * y[kk * nth + t];
                    }
                    self.bmat[ra * nt + k] -= s;
                }
            }
            self.yb[yoff..yoff + bs * nth].copy_from_slice(&y[..bs * nth]);
        }
        // Regularise M lightly (relative), then factor the band.
        let dmax = (0..neq)
            .map(|r| self.m.a[r * (self.m.w + 1)])
            .fold(0.0f64, f64::max);
        for r in 0..neq {
            self.m.a[r * (self.m.w + 1)] += reg * dmax + 1e-300;
        }
        if !self.m.factor() {
            return false;
        }
        // Z = M⁻¹ B; S = P + Bᵀ Z.
        let mut colr = vec![0.0; neq];
        for k in 0..nt {
            for r in 0..neq {
                colr[r] = self.bmat[r * nt + k];
            }
            self.m.solve(&mut colr);
            for r in 0..neq {
                self.zmat[r * nt + k] = colr[r];
            }
        }
        let mut small = nalgebra::DMatrix::<f64>::zeros(nt + nte, nt + nte);
        let mut acc = vec![0.0; nt * nt];
        for r in 0..neq {
            let br = &self.bmat[r * nt..(r + 1) * nt];
            let zr = &self.zmat[r * nt..(r + 1) * nt];
            for a in 0..nt {
                for b in 0..nt {
                    acc[a * nt + b] += br[a] * zr[b];
                }
            }
        }
        for a in 0..nt {
            for b in 0..nt {
                small[(a, b)] = htt[a * nt + b] + acc[a * nt + b];
            }
        }
        let smax = (0..nt).map(|a| small[(a, a)].abs()).fold(0.0f64, f64::max);
        for i in 0..nte {
            for &(j, v) in p.te.row(i) {
                small[(nt + i, j)] = v;
                small[(j, nt + i)] = v;
            }
            small[(nt + i, nt + i)] = -1e-14 * (1.0 + smax);
        }
        self.small_lu = Some(small.lu());
        true
    }

    /// Solve the Newton system `[H Aᵀ; A 0] [dz; dμ] = [r1; r2]`, with two steps of
    /// iterative refinement against the unregularised system.
    fn solve(&self, r1: &[f64], r2: &[f64], r2t: &[f64]) -> Option<(Vec<f64>, Vec<f64>, Vec<f64>)> {
        let p = self.p;
        let (mut dz, mut dmu, mut dtmu) = self.solve_once(r1, r2, r2t)?;
        for _ in 0..self.refine {
            // Residual: r1 - H dz - Aᵀ dμ, r2 - A dz.
            let mut q1 = self
                .pool
                .filled(p.n, (0..p.n).map(|j| r1[j] - self.dbox[j] * dz[j]));
            for (i, row) in p.g.iter().enumerate() {
                let d = self.lam[i] / self.s[i];
                let gdz: f64 = row.iter().map(|&(j, v)| v * dz[j]).sum();
                for &(j, v) in row {
                    q1[j] -= d * v * gdz;
                }
            }
            let mut q2 = self.pool.copy(r2);
            for (r, row) in p.e.iter().enumerate() {
                let mut ez = 0.0;
                for &(j, v) in row {
                    q1[j] -= v * dmu[r];
                    ez += v * dz[j];
                }
                q2[r] -= ez;
            }
            let mut q2t = r2t.to_vec();
            for (r, row) in p.te.iter().enumerate() {
                let mut ez = 0.0;
                for &(j, v) in row {
                    q1[j] -= v * dtmu[r];
                    ez += v * dz[j];
                }
                q2t[r] -= ez;
            }
            let (a, b, c) = self.solve_once(&q1, &q2, &q2t)?;
            dz.iter_mut().zip(&a).for_each(|(x, y)| *x += y);
            dmu.iter_mut().zip(&b).for_each(|(x, y)| *x += y);
            dtmu.iter_mut().zip(&c).for_each(|(x, y)| *x += y);
            for v in [q1, q2, a, b] {
                self.pool.put(v);
            }
        }
        Some((dz, dmu, dtmu))
    }

    fn solve_once(
        &self,
        r1: &[f64],
        r2: &[f64],
        r2t: &[f64],
    ) -> Option<(Vec<f64>, Vec<f64>, Vec<f64>)> {
        let p = self.p;
        let lp = p.lp;
        let nt = lp.nt;
        let neq = p.e.len();
        let nte = p.te.len();
        // t_b = H_b⁻¹ r1_b; ρ_θ = r1_θ - Σ Yᵀ r1_b; ρ_eq = r2 - E_y t.
        let mut t = self.pool.copy(r1);
        let mut rho_t: Vec<f64> = r1[..nt].to_vec();
        let mut wv = self.pool.copy(r2);
        for (bi, &(s0, s1)) in lp.blocks.iter().enumerate() {
            let bs = s1 - s0;
            let th = &p.theta_of[bi];
            let nth = th.len();
            let hb = &self.hb[self.hb_off[bi]..self.hb_off[bi] + bs * bs];
            let y = &self.yb[self.yb_off[bi]..self.yb_off[bi] + bs * nth];
            for (tt, &k) in th.iter().enumerate() {
                let mut s = 0.0;
                for kk in 0..bs {
                    s += y[kk * nth + tt] * r1[s0 + kk];
                }
                rho_t[k] -= s;
            }
            chol_solve(hb, bs, &mut t[s0..s1]);
            for &(r, k) in &p.eq_items[p.eq_ptr[bi]..p.eq_ptr[bi + 1]] {
                let s: f64 = p
                    .eq_ent
                    .row(k)
                    .iter()
                    .map(|&(off, c)| c * t[s0 + off])
                    .sum();
                wv[r] -= s;
            }
        }
        // w = M⁻¹ ρ_eq; small system for dθ and the gain multipliers.
        self.m.solve(&mut wv);
        let mut rhs = nalgebra::DVector::<f64>::zeros(nt + nte);
        for k in 0..nt {
            rhs[k] = rho_t[k];
        }
        for r in 0..neq {
            let br = &self.bmat[r * nt..(r + 1) * nt];
            for k in 0..nt {
                rhs[k] += br[k] * wv[r];
            }
        }
        for i in 0..nte {
            rhs[nt + i] = r2t[i];
        }
        let sol = self.small_lu.as_ref()?.solve(&rhs)?;
        let dth: Vec<f64> = (0..nt).map(|k| sol[k]).collect();
        let dtmu: Vec<f64> = (0..nte).map(|i| sol[nt + i]).collect();
        // dμ = Z dθ - w.
        let dmu = self.pool.filled(
            neq,
            (0..neq).map(|r| {
                let zr = &self.zmat[r * nt..(r + 1) * nt];
                zr.iter().zip(&dth).map(|(a, b)| a * b).sum::<f64>() - wv[r]
            }),
        );
        self.pool.put(wv);
        // dy_b = t_b - Y dθ - H_b⁻¹ E_bᵀ dμ.
        let mut dz = t;
        dz[..nt].copy_from_slice(&dth);
        let maxb = lp.blocks.iter().map(|&(a, b)| b - a).max().unwrap_or(0);
        let mut v = vec![0.0; maxb];
        for (bi, &(s0, s1)) in lp.blocks.iter().enumerate() {
            let bs = s1 - s0;
            let th = &p.theta_of[bi];
            let nth = th.len();
            let hb = &self.hb[self.hb_off[bi]..self.hb_off[bi] + bs * bs];
            let y = &self.yb[self.yb_off[bi]..self.yb_off[bi] + bs * nth];
            let v = &mut v[..bs];
            v.iter_mut().for_each(|x| *x = 0.0);
            for &(r, k) in &p.eq_items[p.eq_ptr[bi]..p.eq_ptr[bi + 1]] {
                for &(off, c) in p.eq_ent.row(k) {
                    v[off] += c * dmu[r];
                }
            }
            chol_solve(hb, bs, v);
            for k in 0..bs {
                let mut s = dz[s0 + k] - v[k];
                for (tt, &kk) in th.iter().enumerate() {
                    s -= y[k * nth + tt] * dth[kk];
                }
                dz[s0 + k] = s;
            }
        }
        if dz.iter().chain(&dmu).chain(&dtmu).any(|v| !v.is_finite()) {
            return None;
        }
        Some((dz, dmu, dtmu))
    }

    /// Run to convergence (or the cap), certifying the dual points near the end: the best
    /// certified bound (`cert` maps a scaled dual point to its bound), and the last primal
    /// iterate (scaled). Mehrotra iterations until the certified bound meets the primal
    /// objective, stops improving, or the iteration cap. With `empty_above`, an iteration
    /// whose barrier parameter did not fall (the iterates diverge, as the multipliers do along
    /// a ray when the rows contradict each other; now and then a converging run's too) is
    /// certified as well, and the run ends as soon as a certificate exceeds it (the LP is
    /// proven empty: the caller reads the bound so). `iterations` counts the Newton steps
    /// taken.
    fn run_mut(
        &mut self,
        cert: &dyn Fn(&[f64], &[f64], &[f64]) -> Option<f64>,
        offset: f64,
        kappa: f64,
        empty_above: Option<f64>,
    ) -> (Option<f64>, Vec<f64>) {
        let p = self.p;
        let n = p.n;
        let mi = p.g.len();
        let neq = p.e.len();
        let nte = p.te.len();
        let npairs = (mi + 2 * n) as f64;
        let mut best: Option<f64> = None;
        let mut stale = 0;
        // `trace` level of the `log` facade (target `smid::stage3`; `SMID_LOG=trace` in the CLI):
        // one line per iteration (asked once, not per iteration).
        let trace = log::log_enabled!(target: "smid::stage3", log::Level::Trace);
        let mut last_mu = f64::INFINITY;
        for it in 0..MAX_ITER {
            self.iterations = it;
            // Residuals.
            let mut rd = self
                .pool
                .filled(n, (0..n).map(|j| self.q[j] - self.zl[j] + self.zu[j]));
            let mut rg = self.pool.zeros(mi);
            for (i, row) in p.g.iter().enumerate() {
                let mut gz = 0.0;
                for &(j, v) in row {
                    rd[j] += v * self.lam[i];
                    gz += v * self.z[j];
                }
                rg[i] = gz + self.s[i] - p.h[i];
            }
            let mut rp = self.pool.zeros(neq);
            for (r, row) in p.e.iter().enumerate() {
                let mut ez = 0.0;
                for &(j, v) in row {
                    rd[j] += v * self.mu[r];
                    ez += v * self.z[j];
                }
                rp[r] = ez - p.f[r];
            }
            let mut rpt = vec![0.0; nte];
            for (r, row) in p.te.iter().enumerate() {
                let mut ez = 0.0;
                for &(j, v) in row {
                    rd[j] += v * self.tmu[r];
                    ez += v * self.z[j];
                }
                rpt[r] = ez - p.tf[r];
            }
            let comp: f64 = (0..mi).map(|i| self.s[i] * self.lam[i]).sum::<f64>()
                + (0..n)
                    .map(|j| self.z[j] * self.zl[j] + (1.0 - self.z[j]) * self.zu[j])
                    .sum::<f64>();
            let mu_c = comp / npairs;
            let inf = |v: &[f64]| v.iter().fold(0.0f64, |a, b| a.max(b.abs()));
            let (ep, ed) = (inf(&rp).max(inf(&rpt)).max(inf(&rg)), inf(&rd));
            // Diverging: does the dual point already prove the LP empty?
            if let Some(top) = empty_above.filter(|_| mu_c >= last_mu) {
                if let Some(v) = cert(&self.lam, &self.mu, &self.tmu).filter(|v| *v > top) {
                    best = Some(v);
                    break;
                }
            }
            last_mu = mu_c;
            // Certify the dual point once it is close; stop when the bound stops improving.
            if mu_c < 1e-8 {
                match cert(&self.lam, &self.mu, &self.tmu) {
                    // An improvement below 1e-10 (relative) is a hundredth of the result pad.
                    Some(v) if best.is_none_or(|b| v > b + 1e-10 * (1.0 + b.abs())) => {
                        best = Some(v);
                        stale = 0;
                    }
                    _ => stale += 1,
                }
                // Done when the certified bound is within 1e-11 (relative) of the primal
                // objective (a thousandth of the result pad), or stops improving. (From N ~ 1e4
                // the equalities' pads alone keep it ~1e-9 away: the second rule ends the run.)
                let obj = offset + kappa * (0..n).map(|j| self.q[j] * self.z[j]).sum::<f64>();
                let close = best.is_some_and(|b| obj - b <= 1e-11 * (1.0 + b.abs()));
                if close || stale >= 1 || mu_c < 1e-14 {
                    break;
                }
            }
            if trace {
                let obj: f64 = (0..n).map(|j| self.q[j] * self.z[j]).sum();
                log::trace!(target: "smid::stage3", "ipm: it {it} ep {ep:.2e} ed {ed:.2e} mu {mu_c:.2e} obj {obj:.12e}");
            }

            if self.stop_at.is_some_and(|t| mu_c < t) {
                break;
            }
            self.refine = if mu_c < 1e-7 { 1 } else { 0 };
            if !self.factor() {
                break;
            }
            // Predictor (τ = 0), then corrector. Reciprocals of the slacks, once per iteration.
            let pool = &self.pool;
            let inv_s = pool.filled(mi, self.s.iter().map(|v| 1.0 / v));
            let inv_z = pool.filled(n, self.z.iter().map(|v| 1.0 / v));
            let inv_u = pool.filled(n, self.z.iter().map(|v| 1.0 / (1.0 - v)));
            let r2 = pool.filled(neq, rp.iter().map(|v| -v));
            let r2t: Vec<f64> = rpt.iter().map(|v| -v).collect();
            // The Newton direction whose complementarity products aim at `tau` (pairs: ineq i ->
            // tau[i]; lower box j -> tau[mi + j]; upper -> tau[mi + n + j]; None: all 0).
            let step = |this: &Self, tau: Option<&[f64]>| {
                let ta = |k: usize| tau.map_or(0.0, |t| t[k]);
                let mut r1 = this.pool.filled(n, rd.iter().map(|v| -v));
                for (i, row) in p.g.iter().enumerate() {
                    let rc = -this.s[i] * this.lam[i] + ta(i);
                    let a = (rc + this.lam[i] * rg[i]) * inv_s[i];
                    for &(j, v) in row {
                        r1[j] -= v * a;
                    }
                }
                for j in 0..n {
                    let rcl = -this.z[j] * this.zl[j] + ta(mi + j);
                    let rcu = -(1.0 - this.z[j]) * this.zu[j] + ta(mi + n + j);
                    r1[j] += rcl * inv_z[j] - rcu * inv_u[j];
                }
                let (dz, dmu, dtmu) = this.solve(&r1, &r2, &r2t)?;
                this.pool.put(r1);
                let mut ds = this.pool.zeros(mi);
                let mut dl = this.pool.zeros(mi);
                for (i, row) in p.g.iter().enumerate() {
                    let gdz: f64 = row.iter().map(|&(j, v)| v * dz[j]).sum();
                    ds[i] = -rg[i] - gdz;
                    let rc = -this.s[i] * this.lam[i] + ta(i);
                    dl[i] = (rc - this.lam[i] * ds[i]) * inv_s[i];
                }
                let mut dzl = this.pool.zeros(n);
                let mut dzu = this.pool.zeros(n);
                for j in 0..n {
                    let rcl = -this.z[j] * this.zl[j] + ta(mi + j);
                    let rcu = -(1.0 - this.z[j]) * this.zu[j] + ta(mi + n + j);
                    dzl[j] = (rcl - this.zl[j] * dz[j]) * inv_z[j];
                    dzu[j] = (rcu + this.zu[j] * dz[j]) * inv_u[j];
                }
                Some(Dir {
                    dz,
                    ds,
                    dl,
                    dzl,
                    dzu,
                    dmu,
                    dtmu,
                })
            };
            // Largest step in [0, 1] keeping x + α dx >= 0.
            let ratio = |x: &[f64], dx: &[f64]| -> f64 {
                let mut a = 1.0f64;
                for (x, d) in x.iter().zip(dx) {
                    if *d < 0.0 {
                        a = a.min(-x / d);
                    }
                }
                a
            };
            let alphas = |this: &Self, st: &Dir| {
                let Dir {
                    dz,
                    ds,
                    dl,
                    dzl,
                    dzu,
                    ..
                } = st;
                let mut ap = ratio(&this.z, dz).min(ratio(&this.s, ds));
                for (z, d) in this.z.iter().zip(dz) {
                    if *d > 0.0 {
                        ap = ap.min((1.0 - z) / d);
                    }
                }
                let ad = ratio(&this.lam, dl)
                    .min(ratio(&this.zl, dzl))
                    .min(ratio(&this.zu, dzu));
                (ap, ad)
            };
            let Some(aff) = step(self, None) else {
                break;
            };
            let (ap, ad) = alphas(self, &aff);
            let mut comp_aff = 0.0;
            for i in 0..mi {
                comp_aff += (self.s[i] + ap * aff.ds[i]) * (self.lam[i] + ad * aff.dl[i]);
            }
            for j in 0..n {
                comp_aff += (self.z[j] + ap * aff.dz[j]) * (self.zl[j] + ad * aff.dzl[j]);
                comp_aff += (1.0 - self.z[j] - ap * aff.dz[j]) * (self.zu[j] + ad * aff.dzu[j]);
            }
            let sigma = ((comp_aff / npairs) / mu_c).clamp(0.0, 1.0).powi(3);
            let target = sigma * mu_c;
            // Mehrotra's corrector targets: σμ minus the predictor's second-order term.
            let tau = self.pool.filled(
                mi + 2 * n,
                (0..mi)
                    .map(|i| target - aff.ds[i] * aff.dl[i])
                    .chain((0..n).map(|j| target - aff.dz[j] * aff.dzl[j]))
                    .chain((0..n).map(|j| target + aff.dz[j] * aff.dzu[j])),
            );
            aff.recycle(&self.pool);
            let Some(st) = step(self, Some(&tau)) else {
                break;
            };
            let (ap, ad) = alphas(self, &st);
            let (ap, ad) = ((0.995 * ap).min(1.0), (0.995 * ad).min(1.0));
            for j in 0..n {
                self.z[j] += ap * st.dz[j];
                self.zl[j] += ad * st.dzl[j];
                self.zu[j] += ad * st.dzu[j];
            }
            for i in 0..mi {
                self.s[i] += ap * st.ds[i];
                self.lam[i] += ad * st.dl[i];
            }
            for r in 0..neq {
                self.mu[r] += ad * st.dmu[r];
            }
            for r in 0..nte {
                self.tmu[r] += ad * st.dtmu[r];
            }
            self.iterations = it + 1;
            st.recycle(&self.pool);
            for v in [tau, rd, rg, rp, inv_s, inv_z, inv_u, r2] {
                self.pool.put(v);
            }
        }
        let last = cert(&self.lam, &self.mu, &self.tmu);
        let v = match (best, last) {
            (Some(b), Some(l)) => Some(b.max(l)),
            (b, l) => b.or(l),
        };
        (v, self.z.clone())
    }
}

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
