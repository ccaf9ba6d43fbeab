//! Monte Carlo containment check per nonlinearity plugin (`smid check --plugin NAME`): random
//! stable linear blocks with unit steady-state gain (eq 8), random parameters of the chosen
//! nonlinearity, a random noise bound (8 to 16 encoder bits, Section 6) and noise uniform in
//! its bound; the whole three-stage pipeline runs and every bound (stage-1 set, inner-signal
//! samples, parameter intervals) must contain the truth. Each trial runs the Appendix filter
//! search, `M = 20` steady-state amplitudes and a PRBS of `N = 100` samples (the paper's `N`),
//! with orders `na = nb = 2` and `b0 = 0` fixed. The cases are derived from the plugin registry
//! ([`smid_core::registry::check_cases`]): each plugin draws its own true block
//! ([`NonlinearityModel::check_draw`]), this module the linear block, the noise and the
//! experiment. `output_backlash` runs the paper's original trial of [`crate::montecarlo`].
//!
//! `--any-record` checks the general method of [`smid_core::cells`] instead: no steady-state
//! experiment, a PRBS of `N = 400` samples, and every nonlinearity parameter bisected over a
//! random prior box that contains the truth ([`montecarlo::any_record`]); stage 3 classical unless
//! `--method` says otherwise (the branch and bound calls it per cell).
use crate::montecarlo::{self, any_record, random_linear, Summary};
use rand::{Rng, SeedableRng};
use smid_core::linear::LinearModel;
use smid_core::noise::NoiseSpec;
use smid_core::nonlinearity::{Nonlinearity, NonlinearityModel, Structure};
use smid_core::pipeline::{self, Identification};
use smid_core::plant::SimulatedPlant;
use smid_core::spec::{EivMethod, ExperimentSpec, MethodSpec, PlantSpec, Spec};
use smid_core::{registry, Outcome, Result, SmidError};

/// The check cases `smid check --plugin` knows, derived from the registry
/// ([`registry::check_cases`]): every linked plugin that offers a random trial, in each
/// structure it offers one in.
pub fn plugins() -> Vec<String> {
    crate::link_plugins();
    registry::check_cases()
        .into_iter()
        .map(|c| c.name)
        .collect()
}

/// One random problem for a plugin.
#[derive(Debug)]
pub struct PluginTrial {
    /// The check case's name (`smid check --list`): the plugin's tag, with a suffix where
    /// it is checked on more than one side.
    pub plugin: String,
    /// Where the plugin sits relative to the linear block.
    pub structure: Structure,
    /// The true linear block: stable, second order, `b0 = 0`, unit gain.
    pub linear: LinearModel,
    /// The true block, with parameters drawn by the plugin.
    pub nonlinearity: Box<dyn Nonlinearity>,
    /// The model that identifies it.
    pub model: Box<dyn NonlinearityModel>,
    /// Encoder resolution `n_bit`, 8 to 16 (sets the noise bound).
    pub bits: u32,
    /// The seed everything was drawn from.
    pub seed: u64,
    /// Steady-state amplitudes `[min, max]`.
    pub steady: (f64, f64),
    /// Amplitude of the dynamic record (PRBS).
    pub amplitude: f64,
    /// Input levels of the dynamic record (the plugin's
    /// [`NonlinearityModel::check_levels`]; 2: the binary PRBS).
    pub levels: usize,
}

impl PluginTrial {
    /// Draw a trial of the check case `plugin` from a seed: the linear block and the encoder
    /// bits here, the true block by the plugin's own [`NonlinearityModel::check_draw`].
    pub fn random(plugin: &str, seed: u64) -> Result<PluginTrial> {
        crate::link_plugins();
        let case = registry::check_case(plugin)?;
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        let linear = random_linear(&mut rng);
        let bits = rng.gen_range(8..=16);
        let draw = case.draw(&mut rng).ok_or_else(|| {
            SmidError::invalid(
                "--plugin",
                format!("`{}` offered no random trial for seed {seed}", case.name),
            )
        })?;
        let levels = draw.model.check_levels(case.structure);
        Ok(PluginTrial {
            levels,
            plugin: case.name,
            structure: case.structure,
            linear,
            nonlinearity: draw.nonlinearity,
            model: draw.model,
            bits,
            seed,
            steady: draw.steady,
            amplitude: draw.amplitude,
        })
    }

