//! The gain traded between the linear block and the block after it when a member is put into
//! another model class ([`GainTrade`]), and the window of gains that keeps that block's values
//! inside their bounds ([`gain_window`]).
use crate::chain::{qualified, Side};
use crate::interval::Interval;
use crate::model::ModelSet;

/// At most this factor either way is traded between the linear block and the block after it
/// ([`GainTrade`]): a parallel input path with `c/A(1)` in `[-3/4, 3]`.
const GAIN_RANGE: f64 = 4.0;

/// The gain `k` a member's linear block may take from the block right after it (the Wiener
/// model's nonlinearity, or a Hammerstein model's first output-side block) when that block is
/// put into `to`'s class: `k·L` followed by the block behind the gain
/// ([`crate::nonlinearity::Nonlinearity::behind_gain`]) simulates as the member does. Under unit
/// gain each class fixes the scale of the inner signal its own way, so two classes whose
/// linear blocks' outputs differ by a scale at rest (a parallel input path's `1 + c/A(1)`
/// against viscous friction on the input velocity, which leaves the gain at rest alone) meet
/// inside `to`'s bounds only with the gain traded.
pub(super) struct GainTrade {
    /// The block's parameters' names, as the plugin gives them.
    short: Vec<String>,
    /// The same, as `to` names them (qualified for a chain block).
    pub(super) names: Vec<String>,
    /// `to`'s bounds of each.
    bounds: Vec<Interval>,
    /// The block at the member's values.
    block: Box<dyn crate::nonlinearity::Nonlinearity>,
    /// The gains that bring every moved value inside `to`'s bounds ([`gain_window`]).
    pub(super) window: Interval,
    /// The member's own values lie outside `to`'s bounds (gain 1 is no point of the class).
    pub(super) needed: bool,
}

impl GainTrade {
    /// The trade for `to`, when the block after its linear block has all its parameters among
    /// the `copied` values and some gain within [`GAIN_RANGE`] brings them inside `to`'s bounds.
    pub(super) fn of(to: &ModelSet, copied: &[(String, f64)]) -> Option<GainTrade> {
        let layout = to.layout().ok()?;
        let (tag, prefix) = match to.model.structure {
            crate::nonlinearity::Structure::Wiener => (to.model.nonlinearity_tag(), None),
            crate::nonlinearity::Structure::Hammerstein => {
                let b = layout.blocks.iter().find(|b| b.side == Side::Output)?;
                (b.tag.clone(), Some(b.prefix.clone()))
            }
        };
        let short = crate::registry::parameter_names(&tag);
        let names: Vec<String> = short
            .iter()
            .map(|n| prefix.as_deref().map_or(n.clone(), |p| qualified(p, n)))
            .collect();
        let values: Vec<(String, f64)> = short
            .iter()
            .zip(&names)
            .map(|(s, f)| {
                copied
                    .iter()
                    .find(|(k, _)| k == f)
                    .map(|(_, v)| (s.clone(), *v))
            })
            .collect::<Option<_>>()?;
        let bounds: Vec<Interval> = names
            .iter()
            .map(|n| to.parameter(n).map(|p| p.interval()))
            .collect::<Option<_>>()?;
        if values.is_empty() {
            return None;
        }
        let mut trade = GainTrade {
            short,
            names,
            bounds,
            block: crate::registry::instantiate(&tag, &values).ok()?,
            window: Interval::new(1.0, 1.0),
            needed: false,
        };
        trade.window = gain_window(&|k| trade.behind(k), &trade.bounds)?;
        trade.needed = trade.moved(1.0).is_none();
        Some(trade)
    }

    /// The block's values behind the gain `k`, in the order of [`GainTrade::short`] (looked up
    /// by name).
    fn behind(&self, k: f64) -> Option<Vec<f64>> {
        let v = self.block.behind_gain(k)?;
        self.short
            .iter()
            .map(|s| v.iter().find(|(n, _)| n == s).map(|(_, x)| *x))
            .collect()
    }

    /// The block's values behind the gain `k`, by their names in `to`, when all lie inside
    /// `to`'s bounds.
    pub(super) fn moved(&self, k: f64) -> Option<Vec<(String, f64)>> {
        self.names
            .iter()
            .zip(self.behind(k)?)
            .zip(&self.bounds)
            .map(|((n, x), b)| b.contains(x).then(|| (n.clone(), x)))
            .collect()
    }

    /// Where gain 1 sits in the window, on [`Transplant::at_gain`]'s log scale (the middle
    /// when outside).
    ///
    /// [`Transplant::at_gain`]: super::comparison::Transplant::at_gain
    pub(super) fn unit_position(&self) -> f64 {
        let w = self.window;
        if w.contains(1.0) && w.hi > w.lo {
            -w.lo.ln() / (w.hi / w.lo).ln()
        } else {
            0.5
        }
    }
}

