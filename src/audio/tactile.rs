//! The tactile display on a sound output (issue 64): a model's vibrotactile
//! drive, sampled at the haptic loop's rate, played on one channel of an
//! output at its rate, to an amplifier and a tactor (seed 001: a piezo
//! bone-conduction speaker driven by 600 Hz bursts).
//!
//! The haptic loop hands each tick's drive, stamped with the loop's time,
//! to [`Feed::push`]: a push onto a wait-free ring ([`rtrb`]), never a
//! wait. The player's thread ([`TactileSource`]) reads the ring and plays
//! the drive at the output's rate at a play time that runs [`DELAY_S`]
//! behind the newest drive it has: a fixed delay, so every request of the
//! server finds the drive it needs already there.
//!
//! A carrier burst (seed 001's 600 Hz) is synthesised between ticks from
//! the tick's complex envelope and the render's carrier and decay
//! ([`crate::friction::ModelParams::burst`]): a 1 kHz loop (the Haply
//! Inverse3's) samples a 600 Hz carrier below its Nyquist rate, so
//! resampling the ticks would play its 400 Hz alias. At each tick's time
//! the output is the tick's drive exactly; the stream's `vibration`
//! column is what was played, at the ticks. Any other drive is
//! interpolated linearly between ticks. If the play time runs
//! past the drive (the loop stalled) the source plays silence and counts a
//! starvation; if the drive runs ahead by more than twice the delay (the
//! two clocks drifted, or the player stalled) the play time jumps to the
//! fixed delay again and counts a slip. Either is an underrun the session
//! treats as a broken stimulus.

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex, PoisonError};

use super::Source;

/// The drive's delay behind the loop, s: one 256-frame buffer at 48 kHz.
/// The server asks for at most a quarter of a buffer at a time, so the
/// drive a request needs is always there.
pub const DELAY_S: f64 = 256.0 / 48_000.0;

/// How many of the loop's periods a late tick may be waited for while
/// the last one plays on (its burst synthesised, or its drive held)
/// before the drive has run out: 2, so one tick late by up to a period
/// (the loop's own lateness under load) breaks nothing.
pub const GRACE_TICKS: f64 = 2.0;

/// The play time's error beyond which it jumps to where it should be (a
/// slip: the drive not played as sent), s: the tactor's buffer
/// ([`super::TACTILE_BUFFER_FRAMES`] at 48 kHz). The server asks for sound
/// in pieces of up to a quarter of it at uneven times, which moves the
/// error by that much and back; more is a stall.
pub const SLIP_S: f64 = 512.0 / 48_000.0;

/// The time over which a smaller error is taken up, s (at most 0.5 %
/// faster or slower: a 600 Hz carrier plays at most 3 Hz off meanwhile).
pub const CATCH_UP_S: f64 = 0.25;

/// The ring's size: 2 s of drive at 10 kHz, more than any loop runs.
const RING: usize = 20_000;

/// Counts the tactile path keeps, shared by the loop's side, the player's
/// thread and the shell.
#[derive(Debug, Default)]
pub struct Counts {
    /// Drive samples the ring had no room for.
    pub dropped: AtomicU64,
    /// Times the play time ran past the drive (silence played).
    pub starved: AtomicU64,
    /// Times the play time jumped back to the fixed delay.
    pub slips: AtomicU64,
    /// The loop's clock origin, once known: what the delays are measured
    /// against.
    pub origin: std::sync::OnceLock<std::time::Instant>,
    /// Each fill's delay from tick to output.
    pub delays: Delays,
}

/// A histogram of delays, 50 us bins up to 100 ms (and one beyond),
/// filled from the player's thread without allocating or waiting.
#[derive(Debug)]
pub struct Delays([AtomicU64; DELAY_BINS + 1]);

const DELAY_BINS: usize = 2000;
const DELAY_BIN_S: f64 = 50e-6;

impl Default for Delays {
    fn default() -> Self {
        Delays(std::array::from_fn(|_| AtomicU64::new(0)))
    }
}

