//! Stage-3 methods form an open registry: a method registered only in this
//! test is offered by the spec, the schema and the name parser, and the pipeline runs it;
//! `method.options` reach the chosen method and are checked by it, with errors naming the
//! field.
use smid::core::spec::{EivMethod, Spec};
use smid::core::stage3::{self, EivProblem, EivResult, Stage3Method};
use smid::core::{registry, Result};
use std::path::Path;

/// Reports the classical outer set unchanged: guaranteed (its start is), if not informative.
struct KeepClassical;
impl Stage3Method for KeepClassical {
    fn name(&self) -> &'static str {
        "test_only_keep"
    }
    fn start(&self) -> Option<EivMethod> {
        Some(EivMethod::Classical)
    }
    fn solve_from(&self, _prob: &EivProblem, start: EivResult) -> Result<EivResult> {
        Ok(start)
    }
}
smid_core::register_stage3!(99, KeepClassical);

fn paper_with(method: &str) -> Result<Spec> {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/paper.yaml");
    let text = std::fs::read_to_string(&path).unwrap();
    assert!(text.contains("  eiv: classical\n"));
    smid::link_plugins();
    Spec::parse(&text.replace("  eiv: classical\n", method), &path)
}

fn bounds(spec: &Spec) -> Vec<(f64, f64)> {
    let base = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples");
    let id = smid::run_spec(spec, &base, &|_| {}).unwrap().unwrap();
    id.parameters().iter().map(|p| (p.lower, p.upper)).collect()
}

#[test]
fn a_method_registered_in_a_test_is_offered_and_runs() {
    assert!(stage3::names().contains(&"test_only_keep"));
    assert!(registry::spec_schema().contains("\"test_only_keep\""));
    let e = EivMethod::parse("test_only_kep").unwrap_err().to_string();
    for name in stage3::names() {
        assert!(e.contains(name), "{name} not listed in: {e}");
    }
    let keep = paper_with("  eiv: test_only_keep\n").unwrap();
    let classical = paper_with("  eiv: classical\n").unwrap();
    assert_eq!(keep.method.eiv.name(), "test_only_keep");
    // Its result is its start's: the classical bounds, to the bit.
    assert_eq!(bounds(&keep), bounds(&classical));
}

#[test]
fn method_options_reach_the_method_and_are_checked() {
    // One round of the shared relaxation: never tighter than its default twelve, and looser
    // somewhere on the paper's data (the options are used, not dropped).
    let one = bounds(&paper_with("  eiv: shared\n  options: { max_rounds: 1 }\n").unwrap());
    let default = bounds(&paper_with("  eiv: shared\n").unwrap());
    assert_eq!(one.len(), default.len());
    for (o, d) in one.iter().zip(&default) {
        assert!(
            o.0 <= d.0 && d.1 <= o.1,
            "one round {o:?} tighter than twelve {d:?}"
        );
    }
    assert!(one != default, "max_rounds: 1 changed nothing");

    let e = paper_with("  eiv: shared\n  options: { max_round: 1 }\n")
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("method.options") && e.contains("max_round") && e.contains("max_rounds"),
        "{e}"
    );
    let e = paper_with("  eiv: classical\n  options: { depth: 3 }\n")
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("method.options.depth") && e.contains("no options"),
        "{e}"
    );
    let e = paper_with("  eiv: shared\n  options: { max_rounds: many }\n")
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("max_rounds") || e.contains("invalid type"),
        "{e}"
    );
}

/// Rounds stopped at their cap before they settled are reported, not hidden: the bounds still
/// hold, but the set may be far smaller or empty. One round of `shared` on the paper's data
/// is flagged in every cell, in the model set read back from `result.json`, in the run's
/// report and among `validate`'s warnings; the default twelve rounds settle there, and the
/// classical method has no rounds.
#[test]
fn rounds_stopped_at_their_cap_are_reported() {
    let base = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples");
    let run = |m: &str| {
        smid::run_spec(&paper_with(m).unwrap(), &base, &|_| {})
            .unwrap()
            .unwrap()
    };
    let one = run("  eiv: shared\n  options: { max_rounds: 1 }\n");
    assert!(
        one.model
            .cells
            .iter()
            .all(|c| c.unsettled.is_some_and(|g| g >= 0.03)),
        "{:?}",
        one.model
            .cells
            .iter()
            .map(|c| c.unsettled)
            .collect::<Vec<_>>()
    );
    let warning = one
        .model
        .duplicate()
        .unsettled_warning()
        .expect("read back from result.json, the model set still says so");
    assert!(warning.contains("max_rounds"), "{warning}");
    assert!(smid::core::report::table(&one).contains(&warning));
    let v = smid::core::validate::validate(
        &one.model,
        &one.model.training.records,
        &Default::default(),
    )
    .unwrap();
    assert!(v.warnings.contains(&warning), "{:?}", v.warnings);
    // A certified member proves the set non-empty: the warning says so, and the diagnosis's
    // verdict on the model as declared is settled (not undecided), its rounds capped or not.
    let certified = one
        .model
        .simulation_member
        .as_ref()
        .is_some_and(|m| m.certified);
    assert!(certified, "the paper's member at one round is certified");
    assert!(warning.contains("it is not empty"), "{warning}");
    assert_eq!(one.model.undecided(), None);
    let mut without = one.model.duplicate();
    without.simulation_member = None;
    assert!(without.undecided().is_some_and(|g| g >= 0.03));
    assert!(without.unsettled_warning().unwrap().contains("or empty"));
    // Without the member, the verdict on the training records themselves is undecided.
    let c = smid::core::validate::consistency(&without, &one.model.training.records).unwrap();
    assert_eq!(c.verdict, smid::core::validate::Verdict::Undecided, "{c:?}");
    let mut src = smid::closeloop::Source {
        spec: paper_with("  eiv: shared\n  options: { max_rounds: 1 }\n").unwrap(),
        base: base.clone(),
        model: None,
    };
    let data = smid::closeloop::training_data(&mut src).unwrap();
    let only = smid::core::diagnose::Options {
        only: vec!["delay".into()],
        ..Default::default()
    };
    let c = smid::core::diagnose::choose(&src.spec, &data, &only, &|_, _| {}).unwrap();
    let verdict = &c.rounds[0].base_train;
    assert!(
        verdict.admissible(),
        "the paper's data falsify its model: {verdict:?}"
    );
    assert_eq!(verdict.undecided(), None, "{verdict:?}");
    for settled in ["  eiv: shared\n", "  eiv: classical\n"] {
        let id = run(settled);
        assert_eq!(id.model.unsettled_warning(), None, "{settled}");
    }
}
