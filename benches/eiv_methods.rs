//! Speed of the stage-3 methods (paper Section 5) on the Section 6 example
//! (`examples/paper.yaml`, n_bit = 10, seed 1): the classical orthant LP, the shared-error
//! relaxation (the default), the moment relaxation (`--features sdp`), the exact-grid
//! reference, and the whole pipeline with the default method, whose target is under one second
//! in release mode: `cargo bench --bench eiv_methods [--features sdp]`.
use criterion::{criterion_group, criterion_main, Criterion};
use smid::core::interval::Interval;
use smid::core::pipeline;
use smid::core::spec::{EivMethod, Spec};
use smid::core::stage3::{self, EivProblem};
use std::path::Path;
use std::time::Duration;

fn paper(bits: Option<u32>, method: EivMethod) -> Spec {
    let mut spec = Spec::parse(
        smid::reproduce::PAPER_SPEC,
        Path::new("examples/paper.yaml"),
    )
    .expect("bundled spec parses");
    if let Some(b) = bits {
        spec.noise.encoder_bits = Some(b);
        spec.noise.delta = None;
    }
    spec.method.eiv = method;
    spec
}

fn bench(c: &mut Criterion) {
    let mut g = c.benchmark_group("eiv");
    g.sample_size(10).measurement_time(Duration::from_secs(10));
    // The whole pipeline (experiments, stages 1-3) on examples/paper.yaml, default method.
    let spec = paper(None, EivMethod::default());
    g.bench_function("pipeline_paper_default_method", |b| {
        b.iter(|| {
            pipeline::run(&spec, Path::new("."))
                .expect("identifies")
                .unwrap()
        })
    });
    // Stage 3 alone on the same inner-signal bounds, n_bit = 10.
    let spec = paper(Some(10), EivMethod::Classical);
    let id = pipeline::run(&spec, Path::new("."))
        .expect("identifies")
        .unwrap();
    let input: Vec<Interval> = id.data.records[0]
        .u
        .iter()
        .map(|&v| Interval::new(v, v))
        .collect();
    let fixed = spec.fixed_theta().expect("fixed");
    let prob = |band: bool| EivProblem {
        locate: true,
        na: 2,
        nb: 2,
        fixed: fixed.clone(),
        unit_gain: true,
        output: &id.inner,
        input: &input,
        use_band_samples: band,
        extra: &[],
        prior: None,
        lagged: None,
    };
    g.bench_function("stage3_classical_nbit10", |b| {
        b.iter(|| stage3::solve(EivMethod::Classical, &prob(false)).expect("bounds"))
    });
    g.bench_function("stage3_shared_nbit10", |b| {
        b.iter(|| stage3::solve(EivMethod::Shared, &prob(true)).expect("bounds"))
    });
    // The moment relaxation (shared start included), with `--features sdp`.
    if EivMethod::Sdp.available() {
        g.bench_function("stage3_sdp_nbit10", |b| {
            b.iter(|| stage3::solve(EivMethod::Sdp, &prob(true)).expect("bounds"))
        });
    }
    // The exact-grid reference (shared start included, depth 7, inner hull).
    g.bench_function("stage3_exact_grid_nbit10", |b| {
        b.iter(|| stage3::solve(EivMethod::ExactGrid, &prob(true)).expect("bounds"))
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
