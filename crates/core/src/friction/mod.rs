//! The friction core: every friction model the studies use.
//!
//! # Conventions
//! - SI units everywhere: metres, seconds, newtons, kilograms.
//! - One axis. Positive `x` is the device's positive direction; a positive
//!   force pushes the device (the finger, the hand) towards positive `x`.
//! - [`Output::force_n`] is the force the device should apply to the user's
//!   hand. Friction opposes the hand's motion, so sliding to the right gives a
//!   negative force.
//! - [`Output::vibration`] is a dimensionless actuator drive in `[-1, 1]`
//!   (fraction of the vibrotactile actuator's full scale); zero for models
//!   without a vibrotactile output.
//! - Parameters are `f64` (as protocols give them); a model converts them
//!   once to its float `T` ([`Real`]: `f64` on the host, `f32` on a
//!   microcontroller) and steps in `T`.
//!
//! # What the core never does
//! No clock, no I/O, no allocation, no global state. Time enters only as the
//! `dt` argument of `step`; a model is a plain state machine over its inputs.
//! Every output force is finite and within the configured [`ForceLimit`];
//! non-finite inputs are ignored (zero force, state unchanged).
//!
//! # Models
//! | name | seed | module |
//! |---|---|---|
//! | `god-object-constant`, `god-object-time-varying` | 000 | [`god_object`] |
//! | `stick-slip-tactile`, `stick-slip-force` | 001 | [`nakano`] |
//! | `karnopp` | 002 | [`karnopp`] |
//! | `dahl` | 002 | [`dahl`] |
//! | `viscous`, `none` | 002 | [`viscous`] |

pub mod dahl;
pub mod god_object;
pub mod karnopp;
pub mod nakano;
pub mod viscous;

#[cfg(feature = "serde")]
use serde::{Deserialize, Serialize};

use crate::check::{ParamChecks, ParamProblem};
use crate::real::Real;

pub use dahl::{Dahl, DahlParams};
pub use god_object::{
    ConstantStatic, GodObject, GodObjectParams, StaticFrictionLaw, TimeVaryingStatic,
};
pub use karnopp::{Karnopp, KarnoppParams};
pub use nakano::{Nakano, NakanoDisplay, NakanoParams};
pub use viscous::{Viscous, ViscousParams};

/// The maximum continuous force of seed 002's apparatus, in newtons: the
/// default force limit.
pub const DEFAULT_FORCE_LIMIT_N: f64 = 9.48;

/// What the device measured this step: the hand's (finger's) state.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Input<T = f64> {
    /// Hand position along the axis, m.
    pub x_m: T,
    /// Hand velocity, m/s.
    pub v_m_s: T,
}

/// Contact phase of a model's frictional element.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "serde", derive(Serialize, Deserialize))]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[cfg_attr(feature = "serde", serde(rename_all = "snake_case"))]
pub enum Phase {
    /// Static contact (or presliding).
    Stick,
    /// Gross sliding.
    Slip,
}

impl Phase {
    /// The name used in CSV files: `stick` or `slip`.
    #[must_use]
    pub fn as_str(self) -> &'static str {
        match self {
            Phase::Stick => "stick",
            Phase::Slip => "slip",
        }
    }
}

/// What a model renders this step.
///
/// `repr(C)` with the flags between the two floats: a model step returns
/// this through memory, written field by field, and a caller that reads
/// `force_n` and `vibration` as one 16-byte load (the compiler pairs them
/// when both go on together) cannot have it forwarded from those two
/// stores and stalls. The simulated session lost about a tenth of its
/// time there.
#[derive(Debug, Clone, Copy, PartialEq)]
#[repr(C)]
pub struct Output<T = f64> {
    /// Force to apply to the hand, N, within the force limit.
    pub force_n: T,
    /// Contact phase after this step.
    pub phase: Phase,
    /// True on the step where a stick-to-slip transition happened.
    pub slip_onset: bool,
    /// Vibrotactile drive in `[-1, 1]`; zero for force-only models.
    pub vibration: T,
    /// The drive's quadrature, in `[-1, 1]`: for a carrier burst (seed
    /// 001's), `vibration_q + i vibration` is the burst's complex envelope
    /// `a e^(i phi)` at this step, so a player at another rate (a sound
    /// output at 48 kHz) can synthesise the carrier between steps
    /// ([`ModelParams::burst`]) instead of resampling a carrier the loop's
    /// rate aliases. Zero for every other model.
    pub vibration_q: T,
}

