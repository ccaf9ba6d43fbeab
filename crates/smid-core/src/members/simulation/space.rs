//! The member search's spaces: what the search shares between cells ([`Search`]), one cell's
//! search space ([`CellSpace`]), and the measures at a point of a cell (the free-run error,
//! the phase-1 measure, the certificate).
use super::{best_at_a, consistency_at};
use crate::error::Result;
use crate::interval::Interval;
use crate::members::{finite_centre, least_squares_theta, point};
use crate::model::{CellSet, ModelSet};
use std::sync::atomic::{AtomicUsize, Ordering::Relaxed};

/// A point of the cell's nonlinearity set: the centre of its parameter bounds when the set
/// holds it, else the grid point (5 levels per parameter, up to 625) nearest that centre.
fn nonlinearity_point(c: &CellSet) -> Option<Vec<f64>> {
    let bounds: Vec<Interval> = c
        .nonlinearity
        .parameters()
        .iter()
        .map(|b| b.interval)
        .collect();
    let centre: Vec<f64> = bounds.iter().map(|i| finite_centre(*i)).collect();
    if c.nonlinearity.contains(&centre) {
        return Some(centre);
    }
    let n = bounds.len();
    if n == 0 || n > 4 {
        return None;
    }
    let levels = [0.5, 0.3, 0.7, 0.1, 0.9];
    let mut best: Option<(f64, Vec<f64>)> = None;
    for idx in 0..levels.len().pow(n as u32) {
        let mut p = Vec::with_capacity(n);
        let mut dist = 0.0;
        let mut r = idx;
        for b in &bounds {
            let l = levels[r % levels.len()];
            r /= levels.len();
            let (lo, hi) = (b.lo, b.hi);
            if !(lo.is_finite() && hi.is_finite()) {
                p.push(finite_centre(*b));
                continue;
            }
            p.push(lo + l * (hi - lo));
            dist += (l - 0.5) * (l - 0.5);
        }
        if best.as_ref().is_some_and(|(d, _)| *d <= dist) {
            continue;
        }
        if c.nonlinearity.contains(&p) {
            best = Some((dist, p));
        }
    }
    best.map(|(_, p)| p)
}

/// What the search shares between cells: the training records, their warm starts (the
/// centre's, as `validate`'s free run) and their spread.
pub(super) struct Search<'s> {
    pub(super) set: &'s ModelSet,
    pub(super) layout: &'s crate::model::Layout,
    pub(super) x_warm: Vec<Vec<f64>>,
    pub(super) spread: f64,
    pub(super) evaluations: AtomicUsize,
}

/// One cell's search space: a point of the cell (nonlinearity parameters, then bisected
/// ones) moved along the coordinates whose bound has a positive radius.
pub(super) struct CellSpace<'c> {
    pub(super) cell: &'c CellSet,
    pub(super) k: usize,
    pub(super) names: Vec<String>,
    pub(super) base: Vec<f64>,
    pub(super) radius: Vec<f64>,
    pub(super) moved: Vec<usize>,
    /// Nonlinearity parameters at the front of `base`.
    pub(super) ng: usize,
    pub(super) theta0: Vec<f64>,
}

impl CellSpace<'_> {
    pub(super) fn at(&self, from: &[f64], z: &[f64]) -> Vec<f64> {
        let mut g = from.to_vec();
        for (&i, zi) in self.moved.iter().zip(z) {
            g[i] = from[i] + self.radius[i] * zi;
        }
        g
    }

    /// The radius of `θ_i`'s bound over the cell, or a tenth of `|θ_i|` when unbounded.
    pub(super) fn theta_scale(&self, i: usize, th: &[f64]) -> f64 {
        let r = self.cell.theta[i].radius();
        if r.is_finite() && r > 0.0 {
            r
        } else {
            0.1 * (th[i].abs() + 1e-3)
        }
    }
}

