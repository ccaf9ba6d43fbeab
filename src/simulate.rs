//! Experiment data out of a plant without identifying (`smid simulate`): the spec's dynamic
//! experiment (its PRBS, or a longer one) run from rest through the plant the spec names (the
//! built-in simulator or an FMU), with the spec's bounded noise (`noise.simulate`, default the
//! bound Δη) added to the noise-free output. The record is written as CSV with the columns
//! `t, u, y, w` (`y = w + η`, `w` the plant's noise-free output), the layout a diagnosis spec
//! (`smid diagnose`) or a measured-data spec reads by column name.
//!
//! `smid simulate --experiment` writes the spec's whole training experiment instead (the
//! designed steady-state points with their sample times, and the dynamic record) and held-out
//! records, with a spec that reads them as measured data ([`export_experiment`]).
use rand::SeedableRng;
use smid_core::experiment;
use smid_core::noise;
use smid_core::pipeline::{self, ExperimentData, Record};
use smid_core::plant::Plant;
use smid_core::spec::{CsvColumns, Spec};
use smid_core::{Result, SmidError};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// One simulated record of the dynamic experiment.
#[derive(Debug, Clone, PartialEq)]
pub struct SimulatedRecord {
    /// Time of each sample: the sample index times the plant's step (1 for the simulator).
    pub t: Vec<f64>,
    /// The input: the spec's PRBS.
    pub u: Vec<f64>,
    /// Measured output `w + η`, `|η| <= noise.simulate` (default Δη).
    pub y: Vec<f64>,
    /// Noise-free plant output.
    pub w: Vec<f64>,
    /// The noise bound Δη the spec declares.
    pub delta: f64,
    /// The amplitude of the noise that was added.
    pub added: f64,
}

/// Run the spec's PRBS (length `length` if given, seed `seed` if given, else the spec's) from
/// rest through `plant`, and add the spec's bounded noise (same seeded generator: PRBS first,
/// then the noise).
pub fn simulate_with_plant(
    spec: &Spec,
    plant: &mut dyn Plant,
    length: Option<usize>,
    seed: Option<u64>,
    step: f64,
) -> Result<SimulatedRecord> {
    let delta = spec.noise.delta()?;
    let added = spec.noise.simulated()?;
    let mut o = spec.experiment.dynamic_options();
    if let Some(n) = length {
        o.length = n;
    }
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed.unwrap_or(spec.experiment.seed));
    let u = experiment::dynamic_input(&o, &mut rng)?;
    let w = pipeline::run_checked(plant, &u)?;
    let eta = noise::uniform(u.len(), added, &mut rng);
    let y = w.iter().zip(&eta).map(|(a, b)| a + b).collect();
    Ok(SimulatedRecord {
        t: (0..u.len()).map(|k| k as f64 * step).collect(),
        u,
        y,
        w,
        delta,
        added,
    })
}

/// Load a spec file and simulate its plant (built-in simulator or FMU; a relative FMU path
/// resolves against the spec's directory). A measured-data plant cannot be simulated.
pub fn simulate_spec_file(
    path: &Path,
    length: Option<usize>,
    seed: Option<u64>,
) -> Result<SimulatedRecord> {
    let spec = crate::load_spec(path)?;
    simulate_spec(&spec, path.parent().unwrap_or(Path::new(".")), length, seed)
}

/// Simulate a parsed spec's plant (relative FMU paths against `base`): see
/// [`simulate_spec_file`].
pub fn simulate_spec(
    spec: &Spec,
    base: &Path,
    length: Option<usize>,
    seed: Option<u64>,
) -> Result<SimulatedRecord> {
    // An FMU's outputs are sampled every `plant.step` seconds; the built-in simulators count
    // samples.
    let step = match spec.plant.fmu {
        Some(_) => spec.plant.step.unwrap_or(1.0),
        None => 1.0,
    };
    crate::closeloop::with_plant(spec, base, |plant| {
        simulate_with_plant(spec, plant, length, seed, step)
    })
}

/// The record as CSV text: header `t,u,y,w`, one row per sample, shortest round-trip numbers.
pub fn to_csv(r: &SimulatedRecord) -> String {
    let mut s = String::from("t,u,y,w\n");
    for k in 0..r.u.len() {
        let _ = writeln!(s, "{},{},{},{}", r.t[k], r.u[k], r.y[k], r.w[k]);
    }
    s
}

/// Write the record as CSV to `path`, creating its directory.
pub fn write_csv(r: &SimulatedRecord, path: &Path) -> Result<()> {
    let io = |source| SmidError::Io {
        path: path.to_path_buf(),
        source,
    };
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(io)?;
    }
    std::fs::write(path, to_csv(r)).map_err(io)
}

/// What [`write_experiment`] wrote: the measured-data spec that reads the files (also written
/// as `spec.yaml`), and every file's path.
#[derive(Debug)]
pub struct Exported {
    /// The spec with its plant replaced by `plant.data` reading the files.
    pub spec: Spec,
    /// `steady.csv` (when the experiment has steady-state points), `train.csv`,
    /// `holdout<k>.csv`, `spec.yaml`.
    pub files: Vec<PathBuf>,
    /// What the measured-data spec had to state or change that the simulated one left to the
    /// plant (a designed filter pole, the `design` α), one line each.
    pub notes: Vec<String>,
}

