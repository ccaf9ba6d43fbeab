//! The YAML model spec: plant (built-in simulator or measured CSV data; other plant kinds are
//! added by the crates that provide them), noise bound (eqs 4-5), experiment (Sections 3.2, 4,
//! Appendix), model structure and orders (eqs 1, 6-8) and method options. Unknown fields are
//! rejected; every error names the file, the line where the parser gives one, and the field.
use crate::effect::Effect;
use crate::error::{Result, SmidError};
use crate::experiment::{BisectionOptions, DynamicOptions, SteadyStateOptions};
use crate::linear::LinearModel;
use crate::noise::NoiseSpec;
use crate::nonlinearity::{Nonlinearity, NonlinearityModel, Structure};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::PathBuf;

/// The stage-3 method names (defined with the methods, in [`crate::stage3`]).
pub use crate::stage3::EivMethod;

mod parse;
mod validate;

/// A whole spec: the plant, the noise bound, the experiment, the model structure to identify
/// and the method's options.
#[derive(Debug, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Spec {
    /// Free-form name shown in reports (not set: none is shown).
    #[serde(default)]
    pub name: Option<String>,
    /// Where the data come from: give exactly one of `simulator` (the built-in simulator with
    /// true parameters), `data` (measured CSV files) or `fmu` (an FMI 2.0 unit).
    pub plant: PlantSpec,
    /// The bound `Δη` on the output's measurement error, `|η_t| <= Δη` for every sample (eqs
    /// 4-5): given (`delta`, `encoder_bits`) or estimated from measured data (`estimate`).
    pub noise: NoiseSpec,
    /// The designed experiments run on a simulator or FMU plant: the low-pass filter, the
    /// steady-state square wave (stage 1) and the dynamic PRBS (stages 2-3). With measured data
    /// (`plant.data`) none is run, and of these fields only `filter.step` is read (by
    /// `method.alpha: bias`).
    #[serde(default)]
    pub experiment: ExperimentSpec,
    /// The model structure to identify: the linear block's orders, the nonlinearity and where it
    /// sits, further blocks and effects, and what is known in advance.
    pub model: ModelSpec,
    /// How the identification runs: the overshoot allowance α, the stage-3 method and the
    /// budgets of the searches.
    #[serde(default)]
    pub method: MethodSpec,
    /// The choice rule of `smid diagnose`: how much an added candidate must lower an estimated
    /// noise bound, and how much training fit it may give up.
    #[serde(default)]
    pub diagnosis: DiagnosisSpec,
}

/// The tunables of the diagnosis's choice rule ([`crate::diagnose`]).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct DiagnosisSpec {
    /// With an estimated noise bound, a candidate must lower the training bound to at most
    /// this fraction of the base model's per added parameter (an information criterion in
    /// the ℓ∞ sense); bounds within this fraction of each other are a step apart at most
    /// (`0 < per_parameter < 1`).
    #[serde(default = "d_per_parameter")]
    pub per_parameter: f64,
    /// With an estimated noise bound, a candidate's free-run fit on the training records may
    /// fall below the base model's by at most this many percentage points; at a declared
    /// bound, the most by which fits within what the noise accounts for may differ (`>= 0`).
    #[serde(default = "d_fit_slack")]
    pub fit_slack: f64,
}

fn d_per_parameter() -> f64 {
    0.9
}
fn d_fit_slack() -> f64 {
    1.0
}

impl Default for DiagnosisSpec {
    fn default() -> Self {
        DiagnosisSpec {
            per_parameter: d_per_parameter(),
            fit_slack: d_fit_slack(),
        }
    }
}

impl crate::settings::Check for DiagnosisSpec {
    const PLACE: &'static str = "diagnosis";
    fn invalid(&self) -> Option<(&'static str, String)> {
        if !(self.per_parameter > 0.0 && self.per_parameter < 1.0) {
            return Some((
                "per_parameter",
                format!("expected 0 < per_parameter < 1, got {}", self.per_parameter),
            ));
        }
        if !(self.fit_slack.is_finite() && self.fit_slack >= 0.0) {
            return Some((
                "fit_slack",
                format!("expected a finite fit_slack >= 0, got {}", self.fit_slack),
            ));
        }
        None
    }
}

