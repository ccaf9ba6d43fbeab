//! Tests of the stage-3 problem, its flattening and the registry, over every registered method.
use super::*;
use crate::error::{SmidError, Stage};
use crate::interval::Interval;
use crate::stage3::testutil::{feedback_case, random_extra_case};

/// Past outputs read from data (`lagged`): every registered method that takes the
/// flattened problem bounds the true θ of random clipped loops, in θ's own order; the
/// flattened problem's equations are the problem's (each residual the same at random points
/// of the boxes); a unit gain and an uncertain input are refused with an error.
#[test]
fn lagged_past_outputs_are_bounded_by_every_method_with_the_truth_inside() {
    use rand::{Rng, SeedableRng};
    let mut solved = 0;
    for seed in 0..12u64 {
        let case = feedback_case(seed);
        let (na, nb, theta) = (case.na, case.nb, &case.theta);
        let (out, input, lagged) = (&case.out, &case.input, &case.lagged);
        let p = theta.len();
        assert_eq!(na + nb + 2, p);
        let prob = case.problem();
        // The flattened equations are the problem's: residuals agree at random points.
        let f = prob.flattened().unwrap().unwrap();
        let flat = f.problem(&prob);
        assert_eq!(flat.names().len(), p);
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed + 100);
        let times = prob.equation_times();
        assert_eq!(times, flat.equation_times(), "seed {seed}");
        assert_eq!(
            prob.one_sided_times(),
            flat.one_sided_times(),
            "seed {seed}"
        );
        for &t in &times {
            let th: Vec<f64> = (0..p).map(|_| rng.gen_range(-2.0..2.0)).collect();
            let pick = |i: Interval| i.lo + (i.hi - i.lo) * 0.37;
            let xt = pick(out[t].interval);
            let mut r = xt;
            for i in 1..=na {
                r += th[i - 1] * lagged[t - i].center();
            }
            for j in 0..=nb {
                r -= th[na + j] * input[t - j].center();
            }
            r -= th[p - 1];
            let mut rf = xt;
            for j in 0..=flat.nb {
                // The flattened input's sample (`-w_{t-1-j}`) at its centre.
                rf -= th[j] * flat.input[t - j].center();
            }
            for (k, col) in flat.extra.iter().enumerate() {
                rf -= th[flat.n_ab() + k] * col.values[t].center();
            }
            assert!(
                (r - rf).abs() <= 1e-12 * (1.0 + r.abs()),
                "seed {seed}, t = {t}"
            );
        }
        for (m, method) in all() {
            if !method.available() {
                continue;
            }
            match method.solve(&prob) {
                Ok(r) => {
                    solved += 1;
                    for (k, b) in r.bounds.iter().enumerate() {
                        assert!(
                            b.contains(theta[k]),
                            "seed {seed}, {}: {} = {} outside {b:?}",
                            m.name(),
                            prob.name(k),
                            theta[k]
                        );
                    }
                }
                Err(SmidError::Unsupported { .. } | SmidError::Unbounded { .. }) => {}
                Err(e) => panic!("seed {seed}, {}: {e}", m.name()),
            }
        }
        assert!(matches!(
            EivProblem {
                unit_gain: true,
                ..prob.clone()
            }
            .flattened(),
            Err(SmidError::Invalid { .. })
        ));
        let uncertain: Vec<Interval> = input
            .iter()
            .map(|v| Interval::new(v.lo - 0.1, v.hi + 0.1))
            .collect();
        assert!(matches!(
            EivProblem {
                input: &uncertain,
                ..prob.clone()
            }
            .flattened(),
            Err(SmidError::Unsupported { .. })
        ));
    }
    assert!(solved >= 24, "only {solved} method runs gave bounds");
}

