//! Certification at a fixed point: the exact LPs of the EIV problem (eqs 1, 28-30) at fixed
//! values of the `a` coefficients, or of the whole `θ`, for an exactly known input (Wiener
//! structure; uncertain input samples become LP columns at a whole `θ`) and exactly known
//! extra regressor columns.
//!
//! With `a` fixed the equations `x_t + Σ a_i x_{t-i} = Σ b_j u_{t-j} + Σ c_k φ_k(t)` with
//! `x_s = x^c_s + δx_s`, `|δx_s| <= Δx_s` are linear in `(b, c, δx)`, so one small LP decides
//! whether the data are consistent there. [`consistency_at`] measures a whole `θ` (a value at
//! most [`CERTIFIED`] certifies it consistent with the stage-2 bounds, up to the LP's
//! tolerances); [`best_at_a`] and [`extreme_at_a`] search at fixed `a` over the free `b`'s
//! and extra coefficients (measurements, to be certified by [`consistency_at`]). The
//! exact-grid reference ([`super::exact_grid`]) grows its inner hull from these LPs, and the
//! simulation member search certifies its members with them.
use super::EivProblem;
use crate::error::{Result, SmidError};
use crate::interval::Interval;
use crate::sparse_lp::{merge, Optimum, SparseLp};
use std::collections::BTreeMap;

/// The margin below which [`consistency_at`] certifies a point (far above the LPs' pads).
pub const CERTIFIED: f64 = INSIDE;

/// Margin of the consistency measure below which a point counts as inside the exact set for
/// the inner hull (relative to the inner-signal error bounds; far above the LPs' pads).
pub(super) const INSIDE: f64 = -1e-6;

/// Relative radius above which an input sample counts as uncertain in [`consistency_at`]
/// (below it, the outward rounding pads of an exact propagation).
const UNCERTAIN: f64 = 1e-9;

/// Columns up to which the fixed-`a` LPs go to the dense simplex ([`crate::lp::Polytope`]).
const DENSE_MAX: usize = 24;

/// Inequality rows above which the measure at a whole `θ` is solved chain by chain
/// ([`SparseLp::minimise_by_blocks`]): at 28 000 rows (14 000 samples) the chains' LPs take
/// 13 ms and one solve of the whole LP 80 to 110 ms; below it the whole LP is solved, as it
/// always was for the records the examples use.
const BLOCKS_ABOVE: usize = 20_000;

/// The consistency measure at a whole parameter vector `theta` (θ order, fixed entries
/// included): the smallest `s` for which the equations (eq 1) hold with every inner-signal
/// sample inside its stage-2 box scaled by `1 + s`. The exact extra columns enter at their
/// values, and each uncertain input sample is an LP column inside its interval (exact at a
/// fixed `θ`). So `s <= INSIDE` **certifies** `theta`
/// consistent with the stage-2 bounds, up to the LP's tolerances; `+inf` when `theta` breaks
/// the unit gain (eq 8) or the solver gave no conclusion. Uncertain extra columns are refused
/// (as by the method).
pub fn consistency_at(prob: &EivProblem, theta: &[f64]) -> Result<f64> {
    if prob.has_mirrored() {
        // A sample whose sign is undecided constrains the equations only through its sign
        // pattern: no certificate here (the member search decides the signs first).
        return Ok(f64::INFINITY);
    }
    let times = lp_times(prob);
    check_extras(prob, &times)?;
    if prob.unit_gain {
        let gain: f64 = (0..prob.n_ab()).map(|k| prob.gain_sign(k) * theta[k]).sum();
        let scale: f64 = 1.0 + theta[..prob.n_ab()].iter().map(|v| v.abs()).sum::<f64>();
        if (gain - 1.0).abs() > 1e-9 * scale {
            return Ok(f64::INFINITY);
        }
    }
    // Every θ entry is given: the fixed-`a` LP with all entries as grid values (its unit-gain
    // row has no column left and was checked above).
    let flat = EivProblem {
        unit_gain: false,
        ..prob.clone()
    };
    let dims: Vec<usize> = (0..prob.p()).filter(|&k| prob.fixed[k].is_none()).collect();
    let a: Vec<f64> = dims.iter().map(|&k| theta[k]).collect();
    let mut at = AtA {
        prob: &flat,
        dims,
        times,
        tb: vec![Interval::entire(); prob.p()],
        lps: 0,
        input_vars: true,
    };
    let s = at.slack(&a)?;
    Ok(if s.is_nan() { f64::INFINITY } else { s })
}

