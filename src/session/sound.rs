//! A session's sound (issue 64), the shell's part ([`super::run::Run`]):
//! the masking noise switched on the session's events, the tactile display
//! fed by a port's haptic loop, and the faults of either.
//!
//! - Masking: on from the run's start (`during: session`), or at each
//!   trial's start until its record is written (`during: trials`); at the
//!   run's end it ramps down and the stream closes.
//! - The tactile display: the loop offers each connected tick's drive to
//!   the [`Tactor`] on its own thread ([`TactileSink`]).
//! - A trial in which the tactile display had an underrun (the server's,
//!   or the drive not played as sent) is aborted, with [`TACTILE_UNDERRUN`]
//!   as its reason, and presented again: the participant felt a broken
//!   stimulus.
//! - An output lost (its server gone, or the output removed) is a lost
//!   device: the trial under way is aborted ([`SOUND_LOST`]) and presented
//!   again; the session pauses and the output is opened again every
//!   [`RETRY_S`] until it is back (the session resumes), or until the
//!   run's device timeout, when the run stops as for a device that failed
//!   (resumable).
//! - The log's `sound` line counts the tactile display's underruns up to
//!   the last record: when the run ends the loop stops, and the drive
//!   running out then broke no stimulus.

use std::sync::Arc;
use std::time::{Duration, Instant};

use crate::audio::{AudioError, During, Masker, Masking, Playing, Server, SoundStats, Tactor};
use crate::device::haptic::{Offer, SampleSink, Tick};
use crate::kinds::LogLine;
use crate::protocol::engine::Input;

use super::{Event, Feed};

/// The abort reason of a trial whose tactile display had an underrun.
pub const TACTILE_UNDERRUN: &str = "tactile underrun";

/// The abort reason of a trial under way when a sound output was lost.
pub const SOUND_LOST: &str = "sound output lost";

/// How often a lost output is opened again, s.
pub const RETRY_S: f64 = 0.5;

/// The outputs a session plays on, opened before it starts.
#[derive(Debug, Clone, Default)]
pub struct Sound {
    /// The protocol's masking noise (`--masking-audio`).
    pub masker: Option<Arc<Masker>>,
    /// The tactile display (`--tactile-audio`).
    pub tactor: Option<Arc<Tactor>>,
    /// How long a lost output may stay lost before the run stops, s (the
    /// run's `--device-timeout`).
    pub timeout_s: f64,
}

/// What a shell asks to play: the CLI's `--masking-audio` and
/// `--tactile-audio`, or the window's Setup.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct SoundChoice {
    /// The server to play on.
    pub server: Server,
    /// The output for the protocol's masking noise.
    pub masking_audio: Option<String>,
    /// The tactile display: `OUTPUT[:CHANNEL]`, the channel from 1.
    pub tactile_audio: Option<String>,
}

/// Why a session's sound cannot open: the session does not start.
#[derive(Debug, thiserror::Error)]
pub enum SoundError {
    /// The protocol plays masking noise and no output was given for it.
    #[error(
        "the protocol plays {noise} noise at {level_dbfs} dBFS on headphones, and no output was chosen for it"
    )]
    NoMaskingOutput {
        /// `pink` or `white`.
        noise: &'static str,
        /// Its level, dBFS.
        level_dbfs: f64,
    },
    /// An output was given for masking, and the protocol has none.
    #[error("the protocol has no `masking` to play")]
    NoMasking,
    /// The masking noise's output did not open.
    #[error("{0}")]
    Masking(AudioError),
    /// The tactile display asked of the simulated apparatus.
    #[error(
        "the tactile display plays a device's haptic loop, and the simulated apparatus runs none in real time"
    )]
    TactileWithoutDevice,
    /// The tactile display's output did not open (or its channel is not
    /// one).
    #[error("{0}")]
    Tactile(String),
}

