//! Fuzzing of user input by a proptest campaign (CI runs it briefly; `PROPTEST_CASES` sets the
//! number of cases, 96 by default): random and mutated YAML specs and CSV files, as text and as
//! bytes. Every input must end in a result or an error, never a panic and never a hang: a
//! parsed spec small enough to run is run through the whole pipeline on a worker thread
//! watched for termination (a generous limit: this finds loops that user input can stretch,
//! it measures no speed). `fuzz/` holds the cargo-fuzz targets for longer campaigns (nightly).
use proptest::prelude::*;
use smid_core::spec::Spec;
use std::io::Write;
use std::path::Path;
use std::sync::mpsc;
use std::time::Duration;

fn cases(default: u32) -> ProptestConfig {
    ProptestConfig::with_cases(
        std::env::var("PROPTEST_CASES")
            .ok()
            .and_then(|v| v.parse().ok())
            .unwrap_or(default),
    )
}

/// The simulator examples the mutations start from.
const SEEDS: [&str; 5] = [
    include_str!("../examples/paper.yaml"),
    include_str!("../examples/input-backlash.yaml"),
    include_str!("../examples/dead-zone-output.yaml"),
    include_str!("../examples/saturation.yaml"),
    include_str!("../examples/example-gain.yaml"),
];

/// Values that stretch loops, overflow sizes or break arithmetic.
const EXTREMES: [&str; 22] = [
    "0",
    "-1",
    "1",
    "2",
    "1.0e-300",
    "1.0e300",
    ".nan",
    ".inf",
    "-.inf",
    "1.0e-12",
    "1.0e-13",
    "0.9999999999999999",
    "0.99999",
    "1.0",
    "4294967296",
    "18446744073709551615",
    "-18446744073709551616",
    "9",
    "1000000",
    "[]",
    "{}",
    "\"x\"",
];

/// Fields with an extreme value, inserted into a section of the spec.
const INSERTS: [(&str, &str); 14] = [
    ("experiment:", "  filter: { a_bar: 1.0, tol: 1.0e-300 }"),
    ("experiment:", "  filter: { pole: 0.9999999999999999 }"),
    ("experiment:", "  filter: { settle: 18446744073709551615 }"),
    (
        "experiment:",
        "  steady_state: { amplitudes: 3, half_period: 4611686018427387904 }",
    ),
    ("experiment:", "  dynamic: { length: 18446744073709551615 }"),
    (
        "experiment:",
        "  dynamic: { length: 50, hold: 0, levels: 0 }",
    ),
    ("method:", "  cells: { depth: 4294967295, max_cells: 0 }"),
    (
        "method:",
        "  cells: { depth: 60, max_cells: 18446744073709551615 }",
    ),
    (
        "method:",
        "  member: { iterations: 0, restarts: 1000, probe: 0 }",
    ),
    (
        "method:",
        "  member: { iterations: 18446744073709551615, cells: 18446744073709551615 }",
    ),
    ("method:", "  eiv: shared"),
    ("method:", "  eiv: exact-grid"),
    ("model:", "  prior: { a1: [1.0e300, -1.0e300] }"),
    ("model:", "  fixed: { a1: .nan }"),
];

/// One edit of a spec's text.
#[derive(Debug, Clone)]
enum Edit {
    /// Replace the `k`-th number by an extreme value.
    Number(usize, usize),
    /// Delete line `k`.
    Delete(usize),
    /// Duplicate line `k`.
    Duplicate(usize),
    /// Overwrite byte `k` with `b`.
    Byte(usize, u8),
    /// Insert one of `INSERTS` under its section.
    Insert(usize),
}

fn edit() -> impl Strategy<Value = Edit> {
    prop_oneof![
        4 => (any::<usize>(), 0..EXTREMES.len()).prop_map(|(k, v)| Edit::Number(k, v)),
        1 => any::<usize>().prop_map(Edit::Delete),
        1 => any::<usize>().prop_map(Edit::Duplicate),
        1 => (any::<usize>(), any::<u8>()).prop_map(|(k, b)| Edit::Byte(k, b)),
        3 => (0..INSERTS.len()).prop_map(Edit::Insert),
    ]
}

