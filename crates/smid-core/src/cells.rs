//! Branch and bound over a box of parameters that the three stages cannot bound in closed
//! form (the sensor parameters of effects; see [`crate::effect`]), in the spirit of set
//! inversion (SIVIA, Jaulin & Walter 1993): the prior box is cut into cells; for each cell the
//! caller runs stages 1-3 with the cell's parameters as intervals, which either **proves** the
//! cell inconsistent (an empty feasible set: the cell is discarded) or leaves it (feasible or
//! undecided: it is bisected, down to a resolution per parameter, or at most `depth` halvings).
//! A solver failure never discards a cell. The union of the surviving cells is an outer bound
//! of the parameters; the hull of the stage results over them is an outer bound of the rest.
//! When the cell budget runs out, the cells not yet evaluated keep their parent's result, so
//! the hull stays guaranteed, only looser, and the result says so.
//!
//! A finished cell whose results are not finite (stage 3 unbounded over it, or its solvers
//! failed) is **refined**: halved further (below the resolution, down to `depth`) and its
//! halves finished, within a second budget of `max_leaves` more evaluations. Only what is
//! left undecided when that budget is spent comes back as a leaf without a value, with its
//! cause: the caller reports it (an unbounded cell still bounds the bisected parameters).
//!
//! Cells of one level are evaluated in parallel (rayon).
use crate::error::{Result, SmidError, Stage};
use crate::interval::Interval;
use crate::outcome::{Falsification, Outcome};
use rayon::prelude::*;

/// What evaluating one cell proved.
#[derive(Debug)]
pub enum Verdict<T> {
    /// The cell is inconsistent with the data (the finding says where): discarded.
    Infeasible(Falsification),
    /// The cell may hold consistent parameters; `T` holds guaranteed results over the cell.
    Feasible(T),
    /// The cell may hold consistent parameters but the results are not finite (stage 3 did
    /// not bound a parameter, or a solver failed; the detail says where): refined, else kept.
    Undecided(UndecidedCause, String),
}

/// Why a cell stayed undecided.
#[derive(Debug, Clone, Copy, serde::Serialize, serde::Deserialize, PartialEq, Eq, Hash)]
#[serde(rename_all = "snake_case")]
pub enum UndecidedCause {
    /// Stage 3 found no finite bound of `θ` over the cell.
    Unbounded,
    /// Every solver path failed on the cell's LPs.
    Solver,
}

impl UndecidedCause {
    /// A short human-readable phrase for reports (e.g. "LP solver failure on a cell").
    pub fn label(self) -> &'static str {
        match self {
            UndecidedCause::Unbounded => "stage 3 unbounded over a cell",
            UndecidedCause::Solver => "LP solver failure on a cell",
        }
    }
}

/// Largest accepted `method.cells.depth` (halvings per parameter; 2^-60 of a prior box is
/// below any resolution an effect asks for).
pub const MAX_DEPTH: u32 = 60;
/// Largest accepted `method.cells.max_cells` (each cell runs stages 1-2 and a stage-3 test).
pub const MAX_CELLS: usize = 1_000_000;

/// Budget of the search.
#[derive(Debug, Clone)]
pub struct Budget {
    /// Per parameter: a cell narrower than this is not halved further.
    pub resolution: Vec<f64>,
    /// Halvings per parameter at most.
    pub depth: u32,
    /// Cells tested at most (the final evaluation of the surviving cells comes on top).
    pub max_cells: usize,
    /// Surviving cells finished at most: beyond it they are merged back into the cells they
    /// were cut from (looser, still guaranteed).
    pub max_leaves: usize,
}

/// A surviving cell.
#[derive(Debug, Clone)]
pub struct Leaf<T> {
    /// The cell's box: one interval per bisected parameter.
    pub cell: Vec<Interval>,
    /// The result over this cell (`None`: undecided).
    pub value: Option<T>,
    /// Why the cell is undecided, and the detail (`None` when it has a value).
    pub cause: Option<(UndecidedCause, String)>,
}

