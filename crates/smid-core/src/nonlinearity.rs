//! Nonlinearity plugin traits: what a plugin implements so the core can simulate it
//! ([`Nonlinearity`]), bound its parameters from steady-state data ([`NonlinearityModel`],
//! paper Section 3) and bound the inner signal through the uncertain map ([`NonlinearitySet`],
//! Section 4). The core names no plugin: a spec selects one by its `type` tag, registered with
//! `typetag` by the plugin crate.
//!
//! Like argmin's capability traits, each trait has one required method and defaults for the rest.
use crate::error::{Result, SmidError};
use crate::interval::Interval;
use crate::inversion::{InnerBound, InnerKind};
use crate::polygon::Polygon;
use rand::RngCore;
use serde::{Deserialize, Serialize};
use std::fmt::Debug;

/// Where the nonlinearity sits relative to the linear block.
#[derive(
    Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default, schemars::JsonSchema,
)]
#[serde(rename_all = "lowercase")]
pub enum Structure {
    /// Linear block, then the nonlinearity (the paper's Fig. 2): `w = N(G u)`.
    #[default]
    Wiener,
    /// Nonlinearity, then the linear block: `w = G(N(u))`.
    Hammerstein,
}

/// A nonlinearity with known parameters, as a plant simulator runs it.
///
/// ```
/// use smid_core::nonlinearity::Nonlinearity;
/// use serde::{Deserialize, Serialize};
///
/// /// `w = k x`: the smallest possible plugin.
/// #[derive(Debug, Serialize, Deserialize)]
/// struct Gain { k: f64 }
///
/// #[typetag::serde(name = "doc_gain")]
/// impl Nonlinearity for Gain {
///     fn step(&self, _memory: &mut Vec<f64>, x: f64) -> f64 { self.k * x }
///     fn parameters(&self) -> Vec<(String, f64)> { vec![("k".into(), self.k)] }
/// }
///
/// let g: Box<dyn Nonlinearity> = serde_json::from_str(r#"{"type":"doc_gain","k":2.0}"#).unwrap();
/// let mut mem = g.initial_memory();
/// assert_eq!(g.step(&mut mem, 1.5), 3.0);
/// ```
#[typetag::serde(tag = "type")]
pub trait Nonlinearity: Debug + Send + Sync {
    /// Map one input sample to one output sample, updating the memory (for maps with memory
    /// such as backlash). Required.
    fn step(&self, memory: &mut Vec<f64>, x: f64) -> f64;
    /// The memory at rest (before the first sample).
    fn initial_memory(&self) -> Vec<f64> {
        Vec::new()
    }
    /// Parameter names and values, in report order.
    fn parameters(&self) -> Vec<(String, f64)> {
        Vec::new()
    }
    /// Check the parameters; errors name the field.
    fn validate(&self) -> Result<()> {
        Ok(())
    }
    /// The same block behind a gain `k > 0` on its input: the parameters (by name, as
    /// [`Nonlinearity::parameters`] reports them) of a map `N'` of this plugin's class with
    /// `N'(k·x_t) = N(x_t)` for every input sequence from rest, memory included; `None`
    /// (default) when the class is not closed under such a gain (a bias, a unit-gain lag).
    /// A block right after the linear block can then trade that gain with it (`k·L` followed
    /// by `N'` behaves as `L` followed by `N`): the diagnosis searches the trade when it tests
    /// two candidates for equivalence (a parallel input path scales the inner signal at rest).
    fn behind_gain(&self, _k: f64) -> Option<Vec<(String, f64)>> {
        None
    }
    /// Run a whole sequence from rest.
    fn simulate(&self, x: &[f64]) -> Vec<f64> {
        let mut mem = self.initial_memory();
        x.iter().map(|&v| self.step(&mut mem, v)).collect()
    }
}

