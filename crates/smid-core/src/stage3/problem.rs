//! The stage-3 problem and result types: the EIV problem, its extra regressors, its
//! flattening when past outputs are read from data, and the result of every method.
use crate::error::{Result, SmidError, Stage};
use crate::interval::Interval;
use crate::inversion::{InnerBound, InnerKind};
use std::ops::Range;

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
    /// by [`Stage3Method::solve`](super::Stage3Method::solve); `exact-grid` refuses that
    /// uncertain input), and [`EivProblem::validate`] refuses it unflattened. The exact LPs at
    /// fixed θ ([`certify::consistency_at`](super::certify::consistency_at)) and the one-step
    /// band read it as it is.
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

    /// Whether a sample has a two-sided preimage ([`InnerKind::Mirrored`]): such a sample
    /// is unusable here, so a bound holds without it, but a certificate (a point proved
    /// consistent) needs its sign decided first.
    pub fn has_mirrored(&self) -> bool {
        self.output.iter().any(|b| b.kind == InnerKind::Mirrored)
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
    /// [`Stage3Method::solve`](super::Stage3Method::solve), [`solve`](super::solve) and
    /// [`feasible`](super::feasible) flatten: a method's own entry point refuses them here).
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
