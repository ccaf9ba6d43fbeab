//! Stage 3 (paper Section 5) reference: the exact feasible parameter set of the EIV problem
//! (eqs 1, 28-30), measured on a grid of the `a`-plane, for at most two free `a`
//! coefficients, an exactly known input (Wiener structure) and exactly known extra regressor
//! columns (an uncertain one is refused, like an uncertain input).
//!
//! For `a` fixed the equations `x_t + Σ a_i x_{t-i} = Σ b_j u_{t-j} + Σ c_k φ_k(t)` with
//! `x_s = x^c_s + δx_s`, `|δx_s| <= Δx_s` are linear in `(b, c, δx)`: one LP decides whether a
//! grid point is feasible and bounds the `b`'s and `c`'s there (the **inner hull** of feasible grid points: inside the exact set, up to
//! the LP's outward tolerances). Over a grid cell, the products `a_i δx_s` are relaxed by
//! McCormick envelopes over the cell, which is exact as the cell shrinks: the cell LP's bounds
//! contain every feasible point of the cell, so the hull of the cell bounds over all feasible
//! cells (the **outer hull**) is a guaranteed outer bound of the exact set.
//!
//! The grid is dyadic (`2^depth` cells per axis inside the shared-error box, itself a
//! guaranteed outer bound) and explored by best-first branch and bound per parameter and
//! direction: a cell's relaxation contains its children's, so a cell whose bound cannot beat the
//! current best never needs refining, and the result equals the hull over all finest cells.
use super::ipm::{Bound, Prepared};
use super::relax::SharedModel;
use super::{EivMethod, EivProblem, EivResult, Stage3Method};
use crate::error::{Result, SmidError, Stage};
use crate::interval::Interval;
use crate::sparse_lp::{merge, Optimum, SparseLp};
use std::collections::BinaryHeap;

/// The method's name (`method.eiv: exact-grid`).
pub const NAME: &str = "exact-grid";

/// Options of the exact-grid reference (`method.options` in a spec).
#[derive(Debug, Clone, Copy, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ExactOptions {
    /// The grid has `2^depth` cells per free `a`.
    pub depth: u32,
    /// Bisection steps of the inner-hull line search (from the anchor to a cell optimiser).
    pub line_steps: u32,
    /// Evaluations of the anchor search (Nelder-Mead on the consistency measure).
    pub anchor_evals: usize,
}

impl ExactOptions {
    /// The defaults: depth 7, 30 bisection steps, 120 anchor evaluations.
    pub const DEFAULT: ExactOptions = ExactOptions {
        depth: 7,
        line_steps: 30,
        anchor_evals: 120,
    };
}

impl Default for ExactOptions {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// The exact-grid reference (`method.eiv: exact-grid`), starting from `shared`; reports the
/// guaranteed outer hull.
#[derive(Debug, Clone, Copy, Default)]
pub struct ExactGrid {
    /// Grid resolution and budget (`method.options` of the spec).
    pub opts: ExactOptions,
}

crate::register_stage3!(
    30,
    ExactGrid {
        opts: ExactOptions::DEFAULT
    }
);

impl Stage3Method for ExactGrid {
    fn name(&self) -> &'static str {
        NAME
    }
    fn description(&self) -> &'static str {
        "Exact set measured on a grid of the a-plane (na <= 2, Wiener): outer hull of feasible cells reported, inner hull of consistent points measured. Options: depth, line_steps, anchor_evals."
    }
    fn with_options(
        &self,
        options: &serde_json::Map<String, serde_json::Value>,
    ) -> Result<Option<Box<dyn Stage3Method>>> {
        super::with_parsed_options(NAME, options, |opts: ExactOptions| {
            Box::new(ExactGrid { opts })
        })
    }
    fn start(&self) -> Option<EivMethod> {
        Some(EivMethod::Shared)
    }
    /// Refuses uncertain extra regressor columns before the start is computed.
    fn check(&self, prob: &EivProblem) -> Result<()> {
        check_extras(prob, &prob.equation_times())
    }
    fn solve_from(&self, prob: &EivProblem, start: EivResult) -> Result<EivResult> {
        Ok(solve_from(prob, &start, &self.opts, || {})?.to_eiv())
    }
}

/// Refuse an extra regressor that is uncertain (radius > 0) at a sample of `times`: the exact
/// LPs substitute the extra columns in the equations, and gridding their coefficients too is
/// out of reach.
fn check_extras(prob: &EivProblem, times: &[usize]) -> Result<()> {
    for r in prob.extra {
        if let Some(&t) = times.iter().find(|&&t| r.values[t].radius() > 0.0) {
            return Err(SmidError::Unsupported {
                plugin: "exact-grid".into(),
                what: format!(
                    "an uncertain extra regressor `{}` (radius {:e} at t = {t}): only exact extra columns enter its exact LPs; use `shared` or `sdp`",
                    r.name,
                    r.values[t].radius()
                ),
            });
        }
    }
    Ok(())
}

/// The exact set measured on the grid.
#[derive(Debug, Clone)]
pub struct ExactResult {
    /// Guaranteed outer hull (θ order; fixed entries degenerate).
    pub outer: Vec<Interval>,
    /// Hull of the feasible grid points found (inside the exact set); `None` where no feasible
    /// grid point was found for a side.
    pub inner: Vec<Option<Interval>>,
    /// LPs solved (cells and exact points).
    pub cell_lps: usize,
    /// The anchor of the inner hull: gridded `a` values where the data are consistent, and the
    /// consistency measure there (the smallest scaling minus one of the inner-signal error
    /// boxes that admits them; negative: strictly inside). `None` when no consistent `a` was
    /// found, and then no inner hull either.
    pub anchor: Option<(Vec<f64>, f64)>,
    /// Time indices `t` of the equations used.
    pub equations: Vec<usize>,
}

impl ExactResult {
    /// The outer hull as a stage-3 result.
    pub fn to_eiv(&self) -> EivResult {
        EivResult {
            bounds: self.outer.clone(),
            equations: self.equations.clone(),
            feasible_orthants: 0,
            unsettled: None,
        }
    }
}

#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
struct Cell {
    depth: u32,
    i: u64,
    j: u64,
}

