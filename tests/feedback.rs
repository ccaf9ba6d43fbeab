//! Output blocks inside the loop (`model.feedback`): the linear block's autoregressive part
//! reads the chain's output. For every registered plugin that offers a random trial at the
//! output side ([`smid::core::registry::check_cases`]), random stable linear blocks, random
//! true blocks (the plugin's own draw), random prior boxes around the truth and noise uniform
//! inside its bound: the built-in plant runs the loop, the whole pipeline identifies it from
//! one dynamic record, and every reported bound must hold the truth (the parameters, the
//! nonlinearity set, every inner-signal sample). The true loop's data can never falsify it.
use smid::core::nonlinearity::Structure;
use smid::core::pipeline;
use smid::core::registry;
use smid::montecarlo::any_record;
use smid::plugin_check::{simulator, PluginTrial};
use smid::Outcome;

#[test]
fn every_output_side_plugin_inside_the_loop_is_bounded_with_the_truth_inside() {
    smid::link_plugins();
    let cases: Vec<String> = registry::check_cases()
        .into_iter()
        .filter(|c| c.structure == Structure::Wiener)
        .map(|c| c.name)
        .collect();
    assert!(cases.len() >= 3, "output-side cases: {cases:?}");
    use rayon::prelude::*;
    let draws: Vec<(String, u64)> = cases
        .iter()
        .flat_map(|case| (0..3u64).map(move |seed| (case.clone(), 7000 + seed)))
        .collect();
    let runs: Vec<(String, u64, Option<bool>, bool)> = draws
        .into_par_iter()
        .map(|(case, seed)| {
            let trial = PluginTrial::random(&case, seed).unwrap();
            let (mut spec, nl, linear) = trial.spec();
            any_record(&mut spec, &nl.parameters(), seed);
            spec.model.feedback = true;
            spec.model.unit_gain = false;
            let mut plant = simulator(linear, nl.as_ref(), Structure::Wiener);
            plant.feedback = true;
            match pipeline::run_with_plant(&spec, &mut plant) {
                Ok(Outcome::Consistent(id)) => {
                    let bounded = id
                        .model
                        .parameters
                        .iter()
                        .all(|p| p.lower.is_finite() && p.upper.is_finite());
                    (case, seed, id.all_contain_truth(), bounded)
                }
                Ok(Outcome::Falsified(f)) => {
                    panic!("{case} seed {seed}: the true loop's data falsified it: {f}")
                }
                // A loop that runs away (its inner signal never invertible) has no answer;
                // counted below, never a miss.
                Err(e) => {
                    eprintln!("{case} seed {seed}: no answer: {e}");
                    (case, seed, None, false)
                }
            }
        })
        .collect();
    for (case, seed, contained, _) in &runs {
        assert_ne!(
            *contained,
            Some(false),
            "{case} seed {seed}: a bound misses the truth"
        );
    }
    let answered = runs.iter().filter(|r| r.2 == Some(true) && r.3).count();
    eprintln!(
        "{answered} of {} trials bounded every parameter with the truth inside",
        runs.len()
    );
    assert!(
        answered * 2 >= runs.len(),
        "only {answered} of {} trials gave finite bounds: {runs:?}",
        runs.len()
    );
}
