//! Block chains: the model's blocks on each side of the identified linear block `L(θ)`,
//!
//! ```text
//! u -> N_in,1 -> ... -> N_in,k -> L(θ) -> N_out,1 -> ... -> N_out,m -> y = w + s + η
//! ```
//!
//! where the spec's `model.nonlinearity` is the last input block (Hammerstein) or the first
//! output block (Wiener), and `model.input` / `model.output` add blocks before and after it. A
//! block is any registered nonlinearity plugin, static or with memory; a low-order linear filter
//! (a sensor or actuator lag) is a plugin of the same kind (`plugins/filters`). A block other
//! than the spec's nonlinearity is bisected by the branch and bound over its prior box (its
//! parameters are named `in1.m_l`, `out1.p`, ...: side, position, parameter).
//!
//! Stage 2 over a cell (Section 4 generalised, eqs 23-27):
//! * **Input side, forward** ([`forward`]): the known input runs through every input block over
//!   its cell as an interval simulation with memory ([`NonlinearitySet::propagate`] for the
//!   first block, [`NonlinearitySet::propagate_intervals`] after it). The result bounds the
//!   signal `v_t` that enters `L` for every member of the cell.
//! * **Output side, backward** ([`backward`]): from `y_t ± Δη_t` (sensor terms already removed),
//!   each output block is inverted in reverse signal order over its cell
//!   ([`NonlinearitySet::invert`]), its result (an interval per sample) being the next block's
//!   output `centre ± radius`. Samples a block leaves unknown split the record into runs that
//!   are inverted separately (a plugin's inversion may not assume it starts at rest). The noise
//!   bound carries through every inversion as part of the interval; an inverse filter
//!   `(s_t - p s_{t-1})/(1 - p)` turns `Δη` into `(1 + |p|)Δη/(1 - p)` (the errors of
//!   consecutive samples are treated as independent intervals: sound, not tight).
//! * **Stage 1** ([`backward_steady`]): steady-state points reach the spec's nonlinearity
//!   through the output blocks' steady-state inverses ([`NonlinearitySet::invert_steady`]).
//!
//! With no block beside the spec's nonlinearity every function here makes exactly the calls
//! the paper's three stages made (the snapshots pin it).
use crate::error::{Result, SmidError, Stage};
use crate::interval::Interval;
use crate::inversion::{InnerBound, InnerKind};
use crate::nonlinearity::{NonlinearitySet, SteadyPoint, Structure};
use serde::{Deserialize, Serialize};
use std::ops::Range;

/// The side of the linear block a block sits on.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Side {
    /// Before `L`: the block sees the input (forward propagation).
    Input,
    /// After `L` (after the spec's nonlinearity in a Wiener model): inverted from the output.
    Output,
}

impl Side {
    /// The structure a plugin must support to sit on this side
    /// ([`crate::nonlinearity::NonlinearityModel::supports`]).
    pub fn structure(self) -> Structure {
        match self {
            Side::Input => Structure::Hammerstein,
            Side::Output => Structure::Wiener,
        }
    }
    /// The spec's field of this side's blocks.
    pub fn field(self) -> &'static str {
        match self {
            Side::Input => "model.input",
            Side::Output => "model.output",
        }
    }
    /// The prefix of the `position`-th block (1-based) of this side: `in1`, `out2`, ...
    pub fn prefix(self, position: usize) -> String {
        match self {
            Side::Input => format!("in{position}"),
            Side::Output => format!("out{position}"),
        }
    }
}

/// A block of the chain besides the spec's nonlinearity, as the layout resolved it.
#[derive(Debug, Clone, PartialEq)]
pub struct BlockLayout {
    /// Whether the block sits before the linear block (`model.input`) or after the
    /// nonlinearity (`model.output`).
    pub side: Side,
    /// Index in its side's list (`model.input[index]`).
    pub index: usize,
    /// The plugin's `type`.
    pub tag: String,
    /// `in1`, `out1`, ...: the prefix of its parameter names.
    pub prefix: String,
    /// Its parameters' slice of the bisected parameters `ψ`.
    pub cells: Range<usize>,
}

impl BlockLayout {
    /// The model's name of one of the block's parameters (`in1.c_l`).
    pub fn name(&self, parameter: &str) -> String {
        qualified(&self.prefix, parameter)
    }
}

