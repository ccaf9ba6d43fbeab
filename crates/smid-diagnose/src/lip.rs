//! Linear-in-parameters (LIP) model sets under an ℓ∞ equation-error bound: the regression
//! `y_t = φ_t θ + e_t`, `|e_t| <= Δ` built from the orders and the effects' columns (linearly
//! dependent columns are dropped and named), the minimax (Chebyshev) fit — the smallest Δ for
//! which the data are consistent with the structure, an LP — the guaranteed parameter box of the
//! feasible set `{θ : |y - Φθ| <= Δ}` (LP engine `smid_core::lp`), least squares for fast
//! hyper-parameter searches, and the interval prediction band of a parameter box.
use crate::effect::{lag, Effect, Orders, Record};
use crate::DiagError;
use good_lp::{solvers::clarabel::clarabel, Expression, ProblemVariables, Solution, SolverModel};
use smid_core::interval::Interval;
use smid_core::lp::{LpOutcome, Polytope};

/// Rows before this sample are not fitted (see [`Structure::start`]).
pub const START_FLOOR: usize = 8;

/// A model structure: base orders plus effects.
#[derive(Debug, Clone)]
pub struct Structure {
    pub base: Orders,
    pub effects: Vec<Box<dyn Effect>>,
}

/// Regression rows stacked over records, with the column names kept after the rank check.
#[derive(Debug, Clone)]
pub struct Regression {
    pub names: Vec<String>,
    /// Rows `φ_t` (kept columns only).
    pub phi: Vec<Vec<f64>>,
    pub y: Vec<f64>,
    /// `(record, t)` of each row.
    pub at: Vec<(usize, usize)>,
    /// Columns dropped as linearly dependent on earlier ones.
    pub dropped: Vec<String>,
}

impl Structure {
    /// The orders after every effect's change.
    pub fn orders(&self) -> Orders {
        let mut o = self.base;
        for e in &self.effects {
            e.augment_orders(&mut o);
        }
        o
    }

    /// First sample with every regressor defined (two more than the largest lag, for
    /// velocities of lagged signals), and at least [`START_FLOOR`], so that structures of
    /// small orders are compared on the same rows.
    pub fn start(&self) -> usize {
        (self.orders().max_lag() + 2).max(START_FLOOR)
    }

    /// Full-length named columns of one record. Input maps apply in order: the base input
    /// regressors and the effects after a map read the mapped input.
    pub fn columns(&self, rec: &Record) -> Vec<(String, Vec<f64>)> {
        let o = self.orders();
        let n = rec.y.len();
        let mut cols = Vec::new();
        for i in 1..=o.na {
            cols.push((
                format!("a{i}"),
                (0..n).map(|t| -lag(&rec.y, t, i)).collect(),
            ));
        }
        let mut view = rec.clone();
        for e in &self.effects {
            if let Some(m) = e.map_input(&view.u) {
                view.u = m;
            }
        }
        for j in 0..o.nb {
            cols.push((
                format!("b{j}"),
                (0..n).map(|t| lag(&view.u, t, o.nk + j)).collect(),
            ));
        }
        let mut view = rec.clone();
        for e in &self.effects {
            if let Some(m) = e.map_input(&view.u) {
                view.u = m;
            }
            for c in e.columns(&view, &o) {
                cols.push((c.name, c.values));
            }
        }
        cols
    }