/// At fixed values `a` of the free `a`'s (in θ order), the smallest consistency measure over
/// the free `b`'s and extra coefficients inside `tb` (the unit gain imposed), and a `θ` that
/// attains it (`None` when the solver gave no point). A measurement to search with: a point
/// it gives is certified afterwards by [`consistency_at`].
pub fn best_at_a(prob: &EivProblem, tb: &[Interval], a: &[f64]) -> Result<(f64, Option<Vec<f64>>)> {
    point_at_a(prob, tb, a, None)
}

/// At fixed `a` (as [`best_at_a`]), a `θ` of the exact set that minimises (`max`: maximises)
/// `θ_k` over the free `b`'s and extra coefficients: a vertex of the set's slice, on its
/// boundary (`None` when the slice is empty or the solver gave no point). A measurement: move
/// it inwards and certify it with [`consistency_at`] before calling it a member.
pub fn extreme_at_a(
    prob: &EivProblem,
    tb: &[Interval],
    a: &[f64],
    k: usize,
    max: bool,
) -> Result<Option<Vec<f64>>> {
    Ok(point_at_a(prob, tb, a, Some((k, max)))?.1)
}

fn point_at_a(
    prob: &EivProblem,
    tb: &[Interval],
    a: &[f64],
    objective: Option<(usize, bool)>,
) -> Result<(f64, Option<Vec<f64>>)> {
    if prob.has_mirrored() {
        return Ok((f64::INFINITY, None));
    }
    let times = lp_times(prob);
    check_extras(prob, &times)?;
    let dims: Vec<usize> = (0..prob.na).filter(|&k| prob.fixed[k].is_none()).collect();
    let at = AtA {
        prob,
        dims: dims.clone(),
        times,
        tb: tb.to_vec(),
        lps: 0,
        input_vars: false,
    };
    let m = at.lp(a, objective.is_none());
    let mut c = vec![0.0; m.lp.n];
    let col = match objective {
        None => m.s,
        Some((k, _)) => match m.col_theta.get(k).copied().flatten() {
            Some(col) => col,
            None => return Ok((f64::INFINITY, None)),
        },
    };
    let sign = if matches!(objective, Some((_, true))) {
        -1.0
    } else {
        1.0
    };
    c[col] = sign;
    let x = match m.lp.dense(DENSE_MAX).and_then(|p| p.vertex_point(&c)) {
        Some(x) => x,
        None => {
            let mut s = m.lp.solver()?;
            match s.optimise(col, sign < 0.0)? {
                Optimum::Value(_) => s.point().to_vec(),
                _ => return Ok((f64::INFINITY, None)),
            }
        }
    };
    let mut theta: Vec<f64> = prob.fixed.iter().map(|f| f.unwrap_or(0.0)).collect();
    for (d, &k) in dims.iter().enumerate() {
        theta[k] = a[d];
    }
    for (k, col) in m.col_theta.iter().enumerate() {
        if let Some(col) = col {
            theta[k] = x[*col];
        }
    }
    let s = x[m.s];
    Ok((if s.is_nan() { f64::INFINITY } else { s }, Some(theta)))
}

