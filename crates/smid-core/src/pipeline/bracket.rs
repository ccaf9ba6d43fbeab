//! The noise-bound bracket of `noise.estimate`: the bar's verdict, the bracket's start at
//! the classical estimate, its doubling, probes and narrowing ([`Bracket`], [`Started`],
//! [`Coarse`]), and the identification at the bound it keeps ([`identify_at_estimate`]).
use super::*;
use crate::cells;
use crate::error::{Result, SmidError};
use crate::model::BoundSource;
use crate::outcome::{Falsification, Outcome};
use crate::settings::Check;
use crate::spec::Spec;
/// [`identify`] of a model whose noise bound is estimated (`noise.estimate`), asked only
/// whether it clears `bar`: the bound it would be identified with must not exceed `bar`.
/// `bar` itself is tested, by the cheap classical test before the classical estimate and by
/// the stage-3 method's verdict before the bracket's doubling ([`bracket_below`]); when either
/// proves the data inconsistent there, the answer is [`BelowBar::Above`] (the bound an
/// estimate reports is one the method accepts, and a relaxation that rejects a bound rejects
/// every smaller one) and the bracket is not run: for a candidate that cannot be kept, one
/// verdict instead of the bracket's five to ten (a model whose estimate is refused or
/// falsified reads so, as the method is not asked then). Otherwise the identification is
/// [`identify`]'s, to the digit as long as the method's verdict is monotone in the bound (the
/// bar's verdict is one more, and a step of the bracket at or above a bar the method accepts,
/// with the same cells, is answered by it). Without a bar (or a bar that is
/// not a positive number), and for a spec with a declared bound, it is [`identify`]. With
/// `noise.from: free_run` the bar is asked of the relaxation's bound, and the bound the model
/// is then identified with may lie above it (the free run's raise, [`identify_at_estimate`]):
/// a caller compares the identified set's own `delta`.
pub fn identify_below(spec: &Spec, data: ExperimentData, bar: Option<f64>) -> Result<BelowBar> {
    match bar.filter(|b| b.is_finite() && *b > 0.0) {
        Some(b) if spec.noise.to_estimate() => {
            identify_estimated(spec, &data, &[], &|_| {}, Some(b))
        }
        _ => identify(spec, data, &[]).map(BelowBar::Identified),
    }
}

/// The training data are inconsistent at `bar`, proven by `test` (the classical test or the
/// stage-3 method; `detail`: what it proved, with the first offending sample where the method
/// names one): the model's estimated bound would exceed the bar, so it is not bracketed
/// further. One finding, carried unchanged from the bracket ([`Bracket::Above`]) through
/// [`BelowBar::Above`] to the diagnosis's verdict.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct AboveBar {
    /// The noise bound at which the data were proven inconsistent.
    pub bar: f64,
    /// Which test proved it (the classical test, or the stage-3 method by name).
    pub test: String,
    /// What the test proved, with the first offending sample where it names one.
    pub detail: String,
}

/// What [`identify_below`] found.
#[derive(Debug)]
// Returned once per candidate and matched at once: boxing the identification buys nothing.
#[allow(clippy::large_enum_variant)]
pub enum BelowBar {
    /// The training data are inconsistent at the bar.
    Above(AboveBar),
    /// Not falsified at the bar: [`identify`]'s answer.
    Identified(Outcome<Identification>),
}

/// What the bracket of an estimated noise bound found, before any identification
/// ([`bracket_below`]).
#[derive(Debug, Clone)]
pub enum Bracket {
    /// The training data are inconsistent at the bar.
    Above(AboveBar),
    /// The data are inconsistent at every bound tried.
    Falsified(Falsification),
    /// The bound the model is identified with ([`identify_at_estimate`]): the margin times the
    /// smallest bound the stage-3 method accepts (to 5 %).
    At(f64),
    /// Not doubled yet ([`bracket_start`]): the classical estimate, below which no bound
    /// can be kept; [`Started::double`] asks the method.
    Started(Started),
    /// Not narrowed yet ([`Started::double`]): the method finds the data inconsistent at `lo`
    /// and consistent at `hi`; [`Coarse::narrow`] gives the bound [`Bracket::At`] would hold.
    Coarse(Coarse),
}

