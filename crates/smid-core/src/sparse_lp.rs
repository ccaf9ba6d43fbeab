//! A small sparse linear-programming front end on Clarabel (CSC matrices, no modelling layer):
//! `min q·z` subject to rows `g·z <= h` and `e·z = f`. One factorisation is reused for many
//! objectives (`update_q`), which is what the shared-error EIV relaxation ([`crate::stage3::shared`])
//! and the exact-grid reference ([`crate::stage3::exact_grid`]) need: the same polytope bounded along many
//! coordinates.
//!
//! Guarantee (as in [`crate::lp`]): every inequality right-hand side is relaxed outward by
//! [`ROW_PAD`] before solving, and a reported optimum is the smaller of the primal and dual
//! objectives (the dual one is a lower bound of a minimum) widened outward by [`RESULT_PAD`].
//! Solver outcomes other than "solved" and "primal infeasible" are reported as
//! [`Optimum::Unknown`], which callers treat conservatively (no tightening, cell kept).
use crate::error::{Result, SmidError};
use crate::lp::{RESULT_PAD, ROW_PAD};
use clarabel::algebra::CscMatrix;
use clarabel::solver::{
    DefaultSettings, DefaultSettingsBuilder, DefaultSolver, IPSolver, SolverStatus, SupportedConeT,
};

/// A sparse LP under construction.
#[derive(Debug, Clone, Default)]
pub struct SparseLp {
    /// Number of variables.
    pub n: usize,
    pub(crate) le: Vec<(Vec<(usize, f64)>, f64)>,
    pub(crate) eq: Vec<(Vec<(usize, f64)>, f64)>,
}

/// Outcome of one optimisation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Optimum {
    /// A guaranteed bound on the optimum (lower bound for `min`, upper bound for `max`), and the
    /// solver's optimal point is available through [`LpSolver::point`].
    Value(f64),
    /// The polytope is empty.
    Infeasible,
    /// The solver stopped without a conclusion (iteration limit, numerical trouble).
    Unknown,
}

/// The `m`-row CSC matrix of column lists `cols` (rows sorted within each column), after checking
/// that it and the right-hand side `b` are finite (`what` names the program in the error).
pub fn csc(m: usize, cols: &[Vec<(usize, f64)>], b: &[f64], what: &str) -> Result<CscMatrix<f64>> {
    let mut colptr = Vec::with_capacity(cols.len() + 1);
    let (mut rowval, mut nzval) = (Vec::new(), Vec::new());
    colptr.push(0);
    for col in cols {
        for &(r, v) in col {
            rowval.push(r);
            nzval.push(v);
        }
        colptr.push(rowval.len());
    }
    if b.iter().any(|v| !v.is_finite()) || nzval.iter().any(|v: &f64| !v.is_finite()) {
        return Err(SmidError::Solver(format!(
            "non-finite coefficient in the {what}"
        )));
    }
    Ok(CscMatrix::new(m, cols.len(), colptr, rowval, nzval))
}

/// A Clarabel solver for `min q·x` (no quadratic term, `q` set later with `update_q`; presolve
/// off so that works), rows `a x + s = b`, `s` in `cones`, at most 100 iterations; `tol` sets
/// the gap and feasibility tolerances (else Clarabel's defaults).
pub fn conic_solver(
    a: &CscMatrix<f64>,
    b: &[f64],
    cones: &[SupportedConeT<f64>],
    tol: Option<f64>,
) -> Result<DefaultSolver<f64>> {
    let mut builder = DefaultSettingsBuilder::default();
    builder.verbose(false).presolve_enable(false).max_iter(100);
    if let Some(t) = tol {
        builder.tol_gap_abs(t).tol_gap_rel(t).tol_feas(t);
    }
    let settings: DefaultSettings<f64> = builder
        .build()
        .map_err(|e| SmidError::Solver(e.to_string()))?;
    let n = a.n;
    let p = CscMatrix::zeros((n, n));
    DefaultSolver::new(&p, &vec![0.0; n], a, b, cones, settings)
        .map_err(|e| SmidError::Solver(e.to_string()))
}

