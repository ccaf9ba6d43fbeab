//! The distance of a member's free run from the training records ([`training_within`]), and
//! the inner-signal estimates free runs and predictions start from.
use super::{point, ModelPoint};
use crate::error::Result;
use crate::model::{Layout, ModelSet};

/// The largest distance `max_t |y_t - ŷ_t|` over every training sample between the records and
/// the free run of the member at `values`, started at the model's first equation
/// `t0 = max(na, nb + nk)` (before it the linear block's output is the inner estimate, as
/// the model leaves it free there, and `ŷ` is that estimate measured through the member's
/// own output blocks and sensor terms). From `t0` on the run obeys the model's equation
/// (eq 1 with the effects' terms) exactly, so the member with that run is a point of the
/// model at which every training output lies within this bound: the model's **exact**
/// smallest consistent bound is at most it, whatever stage 3's relaxations say (they give the
/// lower end: a bound they falsify). `None` with steady-state points (the member's response at
/// rest is not checked here), where the run is not finite, or where the point lies outside
/// the model class (see `in_model_class`: fixed entries, the prior boxes, unit gain,
/// stability as declared). With `model.feedback` the run is [`ModelPoint::reachable_run`]:
/// its warm start takes a preimage of the measured outputs (the stage-2 centres at the first
/// cell, the outputs themselves where a sample is not inverted) as the linear block's output
/// and passes it through the output side (a level above the rim by its noise is clipped
/// there), so that every sample of it is an output of the loop and the warm start's own
/// distance counts.
pub fn training_within(set: &ModelSet, values: &[(String, f64)]) -> Result<Option<f64>> {
    if set.training.steady.is_some() {
        return Ok(None);
    }
    let layout = set.layout()?;
    // A bisected parameter a rounding step outside its prior (a degenerate prior `[1, 1]`
    // read back as 1 + 5e-14 from a cell's outward bounds) is put on it: the run below is
    // then the one of that point of the class.
    let values: Vec<(String, f64)> = values
        .iter()
        .map(|(k, v)| {
            let prior = layout.dims.iter().find(|d| d.name == *k).map(|d| d.prior);
            let v = match prior {
                Some(b) if !b.contains(*v) => {
                    let tol = 1e-9 * (1.0 + b.lo.abs().max(b.hi.abs()));
                    if *v >= b.lo - tol && *v <= b.hi + tol {
                        v.clamp(b.lo, b.hi)
                    } else {
                        *v
                    }
                }
                _ => *v,
            };
            (k.clone(), v)
        })
        .collect();
    let values = values.as_slice();
    let p = point(set, values)?;
    if !in_model_class(set, layout, values, &p) {
        return Ok(None);
    }
    let o = layout.orders;
    let t0 = o.na.max(o.nb + o.nk);
    let mut worst = 0.0f64;
    for rec in &set.training.records {
        let xd = inner_estimate(set, &p, rec)?;
        // Inside the loop the warm start is the linear block's output: a preimage of the
        // measured outputs (the stage-2 centres), the outputs themselves where none is
        // bounded (a clipped sample), so that the output side reproduces the warm start.
        let xd = if set.model.feedback {
            stage2_centres(set, rec, xd)?
        } else {
            xd
        };
        let run = p.reachable_run(&rec.u, &xd, rec.dt, t0.min(rec.y.len())).y;
        for (y, yh) in rec.y.iter().zip(&run) {
            let e = (y - yh).abs();
            if !e.is_finite() {
                return Ok(None);
            }
            worst = worst.max(e);
        }
    }
    Ok(Some(worst))
}

