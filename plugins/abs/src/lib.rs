//! # smid-abs
//!
//! The absolute value `w = |x|` (`type: abs`, no parameters), on either side of the linear
//! block: a sensor that cannot tell the direction of motion (a pulse counter, a tachometer
//! without quadrature), a rectifier.
//!
//! * On the input side (Hammerstein) it is a static map like any other: `v = |u|`, exact.
//! * On the output side (Wiener) it cannot be inverted sample by sample. A measurement
//!   `y ± Δη` with `y - Δη > 0` says `x ∈ [y-Δη, y+Δη]` **or** `x ∈ -[y-Δη, y+Δη]`, two
//!   intervals ([`InnerKind::Mirrored`]); where `y - Δη <= 0` the preimage is the one interval
//!   `[-(y+Δη), y+Δη]`. The pipeline's sign search decides the mirrored samples' signs pattern
//!   by pattern and bounds the hull of the patterns that survive, so the bounds stay guaranteed.
//!   A measurement below `-Δη` is no output of `|·|`: the sample is named as inconsistent.
//!
//! With the linear block's gain free (no unit gain) the set holds `(a, b)` and `(a, -b)`
//! alike: `|·|` cannot tell them apart. The unit gain (eq 8) keeps the positive one.
#![forbid(unsafe_code)]
#![warn(missing_docs)]

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};
use smid_core::prelude::*;

/// `w = |x|` (simulation).
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Abs {}

#[typetag::serde(name = "abs")]
impl Nonlinearity for Abs {
    fn step(&self, _memory: &mut Vec<f64>, x: f64) -> f64 {
        x.abs()
    }
}

/// The absolute value as a model structure (no options).
#[derive(Debug, Clone, Default, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct AbsModel {}

/// The set of the absolute value: one map, no parameters.
#[derive(Debug, Clone, Copy, Default, Serialize, Deserialize)]
pub struct AbsSet {}

#[typetag::serde(name = "abs")]
impl NonlinearityModel for AbsModel {
    /// No parameter to bound: the points are checked and the one map returned.
    fn bound_steady_state(&self, data: &SteadyStateData) -> Result<Box<dyn NonlinearitySet>> {
        data.validate()?;
        Ok(Box::new(AbsSet {}))
    }
    fn supports(&self, _structure: Structure) -> bool {
        true
    }
    /// No parameter: the empty box is the one map.
    fn set_from_box(&self, cell: &[Interval]) -> Result<Box<dyn NonlinearitySet>> {
        if cell.is_empty() {
            Ok(Box::new(AbsSet {}))
        } else {
            Err(SmidError::invalid(
                "model.prior",
                format!(
                    "`abs` has no parameters, got a box of {} interval(s)",
                    cell.len()
                ),
            ))
        }
    }
    /// The containment check (`smid check --plugin abs_input` / `abs_output`): steady-state
    /// amplitudes 0.2 to 3 and a unit PRBS (whose inner signal changes sign many times; of 8
    /// levels on the input side, see `check_levels`).
    fn check_draw(&self, _s: Structure, _rng: &mut dyn RngCore) -> Option<CheckDraw> {
        Some(CheckDraw {
            nonlinearity: Box::new(Abs {}),
            model: Box::new(AbsModel {}),
            steady: (0.2, 3.0),
            amplitude: 1.0,
        })
    }
    /// On the input side a binary PRBS `±a` would enter the linear block as the constant `a`:
    /// 8 levels there, the binary PRBS on the output side.
    fn check_levels(&self, structure: Structure) -> usize {
        match structure {
            Structure::Hammerstein => 8,
            Structure::Wiener => 2,
        }
    }
}

/// The preimage of `w ∈ [lo, hi]` under `|·|`, sample `t`: two mirrored intervals, one
/// interval across zero, or an inconsistency when `hi < 0`.
fn preimage(t: usize, lo: f64, hi: f64) -> Result<InnerBound> {
    if hi < 0.0 {
        return Err(SmidError::inconsistent(
            Stage::InnerSignal,
            t,
            format!(
                "sample {t}: an output of |·| is >= 0, but the measurement allows at most {hi:e}"
            ),
        ));
    }
    Ok(if lo > 0.0 {
        InnerBound::mirrored(Interval::new(lo, hi).outward())
    } else {
        InnerBound {
            interval: Interval::new(-hi, hi).outward(),
            kind: InnerKind::Inverted,
        }
    })
}

