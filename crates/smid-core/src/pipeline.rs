//! The identification pipeline of the paper, for any nonlinearity plugin, structure and
//! effects: acquire data (run the experiments on a [`Plant`], or take measured records), then
//! for each cell of the bisected parameters (one cell when there are none) stage 1
//! (nonlinearity parameter set from steady-state data, Section 3), stage 2 (inner-signal bounds,
//! Section 4: inversion for Wiener, propagation for Hammerstein, of outputs corrected by the
//! sensor terms), stage 3 (linear parameters and equation terms, Section 5,
//! [`crate::stage3`]). The cells are searched by [`crate::cells`]; the result is a
//! [`ModelSet`] with the run's artifacts for reports.
//!
//! The stage functions ([`stage1`], [`stage2`], [`stage3`]) are public: validation runs the same
//! stages on fresh records with the identified sets as constraints.
use crate::cells::{self, Budget, Verdict};
use crate::chain::{self, Side};
use crate::effect::{self, DataScale, Signals};
use crate::error::{Result, SmidError};
use crate::experiment::{self, FilterDesign, SteadyRecord};
use crate::interval::Interval;
use crate::inversion::InnerBound;
use crate::model::{BoundSource, CellSet, Layout, ModelSet, SearchSummary, Training};
use crate::noise;
use crate::nonlinearity::{NonlinearitySet, SteadyStateData, Structure};
use crate::plant::{Plant, SimulatedPlant};
use crate::spec::{AlphaSpec, MethodSpec, ModelSpec, Spec};
use crate::stage3::{EivProblem, EivResult, Regressor};
use rand::SeedableRng;
use std::path::Path;

pub use crate::model::{ParamResult, Record};

/// Everything measured (or simulated) for one identification.
#[derive(Debug, Clone, Default)]
pub struct ExperimentData {
    /// Steady-state points (absent for records without a designed experiment).
    pub steady: Option<SteadyStateData>,
    /// The whole noise-free square-wave record, when simulated.
    pub steady_record: Option<SteadyRecord>,
    /// Dynamic records (the training records).
    pub records: Vec<Record>,
    pub filter: Option<FilterDesign>,
}

/// Result of a whole identification: the model set and the run's artifacts.
#[derive(Debug)]
pub struct Identification {
    pub name: String,
    pub delta_eta: f64,
    pub snr_db: f64,
    /// The identified model set (what `result.json` carries as `model`).
    pub model: ModelSet,
    /// The cell whose artifacts are reported (the one holding the truth when known).
    pub representative: usize,
    /// Stage-2 bounds of the representative cell, first record.
    pub inner: Vec<InnerBound>,
    /// Time indices (in the concatenated records) of the stage-3 equations of that cell.
    pub equations: Vec<usize>,
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

/// The built-in simulator of a spec, if the spec's plant is one.
pub fn builtin_plant(spec: &Spec) -> Option<SimulatedPlant<'_>> {
    spec.plant.simulator.as_ref().map(SimulatedPlant::from_spec)
}

/// Run `plant` from rest on `u`; an output of the wrong length or a non-finite sample is an
/// error naming the plant (and the sample).
pub fn run_checked(plant: &mut dyn Plant, u: &[f64]) -> Result<Vec<f64>> {
    let w = plant.run(u)?;
    if w.len() != u.len() {
        return Err(SmidError::Plant {
            plant: plant.name(),
            message: format!("returned {} samples for {} inputs", w.len(), u.len()),
        });
    }
    if let Some(t) = w.iter().position(|v| !v.is_finite()) {
        return Err(SmidError::Plant {
            plant: plant.name(),
            message: format!("non-finite output at sample {t}"),
        });
    }
    Ok(w)
}

/// One dynamic record from `plant`: the spec's PRBS (length `n`) drawn with `rng`, the plant's
/// noise-free output, bounded noise of the spec's amplitude.
pub fn dynamic_record(
    spec: &Spec,
    plant: &mut dyn Plant,
    rng: &mut rand_chacha::ChaCha8Rng,
    n: usize,
    name: String,
) -> Result<Record> {
    let delta = spec.noise.delta()?;
    let added = spec.noise.simulated()?;
    let mut o = spec.experiment.dynamic_options();
    o.length = n;
    let u = experiment::dynamic_input(&o, rng)?;
    let w = run_checked(plant, &u)?;
    let eta = noise::uniform(u.len(), added, rng);
    let y = w.iter().zip(&eta).map(|(a, b)| a + b).collect();
    let x = plant.inner(&u);
    Ok(Record {
        name,
        dy: vec![delta; u.len()],
        u,
        y,
        dt: 1.0,
        w: Some(w),
        x,
        noise: Some(eta),
    })
}