/// The plant: exactly one of `simulator`, `data` or `fmu`; the other fields belong to `fmu`,
/// except `truth`.
#[derive(Debug, Default, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct PlantSpec {
    /// The built-in simulator with its true parameters.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub simulator: Option<SimulatorSpec>,
    /// Measured data from CSV files.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub data: Option<DataSpec>,
    /// An FMI 2.0 co-simulation unit: the path of the `.fmu` file, relative to the spec's
    /// directory (or a bundled plant's source directory, such as `../fmus/paper`, whose built
    /// unit is used). It needs the `fmu` cargo feature.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub fmu: Option<PathBuf>,
    /// The FMU's input variable (not set: its only real input).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub input: Option<String>,
    /// The FMU's output variable (not set: its only real output).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub output: Option<String>,
    /// The FMU's communication step in seconds, one sample (not set: the step size of the
    /// unit's default experiment).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub step: Option<f64>,
    /// Values of the FMU's parameters, by variable name, set before each run.
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    #[schemars(extend("default" = {}))]
    pub parameters: BTreeMap<String, f64>,
    /// True parameter values by name (`m_l`, `a1`, `offset`, ...), for any plant kind: reports
    /// say whether each bound contains its true value. They replace the values a simulator
    /// knows of itself.
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    #[schemars(extend("default" = {}))]
    pub truth: BTreeMap<String, f64>,
}

/// The built-in simulator: the true linear block `B(q^-1)/A(q^-1)` (eq 1), the true
/// nonlinearity and, optionally, further blocks and effects, with sample time 1.
#[derive(Debug, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct SimulatorSpec {
    /// Where the nonlinearity sits: `wiener` (the linear block, then the nonlinearity) or
    /// `hammerstein` (the nonlinearity, then the linear block).
    #[serde(default)]
    pub structure: Structure,
    /// The true coefficients `[a_1, .., a_na]` of `A(q^-1) = 1 + a_1 q^-1 + .. + a_na q^-na`.
    pub a: Vec<f64>,
    /// The true coefficients `[b_0, .., b_nb]` of `B(q^-1) = b_0 + b_1 q^-1 + .. + b_nb q^-nb`.
    pub b: Vec<f64>,
    /// The true nonlinearity: a block `type` with its parameters.
    pub nonlinearity: Box<dyn Nonlinearity>,
    /// Blocks before the linear block (and before `nonlinearity` when Hammerstein), in signal
    /// order, with their true parameters (a chain of blocks: an input bias, a first
    /// nonlinearity...).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    #[schemars(extend("default" = []))]
    pub input: Vec<Box<dyn Nonlinearity>>,
    /// Blocks after the nonlinearity (Wiener) or the linear block (Hammerstein), in signal
    /// order, with their true parameters: a sensor lag, a second nonlinearity...
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    #[schemars(extend("default" = []))]
    pub output: Vec<Box<dyn Nonlinearity>>,
    /// Effects the plant has, with their true values (an offset, a delay, an actuator lag...):
    /// data with an effect a model may lack, without an FMU.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    #[schemars(extend("default" = []))]
    pub effects: Vec<Box<dyn Effect>>,
    /// The linear block's autoregressive part reads the chain's output, so the output side's
    /// blocks act inside the loop (as `model.feedback` describes). `false`: the linear block
    /// reads its own past outputs (eq 1).
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    #[schemars(extend("default" = false))]
    pub feedback: bool,
}

impl SimulatorSpec {
    /// The built-in simulator of this spec (sample time 1).
    pub fn plant(&self) -> crate::plant::SimulatedPlant<'_> {
        crate::plant::SimulatedPlant {
            linear: self.linear(),
            nonlinearity: self.nonlinearity.as_ref(),
            structure: self.structure,
            input: &self.input,
            output: &self.output,
            effects: &self.effects,
            dt: 1.0,
            feedback: self.feedback,
        }
    }
    /// The linear block.
    pub fn linear(&self) -> LinearModel {
        LinearModel {
            a: self.a.clone(),
            b: self.b.clone(),
        }
    }
}

/// Columns of a CSV file with a header row, named by their headers (optionally only the rows
/// whose `part` column equals a value, a row range, and block means of `decimate` samples).
#[derive(Debug, Clone, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct CsvColumns {
    /// The CSV file, relative to the spec's directory.
    pub file: PathBuf,
    /// The input column's header.
    pub u: String,
    /// The output column's header.
    pub y: String,
    /// Time column in seconds (optional): steady-state points take their sample time from it
    /// (`t / dt`, which a sensor drift needs); a dynamic record's times must be evenly spaced
    /// by `dt`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub t: Option<String>,
    /// Step column (steady-state points only, optional): the height of the square-wave step
    /// that led to each point (`|ū_k - ū_(k-1)|`, finite and > 0). It scales the overshoot
    /// allowance α of eqs (14)-(15); without it α assumes the paper's ascending order, a step
    /// of `2|ū|`, which is looser for points reached by a smaller step (a shuffled design).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub step: Option<String>,
    /// Keep only rows whose `part` column equals this.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub part: Option<String>,
    /// Keep the data rows `[start, end)` (0-based, after `part`). Dynamic records only: an
    /// error on steady-state points.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rows: Option<[usize; 2]>,
    /// Replace each block of `decimate` samples by its mean (1: none). Dynamic records only:
    /// an error on steady-state points.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub decimate: Option<usize>,
}

