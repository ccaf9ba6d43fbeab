//! # smid-bias
//!
//! A constant bias `v = x + d` (`type: bias`): the zero offset of an actuator's command or of a
//! sensor, as a block of a chain on either side of the identified linear block, or as the
//! nonlinearity of a Wiener or Hammerstein model.
//!
//! * **Steady state (stage 1, eqs 13-20 in one dimension):** under unit gain (eq 8) the block
//!   sees `ū` at rest (`ū ± du` behind input blocks), so each point gives
//!   `d ∈ [ȳ - Δη̄ - ū - du, ȳ + Δη̄ - ū + du]`; the set is the intersection. A bias has no
//!   memory, so the overshoot allowance α does not enter.
//! * **Inversion (output side):** `x = w - d`, `w ∈ [y - Δη, y + Δη]`, over `d ∈ [d0, d1]`:
//!   `[y - Δη - d1, y + Δη - d0]`.
//! * **Propagation (input side):** `[u + d0, u + d1]`; monotone, so interval inputs go through
//!   at their ends.
//! * **The designed experiment:** a shift of the square wave keeps the filtered steps free of
//!   overshoot, so steady-state points pass a bias on the input side to the polygons of the
//!   nonlinearity after it (with `du` = the cell's radius).
//!
//! Through the unit-gain linear block (eq 8) an input bias `d` is a constant term
//! `c = B(1)·d` of the linear equation (the `constant` effect), and an output bias after a
//! static map is a sensor offset: the diagnosis reports such pairs as equivalent where the
//! training data cannot tell them apart.
#![forbid(unsafe_code)]
#![warn(missing_docs)]

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};
use smid_core::prelude::*;

/// `v = x + d` with a known `d` (simulation).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Bias {
    /// The bias `d` (finite, in the units of the signal it shifts).
    pub d: f64,
}

#[typetag::serde(name = "bias")]
impl Nonlinearity for Bias {
    fn step(&self, _memory: &mut Vec<f64>, x: f64) -> f64 {
        x + self.d
    }
    fn parameters(&self) -> Vec<(String, f64)> {
        vec![("d".into(), self.d)]
    }
    fn validate(&self) -> Result<()> {
        if self.d.is_finite() {
            Ok(())
        } else {
            Err(SmidError::invalid(
                "d",
                format!("expected a finite bias, got {}", self.d),
            ))
        }
    }
}

/// The bias as a block to identify (no options).
#[derive(Debug, Clone, Default, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct BiasModel {}

/// An interval of biases.
#[derive(Debug, Clone, Copy, Serialize, Deserialize)]
pub struct BiasSet {
    /// Guaranteed interval of the bias `d` (output units of the block).
    pub d: Interval,
}

#[typetag::serde(name = "bias")]
impl NonlinearityModel for BiasModel {
    fn bound_steady_state(&self, data: &SteadyStateData) -> Result<Box<dyn NonlinearitySet>> {
        data.validate()?;
        let mut d = Interval::entire();
        for p in &data.points {
            let here = Interval::new(p.y - p.dy - p.u - p.du, p.y + p.dy - p.u + p.du).outward();
            d = d.intersect(&here).ok_or_else(|| {
                SmidError::inconsistent(
                    Stage::SteadyState,
                    p.index,
                    "no bias d fits this sample and the ones before it",
                )
            })?;
        }
        if !d.is_finite() {
            return Err(SmidError::Unbounded {
                parameter: "d".into(),
                message: "no steady-state sample bounds the bias".into(),
            });
        }
        Ok(Box::new(BiasSet { d }))
    }
    fn supports(&self, _structure: Structure) -> bool {
        true
    }
    fn accepts_input_radius(&self) -> bool {
        true
    }
    /// `|d|` up to a quarter of the range the block sees.
    fn default_prior(&self, _s: Structure, seen: (f64, f64)) -> Option<Vec<Interval>> {
        let r = 0.25 * (seen.1 - seen.0);
        (r.is_finite() && r > 0.0).then(|| vec![Interval::new(-r, r)])
    }
    /// Half the noise bound, as a sensor offset's (at most the default): the bias moves the
    /// output by as much as it moves its input through a unit-gain block, and a cell as wide as
    /// the default (a 64th of the prior) would leave the set far wider than the data do.
    fn resolution(&self, prior: &[Interval], halvings: u32, delta: f64) -> Vec<f64> {
        let mut r = smid_core::nonlinearity::halved_widths(prior, halvings);
        if delta > 0.0 {
            r.iter_mut().for_each(|w| *w = w.min(0.5 * delta));
        }
        r
    }
    fn set_from_box(&self, cell: &[Interval]) -> Result<Box<dyn NonlinearitySet>> {
        match cell {
            [d] if d.lo <= d.hi && d.is_finite() => Ok(Box::new(BiasSet { d: *d })),
            _ => Err(SmidError::invalid(
                "d",
                "expected one finite interval lo <= hi for the bias",
            )),
        }
    }
    /// On either side: a bias in `[-0.5, 0.5)`, steady-state amplitudes 0.2 to 3, a unit PRBS.
    fn check_draw(&self, _s: Structure, rng: &mut dyn RngCore) -> Option<CheckDraw> {
        Some(CheckDraw {
            nonlinearity: Box::new(Bias {
                d: rng.gen_range(-0.5..0.5),
            }),
            model: Box::new(BiasModel {}),
            steady: (0.2, 3.0),
            amplitude: 1.0,
        })
    }
}

