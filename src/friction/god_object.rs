//! Seed 000: god object (proxy) with mass, coupled to the finger by a spring
//! and a damper, with stick-slip on a floor and a damped-sinusoid slip
//! vibration; the static coefficient is constant or grows with stick time.
//!
//! # Conventions
//! SI units. The finger is at `x` (velocity `v`), the proxy at `x0` (velocity
//! `v0`). The coupling force on the proxy is `Fc = k (x - x0) + b (v - v0)`;
//! the finger feels `-Fc` plus the slip vibration `Q`.
//!
//! # Discretisation (choices the seed leaves open)
//! - Semi-implicit Euler at the caller's `dt` (the seed ran explicit Euler at
//!   1 kHz; semi-implicit keeps the undamped parts from gaining energy).
//! - Stick -> slip, as seed eq. (1): while stuck the proxy is at rest, so the
//!   force needed to hold it is `|Fc|`; slip starts when it exceeds
//!   `mu_s(t) F_N`.
//! - Slip -> stick: seed eq. (3) (`|..| < mu_d F_N`) is degenerate while
//!   sliding, because the equation of motion makes its left side equal
//!   `mu_d F_N`. Rule used here: the proxy re-sticks when its velocity
//!   reverses or drops below [`GodObjectParams::restick_speed_m_s`] **and** the
//!   force needed to hold it at rest, `|Fc|` with `v0 = 0`, is below
//!   `mu_d F_N`. Otherwise it keeps sliding (in the new direction if it
//!   reversed).
//! - The slip vibration, seed eq. (2), with `t0` the last stick-to-slip
//!   transition: `Q = A mu_s(t0) F_N exp(-D (t - t0)) sin(kappa v (t - t0)) / v`.
//!   The seed gives `A = 50` and `D = 0.04` without units; read as `D` per
//!   millisecond and `v` in mm/s (the reading that gives plausible
//!   magnitudes), in SI that is `A = 0.05 m/s` and `D = 40 1/s`. The seed's
//!   `omega0` is not given: `kappa = omega0` per metre of finger travel is
//!   chosen so the vibration is 100 Hz at the study's 0.03 m/s slide
//!   (`kappa = 2 pi 100 / 0.03 = 20944 rad/m`). The seed's `1/v` grows
//!   without bound as the finger stops (at 1 mm/s, Q would be 30 times its
//!   size at the study's speed and saturate the device). The seed's physics
//!   is a vibration excited by sliding at about the study's speed, so the
//!   reading here is `sin(kappa |v| tau) / max(|v|, v_min)` with
//!   [`GodObjectParams::vibration_min_speed_m_s`] = 0.03 m/s (the seed's
//!   slide speed): `|Q| <= A mu_s F_N / v_min` (5 N at mu_s 1, F_N 3 N) and
//!   Q vanishes with the sliding, as a stopped finger excites nothing. `Q` is
//!   signed with the slip direction, keeping the model direction-symmetric,
//!   and the total force is clamped to the force limit.

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use super::{ForceLimit, Input, Output, Phase, collect, exceeds, non_negative, positive, sign};
use crate::problem::Problem;

/// How the static coefficient behaves during a stick phase.
pub trait StaticFrictionLaw: Copy {
    /// Static coefficient after `stick_time_s` seconds of stick.
    fn mu_s(&self, stick_time_s: f64) -> f64;
    /// Dynamic (sliding) coefficient.
    fn mu_d(&self) -> f64;
    /// Every invalid field.
    fn validate(&self) -> Vec<Problem>;
}

/// Constant coefficients. Seed 000's comparison condition: mu_s 1.0, mu_d 0.6.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct ConstantStatic {
    /// Static coefficient (dimensionless, > `mu_d`). Default 1.0.
    pub mu_s: f64,
    /// Dynamic coefficient (dimensionless, >= 0). Default 0.6.
    pub mu_d: f64,
}

impl Default for ConstantStatic {
    fn default() -> Self {
        ConstantStatic {
            mu_s: 1.0,
            mu_d: 0.6,
        }
    }
}

impl StaticFrictionLaw for ConstantStatic {
    fn mu_s(&self, _stick_time_s: f64) -> f64 {
        self.mu_s
    }
    fn mu_d(&self) -> f64 {
        self.mu_d
    }
    fn validate(&self) -> Vec<Problem> {
        let mut errors = collect([
            non_negative("mu_s", self.mu_s),
            non_negative("mu_d", self.mu_d),
        ]);
        if errors.is_empty() {
            errors.extend(exceeds("mu_s", self.mu_s, "mu_d", self.mu_d, false).err());
        }
        errors
    }
}

