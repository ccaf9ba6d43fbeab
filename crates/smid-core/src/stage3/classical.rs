//! Stage 3 (paper Section 5) by the classical orthant-wise LP outer set (Cerone 1993): bounds on
//! the linear-block parameters `θ = [a_1..a_na, b_0..b_nb, c_1..c_m]` (eq 7, with the extra
//! regressors' coefficients) from interval-valued inner signals, each equation's error bounded
//! on its own.
//!
//! With `x_t = x^c_t + δx_t`, `|δx_t| <= Δx_t` (eqs 28-30) on the output side, for Hammerstein
//! structures `v_t = v^c_t + δv_t`, `|δv_t| <= Δv_t` on the input side, and
//! `φ_k(t) = φ^c_k(t) + δφ_k(t)`, `|δφ_k(t)| <= Δφ_k(t)` for the extra regressors, each equation
//! `x_t + Σ a_i x_{t-i} = Σ b_j v_{t-j} + Σ c_k φ_k(t)` gives
//! `|x^c_t + Σ a_i x^c_{t-i} - Σ b_j v^c_{t-j} - Σ c_k φ^c_k(t)|
//!  <= Δx_t + Σ |a_i| Δx_{t-i} + Σ |b_j| Δv_{t-j} + Σ |c_k| Δφ_k(t)`,
//! linear in θ inside each sign orthant of the uncertain-multiplied coefficients (exact extra
//! columns are plain LP coefficients, like an exact input). A coefficient whose prior box fixes
//! its sign is not split. The outer set is the union over orthants; its coordinate bounds are the
//! min/max over feasible orthants of one LP pair per parameter. The unit steady-state gain
//! (eq 8) enters as `Σ b_j - Σ a_i = 1`, fixed coefficients as equalities, the prior box as bound
//! rows of every orthant's LP (and the result is intersected with it).
//!
//! The feasibility test of the branch and bound (is the outer set non-empty?) and the location
//! of an emptiness stop at the first feasible orthant, so they try first the orthant of the
//! least-squares fit to the interval centres, then the others by the size of the terms whose
//! sign they flip: the same answer wherever every LP concludes, found in one or two LPs (on
//! the tanks with an input dead zone, 1.7 of 128 instead of 19). An empty outer set still
//! needs every orthant. Where an LP fails, the order can decide whether the test meets the
//! failure or a feasible orthant first: the cell is then kept undecided instead of feasible
//! (or the reverse), never discarded.
//!
//! Guarantee: the LP engine ([`crate::lp`]) relaxes every row outward and widens every optimum.
use super::{EivProblem, EivResult, Stage3Method};
use crate::error::{Result, SmidError, Stage};
use crate::interval::Interval;
use crate::lp::{LpOutcome, Polytope};
use rayon::prelude::*;

/// The method's name (`method.eiv: classical`).
pub const NAME: &str = "classical";

/// The classical orthant-wise LP outer set (`method.eiv: classical`).
#[derive(Debug, Clone, Copy, Default)]
pub struct Classical;

crate::register_stage3!(0, Classical);

impl Stage3Method for Classical {
    fn name(&self) -> &'static str {
        NAME
    }
    fn description(&self) -> &'static str {
        "Orthant-wise LP outer set of Section 5 (Cerone 1993): each equation's error bounded on its own."
    }
    /// Starts from the problem alone (`start` is not read).
    fn solve_from(&self, prob: &EivProblem, _start: EivResult) -> Result<EivResult> {
        solve(prob)
    }
}

/// The sign of θ entry `k` when its prior box fixes it (`+1` inside `[0, ∞)`, `-1` inside
/// `(-∞, 0]`), so that `|θ_k| = sign · θ_k` without splitting.
fn prior_sign(prob: &EivProblem, k: usize) -> Option<f64> {
    let b = prob.prior_of(k);
    if b.lo >= 0.0 {
        Some(1.0)
    } else if b.hi <= 0.0 {
        Some(-1.0)
    } else {
        None
    }
}

/// The terms of equation `t` (eq 7) as `(θ entry, sign, the sample it multiplies)`: the
/// equation is `x_t + Σ sign·θ_k·sample = 0`, with `a_i` on `x_{t-i}` (+), `b_j` on `v_{t-j}`
/// (-) and each extra coefficient on its column (-). The one place the equation's layout and
/// signs are written for the orthant polytopes, their uncertain coefficients and the centre fit.
fn row_terms<'p>(
    prob: &'p EivProblem,
    t: usize,
) -> impl Iterator<Item = (usize, f64, Interval)> + 'p {
    let a = (1..=prob.na).map(move |i| (i - 1, 1.0, prob.output[t - i].interval));
    let b = (0..=prob.nb).map(move |j| (prob.na + j, -1.0, prob.input[t - j]));
    let extra = prob
        .extra
        .iter()
        .enumerate()
        .map(move |(e, r)| (prob.n_ab() + e, -1.0, r.values[t]));
    a.chain(b).chain(extra)
}

