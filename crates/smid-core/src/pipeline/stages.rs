//! The three stages over one cell of the bisected parameters: stage 1 (the nonlinearity's set
//! from steady-state points, Section 3, eqs 13-20, carried through the chain's blocks), stage 2
//! (inner-signal bounds, Section 4, eqs 23-27, through [`crate::chain`]), stage 3 (the linear
//! block, Section 5, [`crate::stage3`]), and the branch and bound's cheap and full cell tests.
use super::*;
use crate::cells::Verdict;
use crate::chain::{self, Side};
use crate::effect::{self, Signals};
use crate::error::{Result, SmidError, Stage};
use crate::interval::Interval;
use crate::inversion::{InnerBound, InnerKind};
use crate::model::{CellSet, Layout, Training};
use crate::nonlinearity::{NonlinearitySet, SteadyStateData, Structure};
use crate::spec::{MethodSpec, ModelSpec};
use crate::stage3::{EivProblem, EivResult, Regressor};

/// Stage 1 for one cell: the nonlinearity's feasible set from the steady-state points with the
/// outputs corrected by the sensor terms over the cell (`ȳ - s`, `s` an interval: its centre
/// moves `ȳ`, its radius widens `Δη̄`).
pub fn stage1(
    model: &ModelSpec,
    layout: &Layout,
    steady: Option<&SteadyStateData>,
    cell: &[Interval],
) -> Result<Box<dyn NonlinearitySet>> {
    stage1_with(model, layout, steady, cell, false)
}

/// Widening of a [`design_prior`] box on each side, as a fraction of its width.
pub const DESIGN_WIDEN_WIDTH: f64 = 0.25;
/// Widening of a [`design_prior`] box on each side, as a fraction of its centre's magnitude.
pub const DESIGN_WIDEN_CENTRE: f64 = 0.05;

/// The advice every refusal of stage 1's polygons ends with: the nonlinearity's parameters
/// by name, to be given a prior box (`model.prior`), so that the branch and bound bisects them
/// and the steady-state points prune its cells with any history.
pub fn prior_box_to_give(model: &ModelSpec) -> String {
    format!(
        "give the nonlinearity's parameters a prior box (`model.prior`: {})",
        crate::registry::parameter_names(&model.nonlinearity_tag()).join(", ")
    )
}

/// A box for the nonlinearity's parameters from the steady-state points **as if** every input
/// block kept the designed experiment valid (the polygons, each point's input an interval over
/// the blocks' whole prior boxes `cell`), widened on each side by [`DESIGN_WIDEN_WIDTH`] of its
/// width and [`DESIGN_WIDEN_CENTRE`] of its centre's magnitude (a positive parameter, a slope, stays above half its
/// lower end; a non-negative one, a play, stays non-negative).
/// This is an assumption, not a bound: a block that breaks the design may make the linear block
/// overshoot, which the polygons do not allow for. The diagnosis uses it, reported, as the
/// prior box of a candidate whose input block breaks the design; identification within it then
/// uses the steady-state points only through stage 1's any-history test of each prior-box
/// cell (the steady input carried forward, the measured output carried backward, with any
/// history), which is sound.
pub fn design_prior(
    model: &ModelSpec,
    layout: &Layout,
    steady: &SteadyStateData,
    cell: &[Interval],
) -> Result<Vec<(String, Interval)>> {
    let set = stage1_with(model, layout, Some(steady), cell, true)?;
    Ok(set
        .parameters()
        .into_iter()
        .map(|b| {
            let i = b.interval;
            let w = DESIGN_WIDEN_WIDTH * (i.hi - i.lo) + DESIGN_WIDEN_CENTRE * i.center().abs();
            let lo = if i.lo > 0.0 {
                (i.lo - w).max(0.5 * i.lo)
            } else if i.lo == 0.0 {
                0.0
            } else {
                i.lo - w
            };
            (b.name, Interval::new(lo, i.hi + w))
        })
        .collect())
}

