//! Closing the loop on the one model: what `smid run` identifies is what `validate` checks and
//! `diagnose` extends. A fresh record of the same plant is consistent with the identified set
//! and the free run fits it; a record with an effect the model lacks falsifies it at a named
//! sample; `result.json` carries the whole model set; the diagnosis names a missing effect from
//! the training data alone and reads the held-out records only for the final table.
mod common;

use smid::closeloop;
use smid::core::diagnose::{self, Options};
use smid::core::pipeline;
use smid::core::plant::SimulatedPlant;
use smid::core::settings::Check;
use smid::core::validate::{self, Validation};
use std::path::{Path, PathBuf};

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn validate_on(model: &smid::core::model::ModelSet, fresh: &[pipeline::Record]) -> Validation {
    validate::validate(model, fresh, &validate::Options::default()).unwrap()
}

#[test]
fn the_paper_model_validates_on_a_fresh_record_and_beats_the_arx_baseline() {
    let path = root().join("examples/paper.yaml");
    let id = smid::run_spec_file(&path).unwrap().unwrap();
    let spec = smid::load_spec(&path).unwrap();
    let fresh =
        closeloop::fresh_records(&spec, &root().join("examples"), &[], 1001, 200, 1).unwrap();
    let v = validate_on(&id.model, &fresh);
    assert!(v.consistency.consistent, "{:?}", v.consistency);
    assert!(
        v.pass,
        "smallest bound {:?} vs {}",
        v.smallest_bound, v.bound
    );
    let (lo, hi) = v.smallest_bound.unwrap();
    assert!(lo <= hi && hi <= v.bound);
    assert!(v.free_run.fit_percent > 99.0, "{:?}", v.free_run);
    assert!(v.free_run.fit_percent > v.baseline.unwrap().fit_percent);
    assert!(v.warnings.is_empty(), "{:?}", v.warnings);
    assert_eq!(v.series.len(), 1);
    let (l, u) = &v.series[0].envelope;
    assert!(l.iter().zip(u).all(|(a, b)| a <= b));
}

#[test]
fn a_fresh_record_too_short_for_one_equation_pair_is_refused_by_name() {
    let path = root().join("examples/paper.yaml");
    let id = smid::run_spec_file(&path).unwrap().unwrap();
    let spec = smid::load_spec(&path).unwrap();
    let fresh =
        closeloop::fresh_records(&spec, &root().join("examples"), &[], 1001, 200, 1).unwrap();
    // na = 2, nb = 2: three samples hold one equation, four hold two.
    for (n, refused) in [(1, true), (3, true), (4, false)] {
        let mut r = fresh[0].clone();
        r.u.truncate(n);
        r.y.truncate(n);
        r.dy.truncate(n);
        for v in [&mut r.w, &mut r.x, &mut r.noise].into_iter().flatten() {
            v.truncate(n);
        }
        r.name = format!("short-{n}");
        let v = validate::validate(&id.model, &[r], &validate::Options::default());
        match v {
            Err(e) if refused => {
                let e = e.to_string();
                assert!(
                    e.contains(&format!("short-{n}")) && e.contains("too short"),
                    "{e}"
                );
            }
            Ok(_) if !refused => {}
            other => panic!("{n} samples: {:?}", other.map(|v| v.consistency)),
        }
    }
}

#[test]
fn a_record_with_an_undeclared_delay_falsifies_the_model_at_a_sample() {
    let path = root().join("examples/paper.yaml");
    let id = smid::run_spec_file(&path).unwrap().unwrap();
    let spec = smid::load_spec(&path).unwrap();
    let sim = spec.plant.simulator.as_ref().unwrap();
    let delay: Vec<Box<dyn smid::core::effect::Effect>> =
        vec![serde_norway::from_str("{type: delay, samples: 1}").unwrap()];
    let mut plant = SimulatedPlant {
        linear: sim.linear(),
        nonlinearity: sim.nonlinearity.as_ref(),
        structure: sim.structure,
        input: &sim.input,
        output: &sim.output,
        effects: &delay,
        dt: 1.0,
        feedback: false,
    };
    let fresh = pipeline::fresh_record(&spec, &mut plant, 1001, 200).unwrap();
    let v = validate_on(&id.model, std::slice::from_ref(&fresh));
    assert!(!v.consistency.consistent);
    let f = v.consistency.falsified_at.as_ref().unwrap();
    assert_eq!(f.record, 0);
    assert!(f.sample < 200);
    assert!(!v.pass);
    assert!(v.smallest_bound.unwrap().0 > v.bound);

    // Behind a clean record, the same record is named as the second one, at a sample inside it.
    let mut clean_plant = SimulatedPlant {
        effects: &[],
        ..plant
    };
    let clean = pipeline::fresh_record(&spec, &mut clean_plant, 1002, 300).unwrap();
    let v = validate_on(&id.model, &[clean, fresh]);
    let g = v.consistency.falsified_at.as_ref().unwrap();
    assert_eq!(g.record, 1, "{g:?}");
    assert!(g.sample < 200, "{g:?}");
}

#[test]
fn result_json_carries_the_whole_model_set() {
    let path = root().join("examples/paper.yaml");
    let spec = smid::load_spec(&path).unwrap();
    let id = smid::run_spec_file(&path).unwrap().unwrap();
    let dir = tempfile::tempdir().unwrap();
    smid::write_run(&id, &spec, path.parent().unwrap(), dir.path()).unwrap();
    let src = closeloop::load_source(&dir.path().join("result.json")).unwrap();
    let back = src.model.unwrap();
    assert_eq!(back.parameters, id.model.parameters);
    assert_eq!(back.cells.len(), id.model.cells.len());
    assert_eq!(back.training.records[0].y, id.data.records[0].y);
    assert_eq!(
        src.base,
        std::fs::canonicalize(root().join("examples")).unwrap()
    );
    let fresh = closeloop::fresh_records(&src.spec, &src.base, &[], 1001, 150, 1).unwrap();
    let a = validate_on(&id.model, &fresh);
    let b = validate_on(&back, &fresh);
    assert_eq!(a.smallest_bound, b.smallest_bound);
    assert_eq!(a.free_run.rms, b.free_run.rms);
    // A file of another kind, of a format version this smid does not read, or without the
    // stamp is refused by the field at fault, naming the file, the versions read and the
    // version of smid that wrote it, instead of being misread (tests/output_reference.rs
    // checks the same through the CLI).
    let text = std::fs::read_to_string(dir.path().join("result.json")).unwrap();
    let mut v: serde_json::Value = serde_json::from_str(&text).unwrap();
    assert_eq!(v["format"], "smid.result");
    let current = v["format_version"]
        .as_u64()
        .expect("result.json states its format version");
    assert!(
        v["smid_version"].is_string(),
        "result.json states the version that wrote it"
    );
    // The version named is the file's, not the reader's.
    let written = "0.0.0-old";
    v["smid_version"] = serde_json::json!(written);
    let refused = |v: &serde_json::Value| -> smid::SmidError {
        match closeloop::source_from_json(&v.to_string(), Path::new("old/result.json")) {
            Ok(_) => panic!(
                "a result of another format was read: {}",
                v["format_version"]
            ),
            Err(e) => e,
        }
    };
    v["format_version"] = serde_json::json!(current + 1);
    let e = refused(&v);
    assert!(matches!(&e, smid::SmidError::Format { field, .. } if field == "format_version"));
    let e = e.to_string();
    assert!(
        e.contains("old/result.json")
            && e.contains(&format!("found {}", current + 1))
            && e.contains(&format!("format_version {current}"))
            && e.contains(written)
            && e.contains("`smid run`"),
        "{e}"
    );
    v["format_version"] = serde_json::json!("1");
    let e = refused(&v).to_string();
    assert!(e.contains("field `format_version`: found \"1\""), "{e}");
    v["format_version"] = serde_json::json!(current);
    v["format"] = serde_json::json!("smid.validation");
    let e = refused(&v).to_string();
    assert!(
        e.contains("field `format`: found \"smid.validation\"") && e.contains("`smid.result`"),
        "{e}"
    );
    v["format"] = serde_json::json!("smid.result");
    v.as_object_mut().unwrap().remove("format_version");
    let e = refused(&v).to_string();
    assert!(e.contains("field `format_version`: missing"), "{e}");
}

fn training_of(spec_path: &Path) -> (smid::core::spec::Spec, pipeline::ExperimentData) {
    let mut src = closeloop::load_source(spec_path).unwrap();
    let data = closeloop::training_data(&mut src).unwrap();
    (src.spec, data)
}

fn only(tags: &[&str]) -> Options {
    Options {
        only: tags.iter().map(|t| t.to_string()).collect(),
        ..Default::default()
    }
}

#[test]
fn the_diagnosis_names_an_undeclared_delay_and_adds_nothing_when_nothing_is_missing() {
    let (spec, data) = training_of(&root().join("examples/diagnose/paper-delay.yaml"));
    let c = diagnose::choose(
        &spec,
        &data,
        &only(&["delay", "actuator_lag", "extra_zero"]),
        &|_, _| {},
    )
    .unwrap();
    assert_eq!(c.added, vec!["one more sample of delay".to_string()]);
    assert!(c.after_admissible);
    assert_eq!(c.after.layout().unwrap().orders.nk, 1);
    let round = &c.rounds[0];
    assert!(round.candidates.iter().filter(|e| e.chosen).count() == 1);

    // The paper's own spec: its training data are consistent, nothing is added.
    let (spec, data) = training_of(&root().join("examples/paper.yaml"));
    let c = diagnose::choose(&spec, &data, &only(&["delay", "actuator_lag"]), &|_, _| {}).unwrap();
    assert!(c.added.is_empty() && c.after_admissible, "{}", c.summary());
    assert!(c.summary().starts_with("no missing effect found"));
    // A misspelt tag is refused by name (it would leave no candidate to try).
    let e = diagnose::choose(&spec, &data, &only(&["delay", "dleay"]), &|_, _| {})
        .expect_err("an unknown tag is refused")
        .to_string();
    assert!(
        e.contains("`dleay`") && e.contains("delay") && e.contains("output_backlash"),
        "{e}"
    );
    // One round tells the equivalent explanations apart from the model as declared; it adds
    // nothing, and whatever it lists as equivalent was identified and admitted.
    assert_eq!(c.rounds.len(), 1);
    assert!(c.rounds[0].candidates.iter().all(|e| !e.chosen));
    for (label, _, set) in &c.equivalent_models {
        let e = c.rounds[0]
            .candidates
            .iter()
            .find(|e| &e.label == label)
            .unwrap();
        assert!(e.train.admissible() && !set.cells.is_empty(), "{label}");
        assert!(e.equivalent_to.iter().any(|l| l == diagnose::AS_DECLARED));
    }
}

