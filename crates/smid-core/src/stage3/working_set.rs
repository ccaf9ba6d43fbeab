//! The shared-error bounds of stage 3 (`relax.rs`, paper eqs 1, 28-30) for long records, from
//! a **working set** of equations (constraint generation): the LP is solved over a few
//! thousand equations instead of all `N`, and grows only where the rest of the record asks.
//!
//! **Guarantee.** Dropping equations (and the `δ`, `w` only they touch) from the shared-error LP
//! leaves a relaxation: the true `(θ, δ, θδ)` satisfies every kept row and box, so the
//! certified bounds of the smaller LP (weak duality, [`super::ipm`]) hold for the whole record.
//! Whatever the working set, no bound can miss the truth; the set only decides how tight.
//!
//! **Tightness.** The set is made of windows of consecutive equations, each about as long as
//! the model's free response takes to die out (`len`, from the poles at the box centre): inside
//! a window the inner signal follows the dynamics as in the whole record, between windows it may
//! jump. After the LP over `W` is solved for every open objective (an end of one θ's interval;
//! all of them at the start of a round), a forward pass tries to complete each one's primal
//! point `(θ*, δ*)` to a point of the whole LP. With `θ = θ*` fixed, every product
//! `w = θ_k δ_s` enters exactly one equation and its McCormick envelope is an interval in
//! `δ_s`; so, in time order, each equation allows an interval for its newest `δ_t` (eq 1 solved
//! for `x_t`, inside the propagated box). The first window keeps the LP's values (the record's
//! initial condition); later `δ_t` take the LP's value where it has one and the equation allows
//! it (clamped otherwise), else the middle of what is allowed. An equation whose `δ_t` is
//! already fixed is checked. A miss counts when it exceeds [`COMPLETE_TOL`] (relative, beyond
//! the equation's own pad) by more than the accuracy floor: [`ACCURACY_FLOOR`] times the point's
//! own largest residual on `W`, capped at [`FLOOR_CAP`] (a miss no worse than the point's own
//! rows is the solver's accuracy; order-4 points stall near 1e-7). An objective without misses
//! has a point feasible for the whole LP up to that accuracy, so its bound is the whole LP's
//! value up to the solver's gap: it is **closed** and not solved again this round. Each open
//! objective adds windows ending at its [`WINDOWS_PER_OBJECTIVE`] most violated equations; a
//! miss inside `W` comes from upstream (the pass could not follow the LP across a gap), so its
//! window closes the nearest gap before it. The growth also ends when no miss has a gap before
//! it, or when a generation moves no open bound by more than [`SETTLED`] of its width.
//!
//! **Pruning between rounds.** Each solve also says which equations its bound leans on: those
//! whose multiplier's magnitude is above [`SUPPORT_WEIGHT`] of the end's largest (order 4,
//! N = 1e5: about 100-120 per end at 1e-5). A later round of the box iteration (smaller boxes,
//! nearly the same support) starts from the equations some end leaned on in the last round,
//! `na` either side, and the first window; its generations add back the windows its
//! completions miss (one or two generations more). Order 4, N = 1e5: the set is pruned to
//! 1400-1900 equations and grows to 3200-4500 in a round (kept whole, it grew to 7100); the
//! whole run takes 36 s instead of 45 s, every radius within 1e-4 (relative) of the unpruned
//! run's. The first round is not pruned (nothing is known yet).
//!
//! **Cost guard.** When a round's working-set LPs would together cost more than the whole LP's
//! (equations times objectives), or `W` would hold more than half the record, the whole LP
//! answers for the objectives still open. When the generations run out
//! ([`FIRST_ROUND_GENERATIONS`] in the first round, which starts from the wide classical box
//! and only shrinks it and grows the set; [`MAX_GENERATIONS`] later) with objectives still
//! open, each is the last working-set LP's bound that solved it (guaranteed, perhaps looser
//! than the whole LP's), and the box iteration does not end on such a round (`shared.rs`). Two
//! unfinished later rounds (either way), a set without the block form, or `W` past half the
//! record retire the working set: the later rounds solve the whole LP. Measured generations per
//! round: the example specs' order-2 records 3 in the first round and 1-3 in the second (the
//! set ending at 12 % of the record at N = 1e4, 1.4 % at 1e5), random order-2 records of
//! N = 6000 up to 7 in the first; order 4 at N = 1e4 3 in the first round, 3-8 later, the set
//! ending at 21-29 % of the record; at N = 1e5 5-6 after the first, the set ending at 3-5 %.
//!
//! `WS_TRACE=1` prints one line per generation on stderr (size of `W`, open objectives, misses
//! per open objective) and one per round (`shared.rs`).
use super::ipm::SparseRow;
use super::relax::{bound_free, pair_ends, solve_ends, End, Ends, FreeBounds, SharedModel};
use super::EivProblem;
use crate::error::Result;
use crate::interval::Interval;
use crate::linear::LinearModel;
use crate::lp::ROW_PAD;
use rayon::prelude::*;

/// At most this many working-set LPs per round; then each end is the last working-set LP's
/// that solved it.
pub(crate) const MAX_GENERATIONS: usize = 8;

