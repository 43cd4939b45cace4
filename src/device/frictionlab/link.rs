//! The host side of the wire protocol: a sans-IO link state machine.
//!
//! The shell feeds it the bytes a read returned ([`Link::receive`]) and asks
//! it what to send each loop tick ([`Link::transmit`]). While not connected
//! the link sends `Hello` every 50 ms; once `Capabilities` arrive it sends a
//! `Command` with a new sequence number every tick. If no valid frame
//! arrives for [`LOST_AFTER_S`], the link is lost, and it goes back to
//! sending `Hello` until the device answers again. Time is an argument, so
//! a test can drive it without a clock.
//!
//! The host speaks version 2 and connects to version 1 devices too: a
//! device's `Capabilities` of either version is accepted. A version 2
//! device that renders on board follows them with `OnBoard`
//! ([`Link::on_board`]); its `Telemetry` arrives as
//! [`Incoming::Telemetry`], and [`Link::heartbeat`] keeps its watchdog fed
//! while it renders by itself.

use super::wire::{DecodeStats, Decoder, Message, PROTOCOL_VERSION};

/// No valid frame for this long: the device is lost, s.
pub const LOST_AFTER_S: f64 = 0.100;

/// How long after a version 2 device's `Capabilities` the link waits for
/// its `OnBoard` (sent right after) before it counts as connected without
/// it, s. Connected earlier, a session could start its first trial on the
/// host's loop when the `OnBoard` came a read later.
pub const ON_BOARD_WAIT_S: f64 = 0.100;

/// Interval between `Hello`s while connecting, s.
pub const HELLO_EVERY_S: f64 = 0.050;

/// Interval between `Heartbeat`s to a device rendering on board, s (its
/// watchdog trips after 20 ms of silence).
pub const HEARTBEAT_EVERY_S: f64 = 0.005;

/// What a version 2 device renders on board (its `OnBoard` message).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct OnBoard {
    /// Bit `k - 1`: renders model kind `k`.
    pub models: u16,
    /// On-board loop rate, Hz.
    pub loop_rate_hz: u16,
    /// Bytes of its float (4: f32, 8: f64).
    pub float_bytes: u8,
}

/// One on-board loop tick, in SI units.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Telemetry {
    /// Loop tick number (wraps).
    pub tick: u32,
    /// Position the model saw, m.
    pub x_m: f64,
    /// Velocity the model saw, m/s.
    pub v_m_s: f64,
    /// Force rendered, N.
    pub force_n: f64,
    /// Vibrotactile drive.
    pub vibration: f64,
    /// Label of the render in effect.
    pub render: u8,
    /// Status flags (`wire::status`).
    pub flags: u8,
}

/// The device's loop statistics (its last `LoopReport`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct DeviceLoop {
    /// Ticks run.
    pub ticks: u32,
    /// Longest loop body, microseconds.
    pub longest_loop_us: u32,
    /// Ticks that missed their deadline.
    pub missed_ticks: u32,
}

/// What the device sent, for the loop.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Incoming {
    /// A force loop tick (version 1, or a version 2 device in host mode).
    Sample(Sample),
    /// An on-board loop tick.
    Telemetry(Telemetry),
}

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

pub use crate::device::backend::LinkState;

/// The host's link to a device.
#[derive(Debug, Clone, Default)]
pub struct Link {
    decoder: Decoder,
    capabilities: Option<Capabilities>,
    last_valid_s: Option<f64>,
    last_hello_s: Option<f64>,
    last_sent_s: Option<f64>,
    seq: u32,
    was_connected: bool,
    /// When the last `Capabilities` arrived.
    handshake_s: Option<f64>,
    on_board: Option<OnBoard>,
    device_loop: DeviceLoop,
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

    /// What the device renders on board (a version 2 device that said so
    /// in this handshake).
    #[must_use]
    pub fn on_board(&self) -> Option<OnBoard> {
        self.on_board.filter(|_| self.capabilities.is_some())
    }

    /// The device's loop statistics, as last reported.
    #[must_use]
    pub fn device_loop(&self) -> DeviceLoop {
        self.device_loop
    }

    /// Decoder counters (frames, CRC errors, resynchronisations).
    #[must_use]
    pub fn stats(&self) -> DecodeStats {
        self.decoder.stats()
    }

    /// The state at `now_s`.
    #[must_use]
    pub fn state(&self, now_s: f64) -> LinkState {
        let awaiting_on_board = self.capabilities.is_some_and(|c| c.version >= 2)
            && self.on_board.is_none()
            && self
                .handshake_s
                .is_some_and(|h| now_s - h < ON_BOARD_WAIT_S);
        match (self.capabilities, self.last_valid_s) {
            _ if awaiting_on_board => LinkState::Connecting,
            (Some(_), Some(t)) if now_s - t <= LOST_AFTER_S => LinkState::Connected,
            _ if self.was_connected => LinkState::Lost,
            _ => LinkState::Connecting,
        }
    }