/// One steady-state sample of the filtered square-wave experiment (paper Section 3.2).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct SteadyPoint {
    /// Steady-state input `ū` (signed; equals the steady inner signal under unit gain, eq 8).
    pub u: f64,
    /// Measured steady-state output `ȳ`.
    pub y: f64,
    /// Noise bound `Δη̄` of this sample.
    pub dy: f64,
    /// Extra allowance for a possible overshoot bias (α of eqs 14-15, made non-negative);
    /// the plugin widens the interval on the side the bias would push the output.
    pub alpha: f64,
    /// The input reached `ū` by rising (positive half-wave) rather than falling.
    pub rising: bool,
    /// Index of the sample in the steady-state record (for error messages).
    pub index: usize,
    /// Sample time of `ȳ` in the steady-state record, when known (sensor drift needs it).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub time: Option<usize>,
    /// Height of the square-wave step that led to `ū`, when known (`None`: `2|ū|`, the
    /// paper's ascending order). Scales the overshoot allowance α.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub step: Option<f64>,
    /// Radius of the steady input actually reaching the nonlinearity, when a chain's input
    /// blocks leave it uncertain over their cell (`ū ± du`); 0 for a known input. Plugins whose
    /// sets are strips in `(m, m·c)` take it through [`Polygon::from_uncertain_strips`]; others
    /// refuse `du > 0` (the nonlinearity then needs a prior box).
    #[serde(default, skip_serializing_if = "is_zero")]
    pub du: f64,
}

fn is_zero(v: &f64) -> bool {
    *v == 0.0
}

impl SteadyPoint {
    /// Sample `index` of a designed experiment: steady input `u` (exact), output `y` with noise
    /// bound `dy`, reached by a rising step when `u > 0`; no overshoot allowance, no time, no
    /// recorded step height. The fields are public: change the ones a case needs.
    pub fn new(index: usize, u: f64, y: f64, dy: f64) -> SteadyPoint {
        SteadyPoint {
            u,
            y,
            dy,
            alpha: 0.0,
            rising: u > 0.0,
            index,
            time: None,
            step: None,
            du: 0.0,
        }
    }

    /// The step height that led to this sample (`2|ū|` when not recorded).
    pub fn step_height(&self) -> f64 {
        self.step.unwrap_or(2.0 * self.u.abs())
    }

    /// The hull of the inputs the designed step to this point moves through: from the previous
    /// level (`ū ∓` the step height, by [`SteadyPoint::rising`]) to `ū`, widened by `du`
    /// (the first-order filter moves monotonically between the two).
    pub fn step_hull(&self) -> Interval {
        let from = if self.rising {
            self.u - self.step_height()
        } else {
            self.u + self.step_height()
        };
        Interval::new(from.min(self.u) - self.du, from.max(self.u) + self.du).outward()
    }
}

/// Steady-state data for stage 1.
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
pub struct SteadyStateData {
    /// The steady-state samples, in the order they were recorded.
    pub points: Vec<SteadyPoint>,
}

impl SteadyStateData {
    /// Check every point: finite `ū` and `ȳ`, a finite noise bound `> 0`, a finite `α >= 0`.
    /// Errors name the sample. The pipeline calls this before stage 1; plugins may rely on it.
    pub fn validate(&self) -> Result<()> {
        for p in &self.points {
            let at = || format!("steady-state sample {}", p.index);
            if !(p.u.is_finite() && p.y.is_finite()) {
                return Err(SmidError::invalid(at(), "non-finite value"));
            }
            if !(p.dy > 0.0 && p.dy.is_finite()) {
                return Err(SmidError::invalid(at(), "noise bound must be > 0"));
            }
            if !(p.du >= 0.0 && p.du.is_finite()) {
                return Err(SmidError::invalid(
                    at(),
                    "input radius du must be finite and >= 0",
                ));
            }
            if !(p.alpha >= 0.0 && p.alpha.is_finite()) {
                return Err(SmidError::invalid(at(), "α must be finite and >= 0"));
            }
        }
        Ok(())
    }
}

/// The two branch polygons of a cell `(m_l, c_l, m_r, c_r)` of a two-branch plugin (backlash,
/// dead zone): each branch's exact image in `(m, m·c)` ([`Polygon::from_slope_offset_box`]);
/// any other number of intervals is an error naming `model.prior`.
pub fn two_branch_polygons(cell: &[Interval]) -> Result<(Polygon, Polygon)> {
    let [m_l, c_l, m_r, c_r] = <[Interval; 4]>::try_from(cell).map_err(|_| {
        SmidError::invalid(
            "model.prior",
            format!(
                "expected 4 intervals (m_l, c_l, m_r, c_r), got {}",
                cell.len()
            ),
        )
    })?;
    Ok((
        Polygon::from_slope_offset_box(m_l, c_l)?,
        Polygon::from_slope_offset_box(m_r, c_r)?,
    ))
}

