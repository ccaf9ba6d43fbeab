//! The shared-error LP model of stage 3 (paper Section 5, eqs 1, 28-30), common to the
//! `shared`, `exact-grid` and `sdp` methods: the variable layout, the equation rows with the
//! bilinear products `w = θ_k δ_s` relaxed by McCormick envelopes over the current boxes, the
//! interval propagation that shrinks the `δ` boxes, and the box-tightening step.
//!
//! Variables: the free θ, one `δ_s` per uncertain signal sample (`|δ_s| <= Δ_s`; output side
//! `x_s = x^c_s + δx_s`, for Hammerstein the input side `v_s = v^c_s + δv_s`, and each uncertain
//! extra regressor sample `φ_k(s) = φ^c_k(s) + δφ_k(s)`), and one `w = θ_k δ_s` per product. Each
//! equation `x_t + Σ a_i x_{t-i} - Σ b_j v_{t-j} - Σ c_k φ_k(t) = 0` (eq 1 with eq 29
//! substituted) is linear in `(θ, δ, w)`; exact samples (a Wiener input, exact extra columns)
//! are plain coefficients. The McCormick envelopes over a box of `θ_k` and of `δ_s` contain
//! every product of the box, so the LP's feasible set contains every `(θ, δ)` consistent with
//! the data and its coordinate bounds are guaranteed.
use super::ipm::{BlockLp, Bound, Prepared, Solved, Warm};
use super::EivProblem;
use crate::error::{Result, SmidError};
use crate::interval::Interval;
use crate::lp::{RESULT_PAD, ROW_PAD};
use crate::sparse_lp::{merge, LpSolver, Optimum, SparseLp};
use std::collections::HashMap;

/// Which signal a sample belongs to.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Side {
    /// The inner signal entering `A` (`x_t`).
    Out,
    /// The signal entering `B` (`v_t`; `u_t` itself for Wiener).
    In,
    /// Extra regressor `k` (`φ_k(t)`, entering with coefficient `c_k`).
    Extra(usize),
}

/// One uncertain signal sample.
#[derive(Debug, Clone, Copy)]
pub struct Sig {
    /// The centre of the sample's interval.
    pub center: f64,
    /// The radius of the sample's interval: its `δ` is bounded by it (`|δ_s| <= Δ_s`).
    pub radius: f64,
    /// Which sample it is.
    pub key: (Side, usize),
}

/// The shared-error LP model of an [`EivProblem`]: variable layout and row builder.
pub struct SharedModel<'p, 'a> {
    /// The problem modelled.
    pub prob: &'p EivProblem<'a>,
    /// Time indices `t` of the equations modelled.
    pub times: Vec<usize>,
    /// Free θ indices, in column order.
    pub free: Vec<usize>,
    /// Column of each θ index (None when fixed).
    pub col_theta: Vec<Option<usize>>,
    /// The uncertain signal samples, one `δ` column each, in column order.
    pub deltas: Vec<Sig>,
    /// The `δ` column of each uncertain sample, by its side and sample.
    pub delta_of: HashMap<(Side, usize), usize>,
    /// Products `(θ index, δ index)`.
    pub products: Vec<(usize, usize)>,
    /// The column of each product `(θ index, δ index)`.
    pub product_of: HashMap<(usize, usize), usize>,
}

/// One term `sign · coef · signal` of an equation; `coef` is `None` for the leading `x_t`.
pub type Term = (Option<usize>, f64, Side, usize);

impl<'p, 'a> SharedModel<'p, 'a> {
    /// The interval of sample `s` of the signal `side`.
    pub fn signal(&self, side: Side, s: usize) -> Interval {
        match side {
            Side::Out => self.prob.output[s].interval,
            Side::In => self.prob.input[s],
            Side::Extra(k) => self.prob.extra[k].values[s],
        }
    }