/// Sum the coefficients of equal columns of a sparse row (dropping zeros).
pub fn merge(mut row: Vec<(usize, f64)>) -> Vec<(usize, f64)> {
    row.sort_by_key(|e| e.0);
    let mut out: Vec<(usize, f64)> = Vec::with_capacity(row.len());
    for (c, v) in row {
        match out.last_mut() {
            Some(l) if l.0 == c => l.1 += v,
            _ => out.push((c, v)),
        }
    }
    out.retain(|e| e.1 != 0.0);
    out
}

impl SparseLp {
    /// Its rows, taken apart: the `g·z <= h` rows and the `e·z = f` rows, as added (for a
    /// conic program that adds cones of its own to them, as the moment relaxation does).
    #[allow(clippy::type_complexity)]
    pub fn into_rows(self) -> (Vec<(Vec<(usize, f64)>, f64)>, Vec<(Vec<(usize, f64)>, f64)>) {
        (self.le, self.eq)
    }

    /// An LP in `n` variables without rows.
    pub fn new(n: usize) -> Self {
        SparseLp {
            n,
            ..Default::default()
        }
    }
    /// Add `g·z <= h` (relaxed outward by [`ROW_PAD`] when solved).
    pub fn le(&mut self, row: Vec<(usize, f64)>, h: f64) {
        self.le.push((merge(row), h));
    }
    /// Add `lo <= z_c <= hi` (each side relaxed outward).
    pub fn bound(&mut self, c: usize, lo: f64, hi: f64) {
        self.le.push((vec![(c, 1.0)], hi));
        self.le.push((vec![(c, -1.0)], -lo));
    }
    /// Add `e·z = f`.
    pub fn eq(&mut self, row: Vec<(usize, f64)>, f: f64) {
        self.eq.push((merge(row), f));
    }
    /// Number of inequality rows.
    pub fn rows(&self) -> usize {
        self.le.len() + self.eq.len()
    }

    /// The same LP as a dense [`crate::lp::Polytope`] (for the low-dimensional simplex), when
    /// it has at most `max_n` variables.
    pub fn dense(&self, max_n: usize) -> Option<crate::lp::Polytope> {
        if self.n > max_n {
            return None;
        }
        let mut p = crate::lp::Polytope::new(self.n);
        let mut row = vec![0.0; self.n];
        for (g, h) in &self.le {
            row.iter_mut().for_each(|v| *v = 0.0);
            for &(c, v) in g {
                row[c] += v;
            }
            p.push_le(&row, *h, 0);
        }
        for (e, f) in &self.eq {
            row.iter_mut().for_each(|v| *v = 0.0);
            for &(c, v) in e {
                row[c] += v;
            }
            p.push_eq(&row, *f);
        }
        Some(p)
    }

    /// Set up the solver (one symbolic factorisation for all objectives).
    pub fn solver(&self) -> Result<LpSolver> {
        let rows = padded_rows(self.n, &self.le, &self.eq);
        let a = csc(rows.b.len(), &rows.cols, &rows.b, "linear program")?;
        let (b, cones) = (rows.b, rows.cones);
        let solver = conic_solver(&a, &b, &cones, Some(1e-10))?;
        Ok(LpSolver {
            n: self.n,
            solver,
            infeasible: false,
        })
    }
}