impl<'s> Search<'s> {
    /// The free-run errors `y - y_sim` over the training records after each record's warm start
    /// (`None` when the point is no model).
    pub(super) fn residuals(&self, values: &[(String, f64)]) -> Option<Vec<f64>> {
        let m = point(self.set, values).ok()?;
        let o = self.layout.orders;
        let warm = o.na + o.nb + o.nk;
        let mut out = Vec::new();
        for (r, xd) in self.set.training.records.iter().zip(&self.x_warm) {
            let w0 = warm.min(r.y.len());
            let y = m.predict(&r.u, Some(xd), r.dt, usize::MAX, w0).y;
            out.extend(r.y[w0..].iter().zip(&y[w0..]).map(|(a, b)| a - b));
        }
        Some(out)
    }

    /// Squared free-run error over the training records (`+inf` when it diverges).
    pub(super) fn sse(&self, values: &[(String, f64)]) -> f64 {
        let e2: f64 = self
            .residuals(values)
            .map_or(f64::INFINITY, |r| r.iter().map(|e| e * e).sum());
        if e2.is_finite() {
            e2
        } else {
            f64::INFINITY
        }
    }

    pub(super) fn fit(&self, e2: f64) -> f64 {
        if self.spread > 0.0 {
            100.0 * (1.0 - (e2 / self.spread).sqrt())
        } else {
            f64::NAN
        }
    }

