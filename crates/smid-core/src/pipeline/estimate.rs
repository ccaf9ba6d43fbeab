//! Noise-bound estimation (`noise.estimate`): the smallest bound at which the training data are
//! consistent with the model (by the branch and bound's cheap test), times a margin (eq 5).
use super::*;
use crate::cells::{self, Budget};
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
    let prior: Vec<Interval> = layout.dims.iter().map(|d| d.prior).collect();
    let scale = data_scale(&data);
    // Coarser than the identification's cells: a test that cannot discard a coarse cell only
    // lowers the estimate, which the identification then raises by the margin if needed.
    let resolution = resolution(&spec.model, &layout, halvings, d, &scale);
    let test = |c: &[Interval]| test_cell(&spec.model, &layout, &spec.method, &training, c);
    match cells::search(
        &prior,
        Budget {
            resolution,
            depth: spec.method.cells.depth,
            // A consistency test stopped early keeps its cells: it can only say "consistent"
            // too soon, which lowers the estimate (raised again by the margin if needed).
            max_cells: spec.method.cells.max_cells.min(500),
            max_leaves: 500,
        },
        &test,
        &test,
        &|_| {},
    ) {
        Ok(Outcome::Consistent(s)) => Ok(!s.leaves.is_empty()),
        Ok(Outcome::Falsified(_)) => Ok(false),
        Err(e) => Err(e),
    }
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
        if let Some(outcome) = estimate_at_halvings(spec, data, halvings)? {
            return Ok(outcome);
        }
        log::info!(target: "smid::estimate", "{}: no bound falsified with cells halved {halvings} times", spec.model.label());
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
) -> Result<Option<Outcome<f64>>> {
    let consistent_at = |d: f64| consistent_at_halvings(spec, data, d, halvings);
    let margin = spec.noise.estimate.unwrap_or(1.1);
    let dscale = data_scale(data);
    let scale = dscale.y_max;
    let start = 1e-3 * scale;
    // The bounds the bisection below tries when every test is consistent, down to the
    // smallest. Where the cells' resolution is the same at all of them (no bisected parameter
    // whose resolution follows the bound, as a sensor offset's 0.5Δ), the test is monotone in
    // the bound: a smaller bound shrinks every cell's outer set, so a cell kept there is kept
    // at every larger bound, and its search tree (the same splits) is a subtree of theirs. So
    // when the smallest is consistent, every larger one is too: the level decides nothing,
    // and one test says so instead of twenty. Elsewhere the bisection runs as it always did.
    let tried = bisection_bounds(start, scale);
    let layout = spec.model.layout()?;
    let cells_at = |d: f64| resolution(&spec.model, &layout, halvings, d, &dscale);
    let same_cells = tried.iter().all(|&d| cells_at(d) == cells_at(start));
    if let (true, Some(&smallest)) = (same_cells, tried.last()) {
        if consistent_at(smallest)? {
            return Ok(None);
        }
    }
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
