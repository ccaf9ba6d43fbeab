//! Output blocks inside the loop (`model.feedback`): the linear block's autoregressive part
//! reads the chain's output. For every registered plugin that offers a random trial at the
//! output side ([`smid::core::registry::check_cases`]), random stable linear blocks, random
//! true blocks (the plugin's own draw), random prior boxes around the truth and noise uniform
//! inside its bound: the built-in plant runs the loop, the whole pipeline identifies it from
//! one dynamic record, and every reported bound must hold the truth (the parameters, the
//! nonlinearity set, every inner-signal sample). The true loop's data can never falsify it.
use smid::core::nonlinearity::Structure;
use smid::core::pipeline;
use smid::core::plant::Plant;
use smid::core::registry;
use smid::montecarlo::any_record;
use smid::plugin_check::{simulator, PluginTrial};
use smid::Outcome;

/// Whether the slow checks run (`scripts/test-slow`, the feature `slow-checks`): the tests
/// here then run every case and seed; without it (CI), the sample each names.
const SLOW_CHECKS: bool = cfg!(feature = "slow-checks");

/// Without `slow-checks` (CI) the first of the three seeds, for every case.
#[test]
fn every_output_side_plugin_inside_the_loop_is_bounded_with_the_truth_inside() {
    smid::link_plugins();
    let cases = output_side_cases();
    assert!(cases.len() >= 3, "output-side cases: {cases:?}");
    use rayon::prelude::*;
    let seeds = if SLOW_CHECKS { 3 } else { 1 };
    let draws: Vec<(String, u64)> = cases
        .iter()
        .flat_map(|case| (0..seeds).map(move |seed| (case.clone(), 7000 + seed)))
        .collect();
    let runs: Vec<(String, u64, Option<bool>, bool)> = draws
        .into_par_iter()
        .map(|(case, seed)| {
            in_the_loop(&case, seed, |spec, plant| {
                match pipeline::run_with_plant(spec, plant) {
                    Ok(Outcome::Consistent(id)) => {
                        let bounded = id
                            .model
                            .parameters
                            .iter()
                            .all(|p| p.lower.is_finite() && p.upper.is_finite());
                        // The block changes what the loop reads on this record (else feedback
                        // changes nothing).
                        let u = &id.model.training.records[0].u;
                        let (x, w) = (plant.inner(u).unwrap(), plant.run(u).unwrap());
                        let acts = x
                            .iter()
                            .zip(&w)
                            .any(|(x, w)| (x - w).abs() > 1e-9 * (1.0 + x.abs()));
                        (case.clone(), seed, id.all_contain_truth(), bounded && acts)
                    }
                    Ok(Outcome::Falsified(f)) => {
                        panic!("{case} seed {seed}: the true loop's data falsified it: {f}")
                    }
                    // A loop that runs away (its inner signal never invertible) has no answer;
                    // counted below, never a miss.
                    Err(e) => {
                        eprintln!("{case} seed {seed}: no answer: {e}");
                        (case.clone(), seed, None, false)
                    }
                }
            })
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
        "{answered} of {} trials bounded every parameter with the truth inside, the block changing what the loop reads",
        runs.len()
    );
    assert!(
        answered + 2 >= runs.len(),
        "only {answered} of {} trials gave finite bounds with the block changing what the loop reads: {runs:?}",
        runs.len()
    );
}

/// A loop member's free-run distance from the training records (`training_within`, which runs
/// the loop from a warm start the output side reaches) is a bound at which the model is
/// consistent: for every registered output-side plugin inside the loop (a random trial as
/// above), the same records with that bound declared are never falsified. This is what
/// `noise.from: free_run` raises an estimated bound to. Without `slow-checks` (CI) every
/// other case in name order, from the first.
#[test]
fn a_loop_members_free_run_distance_is_a_bound_at_which_the_loop_is_consistent() {
    smid::link_plugins();
    let cases: Vec<String> = output_side_cases()
        .into_iter()
        .enumerate()
        .filter(|(i, _)| SLOW_CHECKS || i % 2 == 0)
        .map(|(_, c)| c)
        .collect();
    use rayon::prelude::*;
    let checked: Vec<(String, Option<f64>)> = cases
        .into_par_iter()
        .map(|case| {
            let seed = 7100;
            let (spec, run) = in_the_loop(&case, seed, |spec, plant| {
                // A copy of the spec (its bound is set again below).
                (pipeline::with_bound(spec, 1.0), pipeline::run_with_plant(spec, plant))
            });
            let id = match run {
                Ok(Outcome::Consistent(id)) => id,
                Ok(Outcome::Falsified(f)) => panic!("{case}: the true loop's data falsified it: {f}"),
                Err(e) => {
                    eprintln!("{case}: no answer: {e}");
                    return (case, None);
                }
            };
            let Some(within) = id.model.simulation_member.as_ref().and_then(|m| m.within)
            else {
                return (case, None);
            };
            let d = within * (1.0 + 1e-9) + 1e-12;
            let at = pipeline::with_bound(&spec, d);
            let data = pipeline::ExperimentData {
                steady: None,
                steady_record: None,
                records: id.model.training.records.clone(),
                filter: None,
            };
            match pipeline::identify(&at, pipeline::data_with_bound(&data, d), &[]) {
                Ok(Outcome::Consistent(_)) => {}
                Ok(Outcome::Falsified(f)) => panic!(
                    "{case}: falsified at its member's free-run distance {within:e} (bound {:e}): {f}",
                    id.model.delta
                ),
                Err(e) => panic!("{case}: at its member's free-run distance {within:e}: {e}"),
            }
            (case, Some(within))
        })
        .collect();
    eprintln!("{checked:?}");
    let with = checked.iter().filter(|c| c.1.is_some()).count();
    assert!(
        with + 1 >= checked.len(),
        "a member distance in only {with} of {} cases: {checked:?}",
        checked.len()
    );
}

/// The diagnosis offers the output side inside the loop exactly where the model class can take
/// it and it changes the model: for every registered plugin as the Wiener nonlinearity or as an
/// output block, with and without the unit gain, an input block or the Hammerstein structure.
#[test]
fn the_diagnosis_offers_the_loop_where_the_class_takes_it() {
    use smid::core::diagnose::inside_the_loop;
    smid::link_plugins();
    let mut offered = 0;
    for entry in registry::models() {
        let has_params = !registry::parameter_names(entry.tag).is_empty();
        let plugin = (entry.example)();
        for (structure, as_output_block, unit_gain, input_block) in [
            (Structure::Wiener, false, false, false),
            (Structure::Wiener, true, false, false),
            (Structure::Wiener, false, true, false),
            (Structure::Wiener, true, false, true),
            (Structure::Hammerstein, true, false, false),
        ] {
            let mut spec = smid::parse_spec(
                "plant: { data: { dynamic: { file: x.csv, u: u, y: y } } }\nnoise: { delta: 0.01 }\nmodel: { structure: wiener, nonlinearity: { type: linear }, na: 2, nb: 1, unit_gain: false }\n",
                std::path::Path::new("loop.yaml"),
            )
            .unwrap();
            let m = &mut spec.model;
            m.structure = structure;
            m.unit_gain = unit_gain;
            if as_output_block {
                if !plugin.supports(Structure::Wiener) {
                    continue;
                }
                m.output
                    .push(serde_json::from_value(serde_json::to_value(&plugin).unwrap()).unwrap());
                for n in registry::parameter_names(entry.tag) {
                    m.prior.insert(format!("out1.{n}"), [0.1, 1.0]);
                }
            } else {
                if !plugin.supports(structure) {
                    continue;
                }
                m.nonlinearity =
                    serde_json::from_value(serde_json::to_value(&plugin).unwrap()).unwrap();
            }
            if input_block {
                m.input
                    .push(serde_json::from_value(serde_json::json!({"type": "lag"})).unwrap());
                m.prior.insert("in1.p".into(), [0.1, 0.5]);
            }
            if let Err(e) = m.layout() {
                panic!("{}: the base is no valid model: {e}", entry.tag);
            }
            let output_side = has_params && (as_output_block || structure == Structure::Wiener);
            let expected =
                output_side && !unit_gain && !input_block && structure == Structure::Wiener;
            let got = inside_the_loop(m);
            assert_eq!(
                got.is_some(),
                expected,
                "{} ({structure:?}, output block {as_output_block}, unit gain {unit_gain}, input block {input_block})",
                entry.tag
            );
            if let Some(g) = got {
                offered += 1;
                assert!(g.feedback && g.layout().is_ok());
                let mut back = g.duplicate();
                back.feedback = false;
                assert_eq!(
                    serde_json::to_value(&back).unwrap(),
                    serde_json::to_value(&*m).unwrap(),
                    "the candidate changes only the flag"
                );
            }
        }
    }
    assert!(offered >= 5, "offered {offered} times");
}

/// Steady-state points with the output side inside the loop are refused with an error naming
/// `model.feedback`: stage 1 reads them as the gain times the input, which does not hold there.
#[test]
fn steady_state_points_inside_the_loop_are_refused() {
    let spec = smid::parse_spec(
        "plant:\n  simulator: { structure: wiener, feedback: true, a: [-0.6, 0.25], b: [0.0, 0.4, 0.25], nonlinearity: { type: saturation, m_l: 1.0, s_l: 1.2, m_r: 1.0, s_r: 1.5 } }\nnoise: { encoder_bits: 12 }\nexperiment:\n  seed: 1\n  filter: { pole: 0.8 }\n  steady_state: { amplitudes: 20, min: 0.1, max: 4.0 }\n  dynamic: { length: 100, amplitude: 0.5 }\nmodel: { structure: wiener, nonlinearity: { type: saturation }, feedback: true, na: 2, nb: 2, fixed: { b0: 0.0 }, unit_gain: false }\nmethod: { alpha: bias }\n",
        std::path::Path::new("steady-loop.yaml"),
    )
    .unwrap();
    match smid::run_spec(&spec, std::path::Path::new("."), &|_| {}) {
        Err(e) => assert!(e.to_string().contains("model.feedback"), "{e}"),
        Ok(_) => panic!("steady-state points inside the loop were read"),
    }
}

/// The registered plugins' cases with a random trial at the output side.
fn output_side_cases() -> Vec<String> {
    registry::check_cases()
        .into_iter()
        .filter(|c| c.structure == Structure::Wiener)
        .map(|c| c.name)
        .collect()
}

/// `f` on the random trial `seed` of `case` inside the loop: its spec (one PRBS record,
/// `model.feedback`, no unit gain) and the built-in plant running the loop.
fn in_the_loop<T>(
    case: &str,
    seed: u64,
    f: impl FnOnce(&smid::core::spec::Spec, &mut smid::core::plant::SimulatedPlant) -> T,
) -> T {
    let trial = PluginTrial::random(case, seed).unwrap();
    let (mut spec, nl, linear) = trial.spec();
    any_record(&mut spec, &nl.parameters(), seed);
    spec.model.feedback = true;
    spec.model.unit_gain = false;
    let mut plant = simulator(linear, nl.as_ref(), Structure::Wiener);
    plant.feedback = true;
    f(&spec, &mut plant)
}
