//! The edge of closing the loop: where the model set and the fresh records come from (a run
//! spec, identified now, or a `result.json` of `smid run`; CSV files or the spec's plant with
//! other seeds), and the reports of `smid validate` and `smid diagnose` as text, JSON and SVG.
//! The computing is in `smid_core::validate` and `smid_core::diagnose`.
use crate::{load_spec, with_fmu_plant};
use smid_core::diagnose::{self, Choice, Column};
use smid_core::model::{ModelSet, Record};
use smid_core::pipeline::{self, ExperimentData};
use smid_core::plant::Plant;
use smid_core::plot::{self, Line};
use smid_core::spec::{AlphaSpec, Spec};
use smid_core::validate::{Fit, Validation, Verdict};
use smid_core::{Result, SmidError};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// What `validate` and `diagnose` start from.
pub struct Source {
    /// The run spec (from the file, or stored in `result.json`).
    pub spec: Spec,
    /// Directory relative paths of the spec resolve against.
    pub base: PathBuf,
    /// The model set already identified (`result.json`), if any.
    pub model: Option<ModelSet>,
}

/// Read a run spec (`.yaml`) or a `result.json` of `smid run` (which stores its spec).
pub fn load_source(path: &Path) -> Result<Source> {
    let is_json = path.extension().is_some_and(|e| e == "json");
    if !is_json {
        return Ok(Source {
            spec: load_spec(path)?,
            base: path.parent().unwrap_or(Path::new(".")).to_path_buf(),
            model: None,
        });
    }
    let text = std::fs::read_to_string(path).map_err(|source| SmidError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    source_from_json(&text, path)
}

/// A source from the text of a `result.json` (`path` names it in errors and is the fallback
/// directory of relative paths when the file stores none).
pub fn source_from_json(text: &str, path: &Path) -> Result<Source> {
    crate::link_plugins();
    let bad = |field: &str, message: String| SmidError::Spec {
        file: path.to_path_buf(),
        line: None,
        field: field.into(),
        message,
    };
    let v: serde_json::Value =
        serde_json::from_str(text).map_err(|e| bad("", format!("not JSON: {e}")))?;
    smid_core::output::check(smid_core::output::OutputKind::Result, &v, path)?;
    let model: ModelSet = serde_json::from_value(v.get("model").cloned().ok_or_else(|| {
        bad(
            "model",
            "no model set: write it with this version's `smid run`".into(),
        )
    })?)
    .map_err(|e| bad("model", e.to_string()))?;
    let spec: Spec = serde_json::from_value(
        v.get("spec")
            .cloned()
            .ok_or_else(|| bad("spec", "no spec stored".into()))?,
    )
    .map_err(|e| bad("spec", e.to_string()))?;
    let base = v
        .get("spec_dir")
        .and_then(|d| d.as_str())
        .map(PathBuf::from)
        .unwrap_or_else(|| path.parent().unwrap_or(Path::new(".")).to_path_buf());
    Ok(Source {
        spec,
        base,
        model: Some(model),
    })
}

/// The training data of a source: the spec's experiments (run on its plant, or its measured
/// records), or the training data stored with the model set (α already applied, so the spec's
/// α becomes `zero`).
pub fn training_data(src: &mut Source) -> Result<ExperimentData> {
    if let Some(m) = &src.model {
        src.spec.method.alpha = AlphaSpec::Zero;
        return Ok(ExperimentData {
            steady: m.training.steady.clone(),
            steady_record: None,
            records: m.training.records.clone(),
            filter: None,
        });
    }
    let spec = &src.spec;
    if spec.plant.data.is_some() {
        return pipeline::load_data(spec, &src.base);
    }
    with_plant(spec, &src.base, |plant| {
        pipeline::simulate_experiments(spec, plant)
    })
}

/// Run `f` on the spec's plant (built-in simulator or FMU).
pub fn with_plant<T>(
    spec: &Spec,
    base: &Path,
    f: impl FnOnce(&mut dyn Plant) -> Result<T>,
) -> Result<T> {
    if spec.plant.fmu.is_some() {
        return with_fmu_plant(spec, base, f);
    }
    match pipeline::builtin_plant(spec) {
        Some(mut p) => f(&mut p),
        None => Err(SmidError::invalid(
            "plant",
            "measured data (`plant.data`) have no plant to simulate or draw fresh records from: give a `simulator` or an `fmu` plant, or the records with --data / --holdout",
        )),
    }
}

/// Fresh records: the CSV files given (columns of the spec's first dynamic record for measured
/// data, else `u` and `y` as `smid simulate` writes them), or `count` records of the spec's
/// plant drawn with seeds `seed, seed + 1, ...` (`length` samples each).
pub fn fresh_records(
    spec: &Spec,
    base: &Path,
    csvs: &[PathBuf],
    seed: u64,
    length: usize,
    count: usize,
) -> Result<Vec<Record>> {
    let delta = fresh_bound(spec)?;
    if !csvs.is_empty() {
        let mut out = Vec::new();
        for f in csvs {
            out.extend(records_of_file(spec, f, delta)?);
        }
        return Ok(out);
    }
    with_plant(spec, base, |plant| {
        (0..count as u64)
            .map(|k| pipeline::fresh_record(spec, plant, seed + k, length))
            .collect()
    })
}

/// The fresh records of one CSV file (`PATH` or `PATH@START..END`): one per distinct pair of
/// input and output columns of the spec's dynamic records that the file holds (the columns `u`
/// and `y` as `smid simulate` writes them without measured data), read as those records are
/// (`decimate`), the rows before `START` kept as input history where `plant.data.initial` is
/// `input_history`.
fn records_of_file(spec: &Spec, arg: &Path, delta: f64) -> Result<Vec<Record>> {
    use smid_core::spec::{CsvColumns, InitialState};
    let (templates, dt, initial) = match &spec.plant.data {
        Some(d) => {
            let mut t: Vec<CsvColumns> = Vec::new();
            for c in d.dynamic.items() {
                if !t.iter().any(|k| k.u == c.u && k.y == c.y) {
                    t.push(c.clone());
                }
            }
            (t, d.dt.unwrap_or(1.0), d.initial)
        }
        None => (
            vec![CsvColumns::uy(PathBuf::new())],
            1.0,
            InitialState::Measured,
        ),
    };
    let (file, rows) = split_rows(arg)?;
    let header = smid_core::data::read_header(&file)?;
    let held: Vec<&CsvColumns> = templates
        .iter()
        .filter(|c| header.contains(&c.u) && header.contains(&c.y))
        .collect();
    if held.is_empty() {
        return Err(SmidError::Data {
            file: file.clone(),
            location: "header".into(),
            message: format!(
                "expected the input and output columns of one of the spec's records ({}); columns are: {}",
                templates
                    .iter()
                    .map(|c| format!("`{}` and `{}`", c.u, c.y))
                    .collect::<Vec<_>>()
                    .join(", or "),
                header.join(", ")
            ),
        });
    }
    let several = held.len() > 1;
    held.into_iter()
        .map(|t| {
            let mut c = t.clone();
            c.file = file.clone();
            c.part = None;
            let k = c.decimate.unwrap_or(1);
            c.rows = rows;
            let mut history = None;
            if initial == InitialState::InputHistory {
                // From rest at the file's first row: the rows before START are read too.
                let a = rows.map_or(0, |[a, _]| a);
                if a % k != 0 {
                    return Err(SmidError::Data {
                        file: file.clone(),
                        location: format!("rows from {a}"),
                        message: format!(
                            "with `plant.data.initial: input_history` the start row must be a multiple of `decimate` ({k}), got {a}"
                        ),
                    });
                }
                c.rows = rows.map(|[_, b]| [0, b]);
                history = Some(a / k);
            }
            let mut r = smid_core::data::read_record(Path::new("."), &c, delta, dt)?;
            if let (Some(_), Some([a, b])) = (history, rows) {
                // Named by the rows that count (read from row 0).
                let stem = file.file_name().unwrap_or(file.as_os_str()).to_string_lossy();
                r.name = format!("{stem} rows {a}..{b}");
            }
            if several {
                r.name = format!("{} ({} -> {})", r.name, c.u, c.y);
            }
            r.history = history;
            Ok(r)
        })
        .collect()
}

/// The noise bound a fresh record gets when read: the spec's Δη (validation bounds fresh
/// records by the model's own Δη; an estimated one is not known here, so 1 stands in).
fn fresh_bound(spec: &Spec) -> Result<f64> {
    match spec.noise.delta() {
        Err(_) if spec.noise.estimated() => Ok(1.0),
        d => d,
    }
}

/// Fresh records from arrays `(name, u, y)` (the Python package's way in), shaped as the CSV
/// records of the spec would be (its first dynamic record's `decimate`: block means, sample
/// time `dt·k`) with the same noise bound; lengths and values checked, errors naming the
/// record and sample.
pub fn records_from_arrays(
    spec: &Spec,
    arrays: Vec<(String, Vec<f64>, Vec<f64>)>,
) -> Result<Vec<Record>> {
    let delta = fresh_bound(spec)?;
    let (k, dt) = match &spec.plant.data {
        Some(d) => (
            d.dynamic.items()[0].decimate.unwrap_or(1),
            d.dt.unwrap_or(1.0),
        ),
        None => (1, 1.0),
    };
    arrays
        .into_iter()
        .map(|(name, u, y)| {
            Record::measured(name.clone(), u.clone(), y.clone(), delta, dt).validate()?;
            let origin = PathBuf::from(format!("record `{name}`"));
            smid_core::data::decimated(&origin, name, u, y, k, delta, dt)
        })
        .collect()
}

/// `PATH@START..END`: the data rows `[START, END)` of a CSV file (a held-out stretch of a long
/// record); a plain path takes every row.
pub fn split_rows(arg: &Path) -> Result<(PathBuf, Option<[usize; 2]>)> {
    let text = arg.to_string_lossy();
    let Some((file, range)) = text.rsplit_once('@') else {
        return Ok((arg.to_path_buf(), None));
    };
    let bad = || {
        SmidError::invalid(
            format!("record `{text}`"),
            "expected PATH or PATH@START..END (data rows, END exclusive)",
        )
    };
    let (a, b) = range.split_once("..").ok_or_else(bad)?;
    let a: usize = a.trim().parse().map_err(|_| bad())?;
    let b: usize = b.trim().parse().map_err(|_| bad())?;
    Ok((PathBuf::from(file), Some([a, b])))
}

fn pct(f: f64) -> String {
    if f.is_finite() {
        format!("{f:.2} %")
    } else {
        "-inf %".into()
    }
}

fn fit_line(name: &str, f: &Fit) -> String {
    format!(
        "{name:<26} fit {:>9}  NRMSE {:.4}  RMS {:.4e}  max {:.4e}",
        pct(f.fit_percent),
        f.nrmse,
        f.rms,
        f.max_abs
    )
}

/// PASS, FAIL, or, when the verdict is undecided, that it is not passed for that reason.
fn pass_word(v: &Validation) -> &'static str {
    match (v.pass, v.consistency.verdict) {
        (true, _) => "PASS",
        (false, Verdict::Undecided) => "not passed (the verdict is undecided)",
        (false, _) => "FAIL",
    }
}

