//! The one model: what `smid run` identifies and what `smid validate` and `smid diagnose`
//! check and extend. A [`ModelSpec`] (the spec's `model:` section: structure, nonlinearity
//! plugin, orders, effects, priors) resolves to a [`Layout`] (orders after the effects, the
//! names of `θ = [a_1..a_na, b_0..b_nb, c_1..c_m]` (eq 7 plus the effects' equation
//! coefficients), the bisected parameters `ψ` with their prior box: the nonlinearity's when
//! `model.prior` names them, the chain's blocks' ([`crate::chain`]), the effects'). Identification yields a
//! [`ModelSet`]: one [`CellSet`] per surviving cell of `ψ` (a single cell when nothing is
//! bisected), each holding the nonlinearity's feasible set (stage 1, eqs 13-20: polygons,
//! staircases...) and guaranteed `θ` intervals (stage 3), together with the training data from
//! which the stage-3 LP data are rebuilt exactly. It serialises whole into `result.json`.
//!
//! Concrete members of the set, which simulate, are in [`crate::members`].
use crate::chain::{BlockLayout, Side};
use crate::effect::{self, Orders, Signals};
use crate::error::{Result, SmidError};
use crate::interval::Interval;
use crate::nonlinearity::{tag_of_model, NonlinearitySet, SteadyStateData, Structure};
use crate::spec::{EivMethod, MethodSpec, ModelSpec};
use serde::{Deserialize, Serialize};
use std::ops::Range;

/// A bisected parameter: its name and prior interval.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CellDim {
    /// The parameter's name (`m_l`, `in1.c_l`, an effect's parameter).
    pub name: String,
    /// The prior interval the branch and bound bisects.
    pub prior: Interval,
}

/// The resolved structure of a [`ModelSpec`].
#[derive(Debug, Clone)]
pub struct Layout {
    /// Orders after every effect's change.
    pub orders: Orders,
    /// `θ` names: `a1..a_na`, `b0..b_nb`, then each equation term's coefficient.
    pub theta_names: Vec<String>,
    /// The equation terms' coefficient names (the tail of `theta_names`).
    pub extra_names: Vec<String>,
    /// Fixed `θ` entries (`model.fixed`), in `θ` order.
    pub fixed: Vec<Option<f64>>,
    /// The bisected parameters `ψ`: the nonlinearity's (when its prior is given), then the
    /// effects'.
    pub dims: Vec<CellDim>,
    /// The slice of `ψ` that holds the nonlinearity's parameters (empty: stage 1 from
    /// steady-state data).
    pub nonlinearity_cells: Range<usize>,
    /// The slice of `ψ` that belongs to each effect, in effect order.
    pub effect_cells: Vec<Range<usize>>,
    /// The chain's blocks besides the nonlinearity (`model.input`, then `model.output`), each
    /// with its slice of `ψ` (see [`crate::chain`]).
    pub blocks: Vec<BlockLayout>,
    /// The prior box of `θ` every stage-3 method starts inside (`model.stable`: each `a_i`
    /// within `±C(na, i)`); `None`: the whole space.
    pub theta_prior: Option<Vec<Interval>>,
}

impl Layout {
    /// The part of a cell that belongs to each effect.
    pub fn effect_slices<'c>(&self, cell: &'c [Interval]) -> Vec<&'c [Interval]> {
        self.effect_cells.iter().map(|r| &cell[r.clone()]).collect()
    }
    /// Number of `θ` entries.
    pub fn p(&self) -> usize {
        self.theta_names.len()
    }
}

fn check_prior(name: &str, p: &[f64; 2]) -> Result<Interval> {
    if !(p[0].is_finite() && p[1].is_finite() && p[0] <= p[1]) {
        return Err(SmidError::invalid(
            format!("model.prior.{name}"),
            format!(
                "expected finite [lo, hi] with lo <= hi, got [{}, {}]",
                p[0], p[1]
            ),
        ));
    }
    Ok(Interval::new(p[0], p[1]))
}

impl ModelSpec {
    /// The linear orders as declared (before effects).
    pub fn base_orders(&self) -> Orders {
        Orders {
            na: self.na,
            nb: self.nb,
            nk: self.nk,
        }
    }