/// The choice is made on the training records only: corrupting the held-out record changes
/// the final table but not the chosen model (the CLI writes both).
#[test]
fn corrupting_the_held_out_records_does_not_change_the_chosen_model() {
    let exe = env!("CARGO_BIN_EXE_smid");
    let spec = root().join("examples/diagnose/paper-delay.yaml");
    let dir = tempfile::tempdir().unwrap();
    let sim = std::process::Command::new(exe)
        .args([
            "simulate",
            spec.to_str().unwrap(),
            "--seed",
            "77",
            "--length",
            "200",
        ])
        .args(["--out", dir.path().to_str().unwrap(), "--name", "held"])
        .output()
        .unwrap();
    assert!(
        sim.status.success(),
        "{}",
        String::from_utf8_lossy(&sim.stderr)
    );
    let good = dir.path().join("held.csv");
    let bad = dir.path().join("corrupt.csv");
    let text = std::fs::read_to_string(&good).unwrap();
    let mut lines = text.lines();
    let mut corrupt = format!("{}\n", lines.next().unwrap());
    for (k, l) in lines.enumerate() {
        let f: Vec<&str> = l.split(',').collect();
        let y = if k % 7 == 3 {
            5.0
        } else {
            -f[2].parse::<f64>().unwrap()
        };
        corrupt.push_str(&format!("{},{},{y},{}\n", f[0], f[1], f[3]));
    }
    std::fs::write(&bad, corrupt).unwrap();
    let run = |held: &Path, out: &str| {
        let o = std::process::Command::new(exe)
            .args([
                "diagnose",
                spec.to_str().unwrap(),
                "--only",
                "delay,actuator_lag",
            ])
            .args(["--holdout", held.to_str().unwrap()])
            .args(["--out", dir.path().join(out).to_str().unwrap()])
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let json = smid::core::output::read(
            smid::core::output::OutputKind::Diagnosis,
            &dir.path().join(out).join("diagnosis.json"),
        )
        .unwrap();
        let aug = std::fs::read_to_string(dir.path().join(out).join("augmented.yaml")).unwrap();
        (json, aug)
    };
    let (a, aug_a) = run(&good, "a");
    let (b, aug_b) = run(&bad, "b");
    assert_eq!(aug_a, aug_b);
    assert_eq!(a["choice"], b["choice"]);
    assert!(aug_a.contains("type: delay"));
    // The held-out records were read for the table: the corrupted ones falsify the model.
    assert_eq!(a["after"]["validation"]["consistency"]["consistent"], true);
    assert_eq!(b["after"]["validation"]["consistency"]["consistent"], false);
}

