//! Stage 3 over the signs of samples with a two-sided preimage ([`InnerKind::Mirrored`]: the
//! sample lies in `I` or in `-I`, as behind `|·|`, where the measurement cannot tell the sign
//! of the block's input).
//!
//! Each pattern of signs turns every such sample into one interval, and the equations hold
//! for the truth under its own pattern. So the set is the union over patterns, and its hull
//! is the hull of the patterns' bounds. The patterns are searched depth first in time order:
//! a node decides the signs of the first `d` mirrored samples and leaves the rest unusable
//! (stage 3 drops their equations, so every bound of the node holds for each pattern below
//! it). A node whose outer set (the classical one) is empty is cut with everything below it;
//! a complete pattern that survives is bounded by the spec's method. The same sign as the
//! previous sample is tried first, so a run of one sign is followed to its end before a flip
//! is tried.
//!
//! The search is sound at every budget: when `method.signs.nodes` is spent, the patterns left
//! unexplored are reported (as an unbounded set, the bounds of what was explored not being a
//! bound of the whole), never dropped.
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

/// The error of a search the budget stopped with `open` patterns unexplored.
fn budget_spent(open: usize, n: usize, nodes: usize) -> SmidError {
    SmidError::Unbounded {
        parameter: "θ".into(),
        message: format!(
            "the sign search over {n} samples of two-sided preimage spent its budget of {nodes} nodes (method.signs.nodes) with {open} pattern(s) unexplored: no bound covers them"
        ),
    }
}

/// Stage 3 on `sig` over the sign patterns of its mirrored samples (see the module doc): the
/// hull of the bounds of every pattern that survives. An inconsistency (every pattern cut)
/// is named at the last sample, not located.
pub fn stage3_over_signs(
    model: &ModelSpec,
    layout: &Layout,
    method: &MethodSpec,
    sig: &StageSignals,
    prior: Option<&[Interval]>,
    locate: bool,
) -> Result<EivResult> {
    let idx = mirrored(sig);
    let budget = method.signs.nodes;
    let mut stack: Vec<Node> = vec![vec![false], vec![true]];
    let mut spent = 0usize;
    let mut hull: Option<EivResult> = None;
    let mut first_error: Option<SmidError> = None;
    while let Some(node) = stack.pop() {
        if spent >= budget {
            return Err(budget_spent(stack.len() + 1, idx.len(), budget));
        }
        spent += 1;
        let here = with_signs(sig, &idx, &node);
        if node.len() < idx.len() {
            if may_hold(model, layout, method, &here, prior)? {
                stack.extend(children(&node));
            }
            continue;
        }
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

/// Whether some sign pattern of `sig`'s mirrored samples may fit the equations: `false` is a
/// proof (every pattern's classical outer set is empty); the first pattern whose outer set
/// holds a point ends the search. A spent budget is an `Unbounded` error (nothing proven).
pub fn feasible_over_signs(
    model: &ModelSpec,
    layout: &Layout,
    method: &MethodSpec,
    sig: &StageSignals,
) -> Result<bool> {
    let idx = mirrored(sig);
    let budget = method.signs.nodes;
    let mut stack: Vec<Node> = vec![vec![false], vec![true]];
    let mut spent = 0usize;
    while let Some(node) = stack.pop() {
        if spent >= budget {
            return Err(budget_spent(stack.len() + 1, idx.len(), budget));
        }
        spent += 1;
        let here = with_signs(sig, &idx, &node);
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
