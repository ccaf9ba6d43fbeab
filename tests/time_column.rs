//! Time columns in CSV records: steady-state points take their sample time from one (so a
//! drift can be identified from measured steady-state points), a dynamic record's must be
//! evenly spaced by `dt`, and a point off the grid is an error naming the file, row and column.
mod common;
use smid_core::pipeline;
use std::fmt::Write as _;

fn write(dir: &std::path::Path, steady_t: &[f64], dyn_t_step: f64) -> std::path::PathBuf {
    let mut ss = String::from("u,y,time\n");
    for (k, t) in steady_t.iter().enumerate() {
        let u = 0.6 + 0.1 * k as f64 * if k % 2 == 0 { 1.0 } else { -1.0 };
        let _ = writeln!(ss, "{u},{},{t}", 0.25 * u);
    }
    std::fs::write(dir.join("steady.csv"), ss).unwrap();
    let mut d = String::from("u,y,time\n");
    for k in 0..40 {
        let _ = writeln!(
            d,
            "{},{},{}",
            (k as f64).sin(),
            0.1 * (k as f64).cos(),
            dyn_t_step * k as f64
        );
    }
    std::fs::write(dir.join("dyn.csv"), d).unwrap();
    let spec = "plant:\n  data:\n    dt: 0.5\n    steady_state: { file: steady.csv, u: u, y: y, t: time }\n    dynamic: { file: dyn.csv, u: u, y: y, t: time }\nnoise: { delta: 0.01 }\nexperiment: { filter: { pole: 0.5 } }\nmodel: { nonlinearity: { type: output_backlash }, na: 1, nb: 1 }\nmethod: { alpha: zero }\n";
    let p = dir.join("spec.yaml");
    std::fs::write(&p, spec).unwrap();
    p
}

#[test]
fn steady_state_points_take_their_sample_time_from_the_time_column() {
    let dir = tempfile::tempdir().unwrap();
    let p = write(dir.path(), &[0.0, 10.0, 20.5, 31.0, 40.0, 52.5], 0.5);
    let spec = smid::load_spec(&p).unwrap();
    let data = pipeline::load_data(&spec, dir.path()).unwrap();
    let times: Vec<Option<usize>> = data.steady.unwrap().points.iter().map(|p| p.time).collect();
    assert_eq!(
        times,
        [Some(0), Some(20), Some(41), Some(62), Some(80), Some(105)]
    );
}

#[test]
fn off_grid_times_are_errors_naming_the_row_and_column() {
    let dir = tempfile::tempdir().unwrap();
    let p = write(dir.path(), &[0.0, 10.0, 20.3, 31.0], 0.5);
    let spec = smid::load_spec(&p).unwrap();
    let e = pipeline::load_data(&spec, dir.path())
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("steady.csv") && e.contains("data row 2") && e.contains("`time`"),
        "{e}"
    );
    let p = write(dir.path(), &[0.0, 10.0, 20.0, 30.0], 0.4);
    let spec = smid::load_spec(&p).unwrap();
    let e = pipeline::load_data(&spec, dir.path())
        .unwrap_err()
        .to_string();
    assert!(e.contains("dyn.csv") && e.contains("evenly spaced"), "{e}");
}

/// `smid simulate --experiment` (`simulate::export_experiment`) writes a simulated spec's
/// training experiment and held-out records as measured data: read back through the spec it
/// writes, every steady-state point (value and sample time) and every record sample is the
/// simulated one to the bit, and the held-out records are the ones `smid diagnose` draws by
/// default (seeds `experiment.seed + 1000 + k`, the dynamic length). The steady-state points
/// keep the height of the step that led to each (a shuffled design's), so α and the
/// identification are the simulator's: the same verdict, the same bounds to the bit.
#[test]
fn an_exported_experiment_reads_back_as_the_simulated_data() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    // The 12-bit offset: at 2|ū| for every step, α lets the declared model through (consistent);
    // with the design's heights the data falsify it, as from the simulator.
    for name in [
        "paper-drift.yaml",
        "paper-delay.yaml",
        "12bit/paper-offset.yaml",
    ] {
        let path = root.join("examples/diagnose").join(name);
        let spec = smid::load_spec(&path).unwrap();
        let dir = tempfile::tempdir().unwrap();
        let e = smid::simulate::export_experiment(&spec, root, 2, dir.path()).unwrap();
        assert_eq!(e.files.len(), 5, "{name}: {:?}", e.files);
        let read = pipeline::load_data(&e.spec, dir.path()).unwrap();
        let mut plant = pipeline::builtin_plant(&spec).unwrap();
        let sim = pipeline::simulate_experiments(&spec, &mut plant).unwrap();
        let (a, b) = (read.steady.unwrap(), sim.steady.unwrap());
        assert_eq!(a.points.len(), b.points.len(), "{name}");
        for (p, q) in a.points.iter().zip(&b.points) {
            assert_eq!((p.u, p.y, p.time), (q.u, q.y, q.time), "{name}");
            assert_eq!(p.rising, q.u > 0.0, "{name}");
            assert_eq!(p.step, q.step, "{name}");
        }
        assert_eq!(read.records[0].u, sim.records[0].u, "{name}");
        assert_eq!(read.records[0].y, sim.records[0].y, "{name}");
        let held = smid::closeloop::fresh_records(
            &spec,
            root,
            &[],
            spec.experiment.seed + 1000,
            spec.experiment.dynamic.length,
            2,
        )
        .unwrap();
        let files: Vec<_> = (0..2)
            .map(|k| dir.path().join(format!("holdout{k}.csv")))
            .collect();
        let back = smid::closeloop::fresh_records(&e.spec, dir.path(), &files, 0, 0, 0).unwrap();
        for (h, r) in held.iter().zip(&back) {
            assert_eq!((&h.u, &h.y), (&r.u, &r.y), "{name}");
        }
        let verdict = |o: smid_core::outcome::Outcome<pipeline::Identification>| match o {
            smid_core::outcome::Outcome::Consistent(id) => format!(
                "{:?}",
                id.model
                    .parameters
                    .iter()
                    .map(|p| (p.name.clone(), p.lower, p.upper))
                    .collect::<Vec<_>>()
            ),
            smid_core::outcome::Outcome::Falsified(f) => f.to_string(),
        };
        let from_csv = smid::run_spec(&e.spec, dir.path(), &|_| {}).unwrap();
        if name.starts_with("12bit") {
            assert!(from_csv.falsification().is_some(), "{name}");
        }
        let simulated = smid::run_spec(&spec, root, &|_| {}).unwrap();
        assert_eq!(verdict(from_csv), verdict(simulated), "{name}");
    }
}

