//! FMU plants through the facade: `examples/fmu-paper.yaml` (the paper system as an FMU) gives
//! the same bounds as `examples/paper.yaml` (the built-in simulator) on the same seed, and a
//! spec whose FMU cannot be used fails with a typed plant error naming it.
#![cfg(feature = "fmu")]
use smid::SmidError;
use std::path::Path;

#[test]
fn fmu_paper_gives_the_bounds_of_the_builtin_paper_example() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let fmu = smid::run_spec_file(&root.join("examples/fmu-paper.yaml"))
        .unwrap()
        .unwrap();
    let sim = smid::run_spec_file(&root.join("examples/paper.yaml"))
        .unwrap()
        .unwrap();
    assert_eq!(fmu.parameters().len(), sim.parameters().len());
    assert_eq!(fmu.data.records[0].y.len(), sim.data.records[0].y.len());
    assert_eq!(
        fmu.data.filter.as_ref().map(|f| f.pole),
        sim.data.filter.as_ref().map(|f| f.pole)
    );
    for (a, b) in fmu.parameters().iter().zip(sim.parameters()) {
        assert_eq!(a.name, b.name);
        assert!(
            (a.lower - b.lower).abs() <= 1e-9 && (a.upper - b.upper).abs() <= 1e-9,
            "{}: FMU [{}, {}] vs simulator [{}, {}]",
            a.name,
            a.lower,
            a.upper,
            b.lower,
            b.upper
        );
        if let Some(c) = a.contains {
            assert!(c, "{} misses its truth", a.name);
        }
    }
    // The noise-free outputs of both plants agree exactly.
    assert_eq!(fmu.data.records[0].w, sim.data.records[0].w);
}

#[test]
fn unusable_fmu_in_a_spec_is_a_plant_error() {
    let dir = tempfile::tempdir().unwrap();
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read_to_string(root.join("examples/fmu-paper.yaml"))
        .unwrap()
        .replace("fmu: ../fmus/paper", "fmu: missing/plant.fmu");
    let spec = dir.path().join("spec.yaml");
    std::fs::write(&spec, &text).unwrap();
    match smid::run_spec_file(&spec) {
        Err(SmidError::Plant { plant, message }) => {
            assert!(plant.contains("missing/plant.fmu"), "{plant}");
            assert!(
                message.contains(&dir.path().join("missing/plant.fmu").display().to_string()),
                "resolved against the spec's directory: {message}"
            );
        }
        other => panic!("expected a plant error, got {other:?}"),
    }
    // An unknown FMU parameter named in the spec.
    let text = std::fs::read_to_string(root.join("examples/fmu-paper.yaml"))
        .unwrap()
        .replace(
            "fmu: ../fmus/paper",
            &format!("fmu: {}", root.join("fmus/paper").display()),
        )
        .replace(
            "b0: 0.0, b1: 1.4, b2: 0.8, m_l",
            "b0: 0.0, b1: 1.4, b2: 0.8, b9: 1.0, m_l",
        );
    std::fs::write(&spec, &text).unwrap();
    match smid::run_spec_file(&spec) {
        Err(SmidError::Plant { message, .. }) => assert!(message.contains("`b9`"), "{message}"),
        other => panic!("expected a plant error, got {other:?}"),
    }
}
