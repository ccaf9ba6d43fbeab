//! `smid._native`: the Python extension module of the `smid` package (PyO3). It is a thin
//! edge over the `smid` facade, exactly what the CLI calls: identification from a spec
//! (`smid run`, the content of `result.json`), validation and diagnosis with a model set on
//! fresh arrays (`smid validate`, `smid diagnose`), simulation of a model set (centre and
//! envelope), and the sharded sweeps (`smid check --shard`, `check-merge`,
//! `reproduce --shard`, `reproduce-merge`). Values cross as JSON text, so Python sees the
//! very numbers the CLI writes (serde_json prints the shortest text that reads back to the
//! same bits); the Python layer (`python/smid/`) turns them into numpy arrays and objects.
//! Errors become Python exceptions carrying the same located messages; an empty feasible set
//! in an identification is a result (`"status": "falsified"`), not an exception.
#![forbid(unsafe_code)]
#![warn(missing_docs)]

use pyo3::create_exception;
use pyo3::exceptions::PyException;
use pyo3::prelude::*;
use serde_json::json;
use smid::core::SmidError as Error;
use std::path::{Path, PathBuf};

create_exception!(
    smid,
    SmidError,
    PyException,
    "An error of smid, with its located message (file, field, sample)."
);
create_exception!(
    smid,
    SpecError,
    SmidError,
    "A spec (YAML) could not be read or is invalid."
);
create_exception!(
    smid,
    DataError,
    SmidError,
    "A data file or array holds a missing, malformed or bad sample."
);
create_exception!(
    smid,
    InvalidError,
    SmidError,
    "An invalid parameter or option."
);
create_exception!(
    smid,
    InconsistentError,
    SmidError,
    "The data falsify the model (raised only where a verdict cannot be returned)."
);
create_exception!(
    smid,
    UnboundedError,
    SmidError,
    "The data do not bound a parameter."
);
create_exception!(
    smid,
    SolverError,
    SmidError,
    "The LP solver failed numerically."
);
create_exception!(
    smid,
    PlantError,
    SmidError,
    "A plant (simulator or FMU) failed."
);
create_exception!(
    smid,
    UnsupportedError,
    SmidError,
    "A capability that this build or plugin does not provide."
);
create_exception!(
    smid,
    FormatError,
    SmidError,
    "A JSON file of smid (result.json, validation.json, diagnosis.json) of another kind, of a format version this smid does not read, or without its format stamp."
);

/// The Python exception of an error, with the error's own message.
fn to_py(e: Error) -> PyErr {
    let msg = e.to_string();
    match e {
        Error::Spec { .. } => SpecError::new_err(msg),
        Error::Data { .. } | Error::Io { .. } => DataError::new_err(msg),
        Error::Invalid { .. } => InvalidError::new_err(msg),
        Error::Inconsistent(_) => InconsistentError::new_err(msg),
        Error::Unbounded { .. } => UnboundedError::new_err(msg),
        Error::Solver(_) => SolverError::new_err(msg),
        Error::Plant { .. } => PlantError::new_err(msg),
        Error::Unsupported { .. } => UnsupportedError::new_err(msg),
        Error::Format { .. } => FormatError::new_err(msg),
    }
}

fn to_text(v: &impl serde::Serialize) -> PyResult<String> {
    serde_json::to_string(v).map_err(|e| SmidError::new_err(format!("serialising a result: {e}")))
}

fn parse_json<T: serde::de::DeserializeOwned>(text: &str, what: &str) -> PyResult<T> {
    serde_json::from_str(text).map_err(|e| InvalidError::new_err(format!("{what}: {e}")))
}

/// Identify from a spec's text. `label` names the spec in errors (its file, or `<string>`);
/// relative paths in it resolve against `base`. With `out`, the CLI's files are written there
/// too (`result.json`, `data.csv`, SVG plots). Returns JSON: `{"status": "identified",
/// "result": <result.json>, "table": <the CLI's table>, "files": [...]}` or `{"status":
/// "falsified", "stage", "record", "sample", "located", "detail", "message"}` (`located`:
/// whether `sample` is the first offending one, or one by which the data are inconsistent).
#[pyfunction]
#[pyo3(signature = (spec_text, label, base, out=None))]
fn identify(
    py: Python<'_>,
    spec_text: &str,
    label: &str,
    base: &str,
    out: Option<PathBuf>,
) -> PyResult<String> {
    let label = PathBuf::from(label);
    let base = PathBuf::from(base);
    let spec = smid::parse_spec(spec_text, &label).map_err(to_py)?;
    let run = py.detach(|| smid::run_spec(&spec, &base, &|_| {}));
    let id = match run {
        Ok(smid::Outcome::Consistent(id)) => id,
        Ok(smid::Outcome::Falsified(f)) => {
            return to_text(&json!({
                "status": "falsified",
                "stage": f.stage.to_string(),
                "record": f.record,
                "sample": f.sample,
                "located": f.located,
                "detail": f.detail,
                "message": f.message(),
            }));
        }
        Err(e) => return Err(to_py(e)),
    };
    let result = smid::result_value(&id, &spec, &base).map_err(to_py)?;
    let files = match out {
        Some(dir) => smid::write_run(&id, &spec, &base, &dir).map_err(to_py)?,
        None => Vec::new(),
    };
    to_text(&json!({
        "status": "identified",
        "result": result,
        "table": smid::core::report::table(&id),
        "files": files,
    }))
}

