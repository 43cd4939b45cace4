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
//! - Cheap per step, for a microcontroller: the envelope `exp(-D tau)` is
//!   one multiplication per step by `exp(-D dt)` (computed when `dt`
//!   changes); `sin(kappa |v| tau)` stays a call, as its frequency follows
//!   the finger's speed.

use core::marker::PhantomData;

#[cfg(feature = "serde")]
use serde::{Deserialize, Serialize};

use super::{ForceLimit, Input, Output, Phase};
use crate::check::ParamChecks;
use crate::real::Real;

/// How the static coefficient behaves during a stick phase.
pub trait StaticFrictionLaw: Copy {
    /// The law in the float `T`, ready to evaluate per step.
    fn coefficients<T: Real>(&self) -> Coefficients<T>;
    /// Static coefficient after `stick_time_s` seconds of stick.
    fn mu_s(&self, stick_time_s: f64) -> f64 {
        self.coefficients::<f64>().mu_s(stick_time_s)
    }
    /// Reports every invalid field.
    fn check(&self, c: &mut ParamChecks<'_>);
}

/// A static friction law in the float `T`: `mu_s(t) = mu_d + b log10(c t +
/// 1)`, or a constant `mu_s` when `c` is 0.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Coefficients<T> {
    mu_d: T,
    /// The constant static coefficient (used when `c` is 0).
    mu_s: T,
    b: T,
    c: T,
}

impl<T: Real> Coefficients<T> {
    /// The static coefficient after `stick_time_s` of stick.
    #[must_use]
    pub fn mu_s(&self, stick_time_s: T) -> T {
        if self.c == T::ZERO {
            self.mu_s
        } else {
            self.mu_d + self.b * (self.c * stick_time_s + T::ONE).log10()
        }
    }
}

/// Constant coefficients. Seed 000's comparison condition: mu_s 1.0, mu_d 0.6.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(Serialize, Deserialize))]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields, default))]
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
    fn coefficients<T: Real>(&self) -> Coefficients<T> {
        Coefficients {
            mu_d: T::of(self.mu_d),
            mu_s: T::of(self.mu_s),
            b: T::ZERO,
            c: T::ZERO,
        }
    }
    fn check(&self, c: &mut ParamChecks<'_>) {
        if c.non_negative("mu_s", self.mu_s) & c.non_negative("mu_d", self.mu_d) {
            c.exceeds("mu_s", self.mu_s, "mu_d", self.mu_d, false);
        }
    }
}

/// Seed 000's time-varying static coefficient (after Dieterich):
/// `mu_s(t) = mu_d + b log10(c t + 1)`, `t` the time since the stick phase
/// began. Defaults mu_d 0.6, B 0.3, C 500 1/s.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(Serialize, Deserialize))]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields, default))]
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
    fn coefficients<T: Real>(&self) -> Coefficients<T> {
        Coefficients {
            mu_d: T::of(self.mu_d),
            mu_s: T::of(self.mu_d),
            b: T::of(self.b),
            c: T::of(self.c_per_s),
        }
    }
    fn check(&self, c: &mut ParamChecks<'_>) {
        c.non_negative("mu_d", self.mu_d);
        c.positive("b", self.b);
        c.positive("c_per_s", self.c_per_s);
    }
}

/// Parameters of the god-object model. Defaults: the coupling that reproduces
/// seed 000's Fig. 4 claim (STUDIES 1a) and the seed's vibration constants.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(Serialize, Deserialize))]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[cfg_attr(
    feature = "serde",
    serde(
        deny_unknown_fields,
        default,
        bound(deserialize = "L: Deserialize<'de> + Default")
    )
)]
#[cfg_attr(
    feature = "schema",
    schemars(bound = "L: schemars::JsonSchema + Default + Serialize")
)]
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
    /// Floor stiffness k of seed 000's `F_N = k y`, N/m: where it is set
    /// and the device has a vertical axis (an Inverse3), the normal force
    /// is `k` times the hand's press `y` into the track's surface, tick by
    /// tick, instead of `normal_force_n` (which a device without a vertical
    /// axis still uses). Default: not set.
    #[cfg_attr(feature = "serde", serde(skip_serializing_if = "Option::is_none"))]
    pub press_stiffness_n_m: Option<f64>,
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
            press_stiffness_n_m: None,
            static_friction: L::default(),
            restick_speed_m_s: 0.001,
            vibration_amplitude_m_s: 0.05,
            vibration_decay_per_s: 40.0,
            vibration_wavenumber_rad_m: 2.0 * core::f64::consts::PI * 100.0 / 0.03,
            vibration_min_speed_m_s: 0.03,
        }
    }
}

