//! Noise-bound estimation (`noise.estimate`): the smallest bound at which the training data are
//! consistent with the model (by the branch and bound's cheap test), times a margin (eq 5).
use super::*;
use crate::cells::{self, Budget, Verdict};
use crate::error::{Result, SmidError};
use crate::interval::Interval;
use crate::model::Training;
use crate::outcome::{Falsification, Outcome};
use crate::spec::Spec;

/// Whether the training data are consistent with the model at noise bound `d`, by the
/// branch and bound's cheap test alone (classical outer sets, no bounds computed): `false`
/// proves them inconsistent; `true` proves nothing.
pub fn consistent_at(spec: &Spec, data: &ExperimentData, d: f64) -> Result<bool> {
    consistent_at_halvings(
        spec,
        data,
        d,
        spec.method.cells.nonlinearity_halvings.saturating_sub(2),
    )
}

/// [`consistent_at`] with the test's cells of a bisected parameter halved down to
/// `prior width / 2^halvings`.
fn consistent_at_halvings(
    spec: &Spec,
    data: &ExperimentData,
    d: f64,
    halvings: u32,
) -> Result<bool> {
    Ok(tested_at(spec, data, d, halvings, false)?.0)
}

/// A cell of the test's search, by the bit patterns of its bounds (a key that two searches
/// share exactly when they evaluate the same box).
type CellKey = Vec<(u64, u64)>;

/// The prior box and the budget of the consistency test's search at `d` (cells of a bisected
/// parameter halved `halvings` times; an effect's resolution may follow `d`).
fn test_budget(
    spec: &Spec,
    data: &ExperimentData,
    d: f64,
    halvings: u32,
) -> Result<(Vec<Interval>, Budget)> {
    let layout = spec.model.layout()?;
    let prior: Vec<Interval> = layout.dims.iter().map(|d| d.prior).collect();
    // Coarser than the identification's cells: a test that cannot discard a coarse cell only
    // lowers the estimate, which the identification then raises by the margin if needed.
    let resolution = resolution(&spec.model, &layout, halvings, d, &data_scale(data));
    Ok((
        prior,
        Budget {
            resolution,
            depth: spec.method.cells.depth,
            // A consistency test stopped early keeps its cells: it can only say "consistent"
            // too soon, which lowers the estimate (raised again by the margin if needed).
            max_cells: spec.method.cells.max_cells.min(500),
            max_leaves: 500,
        },
    ))
}

/// The cells the consistency test's search at `d` evaluates when no test discards one (the
/// same search, run with a test that keeps every cell): sorted keys, one per evaluation.
fn undiscarded_cells(
    spec: &Spec,
    data: &ExperimentData,
    d: f64,
    halvings: u32,
) -> Result<Vec<CellKey>> {
    let (prior, budget) = test_budget(spec, data, d, halvings)?;
    let (searched, cells) = recorded(&prior, budget, &|_| Ok(Verdict::Feasible(())));
    searched?;
    Ok(cells)
}

/// `cells::search` with `test` as both its test and its finish, and the sorted keys of every
/// cell it evaluated.
fn recorded(
    prior: &[Interval],
    budget: Budget,
    test: &(dyn Fn(&[Interval]) -> Result<Verdict<()>> + Sync),
) -> (Result<Outcome<cells::Search<()>>>, Vec<CellKey>) {
    let seen = std::sync::Mutex::new(Vec::new());
    let record = |c: &[Interval]| {
        seen.lock().expect("no panic while recording").push(key(c));
        test(c)
    };
    let searched = cells::search(prior, budget, &record, &record, &|_| {});
    let mut cells = seen.into_inner().expect("no panic while recording");
    cells.sort();
    (searched, cells)
}

fn key(c: &[Interval]) -> CellKey {
    c.iter().map(|i| (i.lo.to_bits(), i.hi.to_bits())).collect()
}

/// The consistency test at `d` ([`consistent_at`]'s verdict), and, with `record`, the sorted
/// keys of every cell it evaluated.
fn tested_at(
    spec: &Spec,
    data: &ExperimentData,
    d: f64,
    halvings: u32,
    record: bool,
) -> Result<(bool, Option<Vec<CellKey>>)> {
    let (prior, budget) = test_budget(spec, data, d, halvings)?;
    let spec = with_bound(spec, d);
    let mut data = data_with_bound(data, d);
    // The points as the identification's stage 1 reads them (α at this bound).
    if let Some(st) = data.steady.as_mut() {
        super::with_alpha(&spec, data.filter.as_ref(), st)?;
    }
    let layout = spec.model.layout()?;
    let training = Training {
        steady: data.steady.clone(),
        records: data.records.clone(),
    };
    let test = |c: &[Interval]| test_cell(&spec.model, &layout, &spec.method, &training, c);
    let (searched, cells) = if record {
        let (s, c) = recorded(&prior, budget, &test);
        (s, Some(c))
    } else {
        (cells::search(&prior, budget, &test, &test, &|_| {}), None)
    };
    let verdict = match searched? {
        Outcome::Consistent(s) => !s.leaves.is_empty(),
        Outcome::Falsified(_) => false,
    };
    Ok((verdict, cells))
}

