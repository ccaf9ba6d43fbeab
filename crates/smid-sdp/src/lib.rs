//! Stage 3 (paper Section 5) by a moment (SDP) relaxation of the shared-error EIV problem
//! (eqs 1, 28-30), behind this crate's cargo feature `openblas` (the facade's `sdp`:
//! Clarabel's PSD cone over the system OpenBLAS). A stage-3 method in a crate of its own: it
//! registers itself (`method.eiv: sdp`) and builds on the core's public services
//! (`smid_core::stage3::relax`, `smid_core::sparse_lp`).
//!
//! The variables of the shared-error relaxation (`smid_core::stage3::relax`: the free θ, the
//! inner-signal errors `δ_s`, the products `w = θ_k δ_s`) get the second moments they lack
//! (`θ_k θ_l`, `δ_s δ_r`, missing `θ_k δ_s`), and for every equation `t` the moment matrix of
//! `(1, θ_k, δ_s)` over the coefficients and samples of that equation (a sparse clique of
//! consecutive samples) is constrained positive semidefinite (order-1 moment relaxation), on top
//! of the McCormick envelopes of every moment and the equations themselves. Extra regressor
//! columns enter like the input side: an uncertain sample `φ_k(t)` is a `δ` of the clique of
//! equation `t` with its coefficient `c_k`; exact columns are plain coefficients, as a Wiener
//! input is. The prior box enters through the start (the `shared` result lies inside it).
//! Every `(θ, δ)`
//! consistent with the data, with its rank-one moments, satisfies all of this, so the relaxation
//! contains the exact set.
//!
//! **Guarantee independent of the solver's accuracy.** A bound is not read from the solver's
//! objective. From the solver's dual vector, projected onto the dual cone (non-negative part for
//! inequalities, eigenvalues clipped at zero for each PSD block), weak duality gives a bound
//! valid for *any* such dual point: `c·x >= -b·z + Σ_j min(r_j l_j, r_j u_j)` with
//! `r = c + Aᵀz` and `[l_j, u_j]` a guaranteed box of every variable (θ and `δ` boxes, moment
//! boxes by interval arithmetic). An inaccurate solve gives a looser bound, never a wrong one.
//! The result is intersected with the shared-error result it starts from, so it is never wider.
//! Without the feature, selecting `method.eiv: sdp` is an error naming it.
#![forbid(unsafe_code)]
#![warn(missing_docs)]
use smid_core::error::{Result, SmidError};
use smid_core::stage3::{EivMethod, EivProblem, EivResult, Stage3Method};

/// The method's name (`method.eiv: sdp`).
pub const NAME: &str = "sdp";

/// Options of the moment relaxation (`method.options` in a spec).
#[derive(Debug, Clone, Copy, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SdpOptions {
    /// Maximum number of SDP rounds (each bounds every free parameter, then the boxes shrink).
    pub max_rounds: usize,
    /// Stop when no radius shrinks by more than this fraction in a round.
    pub min_improvement: f64,
}

impl SdpOptions {
    /// The defaults: 3 rounds, stop below 1% improvement.
    pub const DEFAULT: SdpOptions = SdpOptions {
        max_rounds: 3,
        min_improvement: 0.01,
    };
}

impl Default for SdpOptions {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// Whether this build has the moment relaxation (this crate's feature `openblas`, the
/// facade's `sdp`).
pub const AVAILABLE: bool = cfg!(feature = "openblas");

/// The moment relaxation (`method.eiv: sdp`), starting from `shared`.
#[derive(Debug, Clone, Copy, Default)]
pub struct Sdp {
    /// Relaxation options (`method.options` of the spec).
    pub opts: SdpOptions,
}

smid_core::register_stage3!(
    20,
    Sdp {
        opts: SdpOptions::DEFAULT
    }
);

impl Stage3Method for Sdp {
    fn name(&self) -> &'static str {
        NAME
    }
    fn description(&self) -> &'static str {
        "Moment (SDP) relaxation on each equation's clique of consecutive samples, bounds by weak duality; needs the cargo feature `sdp`. Never wider than `shared`. Options: max_rounds, min_improvement."
    }
    fn with_options(
        &self,
        options: &serde_json::Map<String, serde_json::Value>,
    ) -> Result<Option<Box<dyn Stage3Method>>> {
        smid_core::stage3::with_parsed_options(NAME, options, |opts: SdpOptions| {
            Box::new(Sdp { opts })
        })
    }
    fn available(&self) -> bool {
        AVAILABLE
    }
    fn start(&self) -> Option<EivMethod> {
        Some(EivMethod::Shared)
    }
    /// Without the feature `sdp`: an error naming it (before any start is computed).
    fn check(&self, _prob: &EivProblem) -> Result<()> {
        if AVAILABLE {
            Ok(())
        } else {
            Err(unsupported())
        }
    }
    fn solve_from(&self, prob: &EivProblem, start: EivResult) -> Result<EivResult> {
        solve_from(prob, start, &self.opts)
    }
}

