//! Experiments on a [`Plant`]: the filter-pole search of the Appendix, the filtered square-wave
//! steady-state experiment of Section 3.2 (eqs 9-12), and the PRBS dynamic experiment of
//! Section 4, with bounded noise added to the plant's output (eq 4).
//!
//! Filter design: the Appendix bisection compares the steady-state output reached through a
//! filter with pole `a*` against the one reached through the reference pole `ā`, and keeps the
//! last pole that passed (`a_U`). `ā >= 1` is the quasi-static limit, run with the pole
//! `1 - 1e-4`. The search runs on the noise-free plant: the noisy variant of the Remark
//! (threshold `2Δη + ε`) accepts overshooting poles at 12 bits and below and breaks the guarantee
//! of stage 1, so it is not offered; with measured data give the pole directly.
use crate::error::{Result, SmidError};
use crate::nonlinearity::{SteadyPoint, SteadyStateData};
use crate::plant::Plant;
use crate::signals::{filter_settling, lowpass, prbs};
use rand::Rng;
use serde::{Deserialize, Serialize};

/// Pole used for the reference when `ā >= 1`.
pub const QUASI_STATIC_POLE: f64 = 1.0 - 1e-4;

/// Smallest accepted `experiment.filter.tol`: the Appendix bisection halves `[0, ā]` until
/// the bracket is narrower than `tol`, so `tol` sets its number of steps (at most
/// [`MAX_BISECTION_STEPS`]); below about 1e-15 the bracket stops shrinking in floating point.
pub const MIN_FILTER_TOL: f64 = 1e-12;
/// Cap on the Appendix bisection's steps (`log2(1/MIN_FILTER_TOL)` is 40): the search also
/// stops when the midpoint no longer falls strictly inside the bracket.
pub const MAX_BISECTION_STEPS: usize = 64;
/// Largest accepted `experiment.filter.settle` (samples given to the plant to settle).
pub const MAX_SETTLE: usize = 1_000_000;
/// Largest number of samples one experiment may run through the plant (the steady-state
/// square wave: `2 M` half-waves of `half_period` samples, or of the filter's settling time
/// plus `settle`; the dynamic PRBS: `N`).
pub const MAX_EXPERIMENT_SAMPLES: usize = 20_000_000;

/// Options of the Appendix search.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct BisectionOptions {
    /// `ā`, the reference (slowest) pole.
    pub a_bar: f64,
    /// Stop when `|a_U - a_L| < tol`.
    pub tol: f64,
    /// `ε`: largest accepted steady-state difference.
    pub epsilon: f64,
    /// `r̄_F`: amplitude of the test step.
    pub step: f64,
    /// Samples the plant is given to settle after the filter has.
    pub settle: usize,
}

/// One tested pole.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct BisectionTrial {
    /// The tested filter pole `a*` in `[0, ā]`.
    pub pole: f64,
    /// Noise-free steady-state output `w_s(a*)` at the end of the filtered test step.
    pub steady_output: f64,
    /// Whether the pole passed: steady-state difference and overshoot both at most `ε`.
    pub passed: bool,
}

/// Outcome of the filter design.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FilterDesign {
    /// The chosen filter pole `a` in `[0, 1)`: the last one that passed (`a_U`), or the given one.
    pub pole: f64,
    /// `r̄_F` used by the search (enters α of eqs 14-15); `None` when the pole was given.
    pub step: Option<f64>,
    /// Steady-state output `w_s(ā)` through the reference pole; `None` when the pole was given.
    pub reference_output: Option<f64>,
    /// Every pole the bisection tested, in order (empty when the pole was given).
    pub trials: Vec<BisectionTrial>,
    /// Overshoot bias measured at the chosen pole, noise-free, for a step of `+r̄_F`
    /// (`w(a) - w(ā)`, clamped at 0) and of `-r̄_F` (`w(ā) - w(a)`, clamped at 0), with a
    /// rounding pad. It bounds the bias of every steady-state sample after scaling by the step
    /// size `2|ū|/r̄_F` (linearity of the block): the `design` α of eqs (14)-(15).
    pub overshoot: Option<[f64; 2]>,
}

