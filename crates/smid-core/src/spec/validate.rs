//! The checks of a spec beyond its types, each error naming the field.
use super::*;

impl Spec {
    /// Checks beyond the types; errors name the field.
    pub fn validate(&self) -> Result<()> {
        // The stage-3 method's own check of its options (`method.options`).
        crate::stage3::configured(self.method.eiv, &self.method.options)?;
        self.validate_plant()?;
        self.validate_noise()?;
        self.validate_model()?;
        self.validate_experiment()?;
        self.validate_budgets()?;
        let d = &self.experiment.dynamic;
        if !(d.amplitude.is_finite() && d.amplitude > 0.0) {
            return Err(SmidError::invalid(
                "experiment.dynamic.amplitude",
                "expected a finite amplitude > 0",
            ));
        }
        Ok(())
    }

    /// `plant`: exactly one kind, and a simulator's blocks and effects each by its own check.
    fn validate_plant(&self) -> Result<()> {
        let p = &self.plant;
        let kinds = [p.simulator.is_some(), p.data.is_some(), p.fmu.is_some()]
            .iter()
            .filter(|b| **b)
            .count();
        if kinds != 1 {
            return Err(SmidError::invalid(
                "plant",
                "give exactly one of `simulator`, `data` or `fmu`",
            ));
        }
        if let Some(sim) = &p.simulator {
            sim.linear().validate("plant.simulator")?;
            sim.nonlinearity.validate().map_err(|e| match e {
                SmidError::Invalid { field, message } => {
                    SmidError::invalid(format!("plant.simulator.nonlinearity.{field}"), message)
                }
                o => o,
            })?;
            for (side, blocks) in [("input", &sim.input), ("output", &sim.output)] {
                for (i, b) in blocks.iter().enumerate() {
                    b.validate().map_err(|e| match e {
                        SmidError::Invalid { field, message } => SmidError::invalid(
                            format!("plant.simulator.{side}[{i}].{field}"),
                            message,
                        ),
                        o => o,
                    })?;
                }
            }
            for (i, e) in sim.effects.iter().enumerate() {
                e.validate_plant().map_err(|err| match err {
                    SmidError::Invalid { field, message } => {
                        SmidError::invalid(format!("plant.simulator.effects[{i}].{field}"), message)
                    }
                    o => o,
                })?;
            }
        }
        Ok(())
    }

    /// `noise`: a declared bound is a bound; an estimated one is for measured data.
    fn validate_noise(&self) -> Result<()> {
        self.noise.check_estimate()?;
        if !self.noise.estimated() {
            self.noise.delta()?;
        } else if self.plant.data.is_none() {
            return Err(SmidError::invalid(
                "noise.estimate",
                "an estimated bound is for measured data (`plant.data`); a simulated plant's noise is declared",
            ));
        }
        Ok(())
    }

    /// `model`: the orders and delay within reach, every plugin on a side it supports.
    fn validate_model(&self) -> Result<()> {
        let layout = self.model.layout()?;
        if layout.orders.na > 8 || layout.orders.nb > 8 {
            return Err(SmidError::invalid(
                "model.na",
                "orders above 8 (effects included) are not supported by the orthant method (2^na LPs)",
            ));
        }
        if layout.orders.nk > 1000 {
            return Err(SmidError::invalid(
                "model.nk",
                format!(
                    "expected a delay of at most 1000 samples, got {}",
                    layout.orders.nk
                ),
            ));
        }
        if !self.model.nonlinearity.supports(self.model.structure) {
            return Err(SmidError::invalid(
                "model.structure",
                format!(
                    "the nonlinearity plugin does not support {:?}",
                    self.model.structure
                ),
            ));
        }
        for (side, blocks) in [
            (crate::chain::Side::Input, &self.model.input),
            (crate::chain::Side::Output, &self.model.output),
        ] {
            for (i, b) in blocks.iter().enumerate() {
                if !b.supports(side.structure()) {
                    return Err(SmidError::invalid(
                        format!("{}[{i}]", side.field()),
                        format!(
                            "the plugin `{}` cannot sit on the {} side",
                            crate::nonlinearity::tag_of_model(b.as_ref()),
                            if side == crate::chain::Side::Input {
                                "input"
                            } else {
                                "output"
                            }
                        ),
                    ));
                }
            }
        }
        Ok(())
    }

