//! Debug one Monte Carlo trial: `cargo run --release --example debug_trial SEED`.
use smid::montecarlo::Trial;
use smid_core::inversion::InnerKind;
use smid_core::pipeline;
use smid_core::plant::SimulatedPlant;
use smid_core::spec::EivMethod;
fn main() {
    let seed: u64 = std::env::args()
        .nth(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or(1);
    let t = Trial::random(seed);
    println!("{t:?}");
    let mut spec = t.spec();
    spec.method.eiv = EivMethod::Classical;
    let mut plant = SimulatedPlant {
        linear: t.linear.clone(),
        nonlinearity: &t.backlash,
        structure: Default::default(),
        input: &[],
        output: &[],
        effects: &[],
        dt: 1.0,
        feedback: false,
    };
    let data = pipeline::simulate_experiments(&spec, &mut plant).unwrap();
    let x = data.records[0].x.clone().unwrap();
    let w = data.records[0].w.clone().unwrap();
    let truth = plant_truth(&t);
    match pipeline::identify(&spec, data.clone(), &truth).and_then(smid_core::Outcome::into_result)
    {
        Ok(id) => {
            print!("{}", smid_core::report::table(&id));
            for (tt, (b, xv)) in id.inner.iter().zip(&x).enumerate() {
                if b.interval.is_finite() && !b.interval.contains(*xv) {
                    println!(
                        "t={tt} x={xv} bound={:?} y={} y_prev={} w={} w_prev={}",
                        b,
                        data.records[0].y[tt],
                        data.records[0].y[tt.saturating_sub(1)],
                        w[tt],
                        w[tt.saturating_sub(1)]
                    );
                }
            }
            let _ = InnerKind::Band;
        }
        Err(e) => println!("error: {e}"),
    }
}
fn plant_truth(t: &Trial) -> Vec<(String, f64)> {
    use smid_core::plant::Plant;
    SimulatedPlant {
        linear: t.linear.clone(),
        nonlinearity: &t.backlash,
        structure: Default::default(),
        input: &[],
        output: &[],
        effects: &[],
        dt: 1.0,
        feedback: false,
    }
    .truth()
}
