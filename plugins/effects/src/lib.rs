//! # smid-effects
//!
//! The bundled effects: terms of the one model (see `smid_core::effect` for the model they
//! extend), each usable in a model (`model.effects`, values open, bounded by identification) and
//! in the built-in simulator (`plant.simulator.effects`, true values given):
//!
//! | tag | kind | model | plant (true values) |
//! |---|---|---|---|
//! | `delay` | order | `nk += samples` | input delayed by `samples` |
//! | `actuator_lag` | order | `na += 1` (one more pole) | unit-gain lag `(1-p)/(1-p q^-1)` before the linear block |
//! | `extra_zero` | order | `nb += 1` | unit-gain zero `(1 + z q^-1)/(1+z)` |
//! | `offset` | sensor | `s_t = offset`, bisected | `y += offset` |
//! | `drift` | sensor | `s_t = offset + drift·t` (t: sample of the record), bisected | `y += offset + drift·t` |
//! | `quantization` | sensor map | `y = step·round(w/step)`: `w` within `step/2` of a lattice value `k·step` in `y ± Δη`; `step` declared or bisected | `w` rounded to the step |
//! | `coulomb_friction` | equation | `c · sign(u_t - u_{t-1})` (0 below 1e-3 of the largest move) | the same term with `value` |
//! | `viscous_friction` | equation | `c · (u_t - u_{t-1})/dt` | the same term with `value` |
//! | `constant` | equation | `c · 1` | the same term with `value` |
//! | `parallel_input` | equation | `c · u_t` | the same term with `value` |
//! | `input_power` | equation | `Σ_j c_j · u_{t-d-j}^p` (`degree` p, `delay` d, `lags`) | the same terms with `values` |
//!
//! The friction terms read the input velocity: they vanish at steady state, so stage 1 holds.
//! `constant`, `parallel_input` and `input_power` do not vanish at rest; each names its shift
//! there (`EquationTerm::rest_parameter`), which stage 1 carries as a further parameter.
#![forbid(unsafe_code)]
#![warn(missing_docs)]

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};
use smid_core::effect::{
    Column, DataScale, Effect, EquationTerm, OrderChange, Orders, PlantEffect, SensorTerm, Signals,
};
use smid_core::interval::Interval;
use smid_core::register_effect;
use smid_core::{Result, SmidError};

/// A true value a simulator needs: present and finite, else an error naming the field.
fn need(v: Option<f64>, field: &str) -> Result<f64> {
    match v {
        Some(x) if x.is_finite() => Ok(x),
        Some(x) => Err(SmidError::invalid(
            field,
            format!("expected a finite number, got {x}"),
        )),
        None => Err(SmidError::invalid(
            field,
            "a simulator needs the true value of this effect",
        )),
    }
}

fn opt(name: &str, v: Option<f64>) -> Vec<(String, f64)> {
    v.map(|x| vec![(name.to_string(), x)]).unwrap_or_default()
}

fn one() -> usize {
    1
}

/// Dead time of the linear block: the equation reads the input `samples` later.
#[derive(Debug, Clone, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Delay {
    /// Samples of delay (default 1).
    #[serde(default = "one")]
    pub samples: usize,
}

impl OrderChange for Delay {
    fn orders(&self, o: &mut Orders) {
        o.nk += self.samples;
    }
}

impl PlantEffect for Delay {
    fn validate_plant(&self) -> Result<()> {
        if self.samples == 0 || self.samples > 1000 {
            return Err(SmidError::invalid("samples", "expected 1..=1000"));
        }
        Ok(())
    }
    fn plant_factor(&self) -> Option<(Vec<f64>, Vec<f64>)> {
        let mut b = vec![0.0; self.samples + 1];
        b[self.samples] = 1.0;
        Some((Vec::new(), b))
    }
}

#[typetag::serde(name = "delay")]
impl Effect for Delay {
    fn label(&self) -> String {
        if self.samples == 1 {
            "one more sample of delay".into()
        } else {
            format!("{} more samples of delay", self.samples)
        }
    }
    fn as_orders(&self) -> Option<&dyn OrderChange> {
        Some(self)
    }
    fn as_plant(&self) -> Option<&dyn PlantEffect> {
        Some(self)
    }
}
register_effect!(
    "delay",
    Delay,
    5,
    Delay { samples: 1 },
    [Delay { samples: 1 }]
);

/// One more pole: a first-order actuator lag of unit gain before the linear block.
#[derive(Debug, Clone, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct ActuatorLag {
    /// The lag's pole `p` (`0 <= p < 1`): its true value in a simulator; left out in a model,
    /// where it is identified.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub pole: Option<f64>,
}

impl OrderChange for ActuatorLag {
    fn orders(&self, o: &mut Orders) {
        o.na += 1;
    }
}

impl PlantEffect for ActuatorLag {
    fn validate_plant(&self) -> Result<()> {
        let p = need(self.pole, "pole")?;
        if !(0.0..1.0).contains(&p) {
            return Err(SmidError::invalid(
                "pole",
                format!("expected 0 <= p < 1, got {p}"),
            ));
        }
        Ok(())
    }
    fn plant_factor(&self) -> Option<(Vec<f64>, Vec<f64>)> {
        let p = self.pole.unwrap_or(0.0);
        Some((vec![-p], vec![1.0 - p]))
    }
    fn truth(&self) -> Vec<(String, f64)> {
        opt("actuator_pole", self.pole)
    }
}

#[typetag::serde(name = "actuator_lag")]
impl Effect for ActuatorLag {
    fn label(&self) -> String {
        "one more pole (actuator lag)".into()
    }
    fn as_orders(&self) -> Option<&dyn OrderChange> {
        Some(self)
    }
    fn as_plant(&self) -> Option<&dyn PlantEffect> {
        Some(self)
    }
}
register_effect!(
    "actuator_lag",
    ActuatorLag,
    6,
    ActuatorLag { pole: Some(0.3) },
    [ActuatorLag { pole: None }]
);

/// One more zero, of unit gain: `(1 + z q^-1)/(1 + z)`.
#[derive(Debug, Clone, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct ExtraZero {
    /// The zero's coefficient `z` (`|z| < 1`): its true value in a simulator; left out in a
    /// model, where it is identified.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub zero: Option<f64>,
}

impl OrderChange for ExtraZero {
    fn orders(&self, o: &mut Orders) {
        o.nb += 1;
    }
}

