//! Sound on macOS and Windows, through cpal (CoreAudio, WASAPI): the same
//! players as [`super::pulse`]'s on Linux.
//!
//! A [`Player`] owns one output stream, built and held on a thread of its
//! own (a cpal stream may not move between threads on every host): cpal's
//! data callback fills the device's buffer from the [`Source`] straight
//! into the slice it is given (no allocation, no lock), and counts the
//! host's underruns (`Xrun`); the device gone marks the player lost. The
//! latency is the callback's predicted playback instant less its own.
//!
//! Type-checked (and linted) for Windows, `x86_64-pc-windows-gnu`, with
//! stand-ins for its neighbours in `audio`: the rest of frictionlab does
//! not build for Windows yet (its device layer is Unix's: ptys, Unix
//! sockets, signals). Never run on macOS or Windows (issue 64's note). A
//! `Server` names nothing here: the system's default host is the server.

use std::sync::atomic::{AtomicBool, AtomicU32, AtomicU64, Ordering};
use std::sync::{Arc, mpsc};

use cpal::traits::{DeviceTrait, HostTrait, StreamTrait};

use super::{AudioError, Output, Server, Source, StreamInfo, Worker};

/// The rate a stream plays at, Hz: the output must run at it (the
/// tactile display's synthesis is at this rate).
pub const RATE_HZ: u32 = 48_000;

/// The longest a player takes to finish, s.
pub const FINISH_S: f64 = 1.0;

fn host_error(e: &cpal::Error) -> AudioError {
    AudioError::Server(e.to_string())
}

/// The output devices of the system's default host, by name.
fn devices() -> Result<Vec<(String, cpal::Device)>, AudioError> {
    let host = cpal::default_host();
    let devices = host
        .output_devices()
        .map_err(|e| AudioError::NoServer(e.to_string()))?;
    Ok(devices
        .filter_map(|d| Some((d.description().ok()?.name().to_owned(), d)))
        .collect())
}

/// The system's outputs.
///
/// # Errors
/// The host has none, or did not answer.
pub fn list(_server: &Server) -> Result<Vec<Output>, AudioError> {
    let mut outputs = Vec::new();
    for (name, device) in devices()? {
        let Ok(config) = device.default_output_config() else {
            continue;
        };
        let description = device
            .description()
            .ok()
            .and_then(|d| d.driver().map(str::to_owned))
            .unwrap_or_else(|| name.clone());
        outputs.push(Output {
            name,
            channels: usize::from(config.channels()),
            rate_hz: config.sample_rate(),
            description,
        });
    }
    Ok(outputs)
}

/// What a player's thread and its owner share.
#[derive(Debug, Default)]
pub(super) struct Shared {
    pub underruns: AtomicU64,
    pub lost: AtomicBool,
    /// The owner asks the source to end (its ramp down).
    pub finish: AtomicBool,
    /// The owner drops the player: end at once.
    pub stop: AtomicBool,
    /// The source has gone silent after ending: the stream may close.
    pub drained: AtomicBool,
    /// The host's last reported latency, microseconds.
    pub latency_us: AtomicU64,
    /// The largest |sample| of the last buffer filled, as f32 bits.
    pub peak: AtomicU32,
    /// Frames played.
    pub frames: AtomicU64,
}

/// One output stream and its thread: see the module docs.
pub struct Player {
    pub(super) shared: Arc<Shared>,
    thread: Worker,
    pub(super) info: StreamInfo,
}

impl Player {
    /// Opens a stream on `output` with buffers of `buffer_frames` frames
    /// and starts its thread, which plays `source`.
    ///
    /// # Errors
    /// No such output, or the host refused the stream (not at 48 kHz).
    pub fn open(
        _server: &Server,
        output: &str,
        buffer_frames: u32,
        source: Box<dyn Source>,
    ) -> Result<Player, AudioError> {
        let shared = Arc::new(Shared::default());
        let (opened, wait) = mpsc::channel();
        let thread = {
            let shared = shared.clone();
            let output = output.to_owned();
            std::thread::Builder::new()
                .name(format!("audio {output}"))
                .spawn(move || run(&output, buffer_frames, source, &shared, &opened))
                .map_err(|e| AudioError::Server(e.to_string()))?
        };
        let info = wait
            .recv()
            .map_err(|_| AudioError::Server("the player's thread ended".to_owned()))??;
        Ok(Player {
            shared,
            thread: Worker::new(thread),
            info,
        })
    }