    /// The plugin of one of the chain's blocks (`model.input` or `model.output`).
    pub fn block_model(&self, b: &BlockLayout) -> &dyn crate::nonlinearity::NonlinearityModel {
        match b.side {
            Side::Input => self.input[b.index].as_ref(),
            Side::Output => self.output[b.index].as_ref(),
        }
    }

    /// Resolve the structure; errors name the field (`model.fixed.x`, `model.prior.x`).
    pub fn layout(&self) -> Result<Layout> {
        // Orders bound every allocation below: check them (and each effect's share, from
        // zero, so the sum cannot overflow) before anything is sized by them.
        Self::orders_in_range(self.base_orders(), "model")?;
        if self.feedback && self.unit_gain {
            return Err(SmidError::invalid(
                "model.feedback",
                "a model whose autoregressive part reads the chain's output takes no unit steady-state gain (eq 8): set `unit_gain: false`",
            ));
        }
        if self.feedback
            && (self.structure == crate::nonlinearity::Structure::Hammerstein
                || !self.input.is_empty())
        {
            return Err(SmidError::invalid(
                "model.feedback",
                "the past outputs are read from data in the place of an uncertain input, so the linear block's input must be exact: no `model.input` blocks and `structure: wiener` (put the blocks on the output side)",
            ));
        }
        for (i, e) in self.effects.iter().enumerate() {
            let mut o = Orders {
                na: 0,
                nb: 0,
                nk: 0,
            };
            e.orders(&mut o);
            Self::orders_in_range(o, &format!("model.effects[{i}]"))?;
        }
        let orders = effect::augmented(self.base_orders(), &self.effects);
        let empty = Signals::input(&[], 1.0);
        let extra_names: Vec<String> = effect::regressors(&self.effects, &empty)
            .into_iter()
            .map(|c| c.name)
            .collect();
        let mut theta_names = crate::stage3::theta_names(orders.na, orders.nb);
        theta_names.extend(extra_names.iter().cloned());
        let mut dims = Vec::new();
        self.nonlinearity_dims(&mut dims)?;
        let nonlinearity_cells = 0..dims.len();
        let blocks = self.block_dims(&mut dims)?;
        let effect_cells = self.effect_dims(&mut dims)?;
        self.check_names(&theta_names, &dims)?;
        let fixed = self.fixed_theta_values(orders, &theta_names)?;
        let theta_prior = self
            .stable
            .then(|| crate::stage3::stable_prior(orders.na, theta_names.len()));
        Ok(Layout {
            orders,
            theta_names,
            extra_names,
            fixed,
            dims,
            nonlinearity_cells,
            effect_cells,
            blocks,
            theta_prior,
        })
    }

    /// Orders `o` within what the layout allocates (`na`, `nb` at most 8, `nk` at most 1000);
    /// the error names `field`, or for the model's own orders the one out of range.
    fn orders_in_range(o: Orders, field: &str) -> Result<()> {
        if o.na > 8 || o.nb > 8 || o.nk > 1000 {
            // The model's own orders: the field that is out of range.
            let field = match field {
                "model" if o.na > 8 => "model.na".to_string(),
                "model" if o.nb > 8 => "model.nb".to_string(),
                "model" => "model.nk".to_string(),
                f => f.to_string(),
            };
            return Err(SmidError::invalid(
                field,
                format!(
                    "orders na = {}, nb = {} (at most 8) and delay nk = {} (at most 1000) are out of range",
                    o.na, o.nb, o.nk
                ),
            ));
        }
        Ok(())
    }

    /// The nonlinearity's parameters as bisected parameters, appended to `dims`: all of them
    /// when the prior names any (identification from any record), else none.
    fn nonlinearity_dims(&self, dims: &mut Vec<CellDim>) -> Result<()> {
        // The plugin's parameters are bisected when the prior names any of them (identification
        // from any record); then every one needs its prior.
        let pnames = crate::registry::parameter_names(&self.nonlinearity_tag());
        if pnames.iter().any(|n| self.prior.contains_key(n)) {
            for name in &pnames {
                let p = self.prior.get(name).ok_or_else(|| {
                    SmidError::invalid(
                        format!("model.prior.{name}"),
                        format!(
                            "the nonlinearity's parameters are bisected over a prior box: give all of {}",
                            pnames.join(", ")
                        ),
                    )
                })?;
                dims.push(CellDim {
                    name: name.clone(),
                    prior: check_prior(name, p)?,
                });
            }
        }
        Ok(())
    }