impl CsvColumns {
    /// Columns `u` and `y` of `file`, every row, as `smid simulate` writes a record.
    pub fn uy(file: impl Into<PathBuf>) -> Self {
        CsvColumns {
            file: file.into(),
            u: "u".into(),
            y: "y".into(),
            t: None,
            step: None,
            part: None,
            rows: None,
            decimate: None,
        }
    }
}

/// One record or a list of records.
#[derive(Debug, Clone, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(untagged)]
pub enum OneOrMany<T> {
    /// A single item, written without a list.
    One(T),
    /// A list of items.
    Many(Vec<T>),
}

impl<T> OneOrMany<T> {
    /// The items in order.
    pub fn items(&self) -> Vec<&T> {
        match self {
            OneOrMany::One(t) => vec![t],
            OneOrMany::Many(v) => v.iter().collect(),
        }
    }
}

/// Measured data: optional steady-state points and one or more dynamic records (the training
/// records).
#[derive(Debug, Clone, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct DataSpec {
    /// The steady-state points for stage 1, one row each: column `u` the steady input `ū`
    /// (signed), column `y` the steady output `ȳ` (at least 4 points, two per branch). Not
    /// set: identification from the dynamic records alone, the nonlinearity's parameters
    /// bisected over `model.prior`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub steady_state: Option<CsvColumns>,
    /// The training records: one record, or a list of records identified together (each a
    /// dynamic experiment with its own start).
    pub dynamic: OneOrMany<CsvColumns>,
    /// Sample time of the raw data in seconds (default 1); decimation multiplies it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub dt: Option<f64>,
    /// How a fresh record `PATH@START..END` of `smid validate --data` sets the model's initial
    /// state (default `measured`).
    #[serde(default, skip_serializing_if = "InitialState::is_measured")]
    pub initial: InitialState,
}

/// How validation sets a fresh record's initial state.
#[derive(
    Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize, schemars::JsonSchema,
)]
#[serde(rename_all = "snake_case")]
pub enum InitialState {
    /// The first `na + nb + nk` measured samples of the record give the initial condition, as
    /// MATLAB's `compare` estimates one; the figures leave them out.
    #[default]
    Measured,
    /// The rows before `START` are the input history: the model runs from rest at the file's
    /// first row on the input alone, and only the rows `START..END` count (a plain `PATH`:
    /// every row, from rest). No measured output sets the state (a benchmark's protocol for a
    /// test part that follows its estimation part). `START` must be a multiple of the
    /// record's `decimate`.
    InputHistory,
}

impl InitialState {
    fn is_measured(&self) -> bool {
        *self == InitialState::Measured
    }
}

fn d_seed() -> u64 {
    1
}
fn d_abar() -> f64 {
    1.0
}
fn d_tol() -> f64 {
    0.1
}
fn d_eps() -> f64 {
    1e-5
}
fn d_step() -> f64 {
    3.0
}
fn d_settle() -> usize {
    500
}
fn d_m() -> usize {
    50
}
fn d_min() -> f64 {
    0.6
}
fn d_max() -> f64 {
    3.0
}
fn d_n() -> usize {
    100
}
fn d_one() -> f64 {
    1.0
}
fn d_hold() -> usize {
    1
}
fn d_true() -> bool {
    true
}

/// Experiment design: the filter, the steady-state experiment and the dynamic one.
#[derive(Debug, Clone, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct ExperimentSpec {
    /// Seed of the random draws: the PRBS, the noise added to the output, the shuffled order
    /// of `steady_state.shuffle`. The same seed gives the same data.
    #[serde(default = "d_seed")]
    pub seed: u64,
    /// The first-order filter that shapes the steady-state square wave (paper Appendix).
    #[serde(default)]
    pub filter: FilterSpec,
    /// The steady-state experiment of stage 1 (paper Section 3.2).
    #[serde(default)]
    pub steady_state: SteadySpec,
    /// The dynamic experiment (PRBS) of stages 2 and 3.
    #[serde(default)]
    pub dynamic: DynamicSpec,
}
impl Default for ExperimentSpec {
    fn default() -> Self {
        ExperimentSpec {
            seed: 1,
            filter: FilterSpec::default(),
            steady_state: SteadySpec::default(),
            dynamic: DynamicSpec::default(),
        }
    }
}