    /// `experiment`: the filter's pole and step, the steady-state amplitudes and range, the
    /// dynamic record's length.
    fn validate_experiment(&self) -> Result<()> {
        let f = &self.experiment.filter;
        if let Some(a) = f.pole {
            if !(0.0..1.0).contains(&a) {
                return Err(SmidError::invalid(
                    "experiment.filter.pole",
                    format!("expected 0 <= a < 1, got {a}"),
                ));
            }
        }
        if self.method.alpha == AlphaSpec::Bias && !(f.step.is_finite() && f.step != 0.0) {
            return Err(SmidError::invalid(
                "experiment.filter.step",
                "α needs a non-zero step amplitude r̄_F",
            ));
        }
        let s = &self.experiment.steady_state;
        if !s.skip && s.amplitudes < 2 {
            return Err(SmidError::invalid(
                "experiment.steady_state.amplitudes",
                "need at least 2 amplitudes (M >= 2)",
            ));
        }
        if !(s.min > 0.0 && s.max > s.min && s.max.is_finite()) {
            return Err(SmidError::invalid(
                "experiment.steady_state.min",
                format!("expected 0 < min < max, got min {} max {}", s.min, s.max),
            ));
        }
        let d = &self.experiment.dynamic;
        if d.length < 10 {
            return Err(SmidError::invalid(
                "experiment.dynamic.length",
                format!("expected N >= 10, got {}", d.length),
            ));
        }
        Ok(())
    }

    /// Ranges of every field that sets how long a loop runs or how much it allocates (the
    /// Appendix bisection, the experiments' lengths, the branch and bound's budget): a value
    /// outside is an error naming the field, so no user input can make a run spin.
    fn validate_budgets(&self) -> Result<()> {
        use crate::experiment::{MAX_EXPERIMENT_SAMPLES, MAX_SETTLE, MIN_FILTER_TOL};
        let f = &self.experiment.filter;
        let checks: [(bool, &str, String); 7] = [
            (
                f.pole.is_some() || (f.tol >= MIN_FILTER_TOL && f.tol < 1.0),
                "experiment.filter.tol",
                format!("expected {MIN_FILTER_TOL:e} <= tol < 1, got {:e}", f.tol),
            ),
            (
                f.pole.is_some() || (f.a_bar > 0.0 && f.a_bar <= 1.0),
                "experiment.filter.a_bar",
                format!("expected 0 < ā <= 1, got {}", f.a_bar),
            ),
            (
                f.settle <= MAX_SETTLE,
                "experiment.filter.settle",
                format!("expected at most {MAX_SETTLE} samples, got {}", f.settle),
            ),
            (
                self.experiment.steady_state.amplitudes <= 100_000,
                "experiment.steady_state.amplitudes",
                format!(
                    "expected at most 100000 amplitudes, got {}",
                    self.experiment.steady_state.amplitudes
                ),
            ),
            (
                self.experiment.dynamic.length <= MAX_EXPERIMENT_SAMPLES,
                "experiment.dynamic.length",
                format!(
                    "expected N <= {MAX_EXPERIMENT_SAMPLES}, got {}",
                    self.experiment.dynamic.length
                ),
            ),
            (
                self.method.cells.depth <= crate::cells::MAX_DEPTH,
                "method.cells.depth",
                format!(
                    "expected at most {} halvings per parameter, got {}",
                    crate::cells::MAX_DEPTH,
                    self.method.cells.depth
                ),
            ),
            (
                (1..=crate::cells::MAX_CELLS).contains(&self.method.cells.max_cells),
                "method.cells.max_cells",
                format!(
                    "expected 1 <= max_cells <= {}, got {}",
                    crate::cells::MAX_CELLS,
                    self.method.cells.max_cells
                ),
            ),
        ];
        match checks.into_iter().find(|c| !c.0) {
            Some((_, field, message)) => Err(SmidError::invalid(field, message)),
            None => {
                use crate::settings::Check;
                self.method.member.check()?;
                self.method.signs.check()?;
                self.diagnosis.check().map(|_| ())
            }
        }
    }
}
