//! The search: the branch and bound over the bisected parameters ([`crate::cells`]) with the
//! stages as its tests, the hulls over the surviving cells in report order, and the run's
//! artifacts ([`Identification`]). An estimated noise bound is bracketed first (`bracket`).
use super::*;
use crate::cells::{self, Budget};
use crate::chain::{self};
use crate::effect::DataScale;
use crate::error::{Result, SmidError};
use crate::experiment::{self};
use crate::interval::Interval;
use crate::inversion::InnerBound;
use crate::model::{
    BoundSource, CellSet, Layout, ModelSet, SearchSummary, Training, UnboundedCell, UndecidedCause,
};
use crate::noise;
use crate::nonlinearity::{NonlinearitySet, Structure, UnboundedSet};
use crate::outcome::{Falsification, Outcome};
use crate::settings::Check;
use crate::spec::{AlphaSpec, MethodSpec, ModelSpec, Spec};

/// Result of a whole identification: the model set and the run's artifacts.
#[derive(Debug)]
pub struct Identification {
    /// The spec's `name` (`smid` when it has none).
    pub name: String,
    /// The noise bound `Δη` the set was identified with (declared or estimated; see
    /// [`crate::model::ModelSet::bound_source`]).
    pub delta_eta: f64,
    /// Signal-to-noise ratio of the first training record in dB: `10 log10(Σ w² / Σ η²)` when
    /// the noise-free output is known, else the measured output's power against that of
    /// uniform noise in `[-Δη, Δη]`; NaN without a record.
    pub snr_db: f64,
    /// The identified model set (what `result.json` carries as `model`).
    pub model: ModelSet,
    /// The cell whose artifacts are reported (the one holding the truth when known).
    pub representative: usize,
    /// Stage-2 bounds of the representative cell, first record.
    pub inner: Vec<InnerBound>,
    /// Time indices (in the concatenated records) of the stage-3 equations of that cell.
    pub equations: Vec<usize>,
    /// The data identified from (steady-state points, dynamic records, filter design).
    pub data: ExperimentData,
    /// Whether the truth lies in the exact stage-1 set of some cell holding the true `ψ`.
    pub truth_in_nonlinearity_set: Option<bool>,
    /// Inner samples whose true value falls outside its bound (must be 0), when known.
    pub inner_violations: Option<usize>,
}

impl Identification {
    /// Nonlinearity parameters (stage 1), linear parameters and equation terms (stage 3),
    /// bisected parameters: the hull over the surviving cells.
    pub fn parameters(&self) -> &[ParamResult] {
        &self.model.parameters
    }
    /// Whether every parameter with a known truth is inside its bounds.
    pub fn all_contain_truth(&self) -> Option<bool> {
        let c: Vec<bool> = self
            .model
            .parameters
            .iter()
            .filter_map(|p| p.contains)
            .collect();
        (!c.is_empty()).then(|| {
            c.iter().all(|b| *b)
                && self.truth_in_nonlinearity_set != Some(false)
                && self.inner_violations.unwrap_or(0) == 0
        })
    }
    /// A parameter by name.
    pub fn parameter(&self, name: &str) -> Option<&ParamResult> {
        self.model.parameter(name)
    }
    /// The nonlinearity set of the representative cell.
    pub fn set(&self) -> &dyn NonlinearitySet {
        self.model.cells[self.representative].nonlinearity.as_ref()
    }
}

/// The branch and bound's resolution of each bisected parameter: a nonlinearity's or a
/// block's prior width halved `halvings` times, an effect's own resolution.
pub(super) fn resolution(
    model: &ModelSpec,
    layout: &Layout,
    halvings: u32,
    delta: f64,
    scale: &DataScale,
) -> Vec<f64> {
    let prior: Vec<Interval> = layout.dims.iter().map(|d| d.prior).collect();
    let mut out = crate::nonlinearity::halved_widths(&prior, halvings);
    // Each plugin's own parameters: the nonlinearity's, then every chain block's.
    let plugins = std::iter::once((
        model.nonlinearity.as_ref(),
        layout.nonlinearity_cells.clone(),
    ))
    .chain(
        layout
            .blocks
            .iter()
            .map(|b| (model.block_model(b), b.cells.clone())),
    );
    for (plugin, range) in plugins {
        if range.is_empty() {
            continue;
        }
        let r = plugin.resolution(&prior[range.clone()], halvings, delta);
        for (slot, v) in out[range].iter_mut().zip(r) {
            *slot = v;
        }
    }
    // Each effect's own, slot by slot within its slice (a shift at rest without its prior
    // is not in the slice, and its resolution is dropped with it).
    for (e, range) in model.effects.iter().zip(&layout.effect_cells) {
        for (slot, v) in range.clone().zip(e.resolution(delta, scale)) {
            out[slot] = v;
        }
    }
    out
}

