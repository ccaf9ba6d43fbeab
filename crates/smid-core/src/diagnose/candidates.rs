//! Candidate generation: every registered effect and plugin block that extends the model
//! ([`candidates`]), the output side inside the loop ([`inside_the_loop`]), and the design
//! priors that steady-state points give a candidate's nonlinearity.
use super::verdict::{Evidence, TrainVerdict};
use super::Options;
use crate::chain::{qualified, Side};
use crate::effect::{self, DataScale};
use crate::error::Result;
use crate::nonlinearity::SteadyStateData;
use crate::spec::ModelSpec;

/// Whether a candidate effect is offered to a model trained with the designed steady-state
/// experiment: a term that vanishes at rest is (where it breaks the design, in a box from the
/// points); one that does not vanish is only where it names its shift at rest
/// ([`crate::effect::EquationTerm::rest_parameter`]) **and** keeps the design valid: a term
/// that both shifts the rest and breaks the design (a polynomial path of the input) leaves the
/// points bounding nothing (its box from their scale spans decades) at the cost of a branch and
/// bound, so it is not offered (identify it on records without steady-state points, or declare
/// it with a prior box). The registry matrix (`smid diagnose-check`) takes the same rule.
pub fn offered_with_steady_points(cand: &dyn effect::Effect) -> bool {
    cand.vanishes_at_steady_state()
        || (cand.rest_parameter().is_some() && cand.keeps_steady_design())
}

/// The candidates that extend `base`: every registered effect's candidates not declared yet,
/// with default priors for their bisected parameters (from `scale`), and every registered
/// plugin with a default prior as a chain block at each open end; `steady_data`: the training
/// steady-state points as stage 1 reads them, for the design priors of input-side blocks.
pub fn candidates(
    base: &ModelSpec,
    scale: &DataScale,
    opts: &Options,
    steady_data: Option<&SteadyStateData>,
) -> Vec<(ModelSpec, Evidence)> {
    let mut out = effect_candidates(base, scale, opts, steady_data);
    out.extend(block_candidates(base, scale, opts, steady_data));
    out.extend(feedback_candidate(base, opts, steady_data.is_some()));
    out
}

/// Whether `opts.only` lets the candidate tagged `tag` through (empty: every candidate).
fn wanted(opts: &Options, tag: &str) -> bool {
    opts.only.is_empty() || opts.only.iter().any(|t| t == tag)
}

/// A candidate's evidence before it is tried: "not tried" as its verdict, and the verdict
/// known before trying (a failure saying why) when `untried` gives one.
fn not_tried(
    label: String,
    tag: &str,
    added_parameters: usize,
    priors: Vec<(String, [f64; 2])>,
    untried: Option<String>,
) -> Evidence {
    Evidence {
        label,
        tag: tag.to_string(),
        added_parameters,
        priors,
        train: TrainVerdict::NotTried { reason: None },
        chosen: false,
        equivalent_to: Vec::new(),
        untried: untried.map(|reason| TrainVerdict::NotTried {
            reason: Some(reason),
        }),
    }
}

/// Every registered effect's candidates whose tag `base` does not declare yet (with
/// steady-state points, only those [`offered_with_steady_points`]).
fn effect_candidates(
    base: &ModelSpec,
    scale: &DataScale,
    opts: &Options,
    steady_data: Option<&SteadyStateData>,
) -> Vec<(ModelSpec, Evidence)> {
    let steady = steady_data.is_some();
    let mut out = Vec::new();
    for entry in effect::effects() {
        if !wanted(opts, entry.tag) {
            continue;
        }
        for cand in (entry.candidates)() {
            if base
                .effects
                .iter()
                .any(|e| effect::tag_of(e.as_ref()) == entry.tag)
                || (steady && !offered_with_steady_points(cand.as_ref()))
            {
                continue;
            }
            out.extend(effect_candidate(base, entry.tag, cand, scale, steady_data));
        }
    }
    out
}

