//! Free runs compared on the training records: a model's runs from rest, the transients left
//! out, the largest deviation, and a member of one model class put into another
//! ([`transplanted_runs`]).
use super::gain::GainTrade;
use crate::interval::Interval;
use crate::model::ModelSet;

/// Free runs from rest of `point` on each training record of `set` (`None` when one diverges).
fn training_runs(point: &crate::members::ModelPoint, set: &ModelSet) -> Option<Vec<Vec<f64>>> {
    let runs: Vec<Vec<f64>> = set
        .training
        .records
        .iter()
        .map(|r| point.simulate(&r.u, r.dt).y)
        .collect();
    runs.iter()
        .all(|y| y.iter().all(|v| v.is_finite()))
        .then_some(runs)
}

/// Free runs from rest of the representative member of `set` on each training record.
pub(super) fn centre_runs(set: &ModelSet) -> Option<Vec<Vec<f64>>> {
    training_runs(&crate::members::representative(set).ok()?, set)
}

/// Whether two models' centre free runs stay within `tol` of each other on every training
/// sample after the first `skip` of each record.
pub(super) fn indistinguishable(a: &[Vec<f64>], b: &[Vec<f64>], tol: f64, skip: usize) -> bool {
    max_deviation(a, b, skip) <= tol
}

/// Free runs on `to`'s training records of a point of `to`'s model class that reproduces the
/// representative member of `from`: whether `to`'s class holds a point that simulates as
/// `from`'s member does. With exactly the same parameter names (a dead zone and a play at the
/// same place, say) the point is `from`'s values. Otherwise `to`'s parameters that `from` also
/// has are copied by name and the point is sought two ways ([`Transplant`]), keeping the one
/// whose runs come closer to the member's after the first `skip` samples:
/// * `θ` fitted by equation-error least squares to the linear block's output of `from`'s
///   member, the other parameters (a bisected block's, at most [`FITTED_DIMS`]) searched
///   inside `to`'s bounds: a unit-gain lag before the linear block and one more pole of it,
///   whose classes coincide wherever the extra pole is real and inside the lag's prior. A gain
///   traded between the linear block and the block after it is searched too ([`GainTrade`]):
///   a parallel input path and viscous friction on the input velocity, whose inner signals
///   differ by a scale at rest;
/// * `θ` copied, every other parameter moved inside `to`'s bounds by an output-error fit to
///   the member's runs: an input bias through a unit-gain block and a sensor offset after the
///   backlash, whose classes coincide once the plays move with the bias.
///
/// The caller compares the runs, so a fit that misses only fails to report an equivalence.
pub(super) fn transplanted_runs(
    from: &ModelSet,
    to: &ModelSet,
    skip: usize,
) -> Option<Vec<Vec<f64>>> {
    let values = crate::members::representative_values(from).ok()?;
    let mut a: Vec<&str> = from.parameters.iter().map(|p| p.name.as_str()).collect();
    let mut b: Vec<&str> = to.parameters.iter().map(|p| p.name.as_str()).collect();
    a.sort_unstable();
    b.sort_unstable();
    if a == b {
        if !b.iter().all(|n| values.iter().any(|(k, _)| k == n)) {
            return None;
        }
        return training_runs(&crate::members::point(to, &values).ok()?, to);
    }
    let source = crate::members::point(from, &values).ok()?;
    let layout = to.layout().ok()?;
    let others: Vec<&crate::model::ParamResult> = to
        .parameters
        .iter()
        .filter(|p| !layout.theta_names.contains(&p.name))
        .collect();
    let copied: Vec<(String, f64)> = others
        .iter()
        .filter_map(|p| {
            values
                .iter()
                .find(|(k, _)| *k == p.name)
                .map(|(k, v)| (k.clone(), *v))
        })
        .collect();
    let searched: Vec<(String, Interval)> = others
        .iter()
        .filter(|p| !copied.iter().any(|(k, _)| *k == p.name))
        .map(|p| (p.name.clone(), p.interval()))
        .collect();
    if searched.len() > FITTED_DIMS || searched.iter().any(|(_, i)| !i.is_finite()) {
        return None;
    }
    // A copied value outside `to`'s bounds is no point of its class as identified (a box of
    // the nonlinearity from the steady-state points in one candidate, from stage 1 in another),
    // unless it is the block right after the linear block, which a gain traded with the linear
    // block brings inside ([`GainTrade`]).
    let inside = |name: &str, v: f64| to.parameter(name).is_some_and(|p| p.interval().contains(v));
    let gain = GainTrade::of(to, &copied);
    let traded = |name: &str| {
        gain.as_ref()
            .is_some_and(|g| g.names.iter().any(|n| n == name))
    };
    if !copied.iter().all(|(k, v)| traded(k) || inside(k, *v)) {
        return None;
    }
    let target = training_runs(&source, to)?;
    let fit = Transplant {
        to,
        skip,
        layout,
        copied,
        searched,
        gain,
    };
    // Two ways into `to`'s class; the one whose runs come closer to the member's is kept. The
    // output-error way copies θ at the member's scale, so it has no point where the block after
    // the linear block needs a traded gain.
    let needed = fit.gain.as_ref().is_some_and(|g| g.needed);
    [
        fit.equation_error(&source),
        (!needed)
            .then(|| fit.output_error(&values, &target))
            .flatten(),
    ]
    .into_iter()
    .flatten()
    .map(|r| (max_deviation(&r, &target, skip), r))
    .min_by(|a, b| a.0.total_cmp(&b.0))
    .map(|(_, r)| r)
}

