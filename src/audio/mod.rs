//! Sound output (issue 64): the outputs of the sound server, and players
//! that play a [`Source`] on one of them. Seed 001's apparatus plays
//! masking noise on headphones ([`noise`]).
//!
//! The server is PulseAudio or PipeWire's pulse server, spoken to by
//! [`pulse`] (pure Rust, so building needs no system package). A shell
//! opens a player before a session starts, so a missing server or output
//! is an error before anything is written, and watches it during the
//! session ([`Masker::lost`], [`Masker::underruns`]).

// The players: PulseAudio's protocol on Linux (and the other Unixes),
// cpal on macOS and Windows; elsewhere no server is found.
#[cfg(any(target_os = "macos", windows))]
#[path = "cpal.rs"]
pub mod backend;
#[cfg(not(any(unix, windows)))]
#[path = "none.rs"]
pub mod backend;
#[cfg(all(unix, not(target_os = "macos")))]
#[path = "pulse.rs"]
pub mod backend;
pub mod noise;
pub mod tactile;
pub mod tone;

use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex, MutexGuard, PoisonError};

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

/// The buffer a player asks the server for, frames at 48 kHz: 5.3 ms.
pub const BUFFER_FRAMES: u32 = 256;

/// The tactile display's buffer, frames at 48 kHz: 10.7 ms. With 256
/// frames (5.3 ms) PulseAudio's null sink ran dry about once every 2 s
/// beside one busy core (38 underruns in a 71 s session, and 3 in 16 s on
/// an idle machine), even with the server's threads at real-time
/// priority: this client speaks to the server's main thread over its
/// socket (no shared-memory channel to the sink's thread). With 512, none
/// ran dry (issue 64's note).
pub const TACTILE_BUFFER_FRAMES: u32 = 512;

/// A player's thread, as its owner holds it (every backend's).
pub(crate) struct Worker(Mutex<Option<std::thread::JoinHandle<()>>>);

impl Worker {
    pub(crate) fn new(thread: std::thread::JoinHandle<()>) -> Worker {
        Worker(Mutex::new(Some(thread)))
    }

    /// Whether the thread has ended.
    pub(crate) fn done(&self) -> bool {
        self.0
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .as_ref()
            .is_none_or(std::thread::JoinHandle::is_finished)
    }

    /// Waits until the thread has ended by itself, at most `most_s`.
    pub(crate) fn wait(&self, most_s: f64) {
        let started = std::time::Instant::now();
        while started.elapsed().as_secs_f64() < most_s && !self.done() {
            std::thread::sleep(std::time::Duration::from_millis(5));
        }
    }

    /// Joins the thread (once told to stop).
    pub(crate) fn join(&self) {
        let thread = self.0.lock().unwrap_or_else(PoisonError::into_inner).take();
        if let Some(t) = thread {
            let _ = t.join();
        }
    }
}

/// The sound server to play on: PulseAudio's or PipeWire's socket, as the
/// environment names it (`PULSE_SERVER`, `PULSE_RUNTIME_PATH`,
/// `XDG_RUNTIME_DIR`: [`Server::from_env`]), or a socket and cookie given
/// ([`Server::at`]: a test's own server).
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Server {
    pub(crate) socket: Option<std::path::PathBuf>,
    /// The file of the cookie that authenticates a client (default: as
    /// the environment has it, `PULSE_COOKIE` or the user's).
    pub(crate) cookie: Option<std::path::PathBuf>,
}

impl Server {
    /// The server the environment names.
    #[must_use]
    pub fn from_env() -> Server {
        Server::default()
    }

    /// The server listening on the Unix socket `socket`, its clients
    /// authenticated by the cookie in the file `cookie`.
    #[must_use]
    pub fn at(socket: std::path::PathBuf, cookie: std::path::PathBuf) -> Server {
        Server {
            socket: Some(socket),
            cookie: Some(cookie),
        }
    }

    /// The server's outputs.
    ///
    /// # Errors
    /// No sound server, or it did not answer.
    pub fn outputs(&self) -> Result<Vec<Output>, AudioError> {
        backend::list(self)
    }
}

