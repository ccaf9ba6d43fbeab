//! The guaranteed one-step output band of an identified [`ModelSet`] on a record:
//! per sample `t`, an interval that holds the noise-free output `w_t + s_t` (eq 1 with the
//! chain's blocks and the effects' sensor terms) for **every** member of the set, whatever the
//! noise on the past samples within its bound. It uses the record's past only (`y_0..y_{t-1}`,
//! the input up to `t`): it is what the set predicts, not a smoothing of the measurement.
//!
//! Per cell of the set (its bisected parameters, its nonlinearity set, its `θ` box):
//! 1. **θ outer polytope.** Every training equation (eqs 28-30, the stage-2 intervals of the
//!    cell) with each uncertain product bounded by the `θ` box,
//!    `|x^c_t + Σ a_i x^c_{t-i} - Σ b_j v^c_{t-j} - Σ c_k φ^c_k(t)| <= Δx_t + Σ |a_i|^+ Δx_{t-i}
//!    + Σ |b_j|^+ Δv_{t-j} + Σ |c_k|^+ Δφ_k(t)` (`|·|^+` the largest magnitude over the box),
//!    the box itself, the fixed entries and the unit gain (eq 8): a polytope that holds every
//!    `θ` of the cell's feasible set.
//! 2. **Linear block, one step.** The past inner signal `x_{t-i}` is bounded by inverting the
//!    last [`WINDOW`] outputs before `t` through the output side of the chain over the cell
//!    ([`crate::chain::backward`], eqs 23-27; the inversion never assumes its window starts at
//!    rest); the input side is propagated forward. The prediction
//!    `x_t = -Σ a_i x_{t-i} + Σ b_j v_{t-j} + Σ c_k φ_k(t)` is linear in `θ` for the centres of
//!    those intervals: its range over the polytope is two certified LPs
//!    ([`crate::lp::Polytope::extent`]), widened by `Σ |a_i|^+ Δx_{t-i} + ...` for the radii.
//! 3. **Output side.** A candidate noise-free output `z` at `t` is possible only if inverting
//!    the window followed by `z` leaves an inner value inside the predicted interval of step 2.
//!    For a chain of monotone blocks ([`crate::nonlinearity::NonlinearitySet::monotone`]) the
//!    possible `z` form an interval, whose ends are found by bisection, each end kept at a point
//!    proven impossible (outward). A block that is not monotone, or an inversion that fails,
//!    leaves the sample's band unbounded (never a guess). The sensor terms over the cell are
//!    added as intervals.
//!
//! With `model.feedback` the autoregressive part reads the past outputs: steps 1 and 2 take
//! them inside their measurement boxes (`y ± Δ` less the sensor terms) instead of inverting.
//!
//! The band is the hull over the cells; a cell whose `θ` the budget left unbounded makes it
//! unbounded (such cells are evaluated first: one that bounds no sample ends the work). Guarantee: with the training and the record's noise inside their bounds, the true
//! parameters lie in some cell, in its polytope and its nonlinearity set, so the true output at
//! `t` passes every test above.
use crate::chain;
use crate::effect::{self, Signals};
use crate::error::{Result, SmidError};
use crate::interval::Interval;
use crate::inversion::InnerBound;
use crate::lp::{Extent, Polytope};
use crate::model::{Layout, ModelSet, Record};
use crate::nonlinearity::NonlinearitySet;
use crate::pipeline::{eiv_problem, stage2, BlockSets};
use crate::stage3::EivProblem;
use rayon::prelude::*;
use serde::Serialize;

/// Past outputs inverted for each one-step prediction (enough for the memory of every
/// bundled block; a longer memory only widens the band).
pub const WINDOW: usize = 16;

/// Sets with more cells than this take the prediction's range over each cell's `θ` box by
/// interval arithmetic instead of the LPs (two LPs per sample and cell, over hundreds of
/// cells, would cost far more than the identification; the box is an outer bound of the polytope, so the band stays guaranteed,
/// only wider).
pub const LP_CELLS: usize = 16;

