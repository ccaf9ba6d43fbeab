//! The certified search of one cell: phase 1 (Nelder-Mead on the phase-1 measure to a
//! certified point, a stable one where the model is declared stable), phase 2 (the best free
//! run with the uncertified points as an extreme barrier), and the certified members spread
//! around the member found.
use super::optimise::{nelder_mead, nelder_mead_or_give_up};
use super::space::{CellSpace, Search};
use super::{extreme_at_a, Options, CERTIFIED};
use crate::model::SimulationMember;
use std::cell::Cell;
use std::sync::atomic::Ordering::Relaxed;

impl Search<'_> {
    /// The best certified member of one cell: `(squared error, member)`, and the phase-1
    /// measure its last run ended with (`+inf` when it was given up).
    ///
    /// In a ranking search ([`Options::gives_up_early`]) phase 1 gives up on a first run still
    /// above `opts.hopeless` after `opts.hopeless_after` evaluations, and after a run whose measure
    /// stays above `opts.far` ([`Options::far`]).
    pub(super) fn search(
        &self,
        sp: &CellSpace,
        opts: &Options,
    ) -> (Option<(f64, SimulationMember)>, f64) {
        let last = Cell::new(f64::INFINITY);
        let z0 = vec![0.0; sp.moved.len() + self.a_free().len()];
        let found = self
            .certified_point(sp, opts, &last, z0)
            .and_then(|(g, th)| self.best_certified_run(sp, opts, g, th));
        (found, last.get())
    }

    /// The best certified member of the cell found from the point `(g, th)` of it (a free run
    /// that simulates well, not certified itself): phase 2 from the point itself where it is
    /// certified, else phase 1 from its nonlinearity, bisected parameters and `a`'s (the
    /// certified point nearest it), then phase 2. A search from the centre alone stays among
    /// the certified points near the centre, which may all simulate badly where the set holds
    /// good simulators farther out (on a wide set: the tanks' loop at a bound of 2.4 V, a
    /// certified member at -27 % training fit beside a centre at 78 %).
    pub(super) fn search_from(
        &self,
        sp: &CellSpace,
        opts: &Options,
        g: Vec<f64>,
        mut th: Vec<f64>,
    ) -> Option<(f64, SimulationMember)> {
        self.fix_gain(&mut th);
        if self.certify(sp, &g, &th) <= CERTIFIED {
            return self.best_certified_run(sp, opts, g, th);
        }
        let z = self.coordinates(sp, &g, &th);
        let last = Cell::new(f64::INFINITY);
        let (g1, th1) = self.certified_point(sp, opts, &last, z)?;
        self.best_certified_run(sp, opts, g1, th1)
    }

    /// Phase 1 from the search coordinates `z1`: a certified point `(g, θ)` of the cell,
    /// stable where the model is declared stable; `last_measure` takes the phase-1 measure of
    /// the last run.
    pub(super) fn certified_point(
        &self,
        sp: &CellSpace,
        opts: &Options,
        last_measure: &Cell<f64>,
        mut z1: Vec<f64>,
    ) -> Option<(Vec<f64>, Vec<f64>)> {
        let split = sp.moved.len();
        // Phase 1: a certified point, restarting from the best point so far (Nelder-Mead
        // stalls on kinked measures).
        let mut step = 0.1;
        let mut last = f64::INFINITY;
        for run in 0..opts.restarts.max(1) {
            let give_up =
                (run == 0 && opts.gives_up_early()).then_some((opts.hopeless_after, opts.hopeless));
            let Some((z, m)) = nelder_mead_or_give_up(
                &|z| self.measure_at_a(sp, z).0,
                &z1,
                step,
                opts.iterations,
                2.0 * CERTIFIED,
                give_up,
            ) else {
                log::debug!(target: "smid::members", "cell {}: phase 1 given up after {} evaluations above {}", sp.k, opts.hopeless_after, opts.hopeless);
                last_measure.set(f64::INFINITY);
                return None;
            };
            z1 = z;
            log::debug!(target: "smid::members", "cell {}: phase-1 measure {m:.3e} after {} evaluations", sp.k, self.evaluations.load(Relaxed));
            // Certified, or a run that gained less than 10 % of the measure, or one that ends
            // with the boxes more than `far` short: stop (a search that stalls this way has not
            // reached a certified point in any case seen; the ones that do gain 40-90 % a run,
            // and end their first run below 0.013, the failing ones above 0.72).
            last_measure.set(m);
            if m <= 2.0 * CERTIFIED
                || (opts.gives_up_early() && m > opts.far)
                || (last.is_finite() && last - m < 0.1 * last.abs())
            {
                break;
            }
            last = m;
            step *= 0.5;
        }
        let mut g1 = sp.at(&sp.base, &z1[..split]);
        let mut theta1 = self.measure_at_a(sp, &z1).1?;
        self.fix_gain(&mut theta1);
        if self.certify(sp, &g1, &theta1) > CERTIFIED {
            return None;
        }
        // A certified point whose linear block is unstable runs away in every free run, and
        // phase 2's small steps from it stay among runaways (the output backlash on the tanks:
        // a certified member at -2e114 % training fit). Phase 1 again from there, with the
        // root radius's excess over 1 counted as distance from a certificate: a stable
        // certified start when the cell holds one near. Else the certified point as before,
        // unless the model is declared stable (`model.stable`): an unstable point is then no
        // member of the declared class, and the cell has no certified member.
        let stable_only = self.set.model.stable;
        if self.root_radius(sp, &z1) >= 1.0 {
            let stable_measure = |z: &[f64]| {
                let m = self.measure_at_a(sp, z).0;
                let excess = self.root_radius(sp, z) - 1.0;
                if excess >= 0.0 {
                    m.max(2.0 * CERTIFIED) + excess + f64::EPSILON
                } else {
                    m
                }
            };
            let stable = nelder_mead(&stable_measure, &z1, 0.1, opts.iterations, 2.0 * CERTIFIED)
                .filter(|(_, m)| *m <= 2.0 * CERTIFIED)
                .and_then(|(z, _)| {
                    let g = sp.at(&sp.base, &z[..split]);
                    let mut th = self.measure_at_a(sp, &z).1?;
                    self.fix_gain(&mut th);
                    (self.certify(sp, &g, &th) <= CERTIFIED).then_some((g, th))
                });
            log::debug!(target: "smid::members", "cell {}: certified point unstable; a stable one {}", sp.k, if stable.is_some() { "found" } else { "not found" });
            match stable {
                Some((g, th)) => {
                    g1 = g;
                    theta1 = th;
                }
                None if stable_only => return None,
                None => {}
            }
        }
        Some((g1, theta1))
    }

    /// Phase 2: the best free run among certified points of the cell, from the certified point
    /// `(g1, theta1)`: `(squared error, member)`.
    fn best_certified_run(
        &self,
        sp: &CellSpace,
        opts: &Options,
        g1: Vec<f64>,
        theta1: Vec<f64>,
    ) -> Option<(f64, SimulationMember)> {
        let split = sp.moved.len();
        let stable_only = self.set.model.stable;
        let gain = self.gain_slot();
        let t_free: Vec<usize> = (0..self.layout.p())
            .filter(|&i| self.layout.fixed[i].is_none() && Some(i) != gain)
            .collect();
        let t_scale: Vec<f64> = t_free.iter().map(|&i| sp.theta_scale(i, &theta1)).collect();
        let point_of = |z: &[f64]| -> (Vec<f64>, Vec<f64>) {
            let g = sp.at(&g1, &z[..split]);
            let mut th = theta1.clone();
            for ((&i, s), zi) in t_free.iter().zip(&t_scale).zip(&z[split..]) {
                th[i] = theta1[i] + s * zi;
            }
            self.fix_gain(&mut th);
            (g, th)
        };
        let na = self.layout.orders.na;
        let cost = |z: &[f64]| -> f64 {
            let (g, th) = point_of(z);
            if stable_only && crate::linear::spectral_radius(&th[..na]) >= 1.0 {
                return f64::INFINITY;
            }
            if self.certify(sp, &g, &th) > CERTIFIED {
                return f64::INFINITY;
            }
            self.sse(&self.values_of(sp, &g, &th))
        };
        let z0 = vec![0.0; split + t_free.len()];
        let (z2, e2) = nelder_mead(&cost, &z0, 0.01, opts.iterations, f64::NEG_INFINITY)?;
        let (g2, th2) = point_of(&z2);
        let m2 = self.certify(sp, &g2, &th2);
        (m2 <= CERTIFIED && e2.is_finite()).then(|| {
            (
                e2,
                SimulationMember {
                    values: self.values_of(sp, &g2, &th2),
                    cell: sp.k,
                    consistency: m2,
                    training_fit: self.fit(e2),
                    centre_training_fit: f64::NAN,
                    evaluations: 0,
                    envelope: Vec::new(),
                    certified: true,
                    within: None,
                },
            )
        })
    }

    /// Certified members spread around the member `(g, th)` of the cell: along each searched
    /// coordinate (the cell's point and the `a`'s, the `b`'s re-solved by the LP at fixed `a`)
    /// the farthest certified point up to the cell's radius (bisection), and at the member's
    /// `a` the extremes of each free `b` and extra coefficient, moved towards the member until
    /// certified.
    pub(super) fn spread_members(
        &self,
        sp: &CellSpace,
        g: &[f64],
        th: &[f64],
    ) -> Vec<Vec<(String, f64)>> {
        let split = sp.moved.len();
        let a_free = self.a_free();
        let z = self.coordinates(sp, g, th);
        let certified_at = |zz: &[f64]| -> Option<(Vec<f64>, Vec<f64>)> {
            let (m, t) = self.measure_at_a(sp, zz);
            if m > 2.0 * CERTIFIED {
                return None;
            }
            let gg = sp.at(&sp.base, &zz[..split]);
            let mut t = t?;
            self.fix_gain(&mut t);
            (self.certify(sp, &gg, &t) <= CERTIFIED).then_some((gg, t))
        };
        let mut out = Vec::new();
        for d in 0..z.len() {
            for dir in [-1.0, 1.0] {
                let at = |t: f64| {
                    let mut zz = z.clone();
                    zz[d] += dir * t;
                    zz
                };
                let (mut lo, mut hi) = (0.0, 1.0);
                let mut found = certified_at(&at(hi)).map(|p| (hi, p));
                if found.is_none() {
                    for _ in 0..10 {
                        let mid = 0.5 * (lo + hi);
                        match certified_at(&at(mid)) {
                            Some(p) => {
                                lo = mid;
                                found = Some((mid, p));
                            }
                            None => hi = mid,
                        }
                    }
                }
                if let Some((t, (gg, tt))) = found {
                    if t > 0.0 {
                        out.push(self.values_of(sp, &gg, &tt));
                    }
                }
            }
        }
        // The `b` and extra-coefficient extremes at the member's `a`.
        if let Some(sig) = self.signals_at(sp, g) {
            let sig = self.decided(sig, th);
            let prob = self.problem(&sig);
            let a: Vec<f64> = a_free.iter().map(|&i| th[i]).collect();
            let o = self.layout.orders;
            for k in (o.na..self.layout.p()).filter(|&k| self.layout.fixed[k].is_none()) {
                for max in [false, true] {
                    let Ok(Some(v)) = extreme_at_a(&prob, &sp.cell.theta, &a, k, max) else {
                        continue;
                    };
                    for w in [0.98, 0.9, 0.5] {
                        let mut t: Vec<f64> =
                            th.iter().zip(&v).map(|(m, e)| m + w * (e - m)).collect();
                        self.fix_gain(&mut t);
                        if self.certify(sp, g, &t) <= CERTIFIED {
                            out.push(self.values_of(sp, g, &t));
                            break;
                        }
                    }
                }
            }
        }
        out
    }
}