/// An output of the sound server (a PulseAudio sink).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Output {
    /// Its name, as `--masking-audio` takes it.
    pub name: String,
    /// Channels.
    pub channels: usize,
    /// Its sample rate, Hz.
    pub rate_hz: u32,
    /// What the server calls it.
    pub description: String,
}

/// What went wrong with sound.
#[derive(Debug, thiserror::Error)]
pub enum AudioError {
    /// No sound server answers.
    #[error("no sound server: {0}")]
    NoServer(String),
    /// The server has no such output.
    #[error("no output '{output}' on the sound server (it has: {})", if known.is_empty() { "none".to_owned() } else { known.join(", ") })]
    NoSuchOutput {
        /// The output asked for.
        output: String,
        /// Those it has.
        known: Vec<String>,
    },
    /// The server refused or broke off.
    #[error("sound server: {0}")]
    Server(String),
}

/// What a stream turned out to be, for the log's header.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct StreamInfo {
    /// The output.
    pub output: String,
    /// Its channels.
    pub channels: usize,
    /// The stream's rate, Hz.
    pub rate_hz: u32,
    /// The server's buffer for the stream, frames.
    pub buffer_frames: u32,
    /// The latency the server reported when the stream opened: its
    /// output's latency plus the stream's buffer, s.
    pub latency_s: f64,
}

/// What an output plays in a session.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "lowercase")]
pub enum Role {
    /// The protocol's masking noise.
    Masking,
    /// The tactile display: the models' vibrotactile drive.
    Tactile,
}

/// A stream a session played, as its log's header records it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct Playing {
    /// What it played.
    pub role: Role,
    /// The channel it played on, from 1 (the tactile display); every
    /// channel when absent.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub channel: Option<usize>,
    /// The stream.
    #[serde(flatten)]
    pub stream: StreamInfo,
}

/// How a session's sound went, for the log's last lines (`sound`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct SoundStats {
    /// One entry per stream.
    pub streams: Vec<StreamStats>,
}

/// How one stream went.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct StreamStats {
    /// What it played.
    pub role: Role,
    /// The output.
    pub output: String,
    /// Underruns over the run: the server's, and for the tactile display
    /// the drive not played as sent.
    pub underruns: u64,
    /// The tactile display's underruns by cause: the server ran dry, the
    /// loop's drive ran out, the play time slipped.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub underrun_causes: Option<[u64; 3]>,
    /// The tactile display: the delay from a haptic tick to the output,
    /// median and 99th percentile over every buffer, s.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub delay_p50_s: Option<f64>,
    /// See `delay_p50_s`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub delay_p99_s: Option<f64>,
    /// The tactile display: the haptic loop's clock origin (session time
    /// 0 of a device session) on the system's monotonic clock
    /// (`CLOCK_MONOTONIC`, LSL's clock, what `parec`'s timestamps are on),
    /// s: a recording of the output aligns with the session's streams.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub clock_origin_monotonic_s: Option<f64>,
}

/// What a player plays: filled on the player's thread, which is the
/// stream's callback. `fill` must never block or allocate.
pub trait Source: Send + 'static {
    /// Fills `out`, `channels` samples interleaved per frame, full scale
    /// ±1. `ending`: the player is finishing; ramp down.
    fn fill(&mut self, out: &mut [f32], channels: usize, ending: bool);
    /// Whether, ending, the source has gone silent (the stream may drain).
    fn finished(&self) -> bool;
    /// Whether it ends by itself (a test tone): once [`Source::finished`],
    /// the stream drains and closes unasked.
    fn ends(&self) -> bool {
        false
    }
    /// The server's latency for the stream as it last reported,
    /// microseconds: the queue ahead of what is filled now.
    fn latency(&mut self, _latency_us: u64) {}
}

/// Noise of a color at a level.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "lowercase")]
pub enum NoiseColor {
    /// 3 dB per octave down (seed 001).
    Pink,
    /// Flat.
    White,
}

