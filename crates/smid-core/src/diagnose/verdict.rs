//! What the training data said: the verdict on one model ([`TrainVerdict`]), a candidate's
//! evidence, the rounds and the choice they make, and a column of the before/after table.
use crate::error::{Result, Stage};
use crate::model::ModelSet;
use crate::outcome::Outcome;
use crate::pipeline::Identification;
use crate::spec::ModelSpec;
use crate::validate::Validation;
use serde::Serialize;

/// What the training data said of one model.
#[derive(Debug, Clone, Serialize)]
#[serde(tag = "verdict", rename_all = "snake_case")]
pub enum TrainVerdict {
    /// A non-empty feasible set at the declared bound.
    Consistent {
        /// Free-run fit % of the central member on the training records.
        fit_percent: f64,
        /// The noise bound the model was identified with (estimated ones differ per model).
        bound: f64,
        /// The verdict is undecided: stage 3's rounds stopped at their cap before they settled
        /// in some cell, and no certified member proves the set non-empty. The largest
        /// last-round shrinkage ([`ModelSet::unsettled`]). The capped rounds did not falsify
        /// the model; more rounds may. (The rule still ranks it as consistent.)
        #[serde(skip_serializing_if = "Option::is_none")]
        unsettled: Option<f64>,
        /// The largest distance of that member's free run from any training sample
        /// ([`crate::members::training_within`]): the model's exact smallest consistent bound
        /// is at most it (`bound` came from where a relaxation stops falsifying).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        within: Option<f64>,
    },
    /// The training data falsify the model.
    Falsified {
        /// The stage whose proof found the contradiction.
        stage: Stage,
        /// The training record (in the order given).
        record: usize,
        /// The first offending sample of that record, or with `located: false` a sample up to
        /// which the data are inconsistent ([`crate::Falsification::located`]).
        sample: usize,
        /// Whether `sample` is the first offending one.
        located: bool,
        /// What contradicts what, in words.
        detail: String,
    },
    /// With an estimated bound: the training data are inconsistent at the largest bound the
    /// candidate may have to be kept (the bar), proven by `test`, so its own bound was not
    /// bracketed ([`crate::pipeline::bracket_below`]).
    AboveBar(crate::pipeline::AboveBar),
    /// With an estimated bound: bracketed, not identified. The bound it would be identified
    /// with ([`crate::pipeline::bracket_below`], with the diagnosis's cell budget) is above the
    /// chosen candidate's by more than the rule's step (its `per_parameter`): at that bound the
    /// rule could neither choose it nor find it equivalent to the choice, so it has no set, no
    /// member and no fit. (A candidate whose coarse cells leave `θ` unbounded is bracketed
    /// again with the spec's own budget when it is identified, which may move its bound; one
    /// left bracketed is ranked by its first bracket.) With `at_least`, the bracket was not
    /// finished: `bound` is its floor ([`crate::pipeline::Bracket::floor`]: the classical
    /// estimate, or the margin times a bound the method proves inconsistent), and the bound it
    /// would be identified with, if finishing it found one (it may end falsified, or above its
    /// bar), is at least that, already more than the rule's step above the choice's.
    Bracketed {
        /// The bound it would be identified with (with `at_least`: a floor of it).
        bound: f64,
        /// The bracket was not finished: `bound` is a floor.
        #[serde(default, skip_serializing_if = "std::ops::Not::not")]
        at_least: bool,
    },
    /// Identified, but `cells` cells of the set were left without a finite `θ` bound (the
    /// refinement budget was spent): no model to offer.
    UnboundedCells {
        /// Cells without a finite `θ` bound.
        cells: usize,
        /// The first such cell and why, in words.
        detail: String,
    },
    /// Identification failed otherwise (unbounded parameters, solver trouble...).
    Failed {
        /// The error, in words.
        message: String,
    },
    /// Not tried: with `reason`, refused before trying (a term that breaks the designed
    /// experiment under which the steady-state points give no box); without, the rounds never
    /// needed its verdict.
    NotTried {
        /// Why it was refused, in words.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        reason: Option<String>,
    },
    /// Not identified: the base model's class reproduces the candidate's outputs exactly
    /// ([`reproduced_by_base`]: at each of `draws` draws of its parameters, the corners of
    /// their prior box and some inside it, the base model's equation, refitted by least
    /// squares, leaves an error of at most `residual` of the outputs' range), so its exact
    /// smallest consistent bound is not below the base model's (as far as the draws show): a
    /// lower one would be the relaxation's slack, not the data's.
    ///
    /// [`reproduced_by_base`]: super::reproduced_by_base
    Reproduced {
        /// The largest refit error over the draws, as a fraction of the outputs' range.
        residual: f64,
        /// Draws of the candidate's added parameters that were compared.
        draws: usize,
    },
}

