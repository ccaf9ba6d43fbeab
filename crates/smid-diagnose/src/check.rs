//! The diagnosis check (`smid diagnose-check`): for every registered effect, random trials of
//! simulated data with that effect present but not declared. The truth is the base ARX model
//! `y_t = -a_1 y_{t-1} + b_0 u_{t-1} + e_t` (random real poles of magnitude 0.3-0.8, random gain, uniform
//! equation error `|e_t| <= Δ`) augmented by the effect's example instance (an added term's
//! coefficient random, sized 4-8 Δ against the column's RMS; an input map — play, dead zone,
//! saturation — maps the input of the linear block; an extra pole or zero random); the output is
//! measured through the effect's sensor map (quantization). A trial counts as named when the
//! first effect `diagnose` adds has the truth's tag, and as at the noise level when the
//! smallest consistent bound on the held-out record, after, is at most 1.2 × the bound Δ (plus
//! the effect's allowance).
use crate::diagnose;
use crate::effect::{effects, Effect, Record};
use crate::lip::Structure;
use crate::spec::{DataSpec, DiagSpec, DiagnoseOptions, LipModel, NoiseSpec, RecordSpec};
use crate::DiagError;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::Serialize;

/// Equation-error bound of the simulated data.
pub const DELTA: f64 = 0.02;
const BASE: crate::effect::Orders = crate::effect::Orders {
    na: 1,
    nb: 1,
    nk: 1,
};

/// Results for one effect.
#[derive(Debug, Clone, Serialize)]
pub struct EffectCheck {
    pub tag: String,
    pub trials: usize,
    pub named: usize,
    pub at_noise_level: usize,
    /// Median of `Δ*_holdout(after) / Δ_eff`.
    pub median_ratio_after: f64,
    /// Median of `Δ*_holdout(before) / Δ_eff`.
    pub median_ratio_before: f64,
    /// What was named instead, by trial seed.
    pub misses: Vec<(u64, String)>,
}

fn input(rng: &mut ChaCha8Rng, n: usize) -> Vec<f64> {
    let mut u = Vec::with_capacity(n);
    while u.len() < n {
        let v: f64 = rng.gen_range(-1.0..1.0);
        let hold = rng.gen_range(1..=4);
        for _ in 0..hold {
            u.push(v);
        }
    }
    u.truncate(n);
    u
}

/// Simulate `truth` (coefficients `theta` in the order of [`Structure::columns`]).
fn simulate(
    s: &Structure,
    theta: &[f64],
    u: &[f64],
    rng: &mut ChaCha8Rng,
    sensor: Option<&dyn Effect>,
) -> Record {
    let n = u.len();
    let mut rec = Record {
        name: "simulated".into(),
        u: u.to_vec(),
        y: vec![0.0; n],
        dt: 1.0,
    };
    // Columns read only y[..t]: recompute them as y fills in (O(n^2), small n).
    for t in 0..n {
        let cols = s.columns(&rec);
        let mut v: f64 = cols.iter().zip(theta).map(|(c, th)| c.1[t] * th).sum();
        v += rng.gen_range(-DELTA..DELTA);
        rec.y[t] = v;
    }
    if let Some(m) = sensor {
        rec.y = m.measure(&rec.y);
    }
    rec
}

fn rms(x: &[f64]) -> f64 {
    (x.iter().map(|v| v * v).sum::<f64>() / x.len().max(1) as f64).sqrt()
}

