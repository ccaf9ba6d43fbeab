//! Fresh records read from one CSV file that holds several of the spec's records (a column
//! pair each), with the rows before a held-out range as input history
//! (`plant.data.initial: input_history`): one fresh record per record of the spec, the figures
//! over the held-out rows alone, the state set by the input from rest, the tests blind to the
//! history's outputs; and errors that name the file and what was expected.
use rand::{Rng, SeedableRng};
use smid::closeloop;
use smid::core::outcome::Outcome;
use smid::core::spec::Spec;
use smid::core::validate;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

const ROWS: usize = 300;

/// A CSV with two experiments on the plant `y_t = 0.8 y_{t-1} + 0.5 u_{t-1}` (from rest,
/// uniform noise within 1e-3): columns `t, u1, y1, u2, y2`; `outlier` adds 1 to `y1` at a row.
fn write_csv(dir: &Path, outlier: Option<usize>) -> PathBuf {
    let mut rng = rand::rngs::StdRng::seed_from_u64(7);
    let mut cols: Vec<(Vec<f64>, Vec<f64>)> = Vec::new();
    for _ in 0..2 {
        let mut u = vec![0.0; ROWS];
        let mut level = 0.0;
        for (t, v) in u.iter_mut().enumerate() {
            if t % 5 == 0 {
                level = rng.gen_range(-1.0..1.0);
            }
            *v = level;
        }
        let mut w = vec![0.0; ROWS];
        for t in 1..ROWS {
            w[t] = 0.8 * w[t - 1] + 0.5 * u[t - 1];
        }
        let y: Vec<f64> = w.iter().map(|v| v + rng.gen_range(-1e-3..1e-3)).collect();
        cols.push((u, y));
    }
    if let Some(r) = outlier {
        cols[0].1[r] += 1.0;
    }
    let mut s = String::from("t,u1,y1,u2,y2\n");
    for t in 0..ROWS {
        let _ = writeln!(
            s,
            "{t},{},{},{},{}",
            cols[0].0[t], cols[0].1[t], cols[1].0[t], cols[1].1[t]
        );
    }
    let path = dir.join(format!("two-{}.csv", outlier.unwrap_or(0)));
    std::fs::write(&path, s).unwrap();
    path
}

fn spec_text(csv: &Path, initial: &str) -> String {
    format!(
        "plant:
  data:
    dynamic:
      - {{ file: {f}, u: u1, y: y1, rows: [0, 200] }}
      - {{ file: {f}, u: u2, y: y2, rows: [0, 200] }}
    initial: {initial}
noise: {{ delta: 1.0e-3 }}
model: {{ structure: wiener, nonlinearity: {{ type: linear }}, na: 1, nb: 0, nk: 1, unit_gain: false }}
method: {{ member: {{ search: false }} }}
",
        f = csv.display()
    )
}

fn identified(text: &str) -> (Spec, smid::core::model::ModelSet) {
    let spec = Spec::parse(text, Path::new("history.yaml")).unwrap();
    match smid::core::pipeline::run(&spec, Path::new("/")).unwrap() {
        Outcome::Consistent(id) => (spec, id.model),
        Outcome::Falsified(f) => panic!("the plant's own data falsified: {f:?}"),
    }
}

fn at(csv: &Path, range: &str) -> PathBuf {
    PathBuf::from(format!("{}@{range}", csv.display()))
}

/// The fresh records of `arg` (a CSV path, with or without rows) under `spec`.
fn fresh(spec: &Spec, arg: PathBuf) -> Vec<smid::core::model::Record> {
    closeloop::fresh_records(spec, Path::new("/"), &[arg], 0, 0, 1).unwrap()
}

