//! The dense dual simplex of the polytope engine: the starting basis, the pivots, and the
//! basis algebra (vertex, multipliers, LU factors of the basis transpose).
use super::{Polytope, Row, THETA_MAX};
use nalgebra::{DMatrix, DVector};

/// LU factors of a basis matrix's transpose.
type LuT = nalgebra::linalg::LU<f64, nalgebra::Dyn, nalgebra::Dyn>;

/// What the simplex concluded for one objective.
pub(super) enum Simplex {
    /// Optimal basis with its multipliers (`u` per basis row).
    Optimal { basis: Vec<Row>, u: Vec<f64> },
    /// Emptiness proven over the artificial box.
    Infeasible,
    /// The optimum rests on the artificial box.
    Unbounded,
    /// No conclusion (cap, singular basis, unproven emptiness): use the interior-point path.
    Unknown,
}

impl Simplex {
    /// Whether a zero-objective run found the polytope non-empty (`None`: no conclusion).
    pub(super) fn feasibility(&self) -> Option<bool> {
        match self {
            Simplex::Optimal { .. } | Simplex::Unbounded => Some(true),
            Simplex::Infeasible => Some(false),
            Simplex::Unknown => None,
        }
    }

    /// [`Simplex::Unknown`], saying why at debug level (`SMID_LOG=debug`).
    fn unknown(why: &str) -> Simplex {
        log::debug!("dual simplex: no conclusion ({why})");
        Simplex::Unknown
    }
}

impl Polytope {
    /// The dual simplex for `min c·θ` (`c = 0`: feasibility).
    pub(super) fn simplex(&self, c: &[f64]) -> Simplex {
        let n = self.n;
        let m = self.rows();
        if n == 0 {
            return self.simplex_trivial();
        }
        let Some(mut basis) = self.starting_basis() else {
            return Simplex::unknown("dependent equalities");
        };
        // Box signs so that the starting multipliers are >= 0.
        let Some(mut u) = Self::multipliers_lu(&self.lu_t(&basis), c) else {
            return Simplex::unknown("singular starting basis");
        };
        for (b, ub) in basis.iter_mut().zip(u.iter_mut()) {
            if let Row::Box(k, neg) = *b {
                if *ub < 0.0 {
                    *b = Row::Box(k, !neg);
                    *ub = -*ub;
                }
            }
        }
        let norms: Vec<f64> = (0..m)
            .map(|i| self.grow(i).iter().map(|v| v * v).sum::<f64>().sqrt())
            .collect();
        let cap = 50 * n + 100;
        // The factors of `G_Bᵀ` for the current basis, kept from the multipliers after a pivot
        // for the next iteration's entering row (the same matrix, the same factors).
        let mut factors: Option<LuT> = None;
        for _ in 0..cap {
            let Some(x) = self.vertex(&basis) else {
                return Simplex::unknown("singular basis (vertex)");
            };
            let enter =
                match self.most_violated(&x, &norms) {
                    Ok(Some(enter)) => enter,
                    Ok(None) => {
                        // Primal feasible and dual feasible: optimal.
                        if basis.iter().zip(&u).any(|(b, &ub)| {
                            matches!(b, Row::Box(..)) && ub > 1e-9 * (1.0 + norm1(c))
                        }) {
                            return Simplex::Unbounded;
                        }
                        return Simplex::Optimal { basis, u };
                    }
                    Err(conclusion) => return conclusion,
                };
            // Express the entering row in the basis: G_Bᵀ v = g_enter.
            let (ge, _) = self.row(enter);
            let lu = factors.take().unwrap_or_else(|| self.lu_t(&basis));
            let Some(v) = Self::solve_lu_t(&lu, &ge) else {
                return Simplex::unknown("singular basis (entering row)");
            };
            match Self::leaving(&basis, &u, &v) {
                None => {
                    // Farkas: g_enter - Σ v_i g_i = 0 with -v_i >= 0 on the inequalities.
                    return if self.farkas_proves(&basis, &v, enter) {
                        Simplex::Infeasible
                    } else {
                        Simplex::unknown("an emptiness the Farkas combination cannot prove")
                    };
                }
                Some(idx) => {
                    basis[idx] = enter;
                    let lu = self.lu_t(&basis);
                    match Self::multipliers_lu(&lu, c) {
                        Some(nu) => u = nu,
                        None => return Simplex::unknown("singular basis (multipliers)"),
                    }
                    factors = Some(lu);
                    // Rounding may leave tiny negative multipliers: they are clamped in the
                    // certificate (which accounts for the residual they leave).
                }
            }
        }
        Simplex::unknown("iteration cap")
    }

    /// The simplex's starting basis: the equalities, completed to a basis by box rows on the
    /// coordinates that Gaussian elimination of E leaves without a pivot. `None` when the
    /// equalities are dependent.
    fn starting_basis(&self) -> Option<Vec<Row>> {
        let n = self.n;
        let q = self.f.len();
        let mut basis: Vec<Row> = (0..q).map(Row::Eq).collect();
        let mut a = DMatrix::<f64>::zeros(q, n);
        for j in 0..q {
            for k in 0..n {
                a[(j, k)] = self.e[j * n + k];
            }
        }
        let mut pivoted = vec![false; n];
        let mut r = 0;
        for col in 0..n {
            if r == q {
                break;
            }
            let (p, v) = (r..q)
                .map(|i| (i, a[(i, col)].abs()))
                .fold((r, 0.0), |b, x| if x.1 > b.1 { x } else { b });
            if v <= 1e-12 {
                continue;
            }
            a.swap_rows(r, p);
            for i in r + 1..q {
                let f = a[(i, col)] / a[(r, col)];
                for k in col..n {
                    let t = a[(r, k)];
                    a[(i, k)] -= f * t;
                }
            }
            pivoted[col] = true;
            r += 1;
        }
        if r < q {
            return None;
        }
        basis.extend((0..n).filter(|&k| !pivoted[k]).map(|k| Row::Box(k, false)));
        Some(basis)
    }

