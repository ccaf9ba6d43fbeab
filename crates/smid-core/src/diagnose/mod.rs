//! Diagnosis: trace what the model lacks to one of the registered effects, on the **training
//! data only**, then report the error before and after on held-out records touched once.
//!
//! * **Candidates**, generated from the registries: every registered effect (delay, actuator
//!   lag, sensor offset or drift, friction, quantisation...) not yet in the model, each added to
//!   the model as one more term ([`crate::effect`]), and every registered plugin with a default
//!   prior as a chain block at the input side's front and the output side's end
//!   ([`crate::chain`]); bisected parameters get a prior box from the training data's scale
//!   (reported). An input block that breaks the designed steady-state experiment gives the
//!   model's nonlinearity a box from the steady-state points too
//!   ([`crate::pipeline::design_prior`], an assumption, reported), inside which the points
//!   prune the cells with any history.
//! * **Equivalences**: candidates whose members simulate the training records within twice
//!   the noise bound of each other after both transients from rest, or whose member put into
//!   the other's model class does (by an equation-error or an output-error fit), and the
//!   rule's ties (admissible, as many parameters, fits within the noise's slack), are reported
//!   as indistinguishable, never silently chosen between. The equation-error way searches the
//!   gain between the linear block and the block after it too (the inner signal's scale is
//!   each class's convention: `k·L` then `N(·/k)` is the same model).
//! * **Choice (training data only)**: the base model and every candidate are identified on the
//!   training records with the declared noise bound. A model is *admissible* when its feasible
//!   set is not empty (the training data do not falsify it). When the base model is admissible
//!   nothing is missing: "no missing effect found", the model is unchanged. Otherwise the
//!   admissible candidate with the fewest added parameters is chosen, ties broken by the
//!   free-run fit of its centre member on the training records (a parsimony rule, like an
//!   information criterion with an infinite price on inconsistency). When no candidate is
//!   admissible, the one whose first contradiction comes latest in the data (it explains the
//!   longest stretch) is kept and a further round adds another effect to it, up to
//!   `max_effects`. With an estimated bound (`noise.estimate`) every model is admissible at
//!   its own bound: a candidate is kept when it lowers the base model's bound by the rule's
//!   step per added parameter and simulates as well; every candidate's bound is bracketed
//!   first, and only the candidates that could be the pick or its equivalents are identified
//!   whole ([`TrainVerdict::Bracketed`] for the rest).
//! * **Final table**: only then are the held-out records read: before and after are validated
//!   on them ([`crate::validate`]). A base model that the training data falsify has no member;
//!   for the table it is re-identified at the smallest noise bound that makes its training
//!   data consistent (said in the table).
//!
//! The rooms: `verdict` (what the training data said: [`TrainVerdict`], [`Evidence`],
//! [`Round`], [`Choice`], [`Column`]), `comparison` and `gain` (free runs compared, a member
//! put into another model class), `equivalence` (equivalences and the rule's ties), `trying`
//! (one model identified on the training records), `screen` (candidates the base model's class
//! reproduces), `rule` (the picks), `bracket` (a round's candidates bracketed and identified),
//! `schedule` (which brackets a round takes on and which candidates it identifies),
//! `candidates` (generation and design priors), `rounds` (the rounds and [`choose`]) and
//! `assess` (the before/after table).
mod assess;
mod bracket;
mod candidates;
mod comparison;
mod equivalence;
mod gain;
mod rounds;
mod rule;
mod schedule;
mod screen;
mod trying;
mod verdict;

pub use assess::{assess, identify_consistent};
pub use candidates::{candidates, inside_the_loop, offered_with_steady_points, FEEDBACK};
pub use rounds::choose;
pub use screen::reproduced_by_base;
pub use trying::{candidate_spec, training_fit, with_model};
pub use verdict::{Choice, Column, Evidence, Round, Stopped, TrainVerdict};

/// The choice rule's tunables, checked: the spec's `diagnosis` section
/// ([`crate::spec::DiagnosisSpec`]).
pub type Rule = crate::settings::Checked<crate::spec::DiagnosisSpec>;

/// Options of a diagnosis.
#[derive(Debug, Clone)]
pub struct Options {
    /// Effects added at most.
    pub max_effects: usize,
    /// Restrict the candidates to these `type` tags, or `feedback` for the output side inside
    /// the loop (empty: every candidate).
    pub only: Vec<String>,
    /// Horizon of the k-step prediction in the final table.
    pub k: usize,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            max_effects: 2,
            only: Vec::new(),
            k: 5,
        }
    }
}

/// The label of the base model in equivalence lists.
pub const AS_DECLARED: &str = "the model as declared";
