//! Monte Carlo containment check: random stable linear blocks with unit steady-state gain
//! (eq 8), random output backlash, random noise bound, noise uniform inside its bound; runs the
//! whole pipeline and counts the trials whose bounds contain the truth. A bound that misses the
//! truth is the worst bug smid can have; this is the release-mode check that hunts for one.
use rand::{Rng, SeedableRng};
use smid_core::linear::LinearModel;
use smid_core::model::UndecidedCause;
use smid_core::noise::NoiseSpec;
use smid_core::pipeline::{self, Identification};
use smid_core::plant::SimulatedPlant;
use smid_core::spec::{ExperimentSpec, MethodSpec, ModelSpec, PlantSpec, Spec};
use smid_core::Outcome as Status;
use smid_core::Result;
use smid_core::SmidError;
use smid_output_backlash::{Backlash, OutputBacklashModel};

/// One random problem.
#[derive(Debug, Clone)]
pub struct Trial {
    /// The true linear block: stable, second order, `b0 = 0`, unit gain.
    pub linear: LinearModel,
    /// The true output backlash.
    pub backlash: Backlash,
    /// Encoder resolution `n_bit` (sets the noise bound).
    pub bits: u32,
    /// The seed everything was drawn from.
    pub seed: u64,
}

/// A random stable second-order block with `b0 = 0` and unit gain.
pub fn random_linear(rng: &mut impl Rng) -> LinearModel {
    let (a1, a2) = if rng.gen_bool(0.6) {
        let r: f64 = rng.gen_range(0.2..0.85);
        let phi: f64 = rng.gen_range(0.0..std::f64::consts::PI);
        (-2.0 * r * phi.cos(), r * r)
    } else {
        let p1: f64 = rng.gen_range(-0.8..0.9);
        let p2: f64 = rng.gen_range(-0.8..0.9);
        (-(p1 + p2), p1 * p2)
    };
    let g = 1.0 + a1 + a2;
    // A(1) > 0 for a stable A; split the gain between b1 and b2.
    let b1 = rng.gen_range(0.2..1.5) * g;
    LinearModel {
        a: vec![a1, a2],
        b: vec![0.0, b1, g - b1],
    }
}

/// PRBS amplitude that makes the inner signal cross the dead band often: a designer scales the
/// excitation to the play, or most outputs stay constant and the inner signal is not invertible.
pub fn prbs_amplitude(b: &Backlash) -> f64 {
    1.0 + 4.0 * (b.c_l + b.c_r)
}

/// The model a random trial is identified with: `nonlinearity` on its side
/// (`structure`), a linear block of orders 2/2 with `b0 = 0` and unit gain, nothing else.
pub(crate) fn trial_model(
    structure: smid_core::nonlinearity::Structure,
    nonlinearity: Box<dyn smid_core::nonlinearity::NonlinearityModel>,
) -> ModelSpec {
    ModelSpec {
        structure,
        nonlinearity,
        na: 2,
        nb: 2,
        fixed: [("b0".to_string(), 0.0)].into_iter().collect(),
        unit_gain: true,
        nk: 0,
        input: Vec::new(),
        output: Vec::new(),
        effects: Vec::new(),
        prior: Default::default(),
        stable: false,
        feedback: false,
    }
}

impl Trial {
    /// Draw a trial from a seed, redrawing until the backlash is physical over the range the
    /// experiments reach (steady-state amplitudes up to 3; the PRBS response up to the L1 norm
    /// of the impulse response).
    pub fn random(seed: u64) -> Trial {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        loop {
            let linear = random_linear(&mut rng);
            let backlash = Backlash::random(&mut rng);
            let l1: f64 = linear
                .simulate(&[1.0; 400])
                .windows(2)
                .map(|w| (w[1] - w[0]).abs())
                .sum::<f64>()
                + 1.0;
            if backlash.is_physical(3.0f64.max(l1 * prbs_amplitude(&backlash))) {
                return Trial {
                    linear,
                    backlash,
                    bits: rng.gen_range(8..=16),
                    seed,
                };
            }
        }
    }