impl<T: Real> Output<T> {
    /// Zero force, no vibration, in the given phase.
    #[must_use]
    pub fn rest(phase: Phase) -> Self {
        Output {
            force_n: T::ZERO,
            vibration: T::ZERO,
            vibration_q: T::ZERO,
            phase,
            slip_onset: false,
        }
    }
}

/// The largest force magnitude a model may output, N.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ForceLimit<T = f64>(T);

impl<T: Real> ForceLimit<T> {
    /// A limit of `limit_n` newtons.
    ///
    /// # Errors
    /// If `limit_n` is not finite and positive.
    pub fn new(limit_n: T) -> Result<Self, ParamProblem> {
        let mut problem = None;
        let mut report = |p| problem = Some(p);
        ParamChecks::new(&mut report).positive("force_limit_n", limit_n);
        match problem {
            Some(p) => Err(p),
            None => Ok(ForceLimit(limit_n)),
        }
    }

    /// The limit, N.
    #[must_use]
    pub fn newtons(self) -> T {
        self.0
    }

    /// `force` clamped to `[-limit, limit]`; a non-finite force becomes 0.
    #[must_use]
    pub fn clamp(self, force: T) -> T {
        if force.is_finite() {
            force.clamp(-self.0, self.0)
        } else {
            T::ZERO
        }
    }

    /// The same limit in another float (rounded to nearest).
    #[must_use]
    pub fn cast<U: Real>(self) -> ForceLimit<U> {
        ForceLimit(U::of(self.0.to_f64()))
    }
}

impl<T: Real> Default for ForceLimit<T> {
    fn default() -> Self {
        ForceLimit(T::of(DEFAULT_FORCE_LIMIT_N))
    }
}

/// The float a model computes in.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "serde", derive(Serialize, Deserialize))]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[cfg_attr(feature = "serde", serde(rename_all = "lowercase"))]
pub enum Float {
    /// Double precision: the host's default.
    #[default]
    F64,
    /// Single precision: what a device with a single-precision FPU (a
    /// Cortex-M4F) runs.
    F32,
}

/// A model stepped in either float, with `f64` at its edges: inputs are
/// rounded to the model's float, outputs widened (exactly) back.
#[derive(Debug, Clone)]
pub enum Stepper {
    /// In `f64`.
    F64(Friction<f64>),
    /// In `f32`.
    F32(Friction<f32>),
}

impl Stepper {
    /// A model in `float` at rest at `x_m`, limited to `limit`.
    ///
    /// # Errors
    /// The first invalid parameter of `params`.
    pub fn new(
        params: &ModelParams,
        float: Float,
        limit: ForceLimit,
        x_m: f64,
    ) -> Result<Self, ParamProblem> {
        Ok(match float {
            Float::F64 => Stepper::F64(Friction::new(params, limit, x_m)?),
            Float::F32 => Stepper::F32(Friction::new(params, limit.cast(), f32::of(x_m))?),
        })
    }

    /// Advances the model by `dt` to `input` (see [`Friction::step`]).
    pub fn step(&mut self, dt: f64, input: Input) -> Output {
        match self {
            Stepper::F64(m) => m.step(dt, input),
            Stepper::F32(m) => {
                let input = Input {
                    x_m: f32::of(input.x_m),
                    v_m_s: f32::of(input.v_m_s),
                };
                let o = m.step(f32::of(dt), input);
                Output {
                    force_n: o.force_n.to_f64(),
                    vibration: o.vibration.to_f64(),
                    vibration_q: o.vibration_q.to_f64(),
                    phase: o.phase,
                    slip_onset: o.slip_onset,
                }
            }
        }
    }

    /// The current contact phase.
    #[must_use]
    pub fn phase(&self) -> Phase {
        match self {
            Stepper::F64(m) => m.phase(),
            Stepper::F32(m) => m.phase(),
        }
    }
}