#[test]
fn priors_and_effects_are_checked_with_named_fields() {
    smid::link_plugins();
    let base = std::fs::read_to_string(root().join("examples/paper.yaml")).unwrap();
    let with = |model_extra: &str| {
        let text = base.replace(
            "  fixed: { b0: 0.0 }\n",
            &format!("  fixed: {{ b0: 0.0 }}\n{model_extra}"),
        );
        smid::core::spec::Spec::parse(&text, Path::new("t.yaml"))
            .err()
            .map(|e| e.to_string())
            .unwrap_or_default()
    };
    let e = with("  effects: [ { type: offset } ]\n");
    assert!(e.contains("model.prior.offset"), "{e}");
    let e = with("  effects: [ { type: offset } ]\n  prior: { ofset: [0, 1] }\n");
    assert!(e.contains("model.prior"), "{e}");
    let e = with("  effects: [ { type: offset } ]\n  prior: { offset: [1, 0] }\n");
    assert!(e.contains("lo <= hi"), "{e}");
    let e = with("  effects: [ { type: offset }, { type: drift } ]\n  prior: { offset: [0, 1], drift: [0, 1] }\n");
    assert!(e.contains("offset"), "{e}");
    let e = with("  effects: [ { type: wobble } ]\n");
    assert!(e.contains("wobble") && e.contains("delay"), "{e}");
    // A simulator effect without its true value names the field.
    let text = base.replace(
        "    nonlinearity: { type: output_backlash, m_l",
        "    effects: [ { type: actuator_lag } ]\n    nonlinearity: { type: output_backlash, m_l",
    );
    let e = smid::core::spec::Spec::parse(&text, Path::new("t.yaml"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("plant.simulator.effects[0].pole"), "{e}");
}

#[test]
fn a_declared_offset_is_bounded_around_the_truth_by_the_branch_and_bound() {
    let path = root().join("examples/diagnose/paper-offset.yaml");
    let mut spec = smid::load_spec(&path).unwrap();
    spec.model.effects = vec![serde_norway::from_str("{type: offset}").unwrap()];
    spec.model.prior.insert("offset".into(), [-0.05, 0.05]);
    let id = smid::run_spec(&spec, &root().join("examples/diagnose"), &|_| {})
        .unwrap()
        .unwrap();
    assert_eq!(id.all_contain_truth(), Some(true));
    let off = id.parameter("offset").unwrap();
    assert!(off.lower > -0.05 && off.upper < 0.05, "{off:?}");
    assert!(id.model.cells.len() > 1);
    assert!(!id.model.search.budget_stopped);
    // The linear block stays tight although the offset trades against the half-plays.
    assert!(id.parameter("a1").unwrap().radius < 2e-3);
}

/// Every run example (the specs in `examples/`; `examples/diagnose/` holds training data with
/// an undeclared effect by design) validates on a fresh record of its own plant: CONSISTENT,
/// PASS, and its free run fits. The same record with its noise scaled down to a fraction of
/// what the plant drew (`y = w + s·e`, `s` per example) is admitted by the truth at its largest
/// noise, so no check of the smallest consistent bound (each starting from the bounds of a
/// larger one) may prove it inconsistent there.
///
/// Without `slow-checks` (CI) the examples with the largest searches are left out: the FMU
/// drive and the FMU with effects (an FMU stepped sample by sample), the fourth-order model,
/// the chain with blocks on both sides and the gain bisected from any record. Every other
/// example runs, among them an FMU plant, the SDP relaxation and a chain with a block after
/// the backlash.
#[test]
fn every_run_example_validates_on_a_fresh_record_of_its_plant() {
    const SLOW: [&str; 5] = [
        "fmu-drive.yaml",
        "fmu-effects.yaml",
        "order4.yaml",
        "hammerstein-wiener.yaml",
        "example-gain-any.yaml",
    ];
    let paths = common::yaml_files(&root().join("examples"));
    for name in SLOW {
        assert!(paths.iter().any(|p| p.ends_with(name)), "no example {name}");
    }
    // The examples side by side (each run is mostly sequential work); `true` for one validated.
    use rayon::prelude::*;
    let validated = |i: usize, path: &std::path::PathBuf| -> bool {
        if !common::SLOW_CHECKS && SLOW.iter().any(|s| path.ends_with(s)) {
            eprintln!("skipping {}: run by scripts/test-slow", path.display());
            return false;
        }
        let text = std::fs::read_to_string(path).unwrap();
        if text.contains("\n  data:") {
            eprintln!(
                "skipping {}: measured data, no plant to draw a fresh record from (validated on its held-out records in measured_examples_validate_on_their_held_out_rows)",
                path.display()
            );
            return false;
        }
        if text.contains("\n  fmu:") && !cfg!(feature = "fmu") {
            eprintln!(
                "skipping {}: built without the `fmu` feature",
                path.display()
            );
            return false;
        }
        if text.contains("eiv: sdp") && !smid::core::stage3::EivMethod::Sdp.available() {
            eprintln!(
                "skipping {}: built without the `sdp` feature",
                path.display()
            );
            return false;
        }
        let mut src = closeloop::load_source(path).unwrap();
        let id = smid::run_spec(&src.spec, &src.base, &|_| {})
            .unwrap_or_else(|e| panic!("{}: {e}", path.display()))
            .unwrap();
        src.model = Some(id.model);
        let length = src.spec.experiment.dynamic.length;
        let fresh = closeloop::fresh_records(&src.spec, &src.base, &[], 1001, length, 1).unwrap();
        let v = validate_on(src.model.as_ref().unwrap(), &fresh);
        assert!(
            v.consistency.consistent && v.pass,
            "{}: {:?} {:?}",
            path.display(),
            v.consistency,
            v.smallest_bound
        );
        // The same record with its noise scaled to a fraction s in [0.2, 0.7) of what the
        // plant drew (a fixed, varied draw from the example's index): `y = w + s·e`. The
        // smallest consistent bound's proven end never lies above the largest noise it
        // carries (the bisection starts each check from the last consistent one's bounds,
        // which must stay guaranteed), and its consistent end is at most the bound.
        let delta = src.model.as_ref().unwrap().delta;
        let s = 0.2 + 0.5 * ((i as f64 * 0.618_033_988_75).fract());
        let (scaled, noise) = noise_scaled(&fresh, delta, s);
        let (lo, hi) = validate::smallest_bound(src.model.as_ref().unwrap(), &scaled, 0.02, None)
            .unwrap()
            .expect("consistent at the model's bound");
        assert!(
            lo <= noise * (1.0 + 1e-9) && lo <= hi && hi <= delta,
            "{}: [{lo:e}, {hi:e}], the record's largest noise {noise:e} (scale {s}), bound {delta:e}",
            path.display()
        );
        assert!(
            v.free_run.fit_percent > 95.0,
            "{}: {:?}",
            path.display(),
            v.free_run
        );
        // The guaranteed one-step band holds the plant's noise-free output at every sample,
        // and is finite at most of them (a band that is everywhere infinite guarantees nothing).
        for (s, rec) in v.series.iter().zip(&fresh) {
            let (lo, hi) = s.band.as_ref().expect("validate computes the band");
            let w = rec
                .w
                .as_ref()
                .expect("a simulated record carries its noise-free output");
            let mut finite = 0;
            for t in 0..w.len() {
                assert!(
                    lo[t] <= w[t] && w[t] <= hi[t],
                    "{}: sample {t}: the true output {} is outside the band [{}, {}]",
                    path.display(),
                    w[t],
                    lo[t],
                    hi[t]
                );
                finite += usize::from(lo[t].is_finite() && hi[t].is_finite());
            }
            assert!(
                2 * finite >= w.len(),
                "{}: the band is finite at {finite}/{} samples",
                path.display(),
                w.len()
            );
        }
        true
    };
    let n = paths
        .par_iter()
        .enumerate()
        .filter(|(i, p)| validated(*i, p))
        .count();
    assert!(n >= 7, "only {n} examples validated");
}

/// The measured-data examples, identified with the default stage-3 method at their estimated
/// bound from their training rows, validate on their held-out rows (read once, here):
/// CONSISTENT, PASS, and a guaranteed one-step band that no measurement contradicts. Their
/// free run is compared with the least-squares ARX of the same orders plus a constant.
/// - The tanks (the overflow inside the loop, the bound from the free run: docs/case-studies.md):
///   a certified member, with a fit of at least 72 % on the held-out rows, and above the
///   baseline. Its set is wide (the bound is the model's free-run error), so its band is not
///   asked to be finite.
/// - EMPS (the Coulomb friction the baseline lacks, the bound from the relaxation): more than
///   3 points above the baseline, with a band finite at almost every sample.
#[test]
fn measured_examples_validate_on_their_held_out_rows() {
    struct Case {
        spec: &'static str,
        held_out: &'static str,
        above_baseline: f64,
        at_least: f64,
        band_finite: bool,
        certified: bool,
    }
    let cases = [
        Case {
            spec: "examples/tanks.yaml",
            held_out: "../shared/data/cascaded-tanks/tanks_estimation.csv@683..1024",
            above_baseline: 0.0,
            at_least: 72.0,
            band_finite: false,
            certified: true,
        },
        Case {
            spec: "examples/emps.yaml",
            held_out: "../shared/data/emps/emps_train.csv@15000..24841",
            above_baseline: 3.0,
            at_least: f64::NEG_INFINITY,
            band_finite: true,
            certified: false,
        },
    ];
    // The two side by side (each run is mostly sequential work). They are the longest runs of
    // the suite (the estimate and the member search on measured records), so they run under
    // `slow-checks` alone; without it (CI) the tanks' rows are read by the stand-in test below.
    if !common::SLOW_CHECKS {
        println!("skipped: the measured examples run under scripts/test-slow");
        return;
    }
    use rayon::prelude::*;
    cases.par_iter().for_each(|c| {
        let spec_path = c.spec;
        let data = root().join(c.held_out.split('@').next().unwrap());
        if !data.exists() {
            eprintln!("skipping {spec_path}: {} is absent", data.display());
            return;
        }
        let path = root().join(spec_path);
        let mut src = closeloop::load_source(&path).unwrap();
        let id = smid::run_spec(&src.spec, &src.base, &|_| {})
            .unwrap_or_else(|e| panic!("{spec_path}: {e}"))
            .unwrap();
        if c.certified {
            let m = id.model.simulation_member.as_ref();
            assert!(
                m.is_some_and(|m| m.certified),
                "{spec_path}: the member is not certified: {m:?}"
            );
        }
        src.model = Some(id.model);
        let csv = root().join(c.held_out);
        let fresh = closeloop::fresh_records(&src.spec, &src.base, &[csv], 0, 0, 1).unwrap();
        let v = validate_on(src.model.as_ref().unwrap(), &fresh);
        let base = v.baseline.expect("an ARX baseline");
        eprintln!(
            "{spec_path}: free run {:.2} % ({}), ARX+constant {:.2} %",
            v.free_run.fit_percent, v.member, base.fit_percent
        );
        assert!(
            v.free_run.fit_percent > base.fit_percent + c.above_baseline
                && v.free_run.fit_percent >= c.at_least,
            "{spec_path}: free run {:?} vs ARX {:?}",
            v.free_run,
            base
        );
        let band = v.band.as_ref().expect("validate computes the band");
        assert!(
            band.outside == 0 && (!c.band_finite || 10 * band.finite >= 9 * band.samples),
            "{spec_path}: {band:?}"
        );
        assert!(
            v.consistency.consistent && v.pass,
            "{spec_path}: {:?}",
            v.consistency
        );
    });
}

/// Where no point of a measured-data set is certified (an output saturation on the cascaded
/// tanks: its level clips half the samples, and no θ of the cell passes the exact LP), the
/// stand-in is the best training free run over the probed cells' outer bounds: labelled not
/// certified, every value inside the reported bounds, and simulating the training records no
/// worse than the set's centre. The bound is the one `noise.estimate: 1.1` gives on these rows
/// (1.155e-1), declared so that the test does not pay for the bound search (the estimate
/// is tested with the measured examples). Skips when `../shared/data/` is absent.
#[test]
fn an_uncertified_stand_in_lies_in_the_bounds_and_is_labelled() {
    let data = root().join("../shared/data/cascaded-tanks/tanks_estimation.csv");
    if !data.exists() {
        eprintln!("skipping: {} is absent", data.display());
        return;
    }
    let yaml = format!(
        "name: tanks-saturation
plant:
  data:
    dynamic: {{ file: {}, u: u_V, y: y_V, rows: [0, 683] }}
    dt: 4.0
noise: {{ delta: 0.1155 }}
model:
  structure: wiener
  nonlinearity: {{ type: linear }}
  na: 3
  nb: 3
  nk: 1
  unit_gain: false
  stable: true
  effects: [ {{ type: constant }} ]
  output: [ {{ type: saturation }} ]
  prior: {{ out1.m_l: [1.0, 1.0], out1.s_l: [40.0, 40.0], out1.m_r: [1.0, 1.0], out1.s_r: [5.0, 20.0] }}
method:
  cells: {{ nonlinearity_halvings: 3, max_cells: 2000, max_leaves: 64 }}
  member: {{ probe: 8, cells: 2, spread: false }}
",
        data.display()
    );
    let dir = std::env::temp_dir().join(format!("smid-standin-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("tanks-saturation.yaml");
    std::fs::write(&path, yaml).unwrap();
    let id = smid::run_spec_file(&path).unwrap().unwrap();
    let set = &id.model;
    let m = set
        .simulation_member
        .as_ref()
        .expect("a stand-in or a member");
    if m.certified {
        // A certified member lies in the set: inside every bound (what the checks count).
        assert!(set.member_outside_bounds().is_empty());
        return;
    }
    for (name, v) in &m.values {
        let p = set
            .parameters
            .iter()
            .find(|p| &p.name == name)
            .unwrap_or_else(|| panic!("{name} is not a reported parameter"));
        assert!(
            p.lower <= *v && *v <= p.upper,
            "{name} = {v} outside [{}, {}]",
            p.lower,
            p.upper
        );
    }
    assert!(m.envelope.is_empty(), "no envelope around a stand-in");
    assert!(
        m.training_fit >= m.centre_training_fit,
        "stand-in {} % vs centre {} %",
        m.training_fit,
        m.centre_training_fit
    );
    // The label `validate` and the reports print for the member (a whole validation on the
    // training records would only repeat it, at the cost of many LPs).
    let label = smid::core::members::representative_label(set);
    assert!(
        label.contains("NOT certified") || label.contains("not certified"),
        "{label}"
    );
}

/// A candidate asked whether it clears a bar (`pipeline::identify_below`, how an estimated
/// diagnosis skips bracketing candidates that cannot be kept): on records of a linear plant
/// with bounded noise of random sizes, every bar the data falsify lies below the bound the
/// plain identification estimates, and every bar they do not falsify gives that
/// identification, to the digit.
#[test]
fn a_bar_the_data_falsify_lies_below_the_estimated_bound_and_otherwise_changes_nothing() {
    use smid::core::outcome::Outcome;
    use smid::core::rand::{Rng, SeedableRng};
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(27_001);
    for case in 0..2 {
        let noise = rng.gen_range(0.01..0.06);
        let n = rng.gen_range(80..140);
        let levels: Vec<f64> = (0..5).map(|_| rng.gen_range(-1.0..1.0)).collect();
        let hold = rng.gen_range(3..9);
        let u: Vec<f64> = (0..n).map(|t| levels[(t / hold) % 5]).collect();
        let mut x = vec![0.0; n];
        for t in 2..n {
            x[t] = 0.6 * x[t - 1] - 0.25 * x[t - 2] + 0.4 * u[t - 1] + 0.25 * u[t - 2];
        }
        let e = smid::core::noise::uniform(n, noise, &mut rng);
        let y: Vec<f64> = x.iter().zip(&e).map(|(b, e)| b + e).collect();
        let (spec, data) = common::measured(
            "bar",
            &u,
            &y,
            "noise: { estimate: 1.1 }\n\
model:\n  structure: wiener\n  nonlinearity: { type: linear }\n  na: 2\n  nb: 2\n  fixed: { b0: 0.0 }\n  unit_gain: false\n  stable: true\n",
        );
        let plain = match pipeline::identify(&spec, data.clone(), &[]).unwrap() {
            Outcome::Consistent(id) => id,
            Outcome::Falsified(f) => panic!("case {case}: {f}"),
        };
        let d = plain.model.delta;
        for k in 0..4 {
            let bar = d * rng.gen_range(0.3..1.5) * if k == 3 { 3.0 } else { 1.0 };
            match pipeline::identify_below(&spec, data.clone(), Some(bar)).unwrap() {
                pipeline::BelowBar::Above(pipeline::AboveBar { bar: b, detail, .. }) => {
                    assert_eq!(b, bar);
                    assert!(bar < d, "case {case}: inconsistent at the bar {bar} above the estimate {d}: {detail}");
                }
                pipeline::BelowBar::Identified(Outcome::Consistent(id)) => {
                    assert_eq!(id.model.delta, d, "case {case}, bar {bar}");
                    for (a, b) in id.parameters().iter().zip(plain.parameters()) {
                        assert_eq!(
                            (a.lower, a.upper),
                            (b.lower, b.upper),
                            "case {case}: {}",
                            a.name
                        );
                    }
                }
                pipeline::BelowBar::Identified(Outcome::Falsified(f)) => {
                    panic!("case {case}: the plain identification was consistent, this one: {f}")
                }
            }
        }
        // Far below the smallest bound any stage accepts: always falsified at the bar.
        assert!(matches!(
            pipeline::identify_below(&spec, data, Some(d * 1e-3)).unwrap(),
            pipeline::BelowBar::Above(_)
        ));
    }
}

/// A model declared stable (`model.stable`) has stable members only: on records of
/// second-order plants with a pole drawn near the unit circle (some just outside it, where the
/// declared class is wrong but the data leave room), with bounded noise of random size, the
/// simulation member, whenever it is reported certified, has every root of `A` strictly inside
/// the unit circle. (Without that, a certified point whose free run runs away could be kept:
/// on the tanks with an output backlash, a training fit of -2e114 %.)
#[test]
fn a_certified_member_of_a_model_declared_stable_is_stable() {
    use smid::core::outcome::Outcome;
    use smid::core::rand::{Rng, SeedableRng};
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(27_002);
    let (mut certified, mut unstable_undeclared) = (0, 0);
    for case in 0..8 {
        let p1 = rng.gen_range(0.97..1.03);
        let p2 = rng.gen_range(0.2..0.7);
        let (a1, a2) = (-(p1 + p2), p1 * p2);
        let noise = rng.gen_range(0.02..0.1);
        let n = rng.gen_range(50..90);
        let levels: Vec<f64> = (0..4).map(|_| rng.gen_range(-1.0..1.0)).collect();
        let hold = rng.gen_range(3..8);
        let u: Vec<f64> = (0..n).map(|t| levels[(t / hold) % 4]).collect();
        let mut x = vec![0.0; n];
        for t in 2..n {
            x[t] = -a1 * x[t - 1] - a2 * x[t - 2] + 0.2 * u[t - 1];
        }
        let e = smid::core::noise::uniform(n, noise, &mut rng);
        let y: Vec<f64> = x.iter().zip(&e).map(|(b, e)| b + e).collect();
        for stable in [true, false] {
            let (spec, data) = common::measured(
                "stable",
                &u,
                &y,
                &format!("noise: {{ delta: {} }}\n\
method: {{ eiv: classical }}\n\
model:\n  structure: wiener\n  nonlinearity: {{ type: linear }}\n  na: 2\n  nb: 1\n  unit_gain: false\n  stable: {stable}\n", 1.05 * noise),
            );
            let id = match pipeline::identify(&spec, data, &[]).unwrap() {
                Outcome::Consistent(id) => id,
                Outcome::Falsified(_) => continue,
            };
            let Some(m) = id.model.simulation_member.as_ref().filter(|m| m.certified) else {
                continue;
            };
            let a: Vec<f64> = ["a1", "a2"]
                .iter()
                .map(|k| m.values.iter().find(|(n, _)| n == k).unwrap().1)
                .collect();
            let rho = smid::core::linear::spectral_radius(&a);
            if stable {
                certified += 1;
                assert!(rho < 1.0, "case {case}: certified member of a model declared stable has root radius {rho}");
            } else if rho >= 1.0 {
                unstable_undeclared += 1;
            }
        }
    }
    // Not vacuous: declared-stable members were certified, and without the declaration the
    // same kind of record gives certified members that run away.
    eprintln!("{certified} certified stable members; {unstable_undeclared} unstable ones without the declaration");
    assert!(certified >= 3 && unstable_undeclared >= 1);
}

/// `members::theta_reproducing` recovers a member's `θ` from its own linear-block output: on
/// records of random linear plants (orders, delay, poles, an equation term or none, record
/// length and levels drawn per case), the representative member of the identified set, its
/// `θ` forgotten, is fitted back from its free run's inner signal to rounding, with an equation
/// error of rounding size; a `θ` of the wrong sign in the values given is ignored (`θ` is
/// fitted, the rest is taken).
#[test]
fn theta_is_recovered_from_a_members_own_linear_block_output() {
    use smid::core::outcome::Outcome;
    use smid::core::rand::{Rng, SeedableRng};
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(25_003);
    for case in 0..6 {
        let na = rng.gen_range(1..=3usize);
        let nb = rng.gen_range(0..=2usize);
        let nk = rng.gen_range(1..=2usize);
        let constant = rng.gen_bool(0.5);
        let poles: Vec<f64> = (0..na).map(|_| rng.gen_range(-0.6..0.8)).collect();
        let mut a = vec![1.0];
        for p in &poles {
            let mut next = vec![0.0; a.len() + 1];
            for (i, c) in a.iter().enumerate() {
                next[i] += c;
                next[i + 1] -= p * c;
            }
            a = next;
        }
        let b: Vec<f64> = (0..=nb).map(|_| rng.gen_range(0.1..1.0)).collect();
        let n = rng.gen_range(80..150);
        let levels: Vec<f64> = (0..5).map(|_| rng.gen_range(-1.0..1.0)).collect();
        let hold = rng.gen_range(3..9);
        let u: Vec<f64> = (0..n).map(|t| levels[(t / hold) % 5]).collect();
        let mut x = vec![0.0; n];
        for t in 0..n {
            let mut v = if constant { 0.05 } else { 0.0 };
            for (j, bj) in b.iter().enumerate() {
                if t >= nk + j {
                    v += bj * u[t - nk - j];
                }
            }
            for i in 1..=na {
                if t >= i {
                    v -= a[i] * x[t - i];
                }
            }
            x[t] = v;
        }
        let e = smid::core::noise::uniform(n, 0.01, &mut rng);
        let y: Vec<f64> = x.iter().zip(&e).map(|(q, e)| q + e).collect();
        let effects = if constant {
            "  effects: [ { type: constant } ]\n"
        } else {
            ""
        };
        let (spec, data) = common::measured(
            "refit",
            &u,
            &y,
            &format!("noise: {{ delta: 0.0105 }}\n\
method: {{ eiv: classical }}\n\
model:\n  structure: wiener\n  nonlinearity: {{ type: linear }}\n  na: {na}\n  nb: {nb}\n  nk: {nk}\n  unit_gain: false\n{effects}"),
        );
        let set = match pipeline::identify(&spec, data, &[]).unwrap() {
            Outcome::Consistent(id) => id.model,
            Outcome::Falsified(f) => panic!("case {case}: {f}"),
        };
        let values = smid::core::members::representative_values(&set).unwrap();
        let member = smid::core::members::point(&set, &values).unwrap();
        let inner: Vec<Vec<f64>> = set
            .training
            .records
            .iter()
            .map(|r| member.simulate(&r.u, r.dt).x)
            .collect();
        let theta = set.layout().unwrap().theta_names.clone();
        // θ given wrong (negated): only the other parameters are taken.
        let given: Vec<(String, f64)> = values
            .iter()
            .map(|(k, v)| (k.clone(), if theta.contains(k) { -v } else { *v }))
            .collect();
        let (fitted, err) = smid::core::members::theta_reproducing(&set, &given, &inner)
            .unwrap()
            .expect("enough equations");
        let scale: f64 = inner.iter().flatten().map(|v| v * v).sum();
        assert!(
            err <= 1e-18 * scale.max(1.0),
            "case {case}: equation error {err} (scale {scale})"
        );
        for (k, v) in &fitted {
            let want = values.iter().find(|(n, _)| n == k).unwrap().1;
            assert!(
                (v - want).abs() <= 1e-6 * (1.0 + want.abs()),
                "case {case} (na {na}, nb {nb}, nk {nk}, constant {constant}): {k} = {v}, member has {want}"
            );
        }
        assert_eq!(fitted.len(), theta.len());
    }
}

/// `noise.estimate` with cells too coarse for the consistency test to falsify any bound (a
/// play's prior box bisected at most twice, one whole-box cell in the test): the test is asked
/// again with finer cells instead of refusing the estimate. Records of Hammerstein plants with
/// an input backlash of random plays and slopes, random multilevel inputs and bounded noise of
/// random size: the estimate exists, also where the coarse test decides nothing (at least one
/// case must be such, or the test does not exercise the refinement).
#[test]
fn an_estimate_the_coarse_test_cannot_decide_is_refined_not_refused() {
    use smid::core::outcome::Outcome;
    use smid::core::rand::{Rng, SeedableRng};
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(39_001);
    let mut undecided = 0;
    for case in 0..3 {
        let (m_l, m_r) = (rng.gen_range(0.22..0.28), rng.gen_range(0.22..0.28));
        let (c_l, c_r) = (rng.gen_range(0.02..0.12), rng.gen_range(0.02..0.12));
        let noise = rng.gen_range(0.01..0.05);
        let n = rng.gen_range(300..420);
        let levels: Vec<f64> = (0..7).map(|_| rng.gen_range(-1.0..1.0)).collect();
        let hold = rng.gen_range(2..6);
        let u: Vec<f64> = (0..n).map(|t| levels[(t / hold + t % 3) % 7]).collect();
        // The input backlash (the plugin's eq: each branch a line of slope m through ±c).
        let mut v = vec![0.0; n];
        let mut last = 0.0;
        for t in 0..n {
            if u[t] <= last / m_l - c_l {
                last = m_l * (u[t] + c_l);
            } else if u[t] >= last / m_r + c_r {
                last = m_r * (u[t] - c_r);
            }
            v[t] = last;
        }
        let mut x = vec![0.0; n];
        for t in 2..n {
            x[t] = -0.5 * x[t - 1] - 0.7 * x[t - 2] + 1.4 * v[t - 1] + 0.8 * v[t - 2];
        }
        let e = smid::core::noise::uniform(n, noise, &mut rng);
        let y: Vec<f64> = x.iter().zip(&e).map(|(b, e)| b + e).collect();
        let (spec, data) = common::measured(
            "refine",
            &u,
            &y,
            "noise: { estimate: 1.1 }\n\
model:\n  structure: hammerstein\n  nonlinearity: { type: input_backlash, at_rest: false }\n  na: 2\n  nb: 2\n  fixed: { b0: 0.0 }\n  unit_gain: true\n  \
prior: { m_l: [0.2, 0.3], c_l: [0.0, 0.15], m_r: [0.2, 0.3], c_r: [0.0, 0.15] }\n\
method:\n  eiv: classical\n  cells: { nonlinearity_halvings: 2 }\n",
        );
        // At the coarse cells, a bound far below the noise is not falsified: the coarse test
        // decides nothing on this record.
        if pipeline::consistent_at(&spec, &data, 1e-6 * noise).unwrap() {
            undecided += 1;
        }
        match pipeline::estimate_bound(&spec, &data) {
            Ok(Outcome::Consistent(d)) => assert!(
                d.is_finite() && d > 1e-6 * noise,
                "case {case}: estimate {d:e}"
            ),
            Ok(Outcome::Falsified(f)) => panic!("case {case}: {f}"),
            Err(e) => panic!("case {case}: the estimate was refused: {e}"),
        }
    }
    assert!(undecided > 0, "no case left the coarse test undecided");
}

/// A quantiser through the spec, on the paper's plant with its output rounded to a step of
/// 2e-3 (ten times the encoder's bound), the filter pole given: declared with its step, the
/// model is consistent and
/// holds the truth; left out, the data falsify the model; with the step left open (bisected
/// over a prior box), the step is bounded around the truth and every other bound holds it too.
#[test]
fn a_quantiser_declared_or_identified_through_the_spec_holds_the_truth() {
    smid::link_plugins();
    let base = std::fs::read_to_string(root().join("examples/paper.yaml")).unwrap();
    let searched = base.replace(
        "    nonlinearity: { type: output_backlash, m_l",
        "    effects: [ { type: quantization, step: 0.002 } ]\n    nonlinearity: { type: output_backlash, m_l",
    );
    let spec = |text: &str, extra: &str| {
        let text = text.replace(
            "  fixed: { b0: 0.0 }\n",
            &format!("  fixed: {{ b0: 0.0 }}\n{extra}"),
        );
        smid::core::spec::Spec::parse(&text, Path::new("t.yaml")).unwrap()
    };
    // The Appendix search sees the plant through its quantiser, which hides an overshoot
    // below the step (it accepted the pole 0.75 here, and the truth fell outside the stage-1
    // polygons): with a declared sensor map it is refused by name, and the pole is given.
    let refused = smid::run_spec(
        &spec(
            &searched,
            "  effects: [ { type: quantization, step: 0.002 } ]\n",
        ),
        &root(),
        &|_| {},
    )
    .err()
    .map(|e| e.to_string())
    .unwrap_or_default();
    assert!(refused.contains("experiment.filter.pole"), "{refused}");
    let plant = searched
        .replace("step: 3.0 }", "step: 3.0, pole: 0.8125 }")
        .replace("alpha: design", "alpha: bias");
    assert!(plant.contains("pole: 0.8125") && plant.contains("alpha: bias"));
    let run = |extra: &str| {
        smid::run_spec(&spec(&plant, extra), &root(), &|_| {})
            .unwrap()
            .consistent()
    };
    // Every bound and the stage-1 polygons hold the simulator's truth (the pipeline compares
    // them with the plant spec's true values, as the containment tests do).
    let truth_inside = |id: &smid::core::pipeline::Identification| {
        assert_eq!(
            id.all_contain_truth(),
            Some(true),
            "{:?}",
            id.model.parameters
        );
    };
    let declared = run("  effects: [ { type: quantization, step: 0.002 } ]\n")
        .expect("consistent with the declared quantiser");
    truth_inside(&declared);
    assert!(
        run("").is_none(),
        "the rounded outputs must falsify the model without the quantiser"
    );
    let open = run("  effects: [ { type: quantization } ]\n  prior: { step: [0.0008, 0.05] }\n")
        .expect("consistent with the identified quantiser");
    truth_inside(&open);
    let step = open.model.parameter("step").expect("the step is reported");
    assert!(
        step.lower <= 0.002 && 0.002 <= step.upper && step.upper - step.lower < 1e-4,
        "step [{}, {}]",
        step.lower,
        step.upper
    );
}

/// Simulated records with their noise scaled to `s` times what the plant drew (`y = w + s·e`,
/// `w` the noise-free output each carries), declared at `bound`; and the largest noise left.
fn noise_scaled(fresh: &[pipeline::Record], bound: f64, s: f64) -> (Vec<pipeline::Record>, f64) {
    let mut noise = 0.0f64;
    let scaled = fresh
        .iter()
        .map(|r| {
            let w =
                r.w.clone()
                    .expect("a simulated record carries its noise-free output");
            let mut r = r.with_bound(bound);
            for (y, w) in r.y.iter_mut().zip(&w) {
                *y = w + s * (*y - w);
                noise = noise.max((*y - w).abs());
            }
            r
        })
        .collect();
    (scaled, noise)
}

/// The other side of the vacuous end: fresh records of the paper's plant (`examples/paper.yaml`,
/// random seeds and lengths), their noise scaled to `s` times what the plant drew (`s` = 1, or
/// 1e-4: a halving that passes a thousandth of the bound before the records contradict it),
/// carry noise the model set cannot absorb, so the smallest consistent bound is not `(0, 0)`
/// (no cell admits them at a vanishing bound) and its proven end lies below the largest noise
/// they carry.
#[test]
fn records_with_noise_the_set_cannot_absorb_have_a_positive_smallest_bound() {
    use smid::core::rand::{Rng, SeedableRng};
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(67_002);
    let text = std::fs::read_to_string(root().join("examples/paper.yaml")).unwrap();
    let mut spec = smid::parse_spec(&text, Path::new("paper.yaml")).unwrap();
    spec.method.member.search = false;
    let base = root().join("examples");
    let id = smid::run_spec(&spec, &base, &|_| {}).unwrap().unwrap();
    for case in 0..4 {
        let seed = rng.gen_range(2000..3000);
        let length = rng.gen_range(80..200);
        let s = if case % 2 == 0 { 1.0 } else { 1e-4 };
        let fresh = closeloop::fresh_records(&spec, &base, &[], seed, length, 1).unwrap();
        let (fresh, noise) = noise_scaled(&fresh, id.model.delta, s);
        let (lo, hi) = validate::smallest_bound(&id.model, &fresh, 0.02, None)
            .unwrap()
            .expect("consistent at the model's bound");
        assert!(
            0.0 < lo && lo <= hi && lo <= noise * (1.0 + 1e-9),
            "case {case} (seed {seed}, length {length}, noise scaled by {s}): [{lo:e}, {hi:e}], largest noise {noise:e}"
        );
    }
}

/// A model whose cells leave stage 2's intervals wider than the noise on a fresh record (a
/// sensor drift: `offset + drift·t` over each cell) is not contradicted by the record at any
/// bound: the smallest consistent bound is then `(0, 0)`, said at once instead of halving
/// towards 0 cell after cell, and the record is, checked on its own, consistent with the set
/// at a vanishing bound.
#[test]
fn records_a_cell_admits_at_any_bound_give_a_smallest_bound_of_zero() {
    let text = std::fs::read_to_string(root().join("examples/diagnose/paper-drift.yaml"))
        .unwrap()
        .replace(
            "  fixed: { b0: 0.0 }\nmethod:",
            "  fixed: { b0: 0.0 }\n  effects: [ { type: drift } ]\n  prior: { drift: [-3.0e-5, 3.0e-5], offset: [-1.0, 1.0] }\nmethod:",
        );
    let mut spec = smid::parse_spec(&text, Path::new("paper-drift+drift")).unwrap();
    spec.method.member.search = false;
    let base = root().join("examples/diagnose");
    let id = smid::run_spec(&spec, &base, &|_| {}).unwrap().unwrap();
    let fresh = closeloop::fresh_records(&spec, &base, &[], 1001, 200, 1).unwrap();
    let fresh: Vec<_> = fresh.iter().map(|r| r.with_bound(id.model.delta)).collect();
    assert_eq!(
        validate::smallest_bound(&id.model, &fresh, 0.02, None).unwrap(),
        Some((0.0, 0.0))
    );
    let tiny: Vec<_> = fresh
        .iter()
        .map(|r| r.with_bound(1e-12 * id.model.delta))
        .collect();
    assert!(validate::consistency(&id.model, &tiny).unwrap().consistent);
}

/// A member's `within` (`members::training_within`: the largest distance of its free run from
/// any training sample) is a bound at which the model is consistent: the same model declared
/// with that bound is never falsified by the same records, whatever stage 3's relaxation (a
/// falsification there would prove that no point of the model lies that close, and the member
/// is one). Random linear plants (orders, poles, gains, record length and levels per case), half
/// of them with an equation term drawn from the registry (each registered term with a plant
/// side that reads only the input, at a random size, open in the model), noise inside 1.05 × a
/// random bound.
#[test]
fn a_members_free_run_distance_is_a_bound_at_which_the_model_is_consistent() {
    use smid::core::effect::{self, Signals};
    use smid::core::outcome::Outcome;
    use smid::core::rand::{Rng, SeedableRng};
    smid::link_plugins();
    let terms: Vec<&str> = effect::effects()
        .into_iter()
        .filter(|e| {
            let ex = (e.example)();
            ex.as_plant().is_some()
                && ex.as_equation().is_some_and(|t| !t.uses_output())
                && (e.candidates)()
                    .first()
                    .is_some_and(|c| c.as_equation().is_some_and(|t| !t.uses_output()))
        })
        .map(|e| e.tag)
        .collect();
    assert!(terms.contains(&"constant"), "{terms:?}");
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(64_001);
    let (mut checked, mut powers) = (0, 0);
    for case in 0..12 {
        let na = rng.gen_range(1..=2);
        let nb = rng.gen_range(0..=1);
        let poles: Vec<f64> = (0..na).map(|_| rng.gen_range(0.2..0.85)).collect();
        let a: Vec<f64> = if na == 1 {
            vec![-poles[0]]
        } else {
            vec![-(poles[0] + poles[1]), poles[0] * poles[1]]
        };
        let b: Vec<f64> = (0..=nb).map(|_| rng.gen_range(0.1..0.6)).collect();
        let n = rng.gen_range(60..120);
        let levels: Vec<f64> = (0..5).map(|_| rng.gen_range(-1.0..2.0)).collect();
        let hold = rng.gen_range(3..9);
        let u: Vec<f64> = (0..n).map(|t| levels[(t / hold) % 5]).collect();
        let term = (case % 2 == 1).then(|| terms[rng.gen_range(0..terms.len())]);
        let plant_term: Vec<f64> = match term {
            Some(tag) => effect::effect_entry(tag)
                .unwrap()
                .scaled_example(rng.gen_range(0.5..2.0))
                .unwrap()
                .plant_equation(&Signals::input(&u, 1.0))
                .unwrap(),
            None => vec![0.0; n],
        };
        let mut x = vec![0.0; n];
        for t in 0..n {
            let mut v = plant_term[t];
            for (i, ai) in a.iter().enumerate() {
                if t > i {
                    v -= ai * x[t - 1 - i];
                }
            }
            for (j, bj) in b.iter().enumerate() {
                if t > j {
                    v += bj * u[t - 1 - j];
                }
            }
            x[t] = v;
        }
        let noise = rng.gen_range(0.01..0.1);
        let e = smid::core::noise::uniform(n, noise, &mut rng);
        let y: Vec<f64> = x.iter().zip(&e).map(|(x, e)| x + e).collect();
        let effects = term.map_or(String::new(), |t| {
            format!("  effects: [ {{ type: {t} }} ]\n")
        });
        let spec_at = |delta: f64| {
            common::measured(
                "within",
                &u,
                &y,
                &format!(
                    "noise: {{ delta: {delta:e} }}\nmethod: {{ eiv: classical }}\n\
model:\n  structure: wiener\n  nonlinearity: {{ type: linear }}\n  na: {na}\n  nb: {nb}\n  nk: 1\n  unit_gain: false\n  stable: true\n{effects}"
                ),
            )
        };
        let (spec, data) = spec_at(1.05 * noise);
        let id = match pipeline::identify(&spec, data, &[]).unwrap() {
            Outcome::Consistent(id) => id,
            Outcome::Falsified(f) => {
                panic!("case {case} ({term:?}): the true model falsified: {f}")
            }
        };
        let Some(within) = id.model.simulation_member.as_ref().and_then(|m| m.within) else {
            panic!(
                "case {case} ({term:?}): no member distance on records without steady-state points"
            );
        };
        assert!(within.is_finite() && within >= 0.0, "case {case}: {within}");
        // The distance recomputed here, from the member's values alone: its run of the
        // model's equation from the first equation `t0 = max(na, nb + nk)`, the measured
        // outputs before it (the inner estimate of a linear Wiener model), the term's columns
        // from the model-side effect (an unknown one adds nothing).
        let m = id.model.simulation_member.as_ref().unwrap();
        let layout = id.model.layout().unwrap();
        let theta: Vec<f64> = layout
            .theta_names
            .iter()
            .map(|n| m.values.iter().find(|(k, _)| k == n).unwrap().1)
            .collect();
        let cols: Vec<Vec<f64>> = term
            .map(|tag| {
                let open = (effect::effect_entry(tag).unwrap().candidates)().remove(0);
                open.regressors(&Signals::input(&u, 1.0))
                    .into_iter()
                    .map(|c| c.values.iter().map(|v| v.center()).collect())
                    .collect()
            })
            .unwrap_or_default();
        let t0 = na.max(nb + 1);
        let mut run = y.clone();
        let mut recomputed = 0.0f64;
        for t in t0..n {
            let mut v = 0.0;
            for i in 0..na {
                v -= theta[i] * run[t - 1 - i];
            }
            for j in 0..=nb {
                v += theta[na + j] * u[t - 1 - j];
            }
            for (k, col) in cols.iter().enumerate() {
                if col[t].is_finite() {
                    v += theta[na + nb + 1 + k] * col[t];
                }
            }
            run[t] = v;
            recomputed = recomputed.max((y[t] - v).abs());
        }
        assert!(
            (within - recomputed).abs() <= 1e-9 * (1.0 + recomputed),
            "case {case} ({term:?}): the member's distance {within:e}, recomputed {recomputed:e}"
        );
        // The model declared with that bound: never falsified.
        let (spec, data) = spec_at(within * (1.0 + 1e-9) + 1e-12);
        match pipeline::identify(&spec, data, &[]).unwrap() {
            Outcome::Consistent(_) => {}
            Outcome::Falsified(f) => panic!(
                "case {case} ({term:?}): falsified at the member's distance {within:e} (noise {noise:e}): {f}"
            ),
        }
        checked += 1;
        if term == Some("input_power") {
            powers += 1;
        }
        eprintln!("case {case} ({term:?}): noise {noise:.3e}, member within {within:.3e}");
    }
    assert_eq!(checked, 12);
    assert!(powers > 0, "the polynomial path was not drawn");
}

/// `noise.from: free_run` on records a model of too low an order explains only with a larger
/// error than its equation error (random second-order plants, a first-order model, random
/// inputs and sizes). The simulator the raise starts from (`members::best_free_run` over the
/// set at the relaxation's bound) has its free-run distance recomputed here from its values
/// alone; the bound is raised to the larger of the relaxation's and 1.1 times that distance (so
/// the set holds the simulator), then brought down to 1.1 times the member's distance while
/// that takes off a tenth; the member is certified and fits the training records at least as
/// well as the simulator (it starts from it: a point of the set, certified).
#[test]
fn a_bound_from_the_free_run_holds_a_certified_simulator() {
    use smid::core::outcome::Outcome;
    use smid::core::rand::{Rng, SeedableRng};
    smid::link_plugins();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(70_001);
    let (mut raised, mut tightened) = (0, 0);
    for case in 0..6 {
        let poles: Vec<f64> = (0..2).map(|_| rng.gen_range(0.5..0.9)).collect();
        let a = [-(poles[0] + poles[1]), poles[0] * poles[1]];
        let b = rng.gen_range(0.2..0.6);
        let n = rng.gen_range(80..140);
        let levels: Vec<f64> = (0..6).map(|_| rng.gen_range(-1.0..2.0)).collect();
        let hold = rng.gen_range(4..12);
        let u: Vec<f64> = (0..n).map(|t| levels[(t / hold) % 6]).collect();
        let mut x = vec![0.0; n];
        for t in 0..n {
            let mut v = if t > 0 { b * u[t - 1] } else { 0.0 };
            for (i, ai) in a.iter().enumerate() {
                if t > i {
                    v -= ai * x[t - 1 - i];
                }
            }
            x[t] = v;
        }
        let noise = rng.gen_range(0.005..0.02);
        let e = smid::core::noise::uniform(n, noise, &mut rng);
        let y: Vec<f64> = x.iter().zip(&e).map(|(x, e)| x + e).collect();
        let spec_with = |from: &str| {
            common::measured(
                "from-free-run",
                &u,
                &y,
                &format!(
                    "noise: {{ estimate: 1.1{from} }}\nmethod: {{ eiv: classical }}\n\
model:\n  structure: wiener\n  nonlinearity: {{ type: linear }}\n  na: 1\n  nb: 0\n  nk: 1\n  unit_gain: false\n  stable: true\n"
                ),
            )
        };
        let identified = |from: &str| {
            let (spec, data) = spec_with(from);
            match pipeline::identify(&spec, data, &[]).unwrap() {
                Outcome::Consistent(id) => id,
                Outcome::Falsified(f) => panic!("case {case} ({from}): falsified: {f}"),
            }
        };
        let relaxed = identified("");
        let id = identified(", from: free_run");
        // The reports say which estimate the bound is.
        use smid::core::model::BoundSource;
        assert_eq!(
            relaxed.model.bound_source,
            BoundSource::Estimated,
            "case {case}"
        );
        let delta = id.model.delta;
        assert_labelled(&id.model, &relaxed.model, &format!("case {case}"));
        assert!(
            delta >= relaxed.model.delta,
            "case {case}: {delta:e} below the relaxation's {:e}",
            relaxed.model.delta
        );
        let m = id
            .model
            .simulation_member
            .as_ref()
            .unwrap_or_else(|| panic!("case {case}: no member at {delta:e}"));
        assert!(
            m.certified,
            "case {case}: the member at {delta:e} is not certified"
        );
        // The simulator the raise starts from, and its distance recomputed from its values:
        // its run from the first equation (t0 = 1), the measured output before it.
        let seed = smid::core::members::best_free_run(
            &relaxed.model,
            &relaxed.model.method.member.check().unwrap(),
        )
        .unwrap()
        .unwrap_or_else(|| panic!("case {case}: no simulator over the relaxation's set"));
        let get = |k: &str| seed.values.iter().find(|(n, _)| n == k).unwrap().1;
        let (a1, b0) = (get("a1"), get("b0"));
        let mut prev = y[0];
        let mut distance = 0.0f64;
        for t in 1..n {
            let v = -a1 * prev + b0 * u[t - 1];
            distance = distance.max((y[t] - v).abs());
            prev = v;
        }
        assert_eq!(
            seed.within
                .map(|w| (w - distance).abs() <= 1e-9 * (1.0 + distance)),
            Some(true),
            "case {case}: the simulator's distance {:?}, recomputed {distance:e}",
            seed.within
        );
        // Raised to 1.1 times that distance, then brought down to 1.1 times the member's
        // while that takes off a tenth: never above the first, never below the relaxation's.
        let first = relaxed.model.delta.max(1.1 * distance);
        assert!(
            delta <= first * (1.0 + 1e-9),
            "case {case}: the bound {delta:e} above {first:e} (relaxation {:e}, simulator at {distance:e})",
            relaxed.model.delta
        );
        assert!(
            m.training_fit >= seed.training_fit - 1e-6,
            "case {case}: the member fits at {} %, the simulator it starts from at {} %",
            m.training_fit,
            seed.training_fit
        );
        if delta > relaxed.model.delta {
            raised += 1;
        }
        if delta < first * (1.0 - 1e-9) {
            tightened += 1;
        }
        eprintln!(
            "case {case}: relaxation {:.3e}, from the free run {delta:.3e}, simulator at {distance:.3e} ({:.2} %), member {:.2} %",
            relaxed.model.delta, seed.training_fit, m.training_fit
        );
    }
    assert!(
        raised >= 4,
        "the free run raised the bound in {raised} of 6 cases"
    );
    // The members, best free runs of the wider sets, run nearer than the simulators the raises
    // started from in most cases (4 of 6 when written), and the bound comes down to them.
    assert!(
        tightened >= 2,
        "the bound came down to the member's distance in {tightened} of 6"
    );
}

/// A set identified with `noise.from: free_run` carries the free run's label exactly where its
/// bound lies above `relaxed`'s (the relaxation's estimate on the same data), the
/// relaxation's label where it does not.
fn assert_labelled(
    set: &smid::core::model::ModelSet,
    relaxed: &smid::core::model::ModelSet,
    what: &str,
) {
    use smid::core::model::BoundSource;
    assert_eq!(
        set.bound_source,
        if set.delta > relaxed.delta {
            BoundSource::FreeRun
        } else {
            BoundSource::Estimated
        },
        "{what}: {:e} against the relaxation's {:e}",
        set.delta,
        relaxed.delta
    );
}

/// Where `noise.from: free_run` finds no simulator to raise the bound with (the paper's
/// designed experiment: steady-state points, over which no free run is searched), the bound
/// stays the relaxation's and the set says so (`bound_source` `estimated`, not `free_run`).
#[test]
fn a_free_run_bound_that_is_not_raised_is_labelled_the_relaxations() {
    use smid::core::model::BoundSource;
    use smid::core::outcome::Outcome;
    smid::link_plugins();
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/paper.yaml");
    let (spec, data) = smid::load_simulated(&path).unwrap();
    let identified = |from: bool| {
        let mut v = serde_json::to_value(&spec).unwrap();
        v["noise"] = serde_json::json!({ "estimate": 1.1 });
        if from {
            v["noise"]["from"] = serde_json::json!("free_run");
        }
        let s: smid::core::spec::Spec = serde_json::from_value(v).unwrap();
        match pipeline::identify(&s, data.clone(), &[]).unwrap() {
            Outcome::Consistent(id) => id,
            Outcome::Falsified(f) => panic!("falsified: {f}"),
        }
    };
    let (relaxed, id) = (identified(false), identified(true));
    assert_eq!(id.model.delta, relaxed.model.delta);
    assert_eq!(relaxed.model.bound_source, BoundSource::Estimated);
    assert_eq!(id.model.bound_source, BoundSource::Estimated);
}

/// `noise.from: free_run` for every registered plugin with a random trial (the registry's
/// check cases, either side), each on its own random record (N = 400, noise inside the trial's
/// bound) identified with an estimated bound: never a crash or a falsified model; the bound is
/// at least the relaxation's; where it is raised, it is at most 1.1 times the distance of the
/// simulator it starts from (`members::best_free_run` over the relaxation's set), and the
/// member there fits the training records as well as that simulator (to 0.1 points: each set
/// starts its runs from its own inner-signal estimate).
///
/// Without `slow-checks` (CI) every case but the output backlash and the saturation, the two
/// whose estimates take the longest searches on these records.
#[test]
fn a_bound_from_the_free_run_for_every_registered_plugin() {
    use smid::core::noise::EstimateFrom;
    use smid::core::outcome::Outcome;
    use smid::core::registry;
    use smid::montecarlo::any_record;
    use smid::plugin_check::{simulator, PluginTrial};
    smid::link_plugins();
    const SLOW: [&str; 2] = ["output_backlash", "saturation"];
    let mut cases: Vec<_> = registry::check_cases();
    assert!(cases.len() >= 6, "{}", cases.len());
    for name in SLOW {
        assert!(cases.iter().any(|c| c.name == name), "no check case {name}");
    }
    if !common::SLOW_CHECKS {
        cases.retain(|c| !SLOW.contains(&c.name.as_str()));
    }
    use rayon::prelude::*;
    let rows: Vec<(String, bool, bool, bool)> = cases
        .par_iter()
        .map(|case| {
            let seed = 70_100;
            let trial = PluginTrial::random(&case.name, seed).unwrap();
            let (mut spec, nl, linear) = trial.spec();
            any_record(&mut spec, &nl.parameters(), seed);
            spec.method.member.search = false;
            let mut plant = simulator(linear, nl.as_ref(), case.structure);
            let records = match pipeline::run_with_plant(&spec, &mut plant) {
                Ok(Outcome::Consistent(id)) => id.model.training.records.clone(),
                other => {
                    eprintln!("{}: the declared trial gave no set: {:?}", case.name, other.err());
                    return (case.name.clone(), false, false, false);
                }
            };
            let data = pipeline::ExperimentData {
                steady: None,
                steady_record: None,
                records,
                filter: None,
            };
            let estimated = |from: Option<EstimateFrom>| {
                let mut v = serde_json::to_value(&spec).unwrap();
                v["noise"] = serde_json::json!({ "estimate": 1.1 });
                if from.is_some() {
                    v["noise"]["from"] = serde_json::json!("free_run");
                }
                v["method"]["member"]["search"] = serde_json::json!(true);
                let s: smid::core::spec::Spec = serde_json::from_value(v).unwrap();
                match pipeline::identify(&s, data.clone(), &[]) {
                    Ok(Outcome::Consistent(id)) => Some(id),
                    Ok(Outcome::Falsified(f)) => {
                        panic!("{}: an estimated bound falsified: {f}", case.name)
                    }
                    Err(e) => {
                        eprintln!("{}: {e}", case.name);
                        None
                    }
                }
            };
            let Some(relaxed) = estimated(None) else {
                return (case.name.clone(), false, false, false);
            };
            let id = estimated(Some(EstimateFrom::FreeRun))
                .unwrap_or_else(|| panic!("{}: the relaxation answered, the free run not", case.name));
            let delta = id.model.delta;
            assert!(
                delta >= relaxed.model.delta,
                "{}: {delta:e} below the relaxation's {:e}",
                case.name,
                relaxed.model.delta
            );
            assert_labelled(&id.model, &relaxed.model, &case.name);
            if delta == relaxed.model.delta {
                let certified = id.model.simulation_member.as_ref().is_some_and(|m| m.certified);
                return (case.name.clone(), true, certified, false);
            }
            let seed = smid::core::members::best_free_run(&relaxed.model, &relaxed.model.method.member.check().unwrap())
                .unwrap()
                .unwrap_or_else(|| panic!("{}: raised without a simulator", case.name));
            let within = seed.within.unwrap();
            assert!(
                delta <= 1.1 * within * (1.0 + 1e-9),
                "{}: the bound {delta:e} above 1.1 x the simulator's distance {within:e}",
                case.name
            );
            // Each set starts its runs from its own inner-signal estimate (its first cell's
            // stage-2 centres), so the two fits agree to the warm start's effect, not to the
            // digit (an output gain: 4e-3 points).
            let m = id.model.simulation_member.as_ref().unwrap();
            assert!(
                m.training_fit >= seed.training_fit - 0.1,
                "{}: the member fits at {} %, the simulator it starts from at {} %",
                case.name,
                m.training_fit,
                seed.training_fit
            );
            eprintln!(
                "{}: relaxation {:.3e}, raised to {delta:.3e}; member {:.2} % ({}), simulator {:.2} %",
                case.name,
                relaxed.model.delta,
                m.training_fit,
                if m.certified { "certified" } else { "not certified" },
                seed.training_fit
            );
            (case.name.clone(), true, m.certified, true)
        })
        .collect();
    eprintln!("{rows:?}");
    // The relaxation's own estimate is refused on some bisected blocks' trials (no bound
    // falsified within the cell budget: the error names `noise.delta`, the prior and
    // `max_cells`); every one it answers, the free run answers too (above), and each raised
    // bound here holds a certified member.
    let answered = rows.iter().filter(|r| r.1).count();
    assert!(2 * answered >= rows.len(), "{rows:?}");
    assert!(rows.iter().filter(|r| r.1).all(|r| r.2), "{rows:?}");
    // Trials of the right class with noise inside the bound: the equations' bound is still
    // below what a free run needs in most (a raise is what is tested above).
    assert!(
        rows.iter().filter(|r| r.3).count() * 2 >= answered,
        "{rows:?}"
    );
}

/// One case of `implied_estimate_verdicts_give_what_asking_each_gives`: the record `u`, `y`
/// under an estimated bound, a Wiener or Hammerstein model (`na = nb = nk = 1`) with the given
/// block, effects and prior, the classical test with the given budget. The estimate with
/// implied verdicts must give what asking each gives, asking at most one test more per cell
/// level; returns that estimate, its trace, the spec and the data.
#[allow(clippy::too_many_arguments)]
fn estimate_both_ways(
    tag: &str,
    u: &[f64],
    y: &[f64],
    (structure, nonlinearity, unit_gain): (&str, &str, bool),
    effects: &str,
    prior: &[String],
    (max_cells, halvings): (usize, u32),
    context: &str,
) -> (
    smid::core::Result<smid::core::outcome::Outcome<f64>>,
    pipeline::EstimateTrace,
    smid::core::spec::Spec,
    pipeline::ExperimentData,
) {
    let rest = format!(
        "noise: {{ estimate: 1.1 }}\n\
model:\n  structure: {structure}\n  nonlinearity: {nonlinearity}\n  na: 1\n  nb: 1\n  nk: 1\n  unit_gain: {unit_gain}\n  \
effects: [ {effects} ]\n  prior: {{ {} }}\n\
method:\n  eiv: classical\n  member: {{ search: false }}\n  cells: {{ max_cells: {max_cells}, nonlinearity_halvings: {halvings} }}\n",
        prior.join(", ")
    );
    let (spec, data) = common::measured(tag, u, y, &rest);
    let (implied, trace) = pipeline::estimate_bound_traced(&spec, &data, true);
    let (asked, every) = pipeline::estimate_bound_traced(&spec, &data, false);
    let show = |r: &smid::core::Result<smid::core::outcome::Outcome<f64>>| match r {
        Ok(smid::core::outcome::Outcome::Consistent(d)) => format!("consistent {:?}", d.to_bits()),
        Ok(smid::core::outcome::Outcome::Falsified(f)) => format!("falsified: {f}"),
        Err(e) => format!("error: {e}"),
    };
    assert_eq!(show(&implied), show(&asked), "{context}");
    assert_eq!(every.implied, 0, "{context}");
    // At most one test more per level of cells (the smallest bound, asked first).
    assert!(
        trace.asked <= every.asked + 4,
        "{context}: {trace:?} against {every:?}"
    );
    eprintln!(
        "{context}: {} ({trace:?}; asking each: {every:?})",
        show(&implied).chars().take(60).collect::<String>()
    );
    (asked, trace, spec, data)
}

/// The estimate's implied verdicts (`pipeline::estimate_bound_traced`: "consistent" at the
/// smallest bound the bisection may try answers every larger one whose test evaluates the same
/// cells) give what asking every verdict gives. Cases drawn from the effect registry: effect
/// candidates with bisected parameters and a default prior from these data (each box that
/// prior, or shrunk around a random point to 1e-3 to 1 of it), every other case one whose
/// resolution follows the bound (an offset's, a drift's), on records of random linear plants
/// with bounded noise of random size and random cell budgets; then the registry's check-case
/// blocks beside such an effect; then built cases (an output gain beside an offset) where the
/// smallest bound is kept and larger ones near the noise are falsified, which implying
/// "consistent" from the smallest bound would get wrong. Each part must take a verdict from
/// the same cells at another resolution, or meet its built case, or the test does not exercise
/// what it checks.
///
/// Without `slow-checks` (CI) the estimates run for every fifth case of the first part (4, 9,
/// 14), every fourth of the second (2, 6, 10, 14) and every built case; every case is still
/// drawn, so the sampled cases are those of the full run, and among them are cases of both
/// parts that take a verdict from the same cells.
#[test]
fn implied_estimate_verdicts_give_what_asking_each_gives() {
    use smid::core::effect::{effects, DataScale};
    use smid::core::interval::Interval;
    use smid::core::rand::{Rng, SeedableRng};
    smid::link_plugins();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(67_001);
    let candidates: Vec<_> = effects()
        .into_iter()
        .flat_map(|e| (e.candidates)())
        .filter(|c| !c.cell_parameters().is_empty())
        .collect();
    assert!(
        candidates.len() >= 2,
        "the registry offers too few bisected effects"
    );
    let mut exercised = 0;
    for case in 0..16 {
        let n = rng.gen_range(120..240);
        let (a, b) = (rng.gen_range(-0.8..0.8), rng.gen_range(0.5..2.0));
        let levels: Vec<f64> = (0..5).map(|_| rng.gen_range(-1.0..1.0)).collect();
        let hold = rng.gen_range(2..8);
        let u: Vec<f64> = (0..n).map(|t| levels[(t / hold) % 5]).collect();
        let mut x = vec![0.0; n];
        for t in 1..n {
            x[t] = a * x[t - 1] + b * u[t - 1];
        }
        let noise = 10f64.powf(rng.gen_range(-4.0..-1.5));
        let e = smid::core::noise::uniform(n, noise, &mut rng);
        let y: Vec<f64> = x.iter().zip(&e).map(|(x, e)| x + e).collect();
        let range = |v: &[f64]| {
            v.iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &s| {
                    (lo.min(s), hi.max(s))
                })
        };
        let scale = DataScale {
            y_max: y.iter().fold(0.0f64, |m, v| m.max(v.abs())),
            length: n,
            y_range: range(&y),
            u_range: range(&u),
            noise: None,
        };
        // Every other case an effect whose resolution follows the bound.
        let follows = |c: &dyn smid::core::effect::Effect| {
            c.resolution(1.0, &scale) != c.resolution(0.5, &scale)
        };
        let pool: Vec<_> = candidates
            .iter()
            .filter(|c| case % 2 == 1 || follows(c.as_ref()))
            .collect();
        let cand = pool[rng.gen_range(0..pool.len())];
        let boxes = cand.default_prior(&scale);
        let names = cand.cell_parameters();
        if boxes.len() < names.len() {
            continue;
        }
        let prior: Vec<String> = names
            .iter()
            .zip(&boxes)
            .map(|(name, b): (&String, &Interval)| {
                let width = b.hi - b.lo;
                // Half the boxes whole: wide against the noise, as the diagnosis gives them.
                let w = if rng.gen_bool(0.5) {
                    width
                } else {
                    width * 10f64.powf(rng.gen_range(-3.0..0.0))
                };
                let lo = b.lo + rng.gen_range(0.0..1.0) * (width - w);
                format!("{name}: [{lo:?}, {:?}]", lo + w)
            })
            .collect();
        let max_cells = rng.gen_range(16..600);
        let halvings = rng.gen_range(2..7);
        if !common::SLOW_CHECKS && case % 5 != 4 {
            continue;
        }
        let context = format!("case {case} ({}, noise {noise:e}, max_cells {max_cells}, halvings {halvings}, prior {prior:?})", cand.label());
        let (_, trace, _, _) = estimate_both_ways(
            "implied",
            &u,
            &y,
            ("wiener", "{ type: linear }", false),
            &serde_json::to_string(cand).unwrap(),
            &prior,
            (max_cells, halvings),
            &context,
        );
        if follows(cand.as_ref()) && trace.implied > 0 {
            exercised += 1;
        }
    }
    assert!(
        exercised > 0,
        "no case took a verdict from the same cells at another resolution"
    );

    // With a block's parameters bisected too (each registered check case's own draw, its
    // prior box around the truth as `smid check --any-record` draws it) beside an offset or a
    // drift: at the smallest bound the effect's fine resolution takes the budget's splits and
    // leaves the block's cells whole, where a larger bound splits them and may falsify.
    let follows: Vec<_> = candidates
        .iter()
        .filter(|c| {
            let s = DataScale {
                y_max: 1.0,
                length: 100,
                y_range: (-1.0, 1.0),
                u_range: (-1.0, 1.0),
                noise: None,
            };
            c.resolution(1.0, &s) != c.resolution(0.5, &s)
                && c.default_prior(&s).len() == c.cell_parameters().len()
        })
        .collect();
    let cases = smid::core::registry::check_cases();
    let mut differ = 0;
    for case in 0..16 {
        let check = &cases[rng.gen_range(0..cases.len())];
        let Some(draw) = check.draw(&mut rng) else {
            continue;
        };
        // Where the boxes are resolved, a block of at most two parameters (more would take
        // the whole budget).
        if case % 2 == 1 && draw.nonlinearity.parameters().len() > 2 {
            continue;
        }
        let n = rng.gen_range(100..180);
        let a = rng.gen_range(0.2..0.8);
        let levels: Vec<f64> = (0..6)
            .map(|_| rng.gen_range(-1.0..1.0) * draw.amplitude)
            .collect();
        let hold = rng.gen_range(3..9);
        let u: Vec<f64> = (0..n).map(|t| levels[(t / hold) % 6]).collect();
        let linear = |v: &[f64]| {
            let mut x = vec![0.0; v.len()];
            for t in 1..v.len() {
                x[t] = a * x[t - 1] + (1.0 - a) * v[t - 1];
            }
            x
        };
        let wiener = check.structure == smid::core::nonlinearity::Structure::Wiener;
        let clean = if wiener {
            draw.nonlinearity.simulate(&linear(&u))
        } else {
            linear(&draw.nonlinearity.simulate(&u))
        };
        let noise = 10f64.powf(rng.gen_range(-3.5..-1.5));
        let e = smid::core::noise::uniform(n, noise, &mut rng);
        let y: Vec<f64> = clean.iter().zip(&e).map(|(c, e)| c + e).collect();
        let scale = DataScale {
            y_max: y.iter().fold(0.0f64, |m, v| m.max(v.abs())),
            length: n,
            y_range: (0.0, 0.0),
            u_range: (0.0, 0.0),
            noise: None,
        };
        let effect = follows[rng.gen_range(0..follows.len())];
        let max_cells = rng.gen_range(32..400);
        let halvings = rng.gen_range(2..5);
        // The effect's boxes (the plant has none: 0 inside) from a few times the noise
        // (where a bound near the noise splits the block's cells too) to its default prior.
        let mut prior: Vec<String> = effect
            .cell_parameters()
            .iter()
            .zip(effect.default_prior(&scale))
            .map(|(name, b)| {
                let w = (b.hi - b.lo)
                    * (noise / scale.y_max * 10f64.powf(rng.gen_range(0.3..2.0))).min(1.0);
                let lo = -rng.gen_range(0.0..1.0) * w;
                format!("{name}: [{lo:?}, {:?}]", lo + w)
            })
            .collect();
        // The block's boxes as `--any-record` draws them, or (every other case) a few times
        // what the noise resolves after the test's halvings: unsplit, the block leaves a bound
        // below the noise consistent; split, it may not.
        let resolved = case % 2 == 1;
        for (name, v) in draw.nonlinearity.parameters() {
            let w = if resolved {
                v.abs().max(0.05)
                    * (noise / scale.y_max * f64::from(1u32 << halvings) * rng.gen_range(1.0..6.0))
                        .min(1.0)
            } else {
                v.abs().max(0.05) * rng.gen_range(0.2..1.0)
            };
            let f: f64 = rng.gen_range(0.0..1.0);
            let (mut lo, hi) = (v - w * f, v + w * (1.0 - f));
            if name.starts_with('m') {
                lo = lo.max(0.2 * v);
            } else if v >= 0.0 {
                lo = lo.max(0.0);
            }
            prior.push(format!("{name}: [{lo:?}, {hi:?}]"));
        }
        if !common::SLOW_CHECKS && case % 4 != 2 {
            continue;
        }
        let context = format!("block case {case} ({}, {}, noise {noise:e}, max_cells {max_cells}, halvings {halvings}, prior {prior:?})", check.name, effect.label());
        let (_, trace, _, _) = estimate_both_ways(
            "implied-block",
            &u,
            &y,
            (
                if wiener { "wiener" } else { "hammerstein" },
                &serde_json::to_string(&draw.model).unwrap(),
                true,
            ),
            &serde_json::to_string(effect).unwrap(),
            &prior,
            (max_cells, halvings),
            &context,
        );
        if trace.implied > 0 {
            differ += 1;
        }
    }
    assert!(
        differ > 0,
        "no block case took a verdict from the same cells"
    );

    // The case the cells' check is there for, built to occur: an output gain `k` (its box a
    // few times what the noise resolves) beside a sensor offset (its box twice the noise). At
    // the smallest bound the offset's resolution takes every split and leaves `k` whole, and
    // the test keeps a cell; at bounds near the noise `k` is split as well and the test
    // falsifies them. Implying "consistent" there from the smallest bound would refuse the
    // estimate; the cells differ, so the bounds are asked and the estimate exists.
    let mut occurred = 0;
    for (case, (k_boxes, max_cells)) in [(3.0, 127), (4.0, 127), (6.0, 255), (4.0, 255)]
        .into_iter()
        .enumerate()
    {
        let n = 200;
        let levels: Vec<f64> = (0..6).map(|_| rng.gen_range(0.2..1.0)).collect();
        let u: Vec<f64> = (0..n).map(|t| levels[(t / 5) % 6]).collect();
        let mut x = vec![0.0; n];
        for t in 1..n {
            x[t] = 0.6 * x[t - 1] + 0.4 * u[t - 1];
        }
        let y_max = x.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let noise = 1e-2 * y_max;
        let e = smid::core::noise::uniform(n, noise, &mut rng);
        let y: Vec<f64> = x.iter().zip(&e).map(|(x, e)| x + e).collect();
        let k = k_boxes * noise / y_max;
        let context = format!("gain case {case} (k box {k:e}, max_cells {max_cells})");
        let (asked, _, spec, data) = estimate_both_ways(
            "implied-gain",
            &u,
            &y,
            ("wiener", "{ type: example_gain }", true),
            "{ type: offset }",
            &[
                format!("offset: [{:?}, {:?}]", -noise, noise),
                format!("k: [{:?}, {:?}]", 1.0 - 0.5 * k, 1.0 + 0.5 * k),
            ],
            (max_cells, 4),
            &context,
        );
        // The first level's test at the smallest bound its bisection tries (a thousandth of
        // the largest output halved until below 1e-9 of it).
        let scale = pipeline::data_scale(&data).y_max;
        let mut smallest = 1e-3 * scale;
        while smallest >= pipeline::NO_BOUND_BELOW * scale {
            smallest *= 0.5;
        }
        let smallest_kept = pipeline::consistent_at(&spec, &data, smallest).unwrap();
        if smallest_kept && matches!(asked, Ok(smid::core::outcome::Outcome::Consistent(_))) {
            occurred += 1;
        }
    }
    assert!(
        occurred > 0,
        "no gain case kept the smallest bound and estimated a larger one"
    );
}
