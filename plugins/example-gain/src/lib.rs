//! # smid-example-gain
//!
//! The smallest complete smid plugin, the worked example of the guide's `docs/extending.md`:
//! a pure gain `w = k x` (`type: example_gain`, `k > 0`), on either side of the linear block.
//! It adds a nonlinearity to smid without touching `smid-core`:
//!
//! * simulation ([`Gain`], a [`Nonlinearity`]);
//! * stage 1 ([`GainModel`]): under unit gain (eq 8) each steady-state sample gives
//!   `ȳ = k ū + η̄`, so `k` lies in `[(ȳ-Δη)/ū, (ȳ+Δη)/ū]` (ordered); the feasible set is the
//!   intersection of these intervals (the one-dimensional analogue of constraints (16)-(17));
//! * stage 2 ([`GainSet`]): inversion `x = w/k` over `k` in its interval and `w = y ± Δη`
//!   (monotone in both, so the ends suffice, as in Prop 4), or propagation `v = k u`;
//! * its random containment trial ([`GainModel`]'s `check_draw`), which makes it a case of
//!   `smid check --plugin` and of the band tests with no edit elsewhere;
//! * registration of its `type` for the spec's JSON Schema ([`smid_core::register_nonlinearity!`]).
#![forbid(unsafe_code)]
#![warn(missing_docs)]

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};
use smid_core::prelude::*;

/// `w = k x` with known `k` (simulation).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Gain {
    /// The gain `k > 0`.
    pub k: f64,
}

#[typetag::serde(name = "example_gain")]
impl Nonlinearity for Gain {
    fn step(&self, _memory: &mut Vec<f64>, x: f64) -> f64 {
        self.k * x
    }
    /// Behind a gain `g`: the gain divides by it.
    fn behind_gain(&self, g: f64) -> Option<Vec<(String, f64)>> {
        (g.is_finite() && g > 0.0).then(|| vec![("k".into(), self.k / g)])
    }
    fn parameters(&self) -> Vec<(String, f64)> {
        vec![("k".into(), self.k)]
    }
    fn validate(&self) -> Result<()> {
        if self.k.is_finite() && self.k > 0.0 {
            Ok(())
        } else {
            Err(SmidError::invalid(
                "k",
                format!("expected a finite number > 0, got {}", self.k),
            ))
        }
    }
}

/// The gain as a model structure (no options).
#[derive(Debug, Clone, Default, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct GainModel {}

/// The feasible interval of `k`.
#[derive(Debug, Clone, Copy, Serialize, Deserialize)]
pub struct GainSet {
    /// Guaranteed interval of the gain `k`.
    pub k: Interval,
}

#[typetag::serde(name = "example_gain")]
impl NonlinearityModel for GainModel {
    fn bound_steady_state(&self, data: &SteadyStateData) -> Result<Box<dyn NonlinearitySet>> {
        // The core's one check of the points (invariant 6), not a copy.
        data.validate()?;
        let mut k = Interval::new(0.0, f64::INFINITY);
        for p in &data.points {
            if p.u == 0.0 {
                continue;
            }
            let (a, b) = ((p.y - p.dy) / p.u, (p.y + p.dy) / p.u);
            let here = Interval::new(a.min(b), a.max(b)).outward();
            k = k.intersect(&here).ok_or_else(|| {
                SmidError::inconsistent(
                    Stage::SteadyState,
                    p.index,
                    "no gain k > 0 fits this sample and the ones before it",
                )
            })?;
        }
        if !(k.is_finite() && k.lo > 0.0) {
            return Err(SmidError::Unbounded {
                parameter: "k".into(),
                message: "the steady-state samples do not bound k away from 0 and infinity".into(),
            });
        }
        Ok(Box::new(GainSet { k }))
    }
    fn supports(&self, _structure: Structure) -> bool {
        true
    }
    /// Any record, no steady-state data: `k` in a cell `[k0, k1]` (`k0 > 0`) is a gain set as
    /// it stands; its inversion takes the extremes at the ends, valid for every `k` in the cell.
    fn set_from_box(&self, cell: &[Interval]) -> Result<Box<dyn NonlinearitySet>> {
        match cell {
            [k] if k.lo > 0.0 && k.lo <= k.hi && k.hi.is_finite() => {
                Ok(Box::new(GainSet { k: *k }))
            }
            _ => Err(SmidError::invalid(
                "model.prior.k",
                "expected one finite interval 0 < lo <= hi",
            )),
        }
    }
    /// The containment check (`smid check --plugin example_gain_input` / `_output`): a gain in
    /// `[0.5, 2)` on either side, steady-state amplitudes 0.2 to 3, a unit PRBS.
    fn check_draw(&self, _s: Structure, rng: &mut dyn RngCore) -> Option<CheckDraw> {
        Some(CheckDraw {
            nonlinearity: Box::new(Gain {
                k: rng.gen_range(0.5..2.0),
            }),
            model: Box::new(GainModel {}),
            steady: (0.2, 3.0),
            amplitude: 1.0,
        })
    }
}

