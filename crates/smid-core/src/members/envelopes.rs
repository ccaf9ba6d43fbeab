//! Envelopes over members: the members an envelope is drawn over (certified or axis members),
//! the envelope of their runs, and a model set's free run with it ([`simulate_set`]).
use super::{central_values, point, representative, ModelPoint};
use crate::error::{Result, SmidError};
use crate::model::ModelSet;

/// The members an envelope is drawn over, and what the envelope then is: the simulation
/// member and its spread of certified members when there are any (an inner approximation of
/// the set's output range), else the axis members (indicative, see [`axis_members`]).
pub fn envelope_members(set: &ModelSet) -> (Vec<(String, ModelPoint)>, String) {
    if let Some(m) = set
        .simulation_member
        .as_ref()
        .filter(|m| !m.envelope.is_empty())
    {
        let mut out = Vec::new();
        for (i, v) in std::iter::once(&m.values).chain(&m.envelope).enumerate() {
            if let Ok(p) = point(set, v) {
                let name = if i == 0 {
                    "simulation member".to_string()
                } else {
                    format!("certified member {i}")
                };
                out.push((name, p));
            }
        }
        let stable = out.iter().filter(|(_, p)| p.stable()).count();
        let label = format!(
            "certified members: the simulation member and {} further points each proved consistent by the exact LP at fixed θ ({stable} stable of {}); their envelope is an inner approximation of the set's output range (the set's output range holds it)",
            out.len().saturating_sub(1),
            out.len()
        );
        return (out, label);
    }
    let members = axis_members(set);
    let unstable = members.iter().filter(|(_, m)| !m.stable()).count();
    let label = format!(
        "axis members: the central member and each identified parameter at its lower and upper bound ({} stable members of {}; unstable ones left out). They lie in the outer bounds, not necessarily in the feasible set: the envelope is indicative, not a guarantee",
        members.len() - unstable,
        members.len()
    );
    (members, label)
}

/// Members for an envelope: the central member and, per identified parameter, its lower and
/// upper bound with the others central. They lie in the outer bounds, not necessarily in the
/// feasible set, so their envelope is indicative, not a guarantee.
pub fn axis_members(set: &ModelSet) -> Vec<(String, ModelPoint)> {
    let Ok(base) = central_values(set) else {
        return Vec::new();
    };
    let mut out = Vec::new();
    if let Ok(c) = point(set, &base) {
        out.push(("central".to_string(), c));
    }
    for p in set.parameters.iter() {
        if !(p.upper > p.lower && p.lower.is_finite() && p.upper.is_finite()) {
            continue;
        }
        let Some(k) = base.iter().position(|(n, _)| n == &p.name) else {
            continue;
        };
        for (end, v) in [("lower", p.lower), ("upper", p.upper)] {
            let mut vals = base.clone();
            vals[k].1 = v;
            if let Ok(m) = point(set, &vals) {
                out.push((format!("{} at its {end} bound", p.name), m));
            }
        }
    }
    out
}

/// The envelope `(lower, upper)` of `centre_y` and the runs of the stable `members`
/// (`run` gives a member's output; non-finite samples of a run are left out).
pub fn envelope(
    centre_y: &[f64],
    members: &[(String, ModelPoint)],
    run: impl Fn(&ModelPoint) -> Vec<f64>,
) -> (Vec<f64>, Vec<f64>) {
    let mut lo = centre_y.to_vec();
    let mut hi = centre_y.to_vec();
    for (_, m) in members.iter().filter(|(_, m)| m.stable()) {
        for (t, v) in run(m).into_iter().enumerate().take(lo.len()) {
            if v.is_finite() {
                lo[t] = lo[t].min(v);
                hi[t] = hi[t].max(v);
            }
        }
    }
    (lo, hi)
}

/// The free run from rest of a model set on an input: the representative member's output
/// (the simulation member when one was certified, else the centre: [`super::representative`]),
/// inner signal and nonlinearity output, and the envelope over the stable axis members (indicative,
/// not a guarantee: see [`axis_members`]).
#[derive(Debug, Clone, serde::Serialize)]
pub struct SetSimulation {
    /// The representative member's output `y` (with the sensor terms, without noise).
    pub y: Vec<f64>,
    /// The representative member's linear-block output `x`.
    pub x: Vec<f64>,
    /// The representative member's true output `w` (before the sensor terms).
    pub w: Vec<f64>,
    /// Per-sample lowest output of the envelope's stable members (with the representative one).
    pub lower: Vec<f64>,
    /// Per-sample highest output of the envelope's stable members (with the representative one).
    pub upper: Vec<f64>,
    /// Stable members in the envelope.
    pub stable_members: usize,
    /// All members of the envelope, stable or not.
    pub members: usize,
    /// What the envelope is made of ([`envelope_members`]).
    pub envelope: String,
}

/// Simulate a model set from rest on the input `u` (sample time `dt`): see [`SetSimulation`].
/// Non-finite inputs are an error naming the sample.
pub fn simulate_set(set: &ModelSet, u: &[f64], dt: f64) -> Result<SetSimulation> {
    if let Some(t) = u.iter().position(|v| !v.is_finite()) {
        return Err(SmidError::invalid(
            format!("input sample {t}"),
            format!("{} is not a finite number", u[t]),
        ));
    }
    if !(dt.is_finite() && dt > 0.0) {
        return Err(SmidError::invalid(
            "dt",
            format!("{dt}: expected a positive sample time"),
        ));
    }
    let c = representative(set)?;
    let sim = c.simulate(u, dt);
    let (members, label) = envelope_members(set);
    let (lower, upper) = envelope(&sim.y, &members, |m| m.simulate(u, dt).y);
    Ok(SetSimulation {
        envelope: label,
        stable_members: members.iter().filter(|(_, m)| m.stable()).count(),
        members: members.len(),
        y: sim.y,
        x: sim.x,
        w: sim.w,
        lower,
        upper,
    })
}