/// A box for the model's own nonlinearity from the **scale** of its steady-state points
/// ([`crate::nonlinearity::NonlinearityModel::scale_prior`]): the range its input spans
/// (`ū` itself: the linear block has unit gain, and at rest an equation term that vanishes with
/// the velocity adds nothing) and the range its output spans (`ȳ`, each end moved by the
/// points' largest noise bound both ways: the hull of the plugin's boxes for the narrowest
/// and the widest true range). It assumes no designed step, so it serves where
/// [`design_prior`] finds the points inconsistent even as if the design held; the branch and
/// bound then prunes its cells by the points with any history. `None`: the plugin offers
/// none, the model has a block on either side (its nonlinearity's input is then not `ū`, or
/// its output not `ȳ`) or no unit gain (the slopes and the gain are not separable), or the
/// points span nothing.
pub fn scale_prior(model: &ModelSpec, steady: &SteadyStateData) -> Option<Vec<(String, Interval)>> {
    if !model.unit_gain || model.has_blocks() {
        return None;
    }
    let input = Interval::hull_of(steady.points.iter().map(|p| p.u))?;
    let y = Interval::hull_of(steady.points.iter().map(|p| p.y))?;
    let d = steady.points.iter().fold(0.0f64, |m, p| m.max(p.dy));
    let names = crate::registry::parameter_names(&model.nonlinearity_tag());
    let of = |lo: f64, hi: f64| {
        (lo < hi)
            .then(|| {
                model
                    .nonlinearity
                    .scale_prior(model.structure, (input.lo, input.hi), (lo, hi))
            })
            .flatten()
            .filter(|b| b.len() == names.len())
    };
    // The noise could hide the whole range (no narrow box): the slopes may be as small as any.
    let narrow = of(y.lo + d, y.hi - d)?;
    let wide = of(y.lo - d, y.hi + d)?;
    let b = narrow
        .iter()
        .zip(&wide)
        .map(|(a, b)| Interval::new(a.lo.min(b.lo), a.hi.max(b.hi)));
    Some(names.into_iter().zip(b).collect())
}

