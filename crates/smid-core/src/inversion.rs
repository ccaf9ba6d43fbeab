//! The interval-inversion engine (paper Section 4, Props 2-4).
//!
//! Given an uncertain nonlinearity whose parameter set is a convex polygon (known by its
//! vertices) and a measured output `y_t` with `|eta_t| <= Δη_t`, the inner signal on a branch
//! is a function `x = f(vertex, w)` with `w = y - eta`. When `f` is quasi-linear in the vertex
//! coordinates and monotone in `w` (true of every branch inverse of a piecewise-linear
//! nonlinearity written in `(m, m·c)`), its extremes occur at the polygon's vertices and
//! `eta = ±Δη` (Prop 4): that is all this engine evaluates. The result is widened outward.
use crate::interval::Interval;
use crate::polygon::Polygon;

/// Range of `f(vertex, w)` over the polygon's vertices and `w in {y - Δη, y + Δη}`.
pub fn invert_branch(
    poly: &Polygon,
    y: f64,
    dy: f64,
    f: impl Fn([f64; 2], f64) -> f64,
) -> Interval {
    let ws = [y - dy, y + dy];
    Interval::hull_of(
        poly.vertices
            .iter()
            .flat_map(|&v| ws.iter().map(move |&w| (v, w)))
            .map(|(v, w)| f(v, w)),
    )
    .unwrap_or(Interval::new(f64::NAN, f64::NAN))
    .outward()
}

/// Check measured outputs for stage 2: `y` and `dy` of equal length, every `y_t` finite, every
/// `Δη_t` finite and `>= 0`. Errors name the sample. The pipeline calls this before inverting.
pub fn check_outputs(y: &[f64], dy: &[f64]) -> crate::Result<()> {
    if y.len() != dy.len() {
        return Err(crate::SmidError::invalid(
            "dynamic data",
            format!("{} outputs but {} noise bounds", y.len(), dy.len()),
        ));
    }
    match y
        .iter()
        .zip(dy)
        .position(|(y, d)| !(y.is_finite() && d.is_finite() && *d >= 0.0))
    {
        Some(t) => Err(crate::SmidError::invalid(
            format!("dynamic sample {t}"),
            "non-finite output or noise bound",
        )),
        None => Ok(()),
    }
}

/// Stage 2 of a static (memoryless) block on the input side: `f(u_t)` is a guaranteed interval
/// of the block's output for the known input `u_t` over the whole set; the result is widened
/// outward. A non-finite input is an error naming the sample.
pub fn propagate_static(u: &[f64], f: impl Fn(f64) -> Interval) -> crate::Result<Vec<InnerBound>> {
    u.iter()
        .enumerate()
        .map(|(t, &u)| {
            if !u.is_finite() {
                return Err(crate::SmidError::invalid(
                    format!("dynamic sample {t}"),
                    "non-finite input",
                ));
            }
            Ok(InnerBound {
                interval: f(u).outward(),
                kind: InnerKind::Inverted,
            })
        })
        .collect()
}

/// How a sample of the inner signal was bounded.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum InnerKind {
    /// The output moved by more than 2Δη: the sample was inverted on one branch (eqs 24-27).
    Inverted,
    /// The output may not have moved: the inner signal is only known to lie in the dead band
    /// (or another set the plugin derives); the bound is valid but wide.
    Band,
    /// Nothing is known (e.g. the first sample).
    Unknown,
    /// The measurement has a preimage of two intervals, mirror images of each other: the
    /// sample lies in `interval` or in `-interval` (behind `|·|` or another even map, where
    /// the output cannot tell the sign of its input). Stage 3 takes such samples as unusable
    /// (every bound it computes without them holds); the pipeline's sign search
    /// ([`crate::pipeline::signs`]) decides their signs branch by branch and bounds each
    /// surviving pattern. Anything that needs one interval takes [`InnerBound::hull`].
    Mirrored,
}

/// A guaranteed bound on one inner-signal sample.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct InnerBound {
    /// The interval that holds the sample (the whole line when unknown).
    pub interval: Interval,
    /// How the interval was obtained.
    pub kind: InnerKind,
}

impl InnerBound {
    /// An unknown sample (the whole line).
    pub fn unknown() -> Self {
        InnerBound {
            interval: Interval::entire(),
            kind: InnerKind::Unknown,
        }
    }

    /// A sample that lies in `interval` or in `-interval` ([`InnerKind::Mirrored`]).
    pub fn mirrored(interval: Interval) -> Self {
        InnerBound {
            interval,
            kind: InnerKind::Mirrored,
        }
    }

    /// One interval that holds the sample: the interval itself, or for a mirrored sample the
    /// hull of `interval` and `-interval`.
    pub fn hull(&self) -> Interval {
        match self.kind {
            InnerKind::Mirrored => Interval::new(
                self.interval.lo.min(-self.interval.hi),
                self.interval.hi.max(-self.interval.lo),
            ),
            _ => self.interval,
        }
    }

    /// Whether the bound holds `v`: inside `interval`, or for a mirrored sample inside its
    /// mirror image too.
    pub fn contains(&self, v: f64) -> bool {
        self.interval.contains(v)
            || (self.kind == InnerKind::Mirrored && self.interval.contains(-v))
    }

    /// The sample with the sign of a mirrored one decided: `interval` (`positive`) or
    /// `-interval`, as an inverted sample. Any other sample is returned unchanged.
    pub fn with_sign(&self, positive: bool) -> Self {
        match self.kind {
            InnerKind::Mirrored if positive => InnerBound {
                interval: self.interval,
                kind: InnerKind::Inverted,
            },
            InnerKind::Mirrored => InnerBound {
                interval: Interval::new(-self.interval.hi, -self.interval.lo),
                kind: InnerKind::Inverted,
            },
            _ => *self,
        }
    }
}
