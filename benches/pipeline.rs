//! Criterion benchmark of the whole pipeline on `examples/paper.yaml` (Appendix filter search,
//! steady-state and PRBS experiments, stages 1-3), with the spec's own stage-3 method and with
//! the classical one; and the branch and bound from one record (the paper's
//! Section 6 plant at 12 bits, no steady-state experiment, N = 400 and N = 2000,
//! `examples/tightness/any-*.yaml`; target under 30 s at N = 2000 on 2 cores).
//! `cargo bench --bench pipeline`.
use criterion::{criterion_group, criterion_main, Criterion};
use smid_core::pipeline;
use smid_core::spec::EivMethod;
use std::path::Path;

fn bench(c: &mut Criterion) {
    let spec =
        smid::load_spec(Path::new("examples/paper.yaml")).expect("examples/paper.yaml parses");
    c.bench_function("paper.yaml whole pipeline (spec method)", |b| {
        b.iter(|| pipeline::run(&spec, Path::new(".")).expect("pipeline runs"))
    });
    let mut classical = smid::load_spec(Path::new("examples/paper.yaml")).expect("parses");
    classical.method.eiv = EivMethod::Classical;
    c.bench_function("paper.yaml whole pipeline (classical)", |b| {
        b.iter(|| pipeline::run(&classical, Path::new(".")).expect("pipeline runs"))
    });
    let mut group = c.benchmark_group("branch and bound from one record (12 bits)");
    group.sample_size(10);
    for n in [400, 2000] {
        let path = format!("examples/tightness/any-{n}.yaml");
        let spec = smid::load_spec(Path::new(&path)).expect("tightness spec parses");
        group.bench_function(format!("N = {n}"), |b| {
            b.iter(|| pipeline::run(&spec, Path::new("examples/tightness")).expect("runs"))
        });
    }
    group.finish();
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(20);
    targets = bench
}
criterion_main!(benches);
