//! The rounds of a choice: candidates tried, the rule's pick, its equivalents, the model
//! extended, up to `max_effects` ([`choose`]).
use super::assess::identify_consistent;
use super::bracket::try_candidates;
use super::candidates::{candidates, FEEDBACK};
use super::equivalence::{mark_equivalences, mark_ties};
use super::rule::{admissible_pick, estimated_pick};
use super::screen::screen_reproduced;
use super::trying::{candidate_spec, training_fit, try_model, with_model};
use super::verdict::{best_fit, fit_of, Choice, Evidence, Round, TrainVerdict};
use super::{Options, Rule, AS_DECLARED};
use crate::effect::{self, DataScale};
use crate::error::{Result, SmidError};
use crate::model::ModelSet;
use crate::nonlinearity::SteadyStateData;
use crate::pipeline::{data_scale, ExperimentData};
use crate::settings::Check;
use crate::spec::{CellSpec, ModelSpec, Spec};
use crate::validate;

/// What the rounds of a choice reach: the model extended so far, its training verdict and
/// set, the rounds, the effects added and the chosen candidate's equivalents.
struct Reached {
    base: ModelSpec,
    base_train: TrainVerdict,
    base_set: Option<ModelSet>,
    rounds: Vec<Round>,
    added: Vec<String>,
    equivalent_models: Vec<(String, ModelSpec, ModelSet)>,
}

/// Search again, with the spec's own member budget `member` (as a ranking search: no
/// spread, and the give-ups of [`crate::spec::MemberSpec::gives_up_early`]), the members of the
/// admissible candidates that add at most `within` parameters (the rule's pick's) and whose
/// light-budget member ([`crate::spec::MemberSpec::LIGHT`]) simulates the training records more
/// than `slack` points below the best candidate's: the rule compares members, so a set must
/// not lose on fit because its first member search was cut short (a second backlash after the
/// first can fit several points better searched again than on the light budget, and without
/// this pass a worse candidate such as an input saturation would win). The better of the two
/// members is kept (the larger budget probes other cells and may find a worse one). Whether any
/// fit changed. (No spread, unlike the after-model's member search: spread names the right
/// effect in slightly more cases but makes each search several times dearer, and this pass
/// pays it for every contender it searches again.)
fn refine_contenders(
    cands: &mut [(ModelSpec, Evidence)],
    sets: &mut [Option<ModelSet>],
    within: usize,
    slack: f64,
    member: &crate::spec::MemberSpec,
) -> bool {
    use rayon::prelude::*;
    if *member == crate::spec::MemberSpec::LIGHT {
        return false;
    }
    let best_fit = best_fit(cands.iter().map(|(_, e)| e));
    // A ranking search: its fit decides, its envelope would not be used.
    let ranking = crate::spec::MemberSpec {
        spread: false,
        ..*member
    };
    let refined: Vec<(usize, Option<crate::model::SimulationMember>, f64)> = cands
        .iter()
        .zip(sets.iter())
        .enumerate()
        .filter(|(_, ((_, e), set))| {
            set.is_some()
                && e.train.admissible()
                && e.added_parameters <= within
                && fit_of(&e.train) < best_fit - slack
        })
        .collect::<Vec<_>>()
        .into_par_iter()
        .filter_map(|(i, ((_, e), set))| {
            let start = std::time::Instant::now();
            let mut set = set.as_ref()?.duplicate();
            set.simulation_member = crate::members::simulation_member(&set, &ranking.check().ok()?).ok()?;
            let fit = training_fit(&set).ok()?;
            log::info!(target: "smid::diagnose", "{}: member searched again (spec budget, ranking), training fit {:.2} % (was {:.2} %): {:.2} s", e.label, fit, fit_of(&e.train), start.elapsed().as_secs_f64());
            Some((i, set.simulation_member, fit))
        })
        .collect();
    let mut changed = false;
    for (i, m, fit) in refined {
        let Some(set) = sets[i].as_mut() else {
            continue;
        };
        if let TrainVerdict::Consistent {
            fit_percent,
            within,
            ..
        } = &mut cands[i].1.train
        {
            if fit > *fit_percent {
                *within = m.as_ref().and_then(|m| m.within);
                set.simulation_member = m;
                *fit_percent = fit;
                changed = true;
            }
        }
    }
    changed
}

