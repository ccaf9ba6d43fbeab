//! Members of an identified [`ModelSet`]: concrete parameter values that simulate (free run,
//! eqs 1-2 with the effects) and predict `k` steps ahead. The *central member* takes the
//! nonlinearity parameters and bisected parameters at the centre of the central cell's bounds,
//! and `θ` by least squares on the central cell's stage-2 centres (eq 28: `x^c`, `v^c`), subject
//! to the fixed coefficients, the unit gain (eq 8) and the cell's `θ` bounds, so it is a good
//! predictor even when the bound box is wide (its centre can be unstable). The
//! *axis members* put one identified parameter at an end of its bound, the others central: they
//! lie in the outer bounds, not necessarily in the feasible set, so an envelope over them is
//! indicative, not a guarantee.
//!
//! The central and representative members are here; a member's runs in `model_point`
//! ([`ModelPoint`]), the least-squares `θ` in `least_squares`, envelopes in `envelopes`, the
//! free run's distance from the training records in `within` ([`training_within`]), and the
//! simulation member's search in [`simulation`].
use crate::error::{Result, SmidError};
use crate::interval::Interval;
use crate::linear::LinearModel;
use crate::model::ModelSet;

mod envelopes;
mod least_squares;
mod model_point;
pub mod simulation;
mod within;

pub use envelopes::{axis_members, envelope, envelope_members, simulate_set, SetSimulation};
pub(crate) use least_squares::least_squares_theta;
pub use least_squares::theta_reproducing;
pub use model_point::{ModelPoint, Simulation};
pub use simulation::{best_free_run, certificate_on, simulation_member, simulation_member_seeded};
pub use within::{free_run, inner_estimate, training_within};

/// The cells of a model set from the centre of the bisected parameters outwards: by the
/// distance of each cell's centre to the centre of the hull (relative to the hull's widths),
/// the cells with bounded `θ` first (a cell the budget left unbounded has no member to offer).
pub fn cells_from_centre(set: &ModelSet) -> Vec<usize> {
    let hull = crate::cells::hull_of_boxes(set.cells.iter().map(|c| c.cell.as_slice()));
    let dist = |k: usize| -> f64 {
        set.cells[k]
            .cell
            .iter()
            .zip(&hull)
            .map(|(c, h)| {
                let w = (h.hi - h.lo).max(f64::MIN_POSITIVE);
                ((c.center() - h.center()) / w).powi(2)
            })
            .sum()
    };
    let mut order: Vec<usize> = (0..set.cells.len()).collect();
    order.sort_by(|&a, &b| {
        (!set.cells[a].bounded())
            .cmp(&!set.cells[b].bounded())
            .then(dist(a).total_cmp(&dist(b)))
    });
    order
}

/// The index of the central cell: the one whose centre is nearest the centre of the hull of
/// the bisected parameters (relative to the hull's widths).
pub fn central_cell(set: &ModelSet) -> usize {
    cells_from_centre(set).first().copied().unwrap_or(0)
}

/// The central member's values, by name: the central cell's nonlinearity parameters and
/// bisected parameters at their centres, `θ` by least squares on its stage-2 centres (the
/// centres of its `θ` bounds when that fails).
pub fn central_values(set: &ModelSet) -> Result<Vec<(String, f64)>> {
    let layout = set.layout()?;
    if set.cells.is_empty() {
        return Err(SmidError::invalid(
            "model set",
            "has no cell (nothing survived identification)",
        ));
    }
    let k = central_cell(set);
    let c = &set.cells[k];
    let mut v: Vec<(String, f64)> = c
        .nonlinearity
        .parameters()
        .iter()
        .map(|b| (b.name.clone(), finite_centre(b.interval)))
        .collect();
    let theta = least_squares_theta(set, k)?
        .unwrap_or_else(|| c.theta.iter().map(|i| finite_centre(*i)).collect());
    v.extend(layout.theta_names.iter().cloned().zip(theta));
    v.extend(
        layout
            .dims
            .iter()
            .zip(&c.cell)
            .map(|(d, i)| (d.name.clone(), i.center())),
    );
    Ok(v)
}

/// The central member (see the module doc).
pub fn centre(set: &ModelSet) -> Result<ModelPoint> {
    point(set, &central_values(set)?)
}

/// The member that stands for the set in free runs, predictions and plots: the simulation
/// member when one was certified ([`simulation`]), else the central member (uncertified).
pub fn representative(set: &ModelSet) -> Result<ModelPoint> {
    point(set, &representative_values(set)?)
}

/// The parameter values of [`representative`], by name.
pub fn representative_values(set: &ModelSet) -> Result<Vec<(String, f64)>> {
    match &set.simulation_member {
        Some(m) => Ok(m.values.clone()),
        None => central_values(set),
    }
}

/// Which member [`representative`] gives, in words.
pub fn representative_label(set: &ModelSet) -> &'static str {
    match &set.simulation_member {
        Some(m) if m.certified => {
            "the simulation member (certified consistent, best training free run)"
        }
        Some(_) => "the best training free run within the outer bounds (NOT certified: no point of the set was proven consistent within the search budget)",
        None => "the central member (no certified member found)",
    }
}