/// Which θ entries multiply an uncertain quantity (and so split into orthants, unless the prior
/// fixes their sign), in θ order.
fn uncertain_coefficients(prob: &EivProblem, times: &[usize]) -> Vec<usize> {
    let mut uncertain = vec![false; prob.p()];
    for &t in times {
        for (k, _, iv) in row_terms(prob, t) {
            uncertain[k] |= iv.radius() > 0.0;
        }
    }
    (0..prob.p())
        .filter(|&k| uncertain[k] && prob.fixed[k].is_none() && prior_sign(prob, k).is_none())
        .collect()
}

/// The orthant's polytope over the free θ entries (columns in the order of `free`); fixed
/// entries are constants of the rows.
fn polytope(
    prob: &EivProblem,
    times: &[usize],
    signs: &[(usize, f64)],
    free: &[usize],
) -> Polytope {
    let p = prob.p();
    let sign_of = |k: usize| {
        signs
            .iter()
            .find(|(i, _)| *i == k)
            .map(|(_, s)| *s)
            .or_else(|| prior_sign(prob, k))
    };
    let n = free.len();
    let col = columns(p, free);
    let mut poly = Polytope::new(n);
    // Each row's sum `x_t + Σ a_i x_{t-i} - Σ b_j v_{t-j} - Σ c_k φ_k(t)` ranges, for θ in the
    // orthant, over [lo0 + lo·θ, hi0 + hi·θ]; the equation holds for some samples in their
    // bounds iff 0 lies in it. With centres and radii (eqs 28-30) these ends are
    // `e_t(θ) ∓ slack(θ)`, `e_t = x^c_t + Σ a_i x^c_{t-i} - Σ b_j v^c_{t-j} - Σ c_k φ^c_k(t)`,
    // `slack = Δx_t + Σ |a_i| Δx_{t-i} + Σ |b_j| Δv_{t-j} + Σ |c_k| Δφ_k(t)`, `|a| = s a` in the
    // orthant. A sample known from one side only (a clipped one) leaves one end infinite: that
    // row gives one half-space, or none.
    let mut lo = vec![0.0; n];
    let mut hi = vec![0.0; n];
    for &t in times {
        lo.iter_mut().for_each(|v| *v = 0.0);
        hi.iter_mut().for_each(|v| *v = 0.0);
        let xt = prob.output[t].interval;
        let (mut lo0, mut hi0) = (xt.lo, xt.hi);
        // θ_k times `sign · iv`: its ends in the orthant.
        let mut term = |k: usize, sign: f64, iv: Interval, lo0: &mut f64, hi0: &mut f64| {
            let j = if sign > 0.0 {
                iv
            } else {
                Interval::new(-iv.hi, -iv.lo)
            };
            match prob.fixed[k] {
                Some(0.0) => {}
                Some(v) => {
                    let (a, b) = (v * j.lo, v * j.hi);
                    *lo0 += a.min(b);
                    *hi0 += a.max(b);
                }
                None if j.lo == j.hi => {
                    lo[col[k]] += j.lo;
                    hi[col[k]] += j.lo;
                }
                None if sign_of(k).unwrap_or(1.0) > 0.0 => {
                    lo[col[k]] += j.lo;
                    hi[col[k]] += j.hi;
                }
                None => {
                    lo[col[k]] += j.hi;
                    hi[col[k]] += j.lo;
                }
            }
        };
        for (k, sign, iv) in row_terms(prob, t) {
            term(k, sign, iv, &mut lo0, &mut hi0);
        }
        // lo0 + lo·θ <= 0 and -(hi0 + hi·θ) <= 0, each where its end is finite.
        if lo0.is_finite() && lo.iter().all(|v| v.is_finite()) {
            poly.push_le(&lo, -lo0, t);
        }
        if hi0.is_finite() && hi.iter().all(|v| v.is_finite()) {
            hi.iter_mut().for_each(|v| *v = -*v);
            poly.push_le(&hi, hi0, t);
        }
    }
    let mut g = vec![0.0; n];
    let unit = |c: usize, v: f64, g: &mut Vec<f64>| {
        g.iter_mut().for_each(|x| *x = 0.0);
        g[c] = v;
    };
    for &(k, sgn) in signs {
        unit(col[k], -sgn, &mut g); // s θ_k >= 0
        poly.push_le(&g, 0.0, usize::MAX);
    }
    for (c, &k) in free.iter().enumerate() {
        // The prior box: θ_k <= hi, -θ_k <= -lo.
        let b = prob.prior_of(k);
        if b.hi.is_finite() {
            unit(c, 1.0, &mut g);
            poly.push_le(&g, b.hi, usize::MAX);
        }
        if b.lo.is_finite() {
            unit(c, -1.0, &mut g);
            poly.push_le(&g, -b.lo, usize::MAX);
        }
    }
    if prob.unit_gain {
        // Σ b_j - Σ a_i = 1 (eq 8); the extras do not enter; fixed entries move to the right.
        let mut row = vec![0.0; n];
        let mut rhs = 1.0;
        for k in 0..p {
            match prob.fixed[k] {
                Some(v) => rhs -= prob.gain_sign(k) * v,
                None => row[col[k]] = prob.gain_sign(k),
            }
        }
        if row.iter().any(|&v| v != 0.0) {
            poly.push_eq(&row, rhs);
        } else if rhs.abs() > 1e-9 {
            // Every coefficient of the gain is fixed, and they miss it: the set is empty.
            poly.push_le(&vec![0.0; n], -1.0, usize::MAX);
        }
    }
    poly
}

