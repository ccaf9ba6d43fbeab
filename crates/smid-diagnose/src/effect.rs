//! The effect plugin trait: an [`Effect`] is something a model may lack (an offset, a delay, a
//! friction term, a play...). It says how it augments a linear-in-parameters (LIP) model
//! structure — the equation-error form
//!
//! ```text
//! y_t = -a_1 y_{t-1} - ... - a_na y_{t-na} + b_0 u_{t-nk} + ... + b_{nb-1} u_{t-nk-nb+1}
//!       + Σ_effects c_e · φ_e(t) + e_t,          |e_t| <= Δ
//! ```
//!
//! by changing the orders ([`Effect::augment_orders`]), adding regressor columns
//! ([`Effect::columns`]) or widening the error bound ([`Effect::extra_bound`]), and what it
//! leaves in a residual when it is missing ([`Effect::signature`]). Effects are registered like
//! nonlinearities: `#[typetag::serde]` for the spec's `type` tag and [`register_effect!`]
//! (inventory) for the candidate list and the schema, so this crate names no effect.
use serde::{Deserialize, Serialize};
use std::fmt::Debug;

/// Orders of the linear block of the LIP structure.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Orders {
    /// Number of output lags `a_1..a_na`.
    pub na: usize,
    /// Number of input coefficients `b_0..b_{nb-1}`.
    pub nb: usize,
    /// Input delay in samples (the first input lag used is `u_{t-nk}`).
    #[serde(default)]
    pub nk: usize,
}

impl Orders {
    /// The largest lag any base regressor reads.
    pub fn max_lag(&self) -> usize {
        self.na.max(self.nk + self.nb.saturating_sub(1))
    }
}

/// One data record: input, output, sample time (after decimation).
#[derive(Debug, Clone, PartialEq)]
pub struct Record {
    /// Where it came from (file and rows), for reports and errors.
    pub name: String,
    pub u: Vec<f64>,
    pub y: Vec<f64>,
    /// Sample time in seconds.
    pub dt: f64,
}

/// A named regressor column over the samples of one record. Contract: the value at `t` reads
/// only `u[..=t]` and `y[..t]` (it is causal), so the model can be simulated and a one-step
/// prediction uses only the past.
#[derive(Debug, Clone, PartialEq)]
pub struct Column {
    pub name: String,
    pub values: Vec<f64>,
}

