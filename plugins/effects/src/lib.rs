//! # smid-effects
//!
//! The bundled effect plugins of `smid diagnose` (see `smid_diagnose::effect` for the LIP
//! equation they augment). Each computes its regressor columns (causal: column `t` reads
//! `u[..=t]` and `y[..t]`) or changes the orders:
//!
//! | tag | augments | signature in the residual |
//! |---|---|---|
//! | `delay` | `nk += 1` (input or output dead time: the same for a linear block) | `u_{t-nk-nb}` |
//! | `extra_pole` | `na += 1` | `y_{t-na-1}` |
//! | `extra_zero` | `nb += 1` | `u_{t-nk-nb}` |
//! | `offset` | column `1` | constant |
//! | `drift` | columns `1`, `t·dt` | time |
//! | `coulomb_friction` | column `sign(v_t)` | sign of the velocity |
//! | `viscous_friction` | column `v_t` | velocity |
//! | `play` | maps the input: `bl_w(u)`, width `w` by 1-D search | `bl_w(u) - u` |
//! | `dead_zone` | maps the input: `dz_w(u)`, width by 1-D search | `dz_w(u) - u` |
//! | `saturation` | maps the input: `sat_L(u)`, level by 1-D search | `sat_L(u) - u` |
//! | `quantization` | bound `+ q/2 (1+Σ|a_i|)`, step `q` from the output grid | none (grid test) |
//!
//! The velocity `v_t` is of the input (`u_t - u_{t-1}`, e.g. an imposed displacement; of the mapped
//! input when a play or other input map comes earlier in the list) or of the
//! output (`y_{t-1} - y_{t-2}`, e.g. a measured position; one sample late, to stay causal).
#![forbid(unsafe_code)]

use serde::{Deserialize, Serialize};
use smid_diagnose::effect::{lag, Column, Effect, Orders, Record};
use smid_diagnose::register_effect;

fn ones(rec: &Record) -> Vec<f64> {
    vec![1.0; rec.y.len()]
}

/// A constant output offset.
#[derive(Debug, Clone, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Offset {}

#[typetag::serde(name = "offset")]
impl Effect for Offset {
    fn label(&self) -> String {
        "constant offset".into()
    }
    fn boxed(&self) -> Box<dyn Effect> {
        Box::new(self.clone())
    }
    fn columns(&self, rec: &Record, _o: &Orders) -> Vec<Column> {
        vec![Column {
            name: "offset".into(),
            values: ones(rec),
        }]
    }
}
register_effect!("offset", Offset, 10, Offset {}, [Offset {}]);

/// A slow linear drift (with its own constant).
#[derive(Debug, Clone, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Drift {}

#[typetag::serde(name = "drift")]
impl Effect for Drift {
    fn label(&self) -> String {
        "linear drift".into()
    }
    fn boxed(&self) -> Box<dyn Effect> {
        Box::new(self.clone())
    }
    fn columns(&self, rec: &Record, _o: &Orders) -> Vec<Column> {
        vec![
            Column {
                name: "drift_time".into(),
                values: (0..rec.y.len()).map(|t| t as f64 * rec.dt).collect(),
            },
            Column {
                name: "offset".into(),
                values: ones(rec),
            },
        ]
    }
}
register_effect!("drift", Drift, 20, Drift {}, [Drift {}]);

/// One more sample of dead time.
#[derive(Debug, Clone, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Delay {}

#[typetag::serde(name = "delay")]
impl Effect for Delay {
    fn label(&self) -> String {
        "one more sample of delay".into()
    }
    fn boxed(&self) -> Box<dyn Effect> {
        Box::new(self.clone())
    }
    fn augment_orders(&self, o: &mut Orders) {
        o.nk += 1;
    }
}
register_effect!("delay", Delay, 5, Delay {}, [Delay {}]);

/// One more pole.
#[derive(Debug, Clone, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct ExtraPole {}

#[typetag::serde(name = "extra_pole")]
impl Effect for ExtraPole {
    fn label(&self) -> String {
        "one more pole".into()
    }
    fn boxed(&self) -> Box<dyn Effect> {
        Box::new(self.clone())
    }
    fn augment_orders(&self, o: &mut Orders) {
        o.na += 1;
    }
}
register_effect!("extra_pole", ExtraPole, 6, ExtraPole {}, [ExtraPole {}]);

/// One more zero.
#[derive(Debug, Clone, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct ExtraZero {}

