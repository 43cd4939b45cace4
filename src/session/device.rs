//! The one device abstraction a session drives: a backend behind the
//! device seam, rendered by the haptic loop's core, whose time is either
//! the session's (a [`Virtual`](crate::device::backend::Virtual) device,
//! the simulated apparatus, stepped tick by tick) or the clock's (the loop's
//! thread on a port, whose ticks the session reads).

use std::collections::VecDeque;

use crate::device::LinkState;
use crate::device::backend::DeviceLimits;
use crate::device::haptic::{HapticLoop, LoopStats, Mode, Tick, ToLoop};
use crate::device::sim::Simulated;
use crate::device::stepped::Stepped;
use crate::friction::ModelParams;
use crate::hand::HandDrive;
use crate::time::Time;

/// How often the hand drive is sent to an emulated device, s.
pub const HAND_EVERY_S: f64 = 0.005;

/// Loop periods kept for the live p99, ticks.
const PERIODS_KEPT: usize = 5000;

/// The device's live state, for the experimenter.
#[derive(Debug, Clone, PartialEq)]
pub struct DeviceStatus {
    /// `sim` or the port's path.
    pub device: String,
    /// Whether frames arrive (always true for the simulated device).
    pub connected: bool,
    /// Loop rate, Hz.
    pub rate_hz: f64,
    /// 99th percentile of the measured loop period over the last ticks, s
    /// (None for the simulated device, which steps in session time).
    pub period_p99_s: Option<f64>,
    /// Rendered force, N.
    pub force_n: f64,
    /// Device position, m.
    pub x_m: f64,
}

/// A haptic loop on a serial port, with what the session tracks of it.
pub(super) struct Port {
    haptic: HapticLoop,
    /// The device's settings, for the session header.
    settings: Option<serde_json::Value>,
    /// The device's axes.
    pub(super) axes: usize,
    pub(super) rate_hz: f64,
    /// The stretch of the track the device reaches, m.
    travel_m: [f64; 2],
    periods: VecDeque<f64>,
    last_tick_s: Option<f64>,
    pub(super) link: LinkState,
    button: bool,
    last_hand_s: f64,
    hand_segment: Option<u32>,
    /// The loop's thread died (no statistics to stop it for).
    died: bool,
}

impl Port {
    pub(super) fn new(
        haptic: HapticLoop,
        settings: Option<serde_json::Value>,
        axes: usize,
        rate_hz: f64,
        travel_m: [f64; 2],
    ) -> Self {
        Port {
            haptic,
            settings,
            axes,
            rate_hz,
            travel_m,
            periods: VecDeque::with_capacity(PERIODS_KEPT),
            last_tick_s: None,
            link: LinkState::Connecting,
            button: false,
            last_hand_s: f64::NEG_INFINITY,
            hand_segment: None,
            died: false,
        }
    }

    /// The next tick, with the loop's period and link state noted; the
    /// second value is true on a button press (a rising edge).
    pub(super) fn recv(&mut self) -> Option<(Tick, bool)> {
        let tick = self.haptic.recv()?;
        if let Some(last) = self.last_tick_s.replace(tick.now_s) {
            if self.periods.len() == PERIODS_KEPT {
                self.periods.pop_front();
            }
            self.periods.push_back(tick.now_s - last);
        }
        self.link = tick.link;
        let pressed = tick.link == LinkState::Connected && tick.button && !self.button;
        if tick.link == LinkState::Connected {
            self.button = tick.button;
        }
        Some((tick, pressed))
    }

    /// Drops the ticks the loop has reported and the session has not read
    /// (those that queued while the session waited before its start).
    pub(super) fn skip_queued(&mut self) {
        while self.haptic.recv().is_some() {}
    }

    /// Whether the loop's thread died untold: why, said once.
    pub(super) fn died(&mut self) -> Option<String> {
        let why = self.haptic.died()?;
        self.died = true;
        Some(why)
    }

    /// Tells the device the experimenter did what it asked.
    pub(super) fn confirm(&mut self) {
        self.haptic.send(ToLoop::Confirm);
    }

    /// Has the loop offer each connected tick to `sink` from now on.
    pub(super) fn offer(&mut self, sink: crate::device::haptic::Offer) {
        self.haptic.send(ToLoop::Offer(sink));
    }

    /// The instant the loop's ticks count time from.
    pub(super) fn origin(&self) -> std::time::Instant {
        self.haptic.origin()
    }

    /// How `tick`'s render was stepped.
    pub(super) fn how(&self, tick: &Tick) -> super::renders::How {
        use crate::results::RenderMode;
        match tick.mode {
            Mode::Host { limit_n } => super::renders::How {
                mode: RenderMode::HostLoop,
                float: crate::friction::Float::F64,
                rate_hz: self.rate_hz,
                ramp_s: crate::device::haptic::RAMP_S,
                force_limit_n: limit_n,
            },
            Mode::OnBoard {
                rate_hz,
                float,
                limit_n,
            } => super::renders::How {
                mode: RenderMode::OnBoard,
                float,
                rate_hz: f64::from(rate_hz),
                ramp_s: crate::device::haptic::RAMP_S,
                force_limit_n: f64::from(limit_n),
            },
        }
    }

