//! Equation terms and the designed steady-state experiment (`EquationTerm::keeps_steady_design`):
//! stage 1's polygons (eqs 13-20) hold only where the filtered square wave leaves the linear
//! block free of overshoot (Appendix). The cases are generated from the effect registry: every
//! registered term of the linear equation that vanishes at rest and whose example has a plant
//! side, at a random size, on the paper's Wiener plant with a random record.
//!
//! - A term that says it keeps the design: the filter is designed by the Appendix search on the
//!   plant with the term, and the polygons' bounds (no prior box) hold the truth.
//! - A term that says it breaks it: with the filter designed for the plant without it (the
//!   paper's pole), the polygons are refused with an error that names `model.prior` (read
//!   as polygons they would falsify the true model: dry friction turns off while the wave settles, and the
//!   backlash holds the overshoot); with a prior box on the backlash the steady-state points
//!   prune its cells with any history, and every bound holds the truth.
mod common;

use rand::{Rng, SeedableRng};
use smid_core::effect::{self, Effect};
use smid_core::outcome::Outcome;
use smid_core::SmidError;

use common::PAPER_TRUTH as TRUTH;

/// The filter line `common::paper_plant_spec` writes (the pole the Appendix gives the paper's
/// plant without any term).
const PAPER_POLE: &str = "  filter: { pole: 0.8125 }\n";

/// Registered equation terms that vanish at rest and have a plant side: `(tag, the model's
/// term with open values)`.
fn terms() -> Vec<(&'static str, Box<dyn Effect>)> {
    smid::link_plugins();
    effect::effects()
        .into_iter()
        .filter_map(|e| {
            let cand = (e.candidates)().into_iter().next()?;
            let example = (e.example)();
            (example.as_plant().is_some()
                && example.as_equation().is_some()
                && cand.as_equation().is_some()
                && cand.vanishes_at_steady_state()
                && cand.rest_parameter().is_none())
            .then_some((e.tag, cand))
        })
        .collect()
}

fn spec_text(
    seed: u64,
    plant_term: &str,
    model_term: &str,
    prior: bool,
    rng: &mut impl Rng,
) -> String {
    let dynamic = common::random_dynamic_record(rng);
    let prior = if prior {
        "  prior: { m_l: [0.2, 0.3], c_l: [0.0, 0.15], m_r: [0.2, 0.3], c_r: [0.0, 0.15] }\n"
    } else {
        ""
    };
    common::paper_plant_spec(
        "steady-design",
        seed,
        &format!("    effects: [ {plant_term} ]\n"),
        &format!("  steady_state: {{ amplitudes: 30, shuffle: true }}\n{dynamic}"),
        &format!("  unit_gain: true\n  effects: [ {model_term} ]\n{prior}"),
        "",
    )
}

fn run(text: &str) -> smid_core::Result<Outcome<smid::core::pipeline::Identification>> {
    let spec = smid::parse_spec(text, std::path::Path::new("<steady-design>"))
        .unwrap_or_else(|e| panic!("{e}\n{text}"));
    smid::run_spec(&spec, std::path::Path::new("."), &|_| {})
}

fn assert_consistent_around(text: &str, truth: &[(String, f64)], context: &str) {
    match run(text) {
        Ok(Outcome::Consistent(id)) => {
            common::assert_truth_inside(&id, truth, &format!("{context}\n{text}"))
        }
        Ok(Outcome::Falsified(f)) => {
            panic!("{context}: the true model was falsified: {f:?}\n{text}")
        }
        Err(e) => panic!("{context}: {e}\n{text}"),
    }
}

