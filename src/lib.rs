//! # smid
//!
//! Set-membership identification of block-oriented nonlinear systems: the facade crate. It
//! re-exports the core, links every bundled plugin (so their `type` tags are registered), builds
//! plants from specs, and holds the paper reproduction and Monte Carlo containment checks used
//! by the `smid` CLI.
#![forbid(unsafe_code)]

pub use smid_core as core;
pub use smid_core::{Result, SmidError};
pub use smid_dead_zone as dead_zone;
pub use smid_diagnose as diagnose;
pub use smid_effects as effects;
pub use smid_example_gain as example_gain;
#[cfg(feature = "fmu")]
pub use smid_fmu as fmu;
pub use smid_input_backlash as input_backlash;
pub use smid_output_backlash as output_backlash;
pub use smid_saturation as saturation;

pub mod compare;
pub mod montecarlo;
pub mod plugin_check;
pub mod reproduce;
pub mod simulate;

use smid_core::pipeline::{self, Identification};
use smid_core::spec::Spec;
use std::path::Path;

/// Make every bundled plugin crate part of the final binary, so their `type` tags are
/// registered with typetag. A program that uses only `smid_core` links no plugin and sees
/// "unknown variant ... there are no variants"; go through this facade (or call this) instead.
pub fn link_plugins() {
    use smid_core::nonlinearity::NonlinearityModel;
    // A vtable of each plugin's model makes the linker keep that crate's code.
    let models: [Box<dyn NonlinearityModel>; 5] = [
        Box::new(smid_output_backlash::OutputBacklashModel::default()),
        Box::new(smid_input_backlash::InputBacklashModel::default()),
        Box::new(smid_dead_zone::DeadZoneModel::default()),
        Box::new(smid_saturation::SaturationModel::default()),
        Box::new(smid_example_gain::GainModel::default()),
    ];
    std::hint::black_box(models);
    let effects: fn() = smid_effects::link;
    std::hint::black_box(effects);
}

/// Parse a spec file with every bundled plugin registered.
pub fn load_spec(path: &Path) -> Result<Spec> {
    link_plugins();
    Spec::from_file(path)
}

/// Load a spec file, acquire its data (simulator, CSV or FMU) and identify. A relative FMU path
/// resolves against the spec file's directory.
pub fn run_spec_file(path: &Path) -> Result<Identification> {
    let spec = load_spec(path)?;
    let base = path.parent().unwrap_or(Path::new("."));
    if spec.plant.fmu.is_some() {
        return with_fmu_plant(&spec, base, |plant| pipeline::run_with_plant(&spec, plant));
    }
    pipeline::run(&spec, base)
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
