//! Effects: the terms of the one model beside its nonlinearities. The model smid identifies is
//!
//! ```text
//! v_t = N_in(u_t)                        (Hammerstein or Hammerstein-Wiener; else v = u)
//! A(q^-1) x_t = B(q^-1) v_{t-nk} + Σ_k c_k φ_k(t)                 (eq 1 plus equation terms)
//! w_t = N_out(x_t)                       (Wiener; else w = x)
//! y_t = w_t + s_t + η_t,   s_t ∈ S_t(ψ),   |η_t| <= Δη             (eqs 4-5 plus sensor terms)
//! ```
//!
//! An [`Effect`] is one term of it, of one of three kinds on the model side, each a small
//! capability trait with one required method and defaults for the rest (argmin's style):
//!
//! * **orders** ([`OrderChange`]): one more sample of delay (`nk`), one more pole (`na`,
//!   e.g. an actuator lag), one more zero (`nb`); bounded by stage 3 as coefficients of `A`, `B`;
//! * **equation terms** ([`EquationTerm`]): known regressors `φ_k(t)` (a velocity, its
//!   sign...) whose coefficients `c_k` stage 3 bounds beside `θ`. Most vanish at steady state,
//!   so stage 1 is unchanged; one that does not (a constant, a parallel input path) names its
//!   shift at rest ([`EquationTerm::rest_parameter`]), which stage 1 then carries;
//! * **sensor terms** ([`SensorTerm`]): an additive output term `s_t` (an offset, a drift)
//!   known up to parameters `ψ`, which the branch and bound of [`crate::cells`] bisects over a
//!   prior box; every stage sees the outputs `y - s` with `s` as an interval over the cell, so
//!   the bounds stay guaranteed. A sensor may instead be a **map** of the true output
//!   (`additive` false: a quantiser, `y = step·round(w/step) + η`); it then says which true
//!   outputs give a measurement (`true_output`, possibly none, which rules the cell out) and
//!   what a member measures (`measure`). The model is `y = M(w) + Σ s + η`, the maps applied
//!   in list order ([`true_output`], [`measured`]).
//!
//! Apart from the model side, the plant side ([`PlantEffect`]) applies the same effect with its
//! true values in the built-in simulator, so that data with an undeclared effect need no FMU.
//! Effects register with `typetag` (the `type` tag) and with [`register_effect!`](crate::register_effect) (schema,
//! example with true values, diagnosis candidates); the core names none of them.
use crate::error::{Result, SmidError};
use crate::interval::Interval;
use serde::{Deserialize, Serialize};
use std::fmt::Debug;

/// Orders of the linear block: `A` of order `na`, `B` with coefficients `b_0..b_nb`, input
/// delay `nk` (the equation reads `v_{t-nk-j}`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct Orders {
    /// Order of `A(q^-1)`: the coefficients `a_1..a_na`.
    pub na: usize,
    /// Order of `B(q^-1)`: the coefficients `b_0..b_nb` (`nb + 1` of them).
    pub nb: usize,
    /// Input delay in samples.
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
    /// The column's coefficient name in `θ` (as reported).
    pub name: String,
    /// The regressor's interval at each sample of the record.
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
    /// Range of the outputs `(min y, max y)` over the training records.
    pub y_range: (f64, f64),
    /// Range of the inputs `(min u, max u)` over the training records.
    pub u_range: (f64, f64),
    /// The declared noise bound `Δη`, where the caller knows one (a diagnosis of a spec that
    /// declares it; `None` under `noise.estimate`): what a prior may not go below where a
    /// parameter smaller than the noise could not be told from it.
    pub noise: Option<f64>,
}

