//! # smid-dead-zone
//!
//! A dead zone with asymmetric slopes and break points as a smid plugin (`type: dead_zone`),
//! on the output side (Wiener, `w = N(G u)`) or the input side (Hammerstein, `w = G(N(u))`):
//!
//! ```text
//! N(x) = m_r (x - c_r)   for x >= c_r
//!        0               for -c_l < x < c_r
//!        m_l (x + c_l)   for x <= -c_l          (m_l, m_r > 0, c_l, c_r >= 0)
//! ```
//!
//! * Stage 1 (the analogue of paper Section 3): under unit gain (eq 8) a steady-state sample
//!   gives `ȳ = N(ū) + η̄`. Each branch is linear in `z = (m, m·c)` (like eqs 11-12 of the
//!   backlash). A sample whose output is clearly non-zero (`ȳ - Δη > 0` for `ū > 0`) lies on
//!   the branch and gives a strip (constraints (16)-(17)); a sample whose output may be zero
//!   only says `m(ū - c) <= ȳ + Δη` (the branch is clipped at 0), a half-plane. The exact
//!   feasible set of each branch is the polygon of the strips cut by those half-planes.
//!   The dead zone is memoryless, so the steady-state output does not depend on the transient:
//!   the overshoot allowance `α` of eqs (14)-(15) is not needed and is ignored.
//! * Stage 2, output side (Props 2-4 adapted): a sample with `y - Δη > 0` is inverted on the
//!   right branch `x = (w + m_r c_r)/m_r`, with `y + Δη < 0` on the left branch; a sample whose
//!   output may be 0 still bounds `x` to `[(y-Δη)/m_l - c_l, (y+Δη)/m_r + c_r]` (the zone,
//!   widened by the noise). Extremes at the polygon vertices and `η = ±Δη` (Prop 4).
//! * Stage 2, input side: `v_t = max(0, m_r u_t - m_r c_r)` for `u_t > 0` (and the mirror for
//!   `u_t < 0`) is monotone in the linear form `m u - m c`, whose range over a polygon is
//!   attained at its vertices: the propagated interval is exact for the polygon.
#![forbid(unsafe_code)]
#![warn(missing_docs)]

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};
use smid_core::prelude::*;

/// A dead zone with known parameters (simulation).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct DeadZone {
    /// Left slope `m_l > 0`.
    pub m_l: f64,
    /// Left break point is `-c_l` (`c_l >= 0`).
    pub c_l: f64,
    /// Right slope `m_r > 0`.
    pub m_r: f64,
    /// Right break point is `c_r` (`c_r >= 0`).
    pub c_r: f64,
}

impl DeadZone {
    /// `N(x)`.
    pub fn map(&self, x: f64) -> f64 {
        if x >= self.c_r {
            self.m_r * (x - self.c_r)
        } else if x <= -self.c_l {
            self.m_l * (x + self.c_l)
        } else {
            0.0
        }
    }
}

#[typetag::serde(name = "dead_zone")]
impl Nonlinearity for DeadZone {
    fn step(&self, _memory: &mut Vec<f64>, x: f64) -> f64 {
        self.map(x)
    }
    /// Behind a gain `k`: the slopes divide by `k`, the zone's edges (input units) multiply.
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
            let slope = name.starts_with('m');
            let ok = v.is_finite() && if slope { v > 0.0 } else { v >= 0.0 };
            if !ok {
                return Err(SmidError::invalid(
                    name,
                    format!(
                        "expected a finite number {} 0, got {v}",
                        if slope { ">" } else { ">=" }
                    ),
                ));
            }
        }
        Ok(())
    }
}

/// The dead zone as a model structure to identify (no options; Wiener or Hammerstein).
#[derive(Debug, Clone, Default, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct DeadZoneModel {}

/// The two exact branch polygons in `(m, m·c)` coordinates.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct DeadZoneSet {
    /// Left branch `w = m_l x + m_l c_l` (for `x <= -c_l`), coordinates `(m_l, m_l c_l)`.
    pub left: Polygon,
    /// Right branch `w = m_r x - m_r c_r` (for `x >= c_r`), coordinates `(m_r, m_r c_r)`.
    pub right: Polygon,
}