/// Stages 1-3 on acquired data. `truth` holds known true values by parameter name.
pub fn identify(
    spec: &Spec,
    data: ExperimentData,
    truth: &[(String, f64)],
) -> Result<Outcome<Identification>> {
    identify_with(spec, data, truth, &|_| {})
}

/// [`identify`] with a progress callback for the branch and bound over the bisected
/// parameters.
pub fn identify_with(
    spec: &Spec,
    mut data: ExperimentData,
    truth: &[(String, f64)],
    progress: &(dyn Fn(&cells::Progress) + Sync),
) -> Result<Outcome<Identification>> {
    if spec.noise.to_estimate() {
        // Measured data without a known sensor bound: estimate it, then identify with it
        // (growing it by the margin while the stage-3 method still finds the data inconsistent).
        return Ok(
            match identify_estimated(spec, &data, truth, progress, None)? {
                BelowBar::Identified(outcome) => outcome,
                // Without a bar there is none to be above; kept as what it proves.
                BelowBar::Above(AboveBar { detail, .. }) => {
                    Outcome::Falsified(Falsification::new(crate::error::Stage::Linear, 0, detail))
                }
            },
        );
    }
    let (layout, training, search) = match searched(spec, &mut data, progress, false)? {
        Outcome::Consistent(x) => x,
        Outcome::Falsified(f) => return Ok(Outcome::Falsified(f)),
    };
    let delta = spec.noise.delta()?;
    let model = &spec.model;
    let method = &spec.method;
    let screened_by = search
        .screened
        .then(|| screen_of(method).map(|m| m.eiv))
        .flatten();
    let (kept, mut summary) = kept_cells(model, &layout, &training, search)?;
    summary.screened_by = screened_by;
    let truth_of = |n: &str| truth.iter().find(|(k, _)| k == n).map(|(_, v)| *v);
    let (parameters, gnames) = hulls(&layout, &kept, &truth_of);
    let (representative, truth_in_set) = representative_cell(&layout, &kept, &gnames, &truth_of);
    let (inner, equations, inner_violations) =
        representative_artifacts(model, &layout, method, &training, &kept[representative])?;
    let mut set = ModelSet {
        name: spec.name.clone().unwrap_or_else(|| "smid".into()),
        model: model.duplicate(),
        method: method.clone(),
        delta,
        bound_source: if spec.noise.estimated() {
            BoundSource::Estimated
        } else {
            BoundSource::Given
        },
        dims: layout.dims.clone(),
        cells: kept,
        parameters,
        search: summary,
        training,
        simulation_member: None,
        resolved: std::sync::OnceLock::from(layout.clone()),
    };
    let member_start = std::time::Instant::now();
    set.simulation_member = crate::members::simulation_member(&set, &method.member.check()?)?;
    log::debug!(target: "smid::members", "member search: {:.2} s", member_start.elapsed().as_secs_f64());
    let snr_db = first_record_snr_db(&data, delta);
    Ok(Outcome::Consistent(Identification {
        name: set.name.clone(),
        delta_eta: delta,
        snr_db,
        model: set,
        representative,
        inner,
        equations,
        data,
        truth_in_nonlinearity_set: truth_in_set,
        inner_violations,
    }))
}