    /// What the device states of its force and reach, as of `tick`.
    pub(super) fn limits(&self, tick: &Tick) -> DeviceLimits {
        DeviceLimits {
            force_limit_n: tick.device_limit_n,
            travel_m: self.travel_m,
        }
    }

    /// Sends the hand drive to the device, at most every [`HAND_EVERY_S`]
    /// of device time `now_s`, and at once when a new movement segment
    /// starts, preceded by a relaxed drive (zero integral gain) that ends
    /// the last: the wire carries the segment that way (only the emulator
    /// has a hand to drive; real firmware ignores the message).
    pub(super) fn drive_hand(&mut self, now_s: f64, drive: &HandDrive) {
        let new_segment = self.hand_segment.replace(drive.segment) != Some(drive.segment);
        if new_segment {
            let relaxed = HandDrive {
                integral_gain: 0.0,
                ..*drive
            };
            self.haptic.send(ToLoop::Hand(relaxed));
        }
        if new_segment || now_s - self.last_hand_s >= HAND_EVERY_S {
            self.last_hand_s = now_s;
            self.haptic.send(ToLoop::Hand(*drive));
        }
    }
}

/// Where a session renders friction.
pub(super) enum Device {
    /// A device in session time (the simulated apparatus), its loop
    /// stepped by the session at `dt` (the period of the rendered model's
    /// rate, whole nanoseconds).
    Stepped {
        device: Box<Stepped<Simulated>>,
        dt: Time,
    },
    /// The haptic loop's thread on a port.
    Port(Box<Port>),
    /// The haptic loop has stopped (session finished or aborted).
    Stopped { rate_hz: f64 },
}

impl Device {
    /// The device `choice` names: the simulated apparatus with a hand of
    /// `hand_mass_kg` on it, or the haptic loop on a port at `rate_hz`.
    pub(super) fn open(
        choice: &super::DeviceChoice,
        rate_hz: f64,
        hand_mass_kg: f64,
    ) -> Result<Self, super::SessionError> {
        use crate::device::sim::Apparatus;
        use crate::friction::StepParams;
        Ok(match choice {
            super::DeviceChoice::Simulated => {
                let step = StepParams::default();
                let apparatus = Simulated::new(Apparatus::default(), hand_mass_kg);
                Device::Stepped {
                    device: Box::new(Stepped::new(apparatus, step)),
                    dt: Time::period(step.rate_hz),
                }
            }
            super::DeviceChoice::Device(address) => {
                let backend = address
                    .open()
                    .map_err(|e| super::SessionError::Device(address.to_string(), e))?;
                // A device slower than the model's rate renders it at its own
                // (each render's `rendering` says at which).
                let caps = backend.capabilities();
                let settings = backend.settings();
                let step = StepParams {
                    rate_hz: rate_hz.min(caps.max_rate_hz),
                    ..StepParams::default()
                };
                let haptic =
                    HapticLoop::start(backend, step, true).map_err(super::SessionError::Loop)?;
                Device::Port(Box::new(Port::new(
                    haptic,
                    settings,
                    caps.axes,
                    step.rate_hz,
                    caps.travel_m,
                )))
            }
        })
    }

    /// Renders `model` from now on (`None`: nothing), as the session's
    /// render number `render`, at session time `now`.
    pub(super) fn render(&mut self, now: Time, render: u32, model: Option<&ModelParams>) {
        match self {
            Device::Stepped { device, dt } => {
                device.select(now.secs(), render, model);
                if let Some(m) = model {
                    *dt = Time::period(m.loop_rate_hz());
                }
            }
            Device::Port(port) => port.haptic.send(ToLoop::Model {
                render,
                model: model.cloned(),
            }),
            Device::Stopped { .. } => {}
        }
    }

    /// How a device in session time steps its model now (its rows'
    /// `How`); None for a port, whose ticks say how each was stepped.
    pub(super) fn sim_how(&self) -> Option<super::renders::How> {
        match self {
            Device::Stepped { device, dt } => Some(super::renders::How {
                mode: crate::results::RenderMode::Simulated,
                float: crate::friction::Float::F64,
                rate_hz: 1.0 / dt.secs(),
                ramp_s: crate::device::stepped::STEPPED_RAMP_S,
                force_limit_n: device.limit_n(),
            }),
            _ => None,
        }
    }