/// Strips (samples on the branch) and half-planes `g·z <= d` (samples that may sit in the
/// zone) of one branch; `sign` is `+1` for the right branch, `-1` for the left one.
fn branch(
    data: &SteadyStateData,
    sign: f64,
    what: &str,
) -> Result<(Vec<Strip>, Vec<([f64; 2], f64, usize)>)> {
    let mut strips = Vec::new();
    let mut halves = Vec::new();
    for p in data.points.iter().filter(|p| p.u * sign > 0.0) {
        // Mirror the left branch onto the right one: with s = sign, s·w = m (s·ū) - m c.
        // s·w lies in [lo, hi] and equals max(0, s·(n·z)), where the right branch reads
        // w = ū z0 - z1 (n = [ū, -1]) and the left one w = ū z0 + z1 (n = [ū, 1]).
        let (lo, hi) = if sign > 0.0 {
            (p.y - p.dy, p.y + p.dy)
        } else {
            (-(p.y + p.dy), -(p.y - p.dy))
        };
        let n = [p.u, -sign];
        if lo > 0.0 {
            // Surely on the branch.
            let (slo, shi) = if sign > 0.0 { (lo, hi) } else { (-hi, -lo) };
            strips.push(Strip {
                n,
                lo: slo,
                hi: shi,
                sample: p.index,
            });
        } else if hi >= 0.0 {
            // Possibly in the zone: only sign·(n·z) <= hi.
            halves.push(([sign * n[0], sign * n[1]], hi, p.index));
        } else {
            return Err(SmidError::inconsistent(
                Stage::SteadyState,
                p.index,
                format!(
                    "{what}: the output has the wrong sign for ū = {} beyond the noise bound",
                    p.u
                ),
            ));
        }
    }
    Ok((strips, halves))
}

fn branch_polygon(data: &SteadyStateData, sign: f64, what: &str, slope: &str) -> Result<Polygon> {
    let (strips, halves) = branch(data, sign, what)?;
    let mut poly = Polygon::from_strips(&strips, &Polygon::positive_quadrant(), what)?;
    for (g, d, sample) in halves {
        poly = poly.clip(g, d);
        if poly.is_empty() {
            return Err(SmidError::inconsistent(
                Stage::SteadyState,
                sample,
                format!(
                    "{what}: this sample's output may be 0 only for parameters the others exclude"
                ),
            ));
        }
    }
    if poly.vertices.iter().any(|v| v[0] <= 0.0) {
        return Err(SmidError::Unbounded {
            parameter: slope.into(),
            message:
                "the feasible slope reaches 0: the noise bound is too large for these amplitudes"
                    .into(),
        });
    }
    Ok(poly)
}

/// Stage 1: the exact branch polygons from steady-state data.
pub fn branch_polygons(data: &SteadyStateData) -> Result<DeadZoneSet> {
    data.validate()?;
    Ok(DeadZoneSet {
        left: branch_polygon(data, -1.0, "left branch (m_l, m_l·c_l)", "m_l")?,
        right: branch_polygon(data, 1.0, "right branch (m_r, m_r·c_r)", "m_r")?,
    })
}

