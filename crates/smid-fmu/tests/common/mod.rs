//! Helpers shared by the smid-fmu integration tests: the paper system on the host side, a
//! deterministic test input, and loading bundled FMUs.
#![allow(dead_code)]
use smid_core::linear::LinearModel;
use smid_core::nonlinearity::Nonlinearity;
use smid_fmu::{FmuConfig, FmuPlant};
use smid_output_backlash::Backlash;
use std::collections::BTreeMap;

/// Paper Section 6 system (linear block, backlash) with the FMU's parameter names.
pub fn paper_params() -> BTreeMap<String, f64> {
    [
        ("a1", 0.5),
        ("a2", 0.7),
        ("b0", 0.0),
        ("b1", 1.4),
        ("b2", 0.8),
        ("m_l", 0.248),
        ("c_l", 0.0698),
        ("m_r", 0.252),
        ("c_r", 0.0349),
    ]
    .into_iter()
    .map(|(k, v)| (k.to_string(), v))
    .collect()
}

/// smid's built-in simulator on `u` for parameters `p` (names as in [`paper_params`]).
pub fn host_paper(p: &BTreeMap<String, f64>, u: &[f64]) -> Vec<f64> {
    let lin = LinearModel {
        a: vec![p["a1"], p["a2"]],
        b: vec![p["b0"], p["b1"], p["b2"]],
    };
    let bl = Backlash {
        m_l: p["m_l"],
        c_l: p["c_l"],
        m_r: p["m_r"],
        c_r: p["c_r"],
    };
    bl.simulate(&lin.simulate(u))
}

/// A deterministic, rich test input: a held pseudo-random sequence plus slow ramps.
pub fn test_input(n: usize) -> Vec<f64> {
    let mut s: u64 = 0x9e3779b97f4a7c15;
    let mut v = 0.0;
    (0..n)
        .map(|k| {
            if k % 7 == 0 {
                s ^= s << 13;
                s ^= s >> 7;
                s ^= s << 17;
                v = (s >> 11) as f64 / (1u64 << 53) as f64 * 6.0 - 3.0;
            }
            v + 0.5 * ((k as f64) * 0.01).sin()
        })
        .collect()
}

/// Load a bundled FMU.
pub fn bundled(name: &str, output: &str, step: f64, params: BTreeMap<String, f64>) -> FmuPlant {
    FmuPlant::load(&FmuConfig {
        path: smid_fmu::bundled_fmu(name),
        label: None,
        input: Some("u".into()),
        output: Some(output.into()),
        step: Some(step),
        parameters: params,
    })
    .unwrap_or_else(|e| panic!("{e}"))
}

pub fn max_abs_diff(a: &[f64], b: &[f64]) -> f64 {
    assert_eq!(a.len(), b.len());
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max)
}
