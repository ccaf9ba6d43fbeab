//! The polytope/LP bounding engine: for a polytope `{θ : G θ <= h, E θ = f}` it computes, per
//! coordinate, `min θ_k` and `max θ_k` by linear programming (good_lp modelling, clarabel
//! interior-point backend). Infeasibility is an outcome ([`LpOutcome::Infeasible`]), not an error,
//! as Clarabel's `SolverStatus` reports it.
//!
//! Guarantee: every inequality is relaxed outward by [`ROW_PAD`] before solving and every optimum
//! is widened by [`RESULT_PAD`] afterwards, both far above the solver's tolerances (1e-10), so a
//! reported interval contains the exact one.
use crate::error::{Result, SmidError};
use crate::interval::Interval;
use good_lp::{
    solvers::clarabel::clarabel, Expression, ProblemVariables, ResolutionError, Solution,
    SolverModel, Variable,
};

/// Relative outward relaxation of each right-hand side.
pub const ROW_PAD: f64 = 1e-9;
/// Relative outward widening of each optimum.
pub const RESULT_PAD: f64 = 1e-8;
/// Factor on tolerances and pads when a numerical failure forced the sturdier retry.
const STURDY: f64 = 100.0;

/// A polytope in `R^n` by inequalities and equalities.
#[derive(Debug, Clone, Default)]
pub struct Polytope {
    pub n: usize,
    /// Rows `g·θ <= h`, each tagged with a sample index for diagnostics.
    pub le: Vec<(Vec<f64>, f64, usize)>,
    /// Rows `e·θ = f`.
    pub eq: Vec<(Vec<f64>, f64)>,
}

/// Result of bounding a polytope.
#[derive(Debug, Clone, PartialEq)]
pub enum LpOutcome {
    /// Per-coordinate guaranteed intervals.
    Bounds(Vec<Interval>),
    /// The polytope is empty.
    Infeasible,
}

enum Sense {
    Min,
    Max,
}

impl Polytope {
    /// An empty description in `n` variables.
    pub fn new(n: usize) -> Self {
        Polytope {
            n,
            ..Default::default()
        }
    }

    /// Solve; when clarabel fails numerically, retry once with sturdier settings (looser
    /// tolerances, more regularisation), relaxing rows and widening the optimum 100 times more.
    /// Returns the optimum and whether the retry was needed.
    fn solve(&self, objective: Option<(usize, Sense)>) -> Result<Option<(f64, bool)>> {
        match self.solve_once(objective.as_ref(), false) {
            Err(SmidError::Solver(first)) => match self.solve_once(objective.as_ref(), true) {
                Ok(v) => Ok(v.map(|x| (x, true))),
                Err(SmidError::Solver(second)) => Err(SmidError::Solver(format!(
                    "{first}; retried with sturdier settings: {second}"
                ))),
                Err(e) => Err(e),
            },
            other => other.map(|v| v.map(|x| (x, false))),
        }
    }

    fn solve_once(&self, objective: Option<&(usize, Sense)>, sturdy: bool) -> Result<Option<f64>> {
        let scale = if sturdy { STURDY } else { 1.0 };
        let mut vars = ProblemVariables::new();
        let th: Vec<Variable> = (0..self.n).map(|_| vars.add(good_lp::variable())).collect();
        let obj: Expression = match objective {
            Some((k, Sense::Min)) => th[*k].into(),
            Some((k, Sense::Max)) => -Expression::from(th[*k]),
            None => Expression::from(0.0),
        };
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
        for (g, h, _) in &self.le {
            let h = h + ROW_PAD * scale * (1.0 + h.abs());
            problem = problem.with(lin(g).leq(h));
        }
        for (e, f) in &self.eq {
            problem = problem.with(lin(e).eq(*f));
        }
        match problem.solve() {
            Ok(sol) => {
                use clarabel::solver::SolverStatus as S;
                match sol.inner().status {
                    S::Solved | S::AlmostSolved => {}
                    S::DualInfeasible | S::AlmostDualInfeasible => {
                        return Err(SmidError::Unbounded {
                            parameter: objective.map(|(k, _)| format!("θ[{k}]")).unwrap_or_default(),
                            message: "the linear program is unbounded: the data do not constrain this parameter".into(),
                        })
                    }
                    other => return Err(SmidError::Solver(format!("clarabel stopped with status {other:?}"))),
                }
                Ok(Some(match objective {
                    Some((k, _)) => sol.value(th[*k]),
                    None => 0.0,
                }))
            }
            Err(ResolutionError::Infeasible) => Ok(None),
            Err(e) => Err(SmidError::Solver(e.to_string())),
        }
    }

    /// Whether the polytope is non-empty.
    pub fn feasible(&self) -> Result<bool> {
        Ok(self.solve(None)?.is_some())
    }

    /// Guaranteed bounds of every coordinate in `which` (others are left as the whole line).
    pub fn bound(&self, which: &[usize]) -> Result<LpOutcome> {
        let mut out = vec![Interval::entire(); self.n];
        for &k in which {
            let (lo, s1) = match self.solve(Some((k, Sense::Min)))? {
                Some(v) => v,
                None => return Ok(LpOutcome::Infeasible),
            };
            let (hi, s2) = match self.solve(Some((k, Sense::Max)))? {
                Some(v) => v,
                None => return Ok(LpOutcome::Infeasible),
            };
            let pad = RESULT_PAD * if s1 || s2 { STURDY } else { 1.0 };
            out[k] = Interval::new(lo.min(hi), hi.max(lo)).widen(pad, pad);
        }
        Ok(LpOutcome::Bounds(out))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    #[test]
    fn box_with_diagonal_cut() {
        // 0 <= x, y <= 1, x + y <= 1.5
        let mut p = Polytope::new(2);
        p.le.push((vec![-1.0, 0.0], 0.0, 0));
        p.le.push((vec![0.0, -1.0], 0.0, 0));
        p.le.push((vec![1.0, 0.0], 1.0, 0));
        p.le.push((vec![0.0, 1.0], 1.0, 0));
        p.le.push((vec![1.0, 1.0], 1.5, 0));
        p.eq.push((vec![1.0, -1.0], 0.0));
        match p.bound(&[0, 1]).unwrap() {
            LpOutcome::Bounds(b) => {
                assert!(b[0].contains(0.0) && b[0].contains(0.75));
                assert!(
                    (b[0].hi - 0.75).abs() < 1e-6 && b[0].lo.abs() < 1e-6,
                    "{b:?}"
                );
            }
            LpOutcome::Infeasible => panic!("feasible"),
        }
        p.le.push((vec![-1.0, 0.0], -2.0, 9));
        assert_eq!(p.bound(&[0]).unwrap(), LpOutcome::Infeasible);
        assert!(!p.feasible().unwrap());
    }
}
