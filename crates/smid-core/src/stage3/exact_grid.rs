//! Stage 3 (paper Section 5) reference: the exact feasible parameter set of the EIV problem
//! (eqs 1, 28-30), measured on a grid of the `a`-plane, for at most two free `a`
//! coefficients, an exactly known input (Wiener structure) and exactly known extra regressor
//! columns (an uncertain one is refused, like an uncertain input).
//!
//! For `a` fixed the equations `x_t + Σ a_i x_{t-i} = Σ b_j u_{t-j} + Σ c_k φ_k(t)` with
//! `x_s = x^c_s + δx_s`, `|δx_s| <= Δx_s` are linear in `(b, c, δx)`: one LP
//! ([`super::certify`]) decides whether a grid point is feasible and bounds the `b`'s and
//! `c`'s there (the **inner hull** of feasible grid points: inside the exact set, up to the
//! LP's outward tolerances). Over a grid cell, the products `a_i δx_s` are relaxed by
//! McCormick envelopes over the cell, which is exact as the cell shrinks: the cell LP's bounds
//! contain every feasible point of the cell, so the hull of the cell bounds over all feasible
//! cells (the **outer hull**) is a guaranteed outer bound of the exact set.
//!
//! The grid is dyadic (`2^depth` cells per axis inside the shared-error box, itself a
//! guaranteed outer bound) and explored by best-first branch and bound per parameter and
//! direction: a cell's relaxation contains its children's, so a cell whose bound cannot beat the
//! current best never needs refining, and the result equals the hull over all finest cells.
use super::certify::{check_extras, AtA, INSIDE};
use super::ipm::{Bound, Prepared};
use super::relax::SharedModel;
use super::{EivMethod, EivProblem, EivResult, Stage3Method};
use crate::error::{Result, SmidError, Stage};
use crate::interval::Interval;
use crate::sparse_lp::Optimum;
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
    /// The guaranteed start box (the grid's root cell).
    root: Vec<Interval>,
    db: Vec<Interval>,
    lps: usize,
    /// Depth of the finest cells (0 with no gridded `a`).
    depth: u32,
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

    /// The guaranteed bound of `side` over the grid, by best-first branch and bound (key: the
    /// cell's bound in the direction of improvement), and the inner value `inner` finds at
    /// the finest cell that gives it. `start` is θ_k's interval in the start box.
    fn bound(
        &mut self,
        side: Side,
        start: Interval,
        inner: &mut Inner,
    ) -> Result<(f64, Option<f64>)> {
        let max = side.max;
        let key = |v: f64| if max { v } else { -v };
        let mut heap = BinaryHeap::new();
        let root = Cell {
            depth: 0,
            i: 0,
            j: 0,
        };
        if let Some((v, at)) = self.eval(root, side, start, None)? {
            heap.push(Node {
                key: key(v),
                cell: root,
                at,
            });
        }
        let mut bound: Option<f64> = None;
        let mut best_inner: Option<f64> = None;
        while let Some(node) = heap.pop() {
            if node.cell.depth >= self.depth {
                bound = Some(if max { node.key } else { -node.key });
                // Inner hull: the consistent point nearest the relaxation's optimiser on the
                // segment from the anchor, and the anchor itself.
                let target = &node.at[..self.dims.len()];
                inner.widen(self, target, side, &mut best_inner)?;
                break;
            }
            let parent = Some((if max { node.key } else { -node.key }, node.at));
            for c in self.children(node.cell) {
                if let Some((v, at)) = self.eval(c, side, start, parent)? {
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
                self.model.times.last().copied().unwrap_or(0),
                "no cell of the a-grid admits b and inner-signal errors within their bounds",
            ));
        };
        Ok((b, best_inner))
    }

    /// The bound of `side` over cell `c` and the gridded values at its optimum; `None` when
    /// the cell is infeasible. Each cell is evaluated once per direction (its relaxation
    /// contains its children's). Without a conclusion it keeps its parent's bound, or the
    /// start box's (`start`): conservative.
    fn eval(
        &mut self,
        c: Cell,
        side: Side,
        start: Interval,
        parent: Option<(f64, [f64; 2])>,
    ) -> Result<Option<(f64, [f64; 2])>> {
        let max = side.max;
        let tb = self.cell_box(c);
        Ok(match self.solve(&tb, side.col, max)? {
            Optimum2::Value(v, at) => Some((v, at)),
            Optimum2::Infeasible => None,
            Optimum2::Unknown => {
                let mut centre = [0.0; 2];
                for (d, &kk) in self.dims.iter().enumerate() {
                    centre[d] = tb[kk].center();
                }
                let v = parent.map_or(if max { start.hi } else { start.lo }, |p| p.0);
                Some((v, centre))
            }
        })
    }

    /// Whether the shared-error LP over the degenerate box of the gridded values `a` (the
    /// rest of the root box) is feasible. An inner point is kept only where it is: the
    /// fixed-`a` LP's dense measurement can be wrong where the `a`'s are large (a point it
    /// measured consistent at |a1| ≈ 17 that this LP proves infeasible).
    fn confirmed(&self, a: &[f64]) -> Result<bool> {
        let mut tb = self.root.clone();
        for (d, &k) in self.dims.iter().enumerate() {
            tb[k] = Interval::new(a[d], a[d]);
        }
        let lp = self
            .model
            .build(&tb, &self.model.initial_deltas(), &self.model.times)?;
        Ok(lp.solver()?.feasible()? == Some(true))
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

/// The inner-hull search over the fixed-`a` LPs ([`AtA`]): its anchor and the line search
/// toward a cell optimiser.
impl AtA<'_, '_> {
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
    if prob.has_mirrored() {
        // Its inner hull certifies points, and a sample of undecided sign certifies nothing.
        return Err(SmidError::Unsupported {
            plugin: NAME.into(),
            what: "samples of undecided sign (a two-sided preimage): the pipeline's sign search decides them first".into(),
        });
    }
    let model = SharedModel::new(prob, start.equations.clone());
    let dims = gridded(prob, &model)?;
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
    let depth = if dims.is_empty() { 0 } else { opts.depth };
    let mut g = Grid {
        model: &model,
        dims,
        root: start.bounds.clone(),
        db,
        lps: 0,
        depth,
    };
    let at_a = AtA {
        prob,
        dims: g.dims.clone(),
        times: model.times.clone(),
        tb: start.bounds.clone(),
        lps: 0,
        input_vars: false,
    };
    let mut inner_search = Inner {
        at_a,
        anchor: None,
        line_steps: opts.line_steps,
    };
    inner_search.anchor = inner_search.find_anchor(&g, opts.anchor_evals)?;
    let p = prob.p();
    let mut outer: Vec<Interval> = start.bounds.clone();
    let mut inner: Vec<Option<Interval>> = (0..p)
        .map(|k| prob.fixed[k].map(|v| Interval::new(v, v)))
        .collect();
    for (col, &k) in model.free.iter().enumerate() {
        for max in [false, true] {
            let side = Side { col, k, max };
            let (b, best_inner) = g.bound(side, start.bounds[k], &mut inner_search)?;
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
        cell_lps: g.lps + inner_search.at_a.lps,
        anchor: inner_search.anchor,
        equations: start.equations.clone(),
    })
}

/// The θ indices of the free `a`'s, which the grid covers; an error when the problem is out
/// of the method's reach (more than two of them, an uncertain extra column, or an uncertain
/// signal multiplied by a coefficient that is not gridded).
fn gridded(prob: &EivProblem, model: &SharedModel) -> Result<Vec<usize>> {
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
    Ok(dims)
}

/// One end of one free θ's interval: LP column `col` of θ index `k`, the upper end with
/// `max`.
#[derive(Clone, Copy)]
struct Side {
    col: usize,
    k: usize,
    max: bool,
}

/// The inner hull's state: the fixed-`a` LPs, the anchor (a consistent `a` and its measure;
/// `None`: no inner hull) and the bisection steps of the line search.
struct Inner<'p, 'a> {
    at_a: AtA<'p, 'a>,
    anchor: Option<(Vec<f64>, f64)>,
    line_steps: u32,
}

impl Inner<'_, '_> {
    /// The anchor of the inner hull: the fixed-`a` LPs' consistent point, kept where the grid
    /// confirms it ([`Grid::confirmed`]). The fixed-`a` LPs need an exact input (they
    /// substitute it in the equations): `None` otherwise.
    fn find_anchor(&mut self, g: &Grid, evals: usize) -> Result<Option<(Vec<f64>, f64)>> {
        let prob = self.at_a.prob;
        let exact_input = g
            .model
            .times
            .iter()
            .all(|&t| (0..=prob.nb).all(|j| prob.input[t - j].radius() == 0.0));
        if !exact_input {
            return Ok(None);
        }
        Ok(match self.at_a.anchor(&g.root, evals)? {
            Some((a, v)) if g.confirmed(&a)? => Some((a, v)),
            _ => None,
        })
    }

    /// At a finest cell whose relaxation's optimiser has the gridded values `target`: the
    /// consistent point nearest it on the segment from the anchor, and the anchor itself,
    /// each confirmed by the grid, widen `best` (the inner value of `side` so far).
    fn widen(
        &mut self,
        g: &Grid,
        target: &[f64],
        side: Side,
        best: &mut Option<f64>,
    ) -> Result<()> {
        let Some((anchor, _)) = &self.anchor else {
            return Ok(());
        };
        let near = self.at_a.toward(anchor, target, self.line_steps)?;
        for a in [near, anchor.clone()] {
            if !g.confirmed(&a)? {
                continue;
            }
            if let Some(v) = self.at_a.value(&a, side.k, side.max)? {
                *best = Some(match *best {
                    None => v,
                    Some(b) if side.max => b.max(v),
                    Some(b) => b.min(v),
                });
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::stage3::shared::{self, SharedOptions};
    use crate::stage3::testutil::{cases, problem, random_case, random_extra_case};
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
