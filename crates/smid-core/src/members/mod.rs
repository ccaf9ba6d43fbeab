//! Members of an identified [`ModelSet`]: concrete parameter values that simulate (free run,
//! eqs 1-2 with the effects) and predict `k` steps ahead. The *central member* takes the
//! nonlinearity parameters and bisected parameters at the centre of the central cell's bounds,
//! and `θ` by least squares on the central cell's stage-2 centres (eq 28: `x^c`, `v^c`), subject
//! to the fixed coefficients, the unit gain (eq 8) and the cell's `θ` bounds, so it is a good
//! predictor even when the bound box is wide (its centre can be unstable). The
//! *axis members* put one identified parameter at an end of its bound, the others central: they
//! lie in the outer bounds, not necessarily in the feasible set, so an envelope over them is
//! indicative, not a guarantee.
use crate::effect::{self, Effect, Signals};
use crate::error::{Result, SmidError};
use crate::interval::Interval;
use crate::linear::LinearModel;
use crate::model::{Layout, ModelSet};
use crate::nonlinearity::{Nonlinearity, Structure};
use std::ops::Range;

pub mod simulation;
pub use simulation::{best_free_run, simulation_member, simulation_member_seeded};

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

/// `θ` by least squares on a cell's stage-2 centres over the training records (equations whose
/// samples were all inverted), subject to the fixed coefficients and the unit gain, inside the
/// cell's bounds (an active set). `None` when too few equations.
pub(super) fn least_squares_theta(set: &ModelSet, k: usize) -> Result<Option<Vec<f64>>> {
    let layout = set.layout()?;
    let c = &set.cells[k];
    let sig = crate::pipeline::stage2(
        &set.model,
        layout,
        c.nonlinearity.as_ref(),
        &c.cell,
        &set.training.records,
    )?;
    let o = layout.orders;
    let p = layout.p();
    let ok = |b: &crate::inversion::InnerBound| {
        b.interval.is_finite() && b.kind == crate::inversion::InnerKind::Inverted
    };
    let mut rows: Vec<(Vec<f64>, f64)> = Vec::new();
    // The past outputs the autoregressive part reads: the inner signal's (eq 1), or the
    // chain's output with `model.feedback`.
    let past = |t: usize| -> Option<f64> {
        match &sig.lagged {
            None => ok(&sig.output[t]).then(|| sig.output[t].interval.center()),
            Some(w) => w[t].is_finite().then(|| w[t].center()),
        }
    };
    for t in o.na.max(o.nb)..sig.output.len() {
        if !ok(&sig.output[t])
            || !(1..=o.na).all(|i| past(t - i).is_some())
            || !(0..=o.nb).all(|j| sig.input[t - j].is_finite())
            || !sig.extra.iter().all(|e| e.values[t].is_finite())
        {
            continue;
        }
        let mut phi = Vec::with_capacity(p);
        for i in 1..=o.na {
            phi.push(-past(t - i).unwrap_or(f64::NAN));
        }
        for j in 0..=o.nb {
            phi.push(sig.input[t - j].center());
        }
        for e in &sig.extra {
            phi.push(e.values[t].center());
        }
        rows.push((phi, sig.output[t].interval.center()));
    }
    if rows.len() < p {
        return Ok(None);
    }
    let eq = theta_equalities(set, layout);
    let (gram, rhs) = normal_equations(&rows, p);
    let cost = |th: &[f64]| squared_error(&rows, th);
    // Least squares inside the cell's bounds: an active set that clamps the worst violator
    // and releases a clamped coefficient when that lowers the cost and stays inside.
    let mut clamped: Vec<Option<f64>> = vec![None; p];
    let mut best: Option<Vec<f64>> = None;
    for _ in 0..4 * p + 4 {
        let Some(th) = constrained_ls(&gram, &rhs, &eq, &clamped) else {
            break;
        };
        let worst = (0..p)
            .filter(|&i| clamped[i].is_none())
            .map(|i| {
                let b = c.theta[i];
                let v = (b.lo - th[i]).max(th[i] - b.hi);
                (i, v)
            })
            .filter(|(_, v)| *v > 0.0)
            .max_by(|a, b| a.1.total_cmp(&b.1));
        if let Some((i, _)) = worst {
            let b = c.theta[i];
            clamped[i] = Some(th[i].clamp(b.lo, b.hi));
            continue;
        }
        best = Some(th.clone());
        let here = cost(&th);
        let release = (0..p).filter(|&i| clamped[i].is_some()).find(|&i| {
            let mut trial = clamped.clone();
            trial[i] = None;
            constrained_ls(&gram, &rhs, &eq, &trial).is_some_and(|t| {
                (0..p).all(|k| trial[k].is_some() || c.theta[k].contains(t[k])) && cost(&t) < here
            })
        });
        match release {
            Some(i) => clamped[i] = None,
            None => break,
        }
    }
    Ok(best.filter(|t| t.iter().all(|v| v.is_finite())))
}