impl SparseLp {
    /// The minimum of column `s` when the other columns fall into blocks that only `s` couples
    /// (a long record's fixed-`θ` LP: one block per chain of equations), and raising `s` only
    /// relaxes (`s` in no equality, with a coefficient `<= 0` in every inequality): then the
    /// smallest `s` of the whole LP is the largest of the blocks' smallest ones, and each
    /// block is a small LP (the low-dimensional simplex's vertex value at up to `dense_max`
    /// columns, else Clarabel's guaranteed lower bound). `None` when the LP has at most
    /// `above` inequality rows or is not of that shape (solve it whole); a block with no
    /// conclusion gives [`Optimum::Unknown`], an empty one [`Optimum::Infeasible`].
    pub fn minimise_by_blocks(
        &self,
        s: usize,
        dense_max: usize,
        above: usize,
    ) -> Result<Option<Optimum>> {
        if self.le.len() <= above
            || self.eq.iter().any(|(e, _)| e.iter().any(|&(k, _)| k == s))
            || self
                .le
                .iter()
                .any(|(g, _)| g.iter().any(|&(k, v)| k == s && v > 0.0))
        {
            return Ok(None);
        }
        let (block_of, blocks) = self.blocks_apart_from(s);
        if blocks.len() < 2 {
            return Ok(None);
        }
        // Each block's LP: its columns (local numbering), then `s`; the rows of `s` alone go
        // to every block (they bound `s`).
        let mut local = vec![usize::MAX; self.n];
        for cols in &blocks {
            for (i, &k) in cols.iter().enumerate() {
                local[k] = i;
            }
        }
        let to_local = |g: &[(usize, f64)], n_b: usize| -> Vec<(usize, f64)> {
            g.iter()
                .map(|&(k, v)| (if k == s { n_b } else { local[k] }, v))
                .collect()
        };
        let mut lps: Vec<SparseLp> = blocks.iter().map(|c| SparseLp::new(c.len() + 1)).collect();
        let mut alone: Vec<&(Vec<(usize, f64)>, f64)> = Vec::new();
        for row in &self.le {
            match row.0.iter().find(|e| e.0 != s) {
                Some(&(k, _)) => {
                    let b = block_of[k];
                    lps[b].le.push((to_local(&row.0, blocks[b].len()), row.1));
                }
                None => alone.push(row),
            }
        }
        for (e, f) in &self.eq {
            match e.first() {
                Some(&(k, _)) => {
                    let b = block_of[k];
                    lps[b].eq.push((to_local(e, blocks[b].len()), *f));
                }
                None if f.abs() > ROW_PAD => return Ok(Some(Optimum::Infeasible)),
                None => {}
            }
        }
        // A block without rows of its own only repeats the rows of `s` alone, which every
        // other block has too.
        let mut worst = f64::NEG_INFINITY;
        for (b, mut lp) in lps.into_iter().enumerate() {
            if lp.le.is_empty() && lp.eq.is_empty() {
                continue;
            }
            let n_b = blocks[b].len();
            lp.le
                .extend(alone.iter().map(|(g, h)| (to_local(g, n_b), *h)));
            let mut c = vec![0.0; lp.n];
            c[n_b] = 1.0;
            let v = match lp.dense(dense_max).and_then(|p| p.vertex_optimum(&c)) {
                Some(v) => v,
                None => match lp.solver()?.minimise(n_b)? {
                    Optimum::Value(v) => v,
                    o => return Ok(Some(o)),
                },
            };
            worst = worst.max(v);
        }
        // No block with rows of its own: nothing to take apart.
        Ok((worst > f64::NEG_INFINITY).then_some(Optimum::Value(worst)))
    }

    /// The columns other than `s` in blocks that share no row apart from `s` (union-find over
    /// the rows): each column's block, and each block's columns, in order of first column.
    fn blocks_apart_from(&self, s: usize) -> (Vec<usize>, Vec<Vec<usize>>) {
        fn find(root: &mut [usize], mut k: usize) -> usize {
            while root[k] != k {
                root[k] = root[root[k]];
                k = root[k];
            }
            k
        }
        let mut root: Vec<usize> = (0..self.n).collect();
        for (g, _) in self.le.iter().chain(&self.eq) {
            let mut cols = g.iter().map(|e| e.0).filter(|&k| k != s);
            if let Some(first) = cols.next() {
                let r0 = find(&mut root, first);
                for k in cols {
                    let rk = find(&mut root, k);
                    root[rk] = r0;
                }
            }
        }
        let mut block_of = vec![usize::MAX; self.n];
        let mut block_of_root = vec![usize::MAX; self.n];
        let mut blocks: Vec<Vec<usize>> = Vec::new();
        for k in (0..self.n).filter(|&k| k != s) {
            let r = find(&mut root, k);
            if block_of_root[r] == usize::MAX {
                block_of_root[r] = blocks.len();
                blocks.push(Vec::new());
            }
            block_of[k] = block_of_root[r];
            blocks[block_of[k]].push(k);
        }
        (block_of, blocks)
    }
}

/// The linear rows of a conic program in clarabel's column form: the `g·z <= h` rows first,
/// each right-hand side relaxed outward by [`ROW_PAD`] `· (1 + |h|)` (invariant 1: the solved
/// feasible set contains the exact one), then the `e·z = f` rows as given, with their cones.
/// The one copy of the padding and assembly: the LP path here and the moment relaxation
/// (the crate `smid-sdp`, which appends its PSD blocks) both build from it.
pub struct PaddedRows {
    /// Per column, `(row, value)` entries.
    pub cols: Vec<Vec<(usize, f64)>>,
    /// Right-hand sides, padded for the inequality rows.
    pub b: Vec<f64>,
    /// The nonnegative cone of the inequality rows, then the zero cone of the equalities.
    pub cones: Vec<SupportedConeT<f64>>,
}