fn apply(text: &str, e: &Edit) -> String {
    match *e {
        Edit::Number(k, v) => {
            // Byte ranges of the numeric literals (digits, sign, point, exponent).
            let b = text.as_bytes();
            let mut spans = Vec::new();
            let mut i = 0;
            while i < b.len() {
                if b[i].is_ascii_digit() && (i == 0 || !b[i - 1].is_ascii_alphabetic()) {
                    let s = if i > 0 && b[i - 1] == b'-' { i - 1 } else { i };
                    let mut j = i;
                    while j < b.len()
                        && (b[j].is_ascii_digit() || matches!(b[j], b'.' | b'e' | b'E' | b'-'))
                    {
                        j += 1;
                    }
                    spans.push((s, j));
                    i = j;
                } else {
                    i += 1;
                }
            }
            match spans.get(k % spans.len().max(1)) {
                Some(&(s, j)) => format!("{}{}{}", &text[..s], EXTREMES[v], &text[j..]),
                None => text.to_string(),
            }
        }
        Edit::Delete(k) | Edit::Duplicate(k) => {
            let mut lines: Vec<&str> = text.lines().collect();
            let k = k % lines.len().max(1);
            if matches!(e, Edit::Delete(_)) {
                lines.remove(k);
            } else {
                lines.insert(k, lines[k]);
            }
            lines.join("\n") + "\n"
        }
        Edit::Byte(k, b) => {
            let mut bytes = text.as_bytes().to_vec();
            let k = k % bytes.len().max(1);
            bytes[k] = b;
            String::from_utf8_lossy(&bytes).into_owned()
        }
        Edit::Insert(i) => {
            let (section, line) = INSERTS[i];
            match text.find(&format!("\n{section}")) {
                Some(p) => {
                    let at = p + 1 + section.len();
                    format!("{}\n{}{}", &text[..at], line, &text[at..])
                }
                None => format!("{text}{section}\n{line}\n"),
            }
        }
    }
}

/// Whether a parsed spec is small enough to run in a test (the validated caps allow long
/// runs; those are bounded, just not for a test).
fn cheap(spec: &Spec) -> bool {
    let e = &spec.experiment;
    e.dynamic.length <= 3000
        && e.steady_state.amplitudes <= 200
        && e.steady_state.half_period.unwrap_or(0) <= 5000
        && e.filter.settle <= 5000
        && e.filter.pole.is_none_or(|p| p <= 0.999)
        && spec.method.cells.max_cells <= 5000
        && spec
            .method
            .member
            .iterations
            .saturating_mul(spec.method.member.restarts as u64)
            <= 5000
        && spec.method.member.probe <= 1000
        && (spec.model.na + spec.model.nb) <= 8
}

/// Run `f` on a worker thread; a panic fails the test with its message, and so does a run that
/// has not ended after `limit` (a hang, not a slow run: the cheapest spec runs in well under a
/// second).
fn terminates<T: Send + 'static>(
    what: &str,
    limit: Duration,
    f: impl FnOnce() -> T + Send + 'static,
) {
    let (tx, rx) = mpsc::channel();
    let h = std::thread::spawn(move || {
        let r = std::panic::catch_unwind(std::panic::AssertUnwindSafe(f));
        let _ = tx.send(r.is_ok());
    });
    match rx.recv_timeout(limit) {
        Ok(true) => {
            let _ = h.join();
        }
        Ok(false) => panic!("{what}: panicked"),
        Err(_) => panic!("{what}: did not end within {limit:?}"),
    }
}

fn parse_and_run(text: String, base: std::path::PathBuf) {
    smid::link_plugins();
    let spec = match std::panic::catch_unwind(|| Spec::parse(&text, Path::new("fuzz.yaml"))) {
        Ok(Ok(s)) => s,
        Ok(Err(_)) => return,
        Err(_) => panic!("Spec::parse panicked on:\n{text}"),
    };
    if !cheap(&spec) {
        return;
    }
    terminates(
        &format!("smid run on\n{text}"),
        Duration::from_secs(300),
        move || {
            let _ = smid::run_spec(&spec, &base, &|_| {});
        },
    );
}