/// Two linear branches `m·(x ± c)` with breakpoints `c` in input units (a backlash, a dead
/// zone: `(m_l, c_l, m_r, c_r)`) behind a gain `k` on their input
/// ([`Nonlinearity::behind_gain`]): the slopes divide by `k`, the breakpoints multiply.
pub fn two_branches_behind_gain(
    m_l: f64,
    c_l: f64,
    m_r: f64,
    c_r: f64,
    k: f64,
) -> Option<Vec<(String, f64)>> {
    (k.is_finite() && k > 0.0).then(|| {
        vec![
            ("m_l".into(), m_l / k),
            ("c_l".into(), c_l * k),
            ("m_r".into(), m_r / k),
            ("c_r".into(), c_r * k),
        ]
    })
}

/// Plot regions of a nonlinearity with two linear branches parameterised as
/// `(m_l, c_l, m_r, c_r)` and held as polygons in `(m, m·c)` coordinates (output backlash, dead
/// zone); `truth` in report order.
pub fn two_branch_regions(left: &Polygon, right: &Polygon, truth: Option<&[f64]>) -> Vec<Region> {
    let t = |i: usize| {
        truth
            .filter(|t| t.len() >= 4)
            .map(|t| [t[i], t[i] * t[i + 1]])
    };
    vec![
        Region {
            name: "left_branch".into(),
            axes: ["m_l".into(), "m_l·c_l".into()],
            vertices: left.vertices.clone(),
            truth: t(0),
        },
        Region {
            name: "right_branch".into(),
            axes: ["m_r".into(), "m_r·c_r".into()],
            vertices: right.vertices.clone(),
            truth: t(2),
        },
    ]
}

/// Whether `(m_l, c_l, m_r, c_r)` lies in the two branch polygons (exact set membership).
pub fn two_branches_contain(left: &Polygon, right: &Polygon, truth: &[f64]) -> bool {
    truth.len() == 4
        && left.contains([truth[0], truth[0] * truth[1]])
        && right.contains([truth[2], truth[2] * truth[3]])
}

/// A named guaranteed parameter interval.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ParameterBound {
    /// The parameter's name, as the plugin reports it (`m_l`, `c_r`...).
    pub name: String,
    /// Guaranteed interval holding the parameter's true value.
    pub interval: Interval,
}

/// The stage-1 set of a cell whose steady-state points do not bound the nonlinearity (a slope
/// that may reach 0 once an output block's play is subtracted): every parameter in
/// `(-∞, ∞)`, every inner-signal sample unknown. Only a leaf the branch and bound leaves
/// undecided holds it, so that a run still reports what the other cells bound instead of
/// failing; its θ is unbounded too, and the search summary lists the cell with its cause.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct UnboundedSet {
    /// The nonlinearity's parameter names, in report order.
    pub names: Vec<String>,
}

impl UnboundedSet {
    fn unknown(n: usize) -> Vec<InnerBound> {
        vec![
            InnerBound {
                interval: Interval::entire(),
                kind: InnerKind::Unknown,
            };
            n
        ]
    }
}

#[typetag::serde(name = "smid_unbounded")]
impl NonlinearitySet for UnboundedSet {
    fn parameters(&self) -> Vec<ParameterBound> {
        self.names
            .iter()
            .map(|n| ParameterBound {
                name: n.clone(),
                interval: Interval::entire(),
            })
            .collect()
    }
    fn invert(&self, y: &[f64], _dy: &[f64]) -> Result<Vec<InnerBound>> {
        Ok(Self::unknown(y.len()))
    }
    fn propagate(&self, u: &[f64]) -> Result<Vec<InnerBound>> {
        Ok(Self::unknown(u.len()))
    }
    fn propagate_intervals(&self, v: &[Interval]) -> Result<Vec<InnerBound>> {
        Ok(Self::unknown(v.len()))
    }
    fn invert_steady(&self, _y: f64, _dy: f64) -> Result<Interval> {
        Ok(Interval::entire())
    }
    fn propagate_steady(&self, _u: f64) -> Result<Interval> {
        Ok(Interval::entire())
    }
}

/// A two-dimensional feasible region for plots: a polygon in the plugin's linear coordinates.
#[derive(Debug, Clone, Serialize)]
pub struct Region {
    /// File-friendly name, e.g. `left_branch`.
    pub name: String,
    /// Axis labels of the polygon's coordinates.
    pub axes: [String; 2],
    /// The polygon's vertices in those coordinates, counter-clockwise.
    pub vertices: Vec<[f64; 2]>,
    /// The true parameters in the same coordinates, when known.
    pub truth: Option<[f64; 2]>,
}

