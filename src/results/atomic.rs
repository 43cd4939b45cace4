//! The one atomic file write: readers see the old file or the new one,
//! never half of one.

use std::fs::File;
use std::io::{self, Write};
use std::path::Path;

use super::{ResultsError, io_err};

/// Writes `contents` to `path` by a temporary file and a rename, so readers
/// see the old or the new file, never half of one; `durable` also fsyncs.
/// Creates missing parent folders.
///
/// # Errors
/// A path that names no file (`..`, `/`), or any I/O error (naming the
/// parent folder when it cannot be created); `path` is then untouched.
pub fn replace_file(path: &Path, contents: &[u8], durable: bool) -> Result<(), ResultsError> {
    // Unique per call: threads of one process (a parallel `simulate`) may
    // replace the same file at once, and must not share a temporary.
    static CALLS: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
    let parent = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    std::fs::create_dir_all(parent).map_err(io_err(parent))?;
    let name = path
        .file_name()
        .ok_or_else(|| io::Error::new(io::ErrorKind::InvalidInput, "not a file name"))
        .map_err(io_err(path))?
        .to_string_lossy();
    let call = CALLS.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    let tmp = parent.join(format!(".{name}.{}.{call}.partial", std::process::id()));
    let result = (|| {
        let mut f = File::create(&tmp)?;
        f.write_all(contents)?;
        if durable {
            f.sync_all()?;
        }
        std::fs::rename(&tmp, path)
    })();
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result.map_err(io_err(path))
}
