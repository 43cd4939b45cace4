//! The one atomic file write: readers see the old file or the new one,
//! never half of one.

use std::fs::File;
use std::io::Write;
use std::path::Path;

use super::{ResultsError, io_err};

/// Writes `contents` to `path` by a temporary file and a rename, so readers
/// see the old or the new file, never half of one; `durable` also fsyncs.
///
/// # Errors
/// Any I/O error; `path` is then untouched.
pub fn replace_file(path: &Path, contents: &[u8], durable: bool) -> Result<(), ResultsError> {
    // Unique per call: threads of one process (a parallel `simulate`) may
    // replace the same file at once, and must not share a temporary.
    static CALLS: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
    let parent = path.parent().unwrap_or(Path::new("."));
    std::fs::create_dir_all(parent).map_err(io_err(parent))?;
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
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