/// `base` with the effect `cand` (of the effect tagged `tag`) added, its bisected parameters
/// given their default priors from `scale`, and its evidence. `None`: not offered (no default
/// prior from these data, no layout, or no layout with its design prior).
fn effect_candidate(
    base: &ModelSpec,
    tag: &str,
    cand: Box<dyn effect::Effect>,
    scale: &DataScale,
    steady_data: Option<&SteadyStateData>,
) -> Option<(ModelSpec, Evidence)> {
    let steady = steady_data.is_some();
    let mut m = base.duplicate();
    let before = m.layout().map(|l| l.p() + l.dims.len()).unwrap_or(0);
    // A shift at rest is bisected only for steady-state data (without them it is no
    // parameter of the model: `Layout` leaves it out where no prior is given).
    let mut names = cand.cell_parameters();
    let mut priors = cand.default_prior(scale);
    if !steady && cand.rest_parameter().is_some() {
        names.pop();
        priors.truncate(names.len());
    }
    if priors.len() < names.len() {
        // No default prior from these data (a quantiser's step under an estimated
        // bound): not offered, and said so in the log (docs/loop.md).
        log::info!(target: "smid::diagnose", "{}: not offered (no default prior for {} from these data)", cand.label(), names.join(", "));
        return None;
    }
    let mut given = Vec::new();
    let mut untried = None;
    for (n, p) in names.iter().zip(&priors) {
        m.prior.insert(n.clone(), [p.lo, p.hi]);
        given.push((n.clone(), [p.lo, p.hi]));
    }
    let label = cand.label();
    m.effects.push(cand);
    let (after, layout) = match m.layout() {
        Ok(l) => (l.p() + l.dims.len(), l),
        Err(_) => return None, // e.g. a name clash with a declared term
    };
    if !with_design_prior(
        &mut m,
        &layout,
        steady_data,
        false,
        &mut given,
        &mut untried,
        &label,
    ) {
        return None;
    }
    let added = after.saturating_sub(before);
    Some((m, not_tried(label, tag, added, given, untried)))
}

/// Every registered plugin with parameters, as a block at each open position of the chain:
/// the input side (before everything, where an actuator's nonlinearity or lag sits) and the
/// output side (after everything, where a sensor's sits). Its prior comes from the range of
/// the signal it sees (input or output) through its `default_prior` (reported); plugins
/// without one are not offered. A plugin added to the registry is a candidate with no edit.
fn block_candidates(
    base: &ModelSpec,
    scale: &DataScale,
    opts: &Options,
    steady_data: Option<&SteadyStateData>,
) -> Vec<(ModelSpec, Evidence)> {
    let mut out = Vec::new();
    for entry in crate::registry::models() {
        let names = crate::registry::parameter_names(entry.tag);
        if names.is_empty() || !wanted(opts, entry.tag) {
            continue;
        }
        for side in [Side::Input, Side::Output] {
            out.extend(block_candidate(
                base,
                entry,
                &names,
                side,
                scale,
                steady_data,
            ));
        }
    }
    out
}

/// `base` with the plugin of `entry` (parameters `names`) as a block at the open end of
/// `side`, its prior from the range of the signal it sees, and its evidence. `None`: not
/// offered (the plugin does not support the side, gives no prior there, or leaves the model
/// without a layout, also with its design prior).
fn block_candidate(
    base: &ModelSpec,
    entry: &crate::registry::ModelEntry,
    names: &[String],
    side: Side,
    scale: &DataScale,
    steady_data: Option<&SteadyStateData>,
) -> Option<(ModelSpec, Evidence)> {
    let plugin = (entry.example)();
    if !plugin.supports(side.structure()) {
        return None;
    }
    let seen = match side {
        Side::Input => scale.u_range,
        Side::Output => scale.y_range,
    };
    let prior = plugin.default_prior(side.structure(), seen)?;
    if prior.len() != names.len() {
        return None;
    }
    let mut m = base.duplicate();
    let list = match side {
        Side::Input => &mut m.input,
        Side::Output => &mut m.output,
    };
    let position = match side {
        Side::Input => 0,
        Side::Output => list.len(),
    };
    list.insert(position, plugin);
    // Input blocks are renumbered from the new first one: move the old priors along.
    if side == Side::Input {
        renumber_input_priors(&mut m);
    }
    let prefix = side.prefix(position + 1);
    let mut given = Vec::new();
    let mut untried = None;
    for (n, p) in names.iter().zip(&prior) {
        let name = qualified(&prefix, n);
        m.prior.insert(name.clone(), [p.lo, p.hi]);
        given.push((name, [p.lo, p.hi]));
    }
    let Ok(layout) = m.layout() else {
        return None;
    };
    let added = prior.iter().filter(|p| p.hi > p.lo).count();
    let input_block = side == Side::Input;
    if !with_design_prior(
        &mut m,
        &layout,
        steady_data,
        input_block,
        &mut given,
        &mut untried,
        entry.tag,
    ) {
        return None;
    }
    let label = format!(
        "`{}` on the {} side",
        entry.tag,
        match side {
            Side::Input => "input",
            Side::Output => "output",
        }
    );
    Some((m, not_tried(label, entry.tag, added, given, untried)))
}

