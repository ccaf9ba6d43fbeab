//! Tests of the polytope engine: the order of paths, emptiness proofs and random polytopes.
use super::*;
use proptest::prelude::*;

/// The engine's fallback order, driven with stand-in paths.
#[test]
fn paths_are_tried_in_order_and_the_relaxed_one_only_after_a_solver_failure() {
    use std::cell::Cell;
    let solver = || Err(SmidError::Solver("ipm trouble".into()));
    // Each later path runs only where every earlier one did not conclude.
    let called = Cell::new(0);
    let relaxed = |v: Option<u8>| {
        called.set(called.get() + 1);
        v
    };
    assert_eq!(
        first_conclusive(|| Ok(Some(1)), solver, || relaxed(Some(3))).unwrap(),
        1
    );
    assert_eq!(
        first_conclusive(|| Ok(None), || Ok(2), || relaxed(Some(3))).unwrap(),
        2
    );
    assert_eq!(called.get(), 0);
    assert_eq!(
        first_conclusive(|| Ok(None), solver, || relaxed(Some(3))).unwrap(),
        3
    );
    assert_eq!(called.get(), 1);
    // Nothing concludes: the interior-point path's failure, extended, still a solver error.
    match first_conclusive(|| Ok(None), solver, || relaxed(None)) {
        Err(SmidError::Solver(m)) => {
            assert!(
                m.starts_with("ipm trouble") && m.contains("relaxed outward"),
                "{m}"
            )
        }
        other => panic!("{other:?}"),
    }
    // An unbounded coordinate is an answer of its own, never sent to the relaxation (whose
    // "unbounded" says nothing), from either path.
    let unb = || Err::<u8, _>(unbounded(0));
    assert!(matches!(
        first_conclusive(|| Err(unbounded(0)), solver, || relaxed(Some(3))),
        Err(SmidError::Unbounded { .. })
    ));
    assert!(matches!(
        first_conclusive(|| Ok(None), unb, || relaxed(Some(3))),
        Err(SmidError::Unbounded { .. })
    ));
    assert_eq!(called.get(), 2);
}

/// An interval emptier than the rounding of the float certificate (`1 <= x <= 1 - 1e-7`
/// after padding: the float combination's slack over the artificial box is about 1e-6):
/// only the exact combination proves it empty, and the simplex does so without the
/// interior-point path.
#[test]
fn a_nearly_empty_polytope_is_proven_empty_exactly() {
    let mut p = Polytope::new(1);
    p.push_le(&[1.0], 1.0, 0);
    p.push_le(&[-1.0], -(1.0 + 1e-7), 1);
    assert!(matches!(p.simplex(&[0.0]), Simplex::Infeasible));
    assert!(matches!(p.simplex(&[1.0]), Simplex::Infeasible));
    assert_eq!(p.bound().unwrap(), LpOutcome::Infeasible);
    assert!(!p.feasible().unwrap());
    // Just inside (a gap the padding closes): not empty, and bounded around 1.
    let mut q = Polytope::new(1);
    q.push_le(&[1.0], 1.0, 0);
    q.push_le(&[-1.0], -(1.0 + 1e-10), 1);
    assert!(q.feasible().unwrap());
}

fn tri() -> Polytope {
    // 0 <= x, y <= 1, x + y <= 1.5, x - y = 0
    let mut p = Polytope::new(2);
    p.push_le(&[-1.0, 0.0], 0.0, 0);
    p.push_le(&[0.0, -1.0], 0.0, 0);
    p.push_le(&[1.0, 0.0], 1.0, 0);
    p.push_le(&[0.0, 1.0], 1.0, 0);
    p.push_le(&[1.0, 1.0], 1.5, 0);
    p.push_eq(&[1.0, -1.0], 0.0);
    p
}

#[test]
fn box_with_diagonal_cut() {
    let mut p = tri();
    for out in [p.bound().unwrap(), p.clarabel_bounds().unwrap()] {
        match out {
            LpOutcome::Bounds(b) => {
                assert!(b[0].contains(0.0) && b[0].contains(0.75));
                assert!(
                    (b[0].hi - 0.75).abs() < 1e-6 && b[0].lo.abs() < 1e-6,
                    "{b:?}"
                );
            }
            LpOutcome::Infeasible => panic!("feasible"),
        }
    }
    assert!(p.feasible().unwrap());
    p.push_le(&[-1.0, 0.0], -2.0, 9);
    assert_eq!(p.bound().unwrap(), LpOutcome::Infeasible);
    assert!(!p.feasible().unwrap());
}

#[test]
fn an_open_direction_is_unbounded_not_a_number() {
    let mut p = Polytope::new(2);
    p.push_le(&[-1.0, 0.0], 0.0, 0);
    p.push_le(&[0.0, -1.0], 0.0, 0);
    p.push_le(&[1.0, -1.0], 1.0, 0);
    assert!(matches!(p.bound(), Err(SmidError::Unbounded { .. })));
    assert!(p.feasible().unwrap());
}