/// The outcome of the search.
#[derive(Debug)]
pub struct Search<T> {
    /// The surviving cells (those not proven inconsistent); together they cover every
    /// consistent value of the bisected parameters.
    pub leaves: Vec<Leaf<T>>,
    /// Cells tested and finally evaluated.
    pub evaluated: usize,
    /// Cells proven inconsistent with the data and dropped.
    pub discarded: usize,
    /// The budget stopped the bisection before the resolution was reached, or the leaves were
    /// merged back to stay within `max_leaves`.
    pub budget_stopped: bool,
    /// Undecided cells halved further after the first evaluation (each refinement evaluates
    /// two halves).
    pub refined: usize,
    /// Whether the leaves' values are the screen's ([`search_screened`]): some leaf stayed
    /// undecided under the screen, so the finish was not run.
    pub screened: bool,
}

impl<T> Search<T> {
    /// Hull of the surviving cells.
    pub fn hull(&self) -> Vec<Interval> {
        hull_of_boxes(self.leaves.iter().map(|l| l.cell.as_slice()))
    }
}

/// Component-wise hull of boxes (empty input: empty vector).
pub fn hull_of_boxes<'a>(boxes: impl IntoIterator<Item = &'a [Interval]>) -> Vec<Interval> {
    let mut out: Vec<Interval> = Vec::new();
    for b in boxes {
        if out.is_empty() {
            out = b.to_vec();
        } else {
            for (o, i) in out.iter_mut().zip(b) {
                *o = Interval::new(o.lo.min(i.lo), o.hi.max(i.hi));
            }
        }
    }
    out
}

/// Progress of the search, for a progress bar.
#[derive(Debug, Clone)]
pub struct Progress {
    /// Cells tested so far.
    pub evaluated: usize,
    /// Cells queued at the next level.
    pub queued: usize,
    /// Cells of the level just finished that were not discarded.
    pub kept: usize,
    /// Hull of the cells kept so far at this level (empty before the first level is done).
    pub hull: Vec<Interval>,
}

/// Halve `cell` along the parameter widest against its resolution, among those wider than it
/// with halvings left; `None` when every parameter has reached its resolution.
/// With `below_resolution`, any parameter with halvings left may be halved (refinement of an
/// undecided cell).
fn bisect(
    cell: &[Interval],
    depth: &[u32],
    b: &Budget,
    below_resolution: bool,
) -> Option<[(Vec<Interval>, Vec<u32>); 2]> {
    // A parameter split at its geometric mean counts its span in halvings of the span as well
    // (at least 1 while it spans more than GEOMETRIC_SPAN: its width may already be under the
    // resolution at the low end, where a slope's cell still spans an order of magnitude).
    let ratio = |k: usize| {
        let linear = (cell[k].hi - cell[k].lo) / b.resolution.get(k).copied().unwrap_or(0.0);
        if geometric(cell[k]) {
            linear.max((cell[k].hi / cell[k].lo).log2() / GEOMETRIC_SPAN.log2())
        } else {
            linear
        }
    };
    let k = (0..cell.len())
        .filter(|&k| {
            depth[k] < b.depth
                && cell[k].hi > cell[k].lo
                && cell[k].center() > cell[k].lo
                && cell[k].center() < cell[k].hi
                && (below_resolution || ratio(k) > 1.0)
        })
        .max_by(|&i, &j| ratio(i).total_cmp(&ratio(j)).then(j.cmp(&i)))?;
    let mid = split_point(cell[k]);
    let mut a = cell.to_vec();
    let mut b = cell.to_vec();
    a[k].hi = mid;
    b[k].lo = mid;
    let mut d = depth.to_vec();
    d[k] += 1;
    Some([(a, d.clone()), (b, d)])
}

/// Where a cell's parameter is halved: its centre, or, for a positive parameter spanning
/// more than [`GEOMETRIC_SPAN`] times its lower end (a slope whose box comes from points that
/// barely bound it), its geometric mean, so that each order of magnitude gets its share of the
/// halvings instead of the top one taking them all. Any split point keeps the partition exact.
fn split_point(i: Interval) -> f64 {
    if geometric(i) {
        let g = (i.lo.sqrt() * i.hi.sqrt()).clamp(i.lo, i.hi);
        if g > i.lo && g < i.hi {
            return g;
        }
    }
    i.center()
}

/// Whether a cell's parameter is halved at its geometric mean (see [`split_point`]).
fn geometric(i: Interval) -> bool {
    i.lo > 0.0 && i.hi > GEOMETRIC_SPAN * i.lo
}

