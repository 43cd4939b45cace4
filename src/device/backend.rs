//! The device seam: what the haptic loop ([`super::haptic`]) drives. A
//! device backend opens its device, reads the hand's state, sends a force,
//! closes, and says what it can do ([`Capabilities`]). One that renders
//! models itself (frictionlab's own firmware, wire protocol v2) also offers
//! [`OnBoard`]. Each backend is one folder under `src/device/`, listed once
//! in [`super::KINDS`]; the loop, the session and the window name none.
//!
//! Positions and forces are in the device's own frame, SI units, one entry
//! per axis ([`Vector`]; axes a device does not have stay 0).

use crate::friction::{Float, ModelParams};
use crate::hand::HandDrive;

/// The most axes a device has.
pub const MAX_AXES: usize = 3;

/// A position (m), velocity (m/s) or force (N) per axis of a device.
pub type Vector = [f64; MAX_AXES];

/// The render label of a device that renders nothing it was told to (it
/// restarted): rendering nothing.
pub const UNKNOWN_RENDER: u32 = u32::MAX;

/// The link to a device.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LinkState {
    /// Opening, or waiting for the device's first answer.
    Connecting,
    /// The device answers.
    Connected,
    /// Was connected; the device stopped answering.
    Lost,
}

/// What a device asks of the experimenter before it can go on: the loop
/// reports it in its ticks ([`Tick::request`]) for as long as it stands,
/// the session passes it on to its shell, and the experimenter's answer
/// comes back to the device as [`Backend::confirm`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Request {
    /// The device lost its setup and counts its position from where the
    /// handle is when it is set up again: the handle is to be put at the
    /// device's calibration pose, then confirmed. Until then the device
    /// renders nothing and its link is lost.
    CalibrationPose,
}

impl Request {
    /// What the experimenter is asked, one line.
    #[must_use]
    pub fn ask(self) -> &'static str {
        match self {
            Request::CalibrationPose => {
                "the board lost its setup and counts its position from where the handle is when it is set up again: put the handle at its calibration pose, then confirm"
            }
        }
    }
}

/// What a device can do.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Capabilities {
    /// Axes it senses and drives, 1 to [`MAX_AXES`].
    pub axes: usize,
    /// Its vertical axis (pointing up), on a device with one: a track on it
    /// lies on a horizontal surface whose press is this axis.
    pub vertical_axis: Option<usize>,
    /// The largest force it renders, N (the magnitude of the force vector).
    pub force_limit_n: f64,
    /// The stretch of its track the hand can reach, m from the track's
    /// origin along its direction (lowest, highest): every position a
    /// protocol asks for must lie within it (issue 63).
    pub travel_m: [f64; 2],
    /// The fastest loop rate it keeps up with, Hz.
    pub max_rate_hz: f64,
    /// Whether it can render models on board ([`Backend::on_board`]).
    pub on_board: bool,
}

/// What a device states of its force and reach, as a session's header
/// records it (issue 63).
#[derive(
    Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize, schemars::JsonSchema,
)]
pub struct DeviceLimits {
    /// Its own force limit, N ([`Capabilities::force_limit_n`]).
    pub force_limit_n: f64,
    /// The stretch of its track the hand can reach, m from the track's
    /// origin (lowest, highest; [`Capabilities::travel_m`]).
    pub travel_m: [f64; 2],
}

/// What the device reported at a tick.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Reading {
    /// The link.
    pub link: LinkState,
    /// The hand's position, m, device frame (the last one reported).
    pub position_m: Vector,
    /// The device's button.
    pub button: bool,
    /// The device reported its watchdog tripped (it renders nothing).
    pub watchdog: bool,
    /// What is wrong with what comes from the port (it answers, but not in
    /// this device's protocol): while no valid answer has come, or, where
    /// a device judges its answers as they come, at any time. No session
    /// starts on a device with a problem, and one that has started ends
    /// its run.
    pub problem: Option<&'static str>,
}

