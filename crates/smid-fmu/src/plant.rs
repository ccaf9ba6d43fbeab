//! [`FmuPlant`]: an FMI 2.0 co-simulation unit driven as a smid [`Plant`]. Each `run` puts the
//! unit at rest (reset, or a fresh instance after a failure), sets the parameters, and then for
//! every sample `k` sets the input to `u_k`, calls `fmi2DoStep(t_k, t_{k+1} - t_k)` with
//! `t_k = k h`, and reads the output: one communication step is one sample. Every failure is a
//! typed [`FmuError`] naming the FMU, the variable and the time.
// FmuError carries the FMU's log lines for the message; errors end a run, so their size is of
// no consequence.
#![allow(clippy::result_large_err)]
use crate::error::{FmuError, FmuErrorKind};
use crate::logcap;
use fmi::fmi2::import::Fmi2Import;
use fmi::fmi2::instance::{CoSimulation, Common, InstanceCS};
use fmi::fmi2::Fmi2Error;
use fmi::schema::fmi2::{Causality, ScalarVariableElement};
use fmi::traits::FmiImport;
use smid_core::plant::Plant;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// How to drive an FMU.
#[derive(Debug, Clone, Default)]
pub struct FmuConfig {
    /// The `.fmu` file.
    pub path: PathBuf,
    /// Name used in messages (default: the path).
    pub label: Option<String>,
    /// Input variable (default: the only Real input).
    pub input: Option<String>,
    /// Output variable (default: the only Real output).
    pub output: Option<String>,
    /// Communication step = one sample (default: the FMU's DefaultExperiment stepSize).
    pub step: Option<f64>,
    /// Parameter values by name.
    pub parameters: BTreeMap<String, f64>,
}

/// An FMU as a [`Plant`]. Not `Send`: one per thread.
pub struct FmuPlant {
    label: String,
    import: Fmi2Import,
    instance: Option<InstanceCS>,
    input: (String, u32),
    output: (String, u32),
    step: f64,
    parameters: Vec<(String, u32, f64)>,
    runs: u64,
}

impl std::fmt::Debug for FmuPlant {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("FmuPlant")
            .field("fmu", &self.label)
            .field("input", &self.input.0)
            .field("output", &self.output.0)
            .field("step", &self.step)
            .finish()
    }
}

fn status_name(e: &Fmi2Error) -> String {
    match e {
        Fmi2Error::Discard => "fmi2Discard".into(),
        Fmi2Error::Error => "fmi2Error".into(),
        Fmi2Error::Fatal => "fmi2Fatal".into(),
        other => format!("{other:?}"),
    }
}

/// Whether this is a Real variable.
fn is_real(v: &fmi::schema::fmi2::ScalarVariable) -> bool {
    matches!(v.elem, ScalarVariableElement::Real(_))
}