/// One term of the model: the serialised handle (`type` tag) and the list of what it can do.
/// Required: [`Effect::label`]. Each capability is a small trait of its own with one required
/// method (argmin's style), reached through an accessor that defaults to "not this kind":
///
/// * model side: [`OrderChange`] (orders), [`EquationTerm`] (equation regressors),
///   [`SensorTerm`] (an additive output term over bisected parameters);
/// * plant side: [`PlantEffect`] (what the built-in simulator applies, with true values).
///
/// An effect implements the capabilities it has and returns `Some(self)` from their accessors.
/// The rest of smid calls the capabilities through the methods on `dyn Effect` (which read
/// "none" where an accessor says so), never through a list of effect types.
///
/// ```
/// use smid_core::effect::{Effect, Orders, PlantEffect, SensorTerm};
/// use smid_core::interval::Interval;
/// use serde::{Deserialize, Serialize};
///
/// /// A sensor bias `s_t = d`, `d` bisected over its prior box.
/// #[derive(Debug, Clone, Serialize, Deserialize)]
/// struct Bias { value: Option<f64> }
///
/// impl SensorTerm for Bias {
///     fn sensor(&self, _t: Option<usize>, cell: &[Interval]) -> smid_core::Result<Interval> {
///         Ok(cell[0])
///     }
///     fn cell_parameters(&self) -> Vec<String> { vec!["level".into()] }
/// }
/// impl PlantEffect for Bias {
///     fn validate_plant(&self) -> smid_core::Result<()> { Ok(()) }
///     fn plant_output(&self, _t: usize, w: f64) -> f64 { w + self.value.unwrap_or(0.0) }
/// }
///
/// #[typetag::serde(name = "doc_bias")]
/// impl Effect for Bias {
///     fn label(&self) -> String { "sensor bias".into() }
///     fn as_sensor(&self) -> Option<&dyn SensorTerm> { Some(self) }
///     fn as_plant(&self) -> Option<&dyn PlantEffect> { Some(self) }
/// }
///
/// let e: Box<dyn Effect> = serde_json::from_str(r#"{"type":"doc_bias","value":0.5}"#).unwrap();
/// assert_eq!(e.sensor(Some(3), &[Interval::new(0.1, 0.2)]).unwrap(), Interval::new(0.1, 0.2));
/// assert_eq!(e.cell_parameters(), vec!["level".to_string()]);
/// assert_eq!(e.plant_output(3, 1.0), 1.5);
/// let mut o = Orders { na: 2, nb: 2, nk: 0 };
/// e.orders(&mut o); // not an order change: nothing happens
/// assert_eq!(o.na, 2);
/// assert!(e.as_equation().is_none());
/// ```
#[typetag::serde(tag = "type")]
pub trait Effect: Debug + Send + Sync {
    /// Human-readable name for reports (e.g. "sensor offset"). Required.
    fn label(&self) -> String;
    /// The effect changes the linear orders. Default: no.
    fn as_orders(&self) -> Option<&dyn OrderChange> {
        None
    }
    /// The effect adds regressors to the linear equation. Default: no.
    fn as_equation(&self) -> Option<&dyn EquationTerm> {
        None
    }
    /// The effect adds a sensor term to the output. Default: no.
    fn as_sensor(&self) -> Option<&dyn SensorTerm> {
        None
    }
    /// The built-in simulator can apply the effect with its true values. Default: no (a
    /// simulator refuses it by name).
    fn as_plant(&self) -> Option<&dyn PlantEffect> {
        None
    }
    /// Settings this effect carries (a quantiser's step...), for reports. Default: none.
    fn settings(&self) -> Vec<(String, f64)> {
        Vec::new()
    }
}

/// Model side: one more sample of delay (`nk`), one more pole (`na`, an actuator lag), one
/// more zero (`nb`); stage 3 bounds the new coefficients of `A`, `B` (eq 1).
pub trait OrderChange {
    /// Change the linear orders. Required.
    fn orders(&self, orders: &mut Orders);
}

