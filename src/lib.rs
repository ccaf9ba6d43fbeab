//! # smid
//!
//! Set-membership identification of block-oriented nonlinear systems: the facade crate. It
//! re-exports the core, links every bundled plugin (so their `type` tags are registered), builds
//! plants from specs, and holds the paper reproduction and Monte Carlo containment checks used
//! by the `smid` CLI.
#![forbid(unsafe_code)]

pub use smid_core as core;
pub use smid_core::{Result, SmidError};
pub use smid_output_backlash as output_backlash;
pub use smid_fmu as fmu;
pub use smid_dead_zone as dead_zone;
pub use smid_example_gain as example_gain;
pub use smid_input_backlash as input_backlash;
pub use smid_saturation as saturation;
pub use smid_diagnose as diagnose;
pub use smid_effects as effects;

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
    std::hint::black_box(smid_output_backlash::branch_polygons as usize);
    std::hint::black_box(smid_effects::link as *const () as usize);
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
        let mut plant = smid_fmu::from_spec(&spec.plant, base)?;
        return pipeline::run_with_plant(&spec, &mut plant);
    }
    pipeline::run(&spec, base)
}