/// The model structure's nonlinearity, as a spec declares it for identification: a `type`
/// plus the plugin's options, never its (unknown) parameters.
///
/// ```
/// use smid_core::prelude::*;
/// use serde::{Deserialize, Serialize};
///
/// /// Identify `w = k x` from steady-state data: `k` in the hull of `(ȳ ± Δη)/ū`.
/// #[derive(Debug, Serialize, Deserialize)]
/// struct GainModel;
/// #[derive(Debug, Serialize, Deserialize)]
/// struct GainSet(Interval);
/// #[typetag::serde(name = "doc_gain_model_set")]
/// impl NonlinearitySet for GainSet {
///     fn parameters(&self) -> Vec<ParameterBound> {
///         vec![ParameterBound { name: "k".into(), interval: self.0 }]
///     }
/// }
/// #[typetag::serde(name = "doc_gain_model")]
/// impl NonlinearityModel for GainModel {
///     fn bound_steady_state(&self, d: &SteadyStateData) -> Result<Box<dyn NonlinearitySet>> {
///         let mut k = Interval::entire();
///         for p in &d.points {
///             let (a, b) = ((p.y - p.dy) / p.u, (p.y + p.dy) / p.u);
///             k = k.intersect(&Interval::new(a.min(b), a.max(b))).ok_or(SmidError::inconsistent(Stage::SteadyState, p.index, "k"))?;
///         }
///         Ok(Box::new(GainSet(k.outward())))
///     }
/// }
/// let pts = vec![SteadyPoint { u: 2.0, y: 4.0, dy: 0.1, alpha: 0.0, rising: true, index: 0, time: None, step: None , du: 0.0}];
/// let set = GainModel.bound_steady_state(&SteadyStateData { points: pts }).unwrap();
/// assert!(set.parameters()[0].interval.contains(2.0));
/// ```
#[typetag::serde(tag = "type")]
pub trait NonlinearityModel: Debug + Send + Sync {
    /// Stage 1: guaranteed bounds on the parameters from steady-state data. Required.
    fn bound_steady_state(&self, data: &SteadyStateData) -> Result<Box<dyn NonlinearitySet>>;
    /// Whether the plugin can sit in this structure.
    fn supports(&self, structure: Structure) -> bool {
        structure == Structure::Wiener
    }
    /// Whether [`NonlinearityModel::bound_steady_state`] honours [`SteadyPoint::du`] (a steady
    /// input known only to an interval, behind a chain's input blocks). Default: no, and the
    /// pipeline then never passes such points (the nonlinearity needs a prior box instead).
    fn accepts_input_radius(&self) -> bool {
        false
    }
    /// Whether every member, as the Wiener nonlinearity, turns a monotone step of its input
    /// (from rest to rest) into a monotone step of its output: a nondecreasing static map, a
    /// play with positive slopes. Then the first block after it sees each designed step
    /// (Section 3, no overshoot but α) as a monotone one, and stage 1 inverts that block with
    /// [`NonlinearitySet::invert_steady_step`]. Default: no (any history is assumed there).
    fn keeps_steps_monotone(&self) -> bool {
        false
    }
    /// A prior box for the plugin's parameters from the range `seen` of the signal the plugin
    /// sees in the training data (the input for Hammerstein, the output for Wiener), when a
    /// diagnosis offers this plugin as a candidate for a model without a nonlinearity (slopes
    /// fixed to 1: with a free linear gain they are not identifiable). `None` (default): not
    /// offered.
    fn default_prior(&self, _structure: Structure, _seen: (f64, f64)) -> Option<Vec<Interval>> {
        None
    }
    /// A prior box for the plugin's parameters as the model's **own** nonlinearity (slopes
    /// free: the linear block has unit gain), from the ranges `input` and `output` that its
    /// input and output span at the steady-state points. A diagnosis gives it, reported, to a
    /// candidate whose steady-state points give no box even as if the designed experiment held
    /// (a term that switches while the square wave settles moves every point off its branch);
    /// the branch and bound then prunes its cells by the points with any history, so the
    /// bounds hold wherever the truth lies in this box. `None` (default): such a candidate is
    /// not tried. [`two_branch_scale_prior`] serves plugins with `(m_l, c_l, m_r, c_r)`.
    fn scale_prior(
        &self,
        _structure: Structure,
        _input: (f64, f64),
        _output: (f64, f64),
    ) -> Option<Vec<Interval>> {
        None
    }
    /// The branch and bound's resolution of each parameter over its prior box: a cell narrower
    /// than this is not halved further. `halvings` is the spec's
    /// `method.cells.nonlinearity_halvings`, `delta` the output noise bound. Default: the
    /// prior's width halved `halvings` times. A parameter in output units (a bias) may ask for
    /// the noise's scale instead, as a sensor term does.
    fn resolution(&self, prior: &[Interval], halvings: u32, _delta: f64) -> Vec<f64> {
        halved_widths(prior, halvings)
    }
    /// Identification from any record (no steady-state data): the set of **every** parameter
    /// vector in a box (one interval per parameter, in the order of
    /// [`Nonlinearity::parameters`] of the plugin's simulator), whose
    /// [`NonlinearitySet::invert`] / [`NonlinearitySet::propagate`] must bound the inner signal
    /// for every member of the box. The branch and bound of [`crate::cells`] calls it per cell.
    /// Default: unsupported (the plugin then needs steady-state data).
    fn set_from_box(&self, _cell: &[Interval]) -> Result<Box<dyn NonlinearitySet>> {
        Err(SmidError::Unsupported {
            plugin: format!("{self:?}"),
            what: "a parameter box without steady-state data (implement NonlinearityModel::set_from_box)".into(),
        })
    }
    /// The plugin's random containment trial in `structure` (`smid check --plugin`, the band
    /// tests, the benches): a true block drawn from `rng` over the range the plugin is meant
    /// for, the model to identify it with, and the experiment's amplitudes. The check draws the
    /// linear block and the noise itself, runs the whole pipeline and requires every bound to
    /// hold the truth. `None` (default): the plugin is not checked in `structure`. Each
    /// structure that answers `Some` is one check case ([`crate::registry::check_cases`]).
    fn check_draw(&self, _structure: Structure, _rng: &mut dyn RngCore) -> Option<CheckDraw> {
        None
    }
    /// The number of input levels of the containment trial's dynamic record in `structure`
    /// (`experiment.dynamic.levels`). Default: 2, the binary PRBS. A block that maps `±a` to
    /// one value (an even map on the input side) needs more, or its output is constant.
    fn check_levels(&self, _structure: Structure) -> usize {
        2
    }
}

