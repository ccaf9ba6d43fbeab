//! Stage 3 (paper Section 5): guaranteed bounds on the linear-block parameters
//! `θ = [a_1..a_na, b_0..b_nb]` (eq 7) from interval-valued inner signals, an errors-in-variables
//! problem. Each equation `x_t + Σ a_i x_{t-i} - Σ b_j v_{t-j} = 0` (eq 1) holds for the true
//! signals, known only as intervals `x_s = x^c_s + δx_s`, `|δx_s| <= Δx_s` (eqs 28-30; output
//! side) and `v_s` (input side; exact for Wiener). The unit steady-state gain (eq 8) is
//! `Σ b_j - Σ a_i = 1`.
//!
//! This module holds the problem and result types ([`EivProblem`], [`EivResult`]), the method
//! trait ([`Stage3Method`]), the method names ([`EivMethod`], used by specs) and the registry
//! ([`method`], [`by_name`], [`all`], [`solve`]). Each method lives in its own file and imports
//! only this module and the shared pieces (`relax`):
//!
//! | method | file | starts from |
//! |---|---|---|
//! | `classical` | [`classical`]: orthant-wise LP outer set (Cerone 1993) | the problem |
//! | `shared` (default) | [`shared`]: shared-error McCormick relaxation, iterated | `classical` |
//! | `sdp` | [`sdp`]: moment relaxation (feature `sdp`) | `shared` |
//! | `exact-grid` | [`exact_grid`]: exact-set reference on a grid of the a-plane | `shared` |
//!
//! A method that starts from another one names it in [`Stage3Method::start`]; the chaining goes
//! through the registry ([`Stage3Method::solve`]), so no method file imports another.
use crate::error::Result;
use crate::interval::Interval;
use crate::inversion::{InnerBound, InnerKind};
use serde::{Deserialize, Serialize};

pub mod classical;
pub mod exact_grid;
pub(crate) mod relax;
pub mod sdp;
pub mod shared;
#[cfg(test)]
pub(crate) mod testutil;

/// The EIV problem of stage 3.
#[derive(Debug, Clone)]
pub struct EivProblem<'a> {
    /// Order of `A`.
    pub na: usize,
    /// Order of `B` (coefficients `b_0..b_nb`).
    pub nb: usize,
    /// Fixed values per parameter in θ order (`None` = free).
    pub fixed: Vec<Option<f64>>,
    /// Impose the unit steady-state gain (eq 8).
    pub unit_gain: bool,
    /// Output-side inner-signal bounds `x_t`.
    pub output: &'a [InnerBound],
    /// Input-side signal bounds `v_t` (exact for Wiener: degenerate intervals).
    pub input: &'a [Interval],
    /// Also use equations whose samples are only band-bounded (wide but valid).
    pub use_band_samples: bool,
}

/// Stage-3 result: one guaranteed interval per parameter, and the equations used.
#[derive(Debug, Clone)]
pub struct EivResult {
    pub bounds: Vec<Interval>,
    /// Time indices `t` of the equations used.
    pub equations: Vec<usize>,
    /// Number of sign orthants whose LP was feasible.
    pub feasible_orthants: usize,
}

/// Parameter names in θ order: `a1..a_na, b0..b_nb`.
pub fn theta_names(na: usize, nb: usize) -> Vec<String> {
    (1..=na)
        .map(|i| format!("a{i}"))
        .chain((0..=nb).map(|j| format!("b{j}")))
        .collect()
}

impl EivProblem<'_> {
    /// Number of θ entries.
    pub fn p(&self) -> usize {
        self.na + self.nb + 1
    }

    /// Parameter names in θ order.
    pub fn names(&self) -> Vec<String> {
        theta_names(self.na, self.nb)
    }

    fn usable(&self, b: &InnerBound) -> bool {
        b.interval.is_finite()
            && (b.kind == InnerKind::Inverted
                || (self.use_band_samples && b.kind == InnerKind::Band))
    }

    /// Time indices whose equation involves only usable samples.
    pub fn equation_times(&self) -> Vec<usize> {
        let n = self.output.len().min(self.input.len());
        let start = self.na.max(self.nb);
        (start..n)
            .filter(|&t| (0..=self.na).all(|i| self.usable(&self.output[t - i])))
            .filter(|&t| (0..=self.nb).all(|j| self.input[t - j].is_finite()))
            .collect()
    }
}

