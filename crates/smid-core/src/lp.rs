//! The polytope/LP bounding engine of the classical stage 3 ([`crate::stage3::classical`]): for
//! a polytope `{θ ∈ R^n : G θ <= h, E θ = f}` with few variables (`n` = the free parameters,
//! at most a few tens) and many rows (two per equation, so `m` grows with the record), it
//! computes per coordinate `min θ_k` and `max θ_k`, or proves the polytope empty.
//! Infeasibility is an outcome ([`LpOutcome::Infeasible`]), not an error.
//!
//! **Algorithm: a dense dual simplex in active-set form**, the low-dimensional LP of the
//! issue's "cost linear in N". A basis is `n` rows (the equalities, data rows, and rows of an
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
use crate::error::{Result, SmidError};
use crate::interval::Interval;
use good_lp::{solvers::clarabel::clarabel, Expression, ProblemVariables, SolverModel, Variable};
use nalgebra::{DMatrix, DVector};
use num_traits::Signed;

/// LU factors of a basis matrix's transpose.
type LuT = nalgebra::linalg::LU<f64, nalgebra::Dyn, nalgebra::Dyn>;

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

/// What the simplex concluded for one objective.
enum Simplex {
    /// Optimal basis with its multipliers (`u` per basis row).
    Optimal { basis: Vec<Row>, u: Vec<f64> },
    /// Emptiness proven over the artificial box.
    Infeasible,
    /// The optimum rests on the artificial box.
    Unbounded,
    /// No conclusion (cap, singular basis, unproven emptiness): use the interior-point path.
    Unknown,
}

impl Simplex {
    /// Whether a zero-objective run found the polytope non-empty (`None`: no conclusion).
    fn feasibility(&self) -> Option<bool> {
        match self {
            Simplex::Optimal { .. } | Simplex::Unbounded => Some(true),
            Simplex::Infeasible => Some(false),
            Simplex::Unknown => None,
        }
    }

    /// [`Simplex::Unknown`], saying why at debug level (`SMID_LOG=debug`).
    fn unknown(why: &str) -> Simplex {
        log::debug!("dual simplex: no conclusion ({why})");
        Simplex::Unknown
    }
}

/// One certified side: `c·θ >= value - Σ_j resid_j |θ_j|` for every θ of the polytope.
struct Certificate {
    value: f64,
    resid: Vec<f64>,
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