    /// The spec identifying this trial (orders 2/2, `b0 = 0`, α on its bias side).
    pub fn spec(&self) -> Spec {
        let mut experiment = ExperimentSpec {
            seed: self.seed,
            ..Default::default()
        };
        experiment.filter.tol = 0.05;
        experiment.dynamic.length = 200;
        experiment.dynamic.amplitude = prbs_amplitude(&self.backlash);
        Spec {
            name: Some(format!("trial-{}", self.seed)),
            plant: PlantSpec::default(),
            noise: NoiseSpec {
                delta: None,
                encoder_bits: Some(self.bits),
                simulate: None,
                estimate: None,
                from: None,
            },
            experiment,
            model: trial_model(Default::default(), Box::new(OutputBacklashModel::default())),
            method: MethodSpec::default(),
            diagnosis: Default::default(),
        }
    }

    /// Run the whole pipeline on this trial.
    pub fn run(&self) -> Result<Status<Identification>> {
        self.run_spec(&self.spec())
    }
}

/// Turn a trial's spec into identification from any record: no steady-state experiment, a PRBS
/// of 400 samples, classical stage 3, and a prior box per nonlinearity parameter drawn from the
/// trial's seed so that it contains the true value: a width of 20-100 % of the value (at least
/// 0.05) placed at random around it; slopes (`m_*`) keep at least a fifth of their value,
/// half-plays and levels stay non-negative.
pub fn any_record(spec: &mut Spec, truth: &[(String, f64)], seed: u64) {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed ^ 0x5eed_a11c_0de5);
    spec.experiment.steady_state.skip = true;
    spec.experiment.dynamic.length = 400;
    spec.method.eiv = smid_core::spec::EivMethod::Classical;
    // The random linear blocks are stable, and the spec says so (`model.stable`).
    spec.model.stable = true;
    for (name, v) in truth {
        let w = v.abs().max(0.05) * rng.gen_range(0.2..1.0);
        let f: f64 = rng.gen_range(0.0..1.0);
        let (mut lo, hi) = (v - w * f, v + w * (1.0 - f));
        if name.starts_with('m') {
            lo = lo.max(0.2 * v);
        } else if *v >= 0.0 {
            lo = lo.max(0.0);
        }
        spec.model.prior.insert(name.clone(), [lo, hi]);
    }
}

/// Why a trial gave no finite bound: taken from the typed result of the trial (the cell's
/// [`UndecidedCause`], the [`SmidError`] variant), never from its message.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Cause {
    /// Cells left undecided when the refinement budget was spent (every other bound holds).
    Cell(UndecidedCause),
    /// No bisection (the designed experiment): the record itself leaves θ unbounded.
    UnboundedRecord,
    /// The LP solver failed outside the branch and bound's recovery.
    Solver,
    /// Any other error (a plant, a data or spec problem).
    Other,
}

impl Cause {
    /// The cause of a trial that ended in `e`.
    pub fn of_error(e: &SmidError) -> Cause {
        match e {
            SmidError::Unbounded { .. } => Cause::UnboundedRecord,
            SmidError::Solver(_) => Cause::Solver,
            _ => Cause::Other,
        }
    }
    /// What `smid check` prints.
    pub fn label(self) -> &'static str {
        match self {
            Cause::Cell(c) => c.label(),
            Cause::UnboundedRecord => "stage 3 unbounded on the whole record",
            Cause::Solver => "LP solver failure",
            Cause::Other => "other error",
        }
    }
}

/// Outcome counts of a Monte Carlo run (or of one shard of it: `smid check --shard K/M --json`;
/// [`Summary::merge`] joins shards into the summary of the whole run).
#[derive(Debug, Default, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Summary {
    /// Trials run.
    pub trials: usize,
    /// Trials whose every bound is finite and contains the truth.
    pub contained: usize,
    /// Trials whose bounds missed the truth (a bug): seeds.
    pub missed: Vec<u64>,
    /// Trials that ended in an error (e.g. too few invertible samples): seed and message.
    pub errors: Vec<(u64, String)>,
    /// Trials whose every bound holds but some `θ` bound is infinite (cells left unbounded
    /// when the refinement budget was spent): seed and detail. Not counted in `contained`.
    #[serde(default)]
    pub partial: Vec<(u64, String)>,
    /// The cause of each trial in `errors` and `partial`, by seed (in seed order).
    #[serde(default)]
    pub causes: Vec<(u64, Cause)>,
}