impl PlantEffect for ExtraZero {
    fn validate_plant(&self) -> Result<()> {
        let z = need(self.zero, "zero")?;
        if !(z.abs() < 1.0) {
            return Err(SmidError::invalid(
                "zero",
                format!("expected |z| < 1, got {z}"),
            ));
        }
        Ok(())
    }
    fn plant_factor(&self) -> Option<(Vec<f64>, Vec<f64>)> {
        let z = self.zero.unwrap_or(0.0);
        Some((Vec::new(), vec![1.0 / (1.0 + z), z / (1.0 + z)]))
    }
}

#[typetag::serde(name = "extra_zero")]
impl Effect for ExtraZero {
    fn label(&self) -> String {
        "one more zero".into()
    }
    fn as_orders(&self) -> Option<&dyn OrderChange> {
        Some(self)
    }
    fn as_plant(&self) -> Option<&dyn PlantEffect> {
        Some(self)
    }
}
register_effect!(
    "extra_zero",
    ExtraZero,
    7,
    ExtraZero { zero: Some(0.5) },
    [ExtraZero { zero: None }]
);

/// A constant sensor offset: `y = w + offset + η`.
#[derive(Debug, Clone, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Offset {
    /// The true offset, in output units, in a simulator; left out in a model, where it is
    /// identified (bisected over its `model.prior` box, named `offset`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub value: Option<f64>,
}

impl SensorTerm for Offset {
    fn cell_parameters(&self) -> Vec<String> {
        vec!["offset".into()]
    }
    fn sensor(&self, _t: Option<usize>, cell: &[Interval]) -> Result<Interval> {
        Ok(cell[0])
    }
}

impl PlantEffect for Offset {
    fn validate_plant(&self) -> Result<()> {
        need(self.value, "value").map(|_| ())
    }
    fn plant_output(&self, _t: usize, w: f64) -> f64 {
        w + self.value.unwrap_or(0.0)
    }
    fn truth(&self) -> Vec<(String, f64)> {
        opt("offset", self.value)
    }
}

#[typetag::serde(name = "offset")]
impl Effect for Offset {
    fn label(&self) -> String {
        "sensor offset".into()
    }
    fn as_sensor(&self) -> Option<&dyn SensorTerm> {
        Some(self)
    }
    fn as_plant(&self) -> Option<&dyn PlantEffect> {
        Some(self)
    }
}
register_effect!(
    "offset",
    Offset,
    10,
    Offset { value: Some(0.01) },
    [Offset { value: None }]
);

/// A drifting sensor offset: `y_t = w_t + offset + drift·t + η_t`, `t` the sample index in its
/// record (the drift restarts with each record, as a sensor re-zeroed at each run).
#[derive(Debug, Clone, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Drift {
    /// The true offset at `t = 0`, in output units, in a simulator; left out in a model, where
    /// it is identified.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub offset: Option<f64>,
    /// The true drift per sample, in output units, in a simulator; left out in a model, where
    /// it is identified.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rate: Option<f64>,
}

impl SensorTerm for Drift {
    fn cell_parameters(&self) -> Vec<String> {
        vec!["offset".into(), "drift".into()]
    }
    fn default_prior(&self, s: &DataScale) -> Vec<Interval> {
        let r = 2.0 * s.y_max / s.length.max(1) as f64;
        vec![Interval::new(-s.y_max, s.y_max), Interval::new(-r, r)]
    }
    fn resolution(&self, delta: f64, s: &DataScale) -> Vec<f64> {
        vec![0.5 * delta, 0.5 * delta / s.length.max(1) as f64]
    }
    fn sensor(&self, t: Option<usize>, cell: &[Interval]) -> Result<Interval> {
        let t = t.ok_or_else(|| {
            SmidError::invalid(
                "model.effects: drift",
                "a drift needs the sample time of every output, and these steady-state points have none: give the steady-state CSV a time column in seconds (`plant.data.steady_state.t: <column>`)",
            )
        })? as f64;
        Ok(Interval::new(
            cell[0].lo + cell[1].lo * t,
            cell[0].hi + cell[1].hi * t,
        ))
    }
}

impl PlantEffect for Drift {
    fn validate_plant(&self) -> Result<()> {
        need(self.offset, "offset")?;
        need(self.rate, "rate").map(|_| ())
    }
    fn plant_output(&self, t: usize, w: f64) -> f64 {
        w + (self.offset.unwrap_or(0.0) + self.rate.unwrap_or(0.0) * t as f64)
    }
    fn truth(&self) -> Vec<(String, f64)> {
        let mut v = opt("offset", self.offset);
        v.extend(opt("drift", self.rate));
        v
    }
}

#[typetag::serde(name = "drift")]
impl Effect for Drift {
    fn label(&self) -> String {
        "sensor drift".into()
    }
    fn as_sensor(&self) -> Option<&dyn SensorTerm> {
        Some(self)
    }
    fn as_plant(&self) -> Option<&dyn PlantEffect> {
        Some(self)
    }
}
register_effect!(
    "drift",
    Drift,
    20,
    Drift {
        offset: Some(0.01),
        rate: Some(1e-5)
    },
    [Drift {
        offset: None,
        rate: None
    }]
);

/// A sensor coarser than the noise bound says: the measured output is the true output rounded
/// to a step, `y = step·round(w/step) + η`. The step is declared, or, left out, identified: the
/// branch and bound bisects it, and a cell of steps whose lattice `k·step` misses a measurement's
/// noise interval `y ± Δη` is ruled out, so the data themselves say which steps they were
/// rounded to (a step inferred from the size of the errors alone would only be a larger noise
/// bound). This makes the identified quantiser a diagnosis candidate.
#[derive(Debug, Clone, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Quantization {
    /// The quantiser's step (`> 0`); left out in a model, it is identified (bisected).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub step: Option<f64>,
}

impl Quantization {
    /// The step over a cell: the declared one, or the cell's (bisected) interval.
    fn steps(&self, cell: &[Interval]) -> Result<Interval> {
        let q = match self.step {
            Some(q) => Interval::new(q, q),
            None => *cell.first().ok_or_else(|| {
                SmidError::invalid("model.effects: quantization", "no cell for the step")
            })?,
        };
        if !(q.hi.is_finite() && q.hi > 0.0 && q.lo <= q.hi) {
            return Err(SmidError::invalid(
                "model.effects: quantization.step",
                format!("expected a step > 0, got [{}, {}]", q.lo, q.hi),
            ));
        }
        Ok(q)
    }
}

