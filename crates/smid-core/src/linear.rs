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

/// Largest modulus of the roots of `z^n + a_1 z^(n-1) + ... + a_n` (the poles of `1/A`, for
/// `a = [a_1, ..., a_n]`); infinite when the eigenvalue iteration does not converge (a
/// non-finite coefficient; at most 10 000 QR steps, so no input can make it spin).
pub fn spectral_radius(a: &[f64]) -> f64 {
    match roots(a) {
        Some(r) => r.iter().map(|z| z.norm()).fold(0.0, f64::max),
        None => f64::INFINITY,
    }
}

/// The roots of `z^n + a_1 z^(n-1) + ... + a_n`: the eigenvalues of its companion matrix;
/// `None` when the iteration (at most 10 000 QR steps) does not converge.
fn roots(a: &[f64]) -> Option<Vec<nalgebra::Complex<f64>>> {
    let n = a.len();
    if n == 0 {
        return Some(Vec::new());
    }
    let mut c = nalgebra::DMatrix::<f64>::zeros(n, n);
    for j in 0..n {
        c[(0, j)] = -a[j];
    }
    for i in 1..n {
        c[(i, i - 1)] = 1.0;
    }
    let schur = nalgebra::Schur::try_new(c, f64::EPSILON, 10_000)?;
    Some(schur.complex_eigenvalues().iter().copied().collect())
}

/// The coefficients `a_1..a_n` of `A(q) = Π (1 - p_k q⁻¹)` with real poles `p_k`.
pub fn from_real_poles(poles: &[f64]) -> Vec<f64> {
    let mut a = vec![1.0];
    for p in poles {
        let mut next = a.clone();
        next.push(0.0);
        for i in 1..next.len() {
            next[i] -= p * a[i - 1];
        }
        a = next;
    }
    a[1..].to_vec()
}

/// The nearest stable polynomial in the roots: `a` with every root of
/// `z^n + a_1 z^(n-1) + ... + a_n` of modulus above 1 moved radially to just inside the unit
/// circle (modulus `1 - 1e-12`), the others kept; `None` when the roots cannot be computed. A
/// stable `a` comes back unchanged.
pub fn stable_projection(a: &[f64]) -> Option<Vec<f64>> {
    let roots = roots(a)?;
    if roots.iter().all(|z| z.norm() <= 1.0) {
        return Some(a.to_vec());
    }
    let edge = 1.0 - 1e-12;
    // Coefficients of prod (z - r), highest power first.
    let mut poly = vec![nalgebra::Complex::new(1.0, 0.0)];
    for r in roots.iter() {
        let r = if r.norm() > edge {
            r * (edge / r.norm())
        } else {
            *r
        };
        let mut next = poly.clone();
        next.push(nalgebra::Complex::new(0.0, 0.0));
        for (k, p) in poly.iter().enumerate() {
            next[k + 1] -= r * p;
        }
        poly = next;
    }
    let out: Vec<f64> = poly[1..].iter().map(|z| z.re).collect();
    out.iter().all(|v| v.is_finite()).then_some(out)
}

impl LinearModel {
    /// Steady-state gain `sum b / (1 + sum a)` (eq 8).
    pub fn gain(&self) -> f64 {
        self.b.iter().sum::<f64>() / (1.0 + self.a.iter().sum::<f64>())
    }