impl FmuPlant {
    /// Open, check and prepare an FMU (the binary is instantiated at the first run).
    pub fn load(config: &FmuConfig) -> Result<FmuPlant, FmuError> {
        logcap::install();
        let label = config
            .label
            .clone()
            .unwrap_or_else(|| config.path.display().to_string());
        let err = |kind| FmuError::new(label.clone(), kind);
        let path = &config.path;
        if !path.is_file() {
            return Err(err(FmuErrorKind::NotFound(if path.exists() {
                format!("{} is not a file", path.display())
            } else {
                format!("{} does not exist", path.display())
            })));
        }
        let min = fmi::import::peek_descr_path(path).map_err(|e| {
            err(match e {
                fmi::Error::Io(io) => FmuErrorKind::NotFound(io.to_string()),
                fmi::Error::Zip(z) => FmuErrorKind::NotZip(z.to_string()),
                fmi::Error::ArchiveStructure(s) => {
                    FmuErrorKind::NotZip(format!("no modelDescription.xml at the root ({s})"))
                }
                other => FmuErrorKind::ModelDescription(other.to_string()),
            })
        })?;
        if min.fmi_version.trim() != "2.0" {
            return Err(err(FmuErrorKind::Version {
                found: min.fmi_version.clone(),
            }));
        }
        let import: Fmi2Import = fmi::import::from_path(path).map_err(|e| {
            err(match e {
                fmi::Error::Zip(z) => FmuErrorKind::NotZip(z.to_string()),
                fmi::Error::Io(io) => FmuErrorKind::NotZip(io.to_string()),
                other => FmuErrorKind::ModelDescription(other.to_string()),
            })
        })?;
        let md = import.model_description();
        let Some(cs) = md.co_simulation.as_ref() else {
            return Err(err(FmuErrorKind::NotCoSimulation));
        };
        let lib = import.shared_lib_path(&cs.model_identifier).map_err(|e| {
            err(FmuErrorKind::NoBinary {
                expected: e.to_string(),
            })
        })?;
        if !import.archive_path().join(&lib).is_file() {
            return Err(err(FmuErrorKind::NoBinary {
                expected: lib.display().to_string(),
            }));
        }
        // A PythonFMU unit needs the Python runtime's symbols in the process (python.rs).
        if crate::python::is_python_fmu(md.generation_tool.as_deref(), import.archive_path()) {
            crate::python::ensure_runtime().map_err(|e| err(FmuErrorKind::PythonRuntime(e)))?;
        }

        let find = |role: &'static str, name: Option<&String>, want: Causality| {
            let candidates: Vec<&fmi::schema::fmi2::ScalarVariable> = md
                .model_variables
                .variables
                .iter()
                .filter(|v| v.causality == want && is_real(v))
                .collect();
            let list = || {
                candidates
                    .iter()
                    .map(|v| v.name.as_str())
                    .collect::<Vec<_>>()
                    .join(", ")
            };
            match name {
                Some(n) => match md.model_variables.variables.iter().find(|v| &v.name == n) {
                    None => Err(err(FmuErrorKind::Variable {
                        role,
                        name: n.clone(),
                        message: format!("no such variable; the Real {role}s are: {}", list()),
                    })),
                    Some(v) if v.causality != want || !is_real(v) => {
                        Err(err(FmuErrorKind::Variable {
                            role,
                            name: n.clone(),
                            message: format!(
                                "is a {:?} variable, not a Real {role}; the Real {role}s are: {}",
                                v.causality,
                                list()
                            ),
                        }))
                    }
                    Some(v) => Ok((v.name.clone(), v.value_reference)),
                },
                None if candidates.len() == 1 => {
                    Ok((candidates[0].name.clone(), candidates[0].value_reference))
                }
                None => Err(err(FmuErrorKind::Variable {
                    role,
                    name: String::new(),
                    message: format!(
                        "not given and the FMU has {} Real {role}s ({}); name one",
                        candidates.len(),
                        list()
                    ),
                })),
            }
        };
        let input = find("input", config.input.as_ref(), Causality::Input)?;
        let output = find("output", config.output.as_ref(), Causality::Output)?;
        let mut parameters = Vec::new();
        for (name, value) in &config.parameters {
            let (n, vr) = find("parameter", Some(name), Causality::Parameter)?;
            if !value.is_finite() {
                return Err(err(FmuErrorKind::Variable {
                    role: "parameter",
                    name: n,
                    message: format!("value {value} is not finite"),
                }));
            }
            parameters.push((n, vr, *value));
        }
        let step = match config.step {
            Some(h) => h,
            None => md
                .default_experiment
                .as_ref()
                .and_then(|d| d.step_size)
                .ok_or_else(|| {
                    err(FmuErrorKind::Config {
                        field: "step".into(),
                        message: "not given and the FMU has no DefaultExperiment stepSize".into(),
                    })
                })?,
        };
        if !(step.is_finite() && step > 0.0) {
            return Err(err(FmuErrorKind::Config {
                field: "step".into(),
                message: format!("expected a finite step > 0, got {step}"),
            }));
        }
        Ok(FmuPlant {
            label,
            import,
            instance: None,
            input,
            output,
            step,
            parameters,
            runs: 0,
        })
    }

    /// The communication step (one sample).
    pub fn step(&self) -> f64 {
        self.step
    }

    /// The input and output variable names.
    pub fn variables(&self) -> (&str, &str) {
        (&self.input.0, &self.output.0)
    }

    fn fail(&self, kind: FmuErrorKind) -> FmuError {
        FmuError::new(self.label.clone(), kind)
    }

    fn status(
        &self,
        call: &'static str,
        e: &Fmi2Error,
        sample: usize,
        variable: Option<&str>,
    ) -> FmuError {
        self.fail(FmuErrorKind::Status {
            call,
            status: status_name(e),
            time: sample as f64 * self.step,
            sample,
            variable: variable.map(str::to_string),
            log: logcap::take(),
        })
    }

    /// A fresh instance at rest: the previous one reset, or a new one.
    fn rest(&mut self) -> Result<InstanceCS, FmuError> {
        if let Some(mut inst) = self.instance.take() {
            if Common::reset(&mut inst).is_ok() {
                return Ok(inst);
            }
        }
        let name = format!("smid-{}", self.runs);
        self.import
            .instantiate_cs(&name, false, false)
            .map_err(|e| {
                let log = logcap::take();
                self.fail(FmuErrorKind::Load(if log.is_empty() {
                    e.to_string()
                } else {
                    format!("{e}; FMU log: {}", log.join(" | "))
                }))
            })
    }

    fn simulate(&self, inst: &mut InstanceCS, u: &[f64]) -> Result<Vec<f64>, FmuError> {
        let (in_name, in_vr) = (&self.input.0, self.input.1);
        let (out_name, out_vr) = (&self.output.0, self.output.1);
        if let Some(k) = u.iter().position(|v| !v.is_finite()) {
            return Err(self.fail(FmuErrorKind::NonFinite {
                role: "input",
                variable: in_name.clone(),
                value: u[k],
                time: k as f64 * self.step,
                sample: k,
            }));
        }
        Common::setup_experiment(inst, None, 0.0, None)
            .map_err(|e| self.status("fmi2SetupExperiment", &e, 0, None))?;
        Common::enter_initialization_mode(inst)
            .map_err(|e| self.status("fmi2EnterInitializationMode", &e, 0, None))?;
        for (name, vr, value) in &self.parameters {
            Common::set_real(inst, &[*vr], &[*value])
                .map_err(|e| self.status("fmi2SetReal", &e, 0, Some(name)))?;
        }
        if let Some(u0) = u.first() {
            Common::set_real(inst, &[in_vr], &[*u0])
                .map_err(|e| self.status("fmi2SetReal", &e, 0, Some(in_name)))?;
        }
        Common::exit_initialization_mode(inst)
            .map_err(|e| self.status("fmi2ExitInitializationMode", &e, 0, None))?;
        let mut w = Vec::with_capacity(u.len());
        let mut y = [0.0];
        for (k, &uk) in u.iter().enumerate() {
            let t0 = k as f64 * self.step;
            let t1 = (k + 1) as f64 * self.step;
            Common::set_real(inst, &[in_vr], &[uk])
                .map_err(|e| self.status("fmi2SetReal", &e, k, Some(in_name)))?;
            CoSimulation::do_step(&*inst, t0, t1 - t0, true)
                .map_err(|e| self.status("fmi2DoStep", &e, k, Some(out_name)))?;
            Common::get_real(inst, &[out_vr], &mut y)
                .map_err(|e| self.status("fmi2GetReal", &e, k + 1, Some(out_name)))?;
            if !y[0].is_finite() {
                return Err(self.fail(FmuErrorKind::NonFinite {
                    role: "output",
                    variable: out_name.clone(),
                    value: y[0],
                    time: t1,
                    sample: k,
                }));
            }
            w.push(y[0]);
        }
        Common::terminate(inst).map_err(|e| self.status("fmi2Terminate", &e, u.len(), None))?;
        Ok(w)
    }

    /// Run from rest on `u`; one output sample per input sample (the output after the step
    /// that consumed `u_k`).
    pub fn simulate_from_rest(&mut self, u: &[f64]) -> Result<Vec<f64>, FmuError> {
        logcap::clear();
        let mut inst = self.rest()?;
        self.runs += 1;
        let out = self.simulate(&mut inst, u);
        if out.is_ok() {
            // Keep a healthy instance for the next run (reset is cheaper than instantiate);
            // an instance that failed is dropped (fmi2FreeInstance).
            self.instance = Some(inst);
        }
        out
    }
}