/// `prefix.parameter`.
pub fn qualified(prefix: &str, parameter: &str) -> String {
    format!("{prefix}.{parameter}")
}

/// The signal entering `L` from the known input `u`, through the input blocks in signal order
/// (empty: `u` itself, exact).
pub fn forward(blocks: &[&dyn NonlinearitySet], u: &[f64]) -> Result<Vec<InnerBound>> {
    let Some((first, rest)) = blocks.split_first() else {
        return Ok(u
            .iter()
            .map(|&v| InnerBound {
                interval: Interval::new(v, v),
                kind: InnerKind::Inverted,
            })
            .collect());
    };
    let mut v = first.propagate(u)?;
    for b in rest {
        let iv: Vec<Interval> = v.iter().map(|b| b.interval).collect();
        v = b.propagate_intervals(&iv)?;
    }
    Ok(v)
}

/// The signal leaving `L` from the outputs `y ± dy`, through the output blocks given in signal
/// order (inverted from the last). Empty: `[y - dy, y + dy]` widened outward.
pub fn backward(blocks: &[&dyn NonlinearitySet], y: &[f64], dy: &[f64]) -> Result<Vec<InnerBound>> {
    let Some((last, before)) = blocks.split_last() else {
        return Ok(y
            .iter()
            .zip(dy)
            .map(|(&y, &d)| InnerBound {
                interval: Interval::new(y - d, y + d).outward(),
                kind: InnerKind::Inverted,
            })
            .collect());
    };
    // The last block sees the measurements as they are (bit for bit the paper's call).
    let mut cur = last.invert(y, dy)?;
    for b in before.iter().rev() {
        cur = invert_runs(*b, &cur)?;
    }
    Ok(cur)
}

/// Invert `block` from interval outputs, run by run between unknown samples.
fn invert_runs(block: &dyn NonlinearitySet, w: &[InnerBound]) -> Result<Vec<InnerBound>> {
    // A two-sided preimage (a sample behind `|·|`) enters the next block as its hull.
    let w: Vec<InnerBound> = w
        .iter()
        .map(|b| InnerBound {
            interval: b.hull(),
            kind: if b.kind == InnerKind::Mirrored {
                InnerKind::Band
            } else {
                b.kind
            },
        })
        .collect();
    let w = &w[..];
    let mut out = vec![InnerBound::unknown(); w.len()];
    let mut t = 0;
    while t < w.len() {
        if w[t].interval.lo > w[t].interval.hi {
            // The block after this one has no value here over the whole cell (a backlash's dead
            // band closed): the cell is inconsistent, as stage 3 would find from this interval.
            return Err(SmidError::inconsistent(
                Stage::InnerSignal,
                t,
                "the output side of the chain leaves no value for this sample over the cell",
            ));
        }
        if !w[t].interval.is_finite() {
            t += 1;
            continue;
        }
        let start = t;
        while t < w.len() && w[t].interval.is_finite() && w[t].interval.lo <= w[t].interval.hi {
            t += 1;
        }
        let (c, r): (Vec<f64>, Vec<f64>) = w[start..t]
            .iter()
            .map(|b| centre_radius(b.interval))
            .unzip();
        // A block's own proof names a sample of this run: moved to the record's index.
        let inv = block.invert(&c, &r).map_err(|e| match e {
            SmidError::Inconsistent(f) => SmidError::Inconsistent(crate::finding::Falsification {
                sample: f.sample + start,
                ..f
            }),
            e => e,
        })?;
        out[start..t].copy_from_slice(&inv);
    }
    Ok(out)
}

/// `(c, r)` with `[c - r, c + r]` holding the interval despite rounding.
pub fn centre_radius(i: Interval) -> (f64, f64) {
    let c = i.center();
    let r = (i.hi - c).max(c - i.lo);
    (c, r + (c.abs() + r) * 4.0 * f64::EPSILON)
}

/// A steady-state output `y ± dy` (steady-state point `index`) carried back through the output
/// blocks (signal order) to the output of the block before them: `(centre, radius)`. Empty:
/// `(y, dy)` unchanged. A block that no member leaves at this output (beyond a saturation's
/// limits) proves the cell inconsistent at that point (stage 1).
pub fn backward_steady(
    blocks: &[&dyn NonlinearitySet],
    index: usize,
    y: f64,
    dy: f64,
) -> Result<(f64, f64)> {
    let (mut c, mut r) = (y, dy);
    for b in blocks.iter().rev() {
        let i = b.invert_steady(c, r).map_err(at_point(index))?;
        if !i.is_finite() {
            return Ok((0.0, f64::INFINITY));
        }
        (c, r) = centre_radius(i);
    }
    Ok((c, r))
}

