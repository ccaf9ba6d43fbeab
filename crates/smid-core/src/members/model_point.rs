//! A member with concrete values ([`ModelPoint`]): its free run, `k`-step predictions and the
//! run inside the loop (`model.feedback`).
use crate::effect::{self, Effect, Signals};
use crate::interval::Interval;
use crate::linear::LinearModel;
use crate::nonlinearity::{Nonlinearity, Structure};
use std::ops::Range;

/// One member of a model set with concrete values.
#[derive(Debug)]
pub struct ModelPoint {
    /// Where the nonlinearity sits relative to the linear block.
    pub structure: Structure,
    /// The nonlinearity with this member's parameter values.
    pub nonlinearity: Box<dyn Nonlinearity>,
    /// The chain's blocks before the linear block (and the nonlinearity when Hammerstein).
    pub input: Vec<Box<dyn Nonlinearity>>,
    /// The chain's blocks after the nonlinearity (Wiener) or the linear block (Hammerstein).
    pub output: Vec<Box<dyn Nonlinearity>>,
    /// The linear block's `A` and `B` coefficients (the first entries of `θ`).
    pub linear: LinearModel,
    /// Input delay of the linear block, in samples.
    pub nk: usize,
    /// `model.feedback`: the autoregressive part reads the chain's output `w`, so the free run
    /// steps the output side sample by sample.
    pub feedback: bool,
    /// Coefficients of the equation terms.
    pub extras: Vec<f64>,
    /// Values of the bisected (sensor) parameters.
    pub psi: Vec<f64>,
    /// The model's effects (`model.effects`), in spec order.
    pub effects: Vec<Box<dyn Effect>>,
    /// The slice of [`ModelPoint::psi`] that belongs to each effect, in effect order.
    pub effect_cells: Vec<Range<usize>>,
}

/// A simulation: inner signal `x`, nonlinearity output `w`, and the output `y` (with the
/// sensor terms, without noise).
#[derive(Debug, Clone)]
pub struct Simulation {
    /// The linear block's output `x`.
    pub x: Vec<f64>,
    /// The true output `w`: `x` through the chain's output side (the nonlinearity under
    /// Wiener, then the output blocks), before the sensor terms.
    pub w: Vec<f64>,
    /// The measured output `y`: `w` with the sensor maps and terms, without noise.
    pub y: Vec<f64>,
}

impl ModelPoint {
    fn sensor(&self, t: usize) -> f64 {
        let cells: Vec<Vec<Interval>> = self
            .effect_cells
            .iter()
            .map(|r| {
                self.psi[r.clone()]
                    .iter()
                    .map(|&v| Interval::new(v, v))
                    .collect()
            })
            .collect();
        let slices: Vec<&[Interval]> = cells.iter().map(|c| c.as_slice()).collect();
        effect::sensor_sum(&self.effects, &slices, Some(t))
            .map(|s| s.center())
            .unwrap_or(0.0)
    }

    /// The noise-free measurements of the true outputs `w` (the sensor maps and terms at
    /// this point; [`effect::measured`]).
    fn measure(&self, w: &[f64]) -> Vec<f64> {
        let psi: Vec<&[f64]> = self
            .effect_cells
            .iter()
            .map(|r| &self.psi[r.clone()])
            .collect();
        w.iter()
            .enumerate()
            .map(|(t, &v)| effect::measured(&self.effects, &psi, t, v))
            .collect()
    }

    /// The equation-term sequence `Σ c_k φ_k(t)` of a record with the linear block's output
    /// given (`x`: regressors that read it use it), and the coefficient slices of the effects
    /// that read the output (to be evaluated online in a free run).
    fn equation_terms(&self, u: &[f64], dt: f64, x: Option<&[Interval]>) -> Vec<f64> {
        let mut d = vec![0.0; u.len()];
        let mut k = 0;
        for e in &self.effects {
            let cols = e.regressors(&Signals { u, dt, x });
            if x.is_some() || !e.uses_output() {
                for (c, col) in self.extras[k..].iter().zip(&cols) {
                    for (dv, v) in d.iter_mut().zip(&col.values) {
                        if v.is_finite() {
                            *dv += c * v.center();
                        }
                    }
                }
            }
            k += cols.len();
        }
        d
    }