impl TrainVerdict {
    /// Whether the model stays in the running: consistent with the training data (also when
    /// the verdict is undecided: [`TrainVerdict::undecided`]).
    pub fn admissible(&self) -> bool {
        matches!(self, TrainVerdict::Consistent { .. })
    }
    /// A consistent verdict that stage 3's capped rounds leave undecided: the last round's
    /// largest shrinkage.
    pub fn undecided(&self) -> Option<f64> {
        match self {
            TrainVerdict::Consistent { unsettled, .. } => *unsettled,
            _ => None,
        }
    }
    /// How far into the data the model is proven to hold: later is better. A located finding
    /// holds up to its record and sample; one not located proves no prefix (its sample is where
    /// the search stopped, not where the model fails), so it ranks at the start of its stage.
    pub(super) fn reach(&self) -> (u8, usize, usize) {
        match self {
            TrainVerdict::Consistent { .. } => (4, usize::MAX, usize::MAX),
            TrainVerdict::Falsified {
                stage,
                record,
                sample,
                located,
                ..
            } => {
                let stage = match stage {
                    Stage::SteadyState => 1,
                    Stage::InnerSignal => 2,
                    Stage::Linear => 3,
                };
                if *located {
                    (stage, *record, *sample)
                } else {
                    (stage, 0, 0)
                }
            }
            TrainVerdict::AboveBar(_) => (3, 0, 0),
            // Consistent at its bound, as far as the bracket's verdicts say. (The fallback pick
            // by reach never meets one: a round leaves candidates bracketed only beside a pick.)
            TrainVerdict::Bracketed { .. } => (4, usize::MAX, usize::MAX),
            TrainVerdict::UnboundedCells { .. }
            | TrainVerdict::Failed { .. }
            | TrainVerdict::NotTried { .. }
            | TrainVerdict::Reproduced { .. } => (0, 0, 0),
        }
    }
}

/// One candidate's evidence.
#[derive(Debug, Clone, Serialize)]
pub struct Evidence {
    /// The candidate in words (an effect's label, or a block and its side).
    pub label: String,
    /// The `type` tag of the effect or block plugin it adds.
    pub tag: String,
    /// Parameters the candidate adds to the model.
    pub added_parameters: usize,
    /// Prior boxes given to its bisected parameters (from the training data's scale).
    pub priors: Vec<(String, [f64; 2])>,
    /// What the training data said of the base model with this candidate added.
    pub train: TrainVerdict,
    /// The rule chose this candidate in its round.
    pub chosen: bool,
    /// Other admissible candidates of the round (and the base model, as "the model as
    /// declared") that the training records cannot tell from this one: their members' free
    /// runs on the training inputs, or one's member put into the other's class, stay within
    /// twice the noise bound of each other once past their transients from rest; or the rule
    /// could tell them only by a fit difference the noise accounts for, at the same parameter
    /// count.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub equivalent_to: Vec<String>,
    /// The verdict of a candidate that is not identified at all, known before it is tried:
    /// a term that breaks the designed experiment under which the steady-state points give no
    /// box ([`with_design_prior`], a failure saying why), or a class the base model's
    /// reproduces ([`screen_reproduced`]). [`try_candidates`] makes it the verdict.
    ///
    /// [`with_design_prior`]: super::candidates::with_design_prior
    /// [`screen_reproduced`]: super::screen::screen_reproduced
    /// [`try_candidates`]: super::bracket::try_candidates
    #[serde(skip)]
    pub(crate) untried: Option<TrainVerdict>,
}

