//! The session log: its header and lines (JSON Lines, with a JSON Schema),
//! [`SessionLog`] that appends them (flushed and fsync'd line by line), and
//! [`read_log`] that reads them back, a torn last line ignored and measured.

use std::fmt::Write as _;
use std::fs::{File, OpenOptions};
use std::io::{self, BufRead, BufReader, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};
use sha2::{Digest, Sha256};

use super::trial::LoggedTrial;
use super::{ResultsError, io_err, lock};
use crate::protocol::Protocol;
use crate::protocol::engine::{Status, TrialRecord};
use crate::protocol::kind::Kinds;

/// Format tag of the log header. Format 2 (issue 42): every time is a
/// whole number of the session's ticks, and times inside a trial (a Fitts
/// test's taps and clicks) are measured from the trial's start. Format 1
/// logs still read: their float session times to the nearest nanosecond
/// ([`crate::time::Time`]), their Fitts times as the session times they
/// were.
pub const LOG_FORMAT: &str = "frictionlab-log/2";

/// The first line of a session log.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, bound = "")]
#[schemars(rename = "Header", bound = "")]
pub struct Header<K: Kinds> {
    /// [`LOG_FORMAT`].
    pub format: String,
    /// frictionlab version that wrote the log.
    pub software_version: String,
    /// Protocol id.
    pub protocol_id: String,
    /// SHA-256 of the protocol file's bytes, hex.
    pub protocol_sha256: String,
    /// The protocol as loaded (resume replays it).
    pub protocol: Protocol<K>,
    /// Plan seed.
    pub plan_seed: u64,
    /// Participant id.
    pub participant: String,
    /// Participant index used for counterbalancing.
    pub participant_index: u32,
    /// Session number (1-based).
    pub session: u32,
    /// Device (`sim`, a port path, or `KIND:TARGET`).
    pub device: String,
    /// The device's settings as it reported them and as they were chosen
    /// (a service's filters, a calibration, the track), where it has any.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub device_settings: Option<serde_json::Value>,
    /// What the device states of its force limit and its reach along the
    /// track (issue 63; absent in logs from before).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub device_limits: Option<crate::device::backend::DeviceLimits>,
    /// The last bring-up check made on the device in the results folder
    /// when the session began (`frictionlab check-device`, issue 63; absent:
    /// none was, or a log from before).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub device_check: Option<super::device_checks::DeviceCheckRef>,
    /// Responder (`sim` or `gui`).
    pub responder: String,
    /// Number of planned trials.
    pub planned_trials: usize,
    /// The simulated participant's population when it is not the default
    /// (`simulate --population`); absent: the default.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub population: Option<crate::participant::Population>,
    /// What the session played on the sound server's outputs (issue 64):
    /// the output, its rate, its buffer and the latency the server reported;
    /// empty when nothing played.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub sound: Vec<crate::audio::Playing>,
}

/// One line of a session log.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(tag = "type", rename_all = "snake_case", bound = "")]
#[schemars(rename = "LogLine", bound = "")]
pub enum LogLine<K: Kinds> {
    /// The header (first line).
    Header(Box<Header<K>>),
    /// A completed or aborted trial.
    Trial(LoggedTrial<K>),
    /// The session was resumed here.
    Resumed {
        /// First trial run after the resume.
        at_trial: usize,
        /// Bytes of a torn last line that were cut off before resuming.
        torn_bytes: u64,
        /// The format of the records from here on, when it is not the
        /// header's: a session begun in an older format and resumed by a
        /// newer frictionlab (absent: the header's).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        format: Option<String>,
    },
    /// The haptic loop's timing and link statistics (device sessions).
    Loop(crate::device::haptic::LoopStats),
    /// What this run published on the Lab Streaming Layer (`--lsl`):
    /// counts, drops and latencies (issue 34).
    Lsl(crate::lsl::LslStats),
    /// How the run's sound went (issue 64): each stream's underruns, the
    /// tactile display's delays and clock origin.
    Sound(crate::audio::SoundStats),
    /// An experimenter's note.
    Note {
        /// The text.
        text: String,
    },
    /// A signal ended the run here (issue 31); the trial under way, if
    /// any, is logged before this line as aborted (`interrupted`).
    Interrupted {
        /// `SIGINT`, `SIGTERM` or `SIGHUP`.
        signal: String,
    },
    /// Every planned trial is done.
    End {
        /// Completed trials.
        completed: usize,
        /// Aborted trials.
        aborted: usize,
    },
}