/// Seed 000's time-varying static coefficient (after Dieterich):
/// `mu_s(t) = mu_d + b log10(c t + 1)`, `t` the time since the stick phase
/// began. Defaults mu_d 0.6, B 0.3, C 500 1/s.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct TimeVaryingStatic {
    /// Dynamic coefficient, also the static one at the start of a stick
    /// (dimensionless, >= 0). Default 0.6.
    pub mu_d: f64,
    /// Growth per decade of stick time, B (dimensionless, > 0). Default 0.3.
    pub b: f64,
    /// Time scale C of the growth, 1/s (> 0). Default 500.
    pub c_per_s: f64,
}

impl Default for TimeVaryingStatic {
    fn default() -> Self {
        TimeVaryingStatic {
            mu_d: 0.6,
            b: 0.3,
            c_per_s: 500.0,
        }
    }
}

impl StaticFrictionLaw for TimeVaryingStatic {
    fn mu_s(&self, stick_time_s: f64) -> f64 {
        self.mu_d + self.b * (self.c_per_s * stick_time_s + 1.0).log10()
    }
    fn mu_d(&self) -> f64 {
        self.mu_d
    }
    fn validate(&self) -> Vec<Problem> {
        collect([
            non_negative("mu_d", self.mu_d),
            positive("b", self.b),
            positive("c_per_s", self.c_per_s),
        ])
    }
}

/// Parameters of the god-object model. Defaults: the coupling that reproduces
/// seed 000's Fig. 4 claim (STUDIES 1a) and the seed's vibration constants.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(
    deny_unknown_fields,
    default,
    bound(deserialize = "L: Deserialize<'de> + Default")
)]
#[schemars(bound = "L: JsonSchema + Default + Serialize")]
pub struct GodObjectParams<L> {
    /// Proxy (god object) mass m, kg. Default 0.02.
    pub proxy_mass_kg: f64,
    /// Coupling spring k between finger and proxy, N/m. Default 1000.
    pub coupling_stiffness_n_m: f64,
    /// Coupling damper b between finger and proxy, N s/m. Default 2.
    pub coupling_damping_n_s_m: f64,
    /// Normal force F_N of the finger on the floor, N. Default 3 (a 1-DOF
    /// device has no penetration depth, so it is a parameter).
    pub normal_force_n: f64,
    /// Static and dynamic coefficients.
    pub static_friction: L,
    /// Slip -> stick speed band, m/s: the proxy may re-stick below this
    /// speed (or when its velocity reverses). Default 0.001.
    pub restick_speed_m_s: f64,
    /// Vibration amplitude A in SI, m/s (seed A = 50 with v in mm/s).
    /// Default 0.05. Zero disables the vibration.
    pub vibration_amplitude_m_s: f64,
    /// Vibration decay D, 1/s (seed D = 0.04 per ms). Default 40.
    pub vibration_decay_per_s: f64,
    /// Vibration wavenumber kappa (the seed's omega0), rad per metre of
    /// finger travel: frequency = kappa v / 2 pi. Default 20944 (100 Hz at
    /// 0.03 m/s).
    pub vibration_wavenumber_rad_m: f64,
    /// Lower bound of the speed in Q's `1/v`, m/s. Default 0.03, the
    /// seed's slide speed (where its reading of A gives its magnitudes):
    /// `|Q| <= A mu_s F_N / v_min`, so Q no longer grows without bound as
    /// the finger stops (module docs).
    pub vibration_min_speed_m_s: f64,
}

impl<L: Default> Default for GodObjectParams<L> {
    fn default() -> Self {
        GodObjectParams {
            proxy_mass_kg: 0.02,
            coupling_stiffness_n_m: 1000.0,
            coupling_damping_n_s_m: 2.0,
            normal_force_n: 3.0,
            static_friction: L::default(),
            restick_speed_m_s: 0.001,
            vibration_amplitude_m_s: 0.05,
            vibration_decay_per_s: 40.0,
            vibration_wavenumber_rad_m: 2.0 * std::f64::consts::PI * 100.0 / 0.03,
            vibration_min_speed_m_s: 0.03,
        }
    }
}

impl<L: StaticFrictionLaw> GodObjectParams<L> {
    /// Every invalid field.
    #[must_use]
    pub fn validate(&self) -> Vec<Problem> {
        let mut errors = collect([
            positive("proxy_mass_kg", self.proxy_mass_kg),
            positive("coupling_stiffness_n_m", self.coupling_stiffness_n_m),
            non_negative("coupling_damping_n_s_m", self.coupling_damping_n_s_m),
            non_negative("normal_force_n", self.normal_force_n),
            non_negative("restick_speed_m_s", self.restick_speed_m_s),
            non_negative("vibration_amplitude_m_s", self.vibration_amplitude_m_s),
            positive("vibration_decay_per_s", self.vibration_decay_per_s),
            non_negative(
                "vibration_wavenumber_rad_m",
                self.vibration_wavenumber_rad_m,
            ),
            positive("vibration_min_speed_m_s", self.vibration_min_speed_m_s),
        ]);
        errors.extend(
            self.static_friction
                .validate()
                .into_iter()
                .map(|e| e.within("static_friction")),
        );
        errors
    }
}

