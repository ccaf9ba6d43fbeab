//! The shared-error bounds of stage 3 (`relax.rs`, paper eqs 1, 28-30) for long records, from
//! a **working set** of equations (constraint generation): the LP is solved over a few
//! thousand equations instead of all `N`, and grows only where the rest of the record asks.
//!
//! **Guarantee.** Dropping equations (and the `δ`, `w` only they touch) from the shared-error LP
//! leaves a relaxation: the true `(θ, δ, θδ)` satisfies every kept row and box, so the
//! certified bounds of the smaller LP (weak duality, [`super::ipm`]) hold for the whole record.
//! Whatever the working set, no bound can miss the truth; the set only decides how tight.
//!
//! **One set per end.** Each end of a free θ's interval (`2c`: lower end of free θ `c`,
//! `2c + 1`: upper; an *objective*) has its own set and its own LP: an end leans on a few
//! hundred equations of its own (order 4, N = 1e5: 100-120 above 1e-5 of its largest
//! multiplier), and an LP over every end's windows at once costs each end the others' equations
//! (sets of 1400-4500 for all 16 ends, against 150-1600 per end, and a slower run). Every
//! end starts from the same first set (one LP, one warm start, while the sets are equal); ends
//! with equal sets share an LP.
//!
//! **Tightness.** A set is made of windows of consecutive equations, each about as long as
//! the model's free response takes to die out (`len`, from the poles at the box centre): inside
//! a window the inner signal follows the dynamics as in the whole record, between windows it may
//! jump. After an end's LP over its set `W` is solved, a forward pass tries to complete its
//! primal point `(θ*, δ*)` to a point of the whole LP. With `θ = θ*` fixed, every product
//! `w = θ_k δ_s` enters exactly one equation and its McCormick envelope is an interval in
//! `δ_s`; so, in time order, each equation allows an interval for its newest `δ_t` (eq 1 solved
//! for `x_t`, inside the propagated box). The first window keeps the LP's values (the record's
//! initial condition); later `δ_t` take the LP's value where it has one and the equation allows
//! it (clamped otherwise), else the middle of what is allowed. An equation whose `δ_t` is
//! already fixed is checked. A miss counts when it exceeds [`COMPLETE_TOL`] (relative, beyond
//! the equation's own pad) by more than the accuracy floor: [`ACCURACY_FLOOR`] times the point's
//! own largest residual on `W`, capped at [`FLOOR_CAP`] (a miss no worse than the point's own
//! rows is the solver's accuracy; order-4 points stall near 1e-7). An end without misses
//! has a point feasible for the whole LP up to that accuracy, so its bound is the whole LP's
//! value up to the solver's gap: it is **closed** and not solved again this round. Each open
//! end adds to its set the windows ending at its [`WINDOWS_PER_OBJECTIVE`] most violated
//! equations; a miss inside `W` comes from upstream (the pass could not follow the LP across a
//! gap), so its window closes the nearest gap before it; an end whose misses all have no gap
//! before them closes. The growth also ends when a generation moves no open end by more than
//! [`SETTLED`] of its width or [`SETTLED_PADS`] result pads.
//!
//! **Pruning between rounds.** Each solve also says which equations its bound leans on: those
//! whose multiplier's magnitude is above [`SUPPORT_WEIGHT`] of the end's largest. A later round
//! of the box iteration (smaller boxes, nearly the same support) starts each end from the
//! equations it leaned on in the last round, `na` either side, and the first window; its
//! generations add back the windows its completion misses. The first round is not pruned
//! (nothing is known yet).
//!
//! **Cost guard.** When a round's working-set LPs would together cost more than the whole LP's
//! (equations times objectives), or an end's set would hold more than half the record, the
//! whole LP answers for the ends still open. When the generations run out
//! ([`FIRST_ROUND_GENERATIONS`] in the first round, which starts from the wide classical box
//! and only shrinks it and grows the sets; [`MAX_GENERATIONS`] later) with ends still
//! open, each is the last working-set LP's bound that solved it (guaranteed, perhaps looser
//! than the whole LP's), and the box iteration does not end on such a round (`shared.rs`). Two
//! unfinished later rounds (either way), a set without the block form, or a set past half the
//! record retire the working set: the later rounds solve the whole LP.
//!
//! **Typical sizes** (the `debug` log below shows them). Order 4, N = 1e5: the first set is 480
//! equations; the first round's 4 generations grow each end's to about 1430; later rounds start
//! from 150-330 per end and end at 300-1600, in 3-5 generations; 4 rounds, every radius within
//! 1e-4 (relative) of the shared set's run. Order 4, N = 1e4: within 1.2e-4 of the whole LP's
//! rounds (with 3 first-round generations 1.4e-3 looser: the box the first round leaves
//! matters; with 6, identical but slower). Order 2: 3-4 generations in the first
//! round (each end's set ending at 3 % of the record at N = 1e5, 26 % at 1e4), one in the
//! second.
//!
//! At `debug` level of the `log` facade (target `smid::stage3`; the CLI prints it with
//! `SMID_LOG=debug`) one line per generation (open ends, LPs, set sizes, misses per open end, how
//! far the open ends moved) and one per round (`shared.rs`).
use super::ipm::SparseRow;
use super::relax::{bound_free, pair_ends, solve_ends, End, Ends, FreeBounds, SharedModel};
use super::EivProblem;
use crate::error::Result;
use crate::interval::Interval;
use crate::linear::LinearModel;
use crate::lp::{RESULT_PAD, ROW_PAD};
use rayon::prelude::*;

