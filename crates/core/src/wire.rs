//! The device wire protocol (specified in `docs/wire-protocol.md`): messages,
//! frame encoding, and a sans-IO frame decoder.
//!
//! A frame is `COBS(payload || crc16(payload)) || 0x00`. The payload is the
//! postcard encoding of a [`Message`], with every integer fixed-width little
//! endian, so each message has one byte layout. The CRC is CRC-16/IBM-3740
//! (poly 0x1021, init 0xFFFF), little endian. The decoder accepts whatever
//! chunks a read returns, never allocates after construction, and
//! resynchronises at the next 0x00 after a bad frame. No allocation: the
//! device runs this same code.

use serde::{Deserialize, Serialize};

/// Protocol version this build speaks.
pub const PROTOCOL_VERSION: u16 = 2;

/// Values per [`Message::Upload`].
pub const UPLOAD_VALUES: usize = 5;

/// Largest payload (message plus CRC), bytes.
pub const MAX_PAYLOAD: usize = 48;

/// Largest encoded frame including the 0x00 delimiter, bytes.
pub const MAX_FRAME: usize = cobs::max_encoding_length(MAX_PAYLOAD) + 1;

/// The frame check: CRC-16/IBM-3740 (poly 0x1021, init 0xFFFF; check value
/// of "123456789" 0x29B1).
pub const CRC: crc::Crc<u16> = crc::Crc::<u16>::new(&crc::CRC_16_IBM_3740);

/// Status flags of a [`Message::Sample`].
pub mod status {
    /// The watchdog zeroed the force: no valid command for 20 ms.
    pub const WATCHDOG: u8 = 1;
    /// The commanded force exceeded the device maximum and was clamped.
    pub const CLAMPED: u8 = 2;
    /// The device is at an end of its range.
    pub const END_STOP: u8 = 4;
    /// (v2 `Telemetry`) the on-board model is slipping.
    pub const SLIP: u8 = 8;
    /// (v2 `Telemetry`) the device's button is pressed.
    pub const BUTTON: u8 = 16;
    /// (v2 `Telemetry`) the last `Select` was refused: an invalid model
    /// (nothing is rendered from then on), or values missing or a check
    /// that did not match (the device goes on rendering what it did).
    pub const REFUSED: u8 = 32;
    /// (v2 `Telemetry`) a `Select` or `Clear` took effect at this tick.
    pub const SELECTED: u8 = 64;
}

