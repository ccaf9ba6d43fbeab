//! The local searches of the member search: Nelder-Mead (argmin) with an optional give-up,
//! and Levenberg-Marquardt kept inside a box.
use crate::interval::Interval;
use argmin::core::{CostFunction, Error as ArgminError, Executor, State};
use argmin::solver::neldermead::NelderMead;
use std::cell::Cell;

/// A cost for argmin from a closure (non-finite values count as `+inf`), with an optional
/// give-up: after `.0` evaluations whose best is still above `.1`, the run is abandoned.
struct Cost<'f> {
    f: &'f dyn Fn(&[f64]) -> f64,
    give_up: Option<(usize, f64)>,
    seen: Cell<(usize, f64)>,
}

impl CostFunction for Cost<'_> {
    type Param = Vec<f64>;
    type Output = f64;
    fn cost(&self, p: &Self::Param) -> std::result::Result<f64, ArgminError> {
        let v = (self.f)(p);
        let v = if v.is_nan() { f64::INFINITY } else { v };
        let (n, best) = self.seen.get();
        let seen = (n + 1, best.min(v));
        self.seen.set(seen);
        match self.give_up {
            Some((after, above)) if seen.0 >= after && seen.1 > above => Err(ArgminError::msg(
                format!("best {:.3e} after {} evaluations: given up", seen.1, seen.0),
            )),
            _ => Ok(v),
        }
    }
}

/// Nelder-Mead from `z0` with steps `step` along each axis: the best point and its cost.
pub(crate) fn nelder_mead(
    f: &dyn Fn(&[f64]) -> f64,
    z0: &[f64],
    step: f64,
    iterations: u64,
    target: f64,
) -> Option<(Vec<f64>, f64)> {
    nelder_mead_or_give_up(f, z0, step, iterations, target, None)
}

/// [`nelder_mead`] that gives up (`None`) once `give_up = (n, level)` holds: `n` evaluations
/// made and the best still above `level`.
pub(super) fn nelder_mead_or_give_up(
    f: &dyn Fn(&[f64]) -> f64,
    z0: &[f64],
    step: f64,
    iterations: u64,
    target: f64,
    give_up: Option<(usize, f64)>,
) -> Option<(Vec<f64>, f64)> {
    let f0 = f(z0);
    if z0.is_empty() || f0 <= target {
        return Some((z0.to_vec(), f0));
    }
    let mut simplex = vec![z0.to_vec()];
    for d in 0..z0.len() {
        let mut v = z0.to_vec();
        v[d] += step;
        simplex.push(v);
    }
    let solver = NelderMead::new(simplex).with_sd_tolerance(1e-12).ok()?;
    let cost = Cost {
        f,
        give_up,
        seen: Cell::new((1, f0)),
    };
    let res = Executor::new(cost, solver)
        .configure(|s| s.max_iters(iterations).target_cost(target))
        .run()
        .ok()?;
    let st = res.state();
    let best = st.get_best_param()?.clone();
    let c = st.get_best_cost();
    (c <= f0).then_some((best, c)).or(Some((z0.to_vec(), f0)))
}