/// [`stage1`]; `assume_design`: steady-state points pass every input block as if it kept the
/// designed experiment valid (only [`design_prior`] asks for this).
fn stage1_with(
    model: &ModelSpec,
    layout: &Layout,
    steady: Option<&SteadyStateData>,
    cell: &[Interval],
    assume_design: bool,
) -> Result<Box<dyn NonlinearitySet>> {
    if model.feedback && steady.is_some() {
        // At rest inside the loop the linear block's output is `Σb ū - Σa w̄`, not its gain
        // times the input: the points would carry the wrong inner signal into the polygons.
        return Err(SmidError::invalid(
            "model.feedback",
            "steady-state points are read as the linear block's gain times the input, which does not hold inside the loop: identify from dynamic records only (`experiment.steady_state.skip: true`, or no steady-state file) with a prior box on the nonlinearity's parameters",
        ));
    }
    let range = layout.nonlinearity_cells.clone();
    if !range.is_empty() {
        let set = model.nonlinearity.set_from_box(&cell[range])?;
        if let Some(steady) = steady {
            prune_by_steady_points(model, layout, steady, cell, set.as_ref())?;
        }
        return Ok(set);
    }
    let steady = match steady {
        Some(s) => s,
        // A plugin without parameters needs no stage 1.
        None if crate::registry::parameter_names(&model.nonlinearity_tag()).is_empty() => {
            return model.nonlinearity.set_from_box(&[])
        }
        None => {
            return Err(SmidError::invalid(
                "plant",
                format!(
                    "stage 1 needs steady-state data (the designed experiment of Section 3); without it, {}",
                    prior_box_to_give(model)
                ),
            ))
        }
    };
    // The polygons hold only where the design does (Appendix): a term that may make the
    // linear block overshoot under the filtered square wave leaves them unusable.
    if !assume_design {
        if let Some(e) = model.term_breaking_steady_design() {
            return Err(SmidError::invalid(
                "model.effects",
                format!(
                    "`{}` breaks the designed steady-state experiment (it switches while the filtered square wave settles, so the linear block may overshoot, which stage 1's polygons rule out; see EquationTerm::keeps_steady_design): {} (the steady-state points then prune its cells with any history), or identify from records without the steady-state experiment",
                    e.label(),
                    prior_box_to_give(model)
                ),
            ));
        }
    }
    if model.effects.is_empty() && !model.has_blocks() {
        return model.nonlinearity.bound_steady_state(steady);
    }
    let slices = layout.effect_slices(cell);
    let blocks = BlockSets::new(model, layout, cell)?;
    let outputs = blocks.refs(Side::Output);
    let inputs = blocks.refs(Side::Input);
    let mut data = steady.clone();
    // A point whose designed step some input block may bend (a saturation clipping it) is
    // left out: the polygons hold only where the design does. Without any such point left,
    // the nonlinearity needs a prior box.
    if !assume_design && !inputs.is_empty() {
        let mut kept = Vec::with_capacity(data.points.len());
        for p in data.points {
            if chain::keeps_design_forward(&inputs, p.step_hull())? {
                kept.push(p);
            }
        }
        data.points = kept;
        if data.points.is_empty() {
            return Err(SmidError::invalid(
                "model.input",
                format!(
                    "steady-state data reach the nonlinearity through an input block that may make the linear block overshoot under the designed square wave at every point (a clipped or kinked wave; see NonlinearitySet::keeps_steady_design_over): {} (the steady-state points then prune its cells without the design's assumption), or identify from records without the steady-state experiment",
                    prior_box_to_give(model)
                ),
            ));
        }
    }
    let before = steps_before(model, &slices, steady, !outputs.is_empty());
    for p in &mut data.points {
        // The measured steady input, which the terms' shift at rest reads.
        let measured = Interval::new(p.u - p.du, p.u + p.du);
        (p.y, p.dy) = effect::true_output(&model.effects, &slices, p.time, p.y, p.dy)?
            .ok_or_else(|| no_true_output(p.index))?;
        if !outputs.is_empty() {
            (p.y, p.dy) = match before.get(&p.index) {
                Some(&b) => chain::backward_steady_step(
                    &outputs,
                    p.index,
                    b,
                    (p.y, p.dy),
                    p.rising,
                    p.alpha,
                )?,
                None => chain::backward_steady(&outputs, p.index, p.y, p.dy)?,
            };
        }
        if !inputs.is_empty() {
            // The steady input through the input blocks over their cell: an interval.
            let q = chain::forward_steady_point(&inputs, p)?.ok_or_else(|| {
                SmidError::invalid(
                    "model.input",
                    format!(
                        "a steady input reaches a non-monotone input block as an interval: {}",
                        prior_box_to_give(model)
                    ),
                )
            })?;
            if q.du > 0.0 && !model.nonlinearity.accepts_input_radius() {
                return Err(SmidError::invalid(
                    "model.input",
                    format!(
                        "steady-state data reach the nonlinearity through input-side blocks whose steady output is uncertain over their cell, and this plugin's stage 1 needs exact inputs: {}, or identify from records without the steady-state experiment",
                        prior_box_to_give(model)
                    ),
                ));
            }
            *p = q;
        }
        rest_shifted(model, &slices, p, measured)?;
    }
    // A point an output block leaves unknown (a clipped saturation) bounds nothing: it is left
    // out of stage 1 (fewer points can only widen the set).
    data.points.retain(|p| p.dy.is_finite());
    model.nonlinearity.bound_steady_state(&data)
}