/// The gains `k` in `[1/GAIN_RANGE, GAIN_RANGE]` at which every value of `behind(k)` lies in
/// its bound in `bounds`: for each value, the hull of the gains of a log grid where it does,
/// each edge bisected against the grid's next gain; or, where the value jumps over its bound
/// between two grid gains (a bound narrower than the grid's step), that crossing bisected from
/// both sides. Then the intersection over the values. For values monotone in `k` (every
/// registered block's) this is the exact window, widened outward by the bisection's last step;
/// `None` when empty.
fn gain_window(behind: &dyn Fn(f64) -> Option<Vec<f64>>, bounds: &[Interval]) -> Option<Interval> {
    const STEPS: i32 = 200;
    const HALVINGS: usize = 60;
    let step = GAIN_RANGE.ln() / f64::from(STEPS);
    let grid: Vec<f64> = (-STEPS..=STEPS)
        .map(|i| (step * f64::from(i)).exp())
        .collect();
    let last = grid.len() - 1;
    // Where value `i` lies at gain `k`: below its bound -1, inside 0, above 1.
    let side = |i: usize, k: f64| -> Option<i8> {
        let v = *behind(k)?.get(i)?;
        let b = bounds[i];
        if v.is_nan() {
            None
        } else if v < b.lo {
            Some(-1)
        } else if v > b.hi {
            Some(1)
        } else {
            Some(0)
        }
    };
    // Between `a` (where `holds` fails) and `b` (where it holds), bisected in `ln k`: the last
    // gain found failing and the first found holding.
    let split = |a: f64, b: f64, holds: &dyn Fn(f64) -> bool| -> (f64, f64) {
        let (mut a, mut b) = (a, b);
        for _ in 0..HALVINGS {
            let m = (a * b).sqrt();
            if holds(m) {
                b = m;
            } else {
                a = m;
            }
        }
        (a, b)
    };
    let mut window = Interval::new(grid[0], grid[last]);
    for i in 0..bounds.len() {
        let s: Vec<Option<i8>> = grid.iter().map(|&k| side(i, k)).collect();
        let hits: Vec<usize> = (0..=last).filter(|&j| s[j] == Some(0)).collect();
        let w = if let (Some(&a), Some(&b)) = (hits.first(), hits.last()) {
            let lo = if a == 0 {
                grid[0]
            } else {
                split(grid[a - 1], grid[a], &|k| side(i, k) == Some(0)).0
            };
            let hi = if b == last {
                grid[last]
            } else {
                split(grid[b], grid[b + 1], &|k| side(i, k) != Some(0)).1
            };
            Interval::new(lo, hi)
        } else {
            let j = (0..last)
                .find(|&j| matches!((s[j], s[j + 1]), (Some(-1), Some(1)) | (Some(1), Some(-1))))?;
            let (from, to) = (s[j], s[j + 1]);
            let lo = split(grid[j], grid[j + 1], &|k| side(i, k) != from).0;
            let hi = split(grid[j], grid[j + 1], &|k| side(i, k) == to).1;
            Interval::new(lo, hi)
        };
        window = window.intersect(&w)?;
    }
    Some(window)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The gain window of a block whose values move as a backlash's (`m/k`, `c·k`) and a
    /// saturation's limit (fixed): found around the true gain however narrow the bounds (far
    /// narrower than the grid's step), empty when the values ask for different gains or a fixed
    /// value lies outside its bound.
    #[test]
    fn the_gain_window_finds_narrow_bounds_and_refuses_disagreeing_ones() {
        let (m, c, s) = (0.25, 0.1, 1.5);
        let behind = |k: f64| Some(vec![m / k, c * k, s]);
        for (k0, width) in [(1.1, 1e-9), (0.3, 1e-4), (3.7, 0.05), (1.0, 1e-12)] {
            let around = |v: f64| Interval::new(v * (1.0 - width), v * (1.0 + width));
            let bounds = [around(m / k0), around(c * k0), Interval::new(1.0, 2.0)];
            let w = gain_window(&behind, &bounds).expect("a window");
            assert!(w.contains(k0), "{k0} outside {w:?}");
            assert!(
                w.hi / w.lo < (1.0 + 4.0 * width) / (1.0 - 4.0 * width) * (1.0 + 1e-9),
                "{k0}, width {width}: {w:?} wider than its bounds ask"
            );
        }
        // Slopes asking for 1.1, plays for 2.
        let bounds = [
            Interval::new(m / 1.1 * 0.999, m / 1.1 * 1.001),
            Interval::new(c * 2.0 * 0.999, c * 2.0 * 1.001),
            Interval::new(1.0, 2.0),
        ];
        assert!(gain_window(&behind, &bounds).is_none());
        // A fixed value outside its bound.
        let bounds = [
            Interval::new(0.0, 1.0),
            Interval::new(0.0, 1.0),
            Interval::new(2.0, 3.0),
        ];
        assert!(gain_window(&behind, &bounds).is_none());
        // Outside the gain range.
        let bounds = [
            Interval::new(m / 9.0, m / 9.0),
            Interval::new(c * 9.0, c * 9.0),
            Interval::new(1.0, 2.0),
        ];
        assert!(gain_window(&behind, &bounds).is_none());
    }
}