/// `w` rounded to the step `q` (unchanged without a positive step).
fn round_to(q: Option<f64>, w: f64) -> f64 {
    match q {
        Some(q) if q > 0.0 => q * (w / q).round(),
        _ => w,
    }
}

/// The lattice values `k·q`, `q ∈ [qa, qb]` (`0 < qa`), that lie in `y`: the hull of them, or
/// `None`. The ends are padded so that rounding never rules a lattice point out.
fn lattice_in(y: Interval, qa: f64, qb: f64) -> Option<Interval> {
    let pad = 1e-12 * (y.lo.abs() + y.hi.abs() + qb) + f64::MIN_POSITIVE;
    let (ya, yb) = (y.lo - pad, y.hi + pad);
    let (qa, qb) = (qa * (1.0 - 1e-12), qb * (1.0 + 1e-12));
    // k >= 1: k·qa <= yb and k·qb >= ya; k <= -1: k·qa >= ya and k·qb <= yb; k = 0: 0 in y.
    let pos = ((ya / qb).ceil().max(1.0), (yb / qa).floor());
    let neg = ((ya / qa).ceil(), (yb / qb).floor().min(-1.0));
    // The smallest and the largest k present.
    let zero = (ya <= 0.0 && 0.0 <= yb).then_some((0.0, 0.0));
    let present = [neg, pos]
        .into_iter()
        .filter(|r| r.0 <= r.1)
        .chain(zero)
        .fold(None, |acc: Option<(f64, f64)>, r| {
            Some(acc.map_or(r, |a| (a.0.min(r.0), a.1.max(r.1))))
        });
    let (kmin, kmax) = present?;
    let lo = ya.max((kmin * qa).min(kmin * qb));
    let hi = yb.min((kmax * qa).max(kmax * qb));
    Some(Interval::new(lo.min(hi), hi.max(lo)))
}

impl SensorTerm for Quantization {
    fn cell_parameters(&self) -> Vec<String> {
        if self.step.is_some() {
            Vec::new()
        } else {
            vec!["step".into()]
        }
    }
    /// Steps up to an eighth of the training outputs' range (at least eight levels), and at
    /// least four times the declared noise bound: the lattice then leaves gaps of at least
    /// `2Δη` between the noise intervals it can meet, so outputs that were not rounded fall
    /// into them and rule the step out; a finer step would only be a larger noise bound.
    /// Without a declared bound (`noise.estimate`) no prior: a step and the bound being
    /// estimated cannot be told apart, so the quantiser is not offered.
    fn default_prior(&self, s: &DataScale) -> Vec<Interval> {
        let span = (s.y_range.1 - s.y_range.0).abs().max(f64::MIN_POSITIVE);
        let Some(d) = s.noise else {
            return Vec::new();
        };
        let lo = (4.0 * d).min(span / 8.0);
        self.cell_parameters()
            .iter()
            .map(|_| Interval::new(lo, span / 8.0))
            .collect()
    }
    /// Fine enough for the lattice to tell steps apart at the largest output: `k·dq` below
    /// the noise bound for `k` up to `y_max/Δη`.
    fn resolution(&self, delta: f64, s: &DataScale) -> Vec<f64> {
        let r = 0.25 * delta * delta / s.y_max.max(delta);
        vec![r; self.cell_parameters().len()]
    }
    /// An enclosure of `y - w`: `|s_t| <= step/2`.
    fn sensor(&self, _t: Option<usize>, cell: &[Interval]) -> Result<Interval> {
        let h = 0.5 * self.steps(cell)?.hi;
        Ok(Interval::new(-h, h))
    }
    fn additive(&self) -> bool {
        false
    }
    /// `w ∈ [k·q - q/2, k·q + q/2]` for the lattice values `k·q` in `y`; none: ruled out.
    fn true_output(
        &self,
        _t: Option<usize>,
        cell: &[Interval],
        y: Interval,
    ) -> Result<Option<Interval>> {
        let q = self.steps(cell)?;
        let h = 0.5 * q.hi;
        if q.lo <= 0.0 {
            return Ok(Some(Interval::new(y.lo - h, y.hi + h)));
        }
        Ok(lattice_in(y, q.lo, q.hi).map(|k| Interval::new(k.lo - h, k.hi + h)))
    }
    fn measure(&self, _t: usize, psi: &[f64], w: f64) -> f64 {
        round_to(self.step.or(psi.first().copied()), w)
    }
}

impl PlantEffect for Quantization {
    fn validate_plant(&self) -> Result<()> {
        match self.step {
            Some(q) if q.is_finite() && q > 0.0 => Ok(()),
            _ => Err(SmidError::invalid("step", "expected a step > 0")),
        }
    }
    fn plant_output(&self, _t: usize, w: f64) -> f64 {
        round_to(self.step, w)
    }
    fn truth(&self) -> Vec<(String, f64)> {
        opt("step", self.step)
    }
}

#[typetag::serde(name = "quantization")]
impl Effect for Quantization {
    fn label(&self) -> String {
        match self.step {
            Some(q) => format!("output quantization (step {q:.3e})"),
            None => "output quantization".into(),
        }
    }
    fn settings(&self) -> Vec<(String, f64)> {
        self.step
            .map(|q| vec![("step".into(), q)])
            .unwrap_or_default()
    }
    fn as_sensor(&self) -> Option<&dyn SensorTerm> {
        Some(self)
    }
    fn as_plant(&self) -> Option<&dyn PlantEffect> {
        Some(self)
    }
}
register_effect!(
    "quantization",
    Quantization,
    50,
    Quantization { step: Some(0.005) },
    [Quantization { step: None }]
);

/// Which velocity drives a friction term.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "lowercase")]
pub enum Velocity {
    /// Of the input: `u_t - u_{t-1}` (an imposed motion, a drive's command).
    #[default]
    Input,
    /// Of the linear block's output, one sample late to stay causal: `x_{t-1} - x_{t-2}` (a
    /// measured position). `x` is known as an interval (stage 2), so the velocity is too.
    Output,
}

fn is_input(v: &Velocity) -> bool {
    *v == Velocity::Input
}

