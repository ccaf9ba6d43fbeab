//! Stage 3 over the signs of samples with a two-sided preimage ([`InnerKind::Mirrored`]: the
//! sample lies in `I` or in `-I`, as behind `|·|`, where the measurement cannot tell the sign
//! of the block's input).
//!
//! Each pattern of signs turns every such sample into one interval, and the equations hold
//! for the truth under its own pattern. So the set is the union over patterns, and any
//! problem whose intervals hold every surviving pattern's bounds them all.
//!
//! The search runs once under each sign of the first sample, breadth first over the samples
//! in time order. A node decides the signs of the first `d` mirrored samples (each positive,
//! negative, or both: see below) and gives every later one the hull of its pair, an interval
//! that holds it under either sign, so the node's outer set holds every pattern below it. Each
//! node of the frontier branches on the next sample, and a child whose outer set (the
//! classical one) is empty is cut with every pattern below it.
//!
//! A frontier wider than `method.signs.width` is narrowed: the nodes that agree on their latest
//! signs are merged into one node that is "both" wherever they differ, and such a sample takes
//! its pair's hull. The merged node holds every pattern of the nodes it replaces, so the search
//! stays sound at a cost of at most `2 · width` LPs per sample. At the end the frontier is
//! merged the same way and bounded by the spec's method: one solve per sign of the first
//! sample, and the hull of the two results is the bound. Where the surviving patterns never
//! outnumber the width, that bound is the hull of their bounds' problem, exactly.
//!
//! A sample whose pair of intervals nearly meets at zero barely tells its sign; it takes the
//! hull of its pair instead of a branch ([`branching`], `method.signs.hull_within`).
//!
//! When `method.signs.nodes` is spent, the frontier is merged and every later sample keeps its
//! hull: looser, never dropped. [`feasible_over_signs`], the branch and bound's cheap test of a
//! cell, runs the same search and calls a record inconsistent only when both subtrees are cut.
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

/// What a node of the search says of one mirrored sample's sign: positive, negative, or
/// both (the node stands for patterns of either sign there, and the sample takes its pair's
/// hull).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
enum Agreed {
    Positive,
    Negative,
    Both,
}

/// A node of the search: what it says of the first `len()` mirrored samples.
type Node = Vec<Agreed>;

/// The sign search over one record set's stage-2 signals: the problem every node is tested
/// on, and the mirrored samples it branches on.
struct Patterns<'a> {
    model: &'a ModelSpec,
    layout: &'a Layout,
    method: &'a MethodSpec,
    prior: Option<&'a [Interval]>,
    /// The signals, the samples near zero already hulled ([`branching`]).
    sig: StageSignals,
    /// The indices of the samples left mirrored, in time order.
    idx: Vec<usize>,
}

impl<'a> Patterns<'a> {
    fn new(
        model: &'a ModelSpec,
        layout: &'a Layout,
        method: &'a MethodSpec,
        sig: &StageSignals,
        prior: Option<&'a [Interval]>,
    ) -> Self {
        let sig = branching(sig, method.signs.hull_within);
        let idx = mirrored(&sig);
        Patterns {
            model,
            layout,
            method,
            prior,
            sig,
            idx,
        }
    }

    /// The signals with the first `node.len()` mirrored samples as `node` says and every
    /// later one at its pair's hull: an outer bound of every pattern the node stands for.
    fn apply(&self, node: &[Agreed]) -> StageSignals {
        let mut out = self.sig.clone();
        for (k, &t) in self.idx.iter().enumerate() {
            let b = &self.sig.output[t];
            out.output[t] = match node.get(k) {
                Some(Agreed::Positive) => b.with_sign(true),
                Some(Agreed::Negative) => b.with_sign(false),
                _ => crate::inversion::InnerBound {
                    interval: b.hull(),
                    kind: InnerKind::Inverted,
                },
            };
        }
        out
    }

    /// Whether the node's outer set (the classical one) may be non-empty: `false` is a proof
    /// for every pattern the node stands for (a solver's failure or an unbounded set is no
    /// proof of emptiness: kept).
    fn may_hold(&self, node: &[Agreed]) -> Result<bool> {
        let sig = self.apply(node);
        let problem = super::eiv_problem(self.model, self.layout, self.method, &sig, self.prior);
        match crate::stage3::feasible(&problem) {
            Ok(v) => Ok(v),
            Err(SmidError::Unbounded { .. } | SmidError::Solver(_)) => Ok(true),
            Err(e) => Err(e),
        }
    }