/// The model set and spec of a `result.json` text.
fn source(result_text: &str) -> PyResult<smid::closeloop::Source> {
    smid::closeloop::source_from_json(result_text, Path::new("<result>")).map_err(to_py)
}

/// Check the format stamp of a JSON file of smid (`kind`: `result`, `validation` or
/// `diagnosis`) given as text; `label` names it in the error. Returns its `format_version`,
/// or raises `FormatError` naming the file, the field, what it holds and the versions this
/// smid reads.
#[pyfunction]
fn check_format(text: &str, kind: &str, label: &str) -> PyResult<u64> {
    use smid::core::output::{self, OutputKind};
    let kind = match kind {
        "result" => OutputKind::Result,
        "validation" => OutputKind::Validation,
        "diagnosis" => OutputKind::Diagnosis,
        other => {
            return Err(InvalidError::new_err(format!(
                "invalid `kind`: `{other}`, expected `result`, `validation` or `diagnosis`"
            )))
        }
    };
    output::parse(kind, text, Path::new(label))
        .map(|v| v[output::VERSION_FIELD].as_u64().unwrap_or_default())
        .map_err(to_py)
}

/// Validate the model set of a `result.json` text on fresh records `(name, u, y)`; `k` is the
/// prediction horizon. Returns JSON `{"validation": <the content of validation.json>, "series":
/// [...], "text": <the CLI's report>}`.
#[pyfunction]
#[pyo3(signature = (result_text, records, k=5))]
fn validate(
    py: Python<'_>,
    result_text: &str,
    records: Vec<(String, Vec<f64>, Vec<f64>)>,
    k: usize,
) -> PyResult<String> {
    let mut src = source(result_text)?;
    let model = src
        .model
        .take()
        .ok_or_else(|| InvalidError::new_err("no model set"))?;
    let fresh = smid::closeloop::records_from_arrays(&src.spec, records).map_err(to_py)?;
    let v = py
        .detach(|| {
            smid::core::validate::validate(
                &model,
                &fresh,
                &smid::core::validate::Options {
                    k,
                    ..Default::default()
                },
            )
        })
        .map_err(to_py)?;
    to_text(&json!({
        "validation": smid::core::output::OutputKind::Validation.stamp(&v),
        "series": v.series,
        "text": smid::closeloop::format_validation(&v, &fresh),
    }))
}

/// Diagnose: choose the effect (or plugin) the model lacks from its training data, then the
/// before/after table on the held-out records `(name, u, y)`. The source is a `result.json`
/// text (`kind = "result"`) or a spec text (`kind = "spec"`, `label` and `base` as in
/// [`identify`]). Returns the content of `diagnosis.json` (its format stamp, `choice`,
/// `before`, `after`) with `summary` and `text` added.
#[pyfunction]
#[pyo3(signature = (source_text, kind, label, base, holdout, max_effects=2, only=Vec::new(), k=5))]
#[allow(clippy::too_many_arguments)]
fn diagnose(
    py: Python<'_>,
    source_text: &str,
    kind: &str,
    label: &str,
    base: &str,
    holdout: Vec<(String, Vec<f64>, Vec<f64>)>,
    max_effects: usize,
    only: Vec<String>,
    k: usize,
) -> PyResult<String> {
    let mut src = match kind {
        "result" => source(source_text)?,
        "spec" => smid::closeloop::Source {
            spec: smid::parse_spec(source_text, Path::new(label)).map_err(to_py)?,
            base: PathBuf::from(base),
            model: None,
        },
        other => {
            return Err(InvalidError::new_err(format!(
                "source kind `{other}`: expected `result` or `spec`"
            )))
        }
    };
    let held = smid::closeloop::records_from_arrays(&src.spec, holdout).map_err(to_py)?;
    if held.is_empty() {
        return Err(InvalidError::new_err(
            "holdout: no held-out record given (the before/after table is computed on them)",
        ));
    }
    let opts = smid::core::diagnose::Options {
        max_effects,
        only,
        k,
    };
    let (choice, before, after) = py
        .detach(|| -> smid::core::Result<_> {
            let training = smid::closeloop::training_data(&mut src)?;
            let mut choice = smid::core::diagnose::choose(&src.spec, &training, &opts, &|_, _| {})?;
            // Only now are the held-out records read.
            let (before, after) =
                smid::core::diagnose::assess(&src.spec, &training, &mut choice, &held, opts.k)?;
            Ok((choice, before, after))
        })
        .map_err(to_py)?;
    let mut out = smid::closeloop::diagnosis_value(&choice, &before, &after);
    out["summary"] = json!(choice.summary());
    out["text"] = json!(format!(
        "{}{}",
        smid::closeloop::format_choice(&choice),
        smid::closeloop::format_table(&before, &after)
    ));
    to_text(&out)
}