#[typetag::serde(name = "bias")]
impl NonlinearitySet for BiasSet {
    /// A shift of the square wave keeps its filtered steps free of overshoot.
    fn keeps_steady_design(&self) -> bool {
        true
    }
    fn monotone(&self) -> bool {
        true
    }
    fn parameters(&self) -> Vec<ParameterBound> {
        vec![ParameterBound {
            name: "d".into(),
            interval: self.d,
        }]
    }
    fn invert(&self, y: &[f64], dy: &[f64]) -> Result<Vec<InnerBound>> {
        check_outputs(y, dy)?;
        Ok(y.iter()
            .zip(dy)
            .map(|(&y, &e)| InnerBound {
                interval: Interval::new(y - e - self.d.hi, y + e - self.d.lo).outward(),
                kind: InnerKind::Inverted,
            })
            .collect())
    }
    fn propagate(&self, u: &[f64]) -> Result<Vec<InnerBound>> {
        Ok(u.iter()
            .map(|&u| InnerBound {
                interval: Interval::new(u + self.d.lo, u + self.d.hi).outward(),
                kind: InnerKind::Inverted,
            })
            .collect())
    }
}

smid_core::register_nonlinearity!("bias", Bias, Bias { d: 0.1 });
smid_core::register_model!("bias", BiasModel, BiasModel {});

/// The truth lies in the stage-1 set and in every inner-signal bound, for random biases,
/// amplitudes, input radii and noise inside its bound; a wrong bias is ruled out.
#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn cases() -> u32 {
        std::env::var("PROPTEST_CASES")
            .ok()
            .and_then(|v| v.parse().ok())
            .unwrap_or(32)
    }

    /// Steady-state points `ȳ = ū + d + η`, `|η| <= e`, the input known to `± du`.
    fn steady(d: f64, amps: &[f64], e: f64, du: f64, noise: &[f64]) -> SteadyStateData {
        let points = amps
            .iter()
            .flat_map(|&a| [a, -a])
            .enumerate()
            .map(|(i, u)| {
                let mut p = SteadyPoint::new(i, u, u + d + e * noise[i % noise.len()], e);
                // The true input sits anywhere in `u ± du`; the point reports the centre.
                p.u = u - du * noise[(i + 1) % noise.len()];
                p.du = du;
                p
            })
            .collect();
        SteadyStateData { points }
    }

    #[test]
    fn a_sample_no_bias_fits_is_named() {
        let mut data = steady(0.1, &[1.0], 0.01, 0.0, &[0.0]);
        data.points[1].y += 0.5;
        match (BiasModel {}).bound_steady_state(&data) {
            Err(SmidError::Inconsistent(smid_core::Falsification { sample, .. })) => {
                assert_eq!(sample, 1)
            }
            other => panic!("expected an inconsistency at sample 1, got {other:?}"),
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(cases()))]
        #[test]
        fn the_truth_is_in_the_set_and_in_every_inner_bound(
            d in -2.0f64..2.0,
            amps in proptest::collection::vec(0.1f64..3.0, 1..8),
            e in 1e-4f64..0.1,
            du in prop_oneof![Just(0.0), 0.0f64..0.05],
            noise in proptest::collection::vec(-1.0f64..=1.0, 1..16),
            x in proptest::collection::vec(-3.0f64..3.0, 1..40),
            wrong in 0.01f64..1.0,
        ) {
            let set = BiasModel {}.bound_steady_state(&steady(d, &amps, e, du, &noise)).unwrap();
            let i = set.parameters()[0].interval;
            prop_assert!(i.contains(d), "d = {d} outside {i:?}");
            // The set is no wider than one point's interval: 2(Δη + du) and rounding.
            prop_assert!(i.hi - i.lo <= 2.0 * (e + du) * (1.0 + 1e-9) + 1e-12, "{i:?}");
            let truth = Bias { d };
            let w = truth.simulate(&x);
            let y: Vec<f64> = w.iter().enumerate().map(|(t, w)| w + e * noise[t % noise.len()]).collect();
            for (t, b) in set.invert(&y, &vec![e; y.len()]).unwrap().iter().enumerate() {
                prop_assert!(b.interval.contains(x[t]), "x[{t}] = {} outside {:?}", x[t], b.interval);
            }
            for (t, b) in set.propagate(&x).unwrap().iter().enumerate() {
                prop_assert!(b.interval.contains(w[t]), "v[{t}] = {} outside {:?}", w[t], b.interval);
            }
            // A bias off by more than the set's width is outside it.
            let off = d + (i.hi - i.lo) + wrong;
            prop_assert!(!i.contains(off));
        }
    }
}
