//! Mehrotra's predictor-corrector iterations of the interior-point method, with the block
//! elimination that solves each Newton system (see the module doc of [`super`]).
use super::linalg::{chol, chol_solve, Band};
use super::{Prepared, MAX_ITER};

/// One Mehrotra run on the scaled problem.
pub(super) struct Ipm<'p, 'a> {
    p: &'p Prepared<'a>,
    q: Vec<f64>,
    pub(super) z: Vec<f64>,
    pub(super) zl: Vec<f64>,
    pub(super) zu: Vec<f64>,
    pub(super) s: Vec<f64>,
    pub(super) lam: Vec<f64>,
    pub(super) mu: Vec<f64>,
    pub(super) tmu: Vec<f64>,
    // Factorisation workspace.
    hb: Vec<f64>,
    hb_off: Vec<usize>,
    yb: Vec<f64>,
    yb_off: Vec<usize>,
    m: Band,
    bmat: Vec<f64>,
    zmat: Vec<f64>,
    small_lu: Option<nalgebra::LU<f64, nalgebra::Dyn, nalgebra::Dyn>>,
    /// The diagonal box terms of the current Hessian.
    dbox: Vec<f64>,
    /// Steps of iterative refinement per Newton solve (more near the end).
    refine: usize,
    /// Stop (without certifying) once the complementarity falls below this: a warm start.
    pub(super) stop_at: Option<f64>,
    /// Newton steps of the last run.
    pub(super) iterations: usize,
    pool: Pool,
}

/// Reused work vectors: an iteration needs a few dozen vectors as long as the record, and
/// fresh ones every time cost page faults (14 % of the time at N = 1e5).
#[derive(Default)]
struct Pool(std::cell::RefCell<Vec<Vec<f64>>>);

impl Pool {
    /// A vector of `len` values from `it` (reusing a pooled allocation when one fits).
    fn filled(&self, len: usize, it: impl Iterator<Item = f64>) -> Vec<f64> {
        let mut pool = self.0.borrow_mut();
        let pick = pool
            .iter()
            .enumerate()
            .filter(|(_, v)| v.capacity() >= len && v.capacity() <= 2 * len.max(16))
            .min_by_key(|(_, v)| v.capacity())
            .map(|(i, _)| i);
        let mut v = pick.map(|i| pool.swap_remove(i)).unwrap_or_default();
        drop(pool);
        v.clear();
        v.extend(it);
        debug_assert_eq!(v.len(), len);
        v
    }
    fn zeros(&self, len: usize) -> Vec<f64> {
        self.filled(len, std::iter::repeat_n(0.0, len))
    }
    fn copy(&self, src: &[f64]) -> Vec<f64> {
        self.filled(src.len(), src.iter().copied())
    }
    /// Give `v` back (every vector given back is one taken, so the pool holds at most the
    /// vectors one iteration has alive at once).
    fn put(&self, v: Vec<f64>) {
        self.0.borrow_mut().push(v);
    }
}

/// A Newton direction: the scaled variables, the inequality slacks and multipliers, the box
/// multipliers, the equality and gain multipliers.
struct Dir {
    dz: Vec<f64>,
    ds: Vec<f64>,
    dl: Vec<f64>,
    dzl: Vec<f64>,
    dzu: Vec<f64>,
    dmu: Vec<f64>,
    dtmu: Vec<f64>,
}

impl Dir {
    /// Give the record-long vectors back to `pool`.
    fn recycle(self, pool: &Pool) {
        for v in [self.dz, self.ds, self.dl, self.dzl, self.dzu, self.dmu] {
            pool.put(v);
        }
    }
}

/// Scratch of [`Ipm::factor_block`], sized once per factorisation for the largest block: a
/// column of a block, its `Y` and the equality rows touching it with their `H_b⁻¹` images.
struct BlockWork {
    col: Vec<f64>,
    y: Vec<f64>,
    ev: Vec<f64>,
    hv: Vec<f64>,
}

impl BlockWork {
    fn new(p: &Prepared) -> Self {
        let lp = p.lp;
        let maxb = lp.blocks.iter().map(|&(a, b)| b - a).max().unwrap_or(0);
        let maxt = p.theta_of.iter().map(|t| t.len()).max().unwrap_or(0);
        let maxe = (0..lp.blocks.len())
            .map(|b| p.eq_ptr[b + 1] - p.eq_ptr[b])
            .max()
            .unwrap_or(0);
        BlockWork {
            col: vec![0.0; maxb],
            y: vec![0.0; maxb * maxt],
            ev: vec![0.0; maxe * maxb],
            hv: vec![0.0; maxe * maxb],
        }
    }
}