/// The velocity at `t` as an interval.
fn velocity_at(s: &Signals, v: Velocity, t: usize) -> Interval {
    match v {
        Velocity::Input => {
            let d = if t == 0 { 0.0 } else { s.u[t] - s.u[t - 1] };
            Interval::new(d, d)
        }
        Velocity::Output => match s.x {
            Some(x) if t >= 2 && x.len() >= t => {
                let (a, b) = (x[t - 1], x[t - 2]);
                Interval::new(a.lo - b.hi, a.hi - b.lo)
            }
            _ => Interval::new(f64::NEG_INFINITY, f64::INFINITY),
        },
    }
}

/// `sign` over an interval: exact when the interval keeps one side of the dead band `±eps`
/// (0 inside it), else the hull of the possible signs.
fn sign_of(v: Interval, eps: f64) -> Interval {
    let s = |x: f64| {
        if x > eps {
            1.0
        } else if x < -eps {
            -1.0
        } else {
            0.0
        }
    };
    if !(v.lo.is_finite() && v.hi.is_finite()) {
        return Interval::new(-1.0, 1.0);
    }
    Interval::new(s(v.lo), s(v.hi))
}

/// The largest input move of a record (the scale of its velocity dead band).
fn largest_move(u: &[f64]) -> f64 {
    u.windows(2).fold(0.0f64, |m, w| m.max((w[1] - w[0]).abs()))
}

/// Dry (Coulomb) friction: the term `c · sign(v_t)`. On the input velocity, 0 while it stays
/// below 1e-3 of the largest input move per sample (a drive at rest or creeping to a level: the
/// term vanishes at steady state, as stage 1 assumes, even under the filtered square wave). On
/// the output velocity the sign is an interval where the output may not have moved.
#[derive(Debug, Clone, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct CoulombFriction {
    /// Which velocity's sign the term reads: `input` or `output`.
    #[serde(default, skip_serializing_if = "is_input")]
    #[schemars(extend("default" = "input"))]
    pub velocity: Velocity,
    /// The true coefficient `c` in a simulator; left out in a model, where it is identified.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub value: Option<f64>,
}

impl CoulombFriction {
    /// The velocity dead band: 1e-3 of the largest input move for the input velocity; none for
    /// the output's (its interval already says where the output may not have moved).
    fn eps(&self, s: &Signals) -> f64 {
        match self.velocity {
            Velocity::Input => 1e-3 * largest_move(s.u),
            Velocity::Output => 0.0,
        }
    }
    fn name(&self) -> &'static str {
        match self.velocity {
            Velocity::Input => "coulomb",
            Velocity::Output => "coulomb_out",
        }
    }
}

impl EquationTerm for CoulombFriction {
    fn regressors(&self, s: &Signals) -> Vec<Column> {
        let eps = self.eps(s);
        vec![Column {
            name: self.name().into(),
            values: (0..s.u.len())
                .map(|t| sign_of(velocity_at(s, self.velocity, t), eps))
                .collect(),
        }]
    }
    fn regressors_at(&self, s: &Signals, t: usize) -> Vec<f64> {
        vec![sign_of(velocity_at(s, self.velocity, t), self.eps(s)).center()]
    }
    fn uses_output(&self) -> bool {
        self.velocity == Velocity::Output
    }
    /// No: it turns off when the velocity falls into its dead band, a step in the equation
    /// while the filtered square wave settles (the Appendix search on such a plant finds no
    /// pole without overshoot).
    fn keeps_steady_design(&self) -> bool {
        false
    }
}

impl PlantEffect for CoulombFriction {
    fn validate_plant(&self) -> Result<()> {
        if self.velocity == Velocity::Output {
            return Err(SmidError::invalid(
                "velocity",
                "the built-in simulator takes friction on the input velocity only",
            ));
        }
        need(self.value, "value").map(|_| ())
    }
    fn plant_equation(&self, s: &Signals) -> Option<Vec<f64>> {
        let c = self.value.unwrap_or(0.0);
        Some(
            self.regressors(s)[0]
                .values
                .iter()
                .map(|v| c * v.center())
                .collect(),
        )
    }
    fn truth(&self) -> Vec<(String, f64)> {
        opt(self.name(), self.value)
    }
}

#[typetag::serde(name = "coulomb_friction")]
impl Effect for CoulombFriction {
    fn label(&self) -> String {
        match self.velocity {
            Velocity::Input => "Coulomb friction (input velocity)".into(),
            Velocity::Output => "Coulomb friction (output velocity)".into(),
        }
    }
    fn as_equation(&self) -> Option<&dyn EquationTerm> {
        Some(self)
    }
    fn as_plant(&self) -> Option<&dyn PlantEffect> {
        Some(self)
    }
}
register_effect!(
    "coulomb_friction",
    CoulombFriction,
    30,
    CoulombFriction {
        velocity: Velocity::Input,
        value: Some(-0.05)
    },
    [
        CoulombFriction {
            velocity: Velocity::Input,
            value: None
        },
        CoulombFriction {
            velocity: Velocity::Output,
            value: None
        }
    ]
);

/// Viscous friction: the term `c · v_t / dt`.
#[derive(Debug, Clone, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct ViscousFriction {
    /// Which velocity the term reads: `input` or `output`.
    #[serde(default, skip_serializing_if = "is_input")]
    #[schemars(extend("default" = "input"))]
    pub velocity: Velocity,
    /// The true coefficient `c` in a simulator; left out in a model, where it is identified.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub value: Option<f64>,
}

impl ViscousFriction {
    fn name(&self) -> &'static str {
        match self.velocity {
            Velocity::Input => "viscous",
            Velocity::Output => "viscous_out",
        }
    }
    fn at(&self, s: &Signals, t: usize) -> Interval {
        let v = velocity_at(s, self.velocity, t);
        Interval::new(v.lo / s.dt, v.hi / s.dt)
    }
}

impl EquationTerm for ViscousFriction {
    fn regressors(&self, s: &Signals) -> Vec<Column> {
        vec![Column {
            name: self.name().into(),
            values: (0..s.u.len()).map(|t| self.at(s, t)).collect(),
        }]
    }
    fn regressors_at(&self, s: &Signals, t: usize) -> Vec<f64> {
        vec![self.at(s, t).center()]
    }
    fn uses_output(&self) -> bool {
        self.velocity == Velocity::Output
    }
}

