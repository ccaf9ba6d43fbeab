//! # smid
//!
//! Set-membership identification of block-oriented nonlinear systems. smid fits a model made
//! of a linear block `G(q⁻¹) = B(q⁻¹) / A(q⁻¹)` and a hard nonlinearity (backlash, dead zone,
//! saturation, ...) to input/output data and returns a **guaranteed bound** on every
//! parameter: an interval that holds the true value whenever the measurement noise stays
//! within the declared bound, `|η_t| <= Δη`. Set-membership (or bounded-error) identification
//! keeps every parameter value that explains the data within that bound, instead of one
//! least-squares estimate; it proceeds in three stages: the nonlinearity's parameters from
//! steady-state data, bounds on the unmeasured inner signal between the two blocks, then the
//! linear block's parameters.
//!
//! This is the facade crate. It re-exports the core ([`core`], the crate `smid_core`) and
//! every bundled plugin, links the plugins so a spec's `type` tags resolve, and holds the entry
//! points of the `smid` command-line tool: [`parse_spec`] and [`load_spec`] read a *spec* (the
//! YAML document that names the plant, the noise bound, the experiments, the model and the
//! method), [`run_spec`] and [`run_spec_file`] acquire the data and identify, and
//! [`write_run`] writes `result.json` and the plots, as `smid run` does.
//!
//! ## Example
//!
//! The example of the founding paper: a second-order linear block followed by an asymmetric
//! output backlash, read through a 15-bit encoder (the spec `examples/paper.yaml`). The
//! built-in simulator plays the true plant, so every bound can be checked against the truth.
//!
//! ```
//! use smid::Outcome;
//! use std::path::Path;
//!
//! let yaml = r#"
//! name: paper-section-6
//! plant:
//!   simulator:
//!     structure: wiener
//!     a: [0.5, 0.7]
//!     b: [0.0, 1.4, 0.8]
//!     nonlinearity: { type: output_backlash, m_l: 0.248, c_l: 0.0698, m_r: 0.252, c_r: 0.0349 }
//! noise:
//!   encoder_bits: 15
//! experiment:
//!   seed: 1
//!   filter: { a_bar: 1.0, tol: 0.1, epsilon: 1.0e-5, step: 3.0 }
//!   steady_state: { amplitudes: 50, min: 0.6, max: 3.0 }
//!   dynamic: { length: 100, amplitude: 1.0 }
//! model:
//!   structure: wiener
//!   nonlinearity: { type: output_backlash }
//!   na: 2
//!   nb: 2
//!   fixed: { b0: 0.0 }
//!   unit_gain: true
//! method:
//!   alpha: design
//!   eiv: classical
//! "#;
//! let spec = smid::parse_spec(yaml, Path::new("<string>"))?;
//! // Relative paths in the spec (a CSV, an FMU) would resolve against the second argument.
//! let id = match smid::run_spec(&spec, Path::new("."), &|_| {})? {
//!     Outcome::Consistent(id) => id,
//!     // No model of the declared class fits the data within Δη: a finding, not an error.
//!     Outcome::Falsified(f) => panic!("{}", f.message()),
//! };
//! println!("Δη = {:.3e}", id.delta_eta);
//! for p in id.parameters() {
//!     println!("{:<4} in [{:+.5}, {:+.5}], true {:?}", p.name, p.lower, p.upper, p.truth);
//!     // Each parameter's truth lies inside its guaranteed bound.
//!     assert_eq!(p.contains, Some(true), "{}", p.name);
//! }
//! assert_eq!(id.all_contain_truth(), Some(true));
//! # Ok::<(), smid::SmidError>(())
//! ```
//!
//! [`core::report::table`] formats the same bounds as `smid run` prints them.
//!
//! ## The guide
//!
//! The user guide is the mdBook in the repository's `docs/` folder (`mdbook build docs`).
//! Start with `docs/getting-started.md` (installation and a first run), then
//! `docs/concepts.md` (the model class, the three stages, a glossary) and
//! `docs/guarantees.md` (what is guaranteed, under which assumptions). `docs/extending.md`
//! shows how to write a nonlinearity plugin, an effect or a stage-3 method against
//! [`core::nonlinearity`], and `docs/reference/` lists every spec field, output file and
//! command.
//!
//! ## Crate map
//!
//! Besides the entry points above, the modules hold what the CLI's other commands run:
//! validation and diagnosis of an identified model against fresh records ([`closeloop`], for
//! `smid validate` and `smid diagnose`; the computing is in [`core::validate`] and
//! [`core::diagnose`]), experiment data from a plant without identifying ([`simulate`]), the
//! paper's Section 6 tables ([`reproduce`], [`compare`]) and the Monte Carlo containment
//! checks ([`montecarlo`], [`plugin_check`], [`chain_check`], [`diagnose_check`]); [`sweep`]
//! splits the seeds of `smid check` and `smid reproduce paper` into shards. FMU plants ([`with_fmu_plant`]) need the cargo feature `fmu`.
#![forbid(unsafe_code)]
#![warn(missing_docs)]

pub use smid_core as core;
pub use smid_core::{Falsification, Outcome, Result, SmidError};
#[cfg(feature = "fmu")]
pub use smid_fmu as fmu;
/// The moment relaxation of stage 3 (`method.eiv: sdp`), a method in a crate of its own: always
/// linked, so a spec asking for it without the feature `sdp` gets an error naming the feature.
pub use smid_sdp as sdp;
// Every plugin crate of this package's `[dependencies]` under `plugins/`, re-exported by its
// name without `smid-` (`smid::dead_zone`), and `PLUGIN_PACKAGES` (written by `build.rs`).
include!(concat!(env!("OUT_DIR"), "/plugins.rs"));

pub mod chain_check;
pub mod closeloop;
pub mod compare;
pub mod diagnose_check;
pub mod montecarlo;
pub mod plugin_check;
pub mod reproduce;
pub mod simulate;
pub mod spec_reference;
pub mod sweep;

use smid_core::pipeline::{self, Identification};
use smid_core::spec::Spec;
use std::path::Path;

/// Make every bundled plugin crate part of the final binary, so their `type` tags are
/// registered. Linking is done by the facade's re-exports of its plugin dependencies (one line
/// each in its `Cargo.toml`, read by `build.rs`): a binary or test that depends on `smid` links
/// them all, and their `inventory` registrations with them. This function reads the registry
/// once so that the registrations are in place before a spec is parsed; a program that uses
/// only `smid_core` links no plugin and sees "unknown variant ... there are no variants".
pub fn link_plugins() {
    std::hint::black_box(smid_core::registry::model_types());
}

/// The Cargo package names of the plugin crates this facade links, sorted: the dependencies of
/// its `Cargo.toml` whose path lies under `plugins/`. A test checks that each one registered a
/// plugin or an effect.
pub fn bundled_plugins() -> Vec<String> {
    PLUGIN_PACKAGES.iter().map(|p| p.to_string()).collect()
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

/// Parse a spec from text (`label` names it in errors: a file, or `"<string>"`) with every
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
