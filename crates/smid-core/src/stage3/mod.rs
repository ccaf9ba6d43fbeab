//! Stage 3 (paper Section 5): guaranteed bounds on the linear-block parameters
//! `θ = [a_1..a_na, b_0..b_nb, c_1..c_m]` (eq 7, extended by the coefficients of extra
//! regressors) from interval-valued inner signals, an errors-in-variables problem. Each equation
//! `x_t + Σ a_i x_{t-i} - Σ b_j v_{t-j} - Σ c_k φ_k(t) = 0` (eq 1 with additive effect terms
//! `φ_k`: offset, drift, friction...) holds for the true signals, known only as intervals
//! `x_s = x^c_s + δx_s`, `|δx_s| <= Δx_s` (eqs 28-30; output side), `v_s` (input side; exact for
//! Wiener) and `φ_k(s)` (exact or uncertain). The unit steady-state gain (eq 8) is
//! `Σ b_j - Σ a_i = 1` (the extras do not enter it). An optional prior box on θ is intersected
//! with every method's start.
//!
//! This module holds the problem and result types ([`EivProblem`], [`EivResult`]), the method
//! trait ([`Stage3Method`]), the method names ([`EivMethod`], used by specs) and the open,
//! link-time registry ([`register_stage3!`](crate::register_stage3), [`method`], [`by_name`],
//! [`all`], [`names`], [`configured`] for a spec's `method.options`, [`solve`]). Each method
//! lives in its own file, names and registers itself there, and imports only this module and
//! the shared pieces (`relax`):
//!
//! | method | file | starts from |
//! |---|---|---|
//! | `classical` | [`classical`]: orthant-wise LP outer set (Cerone 1993) | the problem |
//! | `shared` (default) | [`shared`]: shared-error McCormick relaxation, iterated | `classical` |
//! | `sdp` | [`sdp`]: moment relaxation (feature `sdp`) | `shared` |
//! | `exact-grid` | [`exact_grid`]: exact-set reference on a grid of the a-plane | `shared` |
//!
//! A method that starts from another one names it in [`Stage3Method::start`]; the chaining goes
//! through the registry ([`Stage3Method::solve`]), so no method file imports another.
use crate::error::{Result, SmidError, Stage};
use crate::interval::Interval;
use crate::inversion::{InnerBound, InnerKind};
use serde::{Deserialize, Serialize};
use std::ops::Range;

pub mod classical;
pub mod exact_grid;
pub(crate) mod ipm;
pub(crate) mod relax;
pub mod sdp;
pub mod shared;
#[cfg(test)]
pub(crate) mod testutil;
pub(crate) mod working_set;

/// The EIV problem of stage 3.
#[derive(Debug, Clone)]
pub struct EivProblem<'a> {
    /// Order of `A`.
    pub na: usize,
    /// Order of `B` (coefficients `b_0..b_nb`).
    pub nb: usize,
    /// Fixed values per parameter in θ order, one per θ entry, extras included (`None` = free).
    pub fixed: Vec<Option<f64>>,
    /// Impose the unit steady-state gain (eq 8).
    pub unit_gain: bool,
    /// Output-side inner-signal bounds `x_t`.
    pub output: &'a [InnerBound],
    /// Input-side signal bounds `v_t` (exact for Wiener: degenerate intervals).
    pub input: &'a [Interval],
    /// Also use equations whose samples are only band-bounded (wide but valid). The rows of
    /// [`one_sided_times`](Self::one_sided_times) take their one-sided samples whatever their
    /// kind (a plugin marks a half-line `Band`): the flag governs the finite samples only.
    pub use_band_samples: bool,
    /// When the data are inconsistent, name the first offending equation (a bisection on
    /// prefixes of the record: about `log2 N` more LPs). `false` for a verdict that only needs
    /// to know *whether* they are (a noise-bound bracket): the error then names the last
    /// equation, marked not located ([`SmidError::inconsistent_unlocated`]).
    pub locate: bool,
    /// Extra regressors: θ gains one coefficient c_k per column, appended after b_nb.
    pub extra: &'a [Regressor],
    /// Optional prior box on θ (all coefficients, in θ order incl. extras); None = unbounded.
    pub prior: Option<&'a [Interval]>,
    /// The signal the autoregressive part reads (`model.feedback`: the chain's output `w_t`,
    /// bounded from the measurements), one interval per sample, indexed as `output`; a
    /// non-finite one is unknown. `None`: the inner output itself (eq 1). With it the equation
    /// is `x_t + Σ a_i w_{t-i} = Σ b_j v_{t-j} + Σ c_k φ_k(t)`. The methods solve it as the
    /// problem with the lagged samples in the input's place ([`EivProblem::flattened`], applied
    /// by [`Stage3Method::solve`]; `exact-grid` refuses that uncertain input), and
    /// [`EivProblem::validate`] refuses it unflattened. The exact LPs at fixed θ
    /// (`exact_grid::consistency_at`) and the one-step band read it as it is.
    pub lagged: Option<&'a [Interval]>,
}

/// An extra regressor column `φ_k` of the linear block (an additive effect such as an offset,
/// a drift or friction): each equation gains the term `- c_k φ_k(t)`.
#[derive(Debug, Clone, PartialEq)]
pub struct Regressor {
    /// The name of its coefficient `c_k` in θ (and in reports and errors).
    pub name: String,
    /// `φ_k(t)`, one interval per sample (same indexing as `output`/`input`). Exact values are
    /// degenerate intervals; a non-finite interval means "unknown here" and excludes the
    /// equation at that sample.
    pub values: Vec<Interval>,
}

/// Stage-3 result: one guaranteed interval per parameter, and the equations used.
#[derive(Debug, Clone)]
pub struct EivResult {
    /// One interval per θ entry, in the order of [`EivProblem::names`].
    pub bounds: Vec<Interval>,
    /// Time indices `t` of the equations used.
    pub equations: Vec<usize>,
    /// Number of sign orthants whose LP was feasible.
    pub feasible_orthants: usize,
    /// `Some(g)` when a method that shrinks the box in rounds (`shared`, `sdp`) stopped at its
    /// round cap before they settled, its last round shrinking a radius by the fraction `g`:
    /// the bounds hold, but more rounds would tighten them, and the set may be far smaller or
    /// empty. `None` when the rounds settled or the method has none.
    pub unsettled: Option<f64>,
}

/// The prior box of a **stable** linear block over `p` θ entries (`a1..a_na` first): a stable
/// `A(q) = Π (1 - r_j q⁻¹)`, every `|r_j| <= 1`, has `|a_i| <= C(na, i)`; the other entries
/// are free.
pub fn stable_prior(na: usize, p: usize) -> Vec<Interval> {
    let mut out = vec![Interval::entire(); p.max(na)];
    let mut binom = 1.0f64;
    for i in 1..=na {
        binom = binom * (na + 1 - i) as f64 / i as f64;
        out[i - 1] = Interval::new(-binom, binom);
    }
    out
}

/// Parameter names in θ order: `a1..a_na, b0..b_nb` (without the extras' coefficients).
pub fn theta_names(na: usize, nb: usize) -> Vec<String> {
    (1..=na)
        .map(|i| format!("a{i}"))
        .chain((0..=nb).map(|j| format!("b{j}")))
        .collect()
}