/// A bracket before its doubling: `first`, the bound the classical test estimates
/// ([`estimate_bound`], with the margin), where the doubling starts. Every bound the bracket
/// can keep is at least `first` (it is `first` itself when the method accepts it, else the
/// margin times a bound above it).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Started {
    /// The classical test's estimate with the margin: where the doubling starts.
    pub first: f64,
    /// The estimate's margin (`noise.estimate`, `>= 1`).
    pub margin: f64,
    /// The bar the classical test did not falsify, still to be asked of the method first
    /// (falsified there: [`Bracket::Above`]; consistent: a step at or above it is answered
    /// without asking where the cells are the same, [`Coarse::consistent_from`]).
    pub bar: Option<f64>,
    /// The bound [`Started::probe`] was given, and the method's answer there: `Some(true)`
    /// falsified, `Some(false)` consistent, `None` not asked (or no answer). `None`: not
    /// probed; a bracket is probed once.
    pub probed: Option<(f64, Option<bool>)>,
}

impl Started {
    /// Started at `first` with the `margin` and `bar`, not probed.
    pub fn new(first: f64, margin: f64, bar: Option<f64>) -> Started {
        Started {
            first,
            margin,
            bar,
            probed: None,
        }
    }

    /// No bound the bracket can keep is below this one: `first`, or, when a probe proved the
    /// data inconsistent at a bound `p >= first`, `margin · p` (the doubling then starts from
    /// a bound the method rejects, so it keeps the margin times a bound above `p`).
    pub fn floor(&self) -> f64 {
        match self.probed {
            Some((p, Some(true))) if p >= self.first => self.margin * p,
            _ => self.first,
        }
    }

    /// Ask the method at the one bound `at` that decides whether the bracket can keep a bound
    /// at or below `margin · at` (a diagnosis's reach), instead of doubling from `first`: the
    /// answer only raises [`Started::floor`] (falsified at `at >= first`) or is recorded, and
    /// [`Started::double`] later asks what it would have asked, so a bracket finished after a
    /// probe keeps the bound it keeps without one. At or above the bar the bar itself is asked
    /// (falsified there: [`Bracket::Above`], as the doubling would find). Not asked, and
    /// recorded as not falsified, where `at` lies below `first` or the search's cells differ
    /// between `first` and `at` (a bisected parameter whose resolution follows the bound:
    /// there a relaxation that rejects `at` need not reject every smaller bound). The floor
    /// rests on the verdicts being monotone in the bound, the premise of the bar and of
    /// `known_or_asked` too; a verdict between `first` and `at` that fails (solver trouble,
    /// which the doubling and the narrowing read as consistent) could let the finished bracket
    /// keep less than the floor.
    pub fn probe(&self, spec: &Spec, data: &ExperimentData, at: f64) -> Bracket {
        let unasked = Bracket::Started(Started {
            probed: Some((at, None)),
            ..*self
        });
        if self.probed.is_some() || at < self.first || !at.is_finite() {
            return unasked;
        }
        let asked = method_verdict(spec, data);
        if let Some(b) = self.bar.filter(|b| at >= *b) {
            return match asked(b) {
                Ok(Outcome::Falsified(f)) => Bracket::Above(AboveBar {
                    bar: b,
                    test: format!("the stage-3 method `{}`", spec.method.eiv.name()),
                    detail: f.to_string(),
                }),
                _ => unasked,
            };
        }
        let cells = cells_at(spec, data);
        let same = cells(self.first);
        if same.is_none() || cells(at) != same {
            return unasked;
        }
        let answer = match asked(at) {
            Ok(Outcome::Falsified(_)) => Some(true),
            Ok(Outcome::Consistent(())) => Some(false),
            // Solver trouble proves nothing: as if not asked.
            Err(_) => None,
        };
        Bracket::Started(Started {
            probed: Some((at, answer)),
            ..*self
        })
    }