    /// The dual simplex for `min c·θ` (`c = 0`: feasibility).
    fn simplex(&self, c: &[f64]) -> Simplex {
        let n = self.n;
        let m = self.rows();
        let q = self.f.len();
        if n == 0 {
            return self.simplex_trivial();
        }
        // Start: the equalities, completed to a basis by box rows on the coordinates that
        // Gaussian elimination of E leaves without a pivot.
        let mut basis: Vec<Row> = (0..q).map(Row::Eq).collect();
        {
            let mut a = DMatrix::<f64>::zeros(q, n);
            for j in 0..q {
                for k in 0..n {
                    a[(j, k)] = self.e[j * n + k];
                }
            }
            let mut pivoted = vec![false; n];
            let mut r = 0;
            for col in 0..n {
                if r == q {
                    break;
                }
                let (p, v) = (r..q)
                    .map(|i| (i, a[(i, col)].abs()))
                    .fold((r, 0.0), |b, x| if x.1 > b.1 { x } else { b });
                if v <= 1e-12 {
                    continue;
                }
                a.swap_rows(r, p);
                for i in r + 1..q {
                    let f = a[(i, col)] / a[(r, col)];
                    for k in col..n {
                        let t = a[(r, k)];
                        a[(i, k)] -= f * t;
                    }
                }
                pivoted[col] = true;
                r += 1;
            }
            if r < q {
                return Simplex::unknown("dependent equalities");
            }
            basis.extend((0..n).filter(|&k| !pivoted[k]).map(|k| Row::Box(k, false)));
        }
        // Box signs so that the starting multipliers are >= 0.
        let Some(mut u) = Self::multipliers_lu(&self.lu_t(&basis), c) else {
            return Simplex::unknown("singular starting basis");
        };
        for (b, ub) in basis.iter_mut().zip(u.iter_mut()) {
            if let Row::Box(k, neg) = *b {
                if *ub < 0.0 {
                    *b = Row::Box(k, !neg);
                    *ub = -*ub;
                }
            }
        }
        let norms: Vec<f64> = (0..m)
            .map(|i| self.grow(i).iter().map(|v| v * v).sum::<f64>().sqrt())
            .collect();
        let cap = 50 * n + 100;
        // The factors of `G_Bᵀ` for the current basis, kept from the multipliers after a pivot
        // for the next iteration's entering row (the same matrix, the same factors).
        let mut factors: Option<LuT> = None;
        for _ in 0..cap {
            let Some(x) = self.vertex(&basis) else {
                return Simplex::unknown("singular basis (vertex)");
            };
            // The most violated row (normalised), data rows and then the box.
            let mut best: Option<(Row, f64)> = None;
            let xmax = x.iter().fold(0.0f64, |a, v| a.max(v.abs()));
            for i in 0..m {
                let g = self.grow(i);
                let hi = self.hp(i, 1.0);
                let lhs: f64 = g.iter().zip(&x).map(|(a, b)| a * b).sum();
                let viol = lhs - hi;
                if norms[i] == 0.0 {
                    if hi < 0.0 {
                        // `0 <= h < 0`: empty, whatever θ.
                        return Simplex::Infeasible;
                    }
                    continue;
                }
                let tol = 1e-12 * (1.0 + hi.abs() + norms[i] * xmax);
                if viol > tol {
                    let s = viol / norms[i];
                    if best.is_none_or(|b| s > b.1) {
                        best = Some((Row::Data(i), s));
                    }
                }
            }
            for (k, &xk) in x.iter().enumerate() {
                if xk.abs() > THETA_MAX * (1.0 + 1e-9) {
                    let s = xk.abs() - THETA_MAX;
                    if best.is_none_or(|b| s > b.1) {
                        best = Some((Row::Box(k, xk < 0.0), s));
                    }
                }
            }
            let Some((enter, _)) = best else {
                // Primal feasible and dual feasible: optimal.
                if basis
                    .iter()
                    .zip(&u)
                    .any(|(b, &ub)| matches!(b, Row::Box(..)) && ub > 1e-9 * (1.0 + norm1(c)))
                {
                    return Simplex::Unbounded;
                }
                return Simplex::Optimal { basis, u };
            };
            // Express the entering row in the basis: G_Bᵀ v = g_enter.
            let (ge, _) = self.row(enter);
            let lu = factors.take().unwrap_or_else(|| self.lu_t(&basis));
            let Some(v) = Self::solve_lu_t(&lu, &ge) else {
                return Simplex::unknown("singular basis (entering row)");
            };
            // Ratio test over the inequality rows of the basis.
            let vmax = v.iter().fold(0.0f64, |a, b| a.max(b.abs()));
            let mut leave: Option<(usize, f64, f64)> = None;
            for (idx, (&b, &vi)) in basis.iter().zip(&v).enumerate() {
                if matches!(b, Row::Eq(_)) || vi <= 1e-12 * vmax.max(1.0) {
                    continue;
                }
                let t = u[idx].max(0.0) / vi;
                let better = match leave {
                    None => true,
                    Some((_, bt, bv)) => t < bt - 1e-15 * bt.abs() || (t <= bt && vi > bv),
                };
                if better {
                    leave = Some((idx, t, vi));
                }
            }
            match leave {
                None => {
                    // Farkas: g_enter - Σ v_i g_i = 0 with -v_i >= 0 on the inequalities.
                    return if self.farkas_proves(&basis, &v, enter) {
                        Simplex::Infeasible
                    } else {
                        Simplex::unknown("an emptiness the Farkas combination cannot prove")
                    };
                }
                Some((idx, _, _)) => {
                    basis[idx] = enter;
                    let lu = self.lu_t(&basis);
                    match Self::multipliers_lu(&lu, c) {
                        Some(nu) => u = nu,
                        None => return Simplex::unknown("singular basis (multipliers)"),
                    }
                    factors = Some(lu);
                    // Rounding may leave tiny negative multipliers: they are clamped in the
                    // certificate (which accounts for the residual they leave).
                }
            }
        }
        Simplex::unknown("iteration cap")
    }

    /// `n = 0`: the polytope is `{()}` when every row holds, else empty.
    fn simplex_trivial(&self) -> Simplex {
        let ok = (0..self.rows()).all(|i| self.hp(i, 1.0) >= 0.0)
            && self.f.iter().all(|f| f.abs() <= 1e-12);
        if ok {
            Simplex::Optimal {
                basis: Vec::new(),
                u: Vec::new(),
            }
        } else {
            Simplex::Infeasible
        }
    }