/// For stage 1's polygons behind output blocks: each point whose designed step began at the
/// point before it, keyed by its index, with that previous point's true output (the sensor
/// terms removed). Under the design a Wiener nonlinearity that
/// [`crate::nonlinearity::NonlinearityModel::keeps_steps_monotone`] hands the first output
/// block a monotone step, which [`chain::backward_steady_step`] inverts from the two outputs.
/// A point qualifies only when the records say its predecessor: both points carry a time and
/// this one its step height, the previous one is the record's point just before (consecutive
/// indices, an earlier time, no gap longer than 1.5 times the shortest between points, which a
/// point left out would leave) and its input is where this step began (`ū ∓ step`). Empty when
/// there is no output block or the nonlinearity does not keep steps monotone (any history is
/// then assumed, as before).
fn steps_before(
    model: &ModelSpec,
    slices: &[&[Interval]],
    steady: &SteadyStateData,
    outputs: bool,
) -> std::collections::HashMap<usize, (f64, f64)> {
    let mut out = std::collections::HashMap::new();
    if !outputs
        || model.structure != Structure::Wiener
        || !model.nonlinearity.keeps_steps_monotone()
    {
        return out;
    }
    let gaps = |w: &[crate::nonlinearity::SteadyPoint]| match (w[0].time, w[1].time) {
        (Some(a), Some(b)) if b > a => Some(b - a),
        _ => None,
    };
    let Some(shortest) = steady.points.windows(2).filter_map(gaps).min() else {
        return out;
    };
    for w in steady.points.windows(2) {
        let (q, p) = (&w[0], &w[1]);
        let (Some(gap), Some(step)) = (gaps(w), p.step) else {
            continue;
        };
        let start = if p.rising { p.u - step } else { p.u + step };
        let tol = 1e-9 * (p.u.abs() + step) + p.du + q.du;
        if q.index + 1 == p.index && 2 * gap <= 3 * shortest && (q.u - start).abs() <= tol {
            // A previous point whose output the terms cannot read is only left unused here.
            if let Ok(Some(b)) = effect::true_output(&model.effects, slices, q.time, q.y, q.dy) {
                out.insert(p.index, b);
            }
        }
    }
    out
}

/// Steady-state points as a necessary test of a cell whose nonlinearity is bisected over a
/// prior box (instead of the polygons of eqs 13-20): at rest the linear block's output equals
/// its input (unit gain, eq 8), so for every point the steady input carried **forward** through
/// the input side over the cell (`propagate_steady` at both ends of each monotone block) must
/// meet the measured `ȳ ± Δη̄` (less the sensor terms) carried **backward** through the output
/// side (`invert_steady`, each block's inversion of one sample **with any history**: for a
/// backlash the whole dead band). Neither carry assumes the designed filter kept the linear
/// block free of overshoot, so the test holds behind any input block (a dead zone, a play, a
/// saturation), where the polygons would not. A point either side leaves unknown, or one that
/// reaches a non-monotone block as an interval, proves nothing and is passed over; a model
/// without unit gain, or with a term that does not vanish at rest, is an error (the points would
/// be dropped unused otherwise). An empty
/// meeting is a proof that the cell is inconsistent (stage 1, the point's index).
fn prune_by_steady_points(
    model: &ModelSpec,
    layout: &Layout,
    steady: &SteadyStateData,
    cell: &[Interval],
    set: &dyn NonlinearitySet,
) -> Result<()> {
    if !model.unit_gain {
        return Err(SmidError::invalid(
            "model.unit_gain",
            "steady-state points with a prior box on the nonlinearity need `unit_gain: true` (at rest the linear block's output is then its input, eq 8); give the steady-state data or the prior box, not both",
        ));
    }
    if let Some(e) = model
        .effects
        .iter()
        .find(|e| !e.steady_state_usable(&model.prior))
    {
        return Err(SmidError::invalid(
            "model.effects",
            not_at_rest(
                e.as_ref(),
                "steady-state points with a prior box on the nonlinearity",
            ),
        ));
    }
    let slices = layout.effect_slices(cell);
    let blocks = BlockSets::new(model, layout, cell)?;
    let (input, output) = blocks.sides(model.structure, set);
    for p in &steady.points {
        let (y, dy) = effect::true_output(&model.effects, &slices, p.time, p.y, p.dy)?
            .ok_or_else(|| no_true_output(p.index))?;
        let (c, r) = chain::backward_steady(&output, p.index, y, dy)?;
        if !r.is_finite() {
            continue;
        }
        let x = Interval::new(c - r, c + r).outward();
        let Some(v) = chain::forward_steady(&input, Interval::new(p.u - p.du, p.u + p.du))? else {
            continue;
        };
        // The terms read the measured input (`c·u_t`), not what the input side makes of it.
        let s = effect::rest_shift(
            &model.effects,
            &slices,
            Interval::new(p.u - p.du, p.u + p.du),
        );
        let v = Interval::new(v.lo + s.lo, v.hi + s.hi).outward();
        if x.intersect(&v.outward()).is_none() {
            return Err(SmidError::inconsistent(
                crate::error::Stage::SteadyState,
                p.index,
                format!(
                    "steady-state point {}: the input side gives [{:.6e}, {:.6e}] at rest, the output {:.6e} ± {:.3e} inverts to [{:.6e}, {:.6e}] over this cell",
                    p.index, v.lo, v.hi, p.y, p.dy, x.lo, x.hi
                ),
            ));
        }
    }
    Ok(())
}