/// At most this many working-set LPs per round; then each end is the last working-set LP's
/// that solved it.
pub(crate) const MAX_GENERATIONS: usize = 8;

/// Working-set LPs in the first round, which starts from the classical box: its wide box
/// spreads the LP's support, so chasing the whole LP's value there costs many generations,
/// while the next round, from the box it leaves, needs the sets anyway. The first round only
/// shrinks the box (guaranteed) and grows the sets; the rounds never end on it. Its box sets
/// the path of the later rounds: order 4, N = 1e4, 3 generations end 1.4e-3 (relative) looser
/// than the whole LP's rounds, 4 within 1.2e-4, 6 identical (at N = 1e5, 5 take longer than 4).
pub(crate) const FIRST_ROUND_GENERATIONS: usize = 4;

/// Relative tolerance of the completion, beyond each equation's own pad: a tenth of the result
/// pad ([`crate::lp::RESULT_PAD`]). A point that passes may violate an equation by this much,
/// and the bound moves by about as much (completions passed at 1e-8 and 3e-9 left bounds 1.3
/// and 1.05 pads looser than the whole LP's); the order-2 iterates' own accuracy is about 1e-9.
/// Order-4 iterates stall near 1e-7: [`ACCURACY_FLOOR`] is the larger tolerance there.
const COMPLETE_TOL: f64 = 1e-9;

/// A generation that moves no open bound by more than this fraction of its width ends the
/// growth.
const SETTLED: f64 = 1e-6;

/// A generation that moves no open bound by more than this many result pads ([`RESULT_PAD`])
/// also ends the growth (see [`settled`]): the certified bounds of near-equal LPs differ by
/// about one pad (order 2, N = 6000: ends of an interval 5e-5 wide
/// moved by 0.5-1.5 pads from one generation to the next while one equation kept missing by
/// 3e-8), so a generation that moves them less has nothing left to find.
const SETTLED_PADS: f64 = 4.0;

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

/// Windows each objective adds to its set per generation. Order 4, N = 1e5 (per-end sets of
/// 200-1800 equations): 32 is no faster than 16, 8 is slower (it needs more generations).
const WINDOWS_PER_OBJECTIVE: usize = 16;

/// The first set holds about `1 / INITIAL_SHARE` of the record (evenly spaced windows, and the
/// first one). Order 4, N = 1e5: a first set of 1/50 of the record is slower than 1/200 (the
/// first round's LPs are the largest; its generations add what each end needs).
const INITIAL_SHARE: usize = 200;