/// The first-order low-pass filter `(1 - a)/(z - a)` that shapes the steady-state square wave
/// so that the inner signal does not overshoot (Section 3.1): a given `pole`, or the Appendix
/// search for the fastest pole that passes, with the other fields as its options.
#[derive(Debug, Clone, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct FilterSpec {
    /// The filter's pole `a` (`0 <= a < 1`; closer to 1 is slower). Not set: the Appendix
    /// search designs it on the plant, noise-free.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub pole: Option<f64>,
    /// `ā`, the slowest pole of the search (`0 < ā <= 1`; 1 is the quasi-static limit, run as
    /// `1 - 1e-4`): the output reached through it is the reference, and poles are searched in
    /// `[0, ā]`.
    #[serde(default = "d_abar")]
    pub a_bar: f64,
    /// The search stops when its bracket of poles is narrower than `tol` (`1e-12 <= tol < 1`).
    #[serde(default = "d_tol")]
    pub tol: f64,
    /// `ε`: a pole passes when its steady-state output and its overshoot differ from the
    /// reference's by at most `ε` (output units, `> 0`).
    #[serde(default = "d_eps")]
    pub epsilon: f64,
    /// `r̄_F`: the amplitude of the search's test step (input units, non-zero). It also scales
    /// the overshoot allowance α of `method.alpha`.
    #[serde(default = "d_step")]
    pub step: f64,
    /// Samples the plant is given to settle after the filter has settled, in each test step
    /// (at most 1000000); also added to each steady-state half-wave when
    /// `steady_state.half_period` is not set.
    #[serde(default = "d_settle")]
    pub settle: usize,
}
impl Default for FilterSpec {
    fn default() -> Self {
        FilterSpec {
            pole: None,
            a_bar: 1.0,
            tol: 0.1,
            epsilon: 1e-5,
            step: 3.0,
            settle: 500,
        }
    }
}
impl FilterSpec {
    /// Options of the Appendix search.
    pub fn bisection(&self) -> BisectionOptions {
        BisectionOptions {
            a_bar: self.a_bar,
            tol: self.tol,
            epsilon: self.epsilon,
            step: self.step,
            settle: self.settle,
        }
    }
}

/// Steady-state experiment (Section 3.2, stage 1): a square wave of `M` amplitudes equally
/// spaced in `[min, max]`, through the filter; each amplitude is held for a positive and then a
/// negative half-wave, and the output is sampled at the end of each (`2M` points).
#[derive(Debug, Clone, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct SteadySpec {
    /// `M`, the number of amplitudes (2 to 100000).
    #[serde(default = "d_m")]
    pub amplitudes: usize,
    /// The smallest amplitude (input units, `0 < min < max`).
    #[serde(default = "d_min")]
    pub min: f64,
    /// The largest amplitude (input units).
    #[serde(default = "d_max")]
    pub max: f64,
    /// Samples per half-wave. Not set: the filter's settling time plus `filter.settle`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub half_period: Option<usize>,
    /// Play the amplitudes in a random order (drawn from the experiment's seed) instead of
    /// ascending: time and amplitude decorrelate, so a sensor drift cannot pass for a slope.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    #[schemars(extend("default" = false))]
    pub shuffle: bool,
    /// No steady-state experiment (nor filter design): identification from the dynamic record
    /// alone, the nonlinearity's parameters bisected over `model.prior`.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    #[schemars(extend("default" = false))]
    pub skip: bool,
}
impl Default for SteadySpec {
    fn default() -> Self {
        SteadySpec {
            amplitudes: 50,
            min: 0.6,
            max: 3.0,
            half_period: None,
            shuffle: false,
            skip: false,
        }
    }
}

/// Dynamic experiment (Section 4, stages 2-3): a pseudo-random binary sequence (PRBS) of
/// `length` samples switching between `±amplitude`, each bit held `hold` samples.
#[derive(Debug, Clone, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct DynamicSpec {
    /// `N`, the number of samples (10 to 20000000).
    #[serde(default = "d_n")]
    pub length: usize,
    /// The input's amplitude (input units, `> 0`).
    #[serde(default = "d_one")]
    pub amplitude: f64,
    /// Samples each bit is held (1: a new bit every sample).
    #[serde(default = "d_hold")]
    pub hold: usize,
    /// Number of input levels: 2 is the binary PRBS `±amplitude`; more draws each held value's
    /// magnitude from `levels/2` equally spaced values in `(0, amplitude]`, with the PRBS's
    /// sign.
    #[serde(default = "d_levels", skip_serializing_if = "is_two")]
    #[schemars(extend("default" = 2))]
    pub levels: usize,
}
fn d_levels() -> usize {
    2
}
fn is_two(n: &usize) -> bool {
    *n == 2
}
impl Default for DynamicSpec {
    fn default() -> Self {
        DynamicSpec {
            length: 100,
            amplitude: 1.0,
            hold: 1,
            levels: 2,
        }
    }
}