impl Delays {
    fn add(&self, delay_s: f64) {
        #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
        let bin = ((delay_s.max(0.0) / DELAY_BIN_S) as usize).min(DELAY_BINS);
        self.0[bin].fetch_add(1, Ordering::Relaxed);
    }

    /// How many delays were recorded.
    #[must_use]
    pub fn count(&self) -> u64 {
        self.0.iter().map(|b| b.load(Ordering::Relaxed)).sum()
    }

    /// The delay below which a fraction `p` of them fell, s (the upper
    /// edge of its bin); `None` when none was recorded.
    #[must_use]
    pub fn quantile(&self, p: f64) -> Option<f64> {
        let n = self.count();
        if n == 0 {
            return None;
        }
        #[allow(
            clippy::cast_precision_loss,
            clippy::cast_possible_truncation,
            clippy::cast_sign_loss
        )]
        let rank = ((p * n as f64).ceil() as u64).clamp(1, n);
        let mut seen = 0;
        for (i, b) in self.0.iter().enumerate() {
            seen += b.load(Ordering::Relaxed);
            if seen >= rank {
                #[allow(clippy::cast_precision_loss)]
                return Some((i + 1) as f64 * DELAY_BIN_S);
            }
        }
        None
    }
}

impl Counts {
    /// Starvations and slips: the drive was not played as sent.
    #[must_use]
    pub fn broken(&self) -> u64 {
        self.starved.load(Ordering::SeqCst) + self.slips.load(Ordering::SeqCst)
    }
}

/// One tick's drive.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Drive {
    /// The loop's time, s.
    pub t_s: f64,
    /// The drive.
    pub v: f32,
    /// Its quadrature (a burst's).
    pub q: f32,
    /// The burst's carrier, Hz (0: no burst).
    pub hz: f32,
    /// The burst's envelope decay, 1/s.
    pub decay: f32,
}

impl Drive {
    const NONE: Drive = Drive {
        t_s: f64::NEG_INFINITY,
        v: 0.0,
        q: 0.0,
        hz: 0.0,
        decay: 0.0,
    };
}

/// The loop's side: where each tick's drive goes.
pub struct Feed {
    ring: Mutex<Producer>,
    counts: Arc<Counts>,
}

/// The loop's side of a ring.
pub type Producer = rtrb::Producer<Drive>;

impl Feed {
    /// The loop's side of `producer`'s ring, counting into `counts`.
    #[must_use]
    pub fn new(producer: Producer, counts: Arc<Counts>) -> Feed {
        Feed {
            ring: Mutex::new(producer),
            counts,
        }
    }

    /// Feeds a new ring from now on (a player opened again).
    pub fn replace(&self, producer: Producer) {
        *self.ring.lock().unwrap_or_else(PoisonError::into_inner) = producer;
    }

    /// Hands the drive `v` (and its quadrature `q`, of a `burst`: carrier
    /// Hz and decay 1/s) at loop time `t_s` (never before the last) to the
    /// player. Never waits: the lock is taken by the loop's thread, and by
    /// the shell only to swap rings after a reopening; a ring busy or full
    /// drops the sample (counted).
    pub fn push(&self, t_s: f64, v: f64, q: f64, burst: Option<(f64, f64)>) {
        let Ok(mut ring) = self.ring.try_lock() else {
            self.counts.dropped.fetch_add(1, Ordering::Relaxed);
            return;
        };
        let (hz, decay) = burst.unwrap_or((0.0, 0.0));
        #[allow(clippy::cast_possible_truncation)]
        let sample = Drive {
            t_s,
            v: v.clamp(-1.0, 1.0) as f32,
            q: q.clamp(-1.0, 1.0) as f32,
            hz: hz as f32,
            decay: decay as f32,
        };
        if ring.push(sample).is_err() {
            self.counts.dropped.fetch_add(1, Ordering::Relaxed);
        }
    }
}