/// A fresh dynamic record of the spec's plant with another seed (for validation): the spec's
/// PRBS and noise, drawn from `seed`.
pub fn fresh_record(spec: &Spec, plant: &mut dyn Plant, seed: u64, n: usize) -> Result<Record> {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let name = format!("{} (seed {seed})", plant.name());
    dynamic_record(spec, plant, &mut rng, n, name)
}

/// Run the spec's experiments on `plant` (noise-free plant output, bounded noise added here).
pub fn simulate_experiments(spec: &Spec, plant: &mut dyn Plant) -> Result<ExperimentData> {
    let delta = spec.noise.delta()?;
    let added = spec.noise.simulated()?;
    let ex = &spec.experiment;
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(ex.seed);
    if ex.steady_state.skip {
        let name = format!("{} (seed {})", plant.name(), ex.seed);
        let record = dynamic_record(spec, plant, &mut rng, ex.dynamic.length, name)?;
        return Ok(ExperimentData {
            steady: None,
            steady_record: None,
            records: vec![record],
            filter: None,
        });
    }
    let filter = match ex.filter.pole {
        Some(a) => FilterDesign::given(a),
        None => experiment::design_filter_pole(plant, &ex.filter.bisection())?,
    };
    let rec = experiment::steady_state_experiment(plant, filter.pole, &ex.steady_options())?;
    let steady = experiment::noisy_steady_state(&rec, delta, added, &mut rng);
    let name = format!("{} (seed {})", plant.name(), ex.seed);
    let record = dynamic_record(spec, plant, &mut rng, ex.dynamic.length, name)?;
    Ok(ExperimentData {
        steady: Some(steady),
        steady_record: Some(rec),
        records: vec![record],
        filter: Some(filter),
    })
}

/// The scale of the training data: largest `|y|`, longest record (steady-state record
/// included), for default priors and the resolution of bisected parameters.
pub fn data_scale(data: &ExperimentData) -> DataScale {
    let mut y_max = 0.0f64;
    let mut length = 0usize;
    let (mut y_range, mut u_range) = (
        (f64::INFINITY, f64::NEG_INFINITY),
        (f64::INFINITY, f64::NEG_INFINITY),
    );
    let widen = |r: &mut (f64, f64), v: f64| {
        r.0 = r.0.min(v);
        r.1 = r.1.max(v);
    };
    for r in &data.records {
        y_max = y_max.max(r.y.iter().fold(0.0, |m, v| m.max(v.abs())));
        length = length.max(r.y.len());
        r.y.iter().for_each(|&v| widen(&mut y_range, v));
        r.u.iter().for_each(|&v| widen(&mut u_range, v));
    }
    if let Some(s) = &data.steady {
        y_max = y_max.max(s.points.iter().fold(0.0, |m, p| m.max(p.y.abs())));
        length = length.max(
            s.points
                .iter()
                .filter_map(|p| p.time)
                .max()
                .map_or(0, |t| t + 1),
        );
    }
    let fix = |r: (f64, f64)| if r.0 <= r.1 { r } else { (0.0, 0.0) };
    DataScale {
        y_max: if y_max > 0.0 { y_max } else { 1.0 },
        length: length.max(1),
        y_range: fix(y_range),
        u_range: fix(u_range),
    }
}