impl EivProblem<'_> {
    /// The finding of a method whose equations `times` are proven inconsistent: with
    /// [`Self::locate`], at the first equation whose addition empties the set (bisection on
    /// prefixes, `feasible` deciding each prefix); otherwise, or when a prefix's LP fails (the
    /// emptiness is proven already, so the verdict never depends on `locate`), at the last
    /// equation, marked not located. `message(t)` says what is empty up to `t`.
    pub(crate) fn emptied(
        &self,
        times: &[usize],
        mut feasible: impl FnMut(&[usize]) -> Result<bool>,
        message: impl Fn(usize) -> String,
    ) -> Result<SmidError> {
        // No equation at all (the prior box and the unit gain alone are empty): sample 0.
        let at = |n: usize| times.get(n.saturating_sub(1)).copied().unwrap_or(0);
        let (mut good, mut bad) = (0usize, times.len());
        while self.locate && bad - good > 1 {
            let mid = (good + bad) / 2;
            match feasible(&times[..mid]) {
                Ok(true) => good = mid,
                Ok(false) => bad = mid,
                Err(SmidError::Solver(_)) => {
                    let t = at(times.len());
                    return Ok(SmidError::inconsistent_unlocated(
                        Stage::Linear,
                        t,
                        message(t),
                    ));
                }
                Err(e) => return Err(e),
            }
        }
        let t = at(bad);
        Ok(if self.locate {
            SmidError::inconsistent(Stage::Linear, t, message(t))
        } else {
            SmidError::inconsistent_unlocated(Stage::Linear, t, message(t))
        })
    }

    /// Number of `a`'s and `b`'s (`na + nb + 1`): the θ index of the first extra coefficient.
    pub fn n_ab(&self) -> usize {
        self.na + self.nb + 1
    }

    /// Number of θ entries (`a`'s, `b`'s and one coefficient per extra regressor).
    pub fn p(&self) -> usize {
        self.n_ab() + self.extra.len()
    }

    /// Parameter names in θ order: `a1..a_na, b0..b_nb`, then each regressor's name.
    pub fn names(&self) -> Vec<String> {
        let mut names = theta_names(self.na, self.nb);
        names.extend(self.extra.iter().map(|r| r.name.clone()));
        names
    }

    /// The name of θ entry `k`.
    pub fn name(&self, k: usize) -> String {
        match k.checked_sub(self.n_ab()) {
            None => theta_names(self.na, self.nb)[k].clone(),
            Some(e) => self
                .extra
                .get(e)
                .map_or_else(|| format!("θ[{k}]"), |r| r.name.clone()),
        }
    }

    /// The coefficient of θ entry `k` in the unit-gain constraint `Σ b_j - Σ a_i = 1` (eq 8):
    /// -1 for an `a`, +1 for a `b`, 0 for an extra coefficient.
    pub fn gain_sign(&self, k: usize) -> f64 {
        if k < self.na {
            -1.0
        } else if k < self.n_ab() {
            1.0
        } else {
            0.0
        }
    }

    fn usable(&self, b: &InnerBound) -> bool {
        b.interval.is_finite()
            && (b.kind == InnerKind::Inverted
                || (self.use_band_samples && b.kind == InnerKind::Band))
    }

    /// Time indices whose equation involves only usable samples (every extra regressor's value
    /// at `t` finite, too).
    pub fn equation_times(&self) -> Vec<usize> {
        self.times_where(|t| self.outputs_usable_at(t))
    }

    /// The times an equation can be written at: from the first (`max(na, nb)`) to the end of
    /// the shortest signal.
    fn equation_range(&self) -> Range<usize> {
        let n = self
            .extra
            .iter()
            .map(|r| r.values.len())
            .fold(self.output.len().min(self.input.len()), usize::min);
        self.na.max(self.nb)..n
    }

    /// Every output sample of the equation at `t` usable: `x_t` and its past (eq 1), or `x_t`
    /// and the past outputs known ([`lagged`](Self::lagged)).
    fn outputs_usable_at(&self, t: usize) -> bool {
        match self.lagged {
            None => (0..=self.na).all(|i| self.usable(&self.output[t - i])),
            Some(w) => self.usable(&self.output[t]) && (1..=self.na).all(|i| w[t - i].is_finite()),
        }
    }

    /// Every input sample of the equation at `t` known.
    fn inputs_known_at(&self, t: usize) -> bool {
        (0..=self.nb).all(|j| self.input[t - j].is_finite())
    }

    /// The equations' times `t` (every signal long enough) whose outputs pass `outputs`, every
    /// input and extra regressor value finite.
    fn times_where(&self, outputs: impl Fn(usize) -> bool) -> Vec<usize> {
        self.equation_range()
            .filter(|&t| outputs(t))
            .filter(|&t| self.inputs_known_at(t))
            .filter(|&t| self.extra.iter().all(|r| r.values[t].is_finite()))
            .collect()
    }

    /// Why samples give no equation, for an error that says how few are left: the records'
    /// length (joined, with the gaps of unknowns between them), the samples before the first
    /// equation (`max(na, nb)`), and per signal (the inner output, the input, each extra
    /// regressor by name) at how many of the rest it is unknown or unusable, largest first.
    /// Empty parts are left out; a regressor unknown at every sample (a delay or lag longer
    /// than the record) reads "unknown or unusable at all".
    pub fn unusable_summary(&self) -> String {
        let range = self.equation_range();
        let (first, n) = (range.start, range.end);
        let rest = range.len();
        let mut parts = vec![format!(
            "the training records have {n} samples (gaps between records included), {} before the first equation (na = {}, nb = {})",
            first.min(n),
            self.na,
            self.nb
        )];
        let mut missing: Vec<(usize, String)> = Vec::new();
        let count = |bad: &dyn Fn(usize) -> bool| range.clone().filter(|&t| bad(t)).count();
        missing.push((
            count(&|t| !self.outputs_usable_at(t)),
            "the inner output".into(),
        ));
        missing.push((count(&|t| !self.inputs_known_at(t)), "the input".into()));
        for r in self.extra {
            let k = count(&|t| !r.values[t].is_finite());
            missing.push((k, format!("regressor `{}`", r.name)));
        }
        missing.sort_by_key(|m| std::cmp::Reverse(m.0));
        for (k, what) in missing.into_iter().filter(|(k, _)| *k > 0) {
            parts.push(if k == rest {
                format!("{what} is unknown or unusable at all {rest} of the rest")
            } else {
                format!("{what} is unknown or unusable at {k} of the other {rest}")
            });
        }
        parts.join("; ")
    }

    /// Time indices whose equation holds a sample known from **one side only** (exactly one
    /// endpoint finite, as a sample clipped by a saturation: `x >= s`) and otherwise only
    /// usable samples as in [`equation_times`](Self::equation_times) (one-sided ones may be
    /// several). Such an equation gives at most one half-space in θ instead of two: where the
    /// sum `x_t + Σ a_i x_{t-i} - Σ b_j v_{t-j} - Σ c_k φ_k(t)` keeps a finite end for θ of one
    /// sign pattern, `0` must lie on its side of that end. A method may use these rows or not:
    /// leaving them out only loosens its bounds.
    pub fn one_sided_times(&self) -> Vec<usize> {
        let one_sided = |b: &InnerBound| {
            b.kind != InnerKind::Unknown
                && b.interval.lo <= b.interval.hi
                && (b.interval.lo.is_finite() != b.interval.hi.is_finite())
        };
        self.times_where(|t| match self.lagged {
            None => {
                let outputs = &self.output[t - self.na..=t];
                outputs.iter().any(one_sided)
                    && outputs.iter().all(|b| self.usable(b) || one_sided(b))
            }
            Some(w) => one_sided(&self.output[t]) && (1..=self.na).all(|i| w[t - i].is_finite()),
        })
    }

    /// A problem with [`lagged`](Self::lagged) past outputs as the problem every method
    /// solves (`None` without them). The lagged signal takes the input's place, shifted by one
    /// sample (`v'_t = -w_{t-1}`, lags `0..na-1`, so its coefficients are `a_1..a_na`), and the
    /// input's lags `v_{t-j}` become exact extra columns (coefficients `b_0..b_nb`) ahead of the
    /// problem's own extras: θ keeps its order, `[a's, b's, extras]`. The lagged samples are
    /// then one uncertain variable each, shared by the `na` equations that read them, as a
    /// Hammerstein model's uncertain input is. An outer bound of the flattened problem is one
    /// of the problem: the two sets of equations are the same. Refused under the unit gain
    /// (its row reads the `a`'s by their place) and for an uncertain input (it would need a
    /// second shared signal).
    pub fn flattened(&self) -> Result<Option<Flattened>> {
        let Some(w) = self.lagged else {
            return Ok(None);
        };
        if w.len() != self.output.len() {
            return Err(SmidError::invalid(
                "lagged",
                format!(
                    "expected {} samples (as the inner output), got {}",
                    self.output.len(),
                    w.len()
                ),
            ));
        }
        let own = theta_names(self.na, self.nb);
        if let Some(r) = self.extra.iter().find(|r| own.contains(&r.name)) {
            return Err(SmidError::invalid(
                "extra.name",
                format!("`{}` must differ from {}", r.name, own.join(", ")),
            ));
        }
        if self.na == 0 {
            // No equation reads a past output.
            return Ok(Some(Flattened {
                na: 0,
                input: Vec::new(),
                extra: Vec::new(),
            }));
        }
        if self.unit_gain {
            return Err(SmidError::invalid(
                "model.feedback",
                "the unit steady-state gain (eq 8) is not taken with feedback: set `unit_gain: false`",
            ));
        }
        if let Some(t) = self
            .input
            .iter()
            .position(|v| v.is_finite() && v.radius() > 1e-9 * (1.0 + v.center().abs()))
        {
            return Err(SmidError::Unsupported {
                plugin: "model.feedback".into(),
                what: format!(
                    "an uncertain input sample (t = {t}) with the past outputs read from data (stage 3 shares one uncertain signal, here the past outputs): `model.layout` refuses the input-side blocks and the Hammerstein structure that make one"
                ),
            });
        }
        let shifted = |signal: &[Interval], lag: usize, negate: bool| -> Vec<Interval> {
            (0..signal.len())
                .map(|t| match t.checked_sub(lag) {
                    Some(s) if signal[s].is_finite() => {
                        if negate {
                            Interval::new(-signal[s].hi, -signal[s].lo)
                        } else {
                            signal[s]
                        }
                    }
                    _ => Interval::entire(),
                })
                .collect()
        };
        let mut extra: Vec<Regressor> = (0..=self.nb)
            .map(|j| Regressor {
                name: format!("input lag {j}"),
                values: shifted(self.input, j, false),
            })
            .collect();
        extra.extend(self.extra.iter().cloned());
        Ok(Some(Flattened {
            na: self.na,
            input: shifted(w, 1, true),
            extra,
        }))
    }

    /// Check the shape of the problem: one `fixed` (and `prior`) entry per θ entry, a prior of
    /// closed intervals, regressor names distinct from each other and from the `a`'s and `b`'s;
    /// no [`lagged`](Self::lagged) past outputs (those are solved flattened, and only
    /// [`Stage3Method::solve`], [`solve`] and [`feasible`] flatten: a method's own entry point
    /// refuses them here).
    pub fn validate(&self) -> Result<()> {
        if self.lagged.is_some() {
            // A method's own entry point reads the inner output's past, not these.
            return Err(SmidError::invalid(
                "lagged",
                "past outputs read from data are solved through `Stage3Method::solve` (or `stage3::solve`, `stage3::feasible`), which flattens the problem first; a method's own entry point does not read them",
            ));
        }
        let p = self.p();
        if self.fixed.len() != p {
            return Err(SmidError::invalid(
                "model.fixed",
                format!("expected {p} entries, got {}", self.fixed.len()),
            ));
        }
        let names = self.names();
        for (e, r) in self.extra.iter().enumerate() {
            let k = self.n_ab() + e;
            if r.name.is_empty() || names[..k].contains(&r.name) {
                return Err(SmidError::invalid(
                    format!("extra[{e}].name"),
                    format!(
                        "`{}` must be non-empty and differ from {}",
                        r.name,
                        names[..k].join(", ")
                    ),
                ));
            }
        }
        if let Some(prior) = self.prior {
            if prior.len() != p {
                return Err(SmidError::invalid(
                    "prior",
                    format!(
                        "expected {p} intervals ({}), got {}",
                        names.join(", "),
                        prior.len()
                    ),
                ));
            }
            if let Some(k) = prior
                .iter()
                .position(|b| b.lo.is_nan() || b.hi.is_nan() || b.lo > b.hi)
            {
                return Err(SmidError::invalid(
                    format!("prior.{}", names[k]),
                    format!("[{}, {}] is not an interval", prior[k].lo, prior[k].hi),
                ));
            }
        }
        Ok(())
    }

    /// The prior box of θ entry `k` (the whole line without a prior).
    pub fn prior_of(&self, k: usize) -> Interval {
        self.prior
            .and_then(|p| p.get(k).copied())
            .unwrap_or_else(Interval::entire)
    }

    /// The box every method starts inside: fixed entries at their values, the others their
    /// prior (the whole line without one). A fixed value outside its prior is the empty set:
    /// [`SmidError::Inconsistent`] at the first equation.
    pub fn start_box(&self) -> Result<Vec<Interval>> {
        self.validate()?;
        (0..self.p())
            .map(|k| {
                let prior = self.prior_of(k);
                match self.fixed[k] {
                    Some(v) if prior.contains(v) => Ok(Interval::new(v, v)),
                    Some(v) => Err(SmidError::inconsistent(
                        Stage::Linear,
                        self.equation_times().first().copied().unwrap_or(0),
                        format!(
                            "the fixed value {v} of `{}` is outside its prior [{}, {}]",
                            self.name(k),
                            prior.lo,
                            prior.hi
                        ),
                    )),
                    None => Ok(prior),
                }
            })
            .collect()
    }
}