    /// The parameters of the chain's blocks (input side, then output side) as bisected
    /// parameters, appended to `dims`; each block's layout.
    fn block_dims(&self, dims: &mut Vec<CellDim>) -> Result<Vec<BlockLayout>> {
        let mut blocks = Vec::new();
        for (side, list) in [(Side::Input, &self.input), (Side::Output, &self.output)] {
            for (index, b) in list.iter().enumerate() {
                let tag = tag_of_model(b.as_ref());
                let prefix = side.prefix(index + 1);
                let start = dims.len();
                let names = crate::registry::parameter_names(&tag);
                for n in &names {
                    let name = crate::chain::qualified(&prefix, n);
                    let p = self.prior.get(&name).ok_or_else(|| {
                        SmidError::invalid(
                            format!("model.prior.{name}"),
                            format!(
                                "the block `{tag}` at {}[{index}] is bisected over a prior box: give {}",
                                side.field(),
                                names
                                    .iter()
                                    .map(|n| format!("`{}: [lo, hi]`", crate::chain::qualified(&prefix, n)))
                                    .collect::<Vec<_>>()
                                    .join(", ")
                            ),
                        )
                    })?;
                    dims.push(CellDim {
                        prior: check_prior(&name, p)?,
                        name,
                    });
                }
                blocks.push(BlockLayout {
                    side,
                    index,
                    tag,
                    prefix,
                    cells: start..dims.len(),
                });
            }
        }
        Ok(blocks)
    }

    /// The effects' sensor parameters (and a shift at rest with its prior) as bisected
    /// parameters, appended to `dims`; each effect's slice of them.
    fn effect_dims(&self, dims: &mut Vec<CellDim>) -> Result<Vec<std::ops::Range<usize>>> {
        let mut effect_cells = Vec::new();
        for e in &self.effects {
            let start = dims.len();
            for name in e.sensor_parameters() {
                let p = self.prior.get(&name).ok_or_else(|| {
                    SmidError::invalid(
                        format!("model.prior.{name}"),
                        format!(
                            "the effect `{}` has the parameter `{name}`, bisected over a prior box: give `{name}: [lo, hi]`",
                            e.label()
                        ),
                    )
                })?;
                let prior = check_prior(&name, p)?;
                dims.push(CellDim { name, prior });
            }
            // A shift at rest is a parameter only where its prior box is given (for use with
            // steady-state data; see `EquationTerm::rest_parameter`).
            if let Some(name) = e.rest_parameter() {
                if let Some(p) = self.prior.get(&name) {
                    let prior = check_prior(&name, p)?;
                    dims.push(CellDim { name, prior });
                }
            }
            effect_cells.push(start..dims.len());
        }
        Ok(effect_cells)
    }

    /// No two terms share a name, and every prior names a bisected parameter.
    fn check_names(&self, theta_names: &[String], dims: &[CellDim]) -> Result<()> {
        let mut all: Vec<&str> = theta_names.iter().map(|s| s.as_str()).collect();
        all.extend(dims.iter().map(|d| d.name.as_str()));
        let mut sorted = all.clone();
        sorted.sort_unstable();
        if let Some(w) = sorted.windows(2).find(|w| w[0] == w[1]) {
            return Err(SmidError::invalid(
                "model.effects",
                format!("two terms of the model are both named `{}`: declare each effect once (a drift carries its own offset)", w[0]),
            ));
        }
        for k in self.prior.keys() {
            if !dims.iter().any(|d| &d.name == k) {
                return Err(SmidError::invalid(
                    format!("model.prior.{k}"),
                    format!(
                        "no bisected parameter is named `{k}`; the model's are: {}",
                        if dims.is_empty() {
                            "none".to_string()
                        } else {
                            dims.iter()
                                .map(|d| d.name.as_str())
                                .collect::<Vec<_>>()
                                .join(", ")
                        }
                    ),
                ));
            }
        }
        Ok(())
    }

