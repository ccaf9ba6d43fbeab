//! Tests of the working-set bounds against the whole LPs, over rounds, pruning and retirement.
use super::*;
use crate::stage3::classical;
use crate::stage3::shared::{solve, SharedOptions};
use crate::stage3::testutil::{cases, problem, random_case, random_extra_case, truth};
use crate::stage3::EivProblem;
use proptest::prelude::*;

/// The first round's start of the shared method on `prob`: the classical box, the model
/// over its equations, and the `δ` boxes propagated through them.
fn first_round<'p, 'a>(
    prob: &'p EivProblem<'a>,
) -> (Vec<Interval>, SharedModel<'p, 'a>, Vec<Interval>) {
    let start = classical::solve(prob).unwrap();
    let model = SharedModel::new(prob, start.equations);
    let mut db = model.initial_deltas();
    assert!(model.propagate(&start.bounds, &mut db).is_none());
    (start.bounds, model, db)
}

/// One round's bounds by the whole LP and by the working set (and the largest set's size,
/// `None` when the round was unfinished: the whole LP answered, or the generations ran out).
fn one_round(prob: &EivProblem) -> (FreeBounds, FreeBounds, Option<usize>, usize) {
    let (tb, model, db) = first_round(prob);
    let whole = bound_free(&model, &tb, &db, &model.times).unwrap().unwrap();
    let mut ws = WorkingSet::new(&model.times, window_len(prob, &tb));
    // A later round's budget: this test is about what the set converges to.
    ws.first_round_generations = MAX_GENERATIONS;
    let (part, _) = bound_free_ws(&model, &tb, &db, &mut ws).unwrap().unwrap();
    let largest = ws.sets.iter().map(Vec::len).max().unwrap_or(0);
    let used = (ws.unfinished == 0).then_some(largest);
    (whole, part, used, model.times.len())
}

/// On records long enough for the working set to stay well under the record, its bounds
/// are the whole LP's (within the result pad), and the truth is inside both.
#[test]
fn working_set_bounds_equal_the_whole_lps() {
    for seed in 0..3 {
        let (m, out, input) = random_case(seed, 6000);
        let prob = problem(&out, &input, true);
        let (whole, part, used, n) = one_round(&prob);
        let used = used.unwrap_or_else(|| panic!("seed {seed}: the round was unfinished"));
        assert!(
            2 * used <= n,
            "seed {seed}: the working set took {used} of {n}"
        );
        assert_whole_lps(
            &format!("seed {seed}, working set"),
            &prob,
            &m,
            &whole,
            &part,
        );
    }
}

/// `part` holds the truth and equals `whole` within the pad every bound carries anyway
/// (its precision) and a millionth of the width.
fn assert_whole_lps(
    what: &str,
    prob: &EivProblem,
    m: &LinearModel,
    whole: &FreeBounds,
    part: &FreeBounds,
) {
    let t = truth(m);
    let free: Vec<usize> = (0..prob.p()).filter(|&k| prob.fixed[k].is_none()).collect();
    for (c, &k) in free.iter().enumerate() {
        let ((wl, wh), (pl, ph)) = (whole[c], part[c]);
        let (wl, wh, pl, ph) = (wl.unwrap(), wh.unwrap(), pl.unwrap(), ph.unwrap());
        assert!(
            pl <= t[k] && t[k] <= ph,
            "{what} θ{k}: [{pl}, {ph}] misses {}",
            t[k]
        );
        let tol = |v: f64| crate::lp::RESULT_PAD * (1.0 + v.abs()) + 1e-6 * (wh - wl);
        assert!(
            (pl - wl).abs() <= tol(wl) && (ph - wh).abs() <= tol(wh),
            "{what} θ{k}: [{pl}, {ph}], whole LP [{wl}, {wh}]"
        );
    }
}