/// The training steady-state points with the overshoot allowance α applied as every
/// candidate's stage 1 reads them ([`crate::pipeline::with_alpha`]), for the candidates'
/// design priors. Where α cannot be applied, the points as given (each candidate's own run
/// then says why).
fn steady_as_stage1_reads(spec: &Spec, training: &ExperimentData) -> Option<SteadyStateData> {
    let mut s = training.steady.clone()?;
    match crate::pipeline::with_alpha(spec, training.filter.as_ref(), &mut s) {
        Ok(()) => Some(s),
        Err(_) => training.steady.clone(),
    }
}

/// The rounds of [`choose`] from `base` (its training verdict and set): each tries every
/// candidate on the training records ([`try_candidates`]: with an estimated bound, brackets
/// every one and identifies whole only those the rule needs) and extends the model by the one
/// the rule picks, until
/// the model is admissible (or, with an estimated bound, nothing is picked) or
/// `opts.max_effects` are added; a model admissible as declared gets one round that only marks
/// its equivalents.
#[allow(clippy::too_many_arguments)]
fn rounds(
    tunables: &Rule,
    spec: &Spec,
    full: &CellSpec,
    training: &ExperimentData,
    opts: &Options,
    progress: &(dyn Fn(usize, usize) + Sync),
    scale: &DataScale,
    member: &crate::spec::MemberSpec,
    mut base: ModelSpec,
    mut base_train: TrainVerdict,
    mut base_set: Option<ModelSet>,
) -> Reached {
    let estimated = spec.noise.estimated();
    let mut rounds = Vec::new();
    let mut added = Vec::new();
    let mut equivalent_models = Vec::new();
    let steady = steady_as_stage1_reads(spec, training);
    while (estimated || !base_train.admissible()) && added.len() < opts.max_effects {
        let mut cands = candidates(&base, scale, opts, steady.as_ref());
        if estimated && base_train.admissible() {
            if let Some(b) = &base_set {
                screen_reproduced(b, &mut cands);
            }
        }
        let mut sets = try_candidates(
            tunables,
            spec,
            full,
            &mut cands,
            training,
            // A spec that also declares its bound identifies every model at that bound: there
            // is nothing to bracket.
            spec.noise.to_estimate().then_some(&base_train),
            progress,
        );
        let slack = fit_slack(tunables, training);
        let pick_of = |cands: &[(ModelSpec, Evidence)]| {
            if estimated {
                estimated_pick(tunables, cands, &base_train)
            } else {
                admissible_pick(cands, slack)
            }
        };
        let mut best_admissible = pick_of(&cands);
        if let Some(i) = best_admissible.filter(|_| !estimated) {
            let within = cands[i].1.added_parameters;
            if refine_contenders(&mut cands, &mut sets, within, slack, member) {
                best_admissible = pick_of(&cands);
            }
        }
        let pick = best_admissible.or_else(|| {
            cands
                .iter()
                .enumerate()
                .filter(|(_, (_, e))| e.train.reach() > base_train.reach())
                .max_by_key(|(_, (_, e))| (e.train.reach(), std::cmp::Reverse(e.added_parameters)))
                .map(|(i, _)| i)
        });
        let mut round = Round {
            base: base.label(),
            base_train: base_train.clone(),
            candidates: cands.iter().map(|(_, e)| e.clone()).collect(),
        };
        mark_equivalences(
            tunables,
            &mut round.candidates,
            &sets,
            base_set.as_ref().filter(|_| base_train.admissible()),
            estimated,
        );
        if let Some(i) = best_admissible.filter(|_| !estimated) {
            mark_ties(&mut round.candidates, i, slack);
        }
        match pick {
            Some(i) => {
                equivalent_models = round.candidates[i]
                    .equivalent_to
                    .iter()
                    .filter_map(|l| {
                        let j = round.candidates.iter().position(|e| &e.label == l)?;
                        let set = sets[j].as_ref()?.duplicate();
                        Some((l.clone(), cands[j].0.duplicate(), set))
                    })
                    .collect();
                round.candidates[i].chosen = true;
                added.push(round.candidates[i].label.clone());
                base_train = round.candidates[i].train.clone();
                base = cands.swap_remove(i).0;
                base_set = sets.swap_remove(i);
                rounds.push(round);
            }
            None => {
                rounds.push(round);
                break;
            }
        }
    }
    if !estimated && added.is_empty() && base_train.admissible() {
        // The model as declared is consistent: one round tells which candidates the training
        // records cannot tell apart from it (an output offset on a backlash is a shift of its
        // plays); none is added.
        let mut cands = candidates(&base, scale, opts, steady.as_ref());
        let sets = try_candidates(tunables, spec, full, &mut cands, training, None, progress);
        let mut round = Round {
            base: base.label(),
            base_train: base_train.clone(),
            candidates: cands.iter().map(|(_, e)| e.clone()).collect(),
        };
        mark_equivalences(
            tunables,
            &mut round.candidates,
            &sets,
            base_set.as_ref(),
            estimated,
        );
        equivalent_models = round
            .candidates
            .iter()
            .enumerate()
            .filter(|(_, e)| e.equivalent_to.iter().any(|l| l == AS_DECLARED))
            .filter_map(|(j, e)| {
                let set = sets[j].as_ref()?.duplicate();
                Some((e.label.clone(), cands[j].0.duplicate(), set))
            })
            .collect();
        rounds.push(round);
    }
    Reached {
        base,
        base_train,
        base_set,
        rounds,
        added,
        equivalent_models,
    }
}