/// A lagged problem is refused by a method's own entry point, and the flattened problem's
/// findings come back in the problem's names: a fixed `a1` outside its prior is named
/// `a1` (the flattened problem calls it `b0`), a bad prior's field `prior.a1`.
#[test]
fn a_lagged_problem_is_refused_unflattened_and_named_in_its_own_terms() {
    let case = feedback_case(3);
    let prob = case.problem();
    let p = prob.p();
    assert!(
        matches!(prob.validate(), Err(SmidError::Invalid { ref field, .. }) if field == "lagged")
    );
    assert!(classical::feasible(&prob).is_err());
    let mut fixed = vec![None; p];
    fixed[0] = Some(5.0);
    let mut prior = vec![Interval::entire(); p];
    prior[0] = Interval::new(-1.0, 1.0);
    let outside = EivProblem {
        fixed,
        prior: Some(&prior),
        ..prob.clone()
    };
    match method(EivMethod::Classical).solve(&outside) {
        Err(SmidError::Inconsistent(f)) => {
            assert!(
                f.detail.contains("`a1`") && !f.detail.contains("`b0`"),
                "{}",
                f.detail
            )
        }
        other => panic!("expected the fixed a1 outside its prior: {other:?}"),
    }
    let mut bad = vec![Interval::entire(); p];
    bad[0] = Interval { lo: 1.0, hi: -1.0 };
    let reversed = EivProblem {
        prior: Some(&bad),
        ..prob.clone()
    };
    match method(EivMethod::Classical).solve(&reversed) {
        Err(SmidError::Invalid { field, .. }) => assert_eq!(field, "prior.a1"),
        other => panic!("expected a reversed prior of a1: {other:?}"),
    }
}

/// The one location of an emptiness, with stand-in prefix tests (the first `k` equations
/// feasible): the bisection finds equation `k`; without `locate`, or when a prefix's LP
/// fails, the last equation is named, marked not located, and the emptiness is kept.
#[test]
fn an_emptiness_is_located_by_bisection_or_named_at_the_last_equation() {
    use crate::stage3::testutil::{problem, random_case};
    let (_, out, input) = random_case(1, 40);
    let located = problem(&out, &input, false);
    let quick = EivProblem {
        locate: false,
        ..located.clone()
    };
    let times: Vec<usize> = (5..45).collect();
    let msg = |t: usize| format!("up to t = {t}");
    for k in [0, 1, 17, 39] {
        let mut calls = 0;
        let prefix = |p: &[usize]| {
            calls += 1;
            Ok(p.len() <= k)
        };
        match located.emptied(&times, prefix, msg).unwrap() {
            SmidError::Inconsistent(f) => {
                assert!(f.located && f.sample == times[k], "k = {k}: {f:?}")
            }
            e => panic!("{e:?}"),
        }
        assert!(calls > 0 && calls <= 7, "k = {k}: {calls} prefix tests");
        let mut calls = 0;
        match quick
            .emptied(
                &times,
                |_| {
                    calls += 1;
                    Ok(true)
                },
                msg,
            )
            .unwrap()
        {
            SmidError::Inconsistent(f) => assert!(!f.located && f.sample == 44, "{f:?}"),
            e => panic!("{e:?}"),
        }
        assert_eq!(calls, 0);
    }
    let trouble = |_: &[usize]| Err(SmidError::Solver("prefix LP".into()));
    match located.emptied(&times, trouble, msg).unwrap() {
        SmidError::Inconsistent(f) => assert!(!f.located && f.sample == 44, "{f:?}"),
        e => panic!("{e:?}"),
    }
    // Any other error is passed on.
    let bad = |_: &[usize]| Err(SmidError::invalid("x", "y"));
    assert!(located.emptied(&times, bad, msg).is_err());
}

