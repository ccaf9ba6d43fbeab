//! What identification and validation conclude, as a status (the idea of Clarabel's
//! `SolverStatus`): an [`Outcome`] is `Consistent` (with the guaranteed result) or `Falsified`
//! (the feasible set of eqs 16-20 / 23-30 is empty: a finding about the plant, with the stage
//! and the `(record, sample)` that proved it). Errors ([`crate::SmidError`]) are for what went
//! wrong: bad input, a solver failure, a plant that failed.
//!
//! Inside the engines a proof of emptiness short-circuits the stages with `?` as
//! [`crate::SmidError::Inconsistent`], which carries the same [`Falsification`]; the
//! boundaries (a cell's verdict, [`crate::pipeline::identify`], validation, the noise-bound
//! estimate, the diagnosis) turn it into an outcome, so no public entry point of
//! identification or validation returns a falsification as an error.
pub use crate::finding::Falsification;

/// The conclusion of an identification or a check of a model against data.
#[derive(Debug)]
pub enum Outcome<T> {
    /// The data are consistent with the model at the declared bound; `T` holds the guaranteed
    /// result.
    Consistent(T),
    /// The data falsify the model.
    Falsified(Falsification),
}

impl<T> Outcome<T> {
    /// The result when consistent.
    pub fn consistent(self) -> Option<T> {
        match self {
            Outcome::Consistent(t) => Some(t),
            Outcome::Falsified(_) => None,
        }
    }
    /// The finding when falsified.
    pub fn falsification(&self) -> Option<&Falsification> {
        match self {
            Outcome::Consistent(_) => None,
            Outcome::Falsified(f) => Some(f),
        }
    }
    /// Whether the data are consistent with the model (no falsification).
    pub fn is_consistent(&self) -> bool {
        matches!(self, Outcome::Consistent(_))
    }
    /// Apply `f` to the result when consistent; a falsification passes through unchanged.
    pub fn map<U>(self, f: impl FnOnce(T) -> U) -> Outcome<U> {
        match self {
            Outcome::Consistent(t) => Outcome::Consistent(f(t)),
            Outcome::Falsified(x) => Outcome::Falsified(x),
        }
    }
    /// The result; panics with the finding when falsified (for tests and examples whose data
    /// are known to be consistent).
    #[track_caller]
    pub fn unwrap(self) -> T {
        match self {
            Outcome::Consistent(t) => t,
            Outcome::Falsified(f) => panic!("the data falsify the model: {f}"),
        }
    }
    /// The result, or the finding as [`crate::SmidError::Inconsistent`]: for an edge (the CLI,
    /// a test, a script) where a falsification ends the work like an error does.
    pub fn into_result(self) -> crate::Result<T> {
        match self {
            Outcome::Consistent(t) => Ok(t),
            Outcome::Falsified(f) => Err(crate::SmidError::Inconsistent(f)),
        }
    }
}

/// A stage's result as an outcome: a proof of emptiness becomes `Falsified`, every other error
/// stays an error.
pub fn lift<T>(r: crate::Result<T>) -> crate::Result<Outcome<T>> {
    match r {
        Ok(t) => Ok(Outcome::Consistent(t)),
        Err(crate::SmidError::Inconsistent(f)) => Ok(Outcome::Falsified(f)),
        Err(e) => Err(e),
    }
}