#[typetag::serde(name = "dead_zone")]
impl NonlinearityModel for DeadZoneModel {
    /// Nondecreasing for every member (positive slopes), so a monotone step stays one.
    fn keeps_steps_monotone(&self) -> bool {
        true
    }
    fn bound_steady_state(&self, data: &SteadyStateData) -> Result<Box<dyn NonlinearitySet>> {
        Ok(Box::new(branch_polygons(data)?))
    }
    fn supports(&self, _structure: Structure) -> bool {
        true
    }
    /// Unit slopes; each break point swallows at most half of the range its input spans on
    /// that side (0 when that side is never seen). Before the linear block (Hammerstein) the
    /// range seen is the zone's input: `c <= |u|max / 2`. After it (Wiener) the range seen is
    /// the zone's output `y = w - c`, whose input reaches `|y|max + c`: `c <= (|y|max + c)/2`,
    /// that is `c <= |y|max`. (Half the output's range would leave out zones of 0.40 and
    /// 0.47 whose outputs reach 0.69 and 0.81.)
    fn default_prior(&self, s: Structure, seen: (f64, f64)) -> Option<Vec<Interval>> {
        let share = match s {
            Structure::Hammerstein => 0.5,
            Structure::Wiener => 1.0,
        };
        let one = Interval::new(1.0, 1.0);
        let cl = Interval::new(0.0, share * (-seen.0).max(0.0));
        let cr = Interval::new(0.0, share * seen.1.max(0.0));
        Some(vec![one, cl, one, cr])
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
    /// A box of `(m_l, c_l, m_r, c_r)`: each branch's exact image in `(m, m·c)`.
    fn set_from_box(&self, cell: &[Interval]) -> Result<Box<dyn NonlinearitySet>> {
        let (left, right) = two_branch_polygons(cell)?;
        Ok(Box::new(DeadZoneSet { left, right }))
    }
    /// On either side: slopes in `[0.2, 2)`, break points in `[0, 0.5)`; small steady-state
    /// amplitudes (from 0.1) land in the zone, so its half-planes are exercised too.
    fn check_draw(&self, _s: Structure, rng: &mut dyn RngCore) -> Option<CheckDraw> {
        let dz = DeadZone {
            m_l: rng.gen_range(0.2..2.0),
            c_l: rng.gen_range(0.0..0.5),
            m_r: rng.gen_range(0.2..2.0),
            c_r: rng.gen_range(0.0..0.5),
        };
        Some(CheckDraw {
            nonlinearity: Box::new(dz),
            model: Box::new(DeadZoneModel {}),
            steady: (0.1, 3.0),
            amplitude: 2.0,
        })
    }
}

smid_core::register_nonlinearity!(
    "dead_zone",
    DeadZone,
    DeadZone {
        m_l: 0.9,
        c_l: 0.3,
        m_r: 1.1,
        c_r: 0.2
    }
);
smid_core::register_model!("dead_zone", DeadZoneModel, DeadZoneModel {});

impl DeadZoneSet {
    /// `x = (w - m_l c_l)/m_l` over the left polygon and `w` in `[y-d, y+d]`.
    pub fn invert_left(&self, y: f64, d: f64) -> Interval {
        invert_branch(&self.left, y, d, |v, w| (w - v[1]) / v[0])
    }
    /// `x = (w + m_r c_r)/m_r` over the right polygon.
    pub fn invert_right(&self, y: f64, d: f64) -> Interval {
        invert_branch(&self.right, y, d, |v, w| (w + v[1]) / v[0])
    }
    /// Bound on `x_t` from one output sample.
    pub fn invert_sample(&self, y: f64, d: f64) -> InnerBound {
        if y - d > 0.0 {
            InnerBound {
                interval: self.invert_right(y, d),
                kind: InnerKind::Inverted,
            }
        } else if y + d < 0.0 {
            InnerBound {
                interval: self.invert_left(y, d),
                kind: InnerKind::Inverted,
            }
        } else {
            // w in [y-d, 0] on the left, 0 in the zone, [0, y+d] on the right: x lies between
            // the left inverse of y-d and the right inverse of y+d (both monotone in w).
            InnerBound {
                interval: Interval::new(self.invert_left(y, d).lo, self.invert_right(y, d).hi),
                kind: InnerKind::Band,
            }
        }
    }
    /// Bound on `v = N(u)` for a known input sample.
    pub fn propagate_sample(&self, u: f64) -> Interval {
        if u > 0.0 {
            let s = self.right.extremes(|v| u * v[0] - v[1]);
            Interval::new(s.lo.max(0.0), s.hi.max(0.0))
        } else if u < 0.0 {
            let s = self.left.extremes(|v| u * v[0] + v[1]);
            Interval::new(s.lo.min(0.0), s.hi.min(0.0))
        } else {
            Interval::new(0.0, 0.0)
        }
    }
}

#[typetag::serde(name = "dead_zone")]
impl NonlinearitySet for DeadZoneSet {
    /// Order-preserving (positive slopes: nondecreasing), so a chain may feed it interval inputs.
    fn monotone(&self) -> bool {
        true
    }
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

    fn invert(&self, y: &[f64], dy: &[f64]) -> Result<Vec<InnerBound>> {
        check_outputs(y, dy)?;
        Ok(y.iter()
            .zip(dy)
            .map(|(&y, &d)| self.invert_sample(y, d))
            .collect())
    }