    fn basis_matrix(&self, basis: &[Row]) -> (DMatrix<f64>, DVector<f64>) {
        let n = self.n;
        let mut a = DMatrix::<f64>::zeros(n, n);
        let mut b = DVector::<f64>::zeros(n);
        for (r, &row) in basis.iter().enumerate() {
            let (g, h) = self.row(row);
            for k in 0..n {
                a[(r, k)] = g[k];
            }
            b[r] = h;
        }
        (a, b)
    }

    /// The vertex of the basis: `G_B θ = h_B`.
    fn vertex(&self, basis: &[Row]) -> Option<Vec<f64>> {
        let (a, b) = self.basis_matrix(basis);
        let x = a.lu().solve(&b)?;
        x.iter()
            .all(|v| v.is_finite())
            .then(|| x.iter().copied().collect())
    }

    /// The LU factors of `G_Bᵀ`.
    fn lu_t(&self, basis: &[Row]) -> LuT {
        let (a, _) = self.basis_matrix(basis);
        a.transpose().lu()
    }

    /// `G_Bᵀ y = rhs` from the factors of `G_Bᵀ` ([`Self::lu_t`]).
    fn solve_lu_t(lu: &LuT, rhs: &[f64]) -> Option<Vec<f64>> {
        let y = lu.solve(&DVector::from_column_slice(rhs))?;
        y.iter()
            .all(|v| v.is_finite())
            .then(|| y.iter().copied().collect())
    }

    /// The multipliers of the basis for `min c·θ` (`G_Bᵀ u = -c`) from the factors of `G_Bᵀ`.
    fn multipliers_lu(lu: &LuT, c: &[f64]) -> Option<Vec<f64>> {
        let neg: Vec<f64> = c.iter().map(|v| -v).collect();
        Self::solve_lu_t(lu, &neg)
    }

    /// Whether the Farkas combination `g_enter - Σ v_i g_i` (weights `1`, `-v_i`) proves that no
    /// θ in the artificial box satisfies the rows: its right-hand side, less the rounding of
    /// the sums and the residual over the box, is negative.
    fn farkas_proves(&self, basis: &[Row], v: &[f64], enter: Row) -> bool {
        let mut weights: Vec<(Row, f64)> = vec![(enter, 1.0)];
        weights.extend(basis.iter().zip(v).map(|(&b, &vi)| (b, -vi)));
        self.farkas_weights_prove(&weights) || self.farkas_proves_exactly(basis, enter)
    }

    /// Whether the combination of rows with `weights` (inequalities clamped at `>= 0`) proves
    /// that no θ of the artificial box satisfies the rows: its right-hand side, less the
    /// rounding of the sums and its residual over the box, is negative.
    fn farkas_weights_prove(&self, weights: &[(Row, f64)]) -> bool {
        let n = self.n;
        let weights = clamped(weights);
        let mut resid = vec![0.0; n];
        let mut mag = vec![0.0; n];
        let (mut rhs, mut rhs_mag) = (0.0, 0.0);
        for &(row, w) in &weights {
            let (g, h) = self.row(row);
            for k in 0..n {
                resid[k] += w * g[k];
                mag[k] += (w * g[k]).abs();
            }
            rhs += w * h;
            rhs_mag += (w * h).abs();
        }
        let k = weights.len();
        let slack: f64 = (0..n)
            .map(|j| (resid[j].abs() + gamma(k) * mag[j]) * THETA_MAX)
            .sum::<f64>();
        // Every θ of the box satisfying the rows has resid·θ <= rhs, and resid·θ >= -slack.
        rhs + gamma(k) * rhs_mag + slack < 0.0
    }

    /// The same proof in exact rational arithmetic ([`crate::exact`]), for a nearly empty
    /// polytope whose float combination is lost in its own rounding: the entering row with
    /// weight 1 and the basis rows with weights that solve `G_Bᵀ v = g_enter` exactly.
    fn farkas_proves_exactly(&self, basis: &[Row], enter: Row) -> bool {
        self.farkas_exact(&[(enter, 1.0)], basis)
    }

