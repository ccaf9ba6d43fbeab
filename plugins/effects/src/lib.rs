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
//! | `quantization` | sensor | `|s_t| <= step/2`, `step` declared | `w` rounded to the step |
//! | `coulomb_friction` | equation | `c · sign(u_t - u_{t-1})` (0 below 1e-3 of the largest move) | the same term with `value` |
//! | `viscous_friction` | equation | `c · (u_t - u_{t-1})/dt` | the same term with `value` |
//!
//! Equation terms use the input velocity: they vanish at steady state, so stage 1 holds.
#![forbid(unsafe_code)]

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};
use smid_core::effect::{Column, DataScale, Effect, Orders, Signals};
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

#[typetag::serde(name = "delay")]
impl Effect for Delay {
    fn label(&self) -> String {
        if self.samples == 1 {
            "one more sample of delay".into()
        } else {
            format!("{} more samples of delay", self.samples)
        }
    }
    fn orders(&self, o: &mut Orders) {
        o.nk += self.samples;
    }
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
    /// The lag's pole `p` (`0 <= p < 1`; true value, simulator only).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub pole: Option<f64>,
}

#[typetag::serde(name = "actuator_lag")]
impl Effect for ActuatorLag {
    fn label(&self) -> String {
        "one more pole (actuator lag)".into()
    }
    fn orders(&self, o: &mut Orders) {
        o.na += 1;
    }
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
    /// The zero's coefficient `z` (`|z| < 1`; true value, simulator only).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub zero: Option<f64>,
}

#[typetag::serde(name = "extra_zero")]
impl Effect for ExtraZero {
    fn label(&self) -> String {
        "one more zero".into()
    }
    fn orders(&self, o: &mut Orders) {
        o.nb += 1;
    }
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
    /// True offset (simulator only).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub value: Option<f64>,
}

#[typetag::serde(name = "offset")]
impl Effect for Offset {
    fn label(&self) -> String {
        "sensor offset".into()
    }
    fn cell_parameters(&self) -> Vec<String> {
        vec!["offset".into()]
    }
    fn sensor(&self, _t: Option<usize>, cell: &[Interval]) -> Result<Interval> {
        Ok(cell[0])
    }
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
    /// True offset at `t = 0` (simulator only).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub offset: Option<f64>,
    /// True drift per sample (simulator only).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rate: Option<f64>,
}

#[typetag::serde(name = "drift")]
impl Effect for Drift {
    fn label(&self) -> String {
        "sensor drift".into()
    }
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
                "a drift needs the sample time of every output (steady-state points without a time)",
            )
        })? as f64;
        Ok(Interval::new(
            cell[0].lo + cell[1].lo * t,
            cell[0].hi + cell[1].hi * t,
        ))
    }
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

/// A sensor coarser than the noise bound says: the output is rounded to a known step, an
/// error of at most `step/2` beside the declared noise. The step is declared, not identified
/// (a step inferred from data would only be the smallest consistent noise bound, which
/// `smid validate` reports), so this effect is no diagnosis candidate.
#[derive(Debug, Clone, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Quantization {
    /// The quantiser's step (`> 0`).
    pub step: f64,
}

#[typetag::serde(name = "quantization")]
impl Effect for Quantization {
    fn label(&self) -> String {
        format!("output quantization (step {:.3e})", self.step)
    }
    fn sensor(&self, _t: Option<usize>, _cell: &[Interval]) -> Result<Interval> {
        if !(self.step.is_finite() && self.step > 0.0) {
            return Err(SmidError::invalid(
                "model.effects: quantization.step",
                format!("expected a step > 0, got {}", self.step),
            ));
        }
        let h = 0.5 * self.step;
        Ok(Interval::new(-h, h))
    }
    fn validate_plant(&self) -> Result<()> {
        if !(self.step.is_finite() && self.step > 0.0) {
            return Err(SmidError::invalid("step", "expected a step > 0"));
        }
        Ok(())
    }
    fn plant_output(&self, _t: usize, w: f64) -> f64 {
        self.step * (w / self.step).round()
    }
    fn settings(&self) -> Vec<(String, f64)> {
        vec![("step".into(), self.step)]
    }
}
register_effect!(
    "quantization",
    Quantization,
    50,
    Quantization { step: 0.005 },
    []
);

