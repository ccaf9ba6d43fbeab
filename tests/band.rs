//! The guaranteed one-step band ([`smid_core::band`]) on random problems drawn from
//! the plugin registry of the containment check: for every plugin, random linear blocks and
//! parameters (`PluginTrial`), identified from their designed experiment, then a fresh record
//! of the same plant with a random input (binary or multilevel PRBS, random length, amplitude
//! and hold) and noise uniform in the identified bound. The band must hold the plant's
//! noise-free output at every sample and be finite at a good share of them.
use rand::{Rng, SeedableRng};
use smid::montecarlo::{any_record, Trial};
use smid::plugin_check::{plugins, simulator, PluginTrial};
use smid_core::band::one_step_band;
use smid_core::linear::LinearModel;
use smid_core::model::Record;
use smid_core::noise;
use smid_core::nonlinearity::{Nonlinearity, Structure};
use smid_core::pipeline;
use smid_core::plant::Plant;
use smid_core::signals;

#[test]
fn the_guaranteed_band_holds_the_true_output_on_random_plants_of_every_plugin() {
    smid::link_plugins();
    let mut checked = 0;
    let cases = plugins();
    for plugin in cases.iter().map(String::as_str) {
        // Two trials from the designed experiment, one from a record alone (the branch and
        // bound over the nonlinearity's prior box: a band over many cells).
        for (seed, any) in [(11u64, false), (12, false), (13, true)] {
            let (mut spec, nl, linear, structure, amplitude) = draw(plugin, seed);
            if any {
                any_record(&mut spec, &nl.parameters(), seed);
                // A small budget keeps the test short: looser cells, the same guarantee.
                spec.method.cells.max_cells = 150;
                spec.method.member.search = false;
            }
            let mut plant = simulator(linear, nl.as_ref(), structure);
            let id = pipeline::run_with_plant(&spec, &mut plant)
                .unwrap_or_else(|e| panic!("{plugin} seed {seed}: {e}"))
                .unwrap();
            let delta = id.model.delta;
            let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(1000 + seed);
            let n = rng.gen_range(60..160);
            let amp = amplitude * rng.gen_range(0.5..1.5);
            let hold = rng.gen_range(1..4);
            let u = if rng.gen_bool(0.5) {
                signals::prbs(n, amp, hold, &mut rng)
            } else {
                signals::multilevel(n, amp, hold, 4, &mut rng)
            };
            let w = plant.run(&u).unwrap();
            let e = noise::uniform(n, delta, &mut rng);
            let y: Vec<f64> = w.iter().zip(&e).map(|(a, b)| a + b).collect();
            let rec = Record {
                name: format!("{plugin}-{seed}-fresh"),
                u,
                y,
                dy: vec![delta; n],
                dt: 1.0,
                w: Some(w.clone()),
                x: None,
                noise: Some(e),
                history: None,
            };
            let band = one_step_band(&id.model, &rec).unwrap();
            for t in 0..n {
                assert!(
                    band.lower[t] <= w[t] && w[t] <= band.upper[t],
                    "{plugin} seed {seed}, sample {t}: the true output {} is outside the band [{}, {}]",
                    w[t],
                    band.lower[t],
                    band.upper[t]
                );
            }
            // Finite at a third of the samples at least (a saturated output leaves the inner
            // signal before it unknown, and with it the prediction: no band there).
            let (finite, _) = band.finite(0);
            assert!(
                3 * finite >= n,
                "{plugin} seed {seed}: the band is finite at {finite}/{n} samples"
            );
            checked += 1;
        }
    }
    assert_eq!(checked, 3 * cases.len());
}

/// A random problem of `plugin`: its spec, the true nonlinearity and linear block, the
/// structure and the PRBS amplitude of its experiment.
fn draw(
    plugin: &str,
    seed: u64,
) -> (
    smid_core::spec::Spec,
    Box<dyn Nonlinearity>,
    LinearModel,
    Structure,
    f64,
) {
    if plugin == "output_backlash" {
        let t = Trial::random(seed);
        let spec = t.spec();
        let amplitude = spec.experiment.dynamic.amplitude;
        return (
            spec,
            Box::new(t.backlash),
            t.linear.clone(),
            Structure::Wiener,
            amplitude,
        );
    }
    let trial = PluginTrial::random(plugin, seed).unwrap();
    let (structure, amplitude) = (trial.structure, trial.amplitude);
    let (spec, nl, linear) = trial.spec();
    (spec, nl, linear, structure, amplitude)
}
