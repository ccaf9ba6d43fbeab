//! Every failure of an FMU plant is a typed error naming the FMU, the variable and the time; the
//! process does not crash, and the plant recovers for the next run.
mod common;
use common::*;
use smid_core::plant::Plant;
use smid_core::SmidError;
use smid_fmu::{FmuConfig, FmuError, FmuErrorKind, FmuPlant};
use std::collections::BTreeMap;
use std::io::Write;
use std::path::{Path, PathBuf};

fn config(path: &Path) -> FmuConfig {
    FmuConfig {
        path: path.to_path_buf(),
        label: None,
        input: Some("u".into()),
        output: Some("w".into()),
        step: Some(1.0),
        parameters: BTreeMap::new(),
    }
}

fn load_err(c: &FmuConfig) -> FmuError {
    match FmuPlant::load(c) {
        Ok(_) => panic!("loading {} should fail", c.path.display()),
        Err(e) => e,
    }
}

/// A zip with the given entries.
fn zip_with(dir: &Path, name: &str, entries: &[(&str, Vec<u8>)]) -> PathBuf {
    let p = dir.join(name);
    let mut z = zip::ZipWriter::new(std::fs::File::create(&p).unwrap());
    for (n, bytes) in entries {
        z.start_file(*n, zip::write::SimpleFileOptions::default())
            .unwrap();
        z.write_all(bytes).unwrap();
    }
    z.finish().unwrap();
    p
}

fn paper_xml() -> Vec<u8> {
    std::fs::read(Path::new(smid_fmu::BUNDLED_SOURCE_DIR).join("paper/modelDescription.xml"))
        .unwrap()
}

#[test]
fn missing_file() {
    let e = load_err(&config(Path::new("/nonexistent/plant.fmu")));
    assert!(matches!(e.kind, FmuErrorKind::NotFound(_)), "{e}");
    assert!(e.to_string().contains("/nonexistent/plant.fmu"), "{e}");
}

#[test]
fn not_a_zip() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("text.fmu");
    std::fs::write(&p, "this is not an FMU").unwrap();
    let e = load_err(&config(&p));
    assert!(matches!(e.kind, FmuErrorKind::NotZip(_)), "{e}");
    assert!(e.to_string().contains("text.fmu"), "{e}");
}

#[test]
fn zip_without_model_description() {
    let dir = tempfile::tempdir().unwrap();
    let p = zip_with(dir.path(), "empty.fmu", &[("readme.txt", b"hi".to_vec())]);
    let e = load_err(&config(&p));
    assert!(matches!(e.kind, FmuErrorKind::NotZip(_)), "{e}");
    assert!(e.to_string().contains("modelDescription.xml"), "{e}");
}

#[test]
fn no_linux64_binary() {
    let dir = tempfile::tempdir().unwrap();
    let p = zip_with(
        dir.path(),
        "nobin.fmu",
        &[("modelDescription.xml", paper_xml())],
    );
    let e = load_err(&config(&p));
    match &e.kind {
        FmuErrorKind::NoBinary { expected } => {
            assert!(expected.contains("binaries/linux64/paper"), "{e}")
        }
        other => panic!("expected NoBinary, got {other:?}"),
    }
}

#[test]
fn fmi_version_other_than_2() {
    let dir = tempfile::tempdir().unwrap();
    let xml = String::from_utf8(paper_xml())
        .unwrap()
        .replace("fmiVersion=\"2.0\"", "fmiVersion=\"3.0\"");
    let p = zip_with(
        dir.path(),
        "v3.fmu",
        &[("modelDescription.xml", xml.into())],
    );
    let e = load_err(&config(&p));
    match &e.kind {
        FmuErrorKind::Version { found } => assert_eq!(found, "3.0"),
        other => panic!("expected Version, got {other:?}"),
    }
    assert!(e.to_string().contains("FMI version 3.0"), "{e}");
}

#[test]
fn unknown_variables_and_parameters() {
    let mut c = config(&smid_fmu::bundled_fmu("paper"));
    c.output = Some("nope".into());
    let e = load_err(&c);
    assert!(
        matches!(&e.kind, FmuErrorKind::Variable { role: "output", name, .. } if name == "nope"),
        "{e}"
    );
    assert!(e.to_string().contains("w, x"), "lists the outputs: {e}");

    let mut c = config(&smid_fmu::bundled_fmu("paper"));
    c.input = Some("w".into());
    let e = load_err(&c);
    assert!(
        matches!(&e.kind, FmuErrorKind::Variable { role: "input", .. }),
        "an output is not an input: {e}"
    );

    let mut c = config(&smid_fmu::bundled_fmu("paper"));
    c.parameters.insert("m_x".into(), 1.0);
    let e = load_err(&c);
    assert!(
        matches!(&e.kind, FmuErrorKind::Variable { role: "parameter", name, .. } if name == "m_x"),
        "{e}"
    );
    assert!(e.to_string().contains("m_l"), "lists the parameters: {e}");

    let mut c = config(&smid_fmu::bundled_fmu("paper"));
    c.step = Some(0.0);
    assert!(matches!(load_err(&c).kind, FmuErrorKind::Config { .. }));
}

