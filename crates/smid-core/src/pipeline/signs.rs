//! Stage 3 over the signs of samples with a two-sided preimage ([`InnerKind::Mirrored`]: the
//! sample lies in `I` or in `-I`, as behind `|·|`, where the measurement cannot tell the sign
//! of the block's input).
//!
//! Each pattern of signs turns every such sample into one interval, and the equations hold
//! for the truth under its own pattern. So the set is the union over patterns, and any
//! problem whose intervals hold every surviving pattern's bounds them all. The patterns are
//! searched depth first in time order, once under each sign of the first sample: a node
//! decides the signs of the first `d` mirrored samples and gives every later one the hull of
//! its pair (an interval that holds it under either sign, so the node's outer set holds every
//! pattern below it). A node whose outer set (the classical one) is empty is cut with
//! everything below it. The same sign as the previous sample is tried first, so a run of one
//! sign is followed to its end before a flip is tried.
//!
//! The complete patterns that survive are bounded together, once per sign of the first
//! sample: a sample on which they all agree keeps that sign, any other takes its pair's hull
//! ([`Agreement`]). One solve of the spec's method per subtree, however many patterns survive;
//! the hull of the two results is the bound.
//!
//! A sample whose pair of intervals nearly meets at zero barely tells its sign; it takes the
//! hull of its pair instead of a branch ([`branching`], `method.signs.hull_within`), which
//! keeps every bound sound and the patterns that survive few.
//!
//! The search is sound at every budget: when `method.signs.nodes` is spent, the nodes still
//! open join the agreement with their undecided samples at their hulls, so the bound covers
//! the patterns below them too: looser, never dropped. ([`feasible_over_signs`], which proves
//! a record inconsistent, reports a spent budget as an unbounded set instead: nothing proven.)
use super::{stage3_decided, StageSignals};
use crate::error::{Result, SmidError};
use crate::interval::Interval;
use crate::inversion::InnerKind;
use crate::model::Layout;
use crate::spec::{MethodSpec, ModelSpec};
use crate::stage3::EivResult;

/// The indices of the mirrored samples of `sig`, in time order.
pub fn mirrored(sig: &StageSignals) -> Vec<usize> {
    sig.output
        .iter()
        .enumerate()
        .filter(|(_, b)| b.kind == InnerKind::Mirrored)
        .map(|(t, _)| t)
        .collect()
}

/// `sig` with every mirrored sample that comes within `within × width` of zero replaced by
/// the hull of its pair (an interval that holds the sample under either sign): the samples
/// left mirrored are the ones the search branches on ([`crate::spec::SignSpec::hull_within`]).
pub fn branching(sig: &StageSignals, within: f64) -> StageSignals {
    let mut out = sig.clone();
    for b in out.output.iter_mut() {
        if b.kind == InnerKind::Mirrored && b.interval.lo < within * 2.0 * b.interval.radius() {
            *b = crate::inversion::InnerBound {
                interval: b.hull(),
                kind: InnerKind::Inverted,
            };
        }
    }
    out
}

/// `sig` with the signs of its mirrored samples `idx[..signs.len()]` decided (`true`: the
/// positive interval); the other mirrored samples stay undecided.
pub fn with_signs(sig: &StageSignals, idx: &[usize], signs: &[bool]) -> StageSignals {
    let mut out = sig.clone();
    for (&t, &s) in idx.iter().zip(signs) {
        out.output[t] = sig.output[t].with_sign(s);
    }
    out
}

/// A node of the search: the signs decided so far.
type Node = Vec<bool>;

/// The children of `node`, to push on the stack: the flip first, so that the same sign as the
/// node's last decided sample is popped (tried) first.
fn children(node: &Node) -> [Node; 2] {
    let last = node.last().copied().unwrap_or(true);
    let mut same = node.clone();
    same.push(last);
    let mut flip = node.clone();
    flip.push(!last);
    [flip, same]
}

/// Whether the node's outer set may be non-empty (a solver's failure or an unbounded set is
/// no proof of emptiness: kept).
fn may_hold(
    model: &ModelSpec,
    layout: &Layout,
    method: &MethodSpec,
    sig: &StageSignals,
    prior: Option<&[Interval]>,
) -> Result<bool> {
    let problem = super::eiv_problem(model, layout, method, sig, prior);
    match crate::stage3::feasible(&problem) {
        Ok(v) => Ok(v),
        Err(SmidError::Unbounded { .. } | SmidError::Solver(_)) => Ok(true),
        Err(e) => Err(e),
    }
}

