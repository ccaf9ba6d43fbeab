//! The set-membership verdict on fresh records: proven where a point of the set satisfies the
//! training and the fresh equations exactly, falsified only by a proof, and undecided, not
//! consistent, where stage 3's rounds stop at their cap while still shrinking.
//!
//! The proof (an exact LP at one point) and the relaxation (stage 3 over each cell) are two
//! engines: a point certified on records that the relaxation falsifies at the same bound, or a
//! proven verdict the relaxation does not admit, would be a false proof, and a true plant's
//! record inside its noise bound that is falsified would be a missed guarantee.
mod common;

use smid::core::effect::Effect;
use smid::core::members;
use smid::core::outcome::Outcome;
use smid::core::pipeline;
use smid::core::registry;
use smid::core::settings::Check;
use smid::core::stage3::certify::CERTIFIED;
use smid::core::validate::{self, Undecided, Verdict};
use smid::plugin_check::{simulator, PluginTrial};
use std::path::PathBuf;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// Per registered plugin and side, a random trial from the designed experiment: fresh
/// records of the true plant (noise inside the bound) and of the plant with an undeclared
/// sensor offset of a random size (up to three noise bounds, where the verdicts go either way), checked against the identified set. The truth's records are
/// never falsified; a proven verdict is never contradicted by the relaxation at that bound;
/// and the proof settles most of the truth's verdicts.
#[test]
fn a_proven_verdict_is_never_contradicted_and_the_truth_is_never_falsified() {
    use rand::{Rng, SeedableRng};
    use rayon::prelude::*;
    smid::link_plugins();
    let cases = registry::check_cases();
    assert!(cases.len() >= 6, "{}", cases.len());
    let rows: Vec<(String, Verdict, Vec<Verdict>)> = cases
        .par_iter()
        .filter_map(|case| {
            let seed = 81_000 + case.name.len() as u64;
            let trial = PluginTrial::random(&case.name, seed).unwrap();
            let (spec, nl, linear) = trial.spec();
            let mut plant = simulator(linear.clone(), nl.as_ref(), case.structure);
            let id = match pipeline::run_with_plant(&spec, &mut plant) {
                Ok(Outcome::Consistent(id)) => id,
                other => {
                    eprintln!("{}: the trial gave no set: {:?}", case.name, other.err());
                    return None;
                }
            };
            let model = &id.model;
            let fresh_of = |effects: &[Box<dyn Effect>], s: u64| {
                let mut p = smid::core::plant::SimulatedPlant {
                    effects,
                    ..simulator(linear.clone(), nl.as_ref(), case.structure)
                };
                let r = pipeline::fresh_record(&spec, &mut p, s, 120).unwrap();
                r.with_bound(model.delta)
            };
            let check = |fresh: pipeline::Record| {
                let c = validate::consistency(model, std::slice::from_ref(&fresh)).unwrap();
                // The proof's engine on its own: where the relaxation proves the joint records
                // inconsistent, no point may be certified on them.
                if let Some(m) = model.simulation_member.as_ref().filter(|m| m.certified) {
                    let mut joint = model.training.records.clone();
                    joint.push(fresh.clone());
                    let opts = model.method.member.check().unwrap();
                    let s = members::certificate_on(model, m, &joint, &opts, true).unwrap();
                    if c.verdict == Verdict::Falsified {
                        assert!(
                            s.is_none_or(|s| s > CERTIFIED),
                            "{}: certified at {s:?} on records the relaxation falsifies",
                            case.name
                        );
                    }
                }
                if c.verdict == Verdict::Proven {
                    let (_, hi) = validate::smallest_bound(model, &[fresh], 0.02, None)
                        .unwrap()
                        .unwrap_or_else(|| panic!("{}: proven, yet no bound admits", case.name));
                    assert!(
                        hi <= model.delta * (1.0 + 1e-9),
                        "{}: proven at {:e}, the relaxation admits only from {hi:e}",
                        case.name,
                        model.delta
                    );
                }
                c.verdict
            };
            let truth = check(fresh_of(&[], seed + 1));
            assert_ne!(
                truth,
                Verdict::Falsified,
                "{}: the truth falsified",
                case.name
            );
            let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
            let offsets: Vec<Verdict> = (0..3)
                .map(|i| {
                    let size = model.delta * rng.gen_range(0.05..3.0);
                    let e: Vec<Box<dyn Effect>> =
                        vec![
                            serde_norway::from_str(&format!("{{type: offset, value: {size}}}"))
                                .unwrap(),
                        ];
                    check(fresh_of(&e, seed + 2 + i))
                })
                .collect();
            Some((case.name.clone(), truth, offsets))
        })
        .collect();
    for r in &rows {
        eprintln!("{}: truth {:?}, offsets {:?}", r.0, r.1, r.2);
    }
    assert!(
        rows.len() >= cases.len() - 1,
        "{} of {} cases ran",
        rows.len(),
        cases.len()
    );
    let proven = rows.iter().filter(|r| r.1 == Verdict::Proven).count();
    assert!(
        2 * proven >= rows.len(),
        "the truth's verdict proven in {proven} of {} cases",
        rows.len()
    );
}

