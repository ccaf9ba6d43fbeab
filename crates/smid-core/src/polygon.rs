//! Exact two-dimensional feasible sets: convex polygons cut out by strips `lo <= n·z <= hi`.
//!
//! For a branch of a two-parameter nonlinearity written linearly in `z = (m, m·c)`, each
//! steady-state sample gives one strip (paper constraints (16)-(17)); the intersection is the
//! exact feasible set of that branch. Vertices come from successive half-plane clipping
//! (Sutherland-Hodgman on a convex polygon). Every half-plane is relaxed outward by a tiny
//! rounding pad so the computed polygon contains the exact one. The first sample whose strip
//! empties the polygon is reported, so an empty set names the offending sample.
use crate::error::{Result, SmidError, Stage};
use crate::interval::Interval;

/// One linear two-sided constraint `lo <= n[0] z0 + n[1] z1 <= hi`, tagged by its sample.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Strip {
    /// Normal vector `n` of the two parallel lines bounding the strip.
    pub n: [f64; 2],
    /// Lower bound of `n·z`.
    pub lo: f64,
    /// Upper bound of `n·z`.
    pub hi: f64,
    /// Index of the sample that produced it (reported when the set becomes empty).
    pub sample: usize,
}

/// A convex polygon given by its vertices in counter-clockwise order.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Polygon {
    /// Vertices `[z0, z1]`, counter-clockwise; empty for the empty set.
    pub vertices: Vec<[f64; 2]>,
}

fn pad(v: f64) -> f64 {
    1e-12 * (1.0 + v.abs())
}

impl Polygon {
    /// The axis-aligned box `[x0,x1] x [y0,y1]`.
    pub fn rect(x: Interval, y: Interval) -> Self {
        Polygon {
            vertices: vec![[x.lo, y.lo], [x.hi, y.lo], [x.hi, y.hi], [x.lo, y.hi]],
        }
    }

    /// Clip by the half-plane `n·z <= d` (relaxed outward by a rounding pad).
    pub fn clip(&self, n: [f64; 2], d: f64) -> Polygon {
        let d = d + pad(d);
        let k = self.vertices.len();
        let mut out = Vec::with_capacity(k + 1);
        for i in 0..k {
            let p = self.vertices[i];
            let q = self.vertices[(i + 1) % k];
            let fp = n[0] * p[0] + n[1] * p[1] - d;
            let fq = n[0] * q[0] + n[1] * q[1] - d;
            if fp <= 0.0 {
                out.push(p);
            }
            if (fp < 0.0 && fq > 0.0) || (fp > 0.0 && fq < 0.0) {
                let t = fp / (fp - fq);
                out.push([p[0] + t * (q[0] - p[0]), p[1] + t * (q[1] - p[1])]);
            }
        }
        // Drop consecutive duplicates produced by degenerate cuts.
        out.dedup_by(|a, b| a == b);
        if out.len() > 1 && out.first() == out.last() {
            out.pop();
        }
        Polygon { vertices: out }
    }

    /// Whether no point survives.
    pub fn is_empty(&self) -> bool {
        self.vertices.is_empty()
    }

    /// [`Polygon::from_strips`] for samples whose input is only known to an interval (a chain's
    /// input blocks before the nonlinearity): strip `k` says `lo <= v z0 + n1 z1 <= hi` for
    /// **some** `v ∈ [n0 - du_k, n0 + du_k]`, with `z0 >= 0` (a slope). Exactly, that is the
    /// two half-planes `(n0 - du) z0 + n1 z1 <= hi` and `(n0 + du) z0 + n1 z1 >= lo`. They are
    /// clipped into the polygon of the strips widened by `du·M`, `M` a slope cap of 1000 times
    /// the largest slope the data suggest (`(|lo| + |hi|) / |n0|`): the widened strips only
    /// bound the start, so the result is the exact set (padded outward) for every slope below
    /// the cap. With every `du = 0` it is [`Polygon::from_strips`] itself.
    pub fn from_uncertain_strips(
        strips: &[Strip],
        du: &[f64],
        domain: &[([f64; 2], f64)],
        what: &str,
    ) -> Result<Polygon> {
        if du.iter().all(|&d| d == 0.0) {
            return Polygon::from_strips(strips, domain, what);
        }
        let cap = 1e3
            * strips
                .iter()
                .filter(|s| s.n[0] != 0.0)
                .map(|s| (s.lo.abs() + s.hi.abs()) / s.n[0].abs())
                .fold(1.0, f64::max);
        let widened: Vec<Strip> = strips
            .iter()
            .zip(du)
            .map(|(s, &d)| Strip {
                lo: s.lo - d * cap,
                hi: s.hi + d * cap,
                ..*s
            })
            .collect();
        let mut poly = Polygon::from_strips(&widened, domain, what)?;
        for (s, &d) in strips.iter().zip(du).filter(|(_, d)| **d > 0.0) {
            poly = poly
                .clip([s.n[0] - d, s.n[1]], s.hi)
                .clip([-(s.n[0] + d), -s.n[1]], -s.lo);
            if poly.is_empty() {
                return Err(SmidError::inconsistent(Stage::SteadyState, s.sample, format!(
                        "{what}: no parameter pair fits this sample (its input known to ±{d:.3e}) and the ones before it"
                    )));
            }
        }
        Ok(poly)
    }

