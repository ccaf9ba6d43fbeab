//! # smid-saturation
//!
//! Saturation as a smid plugin (`type: saturation`): at the output (Wiener structure
//! `w = N(G u)`) or, as a chain's input block, a saturating actuator (`v = N(u)`, propagated).
//!
//! ## Parameterisation
//!
//! Linear inside, clipped outside, with a slope and an output limit per side:
//!
//! ```text
//! N(x) = min(s_r, m_r x)    for x >= 0
//!        max(-s_l, m_l x)   for x <  0        (m_l, s_l, m_r, s_r > 0)
//! ```
//!
//! `m_l`, `m_r` are the slopes and `s_l`, `s_r` the output limits (`-s_l <= w <= s_r`); the
//! input break points are `-s_l/m_l` and `s_r/m_r`. A symmetric saturation with one gain is the
//! special case `m_l = m_r`, `s_l = s_r` (the plugin does not assume it).
//!
//! ## Stage 1: exact staircase sets (the analogue of paper Section 3)
//!
//! Under unit gain (eq 8), a steady-state sample on the right (`ū > 0`) says
//! `min(s_r, m_r ū) ∈ [ȳ - Δη, ȳ + Δη]`, that is
//! `s_r >= ȳ - Δη`, `m_r >= (ȳ - Δη)/ū`, and (`s_r <= ȳ + Δη` **or** `m_r <= (ȳ + Δη)/ū`).
//! The set is not convex, but every constraint is axis-aligned in `(m, s)`, so the exact
//! feasible set of a branch is a "staircase": a lower corner `(L_m, L_s)` and the
//! disjunctions. It is closed downwards towards the corner, so it is empty exactly when the
//! corner violates a disjunction, and its exact projections are
//! `m <= M_k` for the smallest `M_i = (ȳ_i+Δη)/ū_i` whose `R_i = ȳ_i + Δη` lies below `L_s`
//! (such a sample must be linear), and `s <= R_k` for the smallest `R_i` whose `M_i` lies below
//! `L_m` (such a sample must be clipped). If no sample is surely clipped `s` has no upper
//! bound (reported as `+inf`, which is the honest guarantee); if no sample is surely linear the
//! slope is not bounded and stage 1 fails with [`SmidError::Unbounded`].
//! Saturation is memoryless, so the overshoot allowance `α` (eqs 14-15) is not needed.
//!
//! ## Stage 2: inversion (Props 2-4 adapted)
//!
//! With `w ∈ [y-Δη, y+Δη]` and `m`, `s` in their intervals: a sample that is surely below the
//! smallest feasible limit (`y + Δη < s_lo`) is linear and inverts to `x = w/m` (extremes at the
//! interval ends, the analogue of Prop 4); a sample that may be clipped still bounds `x` from
//! one side, `x >= (y-Δη)/m_hi` (clipped: `x >= s/m >= w/m`), with `+inf` on the other
//! (such a bound is valid but not finite, so stage 3 does not use it). Samples whose output may
//! be 0 join the two sides. A sample beyond every limit of the cell (`y - Δη > s_hi`, or
//! `y + Δη < -s_l,hi`) is inconsistent with the cell: every member has `-s_l <= w <= s_r`.
#![forbid(unsafe_code)]
#![warn(missing_docs)]

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};
use smid_core::interval::{ABS_PAD, REL_PAD};
use smid_core::prelude::*;

/// A saturation with known parameters (simulation).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Saturation {
    /// Slope for `x < 0` (`> 0`).
    pub m_l: f64,
    /// Lower output limit is `-s_l` (`s_l > 0`).
    pub s_l: f64,
    /// Slope for `x >= 0` (`> 0`).
    pub m_r: f64,
    /// Upper output limit `s_r > 0`.
    pub s_r: f64,
}

impl Saturation {
    /// `N(x)`.
    pub fn map(&self, x: f64) -> f64 {
        if x >= 0.0 {
            (self.m_r * x).min(self.s_r)
        } else {
            (self.m_l * x).max(-self.s_l)
        }
    }
}