/// The guaranteed one-step band of one record: per sample, the interval of the noise-free
/// output (infinite where nothing is guaranteed: the first samples, before the equation
/// has its past).
#[derive(Debug, Clone, Serialize)]
pub struct Band {
    /// Per-sample lower end of the noise-free output (`-inf` where nothing is guaranteed).
    pub lower: Vec<f64>,
    /// Per-sample upper end of the noise-free output (`+inf` where nothing is guaranteed).
    pub upper: Vec<f64>,
    /// Cells of the set the band is the hull over, and how many of them were proven empty by
    /// their `θ` polytope (they hold no member and add nothing).
    pub cells: usize,
    /// How many of those [`Band::cells`] were proven empty.
    pub empty_cells: usize,
    /// Whether the prediction's range came from the LPs over each cell's polytope (else from
    /// its `θ` box, see [`LP_CELLS`]).
    pub lp: bool,
    /// Cells not evaluated: a cell with `θ` unbounded already left the band unbounded at
    /// every sample (0 when every cell was evaluated).
    pub unevaluated: usize,
}

impl Band {
    /// Samples from `from` on with a finite band, and the sum of their widths.
    pub fn finite(&self, from: usize) -> (usize, f64) {
        self.lower
            .iter()
            .zip(&self.upper)
            .skip(from)
            .filter(|(l, u)| l.is_finite() && u.is_finite())
            .fold((0, 0.0), |(n, s), (l, u)| (n + 1, s + (u - l)))
    }
    /// Samples from `from` on where `y` lies outside the band widened by `dy` (the measured
    /// output against its noise bound): each one is a contradiction of the model set.
    pub fn outside(&self, y: &[f64], dy: &[f64], from: usize) -> Vec<usize> {
        (from..y.len().min(self.lower.len()))
            .filter(|&t| y[t] + dy[t] < self.lower[t] || y[t] - dy[t] > self.upper[t])
            .collect()
    }
}

/// The guaranteed one-step band of `set` on `rec` (noise bound: the record's `dy`).
pub fn one_step_band(set: &ModelSet, rec: &Record) -> Result<Band> {
    rec.validate()?;
    let layout = set.layout()?;
    let n = rec.y.len();
    let lp = set.cells.len() <= LP_CELLS;
    let band_of = |cells: &[usize]| -> Result<Vec<Option<Vec<Interval>>>> {
        cells
            .par_iter()
            .map(|&k| cell_band(set, layout, k, rec, lp))
            .collect()
    };
    // The cells whose θ the search left unbounded first: one that is not proven empty and
    // guarantees nothing at any sample makes the hull unbounded everywhere, whatever the
    // other cells give, and they are not evaluated.
    let (open, bounded): (Vec<usize>, Vec<usize>) =
        (0..set.cells.len()).partition(|&k| set.cells[k].theta.iter().any(|i| !i.is_finite()));
    let mut per_cell = band_of(&open)?;
    let nowhere = |b: &Option<Vec<Interval>>| {
        b.as_ref().is_some_and(|b| {
            b.iter()
                .all(|i| i.lo == f64::NEG_INFINITY && i.hi == f64::INFINITY)
        })
    };
    if per_cell.iter().any(nowhere) {
        return Ok(Band {
            lower: vec![f64::NEG_INFINITY; n],
            upper: vec![f64::INFINITY; n],
            cells: set.cells.len(),
            empty_cells: per_cell.iter().filter(|b| b.is_none()).count(),
            lp,
            unevaluated: bounded.len(),
        });
    }
    per_cell.extend(band_of(&bounded)?);
    let mut lower = vec![f64::INFINITY; n];
    let mut upper = vec![f64::NEG_INFINITY; n];
    let mut empty = 0;
    for b in &per_cell {
        match b {
            None => empty += 1,
            Some(b) => {
                for t in 0..n {
                    lower[t] = lower[t].min(b[t].lo);
                    upper[t] = upper[t].max(b[t].hi);
                }
            }
        }
    }
    if empty == per_cell.len() {
        // Every cell empty: the set holds no member (a falsified set has no band).
        lower.iter_mut().for_each(|v| *v = f64::NEG_INFINITY);
        upper.iter_mut().for_each(|v| *v = f64::INFINITY);
    }
    Ok(Band {
        lower,
        upper,
        cells: per_cell.len(),
        empty_cells: empty,
        lp,
        unevaluated: 0,
    })
}