/// Whether the point `p` (assembled from `values`) lies in the model class the set was
/// identified in: its `θ` (as assembled: unit gain applied, fixed entries) at every fixed value,
/// inside the prior box (`model.stable`), with the static gain 1 under `unit_gain` and the roots
/// of `A` in the closed unit disc under `stable`; every bisected parameter given in `values`
/// inside its prior.
fn in_model_class(
    set: &ModelSet,
    layout: &Layout,
    values: &[(String, f64)],
    p: &ModelPoint,
) -> bool {
    let theta: Vec<f64> = p
        .linear
        .a
        .iter()
        .chain(&p.linear.b)
        .chain(&p.extras)
        .copied()
        .collect();
    let close = |x: f64, y: f64| (x - y).abs() <= 1e-9 * (1.0 + x.abs().max(y.abs()));
    let fixed_ok = layout
        .fixed
        .iter()
        .zip(&theta)
        .all(|(f, v)| f.is_none_or(|f| close(f, *v)));
    let prior_ok = layout
        .theta_prior
        .as_ref()
        .is_none_or(|b| b.iter().zip(&theta).all(|(b, v)| b.contains(*v)));
    let gain_ok = !set.model.unit_gain
        || close(
            p.linear.b.iter().sum::<f64>(),
            1.0 + p.linear.a.iter().sum::<f64>(),
        );
    let stable_ok = !set.model.stable || p.linear.spectral_radius() <= 1.0 + 1e-9;
    let psi_ok = layout.dims.iter().all(|d| {
        values
            .iter()
            .find(|(k, _)| *k == d.name)
            .is_none_or(|(_, v)| d.prior.contains(*v))
    });
    fixed_ok && prior_ok && gain_ok && stable_ok && psi_ok
}

/// The free run of the point `p` on `rec`: its first `warm` samples (at most the record) read
/// from [`inner_estimate`], the rest simulated.
pub fn free_run(
    set: &ModelSet,
    p: &ModelPoint,
    rec: &crate::pipeline::Record,
    warm: usize,
) -> Result<Vec<f64>> {
    let xd = inner_estimate(set, p, rec)?;
    Ok(
        p.predict(&rec.u, Some(&xd), rec.dt, usize::MAX, warm.min(rec.y.len()))
            .y,
    )
}

/// The inner-signal estimate a k-step predictor starts from: Hammerstein without output blocks
/// `y - s` (the centre member's sensor terms), otherwise the centres of the stage-2 bounds of
/// the first cell where inverted, the free-run inner signal elsewhere. With `model.feedback`
/// the past the loop reads: the true outputs `y - s` ([`ModelPoint::predict`]).
pub fn inner_estimate(
    model: &ModelSet,
    point: &ModelPoint,
    rec: &crate::pipeline::Record,
) -> Result<Vec<f64>> {
    let free = point.simulate(&rec.u, rec.dt);
    if model.model.feedback {
        // The loop's past outputs are measured: the true outputs behind the record at this
        // member's sensor terms.
        let s = point.sensor_terms(rec.y.len());
        return Ok(rec.y.iter().zip(&s).map(|(y, s)| y - s).collect());
    }
    // A Hammerstein model without output blocks measures the linear block's output directly.
    match model.model.structure {
        crate::nonlinearity::Structure::Hammerstein if model.model.output.is_empty() => {
            let s = point.sensor_terms(rec.y.len());
            Ok(rec.y.iter().zip(&s).map(|(y, s)| y - s).collect())
        }
        _ => stage2_centres(model, rec, free.x),
    }
}

/// The centres of the stage-2 bounds of the linear block's output on `rec` at the first cell
/// where a sample is inverted, `fallback` elsewhere (and throughout when the record
/// contradicts that cell: an output beyond its saturation limits).
fn stage2_centres(
    model: &ModelSet,
    rec: &crate::pipeline::Record,
    fallback: Vec<f64>,
) -> Result<Vec<f64>> {
    let layout = model.layout()?;
    let c = &model.cells[0];
    let sig = match crate::pipeline::stage2(
        &model.model,
        layout,
        c.nonlinearity.as_ref(),
        &c.cell,
        std::slice::from_ref(rec),
    ) {
        Ok(sig) => sig,
        Err(crate::error::SmidError::Inconsistent(_)) => return Ok(fallback),
        Err(e) => return Err(e),
    };
    Ok(sig
        .output
        .iter()
        .zip(fallback)
        .map(|(b, xf)| {
            if b.interval.is_finite() && b.kind == crate::inversion::InnerKind::Inverted {
                b.interval.center()
            } else {
                xf
            }
        })
        .collect())
}
