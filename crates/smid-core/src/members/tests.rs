//! Tests of members: a member inside the loop (`model.feedback`).
use super::*;
use crate::nonlinearity::{Nonlinearity, Structure};
use rand::{Rng, SeedableRng};
use serde::{Deserialize, Serialize};

/// `min(s, x)`: memoryless, clips from above.
#[derive(Debug, Serialize, Deserialize)]
struct Clip(f64);
#[typetag::serde(name = "members_test_clip")]
impl Nonlinearity for Clip {
    fn step(&self, _m: &mut Vec<f64>, x: f64) -> f64 {
        x.min(self.0)
    }
}

/// `w_t = k w_{t-1} + (1 - k) x_t`: a block with memory.
#[derive(Debug, Serialize, Deserialize)]
struct Lag(f64);
#[typetag::serde(name = "members_test_lag")]
impl Nonlinearity for Lag {
    fn initial_memory(&self) -> Vec<f64> {
        vec![0.0]
    }
    fn step(&self, m: &mut Vec<f64>, x: f64) -> f64 {
        m[0] = self.0 * m[0] + (1.0 - self.0) * x;
        m[0]
    }
}

fn feedback_point(rng: &mut impl Rng, with_lag: bool) -> ModelPoint {
    let na = rng.gen_range(1..=3);
    let poles: Vec<f64> = (0..na).map(|_| rng.gen_range(-0.8..0.9)).collect();
    let nb = rng.gen_range(0..=2);
    let output: Vec<Box<dyn Nonlinearity>> = if with_lag {
        vec![Box::new(Lag(rng.gen_range(0.1..0.7)))]
    } else {
        Vec::new()
    };
    ModelPoint {
        structure: Structure::Wiener,
        nonlinearity: Box::new(Clip(rng.gen_range(0.3..1.0))),
        input: Vec::new(),
        output,
        linear: LinearModel {
            a: crate::linear::from_real_poles(&poles),
            b: (0..=nb).map(|_| rng.gen_range(-1.0..1.0)).collect(),
        },
        nk: rng.gen_range(0..=2),
        feedback: true,
        extras: Vec::new(),
        psi: Vec::new(),
        effects: Vec::new(),
        effect_cells: Vec::new(),
    }
}

/// With feedback, a member's free run is the built-in plant's closed loop (an independent
/// stepping of the same equations), blocks with memory included; its `k`-step prediction of
/// memoryless blocks is the brute-force one: `k` steps from the measured past at each `t`.
#[test]
fn a_feedback_member_runs_the_plants_loop_and_predicts_from_the_measured_past() {
    for seed in 0..40u64 {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        let with_lag = seed % 2 == 0;
        let p = feedback_point(&mut rng, with_lag);
        let n = rng.gen_range(30..120);
        let u: Vec<f64> = (0..n).map(|_| rng.gen_range(-2.0..2.0)).collect();
        let mut plant = crate::plant::SimulatedPlant {
            linear: p.linear.clone(),
            nonlinearity: p.nonlinearity.as_ref(),
            structure: Structure::Wiener,
            input: &[],
            output: &p.output,
            effects: &[],
            dt: 1.0,
            feedback: true,
        };
        // The plant's input is the linear block's (the delay is the member's).
        let v = p.linear_input(&u);
        let truth = crate::plant::Plant::run(&mut plant, &v).unwrap();
        let sim = p.simulate(&u, 1.0);
        for t in 0..n {
            assert!(
                (sim.y[t] - truth[t]).abs() <= 1e-12 * (1.0 + truth[t].abs()),
                "seed {seed}, t = {t}: {} against the plant's {}",
                sim.y[t],
                truth[t]
            );
        }
        assert!(
            sim.y.iter().zip(&sim.x).any(|(w, x)| (w - x).abs() > 1e-9),
            "seed {seed}: the loop never clips: the test is vacuous"
        );
        if with_lag {
            continue;
        }
        // Measured outputs: the truth with noise; k steps from them.
        let y: Vec<f64> = truth
            .iter()
            .map(|w| w + rng.gen_range(-0.05..0.05))
            .collect();
        let na = p.linear.a.len();
        // Predicted from the first equation whose inputs are all in the record.
        let first = na.max(p.linear.b.len() - 1 + p.nk);
        for k in [1usize, 2, 5] {
            let pred = p.predict(&u, Some(&y), 1.0, k, 0).y;
            for t in (k + first - 1)..n {
                let start = t + 1 - k;
                let mut w: Vec<f64> = y[..start].to_vec();
                for s in start..=t {
                    let mut x = 0.0;
                    for (j, b) in p.linear.b.iter().enumerate() {
                        x += b * v[s - j];
                    }
                    for (i, a) in p.linear.a.iter().enumerate() {
                        x -= a * w[s - 1 - i];
                    }
                    w.push(p.nonlinearity.simulate(&[x])[0]);
                }
                assert!(
                    (pred[t] - w[t]).abs() <= 1e-12 * (1.0 + w[t].abs()),
                    "seed {seed}, k = {k}, t = {t}: {} against {}",
                    pred[t],
                    w[t]
                );
            }
        }
    }
}