/// The owned parts of a [`EivProblem::flattened`] problem.
#[derive(Debug, Clone)]
pub struct Flattened {
    na: usize,
    input: Vec<Interval>,
    extra: Vec<Regressor>,
}

impl Flattened {
    /// The flattened problem of `of` (the problem it was made from). With `na = 0` it is `of`
    /// without the lagged signal (no equation reads it).
    pub fn problem<'f>(&'f self, of: &EivProblem<'f>) -> EivProblem<'f> {
        if self.na == 0 {
            return EivProblem {
                lagged: None,
                ..of.clone()
            };
        }
        EivProblem {
            na: 0,
            nb: self.na - 1,
            input: &self.input,
            extra: &self.extra,
            lagged: None,
            ..of.clone()
        }
    }

    /// A flattened problem's error in the names of the problem it was made from: θ keeps its
    /// order, and the flattened problem calls `a_i` `b{i-1}`, `b_j` `input lag j`, and the
    /// past outputs its input. Each flattened name, as a whole parameter or quoted in a
    /// message, becomes the problem's.
    pub fn error(&self, e: SmidError, of: &EivProblem) -> SmidError {
        if self.na == 0 {
            return e;
        }
        let flat = self.problem(of).names();
        let own = of.names();
        let rename = |name: String| -> String {
            flat.iter()
                .position(|n| *n == name)
                .map_or(name, |k| own[k].clone())
        };
        // Quoted names in one pass (a placeholder per index keeps `b0` -> `a1` from being
        // renamed again as the problem's own `b0`).
        let text = |m: String| -> String {
            let mut m = m;
            for (k, n) in flat.iter().enumerate() {
                m = m.replace(&format!("`{n}`"), &format!("`\u{1}{k}\u{1}`"));
            }
            for (k, n) in own.iter().enumerate() {
                m = m.replace(&format!("`\u{1}{k}\u{1}`"), &format!("`{n}`"));
            }
            m.replace(
                "the input is",
                "the past outputs (in the input's place) are",
            )
        };
        match e {
            SmidError::Unbounded { parameter, message } => SmidError::Unbounded {
                parameter: rename(parameter),
                message: text(message),
            },
            SmidError::Invalid { field, message } => SmidError::Invalid {
                field: match field.strip_prefix("prior.") {
                    Some(name) => format!("prior.{}", rename(name.to_string())),
                    None => field,
                },
                message: text(message),
            },
            SmidError::Inconsistent(mut f) => {
                f.detail = text(f.detail);
                SmidError::Inconsistent(f)
            }
            e => e,
        }
    }
}