#[typetag::serde(name = "saturation")]
impl Nonlinearity for Saturation {
    fn step(&self, _memory: &mut Vec<f64>, x: f64) -> f64 {
        self.map(x)
    }
    /// Behind a gain `k`: the slopes divide by `k`, the limits (output units) stay.
    fn behind_gain(&self, k: f64) -> Option<Vec<(String, f64)>> {
        (k.is_finite() && k > 0.0).then(|| {
            vec![
                ("m_l".into(), self.m_l / k),
                ("s_l".into(), self.s_l),
                ("m_r".into(), self.m_r / k),
                ("s_r".into(), self.s_r),
            ]
        })
    }
    fn parameters(&self) -> Vec<(String, f64)> {
        vec![
            ("m_l".into(), self.m_l),
            ("s_l".into(), self.s_l),
            ("m_r".into(), self.m_r),
            ("s_r".into(), self.s_r),
        ]
    }
    fn validate(&self) -> Result<()> {
        for (name, v) in self.parameters() {
            if !(v.is_finite() && v > 0.0) {
                return Err(SmidError::invalid(
                    name,
                    format!("expected a finite number > 0, got {v}"),
                ));
            }
        }
        Ok(())
    }
}

/// Saturation as a model structure to identify (no options; either side of the linear block).
#[derive(Debug, Clone, Default, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct SaturationModel {}

/// One steady-state constraint of a branch, mirrored to `ū > 0`: `min(s, m a) ∈ [lo, hi]`.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Sample {
    /// `|ū| > 0`.
    a: f64,
    lo: f64,
    hi: f64,
    index: usize,
}

fn down(v: f64) -> f64 {
    v - REL_PAD * v.abs() - f64::MIN_POSITIVE
}
fn up(v: f64) -> f64 {
    v + REL_PAD * v.abs() + f64::MIN_POSITIVE
}

/// The exact feasible set of one branch in `(m, s)`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Staircase {
    /// Lower corner: `m >= lo_m`, `s >= lo_s` (rounded down).
    pub lo_m: f64,
    /// Lower bound of the output limit `s` (the corner's second coordinate).
    pub lo_s: f64,
    /// Disjunctions `s <= r_i or m <= m_i` (rounded up).
    pub steps: Vec<(f64, f64)>,
    /// Exact projections (rounded outward); `s.hi` may be `+inf`.
    pub m: Interval,
    /// Exact projection on the output limit `s` (upper end `+inf` when no sample is surely
    /// clipped).
    pub s: Interval,
}

impl Staircase {
    fn corner(samples: &[Sample]) -> (f64, f64) {
        let lo_m = samples.iter().map(|p| p.lo / p.a).fold(0.0, f64::max);
        let lo_s = samples.iter().map(|p| p.lo).fold(0.0, f64::max);
        (down(lo_m).max(0.0), down(lo_s).max(0.0))
    }

    /// Build from the branch's samples; `what` names the branch, `slope` its slope parameter.
    fn new(samples: &[Sample], what: &str, slope: &str) -> Result<Staircase> {
        // Find the first sample (in record order) that empties the set: the set of a prefix is
        // empty iff its corner violates one of its disjunctions.
        let feasible = |k: usize| {
            let (lm, ls) = Self::corner(&samples[..k]);
            samples[..k]
                .iter()
                .all(|p| ls <= up(p.hi) || lm <= up(p.hi / p.a))
        };
        if !feasible(samples.len()) {
            let first = (1..=samples.len())
                .find(|&k| !feasible(k))
                .unwrap_or(samples.len());
            return Err(SmidError::inconsistent(
                Stage::SteadyState,
                samples[first - 1].index,
                format!("{what}: no slope and limit fit this sample and the ones before it"),
            ));
        }
        let (lo_m, lo_s) = Self::corner(samples);
        let steps: Vec<(f64, f64)> = samples.iter().map(|p| (up(p.hi), up(p.hi / p.a))).collect();
        if lo_m <= 0.0 {
            return Err(SmidError::Unbounded {
                parameter: slope.into(),
                message: format!("{what}: no steady-state output is clear of the noise bound, so the slope is not bounded away from 0"),
            });
        }
        // m_max: the smallest M_i among samples that must be linear (R_i < lo_s).
        let m_hi = steps
            .iter()
            .filter(|(r, _)| *r < lo_s)
            .map(|(_, m)| *m)
            .fold(f64::INFINITY, f64::min);
        if !m_hi.is_finite() {
            return Err(SmidError::Unbounded {
                parameter: slope.into(),
                message: format!("{what}: no steady-state sample is surely in the linear range; add smaller amplitudes"),
            });
        }
        // s_max: the smallest R_i among samples that must be clipped (M_i < lo_m).
        let s_hi = steps
            .iter()
            .filter(|(_, m)| *m < lo_m)
            .map(|(r, _)| *r)
            .fold(f64::INFINITY, f64::min);
        Ok(Staircase {
            lo_m,
            lo_s,
            m: Interval::new(lo_m, m_hi),
            s: Interval::new(lo_s, s_hi),
            steps,
        })
    }

