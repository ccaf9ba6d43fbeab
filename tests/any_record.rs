//! Identification from any record (no steady-state experiment): one example per plugin in
//! `examples/any/`, each a simulator plant and one dynamic record, the nonlinearity bisected over
//! its prior box by the branch and bound. The truth lies inside every reported bound, and the
//! data narrow the prior for at least one nonlinearity parameter. Every example stops on its
//! cell budget (a looser hull, never one that misses the truth), so the test checks the
//! guarantee where it is most fragile: coarse, undecided cells.
use std::path::PathBuf;

mod common;

/// Without `slow-checks` (CI) every example but the dead zone on the output side, the longest
/// search (that plugin's trials from one dynamic record run in CI in `tests/plugins.rs`).
#[test]
fn every_plugin_is_bounded_from_a_dynamic_record_alone_with_the_truth_inside() {
    const SLOW: &str = "dead-zone-output.yaml";
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("examples/any");
    let entries = common::yaml_files(&dir);
    assert!(
        entries.iter().any(|p| p.ends_with(SLOW)),
        "no example {SLOW}"
    );
    // The examples side by side (each run is mostly sequential work).
    use rayon::prelude::*;
    entries.par_iter().for_each(|path| {
        if !common::SLOW_CHECKS && path.ends_with(SLOW) {
            eprintln!("skipping {}: run by scripts/test-slow", path.display());
            return;
        }
        let spec = smid::load_spec(path).unwrap();
        assert!(
            spec.experiment.steady_state.skip,
            "{}: expected no steady-state experiment",
            path.display()
        );
        assert!(!spec.model.prior.is_empty(), "{}: no prior", path.display());
        let id = smid::run_spec(&spec, &dir, &|_| {})
            .unwrap_or_else(|e| panic!("{}: {e}", path.display()))
            .unwrap();
        assert_eq!(
            id.all_contain_truth(),
            Some(true),
            "{}: {:?}",
            path.display(),
            id.model.parameters
        );
        let narrowed = spec.model.prior.iter().any(|(name, [lo, hi])| {
            let p = id.parameter(name).unwrap();
            assert!(p.lower.is_finite() && p.upper.is_finite(), "{name}: {p:?}");
            p.upper - p.lower < 0.9 * (hi - lo)
        });
        assert!(narrowed, "{}: the data narrowed no prior", path.display());
    });
    let n = entries.len();
    assert!(n >= 5, "only {n} examples in {}", dir.display());
}

/// A record that leaves unstable explanations open over some cells (the output-backlash trial
/// of seed 17: a huge `a1` with a huge `b` fits there): the run still answers, with the
/// nonlinearity's guaranteed bounds, infinite θ bounds and the cells named with their cause;
/// declaring the block stable (`model.stable`) bounds every θ, the truth inside.
#[test]
fn cells_left_unbounded_give_a_partial_answer_and_a_stable_block_bounds_them() {
    use smid::montecarlo::Trial;
    use smid_core::model::UndecidedCause;
    let t = Trial::random(17);
    let mut spec = t.any_spec();
    spec.model.stable = false;
    spec.method.cells.max_cells = 800;
    spec.method.cells.max_leaves = 64;
    let id = t
        .run_spec(&spec)
        .expect("a partial answer, not an error")
        .unwrap();
    let s = &id.model.search;
    assert!(!s.unbounded.is_empty() && s.refined > 0, "{s:?}");
    assert!(s
        .unbounded
        .iter()
        .all(|u| u.cause == UndecidedCause::Unbounded));
    for name in ["m_l", "c_l", "m_r", "c_r"] {
        let p = id.parameter(name).unwrap();
        assert!(p.lower.is_finite() && p.upper.is_finite(), "{name}: {p:?}");
        assert_eq!(p.contains, Some(true), "{name}: {p:?}");
    }
    let a1 = id.parameter("a1").unwrap();
    assert!(!a1.upper.is_finite() || !a1.lower.is_finite(), "{a1:?}");
    assert_eq!(id.all_contain_truth(), Some(true));
    let report = smid_core::report::table(&id);
    assert!(report.contains("without a finite θ bound"), "{report}");

    spec.model.stable = true;
    let id = t.run_spec(&spec).unwrap().unwrap();
    assert!(id.model.search.unbounded.is_empty());
    for p in &id.model.parameters {
        assert!(p.lower.is_finite() && p.upper.is_finite(), "{p:?}");
    }
    assert_eq!(id.all_contain_truth(), Some(true));
    let a = id.parameter("a1").unwrap();
    assert!(-2.0 <= a.lower && a.upper <= 2.0, "{a:?}");
}
