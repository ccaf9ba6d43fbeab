//! The polytope/LP bounding engine of the classical stage 3 ([`crate::stage3::classical`]): for
//! a polytope `{θ ∈ R^n : G θ <= h, E θ = f}` with few variables (`n` = the free parameters,
//! at most a few tens) and many rows (two per equation, so `m` grows with the record), it
//! computes per coordinate `min θ_k` and `max θ_k`, or proves the polytope empty.
//! Infeasibility is an outcome ([`LpOutcome::Infeasible`]), not an error.
//!
//! **Algorithm: a dense dual simplex in active-set form**, the low-dimensional LP whose
//! cost is linear in the record. A basis is `n` rows (the equalities, data rows, and rows of an
//! artificial box `|θ_j| <= THETA_MAX`) whose multipliers keep the objective's dual feasible;
//! each iteration solves two `n × n` systems and scans the `m` rows once for the most violated
//! one, which enters. A bound takes `n` to `3n` iterations, so its cost is `O(m n²)`: linear in
//! the record. Each objective starts from the artificial box (no warm start is needed at this
//! cost). An optimum that rests on the artificial box is [`SmidError::Unbounded`].
//!
//! **Guarantee, whatever the arithmetic of the iterations.** No bound is read from the
//! vertex. Every row is first relaxed outward by [`ROW_PAD`]. From the final basis's
//! multipliers `u` (inequalities clamped at `u >= 0`, equalities free), weak duality gives, for
//! every θ of the polytope, `c·θ >= -u·h - u_E·f + r·θ` with the residual `r = c + Gᵀu + Eᵀu_E`
//! (about 1e-16 of the terms). The sums are computed with a rigorous floating-point error bound
//! (`(k+2)·ε·Σ|terms|`), and `r·θ` is bounded by a box that the certificates themselves imply:
//! each gives `|θ_k| <= V + ρ max_j |θ_j|` with `ρ = max Σ_j |r_j|`, so every point of the
//! polytope has `max_j |θ_j| <= V / (1 - ρ)` (when `ρ < 1/2`). The bound is then widened by
//! [`RESULT_PAD`], as before. Emptiness is proven by a Farkas combination of `n + 1` rows whose
//! value, with its residual bounded over the artificial box, is negative: "no θ with every
//! `|θ_j| <= THETA_MAX` fits" (a parameter beyond 1e9 is outside every model smid considers;
//! a bound that reaches the box is reported unbounded, never as a number).
//!
//! An emptiness that the float combination cannot prove (a nearly empty polytope, its margin
//! below the rounding of the sums over the artificial box) is proven in exact rational
//! arithmetic ([`crate::exact`]): weights that solve the basis system exactly leave no
//! residual, so the sign of their right-hand side is the proof.
//!
//! When the simplex cannot conclude (iteration cap, a singular basis, an emptiness it cannot
//! prove) the polytope goes to the interior-point path (good_lp + clarabel), retried once with
//! sturdier settings. Clarabel's answer is never read as a number: its multipliers `z` go
//! through the same certificates (weak duality with the residual carried for a bound, a
//! Farkas combination for emptiness), so its bounds are as guaranteed as the simplex's.
//! When both interior-point attempts fail too (a polytope so thin or so nearly empty that no
//! path concludes), the dual simplex runs once more on the polytope with every inequality
//! relaxed outward by 1e-7, then 1e-5 (relative): a superset, so its certified bounds hold for
//! the polytope (looser by about the pad) and its emptiness proves the polytope empty.
//! Multipliers that certify nothing, or a failure of every path, are a [`SmidError::Solver`];
//! the branch and bound then halves the cell (a solver failure never discards one).
//!
//! The engine's files: this module (the polytope, its public bounds and the order of paths),
//! `simplex.rs` (the dual simplex), `certificate.rs` (weak-duality and Farkas certificates)
//! and `interior.rs` (the clarabel path).
mod certificate;
mod interior;
mod simplex;

use crate::error::{Result, SmidError};
use crate::interval::Interval;
use certificate::Certificate;
use interior::Ipm;
use simplex::Simplex;

