//! Stage 3 (paper Section 5) by the shared-error relaxation (the default method): guaranteed
//! bounds on `θ = [a_1..a_na, b_0..b_nb, c_1..c_m]` that keep the inner-signal errors `δx_t`
//! (eqs 28-30) as variables shared by the equations they enter, instead of bounding each
//! equation's error on its own as the classical orthant method ([`super::classical`]) does.
//!
//! The LP model (`relax.rs`): the free θ, one `δ_s` per uncertain signal sample (output side,
//! Hammerstein input side, and each uncertain sample of an extra regressor column), one
//! `w = θ_k δ_s` per product; each equation (eq 1 with eq 29 substituted) is linear in
//! `(θ, δ, w)`, the bilinear `w` relaxed by McCormick envelopes over the current boxes, so the
//! LP's coordinate bounds are guaranteed; exact extra columns are plain coefficients. Starting
//! from the classical box (so the result is never wider than the classical one, and inside the
//! prior box, which the classical LPs carry), each round bounds every free parameter by LP,
//! shrinks the θ box, tightens the `δ` boxes by interval propagation through the equations, and
//! repeats until the radii stop improving, in a round whose bounds are the whole LP's (a long
//! record's round may end on a working set's bounds, `working_set.rs`). As the θ box
//! shrinks the envelopes become exact, so the result approaches the exact feasible set (see
//! [`super::exact_grid`]).
use super::relax::{bound_free, feasible_free, shrink_rounds, Round, RoundLimits, SharedModel};
use super::working_set::{bound_free_ws, window_len, WorkingSet};
use super::{EivMethod, EivProblem, EivResult, Stage3Method};
use crate::error::{Result, SmidError, Stage};
use crate::interval::Interval;

/// The method's name (`method.eiv: shared`).
pub const NAME: &str = "shared";

/// Options of the shared-error relaxation (`method.options` in a spec).
#[derive(Debug, Clone, Copy, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SharedOptions {
    /// Maximum number of LP rounds.
    pub max_rounds: usize,
    /// Stop when no radius shrinks by more than this fraction in a round.
    pub min_improvement: f64,
    /// Records with at least this many equations are bounded from a working set of equations
    /// (guaranteed whatever the set; the whole LP's bounds up to the
    /// solver's accuracy where its completion verifies them, at a fraction of the cost);
    /// shorter ones solve the whole LP each time.
    pub working_set_from: usize,
}

impl SharedOptions {
    /// The defaults: 12 rounds, stop below 3% improvement, a working set from 5000 equations.
    pub const DEFAULT: SharedOptions = SharedOptions {
        max_rounds: 12,
        min_improvement: 0.03,
        working_set_from: 5000,
    };
}

impl Default for SharedOptions {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// The shared-error relaxation (`method.eiv: shared`), starting from `classical`.
#[derive(Debug, Clone, Copy, Default)]
pub struct Shared {
    /// Relaxation options (`method.options` of the spec).
    pub opts: SharedOptions,
}

crate::register_stage3!(
    10,
    Shared {
        opts: SharedOptions::DEFAULT
    }
);

impl Stage3Method for Shared {
    fn name(&self) -> &'static str {
        NAME
    }
    fn description(&self) -> &'static str {
        "Shared-error relaxation: the inner-signal errors are variables shared by consecutive equations, products relaxed by McCormick envelopes, box shrunk until the radii settle. Never wider than `classical`; close to the exact set. Options: max_rounds, min_improvement, working_set_from."
    }
    fn with_options(
        &self,
        options: &serde_json::Map<String, serde_json::Value>,
    ) -> Result<Option<Box<dyn Stage3Method>>> {
        super::with_parsed_options(NAME, options, |opts: SharedOptions| {
            Box::new(Shared { opts })
        })
    }
    fn start(&self) -> Option<EivMethod> {
        Some(EivMethod::Classical)
    }
    /// Its own start's method: the classical outer box.
    fn fallback(&self) -> EivMethod {
        EivMethod::Classical
    }
    fn solve_from(&self, prob: &EivProblem, start: EivResult) -> Result<EivResult> {
        solve_from(prob, start, &self.opts)
    }
}