    /// The terms of the effects that read the output, at sample `s` of a free run.
    fn online_terms(&self, u: &[f64], dt: f64, x: &[Interval], s: usize) -> f64 {
        let mut d = 0.0;
        let mut k = 0;
        for e in &self.effects {
            let n = e.regressors(&Signals::input(&[], dt)).len();
            if e.uses_output() {
                let vals = e.regressors_at(&Signals { u, dt, x: Some(x) }, s);
                // An unknown regressor (a velocity before the run's second sample) adds
                // nothing, as in `equation_terms`: stage 3 uses no equation there.
                d += self.extras[k..k + n]
                    .iter()
                    .zip(&vals)
                    .filter(|(_, v)| v.is_finite())
                    .map(|(c, v)| c * v)
                    .sum::<f64>();
            }
            k += n;
        }
        d
    }

    /// Whether the linear block is asymptotically stable.
    pub fn stable(&self) -> bool {
        self.linear.spectral_radius() < 1.0
    }

    /// The linear block's input on `u`: the input-side blocks, the nonlinearity when
    /// Hammerstein, then the delay `nk` (zeros before it).
    pub fn linear_input(&self, u: &[f64]) -> Vec<f64> {
        let mut v = u.to_vec();
        for b in &self.input {
            v = b.simulate(&v);
        }
        if self.structure == Structure::Hammerstein {
            v = self.nonlinearity.simulate(&v);
        }
        (0..u.len())
            .map(|t| if t >= self.nk { v[t - self.nk] } else { 0.0 })
            .collect()
    }

    /// The blocks from the linear block's output to the true output, in signal order: the
    /// nonlinearity when Wiener, then the output blocks.
    fn output_side(&self) -> Vec<&dyn Nonlinearity> {
        let mut side: Vec<&dyn Nonlinearity> = Vec::with_capacity(self.output.len() + 1);
        if self.structure == Structure::Wiener {
            side.push(self.nonlinearity.as_ref());
        }
        side.extend(self.output.iter().map(|b| b.as_ref()));
        side
    }

    /// The true output `w` of a linear-block output sequence `x` from rest.
    pub fn true_output(&self, x: &[f64]) -> Vec<f64> {
        let mut w = x.to_vec();
        for b in self.output_side() {
            w = b.simulate(&w);
        }
        w
    }

    /// Free-run simulation from rest on the input alone.
    pub fn simulate(&self, u: &[f64], dt: f64) -> Simulation {
        self.predict(u, None, dt, usize::MAX, 0)
    }

    /// The sensor terms `s_t` of this member over a record of `n` samples.
    pub fn sensor_terms(&self, n: usize) -> Vec<f64> {
        (0..n).map(|t| self.sensor(t)).collect()
    }

    /// Simulation or prediction from the input. `x_data` are estimates of the linear block's
    /// output from the measurements (Hammerstein `y - s`; Wiener the centres of the stage-2
    /// inner bounds, the free-run value where a sample was not inverted). The first `warm`
    /// samples take `x_data` as they are (the measured initial condition, as MATLAB's
    /// `compare` estimates one), then the model runs on the input alone (`k = usize::MAX`: the
    /// free run), or, for a `k`-step-ahead prediction, from `x_data` up to `t - k` for each `t`.
    /// With [`feedback`](Self::feedback) the autoregressive part reads the chain's output:
    /// `x_data` are then the measured true outputs `w` (`y - s`), the past the loop reads,
    /// and the free run steps the output side sample by sample; a `k`-step prediction starts
    /// the output side's memory where the one-step predictions up to `t - k` left it. Equation
    /// terms that read the output then read these data in a `k`-step prediction (the measured
    /// outputs, where stage 2 gives them the inner signal).
    pub fn predict(
        &self,
        u: &[f64],
        x_data: Option<&[f64]>,
        dt: f64,
        k: usize,
        warm: usize,
    ) -> Simulation {
        let n = u.len();
        let xd = x_data.filter(|d| d.len() == n);
        let (free, free_w) = self.free_run_from(u, xd, dt, warm, false);
        match xd {
            Some(x) if k < n && k > 0 => self.k_step(u, x, dt, k, warm, free, free_w),
            _ => {
                let w = if self.feedback {
                    free_w
                } else {
                    self.true_output(&free)
                };
                let yy = self.measure(&w);
                Simulation { x: free, w, y: yy }
            }
        }
    }