/// Why a term cannot be used with steady-state data (`what` needs every term to vanish at
/// rest), and what to give instead.
pub(crate) fn not_at_rest(e: &dyn effect::Effect, what: &str) -> String {
    match e.rest_parameter() {
        Some(n) => format!(
            "{what} need every term to vanish at rest or have its shift there bounded, and `{}` shifts the linear block's output at rest: give that shift a prior box, `model.prior.{n}: [lo, hi]` (the shift at the unit input; a diagnosis gives each term its default box)",
            e.label()
        ),
        None => format!(
            "{what} need every term to vanish at rest, and `{}` does not (nor is it a constant shift there): use it on records without the designed steady-state experiment",
            e.label()
        ),
    }
}

/// A steady point moved by the terms' shift at rest over the cell ([`effect::rest_shift`] at
/// the `measured` steady input, before any block): at rest the linear block's output is
/// `x̄ = v̄ + s` (unit gain, eq 8). Wiener: the nonlinearity reads `x̄`, so its input becomes
/// `v̄ + s`, an interval it must honour as an input radius. Hammerstein: the nonlinearity's
/// output is `v̄ = x̄ - s`, so the point's output moves and its input stays. Nothing changes
/// when no term names a shift.
fn rest_shifted(
    model: &ModelSpec,
    slices: &[&[Interval]],
    p: &mut crate::nonlinearity::SteadyPoint,
    measured: Interval,
) -> Result<()> {
    let s = effect::rest_shift(&model.effects, slices, measured);
    if s.lo == 0.0 && s.hi == 0.0 {
        return Ok(());
    }
    if !model.unit_gain {
        return Err(SmidError::invalid(
            "model.unit_gain",
            "a term's shift at rest carries the steady input as `v + s` only with `unit_gain: true` (eq 8)",
        ));
    }
    if model.structure == Structure::Hammerstein {
        let y = Interval::new(p.y - p.dy - s.hi, p.y + p.dy - s.lo).outward();
        (p.y, p.dy) = chain::centre_radius(y);
        return Ok(());
    }
    if !model.nonlinearity.accepts_input_radius() {
        return Err(SmidError::invalid(
            "model.effects",
            format!(
                "a term's shift at rest makes every steady input an interval, and this plugin's stage 1 needs exact inputs: {}, or identify from records without the steady-state experiment",
                prior_box_to_give(model)
            ),
        ));
    }
    let v = Interval::new(p.u - p.du + s.lo, p.u + p.du + s.hi).outward();
    (p.u, p.du) = chain::centre_radius(v);
    Ok(())
}

/// The stage-1 sets of a chain's blocks over one cell (each plugin's set of its prior cell).
pub struct BlockSets {
    sets: Vec<(Side, Box<dyn NonlinearitySet>)>,
}

impl BlockSets {
    /// Every block's set over its slice of `cell`; errors name the block's field.
    pub fn new(model: &ModelSpec, layout: &Layout, cell: &[Interval]) -> Result<BlockSets> {
        let mut sets = Vec::with_capacity(layout.blocks.len());
        for b in &layout.blocks {
            let set = model
                .block_model(b)
                .set_from_box(&cell[b.cells.clone()])
                .map_err(|e| match e {
                    SmidError::Invalid { field, message } => SmidError::invalid(
                        format!("{}[{}] ({field})", b.side.field(), b.index),
                        message,
                    ),
                    o => o,
                })?;
            sets.push((b.side, set));
        }
        Ok(BlockSets { sets })
    }
    /// The sets of one side, in signal order.
    pub fn refs(&self, side: Side) -> Vec<&dyn NonlinearitySet> {
        self.sets
            .iter()
            .filter(|(s, _)| *s == side)
            .map(|(_, b)| b.as_ref())
            .collect()
    }
    /// The whole input side (the input blocks, then `set` when Hammerstein) and output side
    /// (`set` when Wiener, then the output blocks), in signal order.
    pub fn sides<'a>(
        &'a self,
        structure: Structure,
        set: &'a dyn NonlinearitySet,
    ) -> (Vec<&'a dyn NonlinearitySet>, Vec<&'a dyn NonlinearitySet>) {
        let mut input = self.refs(Side::Input);
        let mut output = self.refs(Side::Output);
        match structure {
            Structure::Hammerstein => input.push(set),
            Structure::Wiener => output.insert(0, set),
        }
        (input, output)
    }
}