    /// The spec identifying this trial (orders 2/2, `b0 = 0`, unit gain).
    pub fn spec(self) -> (Spec, Box<dyn Nonlinearity>, LinearModel) {
        let mut experiment = ExperimentSpec {
            seed: self.seed,
            ..Default::default()
        };
        experiment.filter.tol = 0.05;
        experiment.steady_state.min = self.steady.0;
        experiment.steady_state.max = self.steady.1;
        // 20 amplitudes (not the paper's 50) keep 1000 trials per plugin affordable.
        experiment.steady_state.amplitudes = 20;
        experiment.dynamic.length = 100;
        experiment.dynamic.amplitude = self.amplitude;
        experiment.dynamic.levels = self.levels;
        let spec = Spec {
            name: Some(format!("{}-trial-{}", self.plugin, self.seed)),
            plant: PlantSpec::default(),
            noise: NoiseSpec {
                delta: None,
                encoder_bits: Some(self.bits),
                simulate: None,
                estimate: None,
                from: None,
            },
            experiment,
            model: montecarlo::trial_model(self.structure, self.model),
            method: MethodSpec::default(),
            diagnosis: Default::default(),
        };
        (spec, self.nonlinearity, self.linear)
    }

    /// Run the whole pipeline on this trial, stage 3 by `method` (`None`: the spec default),
    /// from the designed experiment or, with `any`, from one dynamic record ([`any_record`]).
    pub fn run(self, method: Option<EivMethod>, any: bool) -> Result<Outcome<Identification>> {
        let structure = self.structure;
        let seed = self.seed;
        let (mut spec, nl, linear) = self.spec();
        if any {
            any_record(&mut spec, &nl.parameters(), seed);
        }
        if let Some(m) = method {
            spec.method.eiv = m;
        }
        pipeline::run_with_plant(&spec, &mut simulator(linear, nl.as_ref(), structure))
    }
}

/// The built-in simulator of a trial's plant: the linear block and the nonlinearity in
/// `structure`, no other block or effect, unit sample time.
pub fn simulator(
    linear: LinearModel,
    nonlinearity: &dyn Nonlinearity,
    structure: Structure,
) -> SimulatedPlant<'_> {
    SimulatedPlant {
        linear,
        nonlinearity,
        structure,
        input: &[],
        output: &[],
        effects: &[],
        dt: 1.0,
        feedback: false,
    }
}

/// One trial of the check case `plugin` from `seed`: the founding `output_backlash` runs the
/// paper's own Monte Carlo trial ([`montecarlo::Trial`]), every other case its plugin's draw
/// ([`PluginTrial`]). Stage 3 by `method` (`None`: the spec default, classical with `any`).
pub fn trial(
    plugin: &str,
    seed: u64,
    method: Option<EivMethod>,
    any: bool,
) -> Result<Outcome<Identification>> {
    match (plugin, any) {
        ("output_backlash", true) => montecarlo::Trial::random(seed).run_any(method),
        ("output_backlash", false) => {
            montecarlo::Trial::random(seed).run_method(method.unwrap_or_default())
        }
        _ => PluginTrial::random(plugin, seed)?.run(method, any),
    }
}

/// Run the trials of `plugin` with `seeds` ([`montecarlo::shard_seeds`]), calling `tick` after each.
/// Stage 3 by `method` (`None`: the spec default, classical with `any`), on `jobs` threads;
/// with `any`, identification from one dynamic record ([`any_record`]).
pub fn run(
    plugin: &str,
    seeds: &[u64],
    method: Option<EivMethod>,
    any: bool,
    jobs: usize,
    tick: impl Fn() + Sync,
) -> Result<Summary> {
    crate::link_plugins();
    let plugin = registry::check_case(plugin)?.name;
    Ok(montecarlo::run_seeds(seeds, jobs, tick, |seed| {
        trial(&plugin, seed, method, any)
    }))
}

/// The summary lines `smid check` prints.
pub fn report(plugin: &str, s: &Summary) -> String {
    let mut out = format!(
        "{plugin}: {} trials: truth inside every bound in {}, missed in {}, θ unbounded (the other bounds hold) in {}, no bound (error) in {}\n",
        s.trials,
        s.contained,
        s.missed.len(),
        s.partial.len(),
        s.errors.len()
    );
    let causes = montecarlo::causes(s);
    if !causes.is_empty() {
        out.push_str(&format!(
            "  without a finite bound, by cause: {}\n",
            causes
                .iter()
                .map(|(c, n)| format!("{c} {n}"))
                .collect::<Vec<_>>()
                .join(", ")
        ));
    }
    for seed in &s.missed {
        out.push_str(&format!("  MISSED: seed {seed}\n"));
    }
    for (seed, c) in s.partial.iter().take(10) {
        out.push_str(&format!("  θ unbounded: seed {seed}: {c}\n"));
    }
    for (seed, e) in s.errors.iter().take(20) {
        out.push_str(&format!("  error: seed {seed}: {e}\n"));
    }
    out
}