/// The moment relaxation of `prob`, starting from the shared-error result (through the
/// registry).
pub fn solve(prob: &EivProblem) -> Result<EivResult> {
    solve_with(prob, &SdpOptions::default())
}

/// As [`solve`], with options.
pub fn solve_with(prob: &EivProblem, opts: &SdpOptions) -> Result<EivResult> {
    Sdp { opts: *opts }.solve(prob)
}

/// The moment relaxation from a guaranteed result `start` (the shared-error one).
#[cfg(feature = "openblas")]
pub use imp::solve_from;

/// The moment relaxation from `start` (this build has no `sdp` feature: an error naming it).
#[cfg(not(feature = "openblas"))]
pub fn solve_from(_prob: &EivProblem, _start: EivResult, _opts: &SdpOptions) -> Result<EivResult> {
    Err(unsupported())
}

/// Selecting the method in a build without the feature `sdp`.
fn unsupported() -> SmidError {
    SmidError::Unsupported {
        plugin: "smid-sdp".into(),
        what: "`method.eiv: sdp` in this build: the moment relaxation needs the cargo feature `sdp` (build with `--features sdp`; it needs apt libopenblas-dev libgfortran-12-dev); or choose `shared` (within a few percent of the exact set on the paper's example) or `exact-grid`".into(),
    }
}

#[cfg(feature = "openblas")]
mod imp {
    use super::*;
    use clarabel::solver::{DefaultSolver, IPSolver, SupportedConeT};
    use smid_core::error::Stage;
    use smid_core::interval::Interval;
    use smid_core::lp::RESULT_PAD;
    use smid_core::sparse_lp::{conic_solver, csc, merge, padded_rows, PaddedRows};
    use smid_core::stage3::relax::{shrink_rounds, Round, RoundLimits, SharedModel};
    use std::collections::HashMap;

    /// `a·b` over boxes, widened outward by a rounding pad.
    fn mul(a: Interval, b: Interval) -> Interval {
        let p = [a.lo * b.lo, a.lo * b.hi, a.hi * b.lo, a.hi * b.hi];
        let lo = p.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = p.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        Interval::new(lo, hi).widen(1e-15, 1e-300)
    }

    /// One entry of a moment matrix.
    #[derive(Clone, Copy)]
    enum Entry {
        One,
        Var(usize),
    }

    /// A conic program `min q·x`, rows `A x + s = b`, `s` in (non-negative, zero, PSD blocks),
    /// with a guaranteed box for every variable.
    pub(super) struct Conic {
        n: usize,
        le: Vec<(Vec<(usize, f64)>, f64)>,
        eq: Vec<(Vec<(usize, f64)>, f64)>,
        psd: Vec<Vec<Vec<Entry>>>,
        boxes: Vec<Interval>,
    }

    /// A key of a second-moment variable.
    #[derive(Clone, Copy, PartialEq, Eq, Hash)]
    enum Moment {
        ThetaDelta(usize, usize),
        ThetaTheta(usize, usize),
        DeltaDelta(usize, usize),
    }

