//! `θ` by least squares: on a cell's stage-2 centres (the central member's), and the `θ` that
//! best reproduces given linear-block outputs ([`theta_reproducing`]).
use super::point;
use crate::effect::Signals;
use crate::error::Result;
use crate::interval::Interval;
use crate::model::ModelSet;

/// `θ` by least squares on a cell's stage-2 centres over the training records (equations whose
/// samples were all inverted), subject to the fixed coefficients and the unit gain, inside the
/// cell's bounds (an active set). `None` when too few equations.
pub(crate) fn least_squares_theta(set: &ModelSet, k: usize) -> Result<Option<Vec<f64>>> {
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
