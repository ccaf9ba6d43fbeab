//! The reference of the output files, `docs/reference/outputs.md`, against the files the CLI
//! writes: `smid run` on the paper's example and on an identification from any record,
//! `smid validate` of the first on a fresh record (consistent) and on a record with a sensor
//! lag (falsified), `smid diagnose` of the paper's plant with an undeclared sensor offset. Every key path of each JSON file (array elements written `[]`) must be
//! documented, and every documented path must occur in the files written (unless its row says
//! `optional`). Each file carries its format stamp and reads back; a `result.json` of an
//! unknown `format_version`, or without one, is refused by the CLI naming the file and the
//! field.
//!
//! How the test reads the markdown (stated at the top of outputs.md too): a `## ` heading that
//! names a file in backticks (`` `result.json` ``) starts that file's section, up to the next
//! `## ` heading. In it, each table row whose first cell starts with a path in backticks
//! documents that path. `{a,b}` in a path stands for each alternative, a path ending in `.*`
//! covers itself and everything below it, and the word `optional` in the first cell exempts
//! the row from having to occur in the files this test writes.
use smid::core::output::{self, OutputKind};
use std::collections::{BTreeMap, BTreeSet};
use std::path::PathBuf;
use std::process::Command;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn smid(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_smid"))
        .args(args)
        .current_dir(root())
        .output()
        .expect("the smid binary runs")
}

fn ok(args: &[&str]) {
    let o = smid(args);
    assert!(
        o.status.success(),
        "smid {}: {}",
        args.join(" "),
        String::from_utf8_lossy(&o.stderr)
    );
}

/// Every key path of `v`: object keys joined by `.`, array elements written `[]`.
fn key_paths(v: &serde_json::Value, prefix: &str, out: &mut BTreeSet<String>) {
    match v {
        serde_json::Value::Object(m) => {
            for (k, x) in m {
                let p = if prefix.is_empty() {
                    k.clone()
                } else {
                    format!("{prefix}.{k}")
                };
                out.insert(p.clone());
                key_paths(x, &p, out);
            }
        }
        serde_json::Value::Array(a) => {
            for x in a {
                key_paths(x, &format!("{prefix}[]"), out);
            }
        }
        _ => {}
    }
}

/// `a.{b,c}.d` → `a.b.d`, `a.c.d` (any number of groups, not nested).
fn expand(path: &str) -> Vec<String> {
    match (path.find('{'), path.find('}')) {
        (Some(i), Some(j)) if i < j => path[i + 1..j]
            .split(',')
            .flat_map(|alt| expand(&format!("{}{}{}", &path[..i], alt.trim(), &path[j + 1..])))
            .collect(),
        _ => vec![path.to_string()],
    }
}

/// One documented path of a table row.
#[derive(Debug)]
struct Row {
    /// The path, braces expanded; a trailing `.*` removed (see `wildcard`).
    path: String,
    /// The row covers the path and everything below it.
    wildcard: bool,
    /// The path need not occur in the files this test writes.
    optional: bool,
    /// The row's first cell, for messages.
    cell: String,
}

impl Row {
    fn covers(&self, p: &str) -> bool {
        p == self.path
            || (self.wildcard
                && p.strip_prefix(self.path.as_str())
                    .is_some_and(|rest| rest.starts_with('.') || rest.starts_with('[')))
    }
}

/// The documented rows of each file's section of outputs.md, by file name.
fn documented(markdown: &str) -> BTreeMap<String, Vec<Row>> {
    let mut out: BTreeMap<String, Vec<Row>> = BTreeMap::new();
    let mut file: Option<String> = None;
    for line in markdown.lines() {
        if let Some(h) = line.strip_prefix("## ") {
            file = h
                .split('`')
                .nth(1)
                .filter(|f| f.ends_with(".json"))
                .map(str::to_string);
            continue;
        }
        let (Some(f), Some(row)) = (&file, line.trim().strip_prefix('|')) else {
            continue;
        };
        let cell = row.split('|').next().unwrap_or("").trim();
        let Some(rest) = cell.strip_prefix('`') else {
            continue;
        };
        let Some(end) = rest.find('`') else { continue };
        let optional = cell.contains("optional");
        for p in expand(&rest[..end]) {
            let (path, wildcard) = match p.strip_suffix(".*") {
                Some(q) => (q.to_string(), true),
                None => (p, false),
            };
            out.entry(f.clone()).or_default().push(Row {
                path,
                wildcard,
                optional,
                cell: cell.to_string(),
            });
        }
    }
    out
}