    /// The stacked regression over records, dependent columns dropped.
    pub fn regression(&self, recs: &[Record]) -> Result<Regression, DiagError> {
        let s = self.start();
        let mut names = Vec::new();
        let mut colv: Vec<Vec<f64>> = Vec::new();
        let mut y = Vec::new();
        let mut at = Vec::new();
        for (ri, rec) in recs.iter().enumerate() {
            if rec.y.len() <= s + 2 {
                return Err(DiagError::Data {
                    file: rec.name.clone().into(),
                    message: format!(
                        "{} samples, fewer than the {} lags need",
                        rec.y.len(),
                        s + 3
                    ),
                });
            }
            let cols = self.columns(rec);
            if ri == 0 {
                names = cols.iter().map(|c| c.0.clone()).collect();
                colv = vec![Vec::new(); cols.len()];
            }
            for (k, (_, v)) in cols.iter().enumerate() {
                colv[k].extend_from_slice(&v[s..]);
            }
            y.extend_from_slice(&rec.y[s..]);
            at.extend((s..rec.y.len()).map(|t| (ri, t)));
        }
        for (k, c) in colv.iter().enumerate() {
            if let Some(i) = c.iter().position(|v| !v.is_finite()) {
                return Err(DiagError::Invalid(format!(
                    "regressor `{}` is not finite at row {i}",
                    names[k]
                )));
            }
        }
        // Modified Gram-Schmidt: drop columns (nearly) in the span of the earlier ones.
        let mut q: Vec<Vec<f64>> = Vec::new();
        let mut keep = Vec::new();
        let mut dropped = Vec::new();
        for (k, c) in colv.iter().enumerate() {
            let n0 = norm(c);
            let mut v = c.clone();
            for qi in &q {
                let d = dot(&v, qi);
                v.iter_mut().zip(qi).for_each(|(a, b)| *a -= d * b);
            }
            let n1 = norm(&v);
            if n0 > 0.0 && n1 > 1e-7 * n0 {
                v.iter_mut().for_each(|a| *a /= n1);
                q.push(v);
                keep.push(k);
            } else {
                dropped.push(names[k].clone());
            }
        }
        let phi = (0..y.len())
            .map(|t| keep.iter().map(|&k| colv[k][t]).collect())
            .collect();
        Ok(Regression {
            names: keep.iter().map(|&k| names[k].clone()).collect(),
            phi,
            y,
            at,
            dropped,
        })
    }

    /// Rows of a record for a fixed set of column names (held-out data: the training fit's
    /// columns, in its order; a column the record lacks is zero).
    pub fn rows_for(&self, rec: &Record, names: &[String]) -> (Vec<Vec<f64>>, Vec<f64>, usize) {
        let s = self.start().min(rec.y.len());
        let cols = self.columns(rec);
        let idx: Vec<Option<usize>> = names
            .iter()
            .map(|n| cols.iter().position(|c| &c.0 == n))
            .collect();
        let phi = (s..rec.y.len())
            .map(|t| {
                idx.iter()
                    .map(|i| i.map(|i| cols[i].1[t]).unwrap_or(0.0))
                    .collect()
            })
            .collect();
        (phi, rec.y[s..].to_vec(), s)
    }
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}
fn norm(a: &[f64]) -> f64 {
    dot(a, a).sqrt()
}

/// Column scales (RMS, 1 if zero) and the output scale, for conditioning.
fn scales(phi: &[Vec<f64>], y: &[f64]) -> (Vec<f64>, f64) {
    let p = phi.first().map(|r| r.len()).unwrap_or(0);
    let n = phi.len().max(1) as f64;
    let cs = (0..p)
        .map(|k| {
            let s = (phi.iter().map(|r| r[k] * r[k]).sum::<f64>() / n).sqrt();
            if s > 0.0 {
                s
            } else {
                1.0
            }
        })
        .collect();
    let ys = (y.iter().map(|v| v * v).sum::<f64>() / n).sqrt();
    (cs, if ys > 0.0 { ys } else { 1.0 })
}

/// Least squares `argmin |y - Φθ|_2` (SVD, scaled columns).
pub fn least_squares(phi: &[Vec<f64>], y: &[f64]) -> Vec<f64> {
    let p = phi.first().map(|r| r.len()).unwrap_or(0);
    if p == 0 {
        return Vec::new();
    }
    let (cs, ys) = scales(phi, y);
    let mut ata = nalgebra::DMatrix::<f64>::zeros(p, p);
    let mut aty = nalgebra::DVector::<f64>::zeros(p);
    for (r, yv) in phi.iter().zip(y) {
        for i in 0..p {
            let ri = r[i] / cs[i];
            aty[i] += ri * yv / ys;
            for j in 0..p {
                ata[(i, j)] += ri * r[j] / cs[j];
            }
        }
    }
    let th = ata
        .svd(true, true)
        .solve(&aty, 1e-12)
        .unwrap_or_else(|_| nalgebra::DVector::zeros(p));
    (0..p).map(|k| th[k] / cs[k] * ys).collect()
}

