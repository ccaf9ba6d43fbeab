//! Block chains generated from the registry (`smid::chain_check`): random stable linear
//! blocks with a random model nonlinearity, a random input-side block and a random block after
//! the nonlinearity, random true values and prior boxes, one multilevel record. No trial may
//! miss the truth (a bound excluding it, or the true chain found inconsistent); most must give
//! finite bounds, so the check is not vacuous.
use smid::chain_check::{trial, Outcome};

#[test]
fn random_chains_from_the_registry_hold_the_truth() {
    let seeds: Vec<u64> = (1..=16).collect();
    let mut contained = 0;
    let mut no_bound = Vec::new();
    let mut shapes = std::collections::BTreeSet::new();
    // The trials side by side (each is mostly sequential work), read back in seed order.
    use rayon::prelude::*;
    let trials: Vec<_> = seeds.par_iter().map(|&seed| trial(seed).unwrap()).collect();
    for (&seed, (spec, outcome)) in seeds.iter().zip(trials) {
        let m = &spec.model;
        shapes.insert((m.input.len(), m.nonlinearity_tag(), m.output.len()));
        match outcome {
            Outcome::Contained => contained += 1,
            Outcome::Missed(why) => {
                panic!("seed {seed} ({}): {why}", spec.name.unwrap_or_default())
            }
            Outcome::NoBound(why) => no_bound.push((seed, why)),
        }
    }
    eprintln!(
        "{contained} of {} contained; no bound: {no_bound:?}",
        seeds.len()
    );
    assert!(
        contained * 2 >= seeds.len(),
        "most trials must bound: {no_bound:?}"
    );
    assert!(
        shapes.iter().any(|s| s.0 > 0) && shapes.iter().any(|s| s.2 > 0),
        "the draws must include input-side and output-side blocks: {shapes:?}"
    );
}