    /// The fixed value of each `θ` entry (`model.fixed`), by index.
    fn fixed_theta_values(
        &self,
        orders: Orders,
        theta_names: &[String],
    ) -> Result<Vec<Option<f64>>> {
        let mut fixed = vec![None; theta_names.len()];
        for (k, v) in &self.fixed {
            let Some(i) = theta_names.iter().position(|n| n == k) else {
                return Err(SmidError::invalid(
                    format!("model.fixed.{k}"),
                    format!(
                        "no such coefficient for na = {}, nb = {} and the declared effects; expected one of {}",
                        orders.na,
                        orders.nb,
                        theta_names.join(", ")
                    ),
                ));
            };
            if !v.is_finite() {
                return Err(SmidError::invalid(
                    format!("model.fixed.{k}"),
                    "expected a finite number",
                ));
            }
            fixed[i] = Some(*v);
        }
        Ok(fixed)
    }

    /// A copy (the plugin and effects are trait objects): a round trip through JSON.
    pub fn duplicate(&self) -> ModelSpec {
        serde_json::from_value(serde_json::to_value(self).expect("model specs serialise"))
            .expect("a serialised model spec deserialises")
    }

    /// The plugin's `type` tag.
    pub fn nonlinearity_tag(&self) -> String {
        tag_of_model(self.nonlinearity.as_ref())
    }

    /// The chain in words: structure, plugin, orders, blocks on each side and the effects'
    /// labels (what a diagnosis report and its log lines name a model by).
    pub fn label(&self) -> String {
        let m = self;
        let mut s = format!(
            "{} {} (na = {}, nb = {}, nk = {})",
            match m.structure {
                crate::nonlinearity::Structure::Wiener => "Wiener",
                crate::nonlinearity::Structure::Hammerstein => "Hammerstein",
            },
            m.nonlinearity_tag(),
            m.na,
            m.nb,
            m.nk
        );
        let tags = |v: &[Box<dyn crate::nonlinearity::NonlinearityModel>]| {
            v.iter()
                .map(|b| tag_of_model(b.as_ref()))
                .collect::<Vec<_>>()
                .join(", ")
        };
        if !m.input.is_empty() {
            s = format!("[{}] -> {s}", tags(&m.input));
        }
        if !m.output.is_empty() {
            s = format!("{s} -> [{}]", tags(&m.output));
        }
        if m.feedback {
            s.push_str(", output side inside the loop");
        }
        for e in &m.effects {
            s.push_str(" + ");
            s.push_str(&e.label());
        }
        s
    }

    /// The term that leaves stage 1's polygons unusable, if any: a term that breaks the
    /// designed steady-state experiment ([`crate::effect::EquationTerm::keeps_steady_design`])
    /// in a Wiener model whose nonlinearity has parameters (it holds the linear block's
    /// overshoot). A Hammerstein nonlinearity sees the filtered input itself, and a nonlinearity
    /// without parameters bounds nothing, so neither needs the design.
    /// Called by stage 1 on every cell: the terms are asked first (most models have none that
    /// breaks the design), the plugin's registry entry only when one does.
    pub fn term_breaking_steady_design(&self) -> Option<&dyn crate::effect::Effect> {
        let term = self.effects.iter().find(|e| !e.keeps_steady_design())?;
        (self.structure == crate::nonlinearity::Structure::Wiener
            && !crate::registry::parameter_names(&self.nonlinearity_tag()).is_empty())
        .then_some(term.as_ref())
    }

    /// Whether the chain has blocks besides the nonlinearity.
    pub fn has_blocks(&self) -> bool {
        !(self.input.is_empty() && self.output.is_empty())
    }
}

/// One dynamic record: input, measured output and per-sample noise bound, with the noise-free
/// signals when they are known (simulated plants).
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
pub struct Record {
    /// Where it came from (file and rows, or the plant and seed), for reports and errors.
    pub name: String,
    /// Input samples `u_t`.
    pub u: Vec<f64>,
    /// Measured output samples `y_t` (noise included).
    pub y: Vec<f64>,
    /// Per-sample noise bound `Δη_t` (eq 5).
    pub dy: Vec<f64>,
    /// Sample time in seconds.
    pub dt: f64,
    /// Noise-free output `w_t`, when simulated.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub w: Option<Vec<f64>>,
    /// Noise-free inner signal `x_t` (between the linear block and the nonlinearity), when
    /// simulated.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub x: Option<Vec<f64>>,
    /// The noise `η_t = y_t - w_t` that was added, when simulated.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub noise: Option<Vec<f64>>,
    /// How validation sets the initial state. `Some(h)`: the model runs from rest at the
    /// first sample on the input alone, and the first `h` samples are input history, left out
    /// of every figure and test. `None`: the first `na + nb + nk` measured samples set it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub history: Option<usize>,
}