/// The text report of a validation.
pub fn format_validation(v: &Validation, records: &[Record]) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "validation of `{}` on {} fresh record(s): {}",
        v.model,
        records.len(),
        records
            .iter()
            .map(|r| match r.history {
                None => format!("{} ({} samples)", r.name, r.y.len()),
                Some(h) => format!(
                    "{} ({} samples from rest, after {h} of input history)",
                    r.name,
                    r.y.len().saturating_sub(h)
                ),
            })
            .collect::<Vec<_>>()
            .join("; ")
    );
    match (&v.consistency.verdict, &v.consistency.falsified_at) {
        (Verdict::Proven, _) => {
            let _ = writeln!(
                s,
                "verdict: CONSISTENT, proven (a member of the set, found from the simulation member, satisfies the training and the fresh equations within their noise bounds)"
            );
        }
        (Verdict::Falsified, None) => {
            let _ = writeln!(
                s,
                "verdict: FALSIFIED (every cell of the set is contradicted)"
            );
        }
        (Verdict::Consistent, _) => {
            let _ = writeln!(
                s,
                "verdict: CONSISTENT (the identified sets and the training equations admit the fresh data: no contradiction found)"
            );
        }
        (Verdict::Undecided, _) => {
            let why = v
                .consistency
                .undecided
                .map_or_else(|| "no cause recorded".to_string(), |u| u.describe());
            let _ = writeln!(s, "verdict: UNDECIDED ({why})");
        }
        (Verdict::Falsified, Some(f)) => {
            let at = if f.located {
                "first offending sample"
            } else {
                "inconsistent up to sample"
            };
            let _ = writeln!(
                s,
                "verdict: FALSIFIED: fresh record {}, {at} {} ({}: {})",
                f.record, f.sample, f.stage, f.detail
            );
        }
    }
    let src = v.bound_source.describe();
    match v.smallest_bound {
        Some((_, 0.0)) => {
            let _ = writeln!(
                s,
                "smallest consistent noise bound: 0 (a cell of the set admits these records down to 1e-9 of the bound, reported as 0: noise-free records in a cell holding the truth, or stage-2 intervals over the cell wider than the noise, where the records test little); bound {:.4e} ({src}): {}",
                v.bound,
                pass_word(v)
            );
        }
        Some((lo, hi)) => {
            let _ = writeln!(
                s,
                "smallest consistent noise bound: {hi:.4e} (provably inconsistent below {lo:.4e}); bound {:.4e} ({src}): {}",
                v.bound,
                pass_word(v)
            );
        }
        None => {
            let _ = writeln!(
                s,
                "smallest consistent noise bound: none up to 2^30 × the bound: FAIL"
            );
        }
    }
    let _ = writeln!(s, "member: {}", v.member);
    let _ = writeln!(s, "{}", fit_line("free run", &v.free_run));
    if let Some(c) = &v.centre_free_run {
        let _ = writeln!(s, "{}", fit_line("free run of the centre", c));
    }
    let _ = writeln!(s, "{}", fit_line("one-step prediction", &v.one_step));
    let _ = writeln!(
        s,
        "{}",
        fit_line(&format!("{}-step prediction", v.k), &v.k_step)
    );
    if let Some(b) = &v.baseline {
        let (na, nb, nk) = v.baseline_orders;
        let _ = writeln!(
            s,
            "{}",
            fit_line(
                &format!("baseline ARX({na},{nb},{nk})+constant free run"),
                b
            )
        );
    }
    if v.per_record.len() > 1 {
        for (name, f) in &v.per_record {
            let _ = writeln!(s, "  {}", fit_line(name, f));
        }
    }
    let c = &v.correlations;
    let _ = writeln!(
        s,
        "one-step residual: autocorrelation outside the 99 % band at {}/{} lags, input cross-correlation at {}/{}",
        c.auto_outside,
        c.auto.len() - 1,
        c.cross_outside,
        c.cross.len()
    );
    let _ = writeln!(s, "envelope: {}", v.envelope);
    match &v.band {
        Some(b) => {
            let _ = writeln!(
                s,
                "guaranteed one-step band (every member of the set, from the past outputs; {} of each of {} cell(s), {} of them proven empty{}): finite at {}/{} samples, mean width {:.4e}; measured outputs outside band ± Δη: {}{}",
                if b.lp { "LPs over the θ polytope" } else { "interval arithmetic over the θ box" },
                b.cells,
                b.empty_cells,
                match b.unevaluated {
                    0 => String::new(),
                    k => format!(", {k} not evaluated: a cell with θ unbounded bounds no sample"),
                },
                b.finite,
                b.samples,
                b.mean_width,
                b.outside,
                match b.first_outside {
                    Some((r, t)) => format!(" (first: record {r}, sample {t}: the set is contradicted there)"),
                    None => String::new(),
                }
            );
        }
        None => {
            let _ = writeln!(s, "guaranteed one-step band: not computed");
        }
    }
    if v.warnings.is_empty() {
        let _ = writeln!(s, "warnings: none");
    } else {
        for w in &v.warnings {
            let _ = writeln!(s, "warning: {w}");
        }
    }
    s
}