/// The band over one cell: `None` when its `θ` polytope is proven empty (no member there).
fn cell_band(
    set: &ModelSet,
    layout: &Layout,
    k: usize,
    rec: &Record,
    lp: bool,
) -> Result<Option<Vec<Interval>>> {
    let n = rec.y.len();
    let c = &set.cells[k];
    if !c.bounded() {
        return Ok(Some(vec![Interval::entire(); n]));
    }
    let o = layout.orders;
    // 1. The θ polytope from the training equations of this cell (with the LPs).
    let poly = if lp {
        let train = match stage2(
            &set.model,
            layout,
            c.nonlinearity.as_ref(),
            &c.cell,
            &set.training.records,
        ) {
            Ok(s) => s,
            Err(SmidError::Inconsistent(_)) => return Ok(None),
            Err(e) => return Err(e),
        };
        let mut prob = eiv_problem(&set.model, layout, &set.method, &train, Some(&c.theta));
        prob.use_band_samples = true;
        Some(theta_polytope(&prob, &c.theta))
    } else {
        None
    };
    let mag: Vec<f64> = c.theta.iter().map(|i| i.lo.abs().max(i.hi.abs())).collect();

    // 2. The record through the chain over the cell, causally.
    let slices = layout.effect_slices(&c.cell);
    let blocks = BlockSets::new(&set.model, layout, &c.cell)?;
    let (input_side, output_side) = blocks.sides(set.model.structure, c.nonlinearity.as_ref());
    let mut yc = rec.y.clone();
    let mut dy = rec.dy.clone();
    let mut sensor = vec![Interval::new(0.0, 0.0); n];
    if !set.model.effects.is_empty() {
        for t in 0..n {
            let s = effect::sensor_sum(&set.model.effects, &slices, Some(t))?;
            yc[t] -= s.center();
            dy[t] += s.radius();
            sensor[t] = s;
        }
    }
    let v: Vec<Interval> = chain::forward(&input_side, &rec.u)?
        .iter()
        .map(|b| b.interval)
        .collect();
    let vin = |t: usize, j: usize| -> Interval {
        if t >= j + o.nk {
            v[t - j - o.nk]
        } else {
            Interval::entire()
        }
    };
    // The inner signal before each `t` from the window of outputs ending at `t - 1`.
    let windows: Vec<Vec<InnerBound>> = (0..n)
        .map(|t| {
            let from = t.saturating_sub(WINDOW);
            if from == t {
                return Vec::new();
            }
            chain::backward(&output_side, &yc[from..t], &dy[from..t])
                .unwrap_or_else(|_| vec![InnerBound::unknown(); t - from])
        })
        .collect();
    // Each sample's inner signal from its own past and itself (`x[s]` reads `y[..=s]`): the
    // effects' regressors at `t` read `x[..t]` only (their contract), so they stay causal.
    let causal: Vec<Interval> = (0..n)
        .map(|s| {
            windows
                .get(s + 1)
                .and_then(|w| w.last())
                .map_or_else(Interval::entire, |b| b.hull())
        })
        .collect();
    let cols = effect::regressors(
        &set.model.effects,
        &Signals {
            u: &rec.u,
            dt: rec.dt,
            x: Some(&causal),
        },
    );

    // 3. Per sample: the linear block's prediction, then the output side.
    let start = o.na.max(o.nb + o.nk);
    let p = layout.p();
    let n_ab = o.na + o.nb + 1;
    let mut out = vec![Interval::entire(); n];
    for t in start..n {
        let w = &windows[t];
        let mut g = vec![0.0; p];
        let mut e = 0.0;
        let mut ok = true;
        let mut take = |k: usize, sign: f64, iv: Interval, g: &mut Vec<f64>| {
            if !iv.is_finite() {
                ok = false;
                return;
            }
            g[k] += sign * iv.center();
            e += mag[k] * iv.radius();
        };
        for i in 1..=o.na {
            let iv = if set.model.feedback {
                // `model.feedback`: the past outputs themselves, inside their measurement box.
                t.checked_sub(i).map_or_else(Interval::entire, |s| {
                    Interval::new(yc[s] - dy[s], yc[s] + dy[s]).outward()
                })
            } else {
                w.len()
                    .checked_sub(i)
                    .map_or_else(Interval::entire, |j| w[j].hull())
            };
            take(i - 1, -1.0, iv, &mut g);
        }
        for j in 0..=o.nb {
            take(o.na + j, 1.0, vin(t, j), &mut g);
        }
        for (x, col) in cols.iter().enumerate() {
            take(n_ab + x, 1.0, col.values[t], &mut g);
        }
        if !ok {
            continue;
        }
        let lin = match poly.as_ref().map(|poly| poly.extent(&g, &c.theta)) {
            Some(Extent::Range(r)) => r,
            Some(Extent::Empty) => return Ok(None),
            Some(Extent::Unknown) | None => box_range(&g, &c.theta),
        };
        let e = e * (1.0 + 1e-12);
        let xhat = Interval::new(lin.lo - e, lin.hi + e).outward();
        let wband = if output_side.is_empty() {
            xhat
        } else {
            let from = t.saturating_sub(WINDOW);
            output_band(&output_side, &yc[from..=t], &dy[from..=t], xhat)
        };
        let s = sensor[t];
        out[t] = Interval::new(wband.lo + s.lo, wband.hi + s.hi).outward();
    }
    Ok(Some(out))
}

