//! Validation of a LIP model set on fresh data. Computes, for a structure identified on
//! training records: the minimax estimate θ̂ and the smallest consistent bound Δ*_train; the
//! guaranteed parameter box of the feasible set at the noise bound Δ; on the held-out records
//! the one-step residual of θ̂ (RMS, max), the **falsification share** — the share of samples
//! whose output lies outside `[φ_t·box - Δ, φ_t·box + Δ]`, i.e. outside the outputs of every
//! model of the box with every admissible error, so each flagged sample is a guaranteed
//! contradiction (the box contains the feasible set, so the test is conservative: it never
//! flags a sample some consistent model explains) — the smallest Δ for which the held-out data
//! alone are consistent with the structure (LP), and the residual auto-/cross-correlations with
//! the 99% confidence band `±2.576/√N` (as MATLAB's `resid`).
//!
//! The prediction is one-step-ahead, using the measured past outputs: that is the model class
//! the equation-error bound describes. When the feasible set at Δ is empty on the training data,
//! no model is consistent and every held-out sample counts as falsified.
use crate::effect::Record;
use crate::lip::{self, Structure};
use crate::DiagError;
use serde::Serialize;
use smid_core::interval::Interval;

/// Largest lag of the correlation analysis.
pub const MAX_LAG: usize = 25;
/// Two-sided 99% normal quantile.
pub const Z99: f64 = 2.576;

/// A structure fitted (minimax) on training records.
#[derive(Debug, Clone)]
pub struct Fit {
    pub structure: Structure,
    pub names: Vec<String>,
    pub dropped: Vec<String>,
    pub theta: Vec<f64>,
    pub dstar_train: f64,
    /// Allowance the effects add to the bound (quantization), at θ̂.
    pub extra: f64,
}

/// Tune the open settings of declared effects (a play width left out of the spec...) on the
/// training records, in order, each by least squares with the others as tuned so far.
pub fn tune_declared(s: &Structure, train: &[Record]) -> Structure {
    let mut out = s.clone();
    for i in 0..out.effects.len() {
        let o = out.orders();
        let cur = out.clone();
        let score = |e: &dyn crate::effect::Effect| {
            let mut t = cur.clone();
            t.effects[i] = e.boxed();
            match t.regression(train) {
                Ok(reg) => {
                    let th = lip::least_squares(&reg.phi, &reg.y);
                    let r = lip::residuals(&reg.phi, &reg.y, &th);
                    (r.iter().map(|v| v * v).sum::<f64>() / r.len().max(1) as f64).sqrt()
                }
                Err(_) => f64::INFINITY,
            }
        };
        if let Some(e) = cur.effects[i].tune(train, &o, &score) {
            out.effects[i] = e;
        }
    }
    out
}

/// Fit a structure on training records.
pub fn fit(structure: &Structure, train: &[Record]) -> Result<Fit, DiagError> {
    let reg = structure.regression(train)?;
    let (theta, dstar_train) = lip::minimax(&reg.phi, &reg.y)?;
    let extra = extra_bound(structure, &reg.names, &theta);
    Ok(Fit {
        structure: structure.clone(),
        names: reg.names,
        dropped: reg.dropped,
        theta,
        dstar_train,
        extra,
    })
}

fn extra_bound(s: &Structure, names: &[String], theta: &[f64]) -> f64 {
    let a1: f64 = 1.0
        + names
            .iter()
            .zip(theta)
            .filter(|(n, _)| n.starts_with('a') && n[1..].parse::<usize>().is_ok())
            .map(|(_, v)| v.abs())
            .sum::<f64>();
    s.effects.iter().map(|e| e.extra_bound(a1)).sum()
}

/// Residual correlations (MATLAB `resid`).
#[derive(Debug, Clone, Serialize)]
pub struct Correlations {
    /// `r_ee(τ)`, τ = 0..=MAX_LAG (r_ee(0) = 1).
    pub auto: Vec<f64>,
    /// `r_eu(τ)`, τ = -MAX_LAG..=MAX_LAG.
    pub cross: Vec<f64>,
    /// 99% band half-width `2.576/√N`.
    pub band: f64,
    /// Lags τ >= 1 with `|r_ee(τ)|` above the band.
    pub auto_outside: usize,
    /// Lags with `|r_eu(τ)|` above the band.
    pub cross_outside: usize,
}

