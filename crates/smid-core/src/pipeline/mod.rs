//! The identification pipeline of the paper, for any nonlinearity plugin, structure and
//! effects: acquire data (run the experiments on a [`crate::plant::Plant`], or take measured records), then
//! for each cell of the bisected parameters (one cell when there are none) stage 1
//! (nonlinearity parameter set from steady-state data, Section 3), stage 2 (inner-signal bounds,
//! Section 4: inversion for Wiener, propagation for Hammerstein, of outputs corrected by the
//! sensor terms), stage 3 (linear parameters and equation terms, Section 5,
//! [`crate::stage3`]). The cells are searched by [`crate::cells`]; the result is a
//! [`crate::model::ModelSet`] with the run's artifacts for reports.
//!
//! The stage functions ([`stage1`], [`stage2`], [`stage3`]) are public: validation runs the same
//! stages on fresh records with the identified sets as constraints.
//!
//! The private files, one concern each: `acquire` (data), `stages` (stages 1-3 over a cell),
//! `search` (the branch and bound and the hulls), `estimate` (the noise bound from the data),
//! `bracket` (the bracket of an estimated bound and the identification at the bound it keeps),
//! `signs` (stage 3 over the sign patterns of samples with a two-sided preimage).
//! Everything is re-exported here, so callers name `pipeline::stage2`, `pipeline::identify`...
mod acquire;
mod bracket;
mod estimate;
mod search;
pub mod signs;
mod stages;

pub use acquire::*;
pub use bracket::*;
pub use estimate::*;
pub use search::*;
pub use stages::*;

pub use crate::model::{ParamResult, Record};