    /// Whether `(m, s)` lies in the set (up to the rounding pads): above the lower ends, below
    /// the upper ends of the hull (a box set, from a prior cell, has no steps to say so), and
    /// on the allowed side of every step.
    pub fn contains(&self, m: f64, s: f64) -> bool {
        m >= self.lo_m
            && s >= self.lo_s
            && m <= self.m.hi
            && s <= self.s.hi
            && self.steps.iter().all(|&(r, mm)| s <= r || m <= mm)
    }
}

/// The feasible sets of both branches.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct SaturationSet {
    /// The left branch (`x < 0`) in `(m_l, s_l)`.
    pub left: Staircase,
    /// The right branch (`x >= 0`) in `(m_r, s_r)`.
    pub right: Staircase,
}

/// Stage 1: the exact staircase sets from steady-state data.
pub fn staircases(data: &SteadyStateData) -> Result<SaturationSet> {
    let mut left = Vec::new();
    let mut right = Vec::new();
    data.validate()?;
    for p in &data.points {
        if p.u > 0.0 {
            right.push(Sample {
                a: p.u,
                lo: p.y - p.dy,
                hi: p.y + p.dy,
                index: p.index,
            });
        } else if p.u < 0.0 {
            // -w = min(s_l, m_l |ū|).
            left.push(Sample {
                a: -p.u,
                lo: -(p.y + p.dy),
                hi: -(p.y - p.dy),
                index: p.index,
            });
        }
    }
    Ok(SaturationSet {
        left: Staircase::new(&left, "left branch (m_l, s_l)", "m_l")?,
        right: Staircase::new(&right, "right branch (m_r, s_r)", "m_r")?,
    })
}

#[typetag::serde(name = "saturation")]
impl NonlinearityModel for SaturationModel {
    /// Nondecreasing for every member (positive slopes), so a monotone step stays one.
    fn keeps_steps_monotone(&self) -> bool {
        true
    }
    fn bound_steady_state(&self, data: &SteadyStateData) -> Result<Box<dyn NonlinearitySet>> {
        Ok(Box::new(staircases(data)?))
    }
    /// Either side: an output saturation (Wiener, inverted) or a saturating actuator (an input
    /// block of a chain, propagated).
    fn supports(&self, _structure: Structure) -> bool {
        true
    }
    /// Unit slopes; each limit within [0.5, 2] × the largest output on its side, or fixed far
    /// beyond the data when that side is never seen.
    fn default_prior(&self, _s: Structure, seen: (f64, f64)) -> Option<Vec<Interval>> {
        let one = Interval::new(1.0, 1.0);
        let far = 4.0 * seen.0.abs().max(seen.1.abs()).max(f64::MIN_POSITIVE);
        let side = |m: f64| {
            if m > 0.0 {
                Interval::new(0.5 * m, 2.0 * m)
            } else {
                Interval::new(far, far)
            }
        };
        Some(vec![one, side(-seen.0), one, side(seen.1)])
    }
    /// A box of `(m_l, s_l, m_r, s_r)`: each branch a staircase with no disjunction (the box
    /// itself); the inversion uses the slope interval and the smallest limit, so it holds for
    /// every member.
    fn set_from_box(&self, cell: &[Interval]) -> Result<Box<dyn NonlinearitySet>> {
        if cell.len() != 4 || cell.iter().any(|i| !(i.lo > 0.0 && i.lo <= i.hi)) {
            return Err(SmidError::invalid(
                "model.prior",
                "expected 4 intervals (m_l, s_l, m_r, s_r), each 0 < lo <= hi",
            ));
        }
        let st = |m: Interval, s: Interval| Staircase {
            lo_m: m.lo,
            lo_s: s.lo,
            m,
            s,
            steps: Vec::new(),
        };
        Ok(Box::new(SaturationSet {
            left: st(cell[0], cell[1]),
            right: st(cell[2], cell[3]),
        }))
    }
    /// After the linear block: slopes in `[0.2, 2)`, each limit 1 to 2.5 times its slope, so
    /// steady-state amplitudes 0.1 to 4 reach both the linear part and the limits.
    fn check_draw(&self, s: Structure, rng: &mut dyn RngCore) -> Option<CheckDraw> {
        if s != Structure::Wiener {
            return None;
        }
        let m_l: f64 = rng.gen_range(0.2..2.0);
        let m_r: f64 = rng.gen_range(0.2..2.0);
        let sat = Saturation {
            m_l,
            s_l: m_l * rng.gen_range(1.0..2.5),
            m_r,
            s_r: m_r * rng.gen_range(1.0..2.5),
        };
        Some(CheckDraw {
            nonlinearity: Box::new(sat),
            model: Box::new(SaturationModel {}),
            steady: (0.1, 4.0),
            amplitude: 0.5,
        })
    }
}

