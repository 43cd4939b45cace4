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

/// Removes the temporaries [`replace_file`] left in `dir` for files whose
/// names start with `prefix` (`.PREFIX....partial`): a process killed
/// (kill -9, power loss) between creating one and renaming it leaves it
/// behind; the file it was replacing is whole. Only for files no other
/// process may be replacing (a session's, under its session lock).
/// Returns how many were removed.
///
/// # Errors
/// A temporary that cannot be removed; a missing `dir` is nothing to do.
pub fn remove_partials(dir: &Path, prefix: &str) -> Result<usize, ResultsError> {
    let entries = match std::fs::read_dir(dir) {
        Ok(entries) => entries,
        Err(e) if e.kind() == io::ErrorKind::NotFound => return Ok(0),
        Err(e) => return Err(io_err(dir)(e)),
    };
    let mut removed = 0;
    for entry in entries {
        let path = entry.map_err(io_err(dir))?.path();
        let name = path.file_name().map(|n| n.to_string_lossy().into_owned());
        if name.is_some_and(|n| {
            n.strip_prefix('.')
                .is_some_and(|n| n.starts_with(prefix) && n.ends_with(".partial"))
        }) {
            std::fs::remove_file(&path).map_err(io_err(&path))?;
            removed += 1;
        }
    }
    Ok(removed)
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, reason = "tests: a panic is a failure")]
    use super::*;

    #[test]
    fn a_killed_writers_temporaries_of_the_named_files_are_removed_and_no_other_file() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        let names = [
            "s1_data.csv",
            ".s1_data.csv.4242.7.partial",
            ".s1_data.csv.4243.0.partial",
            ".s2_data.csv.4242.1.partial",
            "s1_data.csv.partial",
        ];
        for n in names {
            std::fs::write(d.join(n), "x").unwrap();
        }
        assert_eq!(remove_partials(d, "s1_data.csv").unwrap(), 2);
        let mut left: Vec<String> = std::fs::read_dir(d)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        left.sort();
        assert_eq!(
            left,
            [
                ".s2_data.csv.4242.1.partial",
                "s1_data.csv",
                "s1_data.csv.partial"
            ]
        );
        assert_eq!(remove_partials(&d.join("missing"), "s1").unwrap(), 0);
    }
}
