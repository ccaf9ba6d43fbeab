//! Terms that do not vanish at rest but only shift the linear block's output there
//! (`EquationTerm::rest_parameter`, e.g. a constant: `x̄ = v̄ + c/A(1)` under unit gain), used
//! with the designed steady-state experiment: stage 1 carries every steady input as `v̄ + s`
//! over the cell of the bisected shift `s`. The cases are generated from the effect registry:
//! every registered effect whose diagnosis candidate names a rest parameter and whose example
//! has a plant side, at a random size, on the paper's Wiener plant (output backlash) with a
//! random record (binary or multilevel, random length and amplitude). The true values are
//! computed here from what the test drew (the plant's own equation term at rest over the
//! plant's `A(1)`), not read from the report, and every bound must hold them.
mod common;

use rand::{Rng, SeedableRng};
use smid_core::effect::{self, Signals};
use smid_core::interval::Interval;
use smid_core::outcome::Outcome;
use smid_core::SmidError;

use common::PAPER_TRUTH as TRUTH;
const A1: f64 = 2.2;

/// Registered effects whose candidate names a shift at rest: `(tag, rest parameter, whether
/// the term keeps the designed experiment valid)`.
fn shifting_effects() -> Vec<(&'static str, String, bool)> {
    smid::link_plugins();
    effect::effects()
        .into_iter()
        .filter_map(|e| {
            let cand = (e.candidates)().into_iter().next()?;
            let name = cand.rest_parameter()?;
            (e.example)().as_plant()?;
            Some((e.tag, name, cand.keeps_steady_design()))
        })
        .collect()
}

/// The backlash's prior box (around the paper's truth) for a term that breaks the designed
/// experiment: the steady-state points then reach the backlash only through its cells.
const BACKLASH_PRIOR: &str =
    ", m_l: [0.2, 0.3], c_l: [0.0, 0.15], m_r: [0.2, 0.3], c_r: [0.0, 0.15]";

/// The example of `tag` with its numbers scaled by `f` (its true values).
fn run(text: &str) -> Outcome<smid::core::pipeline::Identification> {
    smid::link_plugins();
    let spec = smid::parse_spec(text, std::path::Path::new("<rest-shift>"))
        .unwrap_or_else(|e| panic!("{e}\n{text}"));
    smid::run_spec(&spec, std::path::Path::new("."), &|_| {})
        .unwrap_or_else(|e| panic!("{e}\n{text}"))
}

fn spec_text(
    seed: u64,
    plant_effect: &str,
    tag: &str,
    rest: &str,
    keeps_design: bool,
    rng: &mut impl Rng,
) -> String {
    let boxed = if keeps_design { "" } else { BACKLASH_PRIOR };
    common::paper_plant_spec(
        &format!("rest-shift-{tag}"),
        seed,
        &format!("    effects: [ {plant_effect} ]\n"),
        &format!(
            "  steady_state: {{ amplitudes: 30 }}\n{}",
            common::random_dynamic_record(rng)
        ),
        &format!(
            "  unit_gain: true\n  effects: [ {{ type: {tag} }} ]\n  prior: {{ {rest}: [-0.4, 0.4]{boxed} }}\n"
        ),
        "",
    )
}

/// The same on a Hammerstein plant (the paper's play before the linear block): at rest the
/// play's output is the linear block's input, `x̄ = v̄ + s` with `s` read at the *measured*
/// input, so stage 1's polygons see the point's output moved, not its input; with `prior` the
/// play is bisected over a box and the points prune its cells (carried forward through the
/// play, backward through nothing).
fn hammerstein_spec_text(
    seed: u64,
    plant_effect: &str,
    tag: &str,
    rest: &str,
    prior: bool,
    rng: &mut impl Rng,
) -> String {
    let dynamic = common::random_dynamic_record(rng);
    let play = if prior {
        ", m_l: [0.2, 0.3], c_l: [0.02, 0.12], m_r: [0.2, 0.3], c_r: [0.0, 0.1]"
    } else {
        ""
    };
    format!(
        "name: rest-shift-hammerstein-{tag}
plant:
  simulator:
    structure: hammerstein
    a: [0.5, 0.7]
    b: [0.0, 1.4, 0.8]
    nonlinearity: {{ type: input_backlash, m_l: 0.248, c_l: 0.0698, m_r: 0.252, c_r: 0.0349 }}
    effects: [ {plant_effect} ]
noise: {{ encoder_bits: 15 }}
experiment:
  seed: {seed}
  filter: {{ pole: 0.8125 }}
  steady_state: {{ amplitudes: 30 }}
{dynamic}model:
  structure: hammerstein
  nonlinearity: {{ type: input_backlash, at_rest: false }}
  na: 2
  nb: 2
  fixed: {{ b0: 0.0 }}
  unit_gain: true
  effects: [ {{ type: {tag} }} ]
  prior: {{ {rest}: [-0.4, 0.4]{play} }}
method:
  alpha: zero
  eiv: classical
  member: {{ search: false }}
"
    )
}