/// Model side: known regressors `φ_k(t)` whose coefficients `c_k` stage 3 bounds beside `θ`.
pub trait EquationTerm {
    /// Equation regressors of one record (causal). Required.
    fn regressors(&self, signals: &Signals) -> Vec<Column>;
    /// The regressors at sample `t` alone, from `u[..=t]` and `x[..t]` (a simulation asks
    /// sample by sample when [`EquationTerm::uses_output`]). Default: from
    /// [`EquationTerm::regressors`].
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
    /// Whether the designed steady-state experiment stays valid with this term in the plant:
    /// under the filtered square wave the linear block's output approaches each level without
    /// overshoot (Appendix, Proposition 1), which stage 1's polygons (eqs 13-20) assume. A
    /// term linear in the signals changes the linear block only, and the Appendix designs the
    /// filter on the plant with it. A term that switches while the signal settles does not:
    /// dry friction turns off once the velocity falls into its dead band, a step in the
    /// equation after the filter that no filter pole short of the quasi-static one avoids,
    /// and the backlash then holds the overshoot. Default: yes. With a term that says no,
    /// steady-state points reach a Wiener nonlinearity with parameters only through a prior box
    /// (`model.prior`: the points prune its cells with any history), never through the
    /// polygons ([`crate::spec::ModelSpec::term_breaking_steady_design`]).
    fn keeps_steady_design(&self) -> bool {
        true
    }
    /// A term that does not vanish at rest may still be used with steady-state data when it
    /// only **shifts** the linear block's output there by an amount its parameter fixes: with
    /// unit gain (eq 8), `x̄ = v̄ + s` (a constant term `c`: `s = c/A(1)`; a shift that
    /// grows with the input, [`EquationTerm::rest_shift`]). The shift's parameter is then one
    /// of its own, named here, that the branch and bound bisects over
    /// [`EquationTerm::rest_prior`]; stage 1 carries each steady point over the cell as
    /// `x̄ = v̄ + s`, and stage 3 bounds the term's coefficients beside `θ` as before (the
    /// coupling `c = A(1)·s` is left out: a relaxation, so every bound stays guaranteed).
    /// Default: none (the term vanishes at rest, or steady-state data are refused with it).
    fn rest_parameter(&self) -> Option<String> {
        None
    }
    /// The default prior box of [`EquationTerm::rest_parameter`] from the training data's
    /// scale. Default: `|s|` up to half the input's range (the rest input `v̄` lives in it).
    fn rest_prior(&self, scale: &DataScale) -> Interval {
        let h = 0.5 * (scale.u_range.1 - scale.u_range.0).abs();
        Interval::new(-h, h)
    }
    /// The shift `x̄ - v̄` of the linear block's output at rest (`v̄` its input), at the
    /// **measured** steady input `u` (an interval; the terms' regressors read the measured
    /// input, before any block) over the cell `s` of [`EquationTerm::rest_parameter`]: a
    /// guaranteed interval. The rest parameter is the term's shift at the unit measured input,
    /// `Σ c_k φ_k / A(1)` on a record at rest at `ū = 1`; a term whose shift grows with the
    /// input says how here. Default: `s`, whatever the input (a constant shift). A parallel
    /// path `c·u_t` gives `u·s` (`x̄ = v̄ + ū·c/A(1)`).
    fn rest_shift(&self, u: Interval, s: Interval) -> Interval {
        let _ = u;
        s
    }
}

/// Model side: an output term `s_t` (an offset, a drift) known up to parameters `ψ` that the
/// branch and bound bisects (eqs 4-5 plus `s_t`), or a sensor map of the true output (a
/// quantiser; see [`SensorTerm::additive`]).
pub trait SensorTerm {
    /// The sensor term `s_t` at sample `t` of its record (`None`: the time is unknown, e.g.
    /// measured steady-state points) over the cell `ψ ∈ cell` of this term's parameters: a
    /// guaranteed interval. Required.
    fn sensor(&self, t: Option<usize>, cell: &[Interval]) -> Result<Interval>;
    /// Names of the parameters `ψ` that the branch and bound bisects. Default: none.
    fn cell_parameters(&self) -> Vec<String> {
        Vec::new()
    }
    /// Default prior box of [`SensorTerm::cell_parameters`] for a diagnosis candidate, from the
    /// training data's scale. Default: `|ψ| <= y_max`. Fewer boxes than parameters: these data
    /// give no prior, and the candidate is not offered.
    fn default_prior(&self, scale: &DataScale) -> Vec<Interval> {
        self.cell_parameters()
            .iter()
            .map(|_| Interval::new(-scale.y_max, scale.y_max))
            .collect()
    }
    /// The resolution of each of [`SensorTerm::cell_parameters`]: the branch and bound stops
    /// halving a cell narrower than this. Default: `Δη / 2` (a sensor parameter in output
    /// units then widens the noise by at most a quarter of its bound).
    fn resolution(&self, delta: f64, _scale: &DataScale) -> Vec<f64> {
        vec![0.5 * delta; self.cell_parameters().len()]
    }
    /// Whether the term is additive, `y = w + s_t`, so that [`SensorTerm::true_output`] and
    /// [`SensorTerm::measure`] are their defaults. Default: yes. A sensor that maps the true
    /// output (a quantiser: `y = step·round(w/step)`) says no and overrides both; its
    /// [`SensorTerm::sensor`] is then an enclosure of `y - w`, which the guaranteed output band
    /// uses.
    fn additive(&self) -> bool {
        true
    }
    /// The true outputs `w` that give a noise-free measurement in `y` (the measurement with its
    /// noise interval) for some `ψ` of the cell: a guaranteed interval, `None` when no `w` does
    /// (this sample falsifies the cell). Default: `y - s_t`.
    fn true_output(
        &self,
        t: Option<usize>,
        cell: &[Interval],
        y: Interval,
    ) -> Result<Option<Interval>> {
        let s = self.sensor(t, cell)?;
        Ok(Some(Interval::new(y.lo - s.hi, y.hi - s.lo)))
    }
    /// A sensor map's noise-free measurement of the true output `w` at the point `ψ` (a
    /// member's simulation). Asked of maps only: an additive term's `w + s_t` is added by
    /// [`measured`]. Default: `w`.
    fn measure(&self, _t: usize, _psi: &[f64], w: f64) -> f64 {
        w
    }
}

