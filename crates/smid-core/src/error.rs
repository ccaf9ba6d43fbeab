//! Typed errors of the smid core.
//!
//! Every error names where it comes from: the spec file and field, the data file and sample,
//! or the identification stage and the first sample that falsified the model. An empty
//! feasible set is not a crash but a finding about the plant: inside the engines it travels as
//! [`SmidError::Inconsistent`], and identification and validation return it as a status
//! ([`crate::outcome::Outcome::Falsified`]).
pub use crate::finding::Stage;
use std::path::PathBuf;

/// Everything that can go wrong in the core, each variant naming its origin.
#[derive(Debug, thiserror::Error)]
pub enum SmidError {
    /// A spec file could not be read or parsed.
    #[error("{file}{line}: field `{field}`: {message}", line = line.map(|l| format!(":{l}")).unwrap_or_default())]
    Spec {
        file: PathBuf,
        line: Option<usize>,
        field: String,
        message: String,
    },
    /// A data file (CSV) is missing, malformed or holds a bad sample.
    #[error("{file}: {location}: {message}")]
    Data {
        file: PathBuf,
        location: String,
        message: String,
    },
    /// An invalid parameter or option given programmatically or in a spec.
    #[error("invalid `{field}`: {message}")]
    Invalid { field: String, message: String },
    /// The feasible set is empty: the data falsify the model.
    /// Inside the engines only: the boundaries return it as [`crate::outcome::Outcome`].
    #[error("{}", .0.message())]
    Inconsistent(crate::finding::Falsification),
    /// The data do not determine a bounded set (e.g. too few distinct amplitudes).
    #[error("the data do not bound `{parameter}`: {message}")]
    Unbounded { parameter: String, message: String },
    /// The LP solver failed numerically (not infeasibility).
    #[error("LP solver: {0}")]
    Solver(String),
    /// A plant (simulator, FMU) failed.
    #[error("plant `{plant}`: {message}")]
    Plant { plant: String, message: String },
    /// I/O on a named path.
    #[error("{path}: {source}")]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// A capability that this plugin does not provide.
    #[error("`{plugin}` does not support {what}")]
    Unsupported { plugin: String, what: String },
}

impl SmidError {
    /// Shorthand for [`SmidError::Inconsistent`] at `sample` of record 0 (a plugin's or a
    /// stage's proof that the feasible set is empty).
    pub fn inconsistent(stage: Stage, sample: usize, detail: impl Into<String>) -> Self {
        SmidError::Inconsistent(crate::finding::Falsification::new(stage, sample, detail))
    }
    /// [`SmidError::Inconsistent`] by the data up to `sample` of record 0, the first offending
    /// sample not looked for ([`crate::finding::Falsification::unlocated`]).
    pub fn inconsistent_unlocated(stage: Stage, sample: usize, detail: impl Into<String>) -> Self {
        SmidError::Inconsistent(crate::finding::Falsification::unlocated(
            stage, sample, detail,
        ))
    }
    /// A falsification found in record `record` says so; any other error is returned as is.
    pub fn in_record(self, record: usize) -> Self {
        match self {
            SmidError::Inconsistent(f) => SmidError::Inconsistent(f.in_record(record)),
            e => e,
        }
    }
    /// Shorthand for [`SmidError::Invalid`].
    pub fn invalid(field: impl Into<String>, message: impl Into<String>) -> Self {
        SmidError::Invalid {
            field: field.into(),
            message: message.into(),
        }
    }
}

/// Result alias of the core.
pub type Result<T, E = SmidError> = std::result::Result<T, E>;