/// The cells the search kept, in its order: each decided leaf's set, and each leaf left
/// undecided with its stage-1 set and `θ` unbounded; and the search's summary, with the
/// undecided leaves listed.
fn kept_cells(
    model: &ModelSpec,
    layout: &Layout,
    training: &Training,
    search: cells::Search<CellSet>,
) -> Result<(Vec<CellSet>, SearchSummary)> {
    let mut summary = SearchSummary {
        evaluated: search.evaluated,
        discarded: search.discarded,
        budget_stopped: search.budget_stopped,
        refined: search.refined,
        unbounded: Vec::new(),
        screened_by: None,
    };
    // A leaf left undecided when the refinement budget was spent keeps its stage-1 set (the
    // bisected parameters stay bounded) with θ unbounded, and the summary says which and why.
    let mut kept = Vec::new();
    for leaf in search.leaves {
        match leaf.value {
            Some(c) => kept.push(c),
            None => {
                let (cause, detail) = leaf
                    .cause
                    .unwrap_or((UndecidedCause::Unbounded, String::new()));
                summary.unbounded.push(UnboundedCell {
                    cell: fmt_cell(layout, &leaf.cell),
                    cause,
                    detail,
                });
                // A cell whose steady-state points bound no nonlinearity (left undecided for
                // it) keeps every one of its parameters unbounded; the other cells still
                // report theirs.
                let nonlinearity = match stage1(model, layout, training.steady.as_ref(), &leaf.cell)
                {
                    Ok(set) => set,
                    Err(SmidError::Unbounded { .. }) => Box::new(UnboundedSet {
                        names: crate::registry::parameter_names(&model.nonlinearity_tag()),
                    }),
                    Err(e) => return Err(e),
                };
                kept.push(CellSet {
                    nonlinearity,
                    theta: vec![Interval::entire(); layout.theta_names.len()],
                    unsettled: None,
                    cell: leaf.cell,
                });
            }
        }
    }
    Ok((kept, summary))
}

/// The parameters' hulls over the cells `kept`, in report order (nonlinearity, `θ`, bisected
/// parameters), each with its truth from `truth_of`; and the nonlinearity's parameter names.
fn hulls(
    layout: &Layout,
    kept: &[CellSet],
    truth_of: &dyn Fn(&str) -> Option<f64>,
) -> (Vec<ParamResult>, Vec<String>) {
    // Hulls over the cells, in report order: nonlinearity, θ, ψ.
    let mut parameters: Vec<ParamResult> = Vec::new();
    // Each cell's nonlinearity bounds, read once. The names come from a cell with a set of
    // its own (an undecided cell's [`UnboundedSet`] names them from the registry, which a
    // plugin registered without an example leaves empty); the hull is taken by name.
    let bounds: Vec<Vec<crate::nonlinearity::ParameterBound>> =
        kept.iter().map(|c| c.nonlinearity.parameters()).collect();
    let gnames: Vec<String> = bounds
        .iter()
        .find(|b| b.iter().any(|b| b.interval.is_finite()))
        .unwrap_or(&bounds[0])
        .iter()
        .map(|b| b.name.clone())
        .collect();
    for name in &gnames {
        let h = hull(bounds.iter().map(|c| {
            c.iter()
                .find(|b| &b.name == name)
                .map_or(Interval::entire(), |b| b.interval)
        }));
        parameters.push(ParamResult::new(name, h, truth_of(name)));
    }
    for (k, name) in layout.theta_names.iter().enumerate() {
        let h = hull(kept.iter().map(|c| c.theta[k]));
        parameters.push(ParamResult::new(name, h, truth_of(name)));
    }
    for (k, d) in layout.dims.iter().enumerate() {
        if layout.nonlinearity_cells.contains(&k) {
            continue; // reported above, from the sets (which are these cells)
        }
        let h = hull(kept.iter().map(|c| c.cell[k]));
        parameters.push(ParamResult::new(&d.name, h, truth_of(&d.name)));
    }
    (parameters, gnames)
}

/// The cell whose artifacts are reported: the first bounded cell holding the true bisected
/// parameters (when known), else the first holding them, else the first bounded one; and
/// whether some cell holding them holds the true nonlinearity parameters (named `gnames`).
fn representative_cell(
    layout: &Layout,
    kept: &[CellSet],
    gnames: &[String],
    truth_of: &dyn Fn(&str) -> Option<f64>,
) -> (usize, Option<bool>) {
    // The cell holding the true ψ (when known) is the representative.
    let psi_truth: Option<Vec<f64>> = layout.dims.iter().map(|d| truth_of(&d.name)).collect();
    let gamma_truth: Option<Vec<f64>> = gnames.iter().map(|n| truth_of(n)).collect();
    let holds_psi = |c: &CellSet| {
        psi_truth
            .as_ref()
            .map(|t| c.cell.iter().zip(t).all(|(i, v)| i.contains(*v)))
            .unwrap_or(true)
    };
    let representative = kept
        .iter()
        .position(|c| c.bounded() && holds_psi(c))
        .or_else(|| kept.iter().position(&holds_psi))
        .or_else(|| kept.iter().position(|c| c.bounded()))
        .unwrap_or(0);
    let truth_in_set = match (&gamma_truth, &psi_truth) {
        (Some(g), _) => Some(
            kept.iter()
                .any(|c| holds_psi(c) && c.nonlinearity.contains(g)),
        ),
        _ => None,
    };
    (representative, truth_in_set)
}

