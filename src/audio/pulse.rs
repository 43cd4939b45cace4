//! The sound server's client: PulseAudio's native protocol over its Unix
//! socket, spoken by PulseAudio and by PipeWire's pulse server
//! (`pipewire-pulse`), through the pure-Rust `pulseaudio` crate. No system
//! library or header is needed to build or run it.
//!
//! A [`Player`] owns one playback stream and its thread. The thread is the
//! stream's callback: the server asks for bytes (`Request`), the thread
//! fills them from its [`Source`] into buffers allocated before the stream
//! started and writes them, and counts the server's `Underflow`s. Every
//! 100 ms of sound it asks the server for the stream's latency. The socket
//! closing (the server gone) or the stream killed (the output gone) marks
//! the player lost, and the thread ends.

use std::ffi::CString;
use std::io::BufReader;
use std::os::unix::net::UnixStream;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU32, AtomicU64, Ordering};
use std::time::SystemTime;

use pulseaudio::protocol::{self, Command};

use super::{AudioError, Output, Server, Source, StreamInfo, Worker};

/// The rate a stream asks for, Hz (the server resamples if its output
/// runs at another).
pub const RATE_HZ: u32 = 48_000;

/// A connection, authenticated and named.
struct Conn {
    sock: BufReader<UnixStream>,
    version: u16,
    seq: u32,
}

fn io(e: &protocol::ProtocolError) -> AudioError {
    AudioError::Server(e.to_string())
}

impl Conn {
    fn connect(server: &Server) -> Result<Conn, AudioError> {
        let path = server.socket.clone().or_else(pulseaudio::socket_path_from_env).ok_or_else(|| {
            AudioError::NoServer(
                "no PulseAudio or PipeWire socket (PULSE_SERVER, PULSE_RUNTIME_PATH, XDG_RUNTIME_DIR)"
                    .to_owned(),
            )
        })?;
        let stream = UnixStream::connect(&path)
            .map_err(|e| AudioError::NoServer(format!("{}: {e}", path.display())))?;
        let mut sock = BufReader::new(stream);
        let cookie = server
            .cookie
            .clone()
            .or_else(pulseaudio::cookie_path_from_env)
            .and_then(|p| std::fs::read(p).ok())
            .unwrap_or_default();
        protocol::write_command_message(
            sock.get_mut(),
            0,
            &Command::Auth(protocol::AuthParams {
                version: protocol::MAX_VERSION,
                supports_shm: false,
                supports_memfd: false,
                cookie,
            }),
            protocol::MAX_VERSION,
        )
        .map_err(|e| io(&e))?;
        let (_, auth) =
            protocol::read_reply_message::<protocol::AuthReply>(&mut sock, protocol::MAX_VERSION)
                .map_err(|e| AudioError::NoServer(format!("{}: {e}", path.display())))?;
        let version = protocol::MAX_VERSION.min(auth.version);
        let mut props = protocol::Props::new();
        props.set(protocol::Prop::ApplicationName, c"frictionlab");
        let mut conn = Conn {
            sock,
            version,
            seq: 1,
        };
        conn.send(&Command::SetClientName(props))?;
        conn.reply::<protocol::SetClientNameReply>()?;
        Ok(conn)
    }

    fn send(&mut self, command: &Command) -> Result<u32, AudioError> {
        self.seq += 1;
        protocol::write_command_message(self.sock.get_mut(), self.seq, command, self.version)
            .map_err(|e| io(&e))?;
        Ok(self.seq)
    }

    fn reply<T: protocol::CommandReply>(&mut self) -> Result<T, AudioError> {
        protocol::read_reply_message::<T>(&mut self.sock, self.version)
            .map(|(_, r)| r)
            .map_err(|e| io(&e))
    }

    fn sinks(&mut self) -> Result<Vec<protocol::SinkInfo>, AudioError> {
        self.send(&Command::GetSinkInfoList)?;
        self.reply::<protocol::SinkInfoList>()
    }
}

fn output_of(s: &protocol::SinkInfo) -> Output {
    Output {
        name: s.name.to_string_lossy().into_owned(),
        channels: usize::from(s.sample_spec.channels),
        rate_hz: s.sample_spec.sample_rate,
        description: s
            .description
            .as_ref()
            .map(|d| d.to_string_lossy().into_owned())
            .unwrap_or_default(),
    }
}

/// The server's outputs (its sinks).
///
/// # Errors
/// No server, or it did not answer.
pub fn list(server: &Server) -> Result<Vec<Output>, AudioError> {
    Ok(Conn::connect(server)?
        .sinks()?
        .iter()
        .map(output_of)
        .collect())
}

/// What a player's thread and its owner share.
#[derive(Debug, Default)]
pub(super) struct Shared {
    pub underruns: AtomicU64,
    pub lost: AtomicBool,
    /// The owner asks the source to end (its ramp down), then the stream
    /// drains and the thread ends.
    pub finish: AtomicBool,
    /// The owner drops the player: end at once.
    pub stop: AtomicBool,
    /// The server's last reported latency of the stream, microseconds.
    pub latency_us: AtomicU64,
    /// The largest |sample| of the last buffer filled, as f32 bits.
    pub peak: AtomicU32,
    /// Frames written to the server.
    pub frames: AtomicU64,
}