/// The smallest bound [`estimate_bound`] tries, as a fraction of the largest output (about 30
/// bits): data still "consistent" there were never falsified, and the estimate is refused
/// rather than reported as a bound of 1e-20.
pub const NO_BOUND_BELOW: f64 = 1e-9;

/// The estimated noise bound of `noise.estimate`: the margin times the smallest bound for
/// which the training data are consistent with the model (doubling from a thousandth of the
/// largest output, then bisection to 2 %; at most 60 tests). That smallest bound is a lower
/// bound of the exact one (the test is an outer relaxation), so the identification at the
/// estimate may still find the data inconsistent: the estimate then grows by the margin again.
/// `Falsified` when no bound up to 2^40 times the first try is consistent.
/// When no bound down to [`NO_BOUND_BELOW`] of the largest output is proven inconsistent, the
/// answer is `Unbounded` (the data do not bound the noise here), never a vanishing bound.
pub fn estimate_bound(spec: &Spec, data: &ExperimentData) -> Result<Outcome<f64>> {
    estimate_bound_traced(spec, data, true).0
}

/// How [`estimate_bound`] reached its answer: the consistency tests it ran, and the bounds
/// answered "consistent" from another bound's test without running one (see
/// [`estimate_bound_traced`]; a test's own verdict read again counts in neither).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct EstimateTrace {
    /// Consistency tests actually run.
    pub asked: usize,
    /// Bounds answered "consistent" from another bound's test, without running one.
    pub implied: usize,
}

/// [`estimate_bound`] and its trace. With `imply` false every verdict of the bisection is
/// asked: the reference the implied verdicts are checked against (both give the same answer
/// wherever the test is monotone, the premise below).
///
/// Implied verdicts: where at least three bounds the bisection may try would be answered, the
/// smallest of them is tested first. Where it is consistent, so is every larger bound the
/// bisection may try at which the test's search evaluates the same cells: a smaller bound
/// shrinks every cell's outer set, so a cell the smallest keeps is kept there too (and a kept
/// ancestor stands for cells the larger bound's budget leaves unsplit). The cells are the same
/// (a) where the resolution is the same (no bisected parameter whose resolution follows the
/// bound, as a sensor offset's 0.5Δ does), or (b) where the search that discards no cell
/// evaluates the same cells at both bounds and the search at the smallest bound evaluated
/// exactly those (it discarded no cell before its finish): the budget stopped both before the
/// resolution told them apart. Case (b) is the common one of a refused estimate: an offset's
/// or a drift's prior far wider than the noise, every test stopped by the cell budget. The
/// premise is the one the bar and the same-resolution short cut already rest on, with one
/// gap they share: a cell kept as feasible at the smallest bound that is undecided at a
/// larger one (stage 3 unbounded there) is halved further, and halves the smallest bound
/// never tested could both be discarded.
pub fn estimate_bound_traced(
    spec: &Spec,
    data: &ExperimentData,
    imply: bool,
) -> (Result<Outcome<f64>>, EstimateTrace) {
    let mut trace = EstimateTrace::default();
    let r = estimate_with(spec, data, imply, &mut trace);
    (r, trace)
}

fn estimate_with(
    spec: &Spec,
    data: &ExperimentData,
    imply: bool,
    trace: &mut EstimateTrace,
) -> Result<Outcome<f64>> {
    // The test's cells start two halvings coarser than the identification's. A test that
    // falsifies no bound at all (a bisected prior wide against the noise: the damper's play
    // under a diagnosis budget) is asked again with cells refined by two halvings at a time,
    // up to four finer than the identification's (a steep model needs cells whose interval
    // simulation is narrower than the noise); only then is the estimate refused.
    let h = spec.method.cells.nonlinearity_halvings;
    // A model with no bisected parameter: finer cells change nothing.
    let bisected = spec
        .model
        .layout()?
        .dims
        .iter()
        .any(|d| d.prior.radius() > 0.0);
    let levels: &[u32] = if bisected {
        &[h.saturating_sub(2), h, h + 2, h + 4]
    } else {
        &[h.saturating_sub(2)]
    };
    for &halvings in levels {
        if let Some(outcome) = estimate_at_halvings(spec, data, halvings, imply, trace)? {
            return Ok(outcome);
        }
        log::info!(target: "smid::estimate", "{}: no bound falsified with cells halved {halvings} times ({} tests run, {} implied so far)", spec.model.label(), trace.asked, trace.implied);
    }
    let floor = NO_BOUND_BELOW * data_scale(data).y_max;
    Err(SmidError::Unbounded {
        parameter: "the noise bound (noise.estimate)".into(),
        message: format!(
            "no bound down to {floor:.3e} ({NO_BOUND_BELOW:e} of the largest output) was proven inconsistent with the model: the consistency test decides nothing here (a bisected prior too wide for the cell budget, or noise-free data); give `noise.delta`, narrower `model.prior` boxes or a larger `method.cells.max_cells`"
        ),
    })
}