/// A stage-3 method by its registered name (`method.eiv` in a spec, `--method` on the command
/// line, `method` in `result.json`): one of the methods in the registry ([`all`]). The name is
/// the method's own [`Stage3Method::name`]; a value is made only from a registered name
/// ([`EivMethod::parse`], deserialisation) or one of the built-in constants below.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct EivMethod(&'static str);

#[allow(non_upper_case_globals)]
impl EivMethod {
    /// [`classical`]: the orthant-wise LP outer set of Section 5.
    pub const Classical: EivMethod = EivMethod(classical::NAME);
    /// [`shared`]: the shared-error relaxation (the default).
    pub const Shared: EivMethod = EivMethod(shared::NAME);
    /// [`sdp`]: the moment relaxation (cargo feature `sdp`).
    pub const Sdp: EivMethod = EivMethod(sdp::NAME);
    /// [`exact_grid`]: the exact-set reference on a grid.
    pub const ExactGrid: EivMethod = EivMethod(exact_grid::NAME);

    /// Whether this build can run the method (`sdp` needs the cargo feature `sdp`).
    pub fn available(self) -> bool {
        method(self).available()
    }

    /// The name used in specs and on the command line (the method's own name).
    pub fn name(self) -> &'static str {
        self.0
    }

    /// Every registered method, in documentation order (see [`all`]).
    pub fn registered() -> Vec<EivMethod> {
        all().map(|(m, _)| m).collect()
    }

    /// The registered method called `s` (`_` accepted for `-`).
    pub fn from_name(s: &str) -> Option<Self> {
        all()
            .map(|(m, _)| m)
            .find(|m| m.name() == s || m.name().replace('-', "_") == s)
    }

    /// Parse a name given by a user (surrounding blanks ignored): an error naming the valid
    /// ones (specs, the CLI's `--method` and the Python package's `method=` all use it).
    pub fn parse(s: &str) -> Result<Self> {
        Self::from_name(s.trim()).ok_or_else(|| {
            SmidError::invalid(
                "method",
                format!(
                    "unknown stage-3 method `{s}`; expected one of: {}",
                    names().join(", ")
                ),
            )
        })
    }
}

impl Default for EivMethod {
    /// `shared`.
    fn default() -> Self {
        EivMethod::Shared
    }
}

impl std::fmt::Display for EivMethod {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.0)
    }
}

impl Serialize for EivMethod {
    fn serialize<S: serde::Serializer>(&self, s: S) -> std::result::Result<S::Ok, S::Error> {
        s.serialize_str(self.0)
    }
}

impl<'de> Deserialize<'de> for EivMethod {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> std::result::Result<Self, D::Error> {
        let s = String::deserialize(d)?;
        EivMethod::parse(&s).map_err(|e| match e {
            SmidError::Invalid { message, .. } => serde::de::Error::custom(message),
            e => serde::de::Error::custom(e),
        })
    }
}

impl schemars::JsonSchema for EivMethod {
    fn schema_name() -> std::borrow::Cow<'static, str> {
        "EivMethod".into()
    }
    /// One `const` per registered method, described by the method itself.
    fn json_schema(_: &mut schemars::SchemaGenerator) -> schemars::Schema {
        let one_of: Vec<serde_json::Value> = all()
            .map(|(m, imp)| {
                serde_json::json!({ "description": imp.description(), "type": "string", "const": m.name() })
            })
            .collect();
        schemars::json_schema!({ "description": "Stage-3 method: one of the registered methods.", "oneOf": one_of })
    }
}

/// A stage-3 method: maps an [`EivProblem`] to guaranteed θ intervals.
///
/// One required method, [`solve_from`](Self::solve_from), refines a guaranteed start box; the
/// rest have defaults. [`solve`](Self::solve) checks the problem ([`check`](Self::check)), gets
/// the start from the method named by [`start`](Self::start) through the registry (or the
/// problem's own box when `None`) and refines it. A method is never wider than its start.
///
/// ```
/// use smid_core::stage3::{EivProblem, EivResult, Stage3Method};
/// use smid_core::Result;
///
/// /// Reports its start unchanged: guaranteed (the start is), if not informative.
/// struct Keep;
/// impl Stage3Method for Keep {
///     fn solve_from(&self, _prob: &EivProblem, start: EivResult) -> Result<EivResult> {
///         Ok(start)
///     }
/// }
///
/// let (output, input) = (Vec::new(), Vec::new());
/// let prob = EivProblem {
///     na: 0,
///     nb: 0,
///     fixed: vec![Some(1.0)],
///     unit_gain: false,
///     output: &output,
///     input: &input,
///     use_band_samples: false,
///     lagged: None,
///     locate: true,
///     extra: &[],
///     prior: None,
/// };
/// let start = EivResult {
///     bounds: vec![smid_core::interval::Interval::new(1.0, 1.0)],
///     equations: vec![],
///     feasible_orthants: 0,
///     unsettled: None,
/// };
/// assert_eq!(Keep.solve_from(&prob, start).unwrap().bounds[0].lo, 1.0);
/// ```
pub trait Stage3Method: Send + Sync {
    /// Guaranteed θ bounds of `prob`, starting from the guaranteed result `start` (never wider
    /// than it). Required.
    fn solve_from(&self, prob: &EivProblem, start: EivResult) -> Result<EivResult>;