/// Every message of the protocol, host-to-device and device-to-host. The
/// variant index is the payload's first byte.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub enum Message {
    /// 0, host -> device: start (or restart) a session of this version.
    Hello {
        /// Host protocol version.
        #[serde(with = "postcard::fixint::le")]
        version: u16,
    },
    /// 1, host -> device: render this force and vibration until the next
    /// command.
    Command {
        /// Sequence number, incremented per command.
        #[serde(with = "postcard::fixint::le")]
        seq: u32,
        /// Force on the hand, N (the device clamps it to its maximum).
        force_n: f32,
        /// Vibrotactile drive in [-1, 1].
        vibration: f32,
    },
    /// 2, host -> device: keep the link alive without a new command.
    Heartbeat {
        /// Sequence number.
        #[serde(with = "postcard::fixint::le")]
        seq: u32,
    },
    /// 3, host -> emulator only: what the simulated hand does (its reference
    /// position and velocity and its impedance). Real firmware ignores it.
    HandDrive {
        /// Reference position, m.
        x_m: f32,
        /// Reference velocity, m/s.
        v_m_s: f32,
        /// Hand stiffness, N/m.
        stiffness_n_m: f32,
        /// Hand damping, N s/m.
        damping_n_s_m: f32,
        /// Integral gain, N/(m s).
        integral: f32,
        /// Press the button now.
        click: bool,
    },
    /// 4, device -> host: the answer to `Hello`.
    Capabilities {
        /// Device protocol version.
        #[serde(with = "postcard::fixint::le")]
        version: u16,
        /// Degrees of freedom.
        dof: u8,
        /// Maximum continuous force, N.
        max_force_n: f32,
        /// Encoder counts per metre.
        counts_per_m: f32,
        /// Force loop rate, Hz.
        #[serde(with = "postcard::fixint::le")]
        force_rate_hz: u16,
        /// Vibration output rate, Hz (0: no vibration output).
        #[serde(with = "postcard::fixint::le")]
        vibration_rate_hz: u16,
    },
    /// 5, device -> host: one loop tick.
    Sample {
        /// Sequence number of the last command applied.
        #[serde(with = "postcard::fixint::le")]
        ack_seq: u32,
        /// Device clock, microseconds (wraps).
        #[serde(with = "postcard::fixint::le")]
        time_us: u32,
        /// Encoder position, counts.
        #[serde(with = "postcard::fixint::le")]
        position_counts: i32,
        /// Button pressed.
        button: bool,
        /// [`status`] flags.
        status: u8,
    },
    /// 6, device -> host (v2), right after `Capabilities`: what the device
    /// renders on board.
    OnBoard {
        /// Bit `k - 1` set: renders model kind `k` (1 + its index in
        /// `ModelParams::NAMES`).
        #[serde(with = "postcard::fixint::le")]
        models: u16,
        /// On-board loop rate, Hz.
        #[serde(with = "postcard::fixint::le")]
        loop_rate_hz: u16,
        /// Bytes of the float the models compute in (4: f32, 8: f64).
        float_bytes: u8,
    },
    /// 7, host -> device (v2): part of a model's parameters, staged for the
    /// next `Select`.
    Upload {
        /// Model kind.
        kind: u8,
        /// Index of `values[0]` among the model's parameters.
        first: u8,
        /// Parameters `first..first + 5` (unused ones 0).
        values: [f64; UPLOAD_VALUES],
    },
    /// 8, host -> device (v2): render the staged model, crossfading over
    /// 50 ms.
    Select {
        /// The host's label for this render, echoed in `Telemetry`.
        render: u8,
        /// Model kind.
        kind: u8,
        /// Number of parameters.
        count: u8,
        /// CRC-16/IBM-3740 of the `count` parameters as f64 little endian.
        #[serde(with = "postcard::fixint::le")]
        check: u16,
    },
    /// 9, host -> device (v2): render nothing on board, crossfading out.
    Clear {
        /// The host's label for this render.
        render: u8,
    },
    /// 10, host -> device (v2): send `Telemetry` every `every` loop ticks.
    SetTelemetry {
        /// Decimation, ticks (0: none).
        #[serde(with = "postcard::fixint::le")]
        every: u16,
    },
    /// 11, device -> host (v2): the state of one loop tick.
    Telemetry {
        /// Loop tick number (wraps).
        #[serde(with = "postcard::fixint::le")]
        tick: u32,
        /// Position the model saw, m.
        x_m: f32,
        /// Velocity the model saw, m/s.
        v_m_s: f32,
        /// Force rendered, N (after crossfade, clamp and watchdog).
        force_n: f32,
        /// Vibrotactile drive.
        vibration: f32,
        /// Label of the render in effect.
        render: u8,
        /// [`status`] flags.
        flags: u8,
    },
    /// 12, device -> host (v2), every 100 ms: loop statistics.
    LoopReport {
        /// Loop ticks run.
        #[serde(with = "postcard::fixint::le")]
        ticks: u32,
        /// Longest loop body, microseconds.
        #[serde(with = "postcard::fixint::le")]
        longest_loop_us: u32,
        /// Ticks whose deadline passed before they ran.
        #[serde(with = "postcard::fixint::le")]
        missed_ticks: u32,
    },
}

/// The check of a `Select`: CRC-16/IBM-3740 of the values as f64 little
/// endian.
#[must_use]
pub fn values_check(values: &[f64]) -> u16 {
    let mut digest = CRC.digest();
    for v in values {
        digest.update(&v.to_le_bytes());
    }
    digest.finalize()
}

