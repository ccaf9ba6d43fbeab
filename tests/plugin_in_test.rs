//! A plugin registered only in this test, with no edit anywhere else, shows up wherever the
//! registry reaches: in the spec's JSON Schema, as two cases of the
//! containment check (`smid check --plugin test_only_gain_input` / `_output`, whose trials then
//! hold the truth), and as a diagnosis candidate on each side it supports.
use serde::{Deserialize, Serialize};
use smid::core::diagnose::{self, Options, TrainVerdict};
use smid::core::pipeline;
use smid::core::registry;
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
    /// `ȳ = k ū ± Δη` under unit linear gain, on either side: `k` in the intersection.
    fn bound_steady_state(&self, d: &SteadyStateData) -> Result<Box<dyn NonlinearitySet>> {
        let mut k = Interval::new(0.0, f64::INFINITY);
        for p in d.points.iter().filter(|p| p.u != 0.0) {
            let (a, b) = ((p.y - p.dy) / p.u, (p.y + p.dy) / p.u);
            let here = Interval::new(a.min(b), a.max(b)).outward();
            k = k.intersect(&here).ok_or_else(|| {
                SmidError::inconsistent(Stage::SteadyState, p.index, "no gain fits")
            })?;
        }
        Ok(Box::new(TestGainSet(k)))
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
    /// Its containment trial: a gain in `[0.6, 1.6)` on either side.
    fn check_draw(&self, _s: Structure, rng: &mut dyn RngCore) -> Option<CheckDraw> {
        Some(CheckDraw {
            nonlinearity: Box::new(TestGain {
                k: rng.gen_range(0.6..1.6),
            }),
            model: Box::new(TestGainModel {}),
            steady: (0.2, 3.0),
            amplitude: 1.0,
        })
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

#[test]
fn a_plugin_registered_in_a_test_is_in_the_schema() {
    smid::link_plugins();
    let schema = registry::spec_schema();
    assert!(
        schema.contains("\"test_only_gain\""),
        "the spec schema does not name the test's plugin"
    );
    assert!(registry::model_types().contains(&"test_only_gain"));
}

#[test]
fn a_plugin_registered_in_a_test_is_a_case_of_the_containment_check() {
    let cases = smid::plugin_check::plugins();
    for name in ["test_only_gain_input", "test_only_gain_output"] {
        assert!(cases.iter().any(|c| c == name), "{name} not in {cases:?}");
        // What `smid check --plugin NAME --trials 6` runs: every trial holds the truth.
        let seeds: Vec<u64> = (1..=6).collect();
        let s = smid::plugin_check::run(name, &seeds, None, false, 1, || {}).unwrap();
        assert_eq!(s.trials, 6);
        assert!(s.missed.is_empty(), "{name}: missed {:?}", s.missed);
        assert_eq!(
            s.contained,
            6,
            "{name}: {}",
            smid::plugin_check::report(name, &s)
        );
        // The trial draws the plugin's own block, in the case's structure.
        let t = smid::plugin_check::PluginTrial::random(name, 1).unwrap();
        assert_eq!(
            smid_core::nonlinearity::tag_of_model(t.model.as_ref()),
            "test_only_gain"
        );
        let k = t.nonlinearity.parameters()[0].1;
        assert!((0.6..1.6).contains(&k), "{k}");
    }
}

fn paper_lag() -> (smid_core::spec::Spec, pipeline::ExperimentData) {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/diagnose/paper-lag.yaml");
    smid::load_simulated(&path).unwrap()
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
