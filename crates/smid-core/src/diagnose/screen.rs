//! The reproduction screen: candidates whose outputs the base model's class reproduces exactly
//! are not identified ([`reproduced_by_base`], [`screen_reproduced`]).
use super::comparison::{max_deviation, spread};
use super::verdict::{Evidence, TrainVerdict};
use super::AS_DECLARED;
use crate::model::ModelSet;
use crate::spec::ModelSpec;

/// Interior draws of a candidate's added parameters in [`reproduced_by_base`], as fractions of
/// each prior box (rotated over the parameters), beside the box's corners.
const REPRODUCTION_DRAWS: [f64; 3] = [0.25, 0.6, 0.9];

/// At most this many added parameters are screened (their box has `2^k` corners).
const SCREENED_DIMS: usize = 6;

/// A base model's equation reproduces a candidate's free run when the root of its summed
/// squared least-squares error is at most this fraction of the run's range (rounding, against
/// effects of at least a thousandth: [`ACTIVE`]).
const REPRODUCED: f64 = 1e-8;

/// A draw tells something only when the candidate's free run moves away from the base model's
/// own by more than this fraction of its range; at least one draw must.
const ACTIVE: f64 = 1e-3;

/// Mark the candidates whose outputs the base model's class reproduces exactly
/// ([`reproduced_by_base`]): they are not identified, their verdict says why, and they are
/// listed as equivalent to the round's base model.
pub(super) fn screen_reproduced(base: &ModelSet, cands: &mut [(ModelSpec, Evidence)]) {
    use rayon::prelude::*;
    cands.par_iter_mut().for_each(|(m, ev)| {
        if ev.untried.is_some() {
            return;
        }
        if let Some((residual, draws)) = reproduced_by_base(base, m) {
            log::info!(target: "smid::diagnose", "{}: reproduced by the base model (equation error {residual:.1e} of the range at {draws} draws): not identified", ev.label);
            ev.untried = Some(TrainVerdict::Reproduced { residual, draws });
            ev.equivalent_to.push(AS_DECLARED.into());
        }
    });
}

/// Whether the class of `base` (identified, consistent) holds the candidate class `cand`'s
/// free runs on the training inputs, by sampling: the candidate at the base model's
/// representative values with its added bisected parameters at every corner of their prior box
/// and at three draws inside it (at the fractions 0.25, 0.6 and 0.9 of each box, rotated over
/// the parameters), simulated from rest; the base model's `θ` refitted to each run by
/// equation-error least squares ([`crate::members::theta_reproducing`]).
/// `Some((largest error / range, draws))` when some draw moves the run (by more than `1e-3`
/// of its range) and every refit reproduces its run (the root of its summed squared error at
/// most `1e-8` of the run's range): a sensor offset, or a bias before or after the
/// linear block, beside a constant term. Where the class does hold the candidate's runs, every
/// noise sequence consistent with the candidate is consistent with the base model at the same
/// bound (the equation holds sample by sample), so the candidate's exact smallest consistent
/// bound is not below the base model's. The corners are there for blocks that are affine on
/// the data over part of their prior only (a dead zone whose thresholds stay below the inputs
/// shifts them; at the prior's end it cuts the smallest); the sampling is evidence, not a
/// proof, and a block that is affine on the data at every draw but not between them would be
/// screened wrongly.
///
/// Only a base whose output is its linear block's (no bisected parameter, no chain block, and
/// a Wiener base's nonlinearity passing every candidate run unchanged) and a candidate with the
/// same `θ` names (no order or equation term added) are compared; any other pair, or any draw
/// that fails, gives `None` and the candidate is identified as before.
pub fn reproduced_by_base(base: &ModelSet, cand: &ModelSpec) -> Option<(f64, usize)> {
    let bl = base.layout().ok()?;
    let cl = cand.layout().ok()?;
    if !bl.dims.is_empty() || !bl.blocks.is_empty() || cl.theta_names != bl.theta_names {
        return None;
    }
    let values = crate::members::representative_values(base).ok()?;
    let bp = crate::members::point(base, &values).ok()?;
    let records = &base.training.records;
    let own: Vec<Vec<f64>> = records.iter().map(|r| bp.simulate(&r.u, r.dt).y).collect();
    let added: Vec<&crate::model::CellDim> = cl
        .dims
        .iter()
        .filter(|d| !values.iter().any(|(k, _)| *k == d.name))
        .collect();
    if added.is_empty() || added.len() > SCREENED_DIMS || added.iter().any(|d| !d.prior.is_finite())
    {
        return None;
    }
    let corners = (0..1usize << added.len()).map(|c| {
        (0..added.len())
            .map(|j| if c >> j & 1 == 1 { 1.0 } else { 0.0 })
            .collect::<Vec<f64>>()
    });
    let inside = (0..REPRODUCTION_DRAWS.len()).map(|k| {
        (0..added.len())
            .map(|j| REPRODUCTION_DRAWS[(k + j) % REPRODUCTION_DRAWS.len()])
            .collect::<Vec<f64>>()
    });
    let mut worst: f64 = 0.0;
    let mut moved = false;
    let mut draws = 0;
    for fractions in corners.chain(inside) {
        let mut v = values.clone();
        for (d, f) in added.iter().zip(&fractions) {
            v.push((d.name.clone(), d.prior.lo + f * (d.prior.hi - d.prior.lo)));
        }
        let cp = crate::members::point_of_spec(cand, &v).ok()?;
        let runs: Vec<Vec<f64>> = records.iter().map(|r| cp.simulate(&r.u, r.dt).y).collect();
        let r = spread(runs.iter().flatten());
        if !(r.is_finite() && r > 0.0) {
            return None;
        }
        // A Wiener base reads its output through its nonlinearity: it must pass the run.
        if base.model.structure == crate::nonlinearity::Structure::Wiener
            && runs.iter().any(|y| {
                max_deviation(&[bp.nonlinearity.simulate(y)], std::slice::from_ref(y), 0)
                    > 1e-12 * r
            })
        {
            return None;
        }
        moved |= max_deviation(&runs, &own, 0) > ACTIVE * r;
        let (_, sse) = crate::members::theta_reproducing(base, &values, &runs).ok()??;
        // The whole error, not a mean over rows: rows the refit could not use only lower it.
        let error = sse.sqrt() / r;
        if !(error <= REPRODUCED) {
            return None;
        }
        worst = worst.max(error);
        draws += 1;
    }
    moved.then_some((worst, draws))
}
