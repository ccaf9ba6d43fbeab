//! Experiment data out of a plant without identifying (`smid simulate`): the spec's dynamic
//! experiment (its PRBS, or a longer one) run from rest through the plant the spec names (the
//! built-in simulator or an FMU), with the spec's bounded noise (`noise.simulate`, default the
//! bound Δη) added to the noise-free output. The record is written as CSV with the columns
//! `t, u, y, w` (`y = w + η`, `w` the plant's noise-free output), the layout a diagnosis spec
//! (`smid diagnose`) or a measured-data spec reads by column name.
use rand::SeedableRng;
use smid_core::experiment;
use smid_core::noise;
use smid_core::pipeline;
use smid_core::plant::Plant;
use smid_core::spec::Spec;
use smid_core::{Result, SmidError};
use std::fmt::Write as _;
use std::path::Path;

/// One simulated record of the dynamic experiment.
#[derive(Debug, Clone, PartialEq)]
pub struct SimulatedRecord {
    /// Time of each sample: the sample index times the plant's step (1 for the simulator).
    pub t: Vec<f64>,
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
    if spec.plant.fmu.is_some() {
        let step = spec.plant.step.unwrap_or(1.0);
        return crate::with_fmu_plant(spec, base, |plant| {
            simulate_with_plant(spec, plant, length, seed, step)
        });
    }
    match pipeline::builtin_plant(spec) {
        Some(mut plant) => simulate_with_plant(spec, &mut plant, length, seed, 1.0),
        None => Err(SmidError::invalid(
            "plant",
            "measured data cannot be simulated; give a `simulator` or an `fmu` plant",
        )),
    }
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
