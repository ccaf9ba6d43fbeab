//! # smid-input-backlash
//!
//! Backlash at the input of the linear block (Hammerstein, `w = G(N(u))`) as a smid plugin
//! (`type: input_backlash`), after Cerone & Regruto, "Bounding the parameters of linear systems
//! with input backlash", IEEE TAC 52(3), 2007. The backlash is the map of paper eq (2)-(3)
//! (with `x_t` the known input `u_t` and `v_t` the unmeasured inner signal).
//!
//! * **Stage 1.** Under unit gain (eq 8) the steady state is `ȳ = m_r(ū - c_r)` after a rising
//!   half-wave and `ȳ = m_l(ū + c_l)` after a falling one (eqs 11-12 with the same branches),
//!   so the exact polygons of the output-backlash plugin
//!   ([`smid_output_backlash::branch_polygons`]) apply. The overshoot allowance `α` of
//!   eqs (14)-(15) is set to 0: here the backlash sees the filtered square wave itself, whose
//!   first-order step response is monotone (no overshoot by construction, Section 3.1), so the
//!   play ends on the branch of the last move; the linear block after it only scales a constant
//!   by its unit gain, whatever its transient. (Assumption, as in the paper: each half-wave
//!   crosses the play, `ū > c` on both sides.)
//! * **Stage 2 (propagation).** The inner signal is the backlash driven by the known input.
//!   With `L = m_l(u + c_l)` and `R = m_r(u - c_r)`, eq (2) reads
//!   `v = L if v_prev >= L; R if v_prev <= R; v_prev otherwise`. Two monotone envelopes bound it
//!   for every state and parameter:
//!   `f = min(L, max(R, v_prev)) <= v <= g = max(R, min(L, v_prev))`.
//!   (When `L >= R`, both equal the clamp of `v_prev` to `[R, L]`, which is eq 2; when the
//!   branches cross, `R > L`, eq 2 gives `L` or `R`, and `f = L`, `g = R`.) `f` and `g` are
//!   non-decreasing in each of `L`, `R`, `v_prev`, so over a box of `(L, R, v_prev)` their
//!   extremes sit at the all-low and all-high corners. `L` and `R` are linear in the branch
//!   coordinates `(m, m·c)`, so their ranges over the two polygons come from the vertices, and
//!   the set of possible states `v_prev` after each step is over-approximated by the previous
//!   interval. Hence the interval simulation
//!   `v_t ∈ [min(L_lo, max(R_lo, v_{t-1,lo})), max(R_hi, min(L_hi, v_{t-1,hi}))]`,
//!   widened outward each step, contains `v_t` for every parameter in the feasible set and keeps
//!   the memory of the play. It starts from the state `0` (`at_rest: true`) or from an unknown
//!   state (`(-inf, inf)`, the default, valid for measured data), which the first move through
//!   the play forgets.
//! * **Stage 3** is the core's errors-in-variables stage with the uncertainty on the input side
//!   (`v_t` intervals) and the measured output `y_t ± Δη`.
#![forbid(unsafe_code)]
#![warn(missing_docs)]

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};
use smid_core::prelude::*;
use smid_output_backlash::{Backlash, BacklashSet};

/// Input backlash with known parameters (simulation): eq (2) driven by the input.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct InputBacklash {
    /// Left slope `m_l > 0`.
    pub m_l: f64,
    /// Left half-play `c_l > 0`.
    pub c_l: f64,
    /// Right slope `m_r > 0`.
    pub m_r: f64,
    /// Right half-play `c_r > 0`.
    pub c_r: f64,
}

impl InputBacklash {
    /// The same map as the output backlash (eq 2).
    pub fn backlash(&self) -> Backlash {
        Backlash {
            m_l: self.m_l,
            c_l: self.c_l,
            m_r: self.m_r,
            c_r: self.c_r,
        }
    }
}

#[typetag::serde(name = "input_backlash")]
impl Nonlinearity for InputBacklash {
    fn step(&self, memory: &mut Vec<f64>, x: f64) -> f64 {
        self.backlash().step(memory, x)
    }
    fn initial_memory(&self) -> Vec<f64> {
        vec![0.0]
    }
    /// Behind a gain `k`: as the output backlash's map (slopes `/k`, half-plays `·k`).
    fn behind_gain(&self, k: f64) -> Option<Vec<(String, f64)>> {
        self.backlash().behind_gain(k)
    }
    fn parameters(&self) -> Vec<(String, f64)> {
        self.backlash().parameters()
    }
    fn validate(&self) -> Result<()> {
        self.backlash().validate()
    }
}

/// Input backlash as a model structure to identify (Hammerstein only).
#[derive(Debug, Clone, Default, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct InputBacklashModel {
    /// The dynamic experiment starts from rest (backlash output 0). Default `false`: the
    /// initial state is unknown, which is always valid and costs only the samples before the
    /// input first moves through the play.
    #[serde(default)]
    pub at_rest: bool,
}

