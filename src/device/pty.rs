//! The port an emulated device serves: an existing port, or a new
//! pseudo-terminal linked at a path (a shell: it makes files and links).

use std::io::ErrorKind;
use std::path::{Path, PathBuf};
use std::time::Duration;

/// How long a read or write on the emulator's port may wait.
const PORT_TIMEOUT: Duration = Duration::from_millis(1);

/// Where [`open`] put the emulator.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Endpoint {
    /// The path was a port (or a link to one): opened as it is, the path
    /// left in place.
    Port,
    /// A new pseudo-terminal, linked at the path.
    Pty {
        /// The pseudo-terminal's slave end, where the link points.
        slave: PathBuf,
        /// Where the dangling link that was replaced pointed, if there was
        /// one (a pseudo-terminal of an earlier emulator, gone).
        replaced: Option<PathBuf>,
    },
}

/// Why [`open`] failed; displays as the `<what>` of an error line about
/// the path.
#[derive(Debug, thiserror::Error)]
pub enum OpenError {
    /// The path is a file or a folder.
    #[error("{0}, not a serial port")]
    NotAPort(&'static str),
    /// A dangling link that does not point where pseudo-terminals live: not
    /// one an emulator made, so it is left alone.
    #[error(
        "a link to {}, which does not exist (only a link to a pseudo-terminal that is gone is replaced)",
        .0.display()
    )]
    DanglingLink(PathBuf),
    /// The port would not open.
    #[error("cannot open: {0}")]
    Open(serialport::Error),
    /// No pseudo-terminal could be made.
    #[error("cannot create a pseudo-terminal: {0}")]
    Pty(serialport::Error),
    /// The path could not be read.
    #[error("cannot read: {0}")]
    Inspect(std::io::Error),
    /// The dangling link could not be removed.
    #[error("cannot remove the dangling link: {0}")]
    Unlink(std::io::Error),
    /// The new pseudo-terminal could not be linked at the path.
    #[error("cannot link: {0}")]
    Link(std::io::Error),
    /// Something is at the path already (a new pseudo-terminal's link goes
    /// only where nothing is, or a link to a pseudo-terminal that is gone).
    #[error("something is there already (a link goes only where nothing is)")]
    Exists,
}

/// An emulated device's port: a pseudo-terminal's master end (or a port),
/// for an emulator to serve.
#[derive(Debug)]
pub struct Emulated {
    port: serialport::TTYPort,
    /// A new pseudo-terminal's slave end, held open: the master's reads
    /// fail once every slave handle is closed.
    _slave: Option<serialport::TTYPort>,
    endpoint: Endpoint,
}

impl Emulated {
    /// Where the emulator is.
    #[must_use]
    pub fn endpoint(&self) -> &Endpoint {
        &self.endpoint
    }

    /// The port to serve.
    pub fn port(&mut self) -> &mut serialport::TTYPort {
        &mut self.port
    }

    /// Closes the port as an unplugged device's goes: a new
    /// pseudo-terminal's link at `path` is removed first (if it still
    /// points there), as unplugging a USB device removes its port, then
    /// the pseudo-terminal is closed. (Closed first, the link would point
    /// at a freed pseudo-terminal number, which the next one made on this
    /// machine takes: a host reopening the path would reach another
    /// emulator.) A port that was there before is left as it is.
    pub fn unplug(self, path: &Path) {
        if let Endpoint::Pty { slave, .. } = &self.endpoint
            && std::fs::read_link(path).is_ok_and(|t| t == *slave)
        {
            let _ = std::fs::remove_file(path);
        }
    }
}