/// The player's side: see the module docs.
pub struct TactileSource {
    ring: rtrb::Consumer<Drive>,
    counts: Arc<Counts>,
    /// The output's channel the drive plays on (0-based).
    channel: usize,
    rate_hz: f64,
    /// The loop time of the next output frame; `None` until anchored.
    play_s: Option<f64>,
    /// The last drive at or before the play time.
    current: Drive,
    /// The loop's period, s, from its last two ticks.
    period_s: f64,
    /// The server's latency for the stream, microseconds, as it last
    /// reported ([`Source::latency`]).
    server_latency_us: u64,
    /// The ramp down at the end: the gain, and its step per frame.
    gain: f32,
    ramp_step: f32,
}

/// A ring and the source that plays from it on channel `channel` at
/// `rate_hz`, counting into `counts`; the ring's other end for a
/// [`Feed`].
#[must_use]
pub fn source(channel: usize, rate_hz: f64, counts: &Arc<Counts>) -> (Producer, TactileSource) {
    let (producer, consumer) = rtrb::RingBuffer::new(RING);
    #[allow(clippy::cast_possible_truncation)]
    let ramp_step = (1.0 / (super::noise::RAMP_S * rate_hz)) as f32;
    (
        producer,
        TactileSource {
            ring: consumer,
            counts: counts.clone(),
            channel,
            rate_hz,
            play_s: None,
            current: Drive::NONE,
            period_s: 0.0,
            server_latency_us: 0,
            gain: 1.0,
            ramp_step,
        },
    )
}

impl TactileSource {
    /// The newest drive's time in the ring, if any (not taken).
    fn newest(&mut self) -> Option<f64> {
        let n = self.ring.slots();
        let chunk = self.ring.read_chunk(n).ok()?;
        let (a, b) = chunk.as_slices();
        b.last().or(a.last()).map(|d| d.t_s)
    }

    /// The drive at loop time `t`: the ring read up to it, then the burst
    /// synthesised from the last tick, or linear to the next (the last
    /// held, for at most [`GRACE_TICKS`] of the loop's periods, when the
    /// next is late). `None`: no drive that late.
    fn drive_at(&mut self, t: f64) -> Option<f32> {
        while let Ok(&next) = self.ring.peek() {
            if next.t_s > t {
                break;
            }
            let _ = self.ring.pop();
            // A tick at the same time as the last (the loop's clock held
            // its ticks' times from going back) says nothing of its period.
            let interval = next.t_s - self.current.t_s;
            if interval.is_finite() && interval > 0.0 {
                self.period_s = interval;
            }
            self.current = next;
        }
        let c = self.current;
        let next = self.ring.peek().ok().copied();
        let dt = t - c.t_s;
        if !dt.is_finite() {
            // Before the loop's first tick: its drive held.
            return next.map(|n| n.v);
        }
        if next.is_none() && dt > GRACE_TICKS * self.period_s {
            return None;
        }
        if c.hz > 0.0 {
            let theta = std::f64::consts::TAU * f64::from(c.hz) * dt;
            let a = (-f64::from(c.decay) * dt).exp();
            let v = a * (f64::from(c.q) * theta.sin() + f64::from(c.v) * theta.cos());
            #[allow(clippy::cast_possible_truncation)]
            return Some(v.clamp(-1.0, 1.0) as f32);
        }
        Some(next.map_or(c.v, |n| {
            #[allow(clippy::cast_possible_truncation)]
            let w = (dt / (n.t_s - c.t_s)).clamp(0.0, 1.0) as f32;
            c.v + (n.v - c.v) * w
        }))
    }

    /// Records this fill's delay from tick to output: how far the play
    /// time is behind the loop's clock now, plus the server's latency.
    fn record_delay(&self, play_s: f64) {
        let Some(origin) = self.counts.origin.get() else {
            return;
        };
        let behind = origin.elapsed().as_secs_f64() - play_s;
        #[allow(clippy::cast_precision_loss)]
        let total = behind + self.server_latency_us as f64 * 1e-6;
        self.counts.delays.add(total);
    }
}

