//! # smid-filters
//!
//! Linear filter blocks for block chains (`smid_core::chain`): dynamics a sensor or an actuator
//! adds on either side of the identified linear block, their parameters bisected by the branch
//! and bound over a prior box like any other block's.
//!
//! * `lag`: the unit-gain first-order lag `s_t = p s_{t-1} + (1 - p) w_t`, `0 <= p < 1`, from
//!   rest (`s_{-1} = 0`).
//!   - **Output side (inversion):** `w_t = (s_t - p s_{t-1}) / (1 - p)` with `s_t = y_t - η_t`.
//!     For fixed `s` the map is monotone in `p` (its derivative has the sign of
//!     `s_t - s_{t-1}`), and for fixed `p` it is linear in `(s_t, s_{t-1})`, so its range over
//!     a cell `p ∈ [p1, p2]` and the two noise intervals is reached at the 8 corners. The
//!     noise enters twice: the result's radius is about `(1 + p) Δη / (1 - p)`. The first
//!     sample of a run (no `s_{t-1}`) is unknown.
//!   - **Input side (interval simulation):** `S_t = (1 - p) U_t + p S_{t-1}` has non-negative
//!     coefficients, so its lower end is the smaller of the two cell ends' values at the lower
//!     ends of `U_t` and `S_{t-1}` (linear in `p`), likewise the upper end: guaranteed for every
//!     `p` in the cell and every input in `U_t`. From rest.
//!   - **Steady state:** unit gain, so it passes steady-state points unchanged (stage 1 of the
//!     nonlinearity beside it still uses the polygons).
#![forbid(unsafe_code)]
#![warn(missing_docs)]

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};
use smid_core::prelude::*;

/// The unit-gain first-order lag with a known pole (simulation).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Lag {
    /// The pole `0 <= p < 1`.
    pub p: f64,
}

#[typetag::serde(name = "lag")]
impl Nonlinearity for Lag {
    fn step(&self, memory: &mut Vec<f64>, x: f64) -> f64 {
        if memory.is_empty() {
            memory.push(0.0);
        }
        let s = self.p * memory[0] + (1.0 - self.p) * x;
        memory[0] = s;
        s
    }
    fn initial_memory(&self) -> Vec<f64> {
        vec![0.0]
    }
    fn parameters(&self) -> Vec<(String, f64)> {
        vec![("p".into(), self.p)]
    }
    fn validate(&self) -> Result<()> {
        if self.p.is_finite() && (0.0..1.0).contains(&self.p) {
            Ok(())
        } else {
            Err(SmidError::invalid(
                "p",
                format!("expected a pole 0 <= p < 1, got {}", self.p),
            ))
        }
    }
}

/// The lag as a block to identify (no options).
#[derive(Debug, Clone, Default, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct LagModel {}

/// A cell of the pole.
#[derive(Debug, Clone, Copy, Serialize, Deserialize)]
pub struct LagSet {
    /// The cell's interval of the pole `p`, within `[0, 1)`.
    pub p: Interval,
}

#[typetag::serde(name = "lag")]
impl NonlinearityModel for LagModel {
    /// A unit-gain lag leaves no trace in steady-state data: it is always bisected.
    fn bound_steady_state(&self, _data: &SteadyStateData) -> Result<Box<dyn NonlinearitySet>> {
        Err(SmidError::Unsupported {
            plugin: "lag".into(),
            what: "bounds from steady-state data (a unit-gain lag has no steady-state signature): give its pole a prior box".into(),
        })
    }
    fn supports(&self, _structure: Structure) -> bool {
        true
    }
    /// Poles from 0 to 0.9 (a time constant up to about ten samples).
    fn default_prior(&self, _s: Structure, _seen: (f64, f64)) -> Option<Vec<Interval>> {
        Some(vec![Interval::new(0.0, 0.9)])
    }
    fn set_from_box(&self, cell: &[Interval]) -> Result<Box<dyn NonlinearitySet>> {
        match cell {
            [p] if p.lo >= 0.0 && p.lo <= p.hi && p.hi < 1.0 => Ok(Box::new(LagSet { p: *p })),
            _ => Err(SmidError::invalid(
                "p",
                "expected one interval 0 <= lo <= hi < 1 for the pole",
            )),
        }
    }
}

impl LagSet {
    /// `[min, max]` of `(s - p s_prev)/(1 - p)` over the cell and the two intervals.
    pub fn invert_pair(&self, s: Interval, prev: Interval) -> Interval {
        let mut lo = f64::INFINITY;
        let mut hi = f64::NEG_INFINITY;
        for p in [self.p.lo, self.p.hi] {
            for a in [s.lo, s.hi] {
                for b in [prev.lo, prev.hi] {
                    let w = (a - p * b) / (1.0 - p);
                    lo = lo.min(w);
                    hi = hi.max(w);
                }
            }
        }
        Interval::new(lo, hi).outward()
    }

