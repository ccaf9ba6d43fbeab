//! The bundled FMUs driven by smid's host (`FmuPlant`) against smid's own simulator and against
//! their documented behaviour.
mod common;
use common::*;
use smid_core::plant::Plant;

#[test]
fn paper_fmu_matches_builtin_simulator_bit_for_bit() {
    let u = test_input(5000);
    let mut plant = bundled("paper", "w", 1.0, paper_params());
    let w = plant.run(&u).unwrap();
    let host = host_paper(&paper_params(), &u);
    assert_eq!(max_abs_diff(&w, &host), 0.0);
    // The backlash really acts: the output holds in the dead band sometimes.
    assert!(w.windows(2).filter(|p| p[0] == p[1]).count() > 100);
}

#[test]
fn paper_fmu_parameters_are_set_from_the_spec() {
    let mut p = paper_params();
    p.insert("a1".into(), -0.3);
    p.insert("a2".into(), 0.1);
    p.insert("b0".into(), 0.2);
    p.insert("b1".into(), 0.3);
    p.insert("b2".into(), 0.3);
    p.insert("m_l".into(), 1.1);
    p.insert("c_l".into(), 0.2);
    p.insert("m_r".into(), 0.9);
    p.insert("c_r".into(), 0.1);
    let u = test_input(3000);
    let mut plant = bundled("paper", "w", 0.01, p.clone());
    let w = plant.run(&u).unwrap();
    assert_eq!(max_abs_diff(&w, &host_paper(&p, &u)), 0.0);
    // And it differs from the defaults, so the parameters did reach the FMU.
    assert!(max_abs_diff(&w, &host_paper(&paper_params(), &u)) > 0.1);
}

#[test]
fn every_run_starts_from_rest() {
    let u = test_input(800);
    let mut plant = bundled("paper", "w", 1.0, paper_params());
    let first = plant.run(&u).unwrap();
    let _ = plant.run(&vec![3.0; 100]).unwrap();
    let again = plant.run(&u).unwrap();
    assert_eq!(first, again);
    assert!(plant.run(&[]).unwrap().is_empty());
}

#[test]
fn paper_effects_fmu_adds_each_effect() {
    let u = test_input(1000);
    let host = host_paper(&paper_params(), &u);
    let with = |effect: f64| {
        let mut p = paper_params();
        p.insert("effect".into(), effect);
        p.insert("offset".into(), 0.02);
        p.insert("drift".into(), 1e-4);
        bundled("paper_effects", "y", 1.0, p).run(&u).unwrap()
    };
    assert_eq!(max_abs_diff(&with(0.0), &host), 0.0);
    let off = with(1.0);
    assert!(off
        .iter()
        .zip(&host)
        .all(|(y, w)| (y - w - 0.02).abs() < 1e-12));
    let drift = with(2.0);
    assert!(drift.iter().zip(&host).enumerate().all(|(k, (y, w))| (y
        - w
        - (0.02 + 1e-4 * k as f64))
        .abs()
        < 1e-12));
    let delay = with(3.0);
    assert_eq!(delay[0], 0.0);
    assert_eq!(&delay[1..], &host[..host.len() - 1]);
}

#[test]
fn drive_fmu_behaves_like_a_backlash_drive() {
    let h = 0.01;
    let mut plant = bundled("drive", "y", h, Default::default());
    let q = 2.0 * std::f64::consts::PI / 65536.0;
    // Up to 1, then down to 0.5: the load lags the gear output by the half gap (0.05) on the
    // side of the last motion.
    let u: Vec<f64> = (0..1200).map(|k| if k < 600 { 1.0 } else { 0.5 }).collect();
    let y = plant.run(&u).unwrap();
    assert!(
        y.iter().all(|v| (v / q - (v / q).round()).abs() < 1e-6),
        "quantized"
    );
    assert!((y[599] - 0.95).abs() < 2e-3, "after rising: {}", y[599]);
    assert!((y[1199] - 0.55).abs() < 2e-3, "after falling: {}", y[1199]);
    // The true load angle and the gear output are there too.
    let mut x = bundled("drive", "x", h, Default::default());
    let xs = x.run(&u).unwrap();
    assert!((xs[599] - 1.0).abs() < 1e-3 && (xs[1199] - 0.5).abs() < 1e-3);
    // Its parameters are settable: a 10-bit encoder gives coarser readings.
    let mut p = std::collections::BTreeMap::new();
    p.insert("encoder_bits".to_string(), 10.0);
    let coarse = bundled("drive", "y", h, p).run(&u).unwrap();
    let q10 = 2.0 * std::f64::consts::PI / 1024.0;
    assert!(coarse
        .iter()
        .all(|v| (v / q10 - (v / q10).round()).abs() < 1e-6));
    assert!(max_abs_diff(&coarse, &y) > 1e-4);
}