fn io(path: &Path) -> impl Fn(std::io::Error) -> SmidError + '_ {
    move |source| SmidError::Io {
        path: path.to_path_buf(),
        source,
    }
}

/// Write `validation.json` (the validation stamped with its format,
/// [`smid_core::output::OutputKind::Validation`]) and the SVG plots (measured against free run
/// with the envelope and the baseline, per record; residual correlations).
pub fn write_validation(v: &Validation, dir: &Path, prefix: &str) -> Result<Vec<PathBuf>> {
    std::fs::create_dir_all(dir).map_err(io(dir))?;
    let mut out = Vec::new();
    let json = dir.join(format!("{prefix}validation.json"));
    let stamped = smid_core::output::OutputKind::Validation.stamp(v);
    std::fs::write(
        &json,
        serde_json::to_string_pretty(&stamped).unwrap_or_default(),
    )
    .map_err(io(&json))?;
    out.push(json);
    for (k, s) in v.series.iter().enumerate() {
        let path = dir.join(format!("{prefix}free_run_{k}.svg"));
        let mut lines = vec![
            Line {
                label: "measured y",
                values: &s.y,
                color: (0, 0, 0),
            },
            Line {
                label: if v.centre_free_run.is_some() {
                    "model, free run (simulation member)"
                } else {
                    "model, free run (central member)"
                },
                values: &s.free_run,
                color: (0, 0, 255),
            },
        ];
        if let Some(b) = &s.baseline {
            lines.push(Line {
                label: "ARX baseline, free run",
                values: b,
                color: (0, 150, 0),
            });
        }
        plot::series_svg(
            &format!("{}: {}", v.model, s.name),
            &lines,
            &[plot::Shade {
                label: if v.envelope.starts_with("certified") {
                    "free runs of certified members (inner approximation of the set's range)"
                } else {
                    "free runs of axis members (indicative, not certified)"
                },
                lower: &s.envelope.0,
                upper: &s.envelope.1,
                color: (250, 200, 120),
            }],
            &path,
        )?;
        out.push(path);
        // The one-step prediction against the guaranteed band of the whole set.
        if let Some((lo, hi)) = &s.band {
            let path = dir.join(format!("{prefix}one_step_{k}.svg"));
            let lines = [
                Line {
                    label: "measured y",
                    values: &s.y,
                    color: (0, 0, 0),
                },
                Line {
                    label: "one-step prediction of the member",
                    values: &s.one_step,
                    color: (0, 0, 255),
                },
            ];
            plot::series_svg(
                &format!("{}: {} (one step ahead)", v.model, s.name),
                &lines,
                &[plot::Shade {
                    label: "guaranteed one-step band of the whole set (noise-free output)",
                    lower: lo,
                    upper: hi,
                    color: (120, 170, 250),
                }],
                &path,
            )?;
            out.push(path);
        }
    }
    let path = dir.join(format!("{prefix}residual_correlation.svg"));
    plot::correlation_svg(
        &v.correlations.auto,
        &v.correlations.cross,
        v.correlations.band,
        &path,
    )?;
    out.push(path);
    Ok(out)
}