/// Stage 1 for one cell: the nonlinearity's feasible set from the steady-state points with the
/// outputs corrected by the sensor terms over the cell (`ȳ - s`, `s` an interval: its centre
/// moves `ȳ`, its radius widens `Δη̄`).
pub fn stage1(
    model: &ModelSpec,
    layout: &Layout,
    steady: Option<&SteadyStateData>,
    cell: &[Interval],
) -> Result<Box<dyn NonlinearitySet>> {
    let range = layout.nonlinearity_cells.clone();
    if !range.is_empty() {
        if steady.is_some() {
            return Err(SmidError::invalid(
                "model.prior",
                "a prior box for the nonlinearity's parameters together with steady-state data is not supported yet: give one or the other",
            ));
        }
        return model.nonlinearity.set_from_box(&cell[range]);
    }
    let steady = match steady {
        Some(s) => s,
        // A plugin without parameters needs no stage 1.
        None if crate::registry::parameter_names(&model.nonlinearity_tag()).is_empty() => {
            return model.nonlinearity.set_from_box(&[])
        }
        None => {
            return Err(SmidError::invalid(
                "plant",
                format!(
                    "stage 1 needs steady-state data (the designed experiment of Section 3); without it, give the nonlinearity's parameters a prior box (`model.prior`: {})",
                    crate::registry::parameter_names(&model.nonlinearity_tag()).join(", ")
                ),
            ))
        }
    };
    if model.effects.is_empty() && !model.has_blocks() {
        return model.nonlinearity.bound_steady_state(steady);
    }
    let slices = layout.effect_slices(cell);
    let blocks = BlockSets::new(model, layout, cell)?;
    let outputs = blocks.refs(Side::Output);
    let inputs = blocks.refs(Side::Input);
    let mut data = steady.clone();
    for p in &mut data.points {
        let s = effect::sensor_sum(&model.effects, &slices, p.time)?;
        p.y -= s.center();
        p.dy += s.radius();
        if !outputs.is_empty() {
            (p.y, p.dy) = chain::backward_steady(&outputs, p.y, p.dy)?;
        }
        if !inputs.is_empty() {
            // The steady input through the input blocks over their cell: an interval.
            let mut v = Interval::new(p.u - p.du, p.u + p.du);
            for b in &inputs {
                let lo = b.propagate_steady(v.lo)?;
                let hi = b.propagate_steady(v.hi)?;
                if !b.monotone() && v.lo != v.hi {
                    return Err(SmidError::invalid(
                        "model.input",
                        "a steady input reaches a non-monotone input block as an interval: give the nonlinearity's parameters a prior box (`model.prior`)",
                    ));
                }
                v = Interval::new(lo.lo.min(hi.lo), lo.hi.max(hi.hi));
            }
            if v.lo != v.hi && !model.nonlinearity.accepts_input_radius() {
                return Err(SmidError::invalid(
                    "model.input",
                    "steady-state data reach the nonlinearity through input-side blocks whose steady output is uncertain over their cell, and this plugin's stage 1 needs exact inputs: give the nonlinearity's parameters a prior box too (`model.prior`), or identify from records without the steady-state experiment",
                ));
            }
            (p.u, p.du) = chain::centre_radius(v);
            if v.lo == v.hi {
                p.du = 0.0;
            }
            // `rising` stays: the blocks are monotone, so the input reached v̄ from the same side.
        }
    }
    // A point an output block leaves unknown (a clipped saturation) bounds nothing: it is left
    // out of stage 1 (fewer points can only widen the set).
    data.points.retain(|p| p.dy.is_finite());
    model.nonlinearity.bound_steady_state(&data)
}

/// The stage-1 sets of a chain's blocks over one cell (each plugin's set of its prior cell).
pub struct BlockSets {
    sets: Vec<(Side, Box<dyn NonlinearitySet>)>,
}

impl BlockSets {
    /// Every block's set over its slice of `cell`; errors name the block's field.
    pub fn new(model: &ModelSpec, layout: &Layout, cell: &[Interval]) -> Result<BlockSets> {
        let mut sets = Vec::with_capacity(layout.blocks.len());
        for b in &layout.blocks {
            let plugin = match b.side {
                Side::Input => &model.input[b.index],
                Side::Output => &model.output[b.index],
            };
            let set = plugin.set_from_box(&cell[b.cells.clone()]).map_err(|e| match e {
                SmidError::Invalid { field, message } => SmidError::invalid(
                    format!("{}[{}] ({field})", b.side.field(), b.index),
                    message,
                ),
                o => o,
            })?;
            sets.push((b.side, set));
        }
        Ok(BlockSets { sets })
    }
    /// The sets of one side, in signal order.
    pub fn refs(&self, side: Side) -> Vec<&dyn NonlinearitySet> {
        self.sets
            .iter()
            .filter(|(s, _)| *s == side)
            .map(|(_, b)| b.as_ref())
            .collect()
    }
    /// The whole input side (the input blocks, then `set` when Hammerstein) and output side
    /// (`set` when Wiener, then the output blocks), in signal order.
    pub fn sides<'a>(
        &'a self,
        structure: Structure,
        set: &'a dyn NonlinearitySet,
    ) -> (Vec<&'a dyn NonlinearitySet>, Vec<&'a dyn NonlinearitySet>) {
        let mut input = self.refs(Side::Input);
        let mut output = self.refs(Side::Output);
        match structure {
            Structure::Hammerstein => input.push(set),
            Structure::Wiener => output.insert(0, set),
        }
        (input, output)
    }
}

/// The signals stage 3 sees: records concatenated, separated by gaps of unknown samples so no
/// equation spans two records.
#[derive(Debug, Clone)]
pub struct StageSignals {
    pub output: Vec<InnerBound>,
    pub input: Vec<Interval>,
    pub extra: Vec<Regressor>,
    /// Index of each record's first sample in the concatenation.
    pub starts: Vec<usize>,
}

impl StageSignals {
    /// `(record, sample)` of a concatenated index.
    pub fn locate(&self, i: usize) -> (usize, usize) {
        let r = self.starts.iter().rposition(|&s| s <= i).unwrap_or(0);
        (r, i - self.starts[r])
    }
}

