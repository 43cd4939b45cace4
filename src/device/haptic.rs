//! The haptic loop: a dedicated thread that renders friction on a device at
//! a fixed rate. It is a shell (it reads the clock and owns the port).
//!
//! Each tick it reads what the port returned and updates the position and a
//! velocity estimate (a 100 Hz low-pass of the position difference). It steps
//! the current friction model and sends the force through the [`Link`]
//! (`Command`, or `Hello` while not connected, so the device's watchdog zeroes
//! the force), then reports the tick to the session. When the model changes,
//! the force crossfades from the old model to the new over [`RAMP_S`]: no
//! jumps.
//!
//! Timing: `spin_sleep` sleeps to each deadline (it sleeps natively, then
//! spins only the last stretch); with `fifo` the thread asks for SCHED_FIFO
//! and keeps running without it if refused. It never busy-spins without
//! sleeping. The session talks to the loop through two lock-free ring
//! buffers ([`rtrb`]). Nothing in the loop allocates: messages are encoded
//! into stack buffers, models are plain values, and the period histogram is
//! allocated before the loop starts.
//!
//! # On board (wire protocol v2)
//! When the device states in its handshake that it renders a model on
//! board at least at the model's rate, the loop does not step that model:
//! it uploads it and selects it (`Upload`, `Select`; `Clear` for nothing),
//! resending until the device's telemetry shows it in effect, and after a
//! reconnect. Its ticks to the session are then the device's `Telemetry`,
//! one per device tick, timed by the device's tick count, and it sends only
//! `Heartbeat`s to feed the device's watchdog. A model the device does not
//! render (or a version 1 device) is rendered by the loop itself as above,
//! the device told to `Clear` its own.

use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use super::link::{Incoming, Link, LinkState, OnBoard, Telemetry};
use super::transport::Transport;
use super::wire::{MAX_FRAME, Message, encode, status};
use crate::friction::{Float, Input, ModelParams, StepParams};
use frictionlab_core::render::Renderer;

pub use frictionlab_core::render::RAMP_S;

/// The render label of a device that renders nothing it was told to (it
/// restarted): rendering nothing.
pub const UNKNOWN_RENDER: u32 = u32::MAX;

/// How long the loop waits for telemetry to show a selected model before it
/// uploads it again, s; each further resend of the same render waits twice
/// as long, up to 8 times this (a slow link is not flooded with copies).
const RESEND_AFTER_S: f64 = 0.050;

/// How many labels the loop remembers: renders sent while the device has
/// not yet caught up (a lagging link) keep their meaning.
const LABELS: usize = 16;

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
    /// Forward this message to the device (the emulator's hand drive).
    Device(Message),
    /// From now on, queue each connected tick's sample for the session's
    /// LSL device stream (issue 34): pushed off this thread, by the
    /// publisher's worker.
    Publish(crate::lsl::SampleTap),
}

/// From the loop to the session: one tick.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Tick {
    /// Time since the loop started, s.
    pub now_s: f64,
    /// Position, m.
    pub x_m: f64,
    /// Velocity estimate, m/s.
    pub v_m_s: f64,
    /// Force sent, N.
    pub force_n: f64,
    /// Vibration drive sent.
    pub vibration: f64,
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
}