impl ExperimentSpec {
    /// The steady-state experiment's options as [`crate::experiment`] takes them (the
    /// shuffle seed derived from `seed`).
    pub fn steady_options(&self) -> SteadyStateOptions {
        SteadyStateOptions {
            amplitudes: self.steady_state.amplitudes,
            min: self.steady_state.min,
            max: self.steady_state.max,
            half_period: self.steady_state.half_period,
            settle: self.filter.settle,
            shuffle: self
                .steady_state
                .shuffle
                .then_some(self.seed ^ 0x5eed_5eed_5eed_5eed),
        }
    }
    /// The dynamic experiment's options as [`crate::experiment`] takes them.
    pub fn dynamic_options(&self) -> DynamicOptions {
        DynamicOptions {
            length: self.dynamic.length,
            amplitude: self.dynamic.amplitude,
            hold: self.dynamic.hold,
            levels: self.dynamic.levels,
        }
    }
}

/// The model structure to identify: a linear block `B(q^-1)/A(q^-1)` with a nonlinearity
/// before or after it, further blocks and effects. Parameter names: `a1`.., `b0`.. for the
/// linear block, the nonlinearity's own (`m_l`, `c_l`, ...), `in1.<name>`, `out1.<name>`, ...
/// for the chain's blocks, the effects' own (`offset`, ...).
#[derive(Debug, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct ModelSpec {
    /// Where the nonlinearity sits: `wiener` (the linear block, then the nonlinearity) or
    /// `hammerstein` (the nonlinearity, then the linear block).
    #[serde(default)]
    pub structure: Structure,
    /// The nonlinearity to identify: a block `type` (its parameters are identified; some
    /// `type`s take options).
    pub nonlinearity: Box<dyn NonlinearityModel>,
    /// Blocks before the linear block (and before `nonlinearity` when Hammerstein), in signal
    /// order: any registered plugin that supports the input side. Each is bisected over its
    /// prior box, its parameters named `in1.<name>`, `in2.<name>`, ... in `prior`.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    #[schemars(extend("default" = []))]
    pub input: Vec<Box<dyn NonlinearityModel>>,
    /// Blocks after the nonlinearity (Wiener) or the linear block (Hammerstein), in signal
    /// order: any registered plugin that supports the output side (a sensor lag, a second
    /// nonlinearity). Parameters `out1.<name>`, ... in `prior`.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    #[schemars(extend("default" = []))]
    pub output: Vec<Box<dyn NonlinearityModel>>,
    /// `na`, the order of `A(q^-1) = 1 + a_1 q^-1 + .. + a_na q^-na` (coefficients `a1`..;
    /// at most 8, effects included).
    pub na: usize,
    /// `nb`, the order of `B(q^-1) = b_0 + b_1 q^-1 + .. + b_nb q^-nb` (coefficients `b0`..;
    /// at most 8, effects included).
    pub nb: usize,
    /// Input delay in samples: the equation reads `v_{t-nk-j}` (at most 1000).
    #[serde(default, skip_serializing_if = "is_zero")]
    #[schemars(extend("default" = 0))]
    pub nk: usize,
    /// Coefficients known in advance, by name (`a1`.., `b0`.., effect coefficients), e.g.
    /// `{b0: 0}`.
    #[serde(default)]
    pub fixed: BTreeMap<String, f64>,
    /// Impose the unit steady-state gain of eq (8), `Σ b_j = 1 + Σ a_i`: the nonlinearity then
    /// carries the gain, which makes the parameters unique.
    #[serde(default = "d_true")]
    pub unit_gain: bool,
    /// The linear block is declared **stable** (every root of `A(q)` inside the closed unit
    /// disc): each `a_i` then lies within `±C(na, i)`, a box every stage-3 method starts from.
    /// It cuts off the unstable explanations a poorly exciting record leaves open (an
    /// otherwise unbounded `θ`). An assumption: the bounds are guaranteed for stable plants.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    #[schemars(extend("default" = false))]
    pub stable: bool,
    /// The linear block's autoregressive part reads the chain's **output** (after the output
    /// side's blocks, before the sensor terms): `x_t = -Σ a_i w_{t-i} + Σ b_j v_{t-nk-j} + …`,
    /// `w_t = N(x_t)`. An output block then acts **inside the loop**: a tank's level clipped at
    /// its rim goes on from the clipped level, where a Wiener block would clip only what is
    /// measured. Stage 3 reads the past outputs at the measurements (`w ∈ y ± Δ` through the
    /// sensor terms), so an equation is usable wherever the inner sample `x_t` is bounded, a
    /// clipped sample giving a half-space. `false`: the linear block reads its own past
    /// outputs (eq 1).
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    #[schemars(extend("default" = false))]
    pub feedback: bool,
    /// Effects: further terms of the model (delay, actuator lag, sensor offset or drift,
    /// friction...), each a registered `type`; their values are identified, not given.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    #[schemars(extend("default" = []))]
    pub effects: Vec<Box<dyn Effect>>,
    /// Prior box `[lo, hi]` of every parameter the branch and bound bisects, by name, e.g.
    /// `{offset: [-0.1, 0.1]}`: the sensor parameters of effects, the chain's blocks, and the
    /// nonlinearity's parameters when there are no steady-state data.
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    #[schemars(extend("default" = {}))]
    pub prior: BTreeMap<String, [f64; 2]>,
}

