//! Tests of the branch and bound: coverage, budgets, the verdict and screened searches.
use super::*;

/// The squared distance from the box `c` to the point `(cx, cy)` (0 inside).
fn disc_distance2(c: &[Interval], cx: f64, cy: f64) -> f64 {
    let d = |i: Interval, m: f64| {
        if i.lo <= m && i.hi >= m {
            0.0
        } else {
            (i.lo - m).abs().min((i.hi - m).abs()).powi(2)
        }
    };
    d(c[0], cx) + d(c[1], cy)
}

fn incons(sample: usize) -> Falsification {
    Falsification::new(Stage::Linear, sample, "test")
}

/// A 2-D set `x^2 + y^2 <= 0.25` "identified" by interval arithmetic: the surviving cells
/// cover it, and every discarded cell is disjoint from it.
/// The verdict-only search agrees with the full one on random discs (inside, across and
/// outside the prior box, a cheap test looser than the finish, finishes that leave cells
/// undecided): `Falsified` exactly when the full search says so, and otherwise its one
/// leaf has a value and meets the disc.
#[test]
fn the_verdict_search_agrees_with_the_full_search() {
    use rand::{Rng, SeedableRng};
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
    for trial in 0..200 {
        let (cx, cy): (f64, f64) = (rng.gen_range(-3.0..3.0), rng.gen_range(-3.0..3.0));
        let r: f64 = rng.gen_range(0.01..0.8);
        let undecided_band: f64 = rng.gen_range(0.0..0.3);
        let dist2 = move |c: &[Interval]| disc_distance2(c, cx, cy);
        let test = move |c: &[Interval]| -> Result<Verdict<()>> {
            Ok(if dist2(c) > (r + 0.2).powi(2) {
                Verdict::Infeasible(incons(1))
            } else {
                Verdict::Feasible(())
            })
        };
        let finish = move |c: &[Interval]| -> Result<Verdict<f64>> {
            let d = dist2(c);
            Ok(if d > r * r {
                Verdict::Infeasible(incons(2))
            } else if c[0].center() < cx - r + undecided_band {
                Verdict::Undecided(UndecidedCause::Unbounded, "left part".into())
            } else {
                Verdict::Feasible(d)
            })
        };
        let budget = || Budget {
            resolution: vec![0.25, 0.25],
            depth: 12,
            max_cells: 400,
            max_leaves: 16,
        };
        let prior = [Interval::new(-2.0, 2.0), Interval::new(-2.0, 2.0)];
        let full = search(&prior, budget(), &test, &finish, &|_| {}).unwrap();
        let quick = search_consistent(&prior, budget(), &test, &finish).unwrap();
        assert_eq!(
            full.is_consistent(),
            quick.is_consistent(),
            "trial {trial}: disc ({cx}, {cy}) r {r}"
        );
        if let Outcome::Consistent(q) = quick {
            if let Some(l) = q.leaves.iter().find(|l| l.value.is_some()) {
                assert!(dist2(&l.cell) <= r * r, "trial {trial}");
            } else {
                // No cell with a value: the full search has none either.
                let f = full.unwrap();
                assert!(f.leaves.iter().all(|l| l.value.is_none()), "trial {trial}");
            }
        }
    }
}