    impl Conic {
        /// The moment relaxation over the θ box `tb` and `δ` boxes `db`.
        fn build(model: &SharedModel, tb: &[Interval], db: &[Interval]) -> Result<Conic> {
            let lp = model.build(tb, db, &model.times)?;
            let mut boxes = vec![Interval::new(0.0, 0.0); model.n_cols()];
            for &k in &model.free {
                boxes[model.col_theta[k].unwrap_or(0)] = tb[k];
            }
            for (d, b) in db.iter().enumerate() {
                boxes[model.col_delta(d)] = *b;
            }
            for (w, &(k, d)) in model.products.iter().enumerate() {
                boxes[model.col_product(w)] = mul(tb[k], db[d]);
            }
            let (le, eq) = lp.into_rows();
            let mut c = Conic {
                n: model.n_cols(),
                le,
                eq,
                psd: Vec::new(),
                boxes,
            };
            let mut extra: HashMap<Moment, usize> = HashMap::new();
            let col_t = |k: usize| model.col_theta[k].unwrap_or(0);
            for &t in &model.times {
                let mut ks: Vec<usize> = Vec::new();
                let mut ds: Vec<usize> = Vec::new();
                for (k, _, side, s) in model.terms(t) {
                    let Some(&d) = model.delta_of.get(&(side, s)) else {
                        continue;
                    };
                    if !ds.contains(&d) {
                        ds.push(d);
                    }
                    if let Some(k) = k.filter(|&k| model.prob.fixed[k].is_none()) {
                        if !ks.contains(&k) {
                            ks.push(k);
                        }
                    }
                }
                if ks.is_empty() && ds.len() < 2 {
                    continue; // no product in this equation: nothing to tighten
                }
                // Vector (1, θ_ks, δ_ds).
                enum V {
                    One,
                    T(usize),
                    D(usize),
                }
                let mut v = vec![V::One];
                v.extend(ks.iter().map(|&k| V::T(k)));
                v.extend(ds.iter().map(|&d| V::D(d)));
                let dim = v.len();
                let mut m = vec![vec![Entry::One; dim]; dim];
                for i in 0..dim {
                    for j in i..dim {
                        let e = match (&v[i], &v[j]) {
                            (V::One, V::One) => Entry::One,
                            (V::One, V::T(k)) | (V::T(k), V::One) => Entry::Var(col_t(*k)),
                            (V::One, V::D(d)) | (V::D(d), V::One) => {
                                Entry::Var(model.col_delta(*d))
                            }
                            (V::T(k), V::D(d)) | (V::D(d), V::T(k)) => {
                                match model.product_of.get(&(*k, *d)) {
                                    Some(&w) => Entry::Var(model.col_product(w)),
                                    None => Entry::Var(c.moment(
                                        &mut extra,
                                        Moment::ThetaDelta(*k, *d),
                                        (col_t(*k), tb[*k]),
                                        (model.col_delta(*d), db[*d]),
                                    )),
                                }
                            }
                            (V::T(k), V::T(l)) => {
                                let (k, l) = ((*k).min(*l), (*k).max(*l));
                                Entry::Var(c.moment(
                                    &mut extra,
                                    Moment::ThetaTheta(k, l),
                                    (col_t(k), tb[k]),
                                    (col_t(l), tb[l]),
                                ))
                            }
                            (V::D(d), V::D(e)) => {
                                let (d, e) = ((*d).min(*e), (*d).max(*e));
                                Entry::Var(c.moment(
                                    &mut extra,
                                    Moment::DeltaDelta(d, e),
                                    (model.col_delta(d), db[d]),
                                    (model.col_delta(e), db[e]),
                                ))
                            }
                        };
                        m[i][j] = e;
                        m[j][i] = e;
                    }
                }
                c.psd.push(m);
            }
            Ok(c)
        }

        /// The column of moment `key = u·v` (created with its box and McCormick envelopes).
        fn moment(
            &mut self,
            extra: &mut HashMap<Moment, usize>,
            key: Moment,
            (cu, bu): (usize, Interval),
            (cv, bv): (usize, Interval),
        ) -> usize {
            if let Some(&c) = extra.get(&key) {
                return c;
            }
            let cw = self.n;
            self.n += 1;
            self.boxes.push(mul(bu, bv));
            extra.insert(key, cw);
            let (l, u, dl, du) = (bu.lo, bu.hi, bv.lo, bv.hi);
            // McCormick envelopes of w = u v (for u = v: the secant and two tangents).
            let mut push = |row: Vec<(usize, f64)>, h: f64| {
                let row = merge(row);
                self.le.push((row, h));
            };
            push(vec![(cv, l), (cu, dl), (cw, -1.0)], l * dl);
            push(vec![(cv, u), (cu, du), (cw, -1.0)], u * du);
            push(vec![(cw, 1.0), (cv, -u), (cu, -dl)], -u * dl);
            push(vec![(cw, 1.0), (cv, -l), (cu, -du)], -l * du);
            cw
        }