/// Stage 2 for one cell over records: the outputs corrected by the sensor terms (`y - s`, the
/// interval `s` widening the noise bound), inverted (Wiener) or taken as the linear block's
/// output (Hammerstein); the input as is (Wiener) or propagated through the nonlinearity
/// (Hammerstein); delayed by `nk`; the equation terms' regressors.
pub fn stage2(
    model: &ModelSpec,
    layout: &Layout,
    set: &dyn NonlinearitySet,
    cell: &[Interval],
    records: &[Record],
) -> Result<StageSignals> {
    let o = layout.orders;
    let gap = o.na + o.nb + o.nk + 1;
    let slices = layout.effect_slices(cell);
    let blocks = BlockSets::new(model, layout, cell)?;
    let (input_side, output_side) = blocks.sides(model.structure, set);
    let mut out = StageSignals {
        output: Vec::new(),
        input: Vec::new(),
        extra: layout
            .extra_names
            .iter()
            .map(|n| Regressor {
                name: n.clone(),
                values: Vec::new(),
            })
            .collect(),
        starts: Vec::new(),
    };
    for (r, rec) in records.iter().enumerate() {
        rec.validate()?;
        if r > 0 {
            out.output
                .extend(std::iter::repeat(InnerBound::unknown()).take(gap));
            out.input
                .extend(std::iter::repeat(Interval::entire()).take(gap));
            for e in &mut out.extra {
                e.values
                    .extend(std::iter::repeat(Interval::entire()).take(gap));
            }
        }
        out.starts.push(out.output.len());
        let n = rec.y.len();
        let mut yc = rec.y.clone();
        let mut dy = rec.dy.clone();
        if !model.effects.is_empty() {
            for t in 0..n {
                let s = effect::sensor_sum(&model.effects, &slices, Some(t))?;
                yc[t] -= s.center();
                dy[t] += s.radius();
            }
        }
        // Wiener: the nonlinearity is the first output block; Hammerstein: the last input
        // block (with no other block, the paper's calls exactly).
        let output = chain::backward(&output_side, &yc, &dy)?;
        let input: Vec<Interval> = chain::forward(&input_side, &rec.u)?
            .iter()
            .map(|b| b.interval)
            .collect();
        out.output.extend(output);
        out.input.extend((0..n).map(|t| {
            if t >= o.nk {
                input[t - o.nk]
            } else {
                Interval::entire()
            }
        }));
        let xs: Vec<Interval> = out.output[out.output.len() - n..]
            .iter()
            .map(|b| b.interval)
            .collect();
        let cols = effect::regressors(
            &model.effects,
            &Signals {
                u: &rec.u,
                dt: rec.dt,
                x: Some(&xs),
            },
        );
        for (e, c) in out.extra.iter_mut().zip(cols) {
            e.values.extend(c.values);
        }
    }
    Ok(out)
}

/// The stage-3 problem of stage-2 signals, with an optional prior box on `θ`.
fn eiv_problem<'a>(
    model: &ModelSpec,
    layout: &Layout,
    method: &MethodSpec,
    sig: &'a StageSignals,
    prior: Option<&'a [Interval]>,
) -> EivProblem<'a> {
    EivProblem {
        na: layout.orders.na,
        nb: layout.orders.nb,
        fixed: layout.fixed.clone(),
        unit_gain: model.unit_gain,
        output: &sig.output,
        input: &sig.input,
        extra: &sig.extra,
        prior,
        use_band_samples: method.use_band_samples(),
    }
}

/// Stage 3 on stage-2 signals, with an optional prior box on `θ`. An inconsistency names the
/// sample in the concatenation (see [`relabel`]).
pub fn stage3(
    model: &ModelSpec,
    layout: &Layout,
    method: &MethodSpec,
    sig: &StageSignals,
    prior: Option<&[Interval]>,
) -> Result<EivResult> {
    let problem = eiv_problem(model, layout, method, sig, prior);
    match crate::stage3::solve(method.eiv, &problem) {
        // Solver trouble: another method's outer bound is as guaranteed.
        Err(SmidError::Solver(first)) => {
            let other = if method.eiv == crate::stage3::EivMethod::Shared {
                crate::stage3::EivMethod::Classical
            } else {
                crate::stage3::EivMethod::Shared
            };
            crate::stage3::solve(other, &problem).map_err(|e| match e {
                SmidError::Solver(second) => SmidError::Solver(format!(
                    "{first}; with the {} method too: {second}",
                    other.name()
                )),
                e => e,
            })
        }
        r => r,
    }
}

/// A stage-3 inconsistency with its sample as the index within its record (the record named
/// in the detail when there are several).
pub fn relabel(e: SmidError, sig: &StageSignals) -> SmidError {
    match e {
        SmidError::Inconsistent {
            stage,
            sample,
            detail,
        } => {
            let (r, t) = sig.locate(sample);
            let detail = detail.replace(&format!("t = {sample}"), &format!("sample {t}"));
            SmidError::Inconsistent {
                stage,
                sample: t,
                detail: if sig.starts.len() > 1 {
                    format!("training record {r}: {detail}")
                } else {
                    detail
                },
            }
        }
        other => other,
    }
}