/// At least this many samples at the start of each training record are left out of the
/// equivalence tests ([`warm_up`]).
const SKIP: usize = 20;

/// Samples at the start of each training record that the equivalence tests of `a` and `b`
/// leave out: the runs start from rest, and two classes may rest in different states (a bias
/// before the linear block moves its output at once, and the backlash after it holds what
/// that move left), so the transient of the slower linear block (spectral radius `ρ` of its
/// representative member) is let decay below `tol` of the outputs' range: `ln(tol/range) /
/// ln ρ` samples, at least [`SKIP`], at most a quarter of the shortest record.
pub(super) fn warm_up(a: &ModelSet, b: &ModelSet, tol: f64) -> usize {
    let rho = [a, b]
        .iter()
        .filter_map(|s| crate::members::representative(s).ok())
        .map(|p| p.linear.spectral_radius())
        .fold(0.0, f64::max);
    let records = &a.training.records;
    let shortest = records.iter().map(|r| r.y.len()).min().unwrap_or(0);
    let range = spread(records.iter().flat_map(|r| r.y.iter()));
    let settle = if rho > 0.0 && rho < 1.0 && range > tol && tol > 0.0 {
        ((tol / range).ln() / rho.ln()).ceil() as usize
    } else {
        SKIP
    };
    settle.clamp(SKIP, (shortest / 4).max(SKIP))
}

/// The largest value less the smallest (−∞ for none).
pub(super) fn spread<'a>(values: impl Iterator<Item = &'a f64>) -> f64 {
    let (lo, hi) = values.fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), v| {
        (l.min(*v), h.max(*v))
    });
    hi - lo
}

/// The largest sample deviation between two sets of runs after the first `skip` of each record
/// (+∞ when their shapes differ).
pub(super) fn max_deviation(a: &[Vec<f64>], b: &[Vec<f64>], skip: usize) -> f64 {
    if a.len() != b.len() || a.iter().zip(b).any(|(x, y)| x.len() != y.len()) {
        return f64::INFINITY;
    }
    a.iter()
        .zip(b)
        .flat_map(|(x, y)| x.iter().zip(y).skip(skip).map(|(p, q)| (p - q).abs()))
        // A NaN (a run that broke down) is no match.
        .map(|d| if d.is_nan() { f64::INFINITY } else { d })
        .fold(0.0, f64::max)
}

/// A point of `to`'s class sought for a member of another class ([`transplanted_runs`]): the
/// parameters both classes have are `copied`, the `searched` ones (at most [`FITTED_DIMS`])
/// range over `to`'s bounds.
pub(super) struct Transplant<'a> {
    to: &'a ModelSet,
    /// Samples left out at the start of each record ([`warm_up`]).
    skip: usize,
    layout: &'a crate::model::Layout,
    copied: Vec<(String, f64)>,
    searched: Vec<(String, Interval)>,
    /// The gain traded between the linear block and the block after it, when that block's
    /// values are all copied and some gain brings them inside `to`'s bounds.
    gain: Option<GainTrade>,
}

