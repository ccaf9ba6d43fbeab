//! Stage 3 (paper Section 5) per method against the record length N: the inner-signal
//! bounds of `examples/paper.yaml` (na = nb = 2, unit gain) with `experiment.dynamic.length = N`
//! are computed once per N (stages 1-2), then each method bounds θ from them.
//! `cargo bench --bench scaling [--features sdp]`.
//!
//! The suite is sampled to stay short: N = 1e3 and 1e4 for every method, N = 1e5 only for the
//! classical method unless `SMID_BENCH_LARGE=1` is set (at that length the relaxations take
//! far longer than the classical LP, and criterion repeats each run ten times). The
//! whole-process table, with peak memory and the growth exponent, is
//! `cargo run --release --example scaling` (docs/performance.md).
use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, SamplingMode};
use smid::core::interval::Interval;
use smid::core::pipeline;
use smid::core::spec::{EivMethod, Spec};
use smid::core::stage3::{self, EivProblem};
use std::path::Path;
use std::time::Duration;

fn bench(c: &mut Criterion) {
    let large = std::env::var("SMID_BENCH_LARGE").is_ok_and(|v| v == "1");
    let mut g = c.benchmark_group("stage3 scaling (paper.yaml, na = nb = 2)");
    g.sample_size(10)
        .sampling_mode(SamplingMode::Flat)
        .measurement_time(Duration::from_secs(5));
    for n in [1_000usize, 10_000, 100_000] {
        let mut spec: Spec = smid::load_spec(Path::new("examples/paper.yaml")).expect("parses");
        spec.experiment.dynamic.length = n;
        spec.method.eiv = EivMethod::Classical;
        let id = pipeline::run(&spec, Path::new("examples"))
            .expect("identifies")
            .unwrap();
        let input: Vec<Interval> = id.data.records[0]
            .u
            .iter()
            .map(|&v| Interval::new(v, v))
            .collect();
        let fixed = spec.fixed_theta().expect("fixed entries");
        for m in EivMethod::registered()
            .into_iter()
            .filter(|m| m.available())
        {
            if n >= 100_000 && m != EivMethod::Classical && !large {
                continue;
            }
            // As `smid run` sets it: band-bounded samples for every method but the classical.
            let prob = EivProblem {
                locate: true,
                na: 2,
                nb: 2,
                fixed: fixed.clone(),
                unit_gain: true,
                output: &id.inner,
                input: &input,
                use_band_samples: m != EivMethod::Classical,
                extra: &[],
                prior: None,
                lagged: None,
            };
            g.bench_with_input(BenchmarkId::new(m.name(), n), &prob, |b, p| {
                b.iter(|| stage3::solve(m, p).expect("bounds"))
            });
        }
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