/// Working-set LPs in the first round, which starts from the classical box: its wide box
/// spreads the LP's support, so chasing the whole LP's value there costs many generations
/// (order 4, N = 1e5: 8 generations, still open) while the next round, from the box it
/// leaves, needs the set anyway. The first round only shrinks the box (guaranteed) and grows
/// the set; the rounds never end on it.
pub(crate) const FIRST_ROUND_GENERATIONS: usize = 3;

/// Relative tolerance of the completion, beyond each equation's own pad: a tenth of the result
/// pad ([`crate::lp::RESULT_PAD`]). A point that passes may violate an equation by this much,
/// and the bound moves by about as much (completions passed at 1e-8 and 3e-9 left bounds 1.3
/// and 1.05 pads looser than the whole LP's); the order-2 iterates' own accuracy is about 1e-9.
/// Order-4 iterates stall near 1e-7: [`ACCURACY_FLOOR`] is the larger tolerance there.
const COMPLETE_TOL: f64 = 1e-9;

/// A generation that moves no open bound by more than this fraction of its width ends the
/// growth.
const SETTLED: f64 = 1e-6;

/// A completion miss beyond its tolerance by no more than this many times the working-set
/// point's own largest residual is the solver's accuracy, not a missing equation (order-4
/// points stall near 1e-7).
const ACCURACY_FLOOR: f64 = 2.0;

/// The accuracy floor is at most this, relative to the equations' constants: a point far from
/// feasible does not close its end.
const FLOOR_CAP: f64 = 1e-6;

/// An equation is in an end's support when its weight (the magnitude of its multiplier, see
/// [`super::ipm::Solved::eq_weight`]) exceeds this fraction of the end's largest. Order 4,
/// N = 1e5: 100-120 equations per end above 1e-5; all 16 ends together, 1000-1500 of the
/// set's 7100 above 1e-8. Larger thresholds (1e-5, 1e-3) leave fewer equations and more
/// generations: not faster.
const SUPPORT_WEIGHT: f64 = 1e-7;

/// Windows each objective adds to the working set per generation.
const WINDOWS_PER_OBJECTIVE: usize = 4;

/// The equations of the working set (a sorted subset of the model's equation times).
#[derive(Debug, Clone)]
pub(crate) struct WorkingSet {
    pub times: Vec<usize>,
    /// Equations per window: about the settling time of the model's dynamics.
    pub len: usize,
    /// Rounds not finished by the working set alone: the whole LP answered for the open ends,
    /// or the generations ran out.
    pub unfinished: usize,
    /// The working-set LP has no block form: the sparse path answers every round.
    pub sparse: bool,
    /// Working-set LPs at most in the first round ([`FIRST_ROUND_GENERATIONS`]) and in each
    /// later one ([`MAX_GENERATIONS`]).
    pub first_round_generations: usize,
    pub max_generations: usize,
    /// Rounds bounded so far.
    pub rounds: usize,
    /// Per end, the equations its last working-set LP leaned on (see [`WorkingSet::prune`]).
    pub support: Vec<Vec<usize>>,
}

impl WorkingSet {
    /// The first window of the record and evenly spaced windows of `len` equations, together
    /// about a fiftieth of the record.
    pub fn new(all: &[usize], len: usize) -> Self {
        let len = len.max(1);
        let count = (all.len() / 50 / len).max(1);
        let mut times: Vec<usize> = all.iter().copied().take(len).collect();
        for i in 1..count {
            let at = i * all.len() / count;
            times.extend(all.iter().copied().skip(at).take(len));
        }
        times.sort_unstable();
        times.dedup();
        WorkingSet {
            times,
            len,
            unfinished: 0,
            sparse: false,
            first_round_generations: FIRST_ROUND_GENERATIONS,
            max_generations: MAX_GENERATIONS,
            rounds: 0,
            support: Vec::new(),
        }
    }

    /// The equations to add after a generation: each objective's windows ending at its most
    /// violated equations (one per stretch of `len`, at most [`WINDOWS_PER_OBJECTIVE`]). A miss
    /// inside W comes from upstream (the pass could not follow the LP across a gap): its window
    /// closes the nearest gap before it. A miss with all of the record before it in W is the
    /// solver's accuracy: nothing to add. `misses` holds indices into `all`.
    fn windows_for(&self, all: &[usize], misses: Vec<Vec<(f64, usize)>>) -> Vec<usize> {
        // The nearest equation at or before each one that is not in W (one pass).
        let mut gap_at: Vec<Option<usize>> = Vec::with_capacity(all.len());
        let mut w = self.times.iter().peekable();
        for (i, t) in all.iter().enumerate() {
            let inside = w.peek() == Some(&t);
            if inside {
                w.next();
            }
            let before = if i > 0 { gap_at[i - 1] } else { None };
            gap_at.push(if inside { before } else { Some(i) });
        }
        let mut add = Vec::new();
        for mut m in misses {
            m.sort_by(|a, b| b.0.total_cmp(&a.0));
            let mut chosen: Vec<usize> = Vec::new();
            for &(_, i) in &m {
                if chosen.len() >= WINDOWS_PER_OBJECTIVE {
                    break;
                }
                let Some(end) = gap_at[i] else {
                    continue;
                };
                if chosen.iter().any(|&c| c.abs_diff(end) < self.len) {
                    continue;
                }
                chosen.push(end);
                add.extend(
                    all[(end + 1).saturating_sub(self.len)..=end]
                        .iter()
                        .copied(),
                );
            }
        }
        add
    }

