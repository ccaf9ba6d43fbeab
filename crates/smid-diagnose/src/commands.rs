//! The `smid validate` and `smid diagnose` commands as library calls: load the spec and the
//! records (a `--data`/`--holdout` CSV replaces the spec's records, read with the spec's columns
//! and decimation), run, write the report, JSON and SVG plots to an output directory, and
//! return the report text with the files written.
use crate::diagnose::{self, Diagnosis};
use crate::effect::Record;
use crate::lip::Structure;
use crate::spec::{self, DiagSpec, RecordSpec};
use crate::validate::{self, Assessment};
use crate::{plot, DiagError};
use std::path::{Path, PathBuf};

fn write(path: &Path, text: &str) -> Result<(), DiagError> {
    std::fs::write(path, text).map_err(|source| DiagError::Io {
        path: path.to_path_buf(),
        source,
    })
}

fn one(file: &Path, s: &DiagSpec) -> Result<Record, DiagError> {
    spec::load_record(
        &RecordSpec {
            file: file.to_path_buf(),
            rows: None,
        },
        &s.data,
        Path::new("."),
    )
}

/// Load spec and records: (spec, train, holdout). Without any held-out record, the last 30% of
/// each training record is held out.
pub fn load(
    spec_path: &Path,
    data: Option<&Path>,
    holdout: Option<&Path>,
) -> Result<(DiagSpec, Vec<Record>, Vec<Record>), DiagError> {
    let s = DiagSpec::from_file(spec_path)?;
    let base = spec_path.parent().unwrap_or(Path::new("."));
    let train = match data {
        Some(f) => vec![one(f, &s)?],
        None => spec::load_records(&s.data.train, &s.data, base)?,
    };
    let hold = match holdout {
        Some(f) => vec![one(f, &s)?],
        None => spec::load_records(&s.data.holdout, &s.data, base)?,
    };
    if hold.is_empty() {
        let (t, h) = spec::split_tail(&train, 0.3);
        return Ok((s, t, h));
    }
    Ok((s, train, hold))
}

fn mkdir(dir: &Path) -> Result<(), DiagError> {
    std::fs::create_dir_all(dir).map_err(|source| DiagError::Io {
        path: dir.to_path_buf(),
        source,
    })
}

/// `smid validate`: identify on the spec's training records, validate on `data` (default: the
/// spec's held-out records).
pub fn validate(
    spec_path: &Path,
    data: Option<&Path>,
    out: &Path,
) -> Result<(String, Assessment, Vec<PathBuf>), DiagError> {
    let (s, train, hold) = load(spec_path, None, data)?;
    let st = validate::tune_declared(
        &Structure {
            base: s.model.orders(),
            effects: s.model.effects.clone(),
        },
        &train,
    );
    let f = validate::fit(&st, &train)?;
    let (delta, how) = match s.noise.bound {
        Some(d) => (d, "declared".to_string()),
        None => (
            s.noise.estimate_margin * f.dstar_train,
            format!(
                "estimated: {} × the smallest bound consistent with the training records",
                s.noise.estimate_margin
            ),
        ),
    };
    let a = validate::assess(&f, &train, &hold, delta)?;
    let text = validate::format_report(&a, &how);
    mkdir(out)?;
    let mut files = Vec::new();
    let p = out.join("validation.txt");
    write(&p, &text)?;
    files.push(p);
    let p = out.join("validation.json");
    write(
        &p,
        &serde_json::to_string_pretty(&a).map_err(|e| DiagError::Invalid(e.to_string()))?,
    )?;
    files.push(p);
    if let Some(sr) = a.series.first() {
        let p = out.join("validation.svg");
        plot::validation_svg(sr, &format!("validation: {}", sr.name), &p)?;
        files.push(p);
    }
    let p = out.join("residual-correlation.svg");
    plot::correlation_svg(&a.correlations, "held-out", &p)?;
    files.push(p);
    Ok((text, a, files))
}

/// `smid diagnose`: the report, the diagnosis and the files written (report, JSON, augmented
/// spec YAML, plots).
pub fn diagnose(
    spec_path: &Path,
    data: Option<&Path>,
    holdout: Option<&Path>,
    out: &Path,
    progress: impl FnMut(usize, usize),
) -> Result<(String, Diagnosis, Vec<PathBuf>), DiagError> {
    let (s, train, hold) = load(spec_path, data, holdout)?;
    let d = diagnose::diagnose(&s, &train, &hold, progress)?;
    let text = diagnose::format_report(&d);
    mkdir(out)?;
    let mut files = Vec::new();
    let p = out.join("diagnosis.md");
    write(&p, &text)?;
    files.push(p);
    let p = out.join("diagnosis.json");
    write(
        &p,
        &serde_json::to_string_pretty(&d).map_err(|e| DiagError::Invalid(e.to_string()))?,
    )?;
    files.push(p);
    if let Some(aug) = &d.augmented {
        let p = out.join("augmented.yaml");
        let mut y = format!(
            "# written by `smid diagnose {}`; effects added: {}\n# data paths are relative to the original spec's directory\n",
            spec_path.display(),
            d.added_tags.join(", ")
        );
        y.push_str(&aug.to_yaml()?);
        write(&p, &y)?;
        files.push(p);
    }
    let p = out.join("residual-before-after.svg");
    plot::before_after_svg(&d.before, &d.after, &p)?;
    files.push(p);
    for (tag, a) in [("before", &d.before), ("after", &d.after)] {
        if let Some(sr) = a.series.first() {
            let p = out.join(format!("validation-{tag}.svg"));
            plot::validation_svg(sr, &format!("{tag}: {}", a.model), &p)?;
            files.push(p);
        }
        let p = out.join(format!("residual-correlation-{tag}.svg"));
        plot::correlation_svg(&a.correlations, tag, &p)?;
        files.push(p);
    }
    Ok((text, d, files))
}
