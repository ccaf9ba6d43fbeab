//! Exact rational arithmetic for the certificates of the LP engine ([`crate::lp`]). Every
//! finite `f64` is a rational number, so a combination of rows whose weights solve the basis
//! system **exactly** has no residual and no rounding: its sign is a proof whatever the
//! conditioning of the rows. Used where the floating-point certificate cannot conclude (a
//! nearly empty polytope, whose Farkas combination has a right-hand side below the rounding of
//! the float sums). The systems are small (`n` = the free linear parameters), so the cost of
//! big rationals is negligible next to the LP that asked for them.
use num_rational::BigRational;
use num_traits::{Signed, Zero};

/// Largest system solved exactly (rational entries grow with the size).
pub const MAX_EXACT: usize = 40;

/// The exact rational value of a finite float (`None` for NaN or infinity).
pub fn rational(x: f64) -> Option<BigRational> {
    BigRational::from_float(x)
}

/// Solve `A y = b` exactly, `A` given by `n` rows of `n` floats. `None` when `A` is singular,
/// an entry is not finite, or `n` exceeds [`MAX_EXACT`].
pub fn solve(a: &[Vec<f64>], b: &[f64]) -> Option<Vec<BigRational>> {
    let b: Vec<BigRational> = b.iter().map(|&v| rational(v)).collect::<Option<_>>()?;
    solve_rational(a, b)
}

/// [`solve`] with an exact rational right-hand side.
pub fn solve_rational(a: &[Vec<f64>], b: Vec<BigRational>) -> Option<Vec<BigRational>> {
    let n = b.len();
    if n > MAX_EXACT || a.len() != n || a.iter().any(|r| r.len() != n) {
        return None;
    }
    let mut m: Vec<Vec<BigRational>> = Vec::with_capacity(n);
    for (row, bi) in a.iter().zip(b) {
        let mut r: Vec<BigRational> = row.iter().map(|&v| rational(v)).collect::<Option<_>>()?;
        r.push(bi);
        m.push(r);
    }
    for col in 0..n {
        let p = (col..n).find(|&i| !m[i][col].is_zero())?;
        m.swap(col, p);
        let pivot = m[col][col].clone();
        for i in col + 1..n {
            if m[i][col].is_zero() {
                continue;
            }
            let f = &m[i][col] / &pivot;
            for k in col..=n {
                let t = &f * &m[col][k];
                m[i][k] -= t;
            }
        }
    }
    let mut y: Vec<BigRational> = vec![BigRational::zero(); n];
    for i in (0..n).rev() {
        let mut s = m[i][n].clone();
        for k in i + 1..n {
            s -= &m[i][k] * &y[k];
        }
        y[i] = s / &m[i][i];
    }
    Some(y)
}

/// Whether `Σ w_i h_i < 0` exactly, the weights being exact rationals and `h` floats.
pub fn negative_combination(w: &[BigRational], h: &[f64]) -> Option<bool> {
    let mut s = BigRational::zero();
    for (wi, &hi) in w.iter().zip(h) {
        s += wi * rational(hi)?;
    }
    Some(s.is_negative())
}

#[cfg(test)]
mod tests {
    use super::*;
    use num_traits::ToPrimitive;

    #[test]
    fn solves_exactly_where_floats_round() {
        // 0.1 is not 1/10 in binary; the exact solution of x * 0.1 = 0.3 is the ratio of the
        // two binary fractions, not 3.
        let y = solve(&[vec![0.1]], &[0.3]).unwrap();
        assert_ne!(y[0], BigRational::from_integer(3.into()));
        assert_eq!(&y[0] * rational(0.1).unwrap(), rational(0.3).unwrap());
        // A 3x3 system with a known solution.
        let a = vec![
            vec![2.0, 1.0, -1.0],
            vec![-3.0, -1.0, 2.0],
            vec![-2.0, 1.0, 2.0],
        ];
        let y = solve(&a, &[8.0, -11.0, -3.0]).unwrap();
        let f: Vec<f64> = y.iter().map(|v| v.to_f64().unwrap()).collect();
        assert_eq!(f, vec![2.0, 3.0, -1.0]);
    }

    #[test]
    fn singular_and_non_finite_systems_give_none() {
        assert!(solve(&[vec![1.0, 2.0], vec![2.0, 4.0]], &[1.0, 2.0]).is_none());
        assert!(solve(&[vec![f64::NAN]], &[1.0]).is_none());
    }

    #[test]
    fn the_sign_of_a_combination_is_exact() {
        // 1e16 + 1 - 1e16 rounds to 0 in floats; exactly it is 1.
        let w = vec![rational(1.0).unwrap(); 3];
        assert_eq!(negative_combination(&w, &[1e16, -1.0, -1e16]), Some(true));
        assert_eq!(negative_combination(&w, &[1e16, 1.0, -1e16]), Some(false));
    }
}