/// A step column is read for steady-state points only, and its heights must be positive; the
/// errors name the file, the column and the row.
#[test]
fn step_columns_are_checked() {
    let dir = tempfile::tempdir().unwrap();
    let p = write(dir.path(), &[0.0, 10.0, 20.0, 30.0], 0.5);
    let with = |ss: &str, dy: &str| {
        let text = std::fs::read_to_string(&p)
            .unwrap()
            .replace(
                "t: time }\n    dynamic",
                &format!("t: time{ss} }}\n    dynamic"),
            )
            .replace("t: time }\nnoise", &format!("t: time{dy} }}\nnoise"));
        let q = dir.path().join("with-step.yaml");
        std::fs::write(&q, text).unwrap();
        let spec = smid::load_spec(&q).unwrap();
        pipeline::load_data(&spec, dir.path())
    };
    // Other columns stand in for heights: the times start at 0 (no height), `u` is positive.
    let e = with(", step: time", "").unwrap_err().to_string();
    assert!(
        e.contains("steady.csv") && e.contains("steady-state point 0") && e.contains("`time`"),
        "{e}"
    );
    let ok = with(", step: u", "").unwrap();
    let steady = ok.steady.unwrap();
    assert!(steady.points.iter().all(|p| p.step == Some(p.u)));
    let e = with("", ", step: u").unwrap_err().to_string();
    assert!(
        e.contains("dyn.csv") && e.contains("steady-state points only"),
        "{e}"
    );
}

/// Exporting a spec whose filter pole the Appendix search finds on the plant, with the
/// `design` α that needs the plant's overshoot: the exported spec states the designed pole and
/// the paper's α (`bias`) and says so in its notes, carries the plant's truth, and its
/// identification from the files holds that truth.
#[test]
fn an_exported_designed_experiment_states_its_pole_and_alpha() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    let spec = smid::load_spec(&root.join("examples/paper.yaml")).unwrap();
    assert!(spec.experiment.filter.pole.is_none());
    let dir = tempfile::tempdir().unwrap();
    let e = smid::simulate::export_experiment(&spec, root, 1, dir.path()).unwrap();
    let mut plant = pipeline::builtin_plant(&spec).unwrap();
    let sim = pipeline::simulate_experiments(&spec, &mut plant).unwrap();
    assert_eq!(
        e.spec.experiment.filter.pole,
        Some(sim.filter.unwrap().pole)
    );
    assert_eq!(e.spec.method.alpha, smid_core::spec::AlphaSpec::Bias);
    assert_eq!(e.notes.len(), 2, "{:?}", e.notes);
    assert_eq!(e.spec.plant.truth.get("m_l"), Some(&0.248));
    let id = smid::run_spec(&e.spec, dir.path(), &|_| {})
        .unwrap()
        .unwrap();
    assert_eq!(id.all_contain_truth(), Some(true));
}

/// `data.csv` (what `smid run` writes) carries each steady-state point's step height and time:
/// rerun from it as measured data, a shuffled design (whose steps differ from the paper's
/// 2|ū|) with a drift-free offset declared gives the bounds of the run that wrote it, to the
/// digit.
#[test]
fn a_rerun_from_data_csv_keeps_the_step_heights() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read_to_string(root.join("examples/diagnose/12bit/paper-offset.yaml"))
        .unwrap()
        .replace(
            "  fixed: { b0: 0.0 }",
            "  fixed: { b0: 0.0 }\n  effects: [ { type: offset } ]\n  prior: { offset: [-1.0, 1.0] }",
        );
    let mut spec = smid::parse_spec(&text, std::path::Path::new("paper12-offset+offset")).unwrap();
    spec.method.member.search = false;
    let id = smid::run_spec(&spec, root, &|_| {}).unwrap().unwrap();
    let steady = id.data.steady.as_ref().unwrap();
    assert!(steady
        .points
        .iter()
        .any(|p| p.step_height() != 2.0 * p.u.abs()));
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("data.csv"),
        smid_core::report::data_csv(&id),
    )
    .unwrap();
    let mut v = serde_json::to_value(&spec).unwrap();
    v["plant"] = serde_json::json!({ "data": {
        "steady_state": { "file": "data.csv", "u": "u", "y": "y", "t": "t", "step": "step", "part": "steady" },
        "dynamic": { "file": "data.csv", "u": "u", "y": "y", "part": "dynamic" },
    }});
    let rerun: smid_core::spec::Spec = serde_json::from_value(v).unwrap();
    let again = smid::run_spec(&rerun, dir.path(), &|_| {})
        .unwrap()
        .unwrap();
    common::assert_same_bounds(&id, &again);
}
