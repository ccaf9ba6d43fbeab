//! The stand-in when no point is certified: the best free run over a cell's outer bounds, by
//! Nelder-Mead and, in a thorough search, Levenberg-Marquardt chained with it.
use super::optimise::{least_squares_in_box, nelder_mead};
use super::space::{split_values, CellSpace, Search};
use super::Options;
use crate::interval::Interval;
use crate::model::SimulationMember;

impl Search<'_> {
    /// When no point is certified: the best free run over the cell's **outer** bounds (the
    /// cell's point moved inside the cell, every free `θ_i` inside the cell's `θ` interval),
    /// from the centre, by the same Nelder-Mead. Not certified, and marked so: a stand-in for
    /// free runs that simulates at least as well as the centre, never a claim that the set
    /// holds it.
    pub(super) fn best_uncertified(
        &self,
        sp: &CellSpace,
        opts: &Options,
        centre: &[(String, f64)],
        thorough: bool,
    ) -> Option<(f64, SimulationMember)> {
        // From the central member's θ, and from θ refitted by least squares with the regressors
        // read at the inner-signal estimates themselves (`theta_reproducing`: an output
        // velocity's sign where the centre's interval column says "may not have moved", as on
        // EMPS), each clamped into this cell's bounds; the better run stands in.
        let (_, from_centre) = split_values(self, sp, centre);
        // With `model.feedback` the warm-start data are the measured outputs, not the linear
        // block's: no refit from them.
        let refit: Option<Vec<f64>> = (!self.set.model.feedback)
            .then(|| {
                crate::members::theta_reproducing(
                    self.set,
                    &self.values_of(sp, &sp.base, &from_centre),
                    &self.x_warm,
                )
                .ok()
                .flatten()
            })
            .flatten()
            .map(|(v, _)| v.into_iter().map(|(_, x)| x).collect());
        [Some(from_centre), refit]
            .into_iter()
            .flatten()
            .filter_map(|start| self.uncertified_from(sp, opts, &start, thorough))
            .min_by(|a, b| a.0.total_cmp(&b.0))
    }

    /// [`Self::best_uncertified`] from one start `θ`: one Nelder-Mead run, or with `thorough`
    /// the better of two chained local searches.
    fn uncertified_from(
        &self,
        sp: &CellSpace,
        opts: &Options,
        start: &[f64],
        thorough: bool,
    ) -> Option<(f64, SimulationMember)> {
        let split = sp.moved.len();
        let gain = self.gain_slot();
        let mut theta0: Vec<f64> = start
            .iter()
            .zip(&sp.cell.theta)
            .map(|(v, b)| {
                if v.is_finite() {
                    v.clamp(b.lo, b.hi)
                } else {
                    b.center()
                }
            })
            .collect();
        self.fix_gain(&mut theta0);
        let t_free: Vec<usize> = (0..self.layout.p())
            .filter(|&i| self.layout.fixed[i].is_none() && Some(i) != gain)
            .collect();
        let t_scale: Vec<f64> = t_free.iter().map(|&i| sp.theta_scale(i, &theta0)).collect();
        let point_of = |z: &[f64]| -> Option<(Vec<f64>, Vec<f64>)> {
            if z[..split].iter().any(|v| v.abs() > 1.0) {
                return None;
            }
            let g = sp.at(&sp.base, &z[..split]);
            let mut th = theta0.clone();
            for ((&i, s), zi) in t_free.iter().zip(&t_scale).zip(&z[split..]) {
                th[i] = theta0[i] + s * zi;
            }
            self.fix_gain(&mut th);
            // A declared stable block: a point whose poles leave the unit circle stands for
            // its stable projection (the roots outside moved onto the circle's inside), so
            // the search can lie along the boundary where an integrator's optimum sits (EMPS)
            // instead of stopping at a wall. A declared (fixed) `a` keeps the wall.
            let na = self.layout.orders.na;
            if self.set.model.stable
                && (0..na).all(|i| self.layout.fixed[i].is_none())
                && crate::linear::spectral_radius(&th[..na]) > 1.0
            {
                let a = crate::linear::stable_projection(&th[..na])?;
                th[..na].copy_from_slice(&a);
                self.fix_gain(&mut th);
            }
            th.iter()
                .zip(&sp.cell.theta)
                .all(|(v, b)| b.contains(*v))
                .then_some((g, th))
        };
        // A declared stable block keeps its stand-in stable (a pole outside the unit circle
        // fits the training records and drifts on fresh ones).
        let na = self.layout.orders.na;
        let unstable =
            |th: &[f64]| self.set.model.stable && crate::linear::spectral_radius(&th[..na]) > 1.0;
        let cost = |z: &[f64]| -> f64 {
            match point_of(z) {
                Some((_, th)) if unstable(&th) => f64::INFINITY,
                Some((g, th)) => self.sse(&self.values_of(sp, &g, &th)),
                None => f64::INFINITY,
            }
        };
        // Two local searches from the start, the better kept (on EMPS each wins on some
        // cells): Nelder-Mead, restarted from its best with a fresh, smaller simplex (a
        // collapsed one stalls) for the spec's restarts until a run gains less than a
        // thousandth, then Levenberg-Marquardt on the free-run errors themselves; and
        // Levenberg-Marquardt first (a Gauss-Newton step crosses an integrator's valley that
        // a simplex crawls along), then the restarted Nelder-Mead (the kinks of a friction's
        // sign stop Gauss-Newton).
        let bounds: Vec<Interval> = (0..split)
            .map(|_| Interval::new(-1.0, 1.0))
            .chain(t_free.iter().zip(&t_scale).map(|(&i, s)| {
                let b = sp.cell.theta[i];
                Interval::new((b.lo - theta0[i]) / s, (b.hi - theta0[i]) / s)
            }))
            .collect();
        let errors = |z: &[f64]| -> Option<Vec<f64>> {
            match point_of(z) {
                Some((_, th)) if unstable(&th) => None,
                Some((g, th)) => self.residuals(&self.values_of(sp, &g, &th)),
                None => None,
            }
        };
        let simplex = |mut z: Vec<f64>, mut e2: f64| -> (Vec<f64>, f64) {
            let mut step = 0.05;
            for _ in 0..opts.restarts.max(1) {
                let Some((zn, en)) =
                    nelder_mead(&cost, &z, step, opts.iterations, f64::NEG_INFINITY)
                else {
                    break;
                };
                let gained = e2 - en;
                if en < e2 {
                    z = zn;
                    e2 = en;
                }
                if !(gained > 1e-3 * e2.abs()) {
                    break;
                }
                step *= 0.5;
            }
            (z, e2)
        };
        let gauss = |z: Vec<f64>, e2: f64| -> (Vec<f64>, f64) {
            match least_squares_in_box(&errors, &z, &bounds) {
                Some((zl, el)) if el < e2 => (zl, el),
                _ => (z, e2),
            }
        };
        let z0 = vec![0.0; split + t_free.len()];
        // The quick search, and a ranking search's (the diagnosis's candidates, compared by
        // fit), is one Nelder-Mead run: the two local searches cost several times as much on
        // input-side candidates, and a diagnosis searches a member for every candidate.
        if !thorough {
            let (z, e2) = nelder_mead(&cost, &z0, 0.05, opts.iterations, f64::NEG_INFINITY)?;
            return self.stand_in(sp, &point_of, &z, e2);
        }
        let e0 = cost(&z0);
        let (za, ea) = {
            let (z, e) = simplex(z0.clone(), e0);
            gauss(z, e)
        };
        let (zb, eb) = {
            let (z, e) = gauss(z0, e0);
            simplex(z, e)
        };
        let (z, e2) = if eb < ea { (zb, eb) } else { (za, ea) };
        self.stand_in(sp, &point_of, &z, e2)
    }

    /// The uncertified stand-in at search coordinates `z` with squared error `e2`.
    fn stand_in(
        &self,
        sp: &CellSpace,
        point_of: &dyn Fn(&[f64]) -> Option<(Vec<f64>, Vec<f64>)>,
        z: &[f64],
        e2: f64,
    ) -> Option<(f64, SimulationMember)> {
        let (g, th) = point_of(z)?;
        e2.is_finite().then(|| {
            (
                e2,
                SimulationMember {
                    values: self.values_of(sp, &g, &th),
                    cell: sp.k,
                    consistency: self.certify(sp, &g, &th),
                    training_fit: self.fit(e2),
                    centre_training_fit: f64::NAN,
                    evaluations: 0,
                    envelope: Vec::new(),
                    certified: false,
                    within: None,
                },
            )
        })
    }
}