impl<L: StaticFrictionLaw> GodObjectParams<L> {
    /// Reports every invalid field.
    pub fn check(&self, c: &mut ParamChecks<'_>) {
        c.positive("proxy_mass_kg", self.proxy_mass_kg);
        c.positive("coupling_stiffness_n_m", self.coupling_stiffness_n_m);
        c.non_negative("coupling_damping_n_s_m", self.coupling_damping_n_s_m);
        c.non_negative("normal_force_n", self.normal_force_n);
        if let Some(k) = self.press_stiffness_n_m {
            c.positive("press_stiffness_n_m", k);
        }
        c.non_negative("restick_speed_m_s", self.restick_speed_m_s);
        c.non_negative("vibration_amplitude_m_s", self.vibration_amplitude_m_s);
        c.positive("vibration_decay_per_s", self.vibration_decay_per_s);
        c.non_negative(
            "vibration_wavenumber_rad_m",
            self.vibration_wavenumber_rad_m,
        );
        c.positive("vibration_min_speed_m_s", self.vibration_min_speed_m_s);
        c.within("static_friction");
        self.static_friction.check(c);
    }
}

/// Below this envelope factor the slip vibration is over.
const VIBRATION_END: f64 = 1e-6;

/// Running state of the god-object model, in the float `T`.
#[derive(Debug, Clone)]
pub struct GodObject<L, T: Real = f64> {
    law: Coefficients<T>,
    /// Coupling stiffness k, damping b, 1 / proxy mass m, normal force F_N.
    k: T,
    b: T,
    inv_m: T,
    normal: T,
    /// Floor stiffness of `F_N = k y`, if the normal force is the press.
    press: Option<T>,
    restick_speed: T,
    vibration_amplitude: T,
    vibration_decay: T,
    kappa: T,
    vibration_min_speed: T,
    limit: ForceLimit<T>,
    /// Proxy position, m.
    x0: T,
    /// Proxy velocity, m/s.
    v0: T,
    phase: Phase,
    /// Direction of the current (or last) slip: +1 or -1.
    slip_dir: T,
    /// Time since the current stick phase began, s.
    stick_time_s: T,
    /// `A mu_s(t0) F_N` of the running vibration, N m/s; 0 when none runs.
    vibration_scale: T,
    /// Time since the last stick-to-slip transition, s.
    vibration_time_s: T,
    /// `exp(-D tau)` of the running vibration.
    envelope: T,
    /// The `dt` that `envelope_step` was computed for, and `exp(-D dt)`.
    envelope_dt: T,
    envelope_step: T,
    law_type: PhantomData<L>,
}

impl<L: StaticFrictionLaw, T: Real> GodObject<L, T> {
    /// Where the normal force is the press: sets it to `k` times the press
    /// `y` (m, none below 0) and returns it.
    pub fn press(&mut self, y_m: T) -> Option<T> {
        let k = self.press?;
        self.normal = k * y_m.max(T::ZERO);
        Some(self.normal)
    }

    /// Where the normal force is the press: sets it, N (a replay of a
    /// logged one).
    pub fn set_pressed_normal(&mut self, normal_n: T) {
        if self.press.is_some() {
            self.normal = normal_n;
        }
    }