    /// Double from `first` until the method finds the data consistent: [`Bracket::At`] when it
    /// does at `first`, else [`Bracket::Coarse`] (inconsistent at the last bound doubled,
    /// consistent at twice it); [`Bracket::Falsified`] when no bound up to 2^40 `first` is.
    pub fn double(&self, spec: &Spec, data: &ExperimentData) -> Bracket {
        let asked = method_verdict(spec, data);
        let mut consistent_from = f64::INFINITY;
        if let Some(b) = self.bar {
            // A verdict that failed (solver trouble) proves nothing: the bracket goes on as it
            // would without a bar, and reports such trouble itself.
            match asked(b) {
                Ok(Outcome::Falsified(f)) => {
                    return Bracket::Above(AboveBar {
                        bar: b,
                        test: format!("the stage-3 method `{}`", spec.method.eiv.name()),
                        detail: f.to_string(),
                    })
                }
                Ok(Outcome::Consistent(())) => consistent_from = b,
                Err(_) => {}
            }
        }
        let verdict = known_or_asked(spec, data, consistent_from, asked);
        let first = self.first;
        let mut lo = first;
        let mut hi = first;
        let mut found = false;
        for _ in 0..40 {
            match verdict(hi) {
                Ok(Outcome::Falsified(_)) => {
                    lo = hi;
                    hi *= 2.0;
                }
                _ => {
                    found = true;
                    break;
                }
            }
        }
        if !found {
            return Bracket::Falsified(Falsification::new(crate::error::Stage::Linear, 0, format!(
                "the stage-3 method `{}` finds the training data inconsistent up to a noise bound of {hi:.3e}",
                spec.method.eiv.name()
            )));
        }
        if hi > first {
            // Inconsistent at lo, an answer at hi: narrowed to 5 % (now or when a diagnosis
            // needs it), then identified at the margin above its upper end: the margin times
            // the smallest bound the method accepts (to 5 %), as `noise.estimate` promises.
            return Bracket::Coarse(Coarse {
                lo,
                hi,
                margin: self.margin,
                consistent_from,
            });
        }
        Bracket::At(hi)
    }
}

/// A bracket before its narrowing: the stage-3 method proves the training data inconsistent at
/// `lo` and finds them consistent at `hi` (`lo < hi <= 2 lo`). The bound the narrowing keeps is
/// `margin` times a bound in `(lo, hi]`, so it lies in `(margin · lo, margin · hi]`
/// ([`Coarse::floor`], [`Coarse::ceiling`]): a diagnosis can rank a candidate by these ends and
/// narrow only the brackets whose place in the rule's order they leave open.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Coarse {
    /// A bound at which the method proves the training data inconsistent.
    pub lo: f64,
    /// A bound at which the method finds them consistent (`lo < hi <= 2 lo`).
    pub hi: f64,
    /// The estimate's margin (`noise.estimate`, `>= 1`).
    pub margin: f64,
    /// The method found the data consistent here already (the bar's verdict; `+∞` when
    /// none): a narrowing step at or above it, with the same cells, is consistent without
    /// asking (`known_or_asked`).
    pub consistent_from: f64,
}

impl Coarse {
    /// Every bound the narrowing can keep is above this one.
    pub fn floor(&self) -> f64 {
        self.lo * self.margin
    }
    /// No bound the narrowing keeps is above this one.
    pub fn ceiling(&self) -> f64 {
        self.hi * self.margin
    }
    /// Narrow `(lo, hi]` geometrically to 5 % with the method's verdicts on `spec` and `data`
    /// (as [`bracket_below`] does), and keep the margin times its upper end.
    pub fn narrow(&self, spec: &Spec, data: &ExperimentData) -> f64 {
        let verdict = known_or_asked(spec, data, self.consistent_from, method_verdict(spec, data));
        let (mut lo, mut hi) = (self.lo, self.hi);
        // (Ends that are not finite and positive are kept as they are; a product that
        // overflows takes the geometric mean another way.)
        while hi / lo > 1.05 && hi.is_finite() && lo > 0.0 {
            let mid = match (lo * hi).sqrt() {
                m if m.is_finite() => m,
                _ => lo * (hi / lo).sqrt(),
            };
            match verdict(mid) {
                Ok(Outcome::Falsified(_)) => lo = mid,
                _ => hi = mid,
            }
        }
        hi * self.margin
    }
}