impl Sound {
    /// Opens what `choice` asks for a session of a protocol with
    /// `masking`, on a device (`device`) or the simulated apparatus, its
    /// noise seeded by `seed`; a lost output may stay lost `timeout_s`.
    /// Nothing is played until the session starts ([`Playback`]).
    ///
    /// # Errors
    /// A protocol with masking and no output for it, or an output and no
    /// masking; the tactile display without a device; no sound server, no
    /// such output or channel.
    pub fn open(
        masking: Option<Masking>,
        choice: &SoundChoice,
        device: bool,
        seed: u64,
        timeout_s: f64,
    ) -> Result<Sound, SoundError> {
        let masker = match (masking, &choice.masking_audio) {
            (None, None) => None,
            (Some(m), None) => {
                return Err(SoundError::NoMaskingOutput {
                    noise: match m.noise {
                        crate::audio::NoiseColor::Pink => "pink",
                        crate::audio::NoiseColor::White => "white",
                    },
                    level_dbfs: m.level_dbfs,
                });
            }
            (None, Some(_)) => return Err(SoundError::NoMasking),
            (Some(m), Some(output)) => Some(Arc::new(
                Masker::open(&choice.server, output, m, seed).map_err(SoundError::Masking)?,
            )),
        };
        let tactor = match &choice.tactile_audio {
            None => None,
            Some(_) if !device => return Err(SoundError::TactileWithoutDevice),
            Some(text) => {
                let (output, channel) =
                    crate::audio::output_and_channel(text).map_err(SoundError::Tactile)?;
                Some(Arc::new(
                    Tactor::open(&choice.server, &output, channel)
                        .map_err(|e| SoundError::Tactile(e.to_string()))?,
                ))
            }
        };
        Ok(Sound {
            masker,
            tactor,
            timeout_s,
        })
    }

    /// What the log's header keeps of the streams.
    #[must_use]
    pub fn playing(&self) -> Vec<Playing> {
        let masking = self.masker.iter().map(|m| m.playing());
        masking
            .chain(self.tactor.iter().map(|t| t.playing()))
            .collect()
    }

    fn is_empty(&self) -> bool {
        self.masker.is_none() && self.tactor.is_none()
    }
}

/// The system's monotonic clock now, s (`CLOCK_MONOTONIC`: what
/// `std::time::Instant` reads on Linux, and liblsl's clock).
#[cfg(unix)]
fn monotonic_s() -> f64 {
    let t = rustix::time::clock_gettime(rustix::time::ClockId::Monotonic);
    #[allow(clippy::cast_precision_loss)]
    let s = t.tv_sec as f64 + t.tv_nsec as f64 * 1e-9;
    s
}

#[cfg(not(unix))]
fn monotonic_s() -> f64 {
    f64::NAN
}

/// The loop's ticks into the tactile display.
struct TactileSink(Arc<Tactor>);

impl SampleSink for TactileSink {
    fn offer(&self, tick: &Tick) {
        self.0
            .push(tick.now_s, tick.vibration, tick.vibration_q, tick.burst);
    }
}

/// A run's sound, as it goes: see the module docs.
pub(super) struct Playback {
    sound: Sound,
    in_trial: bool,
    /// The tactile display's underruns by cause when the trial under way
    /// started ([`Tactor::underrun_parts`]), and whether it was aborted
    /// for them already.
    underruns_at_start: [u64; 3],
    aborted: bool,
    /// Since when an output is lost, and when it is next tried.
    lost_since: Option<Instant>,
    next_try: Instant,
    /// Why the run stopped for its sound, if it did.
    failed: Option<String>,
    ended: bool,
    /// The loop's clock origin on the monotonic clock, s.
    origin_monotonic_s: Option<f64>,
    /// The tactile display's underruns by cause when the last record was
    /// written: what the log's line reports. The drive running out when
    /// the run's end stops the loop is not an underrun of any stimulus.
    parts_at_last_record: [u64; 3],
}

impl Playback {
    /// Starts `sound` for `session` (nothing when it has none): the
    /// tactile display offered the loop's ticks, a whole session's masking
    /// on.
    pub(super) fn start<R: super::Responder>(
        sound: Sound,
        session: &mut super::Session<R>,
    ) -> Option<Playback> {
        if sound.is_empty() {
            return None;
        }
        let origin = session.loop_origin();
        let origin_monotonic_s = origin.map(|o| monotonic_s() - o.elapsed().as_secs_f64());
        if let Some(t) = &sound.tactor {
            if let Some(origin) = origin {
                t.set_origin(origin);
            }
            session.offer_samples(Offer(Arc::new(TactileSink(t.clone()))));
        }
        if let Some(m) = &sound.masker {
            m.set_on(m.masking().during == During::Session);
        }
        Some(Playback {
            sound,
            in_trial: false,
            underruns_at_start: [0; 3],
            aborted: false,
            lost_since: None,
            next_try: Instant::now(),
            failed: None,
            ended: false,
            origin_monotonic_s,
            parts_at_last_record: [0; 3],
        })
    }