/// The minimax fit: `min_θ max_t |y_t - φ_t θ|` by LP. Returns `(θ, Δ*)`, where `Δ*` is the
/// maximum residual that the returned `θ` achieves (an upper bound of the minimax value, equal
/// to it up to the solver's tolerance). When clarabel fails numerically, the LP is retried with
/// sturdier settings, and then the least-squares `θ` is used: its achieved maximum residual is
/// still a valid (larger) consistent noise bound.
pub fn minimax(phi: &[Vec<f64>], y: &[f64]) -> Result<(Vec<f64>, f64), DiagError> {
    let theta = match minimax_lp(phi, y, false).or_else(|_| minimax_lp(phi, y, true)) {
        Ok(theta) => theta,
        Err(_) => least_squares(phi, y),
    };
    // Report the achieved maximum residual (exact for the returned θ).
    let dstar = phi
        .iter()
        .zip(y)
        .map(|(r, yv)| (yv - dot(r, &theta)).abs())
        .fold(0.0, f64::max);
    Ok((theta, dstar))
}

fn minimax_lp(phi: &[Vec<f64>], y: &[f64], sturdy: bool) -> Result<Vec<f64>, DiagError> {
    let p = phi.first().map(|r| r.len()).unwrap_or(0);
    let (cs, ys) = scales(phi, y);
    let mut vars = ProblemVariables::new();
    let th: Vec<_> = (0..p).map(|_| vars.add(good_lp::variable())).collect();
    let d = vars.add(good_lp::variable().min(0.0));
    let mut prob = clarabel(vars.minimise(d));
    let tol = if sturdy { 1e-8 } else { 1e-10 };
    prob.settings()
        .tol_gap_abs(tol)
        .tol_gap_rel(tol.max(1e-9))
        .tol_feas(tol)
        .max_iter(if sturdy { 2000 } else { 300 })
        .presolve_enable(true);
    if sturdy {
        prob.settings()
            .static_regularization_constant(1e-7)
            .equilibrate_max_iter(50);
    }
    for (r, yv) in phi.iter().zip(y) {
        let e: Expression = r
            .iter()
            .zip(&th)
            .zip(&cs)
            .filter(|((c, _), _)| **c != 0.0)
            .map(|((c, v), s)| (*c / *s) * *v)
            .sum();
        let yt = yv / ys;
        prob = prob.with((e.clone() - d).leq(yt));
        prob = prob.with((-e - d).leq(-yt));
    }
    let sol = prob
        .solve()
        .map_err(|e| DiagError::Core(smid_core::SmidError::Solver(e.to_string())))?;
    Ok((0..p).map(|k| sol.value(th[k]) / cs[k] * ys).collect())
}

/// Guaranteed bounds of every parameter over `{θ : |y - Φθ| <= Δ}`; `None` when the set is
/// empty (the data are inconsistent with the structure at this bound).
pub fn parameter_box(
    phi: &[Vec<f64>],
    y: &[f64],
    delta: f64,
) -> Result<Option<Vec<Interval>>, DiagError> {
    let p = phi.first().map(|r| r.len()).unwrap_or(0);
    let (cs, ys) = scales(phi, y);
    let mut poly = Polytope::new(p);
    let dl = delta / ys;
    for (t, (r, yv)) in phi.iter().zip(y).enumerate() {
        let g: Vec<f64> = r.iter().zip(&cs).map(|(c, s)| c / s).collect();
        let yt = yv / ys;
        poly.le.push((g.clone(), yt + dl, t));
        poly.le.push((g.iter().map(|v| -v).collect(), -yt + dl, t));
    }
    let all: Vec<usize> = (0..p).collect();
    match poly.bound(&all)? {
        LpOutcome::Infeasible => Ok(None),
        LpOutcome::Bounds(b) => Ok(Some(
            b.iter()
                .zip(&cs)
                .map(|(iv, s)| {
                    let (a, c) = (iv.lo / s * ys, iv.hi / s * ys);
                    Interval::new(a.min(c), a.max(c))
                })
                .collect(),
        )),
    }
}

/// Residuals `y - Φθ`.
pub fn residuals(phi: &[Vec<f64>], y: &[f64], theta: &[f64]) -> Vec<f64> {
    phi.iter().zip(y).map(|(r, v)| v - dot(r, theta)).collect()
}

/// The interval hull `φ_t · box` of the one-step predictions of every model in a box.
pub fn band(phi: &[Vec<f64>], bx: &[Interval]) -> Vec<Interval> {
    phi.iter()
        .map(|r| {
            let (mut lo, mut hi) = (0.0, 0.0);
            for (c, iv) in r.iter().zip(bx) {
                let (a, b) = (c * iv.lo, c * iv.hi);
                lo += a.min(b);
                hi += a.max(b);
            }
            Interval::new(lo, hi)
        })
        .collect()
}