    /// A trajectory of the model inside the loop (`model.feedback`) whose warm start the loop
    /// reaches: for the first `warm` samples the linear block's output (free there: no
    /// equation reads it) is the data `w_data` (a preimage of the measured outputs) and the
    /// output is that value through the output side, memory included; from `warm` on the loop
    /// runs on the input. Every sample of it, the warm start included, is an output of the chain, so
    /// its distance from the records is a bound at which the model holds it
    /// ([`training_within`](super::training_within)). Without feedback, the free run as [`Self::predict`] gives it.
    pub fn reachable_run(&self, u: &[f64], w_data: &[f64], dt: f64, warm: usize) -> Simulation {
        if !self.feedback {
            return self.predict(u, Some(w_data), dt, usize::MAX, warm);
        }
        let xd = Some(w_data).filter(|d| d.len() == u.len());
        let (x, w) = self.free_run_from(u, xd, dt, warm, true);
        let y = self.measure(&w);
        Simulation { x, w, y }
    }

    /// The free run with its warm start: the linear block's output and, with feedback, the
    /// chain's output the loop reads. Without feedback the first `warm` samples of `x` are the
    /// data; with it the first `warm` outputs are the data as measured (`reach` false: the
    /// loop's measured past, as MATLAB's `compare` starts a run) or the data passed through
    /// the output side as the linear block's output (`reach` true: a trajectory of the model).
    fn free_run_from(
        &self,
        u: &[f64],
        xd: Option<&[f64]>,
        dt: f64,
        warm: usize,
        reach: bool,
    ) -> (Vec<f64>, Vec<f64>) {
        let n = u.len();
        let v = self.linear_input(u);
        let online = self.effects.iter().any(|e| e.uses_output());
        let na = self.linear.a.len();
        let side = self.output_side();
        // The output side stepped sample by sample (`model.feedback` reads its past).
        let step_side = |mem: &mut [Vec<f64>], x: f64| step_blocks(&side, mem, x);
        let batch = self.equation_terms(u, dt, None);
        let mut free = Vec::with_capacity(n);
        let mut free_w = Vec::with_capacity(n);
        let mut mem: Vec<Vec<f64>> = side.iter().map(|b| b.initial_memory()).collect();
        let mut free_iv: Vec<Interval> = Vec::with_capacity(n);
        for s in 0..n {
            let xs = match xd {
                Some(d) if s < warm && (!self.feedback || reach) => d[s],
                _ => {
                    let mut ds = batch[s];
                    if online {
                        ds += self.online_terms(u, dt, &free_iv, s);
                    }
                    let past = if self.feedback { &free_w } else { &free };
                    let hist: Vec<f64> = (1..=na)
                        .map(|i| if s >= i { past[s - i] } else { 0.0 })
                        .collect();
                    self.linear_step(&v, ds, s, &hist)
                }
            };
            free.push(xs);
            if self.feedback {
                let ws = step_side(&mut mem, xs);
                // The warm start reads the measured outputs (the loop's past) as they are,
                // unless the run is to be the model's own.
                free_w.push(match xd {
                    Some(d) if s < warm && !reach => d[s],
                    _ => ws,
                });
            }
            free_iv.push(Interval::new(xs, xs));
        }
        (free, free_w)
    }

