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
    NotBuilt {
        /// The bundled FMU's name (its source directory).
        name: String,
        /// The path where the built archive was expected.
        expected: String,
    },
    /// Not a zip archive, or one without `modelDescription.xml`.
    #[error("not an FMU archive: {0}")]
    NotZip(String),
    /// `modelDescription.xml` could not be parsed.
    #[error("modelDescription.xml: {0}")]
    ModelDescription(String),
    /// An FMI version other than 2.0.
    #[error("FMI version {found} is not supported (smid loads FMI 2.0 co-simulation units)")]
    Version {
        /// The `fmiVersion` the model description declares.
        found: String,
    },
    /// No co-simulation interface.
    #[error("the FMU provides no co-simulation interface (Model Exchange is not supported)")]
    NotCoSimulation,
    /// No binary for this platform.
    #[error("no binary for this platform: expected `{expected}` in the archive")]
    NoBinary {
        /// The binary's path expected inside the archive for this platform.
        expected: String,
    },
    /// A unit exported from Python (PythonFMU) and no usable Python runtime to host it.
    #[error("{0}")]
    PythonRuntime(String),
    /// The binary could not be loaded or instantiated.
    #[error("cannot load or instantiate the binary: {0}")]
    Load(String),
    /// A variable named in the spec does not exist or has the wrong role.
    #[error("{role} `{name}`: {message}")]
    Variable {
        /// The role the spec gives it: `input`, `output` or `parameter`.
        role: &'static str,
        /// The variable's name, as the spec gives it.
        name: String,
        /// What is wrong with it.
        message: String,
    },
    /// An invalid plant option (step, ...).
    #[error("`{field}`: {message}")]
    Config {
        /// The plant option (`step`, ...).
        field: String,
        /// What is wrong with it.
        message: String,
    },
    /// An FMI call returned an error status.
    #[error("{call} returned {status} at t = {time} (sample {sample}){variable}{log}",
        variable = variable.as_ref().map(|v| format!(", variable `{v}`")).unwrap_or_default(),
        log = if log.is_empty() { String::new() } else { format!("; FMU log: {}", log.join(" | ")) })]
    Status {
        /// The FMI function (`fmi2DoStep`, ...).
        call: &'static str,
        /// The status it returned (`fmi2Error`, `fmi2Fatal`, ...).
        status: String,
        /// Simulation time in seconds (`sample × step`).
        time: f64,
        /// Index of the sample being simulated.
        sample: usize,
        /// The variable being set or read, when the call concerns one.
        variable: Option<String>,
        /// Messages the FMU logged during the call.
        log: Vec<String>,
    },
    /// An input or output value is not finite.
    #[error("{role} `{variable}` is {value} at t = {time} (sample {sample})")]
    NonFinite {
        /// `input` or `output`.
        role: &'static str,
        /// The variable's name.
        variable: String,
        /// The value (`NaN` or infinite).
        value: f64,
        /// Simulation time in seconds.
        time: f64,
        /// Index of the sample.
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
