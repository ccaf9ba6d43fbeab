//! Criterion benchmarks of the loop's slow paths: the choice of the diagnosis on the
//! paper's plant at 12 bits with one undeclared effect (`examples/diagnose/12bit/`, N = 400,
//! designed steady-state points; every generated candidate identified on the training
//! records), and one any-record containment trial per registered plugin (seed 1: branch and
//! bound over the nonlinearity's prior box, N = 400, classical stage 3).
//! `cargo bench --bench loop_times`. The choice on the cascaded tanks (`examples/tanks-linear.yaml`,
//! 683 measured training rows, estimated bound, the default method) identifies every candidate
//! on the measured rows in each iteration, far more work than the other groups, so its group
//! runs only with `SMID_BENCH_TANKS=1` and `../shared/data` beside the project
//! (`SMID_BENCH_TANKS=1 cargo bench --bench loop_times -- tanks`); otherwise it says why it is
//! skipped.
use criterion::{criterion_group, criterion_main, Criterion};
use smid::closeloop;
use smid::core::diagnose::{self, Options};
use smid::plugin_check::plugins;
use std::path::Path;

fn bench(c: &mut Criterion) {
    let mut group = c.benchmark_group("diagnosis choice, paper plant at 12 bits");
    group.sample_size(10);
    for effect in ["offset", "drift", "delay"] {
        let path = format!("examples/diagnose/12bit/paper-{effect}.yaml");
        let mut src = closeloop::load_source(Path::new(&path)).expect("the 12-bit spec loads");
        let training = closeloop::training_data(&mut src).expect("training data");
        group.bench_function(effect, |b| {
            b.iter(|| {
                diagnose::choose(&src.spec, &training, &Options::default(), &|_, _| {})
                    .expect("the diagnosis chooses")
            })
        });
    }
    group.finish();

    tanks(c);

    let mut group = c.benchmark_group("any-record trial (seed 1)");
    group.sample_size(10);
    for plugin in plugins() {
        let plugin = plugin.as_str();
        group.bench_function(plugin, |b| {
            b.iter(|| smid::plugin_check::trial(plugin, 1, None, true).expect("the trial runs"))
        });
    }
    group.finish();
}

/// The diagnosis's choice on the cascaded tanks' training rows (opt-in: see the module doc).
fn tanks(c: &mut Criterion) {
    let spec = Path::new("examples/tanks-linear.yaml");
    let data = Path::new("../shared/data/cascaded-tanks/tanks_estimation.csv");
    if std::env::var("SMID_BENCH_TANKS").as_deref() != Ok("1") {
        eprintln!("diagnosis choice, cascaded tanks: skipped (minutes per iteration; set SMID_BENCH_TANKS=1 to run it)");
        return;
    }
    if !data.exists() {
        eprintln!(
            "diagnosis choice, cascaded tanks: skipped ({} is absent)",
            data.display()
        );
        return;
    }
    let mut src = closeloop::load_source(spec).expect("the tanks spec loads");
    let training = closeloop::training_data(&mut src).expect("training data");
    let mut group = c.benchmark_group("diagnosis choice, cascaded tanks");
    group.sample_size(10);
    group.bench_function("tanks-linear", |b| {
        b.iter(|| {
            diagnose::choose(&src.spec, &training, &Options::default(), &|_, _| {})
                .expect("the diagnosis chooses")
        })
    });
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