/// When masking noise plays.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "lowercase")]
pub enum During {
    /// From the session's start to its end (breaks too).
    #[default]
    Session,
    /// During each trial only.
    Trials,
}

fn default_level() -> f64 {
    -20.0
}

/// A protocol's masking noise: `{"noise": "pink", "level_dbfs": -20,
/// "during": "session"}`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Masking {
    /// Pink or white.
    pub noise: NoiseColor,
    /// RMS level, dBFS, from -80 to the ceiling, -12 (default -20).
    #[serde(default = "default_level")]
    pub level_dbfs: f64,
    /// The whole session, or trials only (default: session).
    #[serde(default)]
    pub during: During,
}

/// Masking noise, gated by its shell.
struct Gated {
    noise: noise::Masking,
    gate: Arc<AtomicBool>,
}

impl Source for Gated {
    fn fill(&mut self, out: &mut [f32], channels: usize, ending: bool) {
        self.noise
            .set_on(self.gate.load(Ordering::Relaxed) && !ending);
        self.noise.fill(out, channels);
    }

    fn finished(&self) -> bool {
        self.noise.silent()
    }
}

/// A player on an output that can be opened again after it was lost (the
/// server restarted, the output replugged).
struct Held {
    server: Server,
    output: String,
    buffer_frames: u32,
    player: Mutex<backend::Player>,
    /// Underruns of the players before this one.
    carried: AtomicU64,
}

impl Held {
    fn open(
        server: &Server,
        output: &str,
        buffer_frames: u32,
        source: Box<dyn Source>,
    ) -> Result<Held, AudioError> {
        Ok(Held {
            server: server.clone(),
            output: output.to_owned(),
            buffer_frames,
            player: Mutex::new(backend::Player::open(
                server,
                output,
                buffer_frames,
                source,
            )?),
            carried: AtomicU64::new(0),
        })
    }

    fn player(&self) -> MutexGuard<'_, backend::Player> {
        self.player.lock().unwrap_or_else(PoisonError::into_inner)
    }

    /// Opens the output again with `source`, in place of the lost player.
    fn reopen(&self, source: Box<dyn Source>) -> Result<(), AudioError> {
        let fresh = backend::Player::open(&self.server, &self.output, self.buffer_frames, source)?;
        let old = std::mem::replace(&mut *self.player(), fresh);
        self.carried.fetch_add(
            old.shared.underruns.load(Ordering::SeqCst),
            Ordering::SeqCst,
        );
        Ok(())
    }

    fn underruns(&self) -> u64 {
        self.carried.load(Ordering::SeqCst) + self.player().shared.underruns.load(Ordering::SeqCst)
    }

    fn lost(&self) -> bool {
        self.player().shared.lost.load(Ordering::SeqCst)
    }

    fn info(&self) -> StreamInfo {
        self.player().info.clone()
    }

    fn finish(&self) {
        self.player().finish();
    }
}

/// Masking noise playing on an output: on and off with ramps at its
/// shell's word.
pub struct Masker {
    held: Held,
    gate: Arc<AtomicBool>,
    masking: Masking,
    seed: u64,
}

impl Masker {
    fn source(masking: Masking, seed: u64, gate: &Arc<AtomicBool>) -> Box<dyn Source> {
        let color = match masking.noise {
            NoiseColor::Pink => noise::Color::Pink,
            NoiseColor::White => noise::Color::White,
        };
        Box::new(Gated {
            noise: noise::Masking::new(
                color,
                masking.level_dbfs,
                f64::from(backend::RATE_HZ),
                seed,
            ),
            gate: gate.clone(),
        })
    }

    /// Opens `output` of `server` for `masking` (off until
    /// [`Masker::set_on`]), its noise seeded by `seed`.
    ///
    /// # Errors
    /// No sound server, no such output, or the stream refused.
    pub fn open(
        server: &Server,
        output: &str,
        masking: Masking,
        seed: u64,
    ) -> Result<Masker, AudioError> {
        let gate = Arc::new(AtomicBool::new(false));
        // A longer buffer than the tactor's: noise needs no low latency.
        let held = Held::open(
            server,
            output,
            BUFFER_FRAMES * 8,
            Self::source(masking, seed, &gate),
        )?;
        Ok(Masker {
            held,
            gate,
            masking,
            seed,
        })
    }