    /// The terms of equation `t`: `x_t`, `a_i x_{t-i}`, `-b_j v_{t-j}`, `-c_k φ_k(t)` (an
    /// iterator: the passes over long records call it once per equation).
    pub fn terms(&self, t: usize) -> impl Iterator<Item = Term> + '_ {
        let p = self.prob;
        std::iter::once((None, 1.0, Side::Out, t))
            .chain((1..=p.na).map(move |i| (Some(i - 1), 1.0, Side::Out, t - i)))
            .chain((0..=p.nb).map(move |j| (Some(p.na + j), -1.0, Side::In, t - j)))
            .chain((0..p.extra.len()).map(move |k| (Some(p.n_ab() + k), -1.0, Side::Extra(k), t)))
    }

    /// The model of `prob` over the equations at `times`: one column per free θ, per
    /// uncertain sample those equations read (`δ`) and per product `θ_k δ_s` they contain.
    pub fn new(prob: &'p EivProblem<'a>, times: Vec<usize>) -> Self {
        let p = prob.p();
        let free: Vec<usize> = (0..p).filter(|&k| prob.fixed[k].is_none()).collect();
        let mut col_theta = vec![None; p];
        for (c, &k) in free.iter().enumerate() {
            col_theta[k] = Some(c);
        }
        let mut m = SharedModel {
            prob,
            times,
            free,
            col_theta,
            deltas: Vec::new(),
            delta_of: HashMap::new(),
            products: Vec::new(),
            product_of: HashMap::new(),
        };
        let times = m.times.clone();
        for &t in &times {
            let terms: Vec<Term> = m.terms(t).collect();
            for (k, _, side, s) in terms {
                let iv = m.signal(side, s);
                if iv.radius() <= 0.0 {
                    continue;
                }
                let d = match m.delta_of.get(&(side, s)) {
                    Some(&d) => d,
                    None => {
                        m.deltas.push(Sig {
                            center: iv.center(),
                            radius: iv.radius(),
                            key: (side, s),
                        });
                        m.delta_of.insert((side, s), m.deltas.len() - 1);
                        m.deltas.len() - 1
                    }
                };
                if let Some(k) = k {
                    if prob.fixed[k].is_none() && !m.product_of.contains_key(&(k, d)) {
                        m.products.push((k, d));
                        m.product_of.insert((k, d), m.products.len() - 1);
                    }
                }
            }
        }
        m
    }

    /// The number of LP columns: free θ, then `δ`'s, then products.
    pub fn n_cols(&self) -> usize {
        self.free.len() + self.deltas.len() + self.products.len()
    }
    /// The LP column of `δ` number `d` (an index into [`Self::deltas`]).
    pub fn col_delta(&self, d: usize) -> usize {
        self.free.len() + d
    }
    /// The LP column of product number `w` (an index into [`Self::products`]).
    pub fn col_product(&self, w: usize) -> usize {
        self.free.len() + self.deltas.len() + w
    }

    /// The initial `δ` boxes `[-Δ_s, Δ_s]`.
    pub fn initial_deltas(&self) -> Vec<Interval> {
        self.deltas
            .iter()
            .map(|d| Interval::new(-d.radius, d.radius))
            .collect()
    }

    /// The LP over the θ box `tb` (indexed by θ; only free entries are read) and `δ` boxes `db`,
    /// with the equations of `times`.
    pub fn build(&self, tb: &[Interval], db: &[Interval], times: &[usize]) -> Result<SparseLp> {
        let mut lp = SparseLp::new(self.n_cols());
        for &k in &self.free {
            let b = tb[k];
            if b.lo.is_finite() {
                lp.le(vec![(self.col_theta[k].unwrap_or(0), -1.0)], -b.lo);
            }
            if b.hi.is_finite() {
                lp.le(vec![(self.col_theta[k].unwrap_or(0), 1.0)], b.hi);
            }
        }
        for (d, b) in db.iter().enumerate() {
            lp.bound(self.col_delta(d), b.lo, b.hi);
        }
        for (w, &(k, d)) in self.products.iter().enumerate() {
            let cols = (
                self.col_theta[k].unwrap_or(0),
                self.col_delta(d),
                self.col_product(w),
            );
            for (row, rhs) in self.mccormick(k, tb[k], db[d], cols)? {
                lp.le(row, rhs);
            }
        }
        for &t in times {
            let (row, c0) = self.equation(t);
            // c0 + row·z = 0, as two padded inequalities.
            let neg: Vec<(usize, f64)> = row.iter().map(|&(c, v)| (c, -v)).collect();
            lp.le(row, -c0);
            lp.le(neg, c0);
        }
        if let Some((row, rhs)) = self.gain_row() {
            lp.eq(row, rhs);
        }
        Ok(lp)
    }

    /// Tighten the `δ` boxes by interval propagation: each equation gives
    /// `x_t = -Σ a_i x_{t-i} + Σ b_j v_{t-j} + Σ c_k φ_k(t)` over the current boxes. Returns the first sample
    /// whose box became empty.
    pub fn propagate(&self, tb: &[Interval], db: &mut [Interval]) -> Option<usize> {
        for &t in &self.times {
            let Some(&dt) = self.delta_of.get(&(Side::Out, t)) else {
                continue;
            };
            let (mut lo, mut hi) = (0.0, 0.0);
            for (k, sign, side, s) in self.terms(t).skip(1) {
                let iv = self.signal(side, s);
                let sig = match self.delta_of.get(&(side, s)) {
                    Some(&d) => Interval::new(iv.center() + db[d].lo, iv.center() + db[d].hi),
                    None => Interval::new(iv.center(), iv.center()),
                };
                let c = match k.and_then(|k| self.prob.fixed[k]) {
                    Some(v) => Interval::new(v, v),
                    None => tb[k.unwrap_or(0)],
                };
                let prods = [c.lo * sig.lo, c.lo * sig.hi, c.hi * sig.lo, c.hi * sig.hi];
                let pl = prods.iter().cloned().fold(f64::INFINITY, f64::min);
                let ph = prods.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
                // x_t = -(sign · c · sig) summed.
                if sign > 0.0 {
                    lo -= ph;
                    hi -= pl;
                } else {
                    lo += pl;
                    hi += ph;
                }
            }
            if !(lo.is_finite() && hi.is_finite()) {
                continue;
            }
            let c = self.deltas[dt].center;
            let bound = Interval::new(lo - c, hi - c).widen(1e-12, 1e-13);
            match db[dt].intersect(&bound) {
                Some(b) => db[dt] = b,
                None => return Some(t),
            }
        }
        None
    }
}

