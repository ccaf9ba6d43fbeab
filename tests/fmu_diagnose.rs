//! Diagnosis on FMU data: for each effect of the `paper_effects` FMU (1 constant offset, 2
//! drifting offset, 3 one-sample delay; `examples/fmu-effects.yaml` with `effect` set), train
//! and held-out records are simulated from the FMU (`smid::simulate`, the code behind
//! `smid simulate`) and written as CSV to a temporary directory, read back through the diagnosis
//! spec `examples/fmu-effects-diagnose.yaml`, and diagnosed. The diagnosis must name the effect
//! and the held-out error after must be at the noise level (as in `smid diagnose-check`: the
//! smallest bound consistent with the held-out record ≤ 1.2 × (Δ + allowance)), while before it
//! is not. With no effect (0), nothing is added. Also: `smid simulate` on the built-in simulator
//! returns the simulator's output with noise within the bound, and refuses a measured-data plant.
#![cfg(feature = "fmu")]
use smid::diagnose::{commands, diagnose};
use smid::simulate::{self, SimulatedRecord};
use std::path::{Path, PathBuf};

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// Simulate `examples/fmu-effects.yaml` with the FMU's `effect` set.
fn fmu_record(effect: f64, seed: u64, length: usize) -> SimulatedRecord {
    let path = root().join("examples/fmu-effects.yaml");
    let mut spec = smid::load_spec(&path).unwrap();
    spec.plant.parameters.insert("effect".into(), effect);
    let mut plant = smid::fmu::from_spec(&spec.plant, &root().join("examples")).unwrap();
    simulate::simulate_with_plant(&spec, &mut plant, Some(length), Some(seed), 1.0).unwrap()
}

/// (named tag, Δ*_holdout / Δ before, after).
fn diagnose_fmu(effect: f64, dir: &Path) -> (Option<String>, f64, f64) {
    let train = dir.join(format!("train-{effect}.csv"));
    let hold = dir.join(format!("holdout-{effect}.csv"));
    simulate::write_csv(&fmu_record(effect, 1, 400), &train).unwrap();
    simulate::write_csv(&fmu_record(effect, 2, 300), &hold).unwrap();
    let spec = root().join("examples/fmu-effects-diagnose.yaml");
    let (s, tr, ho) = commands::load(&spec, Some(&train), Some(&hold)).unwrap();
    assert_eq!((tr[0].y.len(), ho[0].y.len()), (400, 300));
    let d = diagnose::diagnose(&s, &tr, &ho, |_, _| {}).unwrap();
    (
        d.added_tags.first().cloned(),
        d.before.dstar_holdout / d.before.delta,
        d.after.dstar_holdout / d.after.delta,
    )
}

#[test]
fn diagnosis_names_each_fmu_effect_and_the_error_after_is_at_the_noise_level() {
    let dir = tempfile::tempdir().unwrap();
    for (effect, tag) in [(1.0, "offset"), (2.0, "drift"), (3.0, "delay")] {
        let (named, before, after) = diagnose_fmu(effect, dir.path());
        assert_eq!(named.as_deref(), Some(tag), "effect {effect}");
        assert!(before > 1.2, "effect {effect}: before Δ*/Δ = {before}");
        assert!(after <= 1.2, "effect {effect}: after Δ*/Δ = {after}");
    }
    let (named, before, after) = diagnose_fmu(0.0, dir.path());
    assert_eq!(named, None, "no effect in the FMU, but one was added");
    assert!(before <= 1.2 && after <= 1.2, "{before} {after}");
}

#[test]
fn simulate_runs_the_builtin_simulator_and_adds_bounded_noise() {
    let path = root().join("examples/paper.yaml");
    let r = simulate::simulate_spec_file(&path, Some(200), Some(7)).unwrap();
    assert_eq!(r.u.len(), 200);
    let spec = smid::load_spec(&path).unwrap();
    let mut plant = smid::core::pipeline::builtin_plant(&spec).unwrap();
    let w = smid::core::plant::Plant::run(&mut plant, &r.u).unwrap();
    assert_eq!(r.w, w);
    assert!(r.y.iter().zip(&w).all(|(y, w)| (y - w).abs() <= r.added));
    assert!(r.y.iter().zip(&w).any(|(y, w)| y != w), "no noise added");
    // Same seed, same record; another seed, another PRBS.
    assert_eq!(
        r,
        simulate::simulate_spec_file(&path, Some(200), Some(7)).unwrap()
    );
    assert_ne!(
        r.u,
        simulate::simulate_spec_file(&path, Some(200), Some(8))
            .unwrap()
            .u
    );
    let csv = simulate::to_csv(&r);
    assert!(csv.starts_with("t,u,y,w\n"));
    assert_eq!(csv.lines().count(), 201);
}

#[test]
fn simulate_refuses_a_measured_data_plant() {
    let dir = tempfile::tempdir().unwrap();
    let spec = dir.path().join("data.yaml");
    std::fs::write(
        &spec,
        "plant: { data: { steady_state: { file: s.csv, u: u, y: y }, dynamic: { file: d.csv, u: u, y: y } } }\nnoise: { delta: 0.01 }\nexperiment: { filter: { pole: 0.8 } }\nmodel: { nonlinearity: { type: output_backlash }, na: 2, nb: 2 }\nmethod: { alpha: zero }\n",
    )
    .unwrap();
    let e = simulate::simulate_spec_file(&spec, None, None).unwrap_err();
    assert!(e.to_string().contains("cannot be simulated"), "{e}");
}
