//! The haptic loop: a dedicated thread that renders friction on a device at
//! a fixed rate. It is a shell (it reads the clock); the device is a
//! [`Backend`] it drives, whichever it is.
//!
//! Each tick it reads the device and updates the hand's place along the
//! device's [`Track`] and a velocity estimate (a 100 Hz low-pass of the
//! position difference), and the same for the hand's offset across the
//! track. It steps the current friction model along the track, adds the
//! wall that holds the hand on the track (a device with more than one
//! axis), and sends the force, its magnitude within the device's limit,
//! then reports the tick to the session. When the model changes, the force
//! crossfades from the old model to the new over [`RAMP_S`]: no jumps. A
//! model force that is not a finite number sends zero and is counted
//! ([`LoopStats::non_finite_forces`], the tick's `non_finite`).
//!
//! A device that renders models itself ([`super::backend::OnBoard`]) is
//! told each model; while it renders one, its own ticks are the loop's.
//!
//! Timing: `spin_sleep` sleeps to each deadline (it sleeps natively, then
//! spins only the last stretch); with `fifo` the thread asks for SCHED_FIFO
//! and keeps running without it if refused. It never busy-spins without
//! sleeping. The session talks to the loop through two lock-free ring
//! buffers ([`rtrb`]). Nothing in the loop allocates: models are plain
//! values, and the period histogram is allocated before the loop starts.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use super::backend::{Backend, LinkState, MAX_AXES, Reading, Vector};
pub use super::backend::{Mode, Request, Tick, UNKNOWN_RENDER};
use super::track::Track;
use crate::friction::{ForceLimit, Input, ModelParams, StepParams};
use crate::hand::HandDrive;
use frictionlab_core::render::Renderer;

pub use frictionlab_core::render::RAMP_S;

/// From the session to the loop.
#[derive(Debug, Clone, PartialEq)]
pub enum ToLoop {
    /// Render this model from now on (crossfaded), or nothing, as the
    /// session's render number `render` (ticks report the render in
    /// effect).
    Model {
        /// The session's number for this render.
        render: u32,
        /// The model, or nothing.
        model: Option<ModelParams>,
    },
    /// Drive the hand of an emulated device.
    Hand(HandDrive),
    /// From now on, offer each connected tick to this sink too (up to
    /// [`MAX_SINKS`]: the LSL stream, the tactile display), on the loop's
    /// thread (whoever asked: the loop knows no reader).
    Offer(Offer),
    /// The experimenter did what the device asked (a tick's `request`).
    Confirm,
    /// The bring-up check's pulse ([`super::check`]): from now on add this
    /// force along the track, N, to the model's (0: none), within the
    /// limit.
    Push(f64),
    /// The bring-up check: render the wall that holds the hand on the
    /// track (true, as from the start) or not (a device wired the wrong
    /// way round would push the hand away).
    Wall(bool),
}

/// Whoever wants the loop's ticks as they happen: called on the loop's
/// thread with each connected tick, so it must only queue (never block).
pub trait SampleSink: Send + Sync {
    /// A connected tick, its time never before the last's.
    fn offer(&self, tick: &Tick);
}

/// The most sinks a loop offers its ticks to; a further offer is dropped.
pub const MAX_SINKS: usize = 4;

/// A [`SampleSink`] handed to the loop ([`ToLoop::Offer`]).
#[derive(Clone)]
pub struct Offer(pub std::sync::Arc<dyn SampleSink>);

impl std::fmt::Debug for Offer {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("Offer(..)")
    }
}

impl PartialEq for Offer {
    fn eq(&self, other: &Self) -> bool {
        std::sync::Arc::ptr_eq(&self.0, &other.0)
    }
}