impl<'p, 'a> Ipm<'p, 'a> {
    pub(super) fn new(p: &'p Prepared<'a>, q: &[f64]) -> Self {
        let n = p.n;
        let nt = p.lp.nt;
        // Start at the box centres, products at the product of the centres (inside their
        // envelopes), every slack at least 0.1.
        let mut z = vec![0.5; n];
        let s: Vec<f64> =
            p.g.iter()
                .zip(&p.h)
                .map(|(row, h)| {
                    let gz: f64 = row.iter().map(|&(j, v)| v * z[j]).sum();
                    (h - gz).max(0.1)
                })
                .collect();
        for v in z.iter_mut() {
            *v = v.clamp(0.05, 0.95);
        }
        let mut hb_off = Vec::with_capacity(p.lp.blocks.len() + 1);
        let mut yb_off = Vec::with_capacity(p.lp.blocks.len() + 1);
        let (mut a, mut b) = (0, 0);
        for (bi, &(s0, s1)) in p.lp.blocks.iter().enumerate() {
            hb_off.push(a);
            yb_off.push(b);
            let bs = s1 - s0;
            a += bs * bs;
            b += bs * p.theta_of[bi].len();
        }
        hb_off.push(a);
        yb_off.push(b);
        let neq = p.e.len();
        let nte = p.te.len();
        Ipm {
            p,
            q: q.to_vec(),
            z,
            zl: vec![1.0; n],
            zu: vec![1.0; n],
            lam: vec![1.0; s.len()],
            s,
            mu: vec![0.0; neq],
            tmu: vec![0.0; nte],
            hb: vec![0.0; a],
            hb_off,
            yb: vec![0.0; b],
            yb_off,
            m: Band {
                n: neq,
                w: p.band,
                a: vec![0.0; neq * (p.band + 1)],
            },
            bmat: vec![0.0; neq * nt],
            zmat: vec![0.0; neq * nt],
            small_lu: None,
            dbox: vec![0.0; n],
            refine: 0,
            stop_at: None,
            iterations: 0,
            pool: Pool::default(),
        }
    }

    /// Factor the Newton system, regularising more each time a factorisation breaks down
    /// (refinement against the unregularised system corrects the directions).
    fn factor(&mut self) -> bool {
        (0..5).any(|k| self.factor_reg(1e-13 * 100f64.powi(k)))
    }

    /// Factor the Newton system for the current scaling `d = λ/s` and box terms, with relative
    /// regularisation `reg` of the band (and a thousandth of it on the blocks): each block's
    /// Hessian ([`Self::factor_block`]), then the equalities' band and the system in θ
    /// ([`Self::factor_schur`]).
    fn factor_reg(&mut self, reg: f64) -> bool {
        let p = self.p;
        let lp = p.lp;
        let nt = lp.nt;
        let neq = p.e.len();
        for j in 0..p.n {
            self.dbox[j] = self.zl[j] / self.z[j] + self.zu[j] / (1.0 - self.z[j]) + 1e-14;
        }
        let mut htt = vec![0.0; nt * nt];
        for j in 0..nt {
            htt[j * nt + j] = self.dbox[j];
        }
        self.m.a.iter_mut().for_each(|v| *v = 0.0);
        self.bmat.iter_mut().for_each(|v| *v = 0.0);
        for r in 0..neq {
            for &(j, v) in p.e_theta.row(r) {
                self.bmat[r * nt + j] += v;
            }
        }
        let mut work = BlockWork::new(p);
        for bi in 0..lp.blocks.len() {
            if !self.factor_block(bi, reg, &mut htt, &mut work) {
                return false;
            }
        }
        self.factor_schur(reg, &htt)
    }