    /// Intersect every strip (in sample order) with the `domain` half-planes `g·z <= d`.
    /// The polygon starts as the exact parallelogram of the first strip and the first strip not
    /// parallel to it (no large starting box, so no loss of precision). An empty result names
    /// the first sample whose strip emptied it ([`SmidError::Inconsistent`], stage 1); strips
    /// that are all parallel leave the set unbounded ([`SmidError::Unbounded`]).
    pub fn from_strips(
        strips: &[Strip],
        domain: &[([f64; 2], f64)],
        what: &str,
    ) -> Result<Polygon> {
        for s in strips {
            if !(s.lo.is_finite()
                && s.hi.is_finite()
                && s.n.iter().all(|v| v.is_finite())
                && s.lo <= s.hi)
            {
                return Err(SmidError::invalid(
                    format!("{what}: steady-state sample {}", s.sample),
                    "non-finite or reversed bounds",
                ));
            }
        }
        let empty_at = |sample: usize| {
            SmidError::inconsistent(
                Stage::SteadyState,
                sample,
                format!("{what}: no parameter pair fits this sample and the ones before it"),
            )
        };
        let unbounded = || {
            SmidError::Unbounded {
            parameter: what.to_string(),
            message: "the steady-state samples do not bound this branch (need at least two distinct amplitudes)".into(),
        }
        };
        let first = strips.first().ok_or_else(unbounded)?;
        let norm0 = first.n[0].hypot(first.n[1]);
        let cross = |s: &Strip| {
            (first.n[0] * s.n[1] - first.n[1] * s.n[0]) / (norm0 * s.n[0].hypot(s.n[1]))
        };
        // Strips parallel to the first one, before the first non-parallel: a 1-D consistency check.
        let k = strips.iter().position(|s| cross(s).abs() > 1e-9);
        let mut lo1 = first.lo / norm0;
        let mut hi1 = first.hi / norm0;
        for s in &strips[1..k.unwrap_or(strips.len())] {
            let nn = s.n[0].hypot(s.n[1]);
            let sign = if s.n[0] * first.n[0] + s.n[1] * first.n[1] >= 0.0 {
                1.0
            } else {
                -1.0
            };
            let (a, b) = if sign > 0.0 {
                (s.lo / nn, s.hi / nn)
            } else {
                (-s.hi / nn, -s.lo / nn)
            };
            lo1 = lo1.max(a);
            hi1 = hi1.min(b);
            if lo1 > hi1 + pad(hi1) {
                return Err(empty_at(s.sample));
            }
        }
        let Some(k) = k else { return Err(unbounded()) };
        let (a, b) = (first, &strips[k]);
        let det = a.n[0] * b.n[1] - a.n[1] * b.n[0];
        let solve = |da: f64, db: f64| {
            [
                (da * b.n[1] - db * a.n[1]) / det,
                (a.n[0] * db - b.n[0] * da) / det,
            ]
        };
        let (alo, ahi) = (a.lo - pad(a.lo), a.hi + pad(a.hi));
        let (blo, bhi) = (b.lo - pad(b.lo), b.hi + pad(b.hi));
        let mut poly = Polygon {
            vertices: vec![
                solve(alo, blo),
                solve(ahi, blo),
                solve(ahi, bhi),
                solve(alo, bhi),
            ],
        };
        for s in strips
            .iter()
            .enumerate()
            .filter(|(i, _)| *i != 0 && *i != k)
            .map(|(_, s)| s)
        {
            poly = poly.clip(s.n, s.hi).clip([-s.n[0], -s.n[1]], -s.lo);
            if poly.is_empty() {
                return Err(empty_at(s.sample.max(b.sample)));
            }
        }
        for (g, d) in domain {
            poly = poly.clip(*g, *d);
            if poly.is_empty() {
                return Err(SmidError::inconsistent(
                    Stage::SteadyState,
                    strips.last().map(|s| s.sample).unwrap_or(0),
                    format!("{what}: the samples fit no parameters with positive slope and offset"),
                ));
            }
        }
        Ok(poly)
    }