impl Bracket {
    /// The bound to identify at, when there is one.
    pub fn bound(&self) -> Option<f64> {
        match self {
            Bracket::At(d) => Some(*d),
            _ => None,
        }
    }
    /// One step further: a started bracket doubled, a coarse one narrowed; the others as they
    /// are.
    pub fn advanced(self, spec: &Spec, data: &ExperimentData) -> Bracket {
        match self {
            Bracket::Started(s) => s.double(spec, data),
            Bracket::Coarse(c) => Bracket::At(c.narrow(spec, data)),
            b => b,
        }
    }
    /// The bracket finished: doubled and narrowed to 5 % ([`Bracket::At`], or a finding).
    pub fn narrowed(self, spec: &Spec, data: &ExperimentData) -> Bracket {
        let mut b = self;
        while matches!(b, Bracket::Started(_) | Bracket::Coarse(_)) {
            b = b.advanced(spec, data);
        }
        b
    }
    /// No bound the bracket can keep is below this one (`None`: it keeps none).
    pub fn floor(&self) -> Option<f64> {
        match self {
            Bracket::At(d) => Some(*d),
            Bracket::Started(s) => Some(s.floor()),
            Bracket::Coarse(c) => Some(c.floor()),
            Bracket::Above(_) | Bracket::Falsified(_) => None,
        }
    }
    /// No bound the bracket can keep is above this one (`+∞` before the doubling; `None`: it
    /// keeps none).
    pub fn ceiling(&self) -> Option<f64> {
        match self {
            Bracket::At(d) => Some(*d),
            Bracket::Started(_) => Some(f64::INFINITY),
            Bracket::Coarse(c) => Some(c.ceiling()),
            Bracket::Above(_) | Bracket::Falsified(_) => None,
        }
    }
}

/// Identification at an estimated noise bound (`noise.estimate`): [`bracket_below`], then
/// [`identify_at_estimate`] at the bound it kept.
pub(super) fn identify_estimated(
    spec: &Spec,
    data: &ExperimentData,
    truth: &[(String, f64)],
    progress: &(dyn Fn(&cells::Progress) + Sync),
    bar: Option<f64>,
) -> Result<BelowBar> {
    let bracket = bracket_below(spec, data, bar)?;
    identify_bracketed(spec, data, bracket, truth, progress)
}

/// What a [`bracket_below`] leads to: its finding, or the identification at the bound it kept
/// ([`identify_at_estimate`]).
pub fn identify_bracketed(
    spec: &Spec,
    data: &ExperimentData,
    bracket: Bracket,
    truth: &[(String, f64)],
    progress: &(dyn Fn(&cells::Progress) + Sync),
) -> Result<BelowBar> {
    Ok(match bracket.narrowed(spec, data) {
        Bracket::Above(above) => BelowBar::Above(above),
        Bracket::Falsified(f) => BelowBar::Identified(Outcome::Falsified(f)),
        Bracket::At(d) => {
            BelowBar::Identified(identify_at_estimate(spec, data, d, truth, progress)?)
        }
        // `narrowed` advances until the bracket is none of these.
        Bracket::Started(_) | Bracket::Coarse(_) => {
            unreachable!("a narrowed bracket is finished")
        }
    })
}

/// How many times `noise.from: free_run` brings a raised bound down to its member's distance.
const TIGHTEN_STEPS: usize = 2;

/// The margin of `noise.estimate` (at least 1.01, so a bracket's upper end is raised).
fn estimate_margin(spec: &Spec) -> f64 {
    spec.noise.estimate.unwrap_or(1.1).max(1.01)
}

/// Logs one step of an estimate at bound `d` (`answer`: what a consistent outcome is called).
fn log_step<T>(label: &str, d: f64, answer: &str, r: &Result<Outcome<T>>, t0: std::time::Instant) {
    log::info!(target: "smid::estimate", "{label}: noise bound {d:.4e}: {} ({:.2} s)", match r {
        Ok(Outcome::Consistent(_)) => answer.to_string(),
        Ok(Outcome::Falsified(f)) => format!("falsified: {f}").chars().take(60).collect(),
        Err(e) => e.to_string().chars().take(60).collect(),
    }, t0.elapsed().as_secs_f64());
}