/// The equations an end leans on carry its bound: the LP over the whole record, pruned to
/// the ends' supports (and the first window), gives every end within a millionth of the
/// width of the whole LP's, from a small part of the record; the truth stays inside.
#[test]
fn the_support_carries_the_bounds() {
    for seed in 0..2 {
        let (m, out, input) = random_case(seed, 3000);
        let prob = problem(&out, &input, true);
        let (tb, model, db) = first_round(&prob);
        let ends: Vec<usize> = (0..2 * model.free.len()).collect();
        let Ends::Found(whole) = solve_ends(&model, &tb, &db, &model.times, &ends).unwrap() else {
            panic!("seed {seed}: the whole LP has no block form or is empty");
        };
        let mut ws = WorkingSet::new(&model.times, window_len(&prob, &tb));
        ws.sets = vec![model.times.clone(); ends.len()];
        for (&i, e) in ends.iter().zip(&whole) {
            ws.lean(i, e);
        }
        ws.prune(&model.times, prob.na);
        let n = model.times.len();
        let mut part = Vec::with_capacity(ends.len());
        for &i in &ends {
            let set = &ws.sets[i];
            assert!(
                10 * set.len() < n,
                "seed {seed}, end {i}: its support kept {} of {n}",
                set.len()
            );
            assert!(set.starts_with(&model.times[..ws.len]));
            let SetLp::Found(mut e) = solve_set(&model, &tb, &db, set, &[i], ws.len).unwrap()
            else {
                panic!("seed {seed}: the pruned LP has no block form or is empty");
            };
            part.push(e.remove(0).0);
        }
        let values = |e: &[End]| pair_ends(&e.iter().map(|e| e.value).collect::<Vec<_>>());
        let what = format!("seed {seed}, pruned");
        assert_whole_lps(&what, &prob, &m, &values(&whole), &values(&part));
    }
}

/// Whole shared runs (every round, the sets pruned between rounds) end where the whole LP's
/// rounds end: no end looser than the run without the working set by more than 1e-4 of
/// the width (and two result pads), none tighter by more than that and 16 pads. (A
/// certificate carries every row's pad times its multiplier, so the smaller LPs' bounds can
/// be a few pads tighter than the whole LP's: 8 pads measured here, on an interval only
/// 5e-5 wide.)
#[test]
fn pruned_runs_end_where_the_whole_lps_rounds_end() {
    let (m, out, input) = random_case(1, 6000);
    let prob = problem(&out, &input, true);
    let run = |from: usize| {
        let opts = SharedOptions {
            working_set_from: from,
            ..SharedOptions::default()
        };
        solve(&prob, &opts).unwrap()
    };
    let (ws, whole) = (run(0), run(usize::MAX));
    for (k, t) in truth(&m).into_iter().enumerate() {
        let (a, b) = (ws.bounds[k], whole.bounds[k]);
        assert!(a.contains(t), "θ{k}: {a:?} misses {t}");
        let pad = crate::lp::RESULT_PAD * (1.0 + t.abs());
        let (looser, tighter) = (1e-4 * (b.hi - b.lo) + 2.0 * pad, 16.0 * pad);
        assert!(
            b.lo - a.lo <= looser && a.hi - b.hi <= looser,
            "θ{k}: working set {a:?} looser than the whole LP's {b:?}"
        );
        assert!(
            a.lo - b.lo <= looser + tighter && b.hi - a.hi <= looser + tighter,
            "θ{k}: working set {a:?} much tighter than the whole LP's {b:?}"
        );
    }
}

/// Pruning keeps the first window and each supported equation with its margin, nothing else.
#[test]
fn pruning_keeps_the_first_window_and_the_supports_margins() {
    let all: Vec<usize> = (10..110).collect();
    let mut ws = WorkingSet::new(&all, 5);
    ws.sets = vec![all.clone(); 3];
    ws.support = vec![vec![50], vec![], vec![108, 50]];
    ws.prune(&all, 2);
    let first: Vec<usize> = (10..15).collect();
    let one: Vec<usize> = (10..15).chain(48..53).collect();
    let two: Vec<usize> = (10..15).chain(48..53).chain(106..110).collect();
    assert_eq!(ws.sets, vec![one, first, two]);
    // Without any support recorded (the first round), nothing is dropped.
    let mut fresh = WorkingSet::new(&all, 5);
    fresh.spread(3);
    let before = fresh.sets.clone();
    fresh.prune(&all, 2);
    assert_eq!(fresh.sets, before);
}

