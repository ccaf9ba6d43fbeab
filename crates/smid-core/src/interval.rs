//! Closed real intervals with outward rounding.
//!
//! Bounds in smid are guarantees, so every interval computed in floating point is widened
//! outward by a few units in the last place ([`Interval::outward`]); a bound may be slightly
//! loose, never tight past the truth.
use serde::{Deserialize, Serialize};

/// Relative widening applied to every computed bound (covers floating-point rounding of the
/// closed-form evaluations; solver tolerances are handled separately and more generously).
pub const REL_PAD: f64 = 1e-12;
/// Absolute widening applied next to [`REL_PAD`].
pub const ABS_PAD: f64 = 1e-15;

/// A closed interval `[lo, hi]`. In JSON an infinite end is written `null` (JSON has no
/// infinity) and read back as `-inf` for `lo`, `+inf` for `hi`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Interval {
    /// Lower end (may be `-inf`).
    #[serde(deserialize_with = "lo_or_minus_inf")]
    pub lo: f64,
    /// Upper end (may be `+inf`).
    #[serde(deserialize_with = "hi_or_plus_inf")]
    pub hi: f64,
}

fn lo_or_minus_inf<'de, D: serde::Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    Ok(Option::<f64>::deserialize(d)?.unwrap_or(f64::NEG_INFINITY))
}

fn hi_or_plus_inf<'de, D: serde::Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    Ok(Option::<f64>::deserialize(d)?.unwrap_or(f64::INFINITY))
}

impl Interval {
    /// The interval `[lo, hi]` (the caller ensures `lo <= hi`).
    pub fn new(lo: f64, hi: f64) -> Self {
        Interval { lo, hi }
    }
    /// The whole real line.
    pub fn entire() -> Self {
        Interval::new(f64::NEG_INFINITY, f64::INFINITY)
    }
    /// Center `(lo + hi) / 2` (paper eqs 19, 28).
    pub fn center(&self) -> f64 {
        0.5 * (self.lo + self.hi)
    }
    /// Radius `(hi - lo) / 2` (paper eqs 19, 28).
    pub fn radius(&self) -> f64 {
        0.5 * (self.hi - self.lo)
    }
    /// Whether `v` lies in the interval.
    pub fn contains(&self, v: f64) -> bool {
        self.lo <= v && v <= self.hi
    }
    /// Whether both ends are finite.
    pub fn is_finite(&self) -> bool {
        self.lo.is_finite() && self.hi.is_finite()
    }
    /// Widen by `rel * max(|lo|,|hi|) + abs` on both sides, the max over the finite ends: a
    /// half-line `[a, ∞)` stays one (`[a - rel |a| - abs, ∞)`), not the whole line.
    pub fn widen(&self, rel: f64, abs: f64) -> Self {
        let m = [self.lo, self.hi]
            .into_iter()
            .filter(|v| v.is_finite())
            .fold(0.0f64, |m, v| m.max(v.abs()));
        let pad = rel * m + abs;
        Interval::new(self.lo - pad, self.hi + pad)
    }
    /// Widen by the default rounding pad ([`REL_PAD`], [`ABS_PAD`]).
    pub fn outward(&self) -> Self {
        self.widen(REL_PAD, ABS_PAD)
    }
    /// Smallest interval holding all `values` (None if empty or any value is NaN).
    pub fn hull_of(values: impl IntoIterator<Item = f64>) -> Option<Self> {
        let mut lo = f64::INFINITY;
        let mut hi = f64::NEG_INFINITY;
        let mut any = false;
        for v in values {
            if v.is_nan() {
                return None;
            }
            lo = lo.min(v);
            hi = hi.max(v);
            any = true;
        }
        any.then_some(Interval::new(lo, hi))
    }
    /// Intersection, `None` when empty.
    pub fn intersect(&self, other: &Interval) -> Option<Interval> {
        let lo = self.lo.max(other.lo);
        let hi = self.hi.min(other.hi);
        (lo <= hi).then_some(Interval::new(lo, hi))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    #[test]
    fn outward_only_grows() {
        let i = Interval::new(-1.0, 2.0);
        let o = i.outward();
        assert!(o.lo < i.lo && o.hi > i.hi);
        assert_eq!(
            Interval::hull_of([3.0, -1.0, 2.0]),
            Some(Interval::new(-1.0, 3.0))
        );
        assert_eq!(Interval::hull_of([1.0, f64::NAN]), None);
        assert!(Interval::new(0.0, 1.0)
            .intersect(&Interval::new(2.0, 3.0))
            .is_none());
    }

    #[test]
    fn a_half_line_widens_to_a_half_line() {
        for (lo, hi) in [(2.0, f64::INFINITY), (f64::NEG_INFINITY, -3.0)] {
            let o = Interval::new(lo, hi).outward();
            assert!(o.lo <= lo && o.hi >= hi, "{o:?}");
            // The finite end moves by its rounding pad only.
            let (end, widened) = if lo.is_finite() {
                (lo, o.lo)
            } else {
                (hi, o.hi)
            };
            assert!(
                (widened - end).abs() < 1e-6,
                "{o:?} lost its finite end {end}"
            );
        }
        assert_eq!(Interval::entire().outward(), Interval::entire());
    }

    #[test]
    fn infinite_ends_round_trip_through_json() {
        let i = Interval::new(f64::NEG_INFINITY, 2.0);
        let j: Interval = serde_json::from_str(&serde_json::to_string(&i).unwrap()).unwrap();
        assert_eq!(i, j);
        let e: Interval = serde_json::from_str(r#"{"lo":null,"hi":null}"#).unwrap();
        assert_eq!(e, Interval::entire());
    }
}