impl PlantEffect for ViscousFriction {
    fn validate_plant(&self) -> Result<()> {
        if self.velocity == Velocity::Output {
            return Err(SmidError::invalid(
                "velocity",
                "the built-in simulator takes friction on the input velocity only",
            ));
        }
        need(self.value, "value").map(|_| ())
    }
    fn plant_equation(&self, s: &Signals) -> Option<Vec<f64>> {
        let c = self.value.unwrap_or(0.0);
        Some((0..s.u.len()).map(|t| c * self.at(s, t).center()).collect())
    }
    fn truth(&self) -> Vec<(String, f64)> {
        opt(self.name(), self.value)
    }
}

#[typetag::serde(name = "viscous_friction")]
impl Effect for ViscousFriction {
    fn label(&self) -> String {
        match self.velocity {
            Velocity::Input => "viscous friction (input velocity)".into(),
            Velocity::Output => "viscous friction (output velocity)".into(),
        }
    }
    fn as_equation(&self) -> Option<&dyn EquationTerm> {
        Some(self)
    }
    fn as_plant(&self) -> Option<&dyn PlantEffect> {
        Some(self)
    }
}
register_effect!(
    "viscous_friction",
    ViscousFriction,
    31,
    ViscousFriction {
        velocity: Velocity::Input,
        value: Some(-0.05)
    },
    [
        ViscousFriction {
            velocity: Velocity::Input,
            value: None
        },
        ViscousFriction {
            velocity: Velocity::Output,
            value: None
        }
    ]
);

/// A constant term in the linear equation (a load, a bias of the actuator, an operating
/// point): `c · 1`. It does not vanish at steady state, so it needs records without the
/// designed steady-state experiment (stage 1 would be biased).
#[derive(Debug, Clone, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Constant {
    /// The true constant `c` in a simulator; left out in a model, where it is identified.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub value: Option<f64>,
}

impl EquationTerm for Constant {
    fn regressors(&self, s: &Signals) -> Vec<Column> {
        vec![Column::exact(
            "constant",
            std::iter::repeat_n(1.0, s.u.len()),
        )]
    }
    fn vanishes_at_steady_state(&self) -> bool {
        false
    }
    /// At rest `A(1)·x̄ = B(1)·v̄ + c`: with unit gain, `x̄ = v̄ + c/A(1)`.
    fn rest_parameter(&self) -> Option<String> {
        Some("constant_at_rest".into())
    }
}

impl PlantEffect for Constant {
    fn validate_plant(&self) -> Result<()> {
        need(self.value, "value").map(|_| ())
    }
    fn plant_equation(&self, s: &Signals) -> Option<Vec<f64>> {
        Some(vec![self.value.unwrap_or(0.0); s.u.len()])
    }
    fn truth(&self) -> Vec<(String, f64)> {
        opt("constant", self.value)
    }
}

#[typetag::serde(name = "constant")]
impl Effect for Constant {
    fn label(&self) -> String {
        "constant term (load, bias)".into()
    }
    fn as_equation(&self) -> Option<&dyn EquationTerm> {
        Some(self)
    }
    fn as_plant(&self) -> Option<&dyn PlantEffect> {
        Some(self)
    }
}
register_effect!(
    "constant",
    Constant,
    12,
    Constant { value: Some(0.05) },
    [Constant { value: None }]
);

/// A linear path of the input beside the nonlinearity: the term `c · u_t` (with a play
/// `N(u)` in a Hammerstein model, `c·u + b_0·N(u)` is the elasto-plastic "stop" operator when
/// `c ≈ -b_0`). It does not vanish at steady state.
#[derive(Debug, Clone, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct ParallelInput {
    /// The true coefficient `c` in a simulator; left out in a model, where it is identified.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub value: Option<f64>,
}

impl EquationTerm for ParallelInput {
    fn regressors(&self, s: &Signals) -> Vec<Column> {
        vec![Column::exact("parallel", s.u.iter().copied())]
    }
    fn vanishes_at_steady_state(&self) -> bool {
        false
    }
    /// At rest `A(1)·x̄ = B(1)·v̄ + c·ū` (`ū` the measured input, `v̄` the linear block's):
    /// with unit gain, `x̄ = v̄ + ū·g` for the gain at rest `g = c/A(1)`, the shift at the
    /// unit measured input.
    fn rest_parameter(&self) -> Option<String> {
        Some("parallel_gain_at_rest".into())
    }
    /// `|g| <= 1/2`: a parallel path that changes the static gain by up to a half (a gain, so
    /// not read from the data's scale).
    fn rest_prior(&self, _scale: &DataScale) -> Interval {
        Interval::new(-0.5, 0.5)
    }
    /// `u·g` over the boxes of both, rounded outward.
    fn rest_shift(&self, u: Interval, g: Interval) -> Interval {
        let p = [u.lo * g.lo, u.lo * g.hi, u.hi * g.lo, u.hi * g.hi];
        let lo = p.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = p.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        Interval::new(lo, hi).outward()
    }
}

impl PlantEffect for ParallelInput {
    fn validate_plant(&self) -> Result<()> {
        need(self.value, "value").map(|_| ())
    }
    fn plant_equation(&self, s: &Signals) -> Option<Vec<f64>> {
        let c = self.value.unwrap_or(0.0);
        Some(s.u.iter().map(|v| c * v).collect())
    }
    fn truth(&self) -> Vec<(String, f64)> {
        opt("parallel", self.value)
    }
}

#[typetag::serde(name = "parallel_input")]
impl Effect for ParallelInput {
    fn label(&self) -> String {
        "parallel linear path of the input".into()
    }
    fn as_equation(&self) -> Option<&dyn EquationTerm> {
        Some(self)
    }
    fn as_plant(&self) -> Option<&dyn PlantEffect> {
        Some(self)
    }
}
register_effect!(
    "parallel_input",
    ParallelInput,
    40,
    ParallelInput { value: Some(0.2) },
    [ParallelInput { value: None }]
);

fn two() -> u32 {
    2
}