/// `a·b` over boxes, widened outward by a rounding pad.
pub fn mul(a: Interval, b: Interval) -> Interval {
    let p = [a.lo * b.lo, a.lo * b.hi, a.hi * b.lo, a.hi * b.hi];
    let lo = p.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = p.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    Interval::new(lo, hi).widen(1e-15, 1e-300)
}

impl SharedModel<'_, '_> {
    /// The LP of [`SharedModel::build`] in block form for the interior-point method
    /// ([`super::ipm`]): θ columns first (as in `build`), then one block per `δ` holding `δ`
    /// and its products; the `δ` and θ boxes are variable boxes instead of rows. Returns the
    /// LP and the global index of each model column.
    pub fn block_lp(
        &self,
        tb: &[Interval],
        db: &[Interval],
        times: &[usize],
    ) -> Result<(BlockLp, Vec<usize>)> {
        let nt = self.free.len();
        let mut of_delta: Vec<Vec<usize>> = vec![Vec::new(); self.deltas.len()];
        for (w, &(_, d)) in self.products.iter().enumerate() {
            of_delta[d].push(w);
        }
        let mut glob = vec![0usize; self.n_cols()];
        let mut boxes = Vec::with_capacity(self.n_cols());
        for (c, &k) in self.free.iter().enumerate() {
            glob[c] = c;
            boxes.push(tb[k]);
        }
        let mut lp = BlockLp {
            nt,
            ..Default::default()
        };
        for (d, ws) in of_delta.iter().enumerate() {
            let start = boxes.len();
            glob[self.col_delta(d)] = start;
            boxes.push(db[d]);
            for &w in ws {
                glob[self.col_product(w)] = boxes.len();
                let k = self.products[w].0;
                boxes.push(mul(tb[k], db[d]));
            }
            lp.blocks.push((start, boxes.len()));
            let r0 = lp.ineq.len();
            for &w in ws {
                let k = self.products[w].0;
                let cols = (
                    self.col_theta[k].unwrap_or(0),
                    glob[self.col_delta(d)],
                    glob[self.col_product(w)],
                );
                for (row, rhs) in self.mccormick(k, tb[k], db[d], cols)? {
                    lp.ineq.push((merge(row), rhs));
                }
            }
            lp.ineq_of.push((r0, lp.ineq.len()));
        }
        for &t in times {
            let (row, c0) = self.equation(t);
            let row: Vec<(usize, f64)> = row.into_iter().map(|(c, v)| (glob[c], v)).collect();
            // c0 + row·z = 0, allowed the pad of the two inequalities it stands for.
            lp.eq.push((merge(row), -c0, ROW_PAD * (1.0 + c0.abs())));
        }
        if let Some((row, rhs)) = self.gain_row() {
            lp.theta_eq
                .push((merge(row), rhs, 4.0 * f64::EPSILON * (1.0 + rhs.abs())));
        }
        lp.boxes = boxes;
        Ok((lp, glob))
    }

