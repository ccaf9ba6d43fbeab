//! A finding about the plant: the data falsify the model at a stage (paper Sections 3-5) and a
//! `(record, sample)`. The plain data that both an [`crate::outcome::Outcome`] (the status the
//! boundaries return) and [`crate::SmidError::Inconsistent`] (the proof travelling out of the
//! engines) carry; it imports nothing of the crate, so neither of those two modules needs the
//! other to name it.
use serde::Serialize;

/// Identification stage, used to say where a feasible set became empty.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub enum Stage {
    /// Stage 1: nonlinearity parameters from steady-state data (paper Section 3).
    SteadyState,
    /// Stage 2: inner-signal bounds (paper Section 4).
    InnerSignal,
    /// Stage 3: linear-block parameters (paper Section 5).
    Linear,
}

impl std::fmt::Display for Stage {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Stage::SteadyState => "stage 1 (nonlinearity parameters from steady-state data)",
            Stage::InnerSignal => "stage 2 (inner-signal bounds)",
            Stage::Linear => "stage 3 (linear-block parameters)",
        })
    }
}

/// Where and why the data falsify the model: the first offending sample of the record, or,
/// when the proof did not look for it (`located: false`: a verdict that only needs to know
/// *whether* the data are inconsistent), a sample by which they are.
#[derive(Debug, Clone, PartialEq, Serialize)]
// Out-of-tree plugins build one with `Falsification::new` (and `in_record`, `unlocated`):
// fields may be added without breaking them.
#[non_exhaustive]
pub struct Falsification {
    /// The stage whose proof found the contradiction.
    pub stage: Stage,
    /// Index of the record (training records in identification, fresh records in validation;
    /// 0 for stage 1, whose sample is a steady-state point).
    pub record: usize,
    /// The first offending sample within that record (or steady-state point); with
    /// `located: false`, a sample up to which the data are inconsistent (the first offending
    /// one lies at or before it).
    pub sample: usize,
    /// Whether `sample` is the first offending one.
    pub located: bool,
    /// What contradicts what, in words (e.g. which parameter's set became empty).
    pub detail: String,
}

impl Falsification {
    /// A falsification at `sample` of record 0 (a plugin's or a stage's proof; the boundary
    /// that knows the record sets it with [`Falsification::in_record`]).
    pub fn new(stage: Stage, sample: usize, detail: impl Into<String>) -> Self {
        Falsification {
            stage,
            record: 0,
            sample,
            located: true,
            detail: detail.into(),
        }
    }
    /// A falsification by the data up to `sample` of record 0, the first offending sample not
    /// looked for.
    pub fn unlocated(stage: Stage, sample: usize, detail: impl Into<String>) -> Self {
        Falsification {
            located: false,
            ..Falsification::new(stage, sample, detail)
        }
    }
    /// The finding as a sentence (what the CLI prints, the error's message inside the
    /// engines).
    pub fn message(&self) -> String {
        format!("the data are inconsistent with the model and noise bound: {self}")
    }
    /// The same finding in record `record`.
    pub fn in_record(mut self, record: usize) -> Self {
        self.record = record;
        self
    }
}

impl std::fmt::Display for Falsification {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        if self.located {
            write!(f, "{}: first offending sample {}", self.stage, self.sample)?;
        } else {
            write!(
                f,
                "{}: inconsistent up to sample {}",
                self.stage, self.sample
            )?;
        }
        if self.record > 0 {
            write!(f, " of record {}", self.record)?;
        }
        write!(f, " ({})", self.detail)
    }
}
