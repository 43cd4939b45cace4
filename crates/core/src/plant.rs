//! The simulated apparatus: seed 002's 1-DOF device (Table 2), with the
//! participant's hand on it and the rendered friction acting on both.
//!
//! # Model (SI units; positive x = device positive direction)
//! - Moving mass: the apparatus's 0.692 kg plus the hand's mass.
//! - Forces: the hand's force (from the participant's motor model), the
//!   motor's (the rendered friction, computed by the caller: the host's
//!   loop, the emulator's or the firmware's, within 9.48 N, the maximum
//!   continuous force), the physical friction of a condition (e.g. an
//!   aluminum block on rubber, not rendered: part of the apparatus),
//!   end stops at +-1.6 cm (range 3.2 cm; a 2e4 N/m, 50 N s/m wall), and the
//!   apparatus's own static friction of 0.75 N (Coulomb with stiction, the
//!   same level sliding, as the seed gives only one value).
//! - Integration: semi-implicit Euler at the model's loop rate.
//! - Sensing: position quantized to the encoder resolution (Table 2's
//!   position resolution, read as 2.57e-6 m; its exponent is garbled in the
//!   seed's text: a 2048-line quadrature encoder, 8192 counts per turn, on a
//!   3.35 mm capstan), velocity from the quantized position by differencing
//!   and a first-order low-pass at 100 Hz. The friction models see what a
//!   real host would: the measured position and the estimated velocity.
//!
//! No clock, no I/O: time is the `dt` argument. The host's simulated
//! device, the device emulator and the QEMU firmware all move this plant.

use crate::friction::{ForceLimit, Friction, Input, ModelParams, StepParams};
use crate::hand::{Hand, HandDrive};
use crate::wire::Message;

/// What a device reports each loop tick.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct DeviceSample {
    /// Measured position (encoder resolution), m.
    pub x_m: f64,
    /// Estimated velocity, m/s.
    pub v_m_s: f64,
    /// Rendered force on the hand this tick, N.
    pub force_n: f64,
    /// Vibrotactile drive this tick, `[-1, 1]`.
    pub vibration: f64,
}

/// Parameters of the simulated apparatus (seed 002, Table 2).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Apparatus {
    /// Moving mass of motor and slide, kg. 0.692.
    pub mass_kg: f64,
    /// Static (and sliding) friction of motor and slide, N. 0.75.
    pub static_friction_n: f64,
    /// Maximum continuous force, N. 9.48.
    pub max_force_n: f64,
    /// Range of motion, m. 0.032.
    pub range_m: f64,
    /// Encoder resolution, m. 2.57e-6.
    pub encoder_m: f64,
    /// End-stop stiffness, N/m. 2e4.
    pub stop_stiffness_n_m: f64,
    /// End-stop damping, N s/m. 50.
    pub stop_damping_n_s_m: f64,
}

impl Default for Apparatus {
    fn default() -> Self {
        Apparatus {
            mass_kg: 0.692,
            static_friction_n: 0.75,
            max_force_n: 9.48,
            range_m: 0.032,
            encoder_m: 2.57e-6,
            stop_stiffness_n_m: 2e4,
            stop_damping_n_s_m: 50.0,
        }
    }
}

impl Apparatus {
    /// How far the slide moves between its end stops, m from the middle
    /// (lowest, highest): `range_m` centred on 0.
    #[must_use]
    pub fn travel_m(&self) -> [f64; 2] {
        [-self.range_m / 2.0, self.range_m / 2.0]
    }

    /// What a device on this apparatus states in its `Capabilities`.
    #[must_use]
    #[expect(
        clippy::cast_possible_truncation,
        reason = "f32 is the wire's type; these values need no more"
    )]
    pub fn stated(&self) -> crate::onboard::Apparatus {
        crate::onboard::Apparatus {
            max_force_n: self.max_force_n as f32,
            counts_per_m: (1.0 / self.encoder_m) as f32,
        }
    }
}