/// The span (`hi / lo`) beyond which a positive parameter is halved at its geometric mean.
pub const GEOMETRIC_SPAN: f64 = 16.0;

/// Run the search from `prior`. Each level's cells are `test`ed in parallel (a cheap necessary
/// condition: `Infeasible` must be a proof) and the survivors halved; the cells that reach
/// their resolution (or are queued when the budget runs out) are then evaluated by `finish`,
/// which gives the guaranteed results over each (and may still discard one). With no
/// parameter to bisect, `finish` runs once on the empty cell and its errors are the result.
/// When every cell is discarded the data falsify the model over the whole prior box: the
/// outcome is `Falsified`, at the latest first offending sample among the cells.
pub fn search<T: Send + Sync>(
    prior: &[Interval],
    budget: Budget,
    test: &(dyn Fn(&[Interval]) -> Result<Verdict<()>> + Sync),
    finish: &(dyn Fn(&[Interval]) -> Result<Verdict<T>> + Sync),
    progress: &(dyn Fn(&Progress) + Sync),
) -> Result<Outcome<Search<T>>> {
    Ok(run(prior, budget, test, finish, progress, false)?.concluded(prior))
}

/// Whether the data are consistent, by the same search as [`search`], stopping at the first
/// cell `finish` gives a value: `Consistent` then holds that one leaf (its bounds cover that
/// cell only, not the set), `Falsified` exactly when [`search`] would say so. The cells are
/// finished a thread-count at a time, so an error on a cell after the first with a value may
/// go unseen (a verdict, not bounds, is asked for). The noise-bound bracket uses it.
pub fn search_consistent<T: Send + Sync>(
    prior: &[Interval],
    budget: Budget,
    test: &(dyn Fn(&[Interval]) -> Result<Verdict<()>> + Sync),
    finish: &(dyn Fn(&[Interval]) -> Result<Verdict<T>> + Sync),
) -> Result<Outcome<Search<T>>> {
    Ok(run(prior, budget, test, finish, &|_| {}, true)?.concluded(prior))
}

/// The search of [`search`] and [`search_consistent`] (`first_value`): the levels of tests
/// and halvings ([`test_levels`]), then the finishing rounds, each refining the undecided
/// cells while the second budget lasts ([`Refine::cells`]).
fn run<T: Send + Sync>(
    prior: &[Interval],
    budget: Budget,
    test: &(dyn Fn(&[Interval]) -> Result<Verdict<()>> + Sync),
    finish: &(dyn Fn(&[Interval]) -> Result<Verdict<T>> + Sync),
    progress: &(dyn Fn(&Progress) + Sync),
    first_value: bool,
) -> Result<Ran<T>> {
    for (k, p) in prior.iter().enumerate() {
        if !(p.lo.is_finite() && p.hi.is_finite() && p.lo <= p.hi) {
            return Err(SmidError::invalid(
                format!("model.prior[{k}]"),
                format!("expected a finite box lo <= hi, got [{}, {}]", p.lo, p.hi),
            ));
        }
    }
    let mut tally = Tally::default();
    // Cells to finish, and whether the budget stopped the levels or coarsened their leaves.
    let (finals, stopped) = if prior.is_empty() {
        (vec![Vec::new()], false)
    } else {
        test_levels(prior, &budget, test, progress, &mut tally)?
    };
    let mut leaves = Vec::new();
    let mut refine = Refine {
        spare: budget.max_leaves.max(1),
        refined: 0,
    };
    let mut round: Vec<(Vec<Interval>, Vec<u32>)> = finals
        .into_iter()
        .map(|c| {
            let d = depth_of(&c, prior);
            (c, d)
        })
        .collect();
    while !round.is_empty() {
        let undecided = if first_value {
            match finish_first(round, finish, &mut tally)? {
                Ok(leaf) => {
                    return Ok(Ran::First(Search {
                        leaves: vec![leaf],
                        evaluated: tally.evaluated,
                        discarded: tally.discarded,
                        budget_stopped: stopped,
                        refined: refine.refined,
                        screened: false,
                    }));
                }
                Err(undecided) => undecided,
            }
        } else {
            finish_all(round, finish, &mut tally, &mut leaves)?
        };
        round = refine.cells(undecided, &budget, &mut leaves);
    }
    Ok(Ran::All(Finished {
        leaves,
        tally,
        budget_stopped: stopped,
        refined: refine.refined,
    }))
}