/// How far (in fit points) a candidate's training free run may fall below the best one's and
/// still count as simulating as well: what the noise alone can account for,
/// `100 · ‖Δη‖ / ‖y - ȳ‖` over the training records (the pooled norms of [`validate::Fit`]),
/// at most the rule's `fit_slack`. Near 100 % a fixed slack would let a model with several
/// times the best one's error win on parameter count.
fn fit_slack(tunables: &Rule, training: &ExperimentData) -> f64 {
    // The fit's own norms, of an output that misses each sample by its whole noise bound.
    let off: Vec<Vec<f64>> = training
        .records
        .iter()
        .map(|r| r.y.iter().zip(&r.dy).map(|(y, d)| y - d).collect())
        .collect();
    let pairs: Vec<(&[f64], &[f64])> = training
        .records
        .iter()
        .zip(&off)
        .map(|(r, o)| (r.y.as_slice(), o.as_slice()))
        .collect();
    let floor = 100.0 * validate::Fit::of(&pairs).nrmse;
    if floor.is_finite() {
        floor.min(tunables.fit_slack)
    } else {
        tunables.fit_slack
    }
}

/// Every tag of `only` names a registered effect or plugin (an unknown one would leave the
/// diagnosis without candidates, silently).
fn check_only(only: &[String]) -> Result<()> {
    let effects: Vec<&str> = effect::effects().iter().map(|e| e.tag).collect();
    let plugins: Vec<&str> = crate::registry::models().iter().map(|e| e.tag).collect();
    match only
        .iter()
        .find(|t| {
            !effects.contains(&t.as_str()) && !plugins.contains(&t.as_str()) && *t != FEEDBACK
        })
    {
        Some(t) => Err(SmidError::invalid(
            "only",
            format!(
                "no registered effect or plugin `{t}`, nor `{FEEDBACK}` (the output side inside the loop); effects: {}; plugins: {}",
                effects.join(", "),
                plugins.join(", ")
            ),
        )),
        None => Ok(()),
    }
}