/// The working sets: per end of a free θ (`2c`: lower end of free θ `c`, `2c + 1`: upper), the
/// equations its LP is solved over (a sorted subset of the model's equation times). Every end
/// starts from the same set; each grows where its own completion misses and is pruned to its
/// own support.
#[derive(Debug, Clone)]
pub(crate) struct WorkingSet {
    /// Per end; a single entry (shared by every end) until the first round spreads it.
    pub sets: Vec<Vec<usize>>,
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
    /// about 1/[`INITIAL_SHARE`] of the record, for every end.
    pub fn new(all: &[usize], len: usize) -> Self {
        let len = len.max(1);
        let count = (all.len() / INITIAL_SHARE / len).max(1);
        let mut times: Vec<usize> = all.iter().copied().take(len).collect();
        for i in 1..count {
            let at = i * all.len() / count;
            times.extend(all.iter().copied().skip(at).take(len));
        }
        times.sort_unstable();
        times.dedup();
        WorkingSet {
            sets: vec![times],
            len,
            unfinished: 0,
            sparse: false,
            first_round_generations: FIRST_ROUND_GENERATIONS,
            max_generations: MAX_GENERATIONS,
            rounds: 0,
            support: Vec::new(),
        }
    }

    /// One set per end (`n_ends`), copies of the shared one.
    fn spread(&mut self, n_ends: usize) {
        if self.sets.len() != n_ends {
            let first = self.sets.first().cloned().unwrap_or_default();
            self.sets = vec![first; n_ends];
        }
    }

    /// Whether the later rounds should solve the whole LP: two rounds were unfinished, the
    /// set has no block form, or some end's set holds half the record (`all` equations).
    pub fn retired(&self, all: usize) -> bool {
        self.unfinished >= 2 || self.sparse || self.too_large(all)
    }

    /// Some end's set holds more than half the record: the whole LP costs about as much.
    fn too_large(&self, all: usize) -> bool {
        self.sets.iter().any(|s| 2 * s.len() > all)
    }

    /// Drop, from each end's set, the equations it did not lean on at the end of the last
    /// round: keep the first window (the completion starts from the LP's values there) and
    /// each equation of its support with `margin` equations either side. A smaller set is
    /// still a relaxation (the guarantee does not depend on it); where the completion then
    /// misses, the generations add the windows back.
    fn prune(&mut self, all: &[usize], margin: usize) {
        if self.support.len() != self.sets.len() || all.is_empty() {
            return;
        }
        for (set, support) in self.sets.iter_mut().zip(&self.support) {
            let mut keep = vec![false; all.len()];
            keep.iter_mut().take(self.len).for_each(|k| *k = true);
            for &t in support {
                if let Ok(i) = all.binary_search(&t) {
                    let hi = (i + margin).min(all.len() - 1);
                    keep[i.saturating_sub(margin)..=hi]
                        .iter_mut()
                        .for_each(|k| *k = true);
                }
            }
            *set = all
                .iter()
                .zip(&keep)
                .filter(|(_, k)| **k)
                .map(|(&t, _)| t)
                .collect();
        }
    }

    /// Record, for end `i` just solved over its set (`found`), the equations it leaned on:
    /// weight above [`SUPPORT_WEIGHT`] of its largest.
    fn lean(&mut self, i: usize, found: &End) {
        self.support.resize(self.sets.len(), Vec::new());
        let top = found.weight.iter().fold(0.0f64, |a, b| a.max(*b));
        self.support[i] = self.sets[i]
            .iter()
            .zip(&found.weight)
            .filter(|(_, w)| **w > SUPPORT_WEIGHT * top)
            .map(|(&t, _)| t)
            .collect();
    }

    fn add(&mut self, i: usize, more: impl IntoIterator<Item = usize>) {
        let set = &mut self.sets[i];
        set.extend(more);
        set.sort_unstable();
        set.dedup();
    }
}