/// How a model is stepped on a device: one value for the simulated device,
/// the haptic loop, the emulator and the scripted scenarios (in the spirit
/// of rapier's `IntegrationParameters`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StepParams {
    /// Loop rate, Hz; greater than 0. Default 1000 (seed 002's servo rate);
    /// [`ModelParams::loop_rate_hz`] gives the rate a model needs.
    pub rate_hz: f64,
    /// Largest force the device outputs. Default [`DEFAULT_FORCE_LIMIT_N`]
    /// (seed 002's maximum continuous force).
    pub force_limit: ForceLimit,
    /// Cutoff of the velocity estimate, Hz: a first-order low-pass of the
    /// measured position's difference quotient, as a host estimates
    /// velocity from an encoder. Greater than 0. Default 100.
    pub velocity_cutoff_hz: f64,
    /// The float the model computes in. Default `f64`; `f32` is what a
    /// device with a single-precision FPU runs.
    pub float: Float,
}

impl Default for StepParams {
    fn default() -> Self {
        StepParams {
            rate_hz: 1000.0,
            force_limit: ForceLimit::default(),
            velocity_cutoff_hz: 100.0,
            float: Float::F64,
        }
    }
}

impl StepParams {
    /// The step, s.
    #[must_use]
    pub fn dt(&self) -> f64 {
        1.0 / self.rate_hz
    }

    /// The velocity filter's coefficient for a step of `dt` s:
    /// `exp(-2 pi f_c dt)` (the weight kept of the previous estimate).
    #[must_use]
    pub fn velocity_alpha(&self, dt: f64) -> f64 {
        libm::exp(-core::f64::consts::TAU * self.velocity_cutoff_hz * dt)
    }
}

/// Below this a velocity estimate is exactly zero, m/s: 1 nm/s, more than
/// six orders of magnitude below the slowest motion an encoder resolves
/// (one 1 um count per 0.2 ms tick is 5 mm/s). Without it an estimate
/// that decays while the device is still ends in subnormal numbers (such
/// as 5e-324, which the filter's rounding keeps for ever): slow on most
/// CPUs, and 300-digit decimals in a CSV (issue 37).
pub const VELOCITY_FLOOR_M_S: f64 = 1e-9;

/// One step of the velocity estimate: the first-order low-pass
/// `alpha previous + (1 - alpha) raw` of the position's difference
/// quotient `raw`, settled to exactly 0 below [`VELOCITY_FLOOR_M_S`]. The
/// simulated device, the host's haptic loop and the firmware all step it.
#[inline]
#[must_use]
pub fn filtered_velocity<T: Real>(alpha: T, previous: T, raw: T) -> T {
    let v = alpha * previous + (T::ONE - alpha) * raw;
    if v.abs() < T::of(VELOCITY_FLOOR_M_S) {
        T::ZERO
    } else {
        v
    }
}

/// The parameters of one friction model, tagged by its name.
///
/// In JSON: `{"model": "karnopp", "f_static_n": 2.5, ...}`; omitted fields
/// take the seeds' defaults, unknown fields are refused.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(Serialize, Deserialize))]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[cfg_attr(feature = "serde", serde(tag = "model", rename_all = "kebab-case"))]
pub enum ModelParams {
    /// Seed 000's god object with constant coefficients (mu_s 1.0, mu_d 0.6).
    GodObjectConstant(GodObjectParams<ConstantStatic>),
    /// Seed 000's god object with the time-varying static coefficient
    /// mu_s(t) = mu_d + B log10(C t + 1).
    GodObjectTimeVarying(GodObjectParams<TimeVaryingStatic>),
    /// Seed 001's Nakano stick-slip model driving a 600 Hz vibrotactile burst.
    StickSlipTactile(NakanoParams),
    /// Seed 001's Nakano stick-slip model rendered as tangential force.
    StickSlipForce(NakanoParams),
    /// Seed 002's modified Karnopp model on a virtual block behind a virtual
    /// coupling.
    Karnopp(KarnoppParams),
    /// Seed 002's Dahl model with a viscous term.
    Dahl(DahlParams),
    /// Pure viscous damping, F = -b v (35 N s/m in seed 002's Fitts study).
    Viscous(ViscousParams),
    /// No rendered friction (the apparatus alone).
    None,
}