struct Node {
    key: f64,
    cell: Cell,
    /// Grid-dimension values at the LP optimum.
    at: [f64; 2],
}
impl PartialEq for Node {
    fn eq(&self, o: &Self) -> bool {
        self.key.total_cmp(&o.key).is_eq()
    }
}
impl Eq for Node {}
impl PartialOrd for Node {
    fn partial_cmp(&self, o: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(o))
    }
}
impl Ord for Node {
    fn cmp(&self, o: &Self) -> std::cmp::Ordering {
        self.key.total_cmp(&o.key)
    }
}

struct Grid<'m, 'p, 'a> {
    model: &'m SharedModel<'p, 'a>,
    /// θ indices of the gridded `a`'s.
    dims: Vec<usize>,
    root: Vec<Interval>,
    db: Vec<Interval>,
    lps: usize,
}

impl Grid<'_, '_, '_> {
    fn cell_box(&self, c: Cell) -> Vec<Interval> {
        let mut tb = self.root.clone();
        let n = (1u64 << c.depth) as f64;
        for (d, &k) in self.dims.iter().enumerate() {
            let idx = if d == 0 { c.i } else { c.j } as f64;
            let r = self.root[k];
            let w = r.hi - r.lo;
            let lo = if idx == 0.0 { r.lo } else { r.lo + w * idx / n };
            let hi = if idx + 1.0 == n {
                r.hi
            } else {
                r.lo + w * (idx + 1.0) / n
            };
            // Neighbouring cells overlap by a rounding pad, so no point falls between cells.
            tb[k] = Interval::new(lo, hi).widen(1e-14, 1e-15);
        }
        tb
    }

    /// Bound of column `c` in direction `max` over the relaxation with θ box `tb`:
    /// (guaranteed bound in the natural sense, gridded values at the optimum).
    fn solve(&mut self, tb: &[Interval], col: usize, max: bool) -> Result<Optimum2> {
        self.lps += 1;
        // The structured interior-point method (linear in the record); the sparse clarabel
        // path where its block form does not apply.
        let (blp, _) = self.model.block_lp(tb, &self.db, &self.model.times)?;
        if let Some(prep) = Prepared::new(&blp) {
            let solved = prep.minimise_at(&[(col, if max { -1.0 } else { 1.0 })], None);
            let (b, theta) = (solved.bound, solved.point);
            let mut at = [0.0; 2];
            for (d, &k) in self.dims.iter().enumerate() {
                let c = self.model.col_theta[k].unwrap_or(0);
                at[d] = theta[c].clamp(tb[k].lo, tb[k].hi);
            }
            return Ok(match b {
                Bound::Infeasible => Optimum2::Infeasible,
                Bound::Value(None) => Optimum2::Unknown,
                Bound::Value(Some(v)) => {
                    let pad = crate::lp::RESULT_PAD * (1.0 + v.abs());
                    Optimum2::Value(if max { -v + pad } else { v - pad }, at)
                }
            });
        }
        let lp = self.model.build(tb, &self.db, &self.model.times)?;
        let mut s = lp.solver()?;
        Ok(match s.optimise(col, max)? {
            Optimum::Value(v) => {
                let mut at = [0.0; 2];
                for (d, &k) in self.dims.iter().enumerate() {
                    let c = self.model.col_theta[k].unwrap_or(0);
                    at[d] = s.point()[c].clamp(tb[k].lo, tb[k].hi);
                }
                Optimum2::Value(v, at)
            }
            Optimum::Infeasible => Optimum2::Infeasible,
            Optimum::Unknown => Optimum2::Unknown,
        })
    }

    fn children(&self, c: Cell) -> Vec<Cell> {
        let (i0, j0) = (2 * c.i, 2 * c.j);
        let mut v = vec![];
        for di in 0..2 {
            if self.dims.len() < 2 {
                v.push(Cell {
                    depth: c.depth + 1,
                    i: i0 + di,
                    j: 0,
                });
            } else {
                for dj in 0..2 {
                    v.push(Cell {
                        depth: c.depth + 1,
                        i: i0 + di,
                        j: j0 + dj,
                    });
                }
            }
        }
        v
    }
}

/// The consistency measure at a whole parameter vector `theta` (θ order, fixed entries
/// included): the smallest `s` for which the equations (eq 1) hold with every inner-signal
/// sample inside its stage-2 box scaled by `1 + s`. The exact extra columns enter at their
/// values, and each uncertain input sample is an LP column inside its interval (exact at a
/// fixed `θ`). So `s <= INSIDE` **certifies** `theta`
/// consistent with the stage-2 bounds, up to the LP's tolerances; `+inf` when `theta` breaks
/// the unit gain (eq 8) or the solver gave no conclusion. Uncertain extra columns are refused
/// (as by the method).
pub fn consistency_at(prob: &EivProblem, theta: &[f64]) -> Result<f64> {
    let times = lp_times(prob);
    check_extras(prob, &times)?;
    if prob.unit_gain {
        let gain: f64 = (0..prob.n_ab()).map(|k| prob.gain_sign(k) * theta[k]).sum();
        let scale: f64 = 1.0 + theta[..prob.n_ab()].iter().map(|v| v.abs()).sum::<f64>();
        if (gain - 1.0).abs() > 1e-9 * scale {
            return Ok(f64::INFINITY);
        }
    }
    // Every θ entry is given: the fixed-`a` LP with all entries as grid values (its unit-gain
    // row has no column left and was checked above).
    let flat = EivProblem {
        unit_gain: false,
        ..prob.clone()
    };
    let dims: Vec<usize> = (0..prob.p()).filter(|&k| prob.fixed[k].is_none()).collect();
    let a: Vec<f64> = dims.iter().map(|&k| theta[k]).collect();
    let mut at = AtA {
        prob: &flat,
        dims,
        times,
        tb: vec![Interval::entire(); prob.p()],
        lps: 0,
        input_vars: true,
    };
    let s = at.slack(&a)?;
    Ok(if s.is_nan() { f64::INFINITY } else { s })
}

