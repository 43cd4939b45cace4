//! Scripted scenarios: a hand (or finger, or device) moving through a friction
//! model, stepped in virtual time. Used by `frictionlab render` and the tests
//! that reproduce the seeds' claims.
//!
//! Like the friction core, a scenario reads no clock and does no I/O: it is a
//! pure function of the model, the scenario parameters and the step rate.
//!
//! # Scenarios
//! - `spidar-slide` (seed 000, Fig. 3/4): a hand at rest in long contact,
//!   then sliding at about 0.03 m/s. The hand is a mass that regulates its
//!   speed through its own compliance: it tracks a reference point (at rest
//!   for `stick_s`, then moving at `slide_speed_m_s`) through a spring and a
//!   damper, and is pushed by the rendered force. A purely kinematic finger
//!   does not show the seed's decay of stick-slip. Defaults: 1 kg, 300 N/m,
//!   20 N s/m, 0.03 m/s, 1 s stick (STUDIES 1a). Time `t_s = 0` is the first
//!   stick-to-slip transition (the slide start if there is none); the run
//!   ends `after_onset_s` after it.
//! - `sinusoidal-stroke` (seed 001, Fig. 5): a finger stroke starting at rest,
//!   `x = A (1 - cos(2 pi f t))`, kinematic (the tactile display renders no
//!   force to push back). Defaults 2 cm at 2 Hz, two cycles: peak speed
//!   0.25 m/s, fast enough that stick-slip stops there.
//! - `coupled-block` (seed 002, Fig. 6): user-like motion of the device
//!   through the virtual coupling: minimum-jerk reaches between `-reach_m`
//!   and `+reach_m` (within the apparatus's 3.2 cm range) separated by
//!   dwells, kinematic like the seed's hand-moved mouse. Defaults 12 mm,
//!   0.6 s per reach, 0.3 s dwells, 6 reaches.

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::friction::{Input, ModelParams, Output, Phase, StepParams, Stepper, checked};
use crate::hand::{Hand, HandDrive};
use crate::problem::Problem;

/// Seed 000's slide: a compliant hand that starts sliding after a long stick.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct SpidarSlide {
    /// Hand mass, kg. Default 1 (seed 000's hand mass).
    pub hand_mass_kg: f64,
    /// Stiffness with which the hand tracks its reference, N/m. Default 300.
    pub hand_stiffness_n_m: f64,
    /// Damping with which the hand tracks its reference, N s/m. Default 20.
    pub hand_damping_n_s_m: f64,
    /// Speed of the reference once sliding, m/s. Default 0.03.
    pub slide_speed_m_s: f64,
    /// Stick (rest in contact) before the slide, s. Default 1.
    pub stick_s: f64,
    /// How long to run after slip onset, s. Default 1.5.
    pub after_onset_s: f64,
    /// Longest wait for slip onset after the slide starts, s. Default 5.
    pub max_wait_s: f64,
}

impl Default for SpidarSlide {
    fn default() -> Self {
        SpidarSlide {
            hand_mass_kg: 1.0,
            hand_stiffness_n_m: 300.0,
            hand_damping_n_s_m: 20.0,
            slide_speed_m_s: 0.03,
            stick_s: 1.0,
            after_onset_s: 1.5,
            max_wait_s: 5.0,
        }
    }
}

/// Seed 001's Fig. 5: a sinusoidal finger stroke starting at rest.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct SinusoidalStroke {
    /// Stroke amplitude A, m (the finger moves between 0 and 2A). Default 0.02.
    pub amplitude_m: f64,
    /// Stroke frequency, Hz. Default 2.
    pub frequency_hz: f64,
    /// Number of cycles. Default 2.
    pub cycles: f64,
}

impl Default for SinusoidalStroke {
    fn default() -> Self {
        SinusoidalStroke {
            amplitude_m: 0.02,
            frequency_hz: 2.0,
            cycles: 2.0,
        }
    }
}

impl SinusoidalStroke {
    /// Peak finger speed, m/s.
    #[must_use]
    pub fn peak_speed_m_s(&self) -> f64 {
        self.amplitude_m * std::f64::consts::TAU * self.frequency_hz
    }
}

/// Seed 002's Fig. 6: reaches of the device through the virtual coupling.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct CoupledBlock {
    /// Reach end points at +- this, m. Default 0.012.
    pub reach_m: f64,
    /// Duration of one reach, s. Default 0.6.
    pub move_s: f64,
    /// Dwell before each reach and at the end, s. Default 0.3.
    pub dwell_s: f64,
    /// Number of reaches. Default 6.
    pub reaches: u32,
}