/// A member with the given parameter values (by name; missing ones at the centre).
pub fn point(set: &ModelSet, values: &[(String, f64)]) -> Result<ModelPoint> {
    let layout = set.layout()?;
    let get = |n: &str| {
        values
            .iter()
            .find(|(k, _)| k == n)
            .map(|(_, v)| *v)
            .or_else(|| set.parameter(n).map(|p| finite_centre(p.interval())))
    };
    let cell0 = set.cells.first().ok_or_else(|| {
        SmidError::invalid("model set", "has no cell (nothing survived identification)")
    })?;
    let gamma: Vec<(String, f64)> = cell0
        .nonlinearity
        .parameters()
        .iter()
        .map(|b| (b.name.clone(), get(&b.name).unwrap_or(b.interval.center())))
        .collect();
    assemble(&set.model, layout, gamma, &get)
}

/// A point of the model class `model` before any identification: every parameter by name from
/// `values`, a bisected one left out at the centre of its prior, a `θ` entry left out at zero
/// (its fixed value where `model.fixed` gives one). The nonlinearity's parameters (those of
/// its registered simulation plugin) must all be given. What a diagnosis simulates a candidate
/// class at before it is identified.
pub fn point_of_spec(
    model: &crate::spec::ModelSpec,
    values: &[(String, f64)],
) -> Result<ModelPoint> {
    let layout = model.layout()?;
    let get = |n: &str| values.iter().find(|(k, _)| k == n).map(|(_, v)| *v);
    let tag = model.nonlinearity_tag();
    let gamma = crate::registry::parameter_names(&tag)
        .into_iter()
        .map(|n| {
            let v = get(&n).ok_or_else(|| {
                SmidError::invalid(
                    "values",
                    format!("no value for `{n}`, a parameter of the nonlinearity `{tag}`"),
                )
            })?;
            Ok((n, v))
        })
        .collect::<Result<Vec<_>>>()?;
    assemble(model, &layout, gamma, &get)
}

/// The member of `model` with its nonlinearity at `gamma` and every other parameter from `get`
/// (the chain's blocks and bisected parameters at their prior centres, `θ` at zero, where it
/// gives none), the fixed coefficients and the unit gain (eq 8) applied.
fn assemble(
    model: &crate::spec::ModelSpec,
    layout: &crate::model::Layout,
    gamma: Vec<(String, f64)>,
    get: &dyn Fn(&str) -> Option<f64>,
) -> Result<ModelPoint> {
    let nonlinearity = crate::registry::instantiate(&model.nonlinearity_tag(), &gamma)?;
    // The chain's other blocks at their values (`in1.c_l` -> the plugin's `c_l`).
    let mut input = Vec::new();
    let mut output = Vec::new();
    for b in &layout.blocks {
        let vals: Vec<(String, f64)> = layout.dims[b.cells.clone()]
            .iter()
            .map(|d| {
                let short = d.name[b.prefix.len() + 1..].to_string();
                (short, get(&d.name).unwrap_or(d.prior.center()))
            })
            .collect();
        let block = crate::registry::instantiate(&b.tag, &vals)?;
        match b.side {
            crate::chain::Side::Input => input.push(block),
            crate::chain::Side::Output => output.push(block),
        }
    }
    let o = layout.orders;
    let mut theta: Vec<f64> = layout
        .theta_names
        .iter()
        .zip(&layout.fixed)
        .map(|(n, f)| get(n).or(*f).unwrap_or(0.0))
        .collect();
    if model.unit_gain {
        // Σb − Σa = 1 (eq 8): spread the defect over the free b's.
        let free_b: Vec<usize> = (o.na..=o.na + o.nb)
            .filter(|&k| layout.fixed[k].is_none())
            .collect();
        if !free_b.is_empty() {
            let defect = 1.0 + theta[..o.na].iter().sum::<f64>()
                - theta[o.na..=o.na + o.nb].iter().sum::<f64>();
            for &k in &free_b {
                theta[k] += defect / free_b.len() as f64;
            }
        }
    }
    let psi: Vec<f64> = layout
        .dims
        .iter()
        .map(|d| get(&d.name).unwrap_or(d.prior.center()))
        .collect();
    Ok(ModelPoint {
        structure: model.structure,
        nonlinearity,
        input,
        output,
        linear: LinearModel {
            a: theta[..o.na].to_vec(),
            b: theta[o.na..=o.na + o.nb].to_vec(),
        },
        nk: o.nk,
        feedback: model.feedback,
        extras: theta[o.na + o.nb + 1..].to_vec(),
        psi,
        effects: model.effects.clone(),
        effect_cells: layout.effect_cells.clone(),
    })
}

/// The centre of an interval, or its finite end when the other is infinite (a saturation
/// limit never reached is `[lo, inf)`: its member is the largest finite value).
pub(super) fn finite_centre(i: Interval) -> f64 {
    match (i.lo.is_finite(), i.hi.is_finite()) {
        (true, true) => i.center(),
        (true, false) => f64::MAX.min(i.lo.abs().max(1.0) * 1e6),
        (false, true) => -f64::MAX.max(-i.hi.abs().max(1.0) * 1e6),
        (false, false) => 0.0,
    }
}

#[cfg(test)]
mod tests;