    /// The k-step predictions of [`Self::predict`] from the free run `(free, free_w)`.
    #[allow(clippy::too_many_arguments)]
    fn k_step(
        &self,
        u: &[f64],
        measured_x: &[f64],
        dt: f64,
        k: usize,
        warm: usize,
        free: Vec<f64>,
        free_w: Vec<f64>,
    ) -> Simulation {
        let n = u.len();
        let v = self.linear_input(u);
        let na = self.linear.a.len();
        let side = self.output_side();
        let step_side = |mem: &mut [Vec<f64>], x: f64| step_blocks(&side, mem, x);
        let rest: Vec<Vec<f64>> = side.iter().map(|b| b.initial_memory()).collect();
        // k-step prediction; regressors that read the output read the data.
        let data_iv: Vec<Interval> = measured_x.iter().map(|&v| Interval::new(v, v)).collect();
        let d = self.equation_terms(u, dt, Some(&data_iv));
        // With feedback the past outputs are the data; the output side's memory a prediction
        // starts from is that of the one-step predictions up to there.
        let data_mem = if self.feedback {
            let mut m = rest.clone();
            let mut mems = Vec::with_capacity(n);
            for t in 0..n {
                let hist: Vec<f64> = (1..=na)
                    .map(|i| if t >= i { measured_x[t - i] } else { 0.0 })
                    .collect();
                let xt = if t < na {
                    free[t]
                } else {
                    self.linear_step(&v, d[t], t, &hist)
                };
                step_side(&mut m, xt);
                mems.push(m.clone());
            }
            mems
        } else {
            Vec::new()
        };
        let past = measured_x;
        // The first sample whose equation has its whole past in the record (the input's too).
        let first = na.max(self.linear.b.len().saturating_sub(1) + self.nk);
        let mut x = vec![0.0; n];
        let mut w_pred = if self.feedback {
            free_w.clone()
        } else {
            Vec::new()
        };
        for t in 0..n {
            // Past outputs x_{t-k-i}, i >= 0, from the data (all of them in the record); then
            // k steps of the model, the first of them at an equation with its whole past (no
            // input before the record read as zero). Before that, the free run.
            if t < k.max(warm) || t + 1 < k + first {
                x[t] = free[t];
                continue;
            }
            let start = t + 1 - k;
            let mut hist: Vec<f64> = (0..na)
                .map(|i| if start > i { past[start - 1 - i] } else { 0.0 })
                .collect();
            let mut m = match start.checked_sub(1) {
                Some(p) if self.feedback => data_mem[p].clone(),
                _ => rest.clone(),
            };
            let mut xs = 0.0;
            for s in start..=t {
                xs = self.linear_step(&v, d[s], s, &hist);
                let next = if self.feedback {
                    let ws = step_side(&mut m, xs);
                    w_pred[t] = ws;
                    ws
                } else {
                    xs
                };
                if na > 0 {
                    hist.rotate_right(1);
                    hist[0] = next;
                }
            }
            x[t] = xs;
        }
        let w = if self.feedback {
            w_pred
        } else {
            self.true_output(&x)
        };
        let yy = self.measure(&w);
        Simulation { x, w, y: yy }
    }

    /// `x_s = -Σ a_i x_{s-i} + Σ b_j v_{s-j} + d_s` with the past outputs `hist[i-1] = x_{s-i}`.
    fn linear_step(&self, v: &[f64], d: f64, s: usize, hist: &[f64]) -> f64 {
        let mut x = d;
        for (j, b) in self.linear.b.iter().enumerate() {
            if s >= j {
                x += b * v[s - j];
            }
        }
        for (a, xi) in self.linear.a.iter().zip(hist) {
            x -= a * xi;
        }
        x
    }
}

/// One sample `x` through the blocks `side` in turn, each with its memory in `mem`.
fn step_blocks(side: &[&dyn Nonlinearity], mem: &mut [Vec<f64>], x: f64) -> f64 {
    side.iter()
        .zip(mem.iter_mut())
        .fold(x, |w, (b, m)| b.step(m, w))
}
