//! Plants: what an experiment drives. [`Plant`] maps an input sequence, from rest, to the
//! noise-free output `w` (noise is added by the experiment, eq 4, so every plant is treated
//! alike). [`SimulatedPlant`] is the built-in discrete-time simulator: `A(q^-1)`, `B(q^-1)` and
//! a nonlinearity plugin in a Wiener (`w = N(G u)`, eqs 1-2) or Hammerstein (`w = G(N(u))`)
//! arrangement, plus any effects with their true values (see [`crate::effect`]): unit-gain
//! linear factors in series with `G` (delay, actuator lag), equation terms, sensor terms.
use crate::effect::{Effect, Signals};
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
    /// True parameters `(name, value)` when known: the nonlinearity's and the effects'.
    fn truth(&self) -> Vec<(String, f64)> {
        Vec::new()
    }
    /// The true linear block from the input of `G` to the inner signal, every series factor
    /// (delay, lag) included, when known.
    fn linear_truth(&self) -> Option<LinearModel> {
        None
    }
}

/// The built-in simulator.
#[derive(Debug)]
pub struct SimulatedPlant<'a> {
    /// The true linear block `G = B(q^-1) / A(q^-1)`.
    pub linear: LinearModel,
    /// The true nonlinearity, with its parameter values.
    pub nonlinearity: &'a dyn Nonlinearity,
    /// Wiener (`w = N(G u)`) or Hammerstein (`w = G(N(u))`).
    pub structure: Structure,
    /// Blocks before the linear block (and before `nonlinearity` when Hammerstein), in signal
    /// order (a chain, see [`crate::chain`]).
    pub input: &'a [Box<dyn Nonlinearity>],
    /// Blocks after the nonlinearity (Wiener) or the linear block (Hammerstein).
    pub output: &'a [Box<dyn Nonlinearity>],
    /// Effects with their true values.
    pub effects: &'a [Box<dyn Effect>],
    /// Sample time (for equation terms that use it).
    pub dt: f64,
    /// The linear block's autoregressive part reads the chain's output (`model.feedback`): the
    /// output side runs inside the loop.
    pub feedback: bool,
}

impl SimulatedPlant<'_> {
    /// The signal entering the linear block: the input through the input blocks (and the
    /// nonlinearity when Hammerstein).
    fn entering(&self, u: &[f64]) -> Vec<f64> {
        let mut v = u.to_vec();
        for b in self.input {
            v = b.simulate(&v);
        }
        match self.structure {
            Structure::Wiener => v,
            Structure::Hammerstein => self.nonlinearity.simulate(&v),
        }
    }
    /// The linear block with every effect's series factor.
    fn total_linear(&self) -> LinearModel {
        self.effects
            .iter()
            .filter_map(|e| e.plant_factor())
            .fold(self.linear.clone(), |acc, (a, b)| {
                acc.series(&LinearModel { a, b })
            })
    }

    /// The equation terms' sequence of the plant's effects on `u`.
    fn equation_terms(&self, u: &[f64]) -> Vec<f64> {
        let signals = Signals::input(u, self.dt);
        let mut d = vec![0.0; u.len()];
        for e in self.effects {
            if let Some(term) = e.plant_equation(&signals) {
                for (dv, tv) in d.iter_mut().zip(term) {
                    *dv += tv;
                }
            }
        }
        d
    }

    /// The output side from the linear block's output on (the nonlinearity when Wiener, then
    /// the output blocks).
    fn output_side(&self) -> Vec<&dyn Nonlinearity> {
        let mut side: Vec<&dyn Nonlinearity> = Vec::new();
        if self.structure == Structure::Wiener {
            side.push(self.nonlinearity);
        }
        side.extend(self.output.iter().map(|b| b.as_ref()));
        side
    }

    /// With [`feedback`](Self::feedback): the linear block's output `x` and the true output
    /// `w`, stepped together (`x_t = -Σ a_i w_{t-i} + Σ b_j v_{t-j} + d_t`, `w_t` the output
    /// side's response to `x` up to `t`).
    fn closed_loop(&self, u: &[f64]) -> (Vec<f64>, Vec<f64>) {
        let v = self.entering(u);
        let d = self.equation_terms(u);
        let lin = self.total_linear();
        let side = self.output_side();
        let mut mem: Vec<Vec<f64>> = side.iter().map(|b| b.initial_memory()).collect();
        let (mut x, mut w) = (Vec::with_capacity(u.len()), Vec::with_capacity(u.len()));
        for t in 0..u.len() {
            let mut xt = d[t];
            for (j, b) in lin.b.iter().enumerate() {
                if t >= j {
                    xt += b * v[t - j];
                }
            }
            for (i, a) in lin.a.iter().enumerate() {
                if t > i {
                    xt -= a * w[t - 1 - i];
                }
            }
            let wt = side
                .iter()
                .zip(mem.iter_mut())
                .fold(xt, |z, (b, m)| b.step(m, z));
            x.push(xt);
            w.push(wt);
        }
        (x, w)
    }

    fn inner_signal(&self, u: &[f64]) -> Vec<f64> {
        if self.feedback {
            return self.closed_loop(u).0;
        }
        let v = self.entering(u);
        if self.effects.is_empty() {
            // The exact operation order of the plant FMUs (bit-for-bit agreement).
            return self.linear.simulate(&v);
        }
        let d = self.equation_terms(u);
        self.total_linear().simulate_with(&v, &d)
    }
}

impl Plant for SimulatedPlant<'_> {
    fn run(&mut self, u: &[f64]) -> Result<Vec<f64>> {
        let w = if self.feedback {
            self.closed_loop(u).1
        } else {
            let x = self.inner_signal(u);
            self.output_side().iter().fold(x, |w, b| b.simulate(&w))
        };
        Ok(w.into_iter()
            .enumerate()
            .map(|(t, w)| self.effects.iter().fold(w, |w, e| e.plant_output(t, w)))
            .collect())
    }
    fn name(&self) -> String {
        "built-in simulator".into()
    }
    fn inner(&mut self, u: &[f64]) -> Option<Vec<f64>> {
        Some(match self.structure {
            Structure::Wiener => self.inner_signal(u),
            Structure::Hammerstein => self.entering(u),
        })
    }
    fn truth(&self) -> Vec<(String, f64)> {
        let mut t = self.nonlinearity.parameters();
        for (side, blocks) in [
            (crate::chain::Side::Input, self.input),
            (crate::chain::Side::Output, self.output),
        ] {
            for (i, b) in blocks.iter().enumerate() {
                let prefix = side.prefix(i + 1);
                t.extend(
                    b.parameters()
                        .into_iter()
                        .map(|(n, v)| (crate::chain::qualified(&prefix, &n), v)),
                );
            }
        }
        for e in self.effects {
            t.extend(e.truth());
        }
        t
    }
    fn linear_truth(&self) -> Option<LinearModel> {
        Some(self.total_linear())
    }
}
