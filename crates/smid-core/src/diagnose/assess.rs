//! The before/after table: each model at the smallest noise bound that makes its training
//! data consistent ([`identify_consistent`]), validated on the held-out records ([`assess`]).
use super::trying::with_model;
use super::verdict::{Choice, Column, Stopped};
use crate::error::{Result, SmidError};
use crate::model::ModelSet;
use crate::outcome::{Falsification, Outcome};
use crate::pipeline::{identify, ExperimentData, Identification, Record};
use crate::settings::Check;
use crate::spec::{ModelSpec, Spec};
use crate::validate;

/// Identify a model at the smallest noise bound (≥ the declared one) that makes the training
/// data consistent: the declared bound when it suffices, else bisection between the last
/// failing and the first passing of doubled bounds (relative resolution 2 %, at most 40
/// identifications; below the first bound at which the data are shown not to bound the set,
/// a bisection for a window first). `Falsified` when no bound tried makes them consistent with
/// a bounded set; its proof is the last inconsistent bound's, and its detail names where the
/// data stopped bounding the set.
pub fn identify_consistent(
    spec: &Spec,
    data: &ExperimentData,
) -> Result<Outcome<(Identification, bool)>> {
    let start = std::time::Instant::now();
    let r = identify_consistent_at(spec, data);
    log::info!(target: "smid::diagnose", "smallest consistent bound of {}: {:.2} s", spec.model.label(), start.elapsed().as_secs_f64());
    r
}

fn identify_consistent_at(
    spec: &Spec,
    data: &ExperimentData,
) -> Result<Outcome<(Identification, bool)>> {
    let declared = match identify(spec, data.clone(), &[])? {
        Outcome::Consistent(id) => return Ok(Outcome::Consistent((id, false))),
        Outcome::Falsified(f) => f,
    };
    let d0 = spec.noise.delta()?;
    /// What one trial bound gave.
    enum Tried {
        Found(Box<Identification>),
        /// Not shown consistent: falsified (the proof), or solver trouble or cells the budget
        /// left open (`None`).
        Inconsistent(Option<Falsification>),
        /// Consistent, but the data no longer bound the set (why): nor at any larger bound.
        Unbounded(String),
    }
    let at = |d: f64| -> Result<Tried> {
        let mut v = serde_json::to_value(spec).expect("specs serialise");
        v["noise"] = serde_json::json!({ "delta": d, "simulate": spec.noise.simulated()? });
        let mut s: Spec = serde_json::from_value(v).expect("a serialised spec deserialises");
        // Only the bound finally kept needs its simulation member (computed below).
        s.method.member.search = false;
        let mut d2 = data.clone();
        for r in &mut d2.records {
            *r = r.with_bound(d);
        }
        if let Some(st) = d2.steady.as_mut() {
            for p in &mut st.points {
                p.dy = d;
            }
        }
        // Solver trouble at a trial bound counts as "not shown consistent": the bound found
        // is then only larger (this bound serves the before/after table, not a guarantee).
        match identify(&s, d2, &[]) {
            // Cells left without a finite θ bound: no usable model at this bound either, but
            // not a ceiling: which cells the budget leaves open depends on how the bound's
            // larger box was cut (a larger bound has found every cell bounded), as solver
            // trouble is not a proof either.
            Ok(Outcome::Consistent(id)) if !id.model.search.unbounded.is_empty() => {
                Ok(Tried::Inconsistent(None))
            }
            Ok(Outcome::Consistent(id)) => Ok(Tried::Found(Box::new(id))),
            Ok(Outcome::Falsified(f)) => Ok(Tried::Inconsistent(Some(f))),
            Err(e @ SmidError::Unbounded { .. }) => Ok(Tried::Unbounded(e.to_string())),
            Err(SmidError::Solver(_)) => Ok(Tried::Inconsistent(None)),
            Err(e) => Err(e),
        }
    };
    // Doubling until a bound makes the data consistent. The first bound at which the data are
    // shown not to bound the set (`SmidError::Unbounded`: a slope reaching 0, θ unbounded
    // without cells) is searched below first: a larger bound only widens the exact set, so a
    // window where the model is consistent and bounded lies between the last inconsistent
    // bound and it, and is bisected for. Without one, the doubling goes on past it (the
    // computed sets are outer approximations, and one can be bounded again at a larger
    // bound), and where it stops the column says both ends.
    let (mut lo, mut hi) = (d0, 2.0 * d0);
    let mut ceiling: Option<(f64, String)> = None;
    // Below the ceiling (bisecting for the window) or past it (doubling again).
    let mut past = false;
    // The last bound shown inconsistent, and its proof (the declared bound's to begin with).
    let mut proof = declared;
    let mut proven = d0;
    let mut best = None;
    let (mut checks, mut doublings) = (0, 0);
    while best.is_none() {
        checks += 1;
        if doublings >= 30 || checks > 45 {
            let tail = match &ceiling {
                Some((c, why)) => format!(
                    "; from {c:.3e} on the data are not shown to bound the set ({why}), and no bound up to {lo:.3e} made them consistent with a bounded one"
                ),
                None => format!("; no bound up to {lo:.3e} made them consistent"),
            };
            let mut f = proof;
            f.detail = format!(
                "{}; the training data are inconsistent at a noise bound of {proven:.3e}{tail}",
                f.detail
            );
            return Ok(Outcome::Falsified(f));
        }
        let bisecting = !past && ceiling.is_some();
        match at(hi)? {
            Tried::Found(id) => best = Some(*id),
            Tried::Inconsistent(f) => {
                lo = hi;
                if let Some(f) = f {
                    proof = f;
                    proven = hi;
                }
                hi = match (&ceiling, bisecting) {
                    (Some((c, _)), true) => 0.5 * (lo + c),
                    _ => {
                        doublings += 1;
                        2.0 * hi
                    }
                };
            }
            Tried::Unbounded(why) if !past => {
                ceiling = Some((hi, why));
                hi = 0.5 * (lo + hi);
            }
            Tried::Unbounded(_) => {
                lo = hi;
                doublings += 1;
                hi *= 2.0;
            }
        }
        if let (Some((c, _)), false, None) = (&ceiling, past, &best) {
            if c - lo <= 0.02 * c {
                // No window below the ceiling: double on from it.
                past = true;
                lo = *c;
                hi = 2.0 * c;
            }
        }
    }
    let mut best = best.expect("found above");
    while hi - lo > 0.02 * hi && checks < 40 {
        let mid = 0.5 * (lo + hi);
        checks += 1;
        match at(mid)? {
            Tried::Found(id) => {
                best = *id;
                hi = mid;
            }
            Tried::Inconsistent(_) => lo = mid,
            // Not below a bound found consistent and bounded: solver trouble's kin.
            Tried::Unbounded(_) => lo = mid,
        }
    }
    best.model.simulation_member =
        crate::members::simulation_member(&best.model, &spec.method.member.check()?)?;
    Ok(Outcome::Consistent((best, true)))
}