/// The equations of the exact LPs at fixed `a`: every usable one, and with past outputs read
/// from data ([`EivProblem::lagged`]) also those with a sample known from one side (a clipped
/// output's half-space, which a point consistent with the model must respect). Without
/// lagged outputs a one-sided sample also sits in later equations' chains, where the LP has no
/// row for it, and the usable equations alone are taken (as the relaxations take them).
fn lp_times(prob: &EivProblem) -> Vec<usize> {
    let mut times = prob.equation_times();
    if prob.lagged.is_some() {
        times.extend(prob.one_sided_times());
        times.sort_unstable();
        times.dedup();
    }
    times
}

/// Refuse an extra regressor that is uncertain (radius > 0) at a sample of `times`: the exact
/// LPs substitute the extra columns in the equations, and gridding their coefficients too is
/// out of reach.
pub(super) fn check_extras(prob: &EivProblem, times: &[usize]) -> Result<()> {
    for r in prob.extra {
        if let Some(&t) = times.iter().find(|&&t| r.values[t].radius() > 0.0) {
            return Err(SmidError::Unsupported {
                plugin: "exact-grid".into(),
                what: format!(
                    "an uncertain extra regressor `{}` (radius {:e} at t = {t}): only exact extra columns enter its exact LPs; use `shared` or `sdp`",
                    r.name,
                    r.values[t].radius()
                ),
            });
        }
    }
    Ok(())
}

/// Exact LPs at fixed values of the gridded `a`'s. With `a` known and the input exact
/// (Wiener), the equations determine every inner-signal sample from the `b`'s and the samples
/// that start a chain of equations: `x_t = -Σ a_i x_{t-i} + Σ b_j u_{t-j}`. So `x_t` is an affine
/// function of a few variables (free `b`'s, chain starts), and consistency is a small LP whose
/// rows are the sample bounds `x_t ∈ [lo_t, hi_t]`: the equations hold exactly, by construction.
pub(super) struct AtA<'p, 'a> {
    pub(super) prob: &'p EivProblem<'a>,
    pub(super) dims: Vec<usize>,
    pub(super) times: Vec<usize>,
    /// A guaranteed box (bounds the free `b`'s; a superset of the exact set).
    pub(super) tb: Vec<Interval>,
    pub(super) lps: usize,
    /// Uncertain input samples become LP columns inside their intervals where their `b` is
    /// given (exact at a fixed θ); otherwise the input enters at its centres.
    pub(super) input_vars: bool,
}

/// An affine function `c + Σ coef·z_col`.
type Affine = (f64, Vec<(usize, f64)>);

/// The LP at one `a`: columns `[free θ (b's), chain starts, s]`.
pub(super) struct AtALp {
    pub(super) lp: SparseLp,
    /// Column of each θ index (free `b`'s only).
    pub(super) col_theta: Vec<Option<usize>>,
    /// The slack column.
    pub(super) s: usize,
}

/// The samples of the LP at one `a` ([`AtA::chains`]): `x_s = c + Σ coef·z` over the
/// columns (`None`: not reached by any equation), the columns of uncertain input samples and
/// of uncertain past outputs (sample -> column), and the number of columns so far.
struct Chains {
    x: Vec<Option<Affine>>,
    input_cols: BTreeMap<usize, usize>,
    lag_cols: BTreeMap<usize, usize>,
    n: usize,
}