/// Normalised correlations of `e` with itself and with `u` (same length).
pub fn correlations(e: &[f64], u: &[f64]) -> Correlations {
    let n = e.len();
    let center = |x: &[f64]| {
        let m = x.iter().sum::<f64>() / x.len().max(1) as f64;
        x.iter().map(|v| v - m).collect::<Vec<_>>()
    };
    let (e, u) = (center(e), center(u));
    let se = (e.iter().map(|v| v * v).sum::<f64>()).sqrt().max(1e-300);
    let su = (u.iter().map(|v| v * v).sum::<f64>()).sqrt().max(1e-300);
    let c = |a: &[f64], b: &[f64], tau: i64| -> f64 {
        let mut s = 0.0;
        for t in 0..n as i64 {
            let k = t - tau;
            if k >= 0 && (k as usize) < n {
                s += a[t as usize] * b[k as usize];
            }
        }
        s
    };
    let auto: Vec<f64> = (0..=MAX_LAG as i64)
        .map(|k| c(&e, &e, k) / (se * se))
        .collect();
    let cross: Vec<f64> = (-(MAX_LAG as i64)..=MAX_LAG as i64)
        .map(|k| c(&e, &u, k) / (se * su))
        .collect();
    let band = Z99 / (n.max(1) as f64).sqrt();
    Correlations {
        auto_outside: auto[1..].iter().filter(|v| v.abs() > band).count(),
        cross_outside: cross.iter().filter(|v| v.abs() > band).count(),
        auto,
        cross,
        band,
    }
}

/// The validation of one fitted structure on held-out records.
#[derive(Debug, Clone, Serialize)]
pub struct Assessment {
    /// Structure label (base + effects).
    pub model: String,
    pub n_params: usize,
    pub rms: f64,
    pub max_abs: f64,
    /// Share of held-out samples outside the guaranteed band widened by Δ.
    pub falsified: f64,
    /// Whether the feasible set at Δ is empty on the training data.
    pub empty_on_train: bool,
    pub dstar_train: f64,
    pub dstar_holdout: f64,
    /// The bound used (`Δ + effects' allowance`).
    pub delta: f64,
    /// Mean width of the guaranteed bounds of the linear coefficients a_i, b_j (None: empty).
    pub mean_width: Option<f64>,
    /// RMS of the held-out residual beyond the effects' allowance (the ranking score before
    /// the parameter penalty).
    pub score: f64,
    pub correlations: Correlations,
    /// Parameter names and (estimate, box) pairs.
    pub parameters: Vec<(String, f64, Option<(f64, f64)>)>,
    #[serde(skip)]
    pub series: Vec<Series>,
}

/// Per held-out record: time index, measured output, band (may be empty) and residual.
#[derive(Debug, Clone)]
pub struct Series {
    pub name: String,
    pub t: Vec<usize>,
    pub y: Vec<f64>,
    pub band: Option<Vec<Interval>>,
    pub residual: Vec<f64>,
    pub delta: f64,
}

/// A label for a structure.
pub fn label(s: &Structure) -> String {
    let o = s.base;
    let mut l = format!("ARX(na={}, nb={}, nk={})", o.na, o.nb, o.nk);
    for e in &s.effects {
        l.push_str(" + ");
        l.push_str(&e.label());
    }
    l
}

/// Assess a fit on held-out records at noise bound `delta` (before the effects' allowance).
pub fn assess(
    f: &Fit,
    train: &[Record],
    hold: &[Record],
    delta: f64,
) -> Result<Assessment, DiagError> {
    let s = &f.structure;
    let d_eff = delta + f.extra;
    let reg = s.regression(train)?;
    // Same columns as the fit (the rank check is deterministic on the same data).
    let bx = lip::parameter_box(&reg.phi, &reg.y, d_eff)?;
    let mut all_r = Vec::new();
    let mut all_u = Vec::new();
    let mut all_phi = Vec::new();
    let mut all_y = Vec::new();
    let mut outside = 0usize;
    let mut series = Vec::new();
    for rec in hold {
        let (phi, y, st) = s.rows_for(rec, &f.names);
        let r = lip::residuals(&phi, &y, &f.theta);
        let b = bx.as_ref().map(|bx| lip::band(&phi, bx));
        match &b {
            Some(b) => {
                outside += y
                    .iter()
                    .zip(b)
                    .filter(|(v, iv)| **v < iv.lo - d_eff || **v > iv.hi + d_eff)
                    .count()
            }
            None => outside += y.len(),
        }
        all_u.extend_from_slice(&rec.u[st..]);
        all_r.extend_from_slice(&r);
        series.push(Series {
            name: rec.name.clone(),
            t: (st..rec.y.len()).collect(),
            y: y.clone(),
            band: b,
            residual: r,
            delta: d_eff,
        });
        all_phi.extend(phi);
        all_y.extend(y);
    }
    let n = all_r.len().max(1) as f64;
    let rms = (all_r.iter().map(|v| v * v).sum::<f64>() / n).sqrt();
    let max_abs = all_r.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let score = (all_r
        .iter()
        .map(|v| (v.abs() - f.extra).max(0.0).powi(2))
        .sum::<f64>()
        / n)
        .sqrt();
    let dstar_holdout = lip::minimax(&all_phi, &all_y)?.1;
    let lin: Vec<usize> = f
        .names
        .iter()
        .enumerate()
        .filter(|(_, n)| is_linear_name(n))
        .map(|(k, _)| k)
        .collect();
    let mean_width = bx
        .as_ref()
        .map(|b| lin.iter().map(|&k| b[k].hi - b[k].lo).sum::<f64>() / lin.len().max(1) as f64);
    Ok(Assessment {
        model: label(s),
        n_params: f.names.len(),
        rms,
        max_abs,
        falsified: outside as f64 / n,
        empty_on_train: bx.is_none(),
        dstar_train: f.dstar_train,
        dstar_holdout,
        delta: d_eff,
        mean_width,
        score,
        correlations: correlations(&all_r, &all_u),
        parameters: f
            .names
            .iter()
            .enumerate()
            .map(|(k, nm)| {
                (
                    nm.clone(),
                    f.theta[k],
                    bx.as_ref().map(|b| (b[k].lo, b[k].hi)),
                )
            })
            .collect(),
        series,
    })
}