    /// Whether the later rounds should solve the whole LP: two rounds were unfinished, the
    /// set has no block form, or it holds half the record (`all` equations).
    pub fn retired(&self, all: usize) -> bool {
        self.unfinished >= 2 || self.sparse || self.too_large(all)
    }

    /// `W` holds more than half the record: the whole LP costs about as much.
    fn too_large(&self, all: usize) -> bool {
        2 * self.times.len() > all
    }

    /// Drop the equations no end leaned on at the end of the last round: keep the first window
    /// (the completion starts from the LP's values there) and each equation in some end's
    /// support with `margin` equations either side. A smaller set is still a relaxation (the
    /// guarantee does not depend on it); where the completion then misses, the generations add
    /// the windows back.
    fn prune(&mut self, all: &[usize], margin: usize) {
        if self.support.is_empty() || all.is_empty() {
            return;
        }
        let mut keep = vec![false; all.len()];
        keep.iter_mut().take(self.len).for_each(|k| *k = true);
        for &t in self.support.iter().flatten() {
            if let Ok(i) = all.binary_search(&t) {
                let hi = (i + margin).min(all.len() - 1);
                keep[i.saturating_sub(margin)..=hi]
                    .iter_mut()
                    .for_each(|k| *k = true);
            }
        }
        self.times = all
            .iter()
            .zip(&keep)
            .filter(|(_, k)| **k)
            .map(|(&t, _)| t)
            .collect();
    }

    /// Record, for each end of `ends` just solved over the set (`found`, same order), the
    /// equations it leaned on: weight above [`SUPPORT_WEIGHT`] of its largest.
    fn lean(&mut self, n_ends: usize, ends: &[usize], found: &[End]) {
        self.support.resize(n_ends, Vec::new());
        for (&i, e) in ends.iter().zip(found) {
            let top = e.weight.iter().fold(0.0f64, |a, b| a.max(*b));
            self.support[i] = self
                .times
                .iter()
                .zip(&e.weight)
                .filter(|(_, w)| **w > SUPPORT_WEIGHT * top)
                .map(|(&t, _)| t)
                .collect();
        }
    }

    fn add(&mut self, more: impl IntoIterator<Item = usize>) {
        self.times.extend(more);
        self.times.sort_unstable();
        self.times.dedup();
    }
}

/// Equations per working-set window: the samples the model's free response needs to fall to
/// `1e-6` of its start (spectral radius of `A` at the centre of the box `tb`), within
/// `[4 na, 400]` (at least `4 na`); 50 when `A` is not stable there or not finite.
pub(crate) fn window_len(prob: &EivProblem, tb: &[Interval]) -> usize {
    let na = prob.na;
    let lo = (4 * na).max(4);
    if na == 0 {
        return lo;
    }
    let a: Vec<f64> = (0..na)
        .map(|k| prob.fixed[k].unwrap_or_else(|| tb[k].center()))
        .collect();
    let rho = LinearModel { a, b: vec![1.0] }.spectral_radius();
    if !(rho.is_finite() && rho < 1.0) {
        return 50.max(lo);
    }
    if rho < 1e-3 {
        return lo;
    }
    let n = ((1e-6f64).ln() / rho.ln()).ceil();
    (n as usize).min(400).max(lo)
}

