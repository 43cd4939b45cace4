//! Pure viscous damping, `F = -b v` (seed 002's `viscous` condition:
//! 35 N s/m, about 3 N at typical speeds), and with `b = 0` the `none` model.
//!
//! SI units; the device feels `-b v`. The reported state is `stick` while the
//! hand is exactly at rest and `slip` otherwise (viscous damping has no
//! static phase of its own).

#[cfg(feature = "serde")]
use serde::{Deserialize, Serialize};

use super::{ForceLimit, Input, Output, Phase};
use crate::check::ParamChecks;
use crate::real::Real;

/// Parameters of the viscous model.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(Serialize, Deserialize))]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields, default))]
pub struct ViscousParams {
    /// Damping b, N s/m. Default 35 (seed 002).
    pub damping_n_s_m: f64,
}

impl Default for ViscousParams {
    fn default() -> Self {
        ViscousParams {
            damping_n_s_m: 35.0,
        }
    }
}

impl ViscousParams {
    /// Reports every invalid field.
    pub fn check(&self, c: &mut ParamChecks<'_>) {
        c.non_negative("damping_n_s_m", self.damping_n_s_m);
    }
}

/// Running state of the viscous model (only the reported phase).
#[derive(Debug, Clone)]
pub struct Viscous<T: Real = f64> {
    damping_n_s_m: T,
    limit: ForceLimit<T>,
    phase: Phase,
}

impl<T: Real> Viscous<T> {
    /// Damping `damping_n_s_m`, output limited to `limit`.
    #[must_use]
    pub fn new(damping_n_s_m: T, limit: ForceLimit<T>) -> Self {
        Viscous {
            damping_n_s_m,
            limit,
            phase: Phase::Stick,
        }
    }

    /// Current reported phase.
    #[must_use]
    pub fn phase(&self) -> Phase {
        self.phase
    }

    /// Renders `-b v`.
    pub fn step(&mut self, _dt: T, input: Input<T>) -> Output<T> {
        let phase = if input.v_m_s == T::ZERO {
            Phase::Stick
        } else {
            Phase::Slip
        };
        let slip_onset = phase == Phase::Slip && self.phase == Phase::Stick;
        self.phase = phase;
        Output {
            force_n: self.limit.clamp(-self.damping_n_s_m * input.v_m_s),
            vibration: T::ZERO,
            vibration_q: T::ZERO,
            phase,
            slip_onset,
        }
    }
}
