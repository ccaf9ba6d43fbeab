//! # smid
//!
//! Set-membership identification of block-oriented nonlinear systems: the facade crate. It
//! re-exports the core, links every bundled plugin (so their `type` tags are registered), builds
//! plants from specs, and holds the paper reproduction and Monte Carlo containment checks used
//! by the `smid` CLI.
#![forbid(unsafe_code)]

pub use smid_bias as bias;
pub use smid_core as core;
pub use smid_core::{Falsification, Outcome, Result, SmidError};
pub use smid_dead_zone as dead_zone;
pub use smid_effects as effects;
pub use smid_example_gain as example_gain;
pub use smid_filters as filters;
#[cfg(feature = "fmu")]
pub use smid_fmu as fmu;
pub use smid_input_backlash as input_backlash;
pub use smid_linear as linear;
pub use smid_output_backlash as output_backlash;
pub use smid_saturation as saturation;

pub mod chain_check;
pub mod closeloop;
pub mod compare;
pub mod diagnose_check;
pub mod montecarlo;
pub mod plugin_check;
pub mod reproduce;
pub mod simulate;
pub mod sweep;

use smid_core::pipeline::{self, Identification};
use smid_core::spec::Spec;
use std::path::Path;

/// The bundled plugin crates, one line each (adding a plugin crate to smid is its crate plus
/// one line here): a vtable of each plugin's model makes the linker keep that crate's code,
/// and with it its registrations (`register_model!`, `register_nonlinearity!`, typetag).
fn bundled_models() -> Vec<Box<dyn smid_core::nonlinearity::NonlinearityModel>> {
    vec![
        Box::new(smid_output_backlash::OutputBacklashModel::default()),
        Box::new(smid_input_backlash::InputBacklashModel::default()),
        Box::new(smid_dead_zone::DeadZoneModel::default()),
        Box::new(smid_saturation::SaturationModel::default()),
        Box::new(smid_example_gain::GainModel::default()),
        Box::new(smid_linear::LinearModel::default()),
        Box::new(smid_filters::LagModel::default()),
        Box::new(smid_bias::BiasModel::default()),
    ]
}

/// Make every bundled plugin crate part of the final binary, so their `type` tags are
/// registered with typetag. A program that uses only `smid_core` links no plugin and sees
/// "unknown variant ... there are no variants"; go through this facade (or call this) instead.
pub fn link_plugins() {
    std::hint::black_box(bundled_models());
    let effects: fn() = smid_effects::link;
    std::hint::black_box(effects);
}

/// The `type` tags of the bundled plugin crates (what [`link_plugins`] links), for the test
/// that each one registered itself.
pub fn bundled_plugins() -> Vec<String> {
    bundled_models()
        .iter()
        .map(|m| smid_core::nonlinearity::tag_of_model(m.as_ref()))
        .collect()
}

/// Parse a spec file with every bundled plugin registered.
pub fn load_spec(path: &Path) -> Result<Spec> {
    link_plugins();
    Spec::from_file(path)
}

/// A spec file with its experiments run on its built-in simulator (`plant.simulator`), as
/// `smid run` acquires them: the training data a diagnosis or a test starts from.
pub fn load_simulated(path: &Path) -> Result<(Spec, pipeline::ExperimentData)> {
    let spec = load_spec(path)?;
    let data = {
        let mut plant = pipeline::builtin_plant(&spec).ok_or_else(|| {
            SmidError::invalid(
                "plant",
                format!(
                    "{}: expected a built-in simulator (`plant.simulator`)",
                    path.display()
                ),
            )
        })?;
        pipeline::simulate_experiments(&spec, &mut plant)?
    };
    Ok((spec, data))
}

/// Load a spec file, acquire its data (simulator, CSV or FMU) and identify. A relative FMU path
/// resolves against the spec file's directory.
pub fn run_spec_file(path: &Path) -> Result<Outcome<Identification>> {
    run_spec_file_with(path, &|_| {})
}