    /// One step of the interval simulation.
    pub fn step(&self, state: Interval, u: Interval) -> Interval {
        let at = |p: f64, s: f64, u: f64| (1.0 - p) * u + p * s;
        let lo = at(self.p.lo, state.lo, u.lo).min(at(self.p.hi, state.lo, u.lo));
        let hi = at(self.p.lo, state.hi, u.hi).max(at(self.p.hi, state.hi, u.hi));
        Interval::new(lo, hi).outward()
    }
}

#[typetag::serde(name = "lag")]
impl NonlinearitySet for LagSet {
    /// Linear with a nonnegative impulse response: the designed square wave stays overshoot-free.
    fn keeps_steady_design(&self) -> bool {
        true
    }
    fn parameters(&self) -> Vec<ParameterBound> {
        vec![ParameterBound {
            name: "p".into(),
            interval: self.p,
        }]
    }
    fn invert(&self, y: &[f64], dy: &[f64]) -> Result<Vec<InnerBound>> {
        check_outputs(y, dy)?;
        let s = |t: usize| Interval::new(y[t] - dy[t], y[t] + dy[t]);
        Ok((0..y.len())
            .map(|t| {
                if t == 0 {
                    InnerBound::unknown()
                } else {
                    InnerBound {
                        interval: self.invert_pair(s(t), s(t - 1)),
                        kind: InnerKind::Inverted,
                    }
                }
            })
            .collect())
    }
    fn propagate(&self, u: &[f64]) -> Result<Vec<InnerBound>> {
        let v: Vec<Interval> = u.iter().map(|&u| Interval::new(u, u)).collect();
        self.propagate_intervals(&v)
    }
    fn propagate_intervals(&self, v: &[Interval]) -> Result<Vec<InnerBound>> {
        let mut state = Interval::new(0.0, 0.0);
        v.iter()
            .enumerate()
            .map(|(t, &u)| {
                if !u.is_finite() {
                    return Err(SmidError::invalid(
                        format!("dynamic sample {t}"),
                        "non-finite input to a lag",
                    ));
                }
                state = self.step(state, u);
                Ok(InnerBound {
                    interval: state,
                    kind: InnerKind::Inverted,
                })
            })
            .collect()
    }
    fn monotone(&self) -> bool {
        true
    }
    fn invert_steady(&self, y: f64, dy: f64) -> Result<Interval> {
        Ok(Interval::new(y - dy, y + dy).outward())
    }
    fn propagate_steady(&self, u: f64) -> Result<Interval> {
        Ok(Interval::new(u, u))
    }
}

smid_core::register_nonlinearity!("lag", Lag, Lag { p: 0.6 });
smid_core::register_model!("lag", LagModel, LagModel {});

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        /// Every pole of a cell, every noise sequence inside its bound: the inversion holds the
        /// lag's true input, and the interval simulation its true output.
        #[test]
        fn inversion_and_simulation_hold_every_member(
            p1 in 0.0f64..0.95, width in 0.0f64..0.05, frac in 0.0f64..1.0,
            w in proptest::collection::vec(-3.0f64..3.0, 2..60),
            noise in proptest::collection::vec(-1.0f64..1.0, 60),
            delta in 0.0f64..0.1,
        ) {
            let p2 = (p1 + width).min(0.99);
            let p = p1 + frac * (p2 - p1);
            let set = LagSet { p: Interval::new(p1, p2) };
            let s = Lag { p }.simulate(&w);
            let y: Vec<f64> = s.iter().zip(&noise).map(|(s, e)| s + delta * e).collect();
            let inv = set.invert(&y, &vec![delta; y.len()]).unwrap();
            prop_assert_eq!(inv[0].kind, InnerKind::Unknown);
            for t in 1..w.len() {
                prop_assert!(inv[t].interval.contains(w[t]), "t = {}: {:?} misses {}", t, inv[t], w[t]);
            }
            let fw = set.propagate(&w).unwrap();
            for t in 0..w.len() {
                prop_assert!(fw[t].interval.contains(s[t]), "t = {}: {:?} misses {}", t, fw[t], s[t]);
            }
            // Interval inputs holding w: the simulation of w is inside.
            let iv: Vec<Interval> = w.iter().map(|&v| Interval::new(v - 0.1, v + 0.2)).collect();
            let fi = set.propagate_intervals(&iv).unwrap();
            for t in 0..w.len() {
                prop_assert!(fi[t].interval.contains(s[t]));
            }
        }
    }

    #[test]
    fn bad_cells_and_poles_are_errors_naming_p() {
        assert!(LagModel {}
            .set_from_box(&[Interval::new(0.5, 1.0)])
            .is_err());
        assert!(LagModel {}
            .set_from_box(&[Interval::new(-0.1, 0.5)])
            .is_err());
        let e = Lag { p: 1.0 }.validate().unwrap_err().to_string();
        assert!(e.contains('p') && e.contains("0 <= p < 1"), "{e}");
    }
}