fn orthants(unc: &[usize]) -> Vec<Vec<(usize, f64)>> {
    (0..(1usize << unc.len()))
        .map(|mask| {
            unc.iter()
                .enumerate()
                .map(|(bit, &k)| (k, if mask >> bit & 1 == 1 { -1.0 } else { 1.0 }))
                .collect()
        })
        .collect()
}

/// The least-squares fit of the centre equations `e_t(θ) = 0` (eq 28 with every sample at its
/// interval's centre) over the rows `times`, with the size of each θ entry's term in it,
/// `|θ̂_k| ‖column k‖` (fixed entries: their value, size 0); rows with a centre that is not
/// finite (a clipped sample) are left out. `None` when fewer rows than free entries remain or
/// the fit is not finite.
fn centre_fit(prob: &EivProblem, times: &[usize], free: &[usize]) -> Option<(Vec<f64>, Vec<f64>)> {
    let p = prob.p();
    let n = free.len();
    let col = columns(p, free);
    let mut rows: Vec<(Vec<f64>, f64)> = Vec::new();
    for &t in times {
        // x_t + Σ a_i x_{t-i} - Σ b_j v_{t-j} - Σ c_k φ_k(t) = 0 at the centres.
        let mut row = vec![0.0; n];
        let mut rhs = -prob.output[t].interval.center();
        let mut term = |k: usize, v: f64| match prob.fixed[k] {
            Some(f) => rhs -= f * v,
            None => row[col[k]] += v,
        };
        for (k, sign, iv) in row_terms(prob, t) {
            term(k, sign * iv.center());
        }
        if rhs.is_finite() && row.iter().all(|v| v.is_finite()) {
            rows.push((row, rhs));
        }
    }
    if rows.len() < n || n == 0 {
        return None;
    }
    let fit = crate::linear::least_squares(&rows);
    if fit.iter().any(|v| !v.is_finite()) {
        return None;
    }
    let mut theta = vec![0.0; p];
    let mut size = vec![0.0; p];
    for k in 0..p {
        match prob.fixed[k] {
            Some(f) => theta[k] = f,
            None => {
                let c = col[k];
                let norm = rows.iter().map(|r| r.0[c] * r.0[c]).sum::<f64>().sqrt();
                theta[k] = fit[c];
                size[k] = fit[c].abs() * norm;
            }
        }
    }
    Some((theta, size))
}

/// The orthants of `unc` in the order a feasibility test tries them: first the orthant of the
/// signs of the centre fit ([`centre_fit`]), then the others by the total size of the terms
/// whose sign they flip (ties in [`orthants`]' order). Only the order changes: the outer set is
/// non-empty when any orthant is, so a test's answer is the same, found sooner (a cell that
/// holds the data's θ usually holds it in the fit's orthant).
fn orthants_by_fit(
    prob: &EivProblem,
    times: &[usize],
    unc: &[usize],
    free: &[usize],
) -> Vec<Vec<(usize, f64)>> {
    let mut all = orthants(unc);
    if all.len() > 1 {
        if let Some((theta, size)) = centre_fit(prob, times, free) {
            let cost = |signs: &Vec<(usize, f64)>| -> f64 {
                signs
                    .iter()
                    .filter(|&&(k, s)| theta[k] * s < 0.0)
                    .map(|&(k, _)| size[k])
                    .sum()
            };
            all.sort_by(|a, b| cost(a).total_cmp(&cost(b)));
        }
    }
    all
}