/// See [`PaddedRows`]: `n` columns, `le` inequality and `eq` equality rows.
pub fn padded_rows(
    n: usize,
    le: &[(Vec<(usize, f64)>, f64)],
    eq: &[(Vec<(usize, f64)>, f64)],
) -> PaddedRows {
    let mut cols: Vec<Vec<(usize, f64)>> = vec![Vec::new(); n];
    let mut b = Vec::with_capacity(le.len() + eq.len());
    for (r, (g, h)) in le.iter().enumerate() {
        for &(c, v) in g {
            cols[c].push((r, v));
        }
        b.push(h + ROW_PAD * (1.0 + h.abs()));
    }
    for (r, (e, f)) in eq.iter().enumerate() {
        for &(c, v) in e {
            cols[c].push((le.len() + r, v));
        }
        b.push(*f);
    }
    let mut cones = Vec::new();
    if !le.is_empty() {
        cones.push(SupportedConeT::NonnegativeConeT(le.len()));
    }
    if !eq.is_empty() {
        cones.push(SupportedConeT::ZeroConeT(eq.len()));
    }
    PaddedRows { cols, b, cones }
}

/// A set-up LP, optimised along many objectives.
pub struct LpSolver {
    n: usize,
    solver: DefaultSolver<f64>,
    infeasible: bool,
}

impl LpSolver {
    fn run(&mut self, q: &[f64]) -> Result<Optimum> {
        if self.infeasible {
            return Ok(Optimum::Infeasible);
        }
        self.solver
            .update_q(&q.to_vec())
            .map_err(|e| SmidError::Solver(format!("{e:?}")))?;
        self.solver.solve();
        let s = &self.solver.solution;
        Ok(match s.status {
            SolverStatus::Solved | SolverStatus::AlmostSolved => {
                let v = s.obj_val.min(s.obj_val_dual);
                if v.is_finite() {
                    Optimum::Value(v)
                } else {
                    Optimum::Unknown
                }
            }
            // Only a full infeasibility certificate discards; "almost" is no proof.
            SolverStatus::PrimalInfeasible => {
                self.infeasible = true;
                Optimum::Infeasible
            }
            SolverStatus::DualInfeasible | SolverStatus::AlmostDualInfeasible => {
                return Err(SmidError::Unbounded {
                    parameter: "θ".into(),
                    message:
                        "the linear program is unbounded: the data do not constrain a parameter"
                            .into(),
                })
            }
            _ => Optimum::Unknown,
        })
    }

    fn pad(v: f64) -> f64 {
        RESULT_PAD * (1.0 + v.abs())
    }

    /// A guaranteed lower bound of `min z_c` (or infeasibility).
    pub fn minimise(&mut self, c: usize) -> Result<Optimum> {
        let mut q = vec![0.0; self.n];
        q[c] = 1.0;
        Ok(match self.run(&q)? {
            Optimum::Value(v) => Optimum::Value(v - Self::pad(v)),
            o => o,
        })
    }

    /// A guaranteed upper bound of `max z_c` (or infeasibility).
    pub fn maximise(&mut self, c: usize) -> Result<Optimum> {
        let mut q = vec![0.0; self.n];
        q[c] = -1.0;
        Ok(match self.run(&q)? {
            Optimum::Value(v) => Optimum::Value(-v + Self::pad(v)),
            o => o,
        })
    }

    /// [`Self::maximise`] when `max`, else [`Self::minimise`].
    pub fn optimise(&mut self, c: usize, max: bool) -> Result<Optimum> {
        if max {
            self.maximise(c)
        } else {
            self.minimise(c)
        }
    }

    /// Whether the polytope is non-empty; `None` when the solver could not tell.
    pub fn feasible(&mut self) -> Result<Option<bool>> {
        Ok(match self.run(&vec![0.0; self.n])? {
            Optimum::Value(_) => Some(true),
            Optimum::Infeasible => Some(false),
            Optimum::Unknown => None,
        })
    }