/// A verdict without the search for the first offending equation (`locate: false`) agrees
/// with the located one, for every runnable method, on random records with an outlier at a
/// random sample: both find them inconsistent (or both not); located, the classical and
/// shared methods never name an equation before the outlier (one it enters when it is far
/// out); not located, every method marks its finding so, at the last equation. Some
/// outliers are seen by the shared relaxation only (its own search, not its classical
/// start's).
#[test]
fn an_unlocated_verdict_agrees_and_says_it_is_not_located() {
    use crate::stage3::testutil::{problem, random_case};
    use rand::{Rng, SeedableRng};
    let mut shared_only = 0;
    for seed in 0..16u64 {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed ^ 0x10ca7e);
        let n = rng.gen_range(40..120);
        let (_, mut out, input) = random_case(seed, n);
        let t0 = rng.gen_range(10..n - 5);
        let w = out[t0].interval;
        // Some outliers far out (the classical outer set is empty), some just past the
        // bound (only the tighter relaxation sees them).
        let jump = if seed % 2 == 0 {
            0.5 + 40.0 * w.radius()
        } else {
            rng.gen_range(2.5..6.0) * w.radius()
        };
        out[t0].interval = Interval::new(w.lo + jump, w.hi + jump);
        let located = problem(&out, &input, false);
        let last = *located.equation_times().last().unwrap();
        let quick = EivProblem {
            locate: false,
            ..located.clone()
        };
        for (m, imp) in all() {
            if !imp.available() {
                continue;
            }
            let a = imp.solve(&located);
            let b = imp.solve(&quick);
            let name = m.name();
            match (&a, &b) {
                (Err(SmidError::Inconsistent(fa)), Err(SmidError::Inconsistent(fb))) => {
                    if [EivMethod::Classical, EivMethod::Shared].contains(&m) {
                        assert!(fa.located, "seed {seed} {name}: {fa:?}");
                        // Never before the outlier; with one far out, at an equation it
                        // enters (a small one needs later data to be seen).
                        let reach = if seed % 2 == 0 { t0 + 2 } else { last };
                        assert!(
                            (t0..=reach).contains(&fa.sample),
                            "seed {seed} {name}: outlier at {t0}, located {}",
                            fa.sample
                        );
                    }
                    if !fb.located || fb.sample != fa.sample {
                        assert!(
                            !fb.located && fb.sample == last,
                            "seed {seed} {name}: {fb:?}"
                        );
                    }
                }
                (Ok(_), Ok(_)) => {}
                // Solver trouble in the solve itself, alike in both (locating never turns a
                // proven emptiness into trouble).
                (Err(SmidError::Solver(_)), Err(SmidError::Solver(_))) => {}
                _ => panic!("seed {seed} {name}: located {a:?}, not located {b:?}"),
            }
            if m == EivMethod::Shared && a.is_err() && classical::solve(&located).is_ok() {
                shared_only += 1;
            }
            if [EivMethod::Classical, EivMethod::Shared].contains(&m) && a.is_err() {
                match b {
                    Err(SmidError::Inconsistent(f)) => {
                        assert!(!f.located && f.sample == last, "seed {seed} {name}: {f:?}")
                    }
                    other => panic!("seed {seed} {name}: {other:?}"),
                }
            }
        }
    }
    assert!(
        shared_only > 0,
        "no outlier was left to the shared relaxation alone"
    );
}

/// The one parser of user-given method names: every method by its name (blanks and the
/// `_` spelling of `exact-grid` accepted); an unknown name lists every valid one.
/// Each method names its own fallback, another method this build can run (a retry with
/// itself would repeat the trouble).
#[test]
fn every_method_falls_back_to_another_runnable_method() {
    for (m, imp) in all() {
        let f = imp.fallback();
        assert_ne!(f, m, "{} falls back to itself", m.name());
        assert!(
            method(f).available(),
            "{} falls back to {}",
            m.name(),
            f.name()
        );
    }
}

#[test]
fn method_names_parse_and_unknown_ones_list_the_valid_names() {
    for m in EivMethod::registered() {
        assert_eq!(EivMethod::parse(&format!(" {} ", m.name())).unwrap(), m);
    }
    assert_eq!(
        EivMethod::parse("exact_grid").unwrap(),
        EivMethod::ExactGrid
    );
    let e = EivMethod::parse("clasical").unwrap_err().to_string();
    assert!(e.contains("clasical"), "{e}");
    for m in EivMethod::registered() {
        assert!(e.contains(m.name()), "{e}");
    }
}