/// Link statistics of a backend, for the loop's [`super::haptic::LoopStats`].
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct LinkStats {
    /// Frames with a bad checksum.
    pub crc_errors: u64,
    /// Frames discarded and resynchronised.
    pub resyncs: u64,
    /// Ticks the device rendered on board, if it did.
    pub on_board_ticks: Option<u64>,
    /// Device ticks whose telemetry never arrived.
    pub telemetry_gaps: Option<u64>,
    /// The device's longest loop body, microseconds.
    pub device_longest_loop_us: Option<u32>,
    /// Device ticks that missed their deadline.
    pub device_missed_ticks: Option<u32>,
}

/// Who renders a tick's model.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Mode {
    /// The host's loop, commanding force over the link.
    Host {
        /// The force limit its models were rendered with, N: the smaller
        /// of the loop's (the model's clamp) and the device's.
        limit_n: f64,
    },
    /// The device itself, at `rate_hz` in `float`.
    OnBoard {
        /// On-board loop rate, Hz.
        rate_hz: u16,
        /// The float it computes in.
        float: Float,
        /// Its force limit, N.
        limit_n: f32,
    },
}

/// From the loop to the session: one tick.
#[expect(
    clippy::struct_excessive_bools,
    reason = "independent flags the device and the loop report"
)]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Tick {
    /// Time since the loop started, s.
    pub now_s: f64,
    /// Position along the track, m.
    pub x_m: f64,
    /// Velocity estimate along the track, m/s.
    pub v_m_s: f64,
    /// Force sent along the track, N.
    pub force_n: f64,
    /// Vibration drive sent.
    pub vibration: f64,
    /// The drive's quadrature ([`crate::friction::Output::vibration_q`]):
    /// with `vibration`, a carrier burst's complex envelope.
    pub vibration_q: f64,
    /// The render's carrier burst, if its drive is one: carrier Hz and
    /// envelope decay 1/s ([`crate::friction::ModelParams::burst`]).
    pub burst: Option<(f64, f64)>,
    /// The hand's position on every axis, m, device frame.
    pub position_m: Vector,
    /// The force sent on every axis, N, device frame (friction along the
    /// track and the walls that hold the hand on it).
    pub force_vector_n: Vector,
    /// What is wrong with the device's answers ([`Reading::problem`]).
    pub problem: Option<&'static str>,
    /// The normal force the model rendered with, N, where it is the hand's
    /// press into the track's surface (seed 000's `F_N = k y`; a device
    /// with a vertical axis).
    pub normal_n: Option<f64>,
    /// How far the hand is off the track, m (0 on a one-axis device).
    pub off_track_m: f64,
    /// Device button.
    pub button: bool,
    /// Link state.
    pub link: LinkState,
    /// The session's render in effect this tick.
    pub render: u32,
    /// Whether a render took effect at this tick (its model starting at
    /// rest at this tick's position).
    pub selected: bool,
    /// Whether the device reported its watchdog tripped (it rendered
    /// nothing): on board, at this tick; in the host loop, at the device's
    /// last sample.
    pub watchdog: bool,
    /// The device's loop tick number, for a tick its telemetry reported
    /// (on board): consecutive ticks of the device differ by one, whatever
    /// the link's timing.
    pub device_tick: Option<u32>,
    /// Who rendered this tick.
    pub mode: Mode,
    /// A model sent zero force this tick because it computed a force that
    /// was not a number or infinite.
    pub non_finite: bool,
    /// The device's own force limit as it states it now, N
    /// ([`Capabilities::force_limit_n`]; a device may state it only once
    /// connected).
    pub device_limit_n: f64,
    /// What the device asks of the experimenter, while it asks
    /// ([`Backend::request`]).
    pub request: Option<Request>,
}

impl Tick {
    /// What the device reported at this tick.
    #[must_use]
    pub fn sample(&self) -> super::DeviceSample {
        super::DeviceSample {
            x_m: self.x_m,
            v_m_s: self.v_m_s,
            force_n: self.force_n,
            vibration: self.vibration,
        }
    }