/// A block's inconsistency found at steady-state point `index`, named there (stage 1).
fn at_point(index: usize) -> impl Fn(SmidError) -> SmidError {
    move |e| match e {
        SmidError::Inconsistent(f) => SmidError::inconsistent(
            Stage::SteadyState,
            index,
            format!("steady-state point {index}: {}", f.detail),
        ),
        e => e,
    }
}

/// [`backward_steady`] for a point of the designed experiment whose step started at the
/// steady output `before` (`y0 ± dy0`, the previous point's) and over which the first output
/// block's input moved monotonically but for an overshoot of at most `alpha` against the step's
/// direction (`rising`): that block is inverted with
/// [`NonlinearitySet::invert_steady_step`], widened by `alpha` on the side the overshoot
/// could leave its input (below the branch after a rising step, above after a falling one) and
/// cut to its any-history inversion (a block that does not read the step keeps that one
/// exactly); the blocks after it, and the previous output through them, with any history.
pub fn backward_steady_step(
    blocks: &[&dyn NonlinearitySet],
    index: usize,
    before: (f64, f64),
    (y, dy): (f64, f64),
    rising: bool,
    alpha: f64,
) -> Result<(f64, f64)> {
    let Some((first, rest)) = blocks.split_first() else {
        return Ok((y, dy));
    };
    let (c, r) = backward_steady(rest, index, y, dy)?;
    if !r.is_finite() {
        return Ok((0.0, f64::INFINITY));
    }
    // The previous point is checked as itself; here it only serves when it inverts.
    let (c0, r0) = match backward_steady(rest, index, before.0, before.1) {
        Ok((c0, r0)) if r0.is_finite() => (c0, r0),
        _ => return backward_steady(&[*first], index, c, r),
    };
    // Any history holds whatever the step did; the step's reading, widened by the overshoot
    // allowance, can only cut it down (a block that does not read the step gives it back).
    let any = first.invert_steady(c, r).map_err(at_point(index))?;
    let step = first
        .invert_steady_step(c0, r0, c, r, rising)
        .map_err(at_point(index))?;
    let i = if step == any || !step.is_finite() {
        any
    } else {
        let wide = if rising {
            Interval::new(step.lo - alpha, step.hi)
        } else {
            Interval::new(step.lo, step.hi + alpha)
        }
        .outward();
        wide.intersect(&any).unwrap_or(any)
    };
    if !i.is_finite() {
        return Ok((0.0, f64::INFINITY));
    }
    Ok(centre_radius(i))
}

/// A steady input `v` (an interval) carried forward through the input blocks (signal order) at
/// both ends of each block: the hull of `propagate_steady` at the two ends, which holds every
/// member of an order-preserving block. `None` when an interval reaches a block that is not
/// [`NonlinearitySet::monotone`] (nothing can be said) or a block's answer is not a number.
pub fn forward_steady(
    blocks: &[&dyn NonlinearitySet],
    mut v: Interval,
) -> Result<Option<Interval>> {
    for b in blocks {
        if v.lo != v.hi && !b.monotone() {
            return Ok(None);
        }
        let lo = b.propagate_steady(v.lo)?;
        let hi = b.propagate_steady(v.hi)?;
        v = Interval::new(lo.lo.min(hi.lo), lo.hi.max(hi.hi));
        if v.lo.is_nan() || v.hi.is_nan() {
            return Ok(None);
        }
    }
    Ok(Some(v))
}