/// Finds the emulator's port for `path`:
/// - a path that exists (a port, or a link to one, as in
///   `/dev/serial/by-id/`) is opened as a port, and left as it is;
/// - a path where nothing is gets a new pseudo-terminal, linked there;
/// - so does a dangling link to a pseudo-terminal (as an earlier emulator
///   leaves behind): the link is replaced. Any other dangling link is an
///   error.
///
/// # Errors
/// What went wrong, for `error: <path>: <what>`.
pub fn open(path: &Path) -> Result<Emulated, OpenError> {
    match std::fs::metadata(path) {
        Ok(meta) => return open_port(path, &meta),
        Err(e) if e.kind() != ErrorKind::NotFound => return Err(OpenError::Inspect(e)),
        Err(_) => {}
    }
    // Nothing there, or a link to nothing.
    let dangling = free_place(path)?;
    let (mut master, slave) = serialport::TTYPort::pair().map_err(OpenError::Pty)?;
    serialport::SerialPort::set_timeout(&mut master, PORT_TIMEOUT).map_err(OpenError::Pty)?;
    let slave_path = serialport::SerialPort::name(&slave).map_or_else(
        || {
            Err(OpenError::Pty(serialport::Error::new(
                serialport::ErrorKind::Unknown,
                "the pseudo-terminal has no name",
            )))
        },
        |name| Ok(PathBuf::from(name)),
    )?;
    place_link(path, &slave_path, dangling.as_deref())?;
    Ok(Emulated {
        port: master,
        _slave: Some(slave),
        endpoint: Endpoint::Pty {
            slave: slave_path,
            replaced: dangling,
        },
    })
}

/// Links the pseudo-terminal `slave` at `path`, where nothing may be but a
/// dangling link to a pseudo-terminal (an earlier emulator's or QEMU's,
/// gone), which is replaced; returns where that link pointed.
///
/// # Errors
/// Something else at `path`, or the link failed.
pub fn link_pty(path: &Path, slave: &Path) -> Result<Option<PathBuf>, OpenError> {
    let dangling = free_place(path)?;
    place_link(path, slave, dangling.as_deref())?;
    Ok(dangling)
}

/// Checks that nothing is at `path` but perhaps a dangling link; returns
/// where that link points. (Checked before a new pseudo-terminal is made:
/// it may get the number of the one a dangling link names.)
fn free_place(path: &Path) -> Result<Option<PathBuf>, OpenError> {
    match std::fs::metadata(path) {
        Ok(_) => return Err(OpenError::Exists),
        Err(e) if e.kind() != ErrorKind::NotFound => return Err(OpenError::Inspect(e)),
        Err(_) => {}
    }
    match std::fs::read_link(path) {
        Ok(target) => Ok(Some(target)),
        Err(e) if e.kind() == ErrorKind::NotFound => Ok(None),
        Err(e) => Err(OpenError::Inspect(e)),
    }
}

/// Links `slave` at `path`, replacing the `dangling` link [`free_place`]
/// found if it pointed where pseudo-terminals live.
fn place_link(path: &Path, slave: &Path, dangling: Option<&Path>) -> Result<(), OpenError> {
    if let Some(target) = dangling {
        if target.parent() != slave.parent() {
            return Err(OpenError::DanglingLink(target.to_owned()));
        }
        std::fs::remove_file(path).map_err(OpenError::Unlink)?;
    }
    std::os::unix::fs::symlink(slave, path).map_err(OpenError::Link)
}

/// Opens the existing `path` as a port.
fn open_port(path: &Path, meta: &std::fs::Metadata) -> Result<Emulated, OpenError> {
    if let Some(what) = super::not_a_port(meta) {
        return Err(OpenError::NotAPort(what));
    }
    let port = serialport::new(path.to_string_lossy(), super::transport::BAUD)
        .timeout(PORT_TIMEOUT)
        .open_native()
        .map_err(OpenError::Open)?;
    Ok(Emulated {
        port,
        _slave: None,
        endpoint: Endpoint::Port,
    })
}

/// Whether a port error only means "not now" (nothing to read, no room to
/// write).
#[must_use]
pub fn is_busy(e: &std::io::Error) -> bool {
    matches!(
        e.kind(),
        ErrorKind::TimedOut | ErrorKind::WouldBlock | ErrorKind::Interrupted
    )
}