/// The artifacts of the representative cell `rep`: its stage-2 inner bounds on the first
/// training record, the times of its stage-3 equations, and how many true inner samples fall
/// outside their bounds (when the truth is known).
fn representative_artifacts(
    model: &ModelSpec,
    layout: &Layout,
    method: &crate::spec::MethodSpec,
    training: &Training,
    rep: &CellSet,
) -> Result<(Vec<InnerBound>, Vec<usize>, Option<usize>)> {
    let sig = stage2(
        model,
        layout,
        rep.nonlinearity.as_ref(),
        &rep.cell,
        &training.records,
    )?;
    // The equations stage 3 used (every method uses every usable one): listed, not re-solved.
    // Samples of two-sided preimage with a sign decided: every pattern uses the same ones.
    let listed = StageSignals {
        output: sig.output.iter().map(|b| b.with_sign(true)).collect(),
        ..sig.clone()
    };
    let equations = eiv_problem(model, layout, method, &listed, None).equation_times();
    let first_len = training.records[0].y.len();
    // The inner signal: the nonlinearity's input (Wiener) or output (Hammerstein).
    let inner: Vec<InnerBound> = match model.structure {
        Structure::Wiener => sig.output[..first_len].to_vec(),
        Structure::Hammerstein => {
            let blocks = BlockSets::new(model, layout, &rep.cell)?;
            let (input_side, _) = blocks.sides(model.structure, rep.nonlinearity.as_ref());
            chain::forward(&input_side, &training.records[0].u)?
        }
    };
    let inner_violations = training.records[0].x.as_ref().map(|x| {
        x.iter()
            .zip(&inner)
            .filter(|(v, b)| b.interval.is_finite() && !b.contains(**v))
            .count()
    });
    Ok((inner, equations, inner_violations))
}

/// Signal-to-noise ratio of the first record of `data` in dB (see [`Identification::snr_db`]).
fn first_record_snr_db(data: &ExperimentData, delta: f64) -> f64 {
    match data.records.first() {
        Some(Record {
            w: Some(w),
            noise: Some(n),
            ..
        }) => noise::snr_db(w, n),
        Some(r) => {
            // Measured data: signal power against the power of uniform noise in [-Δη, Δη].
            let ps: f64 = r.y.iter().map(|v| v * v).sum();
            10.0 * (ps / (r.y.len() as f64 * delta * delta / 3.0)).log10()
        }
        None => f64::NAN,
    }
}

/// The steady-state points as stage 1 reads them: the overshoot allowance α of eqs 14-15 set
/// as `method.alpha` says (`bias`: from each point's step and the filter-design step; `design`:
/// from the overshoot the Appendix search measured; `zero`: none), then checked.
pub fn with_alpha(
    spec: &Spec,
    filter: Option<&crate::experiment::FilterDesign>,
    steady: &mut crate::nonlinearity::SteadyStateData,
) -> Result<()> {
    let step = filter
        .and_then(|f| f.step)
        .unwrap_or(spec.experiment.filter.step);
    match spec.method.alpha {
        AlphaSpec::Bias => experiment::apply_alpha(steady, step),
        AlphaSpec::Design => match filter.and_then(|f| f.overshoot) {
            Some(d) => experiment::apply_design_alpha(steady, d, step),
            None => {
                return Err(SmidError::invalid(
                    "method.alpha",
                    "`design` needs the filter pole from the Appendix search on the plant; with a given pole or measured data choose `bias` or `zero`",
                ))
            }
        },
        AlphaSpec::Zero => {}
    }
    steady.validate()
}