/// Stages 1-3 over one cell: `Infeasible` when a stage proves the cell inconsistent,
/// `Undecided` when stage 3 leaves a parameter unbounded over a bisected cell. Without bisected
/// parameters every error is returned as is (the paper's three stages).
pub fn evaluate_cell(
    model: &ModelSpec,
    layout: &Layout,
    method: &MethodSpec,
    training: &Training,
    cell: &[Interval],
) -> Result<Verdict<CellSet>> {
    let bisected = !layout.dims.is_empty();
    let outcome = (|| {
        let set = stage1(model, layout, training.steady.as_ref(), cell)?;
        let sig = stage2(model, layout, set.as_ref(), cell, &training.records)?;
        let r = stage3(model, layout, method, &sig, None).map_err(|e| relabel(e, &sig))?;
        Ok(CellSet {
            cell: cell.to_vec(),
            nonlinearity: set,
            theta: r.bounds,
        })
    })();
    match outcome {
        Ok(c) => Ok(Verdict::Feasible(c)),
        Err(e @ SmidError::Inconsistent { .. }) if bisected => Ok(Verdict::Infeasible(e)),
        Err(SmidError::Unbounded { .. }) if bisected => Ok(Verdict::Undecided),
        Err(e) => Err(e),
    }
}

/// The branch and bound's cheap test of a cell: stages 1 and 2, then whether the classical
/// outer set of stage 3 is empty (a proof of inconsistency) — no bounds computed.
pub fn test_cell(
    model: &ModelSpec,
    layout: &Layout,
    method: &MethodSpec,
    training: &Training,
    cell: &[Interval],
) -> Result<Verdict<()>> {
    let outcome = (|| {
        let set = stage1(model, layout, training.steady.as_ref(), cell)?;
        let sig = stage2(model, layout, set.as_ref(), cell, &training.records)?;
        let o = layout.orders;
        let problem = EivProblem {
            na: o.na,
            nb: o.nb,
            fixed: layout.fixed.clone(),
            unit_gain: model.unit_gain,
            output: &sig.output,
            input: &sig.input,
            extra: &sig.extra,
            prior: None,
            use_band_samples: method.use_band_samples(),
        };
        if crate::stage3::feasible(&problem)? {
            Ok(())
        } else {
            Err(SmidError::Inconsistent {
                stage: crate::error::Stage::Linear,
                sample: sig.output.len(),
                detail: "no θ fits the equations of this cell (classical outer set empty)".into(),
            })
        }
    })();
    match outcome {
        Ok(()) => Ok(Verdict::Feasible(())),
        Err(e @ SmidError::Inconsistent { .. }) => Ok(Verdict::Infeasible(e)),
        // Nothing proven: the cell is kept (a solver failure never discards one).
        Err(SmidError::Unbounded { .. }) | Err(SmidError::Solver(_)) => Ok(Verdict::Undecided),
        Err(e) => Err(e),
    }
}

/// Load measured data named by the spec (`plant.data`), paths relative to `base`.
pub fn load_data(spec: &Spec, base: &Path) -> Result<ExperimentData> {
    let d =
        spec.plant.data.as_ref().ok_or_else(|| {
            SmidError::invalid("plant.data", "the spec's plant is not measured data")
        })?;
    // An estimated bound is set after loading (see `estimate_bound`); 1 stands in until then.
    let delta = match spec.noise.delta() {
        Err(_) if spec.noise.estimated() => 1.0,
        d => d?,
    };
    let steady = match &d.steady_state {
        None => None,
        Some(ss) => {
            let (us, ys) =
                crate::data::read_columns(&base.join(&ss.file), &ss.u, &ss.y, ss.part.as_deref())?;
            if us.len() < 4 {
                return Err(SmidError::Data {
                    file: base.join(&ss.file),
                    location: format!("column `{}`", ss.u),
                    message: format!(
                        "too short: {} steady-state samples, need at least 4 (two amplitudes per branch)",
                        us.len()
                    ),
                });
            }
            let times: Option<Vec<usize>> = match &ss.t {
                None => None,
                Some(tc) => {
                    let file = base.join(&ss.file);
                    let t = crate::data::read_table(&file, &[tc], ss.part.as_deref())?
                        .pop()
                        .expect("one column");
                    Some(crate::data::sample_indices(&file, tc, &t, d.dt.unwrap_or(1.0))?)
                }
            };
            Some(SteadyStateData {
                points: us
                    .iter()
                    .zip(&ys)
                    .enumerate()
                    .map(|(i, (&u, &y))| crate::nonlinearity::SteadyPoint {
                        u,
                        y,
                        dy: delta,
                        alpha: 0.0,
                        rising: u > 0.0,
                        index: i,
                        time: times.as_ref().map(|t| t[i]),
                        step: None,
                        du: 0.0,
                    })
                    .collect(),
            })
        }
    };
    let dt = d.dt.unwrap_or(1.0);
    let mut records = Vec::new();
    for c in d.dynamic.items() {
        records.push(crate::data::read_record(base, c, delta, dt)?);
    }
    let o = spec.model.layout()?.orders;
    let need = 2 * (o.na + o.nb + o.nk + 2);
    for (rec, c) in records.iter().zip(d.dynamic.items()) {
        if rec.u.len() < need {
            return Err(SmidError::Data {
                file: base.join(&c.file),
                location: format!("column `{}`", c.u),
                message: format!(
                    "too short: {} dynamic samples, need at least {need} for na = {}, nb = {}, nk = {}",
                    rec.u.len(),
                    o.na,
                    o.nb,
                    o.nk
                ),
            });
        }
    }
    let filter = spec.experiment.filter.pole.map(FilterDesign::given);
    Ok(ExperimentData {
        steady,
        steady_record: None,
        records,
        filter,
    })
}