    /// Equation `t` as `c0 + row·z = 0` over the model's columns.
    pub fn equation(&self, t: usize) -> (Vec<(usize, f64)>, f64) {
        let mut row: Vec<(usize, f64)> = Vec::new();
        let mut c0 = 0.0;
        for (k, sign, side, s) in self.terms(t) {
            let iv = self.signal(side, s);
            let d = self.delta_of.get(&(side, s)).copied();
            match k.map(|k| (k, self.prob.fixed[k])) {
                None => {
                    c0 += iv.center();
                    if let Some(d) = d {
                        row.push((self.col_delta(d), 1.0));
                    }
                }
                Some((_, Some(v))) => {
                    c0 += sign * v * iv.center();
                    if let Some(d) = d {
                        row.push((self.col_delta(d), sign * v));
                    }
                }
                Some((k, None)) => {
                    row.push((self.col_theta[k].unwrap_or(0), sign * iv.center()));
                    if let Some(d) = d {
                        let w = self.product_of[&(k, d)];
                        row.push((self.col_product(w), sign));
                    }
                }
            }
        }
        (row, c0)
    }

    /// The four McCormick inequalities `row · z <= rhs` of the product `w = θ_k δ` over
    /// `θ_k ∈ t`, `δ ∈ d` (eqs 28-30), on the columns `(θ_k, δ, w)`: the one place they are
    /// written, for the sparse and the block-form LP alike. A θ box that is not finite is
    /// `Unbounded` (the relaxation needs a bounded start).
    fn mccormick(
        &self,
        k: usize,
        t: Interval,
        d: Interval,
        (ct, cd, cw): (usize, usize, usize),
    ) -> Result<[(Vec<(usize, f64)>, f64); 4]> {
        let (l, u) = (t.lo, t.hi);
        let (dl, du) = (d.lo, d.hi);
        if !(l.is_finite() && u.is_finite()) {
            return Err(SmidError::Unbounded {
                parameter: self.prob.name(k),
                message: "the shared-error relaxation needs a bounded start box".into(),
            });
        }
        Ok([
            (vec![(cd, l), (ct, dl), (cw, -1.0)], l * dl),
            (vec![(cd, u), (ct, du), (cw, -1.0)], u * du),
            (vec![(cw, 1.0), (cd, -u), (ct, -dl)], -u * dl),
            (vec![(cw, 1.0), (cd, -l), (ct, -du)], -l * du),
        ])
    }

    /// The unit gain `Σ b_j - Σ a_i = 1` (eq 8) over the free columns, when imposed (fixed
    /// entries moved to the right-hand side; the extras do not enter): one row for both LPs.
    fn gain_row(&self) -> Option<(Vec<(usize, f64)>, f64)> {
        if !self.prob.unit_gain {
            return None;
        }
        let mut row = Vec::new();
        let mut rhs = 1.0;
        for k in 0..self.prob.n_ab() {
            let s = self.prob.gain_sign(k);
            match self.prob.fixed[k] {
                Some(v) => rhs -= s * v,
                None => row.push((self.col_theta[k].unwrap_or(0), s)),
            }
        }
        Some((row, rhs))
    }
}

/// Per free θ: its guaranteed lower and upper bound (`None` where no finite bound came out).
pub type FreeBounds = Vec<(Option<f64>, Option<f64>)>;

/// The ends `[lo_0, hi_0, lo_1, hi_1, ..]` of the free θ as their intervals.
pub fn pair_ends(ends: &[Option<f64>]) -> FreeBounds {
    ends.chunks(2)
        .map(|e| (e[0], e.get(1).copied().flatten()))
        .collect()
}

/// Bound every free θ of the LP over boxes `tb`, `db` and the equations `times`, by the
/// structured interior-point method ([`super::ipm`]), the objectives in parallel. `None`
/// when the warm start or a bound proves the LP empty; `(None, _)` entries where no finite bound came out. When
/// the block form does not apply (a box not finite, an equation without an uncertain sample),
/// the sparse clarabel path answers.
pub fn bound_free(
    model: &SharedModel,
    tb: &[Interval],
    db: &[Interval],
    times: &[usize],
) -> Result<Option<FreeBounds>> {
    let all: Vec<usize> = (0..2 * model.free.len()).collect();
    match solve_ends(model, tb, db, times, &all)? {
        Ends::Found(ends) => {
            let v: Vec<Option<f64>> = ends.into_iter().map(|e| e.value).collect();
            Ok(Some(pair_ends(&v)))
        }
        Ends::Empty => Ok(None),
        Ends::Sparse => {
            let lp = model.build(tb, db, times)?;
            bound_all(model, &mut lp.solver()?)
        }
    }
}