/// The JSON Schema of one session-log line, pretty-printed (as shipped in
/// `results-schema/log-line.schema.json`).
#[must_use]
pub fn log_json_schema<K: Kinds>() -> String {
    let schema = schemars::schema_for!(LogLine<K>);
    serde_json::to_string_pretty(&schema).unwrap_or_default() + "\n"
}

/// Hex SHA-256 of `bytes`.
#[must_use]
pub fn sha256_hex(bytes: &[u8]) -> String {
    Sha256::digest(bytes)
        .iter()
        .fold(String::new(), |mut s, b| {
            let _ = write!(s, "{b:02x}");
            s
        })
}

/// An open session log, appended to line by line.
#[derive(Debug)]
pub struct SessionLog {
    file: File,
    path: PathBuf,
}

impl SessionLog {
    /// Creates a new log at `path` with its header line, never
    /// overwriting, and holds its session lock (issue 31) until dropped.
    /// The log appears whole: it is written under a temporary name, locked,
    /// then linked into place, so no reader finds it without its header or
    /// unlocked. Where the file system has no hard links (FAT, exFAT) it is
    /// created in place and locked at once.
    ///
    /// # Errors
    /// The file exists, or any I/O error.
    pub fn create<K: Kinds>(path: &Path, header: Header<K>) -> Result<Self, ResultsError> {
        if let Some(parent) = path.parent() {
            std::fs::create_dir_all(parent).map_err(io_err(parent))?;
        }
        let who = (header.session, header.participant.clone());
        let line = LogLine::Header(Box::new(header));
        let tmp = lock::temporary(path);
        let mut log = SessionLog::new_locked(&tmp, (who.0, &who.1))?;
        let linked = log
            .append(&line)
            .and_then(|()| std::fs::hard_link(&tmp, path).map_err(io_err(path)));
        let _ = std::fs::remove_file(&tmp);
        log = match linked {
            Ok(()) => SessionLog {
                path: path.to_owned(),
                ..log
            },
            Err(ResultsError::Io { source, .. })
                if source.kind() != io::ErrorKind::AlreadyExists =>
            {
                drop(log);
                let mut log = SessionLog::new_locked(path, (who.0, &who.1))?;
                log.append(&line)?;
                log
            }
            Err(e) => return Err(e),
        };
        if let Some(parent) = path.parent() {
            // Make the new file's directory entry durable too.
            let _ = File::open(parent).and_then(|d| d.sync_all());
        }
        Ok(log)
    }

    /// A new, empty file at `path`, its session lock taken.
    fn new_locked(path: &Path, who: (u32, &str)) -> Result<Self, ResultsError> {
        let file = OpenOptions::new()
            .write(true)
            .create_new(true)
            .open(path)
            .map_err(io_err(path))?;
        if !lock::lock_session(&file).map_err(io_err(path))? {
            return Err(lock::busy(path, who, None));
        }
        Ok(SessionLog {
            file,
            path: path.to_owned(),
        })
    }

    /// Continues an existing log whose session lock `file` holds
    /// ([`super::ResultsDir::lock_session`]); a torn last line (bytes past
    /// `valid_len`) is cut off first. Returns the log and the number of
    /// bytes cut.
    ///
    /// # Errors
    /// Any I/O error.
    pub fn reopen(
        mut file: File,
        path: &Path,
        valid_len: u64,
    ) -> Result<(Self, u64), ResultsError> {
        let len = file.metadata().map_err(io_err(path))?.len();
        let torn = len.saturating_sub(valid_len);
        if torn > 0 {
            file.set_len(valid_len).map_err(io_err(path))?;
            file.sync_all().map_err(io_err(path))?;
        }
        file.seek(SeekFrom::End(0)).map_err(io_err(path))?;
        Ok((
            SessionLog {
                file,
                path: path.to_owned(),
            },
            torn,
        ))
    }

