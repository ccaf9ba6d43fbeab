//! # smid-linear
//!
//! No hard nonlinearity (`type: linear`): `w = x`, on either side of the linear block, so the
//! one model reduces to the linear block of eq (1) with its effects and the bounded output
//! error of eqs (4)-(5): stage 2 gives `x_t ∈ [y_t - Δη_t, y_t + Δη_t]` (Wiener) or the input
//! itself (Hammerstein), and stage 3 bounds the block as an errors-in-variables problem. It has
//! no parameter, so it needs neither steady-state data nor a prior box: a model of measured
//! records (the EMPS axis, the cascaded tanks) starts from it, and `smid diagnose` adds what the
//! data show.
#![forbid(unsafe_code)]
#![warn(missing_docs)]

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};
use smid_core::prelude::*;

/// No nonlinearity, `w = x` (simulation): a purely linear plant.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Identity {}

#[typetag::serde(name = "linear")]
impl Nonlinearity for Identity {
    fn step(&self, _memory: &mut Vec<f64>, x: f64) -> f64 {
        x
    }
}

/// No nonlinearity, `w = x`, as the model structure: a purely linear model (no options).
#[derive(Debug, Clone, Default, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct LinearModel {}

/// The (only) set: the identity.
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
pub struct IdentitySet {}

#[typetag::serde(name = "linear")]
impl NonlinearityModel for LinearModel {
    /// Steady-state points must satisfy `ȳ = ū ± Δη̄` under unit gain (eq 8); a point that does
    /// not falsifies the model.
    fn bound_steady_state(&self, data: &SteadyStateData) -> Result<Box<dyn NonlinearitySet>> {
        data.validate()?;
        for p in &data.points {
            if (p.y - p.u).abs() > p.dy + p.alpha {
                return Err(SmidError::inconsistent(
                    Stage::SteadyState,
                    p.index,
                    format!(
                        "ȳ = {} differs from ū = {} by more than the bound",
                        p.y, p.u
                    ),
                ));
            }
        }
        Ok(Box::new(IdentitySet {}))
    }
    fn supports(&self, _structure: Structure) -> bool {
        true
    }
    fn set_from_box(&self, cell: &[Interval]) -> Result<Box<dyn NonlinearitySet>> {
        if !cell.is_empty() {
            return Err(SmidError::invalid(
                "model.prior",
                "`linear` has no parameter",
            ));
        }
        Ok(Box::new(IdentitySet {}))
    }
}

#[typetag::serde(name = "linear")]
impl NonlinearitySet for IdentitySet {
    /// Linear with a nonnegative impulse response: the designed square wave stays overshoot-free.
    fn keeps_steady_design(&self) -> bool {
        true
    }
    /// Order-preserving (the identity), so a chain may feed it interval inputs.
    fn monotone(&self) -> bool {
        true
    }
    fn parameters(&self) -> Vec<ParameterBound> {
        Vec::new()
    }
    fn invert(&self, y: &[f64], dy: &[f64]) -> Result<Vec<InnerBound>> {
        check_outputs(y, dy)?;
        Ok(y.iter()
            .zip(dy)
            .map(|(&y, &d)| InnerBound {
                interval: Interval::new(y - d, y + d).outward(),
                kind: InnerKind::Inverted,
            })
            .collect())
    }
    fn propagate(&self, u: &[f64]) -> Result<Vec<InnerBound>> {
        Ok(u.iter()
            .map(|&u| InnerBound {
                interval: Interval::new(u, u),
                kind: InnerKind::Inverted,
            })
            .collect())
    }
    fn contains(&self, truth: &[f64]) -> bool {
        truth.is_empty()
    }
}

smid_core::register_nonlinearity!("linear", Identity, Identity {});
smid_core::register_model!("linear", LinearModel, LinearModel {});

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn inversion_is_the_noise_band_and_propagation_the_input() {
        let s = LinearModel {}.set_from_box(&[]).unwrap();
        let x = s.invert(&[1.0, -2.0], &[0.1, 0.2]).unwrap();
        assert!(x[0].interval.contains(0.9) && x[0].interval.contains(1.1));
        assert!(!x[1].interval.contains(-2.21));
        assert_eq!(
            s.propagate(&[3.0]).unwrap()[0].interval,
            Interval::new(3.0, 3.0)
        );
        assert!(LinearModel {}
            .set_from_box(&[Interval::new(0.0, 1.0)])
            .is_err());
    }

    #[test]
    fn steady_state_points_off_the_identity_falsify_it() {
        let p = |u: f64, y: f64, index| SteadyPoint::new(index, u, y, 0.01);
        let ok = SteadyStateData {
            points: vec![p(1.0, 1.005, 0), p(-1.0, -0.995, 1)],
        };
        assert!(LinearModel {}.bound_steady_state(&ok).is_ok());
        let bad = SteadyStateData {
            points: vec![p(1.0, 1.005, 0), p(2.0, 2.5, 1)],
        };
        let r = LinearModel {}.bound_steady_state(&bad);
        match r {
            Err(SmidError::Inconsistent(smid_core::Falsification { sample, .. })) => {
                assert_eq!(sample, 1)
            }
            other => panic!("{other:?}"),
        }
    }
}