/// One end as [`solve_ends`] found it.
pub struct End {
    /// The guaranteed bound (padded outward; `None` when not finite).
    pub value: Option<f64>,
    /// The last primal iterate over the model's columns (original units).
    pub point: Vec<f64>,
    /// How much the bound leans on each equation of `times` (same order; see
    /// [`super::ipm::Solved::eq_weight`]).
    pub weight: Vec<f64>,
}

/// What [`solve_ends`] found.
pub enum Ends {
    /// Per requested end, in order.
    Found(Vec<End>),
    /// The LP is proven empty (by the round's warm start, or by one end's bound).
    Empty,
    /// The block form does not apply; nothing was solved.
    Sparse,
}

/// The ends `ends` of the free θ (`2c`: lower end of free θ `c`, `2c + 1`: upper end) over the
/// equations `times`, by the structured interior-point method, in parallel from one warm start.
/// A warm start that proves the LP empty answers at once (even with no end asked for), and once
/// an end proves it, the ends not yet started are not run.
pub fn solve_ends(
    model: &SharedModel,
    tb: &[Interval],
    db: &[Interval],
    times: &[usize],
    ends: &[usize],
) -> Result<Ends> {
    use rayon::prelude::*;
    let (blp, glob) = model.block_lp(tb, db, times)?;
    let Some(prep) = Prepared::new(&blp) else {
        return Ok(Ends::Sparse);
    };
    let warm = prep.warm_start();
    if let Warm::Empty(steps) = warm {
        log::debug!(target: "smid::stage3", "shared: the round's LP proven empty by its warm start ({steps} Newton steps)");
        return Ok(Ends::Empty);
    }
    // One end proven empty answers the round: the ends not yet started are not run.
    let found: Option<Vec<(Option<f64>, Solved)>> = ends
        .par_iter()
        .map(|&i| {
            let (c, max) = (i / 2, i % 2 == 1);
            let solved = prep.minimise_at(&[(c, if max { -1.0 } else { 1.0 })], warm.start());
            match solved.bound {
                Bound::Infeasible => None,
                Bound::Value(v) => Some((v, solved)),
            }
        })
        .collect();
    let Some(found) = found else {
        return Ok(Ends::Empty);
    };
    log::trace!(
        target: "smid::stage3",
        "shared: {} ends in {} Newton steps",
        found.len(),
        found.iter().map(|(_, s)| s.iterations).sum::<usize>()
    );
    let mut out = Vec::with_capacity(ends.len());
    for (&i, (v, solved)) in ends.iter().zip(found) {
        let max = i % 2 == 1;
        let value = v.map(|v| {
            let pad = RESULT_PAD * (1.0 + v.abs());
            if max {
                -v + pad
            } else {
                v - pad
            }
        });
        out.push(End {
            value,
            point: glob.iter().map(|&g| solved.point[g]).collect(),
            weight: solved.eq_weight,
        });
    }
    Ok(Ends::Found(out))
}

/// Whether the LP over `times` is non-empty: `false` is proven; `true` when not proven empty.
pub fn feasible_free(
    model: &SharedModel,
    tb: &[Interval],
    db: &[Interval],
    times: &[usize],
) -> Result<bool> {
    let (blp, _) = model.block_lp(tb, db, times)?;
    match Prepared::new(&blp) {
        Some(prep) if !model.free.is_empty() => Ok(prep.minimise(&[(0, 1.0)]) != Bound::Infeasible),
        _ => Ok(model
            .build(tb, db, times)?
            .solver()?
            .feasible()?
            .unwrap_or(true)),
    }
}

/// Bound every free θ over one LP; `None` entries where the solver gave no conclusion.
pub fn bound_all(model: &SharedModel, solver: &mut LpSolver) -> Result<Option<FreeBounds>> {
    let mut out = Vec::with_capacity(model.free.len());
    for c in 0..model.free.len() {
        let lo = match solver.minimise(c)? {
            Optimum::Value(v) => Some(v),
            Optimum::Infeasible => return Ok(None),
            Optimum::Unknown => None,
        };
        let hi = match solver.maximise(c)? {
            Optimum::Value(v) => Some(v),
            Optimum::Infeasible => return Ok(None),
            Optimum::Unknown => None,
        };
        out.push((lo, hi));
    }
    Ok(Some(out))
}

