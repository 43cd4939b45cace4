//! The host side of the wire protocol: a sans-IO link state machine.
//!
//! The shell feeds it the bytes a read returned ([`Link::receive`]) and asks
//! it what to send each loop tick ([`Link::transmit`]). While not connected
//! the link sends `Hello` every 50 ms; once `Capabilities` arrive it sends a
//! `Command` with a new sequence number every tick. If no valid frame
//! arrives for [`LOST_AFTER_S`], the link is lost, and it goes back to
//! sending `Hello` until the device answers again. Time is an argument, so
//! a test can drive it without a clock.

use super::wire::{DecodeStats, Decoder, Message, PROTOCOL_VERSION};

/// No valid frame for this long: the device is lost, s.
pub const LOST_AFTER_S: f64 = 0.100;

/// Interval between `Hello`s while connecting, s.
pub const HELLO_EVERY_S: f64 = 0.050;

/// What the device stated in its handshake.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Capabilities {
    /// Protocol version.
    pub version: u16,
    /// Degrees of freedom.
    pub dof: u8,
    /// Maximum continuous force, N.
    pub max_force_n: f64,
    /// Encoder counts per metre.
    pub counts_per_m: f64,
    /// Force loop rate, Hz.
    pub force_rate_hz: u16,
    /// Vibration output rate, Hz (0: none).
    pub vibration_rate_hz: u16,
}

/// One device sample, in SI units.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sample {
    /// Position, m.
    pub x_m: f64,
    /// Button pressed.
    pub button: bool,
    /// Status flags (`wire::status`).
    pub status: u8,
    /// Device clock, microseconds.
    pub device_time_us: u32,
    /// Last command the device applied.
    pub ack_seq: u32,
}

/// The link's state.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LinkState {
    /// Sending `Hello`, no answer yet.
    Connecting,
    /// Handshake done, frames arriving.
    Connected,
    /// Was connected; no valid frame for [`LOST_AFTER_S`].
    Lost,
}

/// The host's link to a device.
#[derive(Debug, Clone, Default)]
pub struct Link {
    decoder: Decoder,
    capabilities: Option<Capabilities>,
    last_valid_s: Option<f64>,
    last_hello_s: Option<f64>,
    seq: u32,
    was_connected: bool,
}

impl Link {
    /// A link that has not spoken yet.
    #[must_use]
    pub fn new() -> Self {
        Self::default()
    }

    /// The device's capabilities, once the handshake is done.
    #[must_use]
    pub fn capabilities(&self) -> Option<Capabilities> {
        self.capabilities
    }

    /// Decoder counters (frames, CRC errors, resynchronisations).
    #[must_use]
    pub fn stats(&self) -> DecodeStats {
        self.decoder.stats()
    }

    /// The state at `now_s`.
    #[must_use]
    pub fn state(&self, now_s: f64) -> LinkState {
        match (self.capabilities, self.last_valid_s) {
            (Some(_), Some(t)) if now_s - t <= LOST_AFTER_S => LinkState::Connected,
            _ if self.was_connected => LinkState::Lost,
            _ => LinkState::Connecting,
        }
    }

    /// Feeds the bytes a read returned at `now_s`; calls `on_sample` for
    /// each sample.
    pub fn receive(&mut self, now_s: f64, bytes: &[u8], mut on_sample: impl FnMut(Sample)) {
        let mut caps = None;
        let mut valid = false;
        let counts_per_m = self.capabilities.map_or(1.0, |c| c.counts_per_m);
        let connected = self.capabilities.is_some();
        self.decoder.feed(bytes, |m| match m {
            Message::Capabilities {
                version,
                dof,
                max_force_n,
                counts_per_m,
                force_rate_hz,
                vibration_rate_hz,
            } => {
                valid = true;
                caps = Some(Capabilities {
                    version,
                    dof,
                    max_force_n: f64::from(max_force_n),
                    counts_per_m: f64::from(counts_per_m),
                    force_rate_hz,
                    vibration_rate_hz,
                });
            }
            Message::Sample {
                ack_seq,
                time_us,
                position_counts,
                button,
                status,
            } if connected => {
                valid = true;
                on_sample(Sample {
                    x_m: f64::from(position_counts) / counts_per_m,
                    button,
                    status,
                    device_time_us: time_us,
                    ack_seq,
                });
            }
            _ => {}
        });
        if let Some(c) = caps.filter(|c| c.version == PROTOCOL_VERSION && c.counts_per_m > 0.0) {
            self.capabilities = Some(c);
            self.was_connected = true;
        }
        if valid && self.capabilities.is_some() {
            self.last_valid_s = Some(now_s);
        }
    }

    /// What to send at `now_s` to render `force_n` and `vibration`: a
    /// `Command` while connected, a periodic `Hello` otherwise.
    pub fn transmit(&mut self, now_s: f64, force_n: f64, vibration: f64) -> Option<Message> {
        if self.state(now_s) == LinkState::Connected {
            self.seq = self.seq.wrapping_add(1);
            #[expect(
                clippy::cast_possible_truncation,
                reason = "forces and drives are small; f32 is the wire's type"
            )]
            return Some(Message::Command {
                seq: self.seq,
                force_n: force_n as f32,
                vibration: vibration as f32,
            });
        }
        if self.last_hello_s.is_none_or(|t| now_s - t >= HELLO_EVERY_S) {
            self.last_hello_s = Some(now_s);
            self.capabilities = None;
            return Some(Message::Hello {
                version: PROTOCOL_VERSION,
            });
        }
        None
    }
}