    /// The method's name in specs, on the command line and in messages: its one name. A
    /// registered method must give its own (the default, the type's path, is for unregistered
    /// helpers such as doc examples).
    fn name(&self) -> &'static str {
        std::any::type_name::<Self>()
    }

    /// One line for the spec's JSON Schema and `--help`. Default: empty.
    fn description(&self) -> &'static str {
        ""
    }

    /// This method with the options of a spec's `method.options` (see [`parse_options`]).
    /// `Ok(None)`: the registered instance as it is. Default: no options; any given is an
    /// error naming the method.
    fn with_options(
        &self,
        options: &serde_json::Map<String, serde_json::Value>,
    ) -> Result<Option<Box<dyn Stage3Method>>> {
        match options.keys().next() {
            None => Ok(None),
            Some(k) => Err(SmidError::invalid(
                format!("method.options.{k}"),
                format!("the stage-3 method `{}` takes no options", self.name()),
            )),
        }
    }

    /// Whether this build can run the method (e.g. a cargo feature it needs is on).
    fn available(&self) -> bool {
        true
    }

    /// The method whose result this one starts from; `None`: from the problem alone.
    fn start(&self) -> Option<EivMethod> {
        None
    }

    /// The method the pipeline retries with when this one reports solver trouble
    /// ([`SmidError::Solver`]); its outer bound is as guaranteed. Default: `shared`.
    fn fallback(&self) -> EivMethod {
        EivMethod::Shared
    }

    /// Refuse a problem this method cannot handle (before any start is computed), with an
    /// error saying why; `Ok` by default.
    fn check(&self, _prob: &EivProblem) -> Result<()> {
        Ok(())
    }

    /// Guaranteed θ bounds of `prob`: a problem with [`lagged`](EivProblem::lagged) past
    /// outputs is solved as its [`flattened`](EivProblem::flattened) problem (the bounds in
    /// its own θ order, errors in its own names); then [`EivProblem::validate`],
    /// [`check`](Self::check), the start (the result of [`start`](Self::start) through the
    /// registry, or [`prior_start`]), then [`solve_from`](Self::solve_from).
    fn solve(&self, prob: &EivProblem) -> Result<EivResult> {
        if let Some(f) = prob.flattened()? {
            return self.solve(&f.problem(prob)).map_err(|e| f.error(e, prob));
        }
        prob.validate()?;
        self.check(prob)?;
        let start = match self.start() {
            Some(m) => solve(m, prob)?,
            None => prior_start(prob)?,
        };
        self.solve_from(prob, start)
    }
}

/// The start of a method that starts from the problem alone: its [`EivProblem::start_box`]
/// (prior box, fixed entries at their values) over every usable equation.
pub fn prior_start(prob: &EivProblem) -> Result<EivResult> {
    Ok(EivResult {
        bounds: prob.start_box()?,
        equations: prob.equation_times(),
        feasible_orthants: 0,
        unsettled: None,
    })
}

/// A registered stage-3 method ([`register_stage3!`](crate::register_stage3)): the method
/// (with its default options) and its place in documentation order.
pub struct MethodEntry {
    /// Documentation order (the built-in methods: 0, 10, 20, 30).
    pub order: u32,
    /// The method with its default options; its [`Stage3Method::name`] is its name everywhere.
    pub method: &'static dyn Stage3Method,
}

inventory::collect!(MethodEntry);

/// Register a stage-3 method: `register_stage3!(order, VALUE)` with `VALUE` a constant
/// expression of a type implementing [`Stage3Method`] (its default options). The method file
/// calls it once; the spec, the schema, the CLI and the Python package then offer the method.
#[macro_export]
macro_rules! register_stage3 {
    ($order:expr, $method:expr) => {
        $crate::inventory::submit! {
            $crate::stage3::MethodEntry { order: $order, method: &$method }
        }
    };
}

/// The registered implementation of `m` (default options).
pub fn method(m: EivMethod) -> &'static dyn Stage3Method {
    entries()
        .iter()
        .find(|e| e.method.name() == m.name())
        .map(|e| e.method)
        .expect("an EivMethod is made only from a registered name")
}

/// The registered methods in documentation order, collected once (the pipeline looks a
/// method up per cell).
fn entries() -> &'static [&'static MethodEntry] {
    static ENTRIES: std::sync::OnceLock<Vec<&'static MethodEntry>> = std::sync::OnceLock::new();
    ENTRIES.get_or_init(|| {
        let mut v: Vec<_> = inventory::iter::<MethodEntry>.into_iter().collect();
        v.sort_by_key(|e| (e.order, e.method.name()));
        v
    })
}

/// The method of a spec name (`_` for `-` too).
pub fn by_name(name: &str) -> Option<&'static dyn Stage3Method> {
    EivMethod::from_name(name).map(method)
}

/// Every registered method with its implementation, in documentation order (including those
/// this build cannot run: see [`Stage3Method::available`]).
pub fn all() -> impl Iterator<Item = (EivMethod, &'static dyn Stage3Method)> {
    entries()
        .iter()
        .map(|e| (EivMethod(e.method.name()), e.method))
}

/// The names of every registered method, in documentation order (the CLI's and the Python
/// package's lists).
pub fn names() -> Vec<&'static str> {
    all().map(|(m, _)| m.name()).collect()
}

/// The method `m` with a spec's options (`method.options`, checked by the method: an unknown
/// or mistyped option is an error naming it); the registered default when none are given.
/// The options are the chosen method's only: the method it starts from
/// ([`Stage3Method::start`]) and its fallback run with their defaults.
pub fn configured(
    m: EivMethod,
    options: &serde_json::Map<String, serde_json::Value>,
) -> Result<ConfiguredMethod> {
    let imp = method(m);
    match imp.with_options(options)? {
        Some(b) => Ok(ConfiguredMethod::Owned(b)),
        None => Ok(ConfiguredMethod::Registered(imp)),
    }
}

