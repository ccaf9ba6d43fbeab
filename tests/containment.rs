//! Guarantee properties: for random stable systems with unit gain, random physical backlash and
//! random noise inside its bound, the truth lies inside the bounds of stage 1 (polygons),
//! stage 2 (inner-signal intervals), stage 3 (θ intervals from exact-in-interval inner signals)
//! and end to end. Case counts are small by default (PROPTEST_CASES raises them); the release
//! check `smid check --trials 1000` runs the end-to-end property on 1000 trials.
use proptest::prelude::*;
use rand::{Rng, SeedableRng};
use smid::montecarlo::{random_linear, Trial};
use smid_core::interval::Interval;
use smid_core::inversion::{InnerBound, InnerKind};
use smid_core::nonlinearity::{Nonlinearity, NonlinearitySet, SteadyPoint, SteadyStateData};
use smid_core::signals::prbs;
use smid_core::spec::EivMethod;
use smid_core::stage3::{self, EivProblem};
use smid_core::{Outcome, SmidError};
use smid_output_backlash::branch_polygons;
use smid_output_backlash::Backlash;

fn cases(default: u32) -> ProptestConfig {
    ProptestConfig::with_cases(
        std::env::var("PROPTEST_CASES")
            .ok()
            .and_then(|v| v.parse().ok())
            .unwrap_or(default),
    )
}

/// Exact steady-state data of a backlash with noise drawn inside `delta`.
fn steady(b: &smid_output_backlash::Backlash, delta: f64, rng: &mut impl Rng) -> SteadyStateData {
    let mut points = Vec::new();
    for k in 0..30 {
        let a = 0.6 + 2.4 * k as f64 / 29.0;
        for (u, rising) in [(a, true), (-a, false)] {
            let w = if rising {
                b.m_r * (u - b.c_r)
            } else {
                b.m_l * (u + b.c_l)
            };
            points.push(SteadyPoint {
                u,
                y: w + rng.gen_range(-delta..=delta),
                dy: delta,
                alpha: 0.0,
                rising,
                index: points.len(),
                time: None,
                step: None,
                du: 0.0,
            });
        }
    }
    SteadyStateData { points }
}

proptest! {
    #![proptest_config(cases(64))]

    #[test]
    fn stage1_polygons_contain_the_truth(seed in any::<u64>(), bits in 6u32..18) {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        let b = Backlash::random(&mut rng);
        let delta = smid_core::noise::encoder_delta(bits);
        match branch_polygons(&steady(&b, delta, &mut rng)) {
            Ok(set) => {
                let truth = [b.m_l, b.c_l, b.m_r, b.c_r];
                prop_assert!(set.contains(&truth), "{b:?} not in {set:?}");
                for (p, t) in set.parameters().iter().zip(truth) {
                    prop_assert!(p.interval.contains(t), "{} = {t} outside {:?}", p.name, p.interval);
                }
            }
            // Very coarse noise may leave a slope unbounded below: a clear error, not a miss.
            Err(SmidError::Unbounded { .. }) => prop_assume!(false),
            Err(e) => prop_assert!(false, "unexpected error {e}"),
        }
    }

    #[test]
    fn stage2_inner_bounds_contain_the_true_inner_signal(seed in any::<u64>(), bits in 8u32..16) {
        let t = Trial::random(seed);
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed ^ 0x5eed);
        let delta = smid_core::noise::encoder_delta(bits);
        let set = match branch_polygons(&steady(&t.backlash, delta, &mut rng)) {
            Ok(s) => s,
            Err(_) => { prop_assume!(false); unreachable!() }
        };
        let u = prbs(150, 1.0, 1, &mut rng);
        let x = t.linear.simulate(&u);
        let w = t.backlash.simulate(&x);
        let y: Vec<f64> = w.iter().map(|v| v + rng.gen_range(-delta..=delta)).collect();
        let inner = set.invert(&y, &vec![delta; y.len()]).unwrap();
        for (k, (b, xv)) in inner.iter().zip(&x).enumerate() {
            prop_assert!(b.interval.contains(*xv), "t = {k}: x = {xv} outside {b:?}");
        }
    }

    #[test]
    fn stage3_bounds_contain_the_true_linear_parameters(seed in any::<u64>(), dx in 1e-5f64..3e-2) {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        let lin = random_linear(&mut rng);
        let u = prbs(120, 1.0, 1, &mut rng);
        let x = lin.simulate(&u);
        // any interval of radius dx that contains x_t, placed at random
        let out: Vec<InnerBound> = x.iter().map(|&v| {
            let off = rng.gen_range(-dx..=dx);
            InnerBound { interval: Interval::new(v + off - dx, v + off + dx), kind: InnerKind::Inverted }
        }).collect();
        let input: Vec<Interval> = u.iter().map(|&v| Interval::new(v, v)).collect();
        let prob = EivProblem { locate: true, na: 2, nb: 2, fixed: vec![None, None, Some(0.0), None, None], unit_gain: true, lagged: None, output: &out, input: &input, use_band_samples: false, extra: &[], prior: None };
        match stage3::solve(EivMethod::Classical, &prob) {
            Ok(r) => {
                let truth = [lin.a[0], lin.a[1], 0.0, lin.b[1], lin.b[2]];
                for (b, t) in r.bounds.iter().zip(truth) {
                    prop_assert!(b.contains(t), "{t} outside {b:?}");
                }
            }
            Err(SmidError::Unbounded { .. }) => prop_assume!(false),
            Err(e) => prop_assert!(false, "unexpected error {e}"),
        }
    }
}