/// Share of its input's range that a branch offset (`c_l`, `c_r`) of a
/// [`two_branch_scale_prior`] may reach: a band `c_l + c_r` up to half the range.
pub const SCALE_PRIOR_OFFSET_SHARE: f64 = 0.25;
/// Factor by which a slope of a [`two_branch_scale_prior`] may lie below or above the ratio of
/// the output's range to the input's.
pub const SCALE_PRIOR_SLOPE_FACTOR: f64 = 4.0;

/// [`NonlinearityModel::scale_prior`] for a two-branch plugin `(m_l, c_l, m_r, c_r)` with
/// slopes `m > 0` and offsets `c >= 0` in input units (a play, a dead zone): with `r` the
/// ratio of the output's range to the input's, each slope in `[r/4, 4r]`
/// ([`SCALE_PRIOR_SLOPE_FACTOR`]) and each offset in `[0, range/4]`
/// ([`SCALE_PRIOR_OFFSET_SHARE`]). It holds every such map whose slopes lie within a factor 2
/// of each other and whose offsets are below a quarter of the range, seen at points that reach
/// both ends of the range on their branches, the two ends within a factor 2 of each other in
/// magnitude (the designed experiment's ± amplitudes): then `r/3 <= m <= 3.5 r` (`tests::a_scale_prior_holds_every_two_branch_map_within_its_ranges`).
/// `None` where either range is empty or not finite, or where the input's range does not
/// straddle 0 with its ends within a factor 2 in magnitude (the claim's premise).
///
/// ```
/// use smid_core::nonlinearity::two_branch_scale_prior;
/// let b = two_branch_scale_prior((-3.0, 3.0), (-0.75, 0.75)).unwrap();
/// assert!(b[0].contains(0.25) && b[1].contains(0.1) && b[1].lo == 0.0);
/// assert!(two_branch_scale_prior((1.0, 1.0), (0.0, 1.0)).is_none());
/// assert!(two_branch_scale_prior((0.6, 3.0), (0.1, 0.7)).is_none()); // one-sided
/// ```
pub fn two_branch_scale_prior(input: (f64, f64), output: (f64, f64)) -> Option<Vec<Interval>> {
    let (si, so) = (input.1 - input.0, output.1 - output.0);
    let straddles = input.0 < 0.0 && input.1 > 0.0 && {
        let (a, b) = (-input.0, input.1);
        a.max(b) <= 2.0 * a.min(b)
    };
    if !(si.is_finite() && so.is_finite() && si > 0.0 && so > 0.0 && straddles) {
        return None;
    }
    let r = so / si;
    if !(r.is_normal() && (r * SCALE_PRIOR_SLOPE_FACTOR).is_finite()) {
        return None;
    }
    let m = Interval::new(r / SCALE_PRIOR_SLOPE_FACTOR, r * SCALE_PRIOR_SLOPE_FACTOR);
    let c = Interval::new(0.0, SCALE_PRIOR_OFFSET_SHARE * si);
    Some(vec![m, c, m, c])
}