    /// Ends the stream: the source ramps down and plays out, then the
    /// thread ends; at most [`FINISH_S`].
    pub fn finish(&self) {
        self.shared.finish.store(true, Ordering::SeqCst);
        self.thread.wait(FINISH_S);
        self.shared.stop.store(true, Ordering::SeqCst);
        self.thread.join();
    }

    /// Whether its thread has ended.
    #[must_use]
    pub fn done(&self) -> bool {
        self.thread.done()
    }
}

impl Drop for Player {
    fn drop(&mut self) {
        self.shared.stop.store(true, Ordering::SeqCst);
        self.thread.join();
    }
}

/// The player's thread: builds and plays the stream, tells the opener how
/// it went, and holds the stream until it is stopped, drained or lost.
fn run(
    output: &str,
    buffer_frames: u32,
    mut source: Box<dyn Source>,
    shared: &Arc<Shared>,
    opened: &mpsc::Sender<Result<StreamInfo, AudioError>>,
) {
    let _ = crate::realtime::ask_fifo_at(crate::realtime::SOUND_PRIORITY);
    let stream = (|| {
        let all = devices()?;
        let Some((_, device)) = all.iter().find(|(n, _)| n == output) else {
            return Err(AudioError::NoSuchOutput {
                output: output.to_owned(),
                known: all.into_iter().map(|(n, _)| n).collect(),
            });
        };
        let channels = device
            .default_output_config()
            .map_err(|e| host_error(&e))?
            .channels();
        let config = cpal::StreamConfig {
            channels,
            sample_rate: RATE_HZ,
            buffer_size: cpal::BufferSize::Fixed(buffer_frames),
        };
        let n = usize::from(channels);
        let (data, errors) = (shared.clone(), shared.clone());
        let stream = device
            .build_output_stream::<f32, _, _>(
                config,
                move |out: &mut [f32], info: &cpal::OutputCallbackInfo| {
                    let ending = data.finish.load(Ordering::SeqCst);
                    source.fill(out, n, ending);
                    let peak = out.iter().fold(0.0f32, |m, s| m.max(s.abs()));
                    data.peak.store(peak.to_bits(), Ordering::SeqCst);
                    data.frames
                        .fetch_add((out.len() / n) as u64, Ordering::SeqCst);
                    let t = info.timestamp();
                    if let Some(ahead) = t.playback.checked_duration_since(t.callback) {
                        let us = u64::try_from(ahead.as_micros()).unwrap_or(u64::MAX);
                        data.latency_us.store(us, Ordering::SeqCst);
                        source.latency(us);
                    }
                    if (ending || source.ends()) && source.finished() {
                        data.drained.store(true, Ordering::SeqCst);
                    }
                },
                move |e: cpal::Error| match e.kind() {
                    cpal::ErrorKind::Xrun => {
                        errors.underruns.fetch_add(1, Ordering::SeqCst);
                    }
                    _ => errors.lost.store(true, Ordering::SeqCst),
                },
                None,
            )
            .map_err(|e| {
                AudioError::Server(format!(
                    "{output}: {e} (frictionlab plays at {RATE_HZ} Hz: set the output to it in the system's sound settings)"
                ))
            })?;
        stream.play().map_err(|e| host_error(&e))?;
        let info = StreamInfo {
            output: output.to_owned(),
            channels: n,
            rate_hz: RATE_HZ,
            buffer_frames,
            latency_s: f64::from(buffer_frames) / f64::from(RATE_HZ),
        };
        Ok((stream, info))
    })();
    let stream = match stream {
        Ok((stream, info)) => {
            let _ = opened.send(Ok(info));
            stream
        }
        Err(e) => {
            let _ = opened.send(Err(e));
            return;
        }
    };
    while !shared.stop.load(Ordering::SeqCst)
        && !shared.lost.load(Ordering::SeqCst)
        && !shared.drained.load(Ordering::SeqCst)
    {
        std::thread::sleep(std::time::Duration::from_millis(10));
    }
    if shared.drained.load(Ordering::SeqCst) {
        // What is buffered plays out.
        std::thread::sleep(std::time::Duration::from_secs_f64(
            2.0 * f64::from(buffer_frames) / f64::from(RATE_HZ),
        ));
    }
    drop(stream);
}