/// Below this envelope factor the slip vibration is over.
const VIBRATION_END: f64 = 1e-6;

/// Running state of the god-object model.
#[derive(Debug, Clone)]
pub struct GodObject<L> {
    p: GodObjectParams<L>,
    limit: ForceLimit,
    /// Proxy position, m.
    x0: f64,
    /// Proxy velocity, m/s.
    v0: f64,
    phase: Phase,
    /// Direction of the current (or last) slip: +1 or -1.
    slip_dir: f64,
    /// Time since the current stick phase began, s.
    stick_time_s: f64,
    /// `A mu_s(t0) F_N` of the running vibration, N m/s; 0 when none runs.
    vibration_scale: f64,
    /// Time since the last stick-to-slip transition, s.
    vibration_time_s: f64,
}

impl<L: StaticFrictionLaw> GodObject<L> {
    /// A stuck proxy at the finger's position `x_m` (relaxed coupling).
    #[must_use]
    pub fn new(p: GodObjectParams<L>, limit: ForceLimit, x_m: f64) -> Self {
        GodObject {
            p,
            limit,
            x0: x_m,
            v0: 0.0,
            phase: Phase::Stick,
            slip_dir: 1.0,
            stick_time_s: 0.0,
            vibration_scale: 0.0,
            vibration_time_s: 0.0,
        }
    }

    /// Current contact phase of the proxy.
    #[must_use]
    pub fn phase(&self) -> Phase {
        self.phase
    }

    /// Proxy position, m.
    #[must_use]
    pub fn proxy_position_m(&self) -> f64 {
        self.x0
    }

    /// Advances by `dt` to the finger state `input`.
    pub fn step(&mut self, dt: f64, input: Input) -> Output {
        let p = &self.p;
        let law = p.static_friction;
        let normal = p.normal_force_n;
        let (k, b, m) = (
            p.coupling_stiffness_n_m,
            p.coupling_damping_n_s_m,
            p.proxy_mass_kg,
        );
        let coupling = |x0: f64, v0: f64| k * (input.x_m - x0) + b * (input.v_m_s - v0);
        let mut slip_onset = false;

        if self.phase == Phase::Stick {
            self.stick_time_s += dt;
            let mu_s = law.mu_s(self.stick_time_s);
            let hold = coupling(self.x0, 0.0);
            if hold.abs() > mu_s * normal {
                self.phase = Phase::Slip;
                self.slip_dir = sign(hold);
                slip_onset = true;
                self.vibration_scale = p.vibration_amplitude_m_s * mu_s * normal;
                self.vibration_time_s = 0.0;
            }
        }

        if self.phase == Phase::Slip {
            let fc = coupling(self.x0, self.v0);
            let dir = if self.v0 == 0.0 {
                sign(fc)
            } else {
                sign(self.v0)
            };
            let friction = -dir * law.mu_d() * normal;
            let v_new = self.v0 + (fc + friction) / m * dt;
            let stopped = v_new * self.slip_dir <= 0.0 || v_new.abs() < p.restick_speed_m_s;
            if stopped && !slip_onset && coupling(self.x0, 0.0).abs() < law.mu_d() * normal {
                self.phase = Phase::Stick;
                self.v0 = 0.0;
                self.stick_time_s = 0.0;
            } else {
                self.v0 = v_new;
                if v_new != 0.0 {
                    self.slip_dir = sign(v_new);
                }
                self.x0 += v_new * dt;
            }
        }

        let q = self.vibration(dt, input.v_m_s);
        Output {
            force_n: self.limit.clamp(-coupling(self.x0, self.v0) + q),
            vibration: 0.0,
            phase: self.phase,
            slip_onset,
        }
    }

    /// The slip vibration Q at the current time, then advances its clock.
    fn vibration(&mut self, dt: f64, finger_v: f64) -> f64 {
        if self.vibration_scale == 0.0 {
            return 0.0;
        }
        let tau = self.vibration_time_s;
        let envelope = (-self.p.vibration_decay_per_s * tau).exp();
        if envelope < VIBRATION_END {
            self.vibration_scale = 0.0;
            return 0.0;
        }
        self.vibration_time_s += dt;
        let kappa = self.p.vibration_wavenumber_rad_m;
        // sin(kappa v tau) / v is even in v; the 1/v is bounded by v_min.
        let speed = finger_v.abs();
        let wave = (kappa * speed * tau).sin() / speed.max(self.p.vibration_min_speed_m_s);
        self.slip_dir * self.vibration_scale * envelope * wave
    }
}