/// Trials without a finite bound (partial and errors) counted by cause, most frequent first.
pub fn causes(s: &Summary) -> Vec<(&'static str, usize)> {
    let mut out: Vec<(&'static str, usize)> = Vec::new();
    for (_, c) in &s.causes {
        let c = c.label();
        match out.iter_mut().find(|(k, _)| *k == c) {
            Some((_, n)) => *n += 1,
            None => out.push((c, 1)),
        }
    }
    out.sort_by(|a, b| b.1.cmp(&a.1).then(a.0.cmp(b.0)));
    out
}

impl Summary {
    /// The summary of the trials of all `parts` (shards of one run): counts added, seeds in
    /// order, so merging the shards of a run gives exactly the one-machine summary.
    pub fn merge(parts: &[Summary]) -> Summary {
        let mut s = Summary::default();
        for p in parts {
            s.trials += p.trials;
            s.contained += p.contained;
            s.missed.extend(&p.missed);
            s.errors.extend(p.errors.iter().cloned());
            s.partial.extend(p.partial.iter().cloned());
            s.causes.extend(p.causes.iter().cloned());
        }
        s.missed.sort_unstable();
        s.errors.sort_by_key(|e| e.0);
        s.partial.sort_by_key(|e| e.0);
        s.causes.sort_by_key(|e| e.0);
        s
    }
}

/// The seeds of shard `k` of `m` (1-based) of the run with seeds `first..first+n`: every m-th
/// seed from the k-th, so the shards are disjoint, cover the run and take about equal time.
/// `None`: the whole run.
pub fn shard_seeds(first: u64, n: usize, shard: Option<(usize, usize)>) -> Vec<u64> {
    let (k, m) = shard.unwrap_or((1, 1));
    (0..n)
        .filter(|i| m == 0 || i % m == k.saturating_sub(1))
        .map(|i| first + i as u64)
        .collect()
}

/// Run `n` trials with seeds `first..first+n`, calling `tick` after each.
pub fn run(first: u64, n: usize, tick: impl Fn() + Sync) -> Summary {
    run_seeds(&shard_seeds(first, n, None), 1, tick, |seed| {
        Trial::random(seed).run()
    })
}

/// Run `trial` for each of `seeds` on `jobs` threads (seeds dealt round-robin), calling `tick`
/// after each; the summary lists seeds in order whatever the thread timing.
pub fn run_seeds(
    seeds: &[u64],
    jobs: usize,
    tick: impl Fn() + Sync,
    trial: impl Fn(u64) -> Result<Status<Identification>> + Sync,
) -> Summary {
    let n = seeds.len();
    let jobs = jobs.clamp(1, n.max(1));
    let mut outcomes: Vec<(u64, std::result::Result<Outcome, (Cause, String)>)> =
        std::thread::scope(|sc| {
            let handles: Vec<_> = (0..jobs)
                .map(|j| {
                    let (tick, trial) = (&tick, &trial);
                    sc.spawn(move || {
                        let mut v = Vec::new();
                        for &seed in seeds.iter().skip(j).step_by(jobs) {
                            let o = match trial(seed) {
                                // A certified simulation member outside the bounds is a miss
                                // too (it lies in the feasible set).
                                Ok(Status::Consistent(id)) => Ok(outcome(&id)),
                                // The true plant's data with noise inside its bound cannot
                                // falsify the true model: a falsification is a miss.
                                Ok(Status::Falsified(_)) => Ok(Outcome::Missed),
                                Err(e) => Err((Cause::of_error(&e), e.to_string())),
                            };
                            v.push((seed, o));
                            tick();
                        }
                        v
                    })
                })
                .collect();
            handles
                .into_iter()
                .flat_map(|h| match h.join() {
                    Ok(v) => v,
                    Err(p) => std::panic::resume_unwind(p),
                })
                .collect()
        });
    outcomes.sort_by_key(|o| o.0);
    let mut s = Summary {
        trials: n,
        ..Default::default()
    };
    for (seed, o) in outcomes {
        match o {
            Ok(Outcome::Contained) => s.contained += 1,
            Ok(Outcome::Missed) => s.missed.push(seed),
            Ok(Outcome::Partial(cause, detail)) => {
                s.partial.push((seed, detail));
                s.causes.push((seed, cause));
            }
            Err((cause, e)) => {
                s.errors.push((seed, e));
                s.causes.push((seed, cause));
            }
        }
    }
    s
}

/// What one trial showed.
enum Outcome {
    /// Every bound finite and holding the truth.
    Contained,
    /// Every bound holds, some `θ` bound infinite (the cause and its detail).
    Partial(Cause, String),
    /// A bound misses the truth, or a certified member lies outside a bound.
    Missed,
}

fn outcome(id: &Identification) -> Outcome {
    // A certified simulation member outside the bounds is a miss too (it lies in the
    // feasible set).
    if id.all_contain_truth() != Some(true) || !id.model.member_outside_bounds().is_empty() {
        return Outcome::Missed;
    }
    match id.model.search.unbounded.first() {
        Some(u) => Outcome::Partial(
            Cause::Cell(u.cause),
            format!("{}: {}", u.cause.label(), u.detail),
        ),
        None if id.parameters().iter().any(|p| !p.interval().is_finite()) => Outcome::Partial(
            Cause::Cell(UndecidedCause::Unbounded),
            format!("{}: an infinite bound", UndecidedCause::Unbounded.label()),
        ),
        None => Outcome::Contained,
    }
}

impl Trial {
    /// Run the whole pipeline on this trial with stage 3 by `method`.
    pub fn run_method(&self, method: smid_core::spec::EivMethod) -> Result<Status<Identification>> {
        let mut spec = self.spec();
        spec.method.eiv = method;
        self.run_spec(&spec)
    }

    /// Run `spec` on this trial's plant.
    pub fn run_spec(&self, spec: &Spec) -> Result<Status<Identification>> {
        let mut plant = SimulatedPlant {
            linear: self.linear.clone(),
            nonlinearity: &self.backlash,
            structure: Default::default(),
            input: &[],
            output: &[],
            effects: &[],
            dt: 1.0,
            feedback: false,
        };
        pipeline::run_with_plant(spec, &mut plant)
    }
}

impl Trial {
    /// Run this trial from one dynamic record, the backlash bisected over a random prior box
    /// around the truth ([`any_record`]); stage 3 by `method` (default
    /// classical).
    pub fn run_any(
        &self,
        method: Option<smid_core::spec::EivMethod>,
    ) -> Result<Status<Identification>> {
        let mut spec = self.any_spec();
        if let Some(m) = method {
            spec.method.eiv = m;
        }
        self.run_spec(&spec)
    }

    /// This trial's spec from one dynamic record ([`any_record`]).
    pub fn any_spec(&self) -> Spec {
        use smid_core::nonlinearity::Nonlinearity;
        let mut spec = self.spec();
        any_record(&mut spec, &self.backlash.parameters(), self.seed);
        spec
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Causes come from the typed result of each trial, not from its message: a plant error
    /// whose text says "unbounded" and "LP solver" is still "other error"; a solver failure
    /// and an unbounded record are told apart, and a cell left undecided keeps its cause
    /// through a merge of shards.
    #[test]
    fn causes_come_from_the_typed_result() {
        let s = run_seeds(
            &[1, 2, 3, 4],
            2,
            || {},
            |seed| match seed {
                1 => Err(SmidError::Solver("numerical error".into())),
                2 => Err(SmidError::Unbounded {
                    parameter: "a1".into(),
                    message: "the linear program is unbounded".into(),
                }),
                3 => Err(SmidError::Plant {
                    plant: "sim".into(),
                    message: "LP solver said the state is unbounded".into(),
                }),
                _ => Err(SmidError::Solver("again".into())),
            },
        );
        assert_eq!(s.errors.len(), 4);
        let c = causes(&s);
        assert_eq!(
            c,
            vec![
                (Cause::Solver.label(), 2),
                (Cause::Other.label(), 1),
                (Cause::UnboundedRecord.label(), 1),
            ]
        );
        let cell = Summary {
            trials: 1,
            partial: vec![(5, "a1 over in1.c_l".into())],
            causes: vec![(5, Cause::Cell(UndecidedCause::Unbounded))],
            ..Default::default()
        };
        let merged = Summary::merge(&[s, cell]);
        assert_eq!(merged.causes.len(), 5);
        assert!(causes(&merged).contains(&(UndecidedCause::Unbounded.label(), 1)));
        // A shard's JSON keeps the causes.
        let back: Summary = serde_json::from_str(&serde_json::to_string(&merged).unwrap()).unwrap();
        assert_eq!(back, merged);
    }
}