/// Stage-3 method.
#[derive(
    Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, schemars::JsonSchema, Default,
)]
#[serde(rename_all = "snake_case")]
pub enum EivMethod {
    /// Orthant-wise LP outer set of Section 5 (Cerone 1993): each equation's error bounded on
    /// its own.
    Classical,
    /// Shared-error relaxation: the inner-signal errors are variables shared by consecutive
    /// equations, products relaxed by McCormick envelopes, box shrunk until the radii settle
    /// ([`crate::stage3::shared`]). Never wider than `classical`; close to the exact set.
    #[default]
    Shared,
    /// Moment (SDP) relaxation on each equation's clique of consecutive samples, bounds by weak
    /// duality ([`crate::stage3::sdp`]); needs the cargo feature `sdp`. Never wider than `shared`.
    Sdp,
    /// Exact set measured on a grid of the a-plane (na <= 2, Wiener): outer hull of feasible
    /// cells reported, inner hull of consistent points measured ([`crate::stage3::exact_grid`]).
    #[serde(rename = "exact-grid", alias = "exact_grid")]
    ExactGrid,
}

impl EivMethod {
    /// Every method, in documentation order.
    pub const ALL: [EivMethod; 4] = [
        EivMethod::Classical,
        EivMethod::Shared,
        EivMethod::Sdp,
        EivMethod::ExactGrid,
    ];

    /// Whether this build can run the method (`sdp` needs the cargo feature `sdp`).
    pub fn available(self) -> bool {
        method(self).available()
    }

    /// The name used in specs and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            EivMethod::Classical => "classical",
            EivMethod::Shared => "shared",
            EivMethod::Sdp => "sdp",
            EivMethod::ExactGrid => "exact-grid",
        }
    }
    /// Parse a name as used in specs (`classical`, `shared`, `sdp`, `exact-grid`).
    pub fn from_name(s: &str) -> Option<Self> {
        Self::ALL
            .into_iter()
            .find(|m| m.name() == s || m.name().replace('-', "_") == s)
    }
}

/// A stage-3 method: maps an [`EivProblem`] to guaranteed θ intervals.
///
/// One required method, [`solve_from`](Self::solve_from), refines a guaranteed start box; the
/// rest have defaults. [`solve`](Self::solve) checks the problem ([`check`](Self::check)), gets
/// the start from the method named by [`start`](Self::start) through the registry (or the
/// problem's own box when `None`) and refines it. A method is never wider than its start.
///
/// ```
/// use smid_core::stage3::{EivProblem, EivResult, Stage3Method};
/// use smid_core::Result;
///
/// /// Reports its start unchanged: guaranteed (the start is), if not informative.
/// struct Keep;
/// impl Stage3Method for Keep {
///     fn solve_from(&self, _prob: &EivProblem, start: EivResult) -> Result<EivResult> {
///         Ok(start)
///     }
/// }
///
/// let (output, input) = (Vec::new(), Vec::new());
/// let prob = EivProblem {
///     na: 0,
///     nb: 0,
///     fixed: vec![Some(1.0)],
///     unit_gain: false,
///     output: &output,
///     input: &input,
///     use_band_samples: false,
/// };
/// let start = EivResult {
///     bounds: vec![smid_core::interval::Interval::new(1.0, 1.0)],
///     equations: vec![],
///     feasible_orthants: 0,
/// };
/// assert_eq!(Keep.solve_from(&prob, start).unwrap().bounds[0].lo, 1.0);
/// ```
pub trait Stage3Method: Send + Sync {
    /// Guaranteed θ bounds of `prob`, starting from the guaranteed result `start` (never wider
    /// than it). Required.
    fn solve_from(&self, prob: &EivProblem, start: EivResult) -> Result<EivResult>;

