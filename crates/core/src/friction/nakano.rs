//! Seed 001: Nakano's 1-DOF stick-slip model, driving a 600 Hz vibrotactile
//! burst at each stick-to-slip transition (tactile display) or rendered as
//! tangential force (force display).
//!
//! # Conventions
//! SI units. An object of mass `m` hangs on a spring `k` and damper `c` from a
//! fixed anchor and rests on a floor that moves with the finger (floor
//! velocity `V` = finger velocity, either sign). `y` is the object's
//! displacement from the spring's natural length (the seed's `x - x0`). The
//! friction force on the object is `F`; the finger (the floor) feels `-F`.
//!
//! # Dynamics
//! - Stick: the object moves with the floor (`y' = V`). The friction needed
//!   to hold it is `F_s = m V' + c V + k y` (seed eq. 7); it slips when
//!   `|F_s| > mu_s W`.
//! - Slip: `m y'' = -c y' - k y + sgn(V - y') mu_k W` (seed eqs. 10-11, both
//!   directions).
//! - Slip -> stick: when the relative velocity `V - y'` changes sign (the
//!   seed's `x' == V`) **and** the holding force is within the static limit;
//!   otherwise the object keeps slipping. Re-sticking on the crossing alone
//!   chatters between states every step.
//! - Integration: semi-implicit Euler on internal sub-steps of at most
//!   [`NakanoParams::max_substep_s`] (the seed gives a closed form; a fine
//!   integration is equivalent and handles a varying `V`).
//! - Burst: at each stick-to-slip transition the envelope jumps to
//!   `A_max = alpha k |y|` (seed eq. 9, the stored elastic force times
//!   `alpha`) and decays with time constant `tau` (80 ms); the drive is
//!   `envelope sin(2 pi 600 Hz t)`, clamped to `[-1, 1]`.
//! - Cheap per step, for a microcontroller: the carrier is a unit phasor
//!   turned by a per-step rotation (`cos`, `sin` of `2 pi f dt` computed
//!   when `dt` changes) and pulled back to unit length each step by one
//!   Newton step of `1/sqrt`, and the envelope decays by a per-step factor
//!   `exp(-dt / tau)`: no `exp` or `sin` call per step.
//!
//! # Parameters the seed leaves open
//! The seed's Fig. 5 gives `m = 0.00016 kg, k = 10 N/m, mu_s = 1.0,
//! mu_k = 0.4` and says the parameters were tuned so that transitions peak at
//! about 100 Hz in natural strokes. With `k = 10 N/m` the natural frequency
//! `sqrt(k/m)` is 39.8 Hz, which caps the transition rate near 40 Hz, so the
//! seed's own claim cannot hold with its figure's values. The peak rate is
//! set by the natural frequency (a slip lasts about one period), so the
//! defaults keep the figure's mass and coefficients and raise the stiffness
//! to 63 N/m (natural frequency 99.9 Hz): transitions then peak at 100 Hz.
//! `c`, `W` and `alpha` are not given. `W` sets the speed above which
//! stick-slip stops (about `delta_mu W / sqrt(k m)`, scaled by the damping):
//! `W = 0.016 N` with `c = 0.001 N s/m` (damping ratio 0.005, the value of
//! STUDIES 1b's quick trial) stops it above 62% of the peak speed of a 2 cm,
//! 2 Hz stroke. Sweep (2 cm, 2 Hz, k = 63): W 0.012 -> 38%, 0.014 -> 42%,
//! 0.016 -> 62%, 0.018 -> never stops. `alpha = 62.5 1/N` maps the largest
//! stored force (`mu_s W` = 0.016 N at mu_s 1) to full-scale drive.
//! `force_scale` (force display only) scales the model's millinewton
//! friction to the device: default 62.5, so `mu_s W` renders as 1 N.

#[cfg(feature = "serde")]
use serde::{Deserialize, Serialize};

use super::{ForceLimit, Input, Output, Phase};
use crate::check::{ParamChecks, Rule};
use crate::real::Real;

/// Below this the burst envelope is exactly 0, drive units (see
/// `advance_burst`).
pub const ENVELOPE_FLOOR: f64 = 1e-9;

