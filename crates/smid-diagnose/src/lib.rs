//! # smid-diagnose
//!
//! Closing the loop with data: `validate` runs an identified set-membership model on fresh data
//! (residual, falsification share against the guaranteed prediction band, residual
//! correlations with 99% bands, smallest consistent noise bound), and `diagnose` traces a failed
//! validation to an effect the model lacks by re-identifying with each registered [`effect`]
//! plugin added and ranking the candidates by held-out error with a penalty per parameter.
//!
//! The model sets here are linear in the parameters (ARX / equation-error form, see
//! [`effect`]), bounded under an ℓ∞ equation-error bound with the LP engine of `smid-core`.
#![forbid(unsafe_code)]

pub mod check;
pub mod commands;
pub mod diagnose;
pub mod effect;
pub mod lip;
pub mod plot;
pub mod spec;
pub mod validate;

#[doc(hidden)]
pub use inventory;
#[doc(hidden)]
pub use schemars;

use std::path::PathBuf;

/// Errors of validation and diagnosis; each names its file, field or regressor.
#[derive(Debug, thiserror::Error)]
pub enum DiagError {
    #[error("{file}: {message}")]
    Spec { file: PathBuf, message: String },
    #[error("{file}: {message}")]
    Data { file: PathBuf, message: String },
    #[error("{0}")]
    Invalid(String),
    #[error(transparent)]
    Core(#[from] smid_core::SmidError),
    #[error("{path}: {source}")]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
}