        pub(super) fn solver(self) -> Result<SdpSolver> {
            let m_le = self.le.len();
            let m_eq = self.eq.len();
            // The one padded assembly of the linear rows (`sparse_lp::padded_rows`).
            let PaddedRows {
                mut cols,
                mut b,
                mut cones,
            } = padded_rows(self.n, &self.le, &self.eq);
            let mut blocks = Vec::new();
            for m in &self.psd {
                let dim = m.len();
                let start = b.len();
                // Upper triangle packed by columns, off-diagonals scaled by sqrt(2): s = b - A x.
                // (Symmetric: row j's first j + 1 entries are column j's upper triangle.)
                for (j, row) in m.iter().enumerate() {
                    for (i, entry) in row.iter().enumerate().take(j + 1) {
                        let scale = if i == j {
                            1.0
                        } else {
                            std::f64::consts::SQRT_2
                        };
                        let r = b.len();
                        match *entry {
                            Entry::One => b.push(scale),
                            Entry::Var(c) => {
                                cols[c].push((r, -scale));
                                b.push(0.0);
                            }
                        }
                    }
                }
                cones.push(SupportedConeT::PSDTriangleConeT(dim));
                blocks.push((start, dim));
            }
            let m = b.len();
            for col in cols.iter_mut() {
                col.sort_by_key(|e| e.0);
            }
            let a = csc(m, &cols, &b, "moment relaxation")?;
            let solver = conic_solver(&a, &b, &cones, None)?;
            Ok(SdpSolver {
                n: self.n,
                cols,
                b,
                m_le,
                m_eq,
                blocks,
                boxes: self.boxes,
                solver,
            })
        }
    }

    /// A set-up conic program, bounded along many objectives.
    pub(super) struct SdpSolver {
        n: usize,
        cols: Vec<Vec<(usize, f64)>>,
        b: Vec<f64>,
        m_le: usize,
        m_eq: usize,
        blocks: Vec<(usize, usize)>,
        boxes: Vec<Interval>,
        solver: DefaultSolver<f64>,
    }

    impl SdpSolver {
        /// A guaranteed lower bound of `min x_c` (`max`: upper bound of `max x_c`) by weak
        /// duality from the solver's dual point projected onto the dual cone; `None` when no
        /// finite bound comes out.
        pub(super) fn bound(&mut self, c: usize, max: bool) -> Result<Option<f64>> {
            let mut q = vec![0.0; self.n];
            q[c] = if max { -1.0 } else { 1.0 };
            self.solver
                .update_q(&q)
                .map_err(|e| SmidError::Solver(format!("{e:?}")))?;
            self.solver.solve();
            let mut z = self.solver.solution.z.clone();
            if z.len() != self.b.len() || z.iter().any(|v| !v.is_finite()) {
                return Ok(None);
            }
            Ok(safe_bound(
                &q,
                &self.cols,
                &self.b,
                self.m_le,
                self.m_eq,
                &self.blocks,
                &self.boxes,
                &mut z,
            )
            .map(|l| if max { -l } else { l }))
        }
    }