impl Record {
    /// A measured record with a constant noise bound.
    pub fn measured(
        name: impl Into<String>,
        u: Vec<f64>,
        y: Vec<f64>,
        delta: f64,
        dt: f64,
    ) -> Self {
        let n = y.len();
        Record {
            name: name.into(),
            u,
            y,
            dy: vec![delta; n],
            dt,
            ..Default::default()
        }
    }
    /// The record without its input history: the samples from `history` on, whose initial
    /// state is then measured (they do not start at rest).
    pub fn without_history(&self) -> Record {
        let h = self.history.unwrap_or(0).min(self.y.len());
        let tail = |v: &Vec<f64>| v[h.min(v.len())..].to_vec();
        Record {
            name: self.name.clone(),
            u: tail(&self.u),
            y: tail(&self.y),
            dy: tail(&self.dy),
            dt: self.dt,
            w: self.w.as_ref().map(tail),
            x: self.x.as_ref().map(tail),
            noise: self.noise.as_ref().map(tail),
            history: None,
        }
    }
    /// The same record with another noise bound.
    pub fn with_bound(&self, delta: f64) -> Record {
        Record {
            dy: vec![delta; self.y.len()],
            ..self.clone()
        }
    }
    /// Check lengths and values; errors name the record and sample.
    pub fn validate(&self) -> Result<()> {
        if self.u.len() != self.y.len() || self.dy.len() != self.y.len() {
            return Err(SmidError::invalid(
                format!("record `{}`", self.name),
                format!(
                    "{} inputs, {} outputs and {} noise bounds: expected equal lengths",
                    self.u.len(),
                    self.y.len(),
                    self.dy.len()
                ),
            ));
        }
        if let Some(t) = self.u.iter().position(|v| !v.is_finite()) {
            return Err(SmidError::invalid(
                format!("record `{}`, sample {t}", self.name),
                "non-finite input",
            ));
        }
        if let Some(t) = (0..self.y.len())
            .find(|&t| !(self.y[t].is_finite() && self.dy[t].is_finite() && self.dy[t] >= 0.0))
        {
            return Err(SmidError::invalid(
                format!("record `{}`, sample {t}", self.name),
                "non-finite output or noise bound",
            ));
        }
        if !(self.dt.is_finite() && self.dt > 0.0) {
            return Err(SmidError::invalid(
                format!("record `{}`", self.name),
                format!("sample time must be > 0, got {}", self.dt),
            ));
        }
        Ok(())
    }
}

/// The training data a model set was identified from (enough to rebuild every stage's data).
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
pub struct Training {
    /// The steady-state points of stage 1 (`None`: the nonlinearity was bounded over a prior
    /// box instead).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub steady: Option<SteadyStateData>,
    /// The dynamic records of stages 2 and 3.
    pub records: Vec<Record>,
}

/// One surviving cell of the bisected parameters, with what the stages proved over it.
#[derive(Debug, Serialize, Deserialize)]
pub struct CellSet {
    /// The cell of `ψ` (empty when nothing is bisected).
    pub cell: Vec<Interval>,
    /// Stage 1: the nonlinearity's feasible set over this cell.
    pub nonlinearity: Box<dyn NonlinearitySet>,
    /// Stage 3: guaranteed `θ` intervals over this cell (fixed entries degenerate).
    pub theta: Vec<Interval>,
    /// Stage 3's rounds stopped at their cap before they settled (the last round's largest
    /// relative shrinkage): `theta` holds, but the set may be far smaller or empty
    /// ([`crate::stage3::EivResult::unsettled`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub unsettled: Option<f64>,
}

impl CellSet {
    /// Whether stage 3 bounded `θ` over this cell (not one left unbounded by the budget).
    pub fn bounded(&self) -> bool {
        self.theta.iter().all(|i| i.is_finite())
    }

    /// A copy (the set is a trait object): a round trip through its serialised form.
    pub fn duplicate(&self) -> CellSet {
        serde_json::from_value(serde_json::to_value(self).expect("cell sets serialise"))
            .expect("a serialised cell set deserialises")
    }
}

/// Where the noise bound came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum BoundSource {
    /// Declared in the spec (a prior guarantee).
    Given,
    /// Estimated from the training data (not a prior guarantee; the report says so): the
    /// margin times the smallest bound the stage-3 method accepts (`noise.estimate`).
    Estimated,
    /// Estimated from the training free run (`noise.from: free_run`): the margin times the
    /// training free-run distance of the best simulator over the set, a bound on the model's
    /// simulation error (not a prior guarantee either).
    FreeRun,
}