#[typetag::serde(name = "extra_zero")]
impl Effect for ExtraZero {
    fn label(&self) -> String {
        "one more zero".into()
    }
    fn boxed(&self) -> Box<dyn Effect> {
        Box::new(self.clone())
    }
    fn augment_orders(&self, o: &mut Orders) {
        o.nb += 1;
    }
}
register_effect!("extra_zero", ExtraZero, 7, ExtraZero {}, [ExtraZero {}]);

/// Which signal's velocity drives a friction term.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(rename_all = "lowercase")]
pub enum Velocity {
    /// `u_t - u_{t-1}`.
    Input,
    /// `y_{t-1} - y_{t-2}`.
    Output,
}

fn velocity(rec: &Record, v: Velocity) -> Vec<f64> {
    (0..rec.y.len())
        .map(|t| match v {
            Velocity::Input => {
                if t >= 1 {
                    rec.u[t] - rec.u[t - 1]
                } else {
                    0.0
                }
            }
            Velocity::Output => lag(&rec.y, t, 1) - lag(&rec.y, t, 2),
        })
        .collect()
}

fn vname(v: Velocity) -> &'static str {
    match v {
        Velocity::Input => "input",
        Velocity::Output => "output",
    }
}

/// Dry (Coulomb) friction: a force `F_c sign(v)`.
#[derive(Debug, Clone, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct CoulombFriction {
    pub velocity: Velocity,
}

#[typetag::serde(name = "coulomb_friction")]
impl Effect for CoulombFriction {
    fn label(&self) -> String {
        format!("Coulomb friction ({} velocity)", vname(self.velocity))
    }
    fn boxed(&self) -> Box<dyn Effect> {
        Box::new(self.clone())
    }
    fn columns(&self, rec: &Record, _o: &Orders) -> Vec<Column> {
        let v = velocity(rec, self.velocity);
        let scale = v.iter().fold(0.0f64, |m, x| m.max(x.abs())) * 1e-9;
        vec![Column {
            name: format!("coulomb_{}", vname(self.velocity)),
            values: v
                .iter()
                .map(|x| if x.abs() <= scale { 0.0 } else { x.signum() })
                .collect(),
        }]
    }
}
register_effect!(
    "coulomb_friction",
    CoulombFriction,
    30,
    CoulombFriction {
        velocity: Velocity::Input
    },
    [
        CoulombFriction {
            velocity: Velocity::Input
        },
        CoulombFriction {
            velocity: Velocity::Output
        }
    ]
);

/// Viscous friction: a force `F_v v`.
#[derive(Debug, Clone, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct ViscousFriction {
    pub velocity: Velocity,
}

#[typetag::serde(name = "viscous_friction")]
impl Effect for ViscousFriction {
    fn label(&self) -> String {
        format!("viscous friction ({} velocity)", vname(self.velocity))
    }
    fn boxed(&self) -> Box<dyn Effect> {
        Box::new(self.clone())
    }
    fn columns(&self, rec: &Record, _o: &Orders) -> Vec<Column> {
        vec![Column {
            name: format!("viscous_{}", vname(self.velocity)),
            values: velocity(rec, self.velocity),
        }]
    }
}
register_effect!(
    "viscous_friction",
    ViscousFriction,
    31,
    ViscousFriction {
        velocity: Velocity::Input
    },
    [
        ViscousFriction {
            velocity: Velocity::Input
        },
        ViscousFriction {
            velocity: Velocity::Output
        }
    ]
);

/// Scale of the input (max |u| over the training records).
fn umax(train: &[Record]) -> f64 {
    train
        .iter()
        .flat_map(|r| r.u.iter())
        .fold(0.0f64, |m, x| m.max(x.abs()))
}

/// Pick the setting with the lowest score: the grid `lo + k·step` (`k = 0..n`), then two
/// refinements of 9 points around the best; `make` builds the variant.
/// Tune a one-setting input map: keep a given setting, else search it on the grid
/// `umax · (lo + k·step)`, `k < n`, over the training input's range.
fn tune_setting(
    given: Option<f64>,
    me: &dyn Effect,
    train: &[Record],
    (lo, step, n): (f64, f64, usize),
    make: impl Fn(f64) -> Box<dyn Effect>,
    score: &dyn Fn(&dyn Effect) -> f64,
) -> Option<Box<dyn Effect>> {
    if given.is_some() {
        return Some(me.boxed());
    }
    let m = umax(train);
    search(m * lo, m * step, n, make, score)
}

/// The report line of a one-setting effect.
fn setting(name: &str, value: Option<f64>) -> Vec<(String, f64)> {
    value.map(|v| vec![(name.into(), v)]).unwrap_or_default()
}