/// Whenever the whole LP proves a record with an outlier (far from the first working set)
/// inconsistent, the working set proves it too, by itself: the completion misses there, the
/// set grows to it, and its LP is empty.
#[test]
fn an_outlier_outside_the_first_set_empties_the_working_set_lp() {
    let (_, clean, input) = random_case(3, 3000);
    // A box that holds the truth, from the clean record.
    let tb = classical::solve(&problem(&clean, &input, true))
        .unwrap()
        .bounds;
    let mut found = 0;
    for shift in [1.5, 2.0, 3.0, 5.0, 10.0, 30.0] {
        let mut out = clean.clone();
        let c = out[2100].interval;
        let d = shift * c.radius();
        out[2100].interval = Interval::new(c.lo + d, c.hi + d);
        let prob = problem(&out, &input, true);
        let model = SharedModel::new(&prob, prob.equation_times());
        let mut db = model.initial_deltas();
        if model.propagate(&tb, &mut db).is_some() {
            continue;
        }
        if bound_free(&model, &tb, &db, &model.times)
            .unwrap()
            .is_some()
        {
            continue;
        }
        found += 1;
        let len = window_len(&prob, &tb);
        let mut ws = WorkingSet::new(&model.times, len);
        assert!(
            ws.sets[0].binary_search(&2100).is_err(),
            "the outlier is in the first set"
        );
        ws.first_round_generations = MAX_GENERATIONS;
        let r = bound_free_ws(&model, &tb, &db, &mut ws).unwrap();
        assert!(
            ws.unfinished == 0,
            "shift {shift}: the working set did not finish the round"
        );
        assert!(
            r.is_none(),
            "shift {shift}: the working set missed the inconsistency"
        );
    }
    assert!(
        found > 0,
        "no shift made an outlier only the whole LP finds"
    );
}

/// The accuracy floor reads the point's own equations: a point moved off one equation by
/// `ε` (its leading `δ_t`, coefficient 1 there) has a floor of twice that (plus the
/// solver's own residual, less the pad), and a point far off is capped.
#[test]
fn the_accuracy_floor_is_twice_the_points_own_residual_capped() {
    let (_, out, input) = random_case(5, 400);
    let prob = problem(&out, &input, true);
    let (tb, model, db) = first_round(&prob);
    let Ends::Found(ends) = solve_ends(&model, &tb, &db, &model.times, &[0]).unwrap() else {
        panic!("the LP of a consistent record is not empty");
    };
    let rows: Vec<(SparseRow, f64)> = model.times.iter().map(|&t| model.equation(t)).collect();
    let scale = rows.iter().fold(0.0f64, |a, r| a.max(r.1.abs()));
    let mut pt = ends[0].point.clone();
    let f0 = accuracy_floor(&rows, &pt);
    assert!(f0 < 1e-7, "the solver's point is off by {}", f0 / 2.0);
    let d = model.delta_of[&(crate::stage3::relax::Side::Out, model.times[200])];
    let eps = 1e-7;
    pt[model.col_delta(d)] += eps;
    let f1 = accuracy_floor(&rows, &pt);
    // Less the equation's own pad (ROW_PAD relative to its constant, which is O(1) here).
    let pad = ROW_PAD * (1.0 + scale);
    assert!(
        f1 >= 2.0 * (eps - pad) - f0 && f1 <= 2.0 * (eps + pad) + f0,
        "moved by {eps}: floor {f1}"
    );
    pt[model.col_delta(d)] += 1.0;
    let f2 = accuracy_floor(&rows, &pt);
    assert!(f2 <= FLOOR_CAP * (1.0 + scale), "floor {f2} not capped");
    pt[model.col_delta(d)] = f64::NAN;
    assert_eq!(accuracy_floor(&rows, &pt), 0.0);
}