    fn tactile_underruns(&self) -> [u64; 3] {
        self.sound
            .tactor
            .as_ref()
            .map_or([0; 3], |t| t.underrun_parts())
    }

    /// Follows the session's `event`.
    pub(super) fn on(&mut self, event: &Event) {
        let trials = self
            .sound
            .masker
            .as_ref()
            .filter(|m| m.masking().during == During::Trials);
        match event {
            Event::TrialStarted { .. } => {
                self.in_trial = true;
                self.aborted = false;
                self.underruns_at_start = self.tactile_underruns();
                if let Some(m) = trials {
                    m.set_on(true);
                }
            }
            Event::Written { .. } => {
                self.in_trial = false;
                self.parts_at_last_record = self.tactile_underruns();
                if let Some(m) = trials {
                    m.set_on(false);
                }
            }
            Event::Finished { .. } | Event::Stopped { .. } => self.finish(),
            _ => {}
        }
    }

    /// Ramps the outputs down and closes them (once).
    fn finish(&mut self) {
        if std::mem::replace(&mut self.ended, true) {
            return;
        }
        if let Some(m) = &self.sound.masker {
            m.finish();
        }
        if let Some(t) = &self.sound.tactor {
            t.finish();
        }
    }

    fn lost(&self) -> bool {
        self.sound.masker.as_ref().is_some_and(|m| m.lost())
            || self.sound.tactor.as_ref().is_some_and(|t| t.lost())
    }

    /// What the session is to be fed for the sound's faults now, at `now`:
    /// an underrun's abort; a lost output's hold (the trial under way
    /// aborted, the session paused); its resume once opened again; the
    /// run's abort when it stayed lost past the timeout.
    pub(super) fn check(&mut self, now: Instant) -> Option<Feed> {
        if self.ended || self.failed.is_some() {
            return None;
        }
        let Some(since) = self.lost_since else {
            if self.lost() {
                self.lost_since = Some(now);
                self.next_try = now + Duration::from_secs_f64(RETRY_S);
                return Some(Feed::Hold(SOUND_LOST.into()));
            }
            let now_parts = self.tactile_underruns();
            let [server, starved, slips] =
                std::array::from_fn(|i| now_parts[i] - self.underruns_at_start[i]);
            if self.in_trial && !self.aborted && server + starved + slips > 0 {
                self.aborted = true;
                return Some(Feed::Input(Input::Abort {
                    reason: format!(
                        "{TACTILE_UNDERRUN}: the sound server ran dry {server} times, the loop's drive ran out {starved} times, the play time slipped {slips} times"
                    ),
                    requeue: true,
                }));
            }
            return None;
        };
        if now < self.next_try {
            return None;
        }
        match self.reopen() {
            Ok(()) => {
                self.lost_since = None;
                self.underruns_at_start = self.tactile_underruns();
                Some(Feed::Resume)
            }
            Err(why) if now.duration_since(since).as_secs_f64() > self.sound.timeout_s => {
                self.failed = Some(format!(
                    "a sound output was lost and not back within {} s ({why})",
                    self.sound.timeout_s
                ));
                Some(Feed::Abort)
            }
            Err(_) => {
                self.next_try = now + Duration::from_secs_f64(RETRY_S);
                None
            }
        }
    }

    /// Opens the lost outputs again.
    fn reopen(&self) -> Result<(), crate::audio::AudioError> {
        if let Some(m) = self.sound.masker.as_ref().filter(|m| m.lost()) {
            m.reopen()?;
        }
        if let Some(t) = self.sound.tactor.as_ref().filter(|t| t.lost()) {
            t.reopen()?;
        }
        Ok(())
    }

    /// The log's line of how the sound went.
    pub(super) fn stats(&self) -> LogLine {
        let masking = self.sound.masker.iter().map(|m| m.stats());
        let tactile = self
            .sound
            .tactor
            .iter()
            .map(|t| t.stats(self.parts_at_last_record, self.origin_monotonic_s));
        LogLine::Sound(SoundStats {
            streams: masking.chain(tactile).collect(),
        })
    }

    /// How long an output has been lost, s, while it is.
    pub(super) fn lost_for_s(&self) -> Option<f64> {
        self.lost_since.map(|t| t.elapsed().as_secs_f64())
    }

    /// Why the run stopped for its sound, if it did.
    pub(super) fn failed(&self) -> Option<&str> {
        self.failed.as_deref()
    }
}
