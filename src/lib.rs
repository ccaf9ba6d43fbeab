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

pub mod compare;
pub mod montecarlo;
pub mod reproduce;

use smid_core::pipeline::{self, Identification};
use smid_core::spec::Spec;
use std::path::Path;

/// Load a spec file, acquire its data (simulator or CSV) and identify.
pub fn run_spec_file(path: &Path) -> Result<Identification> {
    let spec = Spec::from_file(path)?;
    let base = path.parent().unwrap_or(Path::new("."));
    pipeline::run(&spec, base)
}