/// The signals stage 3 sees: records concatenated, separated by gaps of unknown samples so no
/// equation spans two records.
#[derive(Debug, Clone)]
pub struct StageSignals {
    /// Bounds on the linear block's output `x_t` (stage 2: inverted under Wiener, the
    /// sensor-corrected outputs under Hammerstein); unknown in the gaps.
    pub output: Vec<InnerBound>,
    /// The linear block's input `v_{t-nk}`, already delayed by `nk` (exact under Wiener,
    /// propagated intervals under Hammerstein or behind input blocks); unknown in the gaps.
    pub input: Vec<Interval>,
    /// The equation terms' regressor columns, one per extra coefficient of `θ`.
    pub extra: Vec<Regressor>,
    /// `model.feedback`: the chain's output `w_t` the autoregressive part reads, bounded
    /// from the measurements (`y ± Δ` through the sensor terms); unknown in the gaps.
    pub lagged: Option<Vec<Interval>>,
    /// Index of each record's first sample in the concatenation.
    pub starts: Vec<usize>,
}

impl StageSignals {
    /// `(record, sample)` of a concatenated index.
    pub fn locate(&self, i: usize) -> (usize, usize) {
        let r = self.starts.iter().rposition(|&s| s <= i).unwrap_or(0);
        (r, i - self.starts[r])
    }
}

/// Stage 2 for one cell over records: the outputs corrected by the sensor terms (`y - s`, the
/// interval `s` widening the noise bound), inverted (Wiener) or taken as the linear block's
/// output (Hammerstein); the input as is (Wiener) or propagated through the nonlinearity
/// (Hammerstein); delayed by `nk`; the equation terms' regressors; with `model.feedback` the
/// past outputs the loop reads, inside their measurement boxes (`StageSignals::lagged`).
pub fn stage2(
    model: &ModelSpec,
    layout: &Layout,
    set: &dyn NonlinearitySet,
    cell: &[Interval],
    records: &[Record],
) -> Result<StageSignals> {
    let o = layout.orders;
    let gap = o.na + o.nb + o.nk + 1;
    let slices = layout.effect_slices(cell);
    let blocks = BlockSets::new(model, layout, cell)?;
    let (input_side, output_side) = blocks.sides(model.structure, set);
    let mut out = StageSignals {
        output: Vec::new(),
        input: Vec::new(),
        extra: layout
            .extra_names
            .iter()
            .map(|n| Regressor {
                name: n.clone(),
                values: Vec::new(),
            })
            .collect(),
        lagged: model.feedback.then(Vec::new),
        starts: Vec::new(),
    };
    for (r, rec) in records.iter().enumerate() {
        rec.validate()?;
        if r > 0 {
            out.output
                .extend(std::iter::repeat_n(InnerBound::unknown(), gap));
            out.input
                .extend(std::iter::repeat_n(Interval::entire(), gap));
            for e in &mut out.extra {
                e.values
                    .extend(std::iter::repeat_n(Interval::entire(), gap));
            }
            if let Some(w) = &mut out.lagged {
                w.extend(std::iter::repeat_n(Interval::entire(), gap));
            }
        }
        out.starts.push(out.output.len());
        let n = rec.y.len();
        let mut yc = rec.y.clone();
        let mut dy = rec.dy.clone();
        if !model.effects.is_empty() {
            for t in 0..n {
                (yc[t], dy[t]) =
                    effect::true_output(&model.effects, &slices, Some(t), yc[t], dy[t])?
                        .ok_or_else(|| {
                            SmidError::inconsistent(
                                Stage::InnerSignal,
                                t,
                                format!(
                                    "sample {t}: no true output of the cell gives this measurement through the model's sensor"
                                ),
                            )
                            .in_record(r)
                        })?;
            }
        }
        // Wiener: the nonlinearity is the first output block; Hammerstein: the last input
        // block (with no other block, the paper's calls exactly).
        let output = chain::backward(&output_side, &yc, &dy).map_err(|e| e.in_record(r))?;
        let input: Vec<Interval> = chain::forward(&input_side, &rec.u)
            .map_err(|e| e.in_record(r))?
            .iter()
            .map(|b| b.interval)
            .collect();
        out.output.extend(output);
        if let Some(w) = &mut out.lagged {
            w.extend(
                yc.iter()
                    .zip(&dy)
                    .map(|(&y, &d)| Interval::new(y - d, y + d).outward()),
            );
        }
        out.input.extend((0..n).map(|t| {
            if t >= o.nk {
                input[t - o.nk]
            } else {
                Interval::entire()
            }
        }));
        let xs: Vec<Interval> = out.output[out.output.len() - n..]
            .iter()
            .map(|b| b.hull())
            .collect();
        let cols = effect::regressors(
            &model.effects,
            &Signals {
                u: &rec.u,
                dt: rec.dt,
                x: Some(&xs),
            },
        );
        for (e, c) in out.extra.iter_mut().zip(cols) {
            e.values.extend(c.values);
        }
    }
    Ok(out)
}