    /// Feeds the bytes a read returned at `now_s`; calls `on_tick` for each
    /// sample or telemetry.
    #[expect(
        clippy::too_many_lines,
        reason = "one match over the device's messages"
    )]
    pub fn receive(&mut self, now_s: f64, bytes: &[u8], mut on_tick: impl FnMut(Incoming)) {
        let mut caps = None;
        let mut on_board = None;
        let mut valid = false;
        let counts_per_m = self.capabilities.map_or(1.0, |c| c.counts_per_m);
        let connected = self.capabilities.is_some();
        let mut device_loop = None;
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
            Message::OnBoard {
                models,
                loop_rate_hz,
                float_bytes,
            } => {
                valid = true;
                on_board = Some(OnBoard {
                    models,
                    loop_rate_hz,
                    float_bytes,
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
                on_tick(Incoming::Sample(Sample {
                    x_m: f64::from(position_counts) / counts_per_m,
                    button,
                    status,
                    device_time_us: time_us,
                    ack_seq,
                }));
            }
            Message::Telemetry {
                tick,
                x_m,
                v_m_s,
                force_n,
                vibration,
                render,
                flags,
            } if connected => {
                valid = true;
                on_tick(Incoming::Telemetry(Telemetry {
                    tick,
                    x_m: f64::from(x_m),
                    v_m_s: f64::from(v_m_s),
                    force_n: f64::from(force_n),
                    vibration: f64::from(vibration),
                    render,
                    flags,
                }));
            }
            Message::LoopReport {
                ticks,
                longest_loop_us,
                missed_ticks,
            } => {
                valid = true;
                device_loop = Some(DeviceLoop {
                    ticks,
                    longest_loop_us,
                    missed_ticks,
                });
            }
            _ => {}
        });
        // The same `Capabilities` while connected answer a `Hello` sent
        // before this connection: over a link that lags, the host connects
        // on the answer to its first `Hello` while the later ones are on
        // their way. Each started the device afresh before anything the host
        // has sent since reached it (a serial link keeps its order), so the
        // connection stands. Taken as a new handshake, it was a lost device
        // until its `OnBoard` came (a read later, under load), and the
        // `Hello` sent meanwhile restarted the device mid-trial 200 ms
        // later: one more loss, and so on (issue 63).
        let late = self.capabilities.is_some()
            && caps == self.capabilities
            && self.state(now_s) == LinkState::Connected;
        if let Some(c) = caps.filter(|c| {
            !late && (1..=PROTOCOL_VERSION).contains(&c.version) && c.counts_per_m > 0.0
        }) {
            self.capabilities = Some(c);
            self.on_board = None;
            self.was_connected = true;
            self.handshake_s = Some(now_s);
        }
        if let Some(o) = on_board.filter(|_| self.capabilities.is_some_and(|c| c.version >= 2)) {
            self.on_board = Some(o);
        }
        if let Some(d) = device_loop {
            self.device_loop = d;
        }
        if valid && self.capabilities.is_some() {
            self.last_valid_s = Some(now_s);
        }
    }

    /// What to send at `now_s` to a device rendering on board: a
    /// `Heartbeat` every [`HEARTBEAT_EVERY_S`] while connected (`extra`: a
    /// message is going anyway, so none is needed), a periodic `Hello`
    /// otherwise.
    pub fn heartbeat(&mut self, now_s: f64, extra: bool) -> Option<Message> {
        if self.state(now_s) == LinkState::Connected {
            if extra {
                self.last_sent_s = Some(now_s);
                return None;
            }
            if self
                .last_sent_s
                .is_some_and(|t| now_s - t < HEARTBEAT_EVERY_S)
            {
                return None;
            }
            self.last_sent_s = Some(now_s);
            self.seq = self.seq.wrapping_add(1);
            return Some(Message::Heartbeat { seq: self.seq });
        }
        self.hello(now_s)
    }

    /// What to send at `now_s` to render `force_n` and `vibration`: a
    /// `Command` while connected, a periodic `Hello` otherwise.
    pub fn transmit(&mut self, now_s: f64, force_n: f64, vibration: f64) -> Option<Message> {
        if self.state(now_s) == LinkState::Connected {
            self.seq = self.seq.wrapping_add(1);
            self.last_sent_s = Some(now_s);
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
        self.hello(now_s)
    }

    /// A `Hello` if one is due (every [`HELLO_EVERY_S`] while not
    /// connected).
    fn hello(&mut self, now_s: f64) -> Option<Message> {
        if self.last_hello_s.is_none_or(|t| now_s - t >= HELLO_EVERY_S) {
            self.last_hello_s = Some(now_s);
            self.capabilities = None;
            self.on_board = None;
            return Some(Message::Hello {
                version: PROTOCOL_VERSION,
            });
        }
        None
    }
}
