//! Identification from any record (no steady-state experiment): one example per plugin in
//! `examples/any/`, each a simulator plant and one dynamic record, the nonlinearity bisected over
//! its prior box by the branch and bound. The truth lies inside every reported bound, and the
//! data narrow the prior for at least one nonlinearity parameter. Every example stops on its
//! cell budget (a looser hull, never one that misses the truth), so the test checks the
//! guarantee where it is most fragile: coarse, undecided cells.
use std::path::PathBuf;

#[test]
fn every_plugin_is_bounded_from_a_dynamic_record_alone_with_the_truth_inside() {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("examples/any");
    let mut n = 0;
    let mut entries: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "yaml"))
        .collect();
    entries.sort();
    for path in entries {
        let spec = smid::load_spec(&path).unwrap();
        assert!(
            spec.experiment.steady_state.skip,
            "{}: expected no steady-state experiment",
            path.display()
        );
        assert!(!spec.model.prior.is_empty(), "{}: no prior", path.display());
        let id = smid::run_spec(&spec, &dir, &|_| {})
            .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
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
        n += 1;
    }
    assert!(n >= 5, "only {n} examples in {}", dir.display());
}