/// One trial: returns (named tag or "-", ratio before, ratio after).
pub fn trial(example: &dyn Effect, seed: u64) -> Result<(String, f64, f64), DiagError> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let truth = Structure {
        base: BASE,
        effects: vec![example.boxed()],
    };
    let o = truth.orders();
    // Stable A from random real poles; random gains.
    // Poles of magnitude 0.3-0.8 (a pole near 0 would leave no trace to find).
    let poles: Vec<f64> = (0..o.na)
        .map(|_| rng.gen_range(0.3..0.8) * if rng.gen_bool(0.5) { 1.0 } else { -1.0 })
        .collect();
    let mut a = vec![1.0];
    for p in &poles {
        let mut next = vec![0.0; a.len() + 1];
        for (i, c) in a.iter().enumerate() {
            next[i] += c;
            next[i + 1] -= c * p;
        }
        a = next;
    }
    let mut theta: Vec<f64> = a[1..].to_vec();
    for j in 0..o.nb {
        let mag = if j == 0 {
            rng.gen_range(0.5..1.5)
        } else {
            rng.gen_range(0.5..1.0)
        };
        theta.push(if rng.gen_bool(0.5) { mag } else { -mag });
    }
    let (ntr, nho) = (400, 300);
    let u_tr = input(&mut rng, ntr);
    let u_ho = input(&mut rng, nho);
    // Size the effect's columns on a run without them.
    let lin = Structure {
        base: o,
        effects: vec![],
    };
    let probe = simulate(&lin, &theta, &u_tr, &mut rng.clone(), None);
    let ecols = example.columns(&probe, &o);
    for c in &ecols {
        let r = rms(&c.values).max(1e-9);
        let mag = rng.gen_range(4.0..8.0) * DELTA / r;
        theta.push(if rng.gen_bool(0.5) { mag } else { -mag });
    }
    let tr = simulate(&truth, &theta, &u_tr, &mut rng, Some(example));
    let ho = simulate(&truth, &theta, &u_ho, &mut rng, Some(example));
    let spec = DiagSpec {
        name: Some(format!("check {}", seed)),
        data: DataSpec {
            u: "u".into(),
            y: "y".into(),
            decimate: 1,
            dt: 1.0,
            train: vec![RecordSpec {
                file: "simulated".into(),
                rows: None,
            }],
            holdout: vec![],
        },
        noise: NoiseSpec {
            bound: Some(DELTA),
            estimate_margin: 1.1,
        },
        model: LipModel {
            na: BASE.na,
            nb: BASE.nb,
            nk: BASE.nk,
            effects: vec![],
        },
        diagnose: DiagnoseOptions {
            max_effects: 1,
            ..Default::default()
        },
    };
    let d = diagnose::diagnose(&spec, &[tr], &[ho], |_, _| {})?;
    let named = d.added_tags.first().cloned().unwrap_or_else(|| "-".into());
    Ok((
        named,
        d.before.dstar_holdout / d.before.delta,
        d.after.dstar_holdout / d.after.delta,
    ))
}

fn median(mut v: Vec<f64>) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(|a, b| a.partial_cmp(b).unwrap_or(std::cmp::Ordering::Equal));
    v[v.len() / 2]
}

/// Run `trials` trials per registered effect (seeds `first_seed..`), optionally only `only`.
pub fn run(
    trials: usize,
    first_seed: u64,
    only: &[String],
    mut tick: impl FnMut(),
) -> Result<Vec<EffectCheck>, DiagError> {
    let mut out = Vec::new();
    for e in effects() {
        if !only.is_empty() && !only.iter().any(|t| t == e.tag) {
            continue;
        }
        let ex = (e.example)();
        let mut c = EffectCheck {
            tag: e.tag.into(),
            trials,
            named: 0,
            at_noise_level: 0,
            median_ratio_after: 0.0,
            median_ratio_before: 0.0,
            misses: Vec::new(),
        };
        let (mut rb, mut ra) = (Vec::new(), Vec::new());
        for k in 0..trials as u64 {
            let seed = first_seed + k;
            // A trial that fails (e.g. the solver) is a miss with its message, not an abort.
            let (named, b, a) = match trial(ex.as_ref(), seed) {
                Ok(r) => r,
                Err(err) => (format!("error: {err}"), f64::NAN, f64::INFINITY),
            };
            if named == e.tag {
                c.named += 1;
            } else {
                c.misses.push((seed, named));
            }
            if a <= 1.2 {
                c.at_noise_level += 1;
            }
            if b.is_finite() {
                rb.push(b);
                ra.push(a);
            }
            tick();
        }
        c.median_ratio_before = median(rb);
        c.median_ratio_after = median(ra);
        out.push(c);
    }
    Ok(out)
}

/// The check's table.
pub fn format(checks: &[EffectCheck]) -> String {
    let mut s = String::from(
        "| effect | named | error at noise level | median Δ*/Δ before | median Δ*/Δ after | misses (seed: named) |\n|---|---|---|---|---|---|\n",
    );
    for c in checks {
        s.push_str(&format!(
            "| {} | {}/{} | {}/{} | {:.2} | {:.2} | {} |\n",
            c.tag,
            c.named,
            c.trials,
            c.at_noise_level,
            c.trials,
            c.median_ratio_before,
            c.median_ratio_after,
            c.misses
                .iter()
                .map(|(s, n)| format!("{s}: {n}"))
                .collect::<Vec<_>>()
                .join(", ")
        ));
    }
    s
}