/// Timing and link statistics of a loop run.
#[derive(
    Debug,
    Clone,
    Copy,
    PartialEq,
    Default,
    serde::Serialize,
    serde::Deserialize,
    schemars::JsonSchema,
)]
pub struct LoopStats {
    /// Loop rate, Hz.
    pub rate_hz: f64,
    /// Ticks run.
    pub ticks: u64,
    /// Median lateness of a tick against its deadline, microseconds.
    pub period_error_p50_us: f64,
    /// 99th percentile lateness, microseconds.
    pub period_error_p99_us: f64,
    /// Largest lateness, microseconds.
    pub period_error_max_us: f64,
    /// Ticks later than half a period.
    pub missed_deadlines: u64,
    /// Frames with a bad CRC.
    pub crc_errors: u64,
    /// Frames discarded and resynchronised.
    pub resyncs: u64,
    /// Whether SCHED_FIFO was granted.
    pub sched_fifo: bool,
    /// Ticks the device rendered on board (telemetry received).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub on_board_ticks: Option<u64>,
    /// Device ticks whose telemetry never arrived (gaps in its tick count).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub telemetry_gaps: Option<u64>,
    /// The device's longest loop body, microseconds (its `LoopReport`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub device_longest_loop_us: Option<u32>,
    /// Device ticks that missed their deadline (its `LoopReport`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub device_missed_ticks: Option<u32>,
    /// Median time between consecutive ticks, microseconds.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub period_p50_us: Option<f64>,
    /// 99th percentile of the time between consecutive ticks,
    /// microseconds.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub period_p99_us: Option<f64>,
    /// Ticks whose model computed a force that was not a finite number
    /// (zero was sent).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub non_finite_forces: Option<u64>,
}

/// A running haptic loop.
pub struct HapticLoop {
    /// The loop's clock origin: a tick's `now_s` is the time since.
    origin: Instant,
    to_loop: rtrb::Producer<ToLoop>,
    from_loop: rtrb::Consumer<Tick>,
    stop: Arc<AtomicBool>,
    handle: Option<JoinHandle<LoopStats>>,
}

impl std::fmt::Debug for HapticLoop {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("HapticLoop").finish_non_exhaustive()
    }
}

/// Latency histogram bins: 1 us each up to 20 ms.
const BINS: usize = 20_000;

impl HapticLoop {
    /// Starts the loop on `device`, stepped by `step` (rate, force limit,
    /// velocity filter), asking for SCHED_FIFO when `fifo`.
    ///
    /// # Errors
    /// The thread could not be spawned.
    pub fn start(device: Box<dyn Backend>, step: StepParams, fifo: bool) -> std::io::Result<Self> {
        let (to_loop, mut inbox) = rtrb::RingBuffer::<ToLoop>::new(256);
        let (mut outbox, from_loop) = rtrb::RingBuffer::<Tick>::new(16_384);
        let stop = Arc::new(AtomicBool::new(false));
        let flag = stop.clone();
        let origin = Instant::now();
        let handle = std::thread::Builder::new()
            .name("haptic-loop".into())
            .spawn(move || {
                let sched_fifo = fifo && super::realtime::ask_fifo();
                run(
                    device,
                    step,
                    &flag,
                    &mut inbox,
                    &mut outbox,
                    sched_fifo,
                    origin,
                )
            })?;
        Ok(HapticLoop {
            origin,
            to_loop,
            from_loop,
            stop,
            handle: Some(handle),
        })
    }

    /// The instant ticks' `now_s` count from.
    #[must_use]
    pub fn origin(&self) -> Instant {
        self.origin
    }

    /// Sends a message to the loop (dropped if the loop is far behind).
    pub fn send(&mut self, message: ToLoop) {
        let _ = self.to_loop.push(message);
    }

    /// The next tick the loop reported, if any.
    pub fn recv(&mut self) -> Option<Tick> {
        self.from_loop.pop().ok()
    }

    /// Whether the loop's thread has ended without being told to stop
    /// (it panicked, or returned): why, said once (later calls, and
    /// [`HapticLoop::stop`] after it, find no thread).
    pub fn died(&mut self) -> Option<String> {
        if self.stop.load(Ordering::Relaxed)
            || !self.handle.as_ref().is_some_and(JoinHandle::is_finished)
        {
            return None;
        }
        let handle = self.handle.take()?;
        Some(match handle.join() {
            Ok(_) => "its thread returned while not told to stop".to_owned(),
            Err(panic) => {
                let what = panic
                    .downcast_ref::<&str>()
                    .map(|s| (*s).to_owned())
                    .or_else(|| panic.downcast_ref::<String>().cloned())
                    .unwrap_or_else(|| "no message".to_owned());
                format!("its thread panicked: {what}")
            }
        })
    }