impl AtA<'_, '_> {
    /// The LP at `a`; with `slack`, every sample box is scaled by `1 + s` (`s >= -1`), else
    /// `s` is fixed to 0.
    pub(super) fn lp(&self, a: &[f64], slack: bool) -> AtALp {
        let prob = self.prob;
        let p = prob.p();
        let mut theta: Vec<Option<f64>> = prob.fixed.clone();
        for (d, &k) in self.dims.iter().enumerate() {
            theta[k] = Some(a[d]);
        }
        let mut col_theta = vec![None; p];
        let mut n = 0;
        for k in 0..p {
            if theta[k].is_none() {
                col_theta[k] = Some(n);
                n += 1;
            }
        }
        let chains = self.chains(&theta, &col_theta, n);
        let s_col = chains.n;
        let mut lp = SparseLp::new(chains.n + 1);
        self.sample_rows(&chains, s_col, &mut lp);
        if slack {
            lp.le(vec![(s_col, -1.0)], 1.0);
        } else {
            lp.eq(vec![(s_col, 1.0)], 0.0);
        }
        for (k, col) in col_theta.iter().enumerate() {
            if let Some(col) = *col {
                let b = self.tb[k];
                if b.lo.is_finite() {
                    lp.le(vec![(col, -1.0)], -b.lo);
                }
                if b.hi.is_finite() {
                    lp.le(vec![(col, 1.0)], b.hi);
                }
            }
        }
        if prob.unit_gain {
            // Σ b_j - Σ a_i = 1 (eq 8); the extras do not enter.
            let mut row = Vec::new();
            let mut rhs = 1.0;
            for k in 0..prob.n_ab() {
                let sg = prob.gain_sign(k);
                match (theta[k], col_theta[k]) {
                    (Some(v), _) => rhs -= sg * v,
                    (None, Some(col)) => row.push((col, sg)),
                    (None, None) => {}
                }
            }
            lp.eq(row, rhs);
        }
        AtALp {
            lp,
            col_theta,
            s: s_col,
        }
    }

    /// Each sample the equations reach as an affine function of the LP's columns, at the
    /// θ values `theta` (`None`: free, at column `col_theta`), the first `n` columns taken by
    /// the free θ: the chain starts, and the uncertain input samples and past outputs that
    /// become columns of their own.
    fn chains(&self, theta: &[Option<f64>], col_theta: &[Option<usize>], mut n: usize) -> Chains {
        let prob = self.prob;
        // Uncertain input samples as columns (sample -> column).
        let mut input_cols: BTreeMap<usize, usize> = Default::default();
        // Uncertain past outputs read by the autoregressive part (`prob.lagged`: the chain's
        // output inside its measurement box) as columns, the box scaled as the samples'.
        let mut lag_cols: BTreeMap<usize, usize> = Default::default();
        // x_s = c + Σ coef·z over the columns; None: not reached by any equation.
        let len = prob.output.len();
        let mut x: Vec<Option<Affine>> = vec![None; len];
        for &t in &self.times {
            let mut c = 0.0;
            let mut row: Vec<(usize, f64)> = Vec::new();
            if let Some(w) = prob.lagged {
                // `x_t = -Σ a_i w_{t-i} + …`: the past outputs are data, not this chain's.
                for i in 1..=prob.na {
                    let ai = theta[i - 1].unwrap_or(0.0);
                    let wi = w[t - i];
                    if ai != 0.0 && wi.radius() > UNCERTAIN * (1.0 + wi.center().abs()) {
                        let col = *lag_cols.entry(t - i).or_insert_with(|| {
                            n += 1;
                            n - 1
                        });
                        row.push((col, -ai));
                    } else {
                        c -= ai * wi.center();
                    }
                }
            } else {
                // Samples before `t` not set by an earlier equation start a chain: free
                // variables.
                for xs in &mut x[t - prob.na..t] {
                    if xs.is_none() {
                        *xs = Some((0.0, vec![(n, 1.0)]));
                        n += 1;
                    }
                }
                for i in 1..=prob.na {
                    let ai = theta[i - 1].unwrap_or(0.0);
                    if let Some((ci, ri)) = &x[t - i] {
                        c -= ai * ci;
                        row.extend(ri.iter().map(|&(k, v)| (k, -ai * v)));
                    }
                }
            }
            for j in 0..=prob.nb {
                let ui = prob.input[t - j];
                let u = ui.center();
                match (theta[prob.na + j], col_theta[prob.na + j]) {
                    (Some(v), _)
                        if self.input_vars
                            && ui.radius() > UNCERTAIN * (1.0 + u.abs())
                            && v != 0.0 =>
                    {
                        let col = *input_cols.entry(t - j).or_insert_with(|| {
                            n += 1;
                            n - 1
                        });
                        row.push((col, v));
                    }
                    (Some(v), _) => c += v * u,
                    (None, Some(col)) => row.push((col, u)),
                    (None, None) => {}
                }
            }
            // Exact extra columns (checked by `check_extras`): `+ c_k φ_k(t)`.
            for (e, r) in prob.extra.iter().enumerate() {
                let phi = r.values[t].center();
                let k = prob.n_ab() + e;
                match (theta[k], col_theta[k]) {
                    (Some(v), _) => c += v * phi,
                    (None, Some(col)) => row.push((col, phi)),
                    (None, None) => {}
                }
            }
            x[t] = Some((c, merge(row)));
        }
        Chains {
            x,
            input_cols,
            lag_cols,
            n,
        }
    }