impl Default for CoupledBlock {
    fn default() -> Self {
        CoupledBlock {
            reach_m: 0.012,
            move_s: 0.6,
            dwell_s: 0.3,
            reaches: 6,
        }
    }
}

/// Seed 002's identification run (STUDIES 1e): the apparatus's servo moves
/// the slide, with the surface's friction (the model) acting on it, along
/// `x = -A cos(2 pi f t)`. The applied (motor) force is what moves the slide's
/// mass against the friction: `F_applied = m a - force_n`, with `force_n` the
/// model's force on the slide. Rendered samples carry `a_m_s2` and
/// `applied_force_n`, the input `frictionlab identify` reads.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct ServoSinusoid {
    /// Amplitude A, m. Default 0.01 (within the 32 mm range).
    pub amplitude_m: f64,
    /// Frequency, Hz. Default 2 (seed 002's noise SDs are at 2 Hz).
    pub frequency_hz: f64,
    /// Number of cycles. Default 20 (10 s).
    pub cycles: f64,
    /// Moving mass of motor and slide, kg. Default 0.692 (seed 002 Table 2).
    pub slide_mass_kg: f64,
}

impl Default for ServoSinusoid {
    fn default() -> Self {
        ServoSinusoid {
            amplitude_m: 0.01,
            frequency_hz: 2.0,
            cycles: 20.0,
            slide_mass_kg: 0.692,
        }
    }
}

/// A scenario and its parameters, tagged by name.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(tag = "scenario", rename_all = "kebab-case")]
pub enum ScenarioParams {
    /// Seed 000's slide.
    SpidarSlide(SpidarSlide),
    /// Seed 001's stroke.
    SinusoidalStroke(SinusoidalStroke),
    /// Seed 002's coupled block.
    CoupledBlock(CoupledBlock),
    /// Seed 002's identification run.
    ServoSinusoid(ServoSinusoid),
}

impl ScenarioParams {
    /// Every scenario name.
    pub const NAMES: [&'static str; 4] = [
        "spidar-slide",
        "sinusoidal-stroke",
        "coupled-block",
        "servo-sinusoid",
    ];

    /// The default parameters of the scenario called `name`.
    #[must_use]
    pub fn default_for(name: &str) -> Option<Self> {
        Some(match name {
            "spidar-slide" => Self::SpidarSlide(SpidarSlide::default()),
            "sinusoidal-stroke" => Self::SinusoidalStroke(SinusoidalStroke::default()),
            "coupled-block" => Self::CoupledBlock(CoupledBlock::default()),
            "servo-sinusoid" => Self::ServoSinusoid(ServoSinusoid::default()),
            _ => return None,
        })
    }

    /// The scenario's name.
    #[must_use]
    pub fn name(&self) -> &'static str {
        match self {
            Self::SpidarSlide(_) => "spidar-slide",
            Self::SinusoidalStroke(_) => "sinusoidal-stroke",
            Self::CoupledBlock(_) => "coupled-block",
            Self::ServoSinusoid(_) => "servo-sinusoid",
        }
    }

    /// Every invalid field.
    #[must_use]
    pub fn validate(&self) -> Vec<Problem> {
        match self {
            Self::SpidarSlide(s) => checked(|c| {
                c.positive("hand_mass_kg", s.hand_mass_kg);
                c.non_negative("hand_stiffness_n_m", s.hand_stiffness_n_m);
                c.non_negative("hand_damping_n_s_m", s.hand_damping_n_s_m);
                c.non_negative("slide_speed_m_s", s.slide_speed_m_s);
                c.non_negative("stick_s", s.stick_s);
                c.non_negative("after_onset_s", s.after_onset_s);
                c.non_negative("max_wait_s", s.max_wait_s);
            }),
            Self::SinusoidalStroke(s) => checked(|c| {
                c.non_negative("amplitude_m", s.amplitude_m);
                c.positive("frequency_hz", s.frequency_hz);
                c.non_negative("cycles", s.cycles);
            }),
            Self::CoupledBlock(s) => checked(|c| {
                c.non_negative("reach_m", s.reach_m);
                c.positive("move_s", s.move_s);
                c.non_negative("dwell_s", s.dwell_s);
            }),
            Self::ServoSinusoid(s) => checked(|c| {
                c.non_negative("amplitude_m", s.amplitude_m);
                c.positive("frequency_hz", s.frequency_hz);
                c.non_negative("cycles", s.cycles);
                c.positive("slide_mass_kg", s.slide_mass_kg);
            }),
        }
    }
}