    /// Appends one line, flushed and fsync'd before returning.
    ///
    /// # Errors
    /// Any I/O error.
    pub fn append<K: Kinds>(&mut self, line: &LogLine<K>) -> Result<(), ResultsError> {
        let mut text = serde_json::to_string(line).map_err(|e| ResultsError::Io {
            path: self.path.display().to_string(),
            source: io::Error::other(e),
        })?;
        text.push('\n');
        self.file
            .write_all(text.as_bytes())
            .map_err(io_err(&self.path))?;
        self.file.flush().map_err(io_err(&self.path))?;
        self.file.sync_data().map_err(io_err(&self.path))
    }

    /// The log's path.
    #[must_use]
    pub fn path(&self) -> &Path {
        &self.path
    }
}

/// A log as read back.
#[derive(Debug, Clone, PartialEq)]
pub struct ReadLog<K: Kinds> {
    /// The header.
    pub header: Header<K>,
    /// Trial records in log order.
    pub trials: Vec<LoggedTrial<K>>,
    /// Whether the session ended.
    pub ended: bool,
    /// Length of the valid part (up to the last complete line), bytes.
    pub valid_len: u64,
    /// Bytes of a torn last line, ignored.
    pub torn_bytes: u64,
}

impl<K: Kinds> ReadLog<K> {
    /// Trials logged as completed.
    #[must_use]
    pub fn completed(&self) -> usize {
        self.trials
            .iter()
            .filter(|r| r.status == crate::protocol::engine::Status::Completed)
            .count()
    }

    /// The first trial index not yet finally logged: where a resume starts.
    /// A trial is final when completed, or aborted and not re-queued.
    #[must_use]
    pub fn next_trial(&self) -> usize {
        crate::protocol::engine::next_position(self.trials.iter().map(|t| &t.record))
    }
}

/// The first line of the log at `path`, read as `T`.
fn first_line<T: serde::de::DeserializeOwned>(path: &Path) -> Result<T, ResultsError> {
    let file = File::open(path).map_err(io_err(path))?;
    let mut first = String::new();
    BufReader::new(file)
        .read_line(&mut first)
        .map_err(io_err(path))?;
    serde_json::from_str::<T>(first.trim_end())
        .map_err(|e| log_error(path, 1, e.column(), e.to_string()))
}

/// The participant a log's header names, read without its kind.
pub(super) fn header_participant(path: &Path) -> Result<String, ResultsError> {
    /// The header's fields this needs (the others are not read).
    #[derive(Deserialize)]
    struct Who {
        #[serde(rename = "type")]
        line: String,
        participant: String,
    }
    let who: Who = first_line(path)?;
    if who.line == "header" {
        Ok(who.participant)
    } else {
        Err(log_error(
            path,
            1,
            1,
            "the first line is not a header".into(),
        ))
    }
}

/// The header of the session log at `path` (its first line).
///
/// # Errors
/// The file cannot be read, or its first line is not a header.
pub fn read_header<K: Kinds>(path: &Path) -> Result<Header<K>, ResultsError> {
    match first_line::<LogLine<K>>(path)? {
        LogLine::Header(h) => Ok(*h),
        _ => Err(log_error(
            path,
            1,
            1,
            "the first line is not a header".into(),
        )),
    }
}

fn log_error(path: &Path, line: usize, column: usize, message: String) -> ResultsError {
    ResultsError::Log {
        path: path.display().to_string(),
        line,
        column,
        message,
    }
}

/// Reads a log. A last line without its newline, or one that does not parse,
/// is a torn write: ignored and reported in [`ReadLog::torn_bytes`]. A bad
/// line anywhere else is an error.
///
/// # Errors
/// A missing or bad header, a malformed line before the last, or I/O.
pub fn read_log<K: Kinds>(path: &Path) -> Result<ReadLog<K>, ResultsError> {
    let bytes = std::fs::read(path).map_err(io_err(path))?;
    parse_log(path, &bytes)
}

/// [`read_log`] on bytes already read.
///
/// # Errors
/// As [`read_log`].
pub fn parse_log<K: Kinds>(path: &Path, bytes: &[u8]) -> Result<ReadLog<K>, ResultsError> {
    parse_log_lines(path, bytes).map(|(read, _)| read)
}