/// Bound every free θ of the shared LP over the whole record (`model.times`), by LPs over the
/// working set `ws` (grown as needed). As [`bound_free`]: `None` when the LP is proven empty.
/// With the bounds, whether they are **conclusive**: every end closed by its completion, or the
/// growth ended because the open ends settled or no miss had a gap before it (the whole LP's
/// bounds up to the solver's accuracy), or the whole LP answered for the open ends. `false`
/// when the generations ran out with ends still open: each end is then the last working-set
/// LP's that solved it (guaranteed, perhaps looser), and the caller does not end its rounds on
/// such a round.
pub(crate) fn bound_free_ws(
    model: &SharedModel,
    tb: &[Interval],
    db: &[Interval],
    ws: &mut WorkingSet,
) -> Result<Option<(FreeBounds, bool)>> {
    let all = &model.times;
    let n_ends = 2 * model.free.len();
    // Per end (`2c`: lower end of free θ `c`, `2c + 1`: upper): its bound from the last LP that
    // solved it (`None`: not finite). `open`: the ends whose completion has not passed yet; a
    // closed end is the whole LP's value and is not solved again this round.
    let mut value: Vec<Option<f64>> = vec![None; n_ends];
    let mut open: Vec<usize> = (0..n_ends).collect();
    // Equations times ends solved by this round's generations: past the whole LP's, or with W
    // past half the record, the whole LP is the cheaper way to finish the open ends.
    let mut spent = 0;
    let trace = std::env::var_os("WS_TRACE").is_some();
    // A guard (cost, size, no block form) stopped the generations: the whole LP finishes.
    let mut guarded = false;
    let first = ws.rounds == 0;
    let generations = if first {
        ws.first_round_generations
    } else {
        ws.max_generations
    };
    if !first {
        let before = ws.times.len();
        ws.prune(all, model.prob.na.max(1));
        if trace {
            eprintln!("working set: pruned {before} -> {}", ws.times.len());
        }
    }
    ws.rounds += 1;
    for generation in 0..generations.max(1) {
        spent += ws.times.len() * open.len();
        if ws.times.is_empty() || spent > all.len() * n_ends || ws.too_large(all.len()) {
            guarded = true;
            break;
        }
        let sub = SharedModel::new(model.prob, ws.times.clone());
        let sub_db: Vec<Interval> = sub
            .deltas
            .iter()
            .map(|d| db[model.delta_of[&d.key]])
            .collect();
        let ends = match solve_ends(&sub, tb, &sub_db, &sub.times, &open)? {
            Ends::Found(e) => e,
            // A relaxation of the whole LP is empty: so is the whole LP.
            Ends::Empty => return Ok(None),
            Ends::Sparse => {
                ws.sparse = true;
                guarded = true;
                break;
            }
        };
        ws.lean(n_ends, &open, &ends);
        let rows: Vec<(SparseRow, f64)> = sub.times.iter().map(|&t| sub.equation(t)).collect();
        let misses: Vec<Vec<(f64, usize)>> = ends
            .par_iter()
            .map(|e| {
                let pt = &e.point;
                let floor = accuracy_floor(&rows, pt);
                let mut m = complete(model, &sub, tb, db, pt, ws.len);
                m.retain(|&(gap, _)| gap > floor);
                m
            })
            .collect();
        if trace {
            let n: Vec<usize> = misses.iter().map(Vec::len).collect();
            let worst = misses.iter().flatten().fold(0.0f64, |a, m| a.max(m.0));
            eprintln!(
                "working set: {} equations, {} open ends, misses {n:?}, worst {worst:.1e}",
                ws.times.len(),
                open.len()
            );
        }
        let before = value.clone();
        for (&i, e) in open.iter().zip(&ends) {
            value[i] = e.value;
        }
        if generation > 0 && open.iter().all(|&i| settled(&before, &value, i)) {
            return Ok(Some((pair_ends(&value), true)));
        }
        let (still, missed): (Vec<usize>, Vec<Vec<(f64, usize)>>) = open
            .iter()
            .copied()
            .zip(misses)
            .filter(|(_, m)| !m.is_empty())
            .unzip();
        if still.is_empty() {
            return Ok(Some((pair_ends(&value), true)));
        }
        let add = ws.windows_for(all, missed);
        if add.is_empty() {
            return Ok(Some((pair_ends(&value), true)));
        }
        ws.add(add);
        open = still;
    }
    if !guarded {
        // The generations ran out; every end was solved (generation 0 solves them all). In the
        // first round that is the plan, not a failure.
        if !first {
            ws.unfinished += 1;
        }
        return Ok(Some((pair_ends(&value), false)));
    }
    ws.unfinished += 1;
    if ws.sparse {
        return Ok(bound_free(model, tb, db, all)?.map(|b| (b, true)));
    }
    // The whole LP for the open ends (the closed ones are its values already).
    let rest = match solve_ends(model, tb, db, all, &open)? {
        Ends::Found(e) => e,
        Ends::Empty => return Ok(None),
        Ends::Sparse => return Ok(bound_free(model, tb, db, all)?.map(|b| (b, true))),
    };
    for (&i, e) in open.iter().zip(rest) {
        value[i] = e.value;
    }
    Ok(Some((pair_ends(&value), true)))
}

/// Whether end `i` moved by no more than [`SETTLED`] of its parameter's width from `before` to
/// `now` (an end without a finite bound counts as moved).
fn settled(before: &[Option<f64>], now: &[Option<f64>], i: usize) -> bool {
    let c = i / 2;
    match (before[i], now[i], now[2 * c], now[2 * c + 1]) {
        (Some(b), Some(n), Some(lo), Some(hi)) => {
            (n - b).abs() <= SETTLED * (hi - lo).abs().max(f64::MIN_POSITIVE)
        }
        _ => false,
    }
}

/// How far beyond its tolerance a completion may miss and still count as the solver's
/// accuracy: [`ACCURACY_FLOOR`] times the largest residual of the working-set LP's own
/// equations `rows` (`c0 + row·z = 0`) at its point `pt`, beyond each equation's pad, at most
/// [`FLOOR_CAP`] relative to the equations' constants (0 when the residual is not finite).
fn accuracy_floor(rows: &[(SparseRow, f64)], pt: &[f64]) -> f64 {
    let (mut worst, mut scale) = (0.0f64, 0.0f64);
    for (row, c0) in rows {
        let r: f64 = c0 + row.iter().map(|&(c, v)| v * pt[c]).sum::<f64>();
        worst = worst.max(r.abs() - ROW_PAD * (1.0 + c0.abs()));
        scale = scale.max(c0.abs());
    }
    if !worst.is_finite() {
        return 0.0;
    }
    (ACCURACY_FLOOR * worst.max(0.0)).min(FLOOR_CAP * (1.0 + scale))
}