/// The paper's example with stage 3's rounds capped at one and no member search: the rounds
/// stop while still shrinking, so the verdict on a fresh record of the true plant is
/// undecided, not consistent, and not a falsification; `smid validate` says so and does not
/// exit with the falsification's code. With the rounds free to settle it is consistent.
#[test]
fn a_verdict_on_capped_rounds_is_undecided_and_settled_rounds_decide_it() {
    let text = std::fs::read_to_string(root().join("examples/paper.yaml")).unwrap();
    let capped = text.replace(
        "  eiv: classical",
        "  eiv: shared\n  options: { max_rounds: 1 }\n  member: { search: false }",
    );
    let settled = text.replace(
        "  eiv: classical",
        "  eiv: shared\n  member: { search: false }",
    );
    assert_ne!(capped, text, "the paper's method line moved");
    let dir = std::env::temp_dir().join(format!("smid-verdicts-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let smid = env!("CARGO_BIN_EXE_smid");
    let mut verdicts = Vec::new();
    for (name, spec) in [("capped", &capped), ("settled", &settled)] {
        let path = dir.join(format!("{name}.yaml"));
        std::fs::write(&path, spec).unwrap();
        let id = smid::run_spec_file(&path).unwrap().unwrap();
        let loaded = smid::load_spec(&path).unwrap();
        let fresh = smid::closeloop::fresh_records(&loaded, &dir, &[], 1001, 200, 1).unwrap();
        let fresh: Vec<_> = fresh.iter().map(|r| r.with_bound(id.model.delta)).collect();
        let c = validate::consistency(&id.model, &fresh).unwrap();
        assert!(c.falsified_at.is_none(), "{name}: {c:?}");
        verdicts.push((name, c.clone()));
        let out = dir.join(format!("{name}-run"));
        let run = std::process::Command::new(smid)
            .args([
                "run",
                path.to_str().unwrap(),
                "--out",
                out.to_str().unwrap(),
            ])
            .output()
            .unwrap();
        assert!(
            run.status.success(),
            "{}",
            String::from_utf8_lossy(&run.stderr)
        );
        let v = std::process::Command::new(smid)
            .args([
                "validate",
                out.join("result.json").to_str().unwrap(),
                "--out",
                dir.join(format!("{name}-validate")).to_str().unwrap(),
            ])
            .output()
            .unwrap();
        let stdout = String::from_utf8_lossy(&v.stdout);
        assert_eq!(v.status.code(), Some(0), "{name}: {stdout}");
        let line = stdout.lines().find(|l| l.starts_with("verdict:")).unwrap();
        assert!(
            line.starts_with(&format!("verdict: {}", c.verdict.word())),
            "{name}: {line}"
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
    let (_, capped) = &verdicts[0];
    assert_eq!(capped.verdict, Verdict::Undecided, "{capped:?}");
    assert!(!capped.consistent);
    assert!(matches!(
        capped.undecided,
        Some(Undecided::Capped { shrink } | Undecided::SetUnsettled { shrink }) if shrink > 0.0
    ));
    let (_, settled) = &verdicts[1];
    assert_eq!(settled.verdict, Verdict::Consistent, "{settled:?}");
    assert!(settled.consistent && settled.undecided.is_none());
}