/// What [`run`] ends with: the first leaf with a value (`first_value`), or every surviving
/// leaf with the search's counts, to be concluded.
enum Ran<T> {
    First(Search<T>),
    All(Finished<T>),
}

impl<T> Ran<T> {
    fn concluded(self, prior: &[Interval]) -> Outcome<Search<T>> {
        match self {
            Ran::First(s) => Outcome::Consistent(s),
            Ran::All(f) => f.concluded(prior),
        }
    }
}

/// The surviving leaves of a whole search, its counts and latest contradiction.
struct Finished<T> {
    leaves: Vec<Leaf<T>>,
    tally: Tally,
    budget_stopped: bool,
    refined: usize,
}

impl<T> Finished<T> {
    /// `Falsified` at the latest contradiction when no cell survived, else the search.
    fn concluded(self, prior: &[Interval]) -> Outcome<Search<T>> {
        let Tally {
            evaluated,
            discarded,
            worst,
        } = self.tally;
        if self.leaves.is_empty() {
            let f = match worst {
                // No parameter bisected: the stages' own finding.
                Some(f) if prior.is_empty() => f,
                Some(f) => Falsification {
                    detail: format!(
                        "no value in the prior box of the bisected parameters fits ({evaluated} cells tried); the latest contradiction: {}",
                        f.detail
                    ),
                    ..f
                },
                None => Falsification::new(
                    Stage::Linear,
                    0,
                    "every cell of the prior box was discarded",
                ),
            };
            return Outcome::Falsified(f);
        }
        Outcome::Consistent(Search {
            leaves: self.leaves,
            evaluated,
            discarded,
            budget_stopped: self.budget_stopped,
            refined: self.refined,
            screened: false,
        })
    }
}

/// [`search`] with a cheaper finish first: the search runs with `screen`, whose verdicts
/// must match `finish`'s where they matter: a cell `screen` leaves undecided, `finish` leaves
/// undecided too, and `finish`'s value over a cell lies inside `screen`'s (`finish` starts
/// from `screen`'s result, as a stage-3 method from its [`start`](crate::stage3::Stage3Method::start)).
/// When every surviving cell has a value, each is finished again by `finish` (in parallel;
/// `finish` may discard one more), which gives what [`search`] with `finish` gives, the
/// screen's discards counted in the latest contradiction. When a cell stays undecided, its
/// undecided value covers every result over it whatever the finish, so `finish` is not run:
/// the leaves keep `screen`'s values, and the outcome says so ([`Search::screened`]).
pub fn search_screened<T: Send + Sync>(
    prior: &[Interval],
    budget: Budget,
    test: &(dyn Fn(&[Interval]) -> Result<Verdict<()>> + Sync),
    screen: &(dyn Fn(&[Interval]) -> Result<Verdict<T>> + Sync),
    finish: &(dyn Fn(&[Interval]) -> Result<Verdict<T>> + Sync),
    progress: &(dyn Fn(&Progress) + Sync),
) -> Result<Outcome<Search<T>>> {
    let mut ran = match run(prior, budget, test, screen, progress, false)? {
        Ran::All(f) => f,
        first => return Ok(first.concluded(prior)),
    };
    if ran.leaves.iter().any(|l| l.value.is_none()) {
        return Ok(ran.concluded(prior).map(|s| Search {
            screened: true,
            ..s
        }));
    }
    // The same cells again, not new ones: the count stays the screen's.
    let evaluated = ran.tally.evaluated;
    let round: Vec<(Vec<Interval>, Vec<u32>)> = std::mem::take(&mut ran.leaves)
        .into_iter()
        .map(|l| {
            let d = depth_of(&l.cell, prior);
            (l.cell, d)
        })
        .collect();
    let undecided = finish_all(round, finish, &mut ran.tally, &mut ran.leaves)?;
    ran.tally.evaluated = evaluated;
    ran.leaves
        .extend(undecided.into_iter().map(|(cell, _, why)| Leaf {
            cell,
            value: None,
            cause: Some(why),
        }));
    Ok(ran.concluded(prior))
}

/// The counts of a search and its latest contradiction.
#[derive(Default)]
struct Tally {
    evaluated: usize,
    discarded: usize,
    worst: Option<Falsification>,
}