/// `u_t - u_{t-1}` (0 at the first sample).
fn input_difference(u: &[f64]) -> Vec<f64> {
    (0..u.len())
        .map(|t| if t == 0 { 0.0 } else { u[t] - u[t - 1] })
        .collect()
}

/// `sign(u_t - u_{t-1})`, 0 while the input moves by less than 1e-3 of its largest move (the
/// friction of a drive at rest, or creeping to a level: the term vanishes at steady state, as
/// stage 1 assumes, even under the filtered square wave).
fn coulomb_column(u: &[f64]) -> Vec<f64> {
    let d = input_difference(u);
    let scale = d.iter().fold(0.0f64, |m, x| m.max(x.abs())) * 1e-3;
    d.iter()
        .map(|x| if x.abs() <= scale { 0.0 } else { x.signum() })
        .collect()
}

/// Dry (Coulomb) friction driven by the input velocity: the term `c · sign(u_t - u_{t-1})`.
#[derive(Debug, Clone, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct CoulombFriction {
    /// True coefficient (simulator only).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub value: Option<f64>,
}

#[typetag::serde(name = "coulomb_friction")]
impl Effect for CoulombFriction {
    fn label(&self) -> String {
        "Coulomb friction (input velocity)".into()
    }
    fn regressors(&self, s: &Signals) -> Vec<Column> {
        vec![Column {
            name: "coulomb".into(),
            values: coulomb_column(s.u),
        }]
    }
    fn validate_plant(&self) -> Result<()> {
        need(self.value, "value").map(|_| ())
    }
    fn plant_equation(&self, s: &Signals) -> Option<Vec<f64>> {
        let c = self.value.unwrap_or(0.0);
        Some(coulomb_column(s.u).iter().map(|v| c * v).collect())
    }
    fn truth(&self) -> Vec<(String, f64)> {
        opt("coulomb", self.value)
    }
}
register_effect!(
    "coulomb_friction",
    CoulombFriction,
    30,
    CoulombFriction { value: Some(-0.05) },
    [CoulombFriction { value: None }]
);

/// Viscous friction driven by the input velocity: the term `c · (u_t - u_{t-1})/dt`.
#[derive(Debug, Clone, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct ViscousFriction {
    /// True coefficient (simulator only).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub value: Option<f64>,
}

#[typetag::serde(name = "viscous_friction")]
impl Effect for ViscousFriction {
    fn label(&self) -> String {
        "viscous friction (input velocity)".into()
    }
    fn regressors(&self, s: &Signals) -> Vec<Column> {
        vec![Column {
            name: "viscous".into(),
            values: input_difference(s.u).iter().map(|v| v / s.dt).collect(),
        }]
    }
    fn validate_plant(&self) -> Result<()> {
        need(self.value, "value").map(|_| ())
    }
    fn plant_equation(&self, s: &Signals) -> Option<Vec<f64>> {
        let c = self.value.unwrap_or(0.0);
        Some(input_difference(s.u).iter().map(|v| c * v / s.dt).collect())
    }
    fn truth(&self) -> Vec<(String, f64)> {
        opt("viscous", self.value)
    }
}
register_effect!(
    "viscous_friction",
    ViscousFriction,
    31,
    ViscousFriction { value: Some(-0.05) },
    [ViscousFriction { value: None }]
);

/// Make this crate part of a binary (so its effects are registered).
pub fn link() {}

#[cfg(test)]
mod tests {
    use super::*;

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
        let q = Quantization { step: 0.2 };
        let s = q.sensor(None, &[]).unwrap();
        assert!(s.contains(0.1) && s.contains(-0.1) && !s.contains(0.11));
        assert_eq!(q.plant_output(0, 0.29), 0.2);
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
        let s = Signals { u: &u, dt: 0.5 };
        let c = CoulombFriction { value: Some(2.0) };
        let col = &c.regressors(&s)[0].values;
        assert_eq!(col, &vec![0.0, 1.0, 0.0, 0.0, -1.0, 0.0]);
        let p = c.plant_equation(&s).unwrap();
        assert_eq!(p, col.iter().map(|v| 2.0 * v).collect::<Vec<_>>());
        let v = ViscousFriction { value: None };
        assert_eq!(v.regressors(&s)[0].values[4], -4.0);
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