/// An integer field of [`InputPower`] read within `lo..=hi`, else an error naming the field
/// and what is expected.
fn ranged<'de, D: serde::Deserializer<'de>>(
    d: D,
    field: &str,
    lo: usize,
    hi: usize,
    note: &str,
) -> std::result::Result<usize, D::Error> {
    let n = usize::deserialize(d)?;
    if (lo..=hi).contains(&n) {
        Ok(n)
    } else {
        Err(serde::de::Error::custom(format!(
            "{field}: expected an integer from {lo} to {hi}, got {n}{note}"
        )))
    }
}
/// `degree` in `2..=5` (1 is `parallel_input`, 0 the `constant`).
fn degree_2_to_5<'de, D: serde::Deserializer<'de>>(d: D) -> std::result::Result<u32, D::Error> {
    ranged(d, "degree", 2, 5, " (1 is `parallel_input`, 0 `constant`)").map(|p| p as u32)
}
/// `delay` in `0..=1000`, as the linear block's `nk`.
fn delay_0_to_1000<'de, D: serde::Deserializer<'de>>(d: D) -> std::result::Result<usize, D::Error> {
    ranged(d, "delay", 0, 1000, "")
}
/// `lags` in `1..=8`, as the orders (a spec cannot make a term of thousands of columns).
fn lags_1_to_8<'de, D: serde::Deserializer<'de>>(d: D) -> std::result::Result<usize, D::Error> {
    ranged(d, "lags", 1, 8, "")
}

/// A polynomial path of the input beside the linear one (a Hammerstein polynomial's
/// higher-degree part): the terms `c_j · u_{t-d-j}^p`, `j = 0..lags`, with `d` the first lag
/// and `p` the degree. A tank drained through an orifice (Torricelli) settles at a level that
/// grows with the square of the inflow, which a linear block cannot hold. The input is
/// measured, so each column is exact; before the record's start (`t < d + j`) the value is
/// unknown and the equation is not used there (a simulation, which starts at rest, reads 0
/// there, as it reads the linear block's input before its delay). It does not vanish at rest:
/// there it shifts the linear block's output by `g·ū^p` (unit gain), with `g = Σc_j / A(1)`.
#[derive(Debug, Clone, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct InputPower {
    /// The degree `p` of the power, an integer from 2 to 5 (default 2).
    #[serde(default = "two", deserialize_with = "degree_2_to_5")]
    #[schemars(range(min = 2, max = 5))]
    pub degree: u32,
    /// The first lag `d` (default 1: `u_{t-1}^p`, as the linear block reads `u` with `nk = 1`).
    #[serde(default = "one", deserialize_with = "delay_0_to_1000")]
    #[schemars(range(max = 1000))]
    pub delay: usize,
    /// How many lags `d, d+1, ...` get a coefficient (default 1).
    #[serde(default = "one", deserialize_with = "lags_1_to_8")]
    #[schemars(range(min = 1, max = 8))]
    pub lags: usize,
    /// The true coefficients `[c_0, .., c_{lags-1}]` in a simulator; left out in a model,
    /// where they are identified.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub values: Option<Vec<f64>>,
}

impl InputPower {
    /// The column name of lag `d + j`: `u2_lag1` for `u_{t-1}^2`.
    fn name(&self, j: usize) -> String {
        format!("u{}_lag{}", self.degree, self.delay + j)
    }
    /// `u_{t-lag}^p`, `None` before the record's start.
    fn value(&self, u: &[f64], t: usize, lag: usize) -> Option<f64> {
        let k = t.checked_sub(lag)?;
        u.get(k).map(|v| v.powi(self.degree as i32))
    }
    /// The lags `d..d+lags`.
    fn lag_range(&self) -> std::ops::Range<usize> {
        self.delay..self.delay + self.lags
    }
}

impl EquationTerm for InputPower {
    fn regressors(&self, s: &Signals) -> Vec<Column> {
        self.lag_range()
            .enumerate()
            .map(|(j, lag)| Column {
                name: self.name(j),
                values: (0..s.u.len())
                    .map(|t| {
                        self.value(s.u, t, lag)
                            .map_or_else(Interval::entire, |v| Interval::new(v, v))
                    })
                    .collect(),
            })
            .collect()
    }
    fn vanishes_at_steady_state(&self) -> bool {
        false
    }
    /// No: under the filtered square wave the input sweeps between `±a`, and `g·u^p` is not
    /// linear in it (`u²` dips to 0 at every crossing; an odd power against the linear path
    /// turns back), so the linear block's output may reverse on its way to the next level
    /// (quasi-statically when `2|g|a > |G|` for the square) and a backlash then holds the
    /// excursion, which stage 1's polygons (eqs 13-20) do not allow for.
    fn keeps_steady_design(&self) -> bool {
        false
    }
    /// At rest `A(1)·x̄ = B(1)·v̄ + Σc_j·ū^p`: with unit gain, `x̄ = v̄ + g·ū^p` for
    /// `g = Σc_j/A(1)`, the shift at the unit measured input.
    fn rest_parameter(&self) -> Option<String> {
        Some(format!("u{}_gain_at_rest", self.degree))
    }
    /// A shift of at most half the input's range over the input's range: `|g| <= h/max|u|^p`
    /// with `h` half the range (the constant's box, scaled by the power).
    fn rest_prior(&self, scale: &DataScale) -> Interval {
        let (lo, hi) = scale.u_range;
        let h = 0.5 * (hi - lo).abs();
        let m = lo.abs().max(hi.abs()).powi(self.degree as i32);
        let g = if m > 0.0 && (h / m).is_finite() {
            h / m
        } else {
            h
        };
        Interval::new(-g, g)
    }
    /// `g·u^p` over the boxes of both (the power of an interval: 0 inside it for an even
    /// degree when `u` holds 0), rounded outward.
    fn rest_shift(&self, u: Interval, g: Interval) -> Interval {
        let p = self.degree as i32;
        let (a, b) = (u.lo.powi(p), u.hi.powi(p));
        let (mut lo, hi) = (a.min(b), a.max(b));
        if p % 2 == 0 && u.lo < 0.0 && u.hi > 0.0 {
            lo = 0.0;
        }
        let q = [lo * g.lo, lo * g.hi, hi * g.lo, hi * g.hi];
        let lo = q.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = q.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        // `powi` rounds each product: a relative pad of a few ulps per factor.
        Interval::new(lo, hi).widen(1e-14, 0.0).outward()
    }
}