#[typetag::serde(name = "example_gain")]
impl NonlinearitySet for GainSet {
    /// Linear with a nonnegative impulse response: the designed square wave stays overshoot-free.
    fn keeps_steady_design(&self) -> bool {
        true
    }
    /// Order-preserving (k > 0: nondecreasing), so a chain may feed it interval inputs.
    fn monotone(&self) -> bool {
        true
    }
    fn parameters(&self) -> Vec<ParameterBound> {
        vec![ParameterBound {
            name: "k".into(),
            interval: self.k,
        }]
    }
    fn invert(&self, y: &[f64], dy: &[f64]) -> Result<Vec<InnerBound>> {
        check_outputs(y, dy)?;
        let k = self.k;
        Ok(y.iter()
            .zip(dy)
            .map(|(&y, &d)| {
                let ends = [y - d, y + d].into_iter();
                let x = ends.flat_map(|w| [w / k.lo, w / k.hi]);
                match Interval::hull_of(x) {
                    Some(i) => InnerBound {
                        interval: i.outward(),
                        kind: InnerKind::Inverted,
                    },
                    None => InnerBound::unknown(),
                }
            })
            .collect())
    }
    fn propagate(&self, u: &[f64]) -> Result<Vec<InnerBound>> {
        let k = self.k;
        Ok(u.iter()
            .map(|&u| match Interval::hull_of([k.lo * u, k.hi * u]) {
                Some(i) => InnerBound {
                    interval: i.outward(),
                    kind: InnerKind::Inverted,
                },
                None => InnerBound::unknown(),
            })
            .collect())
    }
}

smid_core::register_nonlinearity!("example_gain", Gain, Gain { k: 2.0 });
smid_core::register_model!("example_gain", GainModel, GainModel {});

/// The tests every plugin carries (docs/extending.md), for the worked example: the truth lies
/// in the stage-1 set and in every inner-signal bound, for random gains, amplitudes and noise inside its bound.
#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn cases() -> u32 {
        std::env::var("PROPTEST_CASES")
            .ok()
            .and_then(|v| v.parse().ok())
            .unwrap_or(16)
    }

    /// Steady-state points `ȳ = k ū + η`, `|η| <= d`, at `±` each amplitude.
    fn steady(k: f64, amps: &[f64], d: f64, noise: &[f64]) -> SteadyStateData {
        let points = amps
            .iter()
            .flat_map(|&a| [a, -a])
            .enumerate()
            .map(|(i, u)| SteadyPoint::new(i, u, k * u + d * noise[i % noise.len()], d))
            .collect();
        SteadyStateData { points }
    }

    #[test]
    fn a_sample_no_gain_fits_is_named() {
        // Two samples 1 apart in gain with a bound of 0.01: no k > 0 fits both.
        let mut data = steady(1.0, &[1.0], 0.01, &[0.0]);
        data.points[1].y = -2.0;
        match (GainModel {}).bound_steady_state(&data) {
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
            k in 0.2f64..5.0,
            amps in proptest::collection::vec(0.1f64..3.0, 1..8),
            d in 1e-4f64..0.1,
            noise in proptest::collection::vec(-1.0f64..=1.0, 1..16),
            x in proptest::collection::vec(-3.0f64..3.0, 1..40),
        ) {
            let set = GainModel {}.bound_steady_state(&steady(k, &amps, d, &noise)).unwrap();
            let interval = set.parameters()[0].interval;
            prop_assert!(interval.contains(k), "k = {k} outside {interval:?}");
            let truth = Gain { k };
            let w = truth.simulate(&x);
            let y: Vec<f64> = w.iter().enumerate().map(|(i, w)| w + d * noise[i % noise.len()]).collect();
            for (t, b) in set.invert(&y, &vec![d; y.len()]).unwrap().iter().enumerate() {
                prop_assert!(b.interval.contains(x[t]), "x[{t}] = {} outside {:?}", x[t], b.interval);
            }
            for (t, b) in set.propagate(&x).unwrap().iter().enumerate() {
                prop_assert!(b.interval.contains(w[t]), "v[{t}] = {} outside {:?}", w[t], b.interval);
            }
        }
    }
}