    /// Factor block `bi`'s Hessian `H_b` (regularised by a thousandth of `reg`), keep
    /// `Y = H_b⁻¹ H_bθ`, and fold the block into the θ Hessian `htt` (`P -= H_θb Y`), the band
    /// `M` (`+= e H_b⁻¹ eᵀ`) and `B` (`-= e Y`). `false` when the factor breaks down.
    fn factor_block(&mut self, bi: usize, reg: f64, htt: &mut [f64], work: &mut BlockWork) -> bool {
        let p = self.p;
        let lp = p.lp;
        let nt = lp.nt;
        let BlockWork { col, y, ev, hv } = work;
        let (s0, s1) = lp.blocks[bi];
        let bs = s1 - s0;
        let th = &p.theta_of[bi];
        let nth = th.len();
        let hoff = self.hb_off[bi];
        let yoff = self.yb_off[bi];
        let hb = &mut self.hb[hoff..hoff + bs * bs];
        hb.iter_mut().for_each(|v| *v = 0.0);
        for k in 0..bs {
            hb[k * bs + k] = self.dbox[s0 + k];
        }
        let hbt = &mut self.yb[yoff..yoff + bs * nth];
        hbt.iter_mut().for_each(|v| *v = 0.0);
        let (r0, r1) = lp.ineq_of[bi];
        for i in r0..r1 {
            let d = self.lam[i] / self.s[i];
            let row = p.g.row(i);
            for &(ja, va) in row {
                if ja < nt {
                    htt[ja * nt + ja] += d * va * va;
                    continue;
                }
                let ka = ja - s0;
                for &(jb, vb) in row {
                    let dv = d * va * vb;
                    if jb >= nt {
                        hb[ka * bs + (jb - s0)] += dv;
                    } else {
                        let t = th.iter().position(|&k| k == jb).unwrap_or(0);
                        hbt[ka * nth + t] += dv;
                    }
                }
            }
        }
        let hmax = (0..bs).map(|k| hb[k * bs + k]).fold(0.0f64, f64::max);
        for k in 0..bs {
            hb[k * bs + k] += 1e-3 * reg * hmax;
        }
        if !chol(hb, bs) {
            return false;
        }
        // Y = H_b⁻¹ H_bθ (column by column), P -= H_θb Y.
        for t in 0..nth {
            for k in 0..bs {
                col[k] = hbt[k * nth + t];
            }
            chol_solve(hb, bs, &mut col[..bs]);
            for k in 0..bs {
                y[k * nth + t] = col[k];
            }
        }
        for (ta, &ka) in th.iter().enumerate() {
            for (tb, &kb) in th.iter().enumerate() {
                let mut s = 0.0;
                for k in 0..bs {
                    s += hbt[k * nth + ta] * y[k * nth + tb];
                }
                htt[ka * nt + kb] -= s;
            }
        }
        // Equalities touching the block: M += e H⁻¹ eᵀ, B -= e Y.
        let items = &p.eq_items[p.eq_ptr[bi]..p.eq_ptr[bi + 1]];
        for (a, &(_, k)) in items.iter().enumerate() {
            let v = &mut ev[a * bs..(a + 1) * bs];
            v.iter_mut().for_each(|x| *x = 0.0);
            for &(off, c) in p.eq_ent.row(k) {
                v[off] += c;
            }
            let w = &mut hv[a * bs..(a + 1) * bs];
            w.copy_from_slice(v);
            chol_solve(hb, bs, w);
        }
        for (a, &(ra, _)) in items.iter().enumerate() {
            let va = &ev[a * bs..(a + 1) * bs];
            for (b, &(rb, _)) in items.iter().enumerate().take(a + 1) {
                let wb = &hv[b * bs..(b + 1) * bs];
                let s: f64 = va.iter().zip(wb).map(|(u, v)| u * v).sum();
                *self.m.at(ra, rb) += s;
            }
            for (t, &k) in th.iter().enumerate() {
                let mut s = 0.0;
                for kk in 0..bs {
                    s += va[kk] * y[kk * nth + t];
                }
                self.bmat[ra * nt + k] -= s;
            }
        }
        self.yb[yoff..yoff + bs * nth].copy_from_slice(&y[..bs * nth]);
        true
    }

