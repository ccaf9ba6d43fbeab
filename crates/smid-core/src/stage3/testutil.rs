//! Test helpers of the stage-3 methods: random stable linear blocks (with or without extra
//! regressor columns) with interval-valued inner signals whose bounds contain the truth
//! (eqs 28-30), and the EIV problem over them: the cases the core's methods are tested on, for
//! the tests of a stage-3 method in a crate of its own too. Always compiled, so that a test
//! build and a release build of the core are one build (no feature splits it in two).
use super::{EivProblem, Regressor};
use crate::interval::Interval;
use crate::inversion::{InnerBound, InnerKind};
use crate::linear::LinearModel;
use rand::{Rng, SeedableRng};

/// `default` cases, or `PROPTEST_CASES` when set.
#[cfg(test)]
pub(crate) fn cases(default: u32) -> proptest::test_runner::Config {
    proptest::test_runner::Config::with_cases(
        std::env::var("PROPTEST_CASES")
            .ok()
            .and_then(|v| v.parse().ok())
            .unwrap_or(default),
    )
}

/// A random stable 2nd-order block with `b0 = 0` and unit gain, its PRBS-driven inner
/// signal, and bounds `x_t ± Δ_t` around the true value moved by a uniform error in the bound
/// (some samples band-wide, as the output-backlash plugin gives them).
pub fn random_case(seed: u64, n: usize) -> (LinearModel, Vec<InnerBound>, Vec<Interval>) {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let r: f64 = rng.gen_range(0.2..0.85);
    let phi: f64 = rng.gen_range(0.0..std::f64::consts::PI);
    let (a1, a2) = (-2.0 * r * phi.cos(), r * r);
    let g = 1.0 + a1 + a2;
    let b1 = rng.gen_range(0.2..1.5) * g;
    let m = LinearModel {
        a: vec![a1, a2],
        b: vec![0.0, b1, g - b1],
    };
    let u: Vec<f64> = (0..n)
        .map(|_| if rng.gen_bool(0.5) { 1.0 } else { -1.0 })
        .collect();
    let x = m.simulate(&u);
    let dx = 10f64.powf(rng.gen_range(-4.0..-1.5));
    let out = x
        .iter()
        .map(|&v| {
            let band = rng.gen_bool(0.1);
            let d = if band {
                20.0 * dx
            } else {
                dx * rng.gen_range(0.5..1.5)
            };
            let c = v + rng.gen_range(-d..=d);
            InnerBound {
                interval: Interval::new(c - d, c + d),
                kind: if band {
                    InnerKind::Band
                } else {
                    InnerKind::Inverted
                },
            }
        })
        .collect();
    let input = u.iter().map(|&v| Interval::new(v, v)).collect();
    (m, out, input)
}

/// The EIV problem of a second-order case (`b0` fixed at zero, unit gain) over `out` and
/// `input`; `band` lets the band samples in.
pub fn problem<'a>(out: &'a [InnerBound], input: &'a [Interval], band: bool) -> EivProblem<'a> {
    EivProblem {
        locate: true,
        na: 2,
        nb: 2,
        fixed: vec![None, None, Some(0.0), None, None],
        unit_gain: true,
        output: out,
        input,
        use_band_samples: band,
        lagged: None,
        extra: &[],
        prior: None,
    }
}

/// The true θ of `m` (`a_1..a_na, b_0..b_nb`).
pub fn truth(m: &LinearModel) -> Vec<f64> {
    m.a.iter().chain(&m.b).copied().collect()
}

/// A random case with extra regressor columns: the block of [`random_case`]'s kind plus an
/// offset (a column of exact ones) and a friction-like column `sign(u_t - u_{t-1})`, with
/// random coefficients.
pub struct ExtraCase {
    /// The true linear block.
    pub m: LinearModel,
    /// True coefficients of the extra columns (offset, friction).
    pub c: Vec<f64>,
    /// Bounds of the inner signal, holding the truth.
    pub out: Vec<InnerBound>,
    /// The input (exact).
    pub input: Vec<Interval>,
    /// The extra columns (offset, friction).
    pub extra: Vec<Regressor>,
}

