//! Stage 3 (paper Section 5): guaranteed bounds on the linear-block parameters
//! `θ = [a_1..a_na, b_0..b_nb, c_1..c_m]` (eq 7, extended by the coefficients of extra
//! regressors) from interval-valued inner signals, an errors-in-variables problem. Each equation
//! `x_t + Σ a_i x_{t-i} - Σ b_j v_{t-j} - Σ c_k φ_k(t) = 0` (eq 1 with additive effect terms
//! `φ_k`: offset, drift, friction...) holds for the true signals, known only as intervals
//! `x_s = x^c_s + δx_s`, `|δx_s| <= Δx_s` (eqs 28-30; output side), `v_s` (input side; exact for
//! Wiener) and `φ_k(s)` (exact or uncertain). The unit steady-state gain (eq 8) is
//! `Σ b_j - Σ a_i = 1` (the extras do not enter it). An optional prior box on θ is intersected
//! with every method's start.
//!
//! The problem and result types ([`EivProblem`], [`EivResult`]) live in `problem.rs`; the
//! method trait ([`Stage3Method`]), the method names ([`EivMethod`], used by specs) and the
//! open, link-time registry ([`register_stage3!`](crate::register_stage3), [`method`],
//! [`by_name`], [`all`], [`names`], [`configured`] for a spec's `method.options`, [`solve`])
//! in `method.rs`; this module re-exports both. Each method lives in its own file, names and
//! registers itself there, and imports only this module and the shared pieces ([`relax`],
//! [`ipm`], [`certify`]):
//!
//! | method | file | starts from |
//! |---|---|---|
//! | `classical` | [`classical`]: orthant-wise LP outer set (Cerone 1993) | the problem |
//! | `shared` (default) | [`shared`]: shared-error McCormick relaxation, iterated | `classical` |
//! | `sdp` | the crate `smid-sdp`: moment relaxation (its feature `openblas`) | `shared` |
//! | `exact-grid` | [`exact_grid`]: exact-set reference on a grid of the a-plane | `shared` |
//!
//! A method that starts from another one names it in [`Stage3Method::start`]; the chaining goes
//! through the registry ([`Stage3Method::solve`]), so no method file imports another.
pub mod certify;
pub mod classical;
pub mod exact_grid;
pub mod ipm;
mod method;
mod problem;
pub mod relax;
pub mod shared;
pub mod testutil;
pub(crate) mod working_set;

pub use method::{
    all, by_name, configured, feasible, method, names, parse_options, prior_start, solve,
    with_parsed_options, ConfiguredMethod, EivMethod, MethodEntry, Stage3Method,
};
pub use problem::{stable_prior, theta_names, EivProblem, EivResult, Flattened, Regressor};

#[cfg(test)]
mod tests;
