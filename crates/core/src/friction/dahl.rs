//! Seed 002: the Dahl model, friction as a function of displacement, with a
//! viscous term.
//!
//! # Conventions
//! SI units. `F` is the Dahl friction state, signed like the motion that built
//! it up; the device feels `-(F + b v)`. With `s = sgn(x')`:
//!
//! ```text
//! dF/dx = sigma |1 - F s / Fc|^i sgn(1 - F s / Fc)
//! ```
//!
//! `Fc` is `fc_pos_n` for motion towards +x and `fc_neg_n` towards -x. Under
//! steady motion `F` tends to `s Fc` over a presliding distance of about
//! `Fc / sigma`; on reversal it sweeps to the other limit (hysteresis).
//!
//! # Numerics
//! The seed warns that `sigma` needs care to stay numerically sound: an
//! Euler step overshoots once `sigma |dx| > Fc`. Here each step applies the
//! exact solution of the ODE over the step's displacement `dx` (the finger
//! moves in a straight line within a step): with `e = 1 - F s / Fc` and
//! `u = sigma |dx| / Fc`, `e' = e exp(-u)` for `i = 1`, and
//! `|e'|^(1-i) = |e|^(1-i) - (1-i) u` otherwise (`e' = 0` once that reaches
//! zero for `i < 1`). So `|F|` never exceeds `max(|F|, Fc)` and the model is
//! sound for every `sigma > 0`; the tests cover sigma from 1e2 to 1e8 N/m.
//! What sigma changes is physical: presliding stiffness, which the device
//! must be able to render stably (a device-side limit, not a numerical one).
//!
//! In `f32` the state stalls short of the Coulomb level: once `Fc e u` (the
//! step's change) is below half a unit in the last place of `F`, `F` no
//! longer moves, so `|F|` settles within about `Fc 2^-24 / u` of `Fc`:
//! 3 uN at the seed's 2 N, sigma 2e4 N/m, 2 mm/s at 1 kHz (`u` = 0.02), and
//! 0.6 mN at 0.01 mm/s. In `f64` the same bound is 2^29 times smaller.
//!
//! The CSV `state` is `slip` once `F s / Fc` reaches `slip_fraction` (a
//! reporting convention: the Dahl model itself has no discrete states).

#[cfg(feature = "serde")]
use serde::{Deserialize, Serialize};

use super::{ForceLimit, Input, Output, Phase};
use crate::check::ParamChecks;
use crate::real::Real;

/// Parameters of the Dahl model.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(Serialize, Deserialize))]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields, default))]
pub struct DahlParams {
    /// Rest stiffness sigma, N/m. Default 2e4 (0.1 mm presliding at 2 N).
    pub sigma_n_m: f64,
    /// Coulomb level for motion towards +x, N. Default 2.0.
    pub fc_pos_n: f64,
    /// Coulomb level for motion towards -x, N. Default 2.0.
    pub fc_neg_n: f64,
    /// Shape exponent i (dimensionless, > 0). Default 1.
    pub exponent: f64,
    /// Viscous term b, N s/m. Default 0.5.
    pub viscous_n_s_m: f64,
    /// Fraction of `Fc` from which the state is reported as `slip`. Default 0.9.
    pub slip_fraction: f64,
}

impl Default for DahlParams {
    fn default() -> Self {
        DahlParams {
            sigma_n_m: 2e4,
            fc_pos_n: 2.0,
            fc_neg_n: 2.0,
            exponent: 1.0,
            viscous_n_s_m: 0.5,
            slip_fraction: 0.9,
        }
    }
}

impl DahlParams {
    /// Reports every invalid field.
    pub fn check(&self, c: &mut ParamChecks<'_>) {
        c.positive("sigma_n_m", self.sigma_n_m);
        c.positive("fc_pos_n", self.fc_pos_n);
        c.positive("fc_neg_n", self.fc_neg_n);
        c.positive("exponent", self.exponent);
        c.non_negative("viscous_n_s_m", self.viscous_n_s_m);
        if c.positive("slip_fraction", self.slip_fraction) {
            c.at_most("slip_fraction", self.slip_fraction, 1.0);
        }
    }
}