    /// What it plays.
    #[must_use]
    pub fn masking(&self) -> Masking {
        self.masking
    }

    /// Noise on (ramping up) or off (ramping down).
    pub fn set_on(&self, on: bool) {
        self.gate.store(on, Ordering::Relaxed);
    }

    /// Underruns so far (over every reopening).
    #[must_use]
    pub fn underruns(&self) -> u64 {
        self.held.underruns()
    }

    /// Whether the output or its server is gone.
    #[must_use]
    pub fn lost(&self) -> bool {
        self.held.lost()
    }

    /// Opens the output again after it was lost.
    ///
    /// # Errors
    /// As [`Masker::open`].
    pub fn reopen(&self) -> Result<(), AudioError> {
        self.held.reopen(Self::source(
            self.masking,
            self.seed ^ self.underruns(),
            &self.gate,
        ))
    }

    /// Ramps down, plays out what is buffered and closes (at once if
    /// lost).
    pub fn finish(&self) {
        self.held.finish();
    }

    /// How it went.
    #[must_use]
    pub fn stats(&self) -> StreamStats {
        StreamStats {
            role: Role::Masking,
            output: self.held.output.clone(),
            underruns: self.underruns(),
            underrun_causes: None,
            delay_p50_s: None,
            delay_p99_s: None,
            clock_origin_monotonic_s: None,
        }
    }

    /// What the log's header keeps of it.
    #[must_use]
    pub fn playing(&self) -> Playing {
        Playing {
            role: Role::Masking,
            channel: None,
            stream: self.held.info(),
        }
    }
}

impl std::fmt::Debug for Masker {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Masker")
            .field("masking", &self.masking)
            .field("output", &self.held.output)
            .finish_non_exhaustive()
    }
}

/// `OUTPUT[:CHANNEL]`, the channel counted from 1 (default 1): the
/// output's name and the 0-based channel.
///
/// # Errors
/// A channel that is not a whole number from 1.
pub fn output_and_channel(text: &str) -> Result<(String, usize), String> {
    match text.rsplit_once(':') {
        Some((output, channel)) if !output.is_empty() => match channel.parse::<usize>() {
            Ok(c) if c >= 1 => Ok((output.to_owned(), c - 1)),
            _ => Err(format!(
                "'{channel}' is not a channel (1 for the first, as in OUTPUT:1)"
            )),
        },
        _ => Ok((text.to_owned(), 0)),
    }
}

/// The tactile display on one channel of an output: the haptic loop's
/// drive, resampled and played at a fixed delay ([`tactile`]).
pub struct Tactor {
    held: Held,
    feed: tactile::Feed,
    counts: Arc<tactile::Counts>,
    channel: usize,
}

impl Tactor {
    /// Opens channel `channel` (0-based) of `output` of `server`.
    ///
    /// # Errors
    /// No sound server, no such output or channel, or the stream refused.
    pub fn open(server: &Server, output: &str, channel: usize) -> Result<Tactor, AudioError> {
        Self::open_with(server, output, channel, TACTILE_BUFFER_FRAMES)
    }

    /// As [`Tactor::open`], with a buffer of `buffer_frames` (the
    /// benchmark's comparison of buffers).
    ///
    /// # Errors
    /// As [`Tactor::open`].
    pub fn open_with(
        server: &Server,
        output: &str,
        channel: usize,
        buffer_frames: u32,
    ) -> Result<Tactor, AudioError> {
        let counts = Arc::new(tactile::Counts::default());
        let (producer, source) = tactile::source(channel, f64::from(backend::RATE_HZ), &counts);
        let held = Held::open(server, output, buffer_frames, Box::new(source))?;
        let channels = held.info().channels;
        if channel >= channels {
            return Err(AudioError::Server(format!(
                "output '{output}' has {channels} channels; channel {} was asked for",
                channel + 1
            )));
        }
        Ok(Tactor {
            held,
            feed: tactile::Feed::new(producer, counts.clone()),
            counts,
            channel,
        })
    }

