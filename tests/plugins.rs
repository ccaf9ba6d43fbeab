//! End-to-end tests of the nonlinearity plugins beyond the output backlash (input backlash,
//! dead zone on either side, saturation, the example gain, the bias): insta snapshots of the bounds each
//! example spec gives, proptest containment of the truth over random systems, parameters and
//! noise (the full three-stage pipeline), and the errors a misspelled `type` or parameter gets.
use proptest::prelude::*;
use smid::core::spec::Spec;
use smid::plugin_check::PluginTrial;
use smid::{Outcome, SmidError};
use std::path::Path;

/// The plugin examples, found through the registry: for every registered model `type` (its
/// tag with dashes), `examples/<type>.yaml`, or `examples/<type>-input.yaml` and
/// `-output.yaml` for a plugin shown on both sides. A plugin crate added with such an example
/// gets its snapshot here without a line of this file.
fn plugin_examples() -> Vec<String> {
    smid::link_plugins();
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples");
    let mut names = Vec::new();
    for tag in smid::core::registry::model_types() {
        let stem = tag.replace('_', "-");
        for name in [
            stem.clone(),
            format!("{stem}-input"),
            format!("{stem}-output"),
        ] {
            if dir.join(format!("{name}.yaml")).is_file() {
                names.push(name);
            }
        }
    }
    names
}

/// A machine-independent view of the bounds: six significant digits.
fn bounds_view(name: &str) -> Vec<String> {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("examples")
        .join(format!("{name}.yaml"));
    let id = smid::run_spec_file(&path)
        .unwrap_or_else(|e| panic!("{name}: {e}"))
        .unwrap();
    assert_eq!(
        id.all_contain_truth(),
        Some(true),
        "{name}: truth outside a bound"
    );
    id.parameters()
        .iter()
        .map(|p| {
            format!(
                "{:<4} truth {:>13} in [{:.5e}, {:.5e}]",
                p.name,
                p.truth.map(|t| format!("{t:.5e}")).unwrap_or_default(),
                p.lower,
                p.upper
            )
        })
        .collect()
}

#[test]
fn example_bounds_snapshots() {
    let names = plugin_examples();
    // The bundled plugins with examples: a registry that lost one fails here.
    assert!(names.len() >= 6, "{names:?}");
    for name in names {
        insta::assert_yaml_snapshot!(format!("bounds-{name}"), bounds_view(&name));
    }
}

fn cases() -> u32 {
    std::env::var("PROPTEST_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(4)
}

/// One random end-to-end trial: the truth must be inside every bound; an empty feasible set
/// would mean a bound excluded the truth, so `Inconsistent` fails too. Other errors (too few
/// informative samples) give no bound and are allowed.
fn check(plugin: &str, seed: u64) -> std::result::Result<(), TestCaseError> {
    check_from(plugin, seed, false)
}

/// The same trial from one dynamic record: the nonlinearity bisected over a random prior box
/// around the truth (`smid check --any-record`).
fn check_any(plugin: &str, seed: u64) -> std::result::Result<(), TestCaseError> {
    check_from(plugin, seed, true)
}

fn check_from(plugin: &str, seed: u64, any: bool) -> std::result::Result<(), TestCaseError> {
    let outcome = smid::plugin_check::trial(plugin, seed, None, any);
    match outcome {
        Ok(Outcome::Consistent(id)) => {
            prop_assert_eq!(
                id.all_contain_truth(),
                Some(true),
                "{} seed {}: {:?}",
                plugin,
                seed,
                id.parameters()
            );
        }
        Ok(Outcome::Falsified(f)) => {
            return Err(TestCaseError::fail(format!(
                "{plugin} seed {seed}: {}",
                f.message()
            )))
        }
        Err(_) => {}
    }
    Ok(())
}

/// `f` on every check case, side by side (a trial is mostly sequential work), the first
/// failure in case order reported.
fn each_case(
    f: impl Fn(&str) -> std::result::Result<(), TestCaseError> + Sync,
) -> std::result::Result<(), TestCaseError> {
    use rayon::prelude::*;
    let cases = smid::plugin_check::plugins();
    let results: Vec<_> = cases.par_iter().map(|case| f(case)).collect();
    results.into_iter().collect()
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(cases()))]
    /// Every check case the registry derives (each linked plugin with a random trial, in each
    /// structure it offers one in), from its designed experiment.
    #[test]
    fn every_check_case_contains_truth(seed in 1u64..1_000_000) {
        each_case(|case| check(case, seed))?;
    }
}

