//! Where there is no PulseAudio protocol (no Unix sockets): no sound
//! server is found, and a session that needs one says so before it starts.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU32, AtomicU64};

use super::{AudioError, Output, Server, Source, StreamInfo};

/// The rate a stream would ask for, Hz.
pub const RATE_HZ: u32 = 48_000;

fn none() -> AudioError {
    AudioError::NoServer("this build plays sound through PulseAudio or PipeWire only".to_owned())
}

/// No outputs.
///
/// # Errors
/// Always: no server.
pub fn list(_server: &Server) -> Result<Vec<Output>, AudioError> {
    Err(none())
}

/// What a player's thread and its owner would share.
#[derive(Debug, Default)]
pub(super) struct Shared {
    pub underruns: AtomicU64,
    pub lost: AtomicBool,
    pub latency_us: AtomicU64,
    pub peak: AtomicU32,
    pub frames: AtomicU64,
}

/// Never opened.
pub struct Player {
    pub(super) shared: Arc<Shared>,
    pub(super) info: StreamInfo,
}

impl Player {
    /// # Errors
    /// Always: no server.
    pub fn open(
        _server: &Server,
        _output: &str,
        _buffer_frames: u32,
        _source: Box<dyn Source>,
    ) -> Result<Player, AudioError> {
        Err(none())
    }

    /// Nothing to finish.
    pub fn finish(&self) {}

    /// Never played.
    #[must_use]
    pub fn done(&self) -> bool {
        true
    }
}