/// Free run from rest of the model set of a `result.json` text on the input `u`: the
/// representative member's output (and inner signal; the simulation member when one was
/// certified, else the centre) and the envelope over the members its `envelope` names. `dt` defaults to
/// the spec's sample time (1 when it has none).
#[pyfunction]
#[pyo3(signature = (result_text, u, dt=None))]
fn simulate(py: Python<'_>, result_text: &str, u: Vec<f64>, dt: Option<f64>) -> PyResult<String> {
    let src = source(result_text)?;
    let model = src
        .model
        .ok_or_else(|| InvalidError::new_err("no model set"))?;
    let dt = dt.unwrap_or_else(|| {
        src.spec
            .plant
            .data
            .as_ref()
            .and_then(|d| d.dt)
            .unwrap_or(1.0)
    });
    let s = py
        .detach(|| smid::core::members::simulate_set(&model, &u, dt))
        .map_err(to_py)?;
    to_text(&s)
}

/// Run the plant of a spec (simulator or FMU) on its PRBS experiment (`length` samples,
/// `seed`; the spec's when not given) with its bounded noise, as `smid simulate`: JSON
/// `{"t", "u", "y", "w", "delta", "added"}`.
#[pyfunction]
#[pyo3(signature = (spec_text, label, base, length=None, seed=None))]
fn simulate_plant(
    py: Python<'_>,
    spec_text: &str,
    label: &str,
    base: &str,
    length: Option<usize>,
    seed: Option<u64>,
) -> PyResult<String> {
    let spec = smid::parse_spec(spec_text, Path::new(label)).map_err(to_py)?;
    let r = py
        .detach(|| smid::simulate::simulate_spec(&spec, Path::new(base), length, seed))
        .map_err(to_py)?;
    to_text(&json!({
        "t": r.t, "u": r.u, "y": r.y, "w": r.w, "delta": r.delta, "added": r.added,
    }))
}

fn parse_method(m: Option<&str>) -> PyResult<Option<smid::core::spec::EivMethod>> {
    m.map(|m| {
        smid::core::spec::EivMethod::parse(m).map_err(|e| InvalidError::new_err(e.to_string()))
    })
    .transpose()
}

/// A containment check (or shard `(K, M)` of it), as `smid check --json` writes it.
#[pyfunction]
#[pyo3(signature = (plugin="output_backlash", trials=1000, first_seed=1, method=None, any_record=false, shard=None, jobs=None))]
#[allow(clippy::too_many_arguments)]
fn check(
    py: Python<'_>,
    plugin: &str,
    trials: usize,
    first_seed: u64,
    method: Option<&str>,
    any_record: bool,
    shard: Option<(usize, usize)>,
    jobs: Option<usize>,
) -> PyResult<String> {
    let opts = smid::sweep::CheckOptions {
        plugin: plugin.to_string(),
        method: parse_method(method)?,
        any_record,
        first_seed,
        trials,
        shard,
        jobs: jobs
            .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()))
            .max(1),
    };
    let run = py
        .detach(|| smid::sweep::check(&opts, || {}))
        .map_err(to_py)?;
    to_text(&run)
}

/// The JSON texts of shards, each named `shard N` (its place in the list) for errors.
fn parse_shards<T: serde::de::DeserializeOwned>(shards: &[String]) -> PyResult<Vec<(String, T)>> {
    shards
        .iter()
        .enumerate()
        .map(|(i, t)| {
            let name = format!("shard {}", i + 1);
            let v = parse_json(t, &name)?;
            Ok((name, v))
        })
        .collect()
}