    /// Hands the drive `v` at loop time `t_s` (its quadrature `q`, of a
    /// `burst`: [`tactile::Feed::push`]) to the player: from the loop's
    /// thread, never waiting.
    pub fn push(&self, t_s: f64, v: f64, q: f64, burst: Option<(f64, f64)>) {
        self.feed.push(t_s, v, q, burst);
    }

    /// Underruns so far: the server's, and the drive not played as sent
    /// (the loop stalled, or the clocks slipped).
    #[must_use]
    pub fn underruns(&self) -> u64 {
        let [server, starved, slips] = self.underrun_parts();
        server + starved + slips
    }

    /// Underruns so far by cause: the server ran dry; the loop's drive ran
    /// out (the loop stalled); the play time jumped (the clocks slipped).
    #[must_use]
    pub fn underrun_parts(&self) -> [u64; 3] {
        [
            self.held.underruns(),
            self.counts.starved.load(Ordering::SeqCst),
            self.counts.slips.load(Ordering::SeqCst),
        ]
    }

    /// Whether the output or its server is gone.
    #[must_use]
    pub fn lost(&self) -> bool {
        self.held.lost()
    }

    /// Opens the output again after it was lost: a new ring between the
    /// loop's side and the new player.
    ///
    /// # Errors
    /// As [`Tactor::open`].
    pub fn reopen(&self) -> Result<(), AudioError> {
        let (producer, source) =
            tactile::source(self.channel, f64::from(backend::RATE_HZ), &self.counts);
        self.held.reopen(Box::new(source))?;
        self.feed.replace(producer);
        Ok(())
    }

    /// What the log's header keeps of it: its latency is the server's
    /// plus the fixed delay behind the loop ([`tactile::DELAY_S`]).
    #[must_use]
    pub fn playing(&self) -> Playing {
        let mut stream = self.held.info();
        stream.latency_s += tactile::DELAY_S;
        Playing {
            role: Role::Tactile,
            channel: Some(self.channel + 1),
            stream,
        }
    }

    /// From now on, measure the delay from tick to output against the
    /// loop's clock, which started at `origin` (its ticks' `now_s`).
    pub fn set_origin(&self, origin: std::time::Instant) {
        let _ = self.counts.origin.set(origin);
    }

    /// The delay from a tick to the output, s: its median and 99th
    /// percentile over every buffer played (`None` before any).
    #[must_use]
    pub fn delay_quantiles_s(&self) -> Option<(f64, f64)> {
        let d = &self.counts.delays;
        Some((d.quantile(0.5)?, d.quantile(0.99)?))
    }

    /// How it went, with `parts` its underruns by cause
    /// ([`Tactor::underrun_parts`] when the run's trials ended);
    /// `origin_monotonic_s`: the loop's clock origin on the monotonic
    /// clock, if known.
    #[must_use]
    pub fn stats(&self, parts: [u64; 3], origin_monotonic_s: Option<f64>) -> StreamStats {
        let delays = self.delay_quantiles_s();
        StreamStats {
            role: Role::Tactile,
            output: self.held.output.clone(),
            underruns: parts.iter().sum(),
            underrun_causes: Some(parts),
            delay_p50_s: delays.map(|d| d.0),
            delay_p99_s: delays.map(|d| d.1),
            clock_origin_monotonic_s: origin_monotonic_s,
        }
    }

    /// Ramps down, plays out what is buffered and closes.
    pub fn finish(&self) {
        self.held.finish();
    }
}

impl std::fmt::Debug for Tactor {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Tactor")
            .field("output", &self.held.output)
            .field("channel", &self.channel)
            .finish_non_exhaustive()
    }
}

/// The outputs of the server the environment names.
///
/// # Errors
/// No sound server, or it did not answer.
pub fn outputs() -> Result<Vec<Output>, AudioError> {
    Server::from_env().outputs()
}
