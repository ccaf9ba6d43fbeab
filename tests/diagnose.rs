//! Validation and diagnosis: a model consistent with the data passes validation, an undeclared
//! offset fails it and is named by the diagnosis (report snapshot), and on the measured data
//! sets (skipped with a reason when ../shared/data is absent) the held-out error falls.
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use smid::diagnose::effect::Record;
use smid::diagnose::lip::Structure;
use smid::diagnose::spec::DiagSpec;
use smid::diagnose::{diagnose, validate};
use std::path::Path;

/// ARX(1,1,1) data `y_t = 0.6 y_{t-1} + 0.9 u_{t-1} + offset + e_t`, `|e_t| <= 0.02`.
fn arx(seed: u64, n: usize, offset: f64) -> Record {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut u = Vec::new();
    while u.len() < n {
        let v: f64 = rng.gen_range(-1.0..1.0);
        for _ in 0..rng.gen_range(1..=4) {
            u.push(v);
        }
    }
    u.truncate(n);
    let mut y = vec![0.0; n];
    for t in 1..n {
        y[t] = 0.6 * y[t - 1] + 0.9 * u[t - 1] + offset + rng.gen_range(-0.02..0.02);
    }
    Record {
        name: format!("simulated seed {seed}"),
        u,
        y,
        dt: 1.0,
    }
}

fn spec() -> DiagSpec {
    smid::link_plugins();
    DiagSpec::from_yaml(
        "name: offset-test\ndata: { u: u, y: y, train: [ { file: none.csv } ] }\nnoise: { bound: 0.02 }\nmodel: { na: 1, nb: 1, nk: 1 }\ndiagnose: { max_effects: 2 }\n",
        Path::new("inline.yaml"),
    )
    .unwrap()
}

fn assess(train: &Record, hold: &Record) -> validate::Assessment {
    let s = spec();
    let st = Structure {
        base: s.model.orders(),
        effects: vec![],
    };
    let f = validate::fit(&st, std::slice::from_ref(train)).unwrap();
    validate::assess(
        &f,
        std::slice::from_ref(train),
        std::slice::from_ref(hold),
        0.02,
    )
    .unwrap()
}

#[test]
fn validation_passes_on_consistent_data() {
    let a = assess(&arx(1, 300, 0.0), &arx(2, 200, 0.0));
    assert!(
        validate::passes(&a),
        "{}",
        validate::format_report(&a, "declared")
    );
    assert!(a.dstar_holdout <= 0.02 + 1e-9);
    assert_eq!(a.falsified, 0.0);
}

#[test]
fn validation_fails_with_an_undeclared_offset() {
    let a = assess(&arx(1, 300, 0.1), &arx(2, 200, 0.1));
    assert!(!validate::passes(&a));
}

#[test]
fn diagnosis_names_an_undeclared_offset() {
    let s = spec();
    let d = diagnose::diagnose(&s, &[arx(3, 300, 0.1)], &[arx(4, 200, 0.1)], |_, _| {}).unwrap();
    assert_eq!(d.added_tags.first().map(String::as_str), Some("offset"));
    assert!(
        d.after.dstar_holdout <= 0.02 * 1.05,
        "{}",
        d.after.dstar_holdout
    );
    assert!(validate::passes(&d.after));
    insta::assert_snapshot!("diagnosis-offset", diagnose::format_report(&d));
}

fn data_dir() -> Option<&'static Path> {
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/data");
    if p.is_dir() {
        Some(Box::leak(p.into_boxed_path()))
    } else {
        eprintln!(
            "skipped: {} is absent (measured data are not in the repo)",
            p.display()
        );
        None
    }
}

#[test]
fn measured_data_error_falls_after_diagnosis() {
    if data_dir().is_none() {
        return;
    }
    smid::link_plugins();
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    for ex in ["examples/emps.yaml", "examples/damper.yaml"] {
        let out = tempfile::tempdir().unwrap();
        let (_, d, files) =
            smid::diagnose::commands::diagnose(&root.join(ex), None, None, out.path(), |_, _| {})
                .unwrap();
        assert!(!d.added_tags.is_empty(), "{ex}: nothing added");
        assert!(
            d.after.rms < 0.9 * d.before.rms,
            "{ex}: {} -> {}",
            d.before.rms,
            d.after.rms
        );
        assert!(files.iter().all(|f| f.exists()));
    }
}

/// The committed schema of diagnosis specs is the one the Rust types generate, and the examples
/// that are diagnosis specs name it.
#[test]
fn committed_diagnose_schema_is_up_to_date() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    let committed =
        std::fs::read_to_string(root.join("schemas/smid-diagnose.schema.json")).unwrap_or_default();
    assert!(
        committed == smid_diagnose::spec::schema(),
        "schemas/smid-diagnose.schema.json is stale: regenerate it with `cargo run -- schema --diagnose > schemas/smid-diagnose.schema.json`"
    );
    for ex in ["examples/emps.yaml", "examples/damper.yaml"] {
        let text = std::fs::read_to_string(root.join(ex)).unwrap();
        assert!(
            text.starts_with(
                "# yaml-language-server: $schema=../schemas/smid-diagnose.schema.json\n"
            ),
            "{ex}"
        );
        smid_diagnose::spec::DiagSpec::from_yaml(&text, &root.join(ex)).unwrap();
    }
}