impl Tally {
    /// A discarded cell and its contradiction (kept when later than the latest so far).
    fn discard(&mut self, e: Falsification) {
        self.discarded += 1;
        self.worst = Some(match self.worst.take() {
            Some(w) if later(&w, &e) => w,
            _ => e,
        });
    }
}

/// An undecided cell, its halvings and why it is undecided.
type Undecided = (Vec<Interval>, Vec<u32>, (UndecidedCause, String));

/// The levels of the search from `prior`: each level's cells `test`ed in parallel and the
/// survivors halved, until every cell reaches its resolution or the budget runs out; then,
/// with too many leaves to finish, the leaves coarsened ([`coarsen`]). The cells to finish,
/// and whether the budget stopped the levels or coarsened the leaves.
fn test_levels(
    prior: &[Interval],
    budget: &Budget,
    test: &(dyn Fn(&[Interval]) -> Result<Verdict<()>> + Sync),
    progress: &(dyn Fn(&Progress) + Sync),
    tally: &mut Tally,
) -> Result<(Vec<Vec<Interval>>, bool)> {
    let mut budget_stopped = false;
    // Each cell carries the cells it was cut from (to coarsen the leaves if too many).
    type Node = (Vec<Interval>, Vec<u32>, Vec<Vec<Interval>>);
    let mut level: Vec<Node> = vec![(prior.to_vec(), vec![0u32; prior.len()], Vec::new())];
    let mut tree: Vec<(Vec<Interval>, Vec<Vec<Interval>>)> = Vec::new();
    while !level.is_empty() {
        if tally.evaluated + level.len() > budget.max_cells.max(1) {
            budget_stopped = true;
            tree.extend(level.into_iter().map(|(c, _, a)| (c, a)));
            break;
        }
        let verdicts: Vec<Result<Verdict<()>>> =
            level.par_iter().map(|(c, _, _)| test(c)).collect();
        tally.evaluated += level.len();
        let mut next = Vec::new();
        let mut kept: Vec<Vec<Interval>> = Vec::new();
        for ((cell, depth, ancestors), v) in level.into_iter().zip(verdicts) {
            if let Verdict::Infeasible(e) = v? {
                tally.discard(e);
                continue;
            }
            kept.push(cell.clone());
            match bisect(&cell, &depth, budget, false) {
                Some(children) => {
                    for (c, d) in children {
                        let mut a = ancestors.clone();
                        a.push(cell.clone());
                        next.push((c, d, a));
                    }
                }
                None => tree.push((cell, ancestors)),
            }
        }
        progress(&Progress {
            evaluated: tally.evaluated,
            queued: next.len(),
            kept: kept.len(),
            hull: hull_of_boxes(kept.iter().map(|c| c.as_slice())),
        });
        level = next;
    }
    let (tree, coarsened) = coarsen(tree, budget.max_leaves.max(1));
    Ok((
        tree.into_iter().map(|(c, _)| c).collect(),
        budget_stopped || coarsened,
    ))
}

/// Too many leaves to finish (more than `max_leaves`): replace them by the cells they were
/// cut from (tested and kept, so still a cover), a level at a time. Whether any was replaced.
fn coarsen(
    mut tree: Vec<(Vec<Interval>, Vec<Vec<Interval>>)>,
    max_leaves: usize,
) -> (Vec<(Vec<Interval>, Vec<Vec<Interval>>)>, bool) {
    let mut coarsened = false;
    while tree.len() > max_leaves {
        let mut up: Vec<(Vec<Interval>, Vec<Vec<Interval>>)> = Vec::new();
        let mut moved = false;
        for (cell, mut anc) in tree {
            let item = match anc.pop() {
                Some(parent) => {
                    moved = true;
                    (parent, anc)
                }
                None => (cell, anc),
            };
            if !up.iter().any(|(c, _)| *c == item.0) {
                up.push(item);
            }
        }
        tree = up;
        coarsened = true;
        if !moved {
            break;
        }
    }
    (tree, coarsened)
}

