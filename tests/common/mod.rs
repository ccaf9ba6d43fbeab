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

/// Whether the slow checks run (`scripts/test-slow`, the feature `slow-checks`): the heavy
/// tests then run their whole case lists; without it (`scripts/test`, CI) each runs the sample
/// it names, chosen by a fixed rule.
#[allow(dead_code)] // not every test file uses every helper
pub const SLOW_CHECKS: bool = cfg!(feature = "slow-checks");

/// `full` under the slow checks, `sample` otherwise.
#[allow(dead_code)] // not every test file uses every helper
pub fn full_or<T>(full: T, sample: T) -> T {
    if SLOW_CHECKS {
        full
    } else {
        sample
    }
}

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

/// A spec of the paper's Section 6 plant (`a = [0.5, 0.7]`, `b = [0, 1.4, 0.8]`, output
/// backlash, 15-bit encoder, filter pole 0.8125) identified as a Wiener model with output
/// backlash (`na = nb = 2`, `b0` fixed at 0, `alpha: zero`, classical stage 3, no member
/// search). Each `&str` is YAML lines added to its section, indented by four spaces for
/// `plant` (inside `simulator`) and two for the others: chain blocks and effects of the plant
/// and the model, the experiment's `steady_state` and `dynamic`, the model's prior and the
/// method's budget.
#[allow(dead_code)] // not every test file uses every helper
pub fn paper_plant_spec(
    name: &str,
    seed: u64,
    plant: &str,
    experiment: &str,
    model: &str,
    method: &str,
) -> String {
    format!(
        "name: {name}
plant:
  simulator:
    a: [0.5, 0.7]
    b: [0.0, 1.4, 0.8]
    nonlinearity: {{ type: output_backlash, m_l: 0.248, c_l: 0.0698, m_r: 0.252, c_r: 0.0349 }}
{plant}noise: {{ encoder_bits: 15 }}
experiment:
  seed: {seed}
  filter: {{ pole: 0.8125 }}
{experiment}model:
  nonlinearity: {{ type: output_backlash }}
  na: 2
  nb: 2
  fixed: {{ b0: 0.0 }}
{model}method:
  alpha: zero
  eiv: classical
  member: {{ search: false }}
{method}"
    )
}

/// The `dynamic:` line of an experiment with a random record (`experiment` section, indented
/// two spaces): binary or 8-level, 150-259 samples, amplitude 0.8-1.6, drawn from `rng` in that
/// order.
#[allow(dead_code)] // not every test file uses every helper
pub fn random_dynamic_record(rng: &mut impl rand::Rng) -> String {
    let levels = if rng.gen_bool(0.5) { 2 } else { 8 };
    let length = rng.gen_range(150..260);
    let amplitude = rng.gen_range(0.8..1.6);
    format!("  dynamic: {{ length: {length}, amplitude: {amplitude:?}, levels: {levels} }}\n")
}

/// The paper's backlash and linear block of [`paper_plant_spec`] (`A(1) = 2.2`), `(name, value)`.
#[allow(dead_code)] // not every test file uses every helper
pub const PAPER_TRUTH: [(&str, f64); 8] = [
    ("m_l", 0.248),
    ("c_l", 0.0698),
    ("m_r", 0.252),
    ("c_r", 0.0349),
    ("a1", 0.5),
    ("a2", 0.7),
    ("b1", 1.4),
    ("b2", 0.8),
];
