//! The choice rule's picks: at a declared bound ([`admissible_pick`]) and at an estimated one
//! ([`estimated_pick`], under each candidate's [`bar`]).
use super::equivalence::by_bound;
use super::verdict::{best_fit, bound_of, fit_of, Evidence, TrainVerdict};
use super::Rule;
use crate::spec::ModelSpec;

/// The largest estimated bound a candidate adding `added` parameters may have to be kept,
/// against a base model estimated at `base_bound`.
pub(super) fn bar(rule: &Rule, base_bound: f64, added: usize) -> f64 {
    base_bound * rule.per_parameter.powi(added.max(1) as i32)
}

/// The rule's pick at a declared bound: among the admissible candidates whose members simulate
/// the training records as well as the best one (within `slack` points), the fewest added
/// parameters, then the best fit. (Fewest parameters alone let a wide, uninformative set win: a
/// lag whose pole spans [0, 0.9] admits an input dead zone's data but simulates them at 65 %.)
pub(super) fn admissible_pick(cands: &[(ModelSpec, Evidence)], slack: f64) -> Option<usize> {
    let best_fit = best_fit(cands.iter().map(|(_, e)| e));
    cands
        .iter()
        .enumerate()
        .filter(|(_, (_, e))| e.train.admissible() && fit_of(&e.train) >= best_fit - slack)
        .min_by(|(_, (_, a)), (_, (_, b))| {
            a.added_parameters.cmp(&b.added_parameters).then(
                fit_of(&b.train)
                    .partial_cmp(&fit_of(&a.train))
                    .unwrap_or(std::cmp::Ordering::Equal),
            )
        })
        .map(|(i, _)| i)
}

/// The rule's pick at an estimated bound: the lowest bound among the candidates under their
/// [`bar`] that simulate no worse than the base model (by the rule's `fit_slack`).
pub(super) fn estimated_pick(
    rule: &Rule,
    cands: &[(ModelSpec, Evidence)],
    base_train: &TrainVerdict,
) -> Option<usize> {
    estimated_pick_of(rule, cands.iter().map(|(_, e)| e), base_train)
}

/// [`estimated_pick`] over the candidates' evidence.
pub(super) fn estimated_pick_of<'a>(
    rule: &Rule,
    evidence: impl Iterator<Item = &'a Evidence>,
    base_train: &TrainVerdict,
) -> Option<usize> {
    let base_bound = bound_of(base_train);
    evidence
        .enumerate()
        .filter(|(_, e)| {
            // Admissible first: with a base that is not consistent the bar is infinite, and a
            // failed candidate's infinite bound would clear it.
            e.train.admissible()
                && bound_of(&e.train) <= bar(rule, base_bound, e.added_parameters)
                && fit_of(&e.train) >= fit_of(base_train) - rule.fit_slack
        })
        .min_by(|(_, a), (_, b)| {
            by_bound(
                (bound_of(&a.train), a.added_parameters),
                (bound_of(&b.train), b.added_parameters),
            )
        })
        .map(|(i, _)| i)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::diagnose::verdict::tests::evidence;
    use crate::settings::Check;

    fn rule() -> Rule {
        crate::spec::DiagnosisSpec::default().check().unwrap()
    }

    /// The estimated rule picks only a consistent candidate, also when the base model is not
    /// consistent itself (its bar is then infinite, and so is a failed candidate's bound).
    #[test]
    fn the_estimated_pick_is_consistent_whatever_the_base() {
        let failed = TrainVerdict::Failed {
            message: "the data do not bound the noise bound".into(),
        };
        let mut ev = [evidence("a", 1, None), evidence("b", 2, None)];
        assert_eq!(estimated_pick_of(&rule(), ev.iter(), &failed), None);
        ev[1].train = TrainVerdict::Consistent {
            fit_percent: 50.0,
            bound: 0.3,
            unsettled: None,
            within: None,
        };
        assert_eq!(estimated_pick_of(&rule(), ev.iter(), &failed), Some(1));
        ev[0].train = TrainVerdict::Bracketed {
            bound: 0.1,
            at_least: false,
        };
        assert_eq!(estimated_pick_of(&rule(), ev.iter(), &failed), Some(1));
    }

    /// The estimated rule reads its tunables from the spec's `diagnosis` section: a candidate
    /// one parameter larger whose bound is 0.85 of the base's clears the default bar (0.9) but
    /// not a stricter one (0.8), and one whose fit falls two points clears a `fit_slack` of 3
    /// but not the default (1).
    #[test]
    fn the_estimated_pick_follows_the_rules_settings() {
        let consistent = |bound: f64, fit: f64| TrainVerdict::Consistent {
            fit_percent: fit,
            bound,
            unsettled: None,
            within: None,
        };
        let base = consistent(1.0, 80.0);
        let with = |per_parameter: f64, fit_slack: f64| {
            crate::spec::DiagnosisSpec {
                per_parameter,
                fit_slack,
            }
            .check()
            .unwrap()
        };
        let mut ev = [evidence("a", 1, None)];
        ev[0].train = consistent(0.85, 80.0);
        assert_eq!(estimated_pick_of(&rule(), ev.iter(), &base), Some(0));
        assert_eq!(estimated_pick_of(&with(0.8, 1.0), ev.iter(), &base), None);
        ev[0].train = consistent(0.85, 78.0);
        assert_eq!(estimated_pick_of(&rule(), ev.iter(), &base), None);
        assert_eq!(
            estimated_pick_of(&with(0.9, 3.0), ev.iter(), &base),
            Some(0)
        );
        for bad in [0.0, 1.0, f64::NAN] {
            let e = crate::spec::DiagnosisSpec {
                per_parameter: bad,
                fit_slack: 1.0,
            }
            .check()
            .unwrap_err();
            assert!(e.to_string().contains("diagnosis.per_parameter"), "{e}");
        }
        let e = crate::spec::DiagnosisSpec {
            per_parameter: 0.9,
            fit_slack: -1.0,
        }
        .check()
        .unwrap_err();
        assert!(e.to_string().contains("diagnosis.fit_slack"), "{e}");
    }
}