/// The feasible set: the two branch polygons, and how the propagation starts.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct InputBacklashSet {
    /// The two branch polygons in `(m, m·c)` from stage 1.
    pub polygons: BacklashSet,
    /// Whether the propagation starts the play at rest (the model's `at_rest` option); else
    /// from an unknown state.
    pub at_rest: bool,
}

#[typetag::serde(name = "input_backlash")]
impl NonlinearityModel for InputBacklashModel {
    fn bound_steady_state(&self, data: &SteadyStateData) -> Result<Box<dyn NonlinearitySet>> {
        Ok(Box::new(InputBacklashSet::from_steady(data, self.at_rest)?))
    }
    fn supports(&self, structure: Structure) -> bool {
        structure == Structure::Hammerstein
    }
    /// Stage 1 is the output backlash's polygons, which take interval steady inputs.
    fn accepts_input_radius(&self) -> bool {
        true
    }
    /// A box of `(m_l, c_l, m_r, c_r)`: the branch images of the output backlash; the interval
    /// simulation takes `L`, `R` over their vertices, so it holds for every member.
    /// Unit slopes, half-plays up to a quarter of the range seen.
    fn default_prior(&self, _s: Structure, seen: (f64, f64)) -> Option<Vec<Interval>> {
        let c = Interval::new(0.0, 0.25 * (seen.1 - seen.0).max(0.0));
        let one = Interval::new(1.0, 1.0);
        Some(vec![one, c, one, c])
    }
    fn set_from_box(&self, cell: &[Interval]) -> Result<Box<dyn NonlinearitySet>> {
        Ok(Box::new(InputBacklashSet {
            polygons: smid_output_backlash::box_polygons(cell)?,
            at_rest: self.at_rest,
        }))
    }
    /// Before the linear block: a random physical backlash over the inputs it sees (`|u| <= 3`),
    /// started at rest or not at random, steady-state amplitudes 0.6 to 3, a unit PRBS.
    fn check_draw(&self, s: Structure, rng: &mut dyn RngCore) -> Option<CheckDraw> {
        if s != Structure::Hammerstein {
            return None;
        }
        let b = Backlash::random_physical(rng, 3.0)?;
        Some(CheckDraw {
            nonlinearity: Box::new(InputBacklash {
                m_l: b.m_l,
                c_l: b.c_l,
                m_r: b.m_r,
                c_r: b.c_r,
            }),
            model: Box::new(InputBacklashModel {
                at_rest: rng.gen_bool(0.5),
            }),
            steady: (0.6, 3.0),
            amplitude: 1.0,
        })
    }
}

smid_core::register_nonlinearity!(
    "input_backlash",
    InputBacklash,
    InputBacklash {
        m_l: 0.9,
        c_l: 0.1,
        m_r: 1.1,
        c_r: 0.05
    }
);
smid_core::register_model!(
    "input_backlash",
    InputBacklashModel,
    InputBacklashModel::default()
);

impl InputBacklashSet {
    /// Stage 1: the exact branch polygons (α ignored, see the module docs).
    pub fn from_steady(data: &SteadyStateData, at_rest: bool) -> Result<Self> {
        let mut d = data.clone();
        for p in &mut d.points {
            p.alpha = 0.0;
        }
        Ok(InputBacklashSet {
            polygons: smid_output_backlash::branch_polygons(&d)?,
            at_rest,
        })
    }

    /// One step of the guaranteed interval simulation: the state interval after input `u`.
    pub fn step(&self, state: Interval, u: f64) -> Interval {
        let l = self.polygons.left.extremes(|v| v[0] * u + v[1]);
        let r = self.polygons.right.extremes(|v| v[0] * u - v[1]);
        let lo = l.lo.min(r.lo.max(state.lo));
        let hi = r.hi.max(l.hi.min(state.hi));
        Interval::new(lo, hi).outward()
    }
}

#[typetag::serde(name = "input_backlash")]
impl NonlinearitySet for InputBacklashSet {
    /// Order-preserving (a play is order-preserving from any initial state), so a chain may feed it interval inputs.
    fn monotone(&self) -> bool {
        true
    }
    fn parameters(&self) -> Vec<ParameterBound> {
        self.polygons.parameters()
    }
    /// At rest after any history the play's output is anywhere in its dead band at `u`: one
    /// step from an unknown state, whatever `at_rest` says of a record's start.
    fn propagate_steady(&self, u: f64) -> Result<Interval> {
        Ok(self.step(Interval::entire(), u))
    }

    fn propagate(&self, u: &[f64]) -> Result<Vec<InnerBound>> {
        let mut state = if self.at_rest {
            Interval::new(0.0, 0.0)
        } else {
            Interval::entire()
        };
        let mut out = Vec::with_capacity(u.len());
        for (t, &ut) in u.iter().enumerate() {
            if !ut.is_finite() {
                return Err(SmidError::invalid(
                    format!("dynamic sample {t}"),
                    "non-finite input",
                ));
            }
            state = self.step(state, ut);
            out.push(InnerBound {
                interval: state,
                kind: InnerKind::Inverted,
            });
        }
        Ok(out)
    }