    /// What a device in session time states of its force and reach (None
    /// for a port, whose ticks say).
    pub(super) fn sim_limits(&self) -> Option<DeviceLimits> {
        match self {
            Device::Stepped { device, .. } => {
                let caps = device.capabilities();
                Some(DeviceLimits {
                    force_limit_n: caps.force_limit_n,
                    travel_m: caps.travel_m,
                })
            }
            _ => None,
        }
    }

    /// The physical friction of a condition (a device in session time
    /// only, the simulated apparatus: on a real device it is really there).
    pub(super) fn set_physical(&mut self, model: Option<&ModelParams>) {
        if let Device::Stepped { device, .. } = self {
            device.set_physical(model);
        }
    }

    /// One tick of a device in session time at `now`, the hand pushing
    /// with `hand_force_n` over it (None for a port, whose ticks come from
    /// its loop); it lasts [`Device::stepped_dt`].
    pub(super) fn step(&mut self, now: Time, hand_force_n: f64) -> Option<Tick> {
        match self {
            Device::Stepped { device, dt } => {
                Some(device.tick(now.secs(), dt.secs(), hand_force_n))
            }
            _ => None,
        }
    }

    /// A device in session time's tick length (None for a port).
    pub(super) fn stepped_dt(&self) -> Option<Time> {
        match self {
            Device::Stepped { dt, .. } => Some(*dt),
            _ => None,
        }
    }

    /// The instant a port's ticks count time from (none for a device in
    /// session time).
    pub(super) fn origin(&self) -> Option<std::time::Instant> {
        match self {
            Device::Port(port) => Some(port.origin()),
            _ => None,
        }
    }

    /// Whether the device is in session time (the simulated apparatus).
    pub(super) fn is_sim(&self) -> bool {
        matches!(self, Device::Stepped { .. })
    }

    /// Puts a device in session time at rest at `x_m` at session time
    /// `now`, its model restarted there as render number `render`; false
    /// on a real device, where the hand moves there itself.
    pub(super) fn reset(&mut self, now: Time, x_m: f64, render: u32) -> bool {
        if let Device::Stepped { device, .. } = self {
            device.place(now.secs(), x_m, render);
            true
        } else {
            false
        }
    }

    /// The stretch of the track the device reaches, m from its origin.
    pub(super) fn travel_m(&self) -> [f64; 2] {
        match self {
            Device::Stepped { device, .. } => device.capabilities().travel_m,
            Device::Port(port) => port.travel_m,
            Device::Stopped { .. } => [0.0; 2],
        }
    }

    /// The device's axes (1 for the simulated device).
    pub(super) fn axes(&self) -> usize {
        match self {
            Device::Port(port) => port.axes,
            _ => 1,
        }
    }

    /// The device's settings, for the session header.
    pub(super) fn settings(&self) -> Option<serde_json::Value> {
        match self {
            Device::Port(port) => port.settings.clone(),
            _ => None,
        }
    }

    /// Whether the device answers.
    pub(super) fn connected(&self) -> bool {
        match self {
            Device::Stepped { .. } => true,
            Device::Port(port) => port.link == LinkState::Connected,
            Device::Stopped { .. } => false,
        }
    }

    /// Stops the haptic loop, returning its statistics (None for the
    /// simulated device or a loop already stopped).
    pub(super) fn stop(&mut self) -> Option<LoopStats> {
        let Device::Port(port) = self else {
            return None;
        };
        let rate_hz = port.rate_hz;
        match std::mem::replace(self, Device::Stopped { rate_hz }) {
            Device::Port(port) if !port.died => Some(port.haptic.stop()),
            _ => None,
        }
    }

    /// Connected, rate and period p99.
    pub(super) fn status(&self) -> (bool, f64, Option<f64>) {
        let (rate_hz, p99) = match self {
            Device::Stepped { dt, .. } => (1.0 / dt.secs(), None),
            Device::Stopped { rate_hz } => (*rate_hz, None),
            Device::Port(port) => (port.rate_hz, percentile(&port.periods, 0.99)),
        };
        (self.connected(), rate_hz, p99)
    }
}

/// `q`-quantile (nearest rank) of `values`, None if empty.
#[must_use]
pub fn percentile<'a>(values: impl IntoIterator<Item = &'a f64>, q: f64) -> Option<f64> {
    let mut v: Vec<f64> = values.into_iter().copied().collect();
    if v.is_empty() {
        return None;
    }
    v.sort_by(f64::total_cmp);
    #[expect(
        clippy::cast_possible_truncation,
        clippy::cast_sign_loss,
        reason = "a rank within the slice"
    )]
    let rank = ((q * count_f64(v.len())).ceil() as usize).clamp(1, v.len());
    Some(v[rank - 1])
}

/// A count as f64 (saturating at `u32::MAX`).
pub(super) fn count_f64(n: usize) -> f64 {
    f64::from(u32::try_from(n).unwrap_or(u32::MAX))
}