/// A steady-state point carried forward through the input blocks over their cell (stage 1 of
/// a chain with input blocks that keep its design): the input `ū ± du` becomes the hull of the
/// blocks' steady outputs ([`forward_steady`]), and the step height and the overshoot
/// allowance α (eqs 14-15) grow with the step the linear block now sees: the step's range
/// ([`SteadyPoint::step_hull`]) carried forward is at least `k` times as wide behind a gain
/// `k` of the cell, and α, set for the raw step, is scaled by that ratio (never below it), so
/// it still bounds the overshoot. `rising` stays: the blocks are monotone. `None`: a
/// non-monotone block met an interval.
pub fn forward_steady_point(
    blocks: &[&dyn NonlinearitySet],
    p: &SteadyPoint,
) -> Result<Option<SteadyPoint>> {
    let Some(v) = forward_steady(blocks, Interval::new(p.u - p.du, p.u + p.du))? else {
        return Ok(None);
    };
    let Some(h) = forward_steady(blocks, p.step_hull())? else {
        return Ok(None);
    };
    let mut q = *p;
    (q.u, q.du) = centre_radius(v);
    if v.lo == v.hi {
        q.du = 0.0;
    }
    let (raw, seen) = (p.step_height(), h.hi - h.lo);
    if !seen.is_finite() {
        return Ok(None);
    }
    if raw > 0.0 {
        q.alpha = p.alpha * (seen / raw) * (1.0 + 4.0 * f64::EPSILON);
    }
    q.step = Some(seen);
    Ok(Some(q))
}