/// The simulated device with a hand on it.
#[derive(Debug, Clone)]
pub struct SimDevice {
    p: Apparatus,
    step: StepParams,
    x: f64,
    v: f64,
    stuck: bool,
    x_measured: f64,
    v_estimate: f64,
    physical: Option<Friction>,
    physical_params: Option<ModelParams>,
    /// `dt` for which the filter was computed, the velocity filter's
    /// coefficient `exp(-2 pi f_c dt)`, and `1 / dt`.
    filter: (f64, f64, f64),
    /// `1 / mass` (apparatus and hand) and `1 / encoder resolution`: a step multiplies (a
    /// division held up a fifth of a simulated session's device step).
    inv_mass: f64,
    inv_encoder: f64,
}

impl SimDevice {
    /// The apparatus at rest at 0 with a hand of `hand_mass_kg` on it,
    /// estimating velocity with `step`'s filter (its sensing for a device
    /// that renders itself: [`SimDevice::step_with`]). The rate is each
    /// step's `dt`. It renders no model: the motor's force is the caller's.
    #[must_use]
    pub fn new(p: Apparatus, hand_mass_kg: f64, step: StepParams) -> Self {
        let mass_kg = p.mass_kg + hand_mass_kg.max(0.0);
        SimDevice {
            p,
            step,
            x: 0.0,
            v: 0.0,
            stuck: true,
            x_measured: 0.0,
            v_estimate: 0.0,
            physical: None,
            physical_params: None,
            filter: (0.0, 0.0, 0.0),
            inv_mass: 1.0 / mass_kg,
            inv_encoder: 1.0 / p.encoder_m,
        }
    }

    /// Puts the device at rest at `x_m` (the hand repositions between
    /// trials); its physical friction restarts there.
    pub fn reset(&mut self, x_m: f64) {
        self.x = x_m;
        self.v = 0.0;
        self.stuck = true;
        self.x_measured = self.quantize(x_m);
        self.v_estimate = 0.0;
        let physical = self.physical_params.take();
        self.set_physical(physical.as_ref());
    }

    /// The physical friction of a condition from now on (`None`: none).
    pub fn set_physical(&mut self, model: Option<&ModelParams>) {
        self.physical_params = model.cloned();
        self.physical = model
            .and_then(|m| Friction::new(m, ForceLimit::new(1e3).unwrap_or_default(), self.x).ok());
    }

    /// The apparatus.
    #[must_use]
    pub fn apparatus(&self) -> &Apparatus {
        &self.p
    }

    /// True position, m (for tests; a real device only gives the measured one).
    #[must_use]
    pub fn true_position_m(&self) -> f64 {
        self.x
    }

    fn quantize(&self, x: f64) -> f64 {
        round(x * self.inv_encoder) * self.p.encoder_m
    }

    /// The position the encoder reads now, m.
    #[inline]
    #[must_use]
    pub fn measured_m(&self) -> f64 {
        self.quantize(self.x)
    }

    /// Advances by `dt` with the hand pushing with `hand_force_n` and the
    /// motor applying the force `firmware` computes from what the device
    /// sensed this tick, as a device rendering on board does.
    pub fn step_with(
        &mut self,
        dt: f64,
        hand_force_n: f64,
        firmware: impl FnOnce(Input) -> f64,
    ) -> DeviceSample {
        let sensed = self.sense(dt);
        let force_n = firmware(sensed);
        let force = if force_n.is_finite() { force_n } else { 0.0 };
        self.advance(dt, hand_force_n, force);
        DeviceSample {
            x_m: sensed.x_m,
            v_m_s: sensed.v_m_s,
            force_n: force,
            vibration: 0.0,
        }
    }

    /// Whether the device is at an end of its range.
    #[must_use]
    pub fn at_end_stop(&self) -> bool {
        self.x.abs() >= self.p.range_m / 2.0
    }

    /// Measured position and estimated velocity.
    #[inline]
    fn sense(&mut self, dt: f64) -> Input {
        let measured = self.quantize(self.x);
        if self.filter.0 != dt {
            self.filter = (dt, self.step.velocity_alpha(dt), 1.0 / dt);
        }
        let raw_v = (measured - self.x_measured) * self.filter.2;
        let alpha = self.filter.1;
        self.v_estimate = crate::friction::filtered_velocity(alpha, self.v_estimate, raw_v);
        self.x_measured = measured;
        Input {
            x_m: measured,
            v_m_s: self.v_estimate,
        }
    }

