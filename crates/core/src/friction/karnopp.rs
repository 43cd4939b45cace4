//! Seed 002: the modified Karnopp model on a virtual block, rendered through a
//! virtual coupling.
//!
//! # Conventions
//! SI units. The device (hand) is at `x`, velocity `v`; the virtual block of
//! mass `M` at `xb`, velocity `vb`. The coupling (spring `Kc` and damper `Bc`
//! in parallel) pulls the block with `Fc = Kc (x - xb) + Bc (v - vb)`; the
//! device feels `-Fc`. Friction `f` acts on the block, computed from the
//! block's motion by the seed's algorithm:
//!
//! ```text
//! STUCK:   f = -Kp (xb - x_stuck)
//!          if |f| > F_static: SLIDING, f = -sign(xb - x_stuck) F_dynamic - B vb
//! SLIDING: if |vb| < DV: STUCK, x_stuck = xb + sign(f_old) F_static / Kp,
//!                        f = -Kp (xb - x_stuck)
//!          else f = -sign(vb) F_dynamic - B vb
//! f_old = f
//! ```
//!
//! The block then moves by semi-implicit Euler: `vb += (Fc + f)/M dt`,
//! `xb += vb dt`.
//!
//! # Tuning (seed 002, STUDIES 1c)
//! - Stuck friction never exceeds `F_static`; presliding displacement before
//!   break-away is `F_static / Kp`.
//! - `Kp` too low: in presliding the block follows the device, so its
//!   velocity passes `DV` before the static limit is reached (soft, unrealistic).
//!   In presliding the block moves about `Kc / (Kc + Kp)` as fast as the
//!   device; `Kp` should keep that under `DV` at exploring speeds.
//! - `Kp` too high: unstable. Semi-implicit Euler on the stuck block (device
//!   held) is stable iff `0 < Bc dt / M < 2` and
//!   `(Kp + Kc) dt^2 / M < 4 - 2 Bc dt / M`, that is
//!   `Kp < (4 M - 2 Bc dt) / dt^2 - Kc`: with the defaults at 1 kHz,
//!   `Kp < 3.958e6 N/m` ([`KarnoppParams::max_stable_presliding_stiffness`]).
//! - Defaults: the seed's 1.0 kg block with 2.0 N (dynamic) friction;
//!   `F_static = 2.5 N`, `B = 0.5 N s/m`, `Kp = 1e5 N/m` (25 um presliding),
//!   `DV = 5 mm/s`, coupling `Kc = 2000 N/m`, `Bc = 20 N s/m` (damping ratio
//!   0.22 for the block on the coupling). The seed gives none of these but
//!   the mass and the 2.0 N.

#[cfg(feature = "serde")]
use serde::{Deserialize, Serialize};

use super::{ForceLimit, Input, Output, Phase};
use crate::check::ParamChecks;
use crate::real::Real;

/// Parameters of the modified Karnopp model and its virtual coupling.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(Serialize, Deserialize))]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields, default))]
pub struct KarnoppParams {
    /// Virtual block mass M, kg. Default 1.0 (seed 002 Fig. 6).
    pub block_mass_kg: f64,
    /// Virtual coupling spring Kc, N/m. Default 2000.
    pub coupling_stiffness_n_m: f64,
    /// Virtual coupling damper Bc, N s/m. Default 20.
    pub coupling_damping_n_s_m: f64,
    /// Static friction limit F_static, N (>= `f_dynamic_n`). Default 2.5.
    pub f_static_n: f64,
    /// Dynamic (Coulomb) friction F_dynamic, N. Default 2.0 (seed 002 Fig. 6).
    pub f_dynamic_n: f64,
    /// Viscous friction B while sliding, N s/m. Default 0.5.
    pub viscous_n_s_m: f64,
    /// Presliding stiffness Kp, N/m. Default 1e5.
    pub presliding_stiffness_n_m: f64,
    /// Zero-velocity band DV, m/s. Default 0.005.
    pub zero_velocity_band_m_s: f64,
}

impl Default for KarnoppParams {
    fn default() -> Self {
        KarnoppParams {
            block_mass_kg: 1.0,
            coupling_stiffness_n_m: 2000.0,
            coupling_damping_n_s_m: 20.0,
            f_static_n: 2.5,
            f_dynamic_n: 2.0,
            viscous_n_s_m: 0.5,
            presliding_stiffness_n_m: 1e5,
            zero_velocity_band_m_s: 0.005,
        }
    }
}