smid_core::register_nonlinearity!(
    "saturation",
    Saturation,
    Saturation {
        m_l: 1.0,
        s_l: 1.2,
        m_r: 1.0,
        s_r: 1.5
    }
);
smid_core::register_model!("saturation", SaturationModel, SaturationModel {});

/// Bound on `|x|` on one branch from `|w| ∈ [a, b]` (`0 <= a <= b`); `None` when `a` lies
/// above every limit of the branch (`|w| <= s` for every member; the comparison is padded
/// outwards, so rounding never rejects a member).
fn side(st: &Staircase, a: f64, b: f64) -> Option<Interval> {
    if a > st.s.hi * (1.0 + REL_PAD) + ABS_PAD {
        return None;
    }
    let lo = a / st.m.hi;
    let hi = if b < st.s.lo {
        b / st.m.lo
    } else {
        f64::INFINITY
    };
    Some(Interval::new(lo, hi))
}

impl SaturationSet {
    /// Bound on `x_t` from one output sample; `None` when no member reaches `y ± d` (the
    /// sample lies beyond every limit of the cell).
    pub fn invert_sample(&self, y: f64, d: f64) -> Option<InnerBound> {
        let mut parts = Vec::new();
        if y + d >= 0.0 {
            parts.extend(side(&self.right, (y - d).max(0.0), y + d));
        }
        if y - d <= 0.0 {
            if let Some(i) = side(&self.left, (-(y + d)).max(0.0), -(y - d)) {
                parts.push(Interval::new(-i.hi, -i.lo));
            }
        }
        if parts.is_empty() {
            return None;
        }
        let lo = parts.iter().map(|i| i.lo).fold(f64::INFINITY, f64::min);
        let hi = parts.iter().map(|i| i.hi).fold(f64::NEG_INFINITY, f64::max);
        let interval = Interval::new(lo, hi).outward();
        let kind = if parts.len() == 1 && interval.is_finite() {
            InnerKind::Inverted
        } else {
            InnerKind::Band
        };
        Some(InnerBound { interval, kind })
    }
}

#[typetag::serde(name = "saturation")]
impl NonlinearitySet for SaturationSet {
    fn parameters(&self) -> Vec<ParameterBound> {
        let b = |name: &str, i: Interval| ParameterBound {
            name: name.into(),
            interval: i,
        };
        vec![
            b("m_l", self.left.m),
            b("s_l", self.left.s),
            b("m_r", self.right.m),
            b("s_r", self.right.s),
        ]
    }

    fn invert(&self, y: &[f64], dy: &[f64]) -> Result<Vec<InnerBound>> {
        check_outputs(y, dy)?;
        y.iter()
            .zip(dy)
            .enumerate()
            .map(|(t, (&y, &d))| {
                self.invert_sample(y, d).ok_or_else(|| {
                    SmidError::inconsistent(
                        Stage::InnerSignal,
                        t,
                        format!(
                            "output {y} ± {d} lies beyond the limits of every member (-s_l ≥ {:.6e}, s_r ≤ {:.6e})",
                            -self.left.s.hi,
                            self.right.s.hi
                        ),
                    )
                })
            })
            .collect()
    }