    /// The solver's last optimal point (meaningful after a [`Optimum::Value`]).
    pub fn point(&self) -> &[f64] {
        &self.solver.solution.x
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    #[test]
    fn bounds_a_triangle_and_detects_emptiness() {
        // x, y >= 0, x + y <= 1, x - y = 0.2
        let mut lp = SparseLp::new(2);
        lp.le(vec![(0, -1.0)], 0.0);
        lp.le(vec![(1, -1.0)], 0.0);
        lp.le(vec![(0, 1.0), (1, 1.0)], 1.0);
        lp.eq(vec![(0, 1.0), (1, -1.0)], 0.2);
        let mut s = lp.solver().unwrap();
        let Optimum::Value(hi) = s.maximise(0).unwrap() else {
            panic!("feasible")
        };
        let Optimum::Value(lo) = s.minimise(0).unwrap() else {
            panic!("feasible")
        };
        assert!((0.6..0.6 + 1e-6).contains(&hi), "{hi}");
        assert!(lo <= 0.2 && lo > 0.2 - 1e-6, "{lo}");
        lp.le(vec![(0, 1.0)], 0.1);
        let mut s = lp.solver().unwrap();
        assert_eq!(s.feasible().unwrap(), Some(false));
        assert_eq!(s.maximise(1).unwrap(), Optimum::Infeasible);
    }

    /// A random LP of the fixed-`θ` certificate's shape: `blocks` chains of `len` samples, each
    /// sample an affine function of its chain's two starts (a decaying recursion) and of `nb`
    /// shared columns, inside its box scaled by `1 + s` (a few boxes narrow, so that some
    /// chains need a positive `s`); `s >= -1`, the shared columns in `[-2, 2]`.
    fn chains_lp(seed: u64, blocks: usize, len: usize, nb: usize) -> (SparseLp, usize) {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        let n = nb + 2 * blocks + 1;
        let s = n - 1;
        let mut lp = SparseLp::new(n);
        let a = rng.gen_range(-0.9..0.9);
        for b in 0..blocks {
            let z = nb + 2 * b;
            // The sample's coefficients on the two starts, `(p, q)_t = -a (p, q)_{t-1} - 0.2
            // (p, q)_{t-2}` from `(1, 0)` and `(0, 1)`.
            let (mut now, mut before) = ([1.0, 0.0], [0.0, 1.0]);
            for _ in 0..len {
                let mut row = vec![(z, now[0]), (z + 1, now[1])];
                for k in 0..nb {
                    row.push((k, rng.gen_range(-1.0..1.0)));
                }
                let c: f64 = rng.gen_range(-0.5..0.5);
                let r = if rng.gen_bool(0.05) {
                    0.01
                } else {
                    rng.gen_range(0.2..1.0)
                };
                let mut up = row.clone();
                up.push((s, -r));
                lp.le(up, r - c);
                let mut down: Vec<(usize, f64)> = row.iter().map(|&(k, v)| (k, -v)).collect();
                down.push((s, -r));
                lp.le(down, r + c);
                let next = [-a * now[0] - 0.2 * before[0], -a * now[1] - 0.2 * before[1]];
                (before, now) = (now, next);
            }
        }
        lp.le(vec![(s, -1.0)], 1.0);
        for k in 0..nb {
            lp.bound(k, -2.0, 2.0);
        }
        (lp, s)
    }

    /// Blocks coupled only by the slack: the largest of the blocks' smallest slacks is the
    /// whole LP's smallest slack; a shared column couples the blocks into one, and the LP is
    /// then left to be solved whole.
    #[test]
    fn blocks_coupled_by_the_slack_alone_give_the_whole_minimum() {
        for seed in 0..6 {
            let (lp, s) = chains_lp(seed, 9, 30, 0);
            let Optimum::Value(w) = lp.solver().unwrap().minimise(s).unwrap() else {
                panic!("feasible")
            };
            let Some(Optimum::Value(b)) = lp.minimise_by_blocks(s, 24, 0).unwrap() else {
                panic!("seed {seed}: blocks")
            };
            assert!(
                (w - b).abs() <= 1e-6 * (1.0 + w.abs()),
                "seed {seed}: whole {w}, blocks {b}"
            );
            let (shared, s) = chains_lp(seed, 9, 30, 1);
            assert_eq!(shared.minimise_by_blocks(s, 24, 0).unwrap(), None);
            // At or below the threshold the blocks are not taken apart.
            assert_eq!(lp.minimise_by_blocks(s, 24, lp.le.len()).unwrap(), None);
        }
    }
}