    pub(super) fn space(&self, k: usize) -> Result<Option<CellSpace<'s>>> {
        let c = &self.set.cells[k];
        let Some(gamma0) = nonlinearity_point(c) else {
            return Ok(None);
        };
        let params = c.nonlinearity.parameters();
        let mut base = gamma0.clone();
        base.extend(c.cell.iter().map(|i| i.center()));
        let radius: Vec<f64> = params
            .iter()
            .map(|b| b.interval)
            .chain(c.cell.iter().copied())
            .map(|b| {
                let r = b.radius();
                if r.is_finite() && r > 0.0 {
                    r
                } else {
                    0.0
                }
            })
            .collect();
        let theta0 = match least_squares_theta(self.set, k)? {
            Some(t) => t,
            None => c.theta.iter().map(|i| finite_centre(*i)).collect(),
        };
        Ok(Some(CellSpace {
            cell: c,
            k,
            names: params.iter().map(|b| b.name.clone()).collect(),
            moved: (0..radius.len()).filter(|&i| radius[i] > 0.0).collect(),
            base,
            radius,
            ng: gamma0.len(),
            theta0,
        }))
    }

    /// Stage 2 at a point `g` (nonlinearity, then bisected parameters) of the cell: `None`
    /// outside the cell's set, or when the training data reject that point.
    pub(super) fn signals_at(
        &self,
        sp: &CellSpace,
        g: &[f64],
    ) -> Option<crate::pipeline::StageSignals> {
        let (gamma, psi) = g.split_at(sp.ng);
        if !sp.cell.nonlinearity.contains(gamma)
            || !psi.iter().zip(&sp.cell.cell).all(|(v, b)| b.contains(*v))
        {
            return None;
        }
        let b: Vec<Interval> = gamma.iter().map(|&v| Interval::new(v, v)).collect();
        let pset = self.set.model.nonlinearity.set_from_box(&b).ok()?;
        let cell: Vec<Interval> = psi.iter().map(|&v| Interval::new(v, v)).collect();
        let records = &self.set.training.records;
        crate::pipeline::stage2(&self.set.model, self.layout, pset.as_ref(), &cell, records).ok()
    }

    pub(super) fn values_of(&self, sp: &CellSpace, g: &[f64], th: &[f64]) -> Vec<(String, f64)> {
        let mut v: Vec<(String, f64)> = sp.names.iter().cloned().zip(g.iter().copied()).collect();
        v.extend(
            self.layout
                .theta_names
                .iter()
                .cloned()
                .zip(th.iter().copied()),
        );
        v.extend(
            self.layout
                .dims
                .iter()
                .zip(&g[sp.ng..])
                .map(|(d, x)| (d.name.clone(), *x)),
        );
        v
    }

    /// The stage-3 problem of signals at a point of a cell.
    pub(super) fn problem<'p>(
        &self,
        sig: &'p crate::pipeline::StageSignals,
    ) -> crate::stage3::EivProblem<'p>
    where
        's: 'p,
    {
        crate::pipeline::eiv_problem(&self.set.model, self.layout, &self.set.method, sig, None)
    }

    /// The largest root modulus of the linear block's `A` at phase-1 coordinates `z` (the
    /// free `a`'s from `z`, the fixed ones as declared).
    pub(super) fn root_radius(&self, sp: &CellSpace, z: &[f64]) -> f64 {
        let split = sp.moved.len();
        let mut free = z[split..].iter();
        let a: Vec<f64> = (0..self.layout.orders.na)
            .map(|i| match self.layout.fixed[i] {
                Some(v) => v,
                None => {
                    let zi = free.next().copied().unwrap_or(0.0);
                    sp.theta0[i] + sp.theta_scale(i, &sp.theta0) * zi
                }
            })
            .collect();
        crate::linear::spectral_radius(&a)
    }

    /// Phase-1 coordinates of the point `(g, th)` of the cell: its moved coordinates in the
    /// cell's radii, then its free `a`'s in their scales around `theta0`.
    pub(super) fn coordinates(&self, sp: &CellSpace, g: &[f64], th: &[f64]) -> Vec<f64> {
        let mut z: Vec<f64> = sp
            .moved
            .iter()
            .map(|&i| (g[i] - sp.base[i]) / sp.radius[i])
            .collect();
        z.extend(
            self.a_free()
                .iter()
                .map(|&i| (th[i] - sp.theta0[i]) / sp.theta_scale(i, &sp.theta0)),
        );
        z
    }

    pub(super) fn a_free(&self) -> Vec<usize> {
        (0..self.layout.orders.na)
            .filter(|&i| self.layout.fixed[i].is_none())
            .collect()
    }

    /// The phase-1 measure at `z` (moved coordinates, then the free `a`'s scaled): the
    /// smallest consistency measure over the `b`'s and extra coefficients by the LP at fixed
    /// `a`, with the uncertain input samples (a block's unknown initial state) at the member's
    /// own run; and the `θ` attaining it.
    pub(super) fn measure_at_a(&self, sp: &CellSpace, z: &[f64]) -> (f64, Option<Vec<f64>>) {
        self.evaluations.fetch_add(1, Relaxed);
        let split = sp.moved.len();
        let g = sp.at(&sp.base, &z[..split]);
        let Some(sig) = self.signals_at(sp, &g) else {
            return (f64::INFINITY, None);
        };
        let input = realised_input(self.set, &self.values_of(sp, &g, &sp.theta0), &sig);
        let a: Vec<f64> = self
            .a_free()
            .iter()
            .zip(&z[split..])
            .map(|(&i, zi)| sp.theta0[i] + sp.theta_scale(i, &sp.theta0) * zi)
            .collect();
        let mut at = sp.theta0.clone();
        for (&i, v) in self.a_free().iter().zip(&a) {
            at[i] = *v;
        }
        let sig = self.decided(sig, &at);
        let mut prob = self.problem(&sig);
        prob.input = &input;
        best_at_a(&prob, &sp.cell.theta, &a).unwrap_or((f64::INFINITY, None))
    }

    /// The exact consistency measure at a whole point (the certificate).
    pub(super) fn certify(&self, sp: &CellSpace, g: &[f64], th: &[f64]) -> f64 {
        self.evaluations.fetch_add(1, Relaxed);
        let Some(sig) = self.signals_at(sp, g) else {
            return f64::INFINITY;
        };
        let sig = self.decided(sig, th);
        let prob = self.problem(&sig);
        consistency_at(&prob, th).unwrap_or(f64::INFINITY)
    }

    /// `sig` with the signs of samples of two-sided preimage taken from the free run at `th`
    /// ([`crate::pipeline::signs::decided_by_run`]): a certificate holds under that pattern.
    pub(super) fn decided(
        &self,
        sig: crate::pipeline::StageSignals,
        th: &[f64],
    ) -> crate::pipeline::StageSignals {
        if !sig
            .output
            .iter()
            .any(|b| b.kind == crate::inversion::InnerKind::Mirrored)
        {
            return sig;
        }
        let o = self.layout.orders;
        crate::pipeline::signs::decided_by_run(&sig, o.na, o.nb, th)
    }

    /// `θ` with the unit gain (eq 8) made exact through the last free `b`; that `b`'s index.
    pub(super) fn gain_slot(&self) -> Option<usize> {
        let o = self.layout.orders;
        self.set
            .model
            .unit_gain
            .then(|| {
                (o.na..=o.na + o.nb)
                    .rev()
                    .find(|&i| self.layout.fixed[i].is_none())
            })
            .flatten()
    }

    pub(super) fn fix_gain(&self, th: &mut [f64]) {
        let o = self.layout.orders;
        if let Some(g) = self.gain_slot() {
            let sign = |i: usize| if i < o.na { -1.0 } else { 1.0 };
            let others: f64 = (0..o.na + o.nb + 1)
                .filter(|&i| i != g)
                .map(|i| sign(i) * th[i])
                .sum();
            th[g] = 1.0 - others;
        }
    }
}