impl BoundSource {
    /// Whether the bound was estimated from the data (either way), not declared.
    pub fn estimated(self) -> bool {
        self != BoundSource::Given
    }
    /// What the reports call it.
    pub fn describe(self) -> &'static str {
        match self {
            BoundSource::Given => "declared",
            BoundSource::Estimated => "estimated from the training data",
            BoundSource::FreeRun => "estimated from the training free run",
        }
    }
}

/// One parameter's guaranteed interval with its truth when known.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ParamResult {
    /// The parameter's name (`m_l`, `a1`, `b0`, an effect's coefficient, `in1.c_l`).
    pub name: String,
    /// Guaranteed lower bound (`-inf`, `null` in JSON, when unbounded below).
    #[serde(deserialize_with = "crate::model::lo_inf")]
    pub lower: f64,
    /// Guaranteed upper bound (`+inf`, `null` in JSON, when unbounded above).
    #[serde(deserialize_with = "crate::model::hi_inf")]
    pub upper: f64,
    /// Centre of the bound, `(lower + upper) / 2`.
    #[serde(deserialize_with = "crate::model::hi_inf")]
    pub center: f64,
    /// Half-width of the bound, `(upper - lower) / 2`.
    #[serde(deserialize_with = "crate::model::hi_inf")]
    pub radius: f64,
    /// The true value, when known (simulated plants, or declared in the spec).
    pub truth: Option<f64>,
    /// Whether the truth lies in `[lower, upper]`; `None` when the truth is unknown.
    pub contains: Option<bool>,
}

fn lo_inf<'de, D: serde::Deserializer<'de>>(d: D) -> std::result::Result<f64, D::Error> {
    Ok(Option::<f64>::deserialize(d)?.unwrap_or(f64::NEG_INFINITY))
}
fn hi_inf<'de, D: serde::Deserializer<'de>>(d: D) -> std::result::Result<f64, D::Error> {
    Ok(Option::<f64>::deserialize(d)?.unwrap_or(f64::INFINITY))
}

impl ParamResult {
    /// The result for parameter `name` bounded by `i`, with its truth when known.
    pub fn new(name: &str, i: Interval, truth: Option<f64>) -> Self {
        ParamResult {
            name: name.to_string(),
            lower: i.lo,
            upper: i.hi,
            center: i.center(),
            radius: i.radius(),
            truth,
            contains: truth.map(|t| i.contains(t)),
        }
    }
    /// The bound as an [`Interval`] `[lower, upper]`.
    pub fn interval(&self) -> Interval {
        Interval::new(self.lower, self.upper)
    }
}

/// The identified model set: everything `validate` and `diagnose` need, serialisable.
#[derive(Debug, Serialize, Deserialize)]
pub struct ModelSet {
    /// The spec's `name` (`smid` when it has none).
    pub name: String,
    /// The model structure as declared (plugin, orders, effects, priors).
    pub model: ModelSpec,
    /// The stage options used (stage-3 method, band samples, α, cell budget).
    pub method: MethodSpec,
    /// The noise bound `Δη` of the training data.
    pub delta: f64,
    /// Whether that bound was declared or estimated from the data.
    pub bound_source: BoundSource,
    /// The bisected parameters (empty: one cell, the paper's three stages).
    pub dims: Vec<CellDim>,
    /// The surviving cells.
    pub cells: Vec<CellSet>,
    /// Hull over the cells, in report order: nonlinearity parameters, `θ`, `ψ`.
    pub parameters: Vec<ParamResult>,
    /// Cells evaluated, discarded, and whether the budget stopped the bisection.
    pub search: SearchSummary,
    /// The training data, from which every stage's data are rebuilt exactly.
    pub training: Training,
    /// The simulation member: the certified-consistent member whose free run fits
    /// the training records best; `None` when none was certified (the centre stands in).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub simulation_member: Option<SimulationMember>,
    /// The model's resolved layout (checked once, like linfa's checked hyper-parameters): set
    /// by identification, resolved on first use after reading a `result.json`.
    #[serde(skip)]
    pub resolved: std::sync::OnceLock<Layout>,
}