/// [`estimate_bound`] with the consistency test's cells at `halvings`; `None` when the test
/// falsifies no bound down to [`NO_BOUND_BELOW`] of the largest output (it decides nothing).
fn estimate_at_halvings(
    spec: &Spec,
    data: &ExperimentData,
    halvings: u32,
    imply: bool,
    trace: &mut EstimateTrace,
) -> Result<Option<Outcome<f64>>> {
    let margin = spec.noise.estimate.unwrap_or(1.1);
    let scale = data_scale(data).y_max;
    let start = 1e-3 * scale;
    let tried = bisection_bounds(start, scale);
    let known = if imply {
        known_verdicts(spec, data, halvings, &tried, trace)?
    } else {
        Vec::new()
    };
    let mut consistent_at = |d: f64| -> Result<bool> {
        if let Some(&(_, v)) = known.iter().find(|(k, _)| k.to_bits() == d.to_bits()) {
            if d.to_bits() != tried.last().map_or(0, |s| s.to_bits()) {
                trace.implied += 1;
            }
            return Ok(v);
        }
        trace.asked += 1;
        consistent_at_halvings(spec, data, d, halvings)
    };
    let mut hi = start;
    let mut lo = 0.0;
    let mut n = 0;
    while !consistent_at(hi)? {
        n += 1;
        if n > 40 {
            return Ok(Some(Outcome::Falsified(Falsification::new(
                crate::error::Stage::Linear,
                0,
                format!("no noise bound up to {hi:.3e} makes the training data consistent"),
            ))));
        }
        lo = hi;
        hi *= 2.0;
    }
    while hi - lo > 0.02 * hi && n < 60 {
        if lo == 0.0 && hi < NO_BOUND_BELOW * scale {
            // Never falsified, down to noise no sensor has: the test decides nothing here.
            return Ok(None);
        }
        let mid = 0.5 * (lo + hi);
        if consistent_at(mid)? {
            hi = mid;
        } else {
            lo = mid;
        }
        n += 1;
    }
    Ok(Some(Outcome::Consistent(margin * hi)))
}

/// The verdicts at bounds of `tried` (the bisection's bounds while every test is consistent,
/// smallest last) known from one test at the smallest (see [`estimate_bound_traced`]): that
/// verdict, and, when it is "consistent", "consistent" at every bound where the test's search
/// evaluates the same cells. Empty when fewer than three bounds would be known (the test is not
/// worth running first).
fn known_verdicts(
    spec: &Spec,
    data: &ExperimentData,
    halvings: u32,
    tried: &[f64],
    trace: &mut EstimateTrace,
) -> Result<Vec<(f64, bool)>> {
    let Some(&smallest) = tried.last() else {
        return Ok(Vec::new());
    };
    let layout = spec.model.layout()?;
    let dscale = data_scale(data);
    let cells_at = |d: f64| resolution(&spec.model, &layout, halvings, d, &dscale);
    let at_smallest = cells_at(smallest);
    // (a) the same resolution: the same splits of every cell, whatever the verdicts.
    let (same, other): (Vec<f64>, Vec<f64>) =
        tried.iter().partition(|&&d| cells_at(d) == at_smallest);
    // (b) the same cells while nothing is discarded.
    let plan = if other.is_empty() {
        Vec::new()
    } else {
        undiscarded_cells(spec, data, smallest, halvings)?
    };
    let mut planned = Vec::new();
    for &d in &other {
        if undiscarded_cells(spec, data, d, halvings)? == plan {
            planned.push(d);
        }
    }
    if same.len() + planned.len() < 3 {
        return Ok(Vec::new());
    }
    trace.asked += 1;
    let (consistent, evaluated) = tested_at(spec, data, smallest, halvings, !planned.is_empty())?;
    if !consistent {
        return Ok(vec![(smallest, false)]);
    }
    let mut known: Vec<(f64, bool)> = same.into_iter().map(|d| (d, true)).collect();
    if evaluated.is_some_and(|e| e == plan) {
        known.extend(planned.into_iter().map(|d| (d, true)));
    }
    Ok(known)
}

/// The bounds [`estimate_at_halvings`]'s bisection tries when every test is consistent:
/// `start / 2^k` from `k = 0` to the first `k` that puts it below [`NO_BOUND_BELOW`] of the
/// largest output. Empty for a start that is not a positive finite number.
fn bisection_bounds(start: f64, scale: f64) -> Vec<f64> {
    let mut out = Vec::new();
    if !(start.is_finite() && start > 0.0) {
        return out;
    }
    let mut d = start;
    out.push(d);
    while d >= NO_BOUND_BELOW * scale {
        d *= 0.5;
        out.push(d);
    }
    out
}