/// At fixed values `a` of the free `a`'s (in θ order), the smallest consistency measure over
/// the free `b`'s and extra coefficients inside `tb` (the unit gain imposed), and a `θ` that
/// attains it (`None` when the solver gave no point). A measurement to search with: a point
/// it gives is certified afterwards by [`consistency_at`].
pub fn best_at_a(prob: &EivProblem, tb: &[Interval], a: &[f64]) -> Result<(f64, Option<Vec<f64>>)> {
    point_at_a(prob, tb, a, None)
}

/// At fixed `a` (as [`best_at_a`]), a `θ` of the exact set that minimises (`max`: maximises)
/// `θ_k` over the free `b`'s and extra coefficients: a vertex of the set's slice, on its
/// boundary (`None` when the slice is empty or the solver gave no point). A measurement: move
/// it inwards and certify it with [`consistency_at`] before calling it a member.
pub fn extreme_at_a(
    prob: &EivProblem,
    tb: &[Interval],
    a: &[f64],
    k: usize,
    max: bool,
) -> Result<Option<Vec<f64>>> {
    Ok(point_at_a(prob, tb, a, Some((k, max)))?.1)
}

fn point_at_a(
    prob: &EivProblem,
    tb: &[Interval],
    a: &[f64],
    objective: Option<(usize, bool)>,
) -> Result<(f64, Option<Vec<f64>>)> {
    let times = lp_times(prob);
    check_extras(prob, &times)?;
    let dims: Vec<usize> = (0..prob.na).filter(|&k| prob.fixed[k].is_none()).collect();
    let at = AtA {
        prob,
        dims: dims.clone(),
        times,
        tb: tb.to_vec(),
        lps: 0,
        input_vars: false,
    };
    let m = at.lp(a, objective.is_none());
    let mut c = vec![0.0; m.lp.n];
    let col = match objective {
        None => m.s,
        Some((k, _)) => match m.col_theta.get(k).copied().flatten() {
            Some(col) => col,
            None => return Ok((f64::INFINITY, None)),
        },
    };
    let sign = if matches!(objective, Some((_, true))) {
        -1.0
    } else {
        1.0
    };
    c[col] = sign;
    let x = match m.lp.dense(DENSE_MAX).and_then(|p| p.vertex_point(&c)) {
        Some(x) => x,
        None => {
            let mut s = m.lp.solver()?;
            match s.optimise(col, sign < 0.0)? {
                Optimum::Value(_) => s.point().to_vec(),
                _ => return Ok((f64::INFINITY, None)),
            }
        }
    };
    let mut theta: Vec<f64> = prob.fixed.iter().map(|f| f.unwrap_or(0.0)).collect();
    for (d, &k) in dims.iter().enumerate() {
        theta[k] = a[d];
    }
    for (k, col) in m.col_theta.iter().enumerate() {
        if let Some(col) = col {
            theta[k] = x[*col];
        }
    }
    let s = x[m.s];
    Ok((if s.is_nan() { f64::INFINITY } else { s }, Some(theta)))
}

/// The equations of the exact LPs at fixed `a`: every usable one, and with past outputs read
/// from data ([`EivProblem::lagged`]) also those with a sample known from one side (a clipped
/// output's half-space, which a point consistent with the model must respect). Without
/// lagged outputs a one-sided sample also sits in later equations' chains, where the LP has no
/// row for it, and the usable equations alone are taken (as the relaxations take them).
fn lp_times(prob: &EivProblem) -> Vec<usize> {
    let mut times = prob.equation_times();
    if prob.lagged.is_some() {
        times.extend(prob.one_sided_times());
        times.sort_unstable();
        times.dedup();
    }
    times
}

/// The margin below which [`consistency_at`] certifies a point (far above the LPs' pads).
pub const CERTIFIED: f64 = INSIDE;

/// Relative radius above which an input sample counts as uncertain in [`consistency_at`]
/// (below it, the outward rounding pads of an exact propagation).
const UNCERTAIN: f64 = 1e-9;

/// Columns up to which the fixed-`a` LPs go to the dense simplex ([`crate::lp::Polytope`]).
const DENSE_MAX: usize = 24;

/// Margin of the consistency measure below which a point counts as inside the exact set for
/// the inner hull (relative to the inner-signal error bounds; far above the LPs' pads).
const INSIDE: f64 = -1e-6;

/// Exact LPs at fixed values of the gridded `a`'s. With `a` known and the input exact
/// (Wiener), the equations determine every inner-signal sample from the `b`'s and the samples
/// that start a chain of equations: `x_t = -Σ a_i x_{t-i} + Σ b_j u_{t-j}`. So `x_t` is an affine
/// function of a few variables (free `b`'s, chain starts), and consistency is a small LP whose
/// rows are the sample bounds `x_t ∈ [lo_t, hi_t]`: the equations hold exactly, by construction.
struct AtA<'p, 'a> {
    prob: &'p EivProblem<'a>,
    dims: Vec<usize>,
    times: Vec<usize>,
    /// A guaranteed box (bounds the free `b`'s; a superset of the exact set).
    tb: Vec<Interval>,
    lps: usize,
    /// Uncertain input samples become LP columns inside their intervals where their `b` is
    /// given (exact at a fixed θ); otherwise the input enters at its centres.
    input_vars: bool,
}

/// An affine function `c + Σ coef·z_col`.
type Affine = (f64, Vec<(usize, f64)>);

/// The LP at one `a`: columns `[free θ (b's), chain starts, s]`.
struct AtALp {
    lp: SparseLp,
    /// Column of each θ index (free `b`'s only).
    col_theta: Vec<Option<usize>>,
    /// The slack column.
    s: usize,
}