impl PlantEffect for InputPower {
    fn validate_plant(&self) -> Result<()> {
        let v = self.values.as_ref().ok_or_else(|| {
            SmidError::invalid(
                "values",
                "a simulator needs the true coefficients of this effect",
            )
        })?;
        if v.len() != self.lags || v.iter().any(|c| !c.is_finite()) {
            return Err(SmidError::invalid(
                "values",
                format!(
                    "expected {} finite coefficients (one per lag), got {v:?}",
                    self.lags
                ),
            ));
        }
        Ok(())
    }
    fn plant_equation(&self, s: &Signals) -> Option<Vec<f64>> {
        let c = self.values.clone().unwrap_or_default();
        Some(
            (0..s.u.len())
                .map(|t| {
                    self.lag_range()
                        .zip(&c)
                        .map(|(lag, c)| c * self.value(s.u, t, lag).unwrap_or(0.0))
                        .sum()
                })
                .collect(),
        )
    }
    fn truth(&self) -> Vec<(String, f64)> {
        self.values
            .iter()
            .flatten()
            .enumerate()
            .map(|(j, c)| (self.name(j), *c))
            .collect()
    }
}

#[typetag::serde(name = "input_power")]
impl Effect for InputPower {
    fn label(&self) -> String {
        let lags: Vec<String> = self.lag_range().map(|l| l.to_string()).collect();
        format!(
            "polynomial path of the input: u^{} at lag {}",
            self.degree,
            lags.join(", ")
        )
    }
    fn as_equation(&self) -> Option<&dyn EquationTerm> {
        Some(self)
    }
    fn as_plant(&self) -> Option<&dyn PlantEffect> {
        Some(self)
    }
    fn settings(&self) -> Vec<(String, f64)> {
        vec![
            ("degree".into(), self.degree as f64),
            ("delay".into(), self.delay as f64),
            ("lags".into(), self.lags as f64),
        ]
    }
}
register_effect!(
    "input_power",
    InputPower,
    41,
    InputPower {
        degree: 2,
        delay: 1,
        lags: 1,
        values: Some(vec![0.05])
    },
    [
        InputPower {
            degree: 2,
            delay: 1,
            lags: 1,
            values: None
        },
        InputPower {
            degree: 2,
            delay: 1,
            lags: 2,
            values: None
        }
    ]
);

/// Make this crate part of a binary (so its effects are registered).
pub fn link() {}

#[cfg(test)]
mod tests {
    use super::*;