impl KarnoppParams {
    /// Reports every invalid field.
    pub fn check(&self, c: &mut ParamChecks<'_>) {
        let ok = c.positive("block_mass_kg", self.block_mass_kg)
            & c.non_negative("coupling_stiffness_n_m", self.coupling_stiffness_n_m)
            & c.non_negative("coupling_damping_n_s_m", self.coupling_damping_n_s_m)
            & c.non_negative("f_static_n", self.f_static_n)
            & c.non_negative("f_dynamic_n", self.f_dynamic_n)
            & c.non_negative("viscous_n_s_m", self.viscous_n_s_m)
            & c.positive("presliding_stiffness_n_m", self.presliding_stiffness_n_m)
            & c.non_negative("zero_velocity_band_m_s", self.zero_velocity_band_m_s);
        if ok {
            c.exceeds(
                "f_static_n",
                self.f_static_n,
                "f_dynamic_n",
                self.f_dynamic_n,
                true,
            );
        }
    }

    /// The largest presliding stiffness Kp for which the stuck block is stable
    /// under semi-implicit Euler at step `dt` (device held still), N/m.
    /// Zero or negative when no Kp is stable.
    #[must_use]
    pub fn max_stable_presliding_stiffness(&self, dt: f64) -> f64 {
        (4.0 * self.block_mass_kg - 2.0 * self.coupling_damping_n_s_m * dt) / (dt * dt)
            - self.coupling_stiffness_n_m
    }
}

/// Running state of the Karnopp model and its virtual block, in the float
/// `T`.
#[derive(Debug, Clone)]
pub struct Karnopp<T: Real = f64> {
    /// Block mass M, coupling Kc and Bc, F_static, F_dynamic, B, Kp, DV.
    mass: T,
    kc: T,
    bc: T,
    f_static: T,
    f_dynamic: T,
    viscous: T,
    kp: T,
    dv: T,
    limit: ForceLimit<T>,
    /// Block position, m.
    xb: T,
    /// Block velocity, m/s.
    vb: T,
    phase: Phase,
    /// Presliding anchor, m.
    x_stuck: T,
    /// Friction on the block at the last step, N.
    f_old: T,
}

impl<T: Real> Karnopp<T> {
    /// A stuck block at rest at the device position `x_m`.
    #[must_use]
    pub fn new(p: KarnoppParams, limit: ForceLimit<T>, x_m: T) -> Self {
        Karnopp {
            mass: T::of(p.block_mass_kg),
            kc: T::of(p.coupling_stiffness_n_m),
            bc: T::of(p.coupling_damping_n_s_m),
            f_static: T::of(p.f_static_n),
            f_dynamic: T::of(p.f_dynamic_n),
            viscous: T::of(p.viscous_n_s_m),
            kp: T::of(p.presliding_stiffness_n_m),
            dv: T::of(p.zero_velocity_band_m_s),
            limit,
            xb: x_m,
            vb: T::ZERO,
            phase: Phase::Stick,
            x_stuck: x_m,
            f_old: T::ZERO,
        }
    }

    /// Current state of the block: stuck (`Stick`) or sliding (`Slip`).
    #[must_use]
    pub fn phase(&self) -> Phase {
        self.phase
    }

    /// Block position, m.
    #[must_use]
    pub fn block_position_m(&self) -> T {
        self.xb
    }

    /// Block velocity, m/s.
    #[must_use]
    pub fn block_velocity_m_s(&self) -> T {
        self.vb
    }

    /// Friction force on the block at the last step, N.
    #[must_use]
    pub fn friction_n(&self) -> T {
        self.f_old
    }

    /// Advances by `dt` to the device state `input`.
    pub fn step(&mut self, dt: T, input: Input<T>) -> Output<T> {
        let mut slip_onset = false;
        let f = match self.phase {
            Phase::Stick => {
                let f = -self.kp * (self.xb - self.x_stuck);
                if f.abs() > self.f_static {
                    self.phase = Phase::Slip;
                    slip_onset = true;
                    -(self.xb - self.x_stuck).sign() * self.f_dynamic - self.viscous * self.vb
                } else {
                    f
                }
            }
            Phase::Slip => {
                if self.vb.abs() < self.dv {
                    self.phase = Phase::Stick;
                    self.x_stuck = self.xb + self.f_old.sign() * self.f_static / self.kp;
                    // = -Kp (xb - x_stuck), without its rounding error, so
                    // stuck friction never exceeds F_static.
                    self.f_old.sign() * self.f_static
                } else {
                    -self.vb.sign() * self.f_dynamic - self.viscous * self.vb
                }
            }
        };
        self.f_old = f;
        let coupling = self.kc * (input.x_m - self.xb) + self.bc * (input.v_m_s - self.vb);
        self.vb += (coupling + f) / self.mass * dt;
        self.xb += self.vb * dt;
        Output {
            force_n: self.limit.clamp(-coupling),
            vibration: T::ZERO,
            vibration_q: T::ZERO,
            phase: self.phase,
            slip_onset,
        }
    }
}