/// The McCormick envelope of `w = θ δ` over `tb × db` at fixed `θ`, `δ`: the interval of `w`.
fn envelope(th: f64, d: f64, tb: Interval, db: Interval) -> (f64, f64) {
    let (l, u, dl, du) = (tb.lo, tb.hi, db.lo, db.hi);
    let lo = (l * d + th * dl - l * dl).max(u * d + th * du - u * du);
    let hi = (u * d + th * dl - u * dl).min(l * d + th * du - l * du);
    (lo.min(th * d), hi.max(th * d))
}

/// Try to complete the primal point `pt` of the working-set LP `sub` to the whole record (see
/// the module doc): the `δ` of the first `len` equations as the LP chose them, every later one
/// chosen in time order. Returns the equations it could not satisfy (their index in
/// `model.times`), with by how much.
fn complete(
    model: &SharedModel,
    sub: &SharedModel,
    tb: &[Interval],
    db: &[Interval],
    pt: &[f64],
    len: usize,
) -> Vec<(f64, usize)> {
    let prob = model.prob;
    let theta: Vec<f64> = (0..prob.p())
        .map(|k| match (prob.fixed[k], model.col_theta[k]) {
            (Some(v), _) => v,
            (None, Some(c)) => pt[c].clamp(tb[k].lo, tb[k].hi),
            (None, None) => tb[k].center(),
        })
        .collect();
    // The LP's δ (where W touches them), and the ones fixed so far.
    let mut lp = vec![f64::NAN; model.deltas.len()];
    for (d2, sig) in sub.deltas.iter().enumerate() {
        let d = model.delta_of[&sig.key];
        lp[d] = pt[sub.col_delta(d2)].clamp(db[d].lo, db[d].hi);
    }
    let mut delta = vec![f64::NAN; model.deltas.len()];
    for &t in model.times.iter().take(len) {
        for (_, _, side, s) in model.terms(t) {
            if let Some(&d) = model.delta_of.get(&(side, s)) {
                delta[d] = lp[d];
            }
        }
    }
    let mut misses = Vec::new();
    for (i, &t) in model.times.iter().enumerate().skip(len) {
        let mut terms = model.terms(t);
        let Some((_, _, side0, s0)) = terms.next() else {
            continue;
        };
        let lead = model.signal(side0, s0).center();
        // The rest of the equation, an interval: Σ sign (θ_k c_s + w_ks).
        let (mut lo, mut hi, mut mag) = (0.0, 0.0, lead.abs());
        for (k, sign, side, s) in terms {
            let Some(k) = k else { continue };
            let cs = model.signal(side, s).center();
            let d = model.delta_of.get(&(side, s)).copied();
            let x = match d {
                Some(d) => {
                    if delta[d].is_nan() {
                        let x = if lp[d].is_nan() { 0.0 } else { lp[d] };
                        delta[d] = x.clamp(db[d].lo, db[d].hi);
                    }
                    delta[d]
                }
                None => 0.0,
            };
            let v = theta[k];
            let (wl, wh) = match (prob.fixed[k], d) {
                (None, Some(d)) => envelope(v, x, tb[k], db[d]),
                _ => (v * x, v * x),
            };
            let (a, b) = if sign > 0.0 {
                (sign * (v * cs + wl), sign * (v * cs + wh))
            } else {
                (sign * (v * cs + wh), sign * (v * cs + wl))
            };
            lo += a;
            hi += b;
            mag += a.abs().max(b.abs());
        }
        // lead + δ_t + [lo, hi] ∋ 0, within the equation's pad and the tolerance.
        let tol = ROW_PAD * (1.0 + lead.abs()) + COMPLETE_TOL * (1.0 + mag);
        let need = Interval::new(-lead - hi - tol, -lead - lo + tol);
        let gap = |x: f64| (need.lo - x).max(x - need.hi).max(0.0);
        match model.delta_of.get(&(side0, s0)).copied() {
            None => {
                if gap(0.0) > 0.0 {
                    misses.push((gap(0.0), i));
                }
            }
            Some(d) if !delta[d].is_nan() => {
                if gap(delta[d]) > 0.0 {
                    misses.push((gap(delta[d]), i));
                }
            }
            Some(d) => match need.intersect(&db[d]) {
                // Follow the LP where it has a value (its use of the envelopes' slack), else
                // the middle of what the equation allows.
                Some(iv) if lp[d].is_nan() => delta[d] = iv.center(),
                Some(iv) => delta[d] = lp[d].clamp(iv.lo, iv.hi),
                None => {
                    let x = if need.hi < db[d].lo {
                        db[d].lo
                    } else {
                        db[d].hi
                    };
                    misses.push((gap(x), i));
                    delta[d] = x;
                }
            },
        }
    }
    misses
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::stage3::classical;
    use crate::stage3::shared::{solve, SharedOptions};
    use crate::stage3::testutil::{cases, problem, random_case, random_extra_case, truth};
    use crate::stage3::EivProblem;
    use proptest::prelude::*;

    /// The first round's start of the shared method on `prob`: the classical box, the model
    /// over its equations, and the `δ` boxes propagated through them.
    fn first_round<'p, 'a>(
        prob: &'p EivProblem<'a>,
    ) -> (Vec<Interval>, SharedModel<'p, 'a>, Vec<Interval>) {
        let start = classical::solve(prob).unwrap();
        let model = SharedModel::new(prob, start.equations);
        let mut db = model.initial_deltas();
        assert!(model.propagate(&start.bounds, &mut db).is_none());
        (start.bounds, model, db)
    }

    /// One round's bounds by the whole LP and by the working set (and the set's final size,
    /// `None` when the round was unfinished: the whole LP answered, or the generations ran out).
    fn one_round(prob: &EivProblem) -> (FreeBounds, FreeBounds, Option<usize>, usize) {
        let (tb, model, db) = first_round(prob);
        let whole = bound_free(&model, &tb, &db, &model.times).unwrap().unwrap();
        let mut ws = WorkingSet::new(&model.times, window_len(prob, &tb));
        // A later round's budget: this test is about what the set converges to.
        ws.first_round_generations = MAX_GENERATIONS;
        let (part, _) = bound_free_ws(&model, &tb, &db, &mut ws).unwrap().unwrap();
        let used = (ws.unfinished == 0).then_some(ws.times.len());
        (whole, part, used, model.times.len())
    }

    /// On records long enough for the working set to stay well under the record, its bounds
    /// are the whole LP's (within the result pad), and the truth is inside both.
    #[test]
    fn working_set_bounds_equal_the_whole_lps() {
        for seed in 0..3 {
            let (m, out, input) = random_case(seed, 6000);
            let prob = problem(&out, &input, true);
            let (whole, part, used, n) = one_round(&prob);
            let used = used.unwrap_or_else(|| panic!("seed {seed}: the round was unfinished"));
            assert!(
                2 * used <= n,
                "seed {seed}: the working set took {used} of {n}"
            );
            assert_whole_lps(
                &format!("seed {seed}, working set"),
                &prob,
                &m,
                &whole,
                &part,
            );
        }
    }

    /// `part` holds the truth and equals `whole` within the pad every bound carries anyway
    /// (its precision) and a millionth of the width.
    fn assert_whole_lps(
        what: &str,
        prob: &EivProblem,
        m: &LinearModel,
        whole: &FreeBounds,
        part: &FreeBounds,
    ) {
        let t = truth(m);
        let free: Vec<usize> = (0..prob.p()).filter(|&k| prob.fixed[k].is_none()).collect();
        for (c, &k) in free.iter().enumerate() {
            let ((wl, wh), (pl, ph)) = (whole[c], part[c]);
            let (wl, wh, pl, ph) = (wl.unwrap(), wh.unwrap(), pl.unwrap(), ph.unwrap());
            assert!(
                pl <= t[k] && t[k] <= ph,
                "{what} θ{k}: [{pl}, {ph}] misses {}",
                t[k]
            );
            let tol = |v: f64| crate::lp::RESULT_PAD * (1.0 + v.abs()) + 1e-6 * (wh - wl);
            assert!(
                (pl - wl).abs() <= tol(wl) && (ph - wh).abs() <= tol(wh),
                "{what} θ{k}: [{pl}, {ph}], whole LP [{wl}, {wh}]"
            );
        }
    }

    /// The equations an end leans on carry its bound: the LP over the whole record, pruned to
    /// the ends' supports (and the first window), gives every end within a millionth of the
    /// width of the whole LP's, from a small part of the record; the truth stays inside.
    #[test]
    fn the_support_carries_the_bounds() {
        for seed in 0..2 {
            let (m, out, input) = random_case(seed, 3000);
            let prob = problem(&out, &input, true);
            let (tb, model, db) = first_round(&prob);
            let ends: Vec<usize> = (0..2 * model.free.len()).collect();
            let Ends::Found(whole) = solve_ends(&model, &tb, &db, &model.times, &ends).unwrap()
            else {
                panic!("seed {seed}: the whole LP has no block form or is empty");
            };
            let mut ws = WorkingSet::new(&model.times, window_len(&prob, &tb));
            ws.times = model.times.clone();
            ws.lean(ends.len(), &ends, &whole);
            ws.prune(&model.times, prob.na);
            let n = model.times.len();
            assert!(
                4 * ws.times.len() < n,
                "seed {seed}: the supports kept {} of {n}",
                ws.times.len()
            );
            assert!(ws.times.starts_with(&model.times[..ws.len]));
            let sub = SharedModel::new(&prob, ws.times.clone());
            let sub_db: Vec<Interval> = sub
                .deltas
                .iter()
                .map(|d| db[model.delta_of[&d.key]])
                .collect();
            let Ends::Found(part) = solve_ends(&sub, &tb, &sub_db, &sub.times, &ends).unwrap()
            else {
                panic!("seed {seed}: the pruned LP has no block form or is empty");
            };
            let values = |e: &[End]| pair_ends(&e.iter().map(|e| e.value).collect::<Vec<_>>());
            let what = format!("seed {seed}, pruned");
            assert_whole_lps(&what, &prob, &m, &values(&whole), &values(&part));
        }
    }

    /// Whole shared runs (every round, the set pruned between rounds) end where the whole LP's
    /// rounds end: every radius within 1e-4 (relative) of the run without the working set.
    #[test]
    fn pruned_runs_end_where_the_whole_lps_rounds_end() {
        let (m, out, input) = random_case(1, 6000);
        let prob = problem(&out, &input, true);
        let run = |from: usize| {
            let opts = SharedOptions {
                working_set_from: from,
                ..SharedOptions::default()
            };
            solve(&prob, &opts).unwrap()
        };
        let (ws, whole) = (run(0), run(usize::MAX));
        for (k, t) in truth(&m).into_iter().enumerate() {
            let (a, b) = (ws.bounds[k], whole.bounds[k]);
            assert!(a.contains(t), "θ{k}: {a:?} misses {t}");
            let tol = 1e-4 * (b.hi - b.lo) + 2.0 * crate::lp::RESULT_PAD * (1.0 + t.abs());
            assert!(
                (a.lo - b.lo).abs() <= tol && (a.hi - b.hi).abs() <= tol,
                "θ{k}: working set {a:?}, whole LP {b:?}"
            );
        }
    }

    /// Pruning keeps the first window and each supported equation with its margin, nothing else.
    #[test]
    fn pruning_keeps_the_first_window_and_the_supports_margins() {
        let all: Vec<usize> = (10..110).collect();
        let mut ws = WorkingSet::new(&all, 5);
        ws.times = all.clone();
        ws.support = vec![vec![50], vec![], vec![108, 50]];
        ws.prune(&all, 2);
        let want: Vec<usize> = (10..15).chain(48..53).chain(106..110).collect();
        assert_eq!(ws.times, want);
        // Without any support recorded (the first round), nothing is dropped.
        let mut fresh = WorkingSet::new(&all, 5);
        let before = fresh.times.clone();
        fresh.prune(&all, 2);
        assert_eq!(fresh.times, before);
    }

    /// Whenever the whole LP proves a record with an outlier (far from the first working set)
    /// inconsistent, the working set proves it too, by itself: the completion misses there, the
    /// set grows to it, and its LP is empty.
    #[test]
    fn an_outlier_outside_the_first_set_empties_the_working_set_lp() {
        let (_, clean, input) = random_case(3, 3000);
        // A box that holds the truth, from the clean record.
        let tb = classical::solve(&problem(&clean, &input, true))
            .unwrap()
            .bounds;
        let mut found = 0;
        for shift in [1.5, 2.0, 3.0, 5.0, 10.0, 30.0] {
            let mut out = clean.clone();
            let c = out[2100].interval;
            let d = shift * c.radius();
            out[2100].interval = Interval::new(c.lo + d, c.hi + d);
            let prob = problem(&out, &input, true);
            let model = SharedModel::new(&prob, prob.equation_times());
            let mut db = model.initial_deltas();
            if model.propagate(&tb, &mut db).is_some() {
                continue;
            }
            if bound_free(&model, &tb, &db, &model.times)
                .unwrap()
                .is_some()
            {
                continue;
            }
            found += 1;
            let len = window_len(&prob, &tb);
            let mut ws = WorkingSet::new(&model.times, len);
            assert!(
                ws.times.binary_search(&2100).is_err(),
                "the outlier is in the first set"
            );
            ws.first_round_generations = MAX_GENERATIONS;
            let r = bound_free_ws(&model, &tb, &db, &mut ws).unwrap();
            assert!(
                ws.unfinished == 0,
                "shift {shift}: the working set did not finish the round"
            );
            assert!(
                r.is_none(),
                "shift {shift}: the working set missed the inconsistency"
            );
        }
        assert!(
            found > 0,
            "no shift made an outlier only the whole LP finds"
        );
    }

    /// The accuracy floor reads the point's own equations: a point moved off one equation by
    /// `ε` (its leading `δ_t`, coefficient 1 there) has a floor of twice that (plus the
    /// solver's own residual, less the pad), and a point far off is capped.
    #[test]
    fn the_accuracy_floor_is_twice_the_points_own_residual_capped() {
        let (_, out, input) = random_case(5, 400);
        let prob = problem(&out, &input, true);
        let (tb, model, db) = first_round(&prob);
        let Ends::Found(ends) = solve_ends(&model, &tb, &db, &model.times, &[0]).unwrap() else {
            panic!("the LP of a consistent record is not empty");
        };
        let rows: Vec<(SparseRow, f64)> = model.times.iter().map(|&t| model.equation(t)).collect();
        let scale = rows.iter().fold(0.0f64, |a, r| a.max(r.1.abs()));
        let mut pt = ends[0].point.clone();
        let f0 = accuracy_floor(&rows, &pt);
        assert!(f0 < 1e-7, "the solver's point is off by {}", f0 / 2.0);
        let d = model.delta_of[&(crate::stage3::relax::Side::Out, model.times[200])];
        let eps = 1e-7;
        pt[model.col_delta(d)] += eps;
        let f1 = accuracy_floor(&rows, &pt);
        // Less the equation's own pad (ROW_PAD relative to its constant, which is O(1) here).
        let pad = ROW_PAD * (1.0 + scale);
        assert!(
            f1 >= 2.0 * (eps - pad) - f0 && f1 <= 2.0 * (eps + pad) + f0,
            "moved by {eps}: floor {f1}"
        );
        pt[model.col_delta(d)] += 1.0;
        let f2 = accuracy_floor(&rows, &pt);
        assert!(f2 <= FLOOR_CAP * (1.0 + scale), "floor {f2} not capped");
        pt[model.col_delta(d)] = f64::NAN;
        assert_eq!(accuracy_floor(&rows, &pt), 0.0);
    }

    /// When the generations run out, the round is not conclusive, every end has a bound, and
    /// each is a relaxation's: never inside the whole LP's interval (beyond the pad), truth
    /// inside. A later round that runs out counts as unfinished.
    #[test]
    fn a_round_out_of_generations_answers_with_the_sets_looser_bounds() {
        let (m, out, input) = random_case(1, 6000);
        let prob = problem(&out, &input, true);
        let (tb, model, db) = first_round(&prob);
        let whole = bound_free(&model, &tb, &db, &model.times).unwrap().unwrap();
        let mut ws = WorkingSet::new(&model.times, window_len(&prob, &tb));
        (ws.first_round_generations, ws.max_generations) = (1, 1);
        let (part, conclusive) = bound_free_ws(&model, &tb, &db, &mut ws).unwrap().unwrap();
        assert!(!conclusive, "one generation closed every end");
        // Running out in the first round is the plan, not an unfinished round.
        assert_eq!((ws.unfinished, ws.rounds), (0, 1));
        assert!(!ws.retired(model.times.len()));
        let t = truth(&m);
        let free: Vec<usize> = (0..prob.p()).filter(|&k| prob.fixed[k].is_none()).collect();
        for (c, &k) in free.iter().enumerate() {
            let (Some(pl), Some(ph)) = part[c] else {
                panic!("θ{k}: an end without a bound");
            };
            let (wl, wh) = (whole[c].0.unwrap(), whole[c].1.unwrap());
            assert!(
                pl <= t[k] && t[k] <= ph,
                "θ{k}: [{pl}, {ph}] misses {}",
                t[k]
            );
            let tol = |v: f64| crate::lp::RESULT_PAD * (1.0 + v.abs());
            assert!(
                pl <= wl + tol(wl) && ph >= wh - tol(wh),
                "θ{k}: the set's [{pl}, {ph}] inside the whole LP's [{wl}, {wh}]"
            );
        }
        // A later round that runs out is unfinished; one that concludes is not.
        let (_, conclusive) = bound_free_ws(&model, &tb, &db, &mut ws).unwrap().unwrap();
        assert_eq!(ws.unfinished, usize::from(!conclusive));
    }
    /// The working set stays for later rounds after one unfinished round, and retires after a
    /// second, when it has no block form, or when it holds half the record.
    #[test]
    fn the_working_set_retires_after_two_unfinished_rounds_or_when_large() {
        let all: Vec<usize> = (0..3000).collect();
        let mut ws = WorkingSet::new(&all, 20);
        assert!(!ws.retired(all.len()));
        ws.unfinished = 1;
        assert!(!ws.retired(all.len()));
        ws.unfinished = 2;
        assert!(ws.retired(all.len()));
        ws.unfinished = 0;
        ws.sparse = true;
        assert!(ws.retired(all.len()));
        ws.sparse = false;
        ws.add(0..1400);
        assert!(!ws.retired(all.len()));
        ws.add(0..1501);
        assert!(ws.retired(all.len()));
    }

    #[test]
    fn settling_windows_follow_the_poles() {
        use crate::stage3::testutil::problem;
        let (_, out, input) = random_case(0, 10);
        let mut prob = problem(&out, &input, false);
        prob.na = 1;
        prob.fixed = vec![None, Some(0.0), None, None];
        let at = |a: f64| {
            let tb = vec![Interval::new(a, a); 4];
            window_len(&prob, &tb)
        };
        // |pole| 0.5: 0.5^20 < 1e-6 <= 0.5^19.
        assert_eq!(at(-0.5), 20);
        assert_eq!(at(0.5), 20);
        // Fast poles keep the floor, slow ones the cap, unstable ones 50.
        assert_eq!(at(0.0), 4);
        assert_eq!(at(-0.999), 400);
        assert_eq!(at(-1.5), 50);
    }

    proptest! {
        #![proptest_config(cases(6))]
        /// Whole shared runs with the working set on from the first equation (extra columns
        /// included; the whole LP where the cost guard hands over): the truth is inside.
        #[test]
        fn working_set_runs_contain_the_truth(
            seed in any::<u64>(),
            uncertain in any::<bool>(),
        ) {
            let case = random_extra_case(seed, 1500, if uncertain { 0.05 } else { 0.0 });
            let opts = SharedOptions { working_set_from: 0, ..SharedOptions::default() };
            let r = match solve(&case.problem(true), &opts) {
                Err(crate::error::SmidError::Unbounded { .. }) => { prop_assume!(false); unreachable!() }
                other => other.unwrap(),
            };
            for (k, t) in case.truth().into_iter().enumerate() {
                prop_assert!(r.bounds[k].contains(t), "θ{}: {:?} misses {}", k, r.bounds[k], t);
            }
        }
    }
}
