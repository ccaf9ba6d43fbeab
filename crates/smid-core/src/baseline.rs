//! The plain baseline every model is compared with: a least-squares ARX plus a constant
//! `y_t + a_1 y_{t-1} + ... + a_na y_{t-na} = b_0 u_{t-nk} + ... + b_nb u_{t-nk-nb} + c + e_t`
//! of the model's orders (eq 1 with the measured output in place of the inner signal), fitted
//! on the training records (equations stacked across records, none spanning two) and simulated
//! free-run from rest. No bound, no nonlinearity, no effect: the figure a model must beat.
use crate::error::{Result, SmidError};
use crate::linear::{least_squares, LinearModel};
use crate::model::Record;

/// A fitted ARX model.
#[derive(Debug, Clone, PartialEq)]
pub struct Arx {
    /// The fitted `A` and `B` coefficients.
    pub linear: LinearModel,
    /// Input delay `nk` in samples (`b_0` multiplies `u_{t-nk}`).
    pub nk: usize,
    /// The constant `c` (an offset of the operating point).
    pub constant: f64,
}

impl Arx {
    /// Least squares on the training records (SVD of the scaled normal equations).
    pub fn fit(records: &[Record], na: usize, nb: usize, nk: usize) -> Result<Arx> {
        let p = na + nb + 2;
        let start = na.max(nb + nk);
        let mut rows: Vec<(Vec<f64>, f64)> = Vec::new();
        for r in records {
            for t in start..r.y.len() {
                let mut phi = Vec::with_capacity(p);
                for i in 1..=na {
                    phi.push(-r.y[t - i]);
                }
                for j in 0..=nb {
                    phi.push(r.u[t - nk - j]);
                }
                phi.push(1.0);
                rows.push((phi, r.y[t]));
            }
        }
        if rows.len() < p {
            return Err(SmidError::invalid(
                "baseline",
                format!("{} equations for {p} ARX coefficients", rows.len()),
            ));
        }
        let theta = least_squares(&rows);
        Ok(Arx {
            linear: LinearModel {
                a: theta[..na].to_vec(),
                b: theta[na..p - 1].to_vec(),
            },
            nk,
            constant: theta[p - 1],
        })
    }

    /// Free-run simulation from rest (the constant acts from the first sample).
    pub fn simulate(&self, u: &[f64]) -> Vec<f64> {
        self.simulate_from(u, &[], 0)
    }

    /// Free-run simulation whose first `warm` outputs are the measured `y` (the initial
    /// condition), the rest from the input alone.
    pub fn simulate_from(&self, u: &[f64], y: &[f64], warm: usize) -> Vec<f64> {
        let n = u.len();
        let mut out = Vec::with_capacity(n);
        for t in 0..n {
            if t < warm.min(y.len()) {
                out.push(y[t]);
                continue;
            }
            let mut x = self.constant;
            for (j, b) in self.linear.b.iter().enumerate() {
                if t >= self.nk + j {
                    x += b * u[t - self.nk - j];
                }
            }
            for (i, a) in self.linear.a.iter().enumerate() {
                if t > i {
                    x -= a * out[t - 1 - i];
                }
            }
            out.push(x);
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn recovers_an_exact_arx_and_simulates_it() {
        let m = LinearModel {
            a: vec![-0.5, 0.2],
            b: vec![0.0, 1.0, 0.3],
        };
        let u: Vec<f64> = (0..200).map(|t| ((t * 37 % 11) as f64) - 5.0).collect();
        let y = m.simulate(&u);
        let rec = Record::measured("r", u.clone(), y.clone(), 0.1, 1.0);
        let arx = Arx::fit(&[rec], 2, 2, 0).unwrap();
        for (a, b) in arx.linear.a.iter().zip(&m.a) {
            assert!((a - b).abs() < 1e-9);
        }
        let ys = arx.simulate(&u);
        assert!(ys.iter().zip(&y).all(|(a, b)| (a - b).abs() < 1e-6));
        // From a measured initial condition: the same trajectory (the data start at rest).
        let yw = arx.simulate_from(&u, &y, 4);
        assert!(yw.iter().zip(&ys).all(|(a, b)| (a - b).abs() < 1e-6));
        assert!(arx.constant.abs() < 1e-9);
        // A constant (an operating-point offset) is part of the baseline.
        let with_c = Arx {
            linear: m.clone(),
            nk: 0,
            constant: 0.7,
        };
        let yc = with_c.simulate(&u);
        let fit = Arx::fit(&[Record::measured("c", u.clone(), yc, 0.1, 1.0)], 2, 2, 0).unwrap();
        assert!((fit.constant - 0.7).abs() < 1e-8, "{}", fit.constant);
        let short = Record::measured("s", vec![1.0; 3], vec![1.0; 3], 0.1, 1.0);
        assert!(Arx::fit(&[short], 2, 2, 0).is_err());
    }
}