/// [`parse_log`], with the line (1-based) of each trial record.
pub(super) fn parse_log_lines<K: Kinds>(
    path: &Path,
    bytes: &[u8],
) -> Result<(ReadLog<K>, Vec<usize>), ResultsError> {
    let mut header = None;
    // About one record per line: the records are large, and a log of
    // thousands would otherwise be moved each time the list grows.
    let records = memchr::memchr_iter(b'\n', bytes).count();
    let mut trials = Vec::with_capacity(records);
    let mut lines = Vec::with_capacity(records);
    let mut scratch = String::new();
    let mut ended = false;
    let mut offset = 0_usize;
    let mut valid_len = 0_usize;
    let mut line_no = 0;
    while offset < bytes.len() {
        line_no += 1;
        let end = memchr::memchr(b'\n', &bytes[offset..]).map(|p| offset + p);
        let (line, next, complete) = match end {
            Some(e) => (&bytes[offset..e], e + 1, true),
            None => (&bytes[offset..], bytes.len(), false),
        };
        let parsed = parse_line(line, &mut scratch);
        let is_last = next >= bytes.len();
        match parsed {
            Ok(l) if complete => {
                match l {
                    LogLine::Header(h) if line_no == 1 => header = Some(*h),
                    LogLine::Header(_) => {
                        return Err(log_error(path, line_no, 1, "a second header".into()));
                    }
                    _ if line_no == 1 => {
                        return Err(log_error(
                            path,
                            1,
                            1,
                            "the first line is not a header".into(),
                        ));
                    }
                    LogLine::Trial(r) => {
                        trials.push(r);
                        lines.push(line_no);
                    }
                    LogLine::End { .. } => ended = true,
                    LogLine::Resumed { .. }
                    | LogLine::Note { .. }
                    | LogLine::Loop(_)
                    | LogLine::Lsl(_)
                    | LogLine::Sound(_)
                    | LogLine::Interrupted { .. } => {}
                }
                valid_len = next;
            }
            _ if is_last && line_no > 1 => break,
            Ok(_) => {
                return Err(log_error(
                    path,
                    line_no,
                    line.len() + 1,
                    "the header line is incomplete".into(),
                ));
            }
            Err((column, message)) => return Err(log_error(path, line_no, column, message)),
        }
        offset = next;
    }
    let header = header.ok_or_else(|| log_error(path, 1, 1, "empty log: no header".into()))?;
    let read = ReadLog {
        header,
        trials,
        ended,
        valid_len: valid_len as u64,
        torn_bytes: (bytes.len() - valid_len) as u64,
    };
    Ok((read, lines))
}

/// One log line. A trial record as the log writes it (its `type` first)
/// is read straight into the record, which spares serde buffering the
/// whole line to find the tag (reading a large log is a third faster):
/// by the compact reader (`compact.rs`) where the line is as the log
/// writes it, else by serde_json (`scratch` holds it without its tag).
/// Anything else, or a record that does not read that way, is read as a
/// [`LogLine`], with its error.
///
/// The line is checked as UTF-8 once, whole, and read as text: serde_json
/// then does not check each string again, one short string at a time
/// (that was a twentieth of reading a large log). An error is its column
/// (1-based) and message.
fn parse_line<K: Kinds>(line: &[u8], scratch: &mut String) -> Result<LogLine<K>, (usize, String)> {
    const TRIAL: &str = r#"{"type":"trial","#;
    let text = std::str::from_utf8(line).map_err(|e| (e.valid_up_to() + 1, e.to_string()))?;
    if let Some(rest) = text.strip_prefix(TRIAL) {
        if let Some(record) = super::compact::read_object_rest::<LoggedTrial<K>>(text, TRIAL.len())
        {
            return Ok(LogLine::Trial(record));
        }
        scratch.clear();
        scratch.push('{');
        scratch.push_str(rest);
        if let Ok(record) = serde_json::from_str::<LoggedTrial<K>>(scratch) {
            return Ok(LogLine::Trial(record));
        }
    }
    serde_json::from_str::<LogLine<K>>(text).map_err(|e| (e.column(), e.to_string()))
}

/// Whether a record counts as completed.
#[must_use]
pub fn is_completed<K: Kinds>(r: &TrialRecord<K>) -> bool {
    r.status == Status::Completed
}