/// The methods this build runs.
fn methods() -> impl Iterator<Item = (EivMethod, &'static dyn Stage3Method)> {
    all().filter(|(_, m)| m.available())
}

#[test]
fn names_and_counts_include_the_extra_columns() {
    let case = random_extra_case(1, 30, 0.0);
    let prob = case.problem(false);
    assert_eq!((prob.n_ab(), prob.p()), (5, 7));
    assert_eq!(
        prob.names(),
        ["a1", "a2", "b0", "b1", "b2", "offset", "friction"]
    );
    assert_eq!(prob.name(6), "friction");
    let gain: Vec<f64> = (0..7).map(|k| prob.gain_sign(k)).collect();
    assert_eq!(gain, [-1.0, -1.0, 1.0, 1.0, 1.0, 0.0, 0.0]);
}

/// A non-finite extra sample excludes exactly the equation at that sample (the extras
/// enter at `t` only); a shorter column ends the equations.
#[test]
fn an_unknown_extra_sample_leaves_out_its_equation() {
    let mut case = random_extra_case(1, 30, 0.0);
    let all_times = case.problem(false).equation_times();
    case.extra[1].values[20] = Interval::new(f64::NAN, f64::NAN);
    case.extra[0].values[25] = Interval::entire();
    case.extra[0].values.truncate(28);
    let times = case.problem(false).equation_times();
    let expected: Vec<usize> = all_times
        .into_iter()
        .filter(|&t| t != 20 && t != 25 && t < 28)
        .collect();
    assert_eq!(times, expected);
}

#[test]
fn a_malformed_problem_is_an_error_naming_the_field() {
    let case = random_extra_case(1, 30, 0.0);
    let prob = case.problem(false);
    let short = vec![Interval::entire(); 5];
    let bad_prior = {
        let mut v = vec![Interval::entire(); 7];
        v[6] = Interval::new(1.0, -1.0);
        v
    };
    let mut dup = case.extra.clone();
    dup[1].name = "b1".into();
    let cases: [(EivProblem, &str); 4] = [
        (
            EivProblem {
                fixed: vec![None; 5],
                ..prob.clone()
            },
            "model.fixed",
        ),
        (
            EivProblem {
                prior: Some(&short),
                ..prob.clone()
            },
            "prior",
        ),
        (
            EivProblem {
                prior: Some(&bad_prior),
                ..prob.clone()
            },
            "prior.friction",
        ),
        (
            EivProblem {
                extra: &dup,
                ..prob.clone()
            },
            "extra[1].name",
        ),
    ];
    for (p, field) in cases {
        for (m, imp) in methods() {
            match imp.solve(&p) {
                Err(SmidError::Invalid { field: f, .. }) => {
                    assert_eq!(f, field, "{}", m.name())
                }
                other => panic!("{}: expected an error on {field}, got {other:?}", m.name()),
            }
        }
    }
}