fn is_zero(n: &usize) -> bool {
    *n == 0
}

/// The overshoot allowance α of stage 1 (eqs 14-15): how far below its branch a steady-state
/// point may lie because the filtered square wave made the inner signal overshoot.
#[derive(
    Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, schemars::JsonSchema, Default,
)]
#[serde(rename_all = "snake_case")]
pub enum AlphaSpec {
    /// From the overshoot the noise-free filter design measured at the chosen pole, scaled to
    /// each step (guaranteed when the design ran on the plant; needs the Appendix search).
    #[default]
    Design,
    /// The paper's `α = 2Δη|ū|/r̄_F`, on the side of the possible overshoot bias of each branch.
    Bias,
    /// `α = 0`: the filter is known to be overshoot-free (e.g. designed noise-free).
    Zero,
}

/// Method options: the overshoot allowance, the stage-3 method and the budgets of the searches.
#[derive(Debug, Clone, Serialize, Deserialize, schemars::JsonSchema, Default)]
#[serde(deny_unknown_fields)]
pub struct MethodSpec {
    /// The overshoot allowance α of stage 1 (eqs 14-15).
    #[serde(default)]
    pub alpha: AlphaSpec,
    /// The stage-3 method: how the linear block's parameters are bounded from the inner
    /// signal's bounds (an errors-in-variables problem).
    #[serde(default)]
    pub eiv: EivMethod,
    /// Options of the chosen stage-3 method (its own names, e.g. `max_rounds` for `shared`;
    /// unknown ones are an error naming them). Empty: the method's defaults.
    #[serde(default, skip_serializing_if = "serde_json::Map::is_empty")]
    #[schemars(extend("default" = {}))]
    pub options: serde_json::Map<String, serde_json::Value>,
    /// Also use equations whose inner samples are only known to lie in the dead band
    /// (not set: yes for every method but `classical`, which keeps the paper's choice).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub band_samples: Option<bool>,
    /// Budget of the branch and bound over the bisected parameters (the parameters of
    /// effects, of the chain's blocks, and of the nonlinearity without steady-state data).
    #[serde(default)]
    pub cells: CellSpec,
    /// The search for the simulation member: the member of the identified set whose free run
    /// fits the training records best.
    #[serde(default)]
    pub member: MemberSpec,
    /// Budget of the sign search over samples whose preimage is two intervals (behind `|·|`).
    #[serde(default, skip_serializing_if = "SignSpec::is_default")]
    pub signs: SignSpec,
}

/// Budget of the sign search ([`crate::pipeline::signs`]): where a block cannot tell the sign
/// of its input (`|·|`), the sign patterns are searched sample by sample, each node one
/// feasibility LP, at most `width` nodes kept per sample; the patterns that survive are
/// bounded together at the signs they agree on. Past the node budget the later samples keep
/// their hulls: looser, never dropped.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct SignSpec {
    /// Most nodes of the search (1 to 10000000; default 200000).
    #[serde(default = "d_sign_nodes")]
    pub nodes: usize,
    /// A sample whose interval `[lo, hi]` (the positive one of its pair) comes within
    /// `hull_within × (hi - lo)` of zero (`lo < hull_within·(hi - lo)`) is not branched on: it
    /// takes the hull `[-hi, hi]` of its pair, at most `1 + 2·hull_within` times as wide. Such
    /// samples barely tell their signs apart, and each would double the patterns that survive
    /// (`>= 0`, finite; 0 branches on every sample; default 0.5).
    #[serde(default = "d_hull_within")]
    pub hull_within: f64,
    /// Most nodes kept per decided sample (1 to 4096; default 16). Past it, nodes that agree on
    /// their latest signs are merged into one that takes the hull wherever they differ: sound,
    /// looser where the merged patterns differ. A record whose surviving patterns never
    /// outnumber it gets the exact hull of their bounds.
    #[serde(default = "d_sign_width")]
    pub width: usize,
}