/// One round of the search.
#[derive(Debug, Clone, Serialize)]
pub struct Round {
    /// The model this round extends (its effects).
    pub base: String,
    /// What the training data said of the base model itself.
    pub base_train: TrainVerdict,
    /// Every candidate tried on top of the base, with its evidence.
    pub candidates: Vec<Evidence>,
}

/// The outcome of the choice (made on training data only).
#[derive(Debug, Serialize)]
pub struct Choice {
    /// The rule used, in words.
    pub rule: String,
    /// The rounds of the search, in order (each extends the previous round's choice).
    pub rounds: Vec<Round>,
    /// Labels of the effects added (empty: "no missing effect found").
    pub added: Vec<String>,
    /// The model as declared in the spec.
    #[serde(skip)]
    pub before: ModelSpec,
    /// The model with the chosen effects added.
    #[serde(skip)]
    pub after: ModelSpec,
    /// The after-model is admissible on the training data.
    pub after_admissible: bool,
    /// The after-model's set as identified during the choice (reused by the table).
    #[serde(skip)]
    pub after_set: Option<ModelSet>,
    /// The stage options the diagnosis identified with (its cell budget).
    #[serde(skip)]
    pub method: crate::spec::MethodSpec,
    /// The candidates of the last round reported as indistinguishable from the chosen one on
    /// the training records (label, model, its set): offered beside the choice, not instead.
    #[serde(skip)]
    pub equivalent_models: Vec<(String, ModelSpec, ModelSet)>,
    /// The model as declared at its smallest consistent bound, searched beside the candidates
    /// when the training data falsify it at the declared bound (the table's before column,
    /// from the training records only); `None`: [`assess`] searches it when needed.
    ///
    /// [`assess`]: super::assess()
    #[serde(skip)]
    pub before_identified: Option<Result<Outcome<(Identification, bool)>>>,
}

impl Choice {
    /// "no missing effect found" or the effects added.
    pub fn summary(&self) -> String {
        if self.added.is_empty() {
            if self.after_admissible && !self.equivalent_models.is_empty() {
                format!(
                    "no missing effect found: the training data are consistent with the model as declared; the training records cannot tell it apart from the model with {} (an equivalent explanation, not a missing effect)",
                    self.equivalents().join(", or with ")
                )
            } else if self.after_admissible {
                "no missing effect found: the training data are consistent with the model as declared".into()
            } else {
                "no candidate made the training data consistent; the model is unchanged".into()
            }
        } else {
            let eq: Vec<String> = self
                .rounds
                .iter()
                .flat_map(|r| r.candidates.iter().filter(|e| e.chosen))
                .filter(|e| !e.equivalent_to.is_empty())
                .map(|e| format!("{} ≡ {}", e.label, e.equivalent_to.join(" ≡ ")))
                .collect();
            if eq.is_empty() {
                format!("missing: {}", self.added.join(", "))
            } else {
                format!(
                    "missing: {} (the training records cannot tell apart: {}; the choice among them is the rule's, not the data's)",
                    self.added.join(", "),
                    eq.join("; ")
                )
            }
        }
    }
    /// The labels the training records cannot tell from the chosen ones (equivalent
    /// explanations), including [`AS_DECLARED`] when the model without them simulates alike.
    ///
    /// [`AS_DECLARED`]: super::AS_DECLARED
    pub fn equivalents(&self) -> Vec<String> {
        if self.added.is_empty() {
            // The model as declared stands: the candidates that simulate alike.
            return self
                .equivalent_models
                .iter()
                .map(|(l, _, _)| l.clone())
                .collect();
        }
        self.rounds
            .iter()
            .flat_map(|r| r.candidates.iter().filter(|e| e.chosen))
            .flat_map(|e| e.equivalent_to.iter().cloned())
            .collect()
    }
}

/// One column of the before/after table.
#[derive(Debug, Serialize)]
pub struct Column {
    /// The model in words ([`ModelSpec::label`]).
    pub label: String,
    /// The noise bound the model was identified with.
    pub bound: f64,
    /// The bound was inflated past the declared one to make the training data consistent.
    pub inflated: bool,
    /// Number of identified parameters (those with a non-degenerate bound).
    pub parameters: usize,
    /// Mean radius of the identified parameters' bounds.
    pub mean_radius: f64,
    /// The validation on the held-out records (`None`: no member to validate, see `stopped`).
    pub validation: Option<Validation>,
    /// Why this column has no model: the training data stay inconsistent up to the largest
    /// bound the bounded search tried, or identification gave no finite bound. A row of the
    /// table, never an error exit.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub stopped: Option<Stopped>,
    /// The model set, when identified.
    #[serde(skip)]
    pub model: Option<ModelSet>,
}