/// Relative outward relaxation of each right-hand side.
pub const ROW_PAD: f64 = 1e-9;
/// Relative outward widening of each optimum.
pub const RESULT_PAD: f64 = 1e-8;
/// Factor on tolerances and pads when a numerical failure forced the sturdier retry.
const STURDY: f64 = 100.0;
/// The engine's order of paths, for bounds and for feasibility alike: the dual simplex; where
/// it cannot conclude (`None`), the interior-point path; where that fails as a solver
/// ([`SmidError::Solver`]), the simplex on the relaxed polytope; where that cannot conclude
/// either, the interior-point path's failure, extended. Any other error (an unbounded
/// coordinate) is returned as is.
fn first_conclusive<T>(
    simplex: impl FnOnce() -> Result<Option<T>>,
    ipm: impl FnOnce() -> Result<T>,
    relaxed: impl FnOnce() -> Option<T>,
) -> Result<T> {
    if let Some(out) = simplex()? {
        return Ok(out);
    }
    match ipm() {
        Err(SmidError::Solver(msg)) => relaxed().ok_or_else(|| relaxed_failed(&msg)),
        other => other,
    }
}
/// The solver error when every path failed, the last resort included (`msg`: the
/// interior-point path's).
fn relaxed_failed(msg: &str) -> SmidError {
    SmidError::Solver(format!(
        "{msg}; the dual simplex on the polytope relaxed outward by {RELAXED_PADS:?} did not conclude either (an unbounded relaxation says nothing of the polytope)"
    ))
}
/// Outward relaxations (relative, as [`ROW_PAD`]) tried in turn when neither the simplex nor
/// the interior-point path concludes on a polytope ([`Polytope::bound`]).
const RELAXED_PADS: [f64; 2] = [1e-7, 1e-5];
/// The artificial box of the simplex, `|θ_j| <= THETA_MAX`: an optimum on it is reported
/// unbounded, and emptiness is proven for the θ inside it.
pub const THETA_MAX: f64 = 1e9;
/// A polytope in `R^n` by inequalities and equalities (rows stored densely, row-major).
#[derive(Debug, Clone, Default)]
pub struct Polytope {
    /// Dimension of the space (the number of unknowns, `θ`'s length in stage 3).
    pub n: usize,
    /// Coefficients of the rows `g·θ <= h`, `n` per row.
    g: Vec<f64>,
    h: Vec<f64>,
    /// Each inequality's sample index, for diagnostics.
    tag: Vec<usize>,
    /// Rows `e·θ = f`.
    e: Vec<f64>,
    f: Vec<f64>,
}
/// Result of bounding a polytope.
#[derive(Debug, Clone, PartialEq)]
pub enum LpOutcome {
    /// Per-coordinate guaranteed intervals.
    Bounds(Vec<Interval>),
    /// The polytope is empty.
    Infeasible,
}
/// The range of a linear function over a polytope ([`Polytope::extent`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Extent {
    /// Guaranteed `[min, max]`.
    Range(Interval),
    /// The polytope is empty (proven).
    Empty,
    /// The simplex could not conclude (the caller falls back to a coarser bound).
    Unknown,
}
#[derive(Clone, Copy)]
enum Sense {
    Min,
    Max,
}
/// A row of the simplex basis.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Row {
    /// Inequality `i` of the polytope.
    Data(usize),
    /// Equality `j`.
    Eq(usize),
    /// The artificial box row `s·θ_j <= THETA_MAX`, `s = ±1`.
    Box(usize, bool),
}
/// `(k + 2) ε`: a bound of the relative rounding error of a sum of `k` products.
fn gamma(k: usize) -> f64 {
    (k as f64 + 2.0) * f64::EPSILON
}

impl Polytope {
    /// An empty description in `n` variables.
    pub fn new(n: usize) -> Self {
        Polytope {
            n,
            ..Default::default()
        }
    }

    /// Add `g·θ <= h` (tagged with a sample index for diagnostics).
    pub fn push_le(&mut self, g: &[f64], h: f64, tag: usize) {
        assert_eq!(g.len(), self.n, "row length");
        self.g.extend_from_slice(g);
        self.h.push(h);
        self.tag.push(tag);
    }

    /// Add `e·θ = f`.
    pub fn push_eq(&mut self, e: &[f64], f: f64) {
        assert_eq!(e.len(), self.n, "row length");
        self.e.extend_from_slice(e);
        self.f.push(f);
    }

    /// Number of inequality rows.
    pub fn rows(&self) -> usize {
        self.h.len()
    }

    fn grow(&self, i: usize) -> &[f64] {
        &self.g[i * self.n..(i + 1) * self.n]
    }

    fn erow(&self, j: usize) -> &[f64] {
        &self.e[j * self.n..(j + 1) * self.n]
    }