/// The member of the identified set that simulates the training records best (see
/// [`crate::members::simulation`]): certified consistent with the stage-2 bounds of its cell
/// by the exact LP at fixed `θ`.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct SimulationMember {
    /// Every parameter by name (nonlinearity, `θ`, bisected).
    pub values: Vec<(String, f64)>,
    /// The surviving cell it lies in.
    pub cell: usize,
    /// The consistency measure at it (negative: strictly inside the scaled error boxes; an
    /// infinite one, stored as null, when stage 2 fails at it).
    #[serde(deserialize_with = "crate::model::hi_inf")]
    pub consistency: f64,
    /// Free-run fit % on the training records (warm start as `validate`'s; minus infinity,
    /// stored as null, for a free run that diverges).
    #[serde(deserialize_with = "crate::model::lo_inf")]
    pub training_fit: f64,
    /// The central member's free-run fit % on the same records, for comparison (minus
    /// infinity, stored as null, when it diverges).
    #[serde(deserialize_with = "crate::model::lo_inf")]
    pub centre_training_fit: f64,
    /// Cost evaluations spent by the search.
    pub evaluations: usize,
    /// Further members certified consistent, spread over the set (the farthest certified point
    /// along each searched coordinate from this member, the extremes of each `b` and extra
    /// coefficient at its `a`, moved inwards): the envelope of their free runs is an **inner**
    /// approximation of the set's output range.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub envelope: Vec<Vec<(String, f64)>>,
    /// Whether the exact LP at fixed `θ` proved it consistent. `false`: no point of the set was
    /// certified within the budget, and this is the best free run over the outer bounds, a
    /// stand-in for simulation (reported as not certified, never as a member of the set).
    /// With `model.feedback` the LP holds each sample's inner value and its measured past
    /// output as two variables (stage 3's problem): the point lies in the set stage 3 bounds,
    /// which holds the true `θ`, but need not reproduce the records as a loop within the bound.
    #[serde(default = "certified_default")]
    pub certified: bool,
    /// The largest distance of its free run from any training sample
    /// ([`crate::members::training_within`]): a point of the model consistent at that bound,
    /// so the model's exact smallest consistent bound is at most it. `None` where not
    /// computed (steady-state data, a run that diverges).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub within: Option<f64>,
}

fn certified_default() -> bool {
    true
}

/// What the branch and bound did.
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
pub struct SearchSummary {
    /// Cells tested and finally evaluated.
    pub evaluated: usize,
    /// Cells proven inconsistent with the data and dropped.
    pub discarded: usize,
    /// Whether the cell budget stopped the bisection before every parameter reached its
    /// resolution (the bounds are then looser, still guaranteed).
    pub budget_stopped: bool,
    /// Undecided cells halved further (stage 3 unbounded or a solver failure over them).
    #[serde(default, skip_serializing_if = "is_zero")]
    pub refined: usize,
    /// Cells still undecided when the refinement budget was spent: they are in `cells` with
    /// `θ = (-∞, ∞)` (every θ bound is then infinite; the bisected parameters stay bounded).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub unbounded: Vec<UnboundedCell>,
    /// The stage-3 method whose θ bounds the cells carry, when it is not the spec's: the
    /// spec's method starts from it, and some cell stayed unbounded under it (so under the
    /// spec's method too), which leaves every θ bound infinite whatever the tighter method
    /// finds over the other cells; it was not run. `None`: the cells carry the spec's method's
    /// bounds.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub screened_by: Option<EivMethod>,
}

fn is_zero(n: &usize) -> bool {
    *n == 0
}

/// A cell of the bisected parameters left without a finite `θ` bound.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct UnboundedCell {
    /// The cell, as `name ∈ [lo, hi]` per bisected parameter.
    pub cell: String,
    /// Why stage 3 gave no finite bound over it.
    pub cause: UndecidedCause,
    /// The stage's message (which parameter, which solver path).
    pub detail: String,
}

pub use crate::cells::UndecidedCause;

impl ModelSet {
    /// A copy (trait objects inside): a round trip through its serialised form.
    pub fn duplicate(&self) -> ModelSet {
        serde_json::from_value(serde_json::to_value(self).expect("model sets serialise"))
            .expect("a serialised model set deserialises")
    }