#[test]
fn every_output_field_is_documented_and_every_documented_field_exists() {
    let dir = tempfile::tempdir().unwrap();
    let d = |s: &str| dir.path().join(s).display().to_string();
    ok(&["run", "examples/paper.yaml", "--out", &d("run")]);
    ok(&["run", "examples/example-gain-any.yaml", "--out", &d("any")]);
    ok(&["validate", &d("run/result.json"), "--out", &d("validate")]);
    // A record of the plant read through a sensor lag the model lacks: FALSIFIED (exit 3).
    ok(&[
        "simulate",
        "examples/diagnose/paper-lag.yaml",
        "--out",
        &d("lag"),
    ]);
    let o = smid(&[
        "validate",
        &d("run/result.json"),
        "--data",
        &d("lag/dynamic.csv"),
        "--out",
        &d("falsified"),
    ]);
    assert_eq!(
        o.status.code(),
        Some(3),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    ok(&[
        "diagnose",
        "examples/diagnose/paper-offset.yaml",
        "--out",
        &d("diagnose"),
    ]);
    let files: [(&str, OutputKind, Vec<PathBuf>); 3] = [
        (
            "result.json",
            OutputKind::Result,
            vec![
                dir.path().join("run/result.json"),
                dir.path().join("any/result.json"),
            ],
        ),
        (
            "validation.json",
            OutputKind::Validation,
            vec![
                dir.path().join("validate/validation.json"),
                dir.path().join("falsified/validation.json"),
                dir.path().join("diagnose/after_validation.json"),
            ],
        ),
        (
            "diagnosis.json",
            OutputKind::Diagnosis,
            vec![dir.path().join("diagnose/diagnosis.json")],
        ),
    ];
    let doc_path = root().join("docs/reference/outputs.md");
    let doc = documented(&std::fs::read_to_string(&doc_path).unwrap());
    let mut problems = Vec::new();
    for (name, kind, paths) in &files {
        let rows = doc.get(*name).map(Vec::as_slice).unwrap_or(&[]);
        if rows.is_empty() {
            problems.push(format!(
                "{name}: no `## ` section naming `{name}` with a table"
            ));
            continue;
        }
        let mut written = BTreeSet::new();
        for p in paths {
            // A file freshly written carries its stamp and reads back.
            let v = output::read(*kind, p).unwrap_or_else(|e| panic!("{e}"));
            assert_eq!(v[output::FORMAT_FIELD], kind.tag());
            assert_eq!(v[output::VERSION_FIELD], kind.version());
            key_paths(&v, "", &mut written);
        }
        for p in &written {
            if !rows.iter().any(|r| r.covers(p)) {
                problems.push(format!("{name}: `{p}` is written but not documented"));
            }
        }
        for r in rows.iter().filter(|r| !r.optional) {
            if !written.iter().any(|p| r.covers(p)) {
                problems.push(format!(
                    "{name}: `{}` (row {}) is documented but not written; mark the row `optional` if it is written only sometimes",
                    r.path, r.cell
                ));
            }
        }
    }
    assert!(
        problems.is_empty(),
        "{} does not match the files the CLI writes:\n{}",
        doc_path.display(),
        problems.join("\n")
    );
}

#[test]
fn a_result_of_an_unknown_or_missing_format_version_is_refused_by_name() {
    let dir = tempfile::tempdir().unwrap();
    let run = dir.path().join("run");
    ok(&["run", "examples/paper.yaml", "--out", run.to_str().unwrap()]);
    let fresh = run.join("result.json");
    let text = std::fs::read_to_string(&fresh).unwrap();
    let v: serde_json::Value = serde_json::from_str(&text).unwrap();
    // What `smid run` wrote, `smid validate` reads.
    ok(&[
        "validate",
        fresh.to_str().unwrap(),
        "--out",
        dir.path().join("validate").to_str().unwrap(),
    ]);
    let known = OutputKind::Result.version();
    let cases: [(&str, Option<serde_json::Value>, &str); 2] = [
        ("v999.json", Some(serde_json::json!(999)), "found 999"),
        ("unversioned.json", None, "missing"),
    ];
    for (file, version, found) in cases {
        let mut w = v.clone();
        match version {
            Some(n) => w[output::VERSION_FIELD] = n,
            None => {
                w.as_object_mut().unwrap().remove(output::VERSION_FIELD);
            }
        }
        let path = dir.path().join(file);
        std::fs::write(&path, w.to_string()).unwrap();
        let e = output::read(OutputKind::Result, &path).unwrap_err();
        assert!(
            matches!(&e, smid::SmidError::Format { field, known: k, .. } if field == "format_version" && k == &[known]),
            "{e:?}"
        );
        for command in ["validate", "diagnose"] {
            let o = smid(&[
                command,
                path.to_str().unwrap(),
                "--out",
                dir.path().join("refused").to_str().unwrap(),
            ]);
            let stderr = String::from_utf8_lossy(&o.stderr);
            assert_eq!(o.status.code(), Some(1), "smid {command}: {stderr}");
            let expected = format!(
                "{}: field `format_version`: {found}; this smid reads `smid.result` files of format_version {known}",
                path.display()
            );
            assert!(stderr.contains(&expected), "smid {command}: {stderr}");
        }
    }
    assert!(
        !dir.path().join("refused").exists(),
        "a refused file wrote nothing"
    );
}

#[test]
fn braces_expand_and_wildcards_cover_what_is_below() {
    assert_eq!(
        expand("a.{b,c[]}.{d,e}"),
        ["a.b.d", "a.b.e", "a.c[].d", "a.c[].e"]
    );
    let doc = documented(
        "## `x.json`\n| Field | Type |\n|---|---|\n| `s.*` | object |\n| `t` (optional) | n |\n## Other\n| `u` | n |\n",
    );
    let rows = &doc["x.json"];
    assert_eq!(rows.len(), 2);
    assert!(rows[0].covers("s") && rows[0].covers("s.a.b") && rows[0].covers("s[].a"));
    assert!(!rows[0].covers("sa"));
    assert!(rows[1].optional && rows[1].covers("t") && !rows[1].covers("t.a"));
    assert!(!doc.contains_key("Other"));
}