/// The outer polytope of the cell's `θ` (see the module doc, step 1).
fn theta_polytope(prob: &EivProblem, theta: &[Interval]) -> Polytope {
    let p = prob.p();
    let mag: Vec<f64> = theta.iter().map(|i| i.lo.abs().max(i.hi.abs())).collect();
    let mut poly = Polytope::new(p);
    let mut g = vec![0.0; p];
    for t in prob.equation_times() {
        g.iter_mut().for_each(|v| *v = 0.0);
        let x = prob.output[t].interval;
        let e0 = x.center();
        let mut s0 = x.radius();
        for i in 1..=prob.na {
            let iv = prob
                .lagged
                .map_or(prob.output[t - i].interval, |w| w[t - i]);
            g[i - 1] += iv.center();
            s0 += mag[i - 1] * iv.radius();
        }
        for j in 0..=prob.nb {
            let iv = prob.input[t - j];
            g[prob.na + j] -= iv.center();
            s0 += mag[prob.na + j] * iv.radius();
        }
        for (e, r) in prob.extra.iter().enumerate() {
            let iv = r.values[t];
            g[prob.n_ab() + e] -= iv.center();
            s0 += mag[prob.n_ab() + e] * iv.radius();
        }
        let s0 = s0 * (1.0 + 1e-12);
        // -s0 <= e0 + g·θ <= s0
        poly.push_le(&g, s0 - e0, t);
        let ng: Vec<f64> = g.iter().map(|v| -v).collect();
        poly.push_le(&ng, s0 + e0, t);
    }
    for (k, b) in theta.iter().enumerate() {
        g.iter_mut().for_each(|v| *v = 0.0);
        g[k] = 1.0;
        poly.push_le(&g, b.hi, usize::MAX);
        g[k] = -1.0;
        poly.push_le(&g, -b.lo, usize::MAX);
    }
    if prob.unit_gain {
        let row: Vec<f64> = (0..p).map(|k| prob.gain_sign(k)).collect();
        poly.push_eq(&row, 1.0);
    }
    poly
}

/// `g·θ` over the box alone (interval arithmetic): the fallback when the LP cannot conclude.
fn box_range(g: &[f64], theta: &[Interval]) -> Interval {
    let (lo, hi) = g.iter().zip(theta).fold((0.0, 0.0), |(lo, hi), (c, b)| {
        let (a, z) = (c * b.lo, c * b.hi);
        (lo + a.min(z), hi + a.max(z))
    });
    Interval::new(lo, hi).widen(1e-12, 0.0).outward()
}

/// Where a candidate output `z` at the window's last sample leaves the inner signal, against
/// the predicted interval.
#[derive(Clone, Copy, PartialEq)]
enum Candidate {
    /// The inversion puts the inner value below the prediction: `z` too low.
    Low,
    /// Above it: `z` too high.
    High,
    /// They meet: `z` possible.
    In,
    /// The inversion failed or left no value: nothing to conclude.
    Unknown,
}