    fn propagate(&self, u: &[f64]) -> Result<Vec<InnerBound>> {
        propagate_static(u, |u| self.propagate_sample(u))
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
    use proptest::prelude::*;

    fn steady(
        dz: &DeadZone,
        amps: &[f64],
        d: f64,
        noise: impl Fn(usize) -> f64,
    ) -> SteadyStateData {
        let mut points = Vec::new();
        for &a in amps {
            for u in [a, -a] {
                let i = points.len();
                points.push(SteadyPoint::new(i, u, dz.map(u) + d * noise(i), d));
            }
        }
        SteadyStateData { points }
    }

    const DZ: DeadZone = DeadZone {
        m_l: 0.8,
        c_l: 0.4,
        m_r: 1.2,
        c_r: 0.25,
    };

    #[test]
    fn map_has_the_zone_and_both_branches() {
        assert_eq!(DZ.map(0.0), 0.0);
        assert_eq!(DZ.map(0.2), 0.0);
        assert_eq!(DZ.map(-0.39), 0.0);
        assert!((DZ.map(1.25) - 1.2).abs() < 1e-15);
        assert!((DZ.map(-1.4) + 0.8).abs() < 1e-15);
    }

    #[test]
    fn samples_in_the_zone_cut_the_polygon() {
        // Amplitudes 0.1..0.3 lie in the zone on the left (c_l = 0.4): half-planes only.
        let amps: Vec<f64> = (0..20).map(|k| 0.1 + 0.1 * k as f64).collect();
        let data = steady(&DZ, &amps, 1e-3, |i| ((i * 37 % 11) as f64 / 5.0) - 1.0);
        let set = branch_polygons(&data).unwrap();
        assert!(set.contains(&[DZ.m_l, DZ.c_l, DZ.m_r, DZ.c_r]));
        let c_l = &set.parameters()[1];
        assert!(c_l.interval.radius() < 5e-3, "{c_l:?}");
        // Without the zone samples the set can only be larger.
        let on_branch = SteadyStateData {
            points: data
                .points
                .iter()
                .copied()
                .filter(|p| p.y.abs() > p.dy)
                .collect(),
        };
        let wide = branch_polygons(&on_branch).unwrap();
        for (a, b) in set.parameters().iter().zip(wide.parameters()) {
            assert!(
                a.interval.lo >= b.interval.lo - 1e-12 && a.interval.hi <= b.interval.hi + 1e-12
            );
        }
    }

    #[test]
    fn wrong_sign_output_is_inconsistent_and_names_the_sample() {
        let mut data = steady(&DZ, &[1.0, 2.0, 3.0], 1e-3, |_| 0.0);
        data.points[4].y = -0.5; // ū = +3 but a clearly negative output
        match branch_polygons(&data) {
            Err(SmidError::Inconsistent(smid_core::Falsification { sample, .. })) => {
                assert_eq!(sample, 4)
            }
            other => panic!("expected inconsistency, got {other:?}"),
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(
            std::env::var("PROPTEST_CASES").ok().and_then(|v| v.parse().ok()).unwrap_or(16)))]
        /// Stage 1 and stage 2 (both sides) contain the truth for random dead zones and noise.
        #[test]
        fn truth_inside_stage_1_and_2(
            m_l in 0.2f64..2.0, c_l in 0.0f64..0.5, m_r in 0.2f64..2.0, c_r in 0.0f64..0.5,
            d in 1e-5f64..1e-2, seed in 0u64..1000,
            xs in proptest::collection::vec(-3.0f64..3.0, 20..60),
        ) {
            let dz = DeadZone { m_l, c_l, m_r, c_r };
            let amps: Vec<f64> = (0..15).map(|k| 0.6 + 0.17 * k as f64).collect();
            let noise = |i: usize| (((i as u64 + seed) * 2654435761 % 1000) as f64 / 500.0) - 1.0;
            let set = branch_polygons(&steady(&dz, &amps, d, noise)).unwrap();
            prop_assert!(set.contains(&[m_l, c_l, m_r, c_r]));
            for (b, t) in set.parameters().iter().zip([m_l, c_l, m_r, c_r]) {
                prop_assert!(b.interval.contains(t), "{:?} misses {}", b, t);
            }
            let w: Vec<f64> = xs.iter().map(|&x| dz.map(x)).collect();
            let y: Vec<f64> = w.iter().enumerate().map(|(i, w)| w + d * noise(i + 7)).collect();
            let inner = set.invert(&y, &vec![d; y.len()]).unwrap();
            for (b, x) in inner.iter().zip(&xs) {
                prop_assert!(b.interval.contains(*x), "{:?} misses {}", b, x);
            }
            let v = set.propagate(&xs).unwrap();
            for (b, w) in v.iter().zip(&w) {
                prop_assert!(b.interval.contains(*w), "{:?} misses {}", b, w);
            }
        }
    }
}