/// The equations to add to an end's set `set` after a generation: windows ending at its most
/// violated equations (one per stretch of `len`, at most [`WINDOWS_PER_OBJECTIVE`]). A miss
/// inside the set comes from upstream (the pass could not follow the LP across a gap): its
/// window closes the nearest gap before it. A miss with all of the record before it in the set
/// is the solver's accuracy: nothing to add. `misses` holds indices into `all`.
fn windows_for(set: &[usize], all: &[usize], len: usize, mut misses: Misses) -> Vec<usize> {
    // The nearest equation at or before each one that is not in the set (one pass).
    let mut gap_at: Vec<Option<usize>> = Vec::with_capacity(all.len());
    let mut w = set.iter().peekable();
    for (i, t) in all.iter().enumerate() {
        let inside = w.peek() == Some(&t);
        if inside {
            w.next();
        }
        let before = if i > 0 { gap_at[i - 1] } else { None };
        gap_at.push(if inside { before } else { Some(i) });
    }
    let mut add = Vec::new();
    misses.sort_by(|a, b| b.0.total_cmp(&a.0));
    let mut chosen: Vec<usize> = Vec::new();
    for &(_, i) in &misses {
        if chosen.len() >= WINDOWS_PER_OBJECTIVE {
            break;
        }
        let Some(end) = gap_at[i] else {
            continue;
        };
        if chosen.iter().any(|&c| c.abs_diff(end) < len) {
            continue;
        }
        chosen.push(end);
        add.extend(all[(end + 1).saturating_sub(len)..=end].iter().copied());
    }
    add
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
    ws.spread(n_ends);
    // Per end: its bound from the last LP that solved it (`None`: not finite). `open`: the
    // ends whose completion has not passed yet; a closed end is the whole LP's value and is
    // not solved again this round.
    let mut value: Vec<Option<f64>> = vec![None; n_ends];
    let mut open: Vec<usize> = (0..n_ends).collect();
    // Equations times ends solved by this round's generations: past the whole LP's, or with a
    // set past half the record, the whole LP is the cheaper way to finish the open ends.
    let mut spent = 0;
    let trace = log::log_enabled!(target: "smid::stage3", log::Level::Debug);
    // A guard (cost, size, no block form) stopped the generations: the whole LP finishes.
    let mut guarded = false;
    let first = ws.rounds == 0;
    let generations = if first {
        ws.first_round_generations
    } else {
        ws.max_generations
    };
    if !first {
        let before: usize = ws.sets.iter().map(Vec::len).sum();
        ws.prune(all, model.prob.na.max(1));
        if trace {
            let after: usize = ws.sets.iter().map(Vec::len).sum();
            log::debug!(target: "smid::stage3", "working set: pruned {before} -> {after} (all ends)");
        }
    }
    ws.rounds += 1;
    for generation in 0..generations.max(1) {
        spent += open.iter().map(|&i| ws.sets[i].len()).sum::<usize>();
        if open.iter().any(|&i| ws.sets[i].is_empty())
            || spent > all.len() * n_ends
            || ws.too_large(all.len())
        {
            guarded = true;
            break;
        }
        // The open ends grouped by equal sets: one LP (and warm start) per group.
        let mut groups: Vec<Vec<usize>> = Vec::new();
        for &i in &open {
            match groups.iter_mut().find(|g| ws.sets[g[0]] == ws.sets[i]) {
                Some(g) => g.push(i),
                None => groups.push(vec![i]),
            }
        }
        let solved: Vec<Result<SetLp>> = groups
            .par_iter()
            .map(|g| solve_set(model, tb, db, &ws.sets[g[0]], g, ws.len))
            .collect();
        let mut found: Vec<(usize, End, Misses)> = Vec::with_capacity(open.len());
        let mut sparse = false;
        for (g, r) in groups.iter().zip(solved) {
            match r? {
                SetLp::Sparse => sparse = true,
                // A relaxation of the whole LP is empty: so is the whole LP.
                SetLp::Empty => return Ok(None),
                SetLp::Found(e) => found.extend(g.iter().zip(e).map(|(&i, (e, m))| (i, e, m))),
            }
        }
        if sparse {
            ws.sparse = true;
            guarded = true;
            break;
        }
        found.sort_by_key(|f| f.0);
        for (i, e, _) in &found {
            ws.lean(*i, e);
        }
        if trace {
            let n: Vec<usize> = found.iter().map(|f| f.2.len()).collect();
            let sizes: Vec<usize> = found.iter().map(|f| ws.sets[f.0].len()).collect();
            let worst = found
                .iter()
                .flat_map(|f| &f.2)
                .fold(0.0f64, |a, m| a.max(m.0));
            log::debug!(
                target: "smid::stage3",
                "working set: {} open ends in {} LPs, sets of {}-{} equations, misses {n:?}, \
                 worst {worst:.1e}",
                open.len(),
                groups.len(),
                sizes.iter().min().unwrap_or(&0),
                sizes.iter().max().unwrap_or(&0),
            );
        }
        let before = value.clone();
        for (i, e, _) in &found {
            value[*i] = e.value;
        }
        if trace && generation > 0 {
            let moved = open
                .iter()
                .map(|&i| match (before[i], value[i], value[i ^ 1]) {
                    (Some(b), Some(n), Some(o)) => (n - b).abs() / (n - o).abs(),
                    _ => f64::INFINITY,
                })
                .fold(0.0f64, f64::max);
            log::debug!(target: "smid::stage3", "working set: the open ends moved by up to {moved:.1e} of their width");
        }
        if generation > 0 && open.iter().all(|&i| settled(&before, &value, i)) {
            return Ok(Some((pair_ends(&value), true)));
        }
        let mut still = Vec::new();
        for (i, _, m) in found {
            if m.is_empty() {
                continue;
            }
            let add = windows_for(&ws.sets[i], all, ws.len, m);
            if !add.is_empty() {
                ws.add(i, add);
                still.push(i);
            }
        }
        if still.is_empty() {
            return Ok(Some((pair_ends(&value), true)));
        }
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

/// The equations an end's completion missed, with by how much (indices into `model.times`).
type Misses = Vec<(f64, usize)>;

/// What the LP over one set gave for the ends that share it.
enum SetLp {
    /// Per end (in the order asked), its bound and point, and its completion's misses beyond
    /// the accuracy floor.
    Found(Vec<(End, Misses)>),
    /// The LP is proven empty.
    Empty,
    /// The LP has no block form; nothing was solved.
    Sparse,
}

/// The LP over `set` (equation times) for the ends `ends`, and each one's completion.
fn solve_set(
    model: &SharedModel,
    tb: &[Interval],
    db: &[Interval],
    set: &[usize],
    ends: &[usize],
    len: usize,
) -> Result<SetLp> {
    let sub = SharedModel::new(model.prob, set.to_vec());
    let sub_db: Vec<Interval> = sub
        .deltas
        .iter()
        .map(|d| db[model.delta_of[&d.key]])
        .collect();
    let found = match solve_ends(&sub, tb, &sub_db, &sub.times, ends)? {
        Ends::Found(e) => e,
        Ends::Empty => return Ok(SetLp::Empty),
        Ends::Sparse => return Ok(SetLp::Sparse),
    };
    let rows: Vec<(SparseRow, f64)> = sub.times.iter().map(|&t| sub.equation(t)).collect();
    Ok(SetLp::Found(
        found
            .into_par_iter()
            .map(|e| {
                let floor = accuracy_floor(&rows, &e.point);
                let mut m = complete(model, &sub, tb, db, &e.point, len);
                m.retain(|&(gap, _)| gap > floor);
                (e, m)
            })
            .collect(),
    ))
}

/// Whether end `i` moved by no more than [`SETTLED`] of its parameter's width from `before` to
/// `now`, or by no more than [`SETTLED_PADS`] result pads (the solver's own accuracy: a narrow
/// interval's ends jitter by that much from one set to the next). An end without a finite
/// bound counts as moved.
fn settled(before: &[Option<f64>], now: &[Option<f64>], i: usize) -> bool {
    let c = i / 2;
    match (before[i], now[i], now[2 * c], now[2 * c + 1]) {
        (Some(b), Some(n), Some(lo), Some(hi)) => {
            let noise = SETTLED_PADS * RESULT_PAD * (1.0 + n.abs());
            (n - b).abs() <= (SETTLED * (hi - lo).abs()).max(noise)
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
mod tests;