/// Encodes `message` as one frame into `out` (at least [`MAX_FRAME`] bytes);
/// returns the frame's length.
///
/// # Errors
/// If `out` is too small (a programming error; every message fits).
pub fn encode(message: &Message, out: &mut [u8]) -> Result<usize, &'static str> {
    let mut payload = [0_u8; MAX_PAYLOAD];
    let used = postcard::to_slice(message, &mut payload[..MAX_PAYLOAD - 2])
        .map_err(|_| "message too large")?
        .len();
    let crc = CRC.checksum(&payload[..used]).to_le_bytes();
    payload[used..used + 2].copy_from_slice(&crc);
    let n = cobs::try_encode(&payload[..used + 2], out).map_err(|_| "output buffer too small")?;
    let slot = out.get_mut(n).ok_or("output buffer too small")?;
    *slot = 0;
    Ok(n + 1)
}

/// Counters of what the decoder saw.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct DecodeStats {
    /// Valid frames.
    pub frames: u64,
    /// Frames with a bad CRC.
    pub crc_errors: u64,
    /// Frames that were not valid COBS or not a valid message.
    pub malformed: u64,
    /// Frames longer than [`MAX_FRAME`], skipped to the next delimiter.
    pub overflows: u64,
}

impl DecodeStats {
    /// Frames discarded for any reason (each one a resynchronisation).
    #[must_use]
    pub fn resyncs(&self) -> u64 {
        self.crc_errors + self.malformed + self.overflows
    }
}

/// A sans-IO frame decoder: feed it bytes, get messages.
#[derive(Debug, Clone)]
pub struct Decoder {
    buf: [u8; MAX_FRAME],
    len: usize,
    overflow: bool,
    stats: DecodeStats,
}

impl Default for Decoder {
    fn default() -> Self {
        Decoder {
            buf: [0; MAX_FRAME],
            len: 0,
            overflow: false,
            stats: DecodeStats::default(),
        }
    }
}

impl Decoder {
    /// A decoder with nothing buffered.
    #[must_use]
    pub fn new() -> Self {
        Self::default()
    }

    /// What it saw so far.
    #[must_use]
    pub fn stats(&self) -> DecodeStats {
        self.stats
    }

    /// Feeds `bytes` (any chunk of the stream); calls `on_message` for each
    /// valid frame completed by them.
    pub fn feed(&mut self, bytes: &[u8], mut on_message: impl FnMut(Message)) {
        for &b in bytes {
            if b != 0 {
                if self.len < self.buf.len() {
                    self.buf[self.len] = b;
                    self.len += 1;
                } else {
                    self.overflow = true;
                }
                continue;
            }
            // A delimiter ends a frame.
            let (len, overflow) = (self.len, self.overflow);
            self.len = 0;
            self.overflow = false;
            if overflow {
                self.stats.overflows += 1;
                continue;
            }
            if len == 0 {
                continue; // Back-to-back delimiters: an empty frame, ignored.
            }
            match self.decode(len) {
                Ok(m) => {
                    self.stats.frames += 1;
                    on_message(m);
                }
                Err(FrameError::Crc) => self.stats.crc_errors += 1,
                Err(FrameError::Malformed) => self.stats.malformed += 1,
            }
        }
    }

    /// Decodes the buffered frame of `len` bytes.
    fn decode(&mut self, len: usize) -> Result<Message, FrameError> {
        let n = cobs::decode_in_place(&mut self.buf[..len]).map_err(|_| FrameError::Malformed)?;
        if n < 3 {
            return Err(FrameError::Malformed);
        }
        let (payload, crc) = self.buf[..n].split_at(n - 2);
        if CRC.checksum(payload).to_le_bytes() != [crc[0], crc[1]] {
            return Err(FrameError::Crc);
        }
        match postcard::take_from_bytes::<Message>(payload) {
            Ok((m, [])) => Ok(m),
            _ => Err(FrameError::Malformed),
        }
    }
}

enum FrameError {
    Crc,
    Malformed,
}