/// Something a model may lack, and how to add it.
///
/// ```
/// use smid_diagnose::effect::{Column, Effect, Orders, Record};
/// use serde::{Deserialize, Serialize};
///
/// /// A constant added to the equation.
/// #[derive(Debug, Clone, Serialize, Deserialize)]
/// struct Bias;
///
/// #[typetag::serde(name = "doc_bias")]
/// impl Effect for Bias {
///     fn label(&self) -> String { "bias".into() }
///     fn columns(&self, rec: &Record, _o: &Orders) -> Vec<Column> {
///         vec![Column { name: "bias".into(), values: vec![1.0; rec.y.len()] }]
///     }
///     fn boxed(&self) -> Box<dyn Effect> { Box::new(self.clone()) }
/// }
///
/// let e: Box<dyn Effect> = serde_json::from_str(r#"{"type":"doc_bias"}"#).unwrap();
/// let rec = Record { name: "r".into(), u: vec![0.0; 3], y: vec![1.0; 3], dt: 1.0 };
/// let o = Orders { na: 1, nb: 1, nk: 1 };
/// assert_eq!(e.columns(&rec, &o)[0].values, vec![1.0; 3]);
/// assert_eq!(e.signature(&rec, &o), vec![1.0; 3]);
/// ```
#[typetag::serde(tag = "type")]
pub trait Effect: Debug + Send + Sync {
    /// Human-readable name for reports (e.g. "Coulomb friction (input velocity)").
    fn label(&self) -> String;
    /// A copy of this effect (trait objects cannot derive `Clone`).
    fn boxed(&self) -> Box<dyn Effect>;
    /// An input nonlinearity (a play, a dead zone, a saturation: `y = G(q) N(u)`) maps the
    /// input; the base input regressors and every later effect then read `N(u)`.
    /// Default: `None` (no map).
    fn map_input(&self, _u: &[f64]) -> Option<Vec<f64>> {
        None
    }
    /// Change the linear orders (delay, extra pole or zero). Default: none.
    fn augment_orders(&self, _orders: &mut Orders) {}
    /// Regressor columns this effect adds, on the final orders. Default: none.
    fn columns(&self, _rec: &Record, _orders: &Orders) -> Vec<Column> {
        Vec::new()
    }
    /// Allowance this effect adds to the equation-error bound, given `1 + Σ|a_i|` (e.g. an
    /// output quantizer of step q adds `q/2 · (1 + Σ|a_i|)`). Default: 0.
    fn extra_bound(&self, _one_plus_sum_abs_a: f64) -> f64 {
        0.0
    }
    /// The regressor sequence a residual correlates with when this effect is missing.
    /// Default: the first column (for an input map `N(u) - u`; for order changes, the regressor
    /// the change adds).
    fn signature(&self, rec: &Record, orders: &Orders) -> Vec<f64> {
        let cols = self.columns(rec, orders);
        if let Some(c) = cols.into_iter().next() {
            return c.values;
        }
        if let Some(m) = self.map_input(&rec.u) {
            return m.iter().zip(&rec.u).map(|(a, b)| a - b).collect();
        }
        let mut o = *orders;
        self.augment_orders(&mut o);
        order_signature(rec, orders, &o)
    }
    /// Fix open hyper-parameters (a play width, a saturation level, a quantizer step) from the
    /// training records; `score` returns the training error of a model with a given variant
    /// (lower is better). `None`: the effect does not apply to these data. Default: itself.
    fn tune(
        &self,
        _train: &[Record],
        _orders: &Orders,
        _score: &dyn Fn(&dyn Effect) -> f64,
    ) -> Option<Box<dyn Effect>> {
        Some(self.boxed())
    }
    /// Sensor-side transformation of a true output (quantization). Default: identity. Used to
    /// inject the effect into simulated data.
    fn measure(&self, y: &[f64]) -> Vec<f64> {
        y.to_vec()
    }
    /// Parameter values this effect carries (play width, level...), for reports.
    fn settings(&self) -> Vec<(String, f64)> {
        Vec::new()
    }
}

/// The regressor that an order change adds: the new output lag, the new input lag, or the
/// delayed input.
pub fn order_signature(rec: &Record, before: &Orders, after: &Orders) -> Vec<f64> {
    let n = rec.y.len();
    if after.na > before.na {
        return (0..n).map(|t| lag(&rec.y, t, after.na)).collect();
    }
    if after.nk != before.nk || after.nb > before.nb {
        let k = after.nk + after.nb - 1;
        return (0..n).map(|t| lag(&rec.u, t, k)).collect();
    }
    vec![0.0; n]
}

/// `x[t - k]`, or 0 before the start.
pub fn lag(x: &[f64], t: usize, k: usize) -> f64 {
    if t >= k {
        x.get(t - k).copied().unwrap_or(0.0)
    } else {
        0.0
    }
}

/// A registered effect: its `type` tag, the schema of its fields, a fully specified example
/// (used to inject it into simulated data) and the candidates diagnosis tries.
pub struct EffectEntry {
    pub tag: &'static str,
    pub schema: fn(&mut schemars::SchemaGenerator) -> schemars::Schema,
    /// A concrete instance, every setting given (the truth in simulation checks).
    pub example: fn() -> Box<dyn Effect>,
    /// Candidates with open settings, tuned on the data by [`Effect::tune`].
    pub candidates: fn() -> Vec<Box<dyn Effect>>,
    /// Order of preference when two candidates explain the data equally well (lower first).
    pub priority: u32,
}

inventory::collect!(EffectEntry);

/// Registered effects, by priority then tag.
pub fn effects() -> Vec<&'static EffectEntry> {
    let mut v: Vec<_> = inventory::iter::<EffectEntry>.into_iter().collect();
    v.sort_by_key(|e| (e.priority, e.tag));
    v
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

impl Clone for Box<dyn Effect> {
    fn clone(&self) -> Self {
        self.boxed()
    }
}