    /// Stops the loop (force zeroed) and returns its statistics.
    #[must_use]
    pub fn stop(mut self) -> LoopStats {
        self.stop.store(true, Ordering::Relaxed);
        self.handle
            .take()
            .and_then(|h| h.join().ok())
            .unwrap_or_default()
    }
}

impl Drop for HapticLoop {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(h) = self.handle.take() {
            let _ = h.join();
        }
    }
}

/// The hand's state along the track and across it.
struct Motion {
    along: f64,
    v: f64,
    offset: Vector,
    offset_v: Vector,
    previous: Option<(f64, Vector)>,
}

impl Motion {
    /// Notes where the hand is now (`connected`: the reading is fresh),
    /// its velocity filtered by `alpha` over `1 / dt` = `per_s`.
    fn update(
        &mut self,
        (along, offset): (f64, Vector),
        connected: bool,
        one_axis: bool,
        (alpha, per_s): (f64, f64),
    ) {
        if connected {
            if let Some((a0, o0)) = self.previous {
                self.v = crate::friction::filtered_velocity(alpha, self.v, (along - a0) * per_s);
                // On one axis the hand is never off the track.
                if !one_axis {
                    for i in 0..MAX_AXES {
                        self.offset_v[i] = crate::friction::filtered_velocity(
                            alpha,
                            self.offset_v[i],
                            (offset[i] - o0[i]) * per_s,
                        );
                    }
                }
            }
            self.previous = Some((along, offset));
        } else {
            self.previous = None;
            self.v = 0.0;
            self.offset_v = [0.0; MAX_AXES];
        }
        self.along = along;
        self.offset = offset;
    }

    /// The hand at rest at `at` (a device put there).
    fn rest(&mut self, at: (f64, Vector)) {
        self.along = at.0;
        self.offset = at.1;
        self.previous = Some(at);
        self.v = 0.0;
        self.offset_v = [0.0; MAX_AXES];
    }
}

/// One tick of the loop, whatever keeps its time: the loop's thread
/// ([`HapticLoop`], in real time) or a session stepping a device in its
/// own time ([`super::stepped::Stepped`]). It reads the device, notes the
/// hand's motion, takes the session's messages, renders and sends the
/// force, and reports the tick. No clock, no allocation: time comes in as
/// arguments.
pub(super) struct LoopCore {
    step: StepParams,
    track: Track,
    /// A device of one axis: that axis is the track, and a position or a
    /// force along it is the axis's own number (no projection).
    one_axis: bool,
    renderer: Renderer<f64>,
    /// The model selected last, as the session sent it (restarted where
    /// a device is put, [`LoopCore::place`]).
    model: Option<ModelParams>,
    host_render: u32,
    host_selected: bool,
    motion: Motion,
    sinks: [Option<Offer>; MAX_SINKS],
    push_n: f64,
    wall: bool,
    non_finite: u64,
    last_s: f64,
    /// `dt` the velocity filter was computed for, its coefficient, `1 / dt`.
    filter: (f64, f64, f64),
    /// The device's vertical axis, as it stated it at the last read.
    vertical_axis: Option<usize>,
    /// The device's own limit and the limit in force, N.
    device_limit_n: f64,
    in_force: f64,
}