/// The stage-3 method's verdict at a noise bound `d` on `spec` and `data` (the spec's declared
/// bound, if any, is replaced by `d`), logged: whether the method finds the data consistent.
/// The search stops at the first cell with bounds (the same verdict, a fraction of the cells
/// finished) and searches no member: a bracket's steps ask nothing more.
fn method_verdict<'a>(
    spec: &Spec,
    data: &'a ExperimentData,
) -> impl Fn(f64) -> Result<Outcome<()>> + 'a {
    // Log lines name their model: a diagnosis brackets its candidates side by side.
    let label = spec.model.label();
    // Each verdict sets its own bound.
    let mut quiet = with_bound(spec, 1.0);
    quiet.method.member.search = false;
    move |d: f64| {
        let t0 = std::time::Instant::now();
        let r = consistent_by_method(&with_bound(&quiet, d), data_with_bound(data, d));
        log_step(&label, d, "consistent", &r, t0);
        r
    }
}

/// The resolution of the search's cells at a noise bound `d` on `spec` and `data` (`None`
/// without a layout): two bounds with the same resolution search the same cells, where a
/// verdict at one implies the other's ([`known_or_asked`], [`Started::probe`]).
fn cells_at<'a>(spec: &'a Spec, data: &ExperimentData) -> impl Fn(f64) -> Option<Vec<f64>> + 'a {
    let scale = data_scale(data);
    let layout = spec.model.layout().ok();
    move |d: f64| {
        layout.as_ref().map(|l| {
            resolution(
                &spec.model,
                l,
                spec.method.cells.nonlinearity_halvings,
                d,
                &scale,
            )
        })
    }
}

/// `verdict` on `spec` and `data`, answered "consistent" without asking at a bound at or above
/// `consistent_from`, where the method already found the data consistent: a relaxation that
/// rejects a bound rejects every smaller one (the premise of the bar, [`bracket_below`]), so it
/// accepts every larger one. That holds where the search's cells are the same at both bounds;
/// where a bisected parameter's resolution follows the bound (a sensor offset's 0.5Δ, a
/// bias's), the search trees may differ and the verdict is asked (unlike [`estimate_bound`],
/// this does not compare the searches' cells). A bracket then asks the same questions less
/// often and keeps the same ends.
fn known_or_asked<'a>(
    spec: &'a Spec,
    data: &'a ExperimentData,
    consistent_from: f64,
    verdict: impl Fn(f64) -> Result<Outcome<()>> + 'a,
) -> impl Fn(f64) -> Result<Outcome<()>> + 'a {
    let label = spec.model.label();
    let cells_at = cells_at(spec, data);
    let from = cells_at(consistent_from);
    move |d: f64| {
        if consistent_from.is_finite()
            && d >= consistent_from
            && from.is_some()
            && cells_at(d) == from
        {
            log::info!(target: "smid::estimate", "{label}: noise bound {d:.4e}: consistent (not asked: at or above {consistent_from:.4e}, where the method found it so)");
            return Ok(Outcome::Consistent(()));
        }
        verdict(d)
    }
}

/// The bracket of an estimated noise bound (`noise.estimate`; the spec's declared bound, if
/// any, is ignored), without identifying. With a `bar` (a positive number), the bar is tested
/// first by the classical test, and after the classical estimate by the method's verdict; when
/// either proves the data inconsistent there, the answer is [`Bracket::Above`] (the bound a
/// bracket reports is one the method accepts, and a relaxation that rejects a bound rejects
/// every smaller one) and the bracket is not run (a refused or falsified estimate is answered
/// as such, before the method is asked). The bracket's first try is at the smallest bound the
/// cheap classical test finds consistent ([`estimate_bound`]). A tighter stage-3 method can prove
/// the data inconsistent there: the bound is then doubled until the method finds them
/// consistent, the bracket narrowed geometrically to 5 %, and the bound kept is the margin
/// times its upper end. The steps ask for the method's verdict alone
/// ([`consistent_by_method`]: the search stops at the first cell with bounds).
pub fn bracket_below(spec: &Spec, data: &ExperimentData, bar: Option<f64>) -> Result<Bracket> {
    Ok(bracket_start(spec, data, bar)?.narrowed(spec, data))
}

