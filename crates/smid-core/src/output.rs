//! The JSON files smid writes (`result.json` of `smid run`, `validation.json` of
//! `smid validate`, `diagnosis.json` of `smid diagnose`) and their format stamp.
//!
//! Each file starts with two fields: `format`, the kind of file (`"smid.result"`,
//! `"smid.validation"`, `"smid.diagnosis"`), and `format_version`, a whole number raised
//! whenever a change to the file's layout would make a file written before it read differently.
//! Every reader calls [`check`] (or [`read`]) first: `smid::closeloop::source_from_json`
//! (`smid validate` and `smid diagnose` of a `result.json`, and through the native module every
//! function of the Python package that takes a model set). A file of another kind, of a version
//! this smid does not know, or without the stamp is refused with [`SmidError::Format`], naming
//! the file, the field, what it holds and the versions this smid reads, instead of being
//! misread. When a layout changes, raise [`OutputKind::version`]; keep the old version in
//! [`OutputKind::known`] only if the readers still read it correctly. The fields of each file
//! are documented in `docs/reference/outputs.md` (checked by `tests/output_reference.rs`).
use crate::error::{Result, SmidError};
use serde::Serialize;
use std::path::Path;

/// The field naming the kind of file.
pub const FORMAT_FIELD: &str = "format";
/// The field holding the layout's version.
pub const VERSION_FIELD: &str = "format_version";

/// One kind of JSON file smid writes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum OutputKind {
    /// `result.json` of `smid run`: the model set, its spec and the bounds.
    Result,
    /// `validation.json` of `smid validate` (and `after_validation.json` of `smid diagnose`).
    Validation,
    /// `diagnosis.json` of `smid diagnose`.
    Diagnosis,
}

impl OutputKind {
    /// The value of the `format` field.
    pub fn tag(self) -> &'static str {
        match self {
            OutputKind::Result => "smid.result",
            OutputKind::Validation => "smid.validation",
            OutputKind::Diagnosis => "smid.diagnosis",
        }
    }

    /// The `format_version` this smid writes.
    pub fn version(self) -> u64 {
        match self {
            OutputKind::Result => 1,
            OutputKind::Validation => 1,
            OutputKind::Diagnosis => 1,
        }
    }

    /// The `format_version`s this smid reads.
    pub fn known(self) -> &'static [u64] {
        match self {
            OutputKind::Result => &[1],
            OutputKind::Validation => &[1],
            OutputKind::Diagnosis => &[1],
        }
    }

    /// The command that writes this kind of file.
    pub fn writer(self) -> &'static str {
        match self {
            OutputKind::Result => "smid run",
            OutputKind::Validation => "smid validate",
            OutputKind::Diagnosis => "smid diagnose",
        }
    }

    /// `content` (an object) with the stamp in front: `format`, `format_version` and
    /// `smid_version` (the version of smid that wrote it).
    pub fn stamp<T: Serialize>(self, content: &T) -> Stamped<'_, T> {
        Stamped {
            format: self.tag(),
            format_version: self.version(),
            smid_version: env!("CARGO_PKG_VERSION"),
            content,
        }
    }
}

/// An output's content with its stamp first (see [`OutputKind::stamp`]); it serialises as
/// one object.
#[derive(Debug, Serialize)]
pub struct Stamped<'a, T: Serialize> {
    /// [`OutputKind::tag`].
    pub format: &'static str,
    /// [`OutputKind::version`].
    pub format_version: u64,
    /// The version of smid that wrote the file.
    pub smid_version: &'static str,
    /// The file's fields.
    #[serde(flatten)]
    pub content: &'a T,
}

/// The version of the file `v` if it is a `kind` file of a version this smid reads; otherwise
/// [`SmidError::Format`] naming `file` and the field at fault.
pub fn check(kind: OutputKind, v: &serde_json::Value, file: &Path) -> Result<u64> {
    let refuse = |field: &str, found: Option<&serde_json::Value>| SmidError::Format {
        file: file.to_path_buf(),
        field: field.into(),
        found: found.map(|f| f.to_string()),
        format: kind.tag().into(),
        known: kind.known().to_vec(),
        writer: kind.writer().into(),
        written_by: v
            .get("smid_version")
            .and_then(|s| s.as_str())
            .map(str::to_string),
    };
    let tag = v.get(FORMAT_FIELD);
    if tag.and_then(|t| t.as_str()) != Some(kind.tag()) {
        return Err(refuse(FORMAT_FIELD, tag));
    }
    let version = v.get(VERSION_FIELD);
    match version.and_then(|n| n.as_u64()) {
        Some(n) if kind.known().contains(&n) => Ok(n),
        _ => Err(refuse(VERSION_FIELD, version)),
    }
}

/// Read the `kind` file at `path` as JSON and [`check`] its stamp.
pub fn read(kind: OutputKind, path: &Path) -> Result<serde_json::Value> {
    let text = std::fs::read_to_string(path).map_err(|source| SmidError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    parse(kind, &text, path)
}

/// [`read`] of a file's text (`file` names it in errors).
pub fn parse(kind: OutputKind, text: &str, file: &Path) -> Result<serde_json::Value> {
    let v: serde_json::Value = serde_json::from_str(text).map_err(|e| SmidError::Data {
        file: file.to_path_buf(),
        location: format!("line {}, column {}", e.line(), e.column()),
        message: format!("not JSON: {e}"),
    })?;
    check(kind, &v, file)?;
    Ok(v)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_stamped_object_reads_back_and_others_are_refused_by_field() {
        let body = serde_json::json!({"x": 1});
        let v = serde_json::to_value(OutputKind::Validation.stamp(&body)).unwrap();
        assert_eq!(v["x"], 1);
        let file = Path::new("dir/validation.json");
        assert_eq!(check(OutputKind::Validation, &v, file).unwrap(), 1);
        let e = check(OutputKind::Result, &v, file).unwrap_err().to_string();
        assert!(
            e.contains("dir/validation.json")
                && e.contains("field `format`")
                && e.contains("\"smid.validation\"")
                && e.contains("`smid.result`"),
            "{e}"
        );
        let mut w = v.clone();
        w[VERSION_FIELD] = serde_json::json!(999);
        let e = check(OutputKind::Validation, &w, file)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("field `format_version`") && e.contains("found 999"),
            "{e}"
        );
        w.as_object_mut().unwrap().remove(VERSION_FIELD);
        let e = check(OutputKind::Validation, &w, file)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("field `format_version`: missing") && e.contains("format_version 1"),
            "{e}"
        );
    }
}