impl LoopCore {
    /// Rendering nothing on `device`, stepped by `step` (force limit,
    /// velocity filter), crossfading over `ramp_s` after a model change.
    pub(super) fn new(device: &(impl Backend + ?Sized), step: StepParams, ramp_s: f64) -> Self {
        let caps = device.capabilities();
        let mut core = LoopCore {
            step,
            track: device.track(),
            one_axis: caps.axes == 1,
            renderer: Renderer::new(step.force_limit, ramp_s),
            model: None,
            host_render: 0,
            host_selected: false,
            motion: Motion {
                along: 0.0,
                v: 0.0,
                offset: [0.0; MAX_AXES],
                offset_v: [0.0; MAX_AXES],
                previous: None,
            },
            sinks: Default::default(),
            push_n: 0.0,
            wall: true,
            non_finite: 0,
            last_s: 0.0,
            filter: (f64::NAN, 0.0, 0.0),
            vertical_axis: caps.vertical_axis,
            device_limit_n: caps.force_limit_n,
            in_force: step.force_limit.newtons(),
        };
        core.limit(caps.force_limit_n);
        core
    }

    /// The force limit in force, N: the smaller of the loop's (the
    /// model's clamp) and the device's, which a device may state only
    /// once connected (before any model of a session is selected: a
    /// session starts at a connected tick).
    fn limit(&mut self, device_limit_n: f64) {
        self.device_limit_n = device_limit_n;
        let in_force = device_limit_n.min(self.step.force_limit.newtons());
        if in_force != self.renderer.limit().newtons()
            && let Ok(limit) = ForceLimit::new(in_force)
        {
            self.renderer.set_limit(limit);
        }
        self.in_force = in_force;
    }

    /// The force limit the models render within now, N.
    pub(super) fn limit_n(&self) -> f64 {
        self.renderer.limit().newtons()
    }

    /// A position on the device, along the track and across it.
    fn split(&self, p: Vector) -> (f64, Vector) {
        if self.one_axis {
            (p[0], [0.0; MAX_AXES])
        } else {
            self.track.split(p)
        }
    }

    /// Reads the device at `now` s, `dt` s after the last tick, and notes
    /// the hand's motion and the device's limit.
    pub(super) fn read(
        &mut self,
        device: &mut (impl Backend + ?Sized),
        now: f64,
        dt: f64,
    ) -> Reading {
        let reading = device.read(now);
        let connected = reading.link == LinkState::Connected;
        if self.filter.0 != dt {
            self.filter = (dt, self.step.velocity_alpha(dt), 1.0 / dt);
        }
        let at = self.split(reading.position_m);
        let filter = (self.filter.1, self.filter.2);
        self.motion.update(at, connected, self.one_axis, filter);
        let caps = device.capabilities();
        self.vertical_axis = caps.vertical_axis;
        self.limit(caps.force_limit_n);
        reading
    }

    /// Takes a message from the session at `now` s.
    pub(super) fn handle(
        &mut self,
        device: &mut (impl Backend + ?Sized),
        now: f64,
        message: ToLoop,
    ) {
        match message {
            ToLoop::Model { render, model } => {
                let on_board_renders = device
                    .on_board()
                    .is_some_and(|b| b.select(now, render, model.as_ref()));
                let host_model = model.as_ref().filter(|_| !on_board_renders);
                self.renderer.select(host_model, self.motion.along);
                self.model = host_model.cloned();
                self.host_render = render;
                self.host_selected = true;
            }
            ToLoop::Hand(drive) => device.drive_hand(&drive),
            ToLoop::Offer(offer) => {
                if let Some(free) = self.sinks.iter_mut().find(|s| s.is_none()) {
                    *free = Some(offer);
                }
            }
            ToLoop::Confirm => device.confirm(now),
            ToLoop::Push(f) => self.push_n = if f.is_finite() { f } else { 0.0 },
            ToLoop::Wall(on) => self.wall = on,
        }
    }

    /// The device was put at rest where it reads at `now` s (a simulated
    /// apparatus the hand repositions between trials): the hand is at rest
    /// there, and the model selected last restarts there as the session's
    /// render `render`.
    pub(super) fn place(&mut self, device: &mut (impl Backend + ?Sized), now: f64, render: u32) {
        let at = self.split(device.read(now).position_m);
        self.motion.rest(at);
        self.renderer.select(self.model.as_ref(), at.0);
        self.host_render = render;
        self.host_selected = true;
    }

