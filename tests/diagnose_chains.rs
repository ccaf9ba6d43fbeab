//! The diagnosis searches chains generated from the registry: a plugin registered only in this
//! test becomes a candidate on each side it supports, with no other edit; and a sensor lag
//! after the paper's backlash (`examples/diagnose/paper-lag.yaml`) is found on the training
//! records alone, the after-model consistent with the declared bound on held-out records and
//! its bounds holding the truth.
use serde::{Deserialize, Serialize};
use smid::core::diagnose::{self, Options, TrainVerdict};
use smid::core::pipeline;
use smid_core::prelude::*;
use std::path::Path;

/// `w = k x`, registered here only.
#[derive(Debug, Clone, Copy, Serialize, Deserialize, schemars::JsonSchema)]
struct TestGain {
    k: f64,
}
#[typetag::serde(name = "test_only_gain")]
impl Nonlinearity for TestGain {
    fn step(&self, _m: &mut Vec<f64>, x: f64) -> f64 {
        self.k * x
    }
    fn parameters(&self) -> Vec<(String, f64)> {
        vec![("k".into(), self.k)]
    }
}
#[derive(Debug, Clone, Default, Serialize, Deserialize, schemars::JsonSchema)]
struct TestGainModel {}
#[derive(Debug, Serialize, Deserialize)]
struct TestGainSet(Interval);
#[typetag::serde(name = "test_only_gain")]
impl NonlinearityModel for TestGainModel {
    fn bound_steady_state(&self, _d: &SteadyStateData) -> Result<Box<dyn NonlinearitySet>> {
        Err(SmidError::invalid("k", "not from steady state"))
    }
    fn supports(&self, _s: Structure) -> bool {
        true
    }
    fn default_prior(&self, _s: Structure, _seen: (f64, f64)) -> Option<Vec<Interval>> {
        Some(vec![Interval::new(0.9, 1.1)])
    }
    fn set_from_box(&self, cell: &[Interval]) -> Result<Box<dyn NonlinearitySet>> {
        Ok(Box::new(TestGainSet(cell[0])))
    }
}
#[typetag::serde(name = "test_only_gain")]
impl NonlinearitySet for TestGainSet {
    fn parameters(&self) -> Vec<ParameterBound> {
        vec![ParameterBound {
            name: "k".into(),
            interval: self.0,
        }]
    }
    fn invert(&self, y: &[f64], dy: &[f64]) -> Result<Vec<InnerBound>> {
        Ok(y.iter()
            .zip(dy)
            .map(|(&y, &d)| InnerBound {
                interval: Interval::hull_of([
                    (y - d) / self.0.lo,
                    (y - d) / self.0.hi,
                    (y + d) / self.0.lo,
                    (y + d) / self.0.hi,
                ])
                .unwrap()
                .outward(),
                kind: InnerKind::Inverted,
            })
            .collect())
    }
    fn propagate(&self, u: &[f64]) -> Result<Vec<InnerBound>> {
        Ok(u.iter()
            .map(|&u| InnerBound {
                interval: Interval::hull_of([u * self.0.lo, u * self.0.hi])
                    .unwrap()
                    .outward(),
                kind: InnerKind::Inverted,
            })
            .collect())
    }
}
smid_core::register_nonlinearity!("test_only_gain", TestGain, TestGain { k: 1.0 });
smid_core::register_model!("test_only_gain", TestGainModel, TestGainModel {});

fn paper_lag() -> (smid_core::spec::Spec, pipeline::ExperimentData) {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/diagnose/paper-lag.yaml");
    let spec = smid::load_spec(&path).unwrap();
    let mut plant = pipeline::builtin_plant(&spec).unwrap();
    let data = pipeline::simulate_experiments(&spec, &mut plant).unwrap();
    (spec, data)
}

#[test]
fn a_plugin_registered_in_a_test_is_a_candidate_on_both_sides() {
    let (spec, data) = paper_lag();
    let opts = Options {
        only: vec!["test_only_gain".into()],
        max_effects: 1,
        ..Default::default()
    };
    let choice = diagnose::choose(&spec, &data, &opts, &|_, _| {}).unwrap();
    let labels: Vec<&str> = choice.rounds[0]
        .candidates
        .iter()
        .map(|c| c.label.as_str())
        .collect();
    assert_eq!(
        labels,
        [
            "`test_only_gain` on the input side",
            "`test_only_gain` on the output side"
        ],
        "{labels:?}"
    );
    // Each candidate was identified and says what the data said (no error exit).
    for c in &choice.rounds[0].candidates {
        assert!(!matches!(&c.train, TrainVerdict::Failed { message } if message == "not tried"));
    }
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
