//! One model identified on the training records with the diagnosis's budget, and what the
//! data said of it ([`try_model`]); the specs the candidates are identified with.
use super::verdict::TrainVerdict;
use crate::error::Result;
use crate::model::ModelSet;
use crate::outcome::{Falsification, Outcome};
use crate::pipeline::{BelowBar, Bracket, ExperimentData, Identification};
use crate::spec::{CellSpec, ModelSpec, Spec};
use crate::validate;

/// The spec a diagnosis identifies its candidates with (each through [`with_model`]): the
/// spec's, with the diagnosis's coarse cell budget for bisected parameters (the augmented spec
/// keeps it, so its results reproduce) and the light member budget (a candidate's fit decides;
/// the envelope is the after-model's, identified with the spec's own member budget).
pub fn candidate_spec(spec: &Spec) -> Spec {
    let mut dspec = with_model(spec, &spec.model);
    dspec.method.cells.nonlinearity_halvings = dspec.method.cells.nonlinearity_halvings.min(4);
    dspec.method.cells.max_cells = dspec.method.cells.max_cells.min(2000);
    dspec.method.cells.max_leaves = dspec.method.cells.max_leaves.min(64);
    dspec.method.member = crate::spec::MemberSpec::LIGHT;
    dspec
}

/// A spec whose model is `model` (the rest as `spec`).
pub fn with_model(spec: &Spec, model: &ModelSpec) -> Spec {
    let mut v = serde_json::to_value(spec).expect("specs serialise");
    v["model"] = serde_json::to_value(model).expect("model specs serialise");
    serde_json::from_value(v).expect("a serialised spec deserialises")
}

/// Identify `model` on the training data and say what the data said. `spec` carries the
/// diagnosis's coarse cell budget; a model it leaves with cells whose θ is not bounded (the
/// few leaves the coarse budget keeps are merged into cells too wide to bound θ: the damper's
/// play near zero beside a dead zone) is identified again with the spec's own budget `full`,
/// and its set carries that budget.
pub(super) fn try_model(
    spec: &Spec,
    full: &CellSpec,
    model: &ModelSpec,
    data: &ExperimentData,
    bar: Option<f64>,
    known: Option<Result<Bracket>>,
) -> (TrainVerdict, Option<Identification>) {
    let first = try_model_with(spec, model, data, bar, known);
    let left_unbounded = matches!(&first, (TrainVerdict::UnboundedCells { .. }, Some(_)));
    if left_unbounded && spec.method.cells != *full {
        let mut finer = with_model(spec, &spec.model);
        finer.method.cells = full.clone();
        log::info!(target: "smid::diagnose", "{}: cells left unbounded with the diagnosis budget; again with the spec's", model.label());
        let second = try_model_with(&finer, model, data, bar, None);
        return offered(second);
    }
    offered(first)
}

/// The model a verdict offers: none for a failed one (also when `try_model_with` kept the
/// identification of cells left unbounded, to tell the caller so).
fn offered(
    (t, id): (TrainVerdict, Option<Identification>),
) -> (TrainVerdict, Option<Identification>) {
    match t {
        TrainVerdict::UnboundedCells { .. } | TrainVerdict::Failed { .. } => (t, None),
        t => (t, id),
    }
}

/// [`try_model`] with one budget: the verdict, and the identification (also when it left
/// cells unbounded, so that the caller can tell). With `known`, the model's bound was already
/// bracketed with this budget ([`crate::pipeline::bracket_below`] at `bar`): it is identified
/// at the bound kept (or its verdict is the bracket's), as [`crate::pipeline::identify_below`]
/// would have.
fn try_model_with(
    spec: &Spec,
    model: &ModelSpec,
    data: &ExperimentData,
    bar: Option<f64>,
    known: Option<Result<Bracket>>,
) -> (TrainVerdict, Option<Identification>) {
    let s = with_model(spec, model);
    let below = match known {
        Some(b) => b.and_then(|b| crate::pipeline::identify_bracketed(&s, data, b, &[], &|_| {})),
        None => crate::pipeline::identify_below(&s, data.clone(), bar),
    };
    let outcome = match below {
        Ok(BelowBar::Above(above)) => return (TrainVerdict::AboveBar(above), None),
        Ok(BelowBar::Identified(o)) => Ok(o),
        Err(e) => Err(e),
    };
    match outcome {
        // Consistent, but cells left without a finite θ bound: no model to offer.
        Ok(Outcome::Consistent(id)) if !id.model.search.unbounded.is_empty() => (
            TrainVerdict::UnboundedCells {
                cells: id.model.search.unbounded.len(),
                detail: format!(
                    "first {} ({})",
                    id.model.search.unbounded[0].cell, id.model.search.unbounded[0].detail
                ),
            },
            Some(id),
        ),
        Ok(Outcome::Consistent(id)) => {
            let fit = training_fit(&id.model).unwrap_or(f64::NEG_INFINITY);
            let bound = id.model.delta;
            (
                TrainVerdict::Consistent {
                    fit_percent: fit,
                    bound,
                    unsettled: id.model.undecided(),
                    within: id.model.simulation_member.as_ref().and_then(|m| m.within),
                },
                Some(id),
            )
        }
        Ok(Outcome::Falsified(Falsification {
            stage,
            record,
            sample,
            located,
            detail,
        })) => (
            TrainVerdict::Falsified {
                stage,
                record,
                sample,
                located,
                detail,
            },
            None,
        ),
        Err(e) => (
            TrainVerdict::Failed {
                message: e.to_string(),
            },
            None,
        ),
    }
}

/// Free-run fit % of the representative member (see [`crate::members::representative`]) on the model's own training records.
pub fn training_fit(m: &ModelSet) -> Result<f64> {
    Ok(validate::free_run_fit(m, &m.training.records)?.fit_percent)
}