    /// Whether rows `fixed` with their (float, taken as exact) weights, completed by `basis`
    /// rows whose weights cancel their combination **exactly** (`G_Bᵀ w_B = -Σ w_i g_i` solved
    /// in rationals), prove that no θ satisfies the rows: every inequality weight `>= 0` and
    /// the combined right-hand side `< 0`, both exactly. The combination of the left-hand
    /// sides is then exactly zero, so the rows imply `0 <= Σ w h < 0`.
    fn farkas_exact(&self, fixed: &[(Row, f64)], basis: &[Row]) -> bool {
        use crate::exact::{rational, solve_rational};
        let n = self.n;
        if basis.len() != n
            || fixed
                .iter()
                .any(|&(r, w)| !matches!(r, Row::Eq(_)) && w < 0.0)
        {
            return false;
        }
        let mut rhs = vec![num_rational::BigRational::from_integer(0.into()); n];
        let mut total = num_rational::BigRational::from_integer(0.into());
        for &(r, w) in fixed {
            if w == 0.0 {
                continue;
            }
            let (g, h) = self.row(r);
            let (Some(w), Some(h)) = (rational(w), rational(h)) else {
                return false;
            };
            for k in 0..n {
                if g[k] != 0.0 {
                    rhs[k] -= &w * rational(g[k]).expect("finite row");
                }
            }
            total += w * h;
        }
        let rows: Vec<(Vec<f64>, f64)> = basis.iter().map(|&b| self.row(b)).collect();
        // Column i of the system is basis row i.
        let a: Vec<Vec<f64>> = (0..n)
            .map(|k| rows.iter().map(|(g, _)| g[k]).collect())
            .collect();
        let Some(wb) = solve_rational(&a, rhs) else {
            return false;
        };
        for ((&b, wi), (_, hi)) in basis.iter().zip(wb).zip(&rows) {
            if !matches!(b, Row::Eq(_)) && wi.is_negative() {
                return false;
            }
            let Some(h) = rational(*hi) else {
                return false;
            };
            total += wi * h;
        }
        total.is_negative()
    }

    /// Whether an interior-point Farkas vector proves the polytope empty: as it is (floats,
    /// over the artificial box), or through the `n + 1` rows it weighs most, combined exactly
    /// ([`Self::farkas_proves_exactly`] with each of them in turn as the entering row; an
    /// emptiness in `R^n` always has a proof on at most `n + 1` rows).
    fn farkas_multipliers_prove(&self, weights: &[(Row, f64)]) -> bool {
        if self.farkas_weights_prove(weights) {
            return true;
        }
        // The weights clamped as the certificate reads them; the `n` heaviest independent
        // rows absorb the residual exactly.
        let w = clamped(weights);
        let mut order: Vec<usize> = (0..w.len()).filter(|&i| w[i].1 != 0.0).collect();
        order.sort_by(|&a, &b| w[b].1.abs().total_cmp(&w[a].1.abs()));
        let mut basis: Vec<usize> = Vec::with_capacity(self.n);
        let mut span: Vec<Vec<f64>> = Vec::new();
        for &i in &order {
            if basis.len() == self.n {
                break;
            }
            // Gram-Schmidt: keep the row when it adds a direction.
            let (mut g, _) = self.row(w[i].0);
            let norm0 = g.iter().map(|v| v * v).sum::<f64>().sqrt();
            for q in &span {
                let d: f64 = g.iter().zip(q).map(|(a, b)| a * b).sum();
                g.iter_mut().zip(q).for_each(|(a, b)| *a -= d * b);
            }
            let norm = g.iter().map(|v| v * v).sum::<f64>().sqrt();
            if norm > 1e-9 * norm0 {
                g.iter_mut().for_each(|v| *v /= norm);
                span.push(g);
                basis.push(i);
            }
        }
        let fixed: Vec<(Row, f64)> = (0..w.len())
            .filter(|i| !basis.contains(i))
            .map(|i| w[i])
            .collect();
        let basis_rows: Vec<Row> = basis.iter().map(|&i| w[i].0).collect();
        self.farkas_exact(&fixed, &basis_rows)
    }

    /// The certified lower bound of `min c·θ` from an optimal basis.
    fn certify(&self, basis: &[Row], u: &[f64], c: &[f64]) -> Certificate {
        let weights: Vec<(Row, f64)> = basis.iter().copied().zip(u.iter().copied()).collect();
        self.certify_weights(&weights, c)
    }