/// [`bracket_below`] up to its doubling: the classical test's finding at the bar, the
/// classical estimate's findings, or that estimate as [`Bracket::Started`] (the method's
/// verdict at the bar still to ask), for [`Bracket::advanced`] to take on when needed.
pub fn bracket_start(spec: &Spec, data: &ExperimentData, bar: Option<f64>) -> Result<Bracket> {
    let bar = bar.filter(|b| b.is_finite() && *b > 0.0);
    let margin = estimate_margin(spec);
    let label = spec.model.label();
    // The bar's cheap test first: when the classical test proves the data inconsistent at
    // it, the bound the bracket would reach lies above it; nothing else is asked.
    if let Some(b) = bar {
        if !consistent_at(spec, data, b)? {
            log::info!(target: "smid::estimate", "{label}: noise bound {b:.4e} (the bar): falsified by the classical test");
            return Ok(Bracket::Above(AboveBar {
                bar: b,
                test: "the classical test".into(),
                detail: "no θ fits the equations of any cell (classical outer sets empty)".into(),
            }));
        }
    }
    // Then the classical estimate, and the method's verdict at the bar only with the doubling
    // ([`Started::double`]): a candidate whose estimate is refused, or whose estimate already
    // puts it out of the rule's reach, is not asked it (for a bisected input-side
    // block on a long measured record that verdict is expensive).
    Ok(match estimate_bound(spec, data)? {
        Outcome::Consistent(first) => Bracket::Started(Started::new(first, margin, bar)),
        Outcome::Falsified(f) => Bracket::Falsified(f),
    })
}