proptest! {
    #![proptest_config(cases(96))]

    /// Mutated example specs: parse, and run the cheap ones end to end.
    #[test]
    fn mutated_specs_end_in_a_result_or_an_error(
        seed in 0..SEEDS.len(),
        edits in prop::collection::vec(edit(), 1..4),
    ) {
        let mut text = SEEDS[seed].to_string();
        for e in &edits {
            text = apply(&text, e);
        }
        parse_and_run(text, std::env::temp_dir());
    }

    /// Arbitrary text (and arbitrary bytes read as text) as a spec.
    #[test]
    fn arbitrary_text_is_an_error_not_a_panic(bytes in prop::collection::vec(any::<u8>(), 0..400)) {
        let text = String::from_utf8_lossy(&bytes).into_owned();
        parse_and_run(text, std::env::temp_dir());
    }

    /// CSV files as bytes (mutated valid files and random bytes) read by the data loader and
    /// run through a measured-data spec.
    #[test]
    fn csv_bytes_end_in_a_result_or_an_error(
        mutate in any::<bool>(),
        bytes in prop::collection::vec(any::<u8>(), 0..300),
        flips in prop::collection::vec((any::<usize>(), any::<u8>()), 0..6),
        rows in prop::option::of((0usize..400, 0usize..400)),
        decimate in prop::option::of(0usize..20),
    ) {
        let dir = tempfile::tempdir().unwrap();
        let mut data = if mutate {
            // A valid record of a stable first-order system, then some bytes overwritten.
            let mut s = String::from("t,u,y,part\n");
            let mut y = 0.0;
            for t in 0..300 {
                let u = if (t * 7 + 3) % 11 < 5 { 1.0 } else { -1.0 };
                s.push_str(&format!("{t},{u},{y:.6},dynamic\n"));
                y = 0.6 * y + 0.4 * u;
            }
            s.into_bytes()
        } else {
            bytes
        };
        let len = data.len();
        for (k, b) in flips {
            if len > 0 {
                data[k % len] = b;
            }
        }
        let file = dir.path().join("data.csv");
        std::fs::File::create(&file).unwrap().write_all(&data).unwrap();
        let read = std::panic::catch_unwind(|| {
            let _ = smid_core::data::read_columns(&file, "u", "y", Some("dynamic"));
            let _ = smid_core::data::read_columns(&file, "u", "y", None);
        });
        prop_assert!(read.is_ok(), "read_columns panicked");
        let rows = rows.map(|(a, b)| format!(", rows: [{a}, {b}]")).unwrap_or_default();
        let dec = decimate.map(|d| format!(", decimate: {d}")).unwrap_or_default();
        let spec = format!(
            "plant:\n  data:\n    dynamic: {{ file: data.csv, u: u, y: y{rows}{dec} }}\n\
             noise: {{ delta: 0.01 }}\n\
             model:\n  nonlinearity: {{ type: example_gain }}\n  na: 1\n  nb: 1\n  fixed: {{ b0: 0 }}\n\
             method: {{ eiv: shared }}\n"
        );
        parse_and_run(spec, dir.path().to_path_buf());
    }
}

/// A tolerance whose bisection would never end (`experiment.filter.tol: 1.0e-300` in the
/// input-backlash example) is an error naming the field, and the smallest accepted tolerance
/// runs to the end.
#[test]
fn a_tolerance_below_float_resolution_is_refused() {
    let text = SEEDS[1].replace("tol: 0.1", "tol: 1.0e-300");
    match Spec::parse(&text, Path::new("input-backlash.yaml")) {
        Err(smid_core::SmidError::Spec { field, .. }) => {
            assert_eq!(field, "experiment.filter.tol")
        }
        other => panic!("expected a spec error, got {other:?}"),
    }
    let ok = SEEDS[1].replace("tol: 0.1", "tol: 1.0e-12");
    terminates("tol 1e-12", Duration::from_secs(300), move || {
        smid::link_plugins();
        let spec = Spec::parse(&ok, Path::new("input-backlash.yaml")).unwrap();
        smid::run_spec(&spec, Path::new("."), &|_| {})
            .unwrap()
            .unwrap();
    });
}