#[test]
fn a_term_that_shifts_the_rest_keeps_every_bound_around_the_truth_with_steady_state_data() {
    let cases = shifting_effects();
    assert!(
        cases.iter().any(|(t, _, _)| *t == "constant"),
        "the registry's constant names its shift at rest: {cases:?}"
    );
    for (k, (tag, rest, keeps)) in cases.iter().enumerate() {
        for trial in 0..3u64 {
            let seed = 70 + 10 * k as u64 + trial;
            let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
            let f = rng.gen_range(0.5..2.5) * if rng.gen_bool(0.5) { 1.0 } else { -1.0 };
            let plant_effect = effect::effect_entry(tag)
                .unwrap()
                .scaled_example(f)
                .unwrap();
            let value = serde_json::to_value(&plant_effect).unwrap();
            // The true shift at rest from the plant side: its equation term on a record at rest
            // at the unit input (what the rest parameter is), over the plant's A(1).
            let at_rest = |v: f64| {
                let still = vec![v; 8];
                let term = plant_effect
                    .plant_equation(&Signals::input(&still, 1.0))
                    .expect("a term of the linear equation");
                term.last().unwrap() / A1
            };
            let shift = at_rest(1.0);
            // The model's shift at other steady inputs, from that parameter, holds the plant's.
            let entry = effect::effect_entry(tag).unwrap();
            let cand = (entry.candidates)().into_iter().next().unwrap();
            let model_term = cand.as_equation().expect("a term of the linear equation");
            for _ in 0..5 {
                let v = rng.gen_range(-2.0..2.0);
                let s = Interval::new(shift, shift);
                let got = model_term.rest_shift(Interval::new(v, v), s);
                assert!(
                    got.contains(at_rest(v)),
                    "{tag}: at the steady input {v} the plant shifts by {}, the model by {got:?}",
                    at_rest(v)
                );
            }
            let mut truth: Vec<(String, f64)> =
                TRUTH.iter().map(|(n, v)| (n.to_string(), *v)).collect();
            truth.push((rest.clone(), shift));
            truth.extend(plant_effect.truth());
            // Wiener (the paper's plant), then Hammerstein through the polygons (trial 1) or
            // with the play bisected and pruned by the points (trial 2). A term that breaks
            // the designed experiment (`EquationTerm::keeps_steady_design`) has its polygons
            // refused, so the nonlinearity gets a prior box in every trial.
            let text = match trial {
                0 => spec_text(seed, &value.to_string(), tag, rest, *keeps, &mut rng),
                t => hammerstein_spec_text(
                    seed,
                    &value.to_string(),
                    tag,
                    rest,
                    t == 2 || !keeps,
                    &mut rng,
                ),
            };
            smid::link_plugins();
            let spec = smid::parse_spec(&text, std::path::Path::new("<rest-shift>"))
                .unwrap_or_else(|e| panic!("{e}\n{text}"));
            let id = match smid::run_spec(&spec, std::path::Path::new("."), &|_| {}) {
                Ok(Outcome::Consistent(id)) => id,
                Ok(Outcome::Falsified(f)) => {
                    panic!("{tag}: the true model was falsified: {f:?}\n{text}")
                }
                // Hammerstein's polygons under a shift that grows with the input: every steady
                // point's output is blurred by `|ū|` times a cell of gains, and the play's
                // slope may stay unbounded down to the resolution. A refusal, never a bound
                // that misses (docs/models.md, chains).
                Err(SmidError::Unbounded { parameter, message }) if trial == 1 => {
                    eprintln!("{tag} seed {seed} (trial {trial}): refused: `{parameter}` unbounded: {message}");
                    continue;
                }
                Err(e) => panic!("{tag}: {e}\n{text}"),
            };
            common::assert_truth_inside(&id, &truth, &format!("{tag} seed {seed}\n{text}"));
            eprintln!("{tag} seed {seed} (trial {trial}): shift at rest {shift:.4}, truth inside every bound");
        }
    }
}

/// The test above is not vacuous: the shift is what lets stage 1 see the plays. Declared
/// without the constant, the same data (the plant's constant at its largest draw) put the true
/// plays outside stage 1's bounds, or falsify the model.
#[test]
fn without_the_shift_the_steady_state_points_miss_the_true_plays() {
    smid::link_plugins();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
    let text = spec_text(
        5,
        "{\"type\": \"constant\", \"value\": 0.12}",
        "constant",
        "constant_at_rest",
        true,
        &mut rng,
    )
    .replace(
        "  effects: [ { type: constant } ]\n  prior: { constant_at_rest: [-0.4, 0.4] }\n",
        "",
    );
    assert!(!text.contains("model:\n  effects"), "{text}");
    match run(&text) {
        Outcome::Falsified(_) => {}
        Outcome::Consistent(id) => {
            let missed = TRUTH[..4].iter().any(|(n, v)| {
                let p = id.parameter(n).unwrap();
                !(p.lower <= *v && *v <= p.upper)
            });
            assert!(
                missed,
                "the plays' bounds hold the truth without the shift\n{text}"
            );
        }
    }
}

/// With steady-state data and no prior box for the shift, the error names the field to give.
#[test]
fn a_shift_at_rest_without_its_prior_is_refused_naming_the_prior_to_give() {
    smid::link_plugins();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(6);
    let text = spec_text(
        6,
        "{\"type\": \"constant\", \"value\": 0.05}",
        "constant",
        "constant_at_rest",
        true,
        &mut rng,
    )
    .replace("  prior: { constant_at_rest: [-0.4, 0.4] }\n", "");
    let spec = smid::parse_spec(&text, std::path::Path::new("<rest-shift>")).unwrap();
    let e = smid::run_spec(&spec, std::path::Path::new("."), &|_| {})
        .err()
        .unwrap_or_else(|| panic!("identified without the shift's prior\n{text}"))
        .to_string();
    assert!(e.contains("model.prior.constant_at_rest"), "{e}");
}
