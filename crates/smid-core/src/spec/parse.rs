//! Reading a spec: the YAML parsed into a [`Spec`] and checked, every error located at its
//! file, line and field.
use super::Spec;
use crate::error::{Result, SmidError};
use std::path::Path;

/// 1-based line of `key` (a dotted path such as `model.prior.m_l`) in `text`: its last
/// component at or after the lines of its parents, each found in turn (a best effort when the
/// parser gave none; a parent not found is passed over).
fn line_of(text: &str, key: &str) -> Option<usize> {
    let parts: Vec<&str> = key
        .trim_start_matches('.')
        .split('.')
        .filter_map(|p| p.split('[').next())
        .filter(|p| !p.is_empty())
        .collect();
    let (last, parents) = parts.split_last()?;
    let lines: Vec<&str> = text.lines().collect();
    let has = |l: &str, k: &str| {
        let t = l.trim_start().trim_start_matches("- ");
        t.starts_with(&format!("{k}:"))
            || t.contains(&format!(" {k}:"))
            || t.contains(&format!("{{{k}:"))
    };
    let mut from = 0;
    for p in parents {
        if let Some(i) = lines[from..].iter().position(|l| has(l, p)) {
            from += i;
        }
    }
    lines[from..]
        .iter()
        .position(|l| has(l, last))
        .map(|i| from + i + 1)
        .or_else(|| lines.iter().position(|l| has(l, last)).map(|i| i + 1))
}

impl Spec {
    /// Parse a spec from text; `file` names it in errors.
    pub fn parse(text: &str, file: &Path) -> Result<Spec> {
        let de = serde_norway::Deserializer::from_str(text);
        let spec: Spec = serde_path_to_error::deserialize(de).map_err(|e| {
            // serde_path_to_error writes the root as `.` and an unknown place as `?`.
            let field = match e.path().to_string().as_str() {
                "." => "(top level)".to_string(),
                "?" => "(YAML syntax)".to_string(),
                p => p.to_string(),
            };
            let inner = e.into_inner();
            let line = inner
                .location()
                .map(|l| l.line())
                .or_else(|| line_of(text, &field));
            SmidError::Spec {
                file: file.to_path_buf(),
                line,
                field,
                message: inner.to_string(),
            }
        })?;
        spec.validate().map_err(|e| match e {
            SmidError::Invalid { field, message } => SmidError::Spec {
                file: file.to_path_buf(),
                line: line_of(text, &field),
                field,
                message,
            },
            other => other,
        })?;
        Ok(spec)
    }

    /// Read and parse a spec file.
    pub fn from_file(path: &Path) -> Result<Spec> {
        let text = std::fs::read_to_string(path).map_err(|source| SmidError::Io {
            path: path.to_path_buf(),
            source,
        })?;
        Spec::parse(&text, path)
    }
}

#[cfg(test)]
mod tests {
    use super::line_of;
    #[test]
    fn line_of_finds_nested_keys() {
        let t = "a:\n  b: 1\n  fixed: {b0: 0}\n";
        assert_eq!(line_of(t, "a.b"), Some(2));
        assert_eq!(line_of(t, "model.fixed.b0"), Some(3));
        // A key that also names a field earlier in the file is found under its parents.
        let t = "plant:\n  nl: { m_l: 0.2 }\nmodel:\n  prior: { m_l: [1, 0] }\n";
        assert_eq!(line_of(t, "model.prior.m_l"), Some(4));
        assert_eq!(line_of(t, "plant.nl.m_l"), Some(2));
    }
}
