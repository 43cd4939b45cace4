//! The device emulator: firmware for the simulated apparatus, speaking the
//! wire protocol (`docs/wire-protocol.md`).
//!
//! [`EmulatorCore`] is sans-IO: messages in, samples out, time as an
//! argument. It answers `Hello` with its capabilities and applies each
//! `Command`'s force, clamped to the device maximum. A watchdog zeroes the
//! force when no valid command has arrived for 20 ms. Each tick it steps the
//! simulated apparatus, with the hand `HandDrive` describes, and reports a
//! `Sample`. [`serve`] is the shell: it runs the core on a serial port or
//! pseudo-terminal at the force loop rate.

use std::io::{Read, Write};
use std::time::{Duration, Instant};

use super::sim::{Apparatus, SimDevice};
use super::wire::{Decoder, MAX_FRAME, Message, PROTOCOL_VERSION, encode, status};

/// Force loop rate of the emulated firmware, Hz (seed 002's 1 kHz servo).
pub const FORCE_RATE_HZ: u16 = 1000;

/// Watchdog: no valid command for this long zeroes the force, s.
pub const WATCHDOG_S: f64 = 0.020;

/// Hand mass on the emulated device, kg (as the simulated participant's).
const HAND_MASS_KG: f64 = 0.4;

/// The emulated firmware.
#[derive(Debug, Clone)]
pub struct EmulatorCore {
    p: Apparatus,
    device: SimDevice,
    now_s: f64,
    force_n: f64,
    clamped: bool,
    ack_seq: u32,
    last_command_s: Option<f64>,
    hand: (f64, f64, f64, f64, f64),
    integral: f64,
    click: bool,
    x_m: f64,
    v_m_s: f64,
}

impl Default for EmulatorCore {
    fn default() -> Self {
        Self::new()
    }
}

impl EmulatorCore {
    /// Firmware for seed 002's apparatus, at rest at the centre.
    #[must_use]
    pub fn new() -> Self {
        let p = Apparatus::default();
        EmulatorCore {
            p,
            device: SimDevice::new(p, HAND_MASS_KG, crate::friction::StepParams::default()),
            now_s: 0.0,
            force_n: 0.0,
            clamped: false,
            ack_seq: 0,
            last_command_s: None,
            hand: (0.0, 0.0, 0.0, 0.0, 0.0),
            integral: 0.0,
            click: false,
            x_m: 0.0,
            v_m_s: 0.0,
        }
    }