impl ModelParams {
    /// Every model name, as written in protocols and on the command line.
    pub const NAMES: [&'static str; 8] = [
        "god-object-constant",
        "god-object-time-varying",
        "stick-slip-tactile",
        "stick-slip-force",
        "karnopp",
        "dahl",
        "viscous",
        "none",
    ];

    /// The seeds' default parameters of the model called `name`, or `None`
    /// for an unknown name.
    #[must_use]
    pub fn default_for(name: &str) -> Option<Self> {
        Some(match name {
            "god-object-constant" => Self::GodObjectConstant(GodObjectParams::default()),
            "god-object-time-varying" => Self::GodObjectTimeVarying(GodObjectParams::default()),
            "stick-slip-tactile" => Self::StickSlipTactile(NakanoParams::default()),
            "stick-slip-force" => Self::StickSlipForce(NakanoParams::default()),
            "karnopp" => Self::Karnopp(KarnoppParams::default()),
            "dahl" => Self::Dahl(DahlParams::default()),
            "viscous" => Self::Viscous(ViscousParams::default()),
            "none" => Self::None,
            _ => return None,
        })
    }

    /// The model's name.
    #[must_use]
    pub fn name(&self) -> &'static str {
        match self {
            Self::GodObjectConstant(_) => "god-object-constant",
            Self::GodObjectTimeVarying(_) => "god-object-time-varying",
            Self::StickSlipTactile(_) => "stick-slip-tactile",
            Self::StickSlipForce(_) => "stick-slip-force",
            Self::Karnopp(_) => "karnopp",
            Self::Dahl(_) => "dahl",
            Self::Viscous(_) => "viscous",
            Self::None => "none",
        }
    }

    /// Whether the model drives a vibrotactile actuator.
    #[must_use]
    pub fn has_vibration(&self) -> bool {
        matches!(self, Self::StickSlipTactile(_))
    }

    /// A carrier burst's frequency, Hz, and its envelope's decay rate,
    /// 1/s, for a model whose drive is one (seed 001's tactile display):
    /// between two steps the drive is `Im(z e^((i 2 pi f - d) t))`, `z`
    /// the step's complex envelope ([`Output::vibration_q`]).
    #[must_use]
    pub fn burst(&self) -> Option<(f64, f64)> {
        match self {
            Self::StickSlipTactile(p) => Some((p.carrier_hz, 1.0 / p.envelope_time_constant_s)),
            _ => None,
        }
    }

    /// The loop rate the seed ran this model at, Hz: 5 kHz for seed 001's
    /// stick-slip models, 1 kHz for the others.
    #[must_use]
    pub fn loop_rate_hz(&self) -> f64 {
        match self {
            Self::StickSlipTactile(_) | Self::StickSlipForce(_) => 5000.0,
            _ => 1000.0,
        }
    }

    /// Reports every invalid parameter to `report`, with field names
    /// relative to this object. Allocates nothing.
    pub fn check(&self, report: &mut dyn FnMut(ParamProblem)) {
        let mut c = ParamChecks::new(report);
        match self {
            Self::GodObjectConstant(p) => p.check(&mut c),
            Self::GodObjectTimeVarying(p) => p.check(&mut c),
            Self::StickSlipTactile(p) | Self::StickSlipForce(p) => p.check(&mut c),
            Self::Karnopp(p) => p.check(&mut c),
            Self::Dahl(p) => p.check(&mut c),
            Self::Viscous(p) => p.check(&mut c),
            Self::None => {}
        }
    }

    /// The first invalid parameter, if any.
    #[must_use]
    pub fn first_problem(&self) -> Option<ParamProblem> {
        let mut first = None;
        self.check(&mut |p| {
            first.get_or_insert(p);
        });
        first
    }
}

