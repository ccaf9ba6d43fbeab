//! # smid-fmu
//!
//! FMI 2.0 co-simulation units as smid plants. [`FmuPlant`] loads a `.fmu` with the `fmi` crate
//! and implements [`smid_core::plant::Plant`]: each run starts from rest and maps the input
//! sequence to the output, one communication step per sample. [`from_spec`] builds one from the
//! `plant: { fmu, input, output, step, parameters }` section of a spec.
//!
//! The crate's build script also builds smid's bundled plant FMUs from `fmus/<name>/` (C sources
//! and `modelDescription.xml`) into [`bundled_dir`]; a spec may name such a source directory
//! (e.g. `fmu: ../fmus/paper`) and gets the unit built from it.
//!
//! ```
//! use smid_core::plant::Plant;
//! use smid_fmu::{FmuConfig, FmuPlant};
//! let mut plant = FmuPlant::load(&FmuConfig {
//!     path: smid_fmu::bundled_fmu("paper"),
//!     output: Some("w".into()),
//!     step: Some(1.0),
//!     ..Default::default()
//! })
//! .unwrap();
//! let w = plant.run(&[1.0; 50]).unwrap();
//! assert_eq!(w.len(), 50);
//! // A unit-gain block behind a backlash of slope about 0.25: the output settles near 0.25.
//! assert!(w[49] > 0.2 && w[49] < 0.3);
//! ```
// Unsafe only in `python` (loading the Python runtime for PythonFMU units); denied elsewhere.
#![deny(unsafe_code)]
#![warn(missing_docs)]

pub mod error;
mod logcap;
pub mod plant;
mod python;

pub use error::{FmuError, FmuErrorKind};
pub use plant::{resolve_path, FmuConfig, FmuPlant};

use smid_core::spec::PlantSpec;
use std::path::{Path, PathBuf};

/// Where the build script put the bundled FMUs (`<name>.fmu`).
pub const BUNDLED_DIR: &str = env!("SMID_FMU_DIR");
/// The `fmus/` source directory the bundled FMUs were built from.
pub const BUNDLED_SOURCE_DIR: &str = env!("SMID_FMU_SOURCE_DIR");

/// Directory of the bundled FMUs.
pub fn bundled_dir() -> &'static Path {
    Path::new(BUNDLED_DIR)
}

/// Path of the bundled FMU `name` (e.g. `paper`, `drive`, `paper_effects`).
pub fn bundled_fmu(name: &str) -> PathBuf {
    bundled_dir().join(format!("{name}.fmu"))
}

/// Names of the bundled FMUs that were built.
pub fn bundled_names() -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(bundled_dir())
        .map(|d| {
            d.filter_map(|e| e.ok())
                .filter_map(|e| {
                    let p = e.path();
                    (p.extension()? == "fmu")
                        .then(|| p.file_stem()?.to_str().map(str::to_string))?
                })
                .collect()
        })
        .unwrap_or_default();
    v.sort();
    v
}

/// Build the FMU plant of a spec's `plant` section; relative paths resolve against `base` (the
/// spec file's directory).
#[allow(clippy::result_large_err)]
pub fn from_spec(plant: &PlantSpec, base: &Path) -> smid_core::Result<FmuPlant> {
    let Some(fmu) = plant.fmu.as_ref() else {
        return Err(smid_core::SmidError::invalid(
            "plant.fmu",
            "this plant is not an FMU",
        ));
    };
    let path = resolve_path(fmu, base)?;
    Ok(FmuPlant::load(&FmuConfig {
        path,
        label: Some(fmu.display().to_string()),
        input: plant.input.clone(),
        output: plant.output.clone(),
        step: plant.step,
        parameters: plant.parameters.clone(),
    })?)
}