/// Each interval's width halved `halvings` times: the default resolution of a plugin's
/// parameters in the branch and bound ([`NonlinearityModel::resolution`]).
pub fn halved_widths(prior: &[Interval], halvings: u32) -> Vec<f64> {
    let h = 2f64.powi(halvings as i32);
    prior.iter().map(|p| (p.hi - p.lo) / h).collect()
}

/// One random true block of a plugin for a containment trial ([`NonlinearityModel::check_draw`]).
#[derive(Debug)]
pub struct CheckDraw {
    /// The true block the plant simulates.
    pub nonlinearity: Box<dyn Nonlinearity>,
    /// The model that identifies it (the plugin's options, drawn too where they matter).
    pub model: Box<dyn NonlinearityModel>,
    /// Steady-state amplitudes `[min, max]` of the designed experiment.
    pub steady: (f64, f64),
    /// Amplitude of the dynamic record (PRBS).
    pub amplitude: f64,
}

/// The uncertain nonlinearity left after stage 1: parameter bounds, and the inner-signal bounds
/// it implies (inversion of the output for Wiener, propagation of the input for Hammerstein).
/// Sets serialise (typetag, `type` = the plugin's tag), so an identified model set is written
/// to `result.json` whole and read back by `smid validate` and `smid diagnose`.
///
/// ```
/// use smid_core::prelude::*;
/// use serde::{Deserialize, Serialize};
///
/// /// `w = k x` with `k` in an interval `[k0, k1]`, `k0 > 0`.
/// #[derive(Debug, Serialize, Deserialize)]
/// struct GainSet(Interval);
/// #[typetag::serde(name = "doc_gain_set")]
/// impl NonlinearitySet for GainSet {
///     fn parameters(&self) -> Vec<ParameterBound> {
///         vec![ParameterBound { name: "k".into(), interval: self.0 }]
///     }
///     /// `x = w / k` over `k in [k0, k1]` and `w in [y - Δη, y + Δη]`: extremes at the ends.
///     fn invert(&self, y: &[f64], dy: &[f64]) -> Result<Vec<InnerBound>> {
///         Ok(y.iter().zip(dy).map(|(&y, &d)| {
///             let c = [(y - d) / self.0.lo, (y - d) / self.0.hi, (y + d) / self.0.lo, (y + d) / self.0.hi];
///             let i = Interval::hull_of(c).unwrap().outward();
///             InnerBound { interval: i, kind: InnerKind::Inverted }
///         }).collect())
///     }
/// }
/// let set = GainSet(Interval::new(1.9, 2.1));
/// let x = set.invert(&[4.0], &[0.1]).unwrap();
/// assert!(x[0].interval.contains(2.0) && x[0].interval.contains(3.9 / 2.1));
/// assert!(set.contains(&[2.0]) && !set.contains(&[2.5]));
/// ```
#[typetag::serde(tag = "type")]
pub trait NonlinearitySet: Debug + Send + Sync {
    /// Guaranteed parameter intervals, in report order. Required.
    fn parameters(&self) -> Vec<ParameterBound>;
    /// Stage 2 (Wiener): bound every inner-signal sample `x_t` from the outputs `y` with
    /// per-sample noise bounds `dy`. Contract: the sequence may start anywhere in a record (an
    /// output chain inverts runs between unknown samples), so nothing may assume it starts at
    /// rest.
    fn invert(&self, _y: &[f64], _dy: &[f64]) -> Result<Vec<InnerBound>> {
        Err(SmidError::Unsupported {
            plugin: format!("{self:?}"),
            what: "output inversion (Wiener)".into(),
        })
    }
    /// Stage 2 (Hammerstein): bound every inner-signal sample from the known input.
    fn propagate(&self, _u: &[f64]) -> Result<Vec<InnerBound>> {
        Err(SmidError::Unsupported {
            plugin: format!("{self:?}"),
            what: "input propagation (Hammerstein)".into(),
        })
    }
    /// Whether the map from an input sequence to the output sequence is order-preserving for
    /// every member of the set (`v <= v'` sample by sample gives `N(v) <= N(v')`, from the same
    /// state): a dead zone, a saturation, a play, a unit-gain lag. Then
    /// [`NonlinearitySet::propagate_intervals`] needs nothing else. Default: no.
    fn monotone(&self) -> bool {
        false
    }
    /// Stage 2 of a block further along an input chain ([`crate::chain`]): bound the output
    /// from input **intervals** (the output of the blocks before it). Default: exact inputs go
    /// to [`NonlinearitySet::propagate`]; interval inputs to a [`NonlinearitySet::monotone`]
    /// set are propagated at their lower and upper ends (for every member the output lies
    /// between the two); anything else is unsupported.
    fn propagate_intervals(&self, v: &[Interval]) -> Result<Vec<InnerBound>> {
        if let Some(t) = v.iter().position(|i| !i.is_finite()) {
            return Err(SmidError::invalid(
                format!("dynamic sample {t}"),
                "a block of the input chain received an unknown input",
            ));
        }
        if v.iter().all(|i| i.lo == i.hi) {
            let c: Vec<f64> = v.iter().map(|i| i.lo).collect();
            return self.propagate(&c);
        }
        if !self.monotone() {
            return Err(SmidError::Unsupported {
                plugin: format!("{self:?}"),
                what: "interval inputs (a block after another block on the input side): implement NonlinearitySet::propagate_intervals or monotone".into(),
            });
        }
        let lo: Vec<f64> = v.iter().map(|i| i.lo).collect();
        let hi: Vec<f64> = v.iter().map(|i| i.hi).collect();
        let (a, b) = (self.propagate(&lo)?, self.propagate(&hi)?);
        Ok(a.iter()
            .zip(&b)
            .map(|(a, b)| InnerBound {
                interval: Interval::new(
                    a.interval.lo.min(b.interval.lo),
                    a.interval.hi.max(b.interval.hi),
                ),
                kind: if a.kind == InnerKind::Inverted && b.kind == InnerKind::Inverted {
                    InnerKind::Inverted
                } else {
                    InnerKind::Band
                },
            })
            .collect())
    }
    /// The range of the block's output, over every member of the set and whatever its
    /// history, when its input lies in `x`; `None` (default) when the block gives none (a
    /// block with memory). The one-step band of a block that is not
    /// [`NonlinearitySet::monotone`] is its output range over the prediction.
    fn output_range(&self, _x: Interval) -> Option<Interval> {
        None
    }
    /// The block's input at steady state from its steady output `y ± dy` (stage 1 of a chain
    /// whose output side holds this block after the nonlinearity that steady-state data bound).
    /// Default: the inversion of that one sample (without history, as [`NonlinearitySet::invert`]
    /// must allow for). A unit-gain filter returns `[y - dy, y + dy]`.
    fn invert_steady(&self, y: f64, dy: f64) -> Result<Interval> {
        Ok(self.invert(&[y], &[dy])?[0].hull())
    }
    /// The block's input at the end of a step during which that input moved **monotonically**
    /// (up when `rising`) from one steady state to another, from the steady outputs before
    /// (`y0 ± dy0`) and after (`y ± dy`). Only stage 1's designed experiment asks, for the
    /// block right after a nonlinearity that [`NonlinearityModel::keeps_steps_monotone`]: the
    /// premise is the polygons' own (eqs 13-20), that each designed step ends on the branch of
    /// its direction. Contract: the interval holds for every member whenever the input was
    /// monotone in that direction over the step. Default: the step is not used
    /// ([`NonlinearitySet::invert_steady`], any history). A play overrides it: an output that
    /// moved by more than the noise **in the step's direction** was pushed along that branch,
    /// which the input then sits on, where any history leaves the whole dead band.
    fn invert_steady_step(
        &self,
        _y0: f64,
        _dy0: f64,
        y: f64,
        dy: f64,
        _rising: bool,
    ) -> Result<Interval> {
        self.invert_steady(y, dy)
    }
    /// Whether steady-state points stay valid through this block on the input side: the
    /// designed filter keeps the linear block's response to the filtered square wave free of
    /// overshoot (Appendix), which a Wiener nonlinearity with memory would otherwise hold. A
    /// linear block with a nonnegative impulse response of unit mass (a unit-gain lag, a
    /// positive gain) keeps that property (its output's overshoot-free response is a convex
    /// mixture of overshoot-free responses); a block that stops the signal abruptly (a
    /// saturation clipping the wave: measured, the backlash then holds an overshoot of 3 % of
    /// the step) does not, and neither is proven for a dead zone or a play. Default: no (then
    /// the nonlinearity after it needs a prior box, not the polygons).
    fn keeps_steady_design(&self) -> bool {
        false
    }
    /// Whether one designed step whose input stays inside `t` (the filtered square wave moves
    /// monotonically from the previous level to the point's, so `t` is their hull) still
    /// reaches the next block as a designed step: for every member of the cell and any
    /// history, the block acts on `t` as one positive gain (so the linear block's response
    /// stays overshoot-free, as for [`NonlinearitySet::keeps_steady_design`]). A saturation is
    /// such a gain below its smallest limit, though not over its whole range. Stage 1 keeps
    /// the polygons of the steady-state points whose step passes every input block this way
    /// and leaves the others out (fewer points only widen the set). Default:
    /// [`NonlinearitySet::keeps_steady_design`], whatever `t`.
    fn keeps_steady_design_over(&self, _t: Interval) -> bool {
        self.keeps_steady_design()
    }
    /// The block's steady output for the steady input `u` (stage 1 of a chain whose input side
    /// holds this block before the nonlinearity that steady-state data bound). Contract: it
    /// holds for every state the block may have reached at rest (any history), since the
    /// steady-state test of a prior-box cell relies on it behind blocks with memory. Default:
    /// the propagation of that one sample (a block whose `propagate` assumes a start at rest
    /// overrides it, as the play does). A unit-gain filter returns `[u, u]`.
    fn propagate_steady(&self, u: f64) -> Result<Interval> {
        Ok(self.propagate(&[u])?[0].interval)
    }
    /// Feasible regions to plot (with the truth marked when `truth` is given in the order of
    /// [`NonlinearitySet::parameters`]).
    fn regions(&self, _truth: Option<&[f64]>) -> Vec<Region> {
        Vec::new()
    }
    /// Whether the true parameters (in report order) lie in the feasible set. The default
    /// checks the parameter box.
    fn contains(&self, truth: &[f64]) -> bool {
        self.parameters()
            .iter()
            .zip(truth)
            .all(|(b, &t)| b.interval.contains(t))
    }
}