/// A member's values back as the cell's point (nonlinearity, then bisected) and `θ`.
pub(super) fn split_values(
    search: &Search,
    sp: &CellSpace,
    values: &[(String, f64)],
) -> (Vec<f64>, Vec<f64>) {
    // The nonlinearity's names come first in a member's values and the bisected ones last
    // ([`Search::values_of`]); a bisected parameter may share its name with one of the
    // nonlinearity's (an input backlash bisected in a Hammerstein chain).
    let get = |n: &str| values.iter().find(|(k, _)| k == n).map(|v| v.1);
    let get_last = |n: &str| values.iter().rfind(|(k, _)| k == n).map(|v| v.1);
    let mut g: Vec<f64> = sp
        .names
        .iter()
        .zip(&sp.base)
        .map(|(n, b)| get(n).unwrap_or(*b))
        .collect();
    g.extend(
        search
            .layout
            .dims
            .iter()
            .zip(&sp.base[sp.ng..])
            .map(|(d, b)| get_last(&d.name).unwrap_or(*b)),
    );
    let th = search
        .layout
        .theta_names
        .iter()
        .zip(&sp.theta0)
        .map(|(n, t)| get(n).unwrap_or(*t))
        .collect();
    (g, th)
}

/// The linear block's input as the member with `values` produces it from its blocks' initial
/// state, clamped into the stage-2 intervals (one admissible realisation of an uncertain
/// input: a block's unknown initial state); exact samples and gaps as they are.
fn realised_input(
    set: &ModelSet,
    values: &[(String, f64)],
    sig: &crate::pipeline::StageSignals,
) -> Vec<Interval> {
    let mut out = sig.input.clone();
    if out
        .iter()
        .all(|i| !i.is_finite() || i.radius() <= 1e-9 * (1.0 + i.center().abs()))
    {
        return out;
    }
    let Ok(m) = point(set, values) else {
        return out;
    };
    for (r, rec) in set.training.records.iter().enumerate() {
        let mut v = rec.u.clone();
        for b in &m.input {
            v = b.simulate(&v);
        }
        if m.structure == crate::nonlinearity::Structure::Hammerstein {
            v = m.nonlinearity.simulate(&v);
        }
        let s0 = sig.starts.get(r).copied().unwrap_or(0);
        for t in 0..v.len() {
            let Some(iv) = out.get_mut(s0 + t + m.nk) else {
                break;
            };
            if iv.is_finite() && iv.radius() > 0.0 && v[t].is_finite() {
                let x = v[t].clamp(iv.lo, iv.hi);
                *iv = Interval::new(x, x);
            }
        }
    }
    out
}