/// The error of a feasibility search the budget stopped with `open` patterns unexplored.
fn budget_spent(open: usize, n: usize, nodes: usize) -> SmidError {
    SmidError::Unbounded {
        parameter: "θ".into(),
        message: format!(
            "the sign search over {n} samples of two-sided preimage spent its budget of {nodes} nodes (method.signs.nodes) with {open} pattern(s) unexplored: no bound covers them"
        ),
    }
}

/// Stage 3 on `sig` over the sign patterns of its mirrored samples (see the module doc): the
/// hull of the bounds of the two subtrees (each sign of the first sample), each subtree
/// bounded once, at the signs its surviving patterns agree on. An inconsistency (every
/// pattern cut) is named at the last sample, not located.
pub fn stage3_over_signs(
    model: &ModelSpec,
    layout: &Layout,
    method: &MethodSpec,
    sig: &StageSignals,
    prior: Option<&[Interval]>,
    locate: bool,
) -> Result<EivResult> {
    let sig = &branching(sig, method.signs.hull_within);
    let idx = mirrored(sig);
    let mut spent = 0usize;
    let mut hull: Option<EivResult> = None;
    let mut first_error: Option<SmidError> = None;
    for first in [true, false] {
        let agreed = survivors(model, layout, method, sig, &idx, prior, first, &mut spent)?;
        let Some(agreed) = agreed else { continue };
        let here = agreed.apply(sig, &idx);
        match stage3_decided(model, layout, method, &here, prior, locate) {
            Ok(r) => {
                hull = Some(match hull {
                    None => r,
                    Some(h) => merge(h, r),
                })
            }
            Err(e @ SmidError::Inconsistent(_)) => {
                first_error.get_or_insert(e);
            }
            Err(e) => return Err(e),
        }
    }
    log::debug!(target: "smid::stage3", "sign search: {} samples, {spent} nodes", idx.len());
    match (hull, first_error) {
        (Some(h), _) => Ok(h),
        (None, Some(e)) => Err(e),
        (None, None) => Err(SmidError::inconsistent_unlocated(
            crate::error::Stage::Linear,
            sig.output.len().saturating_sub(1),
            "no sign pattern of the samples of two-sided preimage fits the equations (every pattern's outer set is empty)",
        )),
    }
}

/// What the patterns of a subtree say of one mirrored sample's sign: all positive, all
/// negative, or both (the sample then takes its pair's hull).
#[derive(Debug, Clone, Copy, PartialEq)]
enum Agreed {
    Positive,
    Negative,
    Both,
}

/// The signs a set of patterns agrees on, sample by sample.
struct Agreement(Vec<Option<Agreed>>);

impl Agreement {
    /// Adds a pattern whose first `node.len()` signs are decided, the rest open (both).
    fn add(&mut self, node: &[bool]) {
        for (k, slot) in self.0.iter_mut().enumerate() {
            let here = match node.get(k) {
                Some(true) => Agreed::Positive,
                Some(false) => Agreed::Negative,
                None => Agreed::Both,
            };
            *slot = match *slot {
                None => Some(here),
                Some(a) if a == here => Some(a),
                Some(_) => Some(Agreed::Both),
            };
        }
    }

    /// `sig` with the agreed signs decided and every other mirrored sample at its hull: an
    /// outer bound of every pattern added.
    fn apply(&self, sig: &StageSignals, idx: &[usize]) -> StageSignals {
        let mut out = sig.clone();
        for (&t, a) in idx.iter().zip(&self.0) {
            out.output[t] = match a {
                Some(Agreed::Positive) => sig.output[t].with_sign(true),
                Some(Agreed::Negative) => sig.output[t].with_sign(false),
                _ => crate::inversion::InnerBound {
                    interval: sig.output[t].hull(),
                    kind: InnerKind::Inverted,
                },
            };
        }
        out
    }
}

/// The agreement of the patterns whose first mirrored sample has the sign `first` and whose
/// outer sets survive (`None`: every one is cut): depth first, each node one feasibility LP
/// with its later samples at their hulls. Once the shared node budget is spent, the nodes
/// still open join the agreement with their undecided samples open, so the bound covers them.
#[allow(clippy::too_many_arguments)]
fn survivors(
    model: &ModelSpec,
    layout: &Layout,
    method: &MethodSpec,
    sig: &StageSignals,
    idx: &[usize],
    prior: Option<&[Interval]>,
    first: bool,
    spent: &mut usize,
) -> Result<Option<Agreement>> {
    let mut stack: Vec<Node> = vec![vec![first]];
    let mut agreed = Agreement(vec![None; idx.len()]);
    let mut any = false;
    while let Some(node) = stack.pop() {
        if *spent >= method.signs.nodes {
            log::debug!(target: "smid::stage3", "sign search: node budget spent, {} open patterns bounded with the rest", stack.len() + 1);
            agreed.add(&node);
            stack.iter().for_each(|n| agreed.add(n));
            return Ok(Some(agreed));
        }
        *spent += 1;
        let here = branching(&with_signs(sig, idx, &node), f64::INFINITY);
        if !may_hold(model, layout, method, &here, prior)? {
            continue;
        }
        if node.len() < idx.len() {
            stack.extend(children(&node));
        } else {
            any = true;
            agreed.add(&node);
        }
    }
    Ok(any.then_some(agreed))
}