    /// After every block ([`Self::factor_block`]): regularise the band `M` (relative `reg`)
    /// and factor it, then `Z = M⁻¹ B` and the LU factors of the system in θ and the gain
    /// multipliers, `S = P + Bᵀ Z` (`htt`: `P`). `false` when the band factor breaks down.
    fn factor_schur(&mut self, reg: f64, htt: &[f64]) -> bool {
        let p = self.p;
        let nt = p.lp.nt;
        let neq = p.e.len();
        let nte = p.te.len();
        // Regularise M lightly (relative), then factor the band.
        let dmax = (0..neq)
            .map(|r| self.m.a[r * (self.m.w + 1)])
            .fold(0.0f64, f64::max);
        for r in 0..neq {
            self.m.a[r * (self.m.w + 1)] += reg * dmax + 1e-300;
        }
        if !self.m.factor() {
            return false;
        }
        // Z = M⁻¹ B; S = P + Bᵀ Z.
        let mut colr = vec![0.0; neq];
        for k in 0..nt {
            for r in 0..neq {
                colr[r] = self.bmat[r * nt + k];
            }
            self.m.solve(&mut colr);
            for r in 0..neq {
                self.zmat[r * nt + k] = colr[r];
            }
        }
        let mut small = nalgebra::DMatrix::<f64>::zeros(nt + nte, nt + nte);
        let mut acc = vec![0.0; nt * nt];
        for r in 0..neq {
            let br = &self.bmat[r * nt..(r + 1) * nt];
            let zr = &self.zmat[r * nt..(r + 1) * nt];
            for a in 0..nt {
                for b in 0..nt {
                    acc[a * nt + b] += br[a] * zr[b];
                }
            }
        }
        for a in 0..nt {
            for b in 0..nt {
                small[(a, b)] = htt[a * nt + b] + acc[a * nt + b];
            }
        }
        let smax = (0..nt).map(|a| small[(a, a)].abs()).fold(0.0f64, f64::max);
        for i in 0..nte {
            for &(j, v) in p.te.row(i) {
                small[(nt + i, j)] = v;
                small[(j, nt + i)] = v;
            }
            small[(nt + i, nt + i)] = -1e-14 * (1.0 + smax);
        }
        self.small_lu = Some(small.lu());
        true
    }

    /// Solve the Newton system `[H Aᵀ; A 0] [dz; dμ] = [r1; r2]`, with two steps of
    /// iterative refinement against the unregularised system.
    fn solve(&self, r1: &[f64], r2: &[f64], r2t: &[f64]) -> Option<(Vec<f64>, Vec<f64>, Vec<f64>)> {
        let p = self.p;
        let (mut dz, mut dmu, mut dtmu) = self.solve_once(r1, r2, r2t)?;
        for _ in 0..self.refine {
            // Residual: r1 - H dz - Aᵀ dμ, r2 - A dz.
            let mut q1 = self
                .pool
                .filled(p.n, (0..p.n).map(|j| r1[j] - self.dbox[j] * dz[j]));
            for (i, row) in p.g.iter().enumerate() {
                let d = self.lam[i] / self.s[i];
                let gdz: f64 = row.iter().map(|&(j, v)| v * dz[j]).sum();
                for &(j, v) in row {
                    q1[j] -= d * v * gdz;
                }
            }
            let mut q2 = self.pool.copy(r2);
            for (r, row) in p.e.iter().enumerate() {
                let mut ez = 0.0;
                for &(j, v) in row {
                    q1[j] -= v * dmu[r];
                    ez += v * dz[j];
                }
                q2[r] -= ez;
            }
            let mut q2t = r2t.to_vec();
            for (r, row) in p.te.iter().enumerate() {
                let mut ez = 0.0;
                for &(j, v) in row {
                    q1[j] -= v * dtmu[r];
                    ez += v * dz[j];
                }
                q2t[r] -= ez;
            }
            let (a, b, c) = self.solve_once(&q1, &q2, &q2t)?;
            dz.iter_mut().zip(&a).for_each(|(x, y)| *x += y);
            dmu.iter_mut().zip(&b).for_each(|(x, y)| *x += y);
            dtmu.iter_mut().zip(&c).for_each(|(x, y)| *x += y);
            for v in [q1, q2, a, b] {
                self.pool.put(v);
            }
        }
        Some((dz, dmu, dtmu))
    }