#[test]
fn an_input_history_sets_the_state_and_only_the_held_out_rows_count() {
    smid::link_plugins();
    let dir = tempfile::tempdir().unwrap();
    let csv = write_csv(dir.path(), None);
    let (spec, model) = identified(&spec_text(&csv, "input_history"));
    let records = fresh(&spec, at(&csv, "200..300"));
    assert_eq!(records.len(), 2, "one fresh record per column pair");
    assert!(records[0].name.contains("u1 -> y1") && records[1].name.contains("u2 -> y2"));
    for r in &records {
        assert_eq!((r.y.len(), r.history), (300, Some(200)), "{}", r.name);
    }
    let v = validate::validate(&model, &records, &validate::Options::default()).unwrap();
    assert_eq!(v.per_record.len(), 2);
    for (name, fit) in &v.per_record {
        assert_eq!(fit.samples, 100, "{name}: the held-out rows alone");
        assert!(fit.fit_percent > 95.0, "{name}: {fit:?}");
    }
    // The band, like the other tests, starts after the history (and its own first sample).
    assert_eq!(v.band.as_ref().map(|b| b.samples), Some(2 * 98));

    // The whole file from rest: every row counts.
    let whole = fresh(&spec, csv.clone());
    assert!(whole
        .iter()
        .all(|r| r.y.len() == ROWS && r.history == Some(0)));
    let v = validate::validate(&model, &whole, &validate::Options::default()).unwrap();
    assert!(v.per_record.iter().all(|(_, f)| f.samples == ROWS));

    // Read as measured, the same range gives 100 rows, the first `na + nb + nk` setting the
    // state.
    let (spec_m, _) = identified(&spec_text(&csv, "measured"));
    let plain = fresh(&spec_m, at(&csv, "200..300"));
    assert!(plain
        .iter()
        .all(|r| r.y.len() == 100 && r.history.is_none()));
    let v = validate::validate(&model, &plain, &validate::Options::default()).unwrap();
    assert!(v.per_record.iter().all(|(_, f)| f.samples == 98));
}

#[test]
fn the_tests_read_no_output_of_the_history() {
    smid::link_plugins();
    let dir = tempfile::tempdir().unwrap();
    let clean = write_csv(dir.path(), None);
    let (_, model) = identified(&spec_text(&clean, "input_history"));
    let validated = |row: usize| {
        let csv = write_csv(dir.path(), Some(row));
        let spec = Spec::parse(&spec_text(&csv, "input_history"), Path::new("h.yaml")).unwrap();
        validate::validate(
            &model,
            &fresh(&spec, at(&csv, "200..300")),
            &validate::Options::default(),
        )
        .unwrap()
    };
    let before = validated(120);
    assert_ne!(
        before.consistency.verdict,
        validate::Verdict::Falsified,
        "an outlier in the history"
    );
    // The band is a test like the others: none over the history, finite after it.
    let (lo, hi) = before.series[0].band.clone().expect("a band");
    assert!(lo[..200].iter().chain(&hi[..200]).all(|v| v.is_infinite()));
    assert!(lo[202..]
        .iter()
        .zip(&hi[202..])
        .all(|(l, h)| l.is_finite() && h.is_finite()));
    assert_eq!(
        validated(250).consistency.verdict,
        validate::Verdict::Falsified,
        "an outlier in the held-out rows"
    );
}

#[test]
fn a_file_without_the_columns_or_a_misaligned_start_is_named() {
    smid::link_plugins();
    let dir = tempfile::tempdir().unwrap();
    let csv = write_csv(dir.path(), None);
    let spec = Spec::parse(&spec_text(&csv, "input_history"), Path::new("h.yaml")).unwrap();
    let other = dir.path().join("other.csv");
    std::fs::write(&other, "t,a,b\n0,1,2\n1,1,2\n").unwrap();
    let e = closeloop::fresh_records(&spec, Path::new("/"), &[other], 0, 0, 1).unwrap_err();
    let m = e.to_string();
    assert!(
        m.contains("other.csv") && m.contains("`u1` and `y1`"),
        "{m}"
    );

    let decimated = spec_text(&csv, "input_history")
        .replace("rows: [0, 200] }", "rows: [0, 200], decimate: 4 }");
    let spec = Spec::parse(&decimated, Path::new("h.yaml")).unwrap();
    let e = closeloop::fresh_records(&spec, Path::new("/"), &[at(&csv, "202..298")], 0, 0, 1)
        .unwrap_err();
    assert!(e.to_string().contains("multiple of `decimate`"), "{e}");
}
