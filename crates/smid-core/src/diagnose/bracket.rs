//! A round's candidates tried on the training records ([`try_candidates`]): with an estimated
//! bound, every bound bracketed first and only the candidates the rule needs identified whole
//! ([`identify_needed`]).
use super::rule::bar;
use super::schedule::identify_needed;
use super::trying::{try_model, with_model};
use super::verdict::{bound_of, Evidence, TrainVerdict};
use super::Rule;
use crate::error::Result;
use crate::model::ModelSet;
use crate::pipeline::{Bracket, ExperimentData};
use crate::spec::{CellSpec, ModelSpec, Spec};

/// Identify each candidate on the training records: its verdict into its evidence, its set
/// (when admissible) returned in the same order.
///
/// With `base` (the verdict of the model an estimated-bound round extends), each candidate's
/// bracket is first started alone ([`crate::pipeline::bracket_start`], in parallel): a
/// candidate the training data falsify at its [`bar`] is not bracketed further (its verdict is
/// [`TrainVerdict::AboveBar`]); the others have the classical estimate as a floor, and their
/// brackets are doubled and narrowed only where the rule's order needs it
/// ([`identify_needed`]). Only the candidates the rule needs are identified whole
/// (the set, its member, its fit), one at a time in the order of their bracketed bounds (then
/// fewer added parameters, then candidate order): until the rule's pick is found, and beyond
/// it those whose bound is close enough to the pick's (the rule's `per_parameter`) to be marked
/// equivalent to it. The rest keep [`TrainVerdict::Bracketed`]. The pick and its equivalents
/// are the ones identifying every candidate gives, as long as a candidate's bound is the one
/// its bracket kept (a candidate whose coarse cells leave `θ` unbounded is bracketed again
/// with the spec's own budget, [`try_model`]; it is ranked by its first bracket).
pub(super) fn try_candidates(
    rule: &Rule,
    spec: &Spec,
    full: &CellSpec,
    cands: &mut [(ModelSpec, Evidence)],
    training: &ExperimentData,
    base: Option<&TrainVerdict>,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Vec<Option<ModelSet>> {
    use rayon::prelude::*;
    use std::sync::atomic::{AtomicUsize, Ordering};
    // The candidates are independent: identified (or bracketed) in parallel, results in
    // candidate order (so the choice does not depend on the thread timing).
    let total = cands.len();
    let done = AtomicUsize::new(0);
    let tick = || progress(done.fetch_add(1, Ordering::Relaxed) + 1, total);
    let bar_of = |ev: &Evidence| base.map(|b| bar(rule, bound_of(b), ev.added_parameters));
    // A verdict known before trying ([`Evidence::untried`]) is the candidate's.
    let known = |ev: &mut Evidence| {
        ev.untried.take().map(|t| {
            ev.train = t;
            tick();
        })
    };
    let Some(base) = base else {
        return cands
            .par_iter_mut()
            .map(|(m, ev)| {
                if known(ev).is_some() {
                    return None;
                }
                let start = std::time::Instant::now();
                let (t, id) = try_model(spec, full, m, training, None, None);
                log::info!(target: "smid::diagnose", "{}: {:.2} s", ev.label, start.elapsed().as_secs_f64());
                ev.train = t;
                tick();
                id.map(|id| id.model)
            })
            .collect();
    };
    // Every candidate's bracket, up to its doubling (the bar, the classical estimate); the
    // ones with a bound to take on wait, the others get their verdict now.
    let pending: Vec<Option<Bracket>> = cands
        .par_iter_mut()
        .map(|(m, ev)| {
            if known(ev).is_some() {
                return None;
            }
            let start = std::time::Instant::now();
            let b = crate::pipeline::bracket_start(&with_model(spec, m), training, bar_of(ev));
            log::info!(target: "smid::diagnose", "{}: bracket started in {:.2} s: {}", ev.label, start.elapsed().as_secs_f64(), describe(&b));
            match b {
                Ok(b) if b.floor().is_some() => return Some(b),
                b => ev.train = try_model(spec, full, m, training, bar_of(ev), Some(b)).0,
            }
            tick();
            None
        })
        .collect();
    let mut sets: Vec<Option<ModelSet>> = (0..cands.len()).map(|_| None).collect();
    let order: Vec<(usize, Bracket)> = pending
        .into_iter()
        .enumerate()
        .filter_map(|(i, b)| Some((i, b?)))
        .collect();
    let waiting = order.len();
    let mut evidence: Vec<Evidence> = cands.iter().map(|(_, e)| e.clone()).collect();
    let labels: Vec<String> = evidence.iter().map(|e| e.label.clone()).collect();
    let models: Vec<&ModelSpec> = cands.iter().map(|(m, _)| m).collect();
    let advance = |batch: &[(usize, Bracket, Option<f64>)]| -> Vec<Bracket> {
        batch
            .par_iter()
            .map(|(i, b, probe)| {
                let start = std::time::Instant::now();
                let cand = with_model(spec, models[*i]);
                let (next, step) = match (b, probe) {
                    (Bracket::Started(s), Some(at)) => {
                        let next = s.probe(&cand, training, *at);
                        let asked = match &next {
                            Bracket::Started(n) => n.probed.is_some_and(|(_, a)| a.is_some()),
                            _ => true,
                        };
                        let step = if asked {
                            format!("probed at {at:.4e}")
                        } else {
                            format!("not probed at {at:.4e} (cells differ, or no answer)")
                        };
                        (next, step)
                    }
                    (Bracket::Started(_), None) => {
                        (b.clone().advanced(&cand, training), "doubled".to_string())
                    }
                    _ => (b.clone().advanced(&cand, training), "narrowed".to_string()),
                };
                log::info!(target: "smid::diagnose", "{}: bracket {step} in {:.2} s: {}", labels[*i], start.elapsed().as_secs_f64(), describe(&Ok(next.clone())));
                next
            })
            .collect()
    };
    let mut settled = 0;
    let mut identify = |i: usize, ev: &Evidence, b: Bracket| {
        let start = std::time::Instant::now();
        let at = b.bound();
        let (t, id) = try_model(spec, full, models[i], training, bar_of(ev), Some(Ok(b)));
        if let Some(d) = at {
            log::info!(target: "smid::diagnose", "{}: identified at {d:.4e} in {:.2} s", ev.label, start.elapsed().as_secs_f64());
        }
        tick();
        settled += 1;
        sets[i] = id.map(|id| id.model);
        t
    };
    identify_needed(rule, &mut evidence, order, base, &advance, &mut identify);
    // The candidates left bracketed are done too.
    for _ in settled..waiting {
        tick();
    }
    for ((_, e), ev) in cands.iter_mut().zip(evidence) {
        *e = ev;
    }
    sets
}

/// A bracket's state, for the log.
fn describe(b: &Result<Bracket>) -> String {
    match b {
        Ok(Bracket::At(d)) => format!("bound {d:.4e}"),
        Ok(Bracket::Started(s)) => match s.probed {
            Some((_, Some(true))) if s.floor() > s.first => {
                format!("bound at least {:.4e} (falsified below it)", s.floor())
            }
            _ => format!("bound at least {:.4e} (classical)", s.first),
        },
        Ok(Bracket::Coarse(c)) => format!("bound in ({:.4e}, {:.4e}]", c.floor(), c.ceiling()),
        Ok(Bracket::Above(_)) => "above its bar".into(),
        Ok(Bracket::Falsified(_)) => "falsified".into(),
        Err(e) => e.to_string().chars().take(60).collect(),
    }
}