/// When the generations run out, the round is not conclusive, every end has a bound, and
/// each is a relaxation's: never inside the whole LP's interval (beyond the pad), truth
/// inside. A later round that runs out counts as unfinished.
#[test]
fn a_round_out_of_generations_answers_with_the_sets_looser_bounds() {
    let (m, out, input) = random_case(1, 6000);
    let prob = problem(&out, &input, true);
    let (tb, model, db) = first_round(&prob);
    let whole = bound_free(&model, &tb, &db, &model.times).unwrap().unwrap();
    let mut ws = WorkingSet::new(&model.times, window_len(&prob, &tb));
    (ws.first_round_generations, ws.max_generations) = (1, 1);
    let (part, conclusive) = bound_free_ws(&model, &tb, &db, &mut ws).unwrap().unwrap();
    assert!(!conclusive, "one generation closed every end");
    // Running out in the first round is the plan, not an unfinished round.
    assert_eq!((ws.unfinished, ws.rounds), (0, 1));
    assert!(!ws.retired(model.times.len()));
    let t = truth(&m);
    let free: Vec<usize> = (0..prob.p()).filter(|&k| prob.fixed[k].is_none()).collect();
    for (c, &k) in free.iter().enumerate() {
        let (Some(pl), Some(ph)) = part[c] else {
            panic!("θ{k}: an end without a bound");
        };
        let (wl, wh) = (whole[c].0.unwrap(), whole[c].1.unwrap());
        assert!(
            pl <= t[k] && t[k] <= ph,
            "θ{k}: [{pl}, {ph}] misses {}",
            t[k]
        );
        let tol = |v: f64| crate::lp::RESULT_PAD * (1.0 + v.abs());
        assert!(
            pl <= wl + tol(wl) && ph >= wh - tol(wh),
            "θ{k}: the set's [{pl}, {ph}] inside the whole LP's [{wl}, {wh}]"
        );
    }
    // A later round that runs out is unfinished; one that concludes is not.
    let (_, conclusive) = bound_free_ws(&model, &tb, &db, &mut ws).unwrap().unwrap();
    assert_eq!(ws.unfinished, usize::from(!conclusive));
}
/// The working set stays for later rounds after one unfinished round, and retires after a
/// second, when it has no block form, or when it holds half the record.
#[test]
fn the_working_set_retires_after_two_unfinished_rounds_or_when_large() {
    let all: Vec<usize> = (0..3000).collect();
    let mut ws = WorkingSet::new(&all, 20);
    assert!(!ws.retired(all.len()));
    ws.unfinished = 1;
    assert!(!ws.retired(all.len()));
    ws.unfinished = 2;
    assert!(ws.retired(all.len()));
    ws.unfinished = 0;
    ws.sparse = true;
    assert!(ws.retired(all.len()));
    ws.sparse = false;
    ws.spread(2);
    ws.add(1, 0..1400);
    assert!(!ws.retired(all.len()));
    // One end's set past half the record is enough.
    ws.add(1, 0..1501);
    assert!(ws.retired(all.len()));
}

#[test]
fn settling_windows_follow_the_poles() {
    use crate::stage3::testutil::problem;
    let (_, out, input) = random_case(0, 10);
    let mut prob = problem(&out, &input, false);
    prob.na = 1;
    prob.fixed = vec![None, Some(0.0), None, None];
    let at = |a: f64| {
        let tb = vec![Interval::new(a, a); 4];
        window_len(&prob, &tb)
    };
    // |pole| 0.5: 0.5^20 < 1e-6 <= 0.5^19.
    assert_eq!(at(-0.5), 20);
    assert_eq!(at(0.5), 20);
    // Fast poles keep the floor, slow ones the cap, unstable ones 50.
    assert_eq!(at(0.0), 4);
    assert_eq!(at(-0.999), 400);
    assert_eq!(at(-1.5), 50);
}

proptest! {
    #![proptest_config(cases(6))]
    /// Whole shared runs with the working set on from the first equation (extra columns
    /// included; the whole LP where the cost guard hands over): the truth is inside.
    #[test]
    fn working_set_runs_contain_the_truth(
        seed in any::<u64>(),
        uncertain in any::<bool>(),
    ) {
        let case = random_extra_case(seed, 1500, if uncertain { 0.05 } else { 0.0 });
        let opts = SharedOptions { working_set_from: 0, ..SharedOptions::default() };
        let r = match solve(&case.problem(true), &opts) {
            Err(crate::error::SmidError::Unbounded { .. }) => { prop_assume!(false); unreachable!() }
            other => other.unwrap(),
        };
        for (k, t) in case.truth().into_iter().enumerate() {
            prop_assert!(r.bounds[k].contains(t), "θ{}: {:?} misses {}", k, r.bounds[k], t);
        }
    }
}
