//! One process per session (issue 31): OS file locks (`flock` on Unix,
//! `LockFileEx` on Windows, through std's `File::try_lock`), which the
//! kernel releases when the process ends, even under kill -9.
//!
//! - **The session lock**: an exclusive lock on the session log, held by
//!   the process that has the session open, from the moment it chooses the
//!   session (a resume) or creates its log (a new one) until it lets go of
//!   the session. A second process is refused ([`ResultsError::Busy`]).
//! - **The folder lock**: an exclusive lock on `DIR/logs/` (a lock file in
//!   it where folders cannot be locked), held only while a process chooses
//!   and opens a session. So two processes cannot take one session number,
//!   and a participant with a session open in one process cannot start or
//!   resume one in another.
//! - **Probes** ([`open_elsewhere`]) take a shared lock for an instant and
//!   write nothing: the window, `analyze` and `simulate` use them to tell a
//!   session open elsewhere. A process taking a session lock retries for
//!   a moment, so a probe's instant is never mistaken for a holder.

use std::fs::{File, OpenOptions, TryLockError};
use std::path::{Path, PathBuf};
use std::time::Duration;

use super::{ResultsError, io_err};

/// How often, and how far apart, taking a session lock is tried before the
/// session counts as open elsewhere: a probe holds its shared lock for
/// microseconds.
const TRIES: u32 = 10;
const TRY_EVERY: Duration = Duration::from_millis(20);

/// Who has a session open: the process id where the OS tells it (Linux).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Holder {
    /// The holder's process id.
    pub pid: Option<u32>,
}

impl Holder {
    /// ` (pid N)`, or nothing where the OS does not tell.
    #[must_use]
    pub fn pid_text(self) -> String {
        self.pid.map(|p| format!(" (pid {p})")).unwrap_or_default()
    }
}

/// Takes the session lock on an open log file, retrying for a moment.
/// `Ok(false)`: another process holds it.
pub(super) fn lock_session(file: &File) -> std::io::Result<bool> {
    for attempt in 0..TRIES {
        match file.try_lock() {
            Ok(()) => return Ok(true),
            Err(TryLockError::WouldBlock) if attempt + 1 < TRIES => {
                std::thread::sleep(TRY_EVERY);
            }
            Err(TryLockError::WouldBlock) => return Ok(false),
            Err(TryLockError::Error(e)) => return Err(e),
        }
    }
    Ok(false)
}

/// Whether the session log at `path` is open in another process (or in
/// another part of this one), and who holds it. Writes nothing; a missing
/// or unreadable log is not open.
#[must_use]
pub fn open_elsewhere(path: &Path) -> Option<Holder> {
    let file = File::open(path).ok()?;
    match file.try_lock_shared() {
        Err(TryLockError::WouldBlock) => Some(Holder {
            pid: holder_pid(path),
        }),
        Ok(()) | Err(TryLockError::Error(_)) => None,
    }
}

/// An exclusive lock on a folder, held until dropped: the folder lock of
/// `logs/` (module docs), and an output folder while it is written
/// (`analyze --out`).
#[derive(Debug)]
pub struct FolderLock {
    _file: File,
}

impl FolderLock {
    /// Locks the folder `dir`, waiting for another process's lock to go;
    /// with `create`, makes the folder first. `None`: the folder does not
    /// exist (and `create` is false).
    ///
    /// # Errors
    /// I/O.
    pub fn take(dir: &Path, create: bool) -> Result<Option<FolderLock>, ResultsError> {
        if create {
            std::fs::create_dir_all(dir).map_err(io_err(dir))?;
        } else if !dir.is_dir() {
            return Ok(None);
        }
        let file = folder_handle(dir)?;
        file.lock().map_err(io_err(dir))?;
        Ok(Some(FolderLock { _file: file }))
    }
}

/// Takes an exclusive lock on the file at `path` (made if missing, never
/// truncated) without waiting, held for as long as the file is: the lock
/// of a job that one process at a time may run (a `power` shard).
/// `Ok(Err(holder))`: another process holds it.
///
/// # Errors
/// I/O.
pub fn lock_file(path: &Path) -> Result<Result<File, Holder>, ResultsError> {
    let file = OpenOptions::new()
        .create(true)
        .truncate(false)
        .write(true)
        .open(path)
        .map_err(io_err(path))?;
    Ok(if lock_session(&file).map_err(io_err(path))? {
        Ok(file)
    } else {
        Err(Holder {
            pid: holder_pid(path),
        })
    })
}

#[cfg(unix)]
fn folder_handle(logs: &Path) -> Result<File, ResultsError> {
    File::open(logs).map_err(io_err(logs))
}