    /// What to tell an engineer when stage 3's rounds stopped at their cap before they settled
    /// in some cell ([`CellSet::unsettled`]): the bounds hold, but the set may be far smaller
    /// or empty, so a "consistent" verdict built on it proves less than it says. `None` when
    /// every cell settled.
    pub fn unsettled_warning(&self) -> Option<String> {
        let capped = self.cells.iter().filter(|c| c.unsettled.is_some()).count();
        let certified = self.simulation_member.as_ref().is_some_and(|m| m.certified);
        self.unsettled().map(|worst| {
            format!(
                "stage 3's rounds stopped at their cap before they settled in {} of {} cell(s) (the last round still shrank a radius by {:.1} %): the bounds hold, but the set may be far smaller{}; raise `method.options.max_rounds` to know",
                capped,
                self.cells.len(),
                100.0 * worst,
                if certified {
                    " (it is not empty: the simulation member is certified)"
                } else {
                    ", or empty (the data would then falsify the model)"
                }
            )
        })
    }

    /// [`ModelSet::unsettled`] unless a certified simulation member proves the set non-empty:
    /// the last-round shrinkage of a set that may be empty, so that a verdict resting on it is
    /// undecided. `None` when every cell settled, or the member is certified.
    pub fn undecided(&self) -> Option<f64> {
        let certified = self.simulation_member.as_ref().is_some_and(|m| m.certified);
        self.unsettled().filter(|_| !certified)
    }

    /// The largest last-round shrinkage over the cells whose stage-3 rounds stopped at their
    /// cap before they settled ([`CellSet::unsettled`]); `None` when every cell settled.
    pub fn unsettled(&self) -> Option<f64> {
        self.cells
            .iter()
            .filter_map(|c| c.unsettled)
            .reduce(f64::max)
    }

    /// The parameters (`name = value ∉ [lower, upper]`) whose reported bounds miss the
    /// simulation member or one of its certified envelope members, beyond the LPs' tolerance.
    /// A certified member lies in the feasible set, so inside every guaranteed bound: anything
    /// listed here is a bug.
    pub fn member_outside_bounds(&self) -> Vec<String> {
        let Some(m) = self.simulation_member.as_ref().filter(|m| m.certified) else {
            return Vec::new();
        };
        std::iter::once(&m.values)
            .chain(&m.envelope)
            .flatten()
            .filter_map(|(n, v)| {
                let p = self.parameter(n)?;
                let tol = 1e-9 * (1.0 + v.abs());
                (!(p.lower - tol <= *v && *v <= p.upper + tol))
                    .then(|| format!("{n} = {v} ∉ [{}, {}]", p.lower, p.upper))
            })
            .collect()
    }

    /// A parameter by name.
    pub fn parameter(&self, name: &str) -> Option<&ParamResult> {
        self.parameters.iter().find(|p| p.name == name)
    }

    /// The resolved layout of the model (derived once per model set).
    pub fn layout(&self) -> Result<&Layout> {
        if let Some(l) = self.resolved.get() {
            return Ok(l);
        }
        let l = self.model.layout()?;
        Ok(self.resolved.get_or_init(|| l))
    }

    /// The structure.
    pub fn structure(&self) -> Structure {
        self.model.structure
    }

    /// The parameters with a non-degenerate bound (the identified ones).
    pub fn free_parameters(&self) -> Vec<&ParamResult> {
        self.parameters
            .iter()
            .filter(|p| p.upper > p.lower)
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A stand-in member whose measure is infinite and whose centre diverges (JSON nulls)
    /// survives the round trip of `result.json` and of `ModelSet::duplicate`.
    #[test]
    fn a_member_with_non_finite_figures_round_trips() {
        let m = SimulationMember {
            values: vec![("a1".into(), -0.5)],
            cell: 0,
            consistency: f64::INFINITY,
            training_fit: 42.0,
            centre_training_fit: f64::NEG_INFINITY,
            evaluations: 3,
            envelope: Vec::new(),
            certified: false,
            within: None,
        };
        let v = serde_json::to_value(&m).unwrap();
        assert!(v["consistency"].is_null() && v["centre_training_fit"].is_null());
        let back: SimulationMember = serde_json::from_value(v).unwrap();
        assert_eq!(back.consistency, f64::INFINITY);
        assert_eq!(back.centre_training_fit, f64::NEG_INFINITY);
        assert_eq!(back.training_fit, 42.0);
        assert!(!back.certified);
    }
}
