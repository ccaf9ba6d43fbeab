//! Containment check of block chains generated from the registry: each trial draws a random
//! stable unit-gain linear block and a random chain around it — a model nonlinearity on the
//! output side (any registered plugin that supports it, or none), up to two blocks on the input
//! side and up to two after the nonlinearity (the second one a quarter of the time), each any
//! registered plugin that supports its side —
//! with true parameters drawn around each plugin's registered example (×[0.8, 1.25]) and a
//! random prior box around them, then identifies the chain from one multilevel record with
//! every block's parameters bisected (`smid_core::chain`). A plugin registered anywhere in the
//! binary joins the draws with no edit here.
//!
//! A trial **misses** when a bound excludes the truth or the data falsify the true chain: the
//! worst bug smid can have. A trial without a finite bound (an unidentifiable chain, the cell
//! budget) is counted apart.
use rand::{Rng, SeedableRng};
use serde_json::{json, Map, Value};
use smid_core::chain::{qualified, Side};
use smid_core::nonlinearity::Structure;
use smid_core::registry;
use smid_core::spec::Spec;
use smid_core::{Result, SmidError};

/// What one trial gave.
#[derive(Debug, Clone, PartialEq)]
pub enum Outcome {
    /// Every bound holds the truth.
    Contained,
    /// A bound misses the truth, or the true chain was found inconsistent: a bug.
    Missed(String),
    /// No finite bound (unidentifiable within the budget, solver trouble): not a miss.
    NoBound(String),
}

/// The registered plugins that can sit on `side`, with parameters (a plugin without any is
/// the identity and adds nothing to a chain).
fn plugins_for(side: Side) -> Vec<&'static str> {
    registry::models()
        .iter()
        .filter(|e| (e.example)().supports(side.structure()))
        .map(|e| e.tag)
        .filter(|t| !registry::parameter_names(t).is_empty())
        .collect()
}

/// A true block of type `tag` (its registered example's parameters scaled by [0.8, 1.25],
/// redrawn until the simulator accepts them) and a prior box around it that the model plugin
/// accepts (shrunk toward the truth until it does). `None` when no draw is valid.
fn draw_block(
    tag: &str,
    prefix: Option<&str>,
    rng: &mut impl Rng,
) -> Option<(Value, Vec<(String, [f64; 2])>)> {
    let entry = registry::nonlinearities()
        .into_iter()
        .find(|e| e.tag == tag)?;
    let model = registry::models().into_iter().find(|e| e.tag == tag)?;
    for _ in 0..20 {
        // One factor for the whole block: the example's shape is kept (a backlash's two slopes
        // stay within its example's asymmetry, or its dead band would close at large outputs
        // and the plant leave the model class).
        let f: f64 = rng.gen_range(0.8..1.25);
        let params: Vec<(String, f64)> = (entry.example)()
            .parameters()
            .into_iter()
            .map(|(n, v)| (n, v * f))
            .collect();
        let Ok(sim) = registry::instantiate(tag, &params) else {
            continue;
        };
        if sim.validate().is_err() {
            continue;
        }
        let mut widths: Vec<(f64, f64)> = params
            .iter()
            .map(|(_, v)| {
                let w = v.abs().max(0.05) * rng.gen_range(0.1..0.6);
                let f: f64 = rng.gen_range(0.0..1.0);
                (w * f, w * (1.0 - f))
            })
            .collect();
        for _ in 0..12 {
            let cell: Vec<smid_core::interval::Interval> = params
                .iter()
                .zip(&widths)
                .map(|((_, v), (a, b))| {
                    // Positive parameters keep a positive prior.
                    let lo = if *v > 0.0 {
                        (v - a).max(0.2 * v)
                    } else {
                        v - a
                    };
                    smid_core::interval::Interval::new(lo, v + b)
                })
                .collect();
            if (model.example)().set_from_box(&cell).is_ok() {
                let mut obj = Map::new();
                obj.insert("type".into(), json!(tag));
                for (n, v) in &params {
                    obj.insert(n.clone(), json!(v));
                }
                let prior = params
                    .iter()
                    .zip(&cell)
                    .map(|((n, _), c)| {
                        let name = prefix.map_or(n.clone(), |p| qualified(p, n));
                        (name, [c.lo, c.hi])
                    })
                    .collect();
                return Some((Value::Object(obj), prior));
            }
            for w in &mut widths {
                w.0 *= 0.5;
                w.1 *= 0.5;
            }
        }
    }
    None
}