impl FilterDesign {
    /// A given pole (no search, no overshoot measurement).
    pub fn given(pole: f64) -> Self {
        FilterDesign {
            pole,
            step: None,
            reference_output: None,
            trials: Vec::new(),
            overshoot: None,
        }
    }
}

/// Steady-state output and the extreme output of one filtered step (from rest).
struct StepRun {
    steady: f64,
    /// Largest output for a positive step, smallest for a negative one.
    peak: f64,
}

fn step_run(plant: &mut dyn Plant, pole: f64, step: f64, settle: usize) -> Result<StepRun> {
    let a = if pole >= 1.0 { QUASI_STATIC_POLE } else { pole };
    let n = filter_settling(a)
        .saturating_add(settle)
        .min(MAX_EXPERIMENT_SAMPLES);
    let w = plant.run(&lowpass(a, &vec![step; n]))?;
    if let Some(i) = w.iter().position(|v| !v.is_finite()) {
        return Err(SmidError::Plant {
            plant: plant.name(),
            message: format!("non-finite output at sample {i} of the filter-design step"),
        });
    }
    let steady = *w.last().ok_or_else(|| SmidError::Plant {
        plant: plant.name(),
        message: "returned no samples".into(),
    })?;
    let peak = if step > 0.0 {
        w.iter().copied().fold(f64::NEG_INFINITY, f64::max)
    } else {
        w.iter().copied().fold(f64::INFINITY, f64::min)
    };
    Ok(StepRun { steady, peak })
}

/// The Appendix search for the filter pole (noise-free).
///
/// Step 4 of the Appendix compares steady-state outputs only. With a hysteretic nonlinearity
/// that test is unsound: a large step whose oscillation crosses the whole dead band erases its
/// own overshoot, which then biases the smaller square-wave steps (seen on random systems). Any
/// overshoot of the inner signal is a new maximum on the moving branch, so it always shows in the
/// output's extreme value: a pole passes when both `|w_s(a) - w_s(ā)|` and the overshoot of the
/// extreme output over `w_s(ā)` are at most `ε`. The paper's system still gives `a = 0.8125`.
pub fn design_filter_pole(plant: &mut dyn Plant, o: &BisectionOptions) -> Result<FilterDesign> {
    if !(o.a_bar > 0.0 && o.a_bar <= 1.0) {
        return Err(SmidError::invalid(
            "experiment.filter.a_bar",
            format!("expected 0 < ā <= 1, got {}", o.a_bar),
        ));
    }
    if !(o.tol >= MIN_FILTER_TOL && o.tol < 1.0) {
        return Err(SmidError::invalid(
            "experiment.filter.tol",
            format!("expected {MIN_FILTER_TOL:e} <= tol < 1, got {:e}", o.tol),
        ));
    }
    if o.settle > MAX_SETTLE {
        return Err(SmidError::invalid(
            "experiment.filter.settle",
            format!("expected at most {MAX_SETTLE} samples, got {}", o.settle),
        ));
    }
    if !(o.epsilon > 0.0 && o.epsilon.is_finite()) {
        return Err(SmidError::invalid(
            "experiment.filter.epsilon",
            format!("expected ε > 0, got {}", o.epsilon),
        ));
    }
    if !(o.step.is_finite() && o.step != 0.0) {
        return Err(SmidError::invalid(
            "experiment.filter.step",
            "expected a non-zero finite step amplitude",
        ));
    }
    let sign = o.step.signum();
    let w_ref = step_run(plant, o.a_bar, o.step, o.settle)?.steady;
    let (mut a_u, mut a_l, mut a_star) = (o.a_bar, 0.0f64, 0.0f64);
    let mut trials = Vec::new();
    let mut passed_any = false;
    // Bounded: `tol >= MIN_FILTER_TOL` needs at most 40 halvings; the cap and the midpoint
    // test stop it in any case (the last pole that passed is kept).
    for _ in 0..MAX_BISECTION_STEPS {
        let run = step_run(plant, a_star, o.step, o.settle)?;
        let overshoot = sign * (run.peak - w_ref);
        let passed = (w_ref - run.steady).abs() <= o.epsilon && overshoot <= o.epsilon;
        trials.push(BisectionTrial {
            pole: a_star,
            steady_output: run.steady,
            passed,
        });
        if passed {
            a_u = a_star;
            passed_any = true;
        } else {
            a_l = a_star;
        }
        let mid = 0.5 * (a_u + a_l);
        let inside = mid > a_u.min(a_l) && mid < a_u.max(a_l);
        if (a_u - a_l).abs() >= o.tol && inside {
            a_star = mid;
        } else {
            break;
        }
    }
    if !passed_any && o.a_bar >= 1.0 {
        return Err(SmidError::invalid(
            "experiment.filter",
            "no filter pole below ā passed the no-overshoot test: raise `epsilon` or lower `tol`",
        ));
    }
    // Measure the overshoot bias of the chosen pole in both directions (extreme output beyond the
    // quasi-static steady state): it bounds m·(overshoot of x) for a step of r̄_F.
    let pad = |v: f64| 1e-12 * (1.0 + v.abs());
    let pos = step_run(plant, a_u, o.step, o.settle)?;
    let neg_ref = step_run(plant, o.a_bar, -o.step, o.settle)?.steady;
    let neg = step_run(plant, a_u, -o.step, o.settle)?;
    let (up, down) = if sign > 0.0 {
        ((pos.peak - w_ref), (neg_ref - neg.peak))
    } else {
        ((neg.peak - neg_ref), (w_ref - pos.peak))
    };
    let right = up.max(0.0) + pad(w_ref);
    let left = down.max(0.0) + pad(neg_ref);
    Ok(FilterDesign {
        pole: a_u,
        step: Some(o.step),
        reference_output: Some(w_ref),
        trials,
        overshoot: Some([right, left]),
    })
}