/// Why a column of the before/after table has no model.
#[derive(Debug, Clone, Serialize)]
#[serde(tag = "cause", rename_all = "snake_case")]
pub enum Stopped {
    /// The training data falsify the model at every bound the bounded search tried.
    Falsified {
        /// The finding, in words.
        detail: String,
    },
    /// Identification gave no finite bound.
    Unbounded {
        /// The error, in words.
        detail: String,
    },
    /// The LP solver could not conclude.
    Solver {
        /// The error, in words.
        detail: String,
    },
    /// The method does not support the model.
    Unsupported {
        /// The error, in words.
        detail: String,
    },
}

impl Stopped {
    /// Why, in words.
    pub fn describe(&self) -> &str {
        match self {
            Stopped::Falsified { detail }
            | Stopped::Unbounded { detail }
            | Stopped::Solver { detail }
            | Stopped::Unsupported { detail } => detail,
        }
    }
}

/// A consistent verdict's training free-run fit (−∞ otherwise).
pub(super) fn fit_of(t: &TrainVerdict) -> f64 {
    match t {
        TrainVerdict::Consistent { fit_percent, .. } => *fit_percent,
        _ => f64::NEG_INFINITY,
    }
}

/// A consistent verdict's noise bound (+∞ otherwise).
pub(super) fn bound_of(t: &TrainVerdict) -> f64 {
    match t {
        TrainVerdict::Consistent { bound, .. } => *bound,
        _ => f64::INFINITY,
    }
}

/// The best training free-run fit among the admissible candidates (−∞ when none is).
pub(super) fn best_fit<'a>(evidence: impl Iterator<Item = &'a Evidence>) -> f64 {
    evidence
        .filter(|e| e.train.admissible())
        .map(|e| fit_of(&e.train))
        .fold(f64::NEG_INFINITY, f64::max)
}

#[cfg(test)]
pub(super) mod tests {
    use super::*;

    #[test]
    fn reach_orders_located_findings_by_record_then_sample_and_proves_nothing_unlocated() {
        let f = |stage, record, sample, located| TrainVerdict::Falsified {
            stage,
            record,
            sample,
            located,
            detail: String::new(),
        };
        let lin = Stage::Linear;
        // A later record beats a later sample of an earlier one.
        assert!(f(lin, 1, 10, true).reach() > f(lin, 0, 300, true).reach());
        assert!(f(lin, 0, 300, true).reach() > f(lin, 0, 10, true).reach());
        // Not located: the sample is where the search stopped (the record's end), not a
        // proven prefix; any located finding of the stage reaches further.
        assert!(f(lin, 0, 1, true).reach() > f(lin, 2, 999, false).reach());
        // Stages still come first, and a consistent model beats every finding.
        assert!(f(lin, 0, 0, false).reach() > f(Stage::InnerSignal, 3, 999, true).reach());
        let ok = TrainVerdict::Consistent {
            fit_percent: 0.0,
            bound: 1.0,
            unsettled: None,
            within: None,
        };
        assert!(ok.reach() > f(lin, 9, 999, true).reach());
    }

    /// A candidate's evidence for the rule's tests: `label` (also its tag) adding `added`
    /// parameters, consistent at a bound of `1e-3` with the free-run fit `fit`, or failed
    /// without one.
    pub(in crate::diagnose) fn evidence(label: &str, added: usize, fit: Option<f64>) -> Evidence {
        Evidence {
            label: label.into(),
            tag: label.into(),
            added_parameters: added,
            priors: Vec::new(),
            train: match fit {
                Some(f) => TrainVerdict::Consistent {
                    fit_percent: f,
                    bound: 1e-3,
                    unsettled: None,
                    within: None,
                },
                None => TrainVerdict::Failed {
                    message: "falsified".into(),
                },
            },
            chosen: false,
            equivalent_to: Vec::new(),
            untried: None,
        }
    }
}