/// Choose what to add, from the training data alone. `progress(done, total)` after each
/// candidate.
pub fn choose(
    spec: &Spec,
    training: &ExperimentData,
    opts: &Options,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Result<Choice> {
    check_only(&opts.only)?;
    let tunables = spec.diagnosis.check()?;
    let (per_parameter, fit_slack_most) = (tunables.per_parameter, tunables.fit_slack);
    let mut scale = data_scale(training);
    if !spec.noise.estimated() {
        scale.noise = spec.noise.delta().ok();
    }
    let before = spec.model.duplicate();
    let base = spec.model.duplicate();
    // Candidates that bisect a nonlinearity's parameters get a diagnosis budget (coarser cells);
    // the augmented spec keeps it, so its results reproduce.
    let member_budget = spec.method.member;
    let full = spec.method.cells.clone();
    let dspec = candidate_spec(spec);
    // The stage options of the table (the after-model's member on the spec's own budget).
    let mut method = dspec.method.clone();
    method.member = member_budget;
    let spec = &dspec;
    let start = std::time::Instant::now();
    let (base_train, first) = try_model(spec, &full, &base, training, None, None);
    log::info!(target: "smid::diagnose", "the model as declared: {:.2} s", start.elapsed().as_secs_f64());
    // A model as declared that the training data falsify is the table's before column at its
    // smallest consistent bound whatever the rounds add: that search (training records only)
    // runs beside the rounds, on the cores the candidates leave idle.
    let before_spec = (!spec.noise.estimated() && !base_train.admissible()).then(|| {
        let mut s = with_model(spec, &before);
        s.method = method.clone();
        s
    });
    let estimated = spec.noise.estimated();
    let rule = if estimated {
        format!("the noise bound is estimated per model (the smallest bound consistent with the training records, × margin), so every model is admissible: a candidate is kept when its bound falls below {per_parameter} × the base model's bound per added parameter (an information criterion on the training data, in the ℓ∞ sense) and its free-run fit on the training records is no worse than the base model's (by more than {fit_slack_most} points: a candidate that explains samples away, as a saturation that swallows the worst ones, does not simulate better), the lowest bound first; a candidate the training data falsify at that bar is not bracketed further (\"inconsistent at the bar\"), and one whose bound lies more than a step above the pick's is not identified (\"bracketed, not identified\")")
    } else {
        format!("admissible (training data consistent with the declared noise bound) and simulating the training records as well as the best admissible candidate (free-run fit within {:.3} point(s): what the noise bound accounts for, at most {fit_slack_most}), the fewest added parameters, then the best fit; when none is admissible, the one whose first contradiction comes latest is extended in a further round", fit_slack(&tunables, training))
    };
    let (reached, before_identified) = rayon::join(
        || {
            rounds(
                &tunables,
                spec,
                &full,
                training,
                opts,
                progress,
                &scale,
                &member_budget,
                base,
                base_train,
                first.map(|id| id.model),
            )
        },
        || {
            before_spec
                .as_ref()
                .map(|s| identify_consistent(s, training))
        },
    );
    let Reached {
        mut base,
        base_train,
        base_set,
        rounds,
        mut added,
        mut equivalent_models,
    } = reached;
    let after_admissible = base_train.admissible();
    if !after_admissible {
        // Nothing made the data consistent: keep the model as declared.
        base = before.duplicate();
        added.clear();
        equivalent_models.clear();
    }
    // The after-model's simulation member and envelope on the spec's own budget.
    let after_set = match (after_admissible, base_set) {
        (true, Some(mut set)) => {
            set.method.member = member_budget;
            let start = std::time::Instant::now();
            set.simulation_member =
                crate::members::simulation_member(&set, &member_budget.check()?)?;
            log::info!(target: "smid::diagnose", "the after-model's simulation member: {:.2} s", start.elapsed().as_secs_f64());
            Some(set)
        }
        _ => None,
    };
    // The augmented spec reproduces the after-model: its budget is the one it was identified
    // with (the spec's own when the diagnosis budget left cells unbounded, see `try_model`).
    if let Some(set) = &after_set {
        method.cells = set.method.cells.clone();
    }
    Ok(Choice {
        rule,
        rounds,
        added,
        before,
        after: base,
        after_admissible,
        after_set,
        method,
        equivalent_models,
        before_identified,
    })
}