/// Whether a designed step whose input stays inside `t` (at the chain's input) reaches the
/// nonlinearity still designed: every input block keeps the design over the hull its input
/// moves in ([`NonlinearitySet::keeps_steady_design_over`]), that hull carried forward
/// through the blocks before it ([`forward_steady`]).
pub fn keeps_design_forward(blocks: &[&dyn NonlinearitySet], mut t: Interval) -> Result<bool> {
    for b in blocks {
        if !b.keeps_steady_design_over(t) {
            return Ok(false);
        }
        match forward_steady(&[*b], t)? {
            Some(next) => t = next,
            None => return Ok(false),
        }
    }
    Ok(true)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `w = k x` over `k ∈ [k0, k1]`, `k0 > 0` (monotone).
    #[derive(Debug, Serialize, Deserialize)]
    struct Gain(Interval);
    #[typetag::serde(name = "chain_test_gain")]
    impl NonlinearitySet for Gain {
        fn parameters(&self) -> Vec<crate::nonlinearity::ParameterBound> {
            Vec::new()
        }
        fn invert(&self, y: &[f64], dy: &[f64]) -> Result<Vec<InnerBound>> {
            Ok(y.iter()
                .zip(dy)
                .map(|(&y, &d)| InnerBound {
                    interval: Interval::hull_of([
                        (y - d) / self.0.lo,
                        (y - d) / self.0.hi,
                        (y + d) / self.0.lo,
                        (y + d) / self.0.hi,
                    ])
                    .unwrap()
                    .outward(),
                    kind: InnerKind::Inverted,
                })
                .collect())
        }
        fn propagate(&self, u: &[f64]) -> Result<Vec<InnerBound>> {
            Ok(u.iter()
                .map(|&u| InnerBound {
                    interval: Interval::hull_of([u * self.0.lo, u * self.0.hi])
                        .unwrap()
                        .outward(),
                    kind: InnerKind::Inverted,
                })
                .collect())
        }
        fn monotone(&self) -> bool {
            true
        }
    }

    /// A point carried forward through gains keeps an overshoot allowance at least `k` times
    /// its own for every gain `k` of the cells (the linear block sees a step `k` times as
    /// high), and its input is the hull of every member's: random gains, levels, steps and
    /// directions.
    #[test]
    fn a_point_behind_gains_scales_its_overshoot_allowance_with_the_step() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
        for _ in 0..200 {
            let gains: Vec<Gain> = (0..rng.gen_range(1..4))
                .map(|_| {
                    let k = rng.gen_range(0.2..4.0);
                    Gain(Interval::new(k, k * rng.gen_range(1.0..1.5)))
                })
                .collect();
            let blocks: Vec<&dyn NonlinearitySet> = gains.iter().map(|g| g as _).collect();
            let mut p = SteadyPoint::new(0, rng.gen_range(-3.0..3.0), 0.1, 0.01);
            p.rising = rng.gen_bool(0.5);
            p.step = Some(rng.gen_range(0.1..6.0));
            p.alpha = rng.gen_range(0.0..0.1);
            let q = forward_steady_point(&blocks, &p).unwrap().unwrap();
            let mut k = (1.0, 1.0);
            for g in &gains {
                k = (k.0 * g.0.lo, k.1 * g.0.hi);
            }
            for kk in [k.0, k.1, 0.5 * (k.0 + k.1)] {
                assert!(
                    q.alpha >= kk * p.alpha,
                    "α {} < {kk} · {}",
                    q.alpha,
                    p.alpha
                );
                assert!(q.step_height() >= kk * p.step_height());
                let u = kk * p.u;
                assert!(
                    q.u - q.du <= u && u <= q.u + q.du,
                    "{u} not in {} ± {}",
                    q.u,
                    q.du
                );
            }
            assert_eq!(q.rising, p.rising);
        }
    }

    #[test]
    fn two_gains_each_way_hold_every_member() {
        let (g1, g2) = (Gain(Interval::new(0.5, 0.7)), Gain(Interval::new(2.0, 2.5)));
        let blocks: [&dyn NonlinearitySet; 2] = [&g1, &g2];
        let u = [1.0, -2.0, 0.3];
        let v = forward(&blocks, &u).unwrap();
        for (k1, k2) in [(0.5, 2.0), (0.7, 2.5), (0.6, 2.2)] {
            for (t, &ut) in u.iter().enumerate() {
                assert!(v[t].interval.contains(k1 * k2 * ut), "t = {t}");
            }
        }
        // Backward: y = k2 (k1 x) + η, |η| <= 0.01.
        let x = [1.0, -2.0, 0.3];
        for (k1, k2) in [(0.5, 2.0), (0.7, 2.5), (0.6, 2.2)] {
            let y: Vec<f64> = x.iter().map(|v| k2 * k1 * v + 0.01).collect();
            let b = backward(&blocks, &y, &[0.01; 3]).unwrap();
            for t in 0..3 {
                assert!(b[t].interval.contains(x[t]), "t = {t}: {:?}", b[t]);
            }
        }
    }

    /// The identity on `|w| <= 1`; an output beyond it is inconsistent (as a saturation's
    /// limits make it), named by the sample of the slice it was given.
    #[derive(Debug, Serialize, Deserialize)]
    struct Limit;
    #[typetag::serde(name = "chain_test_limit")]
    impl NonlinearitySet for Limit {
        fn parameters(&self) -> Vec<crate::nonlinearity::ParameterBound> {
            Vec::new()
        }
        fn invert(&self, y: &[f64], dy: &[f64]) -> Result<Vec<InnerBound>> {
            y.iter()
                .zip(dy)
                .enumerate()
                .map(|(t, (&y, &d))| {
                    if (y.abs() - d) > 1.0 {
                        return Err(SmidError::inconsistent(Stage::InnerSignal, t, "beyond 1"));
                    }
                    Ok(InnerBound {
                        interval: Interval::new(y - d, y + d),
                        kind: InnerKind::Inverted,
                    })
                })
                .collect()
        }
        fn propagate(&self, u: &[f64]) -> Result<Vec<InnerBound>> {
            self.invert(u, &vec![0.0; u.len()])
        }
    }

    #[test]
    fn a_block_inside_the_chain_proves_inconsistency_at_the_records_sample() {
        // The block after it leaves sample 1 unknown: the second run starts at sample 2, and
        // its sample 1 (the record's 3) lies beyond the limit.
        let w = [
            InnerBound {
                interval: Interval::new(0.1, 0.2),
                kind: InnerKind::Inverted,
            },
            InnerBound::unknown(),
            InnerBound {
                interval: Interval::new(0.1, 0.2),
                kind: InnerKind::Inverted,
            },
            InnerBound {
                interval: Interval::new(1.5, 1.6),
                kind: InnerKind::Inverted,
            },
        ];
        match invert_runs(&Limit, &w) {
            Err(SmidError::Inconsistent(f)) => assert_eq!(f.sample, 3),
            other => panic!("{other:?}"),
        }
        // A steady-state point beyond it is stage 1's, at the point's index.
        match backward_steady(&[&Limit], 7, 1.5, 0.1) {
            Err(SmidError::Inconsistent(f)) => {
                assert_eq!((f.stage, f.sample), (Stage::SteadyState, 7))
            }
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn unknown_samples_split_the_runs() {
        let g = Gain(Interval::new(1.0, 1.0));
        let w = [
            InnerBound::unknown(),
            InnerBound {
                interval: Interval::new(1.0, 2.0),
                kind: InnerKind::Inverted,
            },
        ];
        let out = invert_runs(&g, &w).unwrap();
        assert_eq!(out[0].kind, InnerKind::Unknown);
        assert!(out[1].interval.contains(1.0) && out[1].interval.contains(2.0));
    }
}