impl AtA<'_, '_> {
    /// The LP at `a`; with `slack`, every sample box is scaled by `1 + s` (`s >= -1`), else
    /// `s` is fixed to 0.
    fn lp(&self, a: &[f64], slack: bool) -> AtALp {
        let prob = self.prob;
        let p = prob.p();
        let mut theta: Vec<Option<f64>> = prob.fixed.clone();
        for (d, &k) in self.dims.iter().enumerate() {
            theta[k] = Some(a[d]);
        }
        let mut col_theta = vec![None; p];
        let mut n = 0;
        for k in 0..p {
            if theta[k].is_none() {
                col_theta[k] = Some(n);
                n += 1;
            }
        }
        // Uncertain input samples as columns (sample -> column).
        let mut input_cols: std::collections::BTreeMap<usize, usize> = Default::default();
        // Uncertain past outputs read by the autoregressive part (`prob.lagged`: the chain's
        // output inside its measurement box) as columns, the box scaled as the samples'.
        let mut lag_cols: std::collections::BTreeMap<usize, usize> = Default::default();
        // x_s = c + Σ coef·z over the columns; None: not reached by any equation.
        let len = prob.output.len();
        let mut x: Vec<Option<Affine>> = vec![None; len];
        for &t in &self.times {
            let mut c = 0.0;
            let mut row: Vec<(usize, f64)> = Vec::new();
            if let Some(w) = prob.lagged {
                // `x_t = -Σ a_i w_{t-i} + …`: the past outputs are data, not this chain's.
                for i in 1..=prob.na {
                    let ai = theta[i - 1].unwrap_or(0.0);
                    let wi = w[t - i];
                    if ai != 0.0 && wi.radius() > UNCERTAIN * (1.0 + wi.center().abs()) {
                        let col = *lag_cols.entry(t - i).or_insert_with(|| {
                            n += 1;
                            n - 1
                        });
                        row.push((col, -ai));
                    } else {
                        c -= ai * wi.center();
                    }
                }
            } else {
                // Samples before `t` not set by an earlier equation start a chain: free
                // variables.
                for xs in &mut x[t - prob.na..t] {
                    if xs.is_none() {
                        *xs = Some((0.0, vec![(n, 1.0)]));
                        n += 1;
                    }
                }
                for i in 1..=prob.na {
                    let ai = theta[i - 1].unwrap_or(0.0);
                    if let Some((ci, ri)) = &x[t - i] {
                        c -= ai * ci;
                        row.extend(ri.iter().map(|&(k, v)| (k, -ai * v)));
                    }
                }
            }
            for j in 0..=prob.nb {
                let ui = prob.input[t - j];
                let u = ui.center();
                match (theta[prob.na + j], col_theta[prob.na + j]) {
                    (Some(v), _)
                        if self.input_vars
                            && ui.radius() > UNCERTAIN * (1.0 + u.abs())
                            && v != 0.0 =>
                    {
                        let col = *input_cols.entry(t - j).or_insert_with(|| {
                            n += 1;
                            n - 1
                        });
                        row.push((col, v));
                    }
                    (Some(v), _) => c += v * u,
                    (None, Some(col)) => row.push((col, u)),
                    (None, None) => {}
                }
            }
            // Exact extra columns (checked by `check_extras`): `+ c_k φ_k(t)`.
            for (e, r) in prob.extra.iter().enumerate() {
                let phi = r.values[t].center();
                let k = prob.n_ab() + e;
                match (theta[k], col_theta[k]) {
                    (Some(v), _) => c += v * phi,
                    (None, Some(col)) => row.push((col, phi)),
                    (None, None) => {}
                }
            }
            x[t] = Some((c, merge(row)));
        }
        let s_col = n;
        let mut lp = SparseLp::new(n + 1);
        for (s, xs) in x.iter().enumerate() {
            let Some((c, row)) = xs else { continue };
            let iv = prob.output[s].interval;
            if !(iv.lo.is_finite() && iv.hi.is_finite()) {
                // A sample known from one side (a clipped output; equations of the lagged
                // problems only, see `lp_times`): its half-space, unscaled.
                if prob.lagged.is_some() && iv.lo.is_finite() {
                    let down: Vec<(usize, f64)> = row.iter().map(|&(k, v)| (k, -v)).collect();
                    lp.le(down, c - iv.lo);
                } else if prob.lagged.is_some() && iv.hi.is_finite() {
                    lp.le(row.clone(), iv.hi - c);
                }
                continue;
            }
            let r = iv.radius();
            // lo - r s <= c + row·z <= hi + r s
            let mut up = row.clone();
            up.push((s_col, -r));
            lp.le(up, iv.hi - c);
            let mut down: Vec<(usize, f64)> = row.iter().map(|&(k, v)| (k, -v)).collect();
            down.push((s_col, -r));
            lp.le(down, c - iv.lo);
        }
        for (&t, &col) in &lag_cols {
            // lo - r s <= w <= hi + r s
            let iv = prob.lagged.map_or(Interval::entire(), |w| w[t]);
            let r = iv.radius();
            lp.le(vec![(col, 1.0), (s_col, -r)], iv.hi);
            lp.le(vec![(col, -1.0), (s_col, -r)], -iv.lo);
        }
        for (&t, &col) in &input_cols {
            let iv = prob.input[t];
            lp.le(vec![(col, -1.0)], -iv.lo);
            lp.le(vec![(col, 1.0)], iv.hi);
        }
        if slack {
            lp.le(vec![(s_col, -1.0)], 1.0);
        } else {
            lp.eq(vec![(s_col, 1.0)], 0.0);
        }
        for (k, col) in col_theta.iter().enumerate() {
            if let Some(col) = *col {
                let b = self.tb[k];
                if b.lo.is_finite() {
                    lp.le(vec![(col, -1.0)], -b.lo);
                }
                if b.hi.is_finite() {
                    lp.le(vec![(col, 1.0)], b.hi);
                }
            }
        }
        if prob.unit_gain {
            // Σ b_j - Σ a_i = 1 (eq 8); the extras do not enter.
            let mut row = Vec::new();
            let mut rhs = 1.0;
            for k in 0..prob.n_ab() {
                let sg = prob.gain_sign(k);
                match (theta[k], col_theta[k]) {
                    (Some(v), _) => rhs -= sg * v,
                    (None, Some(col)) => row.push((col, sg)),
                    (None, None) => {}
                }
            }
            lp.eq(row, rhs);
        }
        AtALp {
            lp,
            col_theta,
            s: s_col,
        }
    }

