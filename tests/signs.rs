//! The sign search behind `|·|` (the `abs` plugin on the output side): random stable linear
//! blocks of random orders, records of random length and levels, noise uniform in a random
//! bound, with and without the unit gain. Every bound holds the true `θ` (under `|·|` the
//! mirror `(a, -b)` is as consistent as the truth without the unit gain, and its hull is
//! reported); a certified member lies inside the bounds; and a budget too small to settle
//! the search, a frontier of width 1, or samples hulled instead of branched on, give looser
//! bounds, never wrong ones; with a bisected offset, the cell test keeps the truth's cell.
use rand::{Rng, SeedableRng};
use smid::core::outcome::Outcome;
use smid::core::spec::Spec;
use std::path::Path;

/// Coefficients `a1..a_n` of `Π (1 - r q⁻¹)`.
fn poly(roots: &[f64]) -> Vec<f64> {
    let mut c = vec![1.0];
    for &r in roots {
        let mut next = vec![0.0; c.len() + 1];
        for (i, v) in c.iter().enumerate() {
            next[i] += v;
            next[i + 1] -= r * v;
        }
        c = next;
    }
    c[1..].to_vec()
}

/// A random trial: the spec's text and the true `θ` (`a`, then `b0..b_nb`).
fn trial(seed: u64, nodes: Option<usize>) -> (String, Vec<f64>, bool) {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let na = rng.gen_range(1..=3usize);
    let nb = rng.gen_range(1..=2usize);
    let roots: Vec<f64> = (0..na).map(|_| rng.gen_range(-0.7..0.7)).collect();
    let a = poly(&roots);
    let mut b: Vec<f64> = (0..nb)
        .map(|_| rng.gen_range(0.3..1.5) * if rng.gen_bool(0.5) { 1.0 } else { -1.0 })
        .collect();
    let unit_gain = rng.gen_bool(0.5);
    let gain = (1.0 + a.iter().sum::<f64>()) / b.iter().sum::<f64>();
    if unit_gain {
        if !(gain.is_finite() && gain.abs() < 20.0) {
            b = vec![1.0 + a.iter().sum::<f64>(); 1];
            b.resize(nb, 0.0);
        } else {
            b.iter_mut().for_each(|v| *v *= gain);
        }
    }
    let length = rng.gen_range(80..240usize);
    let levels = [2usize, 4, 8][rng.gen_range(0..3)];
    let delta = rng.gen_range(0.002..0.03);
    let list = |v: &[f64]| {
        v.iter()
            .map(|x| format!("{x:e}"))
            .collect::<Vec<_>>()
            .join(", ")
    };
    let mut bfull = vec![0.0];
    bfull.extend(&b);
    let signs = nodes.map_or(String::new(), |n| format!("\n  signs: {{ nodes: {n} }}"));
    let text = format!(
        "name: abs-trial-{seed}
plant:
  simulator:
    structure: wiener
    a: [{}]
    b: [{}]
    nonlinearity: {{ type: abs }}
noise:
  delta: {delta:e}
experiment:
  seed: {seed}
  steady_state: {{ skip: true }}
  dynamic: {{ length: {length}, amplitude: 1.0, levels: {levels} }}
model:
  structure: wiener
  nonlinearity: {{ type: abs }}
  na: {na}
  nb: {nb}
  fixed: {{ b0: 0.0 }}
  unit_gain: {unit_gain}
  stable: true
method:
  eiv: classical
  member: {{ spread: false }}{signs}
",
        list(&a),
        list(&bfull),
    );
    let mut truth = a;
    truth.extend(bfull);
    (text, truth, unit_gain)
}

/// The number of `b` coefficients in the plant's line `b: [...]` of a trial's text.
fn b_len(text: &str) -> usize {
    let line = text
        .lines()
        .find(|l| l.trim_start().starts_with("b: ["))
        .unwrap();
    line.matches(',').count() + 1
}