/// Where a folder cannot be opened as a file, a lock file in it.
#[cfg(not(unix))]
fn folder_handle(logs: &Path) -> Result<File, ResultsError> {
    let path = logs.join(".folder.lock");
    OpenOptions::new()
        .create(true)
        .truncate(false)
        .write(true)
        .open(&path)
        .map_err(io_err(&path))
}

/// Opens an existing log to append and takes its session lock.
///
/// # Errors
/// [`ResultsError::Busy`] when another process holds it (`who` names the
/// session in the message), or I/O.
pub(super) fn open_locked(path: &Path, who: (u32, &str)) -> Result<File, ResultsError> {
    let file = OpenOptions::new()
        .read(true)
        .write(true)
        .open(path)
        .map_err(io_err(path))?;
    if lock_session(&file).map_err(io_err(path))? {
        Ok(file)
    } else {
        Err(busy(path, who, holder_pid(path)))
    }
}

/// The error of a session open in another process.
pub(super) fn busy(
    path: &Path,
    (session, participant): (u32, &str),
    pid: Option<u32>,
) -> ResultsError {
    ResultsError::Busy {
        path: path.display().to_string(),
        session,
        participant: participant.to_owned(),
        pid,
    }
}

/// A unique temporary name beside `path` (hidden, never a `_log.jsonl`).
pub(super) fn temporary(path: &Path) -> PathBuf {
    static CALLS: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
    let call = CALLS.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    path.with_file_name(format!(".{name}.{}.{call}.creating", std::process::id()))
}

/// The process holding an exclusive `flock` on `path`, from `/proc/locks`
/// (Linux; `None` elsewhere or when not found). Matched by inode, and by
/// device where it agrees (an overlay file system reports another device
/// than the lock's).
#[cfg(target_os = "linux")]
fn holder_pid(path: &Path) -> Option<u32> {
    use std::os::unix::fs::MetadataExt;
    let meta = std::fs::metadata(path).ok()?;
    let (dev, ino) = (meta.dev(), meta.ino());
    let major = ((dev >> 8) & 0xfff) | ((dev >> 32) & 0xffff_f000);
    let minor = (dev & 0xff) | ((dev >> 12) & 0xffff_ff00);
    let locks = std::fs::read_to_string("/proc/locks").ok()?;
    let mut same_inode = None;
    for line in locks.lines() {
        // "3: FLOCK  ADVISORY  WRITE 6632 fe:00:10010821 0 EOF"; a waiter's
        // line has "->" after the number.
        let f: Vec<&str> = line.split_whitespace().collect();
        if f.get(1) != Some(&"FLOCK") || f.get(3) != Some(&"WRITE") {
            continue;
        }
        let (Some(pid), Some(id)) = (f.get(4).and_then(|p| p.parse::<u32>().ok()), f.get(5)) else {
            continue;
        };
        let mut parts = id.split(':');
        let (Some(maj), Some(min), Some(i)) = (parts.next(), parts.next(), parts.next()) else {
            continue;
        };
        if i.parse::<u64>().ok() != Some(ino) {
            continue;
        }
        let hex = |s: &str| u64::from_str_radix(s, 16).ok();
        if hex(maj) == Some(major) && hex(min) == Some(minor) {
            return Some(pid);
        }
        same_inode.get_or_insert(pid);
    }
    same_inode
}

#[cfg(not(target_os = "linux"))]
fn holder_pid(_path: &Path) -> Option<u32> {
    None
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, reason = "tests: a panic is a failure")]

    use super::*;

    #[test]
    fn a_held_log_is_open_elsewhere_with_this_pid_and_free_once_let_go() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("x_log.jsonl");
        std::fs::write(&path, "{}\n").unwrap();
        assert_eq!(open_elsewhere(&path), None);
        let held = open_locked(&path, (1, "p")).unwrap();
        let holder = open_elsewhere(&path).unwrap();
        if cfg!(target_os = "linux") {
            assert_eq!(holder.pid, Some(std::process::id()));
        }
        let again = open_locked(&path, (1, "p")).unwrap_err();
        assert!(
            again
                .to_string()
                .contains("session 1 of 'p' is open in another process"),
            "{again}"
        );
        drop(held);
        assert_eq!(open_elsewhere(&path), None);
        assert!(open_locked(&path, (1, "p")).is_ok());
    }

    #[test]
    fn a_probe_does_not_keep_a_session_from_opening() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("x_log.jsonl");
        std::fs::write(&path, "{}\n").unwrap();
        let probe = File::open(&path).unwrap();
        probe.try_lock_shared().unwrap();
        let released = std::thread::spawn(move || {
            std::thread::sleep(Duration::from_millis(50));
            drop(probe);
        });
        assert!(open_locked(&path, (1, "p")).is_ok());
        released.join().unwrap();
    }
}