impl Source for TactileSource {
    fn fill(&mut self, out: &mut [f32], channels: usize, ending: bool) {
        out.fill(0.0);
        if ending && self.play_s.is_none() {
            // Silent already: nothing to ramp down.
            self.gain = 0.0;
        }
        let channels = channels.max(1);
        let frames = out.len() / channels;
        // The newest drive: in the ring, or (the ring read empty) the one
        // held, while anchored. Not anchored and nothing new: silence.
        let newest = match (self.newest(), self.play_s) {
            (Some(n), _) => n,
            (None, Some(_)) => self.current.t_s,
            (None, None) => return,
        };
        // Ending, the loop may have stopped first: silence then is the
        // end, not a stimulus broken.
        let count = !ending;
        // Where the play time should be: DELAY_S behind the loop's clock
        // now, once the loop's origin is known. Small errors (the
        // server's requests come in uneven pieces; the two clocks drift)
        // are taken up by playing up to 0.5 % faster or slower; a larger
        // one is a slip. Without the loop's clock (a test feeding its own
        // times), DELAY_S behind the newest drive when anchored, and a
        // slip only when the drive runs twice that ahead.
        let origin = self.counts.origin.get();
        let target = origin.map_or(newest, |o| o.elapsed().as_secs_f64()) - DELAY_S;
        let (play, rate_scale) = match (self.play_s, origin) {
            (None, _) => (target, 1.0),
            (Some(p), Some(_)) if (target - p).abs() > SLIP_S => {
                self.counts.slips.fetch_add(1, Ordering::SeqCst);
                (target, 1.0)
            }
            (Some(p), Some(_)) => (p, 1.0 + ((target - p) / CATCH_UP_S).clamp(-0.005, 0.005)),
            (Some(p), None) if newest - p > 2.0 * DELAY_S => {
                self.counts.slips.fetch_add(1, Ordering::SeqCst);
                (target, 1.0)
            }
            (Some(p), None) => (p, 1.0),
        };
        self.record_delay(play);
        let step = rate_scale / self.rate_hz;
        let channel = self.channel.min(channels - 1);
        let mut starved = false;
        for i in 0..frames {
            #[allow(clippy::cast_precision_loss)]
            let t = play + i as f64 * step;
            let Some(v) = self.drive_at(t) else {
                starved = true;
                break;
            };
            if ending {
                self.gain = (self.gain - self.ramp_step).max(0.0);
            }
            out[i * channels + channel] = v * self.gain;
        }
        if starved {
            if count {
                self.counts.starved.fetch_add(1, Ordering::SeqCst);
            }
            self.play_s = None;
            if ending {
                self.gain = 0.0;
            }
        } else {
            #[allow(clippy::cast_precision_loss)]
            let next = play + frames as f64 * step;
            self.play_s = Some(next);
        }
    }

    fn finished(&self) -> bool {
        self.gain == 0.0
    }

