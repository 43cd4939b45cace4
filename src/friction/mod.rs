//! The friction core: every friction model of the three studies.
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

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::problem::Problem;

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
pub struct Input {
    /// Hand position along the axis, m.
    pub x_m: f64,
    /// Hand velocity, m/s.
    pub v_m_s: f64,
}

/// Contact phase of a model's frictional element.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
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
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Output {
    /// Force to apply to the hand, N, within the force limit.
    pub force_n: f64,
    /// Vibrotactile drive in `[-1, 1]`; zero for force-only models.
    pub vibration: f64,
    /// Contact phase after this step.
    pub phase: Phase,
    /// True on the step where a stick-to-slip transition happened.
    pub slip_onset: bool,
}

impl Output {
    /// Zero force, no vibration, in the given phase.
    #[must_use]
    pub fn rest(phase: Phase) -> Self {
        Output {
            force_n: 0.0,
            vibration: 0.0,
            phase,
            slip_onset: false,
        }
    }
}

/// The largest force magnitude a model may output, N.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ForceLimit(f64);

impl ForceLimit {
    /// A limit of `limit_n` newtons.
    ///
    /// # Errors
    /// If `limit_n` is not finite and positive.
    pub fn new(limit_n: f64) -> Result<Self, Problem> {
        positive("force_limit_n", limit_n)?;
        Ok(ForceLimit(limit_n))
    }

    /// The limit, N.
    #[must_use]
    pub fn newtons(self) -> f64 {
        self.0
    }

    /// `force` clamped to `[-limit, limit]`; a non-finite force becomes 0.
    #[must_use]
    pub fn clamp(self, force: f64) -> f64 {
        if force.is_finite() {
            force.clamp(-self.0, self.0)
        } else {
            0.0
        }
    }
}

impl Default for ForceLimit {
    fn default() -> Self {
        ForceLimit(DEFAULT_FORCE_LIMIT_N)
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
}

impl Default for StepParams {
    fn default() -> Self {
        StepParams {
            rate_hz: 1000.0,
            force_limit: ForceLimit::default(),
            velocity_cutoff_hz: 100.0,
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
        (-std::f64::consts::TAU * self.velocity_cutoff_hz * dt).exp()
    }
}

/// Checks that `value` is finite.
///
/// # Errors
/// A [`Problem`] naming `field` otherwise.
pub fn finite(field: &str, value: f64) -> Result<(), Problem> {
    if value.is_finite() {
        Ok(())
    } else {
        Err(Problem::new(field, format!("must be finite, got {value}")))
    }
}

/// Checks that `value` is finite and greater than zero.
///
/// # Errors
/// A [`Problem`] naming `field` otherwise.
pub fn positive(field: &str, value: f64) -> Result<(), Problem> {
    finite(field, value)?;
    if value > 0.0 {
        Ok(())
    } else {
        Err(Problem::new(
            field,
            format!("must be greater than 0, got {value}"),
        ))
    }
}

/// Checks that `value` is finite and not negative.
///
/// # Errors
/// A [`Problem`] naming `field` otherwise.
pub fn non_negative(field: &str, value: f64) -> Result<(), Problem> {
    finite(field, value)?;
    if value >= 0.0 {
        Ok(())
    } else {
        Err(Problem::new(
            field,
            format!("must not be negative, got {value}"),
        ))
    }
}

/// Checks that `value` (field `field`) is greater than `other` (field
/// `other_field`), or at least equal to it when `allow_equal`.
///
/// # Errors
/// A [`Problem`] naming `field` otherwise.
pub fn exceeds(
    field: &str,
    value: f64,
    other_field: &str,
    other: f64,
    allow_equal: bool,
) -> Result<(), Problem> {
    if value > other || (allow_equal && value == other) {
        return Ok(());
    }
    let relation = if allow_equal {
        "must be at least"
    } else {
        "must be greater than"
    };
    Err(Problem::new(
        field,
        format!("{relation} {other_field} ({other}), got {value}"),
    ))
}

/// Collects the errors of several checks.
pub(crate) fn collect(checks: impl IntoIterator<Item = Result<(), Problem>>) -> Vec<Problem> {
    checks.into_iter().filter_map(Result::err).collect()
}

/// The parameters of one friction model, tagged by its name.
///
/// In JSON: `{"model": "karnopp", "f_static_n": 2.5, ...}`; omitted fields
/// take the seeds' defaults, unknown fields are refused.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(tag = "model", rename_all = "kebab-case")]
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

    /// The loop rate the seed ran this model at, Hz: 5 kHz for seed 001's
    /// stick-slip models, 1 kHz for the others.
    #[must_use]
    pub fn loop_rate_hz(&self) -> f64 {
        match self {
            Self::StickSlipTactile(_) | Self::StickSlipForce(_) => 5000.0,
            _ => 1000.0,
        }
    }

    /// Every invalid parameter, with field names relative to this object.
    #[must_use]
    pub fn validate(&self) -> Vec<Problem> {
        match self {
            Self::GodObjectConstant(p) => p.validate(),
            Self::GodObjectTimeVarying(p) => p.validate(),
            Self::StickSlipTactile(p) | Self::StickSlipForce(p) => p.validate(),
            Self::Karnopp(p) => p.validate(),
            Self::Dahl(p) => p.validate(),
            Self::Viscous(p) => p.validate(),
            Self::None => Vec::new(),
        }
    }
}

/// A friction model's running state: one of the models, ready to step.
#[derive(Debug, Clone)]
pub enum Friction {
    /// God object, constant coefficients.
    GodObjectConstant(GodObject<ConstantStatic>),
    /// God object, time-varying static coefficient.
    GodObjectTimeVarying(GodObject<TimeVaryingStatic>),
    /// Nakano stick-slip (tactile or force display).
    Nakano(Nakano),
    /// Modified Karnopp behind a virtual coupling.
    Karnopp(Karnopp),
    /// Dahl.
    Dahl(Dahl),
    /// Viscous damping, or nothing.
    Viscous(Viscous),
}

impl Friction {
    /// A model at rest at position `x_m`, with output limited to `limit`.
    ///
    /// # Errors
    /// Every invalid parameter of `params`.
    pub fn new(params: &ModelParams, limit: ForceLimit, x_m: f64) -> Result<Self, Vec<Problem>> {
        let errors = params.validate();
        if !errors.is_empty() {
            return Err(errors);
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
            ModelParams::Viscous(p) => Self::Viscous(Viscous::new(p.damping_n_s_m, limit)),
            ModelParams::None => Self::Viscous(Viscous::new(0.0, limit)),
        })
    }

    /// Advances the model by `dt` seconds to the hand state `input`.
    ///
    /// A non-finite or non-positive `dt`, or a non-finite input, leaves the
    /// state unchanged and renders zero force.
    pub fn step(&mut self, dt: f64, input: Input) -> Output {
        if !(dt.is_finite() && dt > 0.0 && input.x_m.is_finite() && input.v_m_s.is_finite()) {
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

/// `+1.0`, `-1.0`, or `0.0` for zero (unlike `f64::signum`).
#[must_use]
pub(crate) fn sign(x: f64) -> f64 {
    if x > 0.0 {
        1.0
    } else if x < 0.0 {
        -1.0
    } else {
        0.0
    }
}