    /// Uniform draws in `[0, 1)` from a seed (a linear congruential generator: the tests'
    /// cases without a dependency).
    fn draws(mut seed: u64) -> impl FnMut() -> f64 {
        move || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (seed >> 11) as f64 / (1u64 << 53) as f64
        }
    }

    #[test]
    fn sensor_terms_contain_every_member_of_the_cell() {
        let d = Drift {
            offset: None,
            rate: None,
        };
        let cell = [Interval::new(0.01, 0.02), Interval::new(-1e-4, 2e-4)];
        let s = d.sensor(Some(100), &cell).unwrap();
        for (o, r) in [(0.01, -1e-4), (0.02, 2e-4), (0.015, 0.0)] {
            let v = o + r * 100.0;
            assert!(s.contains(v), "{s:?} misses {v}");
        }
        assert!(d.sensor(None, &cell).is_err());
        let q = Quantization { step: Some(0.2) };
        let s = q.sensor(None, &[]).unwrap();
        assert!(s.contains(0.1) && s.contains(-0.1) && !s.contains(0.11));
        assert_eq!(q.plant_output(0, 0.29), 0.2);
    }

    /// The quantiser's inversion is sound: for random steps, cells around them, true outputs
    /// of either sign and noise inside its bound, the true output lies in what the
    /// inversion returns; and it has power: a cell of steps away from the true one is ruled
    /// out by some sample of a record that spans several levels.
    #[test]
    fn a_quantiser_inverts_to_every_true_output_and_rules_out_wrong_steps() {
        let q = Quantization { step: None };
        let mut rnd = draws(12345);
        let mut ruled_out = 0;
        for case in 0..300 {
            let step = 10f64.powf(-3.0 + 2.5 * rnd());
            let delta = step * (0.01 + 0.3 * rnd());
            let width = step * 1e-3 * rnd();
            let lo = step - width * rnd();
            let cell = [Interval::new(lo, lo + width)];
            let truth = Quantization { step: Some(step) };
            let mut wrong_ruled_out = false;
            let wrong = [Interval::new(step * 1.13, step * 1.131)];
            for _ in 0..50 {
                let w = (rnd() - 0.5) * 400.0 * step;
                let y = truth.plant_output(0, w) + delta * (2.0 * rnd() - 1.0);
                let yi = Interval::new(y - delta, y + delta);
                let inv = q.true_output(Some(0), &cell, yi).unwrap();
                let inv = inv.unwrap_or_else(|| panic!("case {case}: {w} ruled out"));
                assert!(inv.contains(w), "case {case}: {w} outside {inv:?}");
                wrong_ruled_out |= q.true_output(Some(0), &wrong, yi).unwrap().is_none();
            }
            ruled_out += usize::from(wrong_ruled_out);
        }
        assert!(
            ruled_out > 250,
            "a wrong step was ruled out in {ruled_out} of 300 cases"
        );
        // The prior starts where the lattice can rule steps out (4Δη), and without a declared
        // bound there is none: the quantiser is then not offered.
        let mut scale = DataScale {
            y_max: 2.0,
            length: 100,
            y_range: (-1.0, 2.0),
            u_range: (-1.0, 1.0),
            noise: Some(1e-3),
        };
        assert_eq!(
            q.default_prior(&scale),
            vec![Interval::new(4e-3, 3.0 / 8.0)]
        );
        scale.noise = None;
        assert!(q.default_prior(&scale).is_empty());
    }

    #[test]
    fn plant_factors_have_unit_gain_and_the_declared_order() {
        for e in [
            Box::new(Delay { samples: 2 }) as Box<dyn Effect>,
            Box::new(ActuatorLag { pole: Some(0.4) }),
            Box::new(ExtraZero { zero: Some(-0.3) }),
        ] {
            let (a, b) = e.plant_factor().unwrap();
            let g = b.iter().sum::<f64>() / (1.0 + a.iter().sum::<f64>());
            assert!((g - 1.0).abs() < 1e-12, "{e:?}: gain {g}");
            let mut o = Orders {
                na: 2,
                nb: 2,
                nk: 0,
            };
            e.orders(&mut o);
            assert!(o.na >= 2 && o.nb >= 2);
        }
    }

    #[test]
    fn equation_terms_vanish_at_steady_state_and_match_the_plant() {
        let u = [0.0, 1.0, 1.0, 1.0, -1.0, -1.0];
        let s = Signals::input(&u, 0.5);
        let c = CoulombFriction {
            velocity: Velocity::Input,
            value: Some(2.0),
        };
        let col: Vec<f64> = c.regressors(&s)[0]
            .values
            .iter()
            .map(|v| v.center())
            .collect();
        assert_eq!(col, vec![0.0, 1.0, 0.0, 0.0, -1.0, 0.0]);
        let p = c.plant_equation(&s).unwrap();
        assert_eq!(p, col.iter().map(|v| 2.0 * v).collect::<Vec<_>>());
        let v = ViscousFriction {
            velocity: Velocity::Input,
            value: None,
        };
        assert_eq!(v.regressors(&s)[0].values[4].center(), -4.0);
        assert!(!Constant { value: None }.vanishes_at_steady_state());
    }

    #[test]
    fn output_velocity_signs_are_intervals_holding_every_possible_sign() {
        let u = [0.0; 5];
        let x = [
            Interval::new(0.0, 0.1),
            Interval::new(0.5, 0.6),
            Interval::new(0.55, 0.56),
            Interval::new(0.0, 1.0),
            Interval::new(0.0, 0.0),
        ];
        let s = Signals {
            u: &u,
            dt: 1.0,
            x: Some(&x),
        };
        let c = CoulombFriction {
            velocity: Velocity::Output,
            value: None,
        };
        let col = &c.regressors(&s)[0].values;
        assert_eq!(col[2], Interval::new(1.0, 1.0)); // x1 - x0 in [0.4, 0.6]
        assert!(col[3].contains(-1.0) && col[3].contains(1.0)); // x2 - x1 in [-0.05, 0.06]
        assert!(col[0].contains(-1.0) && col[0].contains(1.0)); // unknown at the start
        assert!(c.uses_output());
        assert_eq!(c.regressors_at(&s, 2), vec![1.0]);
    }

    /// The polynomial path's columns are the input's powers at their lags (unknown before the
    /// record's start), the plant's term is their sum with its coefficients, and its shift at
    /// rest holds `g·ū^p` for every `ū`, `g` in random boxes (each degree, boxes across 0).
    #[test]
    fn the_input_power_path_matches_the_plant_and_its_rest_shift_holds_every_point() {
        let mut rnd = draws(777);
        for case in 0..200 {
            let degree = 2 + (case % 4) as u32;
            let delay = case % 3;
            let lags = 1 + (case / 3) % 3;
            let n = 5 + (rnd() * 20.0) as usize;
            let u: Vec<f64> = (0..n).map(|_| 8.0 * rnd() - 4.0).collect();
            let values: Vec<f64> = (0..lags).map(|_| rnd() - 0.5).collect();
            let e = InputPower {
                degree,
                delay,
                lags,
                values: Some(values.clone()),
            };
            let s = Signals::input(&u, 1.0);
            let cols = e.regressors(&s);
            assert_eq!(cols.len(), lags);
            let plant = e.plant_equation(&s).unwrap();
            for t in 0..n {
                let mut sum = 0.0;
                for (j, col) in cols.iter().enumerate() {
                    let lag = delay + j;
                    if t < lag {
                        assert!(!col.values[t].is_finite(), "case {case}: t {t} lag {lag}");
                    } else {
                        let want = u[t - lag].powi(degree as i32);
                        assert_eq!(col.values[t], Interval::new(want, want));
                        sum += values[j] * want;
                    }
                }
                assert!(
                    (plant[t] - sum).abs() <= 1e-12 * (1.0 + sum.abs()),
                    "case {case}"
                );
            }
            let names: Vec<&str> = cols.iter().map(|c| c.name.as_str()).collect();
            let truth: Vec<String> = e.truth().into_iter().map(|(n, _)| n).collect();
            assert_eq!(names, truth);
            // The shift at rest over boxes, sampled.
            let (a, b) = (4.0 * rnd() - 2.0, 4.0 * rnd() - 2.0);
            let ub = Interval::new(a.min(b), a.max(b));
            let (g1, g2) = (2.0 * rnd() - 1.0, 2.0 * rnd() - 1.0);
            let gb = Interval::new(g1.min(g2), g1.max(g2));
            let shift = e.rest_shift(ub, gb);
            for k in 0..=20 {
                for l in 0..=4 {
                    let uv = ub.lo + (ub.hi - ub.lo) * k as f64 / 20.0;
                    let gv = gb.lo + (gb.hi - gb.lo) * l as f64 / 4.0;
                    let v = gv * uv.powi(degree as i32);
                    assert!(shift.contains(v), "case {case}: {v} outside {shift:?}");
                }
            }
        }
    }

    /// Out-of-range settings of the polynomial path are refused at parsing, naming the field.
    #[test]
    fn input_power_settings_out_of_range_name_the_field() {
        for (text, field) in [
            (r#"{"degree": 1}"#, "degree"),
            (r#"{"degree": 9}"#, "degree"),
            (r#"{"lags": 0}"#, "lags"),
            (r#"{"lags": 40}"#, "lags"),
            (r#"{"delay": 100000}"#, "delay"),
        ] {
            let e = serde_json::from_str::<InputPower>(text)
                .unwrap_err()
                .to_string();
            assert!(
                e.contains(field) && e.contains("expected an integer"),
                "{text}: {e}"
            );
        }
        let ok: InputPower = serde_json::from_str("{}").unwrap();
        assert_eq!((ok.degree, ok.delay, ok.lags), (2, 1, 1));
        let e = InputPower {
            values: Some(vec![0.1]),
            ..ok.clone()
        };
        assert!(e.validate_plant().is_ok());
        let e = InputPower {
            values: Some(vec![0.1, 0.2]),
            ..ok
        };
        assert!(e
            .validate_plant()
            .unwrap_err()
            .to_string()
            .contains("values"));
    }

    #[test]
    fn simulator_values_are_required_and_named() {
        let e = Offset { value: None }
            .validate_plant()
            .unwrap_err()
            .to_string();
        assert!(e.contains("value"), "{e}");
        let e = ActuatorLag { pole: Some(1.5) }
            .validate_plant()
            .unwrap_err()
            .to_string();
        assert!(e.contains("pole"), "{e}");
    }
}
