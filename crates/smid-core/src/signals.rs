//! Input signals: the first-order low-pass filter `F(z) = (1-a)/(z-a)` of Section 3.1 (eq 9),
//! filtered square waves for the steady-state experiment (Section 3.2), and maximal-length
//! PRBS sequences for the dynamic experiment (Section 4).
use rand::Rng;

/// Apply `F(z) = (1-a)/(z-a)` from rest: `u_{t+1} = a u_t + (1-a) r_t`, `u_0 = 0`.
pub fn lowpass(a: f64, r: &[f64]) -> Vec<f64> {
    let mut u = Vec::with_capacity(r.len());
    let mut state = 0.0;
    for &rt in r {
        u.push(state);
        state = a * state + (1.0 - a) * rt;
    }
    u
}

/// Samples after which `a^n * scale` falls below `1e-14 * scale`: the filter has settled
/// (`usize::MAX` for a pole that never settles, `a >= 1` or NaN; callers cap their lengths).
pub fn filter_settling(a: f64) -> usize {
    if a <= 0.0 {
        1
    } else if !(a < 1.0) {
        usize::MAX
    } else {
        // `as` saturates: a pole within 1e-16 of 1 gives usize::MAX, not a wrap.
        (((1e-14f64).ln() / a.ln()).ceil() as usize).saturating_add(1)
    }
}

/// Feedback taps (1-based, Fibonacci LFSR) giving a maximal-length sequence per register size.
fn taps(bits: u32) -> &'static [u32] {
    match bits {
        2 => &[2, 1],
        3 => &[3, 2],
        4 => &[4, 3],
        5 => &[5, 3],
        6 => &[6, 5],
        7 => &[7, 6],
        8 => &[8, 6, 5, 4],
        9 => &[9, 5],
        10 => &[10, 7],
        11 => &[11, 9],
        12 => &[12, 11, 10, 4],
        13 => &[13, 12, 11, 8],
        14 => &[14, 13, 12, 2],
        15 => &[15, 14],
        _ => &[16, 15, 13, 4],
    }
}

/// A PRBS of `n` samples taking `±amplitude`, each bit held `hold` samples, from a maximal
/// LFSR whose register is just long enough for `n / hold` bits and whose non-zero starting
/// state is drawn from `rng`.
pub fn prbs(n: usize, amplitude: f64, hold: usize, rng: &mut impl Rng) -> Vec<f64> {
    let hold = hold.max(1);
    let bits_needed = n.div_ceil(hold).max(3);
    let mut bits = 2;
    while bits < 16 && (1usize << bits) - 1 < bits_needed {
        bits += 1;
    }
    let mask = (1u32 << bits) - 1;
    let mut reg: u32 = rng.gen_range(1..=mask);
    let tp = taps(bits);
    let mut out = Vec::with_capacity(n);
    while out.len() < n {
        let bit = tp.iter().fold(0, |acc, &k| acc ^ ((reg >> (k - 1)) & 1));
        reg = ((reg << 1) | bit) & mask;
        let v = if reg & 1 == 1 { amplitude } else { -amplitude };
        for _ in 0..hold {
            if out.len() < n {
                out.push(v);
            }
        }
    }
    out
}

/// A multilevel pseudo-random sequence: the PRBS's signs times a magnitude drawn uniformly
/// from `levels` equally spaced values in `(0, amplitude]`, held `hold` samples. Steps of
/// several sizes tell apart effects that a binary PRBS cannot (a Coulomb and a viscous term
/// are proportional on `±A`).
pub fn multilevel(
    n: usize,
    amplitude: f64,
    hold: usize,
    levels: usize,
    rng: &mut impl Rng,
) -> Vec<f64> {
    let signs = prbs(n, 1.0, hold, rng);
    let levels = levels.max(1);
    let mut out = Vec::with_capacity(n);
    let mut mag = amplitude;
    for (t, s) in signs.iter().enumerate() {
        if t % hold.max(1) == 0 {
            mag = amplitude * rng.gen_range(1..=levels) as f64 / levels as f64;
        }
        out.push(s * mag);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    #[test]
    fn lowpass_reaches_the_step_without_overshoot() {
        let u = lowpass(0.8, &vec![3.0; 200]);
        assert_eq!(u[0], 0.0);
        assert!(u.windows(2).all(|w| w[1] >= w[0] && w[1] <= 3.0));
        assert!((u[199] - 3.0).abs() < 1e-12);
    }
    #[test]
    fn prbs_is_balanced_and_maximal() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(1);
        let p = prbs(127, 1.0, 1, &mut rng);
        let pos = p.iter().filter(|&&v| v > 0.0).count();
        assert_eq!(pos, 64, "a maximal 7-bit sequence has 64 ones");
        for bits in 3..=16u32 {
            // every tap set must give period 2^bits - 1
            let mask = (1u32 << bits) - 1;
            let mut reg = 1u32;
            let mut period = 0u32;
            loop {
                let bit = taps(bits)
                    .iter()
                    .fold(0, |acc, &k| acc ^ ((reg >> (k - 1)) & 1));
                reg = ((reg << 1) | bit) & mask;
                period += 1;
                if reg == 1 || period > mask {
                    break;
                }
            }
            assert_eq!(period, mask, "taps for {bits} bits");
        }
    }
}
