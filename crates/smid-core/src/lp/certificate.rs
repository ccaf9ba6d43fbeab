//! The certificates of the polytope engine: weak-duality bounds with their residual carried,
//! and Farkas combinations that prove emptiness (in floating point, or exactly).
use super::{gamma, Polytope, Row, THETA_MAX};
use num_traits::Signed;

/// One certified side: `c·θ >= value - Σ_j resid_j |θ_j|` for every θ of the polytope.
pub(super) struct Certificate {
    pub(super) value: f64,
    pub(super) resid: Vec<f64>,
}

impl Polytope {
    /// Whether the Farkas combination `g_enter - Σ v_i g_i` (weights `1`, `-v_i`) proves that no
    /// θ in the artificial box satisfies the rows: its right-hand side, less the rounding of
    /// the sums and the residual over the box, is negative.
    pub(super) fn farkas_proves(&self, basis: &[Row], v: &[f64], enter: Row) -> bool {
        let mut weights: Vec<(Row, f64)> = vec![(enter, 1.0)];
        weights.extend(basis.iter().zip(v).map(|(&b, &vi)| (b, -vi)));
        self.farkas_weights_prove(&weights) || self.farkas_proves_exactly(basis, enter)
    }

    /// Whether the combination of rows with `weights` (inequalities clamped at `>= 0`) proves
    /// that no θ of the artificial box satisfies the rows: its right-hand side, less the
    /// rounding of the sums and its residual over the box, is negative.
    fn farkas_weights_prove(&self, weights: &[(Row, f64)]) -> bool {
        let n = self.n;
        let weights = clamped(weights);
        let mut resid = vec![0.0; n];
        let mut mag = vec![0.0; n];
        let (mut rhs, mut rhs_mag) = (0.0, 0.0);
        for &(row, w) in &weights {
            let (g, h) = self.row(row);
            for k in 0..n {
                resid[k] += w * g[k];
                mag[k] += (w * g[k]).abs();
            }
            rhs += w * h;
            rhs_mag += (w * h).abs();
        }
        let k = weights.len();
        let slack: f64 = (0..n)
            .map(|j| (resid[j].abs() + gamma(k) * mag[j]) * THETA_MAX)
            .sum::<f64>();
        // Every θ of the box satisfying the rows has resid·θ <= rhs, and resid·θ >= -slack.
        rhs + gamma(k) * rhs_mag + slack < 0.0
    }

    /// The same proof in exact rational arithmetic ([`crate::exact`]), for a nearly empty
    /// polytope whose float combination is lost in its own rounding: the entering row with
    /// weight 1 and the basis rows with weights that solve `G_Bᵀ v = g_enter` exactly.
    fn farkas_proves_exactly(&self, basis: &[Row], enter: Row) -> bool {
        self.farkas_exact(&[(enter, 1.0)], basis)
    }

    /// Whether rows `fixed` with their (float, taken as exact) weights, completed by `basis`
    /// rows whose weights cancel their combination **exactly** (`G_Bᵀ w_B = -Σ w_i g_i` solved
    /// in rationals), prove that no θ satisfies the rows: every inequality weight `>= 0` and
    /// the combined right-hand side `< 0`, both exactly. The combination of the left-hand
    /// sides is then exactly zero, so the rows imply `0 <= Σ w h < 0`.
    fn farkas_exact(&self, fixed: &[(Row, f64)], basis: &[Row]) -> bool {
        use crate::exact::{rational, solve_rational};
        let n = self.n;
        if basis.len() != n
            || fixed
                .iter()
                .any(|&(r, w)| !matches!(r, Row::Eq(_)) && w < 0.0)
        {
            return false;
        }
        let mut rhs = vec![num_rational::BigRational::from_integer(0.into()); n];
        let mut total = num_rational::BigRational::from_integer(0.into());
        for &(r, w) in fixed {
            if w == 0.0 {
                continue;
            }
            let (g, h) = self.row(r);
            let (Some(w), Some(h)) = (rational(w), rational(h)) else {
                return false;
            };
            for k in 0..n {
                if g[k] != 0.0 {
                    rhs[k] -= &w * rational(g[k]).expect("finite row");
                }
            }
            total += w * h;
        }
        let rows: Vec<(Vec<f64>, f64)> = basis.iter().map(|&b| self.row(b)).collect();
        // Column i of the system is basis row i.
        let a: Vec<Vec<f64>> = (0..n)
            .map(|k| rows.iter().map(|(g, _)| g[k]).collect())
            .collect();
        let Some(wb) = solve_rational(&a, rhs) else {
            return false;
        };
        for ((&b, wi), (_, hi)) in basis.iter().zip(wb).zip(&rows) {
            if !matches!(b, Row::Eq(_)) && wi.is_negative() {
                return false;
            }
            let Some(h) = rational(*hi) else {
                return false;
            };
            total += wi * h;
        }
        total.is_negative()
    }