/// One playback stream on an output, and its thread: see the module docs.
pub struct Player {
    pub(super) shared: Arc<Shared>,
    thread: Worker,
    sock: UnixStream,
    pub(super) info: StreamInfo,
}

/// The longest a player takes to finish, s: its ramp down (50 ms) and
/// its buffers played out, with room to spare.
pub const FINISH_S: f64 = 1.0;

/// Tags of the requests the player's thread makes.
const TAG_LATENCY: u32 = 0x7000_0000;
const TAG_DRAIN: u32 = 0x7000_0001;

impl Player {
    /// Opens a stream on `output` with buffers of `buffer_frames` frames
    /// and starts its thread, which plays `source`.
    ///
    /// # Errors
    /// No server, no such output, or the server refused the stream.
    pub fn open(
        server: &Server,
        output: &str,
        buffer_frames: u32,
        source: Box<dyn Source>,
    ) -> Result<Player, AudioError> {
        let mut conn = Conn::connect(server)?;
        let sinks = conn.sinks()?;
        let Some(sink) = sinks.iter().find(|s| s.name.to_string_lossy() == output) else {
            return Err(AudioError::NoSuchOutput {
                output: output.to_owned(),
                known: sinks.iter().map(|s| output_of(s).name).collect(),
            });
        };
        let channels = sink.sample_spec.channels;
        let frame_bytes = 4 * u32::from(channels);
        let target = buffer_frames * frame_bytes;
        let name = CString::new(output).map_err(|e| AudioError::Server(e.to_string()))?;
        let mut props = protocol::Props::new();
        props.set(protocol::Prop::MediaName, c"frictionlab");
        conn.send(&Command::CreatePlaybackStream(
            protocol::PlaybackStreamParams {
                sample_spec: protocol::SampleSpec {
                    format: protocol::SampleFormat::Float32Le,
                    channels,
                    sample_rate: RATE_HZ,
                },
                channel_map: sink.channel_map,
                sink_name: Some(name),
                buffer_attr: protocol::stream::BufferAttr {
                    max_length: u32::MAX,
                    target_length: target,
                    pre_buffering: u32::MAX,
                    minimum_request_length: target / 4,
                    fragment_size: u32::MAX,
                },
                cvolume: Some(protocol::ChannelVolume::norm(channels)),
                props,
                flags: protocol::stream::StreamFlags {
                    adjust_latency: true,
                    no_move: true,
                    ..Default::default()
                },
                ..Default::default()
            },
        ))?;
        let reply = conn.reply::<protocol::CreatePlaybackStreamReply>()?;
        let info = StreamInfo {
            output: output.to_owned(),
            channels: usize::from(channels),
            rate_hz: reply.sample_spec.sample_rate,
            buffer_frames: reply.buffer_attr.target_length / frame_bytes,
            latency_s: reply.stream_latency as f64 * 1e-6
                + f64::from(reply.buffer_attr.target_length / frame_bytes)
                    / f64::from(reply.sample_spec.sample_rate),
        };
        let shared = Arc::new(Shared::default());
        let sock = conn
            .sock
            .get_ref()
            .try_clone()
            .map_err(|e| AudioError::Server(e.to_string()))?;
        let thread = {
            let shared = shared.clone();
            let mut stream = Stream {
                conn,
                channel: reply.channel,
                channels: usize::from(channels),
                rate_hz: reply.sample_spec.sample_rate,
                samples: vec![0.0; (reply.buffer_attr.max_length.min(1 << 20) / 4) as usize],
                bytes: vec![0; reply.buffer_attr.max_length.min(1 << 20) as usize],
                source,
                shared,
                since_latency: 0,
                draining: false,
            };
            let first = reply.requested_bytes;
            std::thread::Builder::new()
                .name(format!("audio {output}"))
                .spawn(move || {
                    // The stream's callback runs when it is due, ahead of
                    // the loops that spin (granted or not, it plays).
                    let _ = crate::realtime::ask_fifo_at(crate::realtime::SOUND_PRIORITY);
                    stream.run(first);
                })
                .map_err(|e| AudioError::Server(e.to_string()))?
        };
        Ok(Player {
            shared,
            thread: Worker::new(thread),
            sock,
            info,
        })
    }

    /// Ends the stream: the source ramps down, what is buffered plays out,
    /// then the thread ends; at most [`FINISH_S`] (a server that stopped
    /// asking for sound is cut off). At once if the player was lost.
    pub fn finish(&self) {
        self.shared.finish.store(true, Ordering::SeqCst);
        self.thread.wait(FINISH_S);
        self.shared.stop.store(true, Ordering::SeqCst);
        let _ = self.sock.shutdown(std::net::Shutdown::Both);
        self.thread.join();
    }

