//! The three-stage identification pipeline of the paper, for any nonlinearity plugin and
//! structure: acquire data (run the experiments on a [`Plant`] or load CSV files), stage 1
//! (nonlinearity parameter set from steady-state data, Section 3), stage 2 (inner-signal bounds,
//! Section 4: inversion for Wiener, propagation for Hammerstein), stage 3 (linear parameters,
//! Section 5, [`crate::stage3`]).
use crate::error::{Result, SmidError};
use crate::experiment::{self, FilterDesign, SteadyRecord};
use crate::interval::Interval;
use crate::inversion::{InnerBound, InnerKind};
use crate::noise;
use crate::nonlinearity::{NonlinearitySet, SteadyStateData, Structure};
use crate::plant::{Plant, SimulatedPlant};
use crate::spec::{AlphaSpec, Spec};
use crate::stage3::EivProblem;
use rand::SeedableRng;
use serde::Serialize;
use std::path::Path;

/// Everything measured (or simulated) for one identification.
#[derive(Debug, Clone, Default, Serialize)]
pub struct ExperimentData {
    pub steady: SteadyStateData,
    /// The whole noise-free square-wave record, when simulated.
    #[serde(skip)]
    pub steady_record: Option<SteadyRecord>,
    /// Dynamic experiment: input, measured output and per-sample noise bound.
    pub u: Vec<f64>,
    pub y: Vec<f64>,
    pub dy: Vec<f64>,
    /// Noise-free output, inner signal and noise, when simulated.
    pub w: Option<Vec<f64>>,
    pub x: Option<Vec<f64>>,
    pub noise: Option<Vec<f64>>,
    pub filter: Option<FilterDesign>,
}

/// One parameter's guaranteed interval with its truth when known.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ParamResult {
    pub name: String,
    pub lower: f64,
    pub upper: f64,
    pub center: f64,
    pub radius: f64,
    pub truth: Option<f64>,
    pub contains: Option<bool>,
}

impl ParamResult {
    fn new(name: &str, i: Interval, truth: Option<f64>) -> Self {
        ParamResult {
            name: name.to_string(),
            lower: i.lo,
            upper: i.hi,
            center: i.center(),
            radius: i.radius(),
            truth,
            contains: truth.map(|t| i.contains(t)),
        }
    }
}

/// Result of a whole identification.
#[derive(Debug)]
pub struct Identification {
    pub name: String,
    pub delta_eta: f64,
    pub snr_db: f64,
    /// Nonlinearity parameters (stage 1) then linear parameters (stage 3).
    pub parameters: Vec<ParamResult>,
    pub set: Box<dyn NonlinearitySet>,
    pub inner: Vec<InnerBound>,
    /// Time indices of the stage-3 equations.
    pub equations: Vec<usize>,
    pub data: ExperimentData,
    /// Whether the truth lies in the exact stage-1 set (polygons), when known.
    pub truth_in_nonlinearity_set: Option<bool>,
    /// Inner samples whose true value falls outside its bound (must be 0), when known.
    pub inner_violations: Option<usize>,
}

impl Identification {
    /// Whether every parameter with a known truth is inside its bounds.
    pub fn all_contain_truth(&self) -> Option<bool> {
        let c: Vec<bool> = self.parameters.iter().filter_map(|p| p.contains).collect();
        (!c.is_empty()).then(|| {
            c.iter().all(|b| *b)
                && self.truth_in_nonlinearity_set != Some(false)
                && self.inner_violations.unwrap_or(0) == 0
        })
    }
    /// A parameter by name.
    pub fn parameter(&self, name: &str) -> Option<&ParamResult> {
        self.parameters.iter().find(|p| p.name == name)
    }
}

/// The built-in simulator of a spec, if the spec's plant is one.
pub fn builtin_plant(spec: &Spec) -> Option<SimulatedPlant<'_>> {
    spec.plant.simulator.as_ref().map(|s| SimulatedPlant {
        linear: s.linear(),
        nonlinearity: s.nonlinearity.as_ref(),
        structure: s.structure,
    })
}

/// Run `plant` from rest on `u`; an output of the wrong length or a non-finite sample is an
/// error naming the plant (and the sample).
pub fn run_checked(plant: &mut dyn Plant, u: &[f64]) -> Result<Vec<f64>> {
    let w = plant.run(u)?;
    if w.len() != u.len() {
        return Err(SmidError::Plant {
            plant: plant.name(),
            message: format!("returned {} samples for {} inputs", w.len(), u.len()),
        });
    }
    if let Some(t) = w.iter().position(|v| !v.is_finite()) {
        return Err(SmidError::Plant {
            plant: plant.name(),
            message: format!("non-finite output at sample {t}"),
        });
    }
    Ok(w)
}