    /// Hands a tick to `out` and to the sinks that asked (a connected
    /// tick only). Ticks' times never go back.
    fn emit(
        sinks: &[Option<Offer>; MAX_SINKS],
        last_s: &mut f64,
        out: &mut dyn FnMut(Tick),
        mut tick: Tick,
    ) {
        tick.now_s = tick.now_s.max(*last_s);
        *last_s = tick.now_s;
        if tick.link == LinkState::Connected {
            for sink in sinks.iter().flatten() {
                sink.0.offer(&tick);
            }
        }
        out(tick);
    }

    /// Renders this tick of `dt` s at `now` s on what `reading` says: the
    /// device's own ticks while it renders on board, else the loop's
    /// force, sent; each tick reported to `out`.
    pub(super) fn render(
        &mut self,
        device: &mut (impl Backend + ?Sized),
        now: f64,
        dt: f64,
        reading: &Reading,
        out: &mut dyn FnMut(Tick),
    ) {
        let (sinks, last_s) = (&self.sinks, &mut self.last_s);
        if let Some(board) = device.on_board()
            && board.ticks(now, reading, &mut |tick| {
                Self::emit(sinks, last_s, out, tick);
            })
        {
            return;
        }
        let tick = self.host_tick(device, now, dt, reading);
        Self::emit(&self.sinks, &mut self.last_s, out, tick);
    }

    /// Renders this tick of `dt` s at `now` s on the host, on what
    /// `reading` says, and sends the force: the tick.
    pub(super) fn host_tick(
        &mut self,
        device: &mut (impl Backend + ?Sized),
        now: f64,
        dt: f64,
        reading: &Reading,
    ) -> Tick {
        let connected = reading.link == LinkState::Connected;
        let motion = &self.motion;
        // Where the device has a vertical axis, a model whose normal force
        // is the press takes the hand's press into the surface (below it:
        // the offset's vertical part is negative).
        let normal_n = self
            .vertical_axis
            .and_then(|axis| self.renderer.press(-motion.offset[axis]));
        let out_model = self.renderer.step(
            dt,
            Input {
                x_m: motion.along,
                v_m_s: motion.v,
            },
        );
        let finite = out_model.force_n.is_finite()
            && out_model.vibration.is_finite()
            && out_model.vibration_q.is_finite();
        if !finite {
            self.non_finite += 1;
        }
        let push_n = self.push_n;
        let (along_n, vibration, vibration_q) = match (connected, finite) {
            (true, true) => (
                out_model.force_n + push_n,
                out_model.vibration,
                out_model.vibration_q,
            ),
            (true, false) => (push_n, 0.0, 0.0),
            (false, _) => (0.0, 0.0, 0.0),
        };
        let in_force = self.in_force;
        let force = if !connected {
            [0.0; MAX_AXES]
        } else if self.one_axis {
            [along_n.clamp(-in_force, in_force), 0.0, 0.0]
        } else if self.wall {
            self.track
                .force(along_n, motion.offset, motion.offset_v, in_force)
        } else {
            self.track
                .force(along_n, [0.0; MAX_AXES], [0.0; MAX_AXES], in_force)
        };
        device.send_force(now, force, vibration);
        Tick {
            button: reading.button,
            link: reading.link,
            render: self.host_render,
            selected: std::mem::take(&mut self.host_selected),
            watchdog: reading.watchdog,
            position_m: reading.position_m,
            force_vector_n: force,
            off_track_m: if self.one_axis {
                0.0
            } else {
                super::track::norm(motion.offset)
            },
            normal_n,
            problem: reading.problem,
            non_finite: !finite,
            mode: Mode::Host {
                limit_n: self.renderer.limit().newtons(),
            },
            device_limit_n: self.device_limit_n,
            request: device.request(),
            vibration_q,
            burst: self.model.as_ref().and_then(ModelParams::burst),
            ..Tick::on_axis(now, motion.along, motion.v, along_n, vibration)
        }
    }

