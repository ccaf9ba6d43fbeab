//! # smid-output-backlash
//!
//! The backlash of the paper's eq (2) as a smid plugin (`type: output_backlash`):
//!
//! * [`Backlash`] simulates `w_t = m_l (x_t + c_l)` for `x_t <= z_l`, `m_r (x_t - c_r)` for
//!   `x_t >= z_r`, and `w_t = w_{t-1}` in between (the third case of eq 2), with
//!   `z_l = w_{t-1}/m_l - c_l`, `z_r = w_{t-1}/m_r + c_r` (eq 3).
//! * [`OutputBacklashModel`] bounds `(m_l, c_l, m_r, c_r)` from steady-state data (Section 3):
//!   each branch is linear in `(m, m·c)`, so its feasible set (constraints (16)-(17)) is an exact
//!   polygon; `D_γ` (eq 13) is the Cartesian product of the two branch polygons. Bounds on `m`
//!   and `c = (m·c)/m` are global optima at the vertices (eqs 18-20).
//! * [`BacklashSet`] inverts the uncertain backlash (Section 4, Props 2-4) over the polygon
//!   vertices and `η = ±Δη`, with the corrected left branch `x = w/m_l - c_l` (eqs 24, 26 print
//!   `+γ2`); a sample whose output may not have moved still bounds `x_t` to the dead band
//!   `[w/m_l - c_l, w/m_r + c_r]`.
#![forbid(unsafe_code)]
#![warn(missing_docs)]

use serde::{Deserialize, Serialize};
use smid_core::prelude::*;

/// Backlash (a play) with known parameters (simulation), eq (2): the output follows the left
/// branch `m_l (x + c_l)` or the right branch `m_r (x - c_r)` while the input drives it, and
/// holds its last value while the input moves inside the play.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Backlash {
    /// Slope of the left branch (`m_l > 0`).
    pub m_l: f64,
    /// Left half-play `c_l > 0`, in input units: the left branch crosses 0 at `x = -c_l`.
    pub c_l: f64,
    /// Slope of the right branch (`m_r > 0`).
    pub m_r: f64,
    /// Right half-play `c_r > 0`, in input units: the right branch crosses 0 at `x = c_r`.
    pub c_r: f64,
}

impl Backlash {
    /// One step of eq (2) given `w_{t-1}`.
    pub fn map(&self, w_prev: f64, x: f64) -> f64 {
        let z_l = w_prev / self.m_l - self.c_l;
        let z_r = w_prev / self.m_r + self.c_r;
        if x <= z_l {
            self.m_l * (x + self.c_l)
        } else if x >= z_r {
            self.m_r * (x - self.c_r)
        } else {
            w_prev
        }
    }

    /// A random backlash of the containment checks: a common slope in `[0.1, 2)`, each branch
    /// within ±2.5 % of it, half-plays in `[0.01, 0.3)` (the ranges of Section 6 widened).
    pub fn random(rng: &mut dyn RngCore) -> Backlash {
        let m: f64 = rng.gen_range(0.1..2.0);
        Backlash {
            m_l: m * rng.gen_range(0.975..1.025),
            c_l: rng.gen_range(0.01..0.3),
            m_r: m * rng.gen_range(0.975..1.025),
            c_r: rng.gen_range(0.01..0.3),
        }
    }

    /// Whether eq (2) describes a backlash for inner signals up to `x_max` in magnitude: the
    /// dead band `[w/m_l - c_l, w/m_r + c_r]` must be non-empty for every output reached.
    pub fn is_physical(&self, x_max: f64) -> bool {
        let w_max = self.m_l.max(self.m_r) * (x_max + self.c_l.max(self.c_r));
        w_max * (1.0 / self.m_l - 1.0 / self.m_r).abs() < self.c_l + self.c_r
    }

    /// A random backlash physical over inner signals up to `x_max` (redrawn until it is; `None`
    /// after 1000 draws).
    pub fn random_physical(rng: &mut dyn RngCore, x_max: f64) -> Option<Backlash> {
        (0..1000)
            .map(|_| Backlash::random(rng))
            .find(|b| b.is_physical(x_max))
    }
}