/// The priors of `m`'s input blocks one place on (`in1.…` to `in2.…`, and so on), for a block
/// inserted before them; every other prior as it is.
fn renumber_input_priors(m: &mut ModelSpec) {
    let old: Vec<(String, [f64; 2])> = m
        .prior
        .iter()
        .filter(|(k, _)| k.starts_with("in"))
        .map(|(k, v)| (k.clone(), *v))
        .collect();
    for (k, _) in &old {
        m.prior.remove(k);
    }
    for (k, v) in old {
        if let Some((pre, rest)) = k.split_once('.') {
            if let Ok(i) = pre[2..].parse::<usize>() {
                m.prior
                    .insert(qualified(&Side::Input.prefix(i + 1), rest), v);
                continue;
            }
        }
        m.prior.insert(k, v);
    }
}

/// The output side inside the loop ([`inside_the_loop`]), where `opts.only` lets it through.
/// Not with steady-state points (`steady`): stage 1 reads them as the gain times the input,
/// which does not hold inside the loop.
fn feedback_candidate(
    base: &ModelSpec,
    opts: &Options,
    steady: bool,
) -> Option<(ModelSpec, Evidence)> {
    let m = inside_the_loop(base).filter(|_| !steady && wanted(opts, FEEDBACK))?;
    let label = "the output side inside the loop (`model.feedback`)".to_string();
    Some((m, not_tried(label, FEEDBACK, 0, Vec::new(), None)))
}

/// The tag of the structural candidate [`inside_the_loop`] (`--only feedback`).
pub const FEEDBACK: &str = "feedback";

/// `base` with its output side inside the loop (`model.feedback`): the linear block's past
/// outputs read after the output-side blocks. Offered where that changes the model and the
/// class can take it: an output side with parameters (a Wiener nonlinearity or an output
/// block with parameters), an exact input (Wiener, no input block: stage 3 shares one
/// uncertain signal, here the past outputs), no unit gain (eq 8 is not taken with feedback),
/// not yet inside the loop. No parameter is added. (The diagnosis offers it only without
/// steady-state points, which stage 1 cannot read inside the loop.)
pub fn inside_the_loop(base: &ModelSpec) -> Option<ModelSpec> {
    let has_parameters = |tag: &str| !crate::registry::parameter_names(tag).is_empty();
    let output_side = base
        .output
        .iter()
        .any(|b| has_parameters(&crate::nonlinearity::tag_of_model(b.as_ref())))
        || (base.structure == crate::nonlinearity::Structure::Wiener
            && has_parameters(&base.nonlinearity_tag()));
    let exact_input =
        base.structure == crate::nonlinearity::Structure::Wiener && base.input.is_empty();
    if base.feedback || base.unit_gain || !output_side || !exact_input || base.na == 0 {
        return None;
    }
    let mut m = base.duplicate();
    m.feedback = true;
    m.layout().is_ok().then_some(m)
}