/// Running state of the Dahl model, in the float `T`.
#[derive(Debug, Clone)]
pub struct Dahl<T: Real = f64> {
    /// sigma, Fc towards +x and -x, i, b, slip fraction.
    sigma: T,
    fc_pos: T,
    fc_neg: T,
    exponent: T,
    viscous: T,
    slip_fraction: T,
    limit: ForceLimit<T>,
    /// Dahl friction state, N.
    f: T,
    /// Position at the last step, m.
    x_prev: T,
    phase: Phase,
}

impl<T: Real> Dahl<T> {
    /// A relaxed model (zero friction) at position `x_m`.
    #[must_use]
    pub fn new(p: DahlParams, limit: ForceLimit<T>, x_m: T) -> Self {
        Dahl {
            sigma: T::of(p.sigma_n_m),
            fc_pos: T::of(p.fc_pos_n),
            fc_neg: T::of(p.fc_neg_n),
            exponent: T::of(p.exponent),
            viscous: T::of(p.viscous_n_s_m),
            slip_fraction: T::of(p.slip_fraction),
            limit,
            f: T::ZERO,
            x_prev: x_m,
            phase: Phase::Stick,
        }
    }

    /// Current reported phase.
    #[must_use]
    pub fn phase(&self) -> Phase {
        self.phase
    }

    /// The Dahl friction state F, N (without the viscous term).
    #[must_use]
    pub fn friction_n(&self) -> T {
        self.f
    }

    /// Advances to the device state `input` (`dt` does not enter: the model
    /// is driven by displacement).
    pub fn step(&mut self, _dt: T, input: Input<T>) -> Output<T> {
        let dx = input.x_m - self.x_prev;
        self.x_prev = input.x_m;
        let mut slip_onset = false;
        if dx != T::ZERO {
            let s = dx.sign();
            let fc = if s > T::ZERO {
                self.fc_pos
            } else {
                self.fc_neg
            };
            let e = T::ONE - self.f * s / fc;
            let u = self.sigma * dx.abs() / fc;
            let e_new = exact_decay(e, u, self.exponent);
            self.f = s * fc * (T::ONE - e_new);
            let phase = if T::ONE - e_new >= self.slip_fraction {
                Phase::Slip
            } else {
                Phase::Stick
            };
            slip_onset = phase == Phase::Slip && self.phase == Phase::Stick;
            self.phase = phase;
        }
        Output {
            force_n: self.limit.clamp(-(self.f + self.viscous * input.v_m_s)),
            vibration: T::ZERO,
            vibration_q: T::ZERO,
            phase: self.phase,
            slip_onset,
        }
    }
}

/// The solution at `u` of `de/du = -|e|^i sgn(e)` from `e` at `u = 0`.
fn exact_decay<T: Real>(e: T, u: T, i: T) -> T {
    if e == T::ZERO {
        return T::ZERO;
    }
    if (i - T::ONE).abs() < T::of(1e-12) {
        return e * (-u).exp();
    }
    let q = T::ONE - i;
    let r = e.abs().powf(q) - q * u;
    if r <= T::ZERO {
        // Only for i < 1: reaches zero in finite displacement and stays.
        return T::ZERO;
    }
    e.sign() * r.powf(T::ONE / q)
}

#[cfg(test)]
mod tests {
    use super::exact_decay;
    use crate::real::Real;

    #[test]
    fn exact_decay_matches_fine_euler_for_several_exponents() {
        for &i in &[0.5, 1.0, 1.5, 2.0] {
            for &e0 in &[1.0, 2.0, 0.3, -0.5] {
                let u = 0.7;
                let mut e: f64 = e0;
                let n = 200_000;
                for _ in 0..n {
                    e -= Real::powf(Real::abs(e), i) * e.signum() * (u / f64::from(n));
                }
                let exact = exact_decay(e0, u, i);
                assert!((exact - e).abs() < 1e-4, "i={i} e0={e0}: {exact} vs {e}");
            }
        }
    }
}