#[test]
fn every_bound_behind_abs_holds_the_truth_on_random_plants() {
    smid::link_plugins();
    let (mut bounded, mut certified) = (0, 0);
    for seed in 1..=24u64 {
        let (text, truth, _) = trial(seed, None);
        let spec = Spec::parse(&text, Path::new("abs-trial.yaml")).unwrap();
        let id = match smid::core::pipeline::run(&spec, Path::new(".")) {
            Ok(Outcome::Consistent(id)) => id,
            Ok(Outcome::Falsified(f)) => {
                panic!("seed {seed}: the truth's own data falsified: {f:?}\n{text}")
            }
            // A record that leaves θ unbounded is no wrong bound.
            Err(smid::core::SmidError::Unbounded { .. }) => continue,
            Err(e) => panic!("seed {seed}: {e}\n{text}"),
        };
        let na = truth.len() - b_len(&text);
        for (k, t) in truth.iter().enumerate() {
            let name = if k < na {
                format!("a{}", k + 1)
            } else {
                format!("b{}", k - na)
            };
            let p = id
                .parameter(&name)
                .unwrap_or_else(|| panic!("seed {seed}: no parameter {name}"));
            assert!(
                p.interval().contains(*t),
                "seed {seed}: {name} = {t} outside {:?}\n{text}",
                p.interval()
            );
        }
        assert!(
            id.model.member_outside_bounds().is_empty(),
            "seed {seed}: a certified member outside the bounds"
        );
        bounded += 1;
        if id
            .model
            .simulation_member
            .as_ref()
            .is_some_and(|m| m.certified)
        {
            certified += 1;
        }
    }
    eprintln!("{bounded} of 24 trials bounded, {certified} members certified");
    assert!(bounded >= 18, "only {bounded} of 24 trials bounded");
    assert!(
        certified >= bounded / 2,
        "{certified} of {bounded} members certified"
    );
}

/// The truth inside every bound of `spec`'s identification, when it gives a bound (`None`:
/// the set is unbounded, no wrong bound).
fn holds_truth(text: &str, truth: &[f64]) -> Option<bool> {
    let spec = Spec::parse(text, Path::new("abs-trial.yaml")).unwrap();
    let id = match smid::core::pipeline::run(&spec, Path::new(".")) {
        Ok(Outcome::Consistent(id)) => id,
        Err(smid::core::SmidError::Unbounded { .. }) => return None,
        other => panic!("expected a bound, got {:?}\n{text}", other.map(|_| ())),
    };
    let na = truth.len() - b_len(text);
    Some(truth.iter().enumerate().all(|(k, t)| {
        let name = if k < na {
            format!("a{}", k + 1)
        } else {
            format!("b{}", k - na)
        };
        id.parameter(&name)
            .is_some_and(|p| p.interval().contains(*t))
    }))
}

#[test]
fn a_spent_budget_or_a_narrow_frontier_widens_the_bounds_and_keeps_the_truth() {
    smid::link_plugins();
    let mut bounded = 0;
    for seed in [3u64, 7, 11] {
        let (text, truth, _) = trial(seed, Some(5));
        let held = holds_truth(&text, &truth);
        bounded += usize::from(held.is_some());
        assert_ne!(
            held,
            Some(false),
            "seed {seed}: a spent budget dropped the truth's pattern\n{text}"
        );
        // One node per sample (every disagreement merged at once): still sound.
        let narrow = text.replace("nodes: 5", "nodes: 200000, width: 1");
        assert_ne!(
            holds_truth(&narrow, &truth),
            Some(false),
            "seed {seed}: a narrowed frontier dropped the truth\n{narrow}"
        );
        // Every sample hulled (no branching at all) is one plain stage 3, the loosest: it
        // still bounds the truth.
        let hulled = text.replace("nodes: 5", "nodes: 5, hull_within: 1.0e9");
        assert_eq!(
            holds_truth(&hulled, &truth),
            Some(true),
            "seed {seed}: every sample hulled\n{hulled}"
        );
    }
    assert!(bounded > 0, "no spent search gave a bound");
    // A bisected sensor offset (true value 0): the branch and bound's cheap test of each cell
    // runs the sign search for a proof of emptiness, and keeps the truth's cell.
    for seed in [2u64, 5] {
        let (text, truth, _) = trial(seed, None);
        let with_offset = text.replace(
            "  stable: true\n",
            "  stable: true\n  effects: [ { type: offset } ]\n  prior: { offset: [-0.05, 0.05] }\n",
        );
        assert_eq!(
            holds_truth(&with_offset, &truth),
            Some(true),
            "seed {seed}: a bisected offset\n{with_offset}"
        );
    }
    let (text, _, _) = trial(3, Some(5));
    let bad = text.replace("nodes: 5", "nodes: 0");
    let e = Spec::parse(&bad, Path::new("abs-trial.yaml")).unwrap_err();
    assert!(e.to_string().contains("method.signs.nodes"), "{e}");
    let bad = text.replace("nodes: 5", "nodes: 5, width: 0");
    let e = Spec::parse(&bad, Path::new("abs-trial.yaml")).unwrap_err();
    assert!(e.to_string().contains("width"), "{e}");
    let bad = text.replace("nodes: 5", "nodes: 5, hull_within: -1");
    let e = Spec::parse(&bad, Path::new("abs-trial.yaml")).unwrap_err();
    assert!(e.to_string().contains("hull_within"), "{e}");
}