fn verdict_text(t: &diagnose::TrainVerdict) -> String {
    match t {
        diagnose::TrainVerdict::Consistent {
            fit_percent,
            bound,
            unsettled,
            within,
        } => format!(
            "{} at bound {bound:.3e}, training free-run fit {}{}{}",
            if unsettled.is_some() {
                "undecided"
            } else {
                "consistent"
            },
            pct(*fit_percent),
            within.map_or(String::new(), |e| format!(
                ", its member within {e:.3e} of every training sample"
            )),
            unsettled.map_or(String::new(), |g| format!(
                " (stage 3's rounds stopped at their cap, the last shrank a radius by {:.1} %, and no certified member proves the set non-empty: more rounds may falsify it; ranked as consistent)",
                100.0 * g
            ))
        ),
        diagnose::TrainVerdict::Falsified {
            stage,
            record,
            sample,
            located,
            ..
        } => {
            let at = if *located {
                "falsified at"
            } else {
                "falsified (not located) by"
            };
            match stage {
                smid_core::error::Stage::SteadyState => {
                    format!("{at} steady-state point {sample} ({stage})")
                }
                _ => format!("{at} sample {sample} of training record {record} ({stage})"),
            }
        }
        diagnose::TrainVerdict::AboveBar(pipeline::AboveBar { bar, test, .. }) => format!(
            "inconsistent at the bar {bar:.3e} ({test}): its bound would be above it, not bracketed further"
        ),
        diagnose::TrainVerdict::Bracketed {
            bound,
            at_least: false,
        } => format!(
            "bound {bound:.3e} (bracketed with the diagnosis's cells), not identified: above the chosen candidate's by more than the rule's step, so it could be neither chosen nor equivalent to the choice"
        ),
        diagnose::TrainVerdict::Bracketed {
            bound,
            at_least: true,
        } => format!(
            "bound at least {bound:.3e}, if any (bracketed with the diagnosis's cells, not finished: it cannot keep a lower one, and finishing it might find none), not identified: above the chosen candidate's by more than the rule's step, so it could be neither chosen nor equivalent to the choice"
        ),
        diagnose::TrainVerdict::UnboundedCells { cells, detail } => format!(
            "{cells} cell(s) left without a finite θ bound: {detail}"
        ),
        diagnose::TrainVerdict::Failed { message } => format!("failed: {message}"),
        diagnose::TrainVerdict::NotTried { reason: None } => "not tried".to_string(),
        diagnose::TrainVerdict::NotTried {
            reason: Some(reason),
        } => format!("not tried: {reason}"),
        diagnose::TrainVerdict::Reproduced { residual, draws } => format!(
            "not identified: the base model reproduces its free runs exactly (equation error at most {residual:.1e} of the range at {draws} draws of its parameters: the corners of their prior box and three inside), so its smallest consistent bound is not lower"
        ),
    }
}

