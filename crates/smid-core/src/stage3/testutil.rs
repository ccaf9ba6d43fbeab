//! Test helpers of the stage-3 methods: random stable linear blocks with interval-valued inner
//! signals whose bounds contain the truth (eqs 28-30), and the EIV problem over them.
use super::EivProblem;
use crate::interval::Interval;
use crate::inversion::{InnerBound, InnerKind};
use crate::linear::LinearModel;
use rand::{Rng, SeedableRng};

/// A random stable 2nd-order block with `b0 = 0` and unit gain, its PRBS-driven inner
/// signal, and bounds `x_t ± Δ_t` around the true value moved by a uniform error in the bound
/// (some samples band-wide, as the output-backlash plugin gives them).
pub(crate) fn random_case(seed: u64, n: usize) -> (LinearModel, Vec<InnerBound>, Vec<Interval>) {
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

pub(crate) fn problem<'a>(
    out: &'a [InnerBound],
    input: &'a [Interval],
    band: bool,
) -> EivProblem<'a> {
    EivProblem {
        na: 2,
        nb: 2,
        fixed: vec![None, None, Some(0.0), None, None],
        unit_gain: true,
        output: out,
        input,
        use_band_samples: band,
    }
}

/// The true θ of `m` (`a_1..a_na, b_0..b_nb`).
pub(crate) fn truth(m: &LinearModel) -> Vec<f64> {
    m.a.iter().chain(&m.b).copied().collect()
}