impl Plant for FmuPlant {
    fn run(&mut self, u: &[f64]) -> smid_core::Result<Vec<f64>> {
        Ok(self.simulate_from_rest(u)?)
    }
    fn name(&self) -> String {
        format!("FMU {}", self.label)
    }
}

/// Resolve the `fmu:` path of a spec: relative to `base` (the spec's directory). A directory that
/// is one of smid's bundled FMU sources (`fmus/<name>/`) stands for the unit built from it.
pub fn resolve_path(path: &Path, base: &Path) -> Result<PathBuf, FmuError> {
    let p = if path.is_absolute() {
        path.to_path_buf()
    } else {
        base.join(path)
    };
    if !p.is_dir() {
        return Ok(p);
    }
    let label = path.display().to_string();
    let bundled_src = Path::new(crate::BUNDLED_SOURCE_DIR);
    let canon = p.canonicalize().unwrap_or_else(|_| p.clone());
    let name = canon
        .file_name()
        .and_then(|n| n.to_str())
        .unwrap_or_default()
        .to_string();
    if canon.parent() == Some(bundled_src) && canon.join("modelDescription.xml").is_file() {
        let built = crate::bundled_fmu(&name);
        return if built.is_file() {
            Ok(built)
        } else {
            Err(FmuError::new(
                label,
                FmuErrorKind::NotBuilt {
                    name,
                    expected: built.display().to_string(),
                },
            ))
        };
    }
    Err(FmuError::new(
        label,
        FmuErrorKind::NotAnFmu(format!(
            "{} is a directory, not an .fmu file (only smid's bundled sources {}/<name> may be \
             given as directories; bundled: {})",
            p.display(),
            bundled_src.display(),
            crate::bundled_names().join(", ")
        )),
    ))
}