/// The screened search agrees with the full one on random discs: a screen looser than
/// the finish (it discards less and gives other values), undecided exactly where the
/// finish is. Without an undecided leaf it gives the full search's outcome, leaf by leaf;
/// with one, the full search has one too, the outcome says it was screened, and its
/// leaves cover every leaf the full search keeps.
#[test]
fn the_screened_search_agrees_with_the_full_search() {
    use rand::{Rng, SeedableRng};
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
    let (mut screened_seen, mut finished_seen, mut falsified_seen) = (0, 0, 0);
    for trial in 0..200 {
        let (cx, cy): (f64, f64) = (rng.gen_range(-3.0..3.0), rng.gen_range(-3.0..3.0));
        let r: f64 = rng.gen_range(0.01..0.8);
        let band: f64 = if rng.gen_bool(0.5) {
            0.0
        } else {
            rng.gen_range(0.0..0.3)
        };
        let dist2 = move |c: &[Interval]| disc_distance2(c, cx, cy);
        let test = move |c: &[Interval]| -> Result<Verdict<()>> {
            Ok(if dist2(c) > (r + 0.3).powi(2) {
                Verdict::Infeasible(incons(1))
            } else {
                Verdict::Feasible(())
            })
        };
        let undecided = move |c: &[Interval]| band > 0.0 && c[0].center() < cx - r + band;
        let judged = move |c: &[Interval], reach: f64, scale: f64| -> Result<Verdict<f64>> {
            Ok(if undecided(c) {
                Verdict::Undecided(UndecidedCause::Unbounded, "left part".into())
            } else if dist2(c) > reach * reach {
                // Each cell contradicted at its own sample, so the latest one is the union's
                // only when every discarded cell is counted.
                Verdict::Infeasible(incons(((c[0].lo + 3.0) * 1000.0) as usize))
            } else {
                Verdict::Feasible(scale * dist2(c))
            })
        };
        let finish = move |c: &[Interval]| judged(c, r, 1.0);
        let screen = move |c: &[Interval]| judged(c, r + 0.15, 0.5);
        let budget = || Budget {
            resolution: vec![0.25, 0.25],
            depth: 12,
            max_cells: 400,
            max_leaves: 16,
        };
        let prior = [Interval::new(-2.0, 2.0), Interval::new(-2.0, 2.0)];
        let full = search(&prior, budget(), &test, &finish, &|_| {}).unwrap();
        let quick = search_screened(&prior, budget(), &test, &screen, &finish, &|_| {}).unwrap();
        let (full, quick) = match (full, quick) {
            (Outcome::Consistent(f), Outcome::Consistent(q)) => (f, q),
            (Outcome::Falsified(f), Outcome::Falsified(q)) => {
                falsified_seen += 1;
                assert_eq!(
                    f.sample, q.sample,
                    "trial {trial}: the latest contradiction"
                );
                continue;
            }
            (f, q) => panic!(
                "trial {trial}: full consistent {}, screened consistent {}",
                f.is_consistent(),
                q.is_consistent()
            ),
        };
        let undecided_leaf = |s: &Search<f64>| s.leaves.iter().any(|l| l.value.is_none());
        if quick.screened {
            screened_seen += 1;
            assert!(
                undecided_leaf(&quick) && undecided_leaf(&full),
                "trial {trial}"
            );
            for l in &full.leaves {
                let c = [l.cell[0].center(), l.cell[1].center()];
                assert!(
                    quick
                        .leaves
                        .iter()
                        .any(|q| q.cell[0].contains(c[0]) && q.cell[1].contains(c[1])),
                    "trial {trial}: a kept cell of the full search is not covered"
                );
            }
        } else {
            finished_seen += 1;
            assert!(!undecided_leaf(&full), "trial {trial}");
            let key = |s: &Search<f64>| {
                let mut v: Vec<(Vec<Interval>, Option<f64>)> =
                    s.leaves.iter().map(|l| (l.cell.clone(), l.value)).collect();
                v.sort_by(|a, b| {
                    let k = |x: &(Vec<Interval>, Option<f64>)| (x.0[0].lo, x.0[1].lo);
                    k(a).partial_cmp(&k(b)).unwrap()
                });
                v
            };
            assert_eq!(key(&full), key(&quick), "trial {trial}");
            assert_eq!(full.discarded, quick.discarded, "trial {trial}");
        }
    }
    assert!(
        screened_seen > 10 && finished_seen > 10 && falsified_seen > 10,
        "{screened_seen} {finished_seen} {falsified_seen}"
    );
}

#[test]
fn surviving_cells_cover_the_feasible_set() {
    let eval = |c: &[Interval]| -> Result<Verdict<f64>> {
        let sq = |i: Interval| {
            if i.lo <= 0.0 && i.hi >= 0.0 {
                0.0
            } else {
                i.lo.abs().min(i.hi.abs()).powi(2)
            }
        };
        if sq(c[0]) + sq(c[1]) > 0.25 {
            Ok(Verdict::Infeasible(incons(1)))
        } else {
            Ok(Verdict::Feasible(c[0].hi))
        }
    };
    let prior = [Interval::new(-2.0, 2.0), Interval::new(-1.0, 3.0)];
    let s = search(
        &prior,
        Budget {
            resolution: vec![4.0 / 64.0, 4.0 / 64.0],
            depth: 30,
            max_cells: 100_000,
            max_leaves: 100_000,
        },
        &|c| {
            eval(c).map(|v| match v {
                Verdict::Infeasible(e) => Verdict::Infeasible(e),
                _ => Verdict::Feasible(()),
            })
        },
        &eval,
        &|_| {},
    )
    .unwrap()
    .unwrap();
    assert!(!s.budget_stopped);
    let h = s.hull();
    assert!(h[0].lo <= -0.5 && h[0].hi >= 0.5 && h[1].lo <= -0.5 && h[1].hi >= 0.5);
    assert!(h[0].lo > -0.6 && h[0].hi < 0.6, "{h:?}");
    for k in 0..200 {
        let a = k as f64 * 0.0314;
        let p = [0.5 * a.cos(), 0.5 * a.sin()];
        assert!(
            s.leaves
                .iter()
                .any(|l| l.cell[0].contains(p[0]) && l.cell[1].contains(p[1])),
            "{p:?} not covered"
        );
    }
}

