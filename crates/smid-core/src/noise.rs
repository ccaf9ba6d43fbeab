//! Bounded measurement noise (eqs 4-5): the bound `Δη` given directly or from an absolute encoder
//! of `n_bit` bits read as one LSB over a revolution, `Δη = 2π / 2^n_bit` (Section 6); noise
//! drawn uniformly in `[-Δη, Δη]` for simulated plants; the signal-to-noise ratio of Table II.
use crate::error::{Result, SmidError};
use rand::Rng;
use serde::{Deserialize, Serialize};

/// How the noise bound is declared in a spec: `delta` or `encoder_bits`, or `estimate` for
/// measured data whose sensor bound is not known (then `Δη` is the margin times the smallest
/// bound for which the training records are consistent with the model, and every report says
/// the bound was estimated, not given).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct NoiseSpec {
    /// The bound `Δη` itself.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub delta: Option<f64>,
    /// Encoder resolution: `Δη = 2π / 2^encoder_bits`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub encoder_bits: Option<u32>,
    /// Amplitude of the uniform noise the experiment adds to a simulated or FMU plant (default:
    /// the bound). Set it lower when the plant has its own measurement error (e.g. an encoder's
    /// quantization inside an FMU), so that added noise plus the plant's own stays within the bound.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub simulate: Option<f64>,
    /// Estimate `Δη` from the training data: this margin (`>= 1`) times the smallest bound for
    /// which they are consistent with the model (bisection). With `delta` also present, `delta`
    /// is that estimate (as `result.json` stores it).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub estimate: Option<f64>,
    /// What `estimate` measures (default `relaxation`). `relaxation`: the smallest bound for
    /// which stage 3's relaxation finds the training records consistent, a lower end of the
    /// model's smallest consistent bound. `free_run`: then the largest free-run error on the
    /// training records of the best simulator found in the set at that bound, an upper end (a
    /// trajectory of the model within it of every sample): the set at the margin times it
    /// holds that simulator, certified, where a bound at the lower end may hold no member that
    /// simulates at all (measured data, whose model error is not a sensor's noise).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub from: Option<EstimateFrom>,
}

/// What an estimated noise bound measures ([`NoiseSpec::from`]).
#[derive(
    Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize, schemars::JsonSchema,
)]
#[serde(rename_all = "snake_case")]
pub enum EstimateFrom {
    /// The smallest bound the stage-3 relaxation finds consistent (the lower end).
    #[default]
    Relaxation,
    /// The largest training free-run error of the best simulator found (the upper end).
    FreeRun,
}

impl NoiseSpec {
    /// Whether the bound is (to be) estimated from the data.
    pub fn estimated(&self) -> bool {
        self.estimate.is_some()
    }

    /// Whether an estimated bound is the free-run distance of a simulator (`from: free_run`).
    pub fn from_free_run(&self) -> bool {
        self.estimate.is_some() && self.from == Some(EstimateFrom::FreeRun)
    }

    /// Whether the bound is still to be estimated: `estimate` without a `delta` (with both,
    /// `delta` is the estimate already made).
    pub fn to_estimate(&self) -> bool {
        self.estimate.is_some() && self.delta.is_none()
    }

    /// Check the estimate's margin (`>= 1`, finite).
    pub fn check_estimate(&self) -> Result<()> {
        match self.estimate {
            Some(m) if !(m.is_finite() && m >= 1.0) => Err(SmidError::invalid(
                "noise.estimate",
                format!("expected a margin >= 1, got {m}"),
            )),
            Some(_) if self.encoder_bits.is_some() => Err(SmidError::invalid(
                "noise",
                "give `estimate` or `encoder_bits`, not both",
            )),
            None if self.from.is_some() => Err(SmidError::invalid(
                "noise.from",
                "says what an estimated bound measures: give it with `estimate`",
            )),
            _ => Ok(()),
        }
    }

    /// Amplitude of the noise added to simulated plants, checked (`0 <= simulate`).
    pub fn simulated(&self) -> Result<f64> {
        let d = self.delta()?;
        match self.simulate {
            None => Ok(d),
            Some(s) if s.is_finite() && s >= 0.0 => Ok(s),
            Some(s) => Err(SmidError::invalid(
                "noise.simulate",
                format!("expected a finite number >= 0, got {s}"),
            )),
        }
    }

    /// The bound `Δη > 0`, checked.
    pub fn delta(&self) -> Result<f64> {
        match (self.delta, self.encoder_bits) {
            (Some(d), None) => {
                if d.is_finite() && d > 0.0 {
                    Ok(d)
                } else {
                    Err(SmidError::invalid(
                        "noise.delta",
                        format!("expected a finite number > 0, got {d}"),
                    ))
                }
            }
            (None, Some(b)) => {
                if (1..=52).contains(&b) {
                    Ok(encoder_delta(b))
                } else {
                    Err(SmidError::invalid(
                        "noise.encoder_bits",
                        format!("expected 1..=52 bits, got {b}"),
                    ))
                }
            }
            (Some(_), Some(_)) => Err(SmidError::invalid(
                "noise",
                "give either `delta` or `encoder_bits`, not both",
            )),
            (None, None) if self.estimate.is_some() => Err(SmidError::invalid(
                "noise.estimate",
                "the bound is estimated from the training data during identification (smid run)",
            )),
            (None, None) => Err(SmidError::invalid(
                "noise",
                "give `delta` (the bound Δη), `encoder_bits` or `estimate`",
            )),
        }
    }
}

/// `Δη = 2π / 2^n_bit`.
pub fn encoder_delta(bits: u32) -> f64 {
    2.0 * std::f64::consts::PI / 2f64.powi(bits as i32)
}

/// `n` samples uniform in `[-delta, delta]`.
pub fn uniform(n: usize, delta: f64, rng: &mut impl Rng) -> Vec<f64> {
    (0..n).map(|_| rng.gen_range(-delta..=delta)).collect()
}

/// `10 log10(Σ w² / Σ η²)` in dB.
pub fn snr_db(signal: &[f64], noise: &[f64]) -> f64 {
    let ps: f64 = signal.iter().map(|v| v * v).sum();
    let pn: f64 = noise.iter().map(|v| v * v).sum();
    10.0 * (ps / pn).log10()
}