/// Gives candidate `m` the prior box of [`design_prior_for`] where it needs one (its
/// nonlinearity's parameters were in the model already: bisected now, not added), listed with
/// its priors. Without a box from the points the candidate is tried as it is, and its verdict
/// says why it fails; under a term that breaks the design (whose polygons stage 1 refuses)
/// it gets the box of [`crate::pipeline::scale_prior`] (reported), or, where the plugin offers
/// none, it is not tried, and `untried` says why. `false`: the model with the box has no layout (not
/// offered). Nothing to do without steady-state points, or where the candidate neither adds
/// an input-side block (`input_block`) nor has a term that breaks the design.
pub(super) fn with_design_prior(
    m: &mut ModelSpec,
    layout: &crate::model::Layout,
    steady: Option<&SteadyStateData>,
    input_block: bool,
    given: &mut Vec<(String, [f64; 2])>,
    untried: &mut Option<String>,
    what: &str,
) -> bool {
    // Where a box may be needed: behind the input-side block the candidate adds, or under a
    // term (the candidate's or one declared before) that leaves the polygons unusable.
    let Some(steady) = steady.filter(|_| input_block || m.term_breaking_steady_design().is_some())
    else {
        return true;
    };
    // The model with `boxes` as its nonlinearity's prior, listed with the candidate's priors;
    // `None` where that model has no layout.
    let give = |m: &ModelSpec, boxes: Vec<(String, crate::interval::Interval)>| {
        let mut with = m.duplicate();
        for (n, p) in &boxes {
            with.prior.insert(n.clone(), [p.lo, p.hi]);
        }
        with.layout().is_ok().then(|| {
            let listed: Vec<(String, [f64; 2])> =
                boxes.into_iter().map(|(n, p)| (n, [p.lo, p.hi])).collect();
            (with, listed)
        })
    };
    match design_prior_for(m, layout, steady) {
        Ok(Some(boxes)) => match give(m, boxes) {
            Some((with, listed)) => {
                *m = with;
                given.extend(listed);
                true
            }
            None => false,
        },
        Ok(None) => true,
        Err(e) => {
            log::info!(target: "smid::diagnose", "{what}: no prior box for the nonlinearity from the steady-state points: {e}");
            if let Some(term) = m.term_breaking_steady_design() {
                // The points are off their branches even as if the design held: a box from
                // their scale alone, pruned by them with any history.
                let scale = crate::pipeline::scale_prior(m, steady);
                let from_scale = scale.is_some();
                if let Some((with, listed)) = scale.and_then(|b| give(m, b)) {
                    log::info!(target: "smid::diagnose", "{what}: the nonlinearity's prior from the scale of the steady-state points");
                    *m = with;
                    given.extend(listed);
                    return true;
                }
                *untried = Some(format!(
                    "`{}` breaks the designed steady-state experiment, so stage 1 refuses the polygons, and the steady-state points give no box for the nonlinearity even as if the design held ({e}), {}; {}",
                    term.label(),
                    if from_scale {
                        "and the box from their scale leaves the model without a layout"
                    } else {
                        "nor from their scale (`NonlinearityModel::scale_prior`: the plugin offers none, the chain has blocks, the gain is not unit or the points span nothing)"
                    },
                    crate::pipeline::prior_box_to_give(m)
                ));
            }
            true
        }
    }
}

/// The prior box of a model's nonlinearity when candidate `m` breaks the designed
/// steady-state experiment at every point over its prior (stage 1 over the prior fails: an
/// input block that clips or kinks the wave, a term that switches while it settles,
/// [`crate::effect::EquationTerm::keeps_steady_design`]) and the nonlinearity is not bisected
/// yet: the polygons' hull as if the design held, with each point's input an interval over
/// the blocks' priors, widened ([`crate::pipeline::design_prior`]). The nonlinearity is then
/// bisected in that box and the steady-state points prune its cells with any history. `None`:
/// nothing to add (the candidate keeps the design, or the nonlinearity has no parameters or a
/// prior already).
fn design_prior_for(
    m: &ModelSpec,
    layout: &crate::model::Layout,
    steady: &SteadyStateData,
) -> Result<Option<Vec<(String, crate::interval::Interval)>>> {
    let names = crate::registry::parameter_names(&m.nonlinearity_tag());
    if names.is_empty() || !layout.nonlinearity_cells.is_empty() {
        return Ok(None);
    }
    let cell: Vec<crate::interval::Interval> = layout.dims.iter().map(|d| d.prior).collect();
    // Stage 1 over the whole prior: when some points' designed steps pass every input block
    // (`keeps_steady_design_over`), their polygons bound the nonlinearity in every cell (a
    // smaller cell keeps at least those points), with no assumption.
    if crate::pipeline::stage1(m, layout, Some(steady), &cell).is_ok() {
        return Ok(None);
    }
    let boxes = crate::pipeline::design_prior(m, layout, steady, &cell)?;
    Ok(Some(
        boxes
            .into_iter()
            .filter(|(n, _)| names.contains(n))
            .collect(),
    ))
}