    /// The exact image of a box `m ∈ [m0, m1]`, `c ∈ [c0, c1]` (`m0 > 0`) in the coordinates
    /// `(m, m·c)` of a linear branch: for each `m` the segment `m·c ∈ [c0 m, c1 m]`, so the
    /// image is the quadrilateral between two rays through the origin cut by two verticals.
    /// Quasi-linear functions of `(m, m·c)` (the branch inverses) then take their extremes over
    /// the box at its corners, and the plugins' vertex-based inversion holds per cell.
    pub fn from_slope_offset_box(m: Interval, c: Interval) -> Result<Polygon> {
        if !(m.lo > 0.0 && m.lo <= m.hi && c.lo <= c.hi && m.is_finite() && c.is_finite()) {
            return Err(SmidError::invalid(
                "model.prior",
                format!(
                    "a slope box needs 0 < lo <= hi and an offset box lo <= hi, finite; got m ∈ [{}, {}], c ∈ [{}, {}]",
                    m.lo, m.hi, c.lo, c.hi
                ),
            ));
        }
        Ok(Polygon {
            vertices: vec![
                [m.lo, c.lo * m.lo],
                [m.hi, c.lo * m.hi],
                [m.hi, c.hi * m.hi],
                [m.lo, c.hi * m.lo],
            ],
        })
    }

    /// The half-planes `z0 >= 0`, `z1 >= 0`.
    pub fn positive_quadrant() -> [([f64; 2], f64); 2] {
        [([-1.0, 0.0], 0.0), ([0.0, -1.0], 0.0)]
    }

    /// Range of `f` over the vertices, widened outward. Exact for functions that are
    /// quasi-linear on the polygon (linear or linear-fractional with positive denominator):
    /// their extremes over a convex polygon lie on its vertices.
    pub fn extremes(&self, f: impl Fn([f64; 2]) -> f64) -> Interval {
        Interval::hull_of(self.vertices.iter().map(|&v| f(v)))
            .unwrap_or(Interval::new(f64::NAN, f64::NAN))
            .outward()
    }