    /// Whether its thread has ended: the stream drained (a source that
    /// [`Source::ends`]), finished or lost.
    #[must_use]
    pub fn done(&self) -> bool {
        self.thread.done()
    }
}

impl Drop for Player {
    fn drop(&mut self) {
        self.shared.stop.store(true, Ordering::SeqCst);
        let _ = self.sock.shutdown(std::net::Shutdown::Both);
        self.thread.join();
    }
}

/// The player's thread's state.
struct Stream {
    conn: Conn,
    channel: u32,
    channels: usize,
    rate_hz: u32,
    samples: Vec<f32>,
    bytes: Vec<u8>,
    source: Box<dyn Source>,
    shared: Arc<Shared>,
    /// Frames written since the last latency query.
    since_latency: u64,
    draining: bool,
}

impl Stream {
    fn run(&mut self, first: u32) {
        if self.serve(first).is_err() {
            self.shared.lost.store(true, Ordering::SeqCst);
        }
        while !self.shared.stop.load(Ordering::SeqCst) {
            match protocol::read_command_message(&mut self.conn.sock, self.conn.version) {
                Ok((_, Command::Request(r))) if r.channel == self.channel => {
                    if self.serve(r.length).is_err() {
                        break;
                    }
                }
                Ok((_, Command::Underflow(u))) if u.channel == self.channel => {
                    if !self.draining {
                        self.shared.underruns.fetch_add(1, Ordering::SeqCst);
                    }
                }
                Ok((TAG_LATENCY, Command::Reply)) => {
                    let mut ts =
                        protocol::TagStructReader::new(&mut self.conn.sock, self.conn.version);
                    let Ok(l) = ts.read::<protocol::PlaybackLatency>() else {
                        break;
                    };
                    let queued = u64::try_from(l.write_offset - l.read_offset).unwrap_or(0);
                    let frame_bytes = 4 * self.channels as u64;
                    let queued_us = queued / frame_bytes * 1_000_000 / u64::from(self.rate_hz);
                    self.shared
                        .latency_us
                        .store(l.sink_usec + queued_us, Ordering::SeqCst);
                    self.source.latency(l.sink_usec + queued_us);
                }
                Ok((TAG_DRAIN, Command::Reply)) => return,
                Ok((_, Command::PlaybackStreamKilled(c))) if c == self.channel => break,
                Ok(_) => {}
                Err(_) => break,
            }
        }
        if !self.shared.stop.load(Ordering::SeqCst) {
            self.shared.lost.store(true, Ordering::SeqCst);
        }
    }

    /// Answers a request for `length` bytes. Allocates nothing: the
    /// buffers were made before the stream started (a larger request is
    /// served in pieces).
    fn serve(&mut self, mut length: u32) -> Result<(), AudioError> {
        let frame_bytes = 4 * self.channels;
        let most = self.bytes.len() / frame_bytes * frame_bytes;
        while length as usize >= frame_bytes && !self.draining {
            let n = (length as usize).min(most) / frame_bytes * frame_bytes;
            let samples = &mut self.samples[..n / 4];
            let ending = self.shared.finish.load(Ordering::SeqCst);
            self.source.fill(samples, self.channels, ending);
            let mut peak = 0.0f32;
            for (s, b) in samples.iter().zip(self.bytes[..n].chunks_exact_mut(4)) {
                peak = peak.max(s.abs());
                b.copy_from_slice(&s.to_le_bytes());
            }
            self.shared.peak.store(peak.to_bits(), Ordering::SeqCst);
            protocol::write_memblock(self.conn.sock.get_mut(), self.channel, &self.bytes[..n], 0)
                .map_err(|e| io(&e))?;
            let frames = (n / frame_bytes) as u64;
            self.shared.frames.fetch_add(frames, Ordering::SeqCst);
            self.since_latency += frames;
            length -= u32::try_from(n).unwrap_or(length);
            if (ending || self.source.ends()) && self.source.finished() {
                self.draining = true;
                self.command(TAG_DRAIN, &Command::DrainPlaybackStream(self.channel))?;
            }
        }
        if self.since_latency * 10 >= u64::from(self.rate_hz) {
            self.since_latency = 0;
            self.command(
                TAG_LATENCY,
                &Command::GetPlaybackLatency(protocol::LatencyParams {
                    channel: self.channel,
                    now: SystemTime::now(),
                }),
            )?;
        }
        Ok(())
    }

    /// Sends a command from a fixed buffer (no allocation).
    fn command(&mut self, tag: u32, command: &Command) -> Result<(), AudioError> {
        let mut buf = [0u8; 128];
        let n = protocol::encode_command_message(&mut buf[..], tag, command, self.conn.version)
            .map_err(|e| io(&e))?;
        std::io::Write::write_all(self.conn.sock.get_mut(), &buf[..n])
            .map_err(|e| AudioError::Server(e.to_string()))
    }
}