/// Cells wider than 1/32 around 0.5 are undecided (as a stage 3 left unbounded over a
/// wide cell): they are halved below the resolution until decided, within the second
/// budget; past it they come back without a value and with their cause.
#[test]
fn undecided_cells_are_refined_within_the_budget() {
    let eval = |c: &[Interval]| -> Result<Verdict<f64>> {
        Ok(if c[0].contains(0.5) && c[0].hi - c[0].lo > 1.0 / 32.0 {
            Verdict::Undecided(UndecidedCause::Unbounded, "too wide".into())
        } else {
            Verdict::Feasible(c[0].lo)
        })
    };
    let test = |c: &[Interval]| eval(c).map(|_| Verdict::Feasible(()));
    let budget = |max_leaves| Budget {
        resolution: vec![0.25],
        depth: 30,
        max_cells: 1000,
        max_leaves,
    };
    let prior = [Interval::new(0.0, 1.0)];
    let s = search(&prior, budget(100), &test, &eval, &|_| {})
        .unwrap()
        .unwrap();
    assert!(s
        .leaves
        .iter()
        .all(|l| l.value.is_some() && l.cause.is_none()));
    assert!(s.refined >= 2, "{}", s.refined);
    assert_eq!(s.hull(), vec![Interval::new(0.0, 1.0)]);
    // Every point stays covered.
    for k in 0..=100 {
        let x = k as f64 / 100.0;
        assert!(s.leaves.iter().any(|l| l.cell[0].contains(x)), "{x}");
    }
    let tight = search(&prior, budget(2), &test, &eval, &|_| {})
        .unwrap()
        .unwrap();
    assert!(tight
        .leaves
        .iter()
        .any(|l| l.value.is_none()
            && l.cause == Some((UndecidedCause::Unbounded, "too wide".into()))));
    assert_eq!(tight.hull(), vec![Interval::new(0.0, 1.0)]);
}

#[test]
fn the_budget_stops_the_bisection_and_the_queued_cells_are_finished() {
    let eval = |_: &[Interval]| -> Result<Verdict<u32>> { Ok(Verdict::Feasible(7)) };
    let s = search(
        &[Interval::new(0.0, 1.0)],
        Budget {
            resolution: vec![1e-9],
            depth: 20,
            max_cells: 10,
            max_leaves: 100,
        },
        &|c| {
            eval(c).map(|v| match v {
                Verdict::Infeasible(e) => Verdict::Infeasible(e),
                _ => Verdict::Feasible(()),
            })
        },
        &eval,
        &|_| {},
    )
    .unwrap()
    .unwrap();
    assert!(s.budget_stopped);
    assert!(s.evaluated <= 10 + s.leaves.len(), "{}", s.evaluated);
    assert_eq!(s.hull(), vec![Interval::new(0.0, 1.0)]);
    assert!(s.leaves.iter().all(|l| l.value == Some(7)));
}

#[test]
fn too_many_leaves_are_merged_back_and_still_cover_the_set() {
    // Feasible: the band |x - y| <= 0.3 in [0, 4]^2: many leaves at resolution 1/16.
    let eval = |c: &[Interval]| -> Result<Verdict<()>> {
        let (lo, hi) = (c[0].lo - c[1].hi, c[0].hi - c[1].lo);
        Ok(if lo > 0.3 || hi < -0.3 {
            Verdict::Infeasible(incons(0))
        } else {
            Verdict::Feasible(())
        })
    };
    let budget = |max_leaves| Budget {
        resolution: vec![1.0 / 16.0, 1.0 / 16.0],
        depth: 30,
        max_cells: 100_000,
        max_leaves,
    };
    let prior = [Interval::new(0.0, 4.0), Interval::new(0.0, 4.0)];
    let fine = search(&prior, budget(100_000), &eval, &eval, &|_| {})
        .unwrap()
        .unwrap();
    let coarse = search(&prior, budget(20), &eval, &eval, &|_| {})
        .unwrap()
        .unwrap();
    assert!(fine.leaves.len() > 20 && !fine.budget_stopped);
    assert!(coarse.leaves.len() <= 20 && coarse.budget_stopped);
    for l in &fine.leaves {
        let c = [l.cell[0].center(), l.cell[1].center()];
        assert!(coarse
            .leaves
            .iter()
            .any(|k| k.cell[0].contains(c[0]) && k.cell[1].contains(c[1])));
    }
}