    /// The consistency measure at `a`: the smallest `s` for which the equations hold with the
    /// inner-signal samples inside their boxes scaled by `1 + s` (`+inf` when the solver gave
    /// no conclusion).
    fn slack(&mut self, a: &[f64]) -> Result<f64> {
        self.lps += 1;
        let m = self.lp(a, true);
        // A measurement, not a bound: the low-dimensional simplex's vertex value when the LP
        // has few columns (long chains), else clarabel.
        if let Some(p) = m.lp.dense(DENSE_MAX) {
            let mut c = vec![0.0; m.lp.n];
            c[m.s] = 1.0;
            if let Some(v) = p.vertex_optimum(&c) {
                return Ok(v);
            }
        }
        Ok(match m.lp.solver()?.minimise(m.s)? {
            Optimum::Value(v) => v,
            _ => f64::INFINITY,
        })
    }

    /// The optimum of `θ_k` at a consistent `a` (a point of the exact set's projection, so an
    /// inner value; the LP's outward pad is taken back).
    fn value(&mut self, a: &[f64], k: usize, max: bool) -> Result<Option<f64>> {
        if let Some(d) = self.dims.iter().position(|&kk| kk == k) {
            return Ok(Some(a[d]));
        }
        let m = self.lp(a, false);
        let Some(col) = m.col_theta[k] else {
            return Ok(self.prob.fixed[k]);
        };
        self.lps += 1;
        if let Some(p) = m.lp.dense(DENSE_MAX) {
            let mut c = vec![0.0; m.lp.n];
            c[col] = if max { -1.0 } else { 1.0 };
            if let Some(v) = p.vertex_optimum(&c) {
                return Ok(Some(if max { -v } else { v }));
            }
        }
        Ok(match m.lp.solver()?.optimise(col, max)? {
            Optimum::Value(v) => {
                let pad = crate::lp::RESULT_PAD * (1.0 + v.abs());
                Some(if max { v - pad } else { v + pad })
            }
            _ => None,
        })
    }

    /// A consistent point to grow the inner hull from: Nelder-Mead on the consistency measure,
    /// from the centre of the guaranteed box. `None` when no point is found inside.
    fn anchor(&mut self, start: &[Interval], evals: usize) -> Result<Option<(Vec<f64>, f64)>> {
        let n = self.dims.len();
        let c: Vec<f64> = self.dims.iter().map(|&k| start[k].center()).collect();
        let mut simplex: Vec<(Vec<f64>, f64)> = Vec::with_capacity(n + 1);
        let f0 = self.slack(&c)?;
        simplex.push((c.clone(), f0));
        for d in 0..n {
            let mut v = c.clone();
            v[d] += 0.25 * start[self.dims[d]].radius();
            let f = self.slack(&v)?;
            simplex.push((v, f));
        }
        let mut used = n + 1;
        let lerp = |a: &[f64], b: &[f64], t: f64| -> Vec<f64> {
            a.iter().zip(b).map(|(x, y)| x + t * (y - x)).collect()
        };
        while n > 0 && used < evals {
            simplex.sort_by(|a, b| a.1.total_cmp(&b.1));
            let size = simplex[1..]
                .iter()
                .flat_map(|(v, _)| {
                    v.iter()
                        .zip(&simplex[0].0)
                        .enumerate()
                        .map(|(d, (x, y))| (x - y).abs() / start[self.dims[d]].radius().max(1e-300))
                })
                .fold(0.0, f64::max);
            if size < 1e-9 {
                break;
            }
            let worst = simplex[n].clone();
            let centroid: Vec<f64> = (0..n)
                .map(|d| simplex[..n].iter().map(|(v, _)| v[d]).sum::<f64>() / n as f64)
                .collect();
            let r = lerp(&centroid, &worst.0, -1.0);
            let fr = self.slack(&r)?;
            used += 1;
            if fr < simplex[0].1 {
                let e = lerp(&centroid, &worst.0, -2.0);
                let fe = self.slack(&e)?;
                used += 1;
                simplex[n] = if fe < fr { (e, fe) } else { (r, fr) };
            } else if fr < simplex[n - 1].1 {
                simplex[n] = (r, fr);
            } else {
                let k = lerp(&centroid, &worst.0, 0.5);
                let fk = self.slack(&k)?;
                used += 1;
                if fk < worst.1 {
                    simplex[n] = (k, fk);
                } else {
                    let best = simplex[0].0.clone();
                    for v in simplex.iter_mut().skip(1) {
                        let p = lerp(&best, &v.0, 0.5);
                        let fp = self.slack(&p)?;
                        *v = (p, fp);
                        used += 1;
                    }
                }
            }
        }
        simplex.sort_by(|a, b| a.1.total_cmp(&b.1));
        let (a, f) = simplex.swap_remove(0);
        Ok((f <= INSIDE).then_some((a, f)))
    }