/// Plant side: the effect as the built-in simulator applies it, with true values, so that data
/// with an undeclared effect need no FMU.
pub trait PlantEffect {
    /// Check that the true values a simulator needs are given; errors name the field. Required.
    fn validate_plant(&self) -> Result<()>;
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
    /// coefficients, by name). Default: none.
    fn truth(&self) -> Vec<(String, f64)> {
        Vec::new()
    }
}

/// The capabilities read through the handle: each answers "none" (the capability's neutral
/// value) where the effect does not have it. This is the only place that reads the accessors
/// for the model's and the simulator's code.
impl<'a> dyn Effect + 'a {
    /// [`OrderChange::orders`], or no change.
    pub fn orders(&self, orders: &mut Orders) {
        if let Some(c) = self.as_orders() {
            c.orders(orders)
        }
    }
    /// [`EquationTerm::regressors`], or none.
    pub fn regressors(&self, signals: &Signals) -> Vec<Column> {
        self.as_equation()
            .map(|c| c.regressors(signals))
            .unwrap_or_default()
    }
    /// [`EquationTerm::regressors_at`], or none.
    pub fn regressors_at(&self, signals: &Signals, t: usize) -> Vec<f64> {
        self.as_equation()
            .map(|c| c.regressors_at(signals, t))
            .unwrap_or_default()
    }
    /// [`EquationTerm::uses_output`], or no.
    pub fn uses_output(&self) -> bool {
        self.as_equation().is_some_and(|c| c.uses_output())
    }
    /// [`EquationTerm::vanishes_at_steady_state`], or yes (nothing to vanish).
    pub fn vanishes_at_steady_state(&self) -> bool {
        self.as_equation()
            .is_none_or(|c| c.vanishes_at_steady_state())
    }
    /// [`EquationTerm::keeps_steady_design`], or yes (no equation term).
    pub fn keeps_steady_design(&self) -> bool {
        self.as_equation().is_none_or(|c| c.keeps_steady_design())
    }
    /// [`EquationTerm::rest_parameter`] of a term that does not vanish at rest, or none.
    pub fn rest_parameter(&self) -> Option<String> {
        self.as_equation()
            .filter(|c| !c.vanishes_at_steady_state())
            .and_then(|c| c.rest_parameter())
    }
    /// [`SensorTerm::cell_parameters`], or none: the bisected parameters every model with
    /// this term has.
    pub fn sensor_parameters(&self) -> Vec<String> {
        self.as_sensor()
            .map(|c| c.cell_parameters())
            .unwrap_or_default()
    }
    /// The parameters this term may have bisected: its `sensor_parameters`, then the
    /// [`EquationTerm::rest_parameter`], which a model has only where its prior box is given
    /// (`model.prior`; the diagnosis gives it with steady-state data).
    pub fn cell_parameters(&self) -> Vec<String> {
        let mut v = self.sensor_parameters();
        v.extend(self.rest_parameter());
        v
    }
    /// Whether steady-state data can be used with this term in a model whose bisected
    /// parameters have the prior boxes `prior`: it vanishes at rest, or its shift there is a
    /// parameter with a prior box.
    pub fn steady_state_usable(
        &self,
        prior: &std::collections::BTreeMap<String, [f64; 2]>,
    ) -> bool {
        self.vanishes_at_steady_state()
            || self
                .rest_parameter()
                .is_some_and(|n| prior.contains_key(&n))
    }
    /// [`SensorTerm::default_prior`], then [`EquationTerm::rest_prior`], or none.
    pub fn default_prior(&self, scale: &DataScale) -> Vec<Interval> {
        let mut v = self
            .as_sensor()
            .map(|c| c.default_prior(scale))
            .unwrap_or_default();
        if self.rest_parameter().is_some() {
            v.extend(self.as_equation().map(|c| c.rest_prior(scale)));
        }
        v
    }
    /// [`SensorTerm::resolution`], then a sixteenth of the rest shift's prior (the shift is
    /// told from the nonlinearity's own parameters only as far as the data allow: finer cells
    /// cost a stage 3 each and, where the data cannot tell them apart, decide nothing), or
    /// none.
    pub fn resolution(&self, delta: f64, scale: &DataScale) -> Vec<f64> {
        let mut v = self
            .as_sensor()
            .map(|c| c.resolution(delta, scale))
            .unwrap_or_default();
        if self.rest_parameter().is_some() {
            v.extend(
                self.as_equation()
                    .map(|c| 2.0 * c.rest_prior(scale).radius() / 16.0),
            );
        }
        v
    }
    /// [`SensorTerm::sensor`], or `[0, 0]`.
    pub fn sensor(&self, t: Option<usize>, cell: &[Interval]) -> Result<Interval> {
        match self.as_sensor() {
            Some(c) => c.sensor(t, cell),
            None => Ok(Interval::new(0.0, 0.0)),
        }
    }
    /// [`PlantEffect::validate_plant`]; an effect without a plant side is refused by name.
    pub fn validate_plant(&self) -> Result<()> {
        match self.as_plant() {
            Some(c) => c.validate_plant(),
            None => Err(SmidError::invalid(
                "type",
                format!(
                    "effect `{}` has no plant side (`PlantEffect`): the built-in simulator \
                     cannot apply it; use it in `model.effects`, or give the plant as data or an FMU",
                    tag_of(self)
                ),
            )),
        }
    }
    /// [`PlantEffect::plant_factor`], or none.
    pub fn plant_factor(&self) -> Option<(Vec<f64>, Vec<f64>)> {
        self.as_plant().and_then(|c| c.plant_factor())
    }
    /// [`PlantEffect::plant_equation`], or none.
    pub fn plant_equation(&self, signals: &Signals) -> Option<Vec<f64>> {
        self.as_plant().and_then(|c| c.plant_equation(signals))
    }
    /// [`PlantEffect::plant_output`], or `w`.
    pub fn plant_output(&self, t: usize, w: f64) -> f64 {
        self.as_plant().map_or(w, |c| c.plant_output(t, w))
    }
    /// [`PlantEffect::truth`], or none.
    pub fn truth(&self) -> Vec<(String, f64)> {
        self.as_plant().map(|c| c.truth()).unwrap_or_default()
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
    /// The effect's `type` tag in a spec (`model.effects[].type`).
    pub tag: &'static str,
    /// The Cargo package that registered it (the macro reads the registering crate's
    /// `CARGO_PKG_NAME`).
    pub package: &'static str,
    /// The JSON Schema of the effect's fields, for the spec schema.
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

impl EffectEntry {
    /// The registered example with every non-integer value scaled by `f`, in a list too (a
    /// true effect of another size, as the checks draw them; integers are settings).
    pub fn scaled_example(&self, f: f64) -> Result<Box<dyn Effect>> {
        let bad = |e: serde_json::Error| {
            SmidError::invalid("effect", format!("`{}` scaled by {f}: {e}", self.tag))
        };
        let scale = |x: &mut serde_json::Value| {
            if let Some(n) = x.as_f64().filter(|_| !(x.is_u64() || x.is_i64())) {
                *x = serde_json::json!(n * f);
            }
        };
        let mut v = serde_json::to_value((self.example)()).map_err(bad)?;
        if let Some(o) = v.as_object_mut() {
            for (_, x) in o.iter_mut() {
                match x.as_array_mut() {
                    Some(list) => list.iter_mut().for_each(scale),
                    None => scale(x),
                }
            }
        }
        serde_json::from_value(v).map_err(bad)
    }
}

/// The registered effect `tag`.
pub fn effect_entry(tag: &str) -> Result<&'static EffectEntry> {
    effects().into_iter().find(|e| e.tag == tag).ok_or_else(|| {
        SmidError::invalid(
            "effect",
            format!(
                "no effect `{tag}`; the registered ones are {:?}",
                effect_types()
            ),
        )
    })
}

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
                package: ::std::env!("CARGO_PKG_NAME"),
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
    sum_over(
        effects
            .iter()
            .map(|e| e.as_ref())
            .zip(cells.iter().copied()),
        t,
    )
}