/// The data prepared for the stages (α applied to the steady-state points, every record and
/// effect checked) and the branch and bound over the bisected parameters at the spec's
/// declared bound. With `first_value` the search stops at the first cell with bounds
/// ([`cells::search_consistent`]): a verdict, not the set.
#[allow(clippy::type_complexity)]
fn searched(
    spec: &Spec,
    data: &mut ExperimentData,
    progress: &(dyn Fn(&cells::Progress) + Sync),
    first_value: bool,
) -> Result<Outcome<(Layout, Training, cells::Search<CellSet>)>> {
    let delta = spec.noise.delta()?;
    let layout = spec.model.layout()?;
    if let Some(steady) = data.steady.as_mut() {
        with_alpha(spec, data.filter.as_ref(), steady)?;
    }
    for r in &data.records {
        r.validate()?;
    }
    if data.steady.is_some() {
        if let Some(e) = spec
            .model
            .effects
            .iter()
            .find(|e| !e.steady_state_usable(&spec.model.prior))
        {
            return Err(SmidError::invalid(
                "model.effects",
                super::stages::not_at_rest(e.as_ref(), "steady-state data"),
            ));
        }
    }
    if data.records.is_empty() {
        return Err(SmidError::invalid(
            "plant",
            "no dynamic record to identify from",
        ));
    }
    let training = Training {
        steady: data.steady.clone(),
        records: data.records.clone(),
    };
    let model = &spec.model;
    let method = &spec.method;
    let prior: Vec<Interval> = layout.dims.iter().map(|d| d.prior).collect();
    let scale = data_scale(data);
    let resolution = resolution(
        model,
        &layout,
        method.cells.nonlinearity_halvings,
        delta,
        &scale,
    );
    let test = |cell: &[Interval]| test_cell(model, &layout, method, &training, cell);
    // Only the paper's single cell locates its first offending sample: a verdict
    // (`first_value`) needs none, and with bisected parameters the search reports the latest
    // finding among its cells, mostly the cheap test's (which does not locate), so locating
    // each cell stage 3 discards cost about `log2 N` LPs for a sample rarely reported.
    let locate = !first_value && layout.dims.is_empty();
    let eval = |cell: &[Interval]| evaluate_cell(model, &layout, method, &training, cell, locate);
    let budget = Budget {
        resolution,
        depth: method.cells.depth,
        max_cells: method.cells.max_cells,
        max_leaves: method.cells.max_leaves,
    };
    let search = if first_value {
        cells::search_consistent(&prior, budget, &test, &eval)?
    } else {
        match screen_of(method).filter(|_| !layout.dims.is_empty()) {
            None => cells::search(&prior, budget, &test, &eval, progress)?,
            Some(cheap) => {
                let screen = |cell: &[Interval]| {
                    evaluate_cell(model, &layout, &cheap, &training, cell, locate)
                };
                cells::search_screened(&prior, budget, &test, &screen, &eval, progress)?
            }
        }
    };
    Ok(search.map(|s| (layout, training, s)))
}

/// The screen of the branch and bound's finish for `method`: the same options with the
/// stage-3 method its chosen one starts from, through every start (registered defaults, the same equations: band
/// samples as the chosen method uses them), or `None` for a method that starts from the
/// problem alone. A cell the start leaves unbounded the chosen method leaves unbounded too
/// (its start fails there), and its bounds over a cell lie inside the start's.
pub(super) fn screen_of(method: &MethodSpec) -> Option<MethodSpec> {
    // The root of the chain of starts: every method on it starts from the one below. Options
    // the method refuses give no screen here; the method itself reports them on the first cell.
    let mut start = crate::stage3::configured(method.eiv, &method.options)
        .ok()?
        .start()?;
    while let Some(below) = crate::stage3::method(start).start() {
        start = below;
    }
    Some(MethodSpec {
        eiv: start,
        options: serde_json::Map::new(),
        band_samples: Some(method.use_band_samples()),
        ..method.clone()
    })
}

/// Whether the spec's stage-3 method finds the data consistent at the spec's declared bound,
/// by the identification's own search stopped at the first cell with bounds: `Falsified`
/// exactly when [`identify`] would return it; an error may be reported where `identify` would
/// have given an answer (and the other way round), which the noise-bound bracket treats alike.
pub fn consistent_by_method(spec: &Spec, mut data: ExperimentData) -> Result<Outcome<()>> {
    Ok(searched(spec, &mut data, &|_| {}, true)?.map(|_| ()))
}

pub(super) fn hull(it: impl IntoIterator<Item = Interval>) -> Interval {
    it.into_iter()
        .reduce(|a, b| Interval::new(a.lo.min(b.lo), a.hi.max(b.hi)))
        .unwrap_or(Interval::new(f64::NAN, f64::NAN))
}

/// `name ∈ [lo, hi], ...` of a cell.
pub fn fmt_cell(layout: &Layout, cell: &[Interval]) -> String {
    layout
        .dims
        .iter()
        .zip(cell)
        .map(|(d, i)| format!("{} ∈ [{:.4e}, {:.4e}]", d.name, i.lo, i.hi))
        .collect::<Vec<_>>()
        .join(", ")
}