    fn solve_once(
        &self,
        r1: &[f64],
        r2: &[f64],
        r2t: &[f64],
    ) -> Option<(Vec<f64>, Vec<f64>, Vec<f64>)> {
        let p = self.p;
        let lp = p.lp;
        let nt = lp.nt;
        let neq = p.e.len();
        let nte = p.te.len();
        // t_b = H_b⁻¹ r1_b; ρ_θ = r1_θ - Σ Yᵀ r1_b; ρ_eq = r2 - E_y t.
        let mut t = self.pool.copy(r1);
        let mut rho_t: Vec<f64> = r1[..nt].to_vec();
        let mut wv = self.pool.copy(r2);
        for (bi, &(s0, s1)) in lp.blocks.iter().enumerate() {
            let bs = s1 - s0;
            let th = &p.theta_of[bi];
            let nth = th.len();
            let hb = &self.hb[self.hb_off[bi]..self.hb_off[bi] + bs * bs];
            let y = &self.yb[self.yb_off[bi]..self.yb_off[bi] + bs * nth];
            for (tt, &k) in th.iter().enumerate() {
                let mut s = 0.0;
                for kk in 0..bs {
                    s += y[kk * nth + tt] * r1[s0 + kk];
                }
                rho_t[k] -= s;
            }
            chol_solve(hb, bs, &mut t[s0..s1]);
            for &(r, k) in &p.eq_items[p.eq_ptr[bi]..p.eq_ptr[bi + 1]] {
                let s: f64 = p
                    .eq_ent
                    .row(k)
                    .iter()
                    .map(|&(off, c)| c * t[s0 + off])
                    .sum();
                wv[r] -= s;
            }
        }
        // w = M⁻¹ ρ_eq; small system for dθ and the gain multipliers.
        self.m.solve(&mut wv);
        let mut rhs = nalgebra::DVector::<f64>::zeros(nt + nte);
        for k in 0..nt {
            rhs[k] = rho_t[k];
        }
        for r in 0..neq {
            let br = &self.bmat[r * nt..(r + 1) * nt];
            for k in 0..nt {
                rhs[k] += br[k] * wv[r];
            }
        }
        for i in 0..nte {
            rhs[nt + i] = r2t[i];
        }
        let sol = self.small_lu.as_ref()?.solve(&rhs)?;
        let dth: Vec<f64> = (0..nt).map(|k| sol[k]).collect();
        let dtmu: Vec<f64> = (0..nte).map(|i| sol[nt + i]).collect();
        // dμ = Z dθ - w.
        let dmu = self.pool.filled(
            neq,
            (0..neq).map(|r| {
                let zr = &self.zmat[r * nt..(r + 1) * nt];
                zr.iter().zip(&dth).map(|(a, b)| a * b).sum::<f64>() - wv[r]
            }),
        );
        self.pool.put(wv);
        // dy_b = t_b - Y dθ - H_b⁻¹ E_bᵀ dμ.
        let mut dz = t;
        dz[..nt].copy_from_slice(&dth);
        let maxb = lp.blocks.iter().map(|&(a, b)| b - a).max().unwrap_or(0);
        let mut v = vec![0.0; maxb];
        for (bi, &(s0, s1)) in lp.blocks.iter().enumerate() {
            let bs = s1 - s0;
            let th = &p.theta_of[bi];
            let nth = th.len();
            let hb = &self.hb[self.hb_off[bi]..self.hb_off[bi] + bs * bs];
            let y = &self.yb[self.yb_off[bi]..self.yb_off[bi] + bs * nth];
            let v = &mut v[..bs];
            v.iter_mut().for_each(|x| *x = 0.0);
            for &(r, k) in &p.eq_items[p.eq_ptr[bi]..p.eq_ptr[bi + 1]] {
                for &(off, c) in p.eq_ent.row(k) {
                    v[off] += c * dmu[r];
                }
            }
            chol_solve(hb, bs, v);
            for k in 0..bs {
                let mut s = dz[s0 + k] - v[k];
                for (tt, &kk) in th.iter().enumerate() {
                    s -= y[k * nth + tt] * dth[kk];
                }
                dz[s0 + k] = s;
            }
        }
        if dz.iter().chain(&dmu).chain(&dtmu).any(|v| !v.is_finite()) {
            return None;
        }
        Some((dz, dmu, dtmu))
    }