/// The shared-error relaxation, starting from the classical result `start` (a guaranteed box).
pub fn solve_from(prob: &EivProblem, start: EivResult, opts: &SharedOptions) -> Result<EivResult> {
    prob.validate()?;
    let model = SharedModel::new(prob, start.equations.clone());
    let mut tb = start.bounds.clone();
    let mut ws = (model.times.len() >= opts.working_set_from)
        .then(|| WorkingSet::new(&model.times, window_len(prob, &start.bounds)));
    let unsettled = shrink_rounds(
        &model,
        &mut tb,
        RoundLimits {
            max_rounds: opts.max_rounds,
            min_improvement: opts.min_improvement,
            method: NAME,
        },
        |tb, db| {
            let found = match ws.as_mut() {
                Some(w) => {
                    let found = bound_free_ws(&model, tb, db, w)?;
                    if w.retired(model.times.len()) {
                        ws = None;
                    }
                    found
                }
                None => bound_free(&model, tb, db, &model.times)?.map(|b| (b, true)),
            };
            Ok(match found {
                Some((b, conclusive)) => Round::Bounds(b, conclusive),
                None => Round::Empty,
            })
        },
        |tb, db| emptied(prob, &model, tb, db),
        inconsistent,
    )?;
    Ok(EivResult {
        bounds: tb,
        equations: start.equations,
        feasible_orthants: start.feasible_orthants,
        unsettled,
    })
}

/// The shared-error relaxation of `prob` (classical start through the registry, then LP rounds).
pub fn solve(prob: &EivProblem, opts: &SharedOptions) -> Result<EivResult> {
    Shared { opts: *opts }.solve(prob)
}

fn inconsistent(t: usize) -> SmidError {
    SmidError::inconsistent(Stage::Linear, t, message(t))
}

fn message(t: usize) -> String {
    format!("no θ and inner-signal errors satisfy the equations up to t = {t} within their bounds")
}