/// A random polytope around a known point `x0` (returned): `m` random rows that `x0`
/// satisfies with a random slack, a box of half-width 3 around it (every LP bounded), and
/// with `eq` (and `n > 1`) a random equality through it; everything times `scale`.
fn random_polytope(seed: u64, n: usize, m: usize, eq: bool, scale: f64) -> (Polytope, Vec<f64>) {
    use rand::{Rng, SeedableRng};
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let x0: Vec<f64> = (0..n).map(|_| rng.gen_range(-2.0..2.0)).collect();
    let mut p = Polytope::new(n);
    for _ in 0..m {
        let g: Vec<f64> = (0..n).map(|_| rng.gen_range(-1.0..1.0)).collect();
        let h = g.iter().zip(&x0).map(|(a, b)| a * b).sum::<f64>() + rng.gen_range(0.0..0.5);
        p.push_le(&g, h * scale, 0);
    }
    let x0: Vec<f64> = x0.iter().map(|v| v * scale).collect();
    for k in 0..n {
        let mut g = vec![0.0; n];
        g[k] = 1.0;
        p.push_le(&g, x0[k] + 3.0 * scale, 0);
        g[k] = -1.0;
        p.push_le(&g, -x0[k] + 3.0 * scale, 0);
    }
    if eq && n > 1 {
        let e: Vec<f64> = (0..n).map(|_| rng.gen_range(-1.0..1.0)).collect();
        let f = e.iter().zip(&x0).map(|(a, b)| a * b).sum::<f64>();
        p.push_eq(&e, f);
    }
    (p, x0)
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]
    /// Random polytopes around a known point: the simplex's certified bounds contain the
    /// point and agree with clarabel's to the pads.
    #[test]
    fn simplex_bounds_contain_the_point_and_agree_with_clarabel(
        seed in any::<u64>(), n in 1usize..6, m in 4usize..60, eq in any::<bool>(),
    ) {
        let (mut p, x0) = random_polytope(seed, n, m, eq, 1.0);
        // The simplex itself concludes (no fallback).
        let (Some(LpOutcome::Bounds(s)), LpOutcome::Bounds(c)) =
            (p.simplex_bounds().unwrap(), p.clarabel_bounds().unwrap())
        else {
            panic!("feasible by construction");
        };
        for k in 0..n {
            prop_assert!(s[k].contains(x0[k]), "{:?} misses {}", s[k], x0[k]);
            prop_assert!(c[k].contains(x0[k]), "clarabel {:?} misses {}", c[k], x0[k]);
            let tol = 1e-6 * (1.0 + c[k].lo.abs().max(c[k].hi.abs()));
            prop_assert!((s[k].lo - c[k].lo).abs() < tol && (s[k].hi - c[k].hi).abs() < tol,
                "θ{}: simplex {:?} clarabel {:?}", k, s[k], c[k]);
        }
        // Cut the point off by far: proven empty.
        let mut g = vec![0.0; n];
        g[0] = 1.0;
        p.push_le(&g, x0[0] - 10.0, 0);
        prop_assert!(matches!(p.simplex(&vec![0.0; n]), Simplex::Infeasible));
        prop_assert!(!p.feasible().unwrap());
        prop_assert_eq!(p.bound().unwrap(), LpOutcome::Infeasible);
        // Clarabel's emptiness is proven by its Farkas multipliers too.
        prop_assert!(matches!(p.clarabel(None).unwrap(), Ipm::Empty));
        prop_assert_eq!(p.clarabel_bounds().unwrap(), LpOutcome::Infeasible);
    }

    /// The last resort's relaxed polytope is a superset: its certified bounds contain the
    /// exact ones (and the point), and it proves emptiness only where there is some.
    #[test]
    fn relaxed_bounds_contain_the_exact_ones(
        seed in any::<u64>(), n in 1usize..6, m in 4usize..60, eq in any::<bool>(),
        scale in prop_oneof![Just(1.0), Just(1e4)],
    ) {
        let (p, x0) = random_polytope(seed, n, m, eq, scale);
        let (Some(LpOutcome::Bounds(exact)), Some(LpOutcome::Bounds(relaxed))) =
            (p.simplex_bounds().unwrap(), p.relaxed_bounds())
        else {
            panic!("feasible and bounded by construction");
        };
        for k in 0..n {
            prop_assert!(relaxed[k].contains(x0[k]));
            prop_assert!(relaxed[k].lo <= exact[k].lo && exact[k].hi <= relaxed[k].hi,
                "θ{}: relaxed {:?} inside exact {:?}", k, relaxed[k], exact[k]);
            let tol = 1e-3 * (1.0 + exact[k].lo.abs().max(exact[k].hi.abs()));
            prop_assert!(exact[k].lo - relaxed[k].lo < tol && relaxed[k].hi - exact[k].hi < tol);
        }
        // Cut off by far: still empty when relaxed. Flattened to the slab `θ0 = x0[0]` (two
        // inequalities, the thin polytopes this path is for): still holds the point.
        let mut q = p.clone();
        let mut g = vec![0.0; n];
        g[0] = 1.0;
        q.push_le(&g, x0[0] - 10.0 * scale, 0);
        prop_assert_eq!(q.relaxed_bounds(), Some(LpOutcome::Infeasible));
        let mut thin = p.clone();
        thin.push_le(&g, x0[0], 0);
        g[0] = -1.0;
        thin.push_le(&g, -x0[0], 0);
        match thin.relaxed_bounds() {
            Some(LpOutcome::Bounds(b)) => {
                prop_assert!(b[0].contains(x0[0]), "thin: {:?} misses {}", b[0], x0[0]);
            }
            Some(LpOutcome::Infeasible) => prop_assert!(false, "thin but not empty"),
            None => {}
        }
    }
}