    /// Whether an interior-point Farkas vector proves the polytope empty: as it is (floats,
    /// over the artificial box), or through the `n + 1` rows it weighs most, combined exactly
    /// ([`Self::farkas_proves_exactly`] with each of them in turn as the entering row; an
    /// emptiness in `R^n` always has a proof on at most `n + 1` rows).
    pub(super) fn farkas_multipliers_prove(&self, weights: &[(Row, f64)]) -> bool {
        if self.farkas_weights_prove(weights) {
            return true;
        }
        // The weights clamped as the certificate reads them; the `n` heaviest independent
        // rows absorb the residual exactly.
        let w = clamped(weights);
        let mut order: Vec<usize> = (0..w.len()).filter(|&i| w[i].1 != 0.0).collect();
        order.sort_by(|&a, &b| w[b].1.abs().total_cmp(&w[a].1.abs()));
        let mut basis: Vec<usize> = Vec::with_capacity(self.n);
        let mut span: Vec<Vec<f64>> = Vec::new();
        for &i in &order {
            if basis.len() == self.n {
                break;
            }
            // Gram-Schmidt: keep the row when it adds a direction.
            let (mut g, _) = self.row(w[i].0);
            let norm0 = g.iter().map(|v| v * v).sum::<f64>().sqrt();
            for q in &span {
                let d: f64 = g.iter().zip(q).map(|(a, b)| a * b).sum();
                g.iter_mut().zip(q).for_each(|(a, b)| *a -= d * b);
            }
            let norm = g.iter().map(|v| v * v).sum::<f64>().sqrt();
            if norm > 1e-9 * norm0 {
                g.iter_mut().for_each(|v| *v /= norm);
                span.push(g);
                basis.push(i);
            }
        }
        let fixed: Vec<(Row, f64)> = (0..w.len())
            .filter(|i| !basis.contains(i))
            .map(|i| w[i])
            .collect();
        let basis_rows: Vec<Row> = basis.iter().map(|&i| w[i].0).collect();
        self.farkas_exact(&fixed, &basis_rows)
    }

    /// The certified lower bound of `min c·θ` from an optimal basis.
    pub(super) fn certify(&self, basis: &[Row], u: &[f64], c: &[f64]) -> Certificate {
        let weights: Vec<(Row, f64)> = basis.iter().copied().zip(u.iter().copied()).collect();
        self.certify_weights(&weights, c)
    }

    /// The certified lower bound of `min c·θ` from multipliers on any rows (weak duality:
    /// inequalities clamped at `>= 0`, box rows dropped; the residual is carried).
    pub(super) fn certify_weights(&self, weights: &[(Row, f64)], c: &[f64]) -> Certificate {
        let n = self.n;
        let mut resid: Vec<f64> = c.to_vec();
        let mut mag: Vec<f64> = c.iter().map(|v| v.abs()).collect();
        let (mut dual, mut dual_mag) = (0.0, 0.0);
        for &(b, ub) in weights {
            let (g, h) = self.row(b);
            let w = match b {
                Row::Eq(_) => ub,
                Row::Data(_) => ub.max(0.0),
                // Box rows carry no multiplier at an optimum that is not unbounded.
                Row::Box(..) => 0.0,
            };
            if w == 0.0 {
                continue;
            }
            for k in 0..n {
                resid[k] += w * g[k];
                mag[k] += (w * g[k]).abs();
            }
            dual -= w * h;
            dual_mag += (w * h).abs();
        }
        let k = weights.len() + 1;
        Certificate {
            value: dual - gamma(k) * dual_mag,
            resid: (0..n).map(|j| resid[j].abs() + gamma(k) * mag[j]).collect(),
        }
    }
}

/// Multipliers as a certificate may use them: an inequality's (data or box row) clamped at
/// `>= 0`, an equality's of either sign.
fn clamped(weights: &[(Row, f64)]) -> Vec<(Row, f64)> {
    weights
        .iter()
        .map(|&(r, w)| match r {
            Row::Eq(_) => (r, w),
            _ => (r, w.max(0.0)),
        })
        .collect()
}