    /// A tick along the one axis of a one-axis device (the hand at `x_m`,
    /// pushed with `force_n`).
    #[must_use]
    pub fn on_axis(now_s: f64, x_m: f64, v_m_s: f64, force_n: f64, vibration: f64) -> Self {
        Tick {
            now_s,
            x_m,
            v_m_s,
            force_n,
            vibration,
            vibration_q: 0.0,
            burst: None,
            position_m: [x_m, 0.0, 0.0],
            force_vector_n: [force_n, 0.0, 0.0],
            off_track_m: 0.0,
            normal_n: None,
            problem: None,
            button: false,
            link: LinkState::Connected,
            render: UNKNOWN_RENDER,
            selected: false,
            watchdog: false,
            device_tick: None,
            mode: Mode::Host {
                limit_n: crate::friction::ForceLimit::<f64>::default().newtons(),
            },
            non_finite: false,
            device_limit_n: crate::friction::ForceLimit::<f64>::default().newtons(),
            request: None,
        }
    }
}

/// A haptic device, as the loop drives it. Each call is made from the
/// haptic loop's thread, once per tick: `read`, then (unless the device
/// renders on board) `send_force`. None of them may block for longer than
/// a small part of a tick.
pub trait Backend: Send {
    /// What the device can do (a device may say more once connected).
    fn capabilities(&self) -> Capabilities;

    /// Reads what the device reported since the last tick.
    fn read(&mut self, now_s: f64) -> Reading;

    /// Sends this tick's force, N per axis (already within
    /// [`Capabilities::force_limit_n`]), and vibration drive, `[-1, 1]`.
    fn send_force(&mut self, now_s: f64, force_n: Vector, vibration: f64);

    /// Zeroes the force and closes the device.
    fn close(&mut self);

    /// Drives the hand of an emulated device (an emulator's participant);
    /// a real device has no use for it and drops it.
    fn drive_hand(&mut self, drive: &HandDrive) {
        let _ = drive;
    }

    /// The track the loop renders friction along, and the wall that holds
    /// the hand on it (a one-axis device: its axis).
    fn track(&self) -> super::track::Track {
        super::track::Track::axis()
    }

    /// The device's settings as it reported them and as they were chosen,
    /// for the session header (a service's filters, a calibration).
    fn settings(&self) -> Option<serde_json::Value> {
        None
    }

    /// The device's own rendering, if it renders models on board.
    fn on_board(&mut self) -> Option<&mut dyn OnBoard> {
        None
    }

    /// The link's statistics so far.
    fn stats(&self) -> LinkStats {
        LinkStats::default()
    }

    /// What the device asks of the experimenter now, if anything (asked
    /// after each `read`).
    fn request(&self) -> Option<Request> {
        None
    }

    /// The experimenter did what the device asked ([`Backend::request`]).
    fn confirm(&mut self, now_s: f64) {
        let _ = now_s;
    }
}

/// A device whose time is a session's to keep: the simulated apparatus,
/// in this process, stepped in session time by a [`super::stepped::Stepped`]
/// loop (rather than by a clock: a replay is exact, and runs as fast as
/// the machine can). A tick is `read`, `send_force`, then [`Virtual::elapse`].
pub trait Virtual: Backend {
    /// `dt` s pass: the device moves under the force last sent, and the
    /// hand on it pushes with `hand_force_n` N along its axis.
    fn elapse(&mut self, dt: f64, hand_force_n: f64);

    /// Puts the device at rest at `x_m` (the hand repositions it between
    /// trials).
    fn place(&mut self, x_m: f64);

    /// The physical friction of a condition from now on (a block on
    /// rubber, say: part of the apparatus, not rendered; on a real device
    /// it is really there).
    fn set_physical(&mut self, model: Option<&ModelParams>);
}

/// A device that renders models itself.
pub trait OnBoard {
    /// From now on, `model` (or nothing) as the session's render `render`.
    /// True when the device renders it itself; false when the loop renders
    /// it (and the device is told to render nothing of its own).
    fn select(&mut self, now_s: f64, render: u32, model: Option<&ModelParams>) -> bool;

    /// While the device renders: this loop tick's device ticks, handed to
    /// `emit` (one per device tick, or one at rest while the link is down),
    /// and what the link needs this tick (resends, heartbeats). Returns
    /// false when the loop renders this tick itself.
    fn ticks(&mut self, now_s: f64, reading: &Reading, emit: &mut dyn FnMut(Tick)) -> bool;
}