    /// Largest modulus of the roots of `z^na + a_1 z^(na-1) + ... + a_na`; infinite when the
    /// eigenvalue iteration does not converge (a non-finite coefficient; at most 10 000 QR
    /// steps, so no input can make it spin).
    pub fn spectral_radius(&self) -> f64 {
        spectral_radius(&self.a)
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

    /// Simulate from rest with an additive term in the equation:
    /// `x_t = -sum a_i x_{t-i} + sum b_j u_{t-j} + d_t`.
    pub fn simulate_with(&self, u: &[f64], d: &[f64]) -> Vec<f64> {
        let mut past = vec![0.0; self.a.len()];
        let mut x = Vec::with_capacity(u.len());
        for t in 0..u.len() {
            let mut v = d.get(t).copied().unwrap_or(0.0);
            for (j, b) in self.b.iter().enumerate() {
                if t >= j {
                    v += b * u[t - j];
                }
            }
            for (a, xi) in self.a.iter().zip(&past) {
                v -= a * xi;
            }
            if !past.is_empty() {
                past.rotate_right(1);
                past[0] = v;
            }
            x.push(v);
        }
        x
    }

    /// The series connection `self · other` (polynomial products of `A` and of `B`).
    pub fn series(&self, other: &LinearModel) -> LinearModel {
        let conv = |p: &[f64], q: &[f64]| {
            let mut r = vec![0.0; p.len() + q.len() - 1];
            for (i, a) in p.iter().enumerate() {
                for (j, b) in q.iter().enumerate() {
                    r[i + j] += a * b;
                }
            }
            r
        };
        let one = |a: &[f64]| {
            std::iter::once(1.0)
                .chain(a.iter().copied())
                .collect::<Vec<_>>()
        };
        let a = conv(&one(&self.a), &one(&other.a));
        LinearModel {
            a: a[1..].to_vec(),
            b: conv(&self.b, &other.b),
        }
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

/// `argmin |y - Φθ|_2` with column scaling, by SVD (rank-deficient: the least-norm solution in
/// the scaled columns).
pub fn least_squares(rows: &[(Vec<f64>, f64)]) -> Vec<f64> {
    let p = rows.first().map(|r| r.0.len()).unwrap_or(0);
    if p == 0 {
        return Vec::new();
    }
    let n = rows.len() as f64;
    let scale: Vec<f64> = (0..p)
        .map(|k| {
            let s = (rows.iter().map(|r| r.0[k] * r.0[k]).sum::<f64>() / n).sqrt();
            if s > 0.0 {
                s
            } else {
                1.0
            }
        })
        .collect();
    let mut ata = nalgebra::DMatrix::<f64>::zeros(p, p);
    let mut aty = nalgebra::DVector::<f64>::zeros(p);
    for (phi, y) in rows {
        for i in 0..p {
            let ri = phi[i] / scale[i];
            aty[i] += ri * y;
            for j in 0..p {
                ata[(i, j)] += ri * phi[j] / scale[j];
            }
        }
    }
    let th = ata
        .svd(true, true)
        .solve(&aty, 1e-12)
        .unwrap_or_else(|_| nalgebra::DVector::zeros(p));
    (0..p).map(|k| th[k] / scale[k]).collect()
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
    fn the_stable_projection_moves_only_the_roots_outside_the_unit_circle() {
        // (z - 1.5)(z - 0.5) = z^2 - 2z + 0.75 -> (z - 1)(z - 0.5) = z^2 - 1.5z + 0.5.
        let p = stable_projection(&[-2.0, 0.75]).unwrap();
        assert!(
            (p[0] + 1.5).abs() < 1e-9 && (p[1] - 0.5).abs() < 1e-9,
            "{p:?}"
        );
        assert!(spectral_radius(&p) <= 1.0);
        // A complex pair of modulus 2 keeps its angle: z^2 - 2z + 4 -> z^2 - z + 1.
        let q = stable_projection(&[-2.0, 4.0]).unwrap();
        assert!(
            (q[0] + 1.0).abs() < 1e-9 && (q[1] - 1.0).abs() < 1e-9,
            "{q:?}"
        );
        assert_eq!(stable_projection(&[-0.5, 0.06]).unwrap(), vec![-0.5, 0.06]);
    }

    #[test]
    fn paper_system_has_unit_gain_and_is_stable() {
        let m = paper();
        assert!((m.gain() - 1.0).abs() < 1e-15);
        assert!((m.spectral_radius() - 0.7f64.sqrt()).abs() < 1e-12);
        // Inputs the unbounded QR iteration could spin on end, as not stable.
        for a in [vec![0.0, 0.0, -1.0], vec![f64::NAN, 0.1, 0.2]] {
            let r = LinearModel { a, b: vec![1.0] }.spectral_radius();
            assert!(!(r < 1.0), "{r}");
        }
        assert!(m.validate("plant").is_ok());
        let x = m.simulate(&vec![1.0; 400]);
        assert!((x[399] - 1.0).abs() < 1e-12);
        assert_eq!(x[0], 0.0);
        assert!((x[1] - 1.4).abs() < 1e-15);
    }
    #[test]
    fn series_connection_matches_cascaded_simulation() {
        let lag = LinearModel {
            a: vec![-0.3],
            b: vec![0.7],
        };
        let u: Vec<f64> = (0..40).map(|t| ((t * 7) % 5) as f64 - 2.0).collect();
        let two = paper().simulate(&lag.simulate(&u));
        let one = paper().series(&lag).simulate(&u);
        for (a, b) in two.iter().zip(&one) {
            assert!((a - b).abs() < 1e-12);
        }
        let d: Vec<f64> = (0..40).map(|t| (t % 3) as f64).collect();
        let x = paper().simulate_with(&u, &d);
        let x0 = paper().simulate(&u);
        let xd = LinearModel {
            a: vec![0.5, 0.7],
            b: vec![1.0],
        }
        .simulate(&d);
        for t in 0..40 {
            assert!((x[t] - x0[t] - xd[t]).abs() < 1e-12);
        }
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