/// A method as the pipeline runs it: the registered one or one built with spec options.
pub enum ConfiguredMethod {
    /// The registered instance with its default options (no `method.options` given).
    Registered(&'static dyn Stage3Method),
    /// An instance built from the spec's `method.options`.
    Owned(Box<dyn Stage3Method>),
}

impl std::ops::Deref for ConfiguredMethod {
    type Target = dyn Stage3Method;
    fn deref(&self) -> &Self::Target {
        match self {
            ConfiguredMethod::Registered(m) => *m,
            ConfiguredMethod::Owned(b) => b.as_ref(),
        }
    }
}

/// [`Stage3Method::with_options`] for a method whose options are the fields of `T`: `None`
/// when none are given, else the method `build` makes from the parsed options
/// ([`parse_options`]).
pub fn with_parsed_options<T: serde::de::DeserializeOwned>(
    name: &str,
    options: &serde_json::Map<String, serde_json::Value>,
    build: impl FnOnce(T) -> Box<dyn Stage3Method>,
) -> Result<Option<Box<dyn Stage3Method>>> {
    if options.is_empty() {
        return Ok(None);
    }
    Ok(Some(build(parse_options(name, options)?)))
}

/// Options of a method from `method.options`: the fields of `T` (unknown ones refused), the
/// rest at `T`'s defaults. For [`Stage3Method::with_options`] implementations.
pub fn parse_options<T: serde::de::DeserializeOwned>(
    name: &str,
    options: &serde_json::Map<String, serde_json::Value>,
) -> Result<T> {
    serde_json::from_value(serde_json::Value::Object(options.clone())).map_err(|e| {
        SmidError::invalid(
            "method.options",
            format!("options of the stage-3 method `{name}`: {e}"),
        )
    })
}

/// A cheap necessary test of consistency: whether the classical outer set is non-empty
/// (`false` proves that no θ fits; `true` proves nothing). See [`classical::feasible`].
pub fn feasible(prob: &EivProblem) -> Result<bool> {
    match prob.flattened()? {
        Some(f) => classical::feasible(&f.problem(prob)).map_err(|e| f.error(e, prob)),
        None => classical::feasible(prob),
    }
}

/// Stage 3 by the chosen method (the pipeline's entry point).
pub fn solve(m: EivMethod, prob: &EivProblem) -> Result<EivResult> {
    method(m).solve(prob)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::stage3::testutil::{feedback_case, random_extra_case};

    /// Past outputs read from data (`lagged`): every registered method that takes the
    /// flattened problem bounds the true θ of random clipped loops, in θ's own order; the
    /// flattened problem's equations are the problem's (each residual the same at random points
    /// of the boxes); a unit gain and an uncertain input are refused with an error.
    #[test]
    fn lagged_past_outputs_are_bounded_by_every_method_with_the_truth_inside() {
        use rand::{Rng, SeedableRng};
        let mut solved = 0;
        for seed in 0..12u64 {
            let case = feedback_case(seed);
            let (na, nb, theta) = (case.na, case.nb, &case.theta);
            let (out, input, lagged) = (&case.out, &case.input, &case.lagged);
            let p = theta.len();
            assert_eq!(na + nb + 2, p);
            let prob = case.problem();
            // The flattened equations are the problem's: residuals agree at random points.
            let f = prob.flattened().unwrap().unwrap();
            let flat = f.problem(&prob);
            assert_eq!(flat.names().len(), p);
            let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed + 100);
            let times = prob.equation_times();
            assert_eq!(times, flat.equation_times(), "seed {seed}");
            assert_eq!(
                prob.one_sided_times(),
                flat.one_sided_times(),
                "seed {seed}"
            );
            for &t in &times {
                let th: Vec<f64> = (0..p).map(|_| rng.gen_range(-2.0..2.0)).collect();
                let pick = |i: Interval| i.lo + (i.hi - i.lo) * 0.37;
                let xt = pick(out[t].interval);
                let mut r = xt;
                for i in 1..=na {
                    r += th[i - 1] * lagged[t - i].center();
                }
                for j in 0..=nb {
                    r -= th[na + j] * input[t - j].center();
                }
                r -= th[p - 1];
                let mut rf = xt;
                for j in 0..=flat.nb {
                    // The flattened input's sample (`-w_{t-1-j}`) at its centre.
                    rf -= th[j] * flat.input[t - j].center();
                }
                for (k, col) in flat.extra.iter().enumerate() {
                    rf -= th[flat.n_ab() + k] * col.values[t].center();
                }
                assert!(
                    (r - rf).abs() <= 1e-12 * (1.0 + r.abs()),
                    "seed {seed}, t = {t}"
                );
            }
            for (m, method) in all() {
                if !method.available() {
                    continue;
                }
                match method.solve(&prob) {
                    Ok(r) => {
                        solved += 1;
                        for (k, b) in r.bounds.iter().enumerate() {
                            assert!(
                                b.contains(theta[k]),
                                "seed {seed}, {}: {} = {} outside {b:?}",
                                m.name(),
                                prob.name(k),
                                theta[k]
                            );
                        }
                    }
                    Err(SmidError::Unsupported { .. } | SmidError::Unbounded { .. }) => {}
                    Err(e) => panic!("seed {seed}, {}: {e}", m.name()),
                }
            }
            assert!(matches!(
                EivProblem {
                    unit_gain: true,
                    ..prob.clone()
                }
                .flattened(),
                Err(SmidError::Invalid { .. })
            ));
            let uncertain: Vec<Interval> = input
                .iter()
                .map(|v| Interval::new(v.lo - 0.1, v.hi + 0.1))
                .collect();
            assert!(matches!(
                EivProblem {
                    input: &uncertain,
                    ..prob.clone()
                }
                .flattened(),
                Err(SmidError::Unsupported { .. })
            ));
        }
        assert!(solved >= 24, "only {solved} method runs gave bounds");
    }

    /// A lagged problem is refused by a method's own entry point, and the flattened problem's
    /// findings come back in the problem's names: a fixed `a1` outside its prior is named
    /// `a1` (the flattened problem calls it `b0`), a bad prior's field `prior.a1`.
    #[test]
    fn a_lagged_problem_is_refused_unflattened_and_named_in_its_own_terms() {
        let case = feedback_case(3);
        let prob = case.problem();
        let p = prob.p();
        assert!(
            matches!(prob.validate(), Err(SmidError::Invalid { ref field, .. }) if field == "lagged")
        );
        assert!(classical::feasible(&prob).is_err());
        let mut fixed = vec![None; p];
        fixed[0] = Some(5.0);
        let mut prior = vec![Interval::entire(); p];
        prior[0] = Interval::new(-1.0, 1.0);
        let outside = EivProblem {
            fixed,
            prior: Some(&prior),
            ..prob.clone()
        };
        match method(EivMethod::Classical).solve(&outside) {
            Err(SmidError::Inconsistent(f)) => {
                assert!(
                    f.detail.contains("`a1`") && !f.detail.contains("`b0`"),
                    "{}",
                    f.detail
                )
            }
            other => panic!("expected the fixed a1 outside its prior: {other:?}"),
        }
        let mut bad = vec![Interval::entire(); p];
        bad[0] = Interval { lo: 1.0, hi: -1.0 };
        let reversed = EivProblem {
            prior: Some(&bad),
            ..prob.clone()
        };
        match method(EivMethod::Classical).solve(&reversed) {
            Err(SmidError::Invalid { field, .. }) => assert_eq!(field, "prior.a1"),
            other => panic!("expected a reversed prior of a1: {other:?}"),
        }
    }