/// Merge the JSON texts of the shards of one check (in any order); returns JSON
/// `{"run": <merged run>, "text": <the table `smid check` prints>}`.
#[pyfunction]
fn check_merge(shards: Vec<String>) -> PyResult<String> {
    let runs: Vec<(String, smid::sweep::CheckRun)> = parse_shards(&shards)?;
    let run = smid::sweep::merge_checks(&runs).map_err(to_py)?;
    to_text(&json!({ "run": run, "text": smid::sweep::format_check(&run) }))
}

/// The table `smid check` prints for a run's JSON text.
#[pyfunction]
fn format_check(run: &str) -> PyResult<String> {
    let run: smid::sweep::CheckRun = parse_json(run, "check run")?;
    Ok(smid::sweep::format_check(&run))
}

/// Shard `(K, M)` of `smid reproduce paper --seeds S` (all of it without a shard), as
/// `--shard K/M --json` writes it.
#[pyfunction]
#[pyo3(signature = (seeds=20, shard=None))]
fn reproduce_shard(
    py: Python<'_>,
    seeds: usize,
    shard: Option<(usize, usize)>,
) -> PyResult<String> {
    if seeds == 0 {
        return Err(InvalidError::new_err("seeds: must be at least 1"));
    }
    let s = py
        .detach(|| smid::sweep::paper_shard(seeds, shard, || {}))
        .map_err(to_py)?;
    to_text(&s)
}

/// Merge the JSON texts of the shards of one paper reproduction; returns JSON
/// `{"tables": <medians>, "text": <Tables I-II as the CLI prints them>}`.
#[pyfunction]
fn reproduce_merge(shards: Vec<String>) -> PyResult<String> {
    let parts: Vec<(String, smid::sweep::PaperShard)> = parse_shards(&shards)?;
    let r = smid::sweep::merge_paper(&parts).map_err(to_py)?;
    to_text(&json!({ "tables": r, "text": smid::reproduce::format_tables(&r) }))
}

/// The JSON Schema of specs (every registered plugin and effect).
#[pyfunction]
fn schema() -> String {
    smid::link_plugins();
    smid::core::registry::spec_schema()
}

/// The registered stage-3 methods (`method=` / `method.eiv`), in documentation order, with
/// whether this build runs each.
#[pyfunction]
fn methods() -> Vec<(String, bool)> {
    smid::core::stage3::all()
        .map(|(m, imp)| (m.name().to_string(), imp.available()))
        .collect()
}

/// The containment check's cases (`check(plugin=...)`), derived from the plugin registry.
#[pyfunction]
fn check_cases() -> Vec<String> {
    smid::plugin_check::plugins()
}

#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    smid::link_plugins();
    let py = m.py();
    m.add("SmidError", py.get_type::<SmidError>())?;
    m.add("SpecError", py.get_type::<SpecError>())?;
    m.add("DataError", py.get_type::<DataError>())?;
    m.add("InvalidError", py.get_type::<InvalidError>())?;
    m.add("InconsistentError", py.get_type::<InconsistentError>())?;
    m.add("UnboundedError", py.get_type::<UnboundedError>())?;
    m.add("SolverError", py.get_type::<SolverError>())?;
    m.add("PlantError", py.get_type::<PlantError>())?;
    m.add("UnsupportedError", py.get_type::<UnsupportedError>())?;
    m.add("FormatError", py.get_type::<FormatError>())?;
    m.add_function(wrap_pyfunction!(identify, m)?)?;
    m.add_function(wrap_pyfunction!(validate, m)?)?;
    m.add_function(wrap_pyfunction!(diagnose, m)?)?;
    m.add_function(wrap_pyfunction!(simulate, m)?)?;
    m.add_function(wrap_pyfunction!(simulate_plant, m)?)?;
    m.add_function(wrap_pyfunction!(check, m)?)?;
    m.add_function(wrap_pyfunction!(check_merge, m)?)?;
    m.add_function(wrap_pyfunction!(format_check, m)?)?;
    m.add_function(wrap_pyfunction!(reproduce_shard, m)?)?;
    m.add_function(wrap_pyfunction!(reproduce_merge, m)?)?;
    m.add_function(wrap_pyfunction!(schema, m)?)?;
    m.add_function(wrap_pyfunction!(methods, m)?)?;
    m.add_function(wrap_pyfunction!(check_cases, m)?)?;
    m.add_function(wrap_pyfunction!(check_format, m)?)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