/// Run the spec's experiments on `plant` (noise-free plant output, bounded noise added here).
pub fn simulate_experiments(spec: &Spec, plant: &mut dyn Plant) -> Result<ExperimentData> {
    let delta = spec.noise.delta()?;
    let added = spec.noise.simulated()?;
    let ex = &spec.experiment;
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(ex.seed);
    let filter = match ex.filter.pole {
        Some(a) => FilterDesign::given(a),
        None => experiment::design_filter_pole(plant, &ex.filter.bisection())?,
    };
    let rec = experiment::steady_state_experiment(plant, filter.pole, &ex.steady_options())?;
    let steady = experiment::noisy_steady_state(&rec, delta, added, &mut rng);
    let u = experiment::dynamic_input(&ex.dynamic_options(), &mut rng)?;
    let w = run_checked(plant, &u)?;
    let eta = noise::uniform(u.len(), added, &mut rng);
    let y = w.iter().zip(&eta).map(|(a, b)| a + b).collect();
    let x = plant.inner(&u);
    Ok(ExperimentData {
        steady,
        steady_record: Some(rec),
        dy: vec![delta; u.len()],
        u,
        y,
        w: Some(w),
        x,
        noise: Some(eta),
        filter: Some(filter),
    })
}

/// Load measured data named by the spec (`plant.data`), paths relative to `base`.
pub fn load_data(spec: &Spec, base: &Path) -> Result<ExperimentData> {
    let d =
        spec.plant.data.as_ref().ok_or_else(|| {
            SmidError::invalid("plant.data", "the spec's plant is not measured data")
        })?;
    let delta = spec.noise.delta()?;
    let ss = &d.steady_state;
    let (us, ys) =
        crate::data::read_columns(&base.join(&ss.file), &ss.u, &ss.y, ss.part.as_deref())?;
    if us.len() < 4 {
        return Err(SmidError::Data {
            file: base.join(&ss.file),
            location: format!("column `{}`", ss.u),
            message: format!(
                "too short: {} steady-state samples, need at least 4 (two amplitudes per branch)",
                us.len()
            ),
        });
    }
    let dynm = &d.dynamic;
    let (u, y) = crate::data::read_columns(
        &base.join(&dynm.file),
        &dynm.u,
        &dynm.y,
        dynm.part.as_deref(),
    )?;
    let need = 2 * (spec.model.na + spec.model.nb + 2);
    if u.len() < need {
        return Err(SmidError::Data {
            file: base.join(&dynm.file),
            location: format!("column `{}`", dynm.u),
            message: format!(
                "too short: {} dynamic samples, need at least {need} for na = {}, nb = {}",
                u.len(),
                spec.model.na,
                spec.model.nb
            ),
        });
    }
    let steady = SteadyStateData {
        points: us
            .iter()
            .zip(&ys)
            .enumerate()
            .map(|(i, (&u, &y))| crate::nonlinearity::SteadyPoint {
                u,
                y,
                dy: delta,
                alpha: 0.0,
                rising: u > 0.0,
                index: i,
            })
            .collect(),
    };
    let filter = spec.experiment.filter.pole.map(|a| FilterDesign::given(a));
    Ok(ExperimentData {
        steady,
        dy: vec![delta; u.len()],
        u,
        y,
        filter,
        ..Default::default()
    })
}