/// `a1`, `b0`...: coefficients of the linear block.
pub fn is_linear_name(n: &str) -> bool {
    (n.starts_with('a') || n.starts_with('b')) && n.len() > 1 && n[1..].parse::<usize>().is_ok()
}

/// Whether the data pass: no held-out sample falsifies the model set.
pub fn passes(a: &Assessment) -> bool {
    !a.empty_on_train && a.falsified == 0.0
}

/// A human-readable validation report.
pub fn format_report(a: &Assessment, how_delta: &str) -> String {
    use std::fmt::Write;
    let mut s = String::new();
    let _ = writeln!(s, "model: {}", a.model);
    let _ = writeln!(s, "noise bound Δ = {} ({how_delta})", g(a.delta));
    let _ = writeln!(
        s,
        "residual (one-step, minimax estimate): RMS {}  max {}",
        g(a.rms),
        g(a.max_abs)
    );
    if a.empty_on_train {
        let _ = writeln!(
            s,
            "falsified: the feasible set is EMPTY on the training data at Δ (no consistent model): 100% of held-out samples"
        );
    } else {
        let _ = writeln!(
            s,
            "falsified: {:.2}% of held-out samples lie outside the guaranteed band ± Δ",
            100.0 * a.falsified
        );
    }
    let _ = writeln!(
        s,
        "smallest consistent noise bound: training {}  held-out {}",
        g(a.dstar_train),
        g(a.dstar_holdout)
    );
    let c = &a.correlations;
    let _ = writeln!(
        s,
        "residual autocorrelation: {} of {} lags outside the 99% band ±{:.3} (max |r_ee| {:.3})",
        c.auto_outside,
        MAX_LAG,
        c.band,
        c.auto[1..].iter().fold(0.0f64, |m, v| m.max(v.abs()))
    );
    let _ = writeln!(
        s,
        "input cross-correlation: {} of {} lags outside the 99% band (max |r_eu| {:.3})",
        c.cross_outside,
        2 * MAX_LAG + 1,
        c.cross.iter().fold(0.0f64, |m, v| m.max(v.abs()))
    );
    let _ = writeln!(s, "parameters (minimax estimate, guaranteed box at Δ):");
    for (n, v, b) in &a.parameters {
        match b {
            Some((lo, hi)) => {
                let _ = writeln!(s, "  {n:<12} {:>12}  [{}, {}]", g(*v), g(*lo), g(*hi));
            }
            None => {
                let _ = writeln!(s, "  {n:<12} {:>12}  (empty)", g(*v));
            }
        }
    }
    let _ = writeln!(
        s,
        "verdict: {}",
        if passes(a) {
            "PASS (no held-out sample falsifies the model set)"
        } else {
            "FAIL (the data falsify the model set at this bound)"
        }
    );
    s
}

/// Four significant digits.
pub fn g(v: f64) -> String {
    if v == 0.0 {
        "0".into()
    } else if v.abs() >= 1e-3 && v.abs() < 1e5 {
        let d = (3 - v.abs().log10().floor() as i64).clamp(0, 8) as usize;
        format!("{v:.d$}")
    } else {
        format!("{v:.3e}")
    }
}