    /// The consistent point nearest `to` on the segment from the consistent `from` (bisection).
    fn toward(&mut self, from: &[f64], to: &[f64], steps: u32) -> Result<Vec<f64>> {
        let at =
            |t: f64| -> Vec<f64> { from.iter().zip(to).map(|(x, y)| x + t * (y - x)).collect() };
        if self.slack(to)? <= INSIDE {
            return Ok(to.to_vec());
        }
        let (mut lo, mut hi) = (0.0, 1.0);
        for _ in 0..steps {
            let mid = 0.5 * (lo + hi);
            if self.slack(&at(mid))? <= INSIDE {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        Ok(at(lo))
    }
}

enum Optimum2 {
    Value(f64, [f64; 2]),
    Infeasible,
    Unknown,
}

/// Measure the exact set, starting from a guaranteed box `start` (e.g. the shared-error
/// result). `tick` is called after each bound (2 per free parameter).
pub fn solve_from(
    prob: &EivProblem,
    start: &EivResult,
    opts: &ExactOptions,
    mut tick: impl FnMut(),
) -> Result<ExactResult> {
    prob.validate()?;
    let model = SharedModel::new(prob, start.equations.clone());
    let dims: Vec<usize> = (0..prob.na).filter(|&k| prob.fixed[k].is_none()).collect();
    if dims.len() > 2 {
        return Err(SmidError::Unsupported {
            plugin: "exact-grid".into(),
            what: format!("{} free a coefficients (at most 2)", dims.len()),
        });
    }
    check_extras(prob, &model.times)?;
    if model.products.iter().any(|(k, _)| !dims.contains(k)) {
        return Err(SmidError::Unsupported {
            plugin: "exact-grid".into(),
            what:
                "an uncertain input signal (a Hammerstein nonlinearity, an input-side block, or the measured past outputs of `model.feedback`): the coefficients that multiply it would need gridding too"
                    .into(),
        });
    }
    let mut db = model.initial_deltas();
    for _ in 0..2 {
        if let Some(t) = model.propagate(&start.bounds, &mut db) {
            return Err(SmidError::inconsistent(
                Stage::Linear,
                t,
                "interval propagation emptied an inner-signal error box",
            ));
        }
    }
    let mut g = Grid {
        model: &model,
        dims,
        root: start.bounds.clone(),
        db,
        lps: 0,
    };
    let depth = if g.dims.is_empty() { 0 } else { opts.depth };
    let mut at_a = AtA {
        prob,
        dims: g.dims.clone(),
        times: model.times.clone(),
        tb: start.bounds.clone(),
        lps: 0,
        input_vars: false,
    };
    // The exact LPs at fixed `a` need an exact input (they substitute it in the equations).
    let exact_input = model
        .times
        .iter()
        .all(|&t| (0..=prob.nb).all(|j| prob.input[t - j].radius() == 0.0));
    // An inner point is kept only where the shared-error LP over its degenerate `a` box finds
    // it feasible too: the fixed-`a` LP's dense measurement can be wrong where the `a`'s are
    // large (a point it measured consistent at |a1| ≈ 17 that this LP proves infeasible).
    let gridded = g.dims.clone();
    let confirmed = |a: &[f64]| -> Result<bool> {
        let mut tb = start.bounds.clone();
        for (d, &k) in gridded.iter().enumerate() {
            tb[k] = Interval::new(a[d], a[d]);
        }
        let lp = model.build(&tb, &model.initial_deltas(), &model.times)?;
        Ok(lp.solver()?.feasible()? == Some(true))
    };
    let anchor = match exact_input {
        true => match at_a.anchor(&start.bounds, opts.anchor_evals)? {
            Some((a, v)) if confirmed(&a)? => Some((a, v)),
            _ => None,
        },
        false => None,
    };
    let p = prob.p();
    let mut outer: Vec<Interval> = start.bounds.clone();
    let mut inner: Vec<Option<Interval>> = (0..p)
        .map(|k| prob.fixed[k].map(|v| Interval::new(v, v)))
        .collect();
    for (col, &k) in model.free.iter().enumerate() {
        for max in [false, true] {
            // Best-first search: key = bound in the direction of improvement.
            let key = |v: f64| if max { v } else { -v };
            let mut heap = BinaryHeap::new();
            let root = Cell {
                depth: 0,
                i: 0,
                j: 0,
            };
            // Each cell is evaluated once per direction (its relaxation contains its children's).
            let eval = |g: &mut Grid,
                        c: Cell,
                        parent: Option<(f64, [f64; 2])>|
             -> Result<Option<(f64, [f64; 2])>> {
                let tb = g.cell_box(c);
                Ok(match g.solve(&tb, col, max)? {
                    Optimum2::Value(v, at) => Some((v, at)),
                    Optimum2::Infeasible => None,
                    // No conclusion: keep the parent's (or the start box's) bound: conservative.
                    Optimum2::Unknown => {
                        let mut centre = [0.0; 2];
                        for (d, &kk) in g.dims.iter().enumerate() {
                            centre[d] = tb[kk].center();
                        }
                        let v = parent.map_or(
                            if max {
                                start.bounds[k].hi
                            } else {
                                start.bounds[k].lo
                            },
                            |p| p.0,
                        );
                        Some((v, centre))
                    }
                })
            };
            if let Some((v, at)) = eval(&mut g, root, None)? {
                heap.push(Node {
                    key: key(v),
                    cell: root,
                    at,
                });
            }
            let mut bound: Option<f64> = None;
            let mut best_inner: Option<f64> = None;
            while let Some(node) = heap.pop() {
                if node.cell.depth >= depth {
                    bound = Some(if max { node.key } else { -node.key });
                    // Inner hull: the consistent point nearest the relaxation's optimiser on the
                    // segment from the anchor, and the anchor itself.
                    if let Some((anchor, _)) = &anchor {
                        let target = &node.at[..g.dims.len()];
                        let near = at_a.toward(anchor, target, opts.line_steps)?;
                        for a in [near, anchor.clone()] {
                            if !confirmed(&a)? {
                                continue;
                            }
                            if let Some(v) = at_a.value(&a, k, max)? {
                                best_inner = Some(match best_inner {
                                    None => v,
                                    Some(b) if max => b.max(v),
                                    Some(b) => b.min(v),
                                });
                            }
                        }
                    }
                    break;
                }
                let parent = Some((if max { node.key } else { -node.key }, node.at));
                for c in g.children(node.cell) {
                    if let Some((v, at)) = eval(&mut g, c, parent)? {
                        heap.push(Node {
                            key: key(v),
                            cell: c,
                            at,
                        });
                    }
                }
            }
            let Some(b) = bound else {
                return Err(SmidError::inconsistent_unlocated(
                    Stage::Linear,
                    model.times.last().copied().unwrap_or(0),
                    "no cell of the a-grid admits b and inner-signal errors within their bounds",
                ));
            };
            if max {
                outer[k].hi = b.min(start.bounds[k].hi);
            } else {
                outer[k].lo = b.max(start.bounds[k].lo);
            }
            if let Some(v) = best_inner {
                let cur = inner[k];
                inner[k] = Some(match (cur, max) {
                    (None, _) => Interval::new(v, v),
                    (Some(c), true) => Interval::new(c.lo.min(v), c.hi.max(v)),
                    (Some(c), false) => Interval::new(c.lo.min(v), c.hi.max(v)),
                });
            }
            tick();
        }
    }
    Ok(ExactResult {
        outer,
        inner,
        cell_lps: g.lps + at_a.lps,
        anchor,
        equations: start.equations.clone(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::stage3::shared::{self, SharedOptions};
    use crate::stage3::testutil::{cases, feedback_case, problem, random_case, random_extra_case};
    use proptest::prelude::*;

    fn quick() -> ExactOptions {
        ExactOptions {
            depth: 4,
            ..ExactOptions::default()
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig { cases: 4, .. ProptestConfig::default() })]
        #[test]
        fn exact_grid_outer_contains_truth_and_inner_hull(seed in any::<u64>()) {
            let (m, out, input) = random_case(seed, 40);
            let prob = problem(&out, &input, true);
            // Random data that leave a parameter unbounded are an honest outcome, not a miss.
            let shared = match shared::solve(&prob, &SharedOptions::default()) {
                Err(SmidError::Unbounded { .. }) => { prop_assume!(false); unreachable!() }
                other => other.unwrap(),
            };
            let ex = solve_from(&prob, &shared, &quick(), || {}).unwrap();
            let truth: Vec<f64> = m.a.iter().chain(&m.b).copied().collect();
            for (k, t) in truth.into_iter().enumerate() {
                let o = ex.outer[k];
                prop_assert!(o.contains(t), "outer {:?} misses {}", o, t);
                prop_assert!(shared.bounds[k].lo <= o.lo && o.hi <= shared.bounds[k].hi);
                if let Some(i) = ex.inner[k] {
                    // Inner values come from LPs whose rows are relaxed outward (ROW_PAD), so
                    // they may sit a few 1e-9 beyond the exact set: compare within the pads.
                    let tol = 10.0 * crate::lp::RESULT_PAD * (1.0 + o.lo.abs().max(o.hi.abs()));
                    prop_assert!(o.lo - tol <= i.lo && i.hi <= o.hi + tol, "inner {:?} outside outer {:?}", i, o);
                }
            }
        }
    }

    /// The certificate at a whole `θ`: the truth is consistent (its noise is inside the
    /// bounds), a `θ` moved by several radii of the guaranteed box is not, a `θ` off the unit
    /// gain is refused; with the input made uncertain around the truth (a block's unknown
    /// initial state), the truth stays certified only because the input samples become LP
    /// columns (at the input's perturbed centres it would not be).
    #[test]
    fn consistency_at_certifies_the_truth_and_rejects_far_points() {
        let mut checked_uncertain = 0;
        for seed in 0..12 {
            let (m, out, input) = random_case(seed, 40);
            let prob = problem(&out, &input, true);
            let truth: Vec<f64> = m.a.iter().chain(&m.b).copied().collect();
            let s = consistency_at(&prob, &truth).unwrap();
            assert!(s <= 1e-7, "seed {seed}: the truth measures {s}");
            let shared = shared::solve(&prob, &SharedOptions::default()).unwrap();
            let mut far = truth.clone();
            far[0] += 4.0 * shared.bounds[0].radius().max(1e-3);
            far[3] += 4.0 * shared.bounds[0].radius().max(1e-3);
            let gain = |t: &[f64]| t[2] + t[3] + t[4] - t[0] - t[1];
            assert!((gain(&far) - 1.0).abs() < 1e-12);
            let s_far = consistency_at(&prob, &far).unwrap();
            assert!(
                s_far > CERTIFIED,
                "seed {seed}: a far point measures {s_far}"
            );
            let mut off = truth.clone();
            off[3] += 0.1;
            assert_eq!(consistency_at(&prob, &off).unwrap(), f64::INFINITY);
            // The first samples' input uncertain, its centre moved off the true input.
            let mut uncertain = input.clone();
            for v in uncertain.iter_mut().take(6) {
                let c = v.center();
                *v = Interval::new(c - 0.5, c + 0.3);
            }
            let mut p2 = prob.clone();
            p2.input = &uncertain;
            let s2 = consistency_at(&p2, &truth).unwrap();
            assert!(
                s2 <= 1e-7,
                "seed {seed}: uncertain input, the truth measures {s2}"
            );
            let centred: Vec<Interval> = uncertain
                .iter()
                .map(|v| Interval::new(v.center(), v.center()))
                .collect();
            let mut p3 = prob.clone();
            p3.input = &centred;
            if consistency_at(&p3, &truth).unwrap() > 0.0 {
                checked_uncertain += 1;
            }
        }
        assert!(
            checked_uncertain > 0,
            "the input columns were never needed: the test of them is vacuous"
        );
    }

    /// With the past outputs read from data (`lagged`), the exact LP at a whole `θ` takes each
    /// measured past output as a column inside its box and a clipped sample's half-space: the
    /// truth of random clipped loops is certified; points moved off it by several radii of
    /// the classical outer box are measured, and each one it certifies must leave the classical
    /// outer set over its own degenerate box non-empty (that set is built from the flattened
    /// problem, an independent construction); some must be rejected.
    #[test]
    fn a_lagged_problem_certifies_its_truth_and_only_points_its_outer_set_admits() {
        use rand::{Rng, SeedableRng};
        let (mut rejected, mut certified) = (0, 0);
        for seed in 0..12u64 {
            let case = feedback_case(seed);
            let theta = &case.theta;
            let prob = EivProblem {
                locate: false,
                ..case.problem()
            };
            let s = consistency_at(&prob, theta).unwrap();
            assert!(s <= CERTIFIED, "seed {seed}: the truth measures {s}");
            let Ok(outer) = crate::stage3::solve(EivMethod::Classical, &prob) else {
                continue;
            };
            let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed + 50);
            for _ in 0..20 {
                let pt: Vec<f64> = theta
                    .iter()
                    .zip(&outer.bounds)
                    .map(|(v, b)| v + rng.gen_range(-3.0..3.0) * b.radius().max(1e-3))
                    .collect();
                if consistency_at(&prob, &pt).unwrap() > CERTIFIED {
                    rejected += 1;
                    continue;
                }
                certified += 1;
                let degenerate: Vec<Interval> = pt
                    .iter()
                    .map(|v| Interval::new(v - 1e-9 * (1.0 + v.abs()), v + 1e-9 * (1.0 + v.abs())))
                    .collect();
                let at = EivProblem {
                    prior: Some(&degenerate),
                    ..prob.clone()
                };
                assert!(
                    crate::stage3::feasible(&at).unwrap(),
                    "seed {seed}: {pt:?} certified, but its outer set is empty"
                );
            }
        }
        assert!(
            rejected > 0 && certified > 0,
            "rejected {rejected}, certified {certified}: vacuous"
        );
    }

    /// The fixed-`a` LP (equations substituted) and the shared-error LP over a degenerate `a`
    /// box (equations as rows, products exact) describe the same set: they must agree on
    /// consistency, at the truth (consistent: the noise is inside its bound) and far from it.
    #[test]
    fn fixed_a_lp_agrees_with_the_shared_model() {
        for seed in 0..8 {
            let (m, out, input) = random_case(seed, 40);
            let prob = problem(&out, &input, true);
            let shared = shared::solve(&prob, &SharedOptions::default()).unwrap();
            let model = SharedModel::new(&prob, shared.equations.clone());
            let mut at = AtA {
                prob: &prob,
                dims: vec![0, 1],
                times: model.times.clone(),
                tb: shared.bounds.clone(),
                lps: 0,
                input_vars: false,
            };
            let r = [shared.bounds[0].radius(), shared.bounds[1].radius()];
            for (shift, consistent) in [(0.0, Some(true)), (3.0, Some(false)), (-3.0, Some(false))]
            {
                let a = [m.a[0] + shift * r[0], m.a[1] - shift * r[1]];
                let phi = at.slack(&a).unwrap();
                let mut tb = shared.bounds.clone();
                tb[0] = Interval::new(a[0], a[0]);
                tb[1] = Interval::new(a[1], a[1]);
                let lp = model
                    .build(&tb, &model.initial_deltas(), &model.times)
                    .unwrap();
                let feasible = lp.solver().unwrap().feasible().unwrap();
                assert_eq!(feasible, consistent, "seed {seed} shift {shift}: shared LP");
                assert_eq!(
                    phi <= 0.0,
                    consistent == Some(true),
                    "seed {seed} shift {shift}: φ = {phi}"
                );
            }
        }
    }

    #[test]
    fn three_free_a_coefficients_are_refused() {
        let (_, out, input) = random_case(1, 40);
        let mut prob = problem(&out, &input, true);
        prob.na = 3;
        prob.fixed = vec![None, None, None, Some(0.0), None, None];
        let start = EivResult {
            bounds: vec![Interval::new(-1.0, 1.0); 6],
            equations: prob.equation_times(),
            feasible_orthants: 1,
            unsettled: None,
        };
        assert!(matches!(
            solve_from(&prob, &start, &quick(), || {}),
            Err(SmidError::Unsupported { .. })
        ));
    }

    proptest! {
        #![proptest_config(cases(3))]
        /// Exact extra columns (an offset, a friction column) are free LP variables like the
        /// b's: the outer hull contains the truth, lies inside the shared start, and the inner
        /// hull (consistent points) lies inside the outer one.
        #[test]
        fn exact_grid_with_exact_extra_columns_contains_the_truth(seed in any::<u64>()) {
            let case = random_extra_case(seed, 40, 0.0);
            let prob = case.problem(true);
            let shared = match shared::solve(&prob, &SharedOptions::default()) {
                Err(SmidError::Unbounded { .. }) => { prop_assume!(false); unreachable!() }
                other => other.unwrap(),
            };
            let ex = solve_from(&prob, &shared, &quick(), || {}).unwrap();
            for (k, t) in case.truth().into_iter().enumerate() {
                let o = ex.outer[k];
                prop_assert!(o.contains(t), "θ{}: outer {:?} misses {}", k, o, t);
                prop_assert!(shared.bounds[k].lo <= o.lo && o.hi <= shared.bounds[k].hi);
                if let Some(i) = ex.inner[k] {
                    let tol = 10.0 * crate::lp::RESULT_PAD * (1.0 + o.lo.abs().max(o.hi.abs()));
                    prop_assert!(o.lo - tol <= i.lo && i.hi <= o.hi + tol, "inner {:?} outside outer {:?}", i, o);
                }
            }
        }
    }

    /// The fixed-`a` LP substitutes the exact extra columns in the equations: at the true `a`
    /// the data are consistent, far from it they are not.
    #[test]
    fn fixed_a_lp_with_extra_columns_is_consistent_at_the_truth() {
        for seed in 0..6 {
            let case = random_extra_case(seed, 40, 0.0);
            let prob = case.problem(true);
            let shared = shared::solve(&prob, &SharedOptions::default()).unwrap();
            let mut at = AtA {
                prob: &prob,
                dims: vec![0, 1],
                times: shared.equations.clone(),
                tb: shared.bounds.clone(),
                lps: 0,
                input_vars: false,
            };
            let r = [shared.bounds[0].radius(), shared.bounds[1].radius()];
            let a = [case.m.a[0], case.m.a[1]];
            assert!(
                at.slack(&a).unwrap() <= 0.0,
                "seed {seed}: truth inconsistent"
            );
            // The b's and extra coefficients at the true a: an inner value on each side of the truth.
            for (k, t) in case.truth().into_iter().enumerate().skip(2) {
                let lo = at.value(&a, k, false).unwrap().unwrap();
                let hi = at.value(&a, k, true).unwrap().unwrap();
                let tol = 1e-7 * (1.0 + t.abs());
                assert!(
                    lo <= t + tol && t - tol <= hi,
                    "seed {seed} θ{k}: [{lo}, {hi}] misses {t}"
                );
            }
            for shift in [3.0, -3.0] {
                let far = [a[0] + shift * r[0], a[1] - shift * r[1]];
                assert!(at.slack(&far).unwrap() > 0.0, "seed {seed} shift {shift}");
            }
        }
    }

    /// An uncertain extra column is refused with an error naming it, before any start is
    /// computed (through the registry) and by `solve_from` itself.
    #[test]
    fn uncertain_extra_columns_are_refused() {
        let case = random_extra_case(2, 40, 0.05);
        let prob = case.problem(true);
        for e in [
            ExactGrid::default().solve(&prob).unwrap_err(),
            solve_from(
                &prob,
                &crate::stage3::solve(EivMethod::Shared, &prob).unwrap(),
                &quick(),
                || {},
            )
            .unwrap_err(),
        ] {
            match e {
                SmidError::Unsupported { plugin, what } => {
                    assert_eq!(plugin, "exact-grid");
                    assert!(what.contains("`friction`"), "{what}");
                }
                other => panic!("expected a refusal, got {other:?}"),
            }
        }
    }
}