    /// `min q·x >= -b·z + Σ_j min(r_j l_j, r_j u_j)`, `r = q + Aᵀz`, for `z` projected onto the
    /// dual cone (modified in place); padded outward for rounding.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn safe_bound(
        q: &[f64],
        cols: &[Vec<(usize, f64)>],
        b: &[f64],
        m_le: usize,
        m_eq: usize,
        blocks: &[(usize, usize)],
        boxes: &[Interval],
        z: &mut [f64],
    ) -> Option<f64> {
        for v in z.iter_mut().take(m_le) {
            *v = v.max(0.0);
        }
        let _ = m_eq; // zero cone: its dual is free
        for &(start, dim) in blocks {
            project_psd(&mut z[start..start + dim * (dim + 1) / 2], dim);
        }
        let mut total = 0.0;
        let mut mag = 0.0;
        for (zi, bi) in z.iter().zip(b) {
            total -= zi * bi;
            mag += (zi * bi).abs();
        }
        for (j, col) in cols.iter().enumerate() {
            let mut r = q[j];
            for &(i, a) in col {
                r += a * z[i];
                mag += (a * z[i]).abs();
            }
            if r == 0.0 {
                continue;
            }
            let bx = boxes[j];
            let term = if r > 0.0 { r * bx.lo } else { r * bx.hi };
            if !term.is_finite() {
                return None;
            }
            total += term;
            mag += term.abs();
        }
        let v = total - RESULT_PAD * (1.0 + total.abs()) - 1e-12 * mag;
        v.is_finite().then_some(v)
    }

    /// Project a packed symmetric block (upper triangle by columns, off-diagonals scaled by
    /// sqrt(2)) onto the PSD cone: eigenvalues clipped at zero.
    fn project_psd(z: &mut [f64], dim: usize) {
        let s2 = std::f64::consts::SQRT_2;
        let mut m = nalgebra::DMatrix::<f64>::zeros(dim, dim);
        let mut k = 0;
        for j in 0..dim {
            for i in 0..=j {
                let v = if i == j { z[k] } else { z[k] / s2 };
                m[(i, j)] = v;
                m[(j, i)] = v;
                k += 1;
            }
        }
        let eig = m.symmetric_eigen();
        if eig.eigenvalues.iter().all(|&l| l >= 0.0) {
            return;
        }
        let clipped = eig.eigenvalues.map(|l| l.max(0.0));
        let p = &eig.eigenvectors
            * nalgebra::DMatrix::from_diagonal(&clipped)
            * eig.eigenvectors.transpose();
        let mut k = 0;
        for j in 0..dim {
            for i in 0..=j {
                let v = 0.5 * (p[(i, j)] + p[(j, i)]);
                z[k] = if i == j { v } else { v * s2 };
                k += 1;
            }
        }
    }

    /// The moment relaxation, starting from a guaranteed result `start` (the shared-error one).
    pub fn solve_from(prob: &EivProblem, start: EivResult, opts: &SdpOptions) -> Result<EivResult> {
        smid_openblas::single_threaded();
        prob.validate()?;
        let model = SharedModel::new(prob, start.equations.clone());
        let mut tb = start.bounds.clone();
        let unsettled = shrink_rounds(
            &model,
            &mut tb,
            RoundLimits {
                max_rounds: opts.max_rounds,
                min_improvement: opts.min_improvement,
                method: super::NAME,
            },
            |tb, db| {
                let mut solver = Conic::build(&model, tb, db)?.solver()?;
                let mut found = Vec::with_capacity(model.free.len());
                for c in 0..model.free.len() {
                    found.push((solver.bound(c, false)?, solver.bound(c, true)?));
                }
                Ok(Round::Bounds(found, true))
            },
            // The first offending equation is not looked for: named the last one.
            |_, _| {
                let t = *model.times.last().unwrap_or(&0);
                Ok(SmidError::inconsistent_unlocated(
                    Stage::Linear,
                    t,
                    message(t),
                ))
            },
            inconsistent,
        )?;
        Ok(EivResult {
            bounds: tb,
            equations: start.equations,
            feasible_orthants: start.feasible_orthants,
            unsettled,
        })
    }

    fn inconsistent(t: usize) -> SmidError {
        SmidError::inconsistent(Stage::Linear, t, message(t))
    }

    fn message(t: usize) -> String {
        format!("the moment relaxation admits no θ and inner-signal errors within their bounds (equations up to t = {t})")
    }

    #[cfg(test)]
    mod tests {
        use super::*;

        /// min x s.t. [[1, x], [x, 1]] PSD, -5 <= x <= 5: the optimum is -1; the safe bound
        /// must lie at or below it, and close.
        #[test]
        fn safe_bound_of_a_small_sdp() {
            smid_openblas::single_threaded();
            let c = Conic {
                n: 1,
                le: vec![(vec![(0, 1.0)], 5.0), (vec![(0, -1.0)], 5.0)],
                eq: vec![],
                psd: vec![vec![
                    vec![Entry::One, Entry::Var(0)],
                    vec![Entry::Var(0), Entry::One],
                ]],
                boxes: vec![Interval::new(-5.0, 5.0)],
            };
            let mut s = c.solver().unwrap();
            let lo = s.bound(0, false).unwrap().unwrap();
            let hi = s.bound(0, true).unwrap().unwrap();
            assert!(lo <= -1.0 && lo > -1.0 - 1e-5, "{lo}");
            assert!((1.0..1.0 + 1e-5).contains(&hi), "{hi}");
        }

        /// A dual point off the cone is projected, so the bound stays valid: any z gives a
        /// bound below the true minimum.
        #[test]
        fn any_dual_point_gives_a_valid_bound() {
            // min x s.t. x >= 2 (row -x <= -2), box [0, 10].
            let cols = vec![vec![(0usize, -1.0)]];
            let b = vec![-2.0];
            let boxes = vec![Interval::new(0.0, 10.0)];
            for z0 in [-3.0, 0.0, 0.5, 1.0, 4.0] {
                let mut z = vec![z0];
                let v = safe_bound(&[1.0], &cols, &b, 1, 0, &[], &boxes, &mut z).unwrap();
                assert!(v <= 2.0, "z = {z0}: {v}");
            }
        }
    }
}