    /// `v = min(s_r, m_r u)` (`u >= 0`), `max(-s_l, m_l u)` (`u < 0`) over the box hull of
    /// each branch's set (a superset of the staircase: sound): monotone in `m` and `s`, so the
    /// interval ends suffice.
    fn propagate(&self, u: &[f64]) -> Result<Vec<InnerBound>> {
        let (r, l) = (&self.right, &self.left);
        propagate_static(u, |u| {
            if u >= 0.0 {
                Interval::new((r.m.lo * u).min(r.s.lo), (r.m.hi * u).min(r.s.hi))
            } else {
                Interval::new((l.m.hi * u).max(-l.s.hi), (l.m.lo * u).max(-l.s.lo))
            }
        })
    }
    /// Nondecreasing in the input for every member (positive slopes).
    fn monotone(&self) -> bool {
        true
    }
    /// A designed step inside `t` passes as one positive gain when every member is linear on
    /// `t`: below the smallest limit on each side it reaches (`t.hi·m_r ≤ s_r` and
    /// `-t.lo·m_l ≤ s_l` for the box hull, with a margin for rounding), and with one slope:
    /// `t` on one side of 0, or both slopes known and equal (a kink at 0 bends the step).
    fn keeps_steady_design_over(&self, t: Interval) -> bool {
        let (r, l) = (&self.right, &self.left);
        let below =
            |x: f64, b: &Staircase| x <= 0.0 || x * b.m.hi <= b.s.lo * (1.0 - 8.0 * f64::EPSILON);
        let one_slope = t.lo >= 0.0
            || t.hi <= 0.0
            || (l.m.lo == l.m.hi && r.m.lo == r.m.hi && l.m.lo == r.m.lo);
        below(t.hi, r) && below(-t.lo, l) && one_slope
    }