impl Transplant<'_> {
    /// The copied values and the searched ones at `z ∈ [0, 1]^k` of their bounds.
    fn at(&self, z: &[f64]) -> Vec<(String, f64)> {
        let mut v = self.copied.clone();
        v.extend(
            self.searched
                .iter()
                .zip(z)
                .map(|((n, i), zi)| (n.clone(), i.lo + (i.hi - i.lo) * zi.clamp(0.0, 1.0))),
        );
        v
    }

    /// The traded gain at `z`'s last entry (log-uniform over the trade's window), and the
    /// values of [`Transplant::at`] with the block after the linear block moved behind it
    /// (`None` when a moved value leaves `to`'s bounds). Without a trade: gain 1, `at(z)`.
    pub(super) fn at_gain(&self, z: &[f64]) -> Option<(f64, Vec<(String, f64)>)> {
        let Some(g) = &self.gain else {
            return Some((1.0, self.at(z)));
        };
        let (own, last) = z.split_at(z.len().checked_sub(1)?);
        let w = g.window;
        let k = (w.lo.ln() + (w.hi / w.lo).ln() * last[0].clamp(0.0, 1.0)).exp();
        let moved = g.moved(k)?;
        let mut v = self.at(own);
        for (n, x) in moved {
            if let Some(e) = v.iter_mut().find(|(k, _)| *k == n) {
                e.1 = x;
            }
        }
        Some((k, v))
    }

    /// Nelder-Mead on `error` over the searched parameters and the traded gain (the last
    /// entry of `z`), from a few starts across their bounds (the error need not be convex in
    /// them), the first with the gain at 1 where that is in its window: the best `z`.
    fn minimise(&self, error: &dyn Fn(&[f64]) -> f64) -> Option<Vec<f64>> {
        let dims = self.searched.len() + usize::from(self.gain.is_some());
        let mut best: Option<(Vec<f64>, f64)> = None;
        for start in [0.5, 0.15, 0.85] {
            let mut z0 = vec![start; dims];
            if let (Some(g), Some(z)) = (&self.gain, z0.last_mut()) {
                if start == 0.5 {
                    *z = g.unit_position();
                }
            }
            if let Some((z, e)) =
                crate::members::simulation::nelder_mead(error, &z0, 0.2, 200, f64::NEG_INFINITY)
            {
                if best.as_ref().is_none_or(|(_, b)| e < *b) {
                    best = Some((z, e));
                }
            }
            if dims == 0 {
                break;
            }
        }
        best.filter(|(_, e)| e.is_finite()).map(|(z, _)| z)
    }

    /// Whether `θ` is a point of `to`'s class: inside its θ prior box, and stable when the
    /// model is declared so (an unstable θ can stay close over a finite record).
    fn admits_theta(&self, theta: &[f64]) -> bool {
        let na = self.layout.orders.na;
        if self.to.model.stable && crate::linear::spectral_radius(&theta[..na]) >= 1.0 {
            return false;
        }
        self.layout
            .theta_prior
            .as_ref()
            .is_none_or(|prior| prior.iter().zip(theta).all(|(b, t)| b.contains(*t)))
    }

    /// `θ` fitted by equation-error least squares to the linear block's output of the member
    /// `source` ([`crate::members::theta_reproducing`]), the searched parameters minimising
    /// that fit's error: right where the two classes share the linear block's output (a
    /// unit-gain lag before the linear block and one more pole of it). With a [`GainTrade`]
    /// the output is `k` times the member's, the block after it behind `k`, and `k` is
    /// searched too (the fit's error taken relative to `k²`, the scale of the fitted output).
    fn equation_error(&self, source: &crate::members::ModelPoint) -> Option<Vec<Vec<f64>>> {
        let x: Vec<Vec<f64>> = self
            .to
            .training
            .records
            .iter()
            .map(|r| source.simulate(&r.u, r.dt).x)
            .collect();
        if !x.iter().flatten().all(|v| v.is_finite()) {
            return None;
        }
        let scaled = |k: f64| -> Vec<Vec<f64>> {
            x.iter()
                .map(|r| r.iter().map(|v| k * v).collect())
                .collect()
        };
        let error = |z: &[f64]| -> f64 {
            let Some((k, v)) = self.at_gain(z) else {
                return f64::INFINITY;
            };
            match crate::members::theta_reproducing(self.to, &v, &scaled(k)) {
                Ok(Some((_, e))) => e / (k * k),
                _ => f64::INFINITY,
            }
        };
        let (k, mut v) = self.at_gain(&self.minimise(&error)?)?;
        let theta = crate::members::theta_reproducing(self.to, &v, &scaled(k))
            .ok()??
            .0;
        let values: Vec<f64> = theta.iter().map(|(_, t)| *t).collect();
        if !self.admits_theta(&values) {
            return None;
        }
        v.extend(theta);
        training_runs(&crate::members::point(self.to, &v).ok()?, self.to)
    }

    /// `θ` copied from the member (`values`, when the two classes have the same linear
    /// block), and every other parameter of `to` moved inside `to`'s bounds (from the copied
    /// values, the searched ones from their bounds' middle) to bring the free runs closest, in
    /// squared distance, to the member's runs `target`: right where the classes differ by a
    /// shift the linear block carries (an input bias through a unit-gain block beside a sensor
    /// offset after the backlash: the plays move with the bias).
    fn output_error(&self, values: &[(String, f64)], target: &[Vec<f64>]) -> Option<Vec<Vec<f64>>> {
        let theta: Vec<(String, f64)> = self
            .layout
            .theta_names
            .iter()
            .map(|n| values.iter().find(|(k, _)| k == n).cloned())
            .collect::<Option<_>>()?;
        let t: Vec<f64> = theta.iter().map(|(_, v)| *v).collect();
        if !self.admits_theta(&t) {
            return None;
        }
        // Every non-θ parameter of `to`, with its bounds and start; a point (zero width)
        // stays where it is.
        let mut fixed = theta;
        let mut moved: Vec<(String, Interval, f64)> = Vec::new();
        let start = self
            .copied
            .iter()
            .map(|(n, v)| (n, *v))
            .chain(self.searched.iter().map(|(n, i)| (n, i.center())));
        for (n, v) in start {
            let i = self.to.parameter(n)?.interval();
            if i.hi > i.lo {
                moved.push((n.clone(), i, (v - i.lo) / (i.hi - i.lo)));
            } else {
                // A point bound: its one value (a copy from the member may lie outside it).
                fixed.push((n.clone(), i.lo));
            }
        }
        if moved.len() > OUTPUT_ERROR_DIMS {
            return None;
        }
        let point = |z: &[f64]| {
            let mut v = fixed.clone();
            v.extend(
                moved
                    .iter()
                    .zip(z)
                    .map(|((n, i, _), zi)| (n.clone(), i.lo + (i.hi - i.lo) * zi.clamp(0.0, 1.0))),
            );
            v
        };
        let error = |z: &[f64]| -> f64 {
            let Some(runs) = crate::members::point(self.to, &point(z))
                .ok()
                .and_then(|p| training_runs(&p, self.to))
            else {
                return f64::INFINITY;
            };
            runs.iter()
                .zip(target)
                .flat_map(|(r, g)| {
                    r.iter()
                        .zip(g)
                        .skip(self.skip)
                        .map(|(a, b)| (a - b) * (a - b))
                })
                .sum()
        };
        // Restarted from its best point with ever smaller steps (a simplex collapses in a
        // narrow valley: the shift along which the two classes coincide).
        let mut z: Vec<f64> = moved.iter().map(|(_, _, z)| *z).collect();
        for step in [0.05, 0.01, 0.002] {
            z = crate::members::simulation::nelder_mead(&error, &z, step, 300, 0.0)?.0;
        }
        training_runs(&crate::members::point(self.to, &point(&z)).ok()?, self.to)
    }
}

/// At most this many parameters of the other model's class are searched when a member is put
/// into it ([`transplanted_runs`]): beyond, Nelder-Mead on the fit's error is not worth its
/// cost in a report.
const FITTED_DIMS: usize = 3;

/// At most this many parameters are moved by the output-error way into another class
/// ([`Transplant::output_error`]: from the member's own values, so more of them than
/// [`FITTED_DIMS`], searched from their bounds, are worth it).
const OUTPUT_ERROR_DIMS: usize = 6;