/// Finish every cell of `round` in parallel: the feasible ones become `leaves`, the
/// undecided ones are returned.
fn finish_all<T: Send + Sync>(
    round: Vec<(Vec<Interval>, Vec<u32>)>,
    finish: &(dyn Fn(&[Interval]) -> Result<Verdict<T>> + Sync),
    tally: &mut Tally,
    leaves: &mut Vec<Leaf<T>>,
) -> Result<Vec<Undecided>> {
    let done: Vec<Result<Verdict<T>>> = round.par_iter().map(|(c, _)| finish(c)).collect();
    tally.evaluated += round.len();
    let mut undecided: Vec<Undecided> = Vec::new();
    for ((cell, depth), v) in round.into_iter().zip(done) {
        match v? {
            Verdict::Infeasible(e) => tally.discard(e),
            Verdict::Feasible(t) => leaves.push(Leaf {
                cell,
                value: Some(t),
                cause: None,
            }),
            Verdict::Undecided(cause, detail) => undecided.push((cell, depth, (cause, detail))),
        }
    }
    Ok(undecided)
}

/// Finish the cells of `round` a thread-count at a time: `Ok` with the first cell that has a
/// value (which ends the search), else `Err` with the undecided cells.
fn finish_first<T: Send + Sync>(
    round: Vec<(Vec<Interval>, Vec<u32>)>,
    finish: &(dyn Fn(&[Interval]) -> Result<Verdict<T>> + Sync),
    tally: &mut Tally,
) -> Result<std::result::Result<Leaf<T>, Vec<Undecided>>> {
    let chunk = rayon::current_num_threads().max(1);
    let mut undecided = Vec::new();
    let mut queue = round.into_iter();
    loop {
        let batch: Vec<(Vec<Interval>, Vec<u32>)> = queue.by_ref().take(chunk).collect();
        if batch.is_empty() {
            break;
        }
        let done: Vec<Result<Verdict<T>>> = batch.par_iter().map(|(c, _)| finish(c)).collect();
        tally.evaluated += batch.len();
        for ((cell, depth), v) in batch.into_iter().zip(done) {
            match v? {
                Verdict::Infeasible(e) => tally.discard(e),
                Verdict::Feasible(t) => {
                    return Ok(Ok(Leaf {
                        cell,
                        value: Some(t),
                        cause: None,
                    }));
                }
                Verdict::Undecided(cause, detail) => undecided.push((cell, depth, (cause, detail))),
            }
        }
    }
    Ok(Err(undecided))
}

/// The second budget: leaves left to spend on refining undecided cells, and the cells
/// refined so far.
struct Refine {
    spare: usize,
    refined: usize,
}

impl Refine {
    /// Halve each undecided cell while the budget lasts (both halves or none): the halves,
    /// to finish next; a cell not halved becomes an undecided leaf.
    fn cells<T>(
        &mut self,
        undecided: Vec<Undecided>,
        budget: &Budget,
        leaves: &mut Vec<Leaf<T>>,
    ) -> Vec<(Vec<Interval>, Vec<u32>)> {
        let mut round = Vec::new();
        for (cell, depth, why) in undecided {
            match bisect(&cell, &depth, budget, true) {
                Some(children) if self.spare >= 2 => {
                    self.spare -= 2;
                    self.refined += 1;
                    round.extend(children);
                }
                _ => leaves.push(Leaf {
                    cell,
                    value: None,
                    cause: Some(why),
                }),
            }
        }
        round
    }
}

/// Halvings of each parameter of `cell` from `prior` (by widths; a bisection halves exactly).
fn depth_of(cell: &[Interval], prior: &[Interval]) -> Vec<u32> {
    cell.iter()
        .zip(prior)
        .map(|(c, p)| {
            let (w, pw) = (c.hi - c.lo, p.hi - p.lo);
            if w > 0.0 && pw > 0.0 {
                (pw / w).log2().round().max(0.0) as u32
            } else {
                0
            }
        })
        .collect()
}

/// Whether finding `a` names a later point of the data than `b` (stage, then record and
/// sample). The latest cell finding is the union's: every cell is inconsistent by its sample,
/// and when it was located, its cell is consistent before it, so the union's first offending
/// sample is that one (an unlocated cell's first offending sample lies at or before its own),
/// and `located` carries over as it is.
fn later(a: &Falsification, b: &Falsification) -> bool {
    let key = |f: &Falsification| {
        let s = match f.stage {
            Stage::SteadyState => 0,
            Stage::InnerSignal => 1,
            Stage::Linear => 2,
        };
        (s, f.record, f.sample)
    };
    key(a) >= key(b)
}

#[cfg(test)]
mod tests;