/// The identification of a model whose noise bound is estimated, at the bound `d` its
/// [`bracket_below`] kept: the model set at `d` (without the member search), then its
/// simulation member with the spec's own member options. When the method's start set is
/// unbounded at `d`, the error says what bounds it (a stable block, a prior, or the classical
/// method at its own smaller bound).
pub fn identify_at_estimate(
    spec: &Spec,
    data: &ExperimentData,
    d: f64,
    truth: &[(String, f64)],
    progress: &(dyn Fn(&cells::Progress) + Sync),
) -> Result<Outcome<Identification>> {
    let margin = estimate_margin(spec);
    let label = spec.model.label();
    let mut quiet = with_bound(spec, d);
    quiet.method.member.search = false;
    // `noise.from: free_run` asks the set at `d` only for the simulator that raises the bound:
    // the set of the method's start (wider, as guaranteed) gives its search box, and the
    // method's own set at `d` is identified only where the bound stays at `d`.
    let screen = super::search::screen_of(&quiet.method).filter(|_| spec.noise.from_free_run());
    let mut probe = with_bound(spec, d);
    probe.method = screen.clone().unwrap_or_else(|| quiet.method.clone());
    let t0 = std::time::Instant::now();
    let mut best = identify_with(&probe, data_with_bound(data, d), truth, progress);
    log_step(&label, d, "an answer", &best, t0);
    // `noise.from: free_run`: the bound is raised to the margin times the free-run distance
    // from the training records of the best simulator over the set's outer bounds, where that
    // is larger, and the set taken there (the simulator seeds its member search: a point of
    // the set at that bound).
    let raised = match best.as_ref() {
        Ok(Outcome::Consistent(id)) if spec.noise.from_free_run() => {
            let found = crate::members::best_free_run(&id.model, &spec.method.member.check()?)?
                .and_then(|m| m.within.map(|w| (w, m.values)))
                .filter(|(w, _)| w.is_finite());
            if found.is_none() {
                log::warn!(target: "smid::estimate", "{label}: noise.from: free_run found no simulator whose free-run distance bounds the model (steady-state points, no finite run, or none in the model class): the bound stays the relaxation's, {d:.4e}");
            }
            found.filter(|(w, _)| margin * w > d)
        }
        _ => None,
    };
    if raised.is_none() && screen.is_some() {
        let t0 = std::time::Instant::now();
        best = identify_with(&quiet, data_with_bound(data, d), truth, progress);
        log_step(&label, d, "an answer by the method", &best, t0);
    }
    if let (None, Ok(Outcome::Consistent(id))) = (&raised, best.as_mut()) {
        id.model.method.member = spec.method.member;
        id.model.simulation_member =
            crate::members::simulation_member(&id.model, &spec.method.member.check()?)?;
    }
    let raised_to = raised.as_ref().map(|(w, _)| margin * w);
    if let Some((within, seed)) = raised {
        let d2 = margin * within;
        log::info!(target: "smid::estimate", "{label}: the best simulator at {d:.4e} runs within {within:.4e} of the training records: the bound is raised to {d2:.4e} (noise.from: free_run)");
        let mut quiet = with_bound(spec, d2);
        quiet.method.member.search = false;
        let t0 = std::time::Instant::now();
        best = identify_with(&quiet, data_with_bound(data, d2), truth, progress);
        log_step(&label, d2, "an answer", &best, t0);
        if let Ok(Outcome::Falsified(f)) = &best {
            // A relaxation that accepts a bound accepts every larger one: this is a finding
            // about the method, reported as the outcome, and said here.
            log::warn!(target: "smid::estimate", "{label}: the raised bound {d2:.4e} (noise.from: free_run) is falsified where {d:.4e} was not: {f}");
        }
        if let Ok(Outcome::Consistent(id)) = best.as_mut() {
            id.model.method.member = spec.method.member;
            id.model.simulation_member = crate::members::simulation_member_seeded(
                &id.model,
                &spec.method.member.check()?,
                &[seed],
            )?;
        }
        // The member found there may run nearer the records than the simulator it started
        // from (it is the best free run of a wider set): the bound comes down to the margin
        // times its distance while that takes off a tenth, at most twice, the member seeding
        // the search again (the set at that bound holds it). A step the method does not
        // answer keeps the set before it.
        let mut current = d2;
        for _ in 0..TIGHTEN_STEPS {
            let Ok(Outcome::Consistent(id)) = &best else {
                break;
            };
            let Some((w, member)) = id
                .model
                .simulation_member
                .as_ref()
                .filter(|m| m.certified)
                .and_then(|m| m.within.map(|w| (w, m.values.clone())))
            else {
                break;
            };
            // Never below the relaxation's (a sound relaxation cannot falsify a bound that holds
            // a member; kept explicit).
            let d3 = (margin * w).max(d);
            if !(w.is_finite() && d3 < 0.9 * current) {
                break;
            }
            log::info!(target: "smid::estimate", "{label}: the member at {current:.4e} runs within {w:.4e}: the bound comes down to {d3:.4e} (noise.from: free_run)");
            let mut quiet = with_bound(spec, d3);
            quiet.method.member.search = false;
            let t0 = std::time::Instant::now();
            let mut next = identify_with(&quiet, data_with_bound(data, d3), truth, progress);
            log_step(&label, d3, "an answer", &next, t0);
            match next.as_mut() {
                Ok(Outcome::Consistent(id)) => {
                    id.model.method.member = spec.method.member;
                    id.model.simulation_member = crate::members::simulation_member_seeded(
                        &id.model,
                        &spec.method.member.check()?,
                        &[member],
                    )?;
                    best = next;
                    current = d3;
                }
                _ => {
                    log::warn!(target: "smid::estimate", "{label}: no answer at {d3:.4e}, where the member at {current:.4e} runs: the set at {current:.4e} is kept");
                    break;
                }
            }
        }
    }
    // The free run's label where it raised the bound; else the bound is the relaxation's
    // estimate (no simulator, or one within it), labelled so by `identify_with`.
    if let Ok(Outcome::Consistent(id)) = best.as_mut() {
        if raised_to.is_some() && id.model.delta > d {
            id.model.bound_source = BoundSource::FreeRun;
        }
    }
    best.map_err(|e| match e {
        SmidError::Unbounded { parameter, message } if raised_to.is_some() => SmidError::Unbounded {
            parameter,
            message: format!(
                "{message}. The bound was raised from {d:.4e} (the smallest the method `{}` finds consistent, within the margin {margin}) to {:.4e}, the margin times the best training simulator's free-run distance (`noise.from: free_run`), and at that bound the data do not bound the set: estimate the bound from the relaxation instead (`noise.from: relaxation`, the default), or give it (`noise.delta`)",
                spec.method.eiv.name(),
                raised_to.unwrap_or(f64::NAN),
            ),
        },
        SmidError::Unbounded { parameter, message } if !spec.model.stable => SmidError::Unbounded {
            parameter,
            message: format!(
                "{message}. At the estimated noise bound {d:.4e} (the smallest the method `{}` finds consistent, within the margin {margin}) its start set is unbounded: declare `model.stable: true` if the linear block is stable (each a_i is then bounded by the binomial C(na, i)), give `model.prior` bounds for the a_i, or choose `method.eiv: classical`",
                spec.method.eiv.name()
            ),
        },
        e => e,
    })
}
