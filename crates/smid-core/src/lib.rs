//! # smid-core
//!
//! The core of smid, a framework for set-membership (bounded-error) identification of
//! block-oriented nonlinear systems. It holds the plugin traits ([`nonlinearity`]), the
//! engines (exact 2-D [`polygon`]s, interval [`inversion`], the [`lp`] polytope bounder and the
//! errors-in-variables stage 3 [`stage3`]), plants and experiments, the YAML [`spec`], the
//! three-stage [`pipeline`], reports and plots. It names no nonlinearity plugin.
//!
//! Equation numbers refer to Cerone, Piga & Regruto, "Parameter bounds evaluation for linear
//! system with output backlash" (`../shared/paper/output-backlash-paper.md`).
#![forbid(unsafe_code)]
#![warn(missing_docs)]

pub mod band;
pub mod baseline;
pub mod cells;
pub mod chain;
pub mod data;
pub mod diagnose;
pub mod effect;
pub mod error;
pub mod exact;
pub mod experiment;
pub mod finding;
pub mod interval;
pub mod inversion;
pub mod linear;
pub mod lp;
pub mod members;
pub mod model;
pub mod noise;
pub mod nonlinearity;
pub mod outcome;
pub mod output;
pub mod pipeline;
pub mod plant;
pub mod plot;
pub mod polygon;
pub mod registry;
pub mod report;
pub mod settings;
pub mod signals;
pub mod sparse_lp;
pub mod spec;
pub mod stage3;
pub mod validate;

pub use error::{Result, SmidError, Stage};
pub use outcome::{Falsification, Outcome};

// Re-exported for the plugin registration macros (`register_nonlinearity!`, `register_model!`).
#[doc(hidden)]
pub use inventory;
/// Re-exported so a plugin draws its check trials ([`nonlinearity::NonlinearityModel::check_draw`])
/// with the same `rand` as the core.
pub use rand;
#[doc(hidden)]
pub use schemars;

/// The names a plugin author needs.
pub mod prelude {
    pub use crate::error::{Result, SmidError, Stage};
    pub use crate::interval::Interval;
    pub use crate::inversion::{
        check_outputs, invert_branch, propagate_static, InnerBound, InnerKind,
    };
    pub use crate::nonlinearity::{
        two_branch_polygons, two_branch_regions, two_branches_contain, CheckDraw, Nonlinearity,
        NonlinearityModel, NonlinearitySet, ParameterBound, Region, SteadyPoint, SteadyStateData,
        Structure,
    };
    pub use crate::outcome::{Falsification, Outcome};
    pub use crate::polygon::{Polygon, Strip};
    pub use rand::{Rng, RngCore};
}