    /// The rows of the samples (`chains`): each two-sided box scaled by `1 + s` (column
    /// `s_col`), a one-sided sample's half-space, the past outputs' boxes scaled alike, the
    /// input columns' intervals.
    fn sample_rows(&self, chains: &Chains, s_col: usize, lp: &mut SparseLp) {
        let prob = self.prob;
        let Chains {
            x,
            input_cols,
            lag_cols,
            ..
        } = chains;
        for (s, xs) in x.iter().enumerate() {
            let Some((c, row)) = xs else { continue };
            let iv = prob.output[s].interval;
            if !(iv.lo.is_finite() && iv.hi.is_finite()) {
                // A sample known from one side (a clipped output; equations of the lagged
                // problems only, see `lp_times`): its half-space, unscaled.
                if prob.lagged.is_some() && iv.lo.is_finite() {
                    let down: Vec<(usize, f64)> = row.iter().map(|&(k, v)| (k, -v)).collect();
                    lp.le(down, c - iv.lo);
                } else if prob.lagged.is_some() && iv.hi.is_finite() {
                    lp.le(row.clone(), iv.hi - c);
                }
                continue;
            }
            let r = iv.radius();
            // lo - r s <= c + row·z <= hi + r s
            let mut up = row.clone();
            up.push((s_col, -r));
            lp.le(up, iv.hi - c);
            let mut down: Vec<(usize, f64)> = row.iter().map(|&(k, v)| (k, -v)).collect();
            down.push((s_col, -r));
            lp.le(down, c - iv.lo);
        }
        for (&t, &col) in lag_cols {
            // lo - r s <= w <= hi + r s
            let iv = prob.lagged.map_or(Interval::entire(), |w| w[t]);
            let r = iv.radius();
            lp.le(vec![(col, 1.0), (s_col, -r)], iv.hi);
            lp.le(vec![(col, -1.0), (s_col, -r)], -iv.lo);
        }
        for (&t, &col) in input_cols {
            let iv = prob.input[t];
            lp.le(vec![(col, -1.0)], -iv.lo);
            lp.le(vec![(col, 1.0)], iv.hi);
        }
    }

    /// The consistency measure at `a`: the smallest `s` for which the equations hold with the
    /// inner-signal samples inside their boxes scaled by `1 + s` (`+inf` when the solver gave
    /// no conclusion).
    pub(super) fn slack(&mut self, a: &[f64]) -> Result<f64> {
        self.lps += 1;
        let m = self.lp(a, true);
        // A measurement, not a bound: the low-dimensional simplex's vertex value when the LP
        // has few columns (long chains), else clarabel (one small LP per chain of equations where only the slack couples
        // them, on a long record).
        if let Some(p) = m.lp.dense(DENSE_MAX) {
            let mut c = vec![0.0; m.lp.n];
            c[m.s] = 1.0;
            if let Some(v) = p.vertex_optimum(&c) {
                return Ok(v);
            }
        }
        if let Some(o) = m.lp.minimise_by_blocks(m.s, DENSE_MAX, BLOCKS_ABOVE)? {
            return Ok(match o {
                Optimum::Value(v) => v,
                _ => f64::INFINITY,
            });
        }
        Ok(match m.lp.solver()?.minimise(m.s)? {
            Optimum::Value(v) => v,
            _ => f64::INFINITY,
        })
    }