    /// The padded right-hand side of inequality `i`.
    fn hp(&self, i: usize, scale: f64) -> f64 {
        let h = self.h[i];
        h + ROW_PAD * scale * (1.0 + h.abs())
    }

    /// Coefficients and right-hand side of a basis row.
    fn row(&self, r: Row) -> (Vec<f64>, f64) {
        match r {
            Row::Data(i) => (self.grow(i).to_vec(), self.hp(i, 1.0)),
            Row::Eq(j) => (self.erow(j).to_vec(), self.f[j]),
            Row::Box(j, neg) => {
                let mut g = vec![0.0; self.n];
                g[j] = if neg { -1.0 } else { 1.0 };
                (g, THETA_MAX)
            }
        }
    }

    /// Guaranteed range of `c·θ` over the polytope, every point of which lies in the box
    /// `within` (rows of the polytope, or implied by them): the simplex's certificates for
    /// `min c·θ` and `min -c·θ` with their residuals carried over `within`, widened by
    /// [`RESULT_PAD`]. The guaranteed one-step band of [`crate::band`] asks this once per
    /// sample and side.
    pub fn extent(&self, c: &[f64], within: &[Interval]) -> Extent {
        assert_eq!(c.len(), self.n, "objective length");
        let big: Vec<f64> = within.iter().map(|i| i.lo.abs().max(i.hi.abs())).collect();
        if big.len() != self.n || big.iter().any(|v| !v.is_finite()) {
            return Extent::Unknown;
        }
        let mut ends = [0.0f64; 2];
        for (side, sign) in [1.0f64, -1.0].into_iter().enumerate() {
            let cs: Vec<f64> = c.iter().map(|v| sign * v).collect();
            match self.simplex(&cs) {
                Simplex::Optimal { basis, u } => {
                    let cert = self.certify(&basis, &u, &cs);
                    let slack: f64 = cert.resid.iter().zip(&big).map(|(r, m)| r * m).sum();
                    let v = cert.value - slack * (1.0 + gamma(self.n));
                    if !v.is_finite() {
                        return Extent::Unknown;
                    }
                    ends[side] = sign * v;
                }
                Simplex::Infeasible => return Extent::Empty,
                Simplex::Unbounded | Simplex::Unknown => return Extent::Unknown,
            }
        }
        let (lo, hi) = (ends[0], ends[1]);
        let round = 4.0 * f64::EPSILON * lo.abs().max(hi.abs());
        Extent::Range(
            Interval::new(lo.min(hi) - round, hi.max(lo) + round).widen(RESULT_PAD, RESULT_PAD),
        )
    }

    /// Bounds of every coordinate by the dual simplex: `None` when it cannot conclude.
    fn simplex_bounds(&self) -> Result<Option<LpOutcome>> {
        let n = self.n;
        let mut certs: Vec<[Certificate; 2]> = Vec::with_capacity(n);
        for k in 0..n {
            let mut pair = Vec::with_capacity(2);
            for sense in [Sense::Min, Sense::Max] {
                let mut c = vec![0.0; n];
                c[k] = match sense {
                    Sense::Min => 1.0,
                    Sense::Max => -1.0,
                };
                match self.simplex(&c) {
                    Simplex::Optimal { basis, u } => pair.push(self.certify(&basis, &u, &c)),
                    Simplex::Infeasible => return Ok(Some(LpOutcome::Infeasible)),
                    Simplex::Unbounded => return Err(unbounded(k)),
                    Simplex::Unknown => return Ok(None),
                }
            }
            let hi = pair.pop().expect("two sides");
            let lo = pair.pop().expect("two sides");
            certs.push([lo, hi]);
        }
        Ok(Self::bounds_from(&certs).map(LpOutcome::Bounds))
    }

    /// The guaranteed bounds that a lower and an upper certificate per coordinate give
    /// together; `None` when their residuals are too large to bound the polytope.
    fn bounds_from(certs: &[[Certificate; 2]]) -> Option<Vec<Interval>> {
        let n = certs.len();
        // The box the certificates imply: |θ_k| <= V + ρ max_j |θ_j| for every point.
        let v = certs
            .iter()
            .map(|[lo, hi]| lo.value.abs().max(hi.value.abs()))
            .fold(0.0f64, f64::max);
        let rho = certs
            .iter()
            .flat_map(|p| p.iter().map(|c| c.resid.iter().sum::<f64>()))
            .fold(0.0f64, f64::max);
        if !(v.is_finite() && rho < 0.5) {
            return None;
        }
        let big = v / (1.0 - rho) * (1.0 + 4.0 * f64::EPSILON);
        let mut out = Vec::with_capacity(n);
        for [lo, hi] in certs {
            let dl = lo.resid.iter().sum::<f64>() * big;
            let dh = hi.resid.iter().sum::<f64>() * big;
            let l = lo.value - dl;
            let h = -hi.value + dh;
            let round = 4.0 * f64::EPSILON * (l.abs().max(h.abs()));
            out.push(
                Interval::new(l.min(h) - round, h.max(l) + round).widen(RESULT_PAD, RESULT_PAD),
            );
        }
        Some(out)
    }

