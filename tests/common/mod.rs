//! Helpers shared by the integration tests.
use smid::core::pipeline::{self, ExperimentData};
use smid::core::spec::Spec;
use std::path::Path;

/// A record given as measured data: `u` and `y` written to `rec.csv` (columns `u`, `y`) in a
/// fresh temporary directory, read by a spec `name: tag` whose `plant.data` names that file and
/// whose remaining sections are `rest` (YAML: `noise`, `model`, `method`), then loaded. The
/// directory is removed again.
#[allow(dead_code)] // not every test file uses every helper
pub fn measured(tag: &str, u: &[f64], y: &[f64], rest: &str) -> (Spec, ExperimentData) {
    let mut csv = String::from("u,y\n");
    for (a, b) in u.iter().zip(y) {
        csv.push_str(&format!("{a},{b}\n"));
    }
    let dir = std::env::temp_dir().join(format!(
        "smid-{tag}-{}-{}",
        std::process::id(),
        COUNTER.fetch_add(1, std::sync::atomic::Ordering::Relaxed)
    ));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("rec.csv"), csv).unwrap();
    let text = format!(
        "name: {tag}\nplant:\n  data:\n    dynamic: {{ file: rec.csv, u: u, y: y }}\n{rest}"
    );
    let spec = smid::parse_spec(&text, Path::new(&format!("{tag}.yaml"))).unwrap();
    let data = pipeline::load_data(&spec, &dir).unwrap();
    let _ = std::fs::remove_dir_all(&dir);
    (spec, data)
}

static COUNTER: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);

/// Every `(name, true value)` inside its reported bound; panics naming the first that is not
/// (or is not reported), with `context` (the case and its spec).
#[allow(dead_code)] // not every test file uses every helper
pub fn assert_truth_inside(
    id: &smid::core::pipeline::Identification,
    truth: &[(String, f64)],
    context: &str,
) {
    for (n, v) in truth {
        let p = id
            .model
            .parameters
            .iter()
            .find(|p| &p.name == n)
            .unwrap_or_else(|| panic!("{context}: `{n}` is not reported"));
        assert!(
            p.lower <= *v && *v <= p.upper,
            "{context}: {n} = {v} outside [{}, {}]",
            p.lower,
            p.upper
        );
    }
}

/// The `.yaml` files of `dir`, sorted by path.
#[allow(dead_code)] // not every test file uses every helper
pub fn yaml_files(dir: &Path) -> Vec<std::path::PathBuf> {
    let mut v: Vec<_> = std::fs::read_dir(dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|x| x == "yaml"))
        .collect();
    v.sort();
    v
}

/// The two runs' parameters have the same names and bounds (within 1e-12).
#[allow(dead_code)] // not every test file uses every helper
pub fn assert_same_bounds(a: &pipeline::Identification, b: &pipeline::Identification) {
    assert_eq!(a.parameters().len(), b.parameters().len());
    for (p, q) in a.parameters().iter().zip(b.parameters()) {
        assert_eq!(p.name, q.name);
        assert!(
            (p.lower - q.lower).abs() < 1e-12 && (p.upper - q.upper).abs() < 1e-12,
            "{p:?} vs {q:?}"
        );
    }
}