/// The before/after table on held-out records (the only place they are read).
pub fn assess(
    spec: &Spec,
    training: &ExperimentData,
    choice: &mut Choice,
    holdout: &[Record],
    k: usize,
) -> Result<(Column, Column)> {
    let mut dspec = with_model(spec, &spec.model);
    dspec.method = choice.method.clone();
    let spec = &dspec;
    let column = |model: &ModelSpec,
                  known: Option<&ModelSet>,
                  searched: Option<Result<Outcome<(Identification, bool)>>>|
     -> Result<Column> {
        let (m, inflated) = match known {
            Some(m) => (m.duplicate(), false),
            None => {
                let found = match searched {
                    Some(found) => found,
                    None => identify_consistent(&with_model(spec, model), training),
                };
                let stopped = match found {
                    Ok(Outcome::Consistent((id, inflated))) => Ok((id.model, inflated)),
                    // A model the training data falsify at every bound tried, or that no
                    // bound makes finite: a row that says where the search stopped.
                    Ok(Outcome::Falsified(f)) => Err(Stopped::Falsified {
                        detail: f.message(),
                    }),
                    Err(e @ SmidError::Unbounded { .. }) => Err(Stopped::Unbounded {
                        detail: e.to_string(),
                    }),
                    Err(e @ SmidError::Solver(_)) => Err(Stopped::Solver {
                        detail: e.to_string(),
                    }),
                    Err(e @ SmidError::Unsupported { .. }) => Err(Stopped::Unsupported {
                        detail: e.to_string(),
                    }),
                    Err(e) => return Err(e),
                };
                match stopped {
                    Ok(m) => m,
                    Err(stopped) => {
                        return Ok(Column {
                            label: model.label(),
                            bound: f64::NAN,
                            inflated: true,
                            parameters: 0,
                            mean_radius: f64::NAN,
                            validation: None,
                            stopped: Some(stopped),
                            model: None,
                        })
                    }
                }
            }
        };
        // The before/after table compares fits and verdicts; the band is `validate`'s.
        // The table's verdicts: a proof is searched for only where the relaxation leaves them
        // undecided (`validate` searches everywhere).
        let opts = validate::Options {
            k,
            band: false,
            prove: false,
            ..Default::default()
        };
        let v = validate::validate(&m, holdout, &opts)?;
        let free = m.free_parameters();
        let finite: Vec<f64> = free
            .iter()
            .map(|p| p.radius)
            .filter(|r| r.is_finite())
            .collect();
        Ok(Column {
            label: model.label(),
            bound: m.delta,
            inflated,
            parameters: free.len(),
            mean_radius: finite.iter().sum::<f64>() / finite.len().max(1) as f64,
            validation: Some(v),
            stopped: None,
            model: Some(m),
        })
    };
    let unchanged = choice.added.is_empty();
    // The before column's bound search, when the choice ran it beside its rounds.
    let searched = choice.before_identified.take();
    let choice = &*choice;
    if unchanged {
        if let Some(known) = choice.after_set.as_ref() {
            // Nothing added: both columns are the one model set on the same records, validated
            // once (the validation is deterministic, and on a long measured record it is about
            // half of a diagnosis that adds nothing).
            let after = column(&choice.after, Some(known), None)?;
            let before = Column {
                label: choice.before.label(),
                validation: after.validation.clone(),
                stopped: after.stopped.clone(),
                model: after.model.as_ref().map(ModelSet::duplicate),
                ..after
            };
            return Ok((before, after));
        }
    }
    // The two columns are independent (the before column's bound search is the longer part):
    // computed side by side.
    let (before, after) = rayon::join(
        || {
            let known = choice.after_set.as_ref().filter(|_| unchanged);
            column(&choice.before, known, searched)
        },
        || column(&choice.after, choice.after_set.as_ref(), None),
    );
    Ok((before?, after?))
}