/// The spec with the noise bound `d` (an estimate keeps its margin, so reports say so).
pub fn with_bound(spec: &Spec, d: f64) -> Spec {
    let mut v = serde_json::to_value(spec).expect("specs serialise");
    v["noise"]["delta"] = serde_json::json!(d);
    v["noise"].as_object_mut().map(|o| o.remove("encoder_bits"));
    serde_json::from_value(v).expect("a serialised spec deserialises")
}

/// The data with every noise bound set to `d`.
pub fn data_with_bound(data: &ExperimentData, d: f64) -> ExperimentData {
    let mut out = data.clone();
    for r in &mut out.records {
        *r = r.with_bound(d);
    }
    if let Some(st) = out.steady.as_mut() {
        for p in &mut st.points {
            p.dy = d;
        }
    }
    out
}

/// Whether the training data are consistent with the model at noise bound `d`, by the
/// branch and bound's cheap test alone (classical outer sets, no bounds computed): `false`
/// proves them inconsistent; `true` proves nothing.
pub fn consistent_at(spec: &Spec, data: &ExperimentData, d: f64) -> Result<bool> {
    let spec = with_bound(spec, d);
    let data = data_with_bound(data, d);
    let layout = spec.model.layout()?;
    let training = Training {
        steady: data.steady.clone(),
        records: data.records.clone(),
    };
    let prior: Vec<Interval> = layout.dims.iter().map(|d| d.prior).collect();
    let scale = data_scale(&data);
    // Coarser than the identification's cells: a test that cannot discard a coarse cell only
    // lowers the estimate, which the identification then raises by the margin if needed.
    let resolution = resolution(
        &spec.model,
        &layout,
        spec.method.cells.nonlinearity_halvings.saturating_sub(2),
        d,
        &scale,
    );
    let test = |c: &[Interval]| test_cell(&spec.model, &layout, &spec.method, &training, c);
    match cells::search(
        &prior,
        Budget {
            resolution,
            depth: spec.method.cells.depth,
            // A consistency test stopped early keeps its cells: it can only say "consistent"
            // too soon, which lowers the estimate (raised again by the margin if needed).
            max_cells: spec.method.cells.max_cells.min(500),
            max_leaves: 500,
        },
        &test,
        &test,
        &|_| {},
    ) {
        Ok(s) => Ok(!s.leaves.is_empty()),
        Err(SmidError::Inconsistent { .. }) => Ok(false),
        Err(e) => Err(e),
    }
}

/// The branch and bound's resolution of each bisected parameter: a nonlinearity's or a
/// block's prior width halved `halvings` times, an effect's own resolution.
fn resolution(
    model: &ModelSpec,
    layout: &Layout,
    halvings: u32,
    delta: f64,
    scale: &DataScale,
) -> Vec<f64> {
    let h = 2f64.powi(halvings as i32);
    let effects: Vec<f64> = model
        .effects
        .iter()
        .flat_map(|e| e.resolution(delta, scale))
        .collect();
    let first_effect = layout.effect_cells.first().map_or(layout.dims.len(), |r| r.start);
    layout.dims[..first_effect]
        .iter()
        .map(|d| (d.prior.hi - d.prior.lo) / h)
        .chain(effects)
        .collect()
}

/// The estimated noise bound of `noise.estimate`: the margin times the smallest bound for
/// which the training data are consistent with the model (doubling from a thousandth of the
/// largest output, then bisection to 2 %; at most 60 tests). That smallest bound is a lower
/// bound of the exact one (the test is an outer relaxation), so the identification at the
/// estimate may still find the data inconsistent: the estimate then grows by the margin again.
pub fn estimate_bound(spec: &Spec, data: &ExperimentData) -> Result<f64> {
    let margin = spec.noise.estimate.unwrap_or(1.1);
    let scale = data_scale(data).y_max;
    let mut hi = 1e-3 * scale;
    let mut lo = 0.0;
    let mut n = 0;
    while !consistent_at(spec, data, hi)? {
        n += 1;
        if n > 40 {
            return Err(SmidError::Inconsistent {
                stage: crate::error::Stage::Linear,
                sample: 0,
                detail: format!("no noise bound up to {hi:.3e} makes the training data consistent"),
            });
        }
        lo = hi;
        hi *= 2.0;
    }
    while hi - lo > 0.02 * hi && n < 60 {
        let mid = 0.5 * (lo + hi);
        if consistent_at(spec, data, mid)? {
            hi = mid;
        } else {
            lo = mid;
        }
        n += 1;
    }
    Ok(margin * hi)
}