/// The configuration of the any-record property. Half as many seeds as the designed trials
/// under `slow-checks`, with the seeds saved in `plugins.proptest-regressions` replayed first:
/// an any-record trial costs about ten times as much (the bisection of the nonlinearity's box),
/// and `smid check --any-record --trials 1000` runs this path at full count. Without it (CI) a
/// quarter, one new seed by default, and the saved seeds are not replayed here (as any-record
/// trials they are among the longest; the designed property above replays them in CI).
fn any_record_config() -> ProptestConfig {
    if cfg!(feature = "slow-checks") {
        ProptestConfig::with_cases(cases().div_ceil(2))
    } else {
        ProptestConfig {
            failure_persistence: None,
            ..ProptestConfig::with_cases(cases().div_ceil(4))
        }
    }
}

proptest! {
    #![proptest_config(any_record_config())]
    /// The same cases from one dynamic record.
    #[test]
    fn every_check_case_from_any_record_contains_truth(seed in 1u64..1_000_000) {
        each_case(|case| check_any(case, seed))?;
    }
}

fn example_text(name: &str) -> String {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("examples")
        .join(format!("{name}.yaml"));
    std::fs::read_to_string(path).unwrap()
}

#[test]
fn misspelled_type_lists_the_valid_types() {
    let text = example_text("dead-zone-output").replace("type: dead_zone }", "type: dead_zon }");
    let err = Spec::parse(&text, Path::new("bad.yaml"))
        .unwrap_err()
        .to_string();
    assert!(err.contains("dead_zon"), "{err}");
    assert!(err.contains("model.nonlinearity"), "{err}");
    for t in smid::core::registry::model_types() {
        assert!(err.contains(t), "`{t}` not listed in: {err}");
    }
    let text = example_text("saturation").replace("type: saturation, m_l", "type: saturaton, m_l");
    let err = Spec::parse(&text, Path::new("bad.yaml"))
        .unwrap_err()
        .to_string();
    for t in smid::core::registry::nonlinearity_types() {
        assert!(err.contains(t), "`{t}` not listed in: {err}");
    }
}

#[test]
fn misspelled_parameter_lists_the_valid_parameters() {
    let text = example_text("dead-zone-input").replace("c_l: 0.3", "cl: 0.3");
    let err = Spec::parse(&text, Path::new("bad.yaml"))
        .unwrap_err()
        .to_string();
    assert!(err.contains("unknown field `cl`"), "{err}");
    assert!(err.contains("plant.simulator.nonlinearity"), "{err}");
    for p in ["m_l", "c_l", "m_r", "c_r"] {
        assert!(err.contains(p), "`{p}` not listed in: {err}");
    }
    let text = example_text("input-backlash").replace("at_rest: false", "at_rst: false");
    let err = Spec::parse(&text, Path::new("bad.yaml"))
        .unwrap_err()
        .to_string();
    assert!(err.contains("at_rst") && err.contains("at_rest"), "{err}");
}

#[test]
fn invalid_plugin_parameter_names_the_field() {
    let text = example_text("saturation").replace("s_r: 1.5", "s_r: -1.5");
    let err = Spec::parse(&text, Path::new("bad.yaml"))
        .unwrap_err()
        .to_string();
    assert!(err.contains("plant.simulator.nonlinearity.s_r"), "{err}");
}

#[test]
fn input_backlash_is_refused_in_a_wiener_structure() {
    let text = example_text("input-backlash").replace(
        "model:\n  structure: hammerstein",
        "model:\n  structure: wiener",
    );
    assert!(text.contains("model:\n  structure: wiener"));
    let err = Spec::parse(&text, Path::new("bad.yaml"))
        .unwrap_err()
        .to_string();
    assert!(err.contains("model.structure"), "{err}");
}