    /// Run to convergence (or the cap), certifying the dual points near the end: the best
    /// certified bound (`cert` maps a scaled dual point to its bound), and the last primal
    /// iterate (scaled). Mehrotra iterations until the certified bound meets the primal
    /// objective, stops improving, or the iteration cap. With `empty_above`, an iteration
    /// whose barrier parameter did not fall (the iterates diverge, as the multipliers do along
    /// a ray when the rows contradict each other; now and then a converging run's too) is
    /// certified as well, and the run ends as soon as a certificate exceeds it (the LP is
    /// proven empty: the caller reads the bound so). `iterations` counts the Newton steps
    /// taken.
    pub(super) fn run_mut(
        &mut self,
        cert: &dyn Fn(&[f64], &[f64], &[f64]) -> Option<f64>,
        offset: f64,
        kappa: f64,
        empty_above: Option<f64>,
    ) -> (Option<f64>, Vec<f64>) {
        let p = self.p;
        let n = p.n;
        let mi = p.g.len();
        let npairs = (mi + 2 * n) as f64;
        let mut best: Option<f64> = None;
        let mut stale = 0;
        // `trace` level of the `log` facade (target `smid::stage3`; `SMID_LOG=trace` in the CLI):
        // one line per iteration (asked once, not per iteration).
        let trace = log::log_enabled!(target: "smid::stage3", log::Level::Trace);
        let mut last_mu = f64::INFINITY;
        for it in 0..MAX_ITER {
            self.iterations = it;
            let res = self.residuals();
            let comp: f64 = (0..mi).map(|i| self.s[i] * self.lam[i]).sum::<f64>()
                + (0..n)
                    .map(|j| self.z[j] * self.zl[j] + (1.0 - self.z[j]) * self.zu[j])
                    .sum::<f64>();
            let mu_c = comp / npairs;
            let inf = |v: &[f64]| v.iter().fold(0.0f64, |a, b| a.max(b.abs()));
            let (ep, ed) = (
                inf(&res.rp).max(inf(&res.rpt)).max(inf(&res.rg)),
                inf(&res.rd),
            );
            // Diverging: does the dual point already prove the LP empty?
            if let Some(top) = empty_above.filter(|_| mu_c >= last_mu) {
                if let Some(v) = cert(&self.lam, &self.mu, &self.tmu).filter(|v| *v > top) {
                    best = Some(v);
                    break;
                }
            }
            last_mu = mu_c;
            // Certify the dual point once it is close; stop when the bound stops improving.
            if mu_c < 1e-8 {
                match cert(&self.lam, &self.mu, &self.tmu) {
                    // An improvement below 1e-10 (relative) is a hundredth of the result pad.
                    Some(v) if best.is_none_or(|b| v > b + 1e-10 * (1.0 + b.abs())) => {
                        best = Some(v);
                        stale = 0;
                    }
                    _ => stale += 1,
                }
                // Done when the certified bound is within 1e-11 (relative) of the primal
                // objective (a thousandth of the result pad), or stops improving. (From N ~ 1e4
                // the equalities' pads alone keep it ~1e-9 away: the second rule ends the run.)
                let obj = offset + kappa * (0..n).map(|j| self.q[j] * self.z[j]).sum::<f64>();
                let close = best.is_some_and(|b| obj - b <= 1e-11 * (1.0 + b.abs()));
                if close || stale >= 1 || mu_c < 1e-14 {
                    break;
                }
            }
            if trace {
                let obj: f64 = (0..n).map(|j| self.q[j] * self.z[j]).sum();
                log::trace!(target: "smid::stage3", "ipm: it {it} ep {ep:.2e} ed {ed:.2e} mu {mu_c:.2e} obj {obj:.12e}");
            }

            if self.stop_at.is_some_and(|t| mu_c < t) {
                break;
            }
            self.refine = if mu_c < 1e-7 { 1 } else { 0 };
            if !self.factor() {
                break;
            }
            if !self.predictor_corrector(res, mu_c, npairs) {
                break;
            }
            self.iterations = it + 1;
        }
        let last = cert(&self.lam, &self.mu, &self.tmu);
        let v = match (best, last) {
            (Some(b), Some(l)) => Some(b.max(l)),
            (b, l) => b.or(l),
        };
        (v, self.z.clone())
    }