    /// Moves the device by `dt` under the hand's force, the motor's, the
    /// physical friction, the end stops and the apparatus's own friction
    /// (a device whose host senses it: [`SimDevice::measured_m`]).
    #[inline]
    pub fn advance(&mut self, dt: f64, hand_force_n: f64, motor_n: f64) {
        let physical = self.physical.as_mut().map_or(0.0, |f| {
            f.step(
                dt,
                Input {
                    x_m: self.x,
                    v_m_s: self.v,
                },
            )
            .force_n
        });
        let half = self.p.range_m / 2.0;
        let stop = if self.x.abs() > half {
            -self.p.stop_stiffness_n_m * (self.x - half * self.x.signum())
                - self.p.stop_damping_n_s_m * self.v
        } else {
            0.0
        };
        let hand = if hand_force_n.is_finite() {
            hand_force_n
        } else {
            0.0
        };
        let net = hand + motor_n + physical + stop;
        let fs = self.p.static_friction_n;
        if self.stuck && net.abs() > fs {
            self.stuck = false;
        }
        if !self.stuck {
            let dir = if self.v == 0.0 {
                net.signum()
            } else {
                self.v.signum()
            };
            let v_new = self.v + (net - dir * fs) * self.inv_mass * dt;
            if v_new * dir <= 0.0 && net.abs() <= fs {
                self.stuck = true;
                self.v = 0.0;
            } else {
                self.v = v_new;
            }
        }
        self.x += self.v * dt;
    }
}

/// The apparatus with a hand on it, as a device sees it: the plant in place
/// of motor and encoder for the device emulator and the QEMU firmware. The
/// hand follows the host's `HandDrive` messages ([`Rig::drive`]).
#[derive(Debug, Clone)]
pub struct Rig {
    device: SimDevice,
    drive: HandDrive,
    hand: Hand,
    click: bool,
    x_m: f64,
    v_m_s: f64,
}

/// What a rig's device sensed on a tick, for its firmware.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sensed {
    /// Measured position and estimated velocity.
    pub input: Input,
    /// The button was pressed since the last tick.
    pub button: bool,
    /// The device was at an end of its range when the tick began.
    pub end_stop: bool,
}

impl Sensed {
    /// The sensed position and velocity in `f32`, the float a device
    /// renders in.
    #[must_use]
    #[expect(
        clippy::cast_possible_truncation,
        reason = "the device computes in f32"
    )]
    pub fn input_f32(&self) -> Input<f32> {
        Input {
            x_m: self.input.x_m as f32,
            v_m_s: self.input.v_m_s as f32,
        }
    }
}

impl Rig {
    /// Seed 002's apparatus at rest at the centre with a hand of
    /// `hand_mass_kg` on it, relaxed.
    #[must_use]
    pub fn new(p: Apparatus, hand_mass_kg: f64) -> Self {
        Rig {
            device: SimDevice::new(p, hand_mass_kg, StepParams::default()),
            drive: HandDrive::default(),
            hand: Hand::default(),
            click: false,
            x_m: 0.0,
            v_m_s: 0.0,
        }
    }

    /// Follows a `HandDrive` message (any other is ignored): what the hand
    /// does from now on. Non-finite values read as 0. A relaxed drive (no
    /// integral gain) ends the movement segment: the host sends one at
    /// each new segment.
    pub fn follow(&mut self, message: &Message) {
        let Message::HandDrive {
            x_m,
            v_m_s,
            stiffness_n_m,
            damping_n_s_m,
            integral,
            click,
        } = *message
        else {
            return;
        };
        let finite = |x: f32| if x.is_finite() { f64::from(x) } else { 0.0 };
        let integral_gain = finite(integral);
        let segment = if integral_gain > 0.0 {
            self.drive.segment
        } else {
            self.drive.segment.wrapping_add(1)
        };
        self.drive = HandDrive {
            x_m: finite(x_m),
            v_m_s: finite(v_m_s),
            stiffness_n_m: finite(stiffness_n_m),
            damping_n_s_m: finite(damping_n_s_m),
            integral_gain,
            segment,
        };
        self.click |= click;
    }

    /// The measured position after the last step, m.
    #[must_use]
    pub fn x_m(&self) -> f64 {
        self.x_m
    }

