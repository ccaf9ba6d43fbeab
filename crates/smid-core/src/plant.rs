//! Plants: what an experiment drives. [`Plant`] maps an input sequence, from rest, to the
//! noise-free output `w` (noise is added by the experiment, eq 4, so every plant is treated
//! alike). [`SimulatedPlant`] is the built-in discrete-time simulator: `A(q^-1)`, `B(q^-1)` and
//! a nonlinearity plugin in a Wiener (`w = N(G u)`, eqs 1-2) or Hammerstein (`w = G(N(u))`)
//! arrangement.
use crate::error::Result;
use crate::linear::LinearModel;
use crate::nonlinearity::{Nonlinearity, Structure};

/// A system an experiment can drive.
///
/// ```
/// use smid_core::plant::Plant;
/// /// A pure one-sample delay.
/// struct Delay;
/// impl Plant for Delay {
///     fn run(&mut self, u: &[f64]) -> smid_core::Result<Vec<f64>> {
///         Ok(std::iter::once(0.0).chain(u.iter().copied()).take(u.len()).collect())
///     }
/// }
/// assert_eq!(Delay.run(&[1.0, 2.0]).unwrap(), vec![0.0, 1.0]);
/// ```
pub trait Plant {
    /// Run from rest on `u`; return the noise-free output `w`, one sample per input. Required.
    fn run(&mut self, u: &[f64]) -> Result<Vec<f64>>;
    /// Name used in messages.
    fn name(&self) -> String {
        "plant".into()
    }
    /// The inner signal `x` for the same input, when the plant can tell (simulators).
    fn inner(&mut self, _u: &[f64]) -> Option<Vec<f64>> {
        None
    }
    /// True parameters `(name, value)` when known.
    fn truth(&self) -> Vec<(String, f64)> {
        Vec::new()
    }
}

/// The built-in simulator.
#[derive(Debug)]
pub struct SimulatedPlant<'a> {
    pub linear: LinearModel,
    pub nonlinearity: &'a dyn Nonlinearity,
    pub structure: Structure,
}

impl Plant for SimulatedPlant<'_> {
    fn run(&mut self, u: &[f64]) -> Result<Vec<f64>> {
        Ok(match self.structure {
            Structure::Wiener => self.nonlinearity.simulate(&self.linear.simulate(u)),
            Structure::Hammerstein => self.linear.simulate(&self.nonlinearity.simulate(u)),
        })
    }
    fn name(&self) -> String {
        "built-in simulator".into()
    }
    fn inner(&mut self, u: &[f64]) -> Option<Vec<f64>> {
        Some(match self.structure {
            Structure::Wiener => self.linear.simulate(u),
            Structure::Hammerstein => self.nonlinearity.simulate(u),
        })
    }
    fn truth(&self) -> Vec<(String, f64)> {
        let mut t = self.nonlinearity.parameters();
        t.extend(
            self.linear
                .a
                .iter()
                .enumerate()
                .map(|(i, v)| (format!("a{}", i + 1), *v)),
        );
        t.extend(
            self.linear
                .b
                .iter()
                .enumerate()
                .map(|(j, v)| (format!("b{j}"), *v)),
        );
        t
    }
}