    /// The residuals of the current iterate: dual (`rd`), inequality (`rg`), equality (`rp`)
    /// and gain (`rpt`).
    fn residuals(&self) -> Residuals {
        let p = self.p;
        let n = p.n;
        let mi = p.g.len();
        let neq = p.e.len();
        let nte = p.te.len();
        let mut rd = self
            .pool
            .filled(n, (0..n).map(|j| self.q[j] - self.zl[j] + self.zu[j]));
        let mut rg = self.pool.zeros(mi);
        for (i, row) in p.g.iter().enumerate() {
            let mut gz = 0.0;
            for &(j, v) in row {
                rd[j] += v * self.lam[i];
                gz += v * self.z[j];
            }
            rg[i] = gz + self.s[i] - p.h[i];
        }
        let mut rp = self.pool.zeros(neq);
        for (r, row) in p.e.iter().enumerate() {
            let mut ez = 0.0;
            for &(j, v) in row {
                rd[j] += v * self.mu[r];
                ez += v * self.z[j];
            }
            rp[r] = ez - p.f[r];
        }
        let mut rpt = vec![0.0; nte];
        for (r, row) in p.te.iter().enumerate() {
            let mut ez = 0.0;
            for &(j, v) in row {
                rd[j] += v * self.tmu[r];
                ez += v * self.z[j];
            }
            rpt[r] = ez - p.tf[r];
        }
        Residuals { rd, rg, rp, rpt }
    }

    /// One Mehrotra step on the factored system: the predictor (`τ = 0`), the corrector aimed
    /// at `σμ` (`mu_c`: the current complementarity per pair, `npairs` pairs) less the
    /// predictor's second-order term, and the update at 0.995 of the longest steps.
    /// `false` when a Newton solve fails (the iterate is unchanged).
    fn predictor_corrector(&mut self, res: Residuals, mu_c: f64, npairs: f64) -> bool {
        let p = self.p;
        let n = p.n;
        let mi = p.g.len();
        let neq = p.e.len();
        let nte = p.te.len();
        // Reciprocals of the slacks, once per iteration.
        let pool = &self.pool;
        let sys = Newton {
            inv_s: pool.filled(mi, self.s.iter().map(|v| 1.0 / v)),
            inv_z: pool.filled(n, self.z.iter().map(|v| 1.0 / v)),
            inv_u: pool.filled(n, self.z.iter().map(|v| 1.0 / (1.0 - v))),
            r2: pool.filled(neq, res.rp.iter().map(|v| -v)),
            r2t: res.rpt.iter().map(|v| -v).collect(),
        };
        let Some(aff) = self.direction(&res, &sys, None) else {
            return false;
        };
        let (ap, ad) = self.step_lengths(&aff);
        let mut comp_aff = 0.0;
        for i in 0..mi {
            comp_aff += (self.s[i] + ap * aff.ds[i]) * (self.lam[i] + ad * aff.dl[i]);
        }
        for j in 0..n {
            comp_aff += (self.z[j] + ap * aff.dz[j]) * (self.zl[j] + ad * aff.dzl[j]);
            comp_aff += (1.0 - self.z[j] - ap * aff.dz[j]) * (self.zu[j] + ad * aff.dzu[j]);
        }
        let sigma = ((comp_aff / npairs) / mu_c).clamp(0.0, 1.0).powi(3);
        let target = sigma * mu_c;
        // Mehrotra's corrector targets: σμ minus the predictor's second-order term.
        let tau = self.pool.filled(
            mi + 2 * n,
            (0..mi)
                .map(|i| target - aff.ds[i] * aff.dl[i])
                .chain((0..n).map(|j| target - aff.dz[j] * aff.dzl[j]))
                .chain((0..n).map(|j| target + aff.dz[j] * aff.dzu[j])),
        );
        aff.recycle(&self.pool);
        let Some(st) = self.direction(&res, &sys, Some(&tau)) else {
            return false;
        };
        let (ap, ad) = self.step_lengths(&st);
        let (ap, ad) = ((0.995 * ap).min(1.0), (0.995 * ad).min(1.0));
        for j in 0..n {
            self.z[j] += ap * st.dz[j];
            self.zl[j] += ad * st.dzl[j];
            self.zu[j] += ad * st.dzu[j];
        }
        for i in 0..mi {
            self.s[i] += ap * st.ds[i];
            self.lam[i] += ad * st.dl[i];
        }
        for r in 0..neq {
            self.mu[r] += ad * st.dmu[r];
        }
        for r in 0..nte {
            self.tmu[r] += ad * st.dtmu[r];
        }
        st.recycle(&self.pool);
        let Residuals { rd, rg, rp, .. } = res;
        let Newton {
            inv_s,
            inv_z,
            inv_u,
            r2,
            ..
        } = sys;
        for v in [tau, rd, rg, rp, inv_s, inv_z, inv_u, r2] {
            self.pool.put(v);
        }
        true
    }