/// The `type` tag of a model plugin.
pub fn tag_of_model(m: &dyn NonlinearityModel) -> String {
    serde_json::to_value(m)
        .ok()
        .and_then(|v| v.get("type").and_then(|t| t.as_str()).map(String::from))
        .unwrap_or_default()
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    /// The claim of [`two_branch_scale_prior`]: random two-branch maps (a play's or a dead
    /// zone's branches `y = m_r (x - c_r)`, `y = m_l (x + c_l)`), slopes within a factor 2,
    /// offsets below a quarter of the range, seen at random steady points that reach both ends
    /// of a range (its ends within a factor 2 in magnitude) on their branches, the others on a
    /// branch or inside the band, lie in the box from the points' ranges.
    #[test]
    fn a_scale_prior_holds_every_two_branch_map_within_its_ranges() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(59);
        for _ in 0..2000 {
            let hi = rng.gen_range(0.1..10.0);
            let lo = -hi * 2f64.powf(rng.gen_range(-1.0..1.0));
            let span: f64 = hi - lo;
            let m_l = 10f64.powf(rng.gen_range(-3.0..3.0));
            let m_r = m_l * 2f64.powf(rng.gen_range(-1.0..1.0));
            let c_l = rng.gen_range(0.0..0.25) * span;
            let c_r = rng.gen_range(0.0..0.25) * span;
            let mut xs: Vec<f64> = vec![lo, hi];
            xs.extend((0..rng.gen_range(0..20)).map(|_| rng.gen_range(lo..hi)));
            let ys: Vec<f64> = xs
                .iter()
                .map(|&x| {
                    let (left, right) = (m_l * (x + c_l), m_r * (x - c_r));
                    if x == lo {
                        left
                    } else if x == hi {
                        right
                    } else if left > right && rng.gen_bool(0.3) {
                        // Inside a play's band (a point a switching term left off its branch).
                        right + rng.gen_range(0.0..1.0) * (left - right)
                    } else if rng.gen_bool(0.5) {
                        left
                    } else {
                        right
                    }
                })
                .collect();
            let range = |v: &[f64]| {
                v.iter()
                    .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &x| {
                        (a.min(x), b.max(x))
                    })
            };
            let b = two_branch_scale_prior(range(&xs), range(&ys)).unwrap();
            let truth = [m_l, c_l, m_r, c_r];
            for (i, (p, t)) in b.iter().zip(truth).enumerate() {
                assert!(
                    p.contains(t),
                    "parameter {i}: {t} not in {p:?} (truth {truth:?})"
                );
            }
        }
    }
}