#[cfg(test)]
mod tests {
    #[cfg(not(feature = "openblas"))]
    #[test]
    fn selecting_sdp_names_the_feature() {
        let prob = smid_core::stage3::EivProblem {
            locate: true,
            na: 0,
            nb: 0,
            fixed: vec![None],
            unit_gain: false,
            output: &[],
            input: &[],
            use_band_samples: false,
            lagged: None,
            extra: &[],
            prior: None,
        };
        let e = super::solve(&prob).unwrap_err().to_string();
        assert!(e.contains("feature `sdp`") && e.contains("shared"), "{e}");
    }

    #[cfg(feature = "openblas")]
    #[test]
    fn sdp_contains_the_truth_and_the_exact_inner_hull_and_is_never_wider_than_shared() {
        use smid_core::stage3::exact_grid::{self, ExactOptions};
        use smid_core::stage3::shared::{self, SharedOptions};
        use smid_core::stage3::testutil::{problem, random_case};
        for seed in 0..6 {
            let (m, out, input) = random_case(seed, 40);
            let prob = problem(&out, &input, true);
            let shared = shared::solve(&prob, &SharedOptions::default()).unwrap();
            let sdp = super::solve_from(&prob, shared.clone(), &Default::default()).unwrap();
            let exact = exact_grid::solve_from(
                &prob,
                &shared,
                &ExactOptions {
                    depth: 4,
                    ..Default::default()
                },
                || {},
            )
            .unwrap();
            let truth: Vec<f64> = m.a.iter().chain(&m.b).copied().collect();
            for (k, t) in truth.into_iter().enumerate() {
                let (s, sh) = (sdp.bounds[k], shared.bounds[k]);
                assert!(s.contains(t), "seed {seed} θ{k}: sdp {s:?} misses {t}");
                assert!(
                    sh.lo <= s.lo && s.hi <= sh.hi,
                    "seed {seed} θ{k}: wider than shared"
                );
                if let Some(i) = exact.inner[k] {
                    // Inner points are consistent θ (up to the LPs' row pads).
                    let tol = 1e-7 * (1.0 + i.lo.abs().max(i.hi.abs()));
                    assert!(
                        s.lo <= i.lo + tol && i.hi - tol <= s.hi,
                        "seed {seed} θ{k}: sdp {s:?} cuts the exact inner hull {i:?}"
                    );
                }
            }
        }
    }

    /// Extra columns: exact ones as plain coefficients, an uncertain friction column with its
    /// samples as δ's of the cliques. The truth is inside and the result within shared.
    #[cfg(feature = "openblas")]
    #[test]
    fn sdp_with_extra_columns_contains_the_truth_and_is_never_wider_than_shared() {
        use smid_core::stage3::shared::{self, SharedOptions};
        use smid_core::stage3::testutil::random_extra_case;
        for seed in 0..3 {
            for radius in [0.0, 0.05] {
                let case = random_extra_case(seed, 40, radius);
                let prob = case.problem(true);
                let shared = shared::solve(&prob, &SharedOptions::default()).unwrap();
                let sdp = super::solve_from(&prob, shared.clone(), &Default::default()).unwrap();
                for (k, t) in case.truth().into_iter().enumerate() {
                    let (s, sh) = (sdp.bounds[k], shared.bounds[k]);
                    assert!(
                        s.contains(t),
                        "seed {seed} r {radius} θ{k}: sdp {s:?} misses {t}"
                    );
                    assert!(
                        sh.lo <= s.lo && s.hi <= sh.hi,
                        "seed {seed} r {radius} θ{k}: wider than shared"
                    );
                }
            }
        }
    }
}