fn faulty(kind: f64) -> FmuPlant {
    let mut c = config(&smid_fmu::bundled_fmu("faulty"));
    c.output = Some("y".into());
    c.step = Some(0.01);
    c.parameters.insert("fail_at".into(), 0.05);
    c.parameters.insert("fail_kind".into(), kind);
    FmuPlant::load(&c).unwrap()
}

#[test]
fn error_status_names_call_variable_time_and_fmu_log() {
    let mut plant = faulty(1.0);
    let e = plant.simulate_from_rest(&[1.0; 20]).unwrap_err();
    match &e.kind {
        FmuErrorKind::Status {
            call,
            status,
            time,
            sample,
            variable,
            log,
        } => {
            assert_eq!(*call, "fmi2DoStep");
            assert_eq!(status, "fmi2Error");
            assert_eq!(*sample, 5);
            assert!((time - 0.05).abs() < 1e-12);
            assert_eq!(variable.as_deref(), Some("y"));
            assert!(
                log.iter().any(|l| l.contains("injected failure")),
                "{log:?}"
            );
        }
        other => panic!("expected Status, got {other:?}"),
    }
    // Through the Plant trait it is a SmidError::Plant naming the FMU.
    match plant.run(&[1.0; 20]) {
        Err(SmidError::Plant { plant: p, message }) => {
            assert!(p.contains("faulty.fmu"), "{p}");
            assert!(message.contains("t = 0.05"), "{message}");
        }
        other => panic!("expected SmidError::Plant, got {other:?}"),
    }
    // The failed instance is replaced: a run that ends before the failure succeeds.
    assert_eq!(plant.run(&[1.0; 3]).unwrap().len(), 3);
}

#[test]
fn non_finite_outputs_are_errors() {
    for (kind, what) in [(2.0, "NaN"), (3.0, "inf")] {
        let mut plant = faulty(kind);
        let e = plant.simulate_from_rest(&[1.0; 20]).unwrap_err();
        match &e.kind {
            FmuErrorKind::NonFinite {
                role,
                variable,
                value,
                sample,
                ..
            } => {
                assert_eq!(*role, "output");
                assert_eq!(variable, "y");
                assert_eq!(*sample, 5);
                assert!(!value.is_finite());
            }
            other => panic!("expected NonFinite, got {other:?}"),
        }
        assert!(e.to_string().contains(what), "{e}");
        assert!(plant.run(&[1.0; 3]).is_ok());
    }
}

#[test]
fn non_finite_input_is_an_error() {
    let mut plant = bundled("paper", "w", 1.0, paper_params());
    let e = plant.simulate_from_rest(&[0.0, 1.0, f64::NAN]).unwrap_err();
    assert!(
        matches!(
            &e.kind,
            FmuErrorKind::NonFinite {
                role: "input",
                sample: 2,
                ..
            }
        ),
        "{e}"
    );
}

#[test]
fn parameter_rejected_by_the_fmu() {
    let mut p = paper_params();
    p.insert("m_l".into(), -1.0);
    let mut plant = bundled("paper", "w", 1.0, p);
    let e = plant.simulate_from_rest(&[1.0; 4]).unwrap_err();
    match &e.kind {
        FmuErrorKind::Status { call, log, .. } => {
            assert_eq!(*call, "fmi2ExitInitializationMode");
            assert!(log.iter().any(|l| l.contains("`m_l`")), "{log:?}");
        }
        other => panic!("expected Status, got {other:?}"),
    }
}

#[test]
fn spec_paths_resolve_against_the_spec_directory() {
    let src = Path::new(smid_fmu::BUNDLED_SOURCE_DIR);
    // A bundled source directory stands for the FMU built from it.
    let p = smid_fmu::resolve_path(Path::new("paper"), src).unwrap();
    assert_eq!(p, smid_fmu::bundled_fmu("paper"));
    // A plain relative file path is joined to the base.
    let p = smid_fmu::resolve_path(Path::new("x/plant.fmu"), Path::new("/base")).unwrap();
    assert_eq!(p, Path::new("/base/x/plant.fmu"));
    // Any other directory is not an FMU.
    let dir = tempfile::tempdir().unwrap();
    let e = smid_fmu::resolve_path(Path::new("."), dir.path()).unwrap_err();
    assert!(matches!(e.kind, FmuErrorKind::NotAnFmu(_)), "{e}");
}
