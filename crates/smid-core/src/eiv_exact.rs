//! Stage 3 (paper Section 5) reference: the exact feasible parameter set of the EIV problem
//! (eqs 1, 28-30), measured on a grid of the `a`-plane, for at most two free `a`
//! coefficients and an exactly known input (Wiener structure).
//!
//! For `a` fixed the equations `x_t + Σ a_i x_{t-i} = Σ b_j u_{t-j}` with `x_s = x^c_s + δx_s`,
//! `|δx_s| <= Δx_s` are linear in `(b, δx)`: one LP decides whether a grid point is feasible and
//! bounds the `b`'s there (the **inner hull** of feasible grid points: inside the exact set, up to
//! the LP's outward tolerances). Over a grid cell, the products `a_i δx_s` are relaxed by
//! McCormick envelopes over the cell, which is exact as the cell shrinks: the cell LP's bounds
//! contain every feasible point of the cell, so the hull of the cell bounds over all feasible
//! cells (the **outer hull**) is a guaranteed outer bound of the exact set.
//!
//! The grid is dyadic (`2^depth` cells per axis inside the shared-error box, itself a
//! guaranteed outer bound) and explored by best-first branch and bound per parameter and
//! direction: a cell's relaxation contains its children's, so a cell whose bound cannot beat the
//! current best never needs refining, and the result equals the hull over all finest cells.
use crate::eiv::{EivProblem, EivResult};
use crate::eiv_shared::SharedModel;
use crate::error::{Result, SmidError, Stage};
use crate::interval::Interval;
use crate::sparse_lp::Optimum;
use std::collections::{BinaryHeap, HashMap};

/// Options of the exact-grid reference.
#[derive(Debug, Clone, Copy)]
pub struct ExactOptions {
    /// The grid has `2^depth` cells per free `a`.
    pub depth: u32,
    /// Leaves tried for a feasible grid point per bound (inner hull).
    pub inner_tries: usize,
    /// Extra levels below the grid searched for a feasible point in a leaf (inner hull).
    pub dive: u32,
}

