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

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use super::{ForceLimit, Input, Output, Phase, collect, exceeds, non_negative, positive, sign};
use crate::problem::Problem;

/// Parameters of Nakano's model and its burst. See the module docs for the
/// choices behind the defaults.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
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
    /// Every invalid field.
    #[must_use]
    pub fn validate(&self) -> Vec<Problem> {
        let mut errors = collect([
            positive("mass_kg", self.mass_kg),
            positive("stiffness_n_m", self.stiffness_n_m),
            non_negative("damping_n_s_m", self.damping_n_s_m),
            non_negative("normal_load_n", self.normal_load_n),
            non_negative("mu_s", self.mu_s),
            non_negative("mu_k", self.mu_k),
            non_negative("alpha_per_n", self.alpha_per_n),
            positive("carrier_hz", self.carrier_hz),
            positive("envelope_time_constant_s", self.envelope_time_constant_s),
            non_negative("force_scale", self.force_scale),
            positive("max_substep_s", self.max_substep_s),
        ]);
        if errors.is_empty() {
            errors.extend(exceeds("mu_s", self.mu_s, "mu_k", self.mu_k, false).err());
        }
        if errors.is_empty() {
            let zeta = self.damping_ratio();
            if zeta >= 1.0 {
                errors.push(Problem::new(
                    "damping_n_s_m",
                    format!(
                        "gives damping ratio {zeta:.3}; stick-slip needs c < 2 sqrt(m k) = {:.6}",
                        2.0 * (self.mass_kg * self.stiffness_n_m).sqrt()
                    ),
                ));
            }
        }
        errors
    }

    /// Damping ratio zeta = c / (2 sqrt(m k)).
    #[must_use]
    pub fn damping_ratio(&self) -> f64 {
        self.damping_n_s_m / (2.0 * (self.mass_kg * self.stiffness_n_m).sqrt())
    }

    /// Undamped natural frequency sqrt(k/m) / 2 pi, Hz: the cap on the
    /// transition rate.
    #[must_use]
    pub fn natural_frequency_hz(&self) -> f64 {
        (self.stiffness_n_m / self.mass_kg).sqrt() / std::f64::consts::TAU
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

/// Running state of Nakano's model.
#[derive(Debug, Clone)]
pub struct Nakano {
    p: NakanoParams,
    display: NakanoDisplay,
    limit: ForceLimit,
    /// Spring elongation, m.
    y: f64,
    /// Object velocity, m/s.
    yv: f64,
    phase: Phase,
    /// Sign of `V - y'` during the current slip.
    slip_rel: f64,
    /// Friction on the object at the end of the last step, N.
    friction: f64,
    /// Floor (finger) velocity at the last step, m/s.
    floor_v: f64,
    /// Burst envelope, drive units.
    envelope: f64,
    /// Elastic force `k y` at the last stick-to-slip transition, N.
    onset_elastic_n: f64,
    /// Carrier phase, rad, in `[0, 2 pi)`.
    carrier_phase: f64,
    /// `dt` for which `decay` was computed.
    decay_dt: f64,
    /// `exp(-decay_dt / tau)`.
    decay: f64,
}

impl Nakano {
    /// A stuck, relaxed object on a floor at rest.
    #[must_use]
    pub fn new(p: NakanoParams, display: NakanoDisplay, limit: ForceLimit) -> Self {
        Nakano {
            p,
            display,
            limit,
            y: 0.0,
            yv: 0.0,
            phase: Phase::Stick,
            slip_rel: 0.0,
            friction: 0.0,
            floor_v: 0.0,
            envelope: 0.0,
            onset_elastic_n: 0.0,
            carrier_phase: 0.0,
            decay_dt: 0.0,
            decay: 1.0,
        }
    }

    /// Current contact phase of the object.
    #[must_use]
    pub fn phase(&self) -> Phase {
        self.phase
    }

    /// Burst envelope (drive units, before clamping), as it will apply at
    /// the next step.
    #[must_use]
    pub fn envelope(&self) -> f64 {
        self.envelope
    }

    /// Elastic force `k y` stored at the last stick-to-slip transition, N.
    #[must_use]
    pub fn elastic_force_at_onset_n(&self) -> f64 {
        self.onset_elastic_n
    }

    /// Advances by `dt` to the finger state `input`.
    pub fn step(&mut self, dt: f64, input: Input) -> Output {
        let p = self.p;
        let (m, k, c) = (p.mass_kg, p.stiffness_n_m, p.damping_n_s_m);
        let static_limit = p.mu_s * p.normal_load_n;
        let kinetic = p.mu_k * p.normal_load_n;

        // Sub-steps: the floor velocity ramps linearly over the step.
        let n = (dt / p.max_substep_s).ceil().max(1.0);
        let h = dt / n;
        let floor_a = (input.v_m_s - self.floor_v) / dt;
        let mut slip_onset = false;
        let mut i = 0.0;
        while i < n {
            i += 1.0;
            let floor_v = self.floor_v + floor_a * h * i;
            match self.phase {
                Phase::Stick => {
                    self.yv = floor_v;
                    self.y += floor_v * h;
                    let hold = m * floor_a + c * floor_v + k * self.y;
                    if hold.abs() > static_limit {
                        self.phase = Phase::Slip;
                        slip_onset = true;
                        self.slip_rel = sign(hold);
                        self.onset_elastic_n = k * self.y;
                        self.envelope = p.alpha_per_n * self.onset_elastic_n.abs();
                        self.friction = self.slip_rel * kinetic;
                    } else {
                        self.friction = hold;
                    }
                }
                Phase::Slip => {
                    let friction = self.slip_rel * kinetic;
                    self.yv += (-c * self.yv - k * self.y + friction) / m * h;
                    self.y += self.yv * h;
                    self.friction = friction;
                    let rel = floor_v - self.yv;
                    if rel * self.slip_rel <= 0.0 {
                        let hold = m * floor_a + c * floor_v + k * self.y;
                        if hold.abs() <= static_limit {
                            self.phase = Phase::Stick;
                            self.yv = floor_v;
                            self.friction = hold;
                        } else {
                            self.slip_rel = sign(rel);
                        }
                    }
                }
            }
        }
        self.floor_v = input.v_m_s;

        match self.display {
            NakanoDisplay::Tactile => {
                let vibration = (self.envelope * self.carrier_phase.sin()).clamp(-1.0, 1.0);
                self.advance_burst(dt);
                Output {
                    force_n: 0.0,
                    vibration,
                    phase: self.phase,
                    slip_onset,
                }
            }
            NakanoDisplay::Force => Output {
                force_n: self.limit.clamp(-p.force_scale * self.friction),
                vibration: 0.0,
                phase: self.phase,
                slip_onset,
            },
        }
    }

    /// Advances the carrier phase and the envelope decay by `dt`.
    fn advance_burst(&mut self, dt: f64) {
        if dt != self.decay_dt {
            self.decay_dt = dt;
            self.decay = (-dt / self.p.envelope_time_constant_s).exp();
        }
        self.envelope *= self.decay;
        self.carrier_phase = (self.carrier_phase + std::f64::consts::TAU * self.p.carrier_hz * dt)
            % std::f64::consts::TAU;
    }
}