/// The equalities every `θ` of the class satisfies: the fixed entries, and `Σb − Σa = 1` under
/// the unit gain (eq 8).
fn theta_equalities(set: &ModelSet, layout: &crate::model::Layout) -> Vec<(Vec<f64>, f64)> {
    let o = layout.orders;
    let p = layout.theta_names.len();
    let mut eq: Vec<(Vec<f64>, f64)> = Vec::new();
    for (i, f) in layout.fixed.iter().enumerate() {
        if let Some(v) = f {
            let mut g = vec![0.0; p];
            g[i] = 1.0;
            eq.push((g, *v));
        }
    }
    if set.model.unit_gain {
        let mut g = vec![0.0; p];
        g[..o.na].iter_mut().for_each(|v| *v = -1.0);
        g[o.na..=o.na + o.nb].iter_mut().for_each(|v| *v = 1.0);
        eq.push((g, 1.0));
    }
    eq
}

/// `ΦᵀΦ` and `Φᵀy` of least-squares rows `(φ, y)` with `p` regressors.
fn normal_equations(
    rows: &[(Vec<f64>, f64)],
    p: usize,
) -> (nalgebra::DMatrix<f64>, nalgebra::DVector<f64>) {
    let mut gram = nalgebra::DMatrix::<f64>::zeros(p, p);
    let mut rhs = nalgebra::DVector::<f64>::zeros(p);
    for (phi, y) in rows {
        for i in 0..p {
            rhs[i] += phi[i] * y;
            for j in 0..p {
                gram[(i, j)] += phi[i] * phi[j];
            }
        }
    }
    (gram, rhs)
}

/// `Σ (y − φ·θ)²` over the rows.
fn squared_error(rows: &[(Vec<f64>, f64)], th: &[f64]) -> f64 {
    rows.iter()
        .map(|(phi, y)| {
            let e = y - phi.iter().zip(th).map(|(a, b)| a * b).sum::<f64>();
            e * e
        })
        .sum()
}

/// `argmin |y - Φθ|²` from the normal equations subject to the equalities `eq` and the clamped
/// coefficients (KKT system, SVD).
fn constrained_ls(
    gram: &nalgebra::DMatrix<f64>,
    rhs: &nalgebra::DVector<f64>,
    eq: &[(Vec<f64>, f64)],
    clamped: &[Option<f64>],
) -> Option<Vec<f64>> {
    let p = rhs.len();
    let mut rows: Vec<(Vec<f64>, f64)> = eq.to_vec();
    for (i, c) in clamped.iter().enumerate() {
        if let Some(v) = c {
            let mut g = vec![0.0; p];
            g[i] = 1.0;
            rows.push((g, *v));
        }
    }
    let n = p + rows.len();
    let mut kkt = nalgebra::DMatrix::<f64>::zeros(n, n);
    let mut r = nalgebra::DVector::<f64>::zeros(n);
    kkt.view_mut((0, 0), (p, p)).copy_from(gram);
    r.rows_mut(0, p).copy_from(rhs);
    for (k, (g, f)) in rows.iter().enumerate() {
        for i in 0..p {
            kkt[(p + k, i)] = g[i];
            kkt[(i, p + k)] = g[i];
        }
        r[p + k] = *f;
    }
    let sol = kkt.svd(true, true).solve(&r, 1e-12).ok()?;
    Some((0..p).map(|i| sol[i]).collect())
}

