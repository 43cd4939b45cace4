//! The host's serial transport: a port at a path that is reopened when the
//! device goes away (unplugged, emulator restarted). A shell: it does I/O.

use std::io::{Read, Write};
use std::path::{Path, PathBuf};
use std::time::Duration;

/// Baud rate requested (ignored by USB CDC devices and pseudo-terminals).
pub const BAUD: u32 = 115_200;

/// A serial port that reopens itself after errors.
pub struct Transport {
    path: PathBuf,
    port: Option<Box<dyn serialport::SerialPort>>,
    reopens: u64,
}

impl std::fmt::Debug for Transport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Transport")
            .field("path", &self.path)
            .field("open", &self.port.is_some())
            .finish_non_exhaustive()
    }
}

impl Transport {
    /// A transport for the port at `path` (opened on first use).
    #[must_use]
    pub fn new(path: &Path) -> Self {
        Transport {
            path: path.to_owned(),
            port: None,
            reopens: 0,
        }
    }

    /// Whether the port is open now.
    #[must_use]
    pub fn is_open(&self) -> bool {
        self.port.is_some()
    }

    /// How many times the port was (re)opened.
    #[must_use]
    pub fn opens(&self) -> u64 {
        self.reopens
    }

    fn ensure_open(&mut self) {
        if self.port.is_none()
            && let Ok(port) = serialport::new(self.path.to_string_lossy(), BAUD)
                .timeout(Duration::from_millis(1))
                .open()
        {
            self.port = Some(port);
            self.reopens += 1;
        }
    }

    /// Reads what is available into `buf` without blocking (0 when nothing
    /// is, or the port is closed); an error closes the port, to be reopened
    /// on the next call.
    pub fn read(&mut self, buf: &mut [u8]) -> usize {
        self.ensure_open();
        let Some(port) = self.port.as_mut() else {
            return 0;
        };
        // Never block the loop: read only what is already waiting.
        match port.bytes_to_read() {
            Ok(0) => return 0,
            Ok(_) => {}
            Err(_) => {
                self.port = None;
                return 0;
            }
        }
        match port.read(buf) {
            Ok(n) => n,
            Err(e)
                if matches!(
                    e.kind(),
                    std::io::ErrorKind::TimedOut | std::io::ErrorKind::WouldBlock
                ) =>
            {
                0
            }
            Err(_) => {
                self.port = None;
                0
            }
        }
    }

    /// Writes `bytes`; an error closes the port.
    pub fn write(&mut self, bytes: &[u8]) {
        self.ensure_open();
        if let Some(port) = self.port.as_mut()
            && port.write_all(bytes).is_err()
        {
            self.port = None;
        }
    }
}