/// Parameters of Nakano's model and its burst. See the module docs for the
/// choices behind the defaults.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(Serialize, Deserialize))]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields, default))]
pub struct NakanoParams {
    /// Object mass m, kg. Default 0.00016 (seed Fig. 5).
    pub mass_kg: f64,
    /// Spring stiffness k, N/m. Default 63 (seed Fig. 5: 10, see module docs).
    pub stiffness_n_m: f64,
    /// Damping c, N s/m (> 0: stick-slip stops at high speed). Default 0.001.
    pub damping_n_s_m: f64,
    /// Normal load W, N. Default 0.016.
    pub normal_load_n: f64,
    /// Static coefficient mu_s (> `mu_k`). Default 1.0.
    pub mu_s: f64,
    /// Kinetic coefficient mu_k. Default 0.4.
    pub mu_k: f64,
    /// Burst gain alpha: drive per newton of stored elastic force, 1/N.
    /// Default 62.5.
    pub alpha_per_n: f64,
    /// Vibration carrier frequency, Hz. Default 600.
    pub carrier_hz: f64,
    /// Burst envelope decay time constant, s. Default 0.080.
    pub envelope_time_constant_s: f64,
    /// Force display: rendered force per newton of model friction
    /// (dimensionless). Default 62.5.
    pub force_scale: f64,
    /// Longest internal integration step, s. Default 50e-6.
    pub max_substep_s: f64,
}

impl Default for NakanoParams {
    fn default() -> Self {
        NakanoParams {
            mass_kg: 0.00016,
            stiffness_n_m: 63.0,
            damping_n_s_m: 0.001,
            normal_load_n: 0.016,
            mu_s: 1.0,
            mu_k: 0.4,
            alpha_per_n: 62.5,
            carrier_hz: 600.0,
            envelope_time_constant_s: 0.080,
            force_scale: 62.5,
            max_substep_s: 50e-6,
        }
    }
}

impl NakanoParams {
    /// Reports every invalid field.
    pub fn check(&self, c: &mut ParamChecks<'_>) {
        let ok = c.positive("mass_kg", self.mass_kg)
            & c.positive("stiffness_n_m", self.stiffness_n_m)
            & c.non_negative("damping_n_s_m", self.damping_n_s_m)
            & c.non_negative("normal_load_n", self.normal_load_n)
            & c.non_negative("mu_s", self.mu_s)
            & c.non_negative("mu_k", self.mu_k)
            & c.non_negative("alpha_per_n", self.alpha_per_n)
            & c.positive("carrier_hz", self.carrier_hz)
            & c.positive("envelope_time_constant_s", self.envelope_time_constant_s)
            & c.non_negative("force_scale", self.force_scale)
            & c.positive("max_substep_s", self.max_substep_s);
        if !(ok && c.exceeds("mu_s", self.mu_s, "mu_k", self.mu_k, false)) {
            return;
        }
        let zeta = self.damping_ratio();
        if zeta >= 1.0 {
            let critical = 2.0 * libm::sqrt(self.mass_kg * self.stiffness_n_m);
            c.report(
                "damping_n_s_m",
                self.damping_n_s_m,
                Rule::Underdamped { zeta, critical },
            );
        }
    }

    /// Damping ratio zeta = c / (2 sqrt(m k)).
    #[must_use]
    pub fn damping_ratio(&self) -> f64 {
        self.damping_n_s_m / (2.0 * libm::sqrt(self.mass_kg * self.stiffness_n_m))
    }

    /// Undamped natural frequency sqrt(k/m) / 2 pi, Hz: the cap on the
    /// transition rate.
    #[must_use]
    pub fn natural_frequency_hz(&self) -> f64 {
        libm::sqrt(self.stiffness_n_m / self.mass_kg) / core::f64::consts::TAU
    }
}

/// What the model renders.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum NakanoDisplay {
    /// A 600 Hz burst on the vibrotactile actuator, no tangential force.
    Tactile,
    /// The model's friction as tangential force, no vibration.
    Force,
}