fn d_sign_width() -> usize {
    16
}

fn d_hull_within() -> f64 {
    0.5
}

fn d_sign_nodes() -> usize {
    200_000
}

impl Default for SignSpec {
    fn default() -> Self {
        SignSpec {
            nodes: d_sign_nodes(),
            hull_within: d_hull_within(),
            width: d_sign_width(),
        }
    }
}

impl SignSpec {
    fn is_default(&self) -> bool {
        *self == SignSpec::default()
    }
}

impl crate::settings::Check for SignSpec {
    const PLACE: &'static str = "method.signs";
    fn invalid(&self) -> Option<(&'static str, String)> {
        if !(1..=10_000_000).contains(&self.nodes) {
            return Some((
                "nodes",
                format!("expected 1 <= nodes <= 10000000, got {}", self.nodes),
            ));
        }
        if !(1..=4096).contains(&self.width) {
            return Some((
                "width",
                format!("expected 1 <= width <= 4096, got {}", self.width),
            ));
        }
        (!(self.hull_within.is_finite() && self.hull_within >= 0.0)).then(|| {
            (
                "hull_within",
                format!(
                    "expected a finite hull_within >= 0, got {}",
                    self.hull_within
                ),
            )
        })
    }
}

/// Budget of the search for the simulation member ([`crate::members::simulation`]), a point
/// of the identified set certified consistent whose free run fits the training records best:
/// the cells probed (nearest the central cell), the best ones searched, Nelder-Mead iterations
/// per run and runs for a certified point, and whether certified members are spread over the
/// set for the envelope. `search: false` skips it (the centre, not certified, stands in).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct MemberSpec {
    /// Search for the member. `false`: the centre of the bounds stands in, not certified.
    #[serde(default = "d_true")]
    pub search: bool,
    /// Cells probed: the `probe` bounded cells nearest the central one are ranked by how close
    /// their centres come to consistent (`>= 1`).
    #[serde(default = "d_probe")]
    pub probe: usize,
    /// How many of the best-ranked probed cells are searched (`>= 1`).
    #[serde(default = "d_member_cells")]
    pub cells: usize,
    /// Nelder-Mead iterations per run (1 to 100000).
    #[serde(default = "d_iterations")]
    pub iterations: u64,
    /// Runs per cell towards a certified point, each from the best point so far (1 to 100).
    #[serde(default = "d_restarts")]
    pub restarts: usize,
    /// Spread further certified members over the set around the member, for the envelope of
    /// free runs the reports draw.
    #[serde(default = "d_true")]
    pub spread: bool,
    /// A ranking search (`spread: false`) stops looking for a certified point in a cell, and
    /// in the lower-ranked cells, after a run whose phase-1 measure stays above `far` (the
    /// inner-signal boxes that much short of admitting the point; `> 0`). On the 12-bit
    /// diagnoses every search that certified ended its first run below 0.013, every failed
    /// one above 0.72.
    #[serde(default = "d_far")]
    pub far: f64,
    /// A ranking search gives up its first phase-1 run when, after `hopeless_after`
    /// evaluations, its best measure is still above `hopeless` (`> 0`). On the three 12-bit
    /// diagnoses (36 searches), after 30 evaluations every search that went on to certify
    /// stood at or below 0.18, every one that did not at or above 0.53; a failed search
    /// otherwise spends about 250 evaluations before `far` stops it.
    #[serde(default = "d_hopeless")]
    pub hopeless: f64,
    /// Evaluations after which `hopeless` applies (`>= 1`).
    #[serde(default = "d_hopeless_after")]
    pub hopeless_after: usize,
}

fn d_far() -> f64 {
    0.1
}
fn d_hopeless() -> f64 {
    0.35
}
fn d_hopeless_after() -> usize {
    30
}

fn d_probe() -> usize {
    64
}
fn d_member_cells() -> usize {
    3
}
fn d_iterations() -> u64 {
    150
}
fn d_restarts() -> usize {
    4
}