/// The spec of trial `seed`: a random chain around a random stable unit-gain linear block.
pub fn random_chain(seed: u64) -> Result<Spec> {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed ^ 0x00c4_a12b_10c4);
    let lin = crate::montecarlo::random_linear(&mut rng);
    let mut prior: Vec<(String, [f64; 2])> = Vec::new();
    let pick = |rng: &mut rand_chacha::ChaCha8Rng, list: &[&'static str]| -> Option<&'static str> {
        // Each position is empty with probability 1/3.
        (!list.is_empty() && rng.gen_range(0..3) > 0).then(|| list[rng.gen_range(0..list.len())])
    };
    let outputs = plugins_for(Side::Output);
    let inputs = plugins_for(Side::Input);
    let primary = pick(&mut rng, &outputs);
    let input = pick(&mut rng, &inputs);
    let output = pick(&mut rng, &outputs);
    let mut sim_nl = json!({ "type": "linear" });
    let mut model_nl = json!({ "type": "linear" });
    if let Some(tag) = primary {
        let (v, p) = draw_block(tag, None, &mut rng).ok_or_else(|| no_draw(tag))?;
        sim_nl = v;
        model_nl = json!({ "type": tag });
        prior.extend(p);
    }
    // A second block on a side, now and then: blocks fed by blocks.
    let input2 = input.and_then(|_| {
        if rng.gen_range(0..4) == 0 {
            pick(&mut rng, &inputs)
        } else {
            None
        }
    });
    let output2 = output.and_then(|_| {
        if rng.gen_range(0..4) == 0 {
            pick(&mut rng, &outputs)
        } else {
            None
        }
    });
    let mut side = |tags: [Option<&str>; 2],
                    s: Side,
                    rng: &mut rand_chacha::ChaCha8Rng|
     -> Result<(Vec<Value>, Vec<Value>)> {
        let (mut sims, mut models) = (Vec::new(), Vec::new());
        for t in tags.into_iter().flatten() {
            let (v, p) =
                draw_block(t, Some(&s.prefix(sims.len() + 1)), rng).ok_or_else(|| no_draw(t))?;
            prior.extend(p);
            sims.push(v);
            models.push(json!({ "type": t }));
        }
        Ok((sims, models))
    };
    let (sim_in, model_in) = side([input, input2], Side::Input, &mut rng)?;
    let (sim_out, model_out) = side([output, output2], Side::Output, &mut rng)?;
    let delta = 10f64.powf(rng.gen_range(-4.0..-2.5));
    // The input's amplitude over the block's peak gain (the ℓ1 norm of its impulse response),
    // so the inner signal stays within [-1.5, 1.5] whatever the poles, as a designer scales
    // an experiment to the plant.
    let mut impulse = vec![0.0; 400];
    impulse[0] = 1.0;
    let l1: f64 = lin
        .simulate(&impulse)
        .iter()
        .map(|h| h.abs())
        .sum::<f64>()
        .max(1.0);
    let amplitude = rng.gen_range(0.5..1.5) / l1;
    let spec = json!({
        "name": format!("chain-{seed}"),
        "plant": { "simulator": {
            "structure": "wiener", "a": lin.a, "b": lin.b,
            "nonlinearity": sim_nl, "input": sim_in, "output": sim_out,
        }},
        "noise": { "delta": delta },
        "experiment": {
            "seed": seed,
            "steady_state": { "skip": true },
            "dynamic": { "length": rng.gen_range(200..500), "amplitude": amplitude, "levels": 8 },
        },
        "model": {
            "structure": "wiener", "nonlinearity": model_nl, "input": model_in, "output": model_out,
            "na": 2, "nb": 2, "fixed": { "b0": 0.0 },
            "prior": prior.into_iter().map(|(k, v)| (k, json!(v))).collect::<Map<String, Value>>(),
        },
        "method": { "eiv": "classical", "cells": { "max_cells": 1500, "max_leaves": 64, "nonlinearity_halvings": 4 } },
    });
    let text = serde_json::to_string(&spec).expect("json serialises");
    Spec::parse(&text, std::path::Path::new(&format!("chain-{seed}.json")))
}

fn no_draw(tag: &str) -> SmidError {
    SmidError::Unsupported {
        plugin: tag.to_string(),
        what: "a valid random draw of its parameters and prior box".into(),
    }
}

/// Run trial `seed`.
pub fn trial(seed: u64) -> Result<(Spec, Outcome)> {
    let spec = random_chain(seed)?;
    debug_assert_eq!(spec.model.structure, Structure::Wiener);
    let outcome = match pipeline_run(&spec) {
        Ok(smid_core::Outcome::Consistent(id)) if !id.model.member_outside_bounds().is_empty() => {
            Outcome::Missed(format!(
                "the certified simulation member lies outside the bounds: {}",
                id.model.member_outside_bounds().join(", ")
            ))
        }
        Ok(smid_core::Outcome::Consistent(id)) => match id.all_contain_truth() {
            Some(true) => Outcome::Contained,
            _ => Outcome::Missed(format!(
                "bounds: {}",
                id.parameters()
                    .iter()
                    .filter(|p| p.contains == Some(false))
                    .map(|p| format!("{} ∌ {:?}", p.name, p.truth))
                    .collect::<Vec<_>>()
                    .join(", ")
            )),
        },
        Ok(smid_core::Outcome::Falsified(f)) => Outcome::Missed(format!(
            "the true chain was found inconsistent: {}",
            f.message()
        )),
        Err(e) => Outcome::NoBound(e.to_string()),
    };
    Ok((spec, outcome))
}

fn pipeline_run(spec: &Spec) -> Result<smid_core::Outcome<smid_core::pipeline::Identification>> {
    crate::link_plugins();
    smid_core::pipeline::run(spec, std::path::Path::new("."))
}
