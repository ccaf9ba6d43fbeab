//! The diagnosis searches chains generated from the registry (a plugin registered only in a
//! test becomes a candidate: `tests/plugin_in_test.rs`): a sensor lag after the paper's backlash (`examples/diagnose/paper-lag.yaml`) is found on the training
//! records alone, the after-model consistent with the declared bound on held-out records and
//! its bounds holding the truth.
use smid::core::diagnose::{self, Options};
use smid::core::pipeline;
use std::path::Path;

fn paper_lag() -> (smid_core::spec::Spec, pipeline::ExperimentData) {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/diagnose/paper-lag.yaml");
    smid::load_simulated(&path).unwrap()
}

#[test]
fn an_undeclared_sensor_lag_is_found_and_the_after_model_holds() {
    let (spec, data) = paper_lag();
    let choice = diagnose::choose(&spec, &data, &Options::default(), &|_, _| {}).unwrap();
    assert_eq!(
        choice.added,
        ["`lag` on the output side"],
        "{}",
        choice.summary()
    );
    let after = choice
        .after_set
        .as_ref()
        .expect("the after-model is admissible");
    // The truth of the lag lies in its bound.
    let p = after
        .parameter("out1.p")
        .expect("the lag's pole is reported");
    assert!(p.lower <= 0.5 && 0.5 <= p.upper, "{p:?}");
    // Held-out records of the plant (other seeds), read once, for the table.
    let mut plant = pipeline::builtin_plant(&spec).unwrap();
    let holdout: Vec<_> = [1001, 1002]
        .iter()
        .map(|&s| pipeline::fresh_record(&spec, &mut plant, s, 300).unwrap())
        .collect();
    let (_, after_col) = diagnose::assess(&spec, &data, &choice, &holdout, 5).unwrap();
    assert!(
        after_col
            .validation
            .as_ref()
            .unwrap()
            .consistency
            .consistent
    );
    assert!(!after_col.inflated);
}
