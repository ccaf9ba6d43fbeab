//! Validation of an identified [`ModelSet`] on fresh records, for every structure:
//!
//! * **Set-membership verdict.** The same stages as identification, with the identified sets
//!   as constraints: stage 2 inverts (or propagates) the fresh records through each cell's
//!   identified nonlinearity set (eqs 23-27), and stage 3 asks whether one `θ` satisfies the
//!   training equations and the fresh ones together (eqs 1, 28-30, the cell's `θ` box as a
//!   prior). CONSISTENT when some cell admits such a `θ` (no contradiction found by the
//!   relaxation: a necessary condition), and proven so when the certified simulation member
//!   satisfies the joint equations exactly; UNDECIDED when the relaxation's rounds or the
//!   identified set did not settle; FALSIFIED when no cell admits them (a proof), with the
//!   first offending sample ([`consistency`]). The smallest noise bound of the fresh records for which they are
//!   consistent (bisection; below it the data provably contradict the model) is compared with
//!   the declared bound: PASS when it is within it.
//! * **Free-run simulation** of the representative member (the simulation member, else the central one) ([`crate::members`]) from the input alone
//!   after an initial condition taken from the first `na + nb + nk` measured samples (as
//!   MATLAB's `compare` estimates one; the figures leave those samples out), with an envelope
//!   over certified members where there are any (an inner approximation of the set's output
//!   range), else over members at the ends of each bound (indicative, not a guarantee: those
//!   lie in the outer bounds, not necessarily in the feasible set); RMS error, NRMSE, fit % as
//!   `compare` (`100 (1 - |y - ŷ| / |y - mean y|)`), maximum error; `k`-step-ahead prediction.
//! * **Residuals**: auto- and cross-correlation of the one-step residual with 99 % bands
//!   `±2.576/√N` (MATLAB's `resid`).
//! * **Baseline**: a least-squares ARX of the same orders, trained on the model's training
//!   records, simulated free-run on the same fresh records from the same initial condition.
//! * **Warnings**: an unstable centre model, bisected parameters at the edge of their prior,
//!   a noise bound estimated from the data, a cell budget that stopped the bisection.
use crate::baseline::Arx;
use crate::error::{Result, SmidError};
use crate::members;
use crate::model::{BoundSource, ModelSet, Record};
use serde::Serialize;

mod consistency;

pub use consistency::{
    consistency, consistency_with, smallest_bound, Consistency, Falsification, Undecided, Verdict,
    VACUOUS_BELOW,
};

/// Largest lag of the correlation analysis.
pub const MAX_LAG: usize = 25;
/// Two-sided 99 % normal quantile.
pub const Z99: f64 = 2.576;

/// Options of a validation.
#[derive(Debug, Clone, Copy)]
pub struct Options {
    /// Horizon of the k-step-ahead prediction.
    pub k: usize,
    /// Relative resolution of the smallest consistent bound.
    pub bound_resolution: f64,
    /// Compute the guaranteed one-step band of the whole set ([`crate::band`]).
    pub band: bool,
    /// Where the relaxation's verdict is settled (CONSISTENT), still search for a point of the
    /// set that proves it ([`consistency_with`]); `false`: only the simulation member itself
    /// is checked there, and the search runs only where the verdict would be undecided.
    pub prove: bool,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            k: 5,
            bound_resolution: 0.02,
            band: true,
            prove: true,
        }
    }
}

/// Figures of merit of a simulated or predicted output against the measured one.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct Fit {
    /// Root-mean-square error `sqrt(mean (y - ŷ)²)`, in output units.
    pub rms: f64,
    /// `|y - ŷ| / |y - mean y|`.
    pub nrmse: f64,
    /// `100 (1 - nrmse)`.
    pub fit_percent: f64,
    /// Largest absolute error `max |y - ŷ|`, in output units.
    pub max_abs: f64,
    /// Samples compared (after each record's warm start).
    pub samples: usize,
}