/// The `θ` of `set`'s model class that best reproduces given linear-block outputs: with every
/// other parameter at `values` (by name; the chain's input side and, for Hammerstein, the
/// nonlinearity at those values), `x[r]` the linear block's output on training record `r`,
/// equation-error least squares over `θ` (eq 1 with the equation terms' columns read at
/// `x`), subject to the fixed coefficients and the unit gain. The values by name and the
/// squared equation error; zero (to rounding) exactly when the class holds a point whose
/// input side and linear block produce `x` from the records' inputs (a singular system gives
/// the least-norm solution). `None` when too few equations are usable.
pub fn theta_reproducing(
    set: &ModelSet,
    values: &[(String, f64)],
    x: &[Vec<f64>],
) -> Result<Option<(Vec<(String, f64)>, f64)>> {
    let layout = set.layout()?;
    let o = layout.orders;
    let p = layout.theta_names.len();
    let pt = point(set, values)?;
    let mut rows: Vec<(Vec<f64>, f64)> = Vec::new();
    for (r, xr) in set.training.records.iter().zip(x) {
        let n = r.u.len();
        if xr.len() != n {
            return Ok(None);
        }
        let v = pt.linear_input(&r.u);
        // The past outputs the autoregressive part reads (`model.feedback`: through the
        // output side).
        let past = if pt.feedback {
            pt.true_output(xr)
        } else {
            xr.clone()
        };
        let x_iv: Vec<Interval> = xr.iter().map(|&a| Interval::new(a, a)).collect();
        let cols: Vec<Vec<f64>> = pt
            .effects
            .iter()
            .flat_map(|e| {
                e.regressors(&Signals {
                    u: &r.u,
                    dt: r.dt,
                    x: Some(&x_iv),
                })
            })
            .map(|c| {
                c.values
                    .iter()
                    .map(|i| if i.is_finite() { i.center() } else { f64::NAN })
                    .collect()
            })
            .collect();
        for t in o.na.max(o.nb + o.nk)..n {
            let mut phi = Vec::with_capacity(p);
            phi.extend((1..=o.na).map(|i| -past[t - i]));
            phi.extend((0..=o.nb).map(|j| v[t - j]));
            phi.extend(cols.iter().map(|c| c.get(t).copied().unwrap_or(f64::NAN)));
            if phi.len() == p && phi.iter().chain([&xr[t]]).all(|a| a.is_finite()) {
                rows.push((phi, xr[t]));
            }
        }
    }
    if rows.len() < p {
        return Ok(None);
    }
    let eq = theta_equalities(set, layout);
    let (gram, rhs) = normal_equations(&rows, p);
    let Some(th) = constrained_ls(&gram, &rhs, &eq, &vec![None; p]) else {
        return Ok(None);
    };
    let sse = squared_error(&rows, &th);
    Ok(th
        .iter()
        .all(|v| v.is_finite())
        .then(|| (layout.theta_names.iter().cloned().zip(th).collect(), sse)))
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

/// The free run from rest of a model set on an input: the central member's output, inner
/// signal and nonlinearity output, and the envelope over the stable axis members (indicative,
/// not a guarantee: see [`axis_members`]).
#[derive(Debug, Clone, serde::Serialize)]
pub struct SetSimulation {
    /// The central member's output `y` (with the sensor terms, without noise).
    pub y: Vec<f64>,
    /// The central member's linear-block output `x`.
    pub x: Vec<f64>,
    /// The central member's true output `w` (before the sensor terms).
    pub w: Vec<f64>,
    /// Per-sample lowest output of the envelope's stable members (with the central one).
    pub lower: Vec<f64>,
    /// Per-sample highest output of the envelope's stable members (with the central one).
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

/// One member of a model set with concrete values.
#[derive(Debug)]
pub struct ModelPoint {
    /// Where the nonlinearity sits relative to the linear block.
    pub structure: Structure,
    /// The nonlinearity with this member's parameter values.
    pub nonlinearity: Box<dyn Nonlinearity>,
    /// The chain's blocks before the linear block (and the nonlinearity when Hammerstein).
    pub input: Vec<Box<dyn Nonlinearity>>,
    /// The chain's blocks after the nonlinearity (Wiener) or the linear block (Hammerstein).
    pub output: Vec<Box<dyn Nonlinearity>>,
    /// The linear block's `A` and `B` coefficients (the first entries of `θ`).
    pub linear: LinearModel,
    /// Input delay of the linear block, in samples.
    pub nk: usize,
    /// `model.feedback`: the autoregressive part reads the chain's output `w`, so the free run
    /// steps the output side sample by sample.
    pub feedback: bool,
    /// Coefficients of the equation terms.
    pub extras: Vec<f64>,
    /// Values of the bisected (sensor) parameters.
    pub psi: Vec<f64>,
    /// The model's effects (`model.effects`), in spec order.
    pub effects: Vec<Box<dyn Effect>>,
    /// The slice of [`ModelPoint::psi`] that belongs to each effect, in effect order.
    pub effect_cells: Vec<Range<usize>>,
}

/// A simulation: inner signal `x`, nonlinearity output `w`, and the output `y` (with the
/// sensor terms, without noise).
#[derive(Debug, Clone)]
pub struct Simulation {
    /// The linear block's output `x`.
    pub x: Vec<f64>,
    /// The true output `w`: `x` through the chain's output side (the nonlinearity under
    /// Wiener, then the output blocks), before the sensor terms.
    pub w: Vec<f64>,
    /// The measured output `y`: `w` with the sensor maps and terms, without noise.
    pub y: Vec<f64>,
}

impl ModelPoint {
    fn sensor(&self, t: usize) -> f64 {
        let cells: Vec<Vec<Interval>> = self
            .effect_cells
            .iter()
            .map(|r| {
                self.psi[r.clone()]
                    .iter()
                    .map(|&v| Interval::new(v, v))
                    .collect()
            })
            .collect();
        let slices: Vec<&[Interval]> = cells.iter().map(|c| c.as_slice()).collect();
        effect::sensor_sum(&self.effects, &slices, Some(t))
            .map(|s| s.center())
            .unwrap_or(0.0)
    }

    /// The noise-free measurements of the true outputs `w` (the sensor maps and terms at
    /// this point; [`effect::measured`]).
    fn measure(&self, w: &[f64]) -> Vec<f64> {
        let psi: Vec<&[f64]> = self
            .effect_cells
            .iter()
            .map(|r| &self.psi[r.clone()])
            .collect();
        w.iter()
            .enumerate()
            .map(|(t, &v)| effect::measured(&self.effects, &psi, t, v))
            .collect()
    }

    /// The equation-term sequence `Σ c_k φ_k(t)` of a record with the linear block's output
    /// given (`x`: regressors that read it use it), and the coefficient slices of the effects
    /// that read the output (to be evaluated online in a free run).
    fn equation_terms(&self, u: &[f64], dt: f64, x: Option<&[Interval]>) -> Vec<f64> {
        let mut d = vec![0.0; u.len()];
        let mut k = 0;
        for e in &self.effects {
            let cols = e.regressors(&Signals { u, dt, x });
            if x.is_some() || !e.uses_output() {
                for (c, col) in self.extras[k..].iter().zip(&cols) {
                    for (dv, v) in d.iter_mut().zip(&col.values) {
                        if v.is_finite() {
                            *dv += c * v.center();
                        }
                    }
                }
            }
            k += cols.len();
        }
        d
    }

    /// The terms of the effects that read the output, at sample `s` of a free run.
    fn online_terms(&self, u: &[f64], dt: f64, x: &[Interval], s: usize) -> f64 {
        let mut d = 0.0;
        let mut k = 0;
        for e in &self.effects {
            let n = e.regressors(&Signals::input(&[], dt)).len();
            if e.uses_output() {
                let vals = e.regressors_at(&Signals { u, dt, x: Some(x) }, s);
                // An unknown regressor (a velocity before the run's second sample) adds
                // nothing, as in `equation_terms`: stage 3 uses no equation there.
                d += self.extras[k..k + n]
                    .iter()
                    .zip(&vals)
                    .filter(|(_, v)| v.is_finite())
                    .map(|(c, v)| c * v)
                    .sum::<f64>();
            }
            k += n;
        }
        d
    }

    /// Whether the linear block is asymptotically stable.
    pub fn stable(&self) -> bool {
        self.linear.spectral_radius() < 1.0
    }

    /// The linear block's input on `u`: the input-side blocks, the nonlinearity when
    /// Hammerstein, then the delay `nk` (zeros before it).
    pub fn linear_input(&self, u: &[f64]) -> Vec<f64> {
        let mut v = u.to_vec();
        for b in &self.input {
            v = b.simulate(&v);
        }
        if self.structure == Structure::Hammerstein {
            v = self.nonlinearity.simulate(&v);
        }
        (0..u.len())
            .map(|t| if t >= self.nk { v[t - self.nk] } else { 0.0 })
            .collect()
    }

    /// The blocks from the linear block's output to the true output, in signal order: the
    /// nonlinearity when Wiener, then the output blocks.
    fn output_side(&self) -> Vec<&dyn Nonlinearity> {
        let mut side: Vec<&dyn Nonlinearity> = Vec::with_capacity(self.output.len() + 1);
        if self.structure == Structure::Wiener {
            side.push(self.nonlinearity.as_ref());
        }
        side.extend(self.output.iter().map(|b| b.as_ref()));
        side
    }

    /// The true output `w` of a linear-block output sequence `x` from rest.
    pub fn true_output(&self, x: &[f64]) -> Vec<f64> {
        let mut w = x.to_vec();
        for b in self.output_side() {
            w = b.simulate(&w);
        }
        w
    }

    /// Free-run simulation from rest on the input alone.
    pub fn simulate(&self, u: &[f64], dt: f64) -> Simulation {
        self.predict(u, None, dt, usize::MAX, 0)
    }

    /// The sensor terms `s_t` of this member over a record of `n` samples.
    pub fn sensor_terms(&self, n: usize) -> Vec<f64> {
        (0..n).map(|t| self.sensor(t)).collect()
    }

    /// Simulation or prediction from the input. `x_data` are estimates of the linear block's
    /// output from the measurements (Hammerstein `y - s`; Wiener the centres of the stage-2
    /// inner bounds, the free-run value where a sample was not inverted). The first `warm`
    /// samples take `x_data` as they are (the measured initial condition, as MATLAB's
    /// `compare` estimates one), then the model runs on the input alone (`k = usize::MAX`: the
    /// free run), or, for a `k`-step-ahead prediction, from `x_data` up to `t - k` for each `t`.
    /// With [`feedback`](Self::feedback) the autoregressive part reads the chain's output:
    /// `x_data` are then the measured true outputs `w` (`y - s`), the past the loop reads,
    /// and the free run steps the output side sample by sample; a `k`-step prediction starts
    /// the output side's memory where the one-step predictions up to `t - k` left it. Equation
    /// terms that read the output then read these data in a `k`-step prediction (the measured
    /// outputs, where stage 2 gives them the inner signal).
    pub fn predict(
        &self,
        u: &[f64],
        x_data: Option<&[f64]>,
        dt: f64,
        k: usize,
        warm: usize,
    ) -> Simulation {
        let n = u.len();
        let xd = x_data.filter(|d| d.len() == n);
        let (free, free_w) = self.free_run_from(u, xd, dt, warm, false);
        match xd {
            Some(x) if k < n && k > 0 => self.k_step(u, x, dt, k, warm, free, free_w),
            _ => {
                let w = if self.feedback {
                    free_w
                } else {
                    self.true_output(&free)
                };
                let yy = self.measure(&w);
                Simulation { x: free, w, y: yy }
            }
        }
    }

    /// A trajectory of the model inside the loop (`model.feedback`) whose warm start the loop
    /// reaches: for the first `warm` samples the linear block's output (free there: no
    /// equation reads it) is the data `w_data` (a preimage of the measured outputs) and the
    /// output is that value through the output side, memory included; from `warm` on the loop
    /// runs on the input. Every sample of it, the warm start included, is an output of the chain, so
    /// its distance from the records is a bound at which the model holds it
    /// ([`training_within`]). Without feedback, the free run as [`Self::predict`] gives it.
    pub fn reachable_run(&self, u: &[f64], w_data: &[f64], dt: f64, warm: usize) -> Simulation {
        if !self.feedback {
            return self.predict(u, Some(w_data), dt, usize::MAX, warm);
        }
        let xd = Some(w_data).filter(|d| d.len() == u.len());
        let (x, w) = self.free_run_from(u, xd, dt, warm, true);
        let y = self.measure(&w);
        Simulation { x, w, y }
    }

    /// The free run with its warm start: the linear block's output and, with feedback, the
    /// chain's output the loop reads. Without feedback the first `warm` samples of `x` are the
    /// data; with it the first `warm` outputs are the data as measured (`reach` false: the
    /// loop's measured past, as MATLAB's `compare` starts a run) or the data passed through
    /// the output side as the linear block's output (`reach` true: a trajectory of the model).
    fn free_run_from(
        &self,
        u: &[f64],
        xd: Option<&[f64]>,
        dt: f64,
        warm: usize,
        reach: bool,
    ) -> (Vec<f64>, Vec<f64>) {
        let n = u.len();
        let v = self.linear_input(u);
        let online = self.effects.iter().any(|e| e.uses_output());
        let na = self.linear.a.len();
        let side = self.output_side();
        // The output side stepped sample by sample (`model.feedback` reads its past).
        let step_side = |mem: &mut [Vec<f64>], x: f64| step_blocks(&side, mem, x);
        let batch = self.equation_terms(u, dt, None);
        let mut free = Vec::with_capacity(n);
        let mut free_w = Vec::with_capacity(n);
        let mut mem: Vec<Vec<f64>> = side.iter().map(|b| b.initial_memory()).collect();
        let mut free_iv: Vec<Interval> = Vec::with_capacity(n);
        for s in 0..n {
            let xs = match xd {
                Some(d) if s < warm && (!self.feedback || reach) => d[s],
                _ => {
                    let mut ds = batch[s];
                    if online {
                        ds += self.online_terms(u, dt, &free_iv, s);
                    }
                    let past = if self.feedback { &free_w } else { &free };
                    let hist: Vec<f64> = (1..=na)
                        .map(|i| if s >= i { past[s - i] } else { 0.0 })
                        .collect();
                    self.linear_step(&v, ds, s, &hist)
                }
            };
            free.push(xs);
            if self.feedback {
                let ws = step_side(&mut mem, xs);
                // The warm start reads the measured outputs (the loop's past) as they are,
                // unless the run is to be the model's own.
                free_w.push(match xd {
                    Some(d) if s < warm && !reach => d[s],
                    _ => ws,
                });
            }
            free_iv.push(Interval::new(xs, xs));
        }
        (free, free_w)
    }

    /// The k-step predictions of [`Self::predict`] from the free run `(free, free_w)`.
    #[allow(clippy::too_many_arguments)]
    fn k_step(
        &self,
        u: &[f64],
        measured_x: &[f64],
        dt: f64,
        k: usize,
        warm: usize,
        free: Vec<f64>,
        free_w: Vec<f64>,
    ) -> Simulation {
        let n = u.len();
        let v = self.linear_input(u);
        let na = self.linear.a.len();
        let side = self.output_side();
        let step_side = |mem: &mut [Vec<f64>], x: f64| step_blocks(&side, mem, x);
        let rest: Vec<Vec<f64>> = side.iter().map(|b| b.initial_memory()).collect();
        // k-step prediction; regressors that read the output read the data.
        let data_iv: Vec<Interval> = measured_x.iter().map(|&v| Interval::new(v, v)).collect();
        let d = self.equation_terms(u, dt, Some(&data_iv));
        // With feedback the past outputs are the data; the output side's memory a prediction
        // starts from is that of the one-step predictions up to there.
        let data_mem = if self.feedback {
            let mut m = rest.clone();
            let mut mems = Vec::with_capacity(n);
            for t in 0..n {
                let hist: Vec<f64> = (1..=na)
                    .map(|i| if t >= i { measured_x[t - i] } else { 0.0 })
                    .collect();
                let xt = if t < na {
                    free[t]
                } else {
                    self.linear_step(&v, d[t], t, &hist)
                };
                step_side(&mut m, xt);
                mems.push(m.clone());
            }
            mems
        } else {
            Vec::new()
        };
        let past = measured_x;
        // The first sample whose equation has its whole past in the record (the input's too).
        let first = na.max(self.linear.b.len().saturating_sub(1) + self.nk);
        let mut x = vec![0.0; n];
        let mut w_pred = if self.feedback {
            free_w.clone()
        } else {
            Vec::new()
        };
        for t in 0..n {
            // Past outputs x_{t-k-i}, i >= 0, from the data (all of them in the record); then
            // k steps of the model, the first of them at an equation with its whole past (no
            // input before the record read as zero). Before that, the free run.
            if t < k.max(warm) || t + 1 < k + first {
                x[t] = free[t];
                continue;
            }
            let start = t + 1 - k;
            let mut hist: Vec<f64> = (0..na)
                .map(|i| if start > i { past[start - 1 - i] } else { 0.0 })
                .collect();
            let mut m = match start.checked_sub(1) {
                Some(p) if self.feedback => data_mem[p].clone(),
                _ => rest.clone(),
            };
            let mut xs = 0.0;
            for s in start..=t {
                xs = self.linear_step(&v, d[s], s, &hist);
                let next = if self.feedback {
                    let ws = step_side(&mut m, xs);
                    w_pred[t] = ws;
                    ws
                } else {
                    xs
                };
                if na > 0 {
                    hist.rotate_right(1);
                    hist[0] = next;
                }
            }
            x[t] = xs;
        }
        let w = if self.feedback {
            w_pred
        } else {
            self.true_output(&x)
        };
        let yy = self.measure(&w);
        Simulation { x, w, y: yy }
    }

    /// `x_s = -Σ a_i x_{s-i} + Σ b_j v_{s-j} + d_s` with the past outputs `hist[i-1] = x_{s-i}`.
    fn linear_step(&self, v: &[f64], d: f64, s: usize, hist: &[f64]) -> f64 {
        let mut x = d;
        for (j, b) in self.linear.b.iter().enumerate() {
            if s >= j {
                x += b * v[s - j];
            }
        }
        for (a, xi) in self.linear.a.iter().zip(hist) {
            x -= a * xi;
        }
        x
    }
}

/// One sample `x` through the blocks `side` in turn, each with its memory in `mem`.
fn step_blocks(side: &[&dyn Nonlinearity], mem: &mut [Vec<f64>], x: f64) -> f64 {
    side.iter()
        .zip(mem.iter_mut())
        .fold(x, |w, (b, m)| b.step(m, w))
}

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

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use serde::{Deserialize, Serialize};

    /// `min(s, x)`: memoryless, clips from above.
    #[derive(Debug, Serialize, Deserialize)]
    struct Clip(f64);
    #[typetag::serde(name = "members_test_clip")]
    impl Nonlinearity for Clip {
        fn step(&self, _m: &mut Vec<f64>, x: f64) -> f64 {
            x.min(self.0)
        }
    }

    /// `w_t = k w_{t-1} + (1 - k) x_t`: a block with memory.
    #[derive(Debug, Serialize, Deserialize)]
    struct Lag(f64);
    #[typetag::serde(name = "members_test_lag")]
    impl Nonlinearity for Lag {
        fn initial_memory(&self) -> Vec<f64> {
            vec![0.0]
        }
        fn step(&self, m: &mut Vec<f64>, x: f64) -> f64 {
            m[0] = self.0 * m[0] + (1.0 - self.0) * x;
            m[0]
        }
    }

    fn feedback_point(rng: &mut impl Rng, with_lag: bool) -> ModelPoint {
        let na = rng.gen_range(1..=3);
        let poles: Vec<f64> = (0..na).map(|_| rng.gen_range(-0.8..0.9)).collect();
        let nb = rng.gen_range(0..=2);
        let output: Vec<Box<dyn Nonlinearity>> = if with_lag {
            vec![Box::new(Lag(rng.gen_range(0.1..0.7)))]
        } else {
            Vec::new()
        };
        ModelPoint {
            structure: Structure::Wiener,
            nonlinearity: Box::new(Clip(rng.gen_range(0.3..1.0))),
            input: Vec::new(),
            output,
            linear: LinearModel {
                a: crate::linear::from_real_poles(&poles),
                b: (0..=nb).map(|_| rng.gen_range(-1.0..1.0)).collect(),
            },
            nk: rng.gen_range(0..=2),
            feedback: true,
            extras: Vec::new(),
            psi: Vec::new(),
            effects: Vec::new(),
            effect_cells: Vec::new(),
        }
    }

    /// With feedback, a member's free run is the built-in plant's closed loop (an independent
    /// stepping of the same equations), blocks with memory included; its `k`-step prediction of
    /// memoryless blocks is the brute-force one: `k` steps from the measured past at each `t`.
    #[test]
    fn a_feedback_member_runs_the_plants_loop_and_predicts_from_the_measured_past() {
        for seed in 0..40u64 {
            let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
            let with_lag = seed % 2 == 0;
            let p = feedback_point(&mut rng, with_lag);
            let n = rng.gen_range(30..120);
            let u: Vec<f64> = (0..n).map(|_| rng.gen_range(-2.0..2.0)).collect();
            let mut plant = crate::plant::SimulatedPlant {
                linear: p.linear.clone(),
                nonlinearity: p.nonlinearity.as_ref(),
                structure: Structure::Wiener,
                input: &[],
                output: &p.output,
                effects: &[],
                dt: 1.0,
                feedback: true,
            };
            // The plant's input is the linear block's (the delay is the member's).
            let v = p.linear_input(&u);
            let truth = crate::plant::Plant::run(&mut plant, &v).unwrap();
            let sim = p.simulate(&u, 1.0);
            for t in 0..n {
                assert!(
                    (sim.y[t] - truth[t]).abs() <= 1e-12 * (1.0 + truth[t].abs()),
                    "seed {seed}, t = {t}: {} against the plant's {}",
                    sim.y[t],
                    truth[t]
                );
            }
            assert!(
                sim.y.iter().zip(&sim.x).any(|(w, x)| (w - x).abs() > 1e-9),
                "seed {seed}: the loop never clips: the test is vacuous"
            );
            if with_lag {
                continue;
            }
            // Measured outputs: the truth with noise; k steps from them.
            let y: Vec<f64> = truth
                .iter()
                .map(|w| w + rng.gen_range(-0.05..0.05))
                .collect();
            let na = p.linear.a.len();
            // Predicted from the first equation whose inputs are all in the record.
            let first = na.max(p.linear.b.len() - 1 + p.nk);
            for k in [1usize, 2, 5] {
                let pred = p.predict(&u, Some(&y), 1.0, k, 0).y;
                for t in (k + first - 1)..n {
                    let start = t + 1 - k;
                    let mut w: Vec<f64> = y[..start].to_vec();
                    for s in start..=t {
                        let mut x = 0.0;
                        for (j, b) in p.linear.b.iter().enumerate() {
                            x += b * v[s - j];
                        }
                        for (i, a) in p.linear.a.iter().enumerate() {
                            x -= a * w[s - 1 - i];
                        }
                        w.push(p.nonlinearity.simulate(&[x])[0]);
                    }
                    assert!(
                        (pred[t] - w[t]).abs() <= 1e-12 * (1.0 + w[t].abs()),
                        "seed {seed}, k = {k}, t = {t}: {} against {}",
                        pred[t],
                        w[t]
                    );
                }
            }
        }
    }
}