fn search(
    lo: f64,
    step: f64,
    n: usize,
    make: impl Fn(f64) -> Box<dyn Effect>,
    score: &dyn Fn(&dyn Effect) -> f64,
) -> Option<Box<dyn Effect>> {
    if !(step > 0.0 && step.is_finite()) {
        return None;
    }
    let mut best: Option<(f64, f64)> = None;
    let try_at = |w: f64, best: &mut Option<(f64, f64)>| {
        if w > 0.0 {
            let s = score(make(w).as_ref());
            if s.is_finite() && best.map(|b| s < b.1).unwrap_or(true) {
                *best = Some((w, s));
            }
        }
    };
    for k in 0..n {
        try_at(lo + step * k as f64, &mut best);
    }
    let mut h = step;
    for _ in 0..2 {
        let c = best?.0;
        h /= 4.0;
        for k in -4i32..=4 {
            try_at(c + h * k as f64, &mut best);
        }
    }
    best.map(|(w, _)| make(w))
}

/// A second play (backlash) of total width `width` on the input.
#[derive(Debug, Clone, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Play {
    /// Total play width (input units); open (searched on the data) when absent.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub width: Option<f64>,
}

/// Backlash of total width `w` (starting centred on the first sample).
pub fn backlash(u: &[f64], w: f64) -> Vec<f64> {
    let h = w / 2.0;
    let mut x = u.first().copied().unwrap_or(0.0);
    u.iter()
        .map(|&v| {
            x = x.clamp(v - h, v + h);
            x
        })
        .collect()
}

#[typetag::serde(name = "play")]
impl Effect for Play {
    fn label(&self) -> String {
        "play (backlash) on the input".into()
    }
    fn boxed(&self) -> Box<dyn Effect> {
        Box::new(self.clone())
    }
    fn map_input(&self, u: &[f64]) -> Option<Vec<f64>> {
        Some(backlash(u, self.width.unwrap_or(0.0)))
    }
    fn tune(
        &self,
        train: &[Record],
        _o: &Orders,
        score: &dyn Fn(&dyn Effect) -> f64,
    ) -> Option<Box<dyn Effect>> {
        let make = |w| Box::new(Play { width: Some(w) }) as Box<dyn Effect>;
        tune_setting(self.width, self, train, (0.04, 0.04, 24), make, score)
    }
    fn settings(&self) -> Vec<(String, f64)> {
        setting("width", self.width)
    }
}
register_effect!(
    "play",
    Play,
    40,
    Play { width: Some(0.6) },
    [Play { width: None }]
);

/// A dead zone `|u| <= width` on the input.
#[derive(Debug, Clone, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct DeadZone {
    /// Half-width of the zone (input units); searched when absent.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub width: Option<f64>,
}

#[typetag::serde(name = "dead_zone")]
impl Effect for DeadZone {
    fn label(&self) -> String {
        "dead zone on the input".into()
    }
    fn boxed(&self) -> Box<dyn Effect> {
        Box::new(self.clone())
    }
    fn map_input(&self, u: &[f64]) -> Option<Vec<f64>> {
        let w = self.width.unwrap_or(0.0);
        Some(
            u.iter()
                .map(|&v| v.signum() * (v.abs() - w).max(0.0))
                .collect(),
        )
    }
    fn tune(
        &self,
        train: &[Record],
        _o: &Orders,
        score: &dyn Fn(&dyn Effect) -> f64,
    ) -> Option<Box<dyn Effect>> {
        let make = |w| Box::new(DeadZone { width: Some(w) }) as Box<dyn Effect>;
        tune_setting(self.width, self, train, (0.04, 0.04, 18), make, score)
    }
    fn settings(&self) -> Vec<(String, f64)> {
        setting("width", self.width)
    }
}
register_effect!(
    "dead_zone",
    DeadZone,
    41,
    DeadZone { width: Some(0.4) },
    [DeadZone { width: None }]
);

/// Input saturation at `±level`.
#[derive(Debug, Clone, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Saturation {
    /// Saturation level (input units); searched when absent.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub level: Option<f64>,
}