impl Fit {
    /// Over the pairs of measured and model outputs (several records pooled: the means are
    /// per record, the norms pooled).
    pub fn of(pairs: &[(&[f64], &[f64])]) -> Fit {
        let (mut e2, mut d2, mut mx, mut n) = (0.0, 0.0, 0.0f64, 0usize);
        for (y, yh) in pairs {
            let m = y.iter().sum::<f64>() / y.len().max(1) as f64;
            for (a, b) in y.iter().zip(yh.iter()) {
                let e = a - b;
                e2 += e * e;
                d2 += (a - m) * (a - m);
                mx = mx.max(e.abs());
                n += 1;
            }
        }
        let nrmse = if d2 > 0.0 {
            (e2 / d2).sqrt()
        } else {
            f64::INFINITY
        };
        let rms = (e2 / n.max(1) as f64).sqrt();
        Fit {
            rms: if rms.is_finite() { rms } else { f64::INFINITY },
            nrmse: if nrmse.is_finite() {
                nrmse
            } else {
                f64::INFINITY
            },
            fit_percent: if nrmse.is_finite() {
                100.0 * (1.0 - nrmse)
            } else {
                f64::NEG_INFINITY
            },
            max_abs: if mx.is_finite() { mx } else { f64::INFINITY },
            samples: n,
        }
    }
}