impl ExtraCase {
    /// The true θ: `a1, a2, b0, b1, b2, offset, friction`.
    pub fn truth(&self) -> Vec<f64> {
        truth(&self.m).into_iter().chain(self.c.clone()).collect()
    }

    /// The problem with `b0 = 0` fixed, unit gain, both extra columns.
    pub fn problem(&self, band: bool) -> EivProblem<'_> {
        EivProblem {
            fixed: vec![None, None, Some(0.0), None, None, None, None],
            extra: &self.extra,
            ..problem(&self.out, &self.input, band)
        }
    }
}

/// An [`ExtraCase`] of `n` samples; the friction column is known to within `friction_radius`
/// (0: exact), its intervals placed at random around the true value.
pub fn random_extra_case(seed: u64, n: usize, friction_radius: f64) -> ExtraCase {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let r: f64 = rng.gen_range(0.2..0.85);
    let phi: f64 = rng.gen_range(0.0..std::f64::consts::PI);
    let (a1, a2) = (-2.0 * r * phi.cos(), r * r);
    let g = 1.0 + a1 + a2;
    let b1 = rng.gen_range(0.2..1.5) * g;
    let m = LinearModel {
        a: vec![a1, a2],
        b: vec![0.0, b1, g - b1],
    };
    let c = vec![rng.gen_range(-0.3..0.3), rng.gen_range(-0.2..0.2)];
    let u: Vec<f64> = (0..n)
        .map(|_| if rng.gen_bool(0.5) { 1.0 } else { -1.0 })
        .collect();
    let friction: Vec<f64> = (0..n)
        .map(|t| match t.checked_sub(1).map(|s| u[t] - u[s]) {
            Some(d) if d > 0.0 => 1.0,
            Some(d) if d < 0.0 => -1.0,
            _ => 0.0,
        })
        .collect();
    // x_t = -Σ a_i x_{t-i} + Σ b_j u_{t-j} + c_0 + c_1 φ_t, from rest.
    let mut x = vec![0.0; n];
    for t in 0..n {
        let mut v = c[0] + c[1] * friction[t];
        for (i, a) in m.a.iter().enumerate() {
            if t > i {
                v -= a * x[t - i - 1];
            }
        }
        for (j, b) in m.b.iter().enumerate() {
            if t >= j {
                v += b * u[t - j];
            }
        }
        x[t] = v;
    }
    let dx = 10f64.powf(rng.gen_range(-4.0..-1.5));
    let out = x
        .iter()
        .map(|&v| {
            let band = rng.gen_bool(0.1);
            let d = if band {
                20.0 * dx
            } else {
                dx * rng.gen_range(0.5..1.5)
            };
            let c = v + rng.gen_range(-d..=d);
            InnerBound {
                interval: Interval::new(c - d, c + d),
                kind: if band {
                    InnerKind::Band
                } else {
                    InnerKind::Inverted
                },
            }
        })
        .collect();
    let input = u.iter().map(|&v| Interval::new(v, v)).collect();
    let friction = friction
        .iter()
        .map(|&f| {
            let c = f + rng.gen_range(-friction_radius..=friction_radius);
            Interval::new(c - friction_radius, c + friction_radius)
        })
        .collect();
    let extra = vec![
        Regressor {
            name: "offset".into(),
            values: vec![Interval::new(1.0, 1.0); n],
        },
        Regressor {
            name: "friction".into(),
            values: friction,
        },
    ];
    ExtraCase {
        m,
        c,
        out,
        input,
        extra,
    }
}