/// Whether any orthant's polytope is non-empty, tried in [`orthants_by_fit`]'s order.
fn any_feasible(prob: &EivProblem, times: &[usize], unc: &[usize]) -> Result<bool> {
    let free = free_of(prob);
    first_feasible(
        prob,
        times,
        &orthants_by_fit(prob, times, unc, &free),
        &free,
    )
}

/// Whether any of `orthants` has a non-empty polytope, tried in the order given (the first
/// feasible one ends the test). `false` only when every one is empty; an LP that fails before a
/// feasible one is found is the answer (an error: the caller keeps the cell undecided).
fn first_feasible(
    prob: &EivProblem,
    times: &[usize],
    orthants: &[Vec<(usize, f64)>],
    free: &[usize],
) -> Result<bool> {
    for signs in orthants {
        if polytope(prob, times, signs, free).feasible()? {
            return Ok(true);
        }
    }
    Ok(false)
}

/// Whether the classical outer set is non-empty: one LP per sign orthant until one is feasible.
/// `false` proves the data inconsistent (the outer set contains the exact one); `true` proves
/// nothing. Far cheaper than the bounds (no objective), for pruning in a branch and bound.
pub fn feasible(prob: &EivProblem) -> Result<bool> {
    prob.validate()?;
    let times = row_times(prob, &prob.equation_times());
    let unc = uncertain_coefficients(prob, &times);
    any_feasible(prob, &times, &unc)
}

/// The times of the rows: every equation of `equations` (the two-sided ones,
/// [`EivProblem::equation_times`]: two half-spaces each) and of [`EivProblem::one_sided_times`]
/// (one), in time order.
fn row_times(prob: &EivProblem, equations: &[usize]) -> Vec<usize> {
    let mut times = equations.to_vec();
    times.extend(prob.one_sided_times());
    times.sort_unstable();
    times
}

/// The free θ entries, in θ order (the columns of the orthant polytopes).
fn free_of(prob: &EivProblem) -> Vec<usize> {
    (0..prob.p()).filter(|&k| prob.fixed[k].is_none()).collect()
}

/// Each θ entry's column among the `free` ones (`usize::MAX` for a fixed entry).
fn columns(p: usize, free: &[usize]) -> Vec<usize> {
    let mut col = vec![usize::MAX; p];
    for (c, &k) in free.iter().enumerate() {
        col[k] = c;
    }
    col
}