    /// The node that stands for every pattern whose first mirrored sample has the sign
    /// `first` and whose outer set survives (`None`: every one is cut, a proof). Breadth first
    /// over the samples in time order: each node of the frontier branches on the next sample
    /// (its last sign first), each child is one feasibility LP ([`Self::may_hold`]), and a
    /// frontier wider than `method.signs.width` is narrowed by merging ([`narrowed`]). Once
    /// the shared node budget is spent, the frontier is merged and every later sample keeps
    /// its hull.
    fn survivors(&self, first: Agreed, spent: &mut usize) -> Result<Option<Node>> {
        *spent += 1;
        if !self.may_hold(&[first])? {
            return Ok(None);
        }
        let mut frontier: Vec<Node> = vec![vec![first]];
        for depth in 1..self.idx.len() {
            if *spent >= self.method.signs.nodes {
                log::debug!(target: "smid::stage3", "sign search: node budget spent at depth {depth} of {}: the later samples keep their hulls", self.idx.len());
                return Ok(Some(agree(&frontier)));
            }
            let mut next = Vec::with_capacity(2 * frontier.len());
            for node in &frontier {
                let signs = match node.last() {
                    Some(Agreed::Negative) => [Agreed::Negative, Agreed::Positive],
                    _ => [Agreed::Positive, Agreed::Negative],
                };
                for sign in signs {
                    let mut child = node.clone();
                    child.push(sign);
                    *spent += 1;
                    if self.may_hold(&child)? {
                        next.push(child);
                    }
                }
            }
            if next.is_empty() {
                return Ok(None);
            }
            frontier = narrowed(next, self.method.signs.width);
        }
        Ok(Some(agree(&frontier)))
    }
}

/// The node that stands for every node of `nodes` (all of one depth, at least one): each
/// sample's sign where they agree, both where they differ.
fn agree(nodes: &[Node]) -> Node {
    let mut out = nodes[0].clone();
    for n in &nodes[1..] {
        for (o, &a) in out.iter_mut().zip(n) {
            if *o != a {
                *o = Agreed::Both;
            }
        }
    }
    out
}

/// `frontier` (nodes of one depth) narrowed to at most `width` nodes: the nodes that agree on
/// their latest `k` samples merged into one ([`agree`]), with the longest such `k` that leaves
/// `width` groups at most. The latest signs are the ones the next equations read.
fn narrowed(frontier: Vec<Node>, width: usize) -> Vec<Node> {
    if frontier.len() <= width {
        return frontier;
    }
    let depth = frontier[0].len();
    let groups_of = |k: usize| {
        let mut groups: Vec<Vec<Node>> = Vec::new();
        let mut keys: std::collections::HashMap<&[Agreed], usize> = Default::default();
        for n in &frontier {
            let g = *keys.entry(&n[depth - k..]).or_insert(groups.len());
            if g == groups.len() {
                groups.push(Vec::new());
            }
            groups[g].push(n.clone());
        }
        groups
    };
    // The number of groups grows with `k` (0 gives one group): bisect for the longest `k`
    // that gives `width` groups at most.
    let (mut fits, mut over) = (0, depth);
    while over - fits > 1 {
        let mid = (fits + over) / 2;
        if groups_of(mid).len() <= width {
            fits = mid;
        } else {
            over = mid;
        }
    }
    groups_of(fits).iter().map(|g| agree(g)).collect()
}

/// Stage 3 on `sig` over the sign patterns of its mirrored samples (see the module doc): the
/// hull of the bounds of the two subtrees (each sign of the first sample), each bounded once
/// at the node that stands for its survivors. An inconsistency (every pattern cut) is named at
/// the last sample, not located.
pub fn stage3_over_signs(
    model: &ModelSpec,
    layout: &Layout,
    method: &MethodSpec,
    sig: &StageSignals,
    prior: Option<&[Interval]>,
    locate: bool,
) -> Result<EivResult> {
    let patterns = Patterns::new(model, layout, method, sig, prior);
    if patterns.idx.is_empty() {
        return stage3_decided(model, layout, method, &patterns.sig, prior, locate);
    }
    let mut spent = 0usize;
    let mut hull: Option<EivResult> = None;
    let mut first_error: Option<SmidError> = None;
    for first in [Agreed::Positive, Agreed::Negative] {
        let Some(node) = patterns.survivors(first, &mut spent)? else {
            continue;
        };
        log::debug!(target: "smid::stage3", "sign search: {} of {} samples' signs agreed", node.iter().filter(|a| **a != Agreed::Both).count(), patterns.idx.len());
        match stage3_decided(model, layout, method, &patterns.apply(&node), prior, locate) {
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
    log::debug!(target: "smid::stage3", "sign search: {} samples, {spent} nodes", patterns.idx.len());
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
/// proof (every pattern's classical outer set is empty, by the same search as
/// [`stage3_over_signs`]); a spent budget leaves the patterns open (`true`, nothing proven).
pub fn feasible_over_signs(
    model: &ModelSpec,
    layout: &Layout,
    method: &MethodSpec,
    sig: &StageSignals,
) -> Result<bool> {
    let patterns = Patterns::new(model, layout, method, sig, None);
    if patterns.idx.is_empty() {
        return patterns.may_hold(&[]);
    }
    let mut spent = 0usize;
    for first in [Agreed::Positive, Agreed::Negative] {
        if patterns.survivors(first, &mut spent)?.is_some() {
            return Ok(true);
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
