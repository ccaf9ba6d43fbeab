//! Stage 3 up close: shared-error bounds, the exact-grid outer and inner hulls, their times and
//! LP counts, per parameter with the truth.
//! - Section 6 example: `cargo run --release --example exact_probe BITS SEED [SEED..]`
//! - Monte Carlo trials (`smid check`): `cargo run --release --example exact_probe mc SEED [SEED..]`
//! - `DEPTH=d` sets the grid depth; `SDP=1` (with `--features sdp`) prints the moment
//!   relaxation's bounds instead.
use smid_core::interval::Interval;
use smid_core::pipeline;
use smid_core::spec::EivMethod;
use smid_core::stage3::exact_grid::{self, ExactOptions};
use smid_core::stage3::{self, EivProblem};
use std::path::Path;
fn main() {
    smid::link_plugins();
    let mc = std::env::args().nth(1).as_deref() == Some("mc");
    let args: Vec<u64> = std::env::args()
        .skip(1)
        .filter_map(|s| s.parse().ok())
        .collect();
    let bits = args.first().copied().unwrap_or(8) as u32;
    for &seed in args.iter().skip(if mc { 0 } else { 1 }) {
        let (spec, id) = if mc {
            let t = smid::montecarlo::Trial::random(seed);
            let mut spec = t.spec();
            spec.method.eiv = EivMethod::Classical;
            let mut plant = smid_core::plant::SimulatedPlant {
                linear: t.linear.clone(),
                nonlinearity: &t.backlash,
                structure: Default::default(),
                input: &[],
                output: &[],
                effects: &[],
                dt: 1.0,
                feedback: false,
            };
            let id = pipeline::run_with_plant(&spec, &mut plant)
                .unwrap()
                .unwrap();
            (spec, id)
        } else {
            let spec = smid::reproduce::paper_spec(bits, seed).unwrap();
            let id = pipeline::run(&spec, Path::new(".")).unwrap().unwrap();
            (spec, id)
        };
        let input: Vec<Interval> = id.data.records[0]
            .u
            .iter()
            .map(|&v| Interval::new(v, v))
            .collect();
        let prob = EivProblem {
            locate: true,
            na: 2,
            nb: 2,
            fixed: spec.fixed_theta().unwrap(),
            unit_gain: true,
            output: &id.inner,
            input: &input,
            use_band_samples: true,
            extra: &[],
            prior: None,
            lagged: None,
        };
        let t0 = std::time::Instant::now();
        let shared = stage3::solve(EivMethod::Shared, &prob).unwrap();
        let t1 = t0.elapsed();
        if std::env::var("SDP").is_ok() {
            let t = std::time::Instant::now();
            let r = stage3::solve(EivMethod::Sdp, &prob);
            println!(
                "sdp {:?}: {:?}",
                t.elapsed(),
                r.as_ref()
                    .map(|r| r.bounds.iter().map(|b| (b.lo, b.hi)).collect::<Vec<_>>())
            );
            println!(
                "shared: {:?}",
                shared
                    .bounds
                    .iter()
                    .map(|b| (b.lo, b.hi))
                    .collect::<Vec<_>>()
            );
            continue;
        }
        let depth = std::env::var("DEPTH")
            .ok()
            .and_then(|d| d.parse().ok())
            .unwrap_or(7);
        let ex = exact_grid::solve_from(
            &prob,
            &shared,
            &ExactOptions {
                depth,
                ..ExactOptions::default()
            },
            || {},
        )
        .unwrap();
        let t2 = t0.elapsed() - t1;
        println!(
            "{} seed {seed}: shared {t1:?}, exact {t2:?}, {} LPs, anchor {:?}",
            if mc {
                "trial".to_string()
            } else {
                format!("n_bit {bits}")
            },
            ex.cell_lps,
            ex.anchor
        );
        let names = prob.names();
        let truth: Vec<f64> = names
            .iter()
            .map(|n| id.parameter(n).and_then(|p| p.truth).unwrap_or(f64::NAN))
            .collect();
        for k in [0usize, 1, 3, 4] {
            let s = shared.bounds[k];
            let o = ex.outer[k];
            let i = ex.inner[k];
            println!(
                "  θ{k}: truth {:.5} shared [{:.6},{:.6}] outer [{:.6},{:.6}] inner {:?}  r_s/r_i {:.3}",
                truth[k], s.lo, s.hi, o.lo, o.hi,
                i.map(|i| (i.lo, i.hi)),
                i.map(|i| s.radius() / i.radius()).unwrap_or(f64::NAN)
            );
        }
    }
}