/// The possible noise-free outputs of the output side at the last sample of `y` (the window
/// `y[..last]` with bounds `dy`, the last sample a candidate) when the inner signal there lies
/// in `xhat` (see the module doc, step 3).
fn output_band(blocks: &[&dyn NonlinearitySet], y: &[f64], dy: &[f64], xhat: Interval) -> Interval {
    if blocks.iter().any(|b| !b.monotone()) {
        // A block that is not monotone: its output range over `xhat` whatever its history,
        // block by block, where each knows one.
        return blocks
            .iter()
            .try_fold(xhat, |x, b| b.output_range(x))
            .map_or_else(Interval::entire, |i| i.outward());
    }
    let last = y.len() - 1;
    let mut ys = y.to_vec();
    let mut ds = dy.to_vec();
    ds[last] = 0.0;
    let mut fit = |z: f64| -> Candidate {
        ys[last] = z;
        match chain::backward(blocks, &ys, &ds) {
            Ok(v) => {
                let j = v[last].interval;
                if j.lo.is_nan() || j.hi.is_nan() || j.lo > j.hi {
                    Candidate::Unknown
                } else if j.hi < xhat.lo {
                    Candidate::Low
                } else if j.lo > xhat.hi {
                    Candidate::High
                } else {
                    Candidate::In
                }
            }
            Err(_) => Candidate::Unknown,
        }
    };
    let z0 = y[last];
    let scale = (dy[last] + xhat.radius().min(1e12)).max(1e-9 * (1.0 + z0.abs()));
    let tol = 1e-3 * dy[last].max(1e-9 * (1.0 + z0.abs()));
    // A possible output, by stepping (doubling) then halving towards the prediction.
    let (mut low, mut high): (Option<f64>, Option<f64>) = (None, None);
    let mut z = z0;
    let mut step = scale;
    let mut found = None;
    for _ in 0..300 {
        match fit(z) {
            Candidate::In => {
                found = Some(z);
                break;
            }
            Candidate::Unknown => return Interval::entire(),
            Candidate::Low => {
                low = Some(z);
                z = match high {
                    Some(h) => 0.5 * (z + h),
                    None => {
                        step *= 2.0;
                        z + step
                    }
                };
            }
            Candidate::High => {
                high = Some(z);
                z = match low {
                    Some(l) => 0.5 * (l + z),
                    None => {
                        step *= 2.0;
                        z - step
                    }
                };
            }
        }
        if let (Some(l), Some(h)) = (low, high) {
            if h - l <= tol {
                // No possible output found between a low and a high candidate: the true one,
                // if any, lies between them.
                return Interval::new(l, h);
            }
        }
        if !z.is_finite() {
            return Interval::entire();
        }
    }
    let Some(f) = found else {
        return Interval::entire();
    };
    // Each end: expand from the possible point until a candidate is impossible on that side,
    // then bisect; the end kept is the impossible candidate (outward).
    let mut end = |dir: f64, known: Option<f64>| -> f64 {
        let (bad, wrong) = if dir < 0.0 {
            (Candidate::Low, Candidate::High)
        } else {
            (Candidate::High, Candidate::Low)
        };
        let mut inside = f;
        let mut outside = known;
        let mut step = scale;
        let mut n = 0;
        while outside.is_none() {
            n += 1;
            if n > 80 {
                return dir * f64::INFINITY;
            }
            let cand = inside + dir * step;
            match fit(cand) {
                r if r == bad => outside = Some(cand),
                r if r == wrong => return dir * f64::INFINITY,
                _ => inside = cand,
            }
            step *= 2.0;
        }
        let mut out = outside.expect("set above");
        for _ in 0..200 {
            if (out - inside).abs() <= tol {
                break;
            }
            let mid = 0.5 * (out + inside);
            match fit(mid) {
                r if r == bad => out = mid,
                r if r == wrong => return dir * f64::INFINITY,
                _ => inside = mid,
            }
        }
        out
    };
    let lo = end(-1.0, low.filter(|&l| l < f));
    let hi = end(1.0, high.filter(|&h| h > f));
    Interval::new(lo, hi)
}