/// Every method keeps inside a prior box that cuts its start; a prior the data exclude, or
/// one that excludes a fixed value, is an empty set: `Inconsistent` at an equation's sample.
#[test]
fn every_method_honours_a_prior_box() {
    for seed in 0..2 {
        let case = random_extra_case(seed, 50, 0.0);
        let prob = case.problem(true);
        let truth = case.truth();
        let classical = solve(EivMethod::Classical, &prob).unwrap();
        // Around the truth, narrower than the classical box: it cuts every free entry.
        let prior: Vec<Interval> = truth
            .iter()
            .zip(&classical.bounds)
            .map(|(&t, b)| {
                let r = 0.5 * b.radius() + 1e-6;
                Interval::new(t - r, t + r)
            })
            .collect();
        let with_prior = EivProblem {
            prior: Some(&prior),
            ..prob.clone()
        };
        // Beyond what the data allow for a1: no θ at all.
        let mut excluded = prior.clone();
        let a1 = classical.bounds[0];
        excluded[0] = Interval::new(a1.hi + 0.1, a1.hi + 0.2);
        // b0 is fixed at 0; a prior without 0 empties the set before any equation.
        let mut off_fixed = prior.clone();
        off_fixed[2] = Interval::new(0.5, 1.0);
        for (m, imp) in methods() {
            let r = imp.solve(&with_prior).unwrap();
            for (k, t) in truth.iter().enumerate() {
                let (b, p) = (r.bounds[k], prior[k]);
                assert!(
                    b.contains(*t),
                    "seed {seed} {} θ{k}: {b:?} misses {t}",
                    m.name()
                );
                assert!(
                    p.lo <= b.lo && b.hi <= p.hi,
                    "seed {seed} {} θ{k}: {b:?} outside the prior {p:?}",
                    m.name()
                );
            }
            for (p, what) in [(&excluded, "excluded a1"), (&off_fixed, "b0 off its prior")] {
                let q = EivProblem {
                    prior: Some(p),
                    ..prob.clone()
                };
                match imp.solve(&q) {
                    Err(SmidError::Inconsistent(crate::outcome::Falsification {
                        stage: Stage::Linear,
                        sample,
                        ..
                    })) => assert!(
                        classical.equations.contains(&sample),
                        "seed {seed} {} ({what}): sample {sample}",
                        m.name()
                    ),
                    other => panic!(
                        "seed {seed} {} ({what}): expected Inconsistent, got {other:?}",
                        m.name()
                    ),
                }
            }
        }
    }
}

/// A column the data cannot bound (all zeros) is `Unbounded` naming its coefficient, in
/// every method; a prior on it bounds it again.
#[test]
fn an_unbounded_extra_coefficient_is_named() {
    let mut case = random_extra_case(3, 50, 0.0);
    case.extra.push(Regressor {
        name: "drift".into(),
        values: vec![Interval::new(0.0, 0.0); 50],
    });
    let prob = EivProblem {
        fixed: vec![None, None, Some(0.0), None, None, None, None, None],
        ..case.problem(true)
    };
    let mut prior = vec![Interval::entire(); 8];
    prior[7] = Interval::new(-2.0, 3.0);
    for (m, imp) in methods() {
        match imp.solve(&prob) {
            Err(SmidError::Unbounded { parameter, .. }) => {
                assert_eq!(parameter, "drift", "{}", m.name())
            }
            other => panic!("{}: expected `drift` unbounded, got {other:?}", m.name()),
        }
        let bounded = EivProblem {
            prior: Some(&prior),
            ..prob.clone()
        };
        let r = imp.solve(&bounded).unwrap();
        assert_eq!(r.bounds[7], prior[7], "{}", m.name());
    }
}

#[test]
fn the_registry_knows_every_method_by_its_spec_name() {
    let mut seen = names();
    seen.sort_unstable();
    let n = seen.len();
    seen.dedup();
    assert_eq!(
        seen.len(),
        n,
        "two registered methods share a name: {:?}",
        names()
    );
    for (m, imp) in all() {
        assert_eq!(imp.name(), m.name());
        assert_eq!(by_name(m.name()).map(|i| i.name()), Some(m.name()));
        assert_eq!(
            by_name(&m.name().replace('-', "_")).map(|i| i.name()),
            Some(m.name())
        );
        // A start is an earlier method: the chain ends.
        if let Some(s) = imp.start() {
            assert!(
                method(s).start() != Some(m),
                "{} <-> {}",
                m.name(),
                s.name()
            );
        }
    }
    assert_eq!(
        method(EivMethod::Shared).start(),
        Some(EivMethod::Classical)
    );
    assert!(by_name("simplex").is_none());
    assert!(EivMethod::Classical.available() && EivMethod::Shared.available());
    // `sdp` is registered by the crate smid-sdp, which the core's own tests do not link.
    assert!(!EivMethod::Sdp.available());
}