/// Intersect `old` with new guaranteed bounds (`None`: no conclusion, keep the old end).
/// Returns the new interval and the fraction its radius shrank, or `None` when the bounds do
/// not meet (no θ is consistent).
pub fn tighten(old: Interval, lo: Option<f64>, hi: Option<f64>) -> Option<(Interval, f64)> {
    let new = Interval::new(
        lo.map_or(old.lo, |v| v.max(old.lo)),
        hi.map_or(old.hi, |v| v.min(old.hi)),
    );
    if new.lo > new.hi {
        return None;
    }
    let gain = if old.radius() > 0.0 {
        1.0 - new.radius() / old.radius()
    } else {
        0.0
    };
    Some((new, gain))
}

/// What one round of a relaxation found at the current boxes.
pub enum Round {
    /// Guaranteed ends of the free θ (in `model.free` order), and whether they are the whole
    /// relaxation's (a working set's bounds alone, guaranteed but perhaps looser, do not end
    /// the rounds).
    Bounds(FreeBounds, bool),
    /// The relaxation admits no point at the current boxes.
    Empty,
}

/// When the rounds of [`shrink_rounds`] stop, and the method they are logged under.
#[derive(Debug, Clone, Copy)]
pub struct RoundLimits {
    /// At most this many rounds (at least one runs).
    pub max_rounds: usize,
    /// Settled: no radius shrank by this fraction in a conclusive round.
    pub min_improvement: f64,
    /// The method's name, for the log.
    pub method: &'static str,
}

/// The box-shrinking rounds of a relaxation (`shared`, `sdp`): propagate the `δ` boxes twice
/// (a sample they empty is a finding at `t`, [`SmidError::inconsistent`]), take the round's
/// guaranteed ends of the free θ, intersect (ends that do not meet, or an empty round, are the
/// finding `emptied` makes), until no radius shrinks by `limits.min_improvement` in a conclusive round
/// or `limits.max_rounds` are spent. Returns the last round's largest shrinkage when the rounds
/// stopped at the cap before they settled (`EivResult::unsettled`), `None` when they settled.
/// A round must give one pair of ends per free θ, in `model.free`'s order.
pub fn shrink_rounds(
    model: &SharedModel,
    tb: &mut [Interval],
    limits: RoundLimits,
    mut round: impl FnMut(&[Interval], &[Interval]) -> Result<Round>,
    emptied: impl Fn(&[Interval], &[Interval]) -> Result<SmidError>,
    inconsistent: impl Fn(usize) -> SmidError,
) -> Result<Option<f64>> {
    let RoundLimits {
        max_rounds,
        min_improvement,
        method,
    } = limits;
    let mut db = model.initial_deltas();
    let mut unsettled = None;
    for r in 0..max_rounds.max(1) {
        for _ in 0..2 {
            if let Some(t) = model.propagate(tb, &mut db) {
                return Err(inconsistent(t));
            }
        }
        let (found, conclusive) = match round(tb, &db)? {
            Round::Bounds(found, conclusive) => (found, conclusive),
            Round::Empty => return Err(emptied(tb, &db)?),
        };
        if found.len() != model.free.len() {
            return Err(SmidError::Solver(format!(
                "{method}: a round gave {} pairs of ends for {} free parameters",
                found.len(),
                model.free.len()
            )));
        }
        let mut new = Vec::with_capacity(found.len());
        let mut gain: f64 = 0.0;
        for (&k, &(lo, hi)) in model.free.iter().zip(&found) {
            // Two guaranteed bounds that do not meet: no θ is consistent.
            let Some((b, g)) = tighten(tb[k], lo, hi) else {
                return Err(emptied(tb, &db)?);
            };
            gain = gain.max(g);
            new.push((k, b));
        }
        for (k, b) in new {
            tb[k] = b;
        }
        log::debug!(
            target: "smid::stage3",
            "{method}: round {r}: radii shrank by up to {gain:.4}, conclusive: {conclusive}"
        );
        if gain < min_improvement && conclusive {
            return Ok(None);
        }
        unsettled = Some(gain);
    }
    Ok(unsettled)
}