/// The true values of `θ` under the model's orders from a true linear block: `a_i`, and
/// `b_j = B[nk + j]` (None when the model cannot represent it: a true coefficient before the
/// delay or beyond the orders).
fn theta_truth(layout: &Layout, lin: &crate::linear::LinearModel) -> Vec<(String, f64)> {
    let o = layout.orders;
    let tiny = |v: f64| v.abs() <= 1e-12;
    if lin.a.len() > o.na && !lin.a[o.na..].iter().all(|&v| tiny(v)) {
        return Vec::new();
    }
    if lin.b.len() > o.nk + o.nb + 1 && !lin.b[o.nk + o.nb + 1..].iter().all(|&v| tiny(v)) {
        return Vec::new();
    }
    if lin.b.iter().take(o.nk).any(|&v| !tiny(v)) {
        return Vec::new();
    }
    let mut t = Vec::new();
    for i in 1..=o.na {
        t.push((format!("a{i}"), lin.a.get(i - 1).copied().unwrap_or(0.0)));
    }
    for j in 0..=o.nb {
        t.push((format!("b{j}"), lin.b.get(o.nk + j).copied().unwrap_or(0.0)));
    }
    t
}

/// Stages 1-3 on acquired data. `truth` holds known true values by parameter name.
pub fn identify(
    spec: &Spec,
    data: ExperimentData,
    truth: &[(String, f64)],
) -> Result<Identification> {
    identify_with(spec, data, truth, &|_| {})
}