    /// Puts the apparatus at rest at `x_m`.
    pub fn place(&mut self, x_m: f64) {
        self.device.reset(x_m);
        self.x_m = x_m;
        self.v_m_s = 0.0;
    }

    /// From now on the hand follows `drive` (its own segment number: a new
    /// one restarts the hand's integral). Non-finite values read as 0.
    pub fn drive(&mut self, drive: HandDrive) {
        let finite = |x: f64| if x.is_finite() { x } else { 0.0 };
        self.drive = HandDrive {
            x_m: finite(drive.x_m),
            v_m_s: finite(drive.v_m_s),
            stiffness_n_m: finite(drive.stiffness_n_m),
            damping_n_s_m: finite(drive.damping_n_s_m),
            integral_gain: finite(drive.integral_gain),
            segment: drive.segment,
        };
    }

    /// Advances by `dt`: the hand pushes, and the motor applies the force
    /// `firmware` computes from what the device sensed (already limited).
    pub fn step(&mut self, dt: f64, firmware: impl FnOnce(Sensed) -> f64) -> DeviceSample {
        let hand = self.hand.force(&self.drive, self.x_m, self.v_m_s, dt);
        let button = core::mem::take(&mut self.click);
        let end_stop = self.device.at_end_stop();
        let sample = self.device.step_with(dt, hand, |input| {
            firmware(Sensed {
                input,
                button,
                end_stop,
            })
        });
        self.x_m = sample.x_m;
        self.v_m_s = sample.v_m_s;
        sample
    }

    /// Whether the device is at an end of its range.
    #[must_use]
    pub fn at_end_stop(&self) -> bool {
        self.device.at_end_stop()
    }

    /// The hand's integral effort now, N (see [`crate::hand`]).
    #[must_use]
    pub fn hand_integral_n(&self) -> f64 {
        self.hand.integral_n()
    }
}
/// `x` rounded to the nearest integer, halves away from zero: `libm::round`
/// bit for bit (the sign of a zero kept), by the float-to-integer
/// conversion rather than its software path (which was 4% of a simulated
/// session's instructions, once a tick in the encoder).
#[inline]
fn round(x: f64) -> f64 {
    /// From 2^52 on every float is a whole number.
    const WHOLE: f64 = 4_503_599_627_370_496.0;
    if x.is_nan() || x.abs() >= WHOLE {
        // Whole already (infinities too), or NaN: as it is.
        return x;
    }
    #[expect(
        clippy::cast_possible_truncation,
        reason = "|x| < 2^52: the conversion truncates toward zero exactly"
    )]
    let whole = x as i64 as f64;
    // x - whole is the fraction, exactly.
    let rounded = if (x - whole).abs() >= 0.5 {
        whole + x.signum()
    } else {
        whole
    };
    rounded.copysign(x)
}

#[cfg(test)]
mod tests {
    use super::round;

    #[test]
    fn round_is_libm_round_bit_for_bit() {
        let special = [
            0.0,
            -0.0,
            0.3,
            -0.3,
            0.5,
            -0.5,
            1.5,
            -1.5,
            2.5,
            -2.5,
            0.499_999_999_999_999_94,
            -0.499_999_999_999_999_94,
            4_503_599_627_370_495.5,
            -4_503_599_627_370_495.5,
            4_503_599_627_370_496.0,
            9.007_199_254_740_993e15,
            1e300,
            f64::MIN_POSITIVE,
            -f64::MIN_POSITIVE,
            5e-324,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NAN,
        ];
        // And a spread of values over many magnitudes (an LCG: no RNG
        // dependency in the core).
        let mut state: u64 = 0x2545_f491_4f6c_dd1d;
        let spread = (0..200_000).map(|_| {
            state = state
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            let bits = (state >> 1) & 0x7fef_ffff_ffff_ffff;
            let x = f64::from_bits(bits % 0x4340_0000_0000_0000);
            if state & 1 == 0 { x } else { -x }
        });
        for x in special.into_iter().chain(spread) {
            let (ours, theirs) = (round(x), libm::round(x));
            assert!(
                ours.to_bits() == theirs.to_bits() || (ours.is_nan() && theirs.is_nan()),
                "round({x:e}) = {ours:e}, libm gives {theirs:e}"
            );
        }
    }
}