    /// A stuck proxy at the finger's position `x_m` (relaxed coupling).
    #[must_use]
    pub fn new(p: GodObjectParams<L>, limit: ForceLimit<T>, x_m: T) -> Self {
        GodObject {
            law: p.static_friction.coefficients(),
            k: T::of(p.coupling_stiffness_n_m),
            b: T::of(p.coupling_damping_n_s_m),
            inv_m: T::of(1.0 / p.proxy_mass_kg),
            normal: T::of(p.normal_force_n),
            press: p.press_stiffness_n_m.map(T::of),
            restick_speed: T::of(p.restick_speed_m_s),
            vibration_amplitude: T::of(p.vibration_amplitude_m_s),
            vibration_decay: T::of(p.vibration_decay_per_s),
            kappa: T::of(p.vibration_wavenumber_rad_m),
            vibration_min_speed: T::of(p.vibration_min_speed_m_s),
            limit,
            x0: x_m,
            v0: T::ZERO,
            phase: Phase::Stick,
            slip_dir: T::ONE,
            stick_time_s: T::ZERO,
            vibration_scale: T::ZERO,
            vibration_time_s: T::ZERO,
            envelope: T::ZERO,
            envelope_dt: T::ZERO,
            envelope_step: T::ONE,
            law_type: PhantomData,
        }
    }

    /// Current contact phase of the proxy.
    #[must_use]
    pub fn phase(&self) -> Phase {
        self.phase
    }

    /// Proxy position, m.
    #[must_use]
    pub fn proxy_position_m(&self) -> T {
        self.x0
    }

    /// Advances by `dt` to the finger state `input`.
    pub fn step(&mut self, dt: T, input: Input<T>) -> Output<T> {
        let (k, b, inv_m, normal) = (self.k, self.b, self.inv_m, self.normal);
        let mu_d = self.law.mu_d;
        let coupling = |x0: T, v0: T| k * (input.x_m - x0) + b * (input.v_m_s - v0);
        let mut slip_onset = false;

        if self.phase == Phase::Stick {
            self.stick_time_s += dt;
            let hold = coupling(self.x0, T::ZERO);
            // mu_s(t) >= mu_d always, so below mu_d F_N nothing slips and
            // the law (a log10 for the time-varying one) is not evaluated.
            let mu_s = if hold.abs() > mu_d * normal {
                self.law.mu_s(self.stick_time_s)
            } else {
                mu_d
            };
            if hold.abs() > mu_s * normal {
                self.phase = Phase::Slip;
                self.slip_dir = hold.sign();
                slip_onset = true;
                self.vibration_scale = self.vibration_amplitude * mu_s * normal;
                self.vibration_time_s = T::ZERO;
                self.envelope = T::ONE;
            }
        }

        if self.phase == Phase::Slip {
            let fc = coupling(self.x0, self.v0);
            let dir = if self.v0 == T::ZERO {
                fc.sign()
            } else {
                self.v0.sign()
            };
            let friction = -dir * mu_d * normal;
            let v_new = self.v0 + (fc + friction) * inv_m * dt;
            let stopped = v_new * self.slip_dir <= T::ZERO || v_new.abs() < self.restick_speed;
            if stopped && !slip_onset && coupling(self.x0, T::ZERO).abs() < mu_d * normal {
                self.phase = Phase::Stick;
                self.v0 = T::ZERO;
                self.stick_time_s = T::ZERO;
            } else {
                self.v0 = v_new;
                if v_new != T::ZERO {
                    self.slip_dir = v_new.sign();
                }
                self.x0 += v_new * dt;
            }
        }

        let q = self.vibration(dt, input.v_m_s);
        Output {
            force_n: self.limit.clamp(-coupling(self.x0, self.v0) + q),
            vibration: T::ZERO,
            vibration_q: T::ZERO,
            phase: self.phase,
            slip_onset,
        }
    }

    /// The slip vibration Q at the current time, then advances its clock.
    fn vibration(&mut self, dt: T, finger_v: T) -> T {
        if self.vibration_scale == T::ZERO {
            return T::ZERO;
        }
        if self.envelope < T::of(VIBRATION_END) {
            self.vibration_scale = T::ZERO;
            return T::ZERO;
        }
        let tau = self.vibration_time_s;
        let envelope = self.envelope;
        self.vibration_time_s += dt;
        if dt != self.envelope_dt {
            self.envelope_dt = dt;
            self.envelope_step = (-self.vibration_decay * dt).exp();
        }
        self.envelope *= self.envelope_step;
        // sin(kappa v tau) / v is even in v; the 1/v is bounded by v_min.
        let speed = finger_v.abs();
        let wave = (self.kappa * speed * tau).sin() / speed.max(self.vibration_min_speed);
        self.slip_dir * self.vibration_scale * envelope * wave
    }
}
