//! Equivalences and ties: candidates the training records cannot tell apart, by their free
//! runs ([`mark_equivalences`]) or by the rule's own order ([`mark_ties`]).
use super::comparison::{centre_runs, indistinguishable, transplanted_runs, warm_up};
use super::verdict::{best_fit, fit_of, Evidence};
use super::{Rule, AS_DECLARED};
use crate::model::ModelSet;

/// Mark every pair of admissible candidates (and the admissible base model) whose training
/// behaviour the data cannot tell apart: their members simulate within twice the noise bound
/// of each other, or one's member, put into the other's model class ([`transplanted_runs`]),
/// simulates within that of itself. With `estimated` bounds, two models whose smallest
/// consistent bounds differ by more than the rule's step (its `per_parameter`) are told apart by
/// the data themselves (at the smaller bound the other model is falsified), whatever their runs.
pub(super) fn mark_equivalences(
    rule: &Rule,
    evidence: &mut [Evidence],
    sets: &[Option<ModelSet>],
    base: Option<&ModelSet>,
    estimated: bool,
) {
    // Each model's own bound (estimated bounds differ per model): the looser of the two, when
    // the data do not already tell them apart by their bounds.
    let tol = |a: &ModelSet, b: &ModelSet| {
        let (lo, hi) = (a.delta.min(b.delta), a.delta.max(b.delta));
        (!estimated || within_step(rule, lo, hi)).then_some(2.0 * hi)
    };
    let runs: Vec<Option<Vec<Vec<f64>>>> = sets
        .iter()
        .map(|s| s.as_ref().and_then(centre_runs))
        .collect();
    let base_runs = base.and_then(centre_runs);
    // Two models with their members' runs: alike, or one's member put into the other's class
    // simulates as the member does (after both transients from rest, [`warm_up`]).
    let alike = |ra: &[Vec<f64>], sa: &ModelSet, rb: &[Vec<f64>], sb: &ModelSet| {
        let Some(t) = tol(sa, sb) else {
            return false;
        };
        let skip = warm_up(sa, sb, t);
        let swapped = |from: &ModelSet, to: &ModelSet, own: &[Vec<f64>]| {
            transplanted_runs(from, to, skip).is_some_and(|r| indistinguishable(own, &r, t, skip))
        };
        indistinguishable(ra, rb, t, skip) || swapped(sa, sb, ra) || swapped(sb, sa, rb)
    };
    // The relation is symmetric: each pair is compared once (both transplants), then every
    // candidate's list is filled in candidate order.
    let n = evidence.len();
    let mut same = vec![vec![false; n]; n];
    for i in 0..n {
        for j in i + 1..n {
            if let (Some(ri), Some(si), Some(rj), Some(sj)) =
                (&runs[i], &sets[i], &runs[j], &sets[j])
            {
                let e = alike(ri, si, rj, sj);
                same[i][j] = e;
                same[j][i] = e;
            }
        }
    }
    for i in 0..n {
        let (Some(ri), Some(si)) = (&runs[i], &sets[i]) else {
            continue;
        };
        if let (Some(rb), Some(b)) = (&base_runs, base) {
            if alike(ri, si, rb, b) {
                evidence[i].equivalent_to.push(AS_DECLARED.into());
            }
        }
        for j in (0..n).filter(|&j| same[i][j]) {
            let l = evidence[j].label.clone();
            evidence[i].equivalent_to.push(l);
        }
    }
}

/// Whether two estimated bounds `lo <= hi` lie within one rule step (the rule's `per_parameter`): only
/// then can the data leave the two models alike ([`mark_equivalences`]); farther apart, at
/// the smaller bound the other model is falsified.
pub(super) fn within_step(rule: &Rule, lo: f64, hi: f64) -> bool {
    lo >= rule.per_parameter * hi
}

/// The estimated rule's order: the lower bound first, then fewer added parameters.
pub(super) fn by_bound(a: (f64, usize), b: (f64, usize)) -> std::cmp::Ordering {
    a.0.total_cmp(&b.0).then(a.1.cmp(&b.1))
}

/// Mark as equivalent to the rule's pick `i` (at a declared bound) every candidate the rule
/// could not tell from it: admissible at the same declared bound, adding as many parameters,
/// and simulating the training records within `slack` points of the best (what the noise
/// bound accounts for), so that only the best fit, a difference the noise explains, decided
/// between them (in the 12-bit offset diagnosis of `examples/diagnose/12bit/`, one more pole,
/// one more zero and the frictions beside the offset).
pub(super) fn mark_ties(evidence: &mut [Evidence], i: usize, slack: f64) {
    let best_fit = best_fit(evidence.iter());
    let added = evidence[i].added_parameters;
    let tied: Vec<usize> = (0..evidence.len())
        .filter(|&j| {
            let e = &evidence[j];
            j != i
                && e.train.admissible()
                && e.added_parameters == added
                && fit_of(&e.train) >= best_fit - slack
        })
        .collect();
    for j in tied {
        let (a, b) = (evidence[i].label.clone(), evidence[j].label.clone());
        if !evidence[i].equivalent_to.contains(&b) {
            evidence[i].equivalent_to.push(b);
        }
        if !evidence[j].equivalent_to.contains(&a) {
            evidence[j].equivalent_to.push(a);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::diagnose::verdict::tests::evidence;

    /// The rule's ties are reported both ways, and only ties: the same parameter count and a
    /// fit within the slack of the best; a candidate the slack leaves behind, one with more
    /// parameters, or one not admissible is not tied.
    #[test]
    fn ties_are_the_candidates_only_the_noise_separates() {
        let mut ev = vec![
            evidence("a", 1, Some(99.98)),
            evidence("b", 1, Some(99.95)),
            evidence("c", 1, Some(99.90)),
            evidence("d", 2, Some(99.98)),
            evidence("e", 1, None),
        ];
        let slack = 0.05;
        mark_ties(&mut ev, 0, slack);
        assert_eq!(ev[0].equivalent_to, vec!["b".to_string()]);
        assert_eq!(ev[1].equivalent_to, vec!["a".to_string()]);
        for e in &ev[2..] {
            assert!(
                e.equivalent_to.is_empty(),
                "{}: {:?}",
                e.label,
                e.equivalent_to
            );
        }
        // Marked once, however often asked.
        mark_ties(&mut ev, 0, slack);
        assert_eq!(ev[0].equivalent_to.len(), 1);
    }
}