/// The longest run a scenario may ask for, in steps (10 minutes at 5 kHz).
pub const MAX_STEPS: u64 = 3_000_000;

/// One step of a rendered time series.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sample {
    /// Time, s (scenario-defined origin).
    pub t_s: f64,
    /// Hand position, m.
    pub x_m: f64,
    /// Hand velocity, m/s.
    pub v_m_s: f64,
    /// Rendered force on the hand, N.
    pub force_n: f64,
    /// Vibrotactile drive in `[-1, 1]`.
    pub vibration: f64,
    /// Contact phase.
    pub phase: Phase,
    /// A stick-to-slip transition happened at this step.
    pub slip_onset: bool,
    /// Identification runs only: (acceleration m/s^2, applied force N).
    pub applied: Option<(f64, f64)>,
}

impl Sample {
    /// The sample at time `t_s` of a model that rendered `output` for `input`.
    #[must_use]
    pub fn new(t_s: f64, input: Input, output: Output) -> Self {
        Sample {
            t_s,
            x_m: input.x_m,
            v_m_s: input.v_m_s,
            force_n: output.force_n,
            vibration: output.vibration,
            phase: output.phase,
            slip_onset: output.slip_onset,
            applied: None,
        }
    }
}

/// Why a scenario could not run.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ScenarioError {
    /// A model parameter is invalid.
    #[error("model parameter {0}")]
    Model(Problem),
    /// A scenario parameter is invalid.
    #[error("scenario parameter {0}")]
    Scenario(Problem),
    /// The step rate is not a positive finite number.
    #[error("rate_hz: must be finite and greater than 0, got {0}")]
    Rate(f64),
    /// The run would be longer than [`MAX_STEPS`].
    #[error("the run would take {0} steps, more than the {MAX_STEPS} allowed")]
    TooLong(u64),
}

/// Runs `model` through `scenario`.
///
/// # Errors
/// The first invalid parameter, a bad rate, or a run longer than [`MAX_STEPS`].
pub fn run(
    model: &ModelParams,
    scenario: &ScenarioParams,
    settings: StepParams,
) -> Result<Vec<Sample>, ScenarioError> {
    if let Some(e) = scenario.validate().into_iter().next() {
        return Err(ScenarioError::Scenario(e));
    }
    if !(settings.rate_hz.is_finite() && settings.rate_hz > 0.0) {
        return Err(ScenarioError::Rate(settings.rate_hz));
    }
    let mut friction = Stepper::new(model, settings.float, settings.force_limit, 0.0)
        .map_err(|e| ScenarioError::Model(crate::friction::problem(e)))?;
    let dt = 1.0 / settings.rate_hz;
    match scenario {
        ScenarioParams::SpidarSlide(s) => {
            let steps = steps_for(s.stick_s + s.max_wait_s + s.after_onset_s, dt)?;
            Ok(spidar_slide(&mut friction, s, dt, steps))
        }
        ScenarioParams::SinusoidalStroke(s) => {
            let steps = steps_for(s.cycles / s.frequency_hz, dt)?;
            let omega = std::f64::consts::TAU * s.frequency_hz;
            Ok(kinematic(&mut friction, dt, steps, |t| {
                let (sin, cos) = (omega * t).sin_cos();
                (s.amplitude_m * (1.0 - cos), s.amplitude_m * omega * sin)
            }))
        }
        ScenarioParams::CoupledBlock(s) => {
            let cycle = s.dwell_s + s.move_s;
            let total = f64::from(s.reaches) * cycle + s.dwell_s;
            let steps = steps_for(total, dt)?;
            Ok(kinematic(&mut friction, dt, steps, |t| reaches(s, t)))
        }
        ScenarioParams::ServoSinusoid(s) => {
            let steps = steps_for(s.cycles / s.frequency_hz, dt)?;
            let omega = std::f64::consts::TAU * s.frequency_hz;
            let motion = |t: f64| {
                let (sin, cos) = (omega * t).sin_cos();
                (
                    -s.amplitude_m * cos,
                    s.amplitude_m * omega * sin,
                    s.amplitude_m * omega * omega * cos,
                )
            };
            let mut samples = kinematic(&mut friction, dt, steps, |t| {
                let (x, v, _) = motion(t);
                (x, v)
            });
            for sample in &mut samples {
                let (_, _, a) = motion(sample.t_s);
                sample.applied = Some((a, s.slide_mass_kg * a - sample.force_n));
            }
            Ok(samples)
        }
    }
}

