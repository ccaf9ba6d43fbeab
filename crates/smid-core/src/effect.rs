//! Effects: the terms of the one model beside its nonlinearities. The model smid identifies is
//!
//! ```text
//! v_t = N_in(u_t)                        (Hammerstein or Hammerstein-Wiener; else v = u)
//! A(q^-1) x_t = B(q^-1) v_{t-nk} + Σ_k c_k φ_k(t)                 (eq 1 plus equation terms)
//! w_t = N_out(x_t)                       (Wiener; else w = x)
//! y_t = w_t + s_t + η_t,   s_t ∈ S_t(ψ),   |η_t| <= Δη             (eqs 4-5 plus sensor terms)
//! ```
//!
//! An [`Effect`] is one term of it, of one of three kinds, each a capability with a default
//! that does nothing (like argmin's traits: one required method):
//!
//! * **orders** ([`Effect::orders`]): one more sample of delay (`nk`), one more pole (`na`,
//!   e.g. an actuator lag), one more zero (`nb`); bounded by stage 3 as coefficients of `A`, `B`;
//! * **equation terms** ([`Effect::regressors`]): known regressors `φ_k(t)` (a velocity, its
//!   sign...) whose coefficients `c_k` stage 3 bounds beside `θ`; they vanish at steady state,
//!   so stage 1 is unchanged;
//! * **sensor terms** ([`Effect::sensor`]): an additive output term `s_t` (an offset, a drift,
//!   the error of a quantiser) known up to parameters `ψ` ([`Effect::cell_parameters`]), which
//!   the branch and bound of [`crate::cells`] bisects over a prior box; every stage sees the
//!   outputs `y - s` with `s` as an interval over the cell, so the bounds stay guaranteed.
//!
//! The same effect, given its true values, is also applied by the built-in simulator
//! ([`Effect::plant_factor`], [`Effect::plant_equation`], [`Effect::plant_output`]), so that data
//! with an undeclared effect need no FMU. Effects register with `typetag` (the `type` tag) and
//! with [`register_effect!`] (schema, example with true values, diagnosis candidates); the core
//! names none of them.
use crate::error::{Result, SmidError};
use crate::interval::Interval;
use serde::{Deserialize, Serialize};
use std::fmt::Debug;

/// Orders of the linear block: `A` of order `na`, `B` with coefficients `b_0..b_nb`, input
/// delay `nk` (the equation reads `v_{t-nk-j}`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct Orders {
    pub na: usize,
    pub nb: usize,
    pub nk: usize,
}

/// The signals of one record from which equation terms are computed.
#[derive(Debug, Clone, Copy)]
pub struct Signals<'a> {
    /// The measured input `u_t`.
    pub u: &'a [f64],
    /// Sample time in seconds (1 when unknown).
    pub dt: f64,
    /// The linear block's output `x_t` as far as it is known: the stage-2 bounds in
    /// identification (an interval per sample), the simulated values (degenerate intervals) in a
    /// simulation, where only `x[..t]` exists when the regressor at `t` is asked for. `None`:
    /// not available (column names only).
    pub x: Option<&'a [Interval]>,
}

impl<'a> Signals<'a> {
    /// Signals of the input alone.
    pub fn input(u: &'a [f64], dt: f64) -> Self {
        Signals { u, dt, x: None }
    }
}

/// A named regressor column `φ_k(t)`, one interval per sample of the record (exact values are
/// degenerate intervals; a regressor of the uncertain output is an interval that holds its
/// value; not finite where unknown). Contract: causal (the value at `t` reads `u[..=t]` and
/// `x[..t]` only).
#[derive(Debug, Clone, PartialEq)]
pub struct Column {
    pub name: String,
    pub values: Vec<Interval>,
}

impl Column {
    /// A column of exact values.
    pub fn exact(name: impl Into<String>, values: impl IntoIterator<Item = f64>) -> Self {
        Column {
            name: name.into(),
            values: values.into_iter().map(|v| Interval::new(v, v)).collect(),
        }
    }
}

/// The scale of the training data, from which diagnosis candidates take a default prior box
/// for their sensor parameters (reported as such: a prior from the data's range, not a given)
/// and effects their resolution.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DataScale {
    /// Largest `|y|` over the training records.
    pub y_max: f64,
    /// Longest training record (samples), steady-state record included.
    pub length: usize,
    /// Range of the outputs `[min y, max y]` and of the inputs.
    pub y_range: (f64, f64),
    pub u_range: (f64, f64),
}

