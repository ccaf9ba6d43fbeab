//! An effect registered only in this test, with one capability (a sensor term) and no plant
//! side: identification uses it through `SensorTerm` alone, the simulator
//! refuses it by name, and the registry offers it to the diagnosis with no edit elsewhere.
use serde::{Deserialize, Serialize};
use smid::core::effect::{self, Effect, SensorTerm};
use smid::core::interval::Interval;
use std::path::{Path, PathBuf};

/// `s_t = bias`, the bias bisected: a model-side term only.
#[derive(Debug, Clone, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
struct TestBias {}

impl SensorTerm for TestBias {
    fn sensor(&self, _t: Option<usize>, cell: &[Interval]) -> smid::core::Result<Interval> {
        Ok(cell[0])
    }
    fn cell_parameters(&self) -> Vec<String> {
        vec!["bias".into()]
    }
}

#[typetag::serde(name = "test_only_bias")]
impl Effect for TestBias {
    fn label(&self) -> String {
        "sensor bias (test)".into()
    }
    fn as_sensor(&self) -> Option<&dyn SensorTerm> {
        Some(self)
    }
}
smid_core::register_effect!("test_only_bias", TestBias, 50, TestBias {}, [TestBias {}]);

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

#[test]
fn a_sensor_only_effect_bounds_the_plants_offset() {
    smid::link_plugins();
    let path = root().join("examples/diagnose/paper-offset.yaml");
    let mut spec = smid::load_spec(&path).unwrap();
    spec.model.effects = vec![serde_norway::from_str("{type: test_only_bias}").unwrap()];
    spec.model.prior.insert("bias".into(), [-0.05, 0.05]);
    let id = smid::run_spec(&spec, &root().join("examples/diagnose"), &|_| {})
        .unwrap()
        .unwrap();
    // The plant's offset is 0.01 (the bundled `offset`'s plant side); the test's bias is its
    // model side, reached through the capability alone.
    let bias = id
        .parameter("bias")
        .expect("the bias is a bisected parameter");
    assert!(
        bias.lower <= 0.01 && 0.01 <= bias.upper,
        "bias [{}, {}] misses the plant's offset 0.01",
        bias.lower,
        bias.upper
    );
    assert!(bias.lower > -0.05 && bias.upper < 0.05, "{bias:?}");
}

#[test]
fn a_simulator_refuses_an_effect_without_a_plant_side_by_name() {
    smid::link_plugins();
    let base = std::fs::read_to_string(root().join("examples/diagnose/paper-offset.yaml")).unwrap();
    let text = base.replace(
        "effects: [ { type: offset, value: 0.01 } ]",
        "effects: [ { type: offset, value: 0.01 }, { type: test_only_bias } ]",
    );
    assert_ne!(text, base);
    let e = smid::core::spec::Spec::parse(&text, Path::new("t.yaml"))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("plant.simulator.effects[1].type")
            && e.contains("test_only_bias")
            && e.contains("no plant side"),
        "{e}"
    );
}

#[test]
fn a_registered_effect_is_a_diagnosis_candidate_and_in_the_schema() {
    smid::link_plugins();
    assert!(effect::effect_types().contains(&"test_only_bias"));
    let entry = effect::effects()
        .into_iter()
        .find(|e| e.tag == "test_only_bias")
        .unwrap();
    let c = (entry.candidates)();
    assert_eq!(c.len(), 1);
    assert_eq!(c[0].cell_parameters(), vec!["bias".to_string()]);
    assert!(c[0].as_plant().is_none() && c[0].as_orders().is_none());
    let schema = smid::core::registry::spec_schema();
    assert!(schema.contains("test_only_bias"));
}