    /// The one location of an emptiness, with stand-in prefix tests (the first `k` equations
    /// feasible): the bisection finds equation `k`; without `locate`, or when a prefix's LP
    /// fails, the last equation is named, marked not located, and the emptiness is kept.
    #[test]
    fn an_emptiness_is_located_by_bisection_or_named_at_the_last_equation() {
        use crate::stage3::testutil::{problem, random_case};
        let (_, out, input) = random_case(1, 40);
        let located = problem(&out, &input, false);
        let quick = EivProblem {
            locate: false,
            ..located.clone()
        };
        let times: Vec<usize> = (5..45).collect();
        let msg = |t: usize| format!("up to t = {t}");
        for k in [0, 1, 17, 39] {
            let mut calls = 0;
            let prefix = |p: &[usize]| {
                calls += 1;
                Ok(p.len() <= k)
            };
            match located.emptied(&times, prefix, msg).unwrap() {
                SmidError::Inconsistent(f) => {
                    assert!(f.located && f.sample == times[k], "k = {k}: {f:?}")
                }
                e => panic!("{e:?}"),
            }
            assert!(calls > 0 && calls <= 7, "k = {k}: {calls} prefix tests");
            let mut calls = 0;
            match quick
                .emptied(
                    &times,
                    |_| {
                        calls += 1;
                        Ok(true)
                    },
                    msg,
                )
                .unwrap()
            {
                SmidError::Inconsistent(f) => assert!(!f.located && f.sample == 44, "{f:?}"),
                e => panic!("{e:?}"),
            }
            assert_eq!(calls, 0);
        }
        let trouble = |_: &[usize]| Err(SmidError::Solver("prefix LP".into()));
        match located.emptied(&times, trouble, msg).unwrap() {
            SmidError::Inconsistent(f) => assert!(!f.located && f.sample == 44, "{f:?}"),
            e => panic!("{e:?}"),
        }
        // Any other error is passed on.
        let bad = |_: &[usize]| Err(SmidError::invalid("x", "y"));
        assert!(located.emptied(&times, bad, msg).is_err());
    }