/// The finding for a relaxation the equations empty ([`EivProblem::emptied`]: located by
/// bisection on prefixes when asked for).
fn emptied(
    prob: &EivProblem,
    model: &SharedModel,
    tb: &[Interval],
    db: &[Interval],
) -> Result<SmidError> {
    prob.emptied(
        &model.times,
        |prefix| feasible_free(model, tb, db, prefix),
        message,
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::stage3::classical;
    use crate::stage3::relax::SharedModel;
    use crate::stage3::testutil::{cases, problem, random_case, random_extra_case, truth};
    use proptest::prelude::*;

    #[test]
    fn shared_is_never_wider_than_classical_and_contains_the_truth() {
        for seed in 0..6 {
            let (m, out, input) = random_case(seed, 60);
            for band in [false, true] {
                let prob = problem(&out, &input, band);
                let classical = classical::solve(&prob).unwrap();
                let shared = solve(&prob, &SharedOptions::default()).unwrap();
                for (k, t) in truth(&m).into_iter().enumerate() {
                    let (c, s) = (classical.bounds[k], shared.bounds[k]);
                    assert!(s.contains(t), "seed {seed}: shared {s:?} misses {t}");
                    assert!(
                        c.lo <= s.lo && s.hi <= c.hi,
                        "seed {seed}: {s:?} not inside {c:?}"
                    );
                }
                // The sharing pays: the a's shrink markedly.
                assert!(shared.bounds[0].radius() < 0.7 * classical.bounds[0].radius());
            }
        }
    }

    /// A round's LP may be proven empty before the interior-point iteration cap: by its warm
    /// start, or by an objective's run whose multipliers diverge along a ray
    /// (`ipm::Prepared::warm_start`, `run_mut`). Over θ boxes holding the truth (with its δ a
    /// point of every such LP) no round may say "empty"; over small boxes moved off the truth,
    /// and over boxes bisected between the two towards the edge of emptiness, each "empty" must
    /// be one the sparse simplex does not find feasible; and the LPs the simplex proves empty
    /// must be proven so early, by the warm start and by every objective started cold (runs
    /// that only ended at the cap, before).
    #[test]
    fn a_round_proves_its_lp_empty_only_when_it_is_and_early() {
        use super::super::ipm::{Bound, Prepared, Warm, MAX_ITER};
        use super::super::relax::{solve_ends, Ends};
        use rand::{Rng, SeedableRng};
        let (mut empty, mut edge_feasible) = (0, 0);
        for seed in 0..10u64 {
            let (m, out, input) = random_case(seed, 60);
            let prob = problem(&out, &input, seed % 2 == 0);
            let start = classical::solve(&prob).unwrap();
            let model = SharedModel::new(&prob, start.equations.clone());
            let db = model.initial_deltas();
            let truth = truth(&m);
            let ends: Vec<usize> = (0..2 * model.free.len()).collect();
            // The round's verdict and the simplex's on the box `tb`.
            let verdicts = |tb: &[Interval]| {
                let found = solve_ends(&model, tb, &db, &model.times, &ends).unwrap();
                let simplex = model
                    .build(tb, &db, &model.times)
                    .unwrap()
                    .solver()
                    .unwrap()
                    .feasible()
                    .unwrap();
                (matches!(found, Ends::Empty), simplex)
            };
            // The zero objective run to the end (its certificate then within 1e-11 of 0 on a
            // non-empty LP) and the warm start's reading of it.
            let prepared = |tb: &[Interval]| model.block_lp(tb, &db, &model.times).unwrap().0;
            let empty_at_the_end = |tb: &[Interval]| {
                let blp = prepared(tb);
                matches!(
                    Prepared::new(&blp).unwrap().warm_start_to(0.0),
                    Warm::Empty(_)
                )
            };
            let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
            for trial in 0..8 {
                let holds_truth = trial < 2;
                let r: Vec<f64> = (0..truth.len())
                    .map(|k| 0.05 * start.bounds[k].radius().max(1e-9))
                    .collect();
                let f = if holds_truth { 0.5 } else { 40.0 };
                let shift: Vec<f64> = r.iter().map(|r| rng.gen_range(-f..f) * r).collect();
                // The box moved by `s` times the shift from the truth.
                let tb_at = |s: f64| -> Vec<Interval> {
                    (0..truth.len())
                        .map(|k| {
                            let c = truth[k] + s * shift[k];
                            Interval::new(c - r[k], c + r[k])
                        })
                        .collect()
                };
                let tb = tb_at(1.0);
                let (said_empty, simplex) = verdicts(&tb);
                if holds_truth {
                    assert!(
                        !said_empty,
                        "seed {seed}: a box holding the truth was called empty"
                    );
                    assert!(!empty_at_the_end(&tb), "seed {seed}: truth's box");
                }
                if said_empty {
                    assert_ne!(simplex, Some(true), "seed {seed} trial {trial}: not empty");
                }
                if simplex != Some(false) {
                    continue;
                }
                empty += 1;
                assert!(
                    said_empty,
                    "seed {seed} trial {trial}: emptiness not proven"
                );
                let blp = prepared(&tb);
                let prep = Prepared::new(&blp).unwrap();
                let warm_early = matches!(prep.warm_start(), Warm::Empty(k) if k < MAX_ITER);
                let cold_early = ends.iter().all(|&i| {
                    let c = [(i / 2, if i % 2 == 1 { -1.0 } else { 1.0 })];
                    let s = prep.minimise_at(&c, None);
                    s.bound == Bound::Infeasible && s.iterations < MAX_ITER
                });
                assert!(
                    warm_early && cold_early,
                    "seed {seed} trial {trial}: proven early by the warm start {warm_early}, by every cold objective {cold_early}"
                );
                // Towards the edge: bisect the shift between the truth (not empty) and here.
                let (mut lo, mut hi) = (0.0, 1.0);
                for _ in 0..10 {
                    let mid = 0.5 * (lo + hi);
                    let tb = tb_at(mid);
                    let (said_empty, simplex) = verdicts(&tb);
                    if said_empty {
                        assert_ne!(simplex, Some(true), "seed {seed} trial {trial} at {mid}");
                    }
                    if simplex == Some(true) {
                        assert!(!empty_at_the_end(&tb), "seed {seed} trial {trial} at {mid}");
                        edge_feasible += 1;
                        lo = mid;
                    } else {
                        hi = mid;
                    }
                }
            }
        }
        assert!(empty >= 20, "only {empty} empty boxes drawn");
        assert!(
            edge_feasible >= 100,
            "only {edge_feasible} feasible boxes near the edge"
        );
    }

    #[test]
    fn an_outlier_is_reported_as_inconsistent_not_a_panic() {
        let (_, mut out, input) = random_case(3, 60);
        let c = out[30].interval;
        out[30].interval = Interval::new(c.lo + 0.5, c.hi + 0.5);
        match solve(&problem(&out, &input, true), &SharedOptions::default()) {
            Err(SmidError::Inconsistent(crate::outcome::Falsification {
                stage: Stage::Linear,
                ..
            })) => {}
            other => panic!("expected inconsistency, got {other:?}"),
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig { cases: 8, .. ProptestConfig::default() })]
        #[test]
        fn shared_bounds_contain_the_truth(seed in any::<u64>(), band in any::<bool>()) {
            let (m, out, input) = random_case(seed, 50);
            // Data that leave a parameter unbounded are an honest outcome, not a miss.
            let r = match solve(&problem(&out, &input, band), &SharedOptions::default()) {
                Err(SmidError::Unbounded { .. }) => { prop_assume!(false); unreachable!() }
                other => other.unwrap(),
            };
            for (k, t) in truth(&m).into_iter().enumerate() {
                prop_assert!(r.bounds[k].contains(t), "{:?} misses {}", r.bounds[k], t);
            }
        }
    }

    proptest! {
        #![proptest_config(cases(8))]
        /// Extra columns (an exact offset; a friction column, exact or known to ±0.05, whose
        /// samples get their own δ): the truth, extra coefficients included, is inside.
        #[test]
        fn shared_with_extra_columns_contains_the_truth(
            seed in any::<u64>(),
            band in any::<bool>(),
            uncertain in any::<bool>(),
        ) {
            let case = random_extra_case(seed, 60, if uncertain { 0.05 } else { 0.0 });
            let r = match solve(&case.problem(band), &SharedOptions::default()) {
                Err(SmidError::Unbounded { .. }) => { prop_assume!(false); unreachable!() }
                other => other.unwrap(),
            };
            for (k, t) in case.truth().into_iter().enumerate() {
                prop_assert!(r.bounds[k].contains(t), "θ{}: {:?} misses {}", k, r.bounds[k], t);
            }
        }
    }

    /// With extra columns, classical ⊇ shared still holds, and the uncertain friction samples are
    /// δ variables of the model.
    #[test]
    fn shared_is_never_wider_than_classical_with_extra_columns() {
        for seed in 0..4 {
            for radius in [0.0, 0.05] {
                let case = random_extra_case(seed, 60, radius);
                let prob = case.problem(true);
                let model = SharedModel::new(&prob, prob.equation_times());
                let friction_deltas = model
                    .delta_of
                    .keys()
                    .filter(|(side, _)| *side == crate::stage3::relax::Side::Extra(1))
                    .count();
                assert_eq!(friction_deltas > 0, radius > 0.0, "seed {seed}");
                assert!(!model
                    .delta_of
                    .keys()
                    .any(|(side, _)| *side == crate::stage3::relax::Side::Extra(0)));
                let classical = classical::solve(&prob).unwrap();
                let shared = solve(&prob, &SharedOptions::default()).unwrap();
                for (k, t) in case.truth().into_iter().enumerate() {
                    let (c, s) = (classical.bounds[k], shared.bounds[k]);
                    assert!(s.contains(t), "seed {seed} θ{k}: shared {s:?} misses {t}");
                    assert!(
                        c.lo <= s.lo && s.hi <= c.hi,
                        "seed {seed} θ{k}: {s:?} not inside {c:?}"
                    );
                }
            }
        }
    }
}