/// The evidence of the choice (training data only).
pub fn format_choice(c: &Choice) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "choice rule (training data only): {}", c.rule);
    for (i, r) in c.rounds.iter().enumerate() {
        let _ = writeln!(
            s,
            "round {}: base {} — {}",
            i + 1,
            r.base,
            verdict_text(&r.base_train)
        );
        for e in &r.candidates {
            let _ = writeln!(
                s,
                "  {} {:<36} +{} param  {}{}",
                if e.chosen { "*" } else { " " },
                e.label,
                e.added_parameters,
                verdict_text(&e.train),
                if e.priors.is_empty() {
                    String::new()
                } else {
                    format!(
                        "  (prior {})",
                        e.priors
                            .iter()
                            .map(|(n, p)| format!("{n} ∈ [{:.3e}, {:.3e}]", p[0], p[1]))
                            .collect::<Vec<_>>()
                            .join(", ")
                    )
                }
            );
            if !e.equivalent_to.is_empty() {
                let _ = writeln!(
                    s,
                    "      indistinguishable on the training records from: {}",
                    e.equivalent_to.join("; ")
                );
            }
        }
    }
    let _ = writeln!(s, "diagnosis: {}", c.summary());
    s
}

/// The before/after table on the held-out records.
pub fn format_table(before: &Column, after: &Column) -> String {
    let mut s = String::new();
    let row = |s: &mut String, name: &str, a: String, b: String| {
        let _ = writeln!(s, "| {name} | {a} | {b} |");
    };
    let _ = writeln!(s, "| held-out records | before | after |");
    let _ = writeln!(s, "|---|---|---|");
    row(&mut s, "model", before.label.clone(), after.label.clone());
    row(
        &mut s,
        "noise bound used",
        bound_text(before),
        bound_text(after),
    );
    let verdict = |c: &Column| match &c.validation {
        None => "no member (see below)".to_string(),
        Some(v) => v.consistency.brief(),
    };
    row(&mut s, "verdict", verdict(before), verdict(after));
    let smallest = |c: &Column| match c.validation.as_ref().map(|v| (v.smallest_bound, v)) {
        Some((Some((_, 0.0)), v)) => format!(
            "0 ({}; a cell admits them down to 1e-9 of the bound)",
            pass_word(v)
        ),
        Some((Some((_, hi)), v)) => format!("{hi:.3e} ({})", pass_word(v)),
        _ => "none".into(),
    };
    row(
        &mut s,
        "smallest consistent bound",
        smallest(before),
        smallest(after),
    );
    let fit = |c: &Column, f: fn(&Validation) -> &Fit| match &c.validation {
        Some(v) => format!("{:.3e} / {}", f(v).rms, pct(f(v).fit_percent)),
        None => "-".into(),
    };
    row(
        &mut s,
        "one-step RMS / fit",
        fit(before, |v| &v.one_step),
        fit(after, |v| &v.one_step),
    );
    row(
        &mut s,
        "free-run RMS / fit",
        fit(before, |v| &v.free_run),
        fit(after, |v| &v.free_run),
    );
    let base = |c: &Column| {
        c.validation
            .as_ref()
            .and_then(|v| v.baseline)
            .map(|b| pct(b.fit_percent))
            .unwrap_or_else(|| "-".into())
    };
    row(
        &mut s,
        "ARX baseline free-run fit (same orders)",
        base(before),
        base(after),
    );
    row(
        &mut s,
        "identified parameters",
        before.parameters.to_string(),
        after.parameters.to_string(),
    );
    row(
        &mut s,
        "mean bound radius",
        format!("{:.3e}", before.mean_radius),
        format!("{:.3e}", after.mean_radius),
    );
    for (name, c) in [("before", before), ("after", after)] {
        if let Some(why) = &c.stopped {
            let _ = writeln!(s, "\n{name}: no model to validate: {}", why.describe());
        }
    }
    s
}