/// Options of the steady-state experiment.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct SteadyStateOptions {
    /// `M`, the number of square-wave amplitudes.
    pub amplitudes: usize,
    /// Smallest square-wave amplitude (`> 0`).
    pub min: f64,
    /// Largest square-wave amplitude (`> min`).
    pub max: f64,
    /// Samples per half-wave; `None` = filter settling time + `settle`.
    pub half_period: Option<usize>,
    /// Extra samples per half-wave for the plant to settle after the filter has (used when
    /// `half_period` is `None`).
    pub settle: usize,
    /// Play the amplitudes in a shuffled order drawn from this seed (`None`: ascending, the
    /// paper's). Shuffling decorrelates time from amplitude, so a sensor drift cannot pass for
    /// a change of slope.
    pub shuffle: Option<u64>,
}

/// The noise-free steady-state record: the whole filtered square wave and where it was sampled.
#[derive(Debug, Clone, Default, Serialize)]
pub struct SteadyRecord {
    /// The filtered square wave applied to the plant.
    pub u: Vec<f64>,
    /// The plant's noise-free output.
    pub w: Vec<f64>,
    /// `(time index, ū, rising, step)` of each steady-state sample, `step` the height of the
    /// square wave's step that led to it (`2|ū|` in ascending order).
    pub samples: Vec<(usize, f64, bool, f64)>,
}