/// A positive slope whose box spans four orders of magnitude (as a box from steady-state
/// points that barely bound it does): halved at its geometric mean, the cells around the
/// truth reach a width at which the finish decides them within a budget that halving at the
/// centre spends on the top decade (it would need ten levels to get below 1 near 0.25).
#[test]
fn a_slope_spanning_orders_of_magnitude_is_halved_at_its_geometric_mean() {
    let truth = Interval::new(0.24, 0.26);
    let meets = |c: &[Interval]| c[0].lo <= truth.hi && c[0].hi >= truth.lo;
    let prior = [Interval::new(0.1, 1000.0)];
    let r = search(
        &prior,
        Budget {
            resolution: crate::nonlinearity::halved_widths(&prior, 6),
            depth: 30,
            max_cells: 12,
            max_leaves: 100,
        },
        &|c| {
            Ok(if meets(c) {
                Verdict::Feasible(())
            } else {
                Verdict::Infeasible(incons(0))
            })
        },
        &|c| {
            Ok(if !meets(c) {
                Verdict::Infeasible(incons(0))
            } else if c[0].hi - c[0].lo < 1.0 {
                Verdict::Feasible(c[0])
            } else {
                Verdict::Undecided(UndecidedCause::Unbounded, "wide".into())
            })
        },
        &|_| {},
    )
    .unwrap();
    let Outcome::Consistent(s) = r else {
        panic!("{r:?}")
    };
    assert!(!s.budget_stopped);
    assert!(s.leaves.iter().all(|l| l.value.is_some()), "{:?}", s.leaves);
    assert!(s.leaves.iter().any(|l| l.cell[0].contains(0.25)));
    let h = s.hull();
    assert!(h[0].lo >= 0.1 && h[0].hi < 1.01, "{h:?}");
}

#[test]
fn all_discarded_is_an_inconsistency_and_errors_propagate() {
    let eval = |c: &[Interval]| -> Result<Verdict<()>> {
        Ok(Verdict::Infeasible(incons((c[0].lo * 10.0) as usize)))
    };
    let r = search(
        &[Interval::new(0.0, 1.0)],
        Budget {
            resolution: vec![0.1],
            depth: 3,
            max_cells: 100,
            max_leaves: 100,
        },
        &|c| {
            eval(c).map(|v| match v {
                Verdict::Infeasible(e) => Verdict::Infeasible(e),
                _ => Verdict::Feasible(()),
            })
        },
        &eval,
        &|_| {},
    );
    assert!(matches!(r, Ok(Outcome::Falsified(_))), "{r:?}");
    let bad = |_: &[Interval]| -> Result<Verdict<()>> { Err(SmidError::Solver("x".into())) };
    let r = search(
        &[Interval::new(0.0, 1.0)],
        Budget {
            resolution: vec![0.1],
            depth: 3,
            max_cells: 100,
            max_leaves: 100,
        },
        &bad,
        &bad,
        &|_| {},
    );
    assert!(matches!(r, Err(SmidError::Solver(_))));
    let r = search(
        &[Interval::new(0.0, f64::INFINITY)],
        Budget {
            resolution: vec![0.1],
            depth: 3,
            max_cells: 100,
            max_leaves: 100,
        },
        &|c| {
            eval(c).map(|v| match v {
                Verdict::Infeasible(e) => Verdict::Infeasible(e),
                _ => Verdict::Feasible(()),
            })
        },
        &eval,
        &|_| {},
    );
    assert!(matches!(r, Err(SmidError::Invalid { .. })));
}

#[test]
fn a_degenerate_prior_is_evaluated_once() {
    let eval = |_: &[Interval]| -> Result<Verdict<()>> { Ok(Verdict::Feasible(())) };
    let s = search(
        &[Interval::new(1.0, 1.0)],
        Budget {
            resolution: vec![0.0],
            depth: 8,
            max_cells: 100,
            max_leaves: 100,
        },
        &|c| {
            eval(c).map(|v| match v {
                Verdict::Infeasible(e) => Verdict::Infeasible(e),
                _ => Verdict::Feasible(()),
            })
        },
        &eval,
        &|_| {},
    )
    .unwrap()
    .unwrap();
    assert_eq!(s.evaluated, 2);
    let never = |_: &[Interval]| -> Result<Verdict<()>> { panic!("nothing to test") };
    let s = search(
        &[],
        Budget {
            resolution: vec![],
            depth: 8,
            max_cells: 100,
            max_leaves: 100,
        },
        &never,
        &eval,
        &|_| {},
    )
    .unwrap()
    .unwrap();
    assert_eq!((s.evaluated, s.leaves.len()), (1, 1));
}