/// The stage-3 problem of stage-2 signals, with an optional prior box on `θ`.
pub fn eiv_problem<'a>(
    model: &ModelSpec,
    layout: &'a Layout,
    method: &MethodSpec,
    sig: &'a StageSignals,
    prior: Option<&'a [Interval]>,
) -> EivProblem<'a> {
    EivProblem {
        locate: true,
        na: layout.orders.na,
        nb: layout.orders.nb,
        fixed: layout.fixed.clone(),
        unit_gain: model.unit_gain,
        output: &sig.output,
        input: &sig.input,
        extra: &sig.extra,
        prior: prior.or(layout.theta_prior.as_deref()),
        use_band_samples: method.use_band_samples(),
        lagged: sig.lagged.as_deref(),
    }
}

/// Stage 3 on stage-2 signals, with an optional prior box on `θ`. An inconsistency names the
/// sample in the concatenation (see [`relabel`]): the first offending one with `locate`, else
/// the last equation, marked not located ([`EivProblem::locate`]: a verdict saves the search).
/// Samples of two-sided preimage go through the sign search ([`super::signs`]).
pub fn stage3(
    model: &ModelSpec,
    layout: &Layout,
    method: &MethodSpec,
    sig: &StageSignals,
    prior: Option<&[Interval]>,
    locate: bool,
) -> Result<EivResult> {
    if sig.output.iter().any(|b| b.kind == InnerKind::Mirrored) {
        return super::signs::stage3_over_signs(model, layout, method, sig, prior, locate);
    }
    stage3_decided(model, layout, method, sig, prior, locate)
}

/// [`stage3`] on signals whose every sample has one interval.
pub(crate) fn stage3_decided(
    model: &ModelSpec,
    layout: &Layout,
    method: &MethodSpec,
    sig: &StageSignals,
    prior: Option<&[Interval]>,
    locate: bool,
) -> Result<EivResult> {
    let problem = EivProblem {
        locate,
        ..eiv_problem(model, layout, method, sig, prior)
    };
    let chosen = crate::stage3::configured(method.eiv, &method.options)?;
    match chosen.solve(&problem) {
        // Solver trouble: another method's outer bound is as guaranteed.
        Err(SmidError::Solver(first)) => {
            let other = chosen.fallback();
            crate::stage3::solve(other, &problem).map_err(|e| match e {
                SmidError::Solver(second) => SmidError::Solver(format!(
                    "{first}; with the {} method too: {second}",
                    other.name()
                )),
                e => e,
            })
        }
        r => r,
    }
}