#[test]
fn terms_that_break_the_designed_experiment_reach_the_nonlinearity_only_through_a_prior_box() {
    let cases = terms();
    assert!(
        cases.iter().any(|(_, c)| !c.keeps_steady_design()),
        "the registry has a term that breaks the design (dry friction): {:?}",
        cases.iter().map(|(t, _)| t).collect::<Vec<_>>()
    );
    assert!(
        cases.iter().any(|(_, c)| c.keeps_steady_design()),
        "the registry has a term that keeps the design (viscous friction)"
    );
    for (k, (tag, cand)) in cases.iter().enumerate() {
        let model_term = serde_json::to_value(cand).unwrap().to_string();
        for trial in 0..2u64 {
            let seed = 300 + 10 * k as u64 + trial;
            let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
            let f = rng.gen_range(0.5..2.0) * if rng.gen_bool(0.5) { 1.0 } else { -1.0 };
            let plant = effect::effect_entry(tag)
                .unwrap()
                .scaled_example(f)
                .unwrap();
            let plant_term = serde_json::to_value(&plant).unwrap().to_string();
            let mut truth: Vec<(String, f64)> =
                TRUTH.iter().map(|(n, v)| (n.to_string(), *v)).collect();
            truth.extend(plant.truth());
            let context = format!("{tag} ×{f:.3} seed {seed}");
            if cand.keeps_steady_design() {
                // The filter designed on the plant with its term (Appendix): the polygons hold.
                let text = spec_text(seed, &plant_term, &model_term, false, &mut rng);
                assert!(text.contains(PAPER_POLE));
                let text = text.replace(PAPER_POLE, "");
                assert_consistent_around(&text, &truth, &context);
                eprintln!("{context}: keeps the design; polygons' bounds hold the truth");
            } else {
                // The same records with and without the box.
                let mut same = rng.clone();
                let text = spec_text(seed, &plant_term, &model_term, false, &mut rng);
                match run(&text) {
                    Err(SmidError::Invalid { field, message }) => assert!(
                        field == "model.effects" && message.contains("model.prior"),
                        "{context}: the refusal names the term's field and the prior box: {field}: {message}"
                    ),
                    Ok(Outcome::Consistent(_)) => {
                        panic!("{context}: the polygons were used under a term that breaks the design\n{text}")
                    }
                    Ok(Outcome::Falsified(f)) => panic!(
                        "{context}: the true model was falsified (the polygons under a term that breaks the design): {f:?}\n{text}"
                    ),
                    Err(e) => panic!("{context}: {e}\n{text}"),
                }
                let text = spec_text(seed, &plant_term, &model_term, true, &mut same);
                assert_consistent_around(&text, &truth, &context);
                eprintln!("{context}: breaks the design; refused without a prior box, truth inside with one");
            }
        }
    }
}

/// Only a nonlinearity that holds the linear block's overshoot needs the design: a Wiener
/// nonlinearity with parameters. A Hammerstein nonlinearity sees the filtered input itself,
/// and one without parameters (`linear`) bounds nothing from the points, so a term that breaks
/// the design leaves their stage 1 as it was; a term that keeps it never matters.
#[test]
fn only_a_wiener_nonlinearity_with_parameters_needs_the_design() {
    let cases = terms();
    for (_, cand) in &cases {
        let term = serde_json::to_value(cand).unwrap().to_string();
        let declared = "model:\n  nonlinearity: { type: output_backlash }";
        let model = |structure: &str, nonlinearity: &str| {
            let text = common::paper_plant_spec(
                "steady-design-scope",
                1,
                "",
                "",
                &format!("  unit_gain: true\n  effects: [ {term} ]\n"),
                "",
            );
            assert!(text.contains(declared), "{text}");
            let text = text.replace(
                declared,
                &format!(
                    "model:\n  structure: {structure}\n  nonlinearity: {{ type: {nonlinearity} }}"
                ),
            );
            smid::parse_spec(&text, std::path::Path::new("<scope>"))
                .unwrap_or_else(|e| panic!("{e}\n{text}"))
                .model
        };
        let breaks = !cand.keeps_steady_design();
        let label = cand.label();
        assert_eq!(
            model("wiener", "output_backlash")
                .term_breaking_steady_design()
                .is_some(),
            breaks,
            "{label}: a Wiener backlash"
        );
        assert!(
            model("hammerstein", "input_backlash")
                .term_breaking_steady_design()
                .is_none(),
            "{label}: a Hammerstein play sees the filtered input"
        );
        assert!(
            model("wiener", "linear")
                .term_breaking_steady_design()
                .is_none(),
            "{label}: no parameters to bound"
        );
    }
}