/// Running state of Nakano's model, in the float `T`.
#[derive(Debug, Clone)]
pub struct Nakano<T: Real = f64> {
    /// Mass m, stiffness k, damping c.
    m: T,
    k: T,
    c: T,
    /// mu_s W and mu_k W, N.
    static_limit: T,
    kinetic: T,
    alpha: T,
    force_scale: T,
    max_substep: T,
    /// 2 pi f, rad/s, and the envelope time constant, s.
    carrier_omega: T,
    tau: T,
    display: NakanoDisplay,
    limit: ForceLimit<T>,
    /// Spring elongation, m.
    y: T,
    /// Object velocity, m/s.
    yv: T,
    phase: Phase,
    /// Sign of `V - y'` during the current slip.
    slip_rel: T,
    /// Friction on the object at the end of the last step, N.
    friction: T,
    /// Floor (finger) velocity at the last step, m/s.
    floor_v: T,
    /// Burst envelope, drive units.
    envelope: T,
    /// Elastic force `k y` at the last stick-to-slip transition, N.
    onset_elastic_n: T,
    /// The carrier as a unit phasor: `(cos, sin)` of its phase.
    carrier: (T, T),
    /// `dt` for which the fields below were computed (they change only
    /// with `dt`, so a fixed-rate loop computes them once).
    step_dt: T,
    /// `exp(-step_dt / tau)`.
    decay: T,
    /// `(cos, sin)` of `2 pi f step_dt`.
    turn: (T, T),
    /// Sub-steps per step, the sub-step `h`, `h / m` and `1 / dt`.
    substeps: u32,
    h: T,
    h_over_m: T,
    inv_dt: T,
}

impl<T: Real> Nakano<T> {
    /// A stuck, relaxed object on a floor at rest.
    #[must_use]
    pub fn new(p: NakanoParams, display: NakanoDisplay, limit: ForceLimit<T>) -> Self {
        Nakano {
            m: T::of(p.mass_kg),
            k: T::of(p.stiffness_n_m),
            c: T::of(p.damping_n_s_m),
            static_limit: T::of(p.mu_s) * T::of(p.normal_load_n),
            kinetic: T::of(p.mu_k) * T::of(p.normal_load_n),
            alpha: T::of(p.alpha_per_n),
            force_scale: T::of(p.force_scale),
            max_substep: T::of(p.max_substep_s),
            carrier_omega: T::TAU * T::of(p.carrier_hz),
            tau: T::of(p.envelope_time_constant_s),
            display,
            limit,
            y: T::ZERO,
            yv: T::ZERO,
            phase: Phase::Stick,
            slip_rel: T::ZERO,
            friction: T::ZERO,
            floor_v: T::ZERO,
            envelope: T::ZERO,
            onset_elastic_n: T::ZERO,
            carrier: (T::ONE, T::ZERO),
            step_dt: T::ZERO,
            decay: T::ONE,
            turn: (T::ONE, T::ZERO),
            substeps: 1,
            h: T::ZERO,
            h_over_m: T::ZERO,
            inv_dt: T::ZERO,
        }
    }

    /// Computes what depends only on `dt`, when `dt` changed.
    fn prepare(&mut self, dt: T) {
        if dt == self.step_dt {
            return;
        }
        self.step_dt = dt;
        self.decay = (-dt / self.tau).exp();
        let angle = self.carrier_omega * dt;
        self.turn = (angle.cos(), angle.sin());
        let n = (dt / self.max_substep).ceil().max(T::ONE);
        // A count of sub-steps: n is a whole number >= 1; a step longer
        // than u32::MAX sub-steps saturates (no model runs such a step).
        self.substeps = n.to_count();
        self.h = dt / n;
        self.h_over_m = self.h / self.m;
        self.inv_dt = T::ONE / dt;
    }

    /// Current contact phase of the object.
    #[must_use]
    pub fn phase(&self) -> Phase {
        self.phase
    }

    /// Burst envelope (drive units, before clamping), as it will apply at
    /// the next step.
    #[must_use]
    pub fn envelope(&self) -> T {
        self.envelope
    }