    /// The capabilities this firmware states.
    #[must_use]
    #[expect(
        clippy::cast_possible_truncation,
        reason = "f32 is the wire's type; these values need no more"
    )]
    pub fn capabilities(&self) -> Message {
        Message::Capabilities {
            version: PROTOCOL_VERSION,
            dof: 1,
            max_force_n: self.p.max_force_n as f32,
            counts_per_m: (1.0 / self.p.encoder_m) as f32,
            force_rate_hz: FORCE_RATE_HZ,
            vibration_rate_hz: 0,
        }
    }

    /// Handles one message from the host; returns the reply, if any.
    pub fn receive(&mut self, message: Message) -> Option<Message> {
        match message {
            Message::Hello { .. } => {
                self.force_n = 0.0;
                self.last_command_s = None;
                Some(self.capabilities())
            }
            Message::Command { seq, force_n, .. } => {
                let f = if force_n.is_finite() {
                    f64::from(force_n)
                } else {
                    0.0
                };
                let max = self.p.max_force_n;
                self.clamped = f.abs() > max;
                self.force_n = f.clamp(-max, max);
                self.ack_seq = seq;
                self.last_command_s = Some(self.now_s);
                None
            }
            Message::HandDrive {
                x_m,
                v_m_s,
                stiffness_n_m,
                damping_n_s_m,
                integral,
                click,
            } => {
                let finite = |x: f32| if x.is_finite() { f64::from(x) } else { 0.0 };
                let new_target = (finite(x_m) - self.hand.0).abs() > 1e-3;
                self.hand = (
                    finite(x_m),
                    finite(v_m_s),
                    finite(stiffness_n_m),
                    finite(damping_n_s_m),
                    finite(integral),
                );
                if new_target {
                    self.integral = 0.0;
                }
                self.click |= click;
                None
            }
            Message::Heartbeat { .. } | Message::Capabilities { .. } | Message::Sample { .. } => {
                None
            }
        }
    }

    /// Advances the firmware by `dt`; returns this tick's sample.
    pub fn tick(&mut self, dt: f64) -> Message {
        self.now_s += dt;
        let watchdog = self
            .last_command_s
            .is_none_or(|t| self.now_s - t > WATCHDOG_S);
        let force = if watchdog { 0.0 } else { self.force_n };
        let (x, v, k, b, ki) = self.hand;
        let e = x - self.x_m;
        self.integral = if ki > 0.0 {
            (self.integral + ki * e * dt).clamp(-12.0, 12.0)
        } else {
            0.0
        };
        let hand = k * e + b * (v - self.v_m_s) + self.integral;
        let sample = self.device.step_commanded(dt, hand, force);
        self.x_m = sample.x_m;
        self.v_m_s = sample.v_m_s;
        let mut flags = 0;
        if watchdog && self.last_command_s.is_some() {
            flags |= status::WATCHDOG;
        }
        if self.clamped {
            flags |= status::CLAMPED;
        }
        if self.device.at_end_stop() {
            flags |= status::END_STOP;
        }
        let button = std::mem::take(&mut self.click);
        #[expect(
            clippy::cast_possible_truncation,
            reason = "counts fit i32 over the 3.2 cm range; time wraps by design"
        )]
        #[expect(clippy::cast_sign_loss, reason = "time is non-negative")]
        Message::Sample {
            ack_seq: self.ack_seq,
            time_us: ((self.now_s * 1e6) as u64 & 0xffff_ffff) as u32,
            position_counts: (sample.x_m / self.p.encoder_m).round() as i32,
            button,
            status: flags,
        }
    }

    /// The force being rendered now (after the watchdog), N.
    #[must_use]
    pub fn rendered_force_n(&self) -> f64 {
        if self
            .last_command_s
            .is_none_or(|t| self.now_s - t > WATCHDOG_S)
        {
            0.0
        } else {
            self.force_n
        }
    }
}

/// Runs the emulator on an open port until the port fails (or forever).
///
/// # Errors
/// An I/O error on the port.
pub fn serve(
    port: &mut (impl Read + Write),
    mut on_tick: impl FnMut(&EmulatorCore),
) -> std::io::Result<()> {
    let mut core = EmulatorCore::new();
    let mut decoder = Decoder::new();
    let period = Duration::from_secs_f64(1.0 / f64::from(FORCE_RATE_HZ));
    let dt = period.as_secs_f64();
    let mut next = Instant::now() + period;
    let mut input = [0_u8; 512];
    let mut out = [0_u8; MAX_FRAME];
    loop {
        let n = match port.read(&mut input) {
            Ok(n) => n,
            Err(e)
                if matches!(
                    e.kind(),
                    std::io::ErrorKind::TimedOut | std::io::ErrorKind::WouldBlock
                ) =>
            {
                0
            }
            Err(e) => return Err(e),
        };
        let mut replies = Vec::new();
        decoder.feed(&input[..n], |m| replies.extend(core.receive(m)));
        replies.push(core.tick(dt));
        for m in &replies {
            if let Ok(len) = encode(m, &mut out) {
                port.write_all(&out[..len])?;
            }
        }
        on_tick(&core);
        let now = Instant::now();
        if next > now {
            std::thread::sleep(next - now);
        }
        next += period;
        if Instant::now() > next + period * 50 {
            next = Instant::now() + period; // Fell far behind: do not burst.
        }
    }
}