#[typetag::serde(name = "saturation")]
impl Effect for Saturation {
    fn label(&self) -> String {
        "saturation of the input".into()
    }
    fn boxed(&self) -> Box<dyn Effect> {
        Box::new(self.clone())
    }
    fn map_input(&self, u: &[f64]) -> Option<Vec<f64>> {
        let l = self.level.unwrap_or(f64::INFINITY);
        Some(u.iter().map(|&v| v.clamp(-l, l)).collect())
    }
    fn tune(
        &self,
        train: &[Record],
        _o: &Orders,
        score: &dyn Fn(&dyn Effect) -> f64,
    ) -> Option<Box<dyn Effect>> {
        let make = |l| Box::new(Saturation { level: Some(l) }) as Box<dyn Effect>;
        tune_setting(self.level, self, train, (0.16, 0.04, 21), make, score)
    }
    fn settings(&self) -> Vec<(String, f64)> {
        setting("level", self.level)
    }
}
register_effect!(
    "saturation",
    Saturation,
    42,
    Saturation { level: Some(0.5) },
    [Saturation { level: None }]
);

/// Output (sensor) quantization with step `step`.
#[derive(Debug, Clone, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Quantization {
    /// Quantizer step; estimated from the output grid when absent.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub step: Option<f64>,
}

/// The grid step of `y` if at least 99% of the samples lie on a grid `y_0 + k q` and the grid
/// is coarse (fewer distinct levels than half the samples); otherwise `None`.
pub fn grid_step(y: &[f64]) -> Option<f64> {
    if y.len() < 20 {
        return None;
    }
    let mut v: Vec<f64> = y.to_vec();
    v.sort_by(|a, b| a.partial_cmp(b).unwrap_or(std::cmp::Ordering::Equal));
    let span = v[v.len() - 1] - v[0];
    if span <= 0.0 {
        return None;
    }
    let tol = 1e-9 * span;
    let mut levels = vec![v[0]];
    for &x in &v[1..] {
        if x - levels[levels.len() - 1] > tol {
            levels.push(x);
        }
    }
    if levels.len() * 2 > y.len() || levels.len() < 3 {
        return None;
    }
    let q = levels
        .windows(2)
        .map(|w| w[1] - w[0])
        .fold(f64::INFINITY, f64::min);
    let y0 = v[0];
    let on = y
        .iter()
        .filter(|x| {
            let k = (*x - y0) / q;
            (k - k.round()).abs() < 1e-3
        })
        .count();
    (on as f64 >= 0.99 * y.len() as f64).then_some(q)
}

#[typetag::serde(name = "quantization")]
impl Effect for Quantization {
    fn label(&self) -> String {
        "output quantization".into()
    }
    fn boxed(&self) -> Box<dyn Effect> {
        Box::new(self.clone())
    }
    fn extra_bound(&self, one_plus_sum_abs_a: f64) -> f64 {
        self.step.unwrap_or(0.0) / 2.0 * one_plus_sum_abs_a
    }
    fn tune(
        &self,
        train: &[Record],
        _o: &Orders,
        _score: &dyn Fn(&dyn Effect) -> f64,
    ) -> Option<Box<dyn Effect>> {
        if self.step.is_some() {
            return Some(self.boxed());
        }
        let ys: Vec<f64> = train.iter().flat_map(|r| r.y.iter().copied()).collect();
        grid_step(&ys).map(|q| Box::new(Quantization { step: Some(q) }) as Box<dyn Effect>)
    }
    fn measure(&self, y: &[f64]) -> Vec<f64> {
        match self.step {
            Some(q) if q > 0.0 => y.iter().map(|v| q * (v / q).round()).collect(),
            _ => y.to_vec(),
        }
    }
    fn settings(&self) -> Vec<(String, f64)> {
        self.step
            .map(|w| vec![("step".into(), w)])
            .unwrap_or_default()
    }
}
register_effect!(
    "quantization",
    Quantization,
    50,
    Quantization { step: Some(0.08) },
    [Quantization { step: None }]
);

/// Make this crate part of a binary (so its effects are registered).
pub fn link() {}

#[cfg(test)]
mod tests {
    use super::*;
    #[test]
    fn backlash_holds_inside_the_play() {
        let u = [0.0, 0.2, 0.4, 0.3, 0.0, -0.5];
        let x = backlash(&u, 0.4);
        assert_eq!(x, vec![0.0, 0.0, 0.2, 0.2, 0.2, -0.3]);
    }
    #[test]
    fn grid_is_found_only_on_quantized_data() {
        let y: Vec<f64> = (0..200).map(|t| (t as f64 * 0.37).sin()).collect();
        assert_eq!(grid_step(&y), None);
        let q = Quantization { step: Some(0.1) }.measure(&y);
        let s = grid_step(&q).unwrap();
        assert!((s - 0.1).abs() < 1e-9, "{s}");
    }
}