/// `smid check --plugin P --method M` runs stage 3 by `M`: exact-grid refuses the Hammerstein
/// structure of an input nonlinearity (a clear error), and classical is never tighter than the
/// default (shared) on the same trial.
#[test]
fn plugin_trials_honour_the_stage3_method() {
    use smid_core::spec::EivMethod;
    let trial = || PluginTrial::random("dead_zone_input", 3).unwrap();
    assert!(matches!(
        trial().run(Some(EivMethod::ExactGrid), false),
        Err(SmidError::Unsupported { .. })
    ));
    let (Ok(Outcome::Consistent(classical)), Ok(Outcome::Consistent(shared))) = (
        trial().run(Some(EivMethod::Classical), false),
        trial().run(Some(EivMethod::Shared), false),
    ) else {
        panic!("seed 3 identifies with both methods");
    };
    let mut wider = 0;
    for name in ["a1", "a2", "b1", "b2"] {
        let (c, s) = (
            classical.parameter(name).unwrap(),
            shared.parameter(name).unwrap(),
        );
        assert!(
            c.lower <= s.lower && s.upper <= c.upper,
            "{name}: shared wider than classical"
        );
        wider += usize::from(c.radius > s.radius * 1.5);
    }
    assert!(
        wider > 0,
        "classical and shared gave the same bounds: was the method ignored?"
    );
}

/// Every registered model's set over a prior cell (`set_from_box`: what the branch and bound
/// keeps per cell and the member search moves points by) holds the cell's centre and no point
/// beyond the cell along any coordinate. Cells are drawn at random inside each plugin's default
/// prior, on each side it supports, for random data scales. (Seed 565 of the saturation's
/// any-record check found a certified member with `m_l` above its cell: the saturation's box
/// set checked only the lower ends.)
#[test]
fn every_box_set_holds_its_cell_and_nothing_beyond() {
    use smid::core::interval::Interval;
    use smid::core::nonlinearity::Structure;
    smid::link_plugins();
    // A small deterministic generator (xorshift), uniform in [0, 1).
    let mut state = 0x9E37_79B9_7F4A_7C15u64;
    let mut uniform = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 11) as f64 / (1u64 << 53) as f64
    };
    let mut tried = 0;
    for e in smid::core::registry::models() {
        let model = (e.example)();
        for structure in [Structure::Wiener, Structure::Hammerstein] {
            if !model.supports(structure) {
                continue;
            }
            for _ in 0..25 {
                let seen = (-(0.2 + 3.0 * uniform()), 0.2 + 3.0 * uniform());
                let Some(prior) = model.default_prior(structure, seen) else {
                    continue;
                };
                if prior.is_empty() {
                    continue;
                }
                let cell: Vec<Interval> = prior
                    .iter()
                    .map(|p| {
                        let a = p.lo + uniform() * (p.hi - p.lo);
                        Interval::new(a, a + uniform() * (p.hi - a))
                    })
                    .collect();
                let set = model
                    .set_from_box(&cell)
                    .unwrap_or_else(|err| panic!("{}: {cell:?}: {err}", e.tag));
                let centre: Vec<f64> = cell.iter().map(|i| i.center()).collect();
                assert!(set.contains(&centre), "{}: centre of {cell:?}", e.tag);
                for k in 0..cell.len() {
                    let step = 0.01 * (cell[k].hi - cell[k].lo + cell[k].hi.abs()) + 1e-6;
                    for beyond in [cell[k].hi + step, cell[k].lo - step] {
                        let mut p = centre.clone();
                        p[k] = beyond;
                        assert!(
                            !set.contains(&p),
                            "{}: {p:?} is outside the cell {cell:?} along coordinate {k}",
                            e.tag
                        );
                    }
                }
                tried += 1;
            }
        }
    }
    assert!(tried >= 100, "only {tried} cells tried");
}
