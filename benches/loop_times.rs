//! Criterion benchmarks of the loop's slow paths (issue 28): the choice of the diagnosis on the
//! paper's plant at 12 bits with one undeclared effect (`examples/diagnose/12bit/`, N = 400,
//! designed steady-state points; every generated candidate identified on the training
//! records), and one any-record containment trial per registered plugin (seed 1: branch and
//! bound over the nonlinearity's prior box, N = 400, classical stage 3).
//! `cargo bench --bench loop_times`.
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

criterion_group!(benches, bench);
criterion_main!(benches);