/// [`sensor_sum`] over `(effect, its cell)` pairs.
fn sum_over<'a>(
    terms: impl Iterator<Item = (&'a dyn Effect, &'a [Interval])>,
    t: Option<usize>,
) -> Result<Interval> {
    let mut lo = 0.0;
    let mut hi = 0.0;
    for (e, c) in terms {
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

/// Effect `e`'s sensor when it is a map (not additive; see [`SensorTerm::additive`]).
pub fn sensor_map(e: &dyn Effect) -> Option<&dyn SensorTerm> {
    e.as_sensor().filter(|s| !s.additive())
}

fn is_map(e: &dyn Effect) -> bool {
    sensor_map(e).is_some()
}

/// The true output `w` (centre, radius) behind a measurement `y ± dy` over a cell, where
/// `cells[i]` is effect `i`'s slice: the model is `y = M(w) + Σ s + η` with the sensor maps `M`
/// of the effects that have one applied in list order and the additive terms after them. The
/// additive sum is subtracted (with no map, exactly `y - centre(s)`, `dy + radius(s)`, the
/// arithmetic of eqs 4-5 with `s_t`), then each map is inverted, last first. `None`: a map
/// rules the measurement out over this cell.
pub fn true_output(
    effects: &[Box<dyn Effect>],
    cells: &[&[Interval]],
    t: Option<usize>,
    y: f64,
    dy: f64,
) -> Result<Option<(f64, f64)>> {
    if !effects.iter().any(|e| is_map(e.as_ref())) {
        let s = sensor_sum(effects, cells, t)?;
        return Ok(Some((y - s.center(), dy + s.radius())));
    }
    let s = sum_over(
        effects
            .iter()
            .map(|e| e.as_ref())
            .zip(cells.iter().copied())
            .filter(|(e, _)| !is_map(*e)),
        t,
    )?;
    let mut w = Interval::new(y - dy - s.hi, y + dy - s.lo).outward();
    for (e, c) in effects.iter().zip(cells).rev() {
        if let Some(m) = sensor_map(e.as_ref()) {
            match m.true_output(t, c, w)? {
                Some(v) if v.lo <= v.hi => w = v.outward(),
                Some(_) => {
                    return Err(SmidError::invalid(
                        format!("effect `{}`", e.label()),
                        "its true-output interval is empty or not a number",
                    ))
                }
                None => return Ok(None),
            }
        }
    }
    Ok(Some((w.center(), w.radius())))
}

/// The noise-free measurement of the true output `w` at sample `t` for the parameter point
/// `psi[i]` of effect `i`: the maps in list order, then the additive terms (the model of
/// [`true_output`]). With no map, exactly `w + centre(Σ s)`.
pub fn measured(effects: &[Box<dyn Effect>], psi: &[&[f64]], t: usize, w: f64) -> f64 {
    let mut y = w;
    for (e, p) in effects.iter().zip(psi) {
        if let Some(m) = sensor_map(e.as_ref()) {
            y = m.measure(t, p, y);
        }
    }
    let cells: Vec<Vec<Interval>> = psi
        .iter()
        .map(|p| p.iter().map(|&v| Interval::new(v, v)).collect())
        .collect();
    let add = effects
        .iter()
        .map(|e| e.as_ref())
        .zip(cells.iter().map(|c| c.as_slice()))
        .filter(|(e, _)| !is_map(*e));
    y + sum_over(add, Some(t)).map_or(0.0, |s| s.center())
}

/// The shift of the linear block's output at rest at the measured steady input `u`, summed over the
/// terms that name one ([`EquationTerm::rest_parameter`], [`EquationTerm::rest_shift`]), over a
/// cell where `cells[i]` is effect `i`'s slice (the rest parameter last in it): a guaranteed
/// interval, `[0, 0]` when no term names one.
pub fn rest_shift(effects: &[Box<dyn Effect>], cells: &[&[Interval]], u: Interval) -> Interval {
    let (mut lo, mut hi) = (0.0, 0.0);
    for (e, c) in effects.iter().zip(cells) {
        // The shift is in the cell only where the model has it (its prior given), after the
        // sensor's parameters.
        if e.rest_parameter().is_some() && c.len() > e.sensor_parameters().len() {
            if let (Some(s), Some(term)) = (c.last(), e.as_equation()) {
                let d = term.rest_shift(u, *s);
                lo += d.lo;
                hi += d.hi;
            }
        }
    }
    if lo == 0.0 && hi == 0.0 {
        Interval::new(0.0, 0.0)
    } else {
        Interval::new(lo, hi).outward()
    }
}

/// The regressor columns of every effect on one record.
pub fn regressors(effects: &[Box<dyn Effect>], signals: &Signals) -> Vec<Column> {
    effects.iter().flat_map(|e| e.regressors(signals)).collect()
}