/// Steps in `duration` at `dt`, refusing runs longer than [`MAX_STEPS`].
fn steps_for(duration: f64, dt: f64) -> Result<u64, ScenarioError> {
    let steps = (duration / dt).round();
    if steps > MAX_STEPS as f64 {
        #[expect(
            clippy::cast_possible_truncation,
            clippy::cast_sign_loss,
            reason = "finite, positive and only reported"
        )]
        return Err(ScenarioError::TooLong(steps.min(u64::MAX as f64) as u64));
    }
    #[expect(
        clippy::cast_possible_truncation,
        clippy::cast_sign_loss,
        reason = "finite, non-negative and at most MAX_STEPS"
    )]
    Ok(steps as u64)
}

/// A hand whose position and velocity are prescribed by `motion(t)`.
fn kinematic(
    friction: &mut Stepper,
    dt: f64,
    steps: u64,
    motion: impl Fn(f64) -> (f64, f64),
) -> Vec<Sample> {
    let mut out = Vec::with_capacity(usize::try_from(steps).unwrap_or(0) + 1);
    for i in 0..=steps {
        let t = i as f64 * dt;
        let (x_m, v_m_s) = motion(t);
        let input = Input { x_m, v_m_s };
        out.push(Sample::new(t, input, friction.step(dt, input)));
    }
    out
}

/// Position and velocity at `t` of the coupled-block reaches.
fn reaches(s: &CoupledBlock, t: f64) -> (f64, f64) {
    let cycle = s.dwell_s + s.move_s;
    let n = (t / cycle).floor();
    // Reach n goes from start to -start; the first starts at 0 and ends at +reach.
    let target = |k: f64| {
        if k < 0.0 {
            0.0
        } else if k % 2.0 == 0.0 {
            s.reach_m
        } else {
            -s.reach_m
        }
    };
    if n >= f64::from(s.reaches) {
        return (target(f64::from(s.reaches) - 1.0), 0.0);
    }
    let from = target(n - 1.0);
    let to = target(n);
    let local = t - n * cycle - s.dwell_s;
    if local <= 0.0 {
        return (from, 0.0);
    }
    min_jerk(from, to, s.move_s, local)
}

/// Position and velocity at time `t` (s, from the start) of a minimum-jerk
/// movement from `from` to `to` lasting `duration` s; at rest outside it.
#[must_use]
pub fn min_jerk(from: f64, to: f64, duration: f64, t: f64) -> (f64, f64) {
    if t <= 0.0 || duration <= 0.0 {
        return (if t <= 0.0 { from } else { to }, 0.0);
    }
    let tau = (t / duration).min(1.0);
    let shape = tau * tau * tau * (10.0 - 15.0 * tau + 6.0 * tau * tau);
    let rate = 30.0 * tau * tau * (1.0 - tau) * (1.0 - tau) / duration;
    (from + (to - from) * shape, (to - from) * rate)
}

/// Seed 000's slide with a compliant hand; times shifted so that 0 is the
/// first slip onset.
fn spidar_slide(friction: &mut Stepper, s: &SpidarSlide, dt: f64, max_steps: u64) -> Vec<Sample> {
    let mut out = Vec::new();
    let (mut x, mut v) = (0.0_f64, 0.0_f64);
    let mut hand = Hand::default();
    let mut onset: Option<f64> = None;
    let mut end_t = s.stick_s + s.max_wait_s;
    let mut i = 0_u64;
    loop {
        let t = i as f64 * dt;
        if t > end_t + 0.5 * dt || i > max_steps {
            break;
        }
        let input = Input { x_m: x, v_m_s: v };
        let o = friction.step(dt, input);
        out.push(Sample::new(t, input, o));
        if o.slip_onset && onset.is_none() {
            onset = Some(t);
            end_t = t + s.after_onset_s;
        }
        let (xr, vr) = if t < s.stick_s {
            (0.0, 0.0)
        } else {
            (s.slide_speed_m_s * (t - s.stick_s), s.slide_speed_m_s)
        };
        let drive = HandDrive {
            x_m: xr,
            v_m_s: vr,
            stiffness_n_m: s.hand_stiffness_n_m,
            damping_n_s_m: s.hand_damping_n_s_m,
            ..HandDrive::default()
        };
        let a = (hand.force(&drive, x, v, dt) + o.force_n) / s.hand_mass_kg;
        v += a * dt;
        x += v * dt;
        i += 1;
    }
    let origin = onset.unwrap_or(s.stick_s);
    for sample in &mut out {
        sample.t_s -= origin;
    }
    out
}