impl Default for MemberSpec {
    fn default() -> Self {
        MemberSpec {
            search: true,
            probe: d_probe(),
            cells: d_member_cells(),
            iterations: d_iterations(),
            restarts: d_restarts(),
            spread: true,
            far: d_far(),
            hopeless: d_hopeless(),
            hopeless_after: d_hopeless_after(),
        }
    }
}

impl crate::settings::Check for MemberSpec {
    const PLACE: &'static str = "method.member";
    fn invalid(&self) -> Option<(&'static str, String)> {
        let positive = |v: f64| v.is_finite() && v > 0.0;
        [
            (
                self.probe >= 1,
                "probe",
                format!("expected probe >= 1, got {}", self.probe),
            ),
            (
                self.cells >= 1,
                "cells",
                format!("expected cells >= 1, got {}", self.cells),
            ),
            (
                (1..=100_000).contains(&self.iterations),
                "iterations",
                format!(
                    "expected 1 <= iterations <= 100000, got {}",
                    self.iterations
                ),
            ),
            (
                (1..=100).contains(&self.restarts),
                "restarts",
                format!("expected 1 <= restarts <= 100, got {}", self.restarts),
            ),
            (
                positive(self.far),
                "far",
                format!("expected a finite far > 0, got {}", self.far),
            ),
            (
                positive(self.hopeless),
                "hopeless",
                format!("expected a finite hopeless > 0, got {}", self.hopeless),
            ),
            (
                self.hopeless_after >= 1,
                "hopeless_after",
                format!("expected hopeless_after >= 1, got {}", self.hopeless_after),
            ),
        ]
        .into_iter()
        .find(|c| !c.0)
        .map(|(_, field, message)| (field, message))
    }
}

impl MemberSpec {
    /// Whether the search only ranks (no spread: the diagnosis's candidates, whose fits are
    /// compared, not reported as the model's member): it may then give up on a cell, and on the
    /// lower-ranked cells, once a run ends far from a certified point. A full search does not.
    pub fn gives_up_early(&self) -> bool {
        !self.spread
    }
    /// The light budget the diagnosis gives each candidate (its choice needs a fit, not the
    /// envelope): 16 cells probed, two searched, no spread.
    pub const LIGHT: MemberSpec = MemberSpec {
        search: true,
        probe: 16,
        cells: 2,
        iterations: 150,
        restarts: 4,
        spread: false,
        far: 0.1,
        hopeless: 0.35,
        hopeless_after: 30,
    };
}

fn d_depth() -> u32 {
    30
}
fn d_max_cells() -> usize {
    4000
}

/// Budget of the branch and bound ([`crate::cells`]): each bisected parameter is halved until
/// its cell is narrower than the parameter's resolution (set by its effect from the noise
/// bound: `Δη/2` for an offset) or `depth` times, and at most `max_cells` cells are evaluated;
/// past the budget the hull of the cells kept so far is reported (still guaranteed, looser) and
/// the report says the budget stopped it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct CellSpec {
    /// Most halvings of each bisected parameter (at most 60).
    #[serde(default = "d_depth")]
    pub depth: u32,
    /// Most cells evaluated, each one run of stages 1-2 and a stage-3 test (1 to 1000000).
    #[serde(default = "d_max_cells")]
    pub max_cells: usize,
    /// The nonlinearity's bisected parameters (a prior box without steady-state data) are
    /// halved down to `prior width / 2^nonlinearity_halvings`.
    #[serde(default = "d_nl_halvings")]
    pub nonlinearity_halvings: u32,
    /// Surviving cells bounded at most (each is one stage-3 bound by the spec's method: cheap
    /// with `classical`, much dearer with `shared`); more are merged back into the cells they
    /// were cut from (looser, still guaranteed, and the report says so).
    #[serde(default = "d_max_leaves")]
    pub max_leaves: usize,
}

fn d_nl_halvings() -> u32 {
    6
}
fn d_max_leaves() -> usize {
    1024
}

impl Default for CellSpec {
    fn default() -> Self {
        CellSpec {
            depth: d_depth(),
            max_cells: d_max_cells(),
            nonlinearity_halvings: d_nl_halvings(),
            max_leaves: d_max_leaves(),
        }
    }
}

impl MethodSpec {
    /// Whether band-bounded samples are used (the explicit choice, else the method's default).
    pub fn use_band_samples(&self) -> bool {
        self.band_samples
            .unwrap_or(self.eiv != EivMethod::Classical)
    }
}

impl Spec {
    /// The θ-index of each fixed coefficient (see [`ModelSpec::layout`]).
    pub fn fixed_theta(&self) -> Result<Vec<Option<f64>>> {
        Ok(self.model.layout()?.fixed)
    }
}