/// Whether some sign pattern of `sig`'s mirrored samples may fit the equations: `false` is a
/// proof (every pattern's classical outer set is empty); the first pattern whose outer set
/// holds a point ends the search. A spent budget is an `Unbounded` error (nothing proven).
pub fn feasible_over_signs(
    model: &ModelSpec,
    layout: &Layout,
    method: &MethodSpec,
    sig: &StageSignals,
) -> Result<bool> {
    let sig = &branching(sig, method.signs.hull_within);
    let idx = mirrored(sig);
    let budget = method.signs.nodes;
    let mut stack: Vec<Node> = vec![vec![false], vec![true]];
    let mut spent = 0usize;
    while let Some(node) = stack.pop() {
        if spent >= budget {
            return Err(budget_spent(stack.len() + 1, idx.len(), budget));
        }
        spent += 1;
        let here = branching(&with_signs(sig, &idx, &node), f64::INFINITY);
        if may_hold(model, layout, method, &here, None)? {
            if node.len() == idx.len() {
                return Ok(true);
            }
            stack.extend(children(&node));
        }
    }
    Ok(false)
}

/// The hull of two patterns' results.
fn merge(a: EivResult, b: EivResult) -> EivResult {
    let mut equations = a.equations;
    equations.extend(b.equations);
    equations.sort_unstable();
    equations.dedup();
    EivResult {
        bounds: a
            .bounds
            .iter()
            .zip(&b.bounds)
            .map(|(x, y)| Interval::new(x.lo.min(y.lo), x.hi.max(y.hi)))
            .collect(),
        equations,
        feasible_orthants: a.feasible_orthants + b.feasible_orthants,
        unsettled: match (a.unsettled, b.unsettled) {
            (Some(x), Some(y)) => Some(x.max(y)),
            (x, y) => x.or(y),
        },
    }
}

/// `sig` with every mirrored sample's sign taken from the free run of the linear block at
/// `theta` (θ order: `a1..a_na`, `b0..b_nb`, the extra coefficients), each record from rest,
/// the input and extra columns at their centres (an unknown value as 0), past outputs from the
/// measurements where the model runs in feedback ([`StageSignals::lagged`]). A pattern to
/// certify a point with: the certificate proves the point consistent under that pattern,
/// which makes it a member whatever the other patterns say.
pub fn decided_by_run(sig: &StageSignals, na: usize, nb: usize, theta: &[f64]) -> StageSignals {
    let idx = mirrored(sig);
    if idx.is_empty() {
        return sig.clone();
    }
    let x = free_run(sig, na, nb, theta);
    let signs: Vec<bool> = idx.iter().map(|&t| x[t] >= 0.0).collect();
    with_signs(sig, &idx, &signs)
}

/// The free run of the linear block at `theta` over `sig`'s records (see [`decided_by_run`]).
fn free_run(sig: &StageSignals, na: usize, nb: usize, theta: &[f64]) -> Vec<f64> {
    let n = sig.output.len();
    let centre = |i: Interval| {
        let c = i.center();
        if c.is_finite() {
            c
        } else {
            0.0
        }
    };
    let mut x = vec![0.0; n];
    let mut start_of = vec![0usize; n];
    for (r, &s) in sig.starts.iter().enumerate() {
        let end = sig.starts.get(r + 1).copied().unwrap_or(n);
        start_of[s.min(n)..end.min(n)]
            .iter_mut()
            .for_each(|v| *v = s);
    }
    for t in 0..n {
        let s0 = start_of[t];
        let mut v = 0.0;
        for j in 0..=nb {
            if t >= s0 + j {
                v += theta.get(na + j).copied().unwrap_or(0.0) * centre(sig.input[t - j]);
            }
        }
        for i in 1..=na {
            if t >= s0 + i {
                let past = match &sig.lagged {
                    Some(w) => centre(w[t - i]),
                    None => x[t - i],
                };
                v -= theta[i - 1] * past;
            }
        }
        for (k, e) in sig.extra.iter().enumerate() {
            if let Some(&c) = theta.get(na + nb + 1 + k) {
                v += c * e.values.get(t).copied().map_or(0.0, centre);
            }
        }
        x[t] = v;
    }
    x
}