/// Run the square wave through the filter and the plant: for each amplitude a positive then a
/// negative half-wave, sampled at the end of each half (2M samples).
pub fn steady_state_experiment(
    plant: &mut dyn Plant,
    pole: f64,
    o: &SteadyStateOptions,
) -> Result<SteadyRecord> {
    if o.amplitudes < 2 {
        return Err(SmidError::invalid(
            "experiment.steady_state.amplitudes",
            "need at least 2 amplitudes (M >= 2)",
        ));
    }
    if !(o.min > 0.0 && o.max > o.min && o.max.is_finite()) {
        return Err(SmidError::invalid(
            "experiment.steady_state",
            format!("expected 0 < min < max, got min {} max {}", o.min, o.max),
        ));
    }
    if !(0.0..1.0).contains(&pole) {
        return Err(SmidError::invalid(
            "experiment.filter.pole",
            format!("expected 0 <= a < 1, got {pole}"),
        ));
    }
    if o.settle > MAX_SETTLE {
        return Err(SmidError::invalid(
            "experiment.filter.settle",
            format!("expected at most {MAX_SETTLE} samples, got {}", o.settle),
        ));
    }
    let (half, field) = match o.half_period {
        Some(h) => (h, "experiment.steady_state.half_period"),
        None => (
            filter_settling(pole).saturating_add(o.settle),
            "experiment.filter.pole",
        ),
    };
    let half = half.max(2);
    let m = o.amplitudes;
    let total = half.saturating_mul(m).saturating_mul(2);
    if total > MAX_EXPERIMENT_SAMPLES {
        return Err(SmidError::invalid(
            field,
            format!(
                "the square wave would run {total} samples (2 x {m} amplitudes x {half} per half-wave), more than {MAX_EXPERIMENT_SAMPLES}: {}",
                if o.half_period.is_some() {
                    "shorten the half period or use fewer amplitudes"
                } else {
                    "a pole this close to 1 settles too slowly; choose a faster filter"
                }
            ),
        ));
    }
    let mut r = Vec::with_capacity(2 * m * half);
    let mut samples = Vec::with_capacity(2 * m);
    let mut order: Vec<usize> = (0..m).collect();
    if let Some(seed) = o.shuffle {
        use rand::seq::SliceRandom;
        use rand::SeedableRng;
        order.shuffle(&mut rand_chacha::ChaCha8Rng::seed_from_u64(seed));
    }
    let mut level = 0.0f64;
    for k in order {
        let amp = o.min + (o.max - o.min) * k as f64 / (m - 1) as f64;
        for sign in [1.0, -1.0] {
            r.extend(std::iter::repeat_n(sign * amp, half));
            let step = if o.shuffle.is_some() {
                (sign * amp - level).abs()
            } else {
                2.0 * amp
            };
            level = sign * amp;
            samples.push((r.len() - 1, sign * amp, sign > 0.0, step));
        }
    }
    // The filter delays by one sample: extend by one so the last sample has settled too.
    let u = lowpass(pole, &r);
    let w = plant.run(&u)?;
    if let Some(i) = w.iter().position(|v| !v.is_finite()) {
        return Err(SmidError::Plant {
            plant: plant.name(),
            message: format!("non-finite output at sample {i}"),
        });
    }
    Ok(SteadyRecord { u, w, samples })
}

/// Noisy steady-state data from a record: `ȳ = w + η̄` with `η̄` uniform in `[-added, added]`,
/// declared bound `Δη = delta`.
pub fn noisy_steady_state(
    rec: &SteadyRecord,
    delta: f64,
    added: f64,
    rng: &mut impl Rng,
) -> SteadyStateData {
    SteadyStateData {
        points: rec
            .samples
            .iter()
            .enumerate()
            .map(|(i, &(t, u, rising, step))| SteadyPoint {
                u,
                y: rec.w[t] + rng.gen_range(-added..=added),
                dy: delta,
                alpha: 0.0,
                rising,
                index: i,
                time: Some(t),
                step: Some(step),
                du: 0.0,
            })
            .collect(),
    }
}

/// Set α of eqs (14)-(15) on every point as the paper does, `α = 2Δη|ū|/r̄_F`, made
/// non-negative (the paper's signed `ū_j` would shrink the left branch's interval, unsound).
pub fn apply_alpha(data: &mut SteadyStateData, step: f64) {
    for p in &mut data.points {
        p.alpha = 2.0 * p.dy * p.step_height() / (2.0 * step.abs());
    }
}

/// Set α from the overshoot measured by the design: `α = d · 2|ū|/r̄_F`, with `d` the measured
/// bias for a rising (`overshoot[0]`) or falling (`overshoot[1]`) step.
pub fn apply_design_alpha(data: &mut SteadyStateData, overshoot: [f64; 2], step: f64) {
    for p in &mut data.points {
        let d = if p.rising { overshoot[0] } else { overshoot[1] };
        p.alpha = d * p.step_height() / step.abs();
    }
}

/// Options of the dynamic experiment.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct DynamicOptions {
    /// `N`, the PRBS length.
    pub length: usize,
    /// Largest input magnitude (`> 0`): the PRBS takes `±amplitude`.
    pub amplitude: f64,
    /// Samples each PRBS value is held (at least 1).
    pub hold: usize,
    /// Magnitude levels (2: the binary PRBS `±amplitude`).
    pub levels: usize,
}