    /// The certified lower bound of `min c·θ` from multipliers on any rows (weak duality:
    /// inequalities clamped at `>= 0`, box rows dropped; the residual is carried).
    fn certify_weights(&self, weights: &[(Row, f64)], c: &[f64]) -> Certificate {
        let n = self.n;
        let mut resid: Vec<f64> = c.to_vec();
        let mut mag: Vec<f64> = c.iter().map(|v| v.abs()).collect();
        let (mut dual, mut dual_mag) = (0.0, 0.0);
        for &(b, ub) in weights {
            let (g, h) = self.row(b);
            let w = match b {
                Row::Eq(_) => ub,
                Row::Data(_) => ub.max(0.0),
                // Box rows carry no multiplier at an optimum that is not unbounded.
                Row::Box(..) => 0.0,
            };
            if w == 0.0 {
                continue;
            }
            for k in 0..n {
                resid[k] += w * g[k];
                mag[k] += (w * g[k]).abs();
            }
            dual -= w * h;
            dual_mag += (w * h).abs();
        }
        let k = weights.len() + 1;
        Certificate {
            value: dual - gamma(k) * dual_mag,
            resid: (0..n).map(|j| resid[j].abs() + gamma(k) * mag[j]).collect(),
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

    /// Bounds by the interior-point path (good_lp + clarabel), for what the simplex cannot
    /// conclude. Clarabel's multipliers are certified as the simplex's are (weak duality with
    /// the residual carried), so its bounds are certificates too.
    pub fn clarabel_bounds(&self) -> Result<LpOutcome> {
        let mut certs: Vec<[Certificate; 2]> = Vec::with_capacity(self.n);
        for k in 0..self.n {
            let mut pair = Vec::with_capacity(2);
            for sense in [Sense::Min, Sense::Max] {
                match self.clarabel(Some((k, sense)))? {
                    Ipm::Bound(c) => pair.push(c),
                    Ipm::Empty => return Ok(LpOutcome::Infeasible),
                    Ipm::Feasible => unreachable!("an objective gives a bound"),
                }
            }
            let hi = pair.pop().expect("two sides");
            let lo = pair.pop().expect("two sides");
            certs.push([lo, hi]);
        }
        Self::bounds_from(&certs)
            .map(LpOutcome::Bounds)
            .ok_or_else(|| {
                SmidError::Solver(
                    "the interior-point multipliers leave too large a residual to certify a bound"
                        .into(),
                )
            })
    }

    /// Solve by clarabel; when it fails numerically, retry once with sturdier settings
    /// (looser tolerances, more regularisation, rows relaxed 100 times more: the multipliers
    /// are certified against the rows as they are, whatever problem produced them).
    fn clarabel(&self, objective: Option<(usize, Sense)>) -> Result<Ipm> {
        match self.clarabel_once(objective, false) {
            Err(SmidError::Solver(first)) => match self.clarabel_once(objective, true) {
                Err(SmidError::Solver(second)) => Err(SmidError::Solver(format!(
                    "{first}; retried with sturdier settings: {second}"
                ))),
                other => other,
            },
            other => other,
        }
    }

    fn clarabel_once(&self, objective: Option<(usize, Sense)>, sturdy: bool) -> Result<Ipm> {
        use clarabel::solver::{IPSolver, SolverStatus as S};
        let scale = if sturdy { STURDY } else { 1.0 };
        let mut vars = ProblemVariables::new();
        let th: Vec<Variable> = (0..self.n).map(|_| vars.add(good_lp::variable())).collect();
        let mut c = vec![0.0; self.n];
        if let Some((k, sense)) = objective {
            c[k] = match sense {
                Sense::Min => 1.0,
                Sense::Max => -1.0,
            };
        }
        let obj: Expression = c.iter().zip(&th).map(|(ck, v)| *ck * *v).sum();
        let lin = |coefs: &[f64]| -> Expression {
            coefs
                .iter()
                .zip(&th)
                .filter(|(c, _)| **c != 0.0)
                .map(|(c, v)| *c * *v)
                .sum()
        };
        let mut problem = clarabel(vars.minimise(obj));
        let tol = 1e-10 * scale;
        problem
            .settings()
            .tol_gap_abs(tol)
            .tol_gap_rel(tol)
            .tol_feas(tol)
            .max_iter(if sturdy { 2000 } else { 400 });
        if sturdy {
            problem
                .settings()
                .static_regularization_constant(1e-7)
                .equilibrate_max_iter(50);
        }
        // Rows in order: the inequalities, then the equalities (clarabel's `z` follows them).
        for i in 0..self.rows() {
            problem = problem.with(lin(self.grow(i)).leq(self.hp(i, scale)));
        }
        for j in 0..self.f.len() {
            problem = problem.with(lin(self.erow(j)).eq(self.f[j]));
        }
        let mut solver = problem
            .try_into_solver()
            .map_err(|e| SmidError::Solver(e.to_string()))?;
        solver.solve();
        let sol = &solver.solution;
        let m = self.rows();
        let weights = || -> Vec<(Row, f64)> {
            (0..m)
                .map(|i| (Row::Data(i), sol.z[i]))
                .chain((0..self.f.len()).map(|j| (Row::Eq(j), sol.z[m + j])))
                .collect()
        };
        if sol.z.len() != m + self.f.len() {
            return Err(SmidError::Solver(format!(
                "clarabel returned {} multipliers for {} rows",
                sol.z.len(),
                m + self.f.len()
            )));
        }
        match sol.status {
            S::Solved | S::AlmostSolved => Ok(match objective {
                None => Ipm::Feasible,
                Some(_) => Ipm::Bound(self.certify_weights(&weights(), &c)),
            }),
            S::PrimalInfeasible | S::AlmostPrimalInfeasible => {
                if self.farkas_multipliers_prove(&weights()) {
                    Ok(Ipm::Empty)
                } else {
                    Err(SmidError::Solver(format!(
                        "clarabel stopped with status {:?} but its multipliers do not prove the polytope empty",
                        sol.status
                    )))
                }
            }
            S::DualInfeasible | S::AlmostDualInfeasible => {
                Err(unbounded(objective.map_or(0, |(k, _)| k)))
            }
            other => Err(SmidError::Solver(format!(
                "clarabel stopped with status {other:?}"
            ))),
        }
    }
}

/// What the interior-point path concluded.
enum Ipm {
    /// A certified side of the objective.
    Bound(Certificate),
    /// Solved without an objective (feasibility): nothing proven empty.
    Feasible,
    /// Emptiness proven by clarabel's Farkas multipliers.
    Empty,
}

/// Multipliers as a certificate may use them: an inequality's (data or box row) clamped at
/// `>= 0`, an equality's of either sign.
fn clamped(weights: &[(Row, f64)]) -> Vec<(Row, f64)> {
    weights
        .iter()
        .map(|&(r, w)| match r {
            Row::Eq(_) => (r, w),
            _ => (r, w.max(0.0)),
        })
        .collect()
}

fn norm1(c: &[f64]) -> f64 {
    c.iter().map(|v| v.abs()).sum()
}

fn unbounded(k: usize) -> SmidError {
    SmidError::Unbounded {
        parameter: format!("θ[{k}]"),
        message: "the linear program is unbounded: the data do not constrain this parameter".into(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// The engine's fallback order, driven with stand-in paths.
    #[test]
    fn paths_are_tried_in_order_and_the_relaxed_one_only_after_a_solver_failure() {
        use std::cell::Cell;
        let solver = || Err(SmidError::Solver("ipm trouble".into()));
        // Each later path runs only where every earlier one did not conclude.
        let called = Cell::new(0);
        let relaxed = |v: Option<u8>| {
            called.set(called.get() + 1);
            v
        };
        assert_eq!(
            first_conclusive(|| Ok(Some(1)), solver, || relaxed(Some(3))).unwrap(),
            1
        );
        assert_eq!(
            first_conclusive(|| Ok(None), || Ok(2), || relaxed(Some(3))).unwrap(),
            2
        );
        assert_eq!(called.get(), 0);
        assert_eq!(
            first_conclusive(|| Ok(None), solver, || relaxed(Some(3))).unwrap(),
            3
        );
        assert_eq!(called.get(), 1);
        // Nothing concludes: the interior-point path's failure, extended, still a solver error.
        match first_conclusive(|| Ok(None), solver, || relaxed(None)) {
            Err(SmidError::Solver(m)) => {
                assert!(
                    m.starts_with("ipm trouble") && m.contains("relaxed outward"),
                    "{m}"
                )
            }
            other => panic!("{other:?}"),
        }
        // An unbounded coordinate is an answer of its own, never sent to the relaxation (whose
        // "unbounded" says nothing), from either path.
        let unb = || Err::<u8, _>(unbounded(0));
        assert!(matches!(
            first_conclusive(|| Err(unbounded(0)), solver, || relaxed(Some(3))),
            Err(SmidError::Unbounded { .. })
        ));
        assert!(matches!(
            first_conclusive(|| Ok(None), unb, || relaxed(Some(3))),
            Err(SmidError::Unbounded { .. })
        ));
        assert_eq!(called.get(), 2);
    }

    /// An interval emptier than the rounding of the float certificate (`1 <= x <= 1 - 1e-7`
    /// after padding: the float combination's slack over the artificial box is about 1e-6):
    /// only the exact combination proves it empty, and the simplex does so without the
    /// interior-point path.
    #[test]
    fn a_nearly_empty_polytope_is_proven_empty_exactly() {
        let mut p = Polytope::new(1);
        p.push_le(&[1.0], 1.0, 0);
        p.push_le(&[-1.0], -(1.0 + 1e-7), 1);
        assert!(matches!(p.simplex(&[0.0]), Simplex::Infeasible));
        assert!(matches!(p.simplex(&[1.0]), Simplex::Infeasible));
        assert_eq!(p.bound().unwrap(), LpOutcome::Infeasible);
        assert!(!p.feasible().unwrap());
        // Just inside (a gap the padding closes): not empty, and bounded around 1.
        let mut q = Polytope::new(1);
        q.push_le(&[1.0], 1.0, 0);
        q.push_le(&[-1.0], -(1.0 + 1e-10), 1);
        assert!(q.feasible().unwrap());
    }

    fn tri() -> Polytope {
        // 0 <= x, y <= 1, x + y <= 1.5, x - y = 0
        let mut p = Polytope::new(2);
        p.push_le(&[-1.0, 0.0], 0.0, 0);
        p.push_le(&[0.0, -1.0], 0.0, 0);
        p.push_le(&[1.0, 0.0], 1.0, 0);
        p.push_le(&[0.0, 1.0], 1.0, 0);
        p.push_le(&[1.0, 1.0], 1.5, 0);
        p.push_eq(&[1.0, -1.0], 0.0);
        p
    }

    #[test]
    fn box_with_diagonal_cut() {
        let mut p = tri();
        for out in [p.bound().unwrap(), p.clarabel_bounds().unwrap()] {
            match out {
                LpOutcome::Bounds(b) => {
                    assert!(b[0].contains(0.0) && b[0].contains(0.75));
                    assert!(
                        (b[0].hi - 0.75).abs() < 1e-6 && b[0].lo.abs() < 1e-6,
                        "{b:?}"
                    );
                }
                LpOutcome::Infeasible => panic!("feasible"),
            }
        }
        assert!(p.feasible().unwrap());
        p.push_le(&[-1.0, 0.0], -2.0, 9);
        assert_eq!(p.bound().unwrap(), LpOutcome::Infeasible);
        assert!(!p.feasible().unwrap());
    }

    #[test]
    fn an_open_direction_is_unbounded_not_a_number() {
        let mut p = Polytope::new(2);
        p.push_le(&[-1.0, 0.0], 0.0, 0);
        p.push_le(&[0.0, -1.0], 0.0, 0);
        p.push_le(&[1.0, -1.0], 1.0, 0);
        assert!(matches!(p.bound(), Err(SmidError::Unbounded { .. })));
        assert!(p.feasible().unwrap());
    }

    /// A random polytope around a known point `x0` (returned): `m` random rows that `x0`
    /// satisfies with a random slack, a box of half-width 3 around it (every LP bounded), and
    /// with `eq` (and `n > 1`) a random equality through it; everything times `scale`.
    fn random_polytope(
        seed: u64,
        n: usize,
        m: usize,
        eq: bool,
        scale: f64,
    ) -> (Polytope, Vec<f64>) {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        let x0: Vec<f64> = (0..n).map(|_| rng.gen_range(-2.0..2.0)).collect();
        let mut p = Polytope::new(n);
        for _ in 0..m {
            let g: Vec<f64> = (0..n).map(|_| rng.gen_range(-1.0..1.0)).collect();
            let h = g.iter().zip(&x0).map(|(a, b)| a * b).sum::<f64>() + rng.gen_range(0.0..0.5);
            p.push_le(&g, h * scale, 0);
        }
        let x0: Vec<f64> = x0.iter().map(|v| v * scale).collect();
        for k in 0..n {
            let mut g = vec![0.0; n];
            g[k] = 1.0;
            p.push_le(&g, x0[k] + 3.0 * scale, 0);
            g[k] = -1.0;
            p.push_le(&g, -x0[k] + 3.0 * scale, 0);
        }
        if eq && n > 1 {
            let e: Vec<f64> = (0..n).map(|_| rng.gen_range(-1.0..1.0)).collect();
            let f = e.iter().zip(&x0).map(|(a, b)| a * b).sum::<f64>();
            p.push_eq(&e, f);
        }
        (p, x0)
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]
        /// Random polytopes around a known point: the simplex's certified bounds contain the
        /// point and agree with clarabel's to the pads.
        #[test]
        fn simplex_bounds_contain_the_point_and_agree_with_clarabel(
            seed in any::<u64>(), n in 1usize..6, m in 4usize..60, eq in any::<bool>(),
        ) {
            let (mut p, x0) = random_polytope(seed, n, m, eq, 1.0);
            // The simplex itself concludes (no fallback).
            let (Some(LpOutcome::Bounds(s)), LpOutcome::Bounds(c)) =
                (p.simplex_bounds().unwrap(), p.clarabel_bounds().unwrap())
            else {
                panic!("feasible by construction");
            };
            for k in 0..n {
                prop_assert!(s[k].contains(x0[k]), "{:?} misses {}", s[k], x0[k]);
                prop_assert!(c[k].contains(x0[k]), "clarabel {:?} misses {}", c[k], x0[k]);
                let tol = 1e-6 * (1.0 + c[k].lo.abs().max(c[k].hi.abs()));
                prop_assert!((s[k].lo - c[k].lo).abs() < tol && (s[k].hi - c[k].hi).abs() < tol,
                    "θ{}: simplex {:?} clarabel {:?}", k, s[k], c[k]);
            }
            // Cut the point off by far: proven empty.
            let mut g = vec![0.0; n];
            g[0] = 1.0;
            p.push_le(&g, x0[0] - 10.0, 0);
            prop_assert!(matches!(p.simplex(&vec![0.0; n]), Simplex::Infeasible));
            prop_assert!(!p.feasible().unwrap());
            prop_assert_eq!(p.bound().unwrap(), LpOutcome::Infeasible);
            // Clarabel's emptiness is proven by its Farkas multipliers too.
            prop_assert!(matches!(p.clarabel(None).unwrap(), Ipm::Empty));
            prop_assert_eq!(p.clarabel_bounds().unwrap(), LpOutcome::Infeasible);
        }

        /// The last resort's relaxed polytope is a superset: its certified bounds contain the
        /// exact ones (and the point), and it proves emptiness only where there is some.
        #[test]
        fn relaxed_bounds_contain_the_exact_ones(
            seed in any::<u64>(), n in 1usize..6, m in 4usize..60, eq in any::<bool>(),
            scale in prop_oneof![Just(1.0), Just(1e4)],
        ) {
            let (p, x0) = random_polytope(seed, n, m, eq, scale);
            let (Some(LpOutcome::Bounds(exact)), Some(LpOutcome::Bounds(relaxed))) =
                (p.simplex_bounds().unwrap(), p.relaxed_bounds())
            else {
                panic!("feasible and bounded by construction");
            };
            for k in 0..n {
                prop_assert!(relaxed[k].contains(x0[k]));
                prop_assert!(relaxed[k].lo <= exact[k].lo && exact[k].hi <= relaxed[k].hi,
                    "θ{}: relaxed {:?} inside exact {:?}", k, relaxed[k], exact[k]);
                let tol = 1e-3 * (1.0 + exact[k].lo.abs().max(exact[k].hi.abs()));
                prop_assert!(exact[k].lo - relaxed[k].lo < tol && relaxed[k].hi - exact[k].hi < tol);
            }
            // Cut off by far: still empty when relaxed. Flattened to the slab `θ0 = x0[0]` (two
            // inequalities, the thin polytopes this path is for): still holds the point.
            let mut q = p.clone();
            let mut g = vec![0.0; n];
            g[0] = 1.0;
            q.push_le(&g, x0[0] - 10.0 * scale, 0);
            prop_assert_eq!(q.relaxed_bounds(), Some(LpOutcome::Infeasible));
            let mut thin = p.clone();
            thin.push_le(&g, x0[0], 0);
            g[0] = -1.0;
            thin.push_le(&g, -x0[0], 0);
            match thin.relaxed_bounds() {
                Some(LpOutcome::Bounds(b)) => {
                    prop_assert!(b[0].contains(x0[0]), "thin: {:?} misses {}", b[0], x0[0]);
                }
                Some(LpOutcome::Infeasible) => prop_assert!(false, "thin but not empty"),
                None => {}
            }
        }
    }
}