/// Solve: per-parameter guaranteed bounds (union over orthants).
pub fn solve(prob: &EivProblem) -> Result<EivResult> {
    let p = prob.p();
    let start = prob.start_box()?;
    // The two-sided equations are the result's (a start for the methods that refine it).
    let equations = prob.equation_times();
    let times = row_times(prob, &equations);
    let free = free_of(prob);
    let counted = match times.len() - equations.len() {
        0 => format!("{} usable equations", equations.len()),
        half => format!("{} usable equations and {half} one-sided", equations.len()),
    };
    // Parameters the prior does not bound need the equations.
    let open = free.iter().filter(|&&k| !start[k].is_finite()).count();
    let n_eq = open.saturating_sub(usize::from(prob.unit_gain));
    if open > 0 && times.len() < n_eq.max(1) {
        return Err(SmidError::Unbounded {
            parameter: "θ".into(),
            message: format!(
                "only {counted} for {} free parameters ({}): lengthen the dynamic experiment (or, where a regressor is unknown at all, shorten the delay or lags that reach past it), or enable band samples",
                free.len(),
                prob.unusable_summary()
            ),
        });
    }
    let unc = uncertain_coefficients(prob, &times);
    let mut lo = vec![f64::INFINITY; p];
    let mut hi = vec![f64::NEG_INFINITY; p];
    let mut feasible = 0;
    let names = prob.names();
    // The orthants' LPs are independent: solved in parallel, combined in orthant order (the
    // first error in that order is the one reported; min/max do not depend on the order).
    let outcomes: Vec<Result<LpOutcome>> = orthants(&unc)
        .par_iter()
        .map(|signs| polytope(prob, &times, signs, &free).bound())
        .collect();
    for outcome in outcomes {
        let bounded = outcome.map_err(|e| match e {
            SmidError::Unbounded { parameter, message } => SmidError::Unbounded {
                parameter: parameter
                    .trim_start_matches("θ[")
                    .trim_end_matches(']')
                    .parse::<usize>()
                    .ok()
                    .and_then(|c| free.get(c).and_then(|&k| names.get(k)).cloned())
                    .unwrap_or(parameter),
                message: format!(
                    "{message} ({counted}; a longer or richer dynamic experiment helps)"
                ),
            },
            other => other,
        })?;
        match bounded {
            LpOutcome::Infeasible => {}
            LpOutcome::Bounds(b) => {
                feasible += 1;
                for (c, &k) in free.iter().enumerate() {
                    lo[k] = lo[k].min(b[c].lo);
                    hi[k] = hi[k].max(b[c].hi);
                }
            }
        }
    }
    if feasible == 0 {
        let and_prior = if prob.prior.is_some() {
            " and the prior box"
        } else {
            ""
        };
        return Err(prob.emptied(
            &times,
            |prefix| any_feasible(prob, prefix, &unc),
            |t| format!("no θ satisfies the equations up to t = {t} within their error bounds{and_prior}"),
        )?);
    }
    // Fixed entries at their values; the others inside the prior (the LP's pads may reach past
    // it, and the truth is inside it by assumption).
    let mut bounds = Vec::with_capacity(p);
    for k in 0..p {
        bounds.push(match prob.fixed[k] {
            Some(v) => Interval::new(v, v),
            None => {
                // The LP's bounds contain the set; the set lies inside the prior: bounds that
                // miss the prior leave it empty.
                let (l, h) = (lo[k].max(start[k].lo), hi[k].min(start[k].hi));
                if l > h {
                    let sample = times.last().copied().unwrap_or(0);
                    return Err(SmidError::inconsistent_unlocated(Stage::Linear, sample, format!( "the equations up to t = {sample} leave `{}` outside its prior [{}, {}]", names[k], start[k].lo, start[k].hi )));
                }
                Interval::new(l, h)
            }
        });
    }
    Ok(EivResult {
        bounds,
        equations,
        feasible_orthants: feasible,
        unsettled: None,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::inversion::{InnerBound, InnerKind};
    use crate::linear::LinearModel;
    use crate::stage3::testutil::{
        cases, problem, random_case, random_extra_case, truth, ExtraCase,
    };
    use proptest::prelude::*;

    fn bounds_from(x: &[f64], dx: f64) -> Vec<InnerBound> {
        x.iter()
            .map(|&v| InnerBound {
                interval: Interval::new(v - dx, v + dx),
                kind: InnerKind::Inverted,
            })
            .collect()
    }

    #[test]
    fn recovers_paper_linear_block_from_exact_and_noisy_inner_signal() {
        let m = LinearModel {
            a: vec![0.5, 0.7],
            b: vec![0.0, 1.4, 0.8],
        };
        let u: Vec<f64> = (0..120)
            .map(|t| if (t * 7 + 3) % 11 < 5 { 1.0 } else { -1.0 })
            .collect();
        let x = m.simulate(&u);
        let input: Vec<Interval> = u.iter().map(|&v| Interval::new(v, v)).collect();
        for dx in [1e-6, 1e-3] {
            let out = bounds_from(&x, dx);
            let prob = EivProblem {
                locate: true,
                na: 2,
                nb: 2,
                fixed: vec![None, None, Some(0.0), None, None],
                unit_gain: true,
                output: &out,
                input: &input,
                use_band_samples: false,
                lagged: None,
                extra: &[],
                prior: None,
            };
            let r = solve(&prob).unwrap();
            let truth = [0.5, 0.7, 0.0, 1.4, 0.8];
            for (b, t) in r.bounds.iter().zip(truth) {
                assert!(b.contains(t), "dx={dx}: {b:?} misses {t}");
                assert!(b.radius() < 200.0 * dx + 1e-7, "dx={dx}: too wide {b:?}");
            }
        }
    }

    #[test]
    fn inconsistent_data_name_the_first_offending_equation() {
        let m = LinearModel {
            a: vec![0.5],
            b: vec![0.0, 1.5],
        };
        let u: Vec<f64> = (0..60)
            .map(|t| if t % 3 == 0 { 1.0 } else { -1.0 })
            .collect();
        let mut x = m.simulate(&u);
        x[40] += 0.5; // an outlier far beyond the bound
        let out = bounds_from(&x, 1e-4);
        let input: Vec<Interval> = u.iter().map(|&v| Interval::new(v, v)).collect();
        let prob = EivProblem {
            locate: true,
            na: 1,
            nb: 1,
            fixed: vec![None, Some(0.0), None],
            unit_gain: true,
            output: &out,
            input: &input,
            use_band_samples: false,
            lagged: None,
            extra: &[],
            prior: None,
        };
        match solve(&prob) {
            Err(SmidError::Inconsistent(crate::outcome::Falsification {
                stage: Stage::Linear,
                sample,
                ..
            })) => assert!(sample == 40 || sample == 41, "{sample}"),
            other => panic!("expected inconsistency, got {other:?}"),
        }
    }

    /// Inner intervals so wide that unstable explanations fit: θ is unbounded, until the block
    /// is declared stable; then every bound is finite, holds the truth, and each `a_i` lies in
    /// `±C(na, i)`.
    #[test]
    fn a_declared_stable_block_bounds_what_wide_data_leave_open() {
        let prior = crate::stage3::stable_prior(2, 5);
        assert_eq!(prior[0], Interval::new(-2.0, 2.0));
        assert_eq!(prior[1], Interval::new(-1.0, 1.0));
        assert!(!prior[2].is_finite());
        for seed in 0..4u64 {
            let (m, out, input) = random_case(seed, 60);
            let wide: Vec<InnerBound> = out
                .iter()
                .map(|b| InnerBound {
                    interval: Interval::new(b.interval.lo - 3.0, b.interval.hi + 3.0),
                    kind: b.kind,
                })
                .collect();
            let open = problem(&wide, &input, false);
            assert!(
                matches!(solve(&open), Err(SmidError::Unbounded { .. })),
                "seed {seed}: {:?}",
                solve(&open)
            );
            let mut stable = problem(&wide, &input, false);
            stable.prior = Some(&prior);
            let r = solve(&stable).unwrap();
            for (k, (b, t)) in r.bounds.iter().zip(truth(&m)).enumerate() {
                assert!(
                    b.is_finite() && b.contains(t),
                    "seed {seed} θ{k}: {b:?} vs {t}"
                );
                assert!(prior[k].lo <= b.lo && b.hi <= prior[k].hi, "{b:?}");
            }
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig { cases: 8, .. ProptestConfig::default() })]
        #[test]
        fn classical_bounds_contain_the_truth(seed in any::<u64>(), band in any::<bool>()) {
            let (m, out, input) = random_case(seed, 50);
            let r = match solve(&problem(&out, &input, band)) {
                Err(SmidError::Unbounded { .. }) => { prop_assume!(false); unreachable!() }
                other => other.unwrap(),
            };
            for (k, t) in truth(&m).into_iter().enumerate() {
                prop_assert!(r.bounds[k].contains(t), "{:?} misses {}", r.bounds[k], t);
            }
        }
    }

    proptest! {
        #![proptest_config(cases(8))]
        /// Extra columns (an exact offset; a friction column, exact or known to ±0.05): the
        /// truth, extra coefficients included, is inside.
        #[test]
        fn classical_with_extra_columns_contains_the_truth(
            seed in any::<u64>(),
            band in any::<bool>(),
            uncertain in any::<bool>(),
        ) {
            let case = random_extra_case(seed, 60, if uncertain { 0.05 } else { 0.0 });
            let r = match solve(&case.problem(band)) {
                Err(SmidError::Unbounded { .. }) => { prop_assume!(false); unreachable!() }
                other => other.unwrap(),
            };
            prop_assert_eq!(r.bounds.len(), 7);
            for (k, t) in case.truth().into_iter().enumerate() {
                prop_assert!(r.bounds[k].contains(t), "θ{}: {:?} misses {}", k, r.bounds[k], t);
            }
        }
    }

    /// [`random_extra_case`] with its input known only to ±`du` (its intervals placed at
    /// random around the true input) and its output intervals scaled by `shrink` about their
    /// centres (below 1 the data may be inconsistent): every coefficient but the fixed `b0`
    /// multiplies an uncertain quantity.
    fn uncertain_everywhere(seed: u64, du: f64, shrink: f64) -> ExtraCase {
        use rand::{Rng, SeedableRng};
        let mut case = random_extra_case(seed, 60, 0.05);
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed ^ 0x5eed);
        for v in case.input.iter_mut() {
            let c = v.center() + rng.gen_range(-du..=du);
            *v = Interval::new(c - du, c + du);
        }
        for b in case.out.iter_mut() {
            let (c, r) = (b.interval.center(), b.interval.radius() * shrink);
            b.interval = Interval::new(c - r, c + r);
        }
        case
    }

    proptest! {
        #![proptest_config(cases(24))]
        /// The feasibility test tries the orthants nearest the centre fit first; its answer is
        /// the one of trying them all in any order (checked against the plain enumeration), on
        /// consistent and on shrunk, inconsistent data alike.
        #[test]
        fn the_order_of_the_orthants_changes_no_feasibility_answer(
            seed in any::<u64>(),
            du in 0.0f64..0.01,
            shrink in 0.0f64..1.5,
        ) {
            let case = uncertain_everywhere(seed, du, shrink);
            let prob = case.problem(false);
            let times = row_times(&prob, &prob.equation_times());
            let unc = uncertain_coefficients(&prob, &times);
            let free = free_of(&prob);
            let mut ordered = orthants_by_fit(&prob, &times, &unc, &free);
            let mut plain = orthants(&unc);
            // Every orthant decided (a failed LP leaves the answer to the order: not compared).
            let Ok(each) = plain
                .iter()
                .map(|s| polytope(&prob, &times, s, &free).feasible())
                .collect::<Result<Vec<bool>>>()
            else {
                prop_assume!(false);
                unreachable!()
            };
            let any = each.into_iter().any(|f| f);
            prop_assert_eq!(feasible(&prob).unwrap(), any);
            // The same orthants, each once.
            let key = |s: &Vec<(usize, f64)>| s.iter().map(|&(k, v)| (k, v > 0.0)).collect::<Vec<_>>();
            ordered.sort_by_key(key);
            plain.sort_by_key(key);
            prop_assert_eq!(ordered, plain);
        }
    }

    /// The test goes on past empty orthants: on data that hold the truth, with the truth's
    /// orthant placed last (every other one first, in the fit's order reversed), the set is
    /// found non-empty; with the truth's orthant left out and the data tight, the others may
    /// all be empty, and then the answer is `false` only because every one was tried.
    #[test]
    fn a_feasible_orthant_is_found_wherever_it_stands_in_the_order() {
        let mut last = 0;
        for seed in 0..20u64 {
            let case = uncertain_everywhere(seed, 1e-3, 1.0);
            let truth = case.truth();
            let prob = case.problem(false);
            let times = row_times(&prob, &prob.equation_times());
            let unc = uncertain_coefficients(&prob, &times);
            let free = free_of(&prob);
            let is_truths = |s: &Vec<(usize, f64)>| s.iter().all(|&(k, v)| v * truth[k] >= 0.0);
            let mut order = orthants_by_fit(&prob, &times, &unc, &free);
            order.reverse();
            let Some(at) = order.iter().position(is_truths) else {
                continue;
            };
            let truths = order.remove(at);
            let others_empty = !first_feasible(&prob, &times, &order, &free).unwrap();
            order.push(truths);
            assert!(
                first_feasible(&prob, &times, &order, &free).unwrap(),
                "seed {seed}: the truth's orthant, tried last, was not found feasible"
            );
            last += usize::from(others_empty);
        }
        assert!(
            last >= 3,
            "only {last} cases where every other orthant is empty"
        );
    }

    /// On data that hold the truth tightly, the first orthant tried is the truth's: every
    /// uncertain coefficient's sign as the true block's (cases whose true coefficients are all
    /// clear of zero).
    #[test]
    fn the_first_orthant_tried_is_the_one_of_the_truth() {
        let mut tried = 0;
        for seed in 0..40u64 {
            let case = uncertain_everywhere(seed, 1e-3, 1.0);
            let truth = case.truth();
            let prob = case.problem(false);
            let times = row_times(&prob, &prob.equation_times());
            let unc = uncertain_coefficients(&prob, &times);
            if unc.iter().any(|&k| truth[k].abs() < 0.05) {
                continue;
            }
            assert!(unc.len() >= 4, "seed {seed}: {unc:?}");
            let first = &orthants_by_fit(&prob, &times, &unc, &free_of(&prob))[0];
            for &(k, s) in first {
                assert!(
                    s * truth[k] > 0.0,
                    "seed {seed}: θ{k} = {} tried first with sign {s}",
                    truth[k]
                );
            }
            tried += 1;
        }
        assert!(
            tried >= 10,
            "only {tried} cases with every coefficient clear of zero"
        );
    }

    /// An uncertain extra column splits its coefficient's sign orthants, unless the prior fixes
    /// its sign; either way the truth is inside.
    #[test]
    fn an_uncertain_extra_column_splits_orthants_unless_the_prior_fixes_its_sign() {
        let case = random_extra_case(5, 60, 0.05);
        let prob = case.problem(false);
        let times = prob.equation_times();
        assert!(uncertain_coefficients(&prob, &times).contains(&6));
        let truth = case.truth();
        let mut prior = vec![Interval::entire(); 7];
        prior[6] = if truth[6] >= 0.0 {
            Interval::new(0.0, 1.0)
        } else {
            Interval::new(-1.0, 0.0)
        };
        let with_prior = EivProblem {
            prior: Some(&prior),
            ..prob.clone()
        };
        assert!(!uncertain_coefficients(&with_prior, &times).contains(&6));
        for p in [&prob, &with_prior] {
            let r = solve(p).unwrap();
            for (k, t) in truth.iter().enumerate() {
                assert!(
                    r.bounds[k].contains(*t),
                    "θ{k}: {:?} misses {t}",
                    r.bounds[k]
                );
            }
        }
    }

    /// The prior enters every orthant's LP as bound rows, so a prior on the a's alone also
    /// narrows the b's and the extra coefficients (the set is coupled), never cutting the truth.
    #[test]
    fn a_prior_on_the_a_coefficients_narrows_the_others() {
        let case = random_extra_case(4, 60, 0.05);
        let prob = case.problem(true);
        let truth = case.truth();
        let free = solve(&prob).unwrap();
        let mut prior = vec![Interval::entire(); 7];
        for k in 0..2 {
            let r = 0.25 * free.bounds[k].radius();
            prior[k] = Interval::new(truth[k] - r, truth[k] + r);
        }
        let r = solve(&EivProblem {
            prior: Some(&prior),
            ..prob.clone()
        })
        .unwrap();
        let mut narrower = 0;
        for (k, (&b, &f)) in r.bounds.iter().zip(&free.bounds).enumerate() {
            assert!(b.contains(truth[k]), "θ{k}: {b:?} misses {}", truth[k]);
            // Two LPs, each within its own pads of the exact bound.
            let tol = 1e-7 * (1.0 + f.lo.abs().max(f.hi.abs()));
            assert!(
                f.lo - tol <= b.lo && b.hi <= f.hi + tol,
                "θ{k}: {b:?} wider than {f:?}"
            );
            if k >= 3 && b.radius() < 0.9 * f.radius() {
                narrower += 1;
            }
        }
        assert!(narrower > 0, "{:?} vs {:?}", r.bounds, free.bounds);
    }

    /// Samples clipped at a level (known only to lie above it, as a saturation's inversion
    /// gives them) add half-spaces: the bounds still hold the truth and never widen against the
    /// same samples taken as unknown; where the unclipped equations alone leave θ unbounded
    /// (clipped records rarely separate `b1` from `b2`), the half-spaces mostly bound it.
    #[test]
    fn one_sided_samples_add_half_spaces_that_hold_the_truth_and_bound_clipped_records() {
        let (mut unbounded, mut rescued) = (0, 0);
        let runs = 24;
        for seed in 0..runs {
            let (m, mut out, input) = random_case(7000 + seed, 150);
            // Clip above the median of the centres (from below for odd seeds).
            let flip = if seed % 2 == 0 { 1.0 } else { -1.0 };
            let mut c: Vec<f64> = out.iter().map(|b| flip * b.interval.center()).collect();
            c.sort_by(f64::total_cmp);
            let level = c[c.len() / 2];
            let mut unknown = out.clone();
            let mut clipped = 0;
            for (t, b) in out.iter_mut().enumerate() {
                let (lo, hi) = (b.interval.lo, b.interval.hi);
                let above = if flip > 0.0 { lo > level } else { -hi > level };
                if above {
                    b.interval = if flip > 0.0 {
                        Interval::new(level, f64::INFINITY)
                    } else {
                        Interval::new(f64::NEG_INFINITY, -level)
                    };
                    b.kind = InnerKind::Band;
                    unknown[t] = InnerBound::unknown();
                    clipped += 1;
                }
            }
            assert!(clipped > 10, "seed {seed}: only {clipped} samples clipped");
            let with = problem(&out, &input, false);
            assert!(!with.one_sided_times().is_empty(), "seed {seed}");
            let base = solve(&problem(&unknown, &input, false));
            unbounded += usize::from(matches!(base, Err(SmidError::Unbounded { .. })));
            let r = match solve(&with) {
                Ok(r) => r,
                Err(SmidError::Unbounded { .. }) => {
                    // More rows never unbound what fewer rows bound.
                    assert!(
                        base.is_err(),
                        "seed {seed}: unbounded with the half-spaces only"
                    );
                    continue;
                }
                Err(e) => panic!("seed {seed}: {e}"),
            };
            for (k, (b, t)) in r.bounds.iter().zip(truth(&m)).enumerate() {
                assert!(b.contains(t), "seed {seed}: θ[{k}] = {t} outside {b:?}");
            }
            match &base {
                Ok(base) => {
                    assert_eq!(
                        r.equations, base.equations,
                        "seed {seed}: the two-sided equations"
                    );
                    for (k, (b, u)) in r.bounds.iter().zip(&base.bounds).enumerate() {
                        let slack = 1e-9 * (1.0 + u.lo.abs().max(u.hi.abs()));
                        assert!(
                            b.lo >= u.lo - slack && b.hi <= u.hi + slack,
                            "seed {seed}: θ[{k}] {b:?} wider than {u:?}"
                        );
                    }
                }
                // Bounded only thanks to the half-spaces.
                Err(SmidError::Unbounded { .. }) => rescued += 1,
                Err(e) => panic!("seed {seed}: {e}"),
            }
        }
        assert!(
            unbounded > 0 && rescued * 2 > unbounded,
            "bounded {rescued} of the {unbounded} records the unclipped equations leave unbounded"
        );
    }
}