/// A friction model's running state: one of the models, ready to step in
/// the float `T`.
#[derive(Debug, Clone)]
pub enum Friction<T: Real = f64> {
    /// God object, constant coefficients.
    GodObjectConstant(GodObject<ConstantStatic, T>),
    /// God object, time-varying static coefficient.
    GodObjectTimeVarying(GodObject<TimeVaryingStatic, T>),
    /// Nakano stick-slip (tactile or force display).
    Nakano(Nakano<T>),
    /// Modified Karnopp behind a virtual coupling.
    Karnopp(Karnopp<T>),
    /// Dahl.
    Dahl(Dahl<T>),
    /// Viscous damping, or nothing.
    Viscous(Viscous<T>),
}

impl<T: Real> Friction<T> {
    /// A model at rest at position `x_m`, with output limited to `limit`.
    ///
    /// # Errors
    /// The first invalid parameter of `params` ([`ModelParams::check`]
    /// reports them all).
    pub fn new(params: &ModelParams, limit: ForceLimit<T>, x_m: T) -> Result<Self, ParamProblem> {
        if let Some(problem) = params.first_problem() {
            return Err(problem);
        }
        Ok(match params {
            ModelParams::GodObjectConstant(p) => {
                Self::GodObjectConstant(GodObject::new(*p, limit, x_m))
            }
            ModelParams::GodObjectTimeVarying(p) => {
                Self::GodObjectTimeVarying(GodObject::new(*p, limit, x_m))
            }
            ModelParams::StickSlipTactile(p) => {
                Self::Nakano(Nakano::new(*p, NakanoDisplay::Tactile, limit))
            }
            ModelParams::StickSlipForce(p) => {
                Self::Nakano(Nakano::new(*p, NakanoDisplay::Force, limit))
            }
            ModelParams::Karnopp(p) => Self::Karnopp(Karnopp::new(*p, limit, x_m)),
            ModelParams::Dahl(p) => Self::Dahl(Dahl::new(*p, limit, x_m)),
            ModelParams::Viscous(p) => Self::Viscous(Viscous::new(T::of(p.damping_n_s_m), limit)),
            ModelParams::None => Self::Viscous(Viscous::new(T::ZERO, limit)),
        })
    }

    /// The hand presses `y_m` into the surface: a model whose normal force
    /// is the press (the god object with `press_stiffness_n_m`) takes it,
    /// and returns its normal force.
    pub fn press(&mut self, y_m: T) -> Option<T> {
        match self {
            Self::GodObjectConstant(m) => m.press(y_m),
            Self::GodObjectTimeVarying(m) => m.press(y_m),
            _ => None,
        }
    }

    /// Sets the pressed normal force of a model whose normal force is the
    /// press, N.
    pub fn set_pressed_normal(&mut self, normal_n: T) {
        match self {
            Self::GodObjectConstant(m) => m.set_pressed_normal(normal_n),
            Self::GodObjectTimeVarying(m) => m.set_pressed_normal(normal_n),
            _ => {}
        }
    }

    /// Advances the model by `dt` seconds to the hand state `input`.
    ///
    /// A non-finite or non-positive `dt`, or a non-finite input, leaves the
    /// state unchanged and renders zero force.
    pub fn step(&mut self, dt: T, input: Input<T>) -> Output<T> {
        if !(dt.is_finite() && dt > T::ZERO && input.x_m.is_finite() && input.v_m_s.is_finite()) {
            return Output::rest(self.phase());
        }
        match self {
            Self::GodObjectConstant(m) => m.step(dt, input),
            Self::GodObjectTimeVarying(m) => m.step(dt, input),
            Self::Nakano(m) => m.step(dt, input),
            Self::Karnopp(m) => m.step(dt, input),
            Self::Dahl(m) => m.step(dt, input),
            Self::Viscous(m) => m.step(dt, input),
        }
    }

    /// The current contact phase.
    #[must_use]
    pub fn phase(&self) -> Phase {
        match self {
            Self::GodObjectConstant(m) => m.phase(),
            Self::GodObjectTimeVarying(m) => m.phase(),
            Self::Nakano(m) => m.phase(),
            Self::Karnopp(m) => m.phase(),
            Self::Dahl(m) => m.phase(),
            Self::Viscous(m) => m.phase(),
        }
    }
}