/// Stages 1-3 on acquired data. `truth` holds known true values by parameter name.
pub fn identify(
    spec: &Spec,
    mut data: ExperimentData,
    truth: &[(String, f64)],
) -> Result<Identification> {
    let delta = spec.noise.delta()?;
    let step = data
        .filter
        .as_ref()
        .and_then(|f| f.step)
        .unwrap_or(spec.experiment.filter.step);
    match spec.method.alpha {
        AlphaSpec::Bias => experiment::apply_alpha(&mut data.steady, step),
        AlphaSpec::Design => match data.filter.as_ref().and_then(|f| f.overshoot) {
            Some(d) => experiment::apply_design_alpha(&mut data.steady, d, step),
            None => {
                return Err(SmidError::invalid(
                    "method.alpha",
                    "`design` needs the filter pole from the Appendix search on the plant; with a given pole or measured data choose `bias` or `zero`",
                ))
            }
        },
        AlphaSpec::Zero => {}
    }
    let truth_of = |n: &str| truth.iter().find(|(k, _)| k == n).map(|(_, v)| *v);

    data.steady.validate()?;
    crate::inversion::check_outputs(&data.y, &data.dy)?;

    // Stage 1.
    let set = spec.model.nonlinearity.bound_steady_state(&data.steady)?;
    let gamma = set.parameters();
    let gamma_truth: Option<Vec<f64>> = gamma.iter().map(|b| truth_of(&b.name)).collect();
    let truth_in_set = gamma_truth.as_ref().map(|t| set.contains(t));

    // Stage 2.
    let exact = |v: &[f64]| v.iter().map(|&a| Interval::new(a, a)).collect::<Vec<_>>();
    let (output, input, inner) = match spec.model.structure {
        Structure::Wiener => {
            let inner = set.invert(&data.y, &data.dy)?;
            (inner.clone(), exact(&data.u), inner)
        }
        Structure::Hammerstein => {
            let prop = set.propagate(&data.u)?;
            let out = data
                .y
                .iter()
                .zip(&data.dy)
                .map(|(&y, &d)| InnerBound {
                    interval: Interval::new(y - d, y + d).outward(),
                    kind: InnerKind::Inverted,
                })
                .collect();
            (out, prop.iter().map(|b| b.interval).collect(), prop)
        }
    };
    let inner_violations = data.x.as_ref().map(|x| {
        x.iter()
            .zip(&inner)
            .filter(|(v, b)| b.interval.is_finite() && !b.interval.contains(**v))
            .count()
    });

    // Stage 3.
    let fixed = spec.fixed_theta()?;
    let problem = EivProblem {
        na: spec.model.na,
        nb: spec.model.nb,
        fixed,
        unit_gain: spec.model.unit_gain,
        output: &output,
        input: &input,
        use_band_samples: spec.method.use_band_samples(),
        extra: &[],
        prior: None,
    };
    let eiv = crate::stage3::solve(spec.method.eiv, &problem)?;

    let mut parameters: Vec<ParamResult> = gamma
        .iter()
        .map(|b| ParamResult::new(&b.name, b.interval, truth_of(&b.name)))
        .collect();
    for (name, b) in problem.names().iter().zip(&eiv.bounds) {
        parameters.push(ParamResult::new(name, *b, truth_of(name)));
    }
    let snr_db = match (&data.w, &data.noise) {
        (Some(w), Some(n)) => noise::snr_db(w, n),
        // Measured data: signal power against the power of uniform noise in [-Δη, Δη].
        _ => {
            let ps: f64 = data.y.iter().map(|v| v * v).sum();
            10.0 * (ps / (data.y.len() as f64 * delta * delta / 3.0)).log10()
        }
    };
    Ok(Identification {
        name: spec.name.clone().unwrap_or_else(|| "smid".into()),
        delta_eta: delta,
        snr_db,
        parameters,
        set,
        inner,
        equations: eiv.equations,
        data,
        truth_in_nonlinearity_set: truth_in_set,
        inner_violations,
    })
}

/// Acquire data for a spec whose plant is the built-in simulator or CSV data, then identify.
/// (Other plant kinds are built by the crates that provide them; see [`run_with_plant`].)
pub fn run(spec: &Spec, base: &Path) -> Result<Identification> {
    if let Some(mut plant) = builtin_plant(spec) {
        return run_with_plant(spec, &mut plant);
    }
    if spec.plant.data.is_some() {
        let data = load_data(spec, base)?;
        let truth: Vec<(String, f64)> = spec
            .plant
            .truth
            .iter()
            .map(|(k, v)| (k.clone(), *v))
            .collect();
        return identify(spec, data, &truth);
    }
    Err(SmidError::invalid(
        "plant",
        "this plant kind needs a plant provider (e.g. the FMU crate); use the `smid` CLI",
    ))
}

/// Run the experiments on `plant` and identify. The truth is the plant's own, overridden by
/// `plant.truth` of the spec.
pub fn run_with_plant(spec: &Spec, plant: &mut dyn Plant) -> Result<Identification> {
    let data = simulate_experiments(spec, plant)?;
    let mut truth = plant.truth();
    for (k, v) in &spec.plant.truth {
        truth.retain(|(n, _)| n != k);
        truth.push((k.clone(), *v));
    }
    identify(spec, data, &truth)
}