/// `|·|` of an interval.
fn abs_of(i: Interval) -> Interval {
    let (a, b) = (i.lo.abs(), i.hi.abs());
    if i.lo <= 0.0 && i.hi >= 0.0 {
        Interval::new(0.0, a.max(b))
    } else {
        Interval::new(a.min(b), a.max(b))
    }
}

#[typetag::serde(name = "abs")]
impl NonlinearitySet for AbsSet {
    fn parameters(&self) -> Vec<ParameterBound> {
        Vec::new()
    }
    fn invert(&self, y: &[f64], dy: &[f64]) -> Result<Vec<InnerBound>> {
        check_outputs(y, dy)?;
        y.iter()
            .zip(dy)
            .enumerate()
            .map(|(t, (&y, &d))| preimage(t, y - d, y + d))
            .collect()
    }
    fn propagate(&self, u: &[f64]) -> Result<Vec<InnerBound>> {
        propagate_static(u, |u| Interval::new(u.abs(), u.abs()))
    }
    fn propagate_intervals(&self, v: &[Interval]) -> Result<Vec<InnerBound>> {
        if let Some(t) = v.iter().position(|i| !i.is_finite()) {
            return Err(SmidError::invalid(
                format!("dynamic sample {t}"),
                "a block of the input chain received an unknown input",
            ));
        }
        Ok(v.iter()
            .map(|&i| InnerBound {
                interval: abs_of(i).outward(),
                kind: InnerKind::Inverted,
            })
            .collect())
    }
    /// Memoryless: `|x|` over the interval.
    fn output_range(&self, x: Interval) -> Option<Interval> {
        Some(abs_of(x))
    }
    /// The steady input is `±` the steady output: the hull of both.
    fn invert_steady(&self, y: f64, dy: f64) -> Result<Interval> {
        Ok(preimage(0, y - dy, y + dy)?.hull())
    }
    fn propagate_steady(&self, u: f64) -> Result<Interval> {
        Ok(Interval::new(u.abs(), u.abs()))
    }
}

smid_core::register_nonlinearity!("abs", Abs, Abs {});
smid_core::register_model!("abs", AbsModel, AbsModel {});

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn cases() -> u32 {
        std::env::var("PROPTEST_CASES")
            .ok()
            .and_then(|v| v.parse().ok())
            .unwrap_or(64)
    }

    #[test]
    fn a_negative_measurement_beyond_the_noise_is_named() {
        let set = AbsSet {};
        match set.invert(&[0.5, -0.2, 0.1], &[0.05; 3]) {
            Err(SmidError::Inconsistent(f)) => assert_eq!(f.sample, 1),
            other => panic!("expected an inconsistency at sample 1, got {other:?}"),
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(cases()))]
        /// Every true input lies in its sample's preimage (one of the two mirrored intervals,
        /// or the one across zero), its hull holds it, and the propagations hold `|x|`.
        #[test]
        fn the_truth_lies_in_every_preimage_and_every_propagation(
            x in proptest::collection::vec(-3.0f64..3.0, 1..60),
            d in 1e-4f64..0.5,
            noise in proptest::collection::vec(-1.0f64..=1.0, 1..16),
        ) {
            let set = AbsSet {};
            let w = Abs {}.simulate(&x);
            let y: Vec<f64> = w.iter().enumerate().map(|(i, w)| w + d * noise[i % noise.len()]).collect();
            for (t, b) in set.invert(&y, &vec![d; y.len()]).unwrap().iter().enumerate() {
                let inside = b.interval.contains(x[t])
                    || (b.kind == InnerKind::Mirrored && b.interval.contains(-x[t]));
                prop_assert!(inside, "x[{t}] = {} outside {:?}", x[t], b);
                prop_assert!(b.hull().contains(x[t]));
                if b.kind == InnerKind::Mirrored {
                    prop_assert!(b.with_sign(x[t] >= 0.0).interval.contains(x[t]));
                }
            }
            for (t, b) in set.propagate(&x).unwrap().iter().enumerate() {
                prop_assert!(b.interval.contains(w[t]));
            }
            let iv: Vec<Interval> = x.iter().map(|&v| Interval::new(v - d, v + d)).collect();
            for (t, b) in set.propagate_intervals(&iv).unwrap().iter().enumerate() {
                prop_assert!(b.interval.contains(w[t]), "|x[{t}]| = {} outside {:?}", w[t], b.interval);
            }
        }
    }
}