/// [`run_spec_file`] with a progress callback for the branch and bound.
pub fn run_spec_file_with(
    path: &Path,
    progress: &(dyn Fn(&smid_core::cells::Progress) + Sync),
) -> Result<Outcome<Identification>> {
    let spec = load_spec(path)?;
    let base = path.parent().unwrap_or(Path::new("."));
    run_spec(&spec, base, progress)
}

/// Acquire the data of a parsed spec (relative paths against `base`) and identify.
pub fn run_spec(
    spec: &Spec,
    base: &Path,
    progress: &(dyn Fn(&smid_core::cells::Progress) + Sync),
) -> Result<Outcome<Identification>> {
    if spec.plant.data.is_some() {
        let data = pipeline::load_data(spec, base)?;
        return pipeline::identify_with(spec, data, &pipeline::declared_truth(spec), progress);
    }
    closeloop::with_plant(spec, base, |plant| {
        let data = pipeline::simulate_experiments(spec, plant)?;
        let truth = pipeline::plant_truth(spec, plant)?;
        pipeline::identify_with(spec, data, &truth, progress)
    })
}

/// Parse a spec from text (`label` names it in errors: a file, or "<string>") with every
/// bundled plugin registered.
pub fn parse_spec(text: &str, label: &Path) -> Result<Spec> {
    link_plugins();
    Spec::parse(text, label)
}

/// The content of `result.json`: the identification, its spec and the spec's directory (so
/// `smid validate result.json` and `smid diagnose result.json` can rebuild everything).
pub fn result_value(
    id: &Identification,
    spec: &Spec,
    spec_dir: &Path,
) -> Result<serde_json::Value> {
    let mut v = smid_core::report::result_json(id);
    v["spec"] =
        serde_json::to_value(spec).map_err(|e| SmidError::invalid("spec", e.to_string()))?;
    let spec_dir = if spec_dir.as_os_str().is_empty() {
        Path::new(".")
    } else {
        spec_dir
    };
    let spec_dir = std::fs::canonicalize(spec_dir).unwrap_or_else(|_| spec_dir.to_path_buf());
    v["spec_dir"] = serde_json::json!(spec_dir);
    Ok(v)
}

/// Write the outputs of `smid run` into `dir`: `result.json` ([`result_value`], relative paths
/// of the spec against `spec_dir`), `data.csv`, SVG plots. Returns the files written.
pub fn write_run(
    id: &Identification,
    spec: &Spec,
    spec_dir: &Path,
    dir: &Path,
) -> Result<Vec<std::path::PathBuf>> {
    let mut files = smid_core::report::write_all(id, dir)?;
    let path = dir.join("result.json");
    let v = result_value(id, spec, spec_dir)?;
    std::fs::write(&path, serde_json::to_string_pretty(&v).unwrap_or_default()).map_err(
        |source| SmidError::Io {
            path: path.clone(),
            source,
        },
    )?;
    if !files.contains(&path) {
        files.push(path);
    }
    Ok(files)
}

/// Build the FMU plant a spec names and hand it to `f`.
#[cfg(feature = "fmu")]
pub fn with_fmu_plant<T>(
    spec: &Spec,
    base: &Path,
    f: impl FnOnce(&mut dyn smid_core::plant::Plant) -> Result<T>,
) -> Result<T> {
    let mut plant = smid_fmu::from_spec(&spec.plant, base)?;
    f(&mut plant)
}

/// Without the `fmu` feature an FMU plant is a clear error saying how to get one.
#[cfg(not(feature = "fmu"))]
pub fn with_fmu_plant<T>(
    _spec: &Spec,
    _base: &Path,
    _f: impl FnOnce(&mut dyn smid_core::plant::Plant) -> Result<T>,
) -> Result<T> {
    Err(SmidError::Unsupported {
        plugin: "this smid build".into(),
        what: "FMU plants: rebuild with `--features fmu` (needs apt libclang-dev for the FMI bindings)".into(),
    })
}
