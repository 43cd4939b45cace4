//! How a session drives the hand of an emulated device whose protocol has
//! no message for it (the 2DIY's): a Unix datagram socket beside the
//! device's path (`PATH.hand`), which the emulator binds. A real device has
//! no such socket, so nothing is ever sent to it. A shell.
//!
//! A datagram is one [`HandDrive`]: five `f64` and the `u32` segment,
//! little-endian.

use std::os::unix::net::UnixDatagram;
use std::path::{Path, PathBuf};

use crate::hand::HandDrive;

/// Bytes of a datagram.
pub const DATAGRAM: usize = 44;

/// The socket beside the device at `path`.
#[must_use]
pub fn socket_path(path: &Path) -> PathBuf {
    let mut p = path.as_os_str().to_owned();
    p.push(".hand");
    PathBuf::from(p)
}

/// A drive as a datagram.
#[must_use]
pub fn encode(d: &HandDrive) -> [u8; DATAGRAM] {
    let mut out = [0_u8; DATAGRAM];
    let values = [
        d.x_m,
        d.v_m_s,
        d.stiffness_n_m,
        d.damping_n_s_m,
        d.integral_gain,
    ];
    for (k, v) in values.iter().enumerate() {
        out[8 * k..8 * k + 8].copy_from_slice(&v.to_le_bytes());
    }
    out[40..].copy_from_slice(&d.segment.to_le_bytes());
    out
}

/// A datagram as a drive (values not finite read as 0); None if it is not
/// [`DATAGRAM`] bytes.
#[must_use]
pub fn decode(bytes: &[u8]) -> Option<HandDrive> {
    if bytes.len() != DATAGRAM {
        return None;
    }
    let f = |k: usize| {
        let v = f64::from_le_bytes(bytes[8 * k..8 * k + 8].try_into().unwrap_or([0; 8]));
        if v.is_finite() { v } else { 0.0 }
    };
    Some(HandDrive {
        x_m: f(0),
        v_m_s: f(1),
        stiffness_n_m: f(2),
        damping_n_s_m: f(3),
        integral_gain: f(4),
        segment: u32::from_le_bytes(bytes[40..44].try_into().unwrap_or([0; 4])),
    })
}

/// The host's end: sends drives to the emulator at `path`, if one listens.
#[derive(Debug)]
pub struct Sender {
    target: PathBuf,
    socket: Option<UnixDatagram>,
}

impl Sender {
    /// A sender to the emulator of the device at `path`.
    #[must_use]
    pub fn new(path: &Path) -> Self {
        Sender {
            target: socket_path(path),
            socket: UnixDatagram::unbound()
                .ok()
                .filter(|s| s.set_nonblocking(true).is_ok()),
        }
    }

    /// Sends a drive (dropped when no emulator listens, or its queue is
    /// full).
    pub fn send(&self, d: &HandDrive) {
        if let Some(s) = &self.socket {
            let _ = s.send_to(&encode(d), &self.target);
        }
    }
}

/// The emulator's end, bound beside its device path (replacing a socket an
/// earlier emulator left).
#[derive(Debug)]
pub struct Receiver {
    socket: UnixDatagram,
    path: PathBuf,
}

impl Receiver {
    /// Binds beside `path`.
    ///
    /// # Errors
    /// The socket could not be bound.
    pub fn bind(path: &Path) -> std::io::Result<Self> {
        let at = socket_path(path);
        if std::fs::symlink_metadata(&at).is_ok_and(|m| {
            use std::os::unix::fs::FileTypeExt as _;
            m.file_type().is_socket()
        }) {
            std::fs::remove_file(&at)?;
        }
        let socket = UnixDatagram::bind(&at)?;
        socket.set_nonblocking(true)?;
        Ok(Receiver { socket, path: at })
    }

    /// The newest drive that arrived since the last call, if any.
    #[must_use]
    pub fn latest(&self) -> Option<HandDrive> {
        let mut buf = [0_u8; 64];
        let mut last = None;
        while let Ok(n) = self.socket.recv(&mut buf) {
            last = decode(&buf[..n]).or(last);
        }
        last
    }
}

impl Drop for Receiver {
    fn drop(&mut self) {
        let _ = std::fs::remove_file(&self.path);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_drive_crosses_the_socket_whole() {
        let dir = tempfile::tempdir().unwrap();
        let dev = dir.path().join("dev");
        let rx = Receiver::bind(&dev).unwrap();
        let d = HandDrive {
            x_m: 0.0123,
            v_m_s: -0.2,
            stiffness_n_m: 300.0,
            damping_n_s_m: 12.5,
            integral_gain: 40.0,
            segment: 7,
        };
        Sender::new(&dev).send(&d);
        assert_eq!(rx.latest(), Some(d));
        assert_eq!(rx.latest(), None);
        assert_eq!(decode(&[0; 3]), None);
    }
}