    /// The row that enters at the vertex `x`: the most violated one (normalised by the row
    /// norms `norms`), data rows and then the box; `Ok(None)` when every row holds, `Err` with
    /// the conclusion when a zero row proves the polytope empty.
    fn most_violated(&self, x: &[f64], norms: &[f64]) -> Result<Option<Row>, Simplex> {
        let mut best: Option<(Row, f64)> = None;
        let xmax = x.iter().fold(0.0f64, |a, v| a.max(v.abs()));
        for i in 0..self.rows() {
            let g = self.grow(i);
            let hi = self.hp(i, 1.0);
            let lhs: f64 = g.iter().zip(x).map(|(a, b)| a * b).sum();
            let viol = lhs - hi;
            if norms[i] == 0.0 {
                if hi < 0.0 {
                    // `0 <= h < 0`: empty, whatever θ.
                    return Err(Simplex::Infeasible);
                }
                continue;
            }
            let tol = 1e-12 * (1.0 + hi.abs() + norms[i] * xmax);
            if viol > tol {
                let s = viol / norms[i];
                if best.is_none_or(|b| s > b.1) {
                    best = Some((Row::Data(i), s));
                }
            }
        }
        for (k, &xk) in x.iter().enumerate() {
            if xk.abs() > THETA_MAX * (1.0 + 1e-9) {
                let s = xk.abs() - THETA_MAX;
                if best.is_none_or(|b| s > b.1) {
                    best = Some((Row::Box(k, xk < 0.0), s));
                }
            }
        }
        Ok(best.map(|(row, _)| row))
    }

    /// The ratio test over the inequality rows of the basis: the index of the row that leaves
    /// for an entering row expressed in the basis as `v` (multipliers `u`); `None` when no row
    /// can leave (the entering row and the basis then combine to a Farkas proof).
    fn leaving(basis: &[Row], u: &[f64], v: &[f64]) -> Option<usize> {
        let vmax = v.iter().fold(0.0f64, |a, b| a.max(b.abs()));
        let mut leave: Option<(usize, f64, f64)> = None;
        for (idx, (&b, &vi)) in basis.iter().zip(v).enumerate() {
            if matches!(b, Row::Eq(_)) || vi <= 1e-12 * vmax.max(1.0) {
                continue;
            }
            let t = u[idx].max(0.0) / vi;
            let better = match leave {
                None => true,
                Some((_, bt, bv)) => t < bt - 1e-15 * bt.abs() || (t <= bt && vi > bv),
            };
            if better {
                leave = Some((idx, t, vi));
            }
        }
        leave.map(|(idx, _, _)| idx)
    }

    /// `n = 0`: the polytope is `{()}` when every row holds, else empty.
    fn simplex_trivial(&self) -> Simplex {
        let ok = (0..self.rows()).all(|i| self.hp(i, 1.0) >= 0.0)
            && self.f.iter().all(|f| f.abs() <= 1e-12);
        if ok {
            Simplex::Optimal {
                basis: Vec::new(),
                u: Vec::new(),
            }
        } else {
            Simplex::Infeasible
        }
    }

    fn basis_matrix(&self, basis: &[Row]) -> (DMatrix<f64>, DVector<f64>) {
        let n = self.n;
        let mut a = DMatrix::<f64>::zeros(n, n);
        let mut b = DVector::<f64>::zeros(n);
        for (r, &row) in basis.iter().enumerate() {
            let (g, h) = self.row(row);
            for k in 0..n {
                a[(r, k)] = g[k];
            }
            b[r] = h;
        }
        (a, b)
    }

    /// The vertex of the basis: `G_B θ = h_B`.
    pub(super) fn vertex(&self, basis: &[Row]) -> Option<Vec<f64>> {
        let (a, b) = self.basis_matrix(basis);
        let x = a.lu().solve(&b)?;
        x.iter()
            .all(|v| v.is_finite())
            .then(|| x.iter().copied().collect())
    }

    /// The LU factors of `G_Bᵀ`.
    fn lu_t(&self, basis: &[Row]) -> LuT {
        let (a, _) = self.basis_matrix(basis);
        a.transpose().lu()
    }

    /// `G_Bᵀ y = rhs` from the factors of `G_Bᵀ` ([`Self::lu_t`]).
    fn solve_lu_t(lu: &LuT, rhs: &[f64]) -> Option<Vec<f64>> {
        let y = lu.solve(&DVector::from_column_slice(rhs))?;
        y.iter()
            .all(|v| v.is_finite())
            .then(|| y.iter().copied().collect())
    }

    /// The multipliers of the basis for `min c·θ` (`G_Bᵀ u = -c`) from the factors of `G_Bᵀ`.
    fn multipliers_lu(lu: &LuT, c: &[f64]) -> Option<Vec<f64>> {
        let neg: Vec<f64> = c.iter().map(|v| -v).collect();
        Self::solve_lu_t(lu, &neg)
    }
}

fn norm1(c: &[f64]) -> f64 {
    c.iter().map(|v| v.abs()).sum()
}