    /// The Newton direction whose complementarity products aim at `tau` (pairs: ineq i ->
    /// tau[i]; lower box j -> tau[mi + j]; upper -> tau[mi + n + j]; None: all 0).
    fn direction(&self, res: &Residuals, sys: &Newton, tau: Option<&[f64]>) -> Option<Dir> {
        let p = self.p;
        let n = p.n;
        let mi = p.g.len();
        let Newton {
            inv_s,
            inv_z,
            inv_u,
            r2,
            r2t,
        } = sys;
        let rg = &res.rg;
        let ta = |k: usize| tau.map_or(0.0, |t| t[k]);
        let mut r1 = self.pool.filled(n, res.rd.iter().map(|v| -v));
        for (i, row) in p.g.iter().enumerate() {
            let rc = -self.s[i] * self.lam[i] + ta(i);
            let a = (rc + self.lam[i] * rg[i]) * inv_s[i];
            for &(j, v) in row {
                r1[j] -= v * a;
            }
        }
        for j in 0..n {
            let rcl = -self.z[j] * self.zl[j] + ta(mi + j);
            let rcu = -(1.0 - self.z[j]) * self.zu[j] + ta(mi + n + j);
            r1[j] += rcl * inv_z[j] - rcu * inv_u[j];
        }
        let (dz, dmu, dtmu) = self.solve(&r1, r2, r2t)?;
        self.pool.put(r1);
        let mut ds = self.pool.zeros(mi);
        let mut dl = self.pool.zeros(mi);
        for (i, row) in p.g.iter().enumerate() {
            let gdz: f64 = row.iter().map(|&(j, v)| v * dz[j]).sum();
            ds[i] = -rg[i] - gdz;
            let rc = -self.s[i] * self.lam[i] + ta(i);
            dl[i] = (rc - self.lam[i] * ds[i]) * inv_s[i];
        }
        let mut dzl = self.pool.zeros(n);
        let mut dzu = self.pool.zeros(n);
        for j in 0..n {
            let rcl = -self.z[j] * self.zl[j] + ta(mi + j);
            let rcu = -(1.0 - self.z[j]) * self.zu[j] + ta(mi + n + j);
            dzl[j] = (rcl - self.zl[j] * dz[j]) * inv_z[j];
            dzu[j] = (rcu + self.zu[j] * dz[j]) * inv_u[j];
        }
        Some(Dir {
            dz,
            ds,
            dl,
            dzl,
            dzu,
            dmu,
            dtmu,
        })
    }

    /// The longest primal and dual steps in `[0, 1]` along `st` that keep the iterate inside
    /// (variables in `[0, 1]`, slacks and multipliers `>= 0`).
    fn step_lengths(&self, st: &Dir) -> (f64, f64) {
        let Dir {
            dz,
            ds,
            dl,
            dzl,
            dzu,
            ..
        } = st;
        let mut ap = ratio(&self.z, dz).min(ratio(&self.s, ds));
        for (z, d) in self.z.iter().zip(dz) {
            if *d > 0.0 {
                ap = ap.min((1.0 - z) / d);
            }
        }
        let ad = ratio(&self.lam, dl)
            .min(ratio(&self.zl, dzl))
            .min(ratio(&self.zu, dzu));
        (ap, ad)
    }
}

/// Largest step in [0, 1] keeping x + α dx >= 0.
fn ratio(x: &[f64], dx: &[f64]) -> f64 {
    let mut a = 1.0f64;
    for (x, d) in x.iter().zip(dx) {
        if *d < 0.0 {
            a = a.min(-x / d);
        }
    }
    a
}

/// The residuals of an iterate ([`Ipm::residuals`]).
struct Residuals {
    rd: Vec<f64>,
    rg: Vec<f64>,
    rp: Vec<f64>,
    rpt: Vec<f64>,
}

/// What both Newton solves of one step share: the reciprocals of the inequality slacks and
/// of the box distances, and the equality and gain right-hand sides.
struct Newton {
    inv_s: Vec<f64>,
    inv_z: Vec<f64>,
    inv_u: Vec<f64>,
    r2: Vec<f64>,
    r2t: Vec<f64>,
}
