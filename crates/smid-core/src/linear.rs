//! The linear block `x_t = B(q^-1)/A(q^-1) u_t` (paper eq 1), with `A = 1 + a_1 q^-1 + ...`
//! and `B = b_0 + b_1 q^-1 + ...`: simulation, steady-state gain (eq 8) and a stability test
//! (assumption (i) of Section 2) on the companion matrix's eigenvalues.
use crate::error::{Result, SmidError};
use serde::{Deserialize, Serialize};

/// Coefficients of `A(q^-1)` (without the leading 1) and `B(q^-1)` (from `b_0`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LinearModel {
    /// `[a_1, ..., a_na]`.
    pub a: Vec<f64>,
    /// `[b_0, b_1, ..., b_nb]`.
    pub b: Vec<f64>,
}

impl LinearModel {
    /// Steady-state gain `sum b / (1 + sum a)` (eq 8).
    pub fn gain(&self) -> f64 {
        self.b.iter().sum::<f64>() / (1.0 + self.a.iter().sum::<f64>())
    }

    /// Largest modulus of the roots of `z^na + a_1 z^(na-1) + ... + a_na`.
    pub fn spectral_radius(&self) -> f64 {
        let n = self.a.len();
        if n == 0 {
            return 0.0;
        }
        let mut c = nalgebra::DMatrix::<f64>::zeros(n, n);
        for j in 0..n {
            c[(0, j)] = -self.a[j];
        }
        for i in 1..n {
            c[(i, i - 1)] = 1.0;
        }
        c.complex_eigenvalues()
            .iter()
            .map(|z| z.norm())
            .fold(0.0, f64::max)
    }

    /// Check finiteness, asymptotic stability and a non-zero gain (Section 2, (i)-(ii)).
    pub fn validate(&self, field: &str) -> Result<()> {
        if self.b.is_empty() {
            return Err(SmidError::invalid(
                format!("{field}.b"),
                "needs at least one coefficient",
            ));
        }
        for (name, v) in [("a", &self.a), ("b", &self.b)] {
            if let Some(i) = v.iter().position(|x| !x.is_finite()) {
                return Err(SmidError::invalid(
                    format!("{field}.{name}[{i}]"),
                    "must be a finite number",
                ));
            }
        }
        let r = self.spectral_radius();
        if !(r < 1.0) {
            return Err(SmidError::invalid(
                format!("{field}.a"),
                format!("the linear block must be asymptotically stable (largest pole modulus {r:.4} >= 1)"),
            ));
        }
        if self.b.iter().sum::<f64>() == 0.0 {
            return Err(SmidError::invalid(
                format!("{field}.b"),
                "steady-state gain must not be zero",
            ));
        }
        Ok(())
    }

    /// A stateful simulator starting at rest.
    pub fn simulator(&self) -> LinearSim<'_> {
        LinearSim {
            model: self,
            past_x: vec![0.0; self.a.len()],
            past_u: vec![0.0; self.b.len()],
        }
    }

    /// Simulate from rest: `x_t = -sum a_i x_{t-i} + sum b_j u_{t-j}`.
    pub fn simulate(&self, u: &[f64]) -> Vec<f64> {
        let mut s = self.simulator();
        u.iter().map(|&ut| s.step(ut)).collect()
    }
}

/// Direct-form simulator of a [`LinearModel`] (state: past inputs and outputs).
pub struct LinearSim<'a> {
    model: &'a LinearModel,
    past_x: Vec<f64>, // x_{t-1}, x_{t-2}, ...
    past_u: Vec<f64>, // u_t, u_{t-1}, ... (after push)
}

impl LinearSim<'_> {
    /// Feed `u_t`, return `x_t`.
    pub fn step(&mut self, u: f64) -> f64 {
        self.past_u.rotate_right(1);
        self.past_u[0] = u;
        let mut x = 0.0;
        for (bj, uj) in self.model.b.iter().zip(&self.past_u) {
            x += bj * uj;
        }
        for (ai, xi) in self.model.a.iter().zip(&self.past_x) {
            x -= ai * xi;
        }
        if !self.past_x.is_empty() {
            self.past_x.rotate_right(1);
            self.past_x[0] = x;
        }
        x
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    fn paper() -> LinearModel {
        LinearModel {
            a: vec![0.5, 0.7],
            b: vec![0.0, 1.4, 0.8],
        }
    }
    #[test]
    fn paper_system_has_unit_gain_and_is_stable() {
        let m = paper();
        assert!((m.gain() - 1.0).abs() < 1e-15);
        assert!((m.spectral_radius() - 0.7f64.sqrt()).abs() < 1e-12);
        assert!(m.validate("plant").is_ok());
        let x = m.simulate(&vec![1.0; 400]);
        assert!((x[399] - 1.0).abs() < 1e-12);
        assert_eq!(x[0], 0.0);
        assert!((x[1] - 1.4).abs() < 1e-15);
    }
    #[test]
    fn unstable_is_rejected_with_field() {
        let m = LinearModel {
            a: vec![-2.0],
            b: vec![1.0],
        };
        let e = m.validate("plant").unwrap_err().to_string();
        assert!(e.contains("plant.a") && e.contains("stable"), "{e}");
    }
}