/// A [`feedback_case`]: orders, the true θ (`a`'s, `b`'s, then the constant's coefficient),
/// the stage-2 bounds of `x`, the input, the measured past outputs and the constant column.
pub struct FeedbackCase {
    /// Order of `A(q)`.
    pub na: usize,
    /// Order of `B(q)`.
    pub nb: usize,
    /// The true θ (`a`'s, `b`'s, then the constant's coefficient).
    pub theta: Vec<f64>,
    /// Stage-2 bounds of `x`.
    pub out: Vec<InnerBound>,
    /// The input (exact).
    pub input: Vec<Interval>,
    /// The measured past outputs.
    pub lagged: Vec<Interval>,
    /// The constant column.
    pub extra: Vec<Regressor>,
}

impl FeedbackCase {
    /// The problem with the past outputs read from data, every coefficient free.
    pub fn problem(&self) -> EivProblem<'_> {
        EivProblem {
            na: self.na,
            nb: self.nb,
            fixed: vec![None; self.theta.len()],
            unit_gain: false,
            output: &self.out,
            input: &self.input,
            use_band_samples: false,
            locate: true,
            extra: &self.extra,
            prior: None,
            lagged: Some(&self.lagged),
        }
    }
}

/// A random loop with a clip inside it, `x_t = -Σ a_i w_{t-i} + Σ b_j u_{t-j} + c`,
/// `w_t = min(s, x_t)`, measured as `w_t + η_t` (`|η_t| <= d`): the true θ (`a`'s, `b`'s,
/// `c`), the stage-2 bounds of `x` (a clipped sample known from below only) and the measured
/// past outputs.
pub fn feedback_case(seed: u64) -> FeedbackCase {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let na = rng.gen_range(1..=3);
    let nb = rng.gen_range(0..=2);
    let poles: Vec<f64> = (0..na).map(|_| rng.gen_range(-0.7..0.9)).collect();
    let a = crate::linear::from_real_poles(&poles);
    let b: Vec<f64> = (0..=nb).map(|_| rng.gen_range(-1.0..1.0)).collect();
    let c = rng.gen_range(-0.2..0.2);
    let n = rng.gen_range(60..160);
    let u: Vec<f64> = (0..n).map(|_| rng.gen_range(-1.0..1.0)).collect();
    let mut x: Vec<f64> = Vec::with_capacity(n);
    let mut w: Vec<f64> = Vec::with_capacity(n);
    // The clip sits inside the range the loop would reach.
    let s = rng.gen_range(0.2..0.6) * (1.0 + b.iter().map(|v| v.abs()).sum::<f64>());
    for t in 0..n {
        let mut xt = c;
        for (j, bj) in b.iter().enumerate() {
            if t >= j {
                xt += bj * u[t - j];
            }
        }
        for (i, ai) in a.iter().enumerate() {
            if t > i {
                xt -= ai * w[t - 1 - i];
            }
        }
        x.push(xt);
        w.push(xt.min(s));
    }
    let d = 10f64.powf(rng.gen_range(-3.0..-1.5));
    let y: Vec<f64> = w.iter().map(|v| v + rng.gen_range(-d..=d)).collect();
    let out: Vec<InnerBound> = y
        .iter()
        .map(|&y| {
            if y + d < s {
                InnerBound {
                    interval: Interval::new(y - d, y + d),
                    kind: InnerKind::Inverted,
                }
            } else {
                // At the clip or possibly so: `x >= y - d`, no upper end.
                InnerBound {
                    interval: Interval::new(y - d, f64::INFINITY),
                    kind: InnerKind::Band,
                }
            }
        })
        .collect();
    let lagged: Vec<Interval> = y.iter().map(|&y| Interval::new(y - d, y + d)).collect();
    let input: Vec<Interval> = u.iter().map(|&v| Interval::new(v, v)).collect();
    let theta: Vec<f64> = a.iter().chain(&b).copied().chain([c]).collect();
    let extra = vec![Regressor {
        name: "constant".into(),
        values: vec![Interval::new(1.0, 1.0); n],
    }];
    FeedbackCase {
        na,
        nb,
        theta,
        out,
        input,
        lagged,
        extra,
    }
}