    fn latency(&mut self, latency_us: u64) {
        self.server_latency_us = latency_us;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tactile(channel: usize, rate_hz: f64) -> (Feed, TactileSource, Arc<Counts>) {
        let counts = Arc::new(Counts::default());
        let (producer, source) = source(channel, rate_hz, &counts);
        (Feed::new(producer, counts.clone()), source, counts)
    }

    /// A 600 Hz burst sampled at 5 kHz, fed in the loop's pieces and
    /// played in the server's, comes out at 48 kHz `DELAY_S` late.
    #[test]
    fn the_drive_plays_resampled_at_the_fixed_delay() {
        let (feed, mut source, counts) = tactile(1, 48_000.0);
        let loop_hz = 5000.0;
        let drive = |t: f64| (2.0 * std::f64::consts::PI * 600.0 * t).sin() * 0.5;
        let mut tick = 0u32;
        let mut out = vec![0.0f32; 64 * 2];
        let mut played: Vec<f32> = Vec::new();
        let mut first: Option<f64> = None;
        // 1 s in 64-frame requests, the loop running ahead of each.
        for r in 0..750u32 {
            let now = f64::from(r + 1) * 64.0 / 48_000.0;
            while f64::from(tick) / loop_hz <= now {
                let t = f64::from(tick) / loop_hz;
                feed.push(t, drive(t), 0.0, None);
                tick += 1;
            }
            if first.is_none() {
                first = source.newest().map(|n| n - DELAY_S);
            }
            source.fill(&mut out, 2, false);
            played.extend(out.chunks(2).map(|f| {
                assert_eq!(f[0], 0.0, "only channel 2 plays");
                f[1]
            }));
        }
        assert_eq!(counts.broken(), 0);
        assert_eq!(counts.dropped.load(Ordering::SeqCst), 0);
        let t0 = first.unwrap();
        let worst = played
            .iter()
            .enumerate()
            .map(|(i, &v)| (t0 + i as f64 / 48_000.0, v))
            // Before the loop's first tick the first drive is held.
            .filter(|&(t, _)| t >= 0.0)
            .map(|(t, v)| (f64::from(v) - drive(t)).abs())
            .fold(0.0, f64::max);
        // Linear interpolation of 600 Hz at 5 kHz: error at most
        // (w dt)^2 / 8 of the amplitude, 0.071 x 0.5.
        assert!(worst < 0.04, "largest error {worst}");
    }

    /// Seed 001's burst on a 1 kHz loop (the Inverse3's): the ticks
    /// sample its 600 Hz carrier below their Nyquist rate, but the output
    /// is the burst itself, synthesised between ticks.
    #[test]
    fn a_burst_on_a_1_khz_loop_plays_at_its_carrier_not_its_alias() {
        let (feed, mut source, counts) = tactile(0, 48_000.0);
        let (hz, decay) = (600.0, 1.0 / 0.08);
        let burst = |t: f64| (-decay * t).exp() * (std::f64::consts::TAU * hz * t).sin();
        let quad = |t: f64| (-decay * t).exp() * (std::f64::consts::TAU * hz * t).cos();
        let mut played = Vec::new();
        let mut out = vec![0.0f32; 48];
        let mut tick = 0u32;
        let mut t0 = None;
        for r in 0..200u32 {
            let now = f64::from(r + 1) * 48.0 / 48_000.0;
            while f64::from(tick) / 1000.0 <= now {
                let t = f64::from(tick) / 1000.0;
                feed.push(t, burst(t), quad(t), Some((hz, decay)));
                tick += 1;
            }
            if t0.is_none() {
                t0 = source.newest().map(|n| n - DELAY_S);
            }
            source.fill(&mut out, 1, false);
            played.extend_from_slice(&out);
        }
        assert_eq!(counts.broken(), 0);
        let t0 = t0.unwrap();
        let worst = played
            .iter()
            .enumerate()
            .map(|(i, &v)| (t0 + i as f64 / 48_000.0, v))
            .filter(|&(t, _)| t >= 0.0)
            .map(|(t, v)| (f64::from(v) - burst(t)).abs())
            .fold(0.0, f64::max);
        assert!(worst < 1e-4, "largest error {worst}");
    }

    #[test]
    fn a_stalled_loop_plays_silence_and_counts_it() {
        let (feed, mut source, counts) = tactile(0, 48_000.0);
        for i in 0..100 {
            feed.push(f64::from(i) / 5000.0, 1.0, 0.0, None);
        }
        let mut out = vec![0.0f32; 64];
        source.fill(&mut out, 1, false);
        assert!(out.iter().all(|&v| v == 1.0));
        // The loop stops: the fixed delay runs out, then silence.
        for _ in 0..10 {
            source.fill(&mut out, 1, false);
        }
        assert!(out.iter().all(|&v| v == 0.0));
        assert_eq!(counts.starved.load(Ordering::SeqCst), 1);
    }
}