#[typetag::serde(name = "output_backlash")]
impl Nonlinearity for Backlash {
    fn step(&self, memory: &mut Vec<f64>, x: f64) -> f64 {
        if memory.is_empty() {
            memory.push(0.0);
        }
        let w = self.map(memory[0], x);
        memory[0] = w;
        w
    }
    fn initial_memory(&self) -> Vec<f64> {
        vec![0.0]
    }
    /// Behind a gain `k`: the slopes divide by `k`, the half-plays (in input units) multiply
    /// (the memory holds the output, which does not change).
    fn behind_gain(&self, k: f64) -> Option<Vec<(String, f64)>> {
        smid_core::nonlinearity::two_branches_behind_gain(self.m_l, self.c_l, self.m_r, self.c_r, k)
    }
    fn parameters(&self) -> Vec<(String, f64)> {
        vec![
            ("m_l".into(), self.m_l),
            ("c_l".into(), self.c_l),
            ("m_r".into(), self.m_r),
            ("c_r".into(), self.c_r),
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

/// The output backlash as a model structure to identify (no options).
#[derive(Debug, Clone, Default, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct OutputBacklashModel {}

smid_core::register_nonlinearity!(
    "output_backlash",
    Backlash,
    Backlash {
        m_l: 0.248,
        c_l: 0.0698,
        m_r: 0.252,
        c_r: 0.0349
    }
);
smid_core::register_model!(
    "output_backlash",
    OutputBacklashModel,
    OutputBacklashModel::default()
);

/// The two branch polygons in `(m, m·c)` coordinates.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct BacklashSet {
    /// Left branch: `w = m_l x + m_l c_l`, coordinates `(m_l, m_l c_l)`.
    pub left: Polygon,
    /// Right branch: `w = m_r x - m_r c_r`, coordinates `(m_r, m_r c_r)`.
    pub right: Polygon,
}

/// Stage 1: the exact branch polygons from steady-state data.
pub fn branch_polygons(data: &SteadyStateData) -> Result<BacklashSet> {
    let mut left = Vec::new();
    let mut right = Vec::new();
    let (mut du_l, mut du_r) = (Vec::new(), Vec::new());
    data.validate()?;
    for p in &data.points {
        if p.rising {
            du_r.push(p.du);
        } else {
            du_l.push(p.du);
        }
        if p.rising {
            // ȳ = m_r ū - m_r c_r + η̄, η̄ in [-Δη, Δη + α] (overshoot can only raise ȳ).
            right.push(Strip {
                n: [p.u, -1.0],
                lo: p.y - p.dy - p.alpha,
                hi: p.y + p.dy,
                sample: p.index,
            });
        } else {
            // ȳ = m_l ū + m_l c_l + η̄, η̄ in [-Δη - α, Δη] (undershoot can only lower ȳ).
            left.push(Strip {
                n: [p.u, 1.0],
                lo: p.y - p.dy,
                hi: p.y + p.dy + p.alpha,
                sample: p.index,
            });
        }
    }
    let left = Polygon::from_uncertain_strips(
        &left,
        &du_l,
        &Polygon::positive_quadrant(),
        "left branch (m_l, m_l·c_l)",
    )?;
    let right = Polygon::from_uncertain_strips(
        &right,
        &du_r,
        &Polygon::positive_quadrant(),
        "right branch (m_r, m_r·c_r)",
    )?;
    for (poly, name) in [(&left, "m_l"), (&right, "m_r")] {
        if poly.vertices.iter().any(|v| v[0] <= 0.0) {
            return Err(SmidError::Unbounded {
                parameter: name.into(),
                message: "the feasible slope reaches 0: the noise bound is too large for these amplitudes".into(),
            });
        }
    }
    Ok(BacklashSet { left, right })
}

#[typetag::serde(name = "output_backlash")]
impl NonlinearityModel for OutputBacklashModel {
    /// A play with positive slopes: under a monotone input its output follows one branch or
    /// holds, so a monotone step stays one.
    fn keeps_steps_monotone(&self) -> bool {
        true
    }
    fn bound_steady_state(&self, data: &SteadyStateData) -> Result<Box<dyn NonlinearitySet>> {
        Ok(Box::new(branch_polygons(data)?))
    }
    /// Steady inputs known to an interval (behind a chain's input blocks) give two half-planes
    /// per sample ([`Polygon::from_uncertain_strips`]).
    fn accepts_input_radius(&self) -> bool {
        true
    }
    /// A box of `(m_l, c_l, m_r, c_r)`: each branch's exact image in `(m, m·c)`; the
    /// vertex-based inversion then bounds `x` for every member (extremes at the corners).
    fn set_from_box(&self, cell: &[Interval]) -> Result<Box<dyn NonlinearitySet>> {
        Ok(Box::new(box_polygons(cell)?))
    }
    /// Unit slopes; each half-play up to a quarter of the range its input spans. Before the
    /// linear block (Hammerstein) the range seen is the play's input: `c <= range / 4`. After
    /// it (Wiener) the range seen is the play's output, narrower by `c_l + c_r <= range_in / 2`,
    /// so `range_in <= 2 range` and `c <= range / 2`. (A quarter of the output's range would
    /// leave out a half-play of 0.446 whose output spans 1.66.)
    fn default_prior(&self, s: Structure, seen: (f64, f64)) -> Option<Vec<Interval>> {
        let share = match s {
            Structure::Hammerstein => 0.25,
            Structure::Wiener => 0.5,
        };
        let c = Interval::new(0.0, share * (seen.1 - seen.0).max(0.0));
        let one = Interval::new(1.0, 1.0);
        Some(vec![one, c, one, c])
    }
    /// Slopes around the ratio of the ranges, offsets up to a quarter of the input's range
    /// ([`smid_core::nonlinearity::two_branch_scale_prior`]).
    fn scale_prior(
        &self,
        _s: Structure,
        input: (f64, f64),
        output: (f64, f64),
    ) -> Option<Vec<Interval>> {
        smid_core::nonlinearity::two_branch_scale_prior(input, output)
    }
    /// After the linear block: a random physical backlash over `|x| <= 3`, steady-state
    /// amplitudes 0.6 to 3, a PRBS that crosses the dead band often (`1 + 4 (c_l + c_r)`).
    /// (`smid check --plugin output_backlash` runs the paper's own Monte Carlo instead.)
    fn check_draw(&self, s: Structure, rng: &mut dyn RngCore) -> Option<CheckDraw> {
        if s != Structure::Wiener {
            return None;
        }
        let b = Backlash::random_physical(rng, 3.0)?;
        Some(CheckDraw {
            nonlinearity: Box::new(b),
            model: Box::new(OutputBacklashModel {}),
            steady: (0.6, 3.0),
            amplitude: 1.0 + 4.0 * (b.c_l + b.c_r),
        })
    }
}

/// The branch polygons of a box `(m_l, c_l, m_r, c_r)` (see
/// [`Polygon::from_slope_offset_box`]).
pub fn box_polygons(cell: &[Interval]) -> Result<BacklashSet> {
    let (left, right) = two_branch_polygons(cell)?;
    Ok(BacklashSet { left, right })
}

impl BacklashSet {
    /// `[min, max]` of `x = (w - m_l c_l)/m_l` over the left polygon and `w` in `[y-d, y+d]`.
    pub fn invert_left(&self, y: f64, d: f64) -> Interval {
        invert_branch(&self.left, y, d, |v, w| (w - v[1]) / v[0])
    }
    /// `[min, max]` of `x = (w + m_r c_r)/m_r` over the right polygon.
    pub fn invert_right(&self, y: f64, d: f64) -> Interval {
        invert_branch(&self.right, y, d, |v, w| (w + v[1]) / v[0])
    }
    /// The dead band `[w/m_l - c_l, w/m_r + c_r]`, valid for every sample.
    pub fn band(&self, y: f64, d: f64) -> Interval {
        Interval::new(self.invert_left(y, d).lo, self.invert_right(y, d).hi)
    }
}

#[typetag::serde(name = "output_backlash")]
impl NonlinearitySet for BacklashSet {
    fn parameters(&self) -> Vec<ParameterBound> {
        let b = |name: &str, i: Interval| ParameterBound {
            name: name.into(),
            interval: i,
        };
        vec![
            b("m_l", self.left.extremes(|v| v[0])),
            b("c_l", self.left.extremes(|v| v[1] / v[0])),
            b("m_r", self.right.extremes(|v| v[0])),
            b("c_r", self.right.extremes(|v| v[1] / v[0])),
        ]
    }

    /// A play with positive slopes is order-preserving for every member (a larger input
    /// sequence from the same state never gives a smaller output), and its inversion moves
    /// up with the output: what the guaranteed one-step band ([`smid_core::band`]) bisects on.
    fn monotone(&self) -> bool {
        true
    }

    /// Over a monotone step the two steady outputs are two samples of one monotone run: an
    /// output that moved by more than the noise in the step's direction ends on that branch
    /// (Prop 2, eqs 24-27), whatever happened between them. An output that did not move, or
    /// moved against the step (which a monotone input cannot do), is read with any history.
    fn invert_steady_step(
        &self,
        y0: f64,
        dy0: f64,
        y: f64,
        dy: f64,
        rising: bool,
    ) -> Result<Interval> {
        let moved = if rising { y - y0 } else { y0 - y };
        if moved > dy + dy0 {
            Ok(self.invert(&[y0, y], &[dy0, dy])?[1].interval)
        } else {
            self.invert_steady(y, dy)
        }
    }

    fn invert(&self, y: &[f64], dy: &[f64]) -> Result<Vec<InnerBound>> {
        check_outputs(y, dy)?;
        let mut out = Vec::with_capacity(y.len());
        for t in 0..y.len() {
            let band = self.band(y[t], dy[t]);
            let moved = if t == 0 { 0.0 } else { y[t] - y[t - 1] };
            let thr = if t == 0 {
                f64::INFINITY
            } else {
                dy[t] + dy[t - 1]
            };
            let (interval, kind) = if moved < -thr {
                // Prop 2: the output fell by more than the noise allows: left branch (eq 24, 26).
                (self.invert_left(y[t], dy[t]), InnerKind::Inverted)
            } else if moved > thr {
                // Right branch (eqs 25, 27).
                (self.invert_right(y[t], dy[t]), InnerKind::Inverted)
            } else {
                (band, InnerKind::Band)
            };
            let interval = interval.intersect(&band).unwrap_or(interval);
            out.push(InnerBound { interval, kind });
        }
        Ok(out)
    }

    fn regions(&self, truth: Option<&[f64]>) -> Vec<Region> {
        two_branch_regions(&self.left, &self.right, truth)
    }

    fn contains(&self, truth: &[f64]) -> bool {
        two_branches_contain(&self.left, &self.right, truth)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    const PAPER: Backlash = Backlash {
        m_l: 0.248,
        c_l: 0.0698,
        m_r: 0.252,
        c_r: 0.0349,
    };

    /// A play after the backlash, on random monotone steps from random rest states: read from
    /// the two steady outputs, its input at the step's end lies in the inverted interval for
    /// every member of the cell, and after a move past the noise that interval is the branch,
    /// narrower than the dead band that any history leaves.
    #[test]
    fn a_monotone_step_is_inverted_on_the_branch_it_moved_along() {
        use smid_core::rand::{rngs::StdRng, Rng, SeedableRng};
        let mut rng = StdRng::seed_from_u64(11);
        let mut narrower = 0;
        for _ in 0..2000 {
            let (cl, cr) = (rng.gen_range(0.05..0.4), rng.gen_range(0.05..0.4));
            let cell = [
                Interval::new(1.0, 1.0),
                Interval::new(cl - 0.01, cl + 0.01),
                Interval::new(1.0, 1.0),
                Interval::new(cr - 0.01, cr + 0.01),
            ];
            let set = box_polygons(&cell).unwrap();
            let b = Backlash {
                m_l: 1.0,
                c_l: cl,
                m_r: 1.0,
                c_r: cr,
            };
            // A history, then a monotone step in a few samples to a new level.
            let mut x: Vec<f64> = (0..5).map(|_| rng.gen_range(-2.0..2.0)).collect();
            let start = *x.last().unwrap();
            x.extend(std::iter::repeat_n(start, 3));
            let end = rng.gen_range(-2.0..2.0);
            for k in 1..=4 {
                x.push(start + (end - start) * k as f64 / 4.0);
            }
            let w = b.simulate(&x);
            let (y0, y) = (w[7], *w.last().unwrap());
            let d = 1e-3;
            let (y0, y) = (y0 + rng.gen_range(-d..d), y + rng.gen_range(-d..d));
            let i = set.invert_steady_step(y0, d, y, d, end > start).unwrap();
            assert!(i.contains(end), "{i:?} misses {end} (y0 {y0}, y {y})");
            let any = set.invert_steady(y, d).unwrap();
            assert!(i.hi - i.lo <= any.hi - any.lo + 1e-12);
            if (y - y0).abs() > 2.0 * d {
                assert!(i.hi - i.lo < 0.1, "moved but not on a branch: {i:?}");
                narrower += 1;
            }
        }
        assert!(narrower > 500, "{narrower}");
        // A step that dips before it rises (against the premise: an inverse response) from the
        // left branch: the output falls along it and the rise stays inside the band, so the
        // output moved against the step. That reading is not taken; any history holds.
        let b = Backlash {
            m_l: 1.0,
            c_l: 0.3,
            m_r: 1.0,
            c_r: 0.3,
        };
        let cell = [
            Interval::new(1.0, 1.0),
            Interval::new(0.29, 0.31),
            Interval::new(1.0, 1.0),
            Interval::new(0.29, 0.31),
        ];
        let set = box_polygons(&cell).unwrap();
        let x = [2.0, 0.0, 0.0, -0.5, -0.3, 0.1];
        let w = b.simulate(&x);
        let (y0, y) = (w[2], w[5]);
        assert!(y < y0 - 0.1, "the output must fall: {w:?}");
        let i = set.invert_steady_step(y0, 1e-3, y, 1e-3, true).unwrap();
        assert!(i.contains(0.1), "{i:?}");
    }

    #[test]
    fn eq2_branches_and_dead_band() {
        let b = PAPER;
        let w = b.simulate(&[0.0, 1.0, 0.99, 0.95, -1.0, -0.9]);
        assert_eq!(w[0], 0.0, "x = 0 lies in the initial band [-c_l, c_r]");
        assert!((w[1] - 0.252 * (1.0 - 0.0349)).abs() < 1e-15);
        assert_eq!(w[2], w[1], "small reversal stays in the band");
        assert_eq!(w[3], w[1]);
        assert!((w[4] - 0.248 * (-1.0 + 0.0698)).abs() < 1e-15);
        assert_eq!(w[5], w[4]);
    }

    #[test]
    fn exact_inversion_recovers_inner_signal_with_tiny_noise() {
        let x: Vec<f64> = (0..40).map(|t| (t as f64 * 0.7).sin() * 2.0).collect();
        let w = PAPER.simulate(&x);
        let pts: Vec<SteadyPoint> = (0..20)
            .flat_map(|k| {
                let a = 0.6 + k as f64 * 0.12;
                [
                    SteadyPoint {
                        u: a,
                        y: PAPER.m_r * (a - PAPER.c_r),
                        dy: 1e-9,
                        alpha: 0.0,
                        rising: true,
                        index: 2 * k,
                        time: None,
                        step: None,
                        du: 0.0,
                    },
                    SteadyPoint {
                        u: -a,
                        y: PAPER.m_l * (-a + PAPER.c_l),
                        dy: 1e-9,
                        alpha: 0.0,
                        rising: false,
                        index: 2 * k + 1,
                        time: None,
                        step: None,
                        du: 0.0,
                    },
                ]
            })
            .collect();
        let set = branch_polygons(&SteadyStateData { points: pts }).unwrap();
        assert!(set.contains(&[PAPER.m_l, PAPER.c_l, PAPER.m_r, PAPER.c_r]));
        let inner = set.invert(&w, &vec![1e-9; w.len()]).unwrap();
        for (t, (b, xt)) in inner.iter().zip(&x).enumerate() {
            assert!(b.interval.contains(*xt), "t={t}: {b:?} misses {xt}");
            if b.kind == InnerKind::Inverted {
                assert!(b.interval.radius() < 1e-6, "t={t}: {b:?}");
            }
        }
        assert!(
            inner
                .iter()
                .filter(|b| b.kind == InnerKind::Inverted)
                .count()
                > 10
        );
    }

    proptest::proptest! {
        /// Steady inputs known only to an interval (behind a chain's input blocks): the true
        /// slopes and plays lie in the polygons whatever the true inputs inside the intervals,
        /// and the polygons are those of the exact inputs when every radius is 0.
        #[test]
        fn interval_steady_inputs_keep_the_truth(
            m in 0.1f64..2.0, asym in -0.02f64..0.02, cl in 0.01f64..0.3, cr in 0.01f64..0.3,
            du in 0.0f64..0.05, delta in 1e-5f64..1e-2,
            fr in proptest::collection::vec(0.0f64..1.0, 24),
            noise in proptest::collection::vec(-1.0f64..1.0, 24),
        ) {
            let b = Backlash { m_l: m * (1.0 + asym), c_l: cl, m_r: m * (1.0 - asym), c_r: cr };
            let points: Vec<SteadyPoint> = (0..24).map(|k| {
                let a = 0.6 + 0.1 * (k / 2) as f64;
                let rising = k % 2 == 0;
                let u = if rising { a } else { -a };
                // The input that really reached the backlash: anywhere in u ± du.
                let v = u - du + 2.0 * du * fr[k];
                let w = if rising { b.m_r * (v - b.c_r) } else { b.m_l * (v + b.c_l) };
                SteadyPoint { u, y: w + delta * noise[k], dy: delta, alpha: 0.0, rising, index: k, time: None, step: None, du }
            }).collect();
            let set = branch_polygons(&SteadyStateData { points: points.clone() }).unwrap();
            proptest::prop_assert!(set.contains(&[b.m_l, b.c_l, b.m_r, b.c_r]), "{:?}", set);
            let exact: Vec<SteadyPoint> = points.iter().map(|p| SteadyPoint { du: 0.0, ..*p }).collect();
            let plain = branch_polygons(&SteadyStateData { points: exact.clone() });
            let via = Polygon::from_uncertain_strips(&[], &[], &Polygon::positive_quadrant(), "none");
            proptest::prop_assert!(via.is_err());
            if du == 0.0 {
                proptest::prop_assert_eq!(plain.unwrap().left, set.left);
            }
        }
    }
}