/// Residual correlations (MATLAB `resid`).
#[derive(Debug, Clone, Serialize)]
pub struct Correlations {
    /// `r_ee(τ)`, τ = 0..=MAX_LAG.
    pub auto: Vec<f64>,
    /// `r_eu(τ)`, τ = -MAX_LAG..=MAX_LAG.
    pub cross: Vec<f64>,
    /// 99 % band half-width `2.576/√N`.
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

/// The series of one fresh record, for plots.
#[derive(Debug, Clone, Serialize)]
pub struct Series {
    /// The record's name.
    pub name: String,
    /// The measured output.
    pub y: Vec<f64>,
    /// Free run of the representative member ([`Validation::member`]).
    pub free_run: Vec<f64>,
    /// Envelope over the members (lower, upper).
    pub envelope: (Vec<f64>, Vec<f64>),
    /// One-step-ahead prediction of the same member.
    pub one_step: Vec<f64>,
    /// `k`-step-ahead prediction of the same member ([`Options::k`]).
    pub k_step: Vec<f64>,
    /// Free run of the ARX baseline ([`crate::baseline`]), when it could be fitted.
    pub baseline: Option<Vec<f64>>,
    /// The guaranteed one-step band of the whole set (lower, upper), when computed.
    pub band: Option<(Vec<f64>, Vec<f64>)>,
}

/// The guaranteed one-step band over the fresh records ([`crate::band`]), summarised.
#[derive(Debug, Clone, Serialize)]
pub struct BandSummary {
    /// Cells of the set the band is the hull over, and how many of them the training
    /// equations prove empty (their `θ` polytope holds no point: no member there).
    pub cells: usize,
    /// How many of those cells the training equations prove empty.
    pub empty_cells: usize,
    /// Cells not evaluated: a cell whose `θ` is unbounded already left the band unbounded at
    /// every sample.
    pub unevaluated: usize,
    /// The prediction's range by LPs over each cell's `θ` polytope (else over its `θ` box:
    /// more than [`crate::band::LP_CELLS`] cells).
    pub lp: bool,
    /// Samples (after the warm start) and those with a finite band.
    pub samples: usize,
    /// Samples whose band is finite.
    pub finite: usize,
    /// Mean width of the finite band.
    pub mean_width: f64,
    /// Samples whose measurement lies outside the band widened by its noise bound: each one
    /// contradicts the set (a proof, like FALSIFIED).
    pub outside: usize,
    /// The first of them, `(record, sample)`.
    pub first_outside: Option<(usize, usize)>,
}

/// A whole validation.
#[derive(Debug, Clone, Serialize)]
pub struct Validation {
    /// The model set's name.
    pub model: String,
    /// The set-membership verdict on the fresh records.
    pub consistency: Consistency,
    /// The declared (or estimated) noise bound of the model.
    pub bound: f64,
    /// Whether that bound was declared or estimated.
    pub bound_source: BoundSource,
    /// Smallest noise bound of the fresh records for which they are consistent, as a bracket
    /// `[lo, hi]`: provably inconsistent below `lo`, consistent at `hi`; `(0, 0)` when a cell
    /// admits them down to [`VACUOUS_BELOW`] of the bound ([`smallest_bound`]).
    pub smallest_bound: Option<(f64, f64)>,
    /// The smallest consistent bound is within the declared one.
    pub pass: bool,
    /// Free-run fit of the representative member ([`Validation::member`]), all fresh records
    /// pooled, after each record's warm start.
    pub free_run: Fit,
    /// The member the free run and predictions use ([`members::representative_label`]).
    pub member: String,
    /// The central member's free-run fit on the same records, when the simulation member
    /// stands in for the set (both are reported).
    pub centre_free_run: Option<Fit>,
    /// One-step-ahead prediction fit of the same member.
    pub one_step: Fit,
    /// Horizon of the `k`-step-ahead prediction ([`Options::k`]).
    pub k: usize,
    /// `k`-step-ahead prediction fit of the same member.
    pub k_step: Fit,
    /// Per fresh record: the free-run fit.
    pub per_record: Vec<(String, Fit)>,
    /// Free-run fit of the ARX baseline fitted on the training records, when it could be.
    pub baseline: Option<Fit>,
    /// The baseline's orders `(na, nb, nk)`: the model's.
    pub baseline_orders: (usize, usize, usize),
    /// How the envelope was made.
    pub envelope: String,
    /// The guaranteed one-step band ([`Options::band`]).
    pub band: Option<BandSummary>,
    /// Correlations of the one-step residuals with themselves and with the input.
    pub correlations: Correlations,
    /// What the verdicts rest on beyond the data (an unstable member, a bound reached at a
    /// prior's edge, an estimated noise bound, unchecked cells, a spent budget), in words.
    pub warnings: Vec<String>,
    /// Number of identified parameters (those with a non-degenerate bound).
    pub parameters: usize,
    /// The per-record series, for plots (not serialised).
    #[serde(skip)]
    pub series: Vec<Series>,
}

/// The free-run fit of the representative member on records (warm start as in [`validate`]).
pub fn free_run_fit(model: &ModelSet, records: &[Record]) -> Result<Fit> {
    member_fit(model, &members::representative(model)?, records)
}

/// The free-run fit of one member of `model` on records (warm start as in [`validate`]).
fn member_fit(model: &ModelSet, centre: &members::ModelPoint, records: &[Record]) -> Result<Fit> {
    let o = model.layout()?.orders;
    let warm = o.na + o.nb + o.nk;
    let mut sims = Vec::new();
    for rec in records {
        let (w0, seeded) = start_of(rec, warm);
        let free = members::free_run(model, centre, rec, seeded)?;
        sims.push((rec.y[w0..].to_vec(), free[w0..].to_vec()));
    }
    let pairs: Vec<(&[f64], &[f64])> = sims
        .iter()
        .map(|(a, b)| (a.as_slice(), b.as_slice()))
        .collect();
    Ok(Fit::of(&pairs))
}

/// Where the figures of the fresh record `rec` start, and how many of its measured samples set
/// the initial state: from rest, after its input history and none; else the first `warm`
/// samples, both.
fn start_of(rec: &Record, warm: usize) -> (usize, usize) {
    match rec.history {
        Some(h) => (h.min(rec.y.len()), 0),
        None => {
            let w = warm.min(rec.y.len());
            (w, w)
        }
    }
}

/// The one-step band of `rec`, a test like the others: over the samples after its input
/// history only, which read no output of the history (infinite at the history's samples).
fn band_after_history(model: &ModelSet, rec: &Record) -> Result<crate::band::Band> {
    let h = match rec.history {
        Some(h) if h > 0 => h.min(rec.y.len()),
        _ => return crate::band::one_step_band(model, rec),
    };
    let mut b = crate::band::one_step_band(model, &rec.without_history())?;
    b.lower
        .splice(0..0, std::iter::repeat_n(f64::NEG_INFINITY, h));
    b.upper
        .splice(0..0, std::iter::repeat_n(f64::INFINITY, h));
    Ok(b)
}

/// Fresh records a model of orders `o` can be validated on: well formed, and each with at
/// least two equations (a shorter one would be "consistent" for want of any test). Errors
/// name the record.
pub fn check_fresh(o: crate::effect::Orders, fresh: &[Record]) -> Result<()> {
    let need = o.na.max(o.nb + o.nk) + 2;
    for r in fresh {
        r.validate()?;
        if r.u.len() < need {
            return Err(SmidError::invalid(
                format!("fresh record `{}`", r.name),
                format!(
                    "too short: {} samples, need at least {need} (two equations of na = {}, nb = {}, nk = {})",
                    r.u.len(),
                    o.na,
                    o.nb,
                    o.nk
                ),
            ));
        }
    }
    Ok(())
}

/// Validate `model` on fresh records.
pub fn validate(model: &ModelSet, fresh: &[Record], opts: &Options) -> Result<Validation> {
    if fresh.is_empty() {
        return Err(SmidError::invalid("validation", "no fresh record given"));
    }
    let layout = model.layout()?;
    let o = layout.orders;
    check_fresh(o, fresh)?;
    let fresh: Vec<Record> = fresh.iter().map(|r| r.with_bound(model.delta)).collect();
    // The tests read each record after its input history only.
    let tested: Vec<Record> = fresh.iter().map(Record::without_history).collect();
    let clock = std::time::Instant::now();
    let consistency = consistency_with(model, &tested, opts.prove)?;
    log::info!(target: "smid::validate", "consistency: {:.2} s", clock.elapsed().as_secs_f64());
    let clock = std::time::Instant::now();
    let smallest = smallest_bound(
        model,
        &tested,
        opts.bound_resolution,
        Some(consistency.verdict != Verdict::Falsified),
    )?;
    log::info!(target: "smid::validate", "smallest consistent bound: {:.2} s", clock.elapsed().as_secs_f64());
    let pass = consistency.consistent && smallest.is_some_and(|(_, hi)| hi <= model.delta);

    let centre = members::representative(model)?;
    let clock = std::time::Instant::now();
    let (members, envelope) = members::envelope_members(model);
    log::info!(target: "smid::validate", "envelope members: {:.2} s", clock.elapsed().as_secs_f64());
    let arx = Arx::fit(&model.training.records, o.na, o.nb, o.nk).ok();
    let warnings = warnings(model, &centre, &consistency);
    let mut series = Vec::new();
    let mut per_record = Vec::new();
    let mut residuals = Vec::new();
    let mut inputs = Vec::new();
    // The first `warm` samples give the initial condition (measured), as MATLAB's `compare`
    // estimates one, or an input history does ([`start_of`]); the figures are over the rest.
    let warm = o.na + o.nb + o.nk;
    // The band's summary over the records, and the sum of its finite widths.
    let mut band_sum: Option<(BandSummary, f64)> = None;
    for rec in &fresh {
        let n = rec.y.len();
        let (w0, seeded) = start_of(rec, warm);
        let xd = members::inner_estimate(model, &centre, rec)?;
        let free = centre
            .predict(&rec.u, Some(&xd), rec.dt, usize::MAX, seeded)
            .y;
        let one = centre.predict(&rec.u, Some(&xd), rec.dt, 1, seeded).y;
        let kst = centre.predict(&rec.u, Some(&xd), rec.dt, opts.k, seeded).y;
        let (lo, hi) = members::envelope(&free, &members, |m| {
            m.predict(&rec.u, Some(&xd), rec.dt, usize::MAX, seeded).y
        });
        let base = arx
            .as_ref()
            .map(|a| a.simulate_from(&rec.u, &rec.y, seeded));
        let band = if opts.band {
            let clock = std::time::Instant::now();
            let b = band_after_history(model, rec)?;
            log::info!(target: "smid::validate", "band of `{}`: {:.2} s", rec.name, clock.elapsed().as_secs_f64());
            Some(b)
        } else {
            None
        };
        if let Some(b) = &band {
            // After an input history, the band's own first samples have no past: skipped as
            // a record's first `warm` are.
            let from = match rec.history {
                Some(h) => (h + warm).min(n),
                None => w0,
            };
            add_to_band_summary(&mut band_sum, b, rec, from, series.len());
        }
        per_record.push((rec.name.clone(), Fit::of(&[(&rec.y[w0..], &free[w0..])])));
        let skip = (w0 + 1).min(n);
        residuals.extend(rec.y[skip..].iter().zip(&one[skip..]).map(|(a, b)| a - b));
        inputs.extend_from_slice(&rec.u[skip..]);
        series.push(Series {
            name: rec.name.clone(),
            y: rec.y.clone(),
            free_run: free,
            envelope: (lo, hi),
            one_step: one,
            k_step: kst,
            baseline: base,
            band: band.map(|b| (b.lower, b.upper)),
        });
    }
    let band = band_sum.map(|(mut sum, width)| {
        sum.mean_width = width / sum.finite.max(1) as f64;
        sum
    });
    let starts: Vec<usize> = fresh.iter().map(|r| start_of(r, warm).0).collect();
    let pairs = |f: &dyn Fn(&Series) -> &[f64]| -> Fit {
        let v: Vec<(&[f64], &[f64])> = series
            .iter()
            .zip(&starts)
            .map(|(s, &w0)| (&s.y[w0..], &f(s)[w0..]))
            .collect();
        Fit::of(&v)
    };
    let free_run = pairs(&|s| &s.free_run);
    let centre_free_run = match model.simulation_member {
        Some(_) => Some(member_fit(model, &members::centre(model)?, &fresh)?),
        None => None,
    };
    let k_step = pairs(&|s| &s.k_step);
    let one_step = pairs(&|s| &s.one_step);
    let baseline = arx.as_ref().map(|_| {
        let v: Vec<(&[f64], &[f64])> = series
            .iter()
            .zip(&starts)
            .filter_map(|(s, &w0)| s.baseline.as_ref().map(|b| (&s.y[w0..], &b[w0..])))
            .collect();
        Fit::of(&v)
    });
    Ok(Validation {
        model: model.name.clone(),
        consistency,
        bound: model.delta,
        bound_source: model.bound_source,
        smallest_bound: smallest,
        pass,
        free_run,
        member: members::representative_label(model).to_string(),
        centre_free_run,
        one_step,
        k: opts.k,
        k_step,
        per_record,
        baseline,
        baseline_orders: (o.na, o.nb, o.nk),
        envelope,
        band,
        correlations: correlations(&residuals, &inputs),
        warnings,
        parameters: model.free_parameters().len(),
        series,
    })
}

/// The warnings of a validation: an unstable representative member `centre`, parameters
/// at the edge of their prior, unsettled steady-state points, an estimated bound, cells the
/// `consistency` check could not decide, unbounded cells, a spent cell budget.
fn warnings(
    model: &ModelSet,
    centre: &members::ModelPoint,
    consistency: &Consistency,
) -> Vec<String> {
    let mut warnings = Vec::new();
    if !centre.stable() {
        warnings.push(format!(
            "the representative member is unstable (largest pole modulus {:.4}): its free run diverges",
            centre.linear.spectral_radius()
        ));
    }
    for d in &model.dims {
        if let Some(p) = model.parameter(&d.name) {
            let w = d.prior.hi - d.prior.lo;
            let tol = 1e-6 * w;
            if w > 0.0 && (p.lower <= d.prior.lo + tol || p.upper >= d.prior.hi - tol) {
                warnings.push(format!(
                    "`{}` reaches the edge of its prior [{:.4e}, {:.4e}]: the prior, not the data, bounds it there",
                    d.name, d.prior.lo, d.prior.hi
                ));
            }
        }
    }
    warnings.extend(model.unsettled_warning());
    if model.bound_source.estimated() {
        warnings.push(format!(
            "the noise bound was {}, not given: the verdicts hold for that estimate, not as a prior guarantee",
            model.bound_source.describe()
        ));
    }
    if consistency.unchecked > 0 {
        warnings.push(format!(
            "{} cell(s) could not be checked (LP solver trouble): they are not counted as contradicted, and no verdict rests on them",
            consistency.unchecked
        ));
    }
    if !model.search.unbounded.is_empty() {
        warnings.push(format!(
            "{} cell(s) of the identified set have no finite θ bound (the refinement budget was spent): the simulated members come from the bounded cells only",
            model.search.unbounded.len()
        ));
    }
    if model.search.budget_stopped {
        warnings.push(
            "the cell budget stopped the branch and bound: the bounds hold but are looser than the resolution asked for".into(),
        );
    }
    warnings
}

/// The band `b` of the fresh record `rec` (number `record`, warm start `w0`) added to the
/// summary over the records and the sum of its finite widths.
fn add_to_band_summary(
    band_sum: &mut Option<(BandSummary, f64)>,
    b: &crate::band::Band,
    rec: &Record,
    w0: usize,
    record: usize,
) {
    let n = rec.y.len();
    let (sum, width) = band_sum.get_or_insert_with(|| {
        let sum = BandSummary {
            cells: b.cells,
            empty_cells: b.empty_cells,
            unevaluated: b.unevaluated,
            lp: b.lp,
            samples: 0,
            finite: 0,
            mean_width: 0.0,
            outside: 0,
            first_outside: None,
        };
        (sum, 0.0)
    });
    let (finite, w) = b.finite(w0);
    let outside = b.outside(&rec.y, &rec.dy, w0);
    sum.samples += n - w0;
    sum.finite += finite;
    *width += w;
    sum.outside += outside.len();
    if sum.first_outside.is_none() {
        sum.first_outside = outside.first().map(|&t| (record, t));
    }
}
