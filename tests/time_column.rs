//! Time columns in CSV records: steady-state points take their sample time from one (so a
//! drift can be identified from measured steady-state points), a dynamic record's must be
//! evenly spaced by `dt`, and a point off the grid is an error naming the file, row and column.
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