fn bound_text(c: &Column) -> String {
    if c.stopped.is_some() {
        "none found (the bounded search stopped)".into()
    } else if c.inflated {
        format!(
            "{:.3e} (inflated: the training data falsify the model at the declared bound)",
            c.bound
        )
    } else {
        format!("{:.3e}", c.bound)
    }
}

/// The content of `diagnosis.json`: the choice and the before/after columns, stamped with the
/// file's format ([`smid_core::output::OutputKind::Diagnosis`]).
pub fn diagnosis_value(choice: &Choice, before: &Column, after: &Column) -> serde_json::Value {
    let content = serde_json::json!({
        "choice": choice,
        "before": before,
        "after": after,
    });
    serde_json::to_value(smid_core::output::OutputKind::Diagnosis.stamp(&content))
        .unwrap_or(content)
}

/// Write `diagnosis.json`, the augmented spec, and the before/after plots.
pub fn write_diagnosis(
    spec: &Spec,
    choice: &Choice,
    before: &Column,
    after: &Column,
    dir: &Path,
) -> Result<Vec<PathBuf>> {
    std::fs::create_dir_all(dir).map_err(io(dir))?;
    let mut out = Vec::new();
    let json = dir.join("diagnosis.json");
    let v = diagnosis_value(choice, before, after);
    std::fs::write(&json, serde_json::to_string_pretty(&v).unwrap_or_default())
        .map_err(io(&json))?;
    out.push(json);
    let augmented = dir.join("augmented.yaml");
    let mut s = diagnose::with_model(spec, &choice.after);
    s.method = choice.method.clone();
    let text =
        serde_norway::to_string(&s).map_err(|e| SmidError::invalid("spec", e.to_string()))?;
    std::fs::write(&augmented, text).map_err(io(&augmented))?;
    out.push(augmented);
    let series = |c: &Column| {
        c.validation
            .as_ref()
            .map(|v| v.series.clone())
            .unwrap_or_default()
    };
    let (bs, as_) = (series(before), series(after));
    for (k, (b, a)) in bs.iter().zip(&as_).enumerate() {
        let path = dir.join(format!("before_after_{k}.svg"));
        let mut lines = vec![
            Line {
                label: "measured y",
                values: &b.y,
                color: (0, 0, 0),
            },
            Line {
                label: "before, free run",
                values: &b.free_run,
                color: (220, 0, 0),
            },
            Line {
                label: "after, free run",
                values: &a.free_run,
                color: (0, 0, 255),
            },
        ];
        if let Some(base) = &a.baseline {
            lines.push(Line {
                label: "ARX baseline, free run",
                values: base,
                color: (0, 150, 0),
            });
        }
        plot::series_svg(&format!("held-out: {}", b.name), &lines, &[], &path)?;
        out.push(path);
    }
    if let Some(v) = &after.validation {
        out.extend(write_validation(v, dir, "after_")?);
    }
    Ok(out)
}
