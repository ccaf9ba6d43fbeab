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
        /// The spec file (or the label given for a spec parsed from text).
        file: PathBuf,
        /// 1-based line of the offending field, when it could be located.
        line: Option<usize>,
        /// Dotted path of the field (`experiment.filter.tol`).
        field: String,
        /// What is wrong with it.
        message: String,
    },
    /// A data file (CSV) is missing, malformed or holds a bad sample.
    #[error("{file}: {location}: {message}")]
    Data {
        /// The data file.
        file: PathBuf,
        /// Where in the file: a line, a column, a sample.
        location: String,
        /// What is wrong there.
        message: String,
    },
    /// An invalid parameter or option given programmatically or in a spec.
    #[error("invalid `{field}`: {message}")]
    Invalid {
        /// Dotted path of the field or option (`model.prior.m_l`).
        field: String,
        /// What is wrong with it.
        message: String,
    },
    /// The feasible set is empty: the data falsify the model.
    /// Inside the engines only: the boundaries return it as [`crate::outcome::Outcome`].
    #[error("{}", .0.message())]
    Inconsistent(crate::finding::Falsification),
    /// The data do not determine a bounded set (e.g. too few distinct amplitudes).
    #[error("the data do not bound `{parameter}`: {message}")]
    Unbounded {
        /// The parameter left without a finite bound.
        parameter: String,
        /// Why the data leave it unbounded.
        message: String,
    },
    /// The LP solver failed numerically (not infeasibility).
    #[error("LP solver: {0}")]
    Solver(String),
    /// A plant (simulator, FMU) failed.
    #[error("plant `{plant}`: {message}")]
    Plant {
        /// The plant's name ([`crate::plant::Plant::name`]).
        plant: String,
        /// What failed.
        message: String,
    },
    /// I/O on a named path.
    #[error("{path}: {source}")]
    Io {
        /// The file or directory read or written.
        path: PathBuf,
        /// The operating system's error.
        #[source]
        source: std::io::Error,
    },
    /// A capability that this plugin does not provide.
    #[error("`{plugin}` does not support {what}")]
    Unsupported {
        /// The plugin (or build) that lacks the capability.
        plugin: String,
        /// The capability asked for.
        what: String,
    },
    /// A JSON file of smid (`result.json`, `validation.json`, `diagnosis.json`) of another
    /// kind, of a format version this smid does not read, or without its format stamp
    /// ([`crate::output`]).
    #[error(
        "{file}: field `{field}`: {found}; this smid reads `{format}` files of format_version {known} (as its `{writer}` writes them){written_by}",
        found = found.as_deref().map_or_else(|| "missing".to_string(), |f| format!("found {f}")),
        known = known.iter().map(|v| v.to_string()).collect::<Vec<_>>().join(" or "),
        written_by = written_by.as_deref().map(|v| format!("; the file says smid {v} wrote it")).unwrap_or_default()
    )]
    Format {
        /// The file read (or the label of a text read).
        file: PathBuf,
        /// The field at fault: `format` or `format_version`.
        field: String,
        /// What the file holds there, as JSON text (`None`: the field is missing).
        found: Option<String>,
        /// The kind of file expected (its `format` value, e.g. `smid.result`).
        format: String,
        /// The `format_version`s this smid reads.
        known: Vec<u64>,
        /// The command that writes such a file (e.g. `smid run`).
        writer: String,
        /// The `smid_version` the file states, if any.
        written_by: Option<String>,
    },
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