/// One term of the model. Required: [`Effect::label`]; every capability defaults to "none".
///
/// ```
/// use smid_core::effect::{Effect, Orders};
/// use smid_core::interval::Interval;
/// use serde::{Deserialize, Serialize};
///
/// /// A sensor bias `s_t = d`, `d` bisected over its prior box.
/// #[derive(Debug, Clone, Serialize, Deserialize)]
/// struct Bias { value: Option<f64> }
///
/// #[typetag::serde(name = "doc_bias")]
/// impl Effect for Bias {
///     fn label(&self) -> String { "sensor bias".into() }
///     fn cell_parameters(&self) -> Vec<String> { vec!["bias".into()] }
///     fn sensor(&self, _t: Option<usize>, cell: &[Interval]) -> smid_core::Result<Interval> {
///         Ok(cell[0])
///     }
///     fn plant_output(&self, _t: usize, w: f64) -> f64 { w + self.value.unwrap_or(0.0) }
/// }
///
/// let e: Box<dyn Effect> = serde_json::from_str(r#"{"type":"doc_bias","value":0.5}"#).unwrap();
/// assert_eq!(e.sensor(Some(3), &[Interval::new(0.1, 0.2)]).unwrap(), Interval::new(0.1, 0.2));
/// assert_eq!(e.plant_output(3, 1.0), 1.5);
/// let mut o = Orders { na: 2, nb: 2, nk: 0 };
/// e.orders(&mut o);
/// assert_eq!(o.na, 2);
/// ```
#[typetag::serde(tag = "type")]
pub trait Effect: Debug + Send + Sync {
    /// Human-readable name for reports (e.g. "sensor offset"). Required.
    fn label(&self) -> String;

    // ---- the model side ------------------------------------------------------------------
    /// Change the linear orders (delay, extra pole or zero). Default: none.
    fn orders(&self, _orders: &mut Orders) {}
    /// Equation regressors of one record (causal). Default: none.
    fn regressors(&self, _signals: &Signals) -> Vec<Column> {
        Vec::new()
    }
    /// The regressors at sample `t` alone, from `u[..=t]` and `x[..t]` (a simulation asks
    /// sample by sample when [`Effect::uses_output`]). Default: from [`Effect::regressors`].
    fn regressors_at(&self, signals: &Signals, t: usize) -> Vec<f64> {
        self.regressors(signals)
            .iter()
            .map(|c| c.values.get(t).map_or(0.0, |v| v.center()))
            .collect()
    }
    /// Whether the regressors read the linear block's output (then a simulation computes them
    /// sample by sample from its own output). Default: no.
    fn uses_output(&self) -> bool {
        false
    }
    /// Whether the equation terms vanish at steady state (stage 1 from steady-state data assumes
    /// so). Default: yes. A constant term does not: it needs data without the designed
    /// steady-state experiment.
    fn vanishes_at_steady_state(&self) -> bool {
        true
    }
    /// Names of the sensor parameters `ψ` that the branch and bound bisects. Default: none.
    fn cell_parameters(&self) -> Vec<String> {
        Vec::new()
    }
    /// Default prior box of [`Effect::cell_parameters`] for a diagnosis candidate, from the
    /// training data's scale. Default: `|ψ| <= y_max`.
    fn default_prior(&self, scale: &DataScale) -> Vec<Interval> {
        self.cell_parameters()
            .iter()
            .map(|_| Interval::new(-scale.y_max, scale.y_max))
            .collect()
    }
    /// The resolution of each of [`Effect::cell_parameters`]: the branch and bound stops
    /// halving a cell narrower than this. Default: `Δη / 2` (a sensor parameter in output
    /// units then widens the noise by at most a quarter of its bound).
    fn resolution(&self, delta: f64, _scale: &DataScale) -> Vec<f64> {
        vec![0.5 * delta; self.cell_parameters().len()]
    }
    /// The sensor term `s_t` at sample `t` of its record (`None`: the time is unknown, e.g.
    /// measured steady-state points) over the cell `ψ ∈ cell` of this effect's parameters:
    /// a guaranteed interval. Default: `[0, 0]`.
    fn sensor(&self, _t: Option<usize>, _cell: &[Interval]) -> Result<Interval> {
        Ok(Interval::new(0.0, 0.0))
    }
    /// Settings this effect carries (a quantiser's step...), for reports. Default: none.
    fn settings(&self) -> Vec<(String, f64)> {
        Vec::new()
    }

    // ---- the plant side (the built-in simulator, with true values) -----------------------
    /// Check that the true values a simulator needs are given; errors name the field.
    fn validate_plant(&self) -> Result<()> {
        Ok(())
    }
    /// A unit-gain linear factor `F(q^-1) = Bf/Af` in series with the linear block (a delay
    /// `q^-1`, an actuator lag `(1-p)/(1 - p q^-1)`): `(Af without its leading 1, Bf)`.
    /// Default: none.
    fn plant_factor(&self) -> Option<(Vec<f64>, Vec<f64>)> {
        None
    }
    /// The term `c φ(t)` this effect adds to the linear equation, per sample. Default: none.
    fn plant_equation(&self, _signals: &Signals) -> Option<Vec<f64>> {
        None
    }
    /// The measured output for the true output `w` at sample `t` (offset, drift, quantiser).
    /// Default: `w`.
    fn plant_output(&self, _t: usize, w: f64) -> f64 {
        w
    }
    /// True values of the model parameters this effect adds (sensor parameters and equation
    /// coefficients, by name), when the effect is a simulator's. Default: none.
    fn truth(&self) -> Vec<(String, f64)> {
        Vec::new()
    }
}

