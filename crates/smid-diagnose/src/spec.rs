//! The validation/diagnosis spec (YAML): where the training and held-out records are (CSV
//! columns, row ranges, decimation), the equation-error bound Δ (given, or estimated from the
//! data), the LIP model structure (orders plus declared effects) and the diagnosis options.
//! Loading turns it into [`Record`]s; every error names the file and field or row.
use crate::effect::{Effect, Orders, Record};
use crate::DiagError;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// A validation/diagnosis spec.
#[derive(Debug, Clone, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct DiagSpec {
    #[serde(default)]
    pub name: Option<String>,
    pub data: DataSpec,
    #[serde(default)]
    pub noise: NoiseSpec,
    pub model: LipModel,
    #[serde(default)]
    pub diagnose: DiagnoseOptions,
}

/// Columns, records and preprocessing.
#[derive(Debug, Clone, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct DataSpec {
    /// Input column.
    pub u: String,
    /// Output column.
    pub y: String,
    /// Keep every `decimate`-th block mean (1: no decimation).
    #[serde(default = "one")]
    pub decimate: usize,
    /// Sample time of the raw data in seconds (default 1).
    #[serde(default = "onef")]
    pub dt: f64,
    /// Training records.
    pub train: Vec<RecordSpec>,
    /// Held-out records (default: none; diagnosis then holds out the last 30% of each
    /// training record).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub holdout: Vec<RecordSpec>,
}

fn one() -> usize {
    1
}
fn onef() -> f64 {
    1.0
}

/// One CSV record, optionally a row range `[start, end)` of it (data rows, 0-based).
#[derive(Debug, Clone, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct RecordSpec {
    pub file: PathBuf,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rows: Option<[usize; 2]>,
}

/// The equation-error bound Δ: given, or estimated.
#[derive(Debug, Clone, Default, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct NoiseSpec {
    /// `|e_t| <= bound` in the LIP equation. For output noise `|η_t| <= Δη` in an ARX
    /// structure this is `(1 + Σ|a_i|) Δη`. When absent, Δ is estimated: the smallest bound
    /// for which the training records are consistent with the final (augmented) model, times
    /// `estimate_margin` (so the bound is a data-based estimate, not a prior guarantee).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub bound: Option<f64>,
    #[serde(default = "margin")]
    pub estimate_margin: f64,
}
fn margin() -> f64 {
    1.1
}

/// The JSON Schema of diagnosis specs (pretty-printed, newline-terminated); the committed copy
/// is `schemas/smid-diagnose.schema.json`.
pub fn schema() -> String {
    let schema = schemars::schema_for!(DiagSpec);
    serde_json::to_string_pretty(&schema).unwrap_or_default() + "\n"
}

/// The LIP model structure: linear orders and declared effects.
#[derive(Debug, Clone, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct LipModel {
    /// Number of output lags `a_1..a_na`.
    pub na: usize,
    /// Number of input coefficients `b_0..b_{nb-1}`.
    pub nb: usize,
    /// Input delay in samples.
    #[serde(default)]
    pub nk: usize,
    /// Declared effects (each a registered `type`).
    #[serde(default)]
    #[schemars(with = "Vec<serde_json::Value>")]
    pub effects: Vec<Box<dyn Effect>>,
}

impl LipModel {
    /// The linear orders.
    pub fn orders(&self) -> Orders {
        Orders {
            na: self.na,
            nb: self.nb,
            nk: self.nk,
        }
    }
}

/// Options of `smid diagnose`.
#[derive(Debug, Clone, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct DiagnoseOptions {
    /// Relative penalty per added parameter: a candidate scores
    /// `RMS_holdout · (1 + penalty)^k` (k added parameters).
    #[serde(default = "pen")]
    pub penalty: f64,
    /// How many effects to add at most (greedy rounds).
    #[serde(default = "maxe")]
    pub max_effects: usize,
    /// Restrict the candidates to these `type` tags (default: every registered effect).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub only: Vec<String>,
}
fn pen() -> f64 {
    0.02
}
fn maxe() -> usize {
    3
}
impl Default for DiagnoseOptions {
    fn default() -> Self {
        DiagnoseOptions {
            penalty: pen(),
            max_effects: maxe(),
            only: Vec::new(),
        }
    }
}

impl DiagSpec {
    /// Parse a spec file.
    pub fn from_file(path: &Path) -> Result<Self, DiagError> {
        let text = std::fs::read_to_string(path).map_err(|e| DiagError::Spec {
            file: path.to_path_buf(),
            message: e.to_string(),
        })?;
        Self::from_yaml(&text, path)
    }