    /// Ticks whose model computed a force that was not a finite number.
    pub(super) fn non_finite(&self) -> u64 {
        self.non_finite
    }
}

/// The loop's thread: a [`LoopCore`] tick at each deadline; returns its
/// statistics when `stop` is set.
fn run(
    mut device: Box<dyn Backend>,
    step: StepParams,
    stop: &AtomicBool,
    inbox: &mut rtrb::Consumer<ToLoop>,
    outbox: &mut rtrb::Producer<Tick>,
    sched_fifo: bool,
    start: Instant,
) -> LoopStats {
    let rate_hz = step.rate_hz;
    let period = Duration::from_secs_f64(step.dt());
    let dt = period.as_secs_f64();
    let mut histogram = vec![0_u32; BINS + 1];
    let mut periods = vec![0_u32; BINS + 1];
    let mut last_woke: Option<Instant> = None;
    let (mut ticks, mut missed, mut max_late) = (0_u64, 0_u64, 0.0_f64);
    let mut core = LoopCore::new(device.as_ref(), step, RAMP_S);
    let mut deadline = Instant::now() + period;
    while !stop.load(Ordering::Relaxed) {
        spin_sleep::sleep_until(deadline);
        let woke = Instant::now();
        let late = woke.saturating_duration_since(deadline).as_secs_f64() * 1e6;
        max_late = max_late.max(late);
        #[expect(
            clippy::cast_possible_truncation,
            clippy::cast_sign_loss,
            reason = "non-negative, clamped to the histogram"
        )]
        let bin = (late as usize).min(BINS);
        histogram[bin] += 1;
        if let Some(last) = last_woke.replace(woke) {
            #[expect(
                clippy::cast_possible_truncation,
                clippy::cast_sign_loss,
                reason = "non-negative, clamped to the histogram"
            )]
            let us = (woke.duration_since(last).as_secs_f64() * 1e6) as usize;
            periods[us.min(BINS)] += 1;
        }
        if late > 0.5e6 * dt {
            missed += 1;
        }
        deadline += period;
        if woke > deadline + period * 100 {
            deadline = woke + period; // Far behind (machine stalled): no burst of catch-up ticks.
        }
        ticks += 1;
        let now = woke.duration_since(start).as_secs_f64();
        // Device -> host; session -> loop; the force -> device.
        let reading = core.read(device.as_mut(), now, dt);
        while let Ok(m) = inbox.pop() {
            core.handle(device.as_mut(), now, m);
        }
        core.render(device.as_mut(), now, dt, &reading, &mut |tick| {
            let _ = outbox.push(tick);
        });
    }
    let non_finite = core.non_finite();
    device.close();
    let quantile = |histogram: &[u32], q: f64| {
        let ticks: u64 = histogram.iter().map(|&c| u64::from(c)).sum();
        #[expect(
            clippy::cast_possible_truncation,
            clippy::cast_sign_loss,
            reason = "a rank within the tick count"
        )]
        let target = ((ticks as f64) * q).ceil() as u64;
        let mut seen = 0_u64;
        for (i, &c) in histogram.iter().enumerate() {
            seen += u64::from(c);
            if seen >= target.max(1) {
                return i as f64;
            }
        }
        BINS as f64
    };
    let stats = device.stats();
    LoopStats {
        rate_hz,
        ticks,
        period_error_p50_us: quantile(&histogram, 0.5),
        period_error_p99_us: quantile(&histogram, 0.99),
        period_error_max_us: max_late,
        missed_deadlines: missed,
        crc_errors: stats.crc_errors,
        resyncs: stats.resyncs,
        sched_fifo,
        on_board_ticks: stats.on_board_ticks,
        telemetry_gaps: stats.telemetry_gaps,
        device_longest_loop_us: stats.device_longest_loop_us,
        device_missed_ticks: stats.device_missed_ticks,
        period_p50_us: (ticks > 1).then(|| quantile(&periods, 0.5)),
        period_p99_us: (ticks > 1).then(|| quantile(&periods, 0.99)),
        non_finite_forces: (non_finite > 0).then_some(non_finite),
    }
}
