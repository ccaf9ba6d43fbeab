//! The interior-point path of the polytope engine (good_lp + clarabel), whose multipliers go
//! through the same certificates as the simplex's.
use super::{unbounded, Certificate, LpOutcome, Polytope, Row, Sense, STURDY};
use crate::error::{Result, SmidError};
use good_lp::{solvers::clarabel::clarabel, Expression, ProblemVariables, SolverModel, Variable};

impl Polytope {
    /// Bounds by the interior-point path (good_lp + clarabel), for what the simplex cannot
    /// conclude. Clarabel's multipliers are certified as the simplex's are (weak duality with
    /// the residual carried), so its bounds are certificates too.
    pub fn clarabel_bounds(&self) -> Result<LpOutcome> {
        let mut certs: Vec<[Certificate; 2]> = Vec::with_capacity(self.n);
        for k in 0..self.n {
            let mut pair = Vec::with_capacity(2);
            for sense in [Sense::Min, Sense::Max] {
                match self.clarabel(Some((k, sense)))? {
                    Ipm::Bound(c) => pair.push(c),
                    Ipm::Empty => return Ok(LpOutcome::Infeasible),
                    Ipm::Feasible => unreachable!("an objective gives a bound"),
                }
            }
            let hi = pair.pop().expect("two sides");
            let lo = pair.pop().expect("two sides");
            certs.push([lo, hi]);
        }
        Self::bounds_from(&certs)
            .map(LpOutcome::Bounds)
            .ok_or_else(|| {
                SmidError::Solver(
                    "the interior-point multipliers leave too large a residual to certify a bound"
                        .into(),
                )
            })
    }

    /// Solve by clarabel; when it fails numerically, retry once with sturdier settings
    /// (looser tolerances, more regularisation, rows relaxed 100 times more: the multipliers
    /// are certified against the rows as they are, whatever problem produced them).
    pub(super) fn clarabel(&self, objective: Option<(usize, Sense)>) -> Result<Ipm> {
        match self.clarabel_once(objective, false) {
            Err(SmidError::Solver(first)) => match self.clarabel_once(objective, true) {
                Err(SmidError::Solver(second)) => Err(SmidError::Solver(format!(
                    "{first}; retried with sturdier settings: {second}"
                ))),
                other => other,
            },
            other => other,
        }
    }

    fn clarabel_once(&self, objective: Option<(usize, Sense)>, sturdy: bool) -> Result<Ipm> {
        use clarabel::solver::{IPSolver, SolverStatus as S};
        let scale = if sturdy { STURDY } else { 1.0 };
        let mut vars = ProblemVariables::new();
        let th: Vec<Variable> = (0..self.n).map(|_| vars.add(good_lp::variable())).collect();
        let mut c = vec![0.0; self.n];
        if let Some((k, sense)) = objective {
            c[k] = match sense {
                Sense::Min => 1.0,
                Sense::Max => -1.0,
            };
        }
        let obj: Expression = c.iter().zip(&th).map(|(ck, v)| *ck * *v).sum();
        let lin = |coefs: &[f64]| -> Expression {
            coefs
                .iter()
                .zip(&th)
                .filter(|(c, _)| **c != 0.0)
                .map(|(c, v)| *c * *v)
                .sum()
        };
        let mut problem = clarabel(vars.minimise(obj));
        let tol = 1e-10 * scale;
        problem
            .settings()
            .tol_gap_abs(tol)
            .tol_gap_rel(tol)
            .tol_feas(tol)
            .max_iter(if sturdy { 2000 } else { 400 });
        if sturdy {
            problem
                .settings()
                .static_regularization_constant(1e-7)
                .equilibrate_max_iter(50);
        }
        // Rows in order: the inequalities, then the equalities (clarabel's `z` follows them).
        for i in 0..self.rows() {
            problem = problem.with(lin(self.grow(i)).leq(self.hp(i, scale)));
        }
        for j in 0..self.f.len() {
            problem = problem.with(lin(self.erow(j)).eq(self.f[j]));
        }
        let mut solver = problem
            .try_into_solver()
            .map_err(|e| SmidError::Solver(e.to_string()))?;
        solver.solve();
        let sol = &solver.solution;
        let m = self.rows();
        let weights = || -> Vec<(Row, f64)> {
            (0..m)
                .map(|i| (Row::Data(i), sol.z[i]))
                .chain((0..self.f.len()).map(|j| (Row::Eq(j), sol.z[m + j])))
                .collect()
        };
        if sol.z.len() != m + self.f.len() {
            return Err(SmidError::Solver(format!(
                "clarabel returned {} multipliers for {} rows",
                sol.z.len(),
                m + self.f.len()
            )));
        }
        match sol.status {
            S::Solved | S::AlmostSolved => Ok(match objective {
                None => Ipm::Feasible,
                Some(_) => Ipm::Bound(self.certify_weights(&weights(), &c)),
            }),
            S::PrimalInfeasible | S::AlmostPrimalInfeasible => {
                if self.farkas_multipliers_prove(&weights()) {
                    Ok(Ipm::Empty)
                } else {
                    Err(SmidError::Solver(format!(
                        "clarabel stopped with status {:?} but its multipliers do not prove the polytope empty",
                        sol.status
                    )))
                }
            }
            S::DualInfeasible | S::AlmostDualInfeasible => {
                Err(unbounded(objective.map_or(0, |(k, _)| k)))
            }
            other => Err(SmidError::Solver(format!(
                "clarabel stopped with status {other:?}"
            ))),
        }
    }
}

/// What the interior-point path concluded.
pub(super) enum Ipm {
    /// A certified side of the objective.
    Bound(Certificate),
    /// Solved without an objective (feasibility): nothing proven empty.
    Feasible,
    /// Emptiness proven by clarabel's Farkas multipliers.
    Empty,
}