/// The PRBS input for the dynamic experiment.
pub fn dynamic_input(o: &DynamicOptions, rng: &mut impl Rng) -> Result<Vec<f64>> {
    if !(10..=MAX_EXPERIMENT_SAMPLES).contains(&o.length) {
        return Err(SmidError::invalid(
            "experiment.dynamic.length",
            format!(
                "expected 10 <= N <= {MAX_EXPERIMENT_SAMPLES}, got {}",
                o.length
            ),
        ));
    }
    if !(o.amplitude.is_finite() && o.amplitude > 0.0) {
        return Err(SmidError::invalid(
            "experiment.dynamic.amplitude",
            "expected a finite amplitude > 0",
        ));
    }
    Ok(if o.levels <= 2 {
        prbs(o.length, o.amplitude, o.hold, rng)
    } else {
        crate::signals::multilevel(o.length, o.amplitude, o.hold, o.levels / 2, rng)
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A first-order lag with an overshooting second pole: `w_t = 1.2 w_{t-1} - 0.5 w_{t-2} + 0.3 u_{t-1}`.
    struct Lag;
    impl Plant for Lag {
        fn run(&mut self, u: &[f64]) -> Result<Vec<f64>> {
            let mut w = vec![0.0; u.len()];
            for t in 2..u.len() {
                w[t] = 1.2 * w[t - 1] - 0.5 * w[t - 2] + 0.3 * u[t - 1];
            }
            Ok(w)
        }
    }

    fn opts(tol: f64) -> BisectionOptions {
        BisectionOptions {
            a_bar: 1.0,
            tol,
            epsilon: 1e-5,
            step: 3.0,
            settle: 100,
        }
    }

    /// A bisection below floating-point resolution would never end: a tolerance below
    /// `MIN_FILTER_TOL` is an error naming the field; at the limit the search ends within the
    /// cap, and the pole it keeps passed.
    #[test]
    fn the_filter_search_is_bounded() {
        for tol in [1e-300, 0.0, -1.0, f64::NAN, 1.0] {
            match design_filter_pole(&mut Lag, &opts(tol)) {
                Err(SmidError::Invalid { field, .. }) => assert_eq!(field, "experiment.filter.tol"),
                other => panic!("tol {tol}: expected an error, got {other:?}"),
            }
        }
        let d = design_filter_pole(&mut Lag, &opts(MIN_FILTER_TOL)).unwrap();
        assert!(d.trials.len() <= MAX_BISECTION_STEPS, "{}", d.trials.len());
        assert!(d.trials.iter().any(|t| t.passed && t.pole == d.pole));
        let mut o = opts(0.1);
        o.settle = MAX_SETTLE + 1;
        assert!(matches!(
            design_filter_pole(&mut Lag, &o),
            Err(SmidError::Invalid { field, .. }) if field == "experiment.filter.settle"
        ));
    }

    /// A pole so close to 1 that the square wave would need more than `MAX_EXPERIMENT_SAMPLES`
    /// samples is an error naming the pole (not an allocation failure); a huge half period
    /// names its own field.
    #[test]
    fn the_square_wave_length_is_bounded() {
        let o = SteadyStateOptions {
            amplitudes: 50,
            min: 0.6,
            max: 3.0,
            half_period: None,
            settle: 500,
            shuffle: None,
        };
        match steady_state_experiment(&mut Lag, 1.0 - 1e-15, &o) {
            Err(SmidError::Invalid { field, .. }) => assert_eq!(field, "experiment.filter.pole"),
            other => panic!("expected an error, got {:?}", other.map(|r| r.u.len())),
        }
        let long = SteadyStateOptions {
            half_period: Some(usize::MAX),
            ..o
        };
        match steady_state_experiment(&mut Lag, 0.8, &long) {
            Err(SmidError::Invalid { field, .. }) => {
                assert_eq!(field, "experiment.steady_state.half_period")
            }
            other => panic!("expected an error, got {:?}", other.map(|r| r.u.len())),
        }
        assert_eq!(crate::signals::filter_settling(1.0), usize::MAX);
        assert_eq!(crate::signals::filter_settling(f64::NAN), usize::MAX);
    }
}