    /// Whether `z` lies in the polygon (up to the rounding pad).
    pub fn contains(&self, z: [f64; 2]) -> bool {
        let k = self.vertices.len();
        match k {
            0 => false,
            1 => {
                let v = self.vertices[0];
                (v[0] - z[0]).abs() <= pad(v[0]) * 10.0 && (v[1] - z[1]).abs() <= pad(v[1]) * 10.0
            }
            _ => {
                // Inside the vertices' bounding box first (to the edge test's relative
                // tolerance): a polygon flattened to a segment (a fixed slope, `m.lo == m.hi`)
                // has only collinear edges, which bound nothing along the segment itself.
                let tol = 1e-10 * (1.0 + z[0].abs() + z[1].abs());
                for (i, zi) in z.iter().enumerate() {
                    let (lo, hi) = self
                        .vertices
                        .iter()
                        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
                            (a.min(v[i]), b.max(v[i]))
                        });
                    if *zi < lo - tol || *zi > hi + tol {
                        return false;
                    }
                }
                // Orientation-agnostic: z is inside when it is on the same side of every edge.
                // Clipping can leave edges of ~1e-15 between near-duplicate vertices; their
                // direction is rounding noise, so edges negligible against the polygon's size
                // are skipped (the neighbouring edges carry the boundary there).
                let diam = self
                    .vertices
                    .iter()
                    .flat_map(|a| {
                        self.vertices
                            .iter()
                            .map(move |b| (a[0] - b[0]).hypot(a[1] - b[1]))
                    })
                    .fold(0.0, f64::max);
                let sides: Vec<f64> = (0..k)
                    .filter_map(|i| {
                        let p = self.vertices[i];
                        let q = self.vertices[(i + 1) % k];
                        let len = (q[0] - p[0]).hypot(q[1] - p[1]);
                        if len <= 1e-9 * diam {
                            return None;
                        }
                        let cross = (q[0] - p[0]) * (z[1] - p[1]) - (q[1] - p[1]) * (z[0] - p[0]);
                        Some(cross / (len * (1.0 + z[0].abs() + z[1].abs())))
                    })
                    .collect();
                sides.iter().all(|&c| c >= -1e-10) || sides.iter().all(|&c| c <= 1e-10)
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// A fixed slope flattens a slope-offset box to a segment: its collinear edges bound
    /// nothing along it, the bounding box does.
    #[test]
    fn a_segment_holds_its_own_extent_only() {
        let seg = Polygon::from_slope_offset_box(Interval::new(1.0, 1.0), Interval::new(0.2, 0.4))
            .unwrap();
        assert!(seg.contains([1.0, 0.3]));
        assert!(seg.contains([1.0, 0.4]));
        assert!(!seg.contains([1.0, 0.45]));
        assert!(!seg.contains([1.0, 0.15]));
        assert!(!seg.contains([1.01, 0.3]));
    }

    #[test]
    fn two_strips_make_a_parallelogram() {
        let strips = [
            Strip {
                n: [1.0, -1.0],
                lo: -0.1,
                hi: 0.1,
                sample: 0,
            },
            Strip {
                n: [2.0, -1.0],
                lo: 0.9,
                hi: 1.1,
                sample: 1,
            },
        ];
        let p = Polygon::from_strips(&strips, &Polygon::positive_quadrant(), "test").unwrap();
        assert_eq!(p.vertices.len(), 4);
        let x = p.extremes(|v| v[0]);
        assert!(
            (x.lo - 0.8).abs() < 1e-9 && (x.hi - 1.2).abs() < 1e-9,
            "{x:?}"
        );
    }

    #[test]
    fn empty_names_first_offending_sample() {
        let strips = [
            Strip {
                n: [1.0, 0.0],
                lo: 1.0,
                hi: 2.0,
                sample: 0,
            },
            Strip {
                n: [0.0, 1.0],
                lo: 1.0,
                hi: 2.0,
                sample: 1,
            },
            Strip {
                n: [1.0, 0.0],
                lo: 3.0,
                hi: 4.0,
                sample: 7,
            },
        ];
        match Polygon::from_strips(&strips, &Polygon::positive_quadrant(), "t") {
            Err(SmidError::Inconsistent(crate::outcome::Falsification {
                sample, stage, ..
            })) => {
                assert_eq!(sample, 7);
                assert_eq!(stage, Stage::SteadyState);
            }
            other => panic!("expected inconsistency, got {other:?}"),
        }
    }

    #[test]
    fn contains_ignores_rounding_edges_between_near_duplicate_vertices() {
        // The left-branch polygon of a proptest case (input backlash, seed 348): clipping left
        // near-duplicate vertices whose ~1e-15 edges flipped the side test.
        let p = Polygon {
            vertices: vec![
                [0.665958303166066, 0.18162683494725518],
                [0.6615393043777904, 0.178224205880283],
                [0.6615393043777902, 0.17822420588028254],
                [0.6571203055909394, 0.1658068192892319],
                [0.6615393043791133, 0.16845821856213633],
                [0.6615393043791133, 0.16845821856213639],
                [0.661539304379114, 0.1684582185621381],
            ],
        };
        let (m, c) = (0.6640669716838972, 0.2680489590816805);
        assert!(p.contains([m, m * c]));
        assert!(!p.contains([m, m * c + 0.01]));
        assert!(!p.contains([0.70, 0.17]));
    }

    #[test]
    fn single_direction_is_unbounded() {
        let strips = [Strip {
            n: [1.0, -1.0],
            lo: -0.1,
            hi: 0.1,
            sample: 0,
        }];
        assert!(matches!(
            Polygon::from_strips(&strips, &Polygon::positive_quadrant(), "t"),
            Err(SmidError::Unbounded { .. })
        ));
    }

    proptest! {
        /// Any point satisfying all strips lies inside the computed polygon.
        #[test]
        fn polygon_contains_every_feasible_point(
            z0 in 0.1f64..2.0, z1 in 0.0f64..0.5,
            us in proptest::collection::vec(0.3f64..3.0, 2..20),
            w in 1e-5f64..1e-2,
        ) {
            let strips: Vec<Strip> = us.iter().enumerate().map(|(i, &u)| {
                let c = u * z0 - z1;
                Strip { n: [u, -1.0], lo: c - w, hi: c + w * 0.3, sample: i }
            }).collect();
            // need two distinct amplitudes for boundedness
            prop_assume!(us.iter().any(|&u| (u - us[0]).abs() > 0.05));
            let p = Polygon::from_strips(&strips, &Polygon::positive_quadrant(), "t").unwrap();
            prop_assert!(p.contains([z0, z1]));
            let r = p.extremes(|v| v[0]);
            prop_assert!(r.contains(z0));
        }
    }
}