/// Levenberg-Marquardt (the `levenberg-marquardt` crate, MINPACK's method) on the residual
/// vector `f(z)`, from `z0`, kept inside `bounds` by the transform `z = c + r·sin(w)` on each
/// finite bound (a coordinate without one is free). A point where `f` is `None`, or not finite,
/// gets residuals ten times the start's norm, so a step there is refused. The Jacobian is by
/// forward differences. The best point and its sum of squares, `None` when the start has no
/// residuals.
pub(crate) fn least_squares_in_box(
    f: &dyn Fn(&[f64]) -> Option<Vec<f64>>,
    z0: &[f64],
    bounds: &[Interval],
) -> Option<(Vec<f64>, f64)> {
    use levenberg_marquardt::{LeastSquaresProblem, LevenbergMarquardt};
    use nalgebra::{DMatrix, DVector, Dyn, Owned};
    let r0 = f(z0).filter(|r| r.iter().all(|v| v.is_finite()) && !r.is_empty())?;
    if z0.is_empty() {
        return None;
    }
    let finite = |b: &Interval| b.lo.is_finite() && b.hi.is_finite() && b.hi > b.lo;
    let to_z = |w: &[f64]| -> Vec<f64> {
        w.iter()
            .zip(bounds)
            .map(|(&w, b)| {
                if finite(b) {
                    (b.center() + b.radius() * w.sin()).clamp(b.lo, b.hi)
                } else {
                    w
                }
            })
            .collect()
    };
    let w0: Vec<f64> = z0
        .iter()
        .zip(bounds)
        .map(|(&z, b)| {
            if finite(b) {
                ((z - b.center()) / b.radius()).clamp(-1.0, 1.0).asin()
            } else {
                z
            }
        })
        .collect();
    let big = 10.0
        * (r0.iter().map(|v| v * v).sum::<f64>() / r0.len() as f64)
            .sqrt()
            .max(1e-300);
    let m = r0.len();
    let eval = |w: &[f64]| -> DVector<f64> {
        match f(&to_z(w)) {
            Some(r) if r.len() == m => DVector::from_iterator(
                m,
                r.into_iter().map(|v| if v.is_finite() { v } else { big }),
            ),
            _ => DVector::from_element(m, big),
        }
    };
    struct Problem<'e> {
        eval: &'e dyn Fn(&[f64]) -> DVector<f64>,
        w: DVector<f64>,
    }
    impl LeastSquaresProblem<f64, Dyn, Dyn> for Problem<'_> {
        type ResidualStorage = Owned<f64, Dyn>;
        type JacobianStorage = Owned<f64, Dyn, Dyn>;
        type ParameterStorage = Owned<f64, Dyn>;
        fn set_params(&mut self, w: &DVector<f64>) {
            self.w.copy_from(w);
        }
        fn params(&self) -> DVector<f64> {
            self.w.clone()
        }
        fn residuals(&self) -> Option<DVector<f64>> {
            Some((self.eval)(self.w.as_slice()))
        }
        fn jacobian(&self) -> Option<DMatrix<f64>> {
            let r = (self.eval)(self.w.as_slice());
            let mut j = DMatrix::zeros(r.len(), self.w.len());
            for k in 0..self.w.len() {
                let mut w = self.w.clone();
                let h = 1e-5 * w[k].abs().max(1.0);
                w[k] += h;
                let rk = (self.eval)(w.as_slice());
                j.set_column(k, &((rk - &r) / h));
            }
            Some(j)
        }
    }
    let (solved, report) = LevenbergMarquardt::new()
        .with_patience(50)
        .minimize(Problem {
            eval: &eval,
            w: DVector::from_vec(w0),
        });
    let z = to_z(solved.w.as_slice());
    let e2: f64 = f(&z)?.iter().map(|v| v * v).sum();
    log::debug!(target: "smid::members", "Levenberg-Marquardt: {:?} after {} evaluations, sum of squares {:.4e} from {:.4e}", report.termination, report.number_of_evaluations, e2, r0.iter().map(|v| v * v).sum::<f64>());
    e2.is_finite().then_some((z, e2))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A bowl whose minimum is `floor`, at (1, -2).
    fn bowl(floor: f64) -> impl Fn(&[f64]) -> f64 {
        move |z: &[f64]| floor + (z[0] - 1.0).powi(2) + (z[1] + 2.0).powi(2)
    }

    #[test]
    fn a_run_that_stays_above_the_level_gives_up_and_one_that_falls_below_does_not() {
        let z0 = [0.0, 0.0];
        // The bowl's floor lies above the level: abandoned after the given evaluations.
        let far = bowl(1.0);
        assert!(nelder_mead_or_give_up(&far, &z0, 0.1, 150, -1.0, Some((30, 0.5))).is_none());
        // Without a give-up the same run ends near its floor.
        let (_, v) = nelder_mead(&far, &z0, 0.1, 150, -1.0).expect("the run ends");
        assert!((v - 1.0).abs() < 1e-3, "{v}");
        // A run whose best lies below the level is never abandoned, however long it takes.
        let near = bowl(-0.5);
        let count = Cell::new(0usize);
        let counted = |z: &[f64]| {
            count.set(count.get() + 1);
            near(z)
        };
        let (_, v) = nelder_mead_or_give_up(
            &counted,
            &[0.37, -1.23],
            0.1,
            150,
            -0.5 + 1e-12,
            Some((30, 0.5)),
        )
        .expect("not given up");
        assert!(count.get() > 30, "the run took {} evaluations", count.get());
        assert!(v < -0.499, "{v}");
    }

    /// Rosenbrock's valley as residuals: least squares at (1, 1).
    fn valley(z: &[f64]) -> Option<Vec<f64>> {
        Some(vec![1.0 - z[0], 10.0 * (z[1] - z[0] * z[0])])
    }

    #[test]
    fn levenberg_marquardt_crosses_a_curved_valley_and_keeps_to_its_box() {
        let wide = [Interval::new(-5.0, 5.0), Interval::new(-5.0, 5.0)];
        let (z, e2) = least_squares_in_box(&valley, &[-1.2, 1.0], &wide).expect("a start");
        assert!(
            (z[0] - 1.0).abs() < 1e-6 && (z[1] - 1.0).abs() < 1e-6,
            "{z:?}"
        );
        assert!(e2 < 1e-12, "{e2}");
        // The minimum outside the box: the best point of the box, on its edge.
        let boxed = [Interval::new(-5.0, 0.5), Interval::new(-5.0, 5.0)];
        let (z, e2) = least_squares_in_box(&valley, &[-1.2, 1.0], &boxed).expect("a start");
        assert!(z[0] <= 0.5 && (z[0] - 0.5).abs() < 1e-4, "{z:?}");
        assert!(
            (z[1] - 0.25).abs() < 1e-3 && (e2 - 0.25).abs() < 1e-6,
            "{z:?} {e2}"
        );
        // A region without residuals (a run that diverges) is stepped around, never returned.
        let holed = |z: &[f64]| (z[1] <= 1.5).then(|| valley(z)).flatten();
        let (z, _) = least_squares_in_box(&holed, &[-1.2, 1.0], &wide).expect("a start");
        assert!(z[1] <= 1.5, "{z:?}");
        // No residuals at the start: no search.
        assert!(least_squares_in_box(&holed, &[0.0, 2.0], &wide).is_none());
    }
}