/// [`identify`] with a progress callback for the branch and bound over the bisected
/// parameters.
pub fn identify_with(
    spec: &Spec,
    mut data: ExperimentData,
    truth: &[(String, f64)],
    progress: &(dyn Fn(&cells::Progress) + Sync),
) -> Result<Identification> {
    if spec.noise.estimated() && spec.noise.delta.is_none() {
        // Measured data without a known sensor bound: estimate it, then identify with it
        // (growing it by the margin while the stage-3 method still finds the data inconsistent).
        let margin = spec.noise.estimate.unwrap_or(1.1);
        let mut d = estimate_bound(spec, &data)?;
        for _ in 0..10 {
            match identify_with(
                &with_bound(spec, d),
                data_with_bound(&data, d),
                truth,
                progress,
            ) {
                Err(SmidError::Inconsistent { .. }) => d *= margin,
                r => return r,
            }
        }
        return identify_with(
            &with_bound(spec, d),
            data_with_bound(&data, d),
            truth,
            progress,
        );
    }
    let delta = spec.noise.delta()?;
    let layout = spec.model.layout()?;
    if let Some(steady) = data.steady.as_mut() {
        let step = data
            .filter
            .as_ref()
            .and_then(|f| f.step)
            .unwrap_or(spec.experiment.filter.step);
        match spec.method.alpha {
            AlphaSpec::Bias => experiment::apply_alpha(steady, step),
            AlphaSpec::Design => match data.filter.as_ref().and_then(|f| f.overshoot) {
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
        steady.validate()?;
    }
    for r in &data.records {
        r.validate()?;
    }
    if data.steady.is_some() {
        if let Some(e) = spec
            .model
            .effects
            .iter()
            .find(|e| !e.vanishes_at_steady_state())
        {
            return Err(SmidError::invalid(
                "model.effects",
                format!(
                    "`{}` does not vanish at steady state, so stage 1 from steady-state data would be biased: use it on records without the designed steady-state experiment",
                    e.label()
                ),
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
    let scale = data_scale(&data);
    let resolution = resolution(
        model,
        &layout,
        method.cells.nonlinearity_halvings,
        delta,
        &scale,
    );
    let test = |cell: &[Interval]| test_cell(model, &layout, method, &training, cell);
    let eval = |cell: &[Interval]| evaluate_cell(model, &layout, method, &training, cell);
    let search = cells::search(
        &prior,
        Budget {
            resolution,
            depth: method.cells.depth,
            max_cells: method.cells.max_cells,
            max_leaves: method.cells.max_leaves,
        },
        &test,
        &eval,
        progress,
    )?;
    let summary = SearchSummary {
        evaluated: search.evaluated,
        discarded: search.discarded,
        budget_stopped: search.budget_stopped,
    };
    let mut kept = Vec::new();
    for leaf in search.leaves {
        match leaf.value {
            Some(c) => kept.push(c),
            None => {
                return Err(SmidError::Unbounded {
                    parameter: "θ".into(),
                    message: format!(
                    "over the cell {} of the bisected parameters stage 3 found no finite bound{}",
                    fmt_cell(&layout, &leaf.cell),
                    if summary.budget_stopped {
                        " (the cell budget stopped the bisection: raise method.cells.max_cells)"
                    } else {
                        ""
                    }
                ),
                })
            }
        }
    }
    let truth_of = |n: &str| truth.iter().find(|(k, _)| k == n).map(|(_, v)| *v);

    // Hulls over the cells, in report order: nonlinearity, θ, ψ.
    let mut parameters: Vec<ParamResult> = Vec::new();
    let gnames: Vec<String> = kept[0]
        .nonlinearity
        .parameters()
        .iter()
        .map(|b| b.name.clone())
        .collect();
    for (k, name) in gnames.iter().enumerate() {
        let h = hull(kept.iter().map(|c| c.nonlinearity.parameters()[k].interval));
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

    // The cell holding the true ψ (when known) is the representative.
    let psi_truth: Option<Vec<f64>> = layout.dims.iter().map(|d| truth_of(&d.name)).collect();
    let gamma_truth: Option<Vec<f64>> = gnames.iter().map(|n| truth_of(n)).collect();
    let holds_psi = |c: &CellSet| {
        psi_truth
            .as_ref()
            .map(|t| c.cell.iter().zip(t).all(|(i, v)| i.contains(*v)))
            .unwrap_or(true)
    };
    let representative = kept.iter().position(|c| holds_psi(c)).unwrap_or(0);
    let truth_in_set = match (&gamma_truth, &psi_truth) {
        (Some(g), _) => Some(
            kept.iter()
                .any(|c| holds_psi(c) && c.nonlinearity.contains(g)),
        ),
        _ => None,
    };
    let rep = &kept[representative];
    let sig = stage2(
        model,
        &layout,
        rep.nonlinearity.as_ref(),
        &rep.cell,
        &training.records,
    )?;
    // The equations stage 3 used (every method uses every usable one): listed, not re-solved.
    let equations = eiv_problem(model, &layout, method, &sig, None).equation_times();
    let first_len = training.records[0].y.len();
    // The inner signal: the nonlinearity's input (Wiener) or output (Hammerstein).
    let inner: Vec<InnerBound> = match model.structure {
        Structure::Wiener => sig.output[..first_len].to_vec(),
        Structure::Hammerstein => {
            let blocks = BlockSets::new(model, &layout, &rep.cell)?;
            let (input_side, _) = blocks.sides(model.structure, rep.nonlinearity.as_ref());
            chain::forward(&input_side, &training.records[0].u)?
        }
    };
    let inner_violations = training.records[0].x.as_ref().map(|x| {
        x.iter()
            .zip(&inner)
            .filter(|(v, b)| b.interval.is_finite() && !b.interval.contains(**v))
            .count()
    });
    let set = ModelSet {
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
    };
    let snr_db = match data.records.first() {
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
    };
    Ok(Identification {
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
    })
}

fn hull(it: impl IntoIterator<Item = Interval>) -> Interval {
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

/// The truth of a plant in the model's names: the nonlinearity's and effects' own, and `θ`
/// from the plant's total linear block under the model's orders; `plant.truth` of the spec
/// overrides.
pub fn plant_truth(spec: &Spec, plant: &dyn Plant) -> Result<Vec<(String, f64)>> {
    let layout = spec.model.layout()?;
    let mut truth = plant.truth();
    if let Some(lin) = plant.linear_truth() {
        truth.extend(theta_truth(&layout, &lin));
    }
    for (k, v) in &spec.plant.truth {
        truth.retain(|(n, _)| n != k);
        truth.push((k.clone(), *v));
    }
    Ok(truth)
}

/// Acquire data for a spec whose plant is the built-in simulator or CSV data, then identify.
/// (Other plant kinds are built by the crates that provide them; see [`run_with_plant`].)
pub fn run(spec: &Spec, base: &Path) -> Result<Identification> {
    if let Some(mut plant) = builtin_plant(spec) {
        return run_with_plant(spec, &mut plant);
    }
    if spec.plant.data.is_some() {
        let data = load_data(spec, base)?;
        let truth: Vec<(String, f64)> = spec
            .plant
            .truth
            .iter()
            .map(|(k, v)| (k.clone(), *v))
            .collect();
        return identify(spec, data, &truth);
    }
    Err(SmidError::invalid(
        "plant",
        "this plant kind needs a plant provider (e.g. the FMU crate); use the `smid` CLI",
    ))
}

/// Run the experiments on `plant` and identify.
pub fn run_with_plant(spec: &Spec, plant: &mut dyn Plant) -> Result<Identification> {
    let data = simulate_experiments(spec, plant)?;
    let truth = plant_truth(spec, plant)?;
    identify(spec, data, &truth)
}