proptest! {
    #![proptest_config(cases(12))]

    #[test]
    fn end_to_end_bounds_contain_the_truth(seed in any::<u64>()) {
        match Trial::random(seed).run() {
            Ok(Outcome::Falsified(f)) => prop_assert!(false, "seed {seed}: the truth falsified: {f}"),
            Ok(Outcome::Consistent(id)) => prop_assert_eq!(id.all_contain_truth(), Some(true), "{}", smid_core::report::table(&id)),
            Err(SmidError::Unbounded { .. }) => prop_assume!(false),
            Err(e) => prop_assert!(false, "seed {seed}: {e}"),
        }
    }
}

proptest! {
    #![proptest_config(cases(if cfg!(feature = "slow-checks") { 2 } else { 1 }))]

    /// Every stage-3 method of this build (the moment relaxation only with the feature `sdp`)
    /// on the same random trial: each contains the truth, and the tighter methods are never
    /// wider than the ones they start from (classical ⊇ shared ⊇ sdp, exact-grid). Two trials
    /// under `slow-checks`, one without it (CI).
    #[test]
    fn every_stage3_method_contains_the_truth(seed in any::<u64>()) {
        let trial = Trial::random(seed);
        let mut shared = None;
        for m in EivMethod::registered().into_iter().filter(|m| m.available()) {
            match trial.run_method(m) {
                Ok(Outcome::Falsified(f)) => prop_assert!(false, "{}: the truth falsified: {f}", m.name()),
                Ok(Outcome::Consistent(id)) => {
                    prop_assert_eq!(id.all_contain_truth(), Some(true), "{}: {}", m.name(), smid_core::report::table(&id));
                    let theta: Vec<Interval> = ["a1", "a2", "b1", "b2"]
                        .iter()
                        .filter_map(|n| id.parameter(n).map(|p| Interval::new(p.lower, p.upper)))
                        .collect();
                    if m == EivMethod::Shared {
                        shared = Some(theta);
                    } else if let (Some(s), true) = (&shared, m != EivMethod::Classical) {
                        for (k, (t, s)) in theta.iter().zip(s).enumerate() {
                            prop_assert!(s.lo <= t.lo && t.hi <= s.hi, "{}: θ{k} {t:?} wider than shared {s:?}", m.name());
                        }
                    }
                }
                Err(SmidError::Unbounded { .. }) => prop_assume!(false),
                Err(e) => prop_assert!(false, "seed {seed}, {}: {e}", m.name()),
            }
        }
    }
}