    /// Elastic force `k y` stored at the last stick-to-slip transition, N.
    #[must_use]
    pub fn elastic_force_at_onset_n(&self) -> T {
        self.onset_elastic_n
    }

    /// Advances by `dt` to the finger state `input`.
    pub fn step(&mut self, dt: T, input: Input<T>) -> Output<T> {
        let (m, k, c) = (self.m, self.k, self.c);
        let static_limit = self.static_limit;
        let kinetic = self.kinetic;

        // Sub-steps: the floor velocity ramps linearly over the step.
        self.prepare(dt);
        let (h, h_over_m) = (self.h, self.h_over_m);
        let floor_a = (input.v_m_s - self.floor_v) * self.inv_dt;
        let floor_dv = floor_a * h;
        let hold_a = m * floor_a;
        let mut slip_onset = false;
        let mut floor_v = self.floor_v;
        // The state in locals for the sub-steps (written back after), the
        // arithmetic as it reads.
        let (mut phase, mut y, mut yv) = (self.phase, self.y, self.yv);
        let (mut slip_rel, mut friction) = (self.slip_rel, self.friction);
        for _ in 0..self.substeps {
            floor_v += floor_dv;
            match phase {
                Phase::Stick => {
                    yv = floor_v;
                    y += floor_v * h;
                    let hold = hold_a + c * floor_v + k * y;
                    if hold.abs() > static_limit {
                        phase = Phase::Slip;
                        slip_onset = true;
                        slip_rel = hold.sign();
                        self.onset_elastic_n = k * y;
                        self.envelope = self.alpha * self.onset_elastic_n.abs();
                        friction = slip_rel * kinetic;
                    } else {
                        friction = hold;
                    }
                }
                Phase::Slip => {
                    let slipping = slip_rel * kinetic;
                    yv += (-c * yv - k * y + slipping) * h_over_m;
                    y += yv * h;
                    friction = slipping;
                    let rel = floor_v - yv;
                    if rel * slip_rel <= T::ZERO {
                        let hold = hold_a + c * floor_v + k * y;
                        if hold.abs() <= static_limit {
                            phase = Phase::Stick;
                            yv = floor_v;
                            friction = hold;
                        } else {
                            slip_rel = rel.sign();
                        }
                    }
                }
            }
        }
        (self.phase, self.y, self.yv) = (phase, y, yv);
        (self.slip_rel, self.friction) = (slip_rel, friction);
        self.floor_v = input.v_m_s;

        match self.display {
            NakanoDisplay::Tactile => {
                let vibration = (self.envelope * self.carrier.1).clamp(-T::ONE, T::ONE);
                let vibration_q = (self.envelope * self.carrier.0).clamp(-T::ONE, T::ONE);
                self.advance_burst();
                Output {
                    force_n: T::ZERO,
                    vibration,
                    vibration_q,
                    phase: self.phase,
                    slip_onset,
                }
            }
            NakanoDisplay::Force => Output {
                force_n: self.limit.clamp(-self.force_scale * self.friction),
                vibration: T::ZERO,
                vibration_q: T::ZERO,
                phase: self.phase,
                slip_onset,
            },
        }
    }

    /// Turns the carrier and decays the envelope by one step (the `dt` of
    /// [`Self::prepare`]).
    fn advance_burst(&mut self) {
        self.envelope *= self.decay;
        // A decayed burst ends at exactly 0 (not in subnormal numbers:
        // issue 37) once below a billionth of full-scale drive, far below
        // a 16-bit DAC's step (1.5e-5).
        if self.envelope.abs() < T::of(ENVELOPE_FLOOR) {
            self.envelope = T::ZERO;
        }
        let ((c, s), (tc, ts)) = (self.carrier, self.turn);
        let (c, s) = (c * tc - s * ts, s * tc + c * ts);
        // One Newton step of 1/sqrt(c^2 + s^2) near 1 keeps the phasor on
        // the unit circle in f32 over any number of steps.
        let norm = (T::of(3.0) - (c * c + s * s)) / T::of(2.0);
        self.carrier = (c * norm, s * norm);
    }
}
