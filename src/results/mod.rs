//! The results folder: the crash-safe trial log, the data CSVs made from it,
//! and `dataset_description.json` (documented in `results-schema/`).
//!
//! ```text
//! DIR/dataset_description.json
//! DIR/data/study-<P>_subject-<S>_session-<n>_data.csv
//! DIR/logs/study-<P>_subject-<S>_session-<n>_log.jsonl
//! ```
//!
//! `<P>` and `<S>` are the protocol and participant ids with everything but
//! letters and digits left out. The log is primary: append-only JSON Lines, a
//! header, then one line per completed or aborted trial, each flushed and
//! fsync'd before the next trial starts. The CSV is rewritten from the log
//! after every trial (atomically, by rename). It is derived data, rebuilt on
//! resume, so it is not fsync'd. A session's log is created with
//! `create_new`, so a session is never overwritten.
//!
//! The parts: `session_log.rs` (the log's lines, writing and reading it back,
//! torn lines), `trial.rs` (a trial as logged: the engine's record and what
//! the session added), `folder.rs` (the folder's layout, file names, session
//! numbering), `export.rs` (the data CSVs and `dataset_description.json`;
//! each kind writes its own cells with `csv.rs`), `reader.rs` (the one CSV
//! reader), `verify.rs` (each data CSV held against its log),
//! `atomic.rs` (the one atomic file write) and `device_checks.rs` (the
//! bring-up checks' reports, `DIR/device-checks/`).

mod atomic;
mod compact;
pub mod csv;
pub mod device_checks;
mod export;
mod folder;
mod lock;
pub mod reader;
mod session_log;
mod trial;
mod verify;

use std::io;
use std::path::Path;

pub use atomic::{remove_partials, replace_file};
pub use export::{
    COMMON_COLUMNS, Cells, DataText, LSL_COLUMNS, data_columns, data_csv, kinds_present,
    write_dataset_description,
};
pub use folder::{
    MAX_ID_CHARS, ResultsDir, SessionFiles, SessionOverview, SessionStatus, check_participant,
    file_key,
};
pub use lock::{FolderLock, Holder, lock_file, open_elsewhere};
pub use session_log::{
    Header, LOG_FORMAT, LogLine, ReadLog, SessionLog, is_completed, log_json_schema, parse_log,
    read_header, read_log, sha256_hex,
};
pub use trial::{LoggedTrial, RenderEntry, RenderMode};
pub use verify::{Checked, NO_LOG, Source, Verified, data_files, verify};

/// Why a results operation failed.
#[derive(Debug, thiserror::Error)]
pub enum ResultsError {
    /// A participant id whose file names are another participant's (ids
    /// differing only in `-` and `_`): bad input (exit 2).
    #[error(
        "'{participant}' collides with participant '{other}' in file names ({key}); choose another id"
    )]
    Collision {
        /// The id asked for.
        participant: String,
        /// The id already in the folder.
        other: String,
        /// The file-name key both give.
        key: String,
    },
    /// An unreadable or malformed log.
    #[error("{path}: {line}:{column}: {message}")]
    Log {
        /// The log file.
        path: String,
        /// 1-based line.
        line: usize,
        /// 1-based column.
        column: usize,
        /// What is wrong.
        message: String,
    },
    /// The session is open in another process (issue 31): bad input (exit
    /// 2); nothing was written.
    #[error(
        "{path}: session {session} of '{participant}' is open in another process{}; wait for it to end, or resume it there",
        pid.map(|p| format!(" (pid {p})")).unwrap_or_default()
    )]
    Busy {
        /// The session's log.
        path: String,
        /// Its number.
        session: u32,
        /// Its participant.
        participant: String,
        /// The process holding it, where the OS tells.
        pid: Option<u32>,
    },
    /// An I/O error on a file.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: String,
        /// The error.
        source: io::Error,
    },
}

fn io_err(path: &Path) -> impl FnOnce(io::Error) -> ResultsError + '_ {
    move |source| ResultsError::Io {
        path: path.display().to_string(),
        source,
    }
}