    /// The name used in messages (the built-in methods use their spec names).
    fn name(&self) -> &'static str {
        std::any::type_name::<Self>()
    }

    /// Whether this build can run the method (e.g. a cargo feature it needs is on).
    fn available(&self) -> bool {
        true
    }

    /// The method whose result this one starts from; `None`: from the problem alone.
    fn start(&self) -> Option<EivMethod> {
        None
    }

    /// Refuse a problem this method cannot handle (before any start is computed), with an
    /// error saying why; `Ok` by default.
    fn check(&self, _prob: &EivProblem) -> Result<()> {
        Ok(())
    }

    /// Guaranteed θ bounds of `prob`: [`check`](Self::check), then the start (the result of
    /// [`start`](Self::start) through the registry), then [`solve_from`](Self::solve_from).
    fn solve(&self, prob: &EivProblem) -> Result<EivResult> {
        self.check(prob)?;
        let start = match self.start() {
            Some(m) => solve(m, prob)?,
            None => unbounded_start(prob),
        };
        self.solve_from(prob, start)
    }
}

/// The start of a method that starts from the problem alone: every free parameter unbounded,
/// fixed ones at their values, every usable equation.
pub fn unbounded_start(prob: &EivProblem) -> EivResult {
    EivResult {
        bounds: (0..prob.p())
            .map(|k| match prob.fixed.get(k).copied().flatten() {
                Some(v) => Interval::new(v, v),
                None => Interval::entire(),
            })
            .collect(),
        equations: prob.equation_times(),
        feasible_orthants: 0,
    }
}

static CLASSICAL: classical::Classical = classical::Classical;
static SHARED: shared::Shared = shared::Shared {
    opts: shared::SharedOptions::DEFAULT,
};
static SDP: sdp::Sdp = sdp::Sdp {
    opts: sdp::SdpOptions::DEFAULT,
};
static EXACT_GRID: exact_grid::ExactGrid = exact_grid::ExactGrid {
    opts: exact_grid::ExactOptions::DEFAULT,
};

/// The registered implementation of `m` (default options).
pub fn method(m: EivMethod) -> &'static dyn Stage3Method {
    match m {
        EivMethod::Classical => &CLASSICAL,
        EivMethod::Shared => &SHARED,
        EivMethod::Sdp => &SDP,
        EivMethod::ExactGrid => &EXACT_GRID,
    }
}

/// The method of a spec name (`classical`, `shared`, `sdp`, `exact-grid`; `_` for `-` too).
pub fn by_name(name: &str) -> Option<&'static dyn Stage3Method> {
    EivMethod::from_name(name).map(method)
}

/// Every method with its implementation, in documentation order (including those this build
/// cannot run: see [`Stage3Method::available`]).
pub fn all() -> impl Iterator<Item = (EivMethod, &'static dyn Stage3Method)> {
    EivMethod::ALL.into_iter().map(|m| (m, method(m)))
}

/// Stage 3 by the chosen method (the pipeline's entry point).
pub fn solve(m: EivMethod, prob: &EivProblem) -> Result<EivResult> {
    method(m).solve(prob)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_registry_knows_every_method_by_its_spec_name() {
        for (m, imp) in all() {
            assert_eq!(imp.name(), m.name());
            assert_eq!(by_name(m.name()).map(|i| i.name()), Some(m.name()));
            assert_eq!(
                by_name(&m.name().replace('-', "_")).map(|i| i.name()),
                Some(m.name())
            );
            // A start is an earlier method: the chain ends.
            if let Some(s) = imp.start() {
                assert!(
                    method(s).start() != Some(m),
                    "{} <-> {}",
                    m.name(),
                    s.name()
                );
            }
        }
        assert_eq!(
            method(EivMethod::Shared).start(),
            Some(EivMethod::Classical)
        );
        assert!(by_name("simplex").is_none());
        assert!(EivMethod::Classical.available() && EivMethod::Shared.available());
        assert_eq!(EivMethod::Sdp.available(), cfg!(feature = "sdp"));
    }
}