    /// A verdict without the search for the first offending equation (`locate: false`) agrees
    /// with the located one, for every runnable method, on random records with an outlier at a
    /// random sample: both find them inconsistent (or both not); located, the classical and
    /// shared methods never name an equation before the outlier (one it enters when it is far
    /// out); not located, every method marks its finding so, at the last equation. Some
    /// outliers are seen by the shared relaxation only (its own search, not its classical
    /// start's).
    #[test]
    fn an_unlocated_verdict_agrees_and_says_it_is_not_located() {
        use crate::stage3::testutil::{problem, random_case};
        use rand::{Rng, SeedableRng};
        let mut shared_only = 0;
        for seed in 0..16u64 {
            let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed ^ 0x10ca7e);
            let n = rng.gen_range(40..120);
            let (_, mut out, input) = random_case(seed, n);
            let t0 = rng.gen_range(10..n - 5);
            let w = out[t0].interval;
            // Some outliers far out (the classical outer set is empty), some just past the
            // bound (only the tighter relaxation sees them).
            let jump = if seed % 2 == 0 {
                0.5 + 40.0 * w.radius()
            } else {
                rng.gen_range(2.5..6.0) * w.radius()
            };
            out[t0].interval = Interval::new(w.lo + jump, w.hi + jump);
            let located = problem(&out, &input, false);
            let last = *located.equation_times().last().unwrap();
            let quick = EivProblem {
                locate: false,
                ..located.clone()
            };
            for (m, imp) in all() {
                if !imp.available() {
                    continue;
                }
                let a = imp.solve(&located);
                let b = imp.solve(&quick);
                let name = m.name();
                match (&a, &b) {
                    (Err(SmidError::Inconsistent(fa)), Err(SmidError::Inconsistent(fb))) => {
                        if [EivMethod::Classical, EivMethod::Shared].contains(&m) {
                            assert!(fa.located, "seed {seed} {name}: {fa:?}");
                            // Never before the outlier; with one far out, at an equation it
                            // enters (a small one needs later data to be seen).
                            let reach = if seed % 2 == 0 { t0 + 2 } else { last };
                            assert!(
                                (t0..=reach).contains(&fa.sample),
                                "seed {seed} {name}: outlier at {t0}, located {}",
                                fa.sample
                            );
                        }
                        if !fb.located || fb.sample != fa.sample {
                            assert!(
                                !fb.located && fb.sample == last,
                                "seed {seed} {name}: {fb:?}"
                            );
                        }
                    }
                    (Ok(_), Ok(_)) => {}
                    // Solver trouble in the solve itself, alike in both (locating never turns a
                    // proven emptiness into trouble).
                    (Err(SmidError::Solver(_)), Err(SmidError::Solver(_))) => {}
                    _ => panic!("seed {seed} {name}: located {a:?}, not located {b:?}"),
                }
                if m == EivMethod::Shared && a.is_err() && classical::solve(&located).is_ok() {
                    shared_only += 1;
                }
                if [EivMethod::Classical, EivMethod::Shared].contains(&m) && a.is_err() {
                    match b {
                        Err(SmidError::Inconsistent(f)) => {
                            assert!(!f.located && f.sample == last, "seed {seed} {name}: {f:?}")
                        }
                        other => panic!("seed {seed} {name}: {other:?}"),
                    }
                }
            }
        }
        assert!(
            shared_only > 0,
            "no outlier was left to the shared relaxation alone"
        );
    }

    /// The one parser of user-given method names: every method by its name (blanks and the
    /// `_` spelling of `exact-grid` accepted); an unknown name lists every valid one.
    /// Each method names its own fallback, another method this build can run (a retry with
    /// itself would repeat the trouble).
    #[test]
    fn every_method_falls_back_to_another_runnable_method() {
        for (m, imp) in all() {
            let f = imp.fallback();
            assert_ne!(f, m, "{} falls back to itself", m.name());
            assert!(
                method(f).available(),
                "{} falls back to {}",
                m.name(),
                f.name()
            );
        }
    }

    #[test]
    fn method_names_parse_and_unknown_ones_list_the_valid_names() {
        for m in EivMethod::registered() {
            assert_eq!(EivMethod::parse(&format!(" {} ", m.name())).unwrap(), m);
        }
        assert_eq!(
            EivMethod::parse("exact_grid").unwrap(),
            EivMethod::ExactGrid
        );
        let e = EivMethod::parse("clasical").unwrap_err().to_string();
        assert!(e.contains("clasical"), "{e}");
        for m in EivMethod::registered() {
            assert!(e.contains(m.name()), "{e}");
        }
    }

    /// The methods this build runs.
    fn methods() -> impl Iterator<Item = (EivMethod, &'static dyn Stage3Method)> {
        all().filter(|(_, m)| m.available())
    }

    #[test]
    fn names_and_counts_include_the_extra_columns() {
        let case = random_extra_case(1, 30, 0.0);
        let prob = case.problem(false);
        assert_eq!((prob.n_ab(), prob.p()), (5, 7));
        assert_eq!(
            prob.names(),
            ["a1", "a2", "b0", "b1", "b2", "offset", "friction"]
        );
        assert_eq!(prob.name(6), "friction");
        let gain: Vec<f64> = (0..7).map(|k| prob.gain_sign(k)).collect();
        assert_eq!(gain, [-1.0, -1.0, 1.0, 1.0, 1.0, 0.0, 0.0]);
    }

    /// A non-finite extra sample excludes exactly the equation at that sample (the extras
    /// enter at `t` only); a shorter column ends the equations.
    #[test]
    fn an_unknown_extra_sample_leaves_out_its_equation() {
        let mut case = random_extra_case(1, 30, 0.0);
        let all_times = case.problem(false).equation_times();
        case.extra[1].values[20] = Interval::new(f64::NAN, f64::NAN);
        case.extra[0].values[25] = Interval::entire();
        case.extra[0].values.truncate(28);
        let times = case.problem(false).equation_times();
        let expected: Vec<usize> = all_times
            .into_iter()
            .filter(|&t| t != 20 && t != 25 && t < 28)
            .collect();
        assert_eq!(times, expected);
    }

    #[test]
    fn a_malformed_problem_is_an_error_naming_the_field() {
        let case = random_extra_case(1, 30, 0.0);
        let prob = case.problem(false);
        let short = vec![Interval::entire(); 5];
        let bad_prior = {
            let mut v = vec![Interval::entire(); 7];
            v[6] = Interval::new(1.0, -1.0);
            v
        };
        let mut dup = case.extra.clone();
        dup[1].name = "b1".into();
        let cases: [(EivProblem, &str); 4] = [
            (
                EivProblem {
                    fixed: vec![None; 5],
                    ..prob.clone()
                },
                "model.fixed",
            ),
            (
                EivProblem {
                    prior: Some(&short),
                    ..prob.clone()
                },
                "prior",
            ),
            (
                EivProblem {
                    prior: Some(&bad_prior),
                    ..prob.clone()
                },
                "prior.friction",
            ),
            (
                EivProblem {
                    extra: &dup,
                    ..prob.clone()
                },
                "extra[1].name",
            ),
        ];
        for (p, field) in cases {
            for (m, imp) in methods() {
                match imp.solve(&p) {
                    Err(SmidError::Invalid { field: f, .. }) => {
                        assert_eq!(f, field, "{}", m.name())
                    }
                    other => panic!("{}: expected an error on {field}, got {other:?}", m.name()),
                }
            }
        }
    }

    /// Every method keeps inside a prior box that cuts its start; a prior the data exclude, or
    /// one that excludes a fixed value, is an empty set: `Inconsistent` at an equation's sample.
    #[test]
    fn every_method_honours_a_prior_box() {
        for seed in 0..2 {
            let case = random_extra_case(seed, 50, 0.0);
            let prob = case.problem(true);
            let truth = case.truth();
            let classical = solve(EivMethod::Classical, &prob).unwrap();
            // Around the truth, narrower than the classical box: it cuts every free entry.
            let prior: Vec<Interval> = truth
                .iter()
                .zip(&classical.bounds)
                .map(|(&t, b)| {
                    let r = 0.5 * b.radius() + 1e-6;
                    Interval::new(t - r, t + r)
                })
                .collect();
            let with_prior = EivProblem {
                prior: Some(&prior),
                ..prob.clone()
            };
            // Beyond what the data allow for a1: no θ at all.
            let mut excluded = prior.clone();
            let a1 = classical.bounds[0];
            excluded[0] = Interval::new(a1.hi + 0.1, a1.hi + 0.2);
            // b0 is fixed at 0; a prior without 0 empties the set before any equation.
            let mut off_fixed = prior.clone();
            off_fixed[2] = Interval::new(0.5, 1.0);
            for (m, imp) in methods() {
                let r = imp.solve(&with_prior).unwrap();
                for (k, t) in truth.iter().enumerate() {
                    let (b, p) = (r.bounds[k], prior[k]);
                    assert!(
                        b.contains(*t),
                        "seed {seed} {} θ{k}: {b:?} misses {t}",
                        m.name()
                    );
                    assert!(
                        p.lo <= b.lo && b.hi <= p.hi,
                        "seed {seed} {} θ{k}: {b:?} outside the prior {p:?}",
                        m.name()
                    );
                }
                for (p, what) in [(&excluded, "excluded a1"), (&off_fixed, "b0 off its prior")] {
                    let q = EivProblem {
                        prior: Some(p),
                        ..prob.clone()
                    };
                    match imp.solve(&q) {
                        Err(SmidError::Inconsistent(crate::outcome::Falsification {
                            stage: Stage::Linear,
                            sample,
                            ..
                        })) => assert!(
                            classical.equations.contains(&sample),
                            "seed {seed} {} ({what}): sample {sample}",
                            m.name()
                        ),
                        other => panic!(
                            "seed {seed} {} ({what}): expected Inconsistent, got {other:?}",
                            m.name()
                        ),
                    }
                }
            }
        }
    }

    /// A column the data cannot bound (all zeros) is `Unbounded` naming its coefficient, in
    /// every method; a prior on it bounds it again.
    #[test]
    fn an_unbounded_extra_coefficient_is_named() {
        let mut case = random_extra_case(3, 50, 0.0);
        case.extra.push(Regressor {
            name: "drift".into(),
            values: vec![Interval::new(0.0, 0.0); 50],
        });
        let prob = EivProblem {
            fixed: vec![None, None, Some(0.0), None, None, None, None, None],
            ..case.problem(true)
        };
        let mut prior = vec![Interval::entire(); 8];
        prior[7] = Interval::new(-2.0, 3.0);
        for (m, imp) in methods() {
            match imp.solve(&prob) {
                Err(SmidError::Unbounded { parameter, .. }) => {
                    assert_eq!(parameter, "drift", "{}", m.name())
                }
                other => panic!("{}: expected `drift` unbounded, got {other:?}", m.name()),
            }
            let bounded = EivProblem {
                prior: Some(&prior),
                ..prob.clone()
            };
            let r = imp.solve(&bounded).unwrap();
            assert_eq!(r.bounds[7], prior[7], "{}", m.name());
        }
    }

    #[test]
    fn the_registry_knows_every_method_by_its_spec_name() {
        let mut seen = names();
        seen.sort_unstable();
        let n = seen.len();
        seen.dedup();
        assert_eq!(
            seen.len(),
            n,
            "two registered methods share a name: {:?}",
            names()
        );
        for (m, imp) in all() {
            assert_eq!(imp.name(), m.name());
            assert_eq!(by_name(m.name()).map(|i| i.name()), Some(m.name()));
            assert_eq!(
                by_name(&m.name().replace('-', "_")).map(|i| i.name()),
                Some(m.name())
            );
            // A start is an earlier method: the chain ends.
            if let Some(s) = imp.start() {
                assert!(
                    method(s).start() != Some(m),
                    "{} <-> {}",
                    m.name(),
                    s.name()
                );
            }
        }
        assert_eq!(
            method(EivMethod::Shared).start(),
            Some(EivMethod::Classical)
        );
        assert!(by_name("simplex").is_none());
        assert!(EivMethod::Classical.available() && EivMethod::Shared.available());
        assert_eq!(EivMethod::Sdp.available(), cfg!(feature = "sdp"));
    }
}