/// A stage-3 inconsistency located in its record: the concatenated index of the equations
/// becomes `(record, sample)` (the records in the order stage 2 was given them).
pub fn relabel(e: SmidError, sig: &StageSignals) -> SmidError {
    match e {
        SmidError::Inconsistent(f) => {
            let (r, t) = sig.locate(f.sample);
            let detail = f
                .detail
                .replace(&format!("t = {}", f.sample), &format!("sample {t}"));
            SmidError::Inconsistent(crate::outcome::Falsification {
                stage: f.stage,
                record: r,
                sample: t,
                located: f.located,
                detail,
            })
        }
        other => other,
    }
}

/// Stages 1-3 over one cell: `Infeasible` when a stage proves the cell inconsistent (located
/// in its record; stage 3's first offending sample only with `locate`), `Undecided` when
/// stage 3 leaves a parameter unbounded over a bisected cell or its solvers fail there (the
/// search then halves the cell further). Without bisected parameters every error is returned
/// as is (the paper's three stages).
pub fn evaluate_cell(
    model: &ModelSpec,
    layout: &Layout,
    method: &MethodSpec,
    training: &Training,
    cell: &[Interval],
    locate: bool,
) -> Result<Verdict<CellSet>> {
    let bisected = !layout.dims.is_empty();
    let outcome = (|| {
        let set = stage1(model, layout, training.steady.as_ref(), cell)?;
        let sig = stage2(model, layout, set.as_ref(), cell, &training.records)?;
        let r = stage3(model, layout, method, &sig, None, locate).map_err(|e| relabel(e, &sig))?;
        Ok(CellSet {
            cell: cell.to_vec(),
            nonlinearity: set,
            theta: r.bounds,
            unsettled: r.unsettled,
        })
    })();
    match outcome {
        Ok(c) => Ok(Verdict::Feasible(c)),
        Err(SmidError::Inconsistent(f)) => Ok(Verdict::Infeasible(f)),
        Err(e @ (SmidError::Unbounded { .. } | SmidError::Solver(_))) if bisected => {
            Ok(undecided(&e))
        }
        Err(e) => Err(e),
    }
}

/// The branch and bound's cheap test of a cell: stages 1 and 2, then whether the classical
/// outer set of stage 3 is empty (a proof of inconsistency) — no bounds computed.
pub fn test_cell(
    model: &ModelSpec,
    layout: &Layout,
    method: &MethodSpec,
    training: &Training,
    cell: &[Interval],
) -> Result<Verdict<()>> {
    let outcome = (|| {
        let set = stage1(model, layout, training.steady.as_ref(), cell)?;
        let sig = stage2(model, layout, set.as_ref(), cell, &training.records)?;
        let problem = eiv_problem(model, layout, method, &sig, None);
        let holds = if problem.has_mirrored() {
            super::signs::feasible_over_signs(model, layout, method, &sig)?
        } else {
            crate::stage3::feasible(&problem)?
        };
        if holds {
            Ok(())
        } else {
            // Named in its record (the concatenation's last sample).
            Err(relabel(
                SmidError::inconsistent_unlocated(
                    crate::error::Stage::Linear,
                    sig.output.len().saturating_sub(1),
                    "no θ fits the equations of this cell (classical outer set empty)",
                ),
                &sig,
            ))
        }
    })();
    match outcome {
        Ok(()) => Ok(Verdict::Feasible(())),
        Err(SmidError::Inconsistent(f)) => Ok(Verdict::Infeasible(f)),
        // Nothing proven: the cell is kept (a solver failure never discards one).
        Err(e @ (SmidError::Unbounded { .. } | SmidError::Solver(_))) => Ok(undecided(&e)),
        Err(e) => Err(e),
    }
}

/// An undecided cell's verdict from the error that left it undecided.
fn undecided<T>(e: &SmidError) -> Verdict<T> {
    use crate::cells::UndecidedCause;
    match e {
        SmidError::Solver(m) => Verdict::Undecided(UndecidedCause::Solver, m.clone()),
        other => Verdict::Undecided(UndecidedCause::Unbounded, other.to_string()),
    }
}

/// Steady-state point `index` is ruled out by a sensor map of the model over the cell.
fn no_true_output(index: usize) -> SmidError {
    SmidError::inconsistent(
        Stage::SteadyState,
        index,
        format!(
            "steady-state point {index}: no true output of the cell gives this measurement through the model's sensor"
        ),
    )
}