    fn contains(&self, truth: &[f64]) -> bool {
        truth.len() == 4
            && self.left.contains(truth[0], truth[1])
            && self.right.contains(truth[2], truth[3])
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn steady(
        sat: &Saturation,
        amps: &[f64],
        d: f64,
        noise: impl Fn(usize) -> f64,
    ) -> SteadyStateData {
        let mut points = Vec::new();
        for &a in amps {
            for u in [a, -a] {
                let i = points.len();
                points.push(SteadyPoint::new(i, u, sat.map(u) + d * noise(i), d));
            }
        }
        SteadyStateData { points }
    }

    const SAT: Saturation = Saturation {
        m_l: 0.8,
        s_l: 1.0,
        m_r: 1.2,
        s_r: 1.5,
    };

    #[test]
    fn map_is_linear_inside_and_clipped_outside() {
        assert_eq!(SAT.map(0.5), 0.6);
        assert_eq!(SAT.map(3.0), 1.5);
        assert_eq!(SAT.map(-0.5), -0.4);
        assert_eq!(SAT.map(-3.0), -1.0);
    }

    #[test]
    fn exact_projections_are_tight_with_tiny_noise() {
        let amps: Vec<f64> = (0..30).map(|k| 0.1 + 0.1 * k as f64).collect();
        let set = staircases(&steady(&SAT, &amps, 1e-9, |_| 0.0)).unwrap();
        for (b, t) in set.parameters().iter().zip([0.8, 1.0, 1.2, 1.5]) {
            assert!(b.interval.contains(t), "{b:?}");
            assert!(b.interval.radius() < 0.1, "{b:?}");
        }
        assert!(set.contains(&[0.8, 1.0, 1.2, 1.5]));
        assert!(!set.contains(&[0.8, 1.0, 1.3, 1.5]));
    }

    /// A prior cell's set holds its box and nothing beyond it, on every side: the member
    /// search moves points by this test (seed 565 of the any-record check reported a certified
    /// member with `m_l` above its cell before the upper ends were checked).
    #[test]
    fn a_box_set_contains_its_box_only() {
        let i = Interval::new;
        let set = SaturationModel {}
            .set_from_box(&[i(0.7, 0.9), i(0.9, 1.1), i(1.1, 1.3), i(1.4, 1.6)])
            .unwrap();
        assert!(set.contains(&[0.8, 1.0, 1.2, 1.5]));
        assert!(set.contains(&[0.9, 1.1, 1.3, 1.6]));
        for k in 0..4 {
            for (d, hi) in [(-0.11, false), (0.11, true)] {
                let mut p = [0.8, 1.0, 1.2, 1.5];
                p[k] += d;
                assert!(
                    !set.contains(&p),
                    "coordinate {k} {}: {p:?}",
                    if hi { "above" } else { "below" }
                );
            }
        }
    }

    #[test]
    fn no_clipped_sample_leaves_the_limit_unbounded_above() {
        let amps = [0.2, 0.4, 0.6];
        let set = staircases(&steady(&SAT, &amps, 1e-6, |_| 0.0)).unwrap();
        assert_eq!(set.right.s.hi, f64::INFINITY);
        assert!(set.right.m.radius() < 1e-4);
        // A sample that is surely linear inverts; a possibly clipped one is one-sided.
        let b = set.invert_sample(0.3, 1e-6).unwrap();
        assert_eq!(b.kind, InnerKind::Inverted);
        assert!(b.interval.contains(0.25));
        let c = set.invert_sample(0.9, 1e-6).unwrap();
        assert_eq!(c.interval.hi, f64::INFINITY);
        assert!(c.interval.lo <= 0.75);
    }

    #[test]
    fn an_output_beyond_every_limit_of_the_cell_is_inconsistent() {
        // A cell whose right limit is at most 0.5: an output of 0.6 ± 0.01 no member reaches.
        let set = SaturationModel {}
            .set_from_box(&[
                Interval::new(0.8, 1.2),
                Interval::new(0.4, 0.6),
                Interval::new(0.8, 1.2),
                Interval::new(0.3, 0.5),
            ])
            .unwrap();
        let y = [0.1, -0.55, 0.49, 0.6];
        match set.invert(&y, &[0.01; 4]) {
            Err(SmidError::Inconsistent(f)) => assert_eq!(f.sample, 3),
            other => panic!("{other:?}"),
        }
        // Within the noise of the largest limit, the sample is kept (one-sided).
        let inner = set.invert(&y[..3], &[0.01; 3]).unwrap();
        assert_eq!(inner[2].interval.hi, f64::INFINITY);
        assert!(set.invert(&[-0.605], &[0.01]).is_ok() && set.invert(&[-0.62], &[0.01]).is_err());
    }

    #[test]
    fn contradictory_samples_are_inconsistent() {
        let mut data = steady(&SAT, &[0.5, 1.0, 2.0, 3.0], 1e-3, |_| 0.0);
        // ū = 3 gives more than ū = 2 would allow if both were clipped, and less than linear.
        data.points[6].y = 1.3;
        assert!(matches!(
            staircases(&data),
            Err(SmidError::Inconsistent(smid_core::Falsification {
                sample: 6,
                ..
            }))
        ));
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(
            std::env::var("PROPTEST_CASES").ok().and_then(|v| v.parse().ok()).unwrap_or(16)))]
        /// Stage 1 and stage 2 contain the truth for random saturations and noise.
        #[test]
        fn truth_inside_stage_1_and_2(
            m_l in 0.2f64..2.0, s_l in 0.3f64..2.0, m_r in 0.2f64..2.0, s_r in 0.3f64..2.0,
            d in 1e-5f64..1e-2, seed in 0u64..1000,
            xs in proptest::collection::vec(-4.0f64..4.0, 20..60),
        ) {
            let sat = Saturation { m_l, s_l, m_r, s_r };
            let amps: Vec<f64> = (0..25).map(|k| 0.05 + 0.2 * k as f64).collect();
            let noise = |i: usize| (((i as u64 + seed) * 2654435761 % 1000) as f64 / 500.0) - 1.0;
            let set = staircases(&steady(&sat, &amps, d, noise)).unwrap();
            prop_assert!(set.contains(&[m_l, s_l, m_r, s_r]));
            for (b, t) in set.parameters().iter().zip([m_l, s_l, m_r, s_r]) {
                prop_assert!(b.interval.contains(t), "{:?} misses {}", b, t);
            }
            let y: Vec<f64> = xs.iter().enumerate().map(|(i, &x)| sat.map(x) + d * noise(i + 7)).collect();
            let inner = set.invert(&y, &vec![d; y.len()]).unwrap();
            for (b, x) in inner.iter().zip(&xs) {
                prop_assert!(b.interval.contains(*x), "{:?} misses {}", b, x);
            }
        }
    }

    proptest! {
        /// A saturating actuator (an input block): for every member of a box the output of
        /// every input lies in the propagated interval.
        #[test]
        fn propagation_over_a_box_holds_every_member(
            m in 0.5f64..2.0, s in 0.2f64..2.0, w in 0.0f64..0.3, f in 0.0f64..1.0,
            u in proptest::collection::vec(-3.0f64..3.0, 1..40),
        ) {
            let b = |v: f64| Interval::new(v, v * (1.0 + w));
            let set = SaturationModel {}
                .set_from_box(&[b(m), b(s), b(m * 1.1), b(s * 0.9)])
                .unwrap();
            let truth = Saturation {
                m_l: m * (1.0 + w * f),
                s_l: s * (1.0 + w * f),
                m_r: m * 1.1 * (1.0 + w * (1.0 - f)),
                s_r: s * 0.9 * (1.0 + w * f),
            };
            let v = set.propagate(&u).unwrap();
            for (k, &ut) in u.iter().enumerate() {
                let x = truth.simulate(&[ut])[0];
                prop_assert!(v[k].interval.contains(x), "{:?} misses {}", v[k], x);
            }
        }

        /// Where the set says a designed step inside `t` passes, every member of the box is
        /// one gain on `t`: `w = k x` with the same `k` at every input of `t`. Equal unit
        /// slopes (the diagnosis's prior) or different ones; `t` on both sides of 0 or one.
        #[test]
        fn a_step_passed_as_designed_meets_one_gain_in_every_member(
            ml in 0.5f64..2.0, sl in 0.2f64..2.0, mr in 0.5f64..2.0, sr in 0.2f64..2.0,
            w in 0.0f64..0.3, equal in proptest::bool::ANY, lo in -2.0f64..2.0, len in 0.0f64..2.0,
            f in proptest::collection::vec((0.0f64..=1.0, 0.0f64..=1.0, 0.0f64..=1.0, 0.0f64..=1.0), 1..8),
        ) {
            let mr = if equal { ml } else { mr };
            let b = |v: f64| if equal { Interval::new(v, v) } else { Interval::new(v, v * (1.0 + w)) };
            let bs = |v: f64| Interval::new(v, v * (1.0 + w));
            let set = SaturationModel {}
                .set_from_box(&[b(ml), bs(sl), b(mr), bs(sr)])
                .unwrap();
            let t = Interval::new(lo, lo + len);
            if set.keeps_steady_design_over(t) {
                let at = |x: f64, v: f64| if equal { v } else { v * (1.0 + w * x) };
                for &(a, c, d, e) in &f {
                    let member = Saturation {
                        m_l: at(a, ml),
                        s_l: sl * (1.0 + w * c),
                        m_r: at(d, mr),
                        s_r: sr * (1.0 + w * e),
                    };
                    let xs: Vec<f64> = (0..=20).map(|i| t.lo + (t.hi - t.lo) * i as f64 / 20.0).collect();
                    let ys = member.simulate(&xs);
                    let gains: Vec<f64> = xs.iter().zip(&ys).filter(|(x, _)| x.abs() > 1e-9).map(|(x, y)| y / x).collect();
                    for g in &gains {
                        prop_assert!((g - gains[0]).abs() <= 1e-9 * gains[0].abs(), "{member:?} on {t:?}: gains {gains:?}");
                    }
                }
            }
        }
    }

    /// The pass is not vacuous: below the smallest limits a step across 0 passes with equal
    /// known slopes, and one reaching past a limit does not.
    #[test]
    fn a_step_below_the_limits_passes_and_one_past_them_does_not() {
        let one = Interval::new(1.0, 1.0);
        let set = SaturationModel {}
            .set_from_box(&[one, Interval::new(1.0, 2.0), one, Interval::new(1.5, 3.0)])
            .unwrap();
        assert!(set.keeps_steady_design_over(Interval::new(-0.9, 1.4)));
        assert!(!set.keeps_steady_design_over(Interval::new(-0.9, 1.6)));
        assert!(!set.keeps_steady_design_over(Interval::new(-1.1, 1.0)));
        let kinked = SaturationModel {}
            .set_from_box(&[
                one,
                Interval::new(1.0, 2.0),
                Interval::new(1.2, 1.2),
                Interval::new(1.5, 3.0),
            ])
            .unwrap();
        assert!(!kinked.keeps_steady_design_over(Interval::new(-0.5, 0.5)));
        assert!(kinked.keeps_steady_design_over(Interval::new(0.1, 0.5)));
    }
}