/// Who renders a tick's model.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Mode {
    /// The host's loop, commanding force over the link.
    Host,
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
    /// Starts the loop on the device at `path`, stepped by `step` (rate,
    /// force limit, velocity filter), asking for SCHED_FIFO when `fifo`.
    ///
    /// # Errors
    /// The thread could not be spawned.
    pub fn start(path: PathBuf, step: StepParams, fifo: bool) -> std::io::Result<Self> {
        let (to_loop, mut inbox) = rtrb::RingBuffer::<ToLoop>::new(256);
        let (mut outbox, from_loop) = rtrb::RingBuffer::<Tick>::new(16_384);
        let stop = Arc::new(AtomicBool::new(false));
        let flag = stop.clone();
        let origin = Instant::now();
        let handle = std::thread::Builder::new()
            .name("haptic-loop".into())
            .spawn(move || {
                let sched_fifo = fifo
                    && thread_priority::set_thread_priority_and_policy(
                        thread_priority::thread_native_id(),
                        thread_priority::ThreadPriority::Min,
                        thread_priority::ThreadSchedulePolicy::Realtime(
                            thread_priority::RealtimeThreadSchedulePolicy::Fifo,
                        ),
                    )
                    .is_ok();
                run(
                    &path,
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

/// What the loop knows of the device's on-board rendering.
struct OnBoardState {
    /// The session's render to render, and whether the device renders it.
    wanted: (u32, Option<ModelParams>),
    rendering: bool,
    /// Labels sent lately and the renders they stand for, newest first
    /// (a resend is not a new label).
    labels: [(u8, u32); LABELS],
    /// Resends of the wanted render so far.
    resends: u32,
    /// The render whose telemetry shows in effect on the device.
    device_render: u32,
    /// When the wanted render was last sent, if not yet in effect.
    sent_s: Option<f64>,
    /// Device tick and loop time of the first telemetry since connecting,
    /// and the last tick seen.
    anchor: Option<(u32, f64)>,
    last_tick: Option<u32>,
    last_now: f64,
    ticks: u64,
    gaps: u64,
}

impl OnBoardState {
    fn new() -> Self {
        OnBoardState {
            wanted: (0, None),
            rendering: false,
            labels: [(0, UNKNOWN_RENDER); LABELS],
            resends: 0,
            device_render: UNKNOWN_RENDER,
            sent_s: None,
            anchor: None,
            last_tick: None,
            last_now: 0.0,
            ticks: 0,
            gaps: 0,
        }
    }

    /// Whether the device renders `model` on board.
    fn renders(on_board: Option<OnBoard>, model: Option<&ModelParams>) -> bool {
        on_board.is_some_and(|o| {
            model.is_none_or(|m| {
                let kind = m.kind();
                kind > 0
                    && o.models & (1 << (kind - 1)) != 0
                    && f64::from(o.loop_rate_hz) >= m.loop_rate_hz()
            })
        })
    }

    /// Sends the wanted render to the device (upload and select, or clear)
    /// through `send`.
    #[expect(clippy::cast_possible_truncation, reason = "labels wrap by design")]
    fn send(&mut self, now_s: f64, model: Option<&ModelParams>, mut send: impl FnMut(Message)) {
        let render = self.wanted.0;
        let label = render as u8;
        if self.labels[0] == (label, render) {
            self.resends += 1;
        } else {
            self.labels.rotate_right(1);
            self.labels[0] = (label, render);
            self.resends = 0;
        }
        match model {
            Some(m) => frictionlab_core::onboard::upload(m, label, &mut send),
            None => send(Message::Clear { render: label }),
        }
        self.sent_s = Some(now_s);
    }

    /// Notes one telemetry: the render in effect, gaps, and its time on the
    /// loop's clock (device ticks from an anchor, never going back).
    fn observe(&mut self, t: &Telemetry, now_s: f64, dt: f64) -> f64 {
        if let Some(&(_, render)) = self.labels.iter().find(|(l, _)| *l == t.render) {
            self.device_render = render;
            if render == self.wanted.0 {
                self.sent_s = None;
            }
        } else {
            self.device_render = UNKNOWN_RENDER;
        }
        if let Some(last) = self.last_tick {
            self.gaps += u64::from(t.tick.wrapping_sub(last).saturating_sub(1));
        }
        self.last_tick = Some(t.tick);
        self.ticks += 1;
        let (tick0, t0) = *self.anchor.get_or_insert((t.tick, now_s));
        let mut at = t0 + f64::from(t.tick.wrapping_sub(tick0)) * dt;
        if (at - now_s).abs() > 0.1 {
            // Restarted or drifted: anchor afresh.
            self.anchor = Some((t.tick, now_s));
            at = now_s;
        }
        at = at.max(self.last_now);
        self.last_now = at;
        at
    }

    /// How long after the last send of the wanted render to resend it, s.
    fn resend_after(&self) -> f64 {
        RESEND_AFTER_S * f64::from(1_u32 << self.resends.min(3))
    }

    /// Forgets the device's state (a new connection).
    fn disconnected(&mut self) {
        self.labels = [(0, UNKNOWN_RENDER); LABELS];
        self.device_render = UNKNOWN_RENDER;
        self.anchor = None;
        self.last_tick = None;
        self.sent_s = None;
    }
}

/// Hands a tick to the session and, when publishing, its sample to the LSL
/// stream (a connected tick only).
fn emit(outbox: &mut rtrb::Producer<Tick>, lsl: Option<&crate::lsl::SampleTap>, tick: Tick) {
    if let Some(tap) = lsl
        && tick.link == LinkState::Connected
    {
        #[expect(
            clippy::cast_possible_truncation,
            reason = "the stream is float32, as LSL's float channels are"
        )]
        tap.push(
            tick.now_s,
            [
                tick.x_m as f32,
                tick.v_m_s as f32,
                tick.force_n as f32,
                tick.vibration as f32,
                tick.device_tick.map_or(0.0, |t| t as f32),
            ],
        );
    }
    let _ = outbox.push(tick);
}

/// The loop body; returns its statistics when `stop` is set.
#[expect(
    clippy::too_many_lines,
    reason = "one tick of the loop reads best in one place"
)]
fn run(
    path: &std::path::Path,
    step: StepParams,
    stop: &AtomicBool,
    inbox: &mut rtrb::Consumer<ToLoop>,
    outbox: &mut rtrb::Producer<Tick>,
    sched_fifo: bool,
    start: Instant,
) -> LoopStats {
    let mut transport = Transport::new(path);
    let mut link = Link::new();
    let (rate_hz, limit) = (step.rate_hz, step.force_limit);
    let period = Duration::from_secs_f64(step.dt());
    let dt = period.as_secs_f64();
    let alpha = step.velocity_alpha(dt);
    let mut histogram = vec![0_u32; BINS + 1];
    let (mut ticks, mut missed, mut max_late) = (0_u64, 0_u64, 0.0_f64);
    let mut renderer = Renderer::<f64>::new(limit, RAMP_S);
    let mut host_render = 0_u32;
    let mut host_selected = false;
    let mut device_watchdog = false;
    let mut board = OnBoardState::new();
    let mut was_connected = false;
    let mut telemetry: Vec<Telemetry> = Vec::with_capacity(64);
    let (mut x, mut x_prev, mut v, mut button) = (0.0_f64, None::<f64>, 0.0_f64, false);
    let mut bytes = [0_u8; 1024];
    let mut frame = [0_u8; MAX_FRAME];
    let mut deadline = Instant::now() + period;
    let mut lsl: Option<crate::lsl::SampleTap> = None;
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
        if late > 0.5e6 * dt {
            missed += 1;
        }
        deadline += period;
        if woke > deadline + period * 100 {
            deadline = woke + period; // Far behind (machine stalled): no burst of catch-up ticks.
        }
        ticks += 1;
        let now = woke.duration_since(start).as_secs_f64();
        let n = transport.read(&mut bytes);
        let mut write = |m: Message| {
            if let Ok(len) = encode(&m, &mut frame) {
                transport.write(&frame[..len]);
            }
        };

        // Device -> host.
        telemetry.clear();
        link.receive(now, &bytes[..n], |incoming| match incoming {
            Incoming::Sample(s) => {
                x = s.x_m;
                button = s.button;
                device_watchdog = s.status & status::WATCHDOG != 0;
            }
            Incoming::Telemetry(t) => {
                x = t.x_m;
                button = t.flags & status::BUTTON != 0;
                if telemetry.len() < telemetry.capacity() {
                    telemetry.push(t);
                }
            }
        });
        let link_state = link.state(now);
        let connected = link_state == LinkState::Connected;
        let on_board = link.on_board();
        let mut sent = false;
        if connected && !was_connected {
            // A new connection: the device has nothing of ours.
            board.disconnected();
            if on_board.is_some() {
                write(Message::SetTelemetry { every: 1 });
                board.rendering = OnBoardState::renders(on_board, board.wanted.1.as_ref());
                if board.rendering {
                    let wanted = board.wanted.1.clone();
                    board.send(now, wanted.as_ref(), &mut write);
                }
                sent = true;
            }
        }
        was_connected = connected;
        if connected {
            let raw = x_prev.map_or(0.0, |p| (x - p) / dt);
            v = crate::friction::filtered_velocity(alpha, v, raw);
            x_prev = Some(x);
        } else {
            x_prev = None;
            v = 0.0;
        }

        // Session -> loop.
        while let Ok(m) = inbox.pop() {
            match m {
                ToLoop::Model { render, model } => {
                    board.rendering = OnBoardState::renders(on_board, model.as_ref());
                    board.wanted = (render, model.clone());
                    if board.rendering {
                        renderer.select(None, x);
                    } else {
                        renderer.select(model.as_ref(), x);
                    }
                    host_render = render;
                    host_selected = true;
                    if connected && on_board.is_some() {
                        // On board: this model; host-rendered: nothing of
                        // the device's own.
                        board.send(now, model.as_ref().filter(|_| board.rendering), &mut write);
                        sent = true;
                    }
                }
                ToLoop::Device(message) => write(message),
                ToLoop::Publish(tap) => lsl = Some(tap),
            }
        }

        if board.rendering && on_board.is_some() {
            // The device renders: its telemetry are the ticks.
            let mode = Mode::OnBoard {
                rate_hz: on_board.map_or(0, |o| o.loop_rate_hz),
                float: if on_board.is_some_and(|o| o.float_bytes == 4) {
                    Float::F32
                } else {
                    Float::F64
                },
                #[expect(clippy::cast_possible_truncation, reason = "the wire's f32")]
                limit_n: link.capabilities().map_or(0.0, |c| c.max_force_n as f32),
            };
            let device_dt = 1.0 / f64::from(on_board.map_or(1, |o| o.loop_rate_hz.max(1)));
            for t in &telemetry {
                let at = board.observe(t, now, device_dt);
                emit(
                    outbox,
                    lsl.as_ref(),
                    Tick {
                        now_s: at,
                        x_m: t.x_m,
                        v_m_s: t.v_m_s,
                        force_n: t.force_n,
                        vibration: t.vibration,
                        button: t.flags & status::BUTTON != 0,
                        link: link_state,
                        render: board.device_render,
                        selected: t.flags & status::SELECTED != 0,
                        watchdog: t.flags & status::WATCHDOG != 0,
                        device_tick: Some(t.tick),
                        mode,
                    },
                );
            }
            // Resend only after this tick's telemetry is seen: after a stall
            // it may already show the select in effect.
            if connected
                && board
                    .sent_s
                    .is_some_and(|t| now - t >= board.resend_after())
            {
                let wanted = board.wanted.1.clone();
                board.send(now, wanted.as_ref(), &mut write);
                sent = true;
            }
            if let Some(m) = link.heartbeat(now, sent) {
                write(m);
            }
            if !connected {
                emit(
                    outbox,
                    lsl.as_ref(),
                    Tick {
                        now_s: now.max(board.last_now),
                        x_m: x,
                        v_m_s: 0.0,
                        force_n: 0.0,
                        vibration: 0.0,
                        button: false,
                        link: link_state,
                        render: UNKNOWN_RENDER,
                        selected: false,
                        watchdog: false,
                        device_tick: None,
                        mode,
                    },
                );
            }
            continue;
        }
        for t in &telemetry {
            board.observe(t, now, dt);
        }

        // Render on the host, crossfading after a model change.
        let out = renderer.step(dt, Input { x_m: x, v_m_s: v });
        let force = if connected { out.force_n } else { 0.0 };
        let vibration = out.vibration;
        if let Some(m) = link.transmit(now, force, vibration) {
            write(m);
        }
        emit(
            outbox,
            lsl.as_ref(),
            Tick {
                now_s: now.max(board.last_now),
                x_m: x,
                v_m_s: v,
                force_n: force,
                vibration,
                button,
                link: link_state,
                render: host_render,
                selected: std::mem::take(&mut host_selected),
                watchdog: device_watchdog,
                device_tick: None,
                mode: Mode::Host,
            },
        );
    }
    // Zero the force on the way out.
    if let Some(m) = link.transmit(start.elapsed().as_secs_f64(), 0.0, 0.0)
        && let Ok(len) = encode(&m, &mut frame)
    {
        transport.write(&frame[..len]);
    }
    let percentile = |q: f64| {
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
    let stats = link.stats();
    LoopStats {
        rate_hz,
        ticks,
        period_error_p50_us: percentile(0.5),
        period_error_p99_us: percentile(0.99),
        period_error_max_us: max_late,
        missed_deadlines: missed,
        crc_errors: stats.crc_errors,
        resyncs: stats.resyncs(),
        sched_fifo,
        on_board_ticks: (board.ticks > 0).then_some(board.ticks),
        telemetry_gaps: (board.ticks > 0).then_some(board.gaps),
        device_longest_loop_us: (board.ticks > 0).then(|| link.device_loop().longest_loop_us),
        device_missed_ticks: (board.ticks > 0).then(|| link.device_loop().missed_ticks),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn telemetry(tick: u32, render: u8) -> Telemetry {
        Telemetry {
            tick,
            x_m: 0.0,
            v_m_s: 0.0,
            force_n: 0.0,
            vibration: 0.0,
            render,
            flags: 0,
        }
    }

    /// Over a link that lags (QEMU's UART on a loaded machine lagged
    /// 200 ms), the loop resends a render the device has not yet shown in
    /// effect: ever less often, and without forgetting what the labels
    /// sent before it stand for.
    #[test]
    fn resends_back_off_and_keep_the_labels_sent_before() {
        let mut board = OnBoardState::new();
        let model = ModelParams::default_for("karnopp").unwrap();
        let mut sent = 0;
        board.wanted = (18, Some(model.clone()));
        board.send(0.0, Some(&model), |_| sent += 1);
        board.wanted = (19, None);
        board.send(0.01, None, |_| sent += 1);
        let mut waits = Vec::new();
        for k in 0..6 {
            waits.push(board.resend_after());
            board.send(0.1 * f64::from(k), None, |_| sent += 1);
        }
        assert_eq!(waits, [0.05, 0.1, 0.2, 0.4, 0.4, 0.4]);
        assert!(sent > 7);
        // The device still shows label 18, then takes 19.
        board.observe(&telemetry(1, 18), 0.6, 0.0002);
        assert_eq!(board.device_render, 18, "label 18 still means render 18");
        assert!(board.sent_s.is_some(), "19 not in effect yet");
        board.observe(&telemetry(2, 19), 0.6, 0.0002);
        assert_eq!((board.device_render, board.sent_s), (19, None));
        // A new render starts the backoff afresh.
        board.wanted = (20, None);
        board.send(0.7, None, |_| {});
        assert_eq!(board.resend_after(), 0.05);
    }
}