    /// The optimum of `min c·θ` read at the simplex's optimal vertex: accurate but **not** a
    /// guaranteed bound (for measurements such as the exact-grid inner hull). `Ok(None)` when
    /// the polytope is empty, unbounded in that direction, or the simplex cannot conclude.
    pub fn vertex_optimum(&self, c: &[f64]) -> Option<f64> {
        match self.simplex(c) {
            Simplex::Optimal { basis, .. } => {
                let x = self.vertex(&basis)?;
                Some(c.iter().zip(&x).map(|(a, b)| a * b).sum())
            }
            _ => None,
        }
    }

    /// The simplex's optimal vertex of `min c·θ` (a measurement, as [`Self::vertex_optimum`]).
    pub fn vertex_point(&self, c: &[f64]) -> Option<Vec<f64>> {
        match self.simplex(c) {
            Simplex::Optimal { basis, .. } => self.vertex(&basis),
            _ => None,
        }
    }

    /// Whether the polytope is non-empty: `false` is a proof (over the artificial box).
    pub fn feasible(&self) -> Result<bool> {
        first_conclusive(
            || Ok(self.simplex(&vec![0.0; self.n]).feasibility()),
            || self.clarabel(None).map(|ipm| !matches!(ipm, Ipm::Empty)),
            || self.relaxed_feasible(),
        )
    }

    /// Guaranteed bounds of every coordinate, or [`LpOutcome::Infeasible`].
    pub fn bound(&self) -> Result<LpOutcome> {
        first_conclusive(
            || self.simplex_bounds(),
            || self.clarabel_bounds(),
            || self.relaxed_bounds(),
        )
    }

    /// The last resort of [`Self::feasible`] ([`Self::relaxed_bounds`]'s, for feasibility):
    /// `Some(false)` proves this polytope empty (a superset is); `Some(true)` only keeps the
    /// cell, as the interior-point path's "not empty" does; `None` when no relaxation concludes.
    fn relaxed_feasible(&self) -> Option<bool> {
        RELAXED_PADS.iter().find_map(|&pad| {
            let out = self.relaxed(pad).simplex(&vec![0.0; self.n]).feasibility();
            if let Some(f) = out {
                log::debug!("LP: feasible = {f} on the polytope relaxed outward by {pad:e}");
            }
            out
        })
    }

    /// The last resort when the simplex and both interior-point attempts fail (a polytope so
    /// thin, or so nearly empty, that neither concludes): the dual simplex on the polytope with
    /// every inequality relaxed outward by [`RELAXED_PADS`] in turn (relative, as
    /// [`ROW_PAD`]). The relaxed polytope contains this one, so its certified bounds hold here
    /// (looser by about the pad) and its emptiness proves this one empty. An answer that the
    /// relaxed polytope is unbounded says nothing of this one: `None`, as a failure.
    fn relaxed_bounds(&self) -> Option<LpOutcome> {
        RELAXED_PADS.iter().find_map(|&pad| {
            let out = self.relaxed(pad).simplex_bounds().ok().flatten();
            if out.is_some() {
                log::debug!("LP: concluded on the polytope relaxed outward by {pad:e}");
            }
            out
        })
    }

    /// This polytope with every inequality's right-hand side raised by `pad·(1 + |h|)`: a
    /// superset of it (the equalities stay).
    fn relaxed(&self, pad: f64) -> Polytope {
        let mut p = self.clone();
        for h in &mut p.h {
            *h += pad * (1.0 + h.abs());
        }
        p
    }
}

fn unbounded(k: usize) -> SmidError {
    SmidError::Unbounded {
        parameter: format!("θ[{k}]"),
        message: "the linear program is unbounded: the data do not constrain this parameter".into(),
    }
}

#[cfg(test)]
mod tests;
