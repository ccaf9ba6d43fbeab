//! Typed errors of FMU plants: every error names the FMU, and where it applies the variable and
//! the simulation time; [`FmuError`] converts to [`smid_core::SmidError::Plant`].
use smid_core::SmidError;

/// An error of one FMU, named by the path the user gave (or the file).
#[derive(Debug, thiserror::Error)]
#[error("FMU `{fmu}`: {kind}")]
pub struct FmuError {
    /// The FMU as the user named it.
    pub fmu: String,
    /// What went wrong.
    pub kind: FmuErrorKind,
}

/// What went wrong with an FMU.
#[derive(Debug, thiserror::Error)]
pub enum FmuErrorKind {
    /// The file does not exist (or cannot be opened).
    #[error("cannot open the file: {0}")]
    NotFound(String),
    /// A directory that is not one of smid's bundled FMU sources.
    #[error("{0}")]
    NotAnFmu(String),
    /// The bundled FMU source directory exists but its FMU was not built.
    #[error("the bundled FMU `{name}` was not built (expected {expected}); rebuild smid")]
    NotBuilt { name: String, expected: String },
    /// Not a zip archive, or one without `modelDescription.xml`.
    #[error("not an FMU archive: {0}")]
    NotZip(String),
    /// `modelDescription.xml` could not be parsed.
    #[error("modelDescription.xml: {0}")]
    ModelDescription(String),
    /// An FMI version other than 2.0.
    #[error("FMI version {found} is not supported (smid loads FMI 2.0 co-simulation units)")]
    Version { found: String },
    /// No co-simulation interface.
    #[error("the FMU provides no co-simulation interface (Model Exchange is not supported)")]
    NotCoSimulation,
    /// No binary for this platform.
    #[error("no binary for this platform: expected `{expected}` in the archive")]
    NoBinary { expected: String },
    /// A unit exported from Python (PythonFMU) and no usable Python runtime to host it.
    #[error("{0}")]
    PythonRuntime(String),
    /// The binary could not be loaded or instantiated.
    #[error("cannot load or instantiate the binary: {0}")]
    Load(String),
    /// A variable named in the spec does not exist or has the wrong role.
    #[error("{role} `{name}`: {message}")]
    Variable {
        role: &'static str,
        name: String,
        message: String,
    },
    /// An invalid plant option (step, ...).
    #[error("`{field}`: {message}")]
    Config { field: String, message: String },
    /// An FMI call returned an error status.
    #[error("{call} returned {status} at t = {time} (sample {sample}){variable}{log}",
        variable = variable.as_ref().map(|v| format!(", variable `{v}`")).unwrap_or_default(),
        log = if log.is_empty() { String::new() } else { format!("; FMU log: {}", log.join(" | ")) })]
    Status {
        call: &'static str,
        status: String,
        time: f64,
        sample: usize,
        variable: Option<String>,
        log: Vec<String>,
    },
    /// An input or output value is not finite.
    #[error("{role} `{variable}` is {value} at t = {time} (sample {sample})")]
    NonFinite {
        role: &'static str,
        variable: String,
        value: f64,
        time: f64,
        sample: usize,
    },
}

impl FmuError {
    /// An error of `fmu`.
    pub fn new(fmu: impl Into<String>, kind: FmuErrorKind) -> Self {
        FmuError {
            fmu: fmu.into(),
            kind,
        }
    }
}

impl From<FmuError> for SmidError {
    fn from(e: FmuError) -> Self {
        SmidError::Plant {
            plant: format!("FMU {}", e.fmu),
            message: e.kind.to_string(),
        }
    }
}