/// A copy of an effect (trait objects cannot derive `Clone`): a round trip through its
/// serialised form, which every registered effect has.
pub fn clone_effect(e: &dyn Effect) -> Box<dyn Effect> {
    let v = serde_json::to_value(e).expect("effects serialise");
    serde_json::from_value(v).expect("a serialised effect deserialises")
}

impl Clone for Box<dyn Effect> {
    fn clone(&self) -> Self {
        clone_effect(self.as_ref())
    }
}

/// The `type` tag of an effect.
pub fn tag_of(e: &dyn Effect) -> String {
    serde_json::to_value(e)
        .ok()
        .and_then(|v| v.get("type").and_then(|t| t.as_str()).map(String::from))
        .unwrap_or_default()
}

/// Two effects are the same term when they serialise alike.
pub fn same_effect(a: &dyn Effect, b: &dyn Effect) -> bool {
    serde_json::to_value(a).ok() == serde_json::to_value(b).ok()
}

/// A registered effect: its `type` tag, the schema of its fields, a fully specified example
/// (true values given: what the simulator injects in checks) and the candidates diagnosis
/// tries (open values).
pub struct EffectEntry {
    pub tag: &'static str,
    pub schema: fn(&mut schemars::SchemaGenerator) -> schemars::Schema,
    /// An instance with every true value given.
    pub example: fn() -> Box<dyn Effect>,
    /// Candidates with open values, for `smid diagnose`.
    pub candidates: fn() -> Vec<Box<dyn Effect>>,
    /// Order of preference when candidates explain the training data equally well (lower
    /// first).
    pub priority: u32,
}

inventory::collect!(EffectEntry);

/// Registered effects, by priority then tag.
pub fn effects() -> Vec<&'static EffectEntry> {
    let mut v: Vec<_> = inventory::iter::<EffectEntry>.into_iter().collect();
    v.sort_by_key(|e| (e.priority, e.tag));
    v
}

/// The valid effect `type` names.
pub fn effect_types() -> Vec<&'static str> {
    effects().iter().map(|e| e.tag).collect()
}

/// Register an effect: `register_effect!("tag", Type, priority, example_expr, [candidates...])`.
#[macro_export]
macro_rules! register_effect {
    ($tag:literal, $ty:ty, $prio:expr, $example:expr, [$($cand:expr),* $(,)?]) => {
        $crate::inventory::submit! {
            $crate::effect::EffectEntry {
                tag: $tag,
                schema: |g| <$ty as $crate::schemars::JsonSchema>::json_schema(g),
                example: || -> ::std::boxed::Box<dyn $crate::effect::Effect> {
                    ::std::boxed::Box::new($example)
                },
                candidates: || -> ::std::vec::Vec<::std::boxed::Box<dyn $crate::effect::Effect>> {
                    ::std::vec![$(::std::boxed::Box::new($cand) as ::std::boxed::Box<dyn $crate::effect::Effect>),*]
                },
                priority: $prio,
            }
        }
    };
}

/// The orders after every effect's change.
pub fn augmented(base: Orders, effects: &[Box<dyn Effect>]) -> Orders {
    let mut o = base;
    for e in effects {
        e.orders(&mut o);
    }
    o
}

/// The sensor interval `Σ_e s_e(t)` of a list of effects over a cell, where `cells[i]` is the
/// slice of the cell that belongs to effect `i`.
pub fn sensor_sum(
    effects: &[Box<dyn Effect>],
    cells: &[&[Interval]],
    t: Option<usize>,
) -> Result<Interval> {
    let mut lo = 0.0;
    let mut hi = 0.0;
    for (e, c) in effects.iter().zip(cells) {
        let s = e.sensor(t, c)?;
        if !(s.lo <= s.hi) {
            return Err(SmidError::invalid(
                format!("effect `{}`", e.label()),
                "its sensor interval is empty or not a number",
            ));
        }
        lo += s.lo;
        hi += s.hi;
    }
    if lo == 0.0 && hi == 0.0 {
        return Ok(Interval::new(0.0, 0.0));
    }
    Ok(Interval::new(lo, hi).outward())
}

/// The regressor columns of every effect on one record.
pub fn regressors(effects: &[Box<dyn Effect>], signals: &Signals) -> Vec<Column> {
    effects.iter().flat_map(|e| e.regressors(signals)).collect()
}