impl Default for ExactOptions {
    fn default() -> Self {
        ExactOptions {
            depth: 7,
            inner_tries: 4,
            dive: 10,
        }
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
    /// Cell LPs solved.
    pub cell_lps: usize,
    pub equations: Vec<usize>,
}

impl ExactResult {
    /// The outer hull as a stage-3 result.
    pub fn to_eiv(&self) -> EivResult {
        EivResult {
            bounds: self.outer.clone(),
            equations: self.equations.clone(),
            feasible_orthants: 0,
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
        let lp = self.model.build(tb, &self.db, &self.model.times)?;
        let mut s = lp.solver()?;
        let o = if max {
            s.maximise(col)?
        } else {
            s.minimise(col)?
        };
        Ok(match o {
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
    let model = SharedModel::new(prob, start.equations.clone());
    let dims: Vec<usize> = (0..prob.na).filter(|&k| prob.fixed[k].is_none()).collect();
    if dims.len() > 2 {
        return Err(SmidError::Unsupported {
            plugin: "exact-grid".into(),
            what: format!("{} free a coefficients (at most 2)", dims.len()),
        });
    }
    if model.products.iter().any(|(k, _)| !dims.contains(k)) {
        return Err(SmidError::Unsupported {
            plugin: "exact-grid".into(),
            what:
                "an uncertain input signal (Hammerstein structure): the b's would need gridding too"
                    .into(),
        });
    }
    let mut db = model.initial_deltas();
    for _ in 0..2 {
        if let Some(t) = model.propagate(&start.bounds, &mut db) {
            return Err(SmidError::Inconsistent {
                stage: Stage::Linear,
                sample: t,
                detail: "interval propagation emptied an inner-signal error box".into(),
            });
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
    let p = prob.na + prob.nb + 1;
    let mut outer: Vec<Interval> = start.bounds.clone();
    let mut inner: Vec<Option<Interval>> = (0..p)
        .map(|k| prob.fixed[k].map(|v| Interval::new(v, v)))
        .collect();
    let mut cache: HashMap<(Cell, usize, bool), Option<(f64, [f64; 2])>> = HashMap::new();
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
            let mut eval = |g: &mut Grid,
                            c: Cell,
                            parent: Option<(f64, [f64; 2])>|
             -> Result<Option<(f64, [f64; 2])>> {
                if let Some(r) = cache.get(&(c, col, max)) {
                    return Ok(*r);
                }
                let tb = g.cell_box(c);
                let r = match g.solve(&tb, col, max)? {
                    Optimum2::Value(v, at) => Some((v, at)),
                    Optimum2::Infeasible => None,
                    // No conclusion: keep the parent's (or the start box's) bound: conservative.
                    Optimum2::Unknown => Some(parent.unwrap_or((
                        if max {
                            start.bounds[k].hi
                        } else {
                            start.bounds[k].lo
                        },
                        [0.0; 2],
                    ))),
                };
                cache.insert((c, col, max), r);
                Ok(r)
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
            let mut tries = 0;
            while let Some(node) = heap.pop() {
                if node.cell.depth >= depth {
                    if bound.is_none() {
                        bound = Some(if max { node.key } else { -node.key });
                    }
                    // Inner hull: exact LPs (a fixed) at points of this leaf: the relaxation's
                    // optimiser and the cell centre; if neither is feasible (a thin set), dive
                    // into the best sub-cell, where the envelopes are tighter, and retry.
                    let (mut cell, mut at) = (node.cell, node.at);
                    for _level in 0..=opts.dive {
                        let cb = g.cell_box(cell);
                        let centre: Vec<f64> = g.dims.iter().map(|&k| cb[k].center()).collect();
                        let mut cands = vec![at.to_vec(), centre];
                        cands.truncate(if g.dims.is_empty() { 1 } else { 2 });
                        for a in cands {
                            let mut tb = start.bounds.clone();
                            for (d, &kk) in g.dims.iter().enumerate() {
                                tb[kk] = Interval::new(a[d], a[d]);
                            }
                            if let Optimum2::Value(v, _) = g.solve(&tb, col, max)? {
                                // Undo the outward pad: an inner value is a point estimate.
                                let v = v + if max { -1.0 } else { 1.0 }
                                    * crate::lp::RESULT_PAD
                                    * (1.0 + v.abs());
                                best_inner = Some(match best_inner {
                                    None => v,
                                    Some(b) if max => b.max(v),
                                    Some(b) => b.min(v),
                                });
                            }
                        }
                        if best_inner.is_some() || g.dims.is_empty() {
                            break;
                        }
                        let parent = Some((if max { node.key } else { -node.key }, at));
                        let mut best: Option<(f64, Cell, [f64; 2])> = None;
                        for c in g.children(cell) {
                            if let Some((v, a)) = eval(&mut g, c, parent)? {
                                if best.map_or(true, |b| key(v) > b.0) {
                                    best = Some((key(v), c, a));
                                }
                            }
                        }
                        match best {
                            Some((_, c, a)) => {
                                cell = c;
                                at = a;
                            }
                            None => break,
                        }
                    }
                    tries += 1;
                    if best_inner.is_some() || tries >= opts.inner_tries.max(1) {
                        break;
                    }
                    continue;
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
                return Err(SmidError::Inconsistent {
                    stage: Stage::Linear,
                    sample: model.times.last().copied().unwrap_or(0),
                    detail:
                        "no cell of the a-grid admits b and inner-signal errors within their bounds"
                            .into(),
                });
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
        cell_lps: g.lps,
        equations: start.equations.clone(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::eiv_shared::tests::{problem, random_case};
    use crate::eiv_shared::{self, SharedOptions};
    use proptest::prelude::*;

    fn quick() -> ExactOptions {
        ExactOptions {
            depth: 4,
            inner_tries: 2,
            dive: 6,
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig { cases: 4, .. ProptestConfig::default() })]
        #[test]
        fn exact_grid_outer_contains_truth_and_inner_hull(seed in any::<u64>()) {
            let (m, out, input) = random_case(seed, 40);
            let prob = problem(&out, &input, true);
            let shared = eiv_shared::solve(&prob, &SharedOptions::default()).unwrap();
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
        };
        assert!(matches!(
            solve_from(&prob, &start, &quick(), || {}),
            Err(SmidError::Unsupported { .. })
        ));
    }
}