    /// The optimum of `θ_k` at a consistent `a` (a point of the exact set's projection, so an
    /// inner value; the LP's outward pad is taken back).
    pub(super) fn value(&mut self, a: &[f64], k: usize, max: bool) -> Result<Option<f64>> {
        if let Some(d) = self.dims.iter().position(|&kk| kk == k) {
            return Ok(Some(a[d]));
        }
        let m = self.lp(a, false);
        let Some(col) = m.col_theta[k] else {
            return Ok(self.prob.fixed[k]);
        };
        self.lps += 1;
        if let Some(p) = m.lp.dense(DENSE_MAX) {
            let mut c = vec![0.0; m.lp.n];
            c[col] = if max { -1.0 } else { 1.0 };
            if let Some(v) = p.vertex_optimum(&c) {
                return Ok(Some(if max { -v } else { v }));
            }
        }
        Ok(match m.lp.solver()?.optimise(col, max)? {
            Optimum::Value(v) => {
                let pad = crate::lp::RESULT_PAD * (1.0 + v.abs());
                Some(if max { v - pad } else { v + pad })
            }
            _ => None,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::stage3::relax::SharedModel;
    use crate::stage3::shared::{self, SharedOptions};
    use crate::stage3::testutil::{feedback_case, problem, random_case, random_extra_case};
    use crate::stage3::EivMethod;

    /// The certificate at a whole `θ`: the truth is consistent (its noise is inside the
    /// bounds), a `θ` moved by several radii of the guaranteed box is not, a `θ` off the unit
    /// gain is refused; with the input made uncertain around the truth (a block's unknown
    /// initial state), the truth stays certified only because the input samples become LP
    /// columns (at the input's perturbed centres it would not be).
    #[test]
    fn consistency_at_certifies_the_truth_and_rejects_far_points() {
        let mut checked_uncertain = 0;
        for seed in 0..12 {
            let (m, out, input) = random_case(seed, 40);
            let prob = problem(&out, &input, true);
            let truth: Vec<f64> = m.a.iter().chain(&m.b).copied().collect();
            let s = consistency_at(&prob, &truth).unwrap();
            assert!(s <= 1e-7, "seed {seed}: the truth measures {s}");
            let shared = shared::solve(&prob, &SharedOptions::default()).unwrap();
            let mut far = truth.clone();
            far[0] += 4.0 * shared.bounds[0].radius().max(1e-3);
            far[3] += 4.0 * shared.bounds[0].radius().max(1e-3);
            let gain = |t: &[f64]| t[2] + t[3] + t[4] - t[0] - t[1];
            assert!((gain(&far) - 1.0).abs() < 1e-12);
            let s_far = consistency_at(&prob, &far).unwrap();
            assert!(
                s_far > CERTIFIED,
                "seed {seed}: a far point measures {s_far}"
            );
            let mut off = truth.clone();
            off[3] += 0.1;
            assert_eq!(consistency_at(&prob, &off).unwrap(), f64::INFINITY);
            // The first samples' input uncertain, its centre moved off the true input.
            let mut uncertain = input.clone();
            for v in uncertain.iter_mut().take(6) {
                let c = v.center();
                *v = Interval::new(c - 0.5, c + 0.3);
            }
            let mut p2 = prob.clone();
            p2.input = &uncertain;
            let s2 = consistency_at(&p2, &truth).unwrap();
            assert!(
                s2 <= 1e-7,
                "seed {seed}: uncertain input, the truth measures {s2}"
            );
            let centred: Vec<Interval> = uncertain
                .iter()
                .map(|v| Interval::new(v.center(), v.center()))
                .collect();
            let mut p3 = prob.clone();
            p3.input = &centred;
            if consistency_at(&p3, &truth).unwrap() > 0.0 {
                checked_uncertain += 1;
            }
        }
        assert!(
            checked_uncertain > 0,
            "the input columns were never needed: the test of them is vacuous"
        );
    }

    /// With the past outputs read from data (`lagged`), the exact LP at a whole `θ` takes each
    /// measured past output as a column inside its box and a clipped sample's half-space: the
    /// truth of random clipped loops is certified; points moved off it by several radii of
    /// the classical outer box are measured, and each one it certifies must leave the classical
    /// outer set over its own degenerate box non-empty (that set is built from the flattened
    /// problem, an independent construction); some must be rejected.
    #[test]
    fn a_lagged_problem_certifies_its_truth_and_only_points_its_outer_set_admits() {
        use rand::{Rng, SeedableRng};
        let (mut rejected, mut certified) = (0, 0);
        for seed in 0..12u64 {
            let case = feedback_case(seed);
            let theta = &case.theta;
            let prob = EivProblem {
                locate: false,
                ..case.problem()
            };
            let s = consistency_at(&prob, theta).unwrap();
            assert!(s <= CERTIFIED, "seed {seed}: the truth measures {s}");
            let Ok(outer) = crate::stage3::solve(EivMethod::Classical, &prob) else {
                continue;
            };
            let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed + 50);
            for _ in 0..20 {
                let pt: Vec<f64> = theta
                    .iter()
                    .zip(&outer.bounds)
                    .map(|(v, b)| v + rng.gen_range(-3.0..3.0) * b.radius().max(1e-3))
                    .collect();
                if consistency_at(&prob, &pt).unwrap() > CERTIFIED {
                    rejected += 1;
                    continue;
                }
                certified += 1;
                let degenerate: Vec<Interval> = pt
                    .iter()
                    .map(|v| Interval::new(v - 1e-9 * (1.0 + v.abs()), v + 1e-9 * (1.0 + v.abs())))
                    .collect();
                let at = EivProblem {
                    prior: Some(&degenerate),
                    ..prob.clone()
                };
                assert!(
                    crate::stage3::feasible(&at).unwrap(),
                    "seed {seed}: {pt:?} certified, but its outer set is empty"
                );
            }
        }
        assert!(
            rejected > 0 && certified > 0,
            "rejected {rejected}, certified {certified}: vacuous"
        );
    }

    /// The fixed-`a` LP (equations substituted) and the shared-error LP over a degenerate `a`
    /// box (equations as rows, products exact) describe the same set: they must agree on
    /// consistency, at the truth (consistent: the noise is inside its bound) and far from it.
    #[test]
    fn fixed_a_lp_agrees_with_the_shared_model() {
        for seed in 0..8 {
            let (m, out, input) = random_case(seed, 40);
            let prob = problem(&out, &input, true);
            let shared = shared::solve(&prob, &SharedOptions::default()).unwrap();
            let model = SharedModel::new(&prob, shared.equations.clone());
            let mut at = AtA {
                prob: &prob,
                dims: vec![0, 1],
                times: model.times.clone(),
                tb: shared.bounds.clone(),
                lps: 0,
                input_vars: false,
            };
            let r = [shared.bounds[0].radius(), shared.bounds[1].radius()];
            for (shift, consistent) in [(0.0, Some(true)), (3.0, Some(false)), (-3.0, Some(false))]
            {
                let a = [m.a[0] + shift * r[0], m.a[1] - shift * r[1]];
                let phi = at.slack(&a).unwrap();
                let mut tb = shared.bounds.clone();
                tb[0] = Interval::new(a[0], a[0]);
                tb[1] = Interval::new(a[1], a[1]);
                let lp = model
                    .build(&tb, &model.initial_deltas(), &model.times)
                    .unwrap();
                let feasible = lp.solver().unwrap().feasible().unwrap();
                assert_eq!(feasible, consistent, "seed {seed} shift {shift}: shared LP");
                assert_eq!(
                    phi <= 0.0,
                    consistent == Some(true),
                    "seed {seed} shift {shift}: φ = {phi}"
                );
            }
        }
    }

    /// On a record long enough that the fixed-`θ` certificate splits into one LP per chain of
    /// equations, it gives what one solve of the whole LP gives, at the truth (certified) and
    /// at a point moved off it (rejected).
    #[test]
    fn long_record_lps_agree_with_the_whole_lp() {
        for seed in 0..2 {
            let (m, out, input) = random_case(seed, 14_000);
            let prob = problem(&out, &input, false);
            let truth: Vec<f64> = m.a.iter().chain(&m.b).copied().collect();
            let mut far = truth.clone();
            far[0] += 0.05;
            far[3] += 0.05;
            // One solve of the whole LP at a whole θ (the unit gain holds at both points).
            let whole = |at: &[f64]| -> f64 {
                let p = EivProblem {
                    unit_gain: false,
                    ..prob.clone()
                };
                let at_a = AtA {
                    prob: &p,
                    dims: vec![0, 1, 3, 4],
                    times: lp_times(&p),
                    tb: vec![Interval::entire(); p.p()],
                    lps: 0,
                    input_vars: true,
                };
                let lp = at_a.lp(at, true);
                assert!(lp.lp.le.len() > BLOCKS_ABOVE, "too short to test");
                match lp.lp.solver().unwrap().minimise(lp.s).unwrap() {
                    Optimum::Value(v) => v,
                    _ => f64::INFINITY,
                }
            };
            for (what, th) in [("truth", &truth), ("far", &far)] {
                let got = consistency_at(&prob, th).unwrap();
                let free: Vec<f64> = [0, 1, 3, 4].iter().map(|&k| th[k]).collect();
                let w = whole(&free);
                assert!(
                    (got - w).abs() <= 1e-6 * (1.0 + w.abs()),
                    "seed {seed} {what}: chains {got}, whole {w}"
                );
            }
            assert!(
                consistency_at(&prob, &truth).unwrap() <= CERTIFIED,
                "seed {seed}"
            );
            assert!(
                consistency_at(&prob, &far).unwrap() > CERTIFIED,
                "seed {seed}"
            );
        }
    }

    /// The fixed-`a` LP substitutes the exact extra columns in the equations: at the true `a`
    /// the data are consistent, far from it they are not.
    #[test]
    fn fixed_a_lp_with_extra_columns_is_consistent_at_the_truth() {
        for seed in 0..6 {
            let case = random_extra_case(seed, 40, 0.0);
            let prob = case.problem(true);
            let shared = shared::solve(&prob, &SharedOptions::default()).unwrap();
            let mut at = AtA {
                prob: &prob,
                dims: vec![0, 1],
                times: shared.equations.clone(),
                tb: shared.bounds.clone(),
                lps: 0,
                input_vars: false,
            };
            let r = [shared.bounds[0].radius(), shared.bounds[1].radius()];
            let a = [case.m.a[0], case.m.a[1]];
            assert!(
                at.slack(&a).unwrap() <= 0.0,
                "seed {seed}: truth inconsistent"
            );
            // The b's and extra coefficients at the true a: an inner value on each side of the truth.
            for (k, t) in case.truth().into_iter().enumerate().skip(2) {
                let lo = at.value(&a, k, false).unwrap().unwrap();
                let hi = at.value(&a, k, true).unwrap().unwrap();
                let tol = 1e-7 * (1.0 + t.abs());
                assert!(
                    lo <= t + tol && t - tol <= hi,
                    "seed {seed} θ{k}: [{lo}, {hi}] misses {t}"
                );
            }
            for shift in [3.0, -3.0] {
                let far = [a[0] + shift * r[0], a[1] - shift * r[1]];
                assert!(at.slack(&far).unwrap() > 0.0, "seed {seed} shift {shift}");
            }
        }
    }
}
