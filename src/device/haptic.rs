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

use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use super::link::{Link, LinkState};
use super::transport::Transport;
use super::wire::{MAX_FRAME, Message, encode};
use crate::friction::{Friction, Input, ModelParams, StepParams};

/// Crossfade time between models, s.
pub const RAMP_S: f64 = 0.050;

/// From the session to the loop.
#[derive(Debug, Clone, PartialEq)]
pub enum ToLoop {
    /// Render this model from now on (crossfaded), or nothing.
    Model(Option<ModelParams>),
    /// Forward this message to the device (the emulator's hand drive).
    Device(Message),
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
}

/// A running haptic loop.
pub struct HapticLoop {
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
                run(&path, step, &flag, &mut inbox, &mut outbox, sched_fifo)
            })?;
        Ok(HapticLoop {
            to_loop,
            from_loop,
            stop,
            handle: Some(handle),
        })
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
) -> LoopStats {
    let mut transport = Transport::new(path);
    let mut link = Link::new();
    let (rate_hz, limit) = (step.rate_hz, step.force_limit);
    let period = Duration::from_secs_f64(step.dt());
    let dt = period.as_secs_f64();
    let alpha = step.velocity_alpha(dt);
    let mut histogram = vec![0_u32; BINS + 1];
    let (mut ticks, mut missed, mut max_late) = (0_u64, 0_u64, 0.0_f64);
    let (mut current, mut previous): (Option<Friction>, Option<Friction>) = (None, None);
    let mut ramp = 1.0_f64;
    let (mut x, mut x_prev, mut v, mut button) = (0.0_f64, None::<f64>, 0.0_f64, false);
    let mut bytes = [0_u8; 1024];
    let mut frame = [0_u8; MAX_FRAME];
    let start = Instant::now();
    let mut deadline = start + period;
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

        // Device -> host.
        let n = transport.read(&mut bytes);
        link.receive(now, &bytes[..n], |s| {
            x = s.x_m;
            button = s.button;
        });
        let connected = link.state(now) == LinkState::Connected;
        if connected {
            let raw = x_prev.map_or(0.0, |p| (x - p) / dt);
            v = alpha * v + (1.0 - alpha) * raw;
            x_prev = Some(x);
        } else {
            x_prev = None;
            v = 0.0;
        }

        // Session -> loop.
        while let Ok(m) = inbox.pop() {
            match m {
                ToLoop::Model(params) => {
                    previous = current.take();
                    current = params.and_then(|p| Friction::new(&p, limit, x).ok());
                    ramp = 0.0;
                }
                ToLoop::Device(message) => {
                    if let Ok(len) = encode(&message, &mut frame) {
                        transport.write(&frame[..len]);
                    }
                }
            }
        }

        // Render, crossfading after a model change.
        let input = Input { x_m: x, v_m_s: v };
        let now_out = current.as_mut().map(|f| f.step(dt, input));
        let old_out = if ramp < 1.0 {
            previous.as_mut().map(|f| f.step(dt, input))
        } else {
            None
        };
        ramp = (ramp + dt / RAMP_S).min(1.0);
        let force = if connected {
            let new = now_out.map_or(0.0, |o| o.force_n);
            let old = old_out.map_or(0.0, |o| o.force_n);
            limit.clamp(ramp * new + (1.0 - ramp) * old)
        } else {
            0.0
        };
        let vibration = now_out.map_or(0.0, |o| o.vibration) * ramp;
        if let Some(m) = link.transmit(now, force, vibration)
            && let Ok(len) = encode(&m, &mut frame)
        {
            transport.write(&frame[..len]);
        }
        let _ = outbox.push(Tick {
            now_s: now,
            x_m: x,
            v_m_s: v,
            force_n: force,
            vibration,
            button,
            link: link.state(now),
        });
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
    }
}