    fn regions(&self, truth: Option<&[f64]>) -> Vec<Region> {
        self.polygons.regions(truth)
    }

    fn contains(&self, truth: &[f64]) -> bool {
        self.polygons.contains(truth)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// Noisy steady-state data of the filtered square wave (branch of the last move).
    fn steady(b: &InputBacklash, d: f64, noise: impl Fn(usize) -> f64) -> SteadyStateData {
        let mut points = Vec::new();
        for k in 0..15 {
            let a = 0.6 + 0.17 * k as f64;
            for (u, rising) in [(a, true), (-a, false)] {
                let i = points.len();
                let w = if rising {
                    b.m_r * (u - b.c_r)
                } else {
                    b.m_l * (u + b.c_l)
                };
                points.push(SteadyPoint {
                    u,
                    y: w + d * noise(i),
                    dy: d,
                    alpha: 0.0,
                    rising,
                    index: i,
                    time: None,
                    step: None,
                    du: 0.0,
                });
            }
        }
        SteadyStateData { points }
    }

    const B: InputBacklash = InputBacklash {
        m_l: 0.9,
        c_l: 0.2,
        m_r: 1.1,
        c_r: 0.1,
    };

    #[test]
    fn propagation_keeps_the_play_memory_and_is_tight_with_tiny_noise() {
        let set = InputBacklashSet::from_steady(&steady(&B, 1e-9, |_| 0.0), true).unwrap();
        let u = [1.0, 0.9, 0.8, -1.0, -0.95, 0.5, 1.0];
        let v = B.simulate(&u);
        let p = set.propagate(&u).unwrap();
        for (t, (b, v)) in p.iter().zip(&v).enumerate() {
            assert!(b.interval.contains(*v), "t={t}: {b:?} misses {v}");
            assert!(b.interval.radius() < 1e-6, "t={t}: {b:?}");
        }
        // The play holds the output while the input reverses by less than the play.
        assert_eq!(v[1], v[0]);
        assert_eq!(v[4], v[3]);
    }

    #[test]
    fn unknown_initial_state_is_forgotten_after_the_first_move_through_the_play() {
        let set = InputBacklashSet::from_steady(&steady(&B, 1e-9, |_| 0.0), false).unwrap();
        let u = [0.05, 0.05, 1.0, -1.0];
        let p = set.propagate(&u).unwrap();
        // At u = 0.05 the state could be anything between the branches R(0.05) and L(0.05).
        assert!(p[0].interval.lo <= B.m_r * (0.05 - B.c_r) + 1e-9);
        assert!(p[0].interval.hi >= B.m_l * (0.05 + B.c_l) - 1e-9);
        assert!(p[3].interval.radius() < 1e-6, "{:?}", p[3]);
    }

    #[test]
    fn alpha_is_ignored_on_the_input_side() {
        let mut d = steady(&B, 1e-4, |i| if i % 2 == 0 { 0.5 } else { -0.5 });
        let a = InputBacklashSet::from_steady(&d, false)
            .unwrap()
            .parameters();
        for p in &mut d.points {
            p.alpha = 0.1;
        }
        let b = InputBacklashSet::from_steady(&d, false)
            .unwrap()
            .parameters();
        assert_eq!(a, b);
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(
            std::env::var("PROPTEST_CASES").ok().and_then(|v| v.parse().ok()).unwrap_or(16)))]
        /// Stage 1 and the interval simulation contain the truth for random backlashes, inputs
        /// (including small reversals inside the play and crossed branches) and noise.
        #[test]
        fn truth_inside_stage_1_and_propagation(
            m_l in 0.1f64..2.0, c_l in 0.01f64..0.3, m_r in 0.1f64..2.0, c_r in 0.01f64..0.3,
            d in 1e-6f64..1e-2, seed in 0u64..1000, at_rest: bool,
            u in proptest::collection::vec(-5.0f64..5.0, 10..80),
        ) {
            let b = InputBacklash { m_l, c_l, m_r, c_r };
            let noise = |i: usize| (((i as u64 + seed) * 2654435761 % 1000) as f64 / 500.0) - 1.0;
            let set = InputBacklashSet::from_steady(&steady(&b, d, noise), at_rest).unwrap();
            prop_assert!(set.contains(&[m_l, c_l, m_r, c_r]));
            let v = b.simulate(&u);
            let p = set.propagate(&u).unwrap();
            for (t, (bd, v)) in p.iter().zip(&v).enumerate() {
                prop_assert!(bd.interval.contains(*v), "t={}: {:?} misses {}", t, bd, v);
            }
        }
    }
}
