//! Sound output (issue 64): the outputs of the sound server, and players
//! that play a [`Source`] on one of them. Seed 001's apparatus plays
//! masking noise on headphones ([`noise`]).
//!
//! The server is PulseAudio or PipeWire's pulse server, spoken to by
//! [`pulse`] (pure Rust, so building needs no system package). A shell
//! opens a player before a session starts, so a missing server or output
//! is an error before anything is written, and watches it during the
//! session ([`Masker::lost`], [`Masker::underruns`]).

pub mod noise;
#[cfg(unix)]
pub mod pulse;
// Elsewhere no server is found (cpal's backends for macOS and Windows are
// not yet built in: see the guide's sound page).
#[cfg(not(unix))]
#[path = "none.rs"]
pub mod pulse;

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

/// The buffer a player asks the server for, frames at 48 kHz: 5.3 ms.
pub const BUFFER_FRAMES: u32 = 256;

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
}

/// A stream a session played, as its log's header records it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct Playing {
    /// What it played.
    pub role: Role,
    /// The stream.
    #[serde(flatten)]
    pub stream: StreamInfo,
}

/// What a player plays: filled on the player's thread, which is the
/// stream's callback. `fill` must never block or allocate.
pub trait Source: Send + 'static {
    /// Fills `out`, `channels` samples interleaved per frame, full scale
    /// ±1. `ending`: the player is finishing; ramp down.
    fn fill(&mut self, out: &mut [f32], channels: usize, ending: bool);
    /// Whether, ending, the source has gone silent (the stream may drain).
    fn finished(&self) -> bool;
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

/// Masking noise playing on an output: on and off with ramps at its
/// shell's word.
pub struct Masker {
    player: pulse::Player,
    gate: Arc<AtomicBool>,
    masking: Masking,
}

impl Masker {
    /// Opens `output` for `masking` (off until [`Masker::set_on`]), its
    /// noise seeded by `seed`.
    ///
    /// # Errors
    /// No sound server, no such output, or the stream refused.
    pub fn open(output: &str, masking: Masking, seed: u64) -> Result<Masker, AudioError> {
        let gate = Arc::new(AtomicBool::new(false));
        let color = match masking.noise {
            NoiseColor::Pink => noise::Color::Pink,
            NoiseColor::White => noise::Color::White,
        };
        let source = Gated {
            noise: noise::Masking::new(color, masking.level_dbfs, f64::from(pulse::RATE_HZ), seed),
            gate: gate.clone(),
        };
        // A longer buffer than the tactor's: noise needs no low latency.
        let player = pulse::Player::open(output, BUFFER_FRAMES * 8, Box::new(source))?;
        Ok(Masker {
            player,
            gate,
            masking,
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

    /// The stream as it opened.
    #[must_use]
    pub fn info(&self) -> &StreamInfo {
        &self.player.info
    }

    /// Underruns so far.
    #[must_use]
    pub fn underruns(&self) -> u64 {
        self.player.shared.underruns.load(Ordering::SeqCst)
    }

    /// Whether the output or its server is gone.
    #[must_use]
    pub fn lost(&self) -> bool {
        self.player.shared.lost.load(Ordering::SeqCst)
    }

    /// Ramps down, plays out what is buffered and closes (at once if
    /// lost).
    pub fn finish(&self) {
        self.player.finish();
    }

    /// What the log's header keeps of it.
    #[must_use]
    pub fn playing(&self) -> Playing {
        Playing {
            role: Role::Masking,
            stream: self.player.info.clone(),
        }
    }
}

impl std::fmt::Debug for Masker {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Masker")
            .field("masking", &self.masking)
            .field("stream", &self.player.info)
            .finish_non_exhaustive()
    }
}

/// The server's outputs.
///
/// # Errors
/// No sound server, or it did not answer.
pub fn outputs() -> Result<Vec<Output>, AudioError> {
    pulse::list()
}