/// Write the training data and held-out records as CSV files in `dir` (created), with
/// `spec.yaml`: `spec` with its plant replaced by `plant.data` reading them (and `truth`, when
/// given, as `plant.truth`), as measured data come. Steady-state points: columns `u, y, t`
/// (each point's sample index, which a drift needs; the simulator's sample time is 1) and
/// `step` (the height of the step that led to it, which scales α); records: `u, y`. Numbers
/// in shortest round-trip form, so the files read back to the same values.
pub fn write_experiment(
    spec: &Spec,
    training: &ExperimentData,
    holdout: &[Record],
    truth: &[(String, f64)],
    dir: &Path,
) -> Result<Exported> {
    let write = |name: &str, text: String| -> Result<PathBuf> {
        let path = dir.join(name);
        std::fs::write(&path, text).map_err(|source| SmidError::Io {
            path: path.clone(),
            source,
        })?;
        Ok(path)
    };
    std::fs::create_dir_all(dir).map_err(|source| SmidError::Io {
        path: dir.to_path_buf(),
        source,
    })?;
    let mut files = Vec::new();
    // The columns as `smid simulate` writes them (`CsvColumns::uy`), the steady-state points'
    // with their time and step-height columns.
    let columns = |c: CsvColumns| serde_json::to_value(c).expect("columns serialise");
    let mut data = serde_json::json!({ "dynamic": columns(CsvColumns::uy("train.csv")) });
    if let Some(steady) = &training.steady {
        let mut ss = String::from("u,y,t,step\n");
        for (k, p) in steady.points.iter().enumerate() {
            let t = p.time.ok_or_else(|| {
                SmidError::invalid(
                    format!("steady-state point {k}"),
                    "has no sample time: the CSV's `t` column needs one",
                )
            })?;
            let _ = writeln!(ss, "{:e},{:e},{t},{:e}", p.u, p.y, p.step_height());
        }
        files.push(write("steady.csv", ss)?);
        data["steady_state"] = columns(CsvColumns {
            t: Some("t".into()),
            step: Some("step".into()),
            ..CsvColumns::uy("steady.csv")
        });
    }
    let rec_csv = |r: &Record| {
        let mut d = String::from("u,y\n");
        for (u, y) in r.u.iter().zip(&r.y) {
            let _ = writeln!(d, "{u:e},{y:e}");
        }
        d
    };
    let train = training
        .records
        .first()
        .ok_or_else(|| SmidError::invalid("training data", "no dynamic record"))?;
    files.push(write("train.csv", rec_csv(train))?);
    for (k, r) in holdout.iter().enumerate() {
        files.push(write(&format!("holdout{k}.csv"), rec_csv(r))?);
    }
    let mut v =
        serde_json::to_value(spec).map_err(|e| SmidError::invalid("spec", e.to_string()))?;
    v["plant"] = serde_json::json!({ "data": data });
    if !truth.is_empty() {
        // A true value JSON cannot hold (not finite) is left out rather than written as null.
        let t: serde_json::Map<String, serde_json::Value> = truth
            .iter()
            .filter(|(_, x)| x.is_finite())
            .map(|(k, x)| (k.clone(), serde_json::json!(x)))
            .collect();
        v["plant"]["truth"] = serde_json::Value::Object(t);
    }
    let mut notes = Vec::new();
    // A pole the Appendix search found on the plant is written down: files have no plant to
    // search on. The `design` α needs the plant's measured overshoot, which files do not
    // carry either: the paper's α (`bias`) stands in, and the note says so.
    if let (None, Some(f)) = (spec.experiment.filter.pole, &training.filter) {
        v["experiment"]["filter"]["pole"] = serde_json::json!(f.pole);
        notes.push(format!(
            "experiment.filter.pole: {} (found by the Appendix search on the plant)",
            f.pole
        ));
    }
    if spec.method.alpha == smid_core::spec::AlphaSpec::Design && training.steady.is_some() {
        v["method"]["alpha"] = serde_json::json!("bias");
        notes.push("method.alpha: bias (the spec's `design` needs the plant's measured overshoot, which the files do not carry; `bias` is the paper's α = 2Δη|ū|/r̄_F)".into());
    }
    let spec: Spec =
        serde_json::from_value(v).map_err(|e| SmidError::invalid("spec", e.to_string()))?;
    let text =
        serde_norway::to_string(&spec).map_err(|e| SmidError::invalid("spec", e.to_string()))?;
    files.push(write("spec.yaml", text)?);
    Ok(Exported { spec, files, notes })
}

/// Simulate the spec's whole training experiment through its plant (built-in simulator or
/// FMU, relative paths against `base`) and `holdouts` fresh records (the spec's dynamic length,
/// seeds `experiment.seed + 1000 + k`: the records `smid diagnose` draws when no `--holdout`
/// is given), and write them with [`write_experiment`], the plant's true parameters in the
/// model's names as `plant.truth`.
pub fn export_experiment(
    spec: &Spec,
    base: &Path,
    holdouts: usize,
    dir: &Path,
) -> Result<Exported> {
    type Drawn = (ExperimentData, Vec<Record>, Vec<(String, f64)>);
    let run = |plant: &mut dyn Plant| -> Result<Drawn> {
        let training = pipeline::simulate_experiments(spec, plant)?;
        let seed = spec.experiment.seed + 1000;
        let n = spec.experiment.dynamic.length;
        let held = (0..holdouts as u64)
            .map(|k| pipeline::fresh_record(spec, plant, seed + k, n))
            .collect::<Result<Vec<_>>>()?;
        Ok((training, held, pipeline::plant_truth(spec, plant)?))
    };
    let (training, held, truth) = crate::closeloop::with_plant(spec, base, run)?;
    write_experiment(spec, &training, &held, &truth, dir)
}