    /// Parse YAML text (`path` only names the source in errors).
    pub fn from_yaml(text: &str, path: &Path) -> Result<Self, DiagError> {
        let de = serde_norway::Deserializer::from_str(text);
        let spec: DiagSpec = serde_path_to_error_free(de).map_err(|message| DiagError::Spec {
            file: path.to_path_buf(),
            message,
        })?;
        spec.check().map_err(|message| DiagError::Spec {
            file: path.to_path_buf(),
            message,
        })?;
        Ok(spec)
    }

    fn check(&self) -> Result<(), String> {
        if self.data.decimate == 0 {
            return Err("field `data.decimate`: must be at least 1".into());
        }
        if !(self.data.dt > 0.0 && self.data.dt.is_finite()) {
            return Err("field `data.dt`: must be a positive number".into());
        }
        if self.data.train.is_empty() {
            return Err("field `data.train`: give at least one record".into());
        }
        if let Some(b) = self.noise.bound {
            if !(b > 0.0 && b.is_finite()) {
                return Err(format!("field `noise.bound`: must be positive, got {b}"));
            }
        }
        if !(self.noise.estimate_margin >= 1.0 && self.noise.estimate_margin.is_finite()) {
            return Err("field `noise.estimate_margin`: must be at least 1".into());
        }
        if self.model.nb == 0 && self.model.na == 0 {
            return Err("field `model`: na and nb are both 0".into());
        }
        if !(self.diagnose.penalty >= 0.0 && self.diagnose.penalty.is_finite()) {
            return Err("field `diagnose.penalty`: must be non-negative".into());
        }
        Ok(())
    }

    /// Serialize back to YAML (the augmented spec).
    pub fn to_yaml(&self) -> Result<String, DiagError> {
        serde_norway::to_string(self).map_err(|e| DiagError::Invalid(e.to_string()))
    }
}

fn serde_path_to_error_free(de: serde_norway::Deserializer<'_>) -> Result<DiagSpec, String> {
    let mut track = serde_path_to_error::Track::new();
    let pd = serde_path_to_error::Deserializer::new(de, &mut track);
    DiagSpec::deserialize(pd).map_err(|e| {
        let path = track.path().to_string();
        if path.is_empty() || path == "." {
            e.to_string()
        } else {
            format!("field `{path}`: {e}")
        }
    })
}

/// Load one record: read the columns, cut the row range, decimate by block means.
pub fn load_record(r: &RecordSpec, data: &DataSpec, base: &Path) -> Result<Record, DiagError> {
    let file = if r.file.is_absolute() {
        r.file.clone()
    } else {
        base.join(&r.file)
    };
    let (u, y) = smid_core::data::read_columns(&file, &data.u, &data.y, None)?;
    let (s, e) = match r.rows {
        Some([s, e]) => (s, e.min(u.len())),
        None => (0, u.len()),
    };
    if s >= e {
        return Err(DiagError::Data {
            file,
            message: format!(
                "row range [{s}, {e}) is empty (the file has {} rows)",
                u.len()
            ),
        });
    }
    let d = data.decimate;
    let dec = |x: &[f64]| -> Vec<f64> {
        x[s..e]
            .chunks_exact(d)
            .map(|c| c.iter().sum::<f64>() / d as f64)
            .collect()
    };
    let (u, y) = (dec(&u), dec(&y));
    if u.len() < 10 {
        return Err(DiagError::Data {
            file,
            message: format!("only {} samples after decimation by {d}", u.len()),
        });
    }
    Ok(Record {
        name: match r.rows {
            Some([s, e]) => format!("{}[{s}..{e}]", r.file.display()),
            None => r.file.display().to_string(),
        },
        u,
        y,
        dt: data.dt * d as f64,
    })
}

/// Load a list of records.
pub fn load_records(
    rs: &[RecordSpec],
    data: &DataSpec,
    base: &Path,
) -> Result<Vec<Record>, DiagError> {
    rs.iter().map(|r| load_record(r, data, base)).collect()
}

/// The last `frac` of each record as held-out records, the rest as training records.
pub fn split_tail(recs: &[Record], frac: f64) -> (Vec<Record>, Vec<Record>) {
    let mut train = Vec::new();
    let mut hold = Vec::new();
    for r in recs {
        let k = ((r.y.len() as f64) * (1.0 - frac)).round() as usize;
        let cut = |a: usize, b: usize, tag: &str| Record {
            name: format!("{} ({tag})", r.name),
            u: r.u[a..b].to_vec(),
            y: r.y[a..b].to_vec(),
            dt: r.dt,
        };
        train.push(cut(0, k, "head"));
        hold.push(cut(k, r.y.len(), "tail"));
    }
    (train, hold)
}
