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

use std::collections::BTreeSet;
use std::fmt::Write as _;
use std::fs::{File, OpenOptions};
use std::io::{self, BufRead, BufReader, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};
use sha2::{Digest, Sha256};

use crate::protocol::Kind;
use crate::protocol::Protocol;
use crate::protocol::engine::{Status, TrialData, TrialRecord};

/// Format tag of the log header.
pub const LOG_FORMAT: &str = "frictionlab-log/1";

/// The first line of a session log.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Header {
    /// [`LOG_FORMAT`].
    pub format: String,
    /// frictionlab version that wrote the log.
    pub software_version: String,
    /// Protocol id.
    pub protocol_id: String,
    /// SHA-256 of the protocol file's bytes, hex.
    pub protocol_sha256: String,
    /// The protocol as loaded (resume replays it).
    pub protocol: Protocol,
    /// Plan seed.
    pub plan_seed: u64,
    /// Participant id.
    pub participant: String,
    /// Participant index used for counterbalancing.
    pub participant_index: u32,
    /// Session number (1-based).
    pub session: u32,
    /// Device (`sim` or a port path).
    pub device: String,
    /// Responder (`sim` or `gui`).
    pub responder: String,
    /// Number of planned trials.
    pub planned_trials: usize,
}

/// One line of a session log.
#[expect(
    clippy::large_enum_variant,
    reason = "lines are written one at a time; boxing the trial record buys nothing"
)]
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(tag = "type", rename_all = "snake_case")]
pub enum LogLine {
    /// The header (first line).
    Header(Box<Header>),
    /// A completed or aborted trial.
    Trial(TrialRecord),
    /// The session was resumed here.
    Resumed {
        /// First trial run after the resume.
        at_trial: usize,
        /// Bytes of a torn last line that were cut off before resuming.
        torn_bytes: u64,
    },
    /// The haptic loop's timing and link statistics (device sessions).
    Loop(crate::device::haptic::LoopStats),
    /// An experimenter's note.
    Note {
        /// The text.
        text: String,
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
pub fn log_json_schema() -> String {
    let schema = schemars::schema_for!(LogLine);
    serde_json::to_string_pretty(&schema).unwrap_or_default() + "\n"
}

/// Why a results operation failed.
#[derive(Debug, thiserror::Error)]
pub enum ResultsError {
    /// Bad input from the user (exit 2): `place: message`.
    #[error("{place}: {message}")]
    Input {
        /// Flag or file.
        place: String,
        /// What is wrong.
        message: String,
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

/// Participant ids: letters, digits, `-`, `_`, with at least one letter or
/// digit.
///
/// # Errors
/// Why the id is refused.
pub fn check_participant(id: &str) -> Result<(), String> {
    if crate::protocol::load::is_valid_id(id) {
        Ok(())
    } else {
        Err(format!(
            "'{id}': use letters, digits, '-' and '_' (and at least one letter or digit)"
        ))
    }
}

/// An id with everything but letters and digits left out (psych-DS keyword
/// values).
#[must_use]
pub fn file_key(id: &str) -> String {
    id.chars().filter(char::is_ascii_alphanumeric).collect()
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

/// The results folder.
#[derive(Debug, Clone)]
pub struct ResultsDir {
    root: PathBuf,
}

/// A session's files.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SessionFiles {
    /// Session number.
    pub session: u32,
    /// The log.
    pub log: PathBuf,
    /// The data CSV.
    pub csv: PathBuf,
}

impl ResultsDir {
    /// The folder at `root` (created when the first session starts).
    #[must_use]
    pub fn new(root: impl Into<PathBuf>) -> Self {
        ResultsDir { root: root.into() }
    }

    /// The folder.
    #[must_use]
    pub fn root(&self) -> &Path {
        &self.root
    }

    /// The files of a session.
    #[must_use]
    pub fn files(&self, protocol_id: &str, participant: &str, session: u32) -> SessionFiles {
        let stem = format!(
            "study-{}_subject-{}_session-{session}",
            file_key(protocol_id),
            file_key(participant)
        );
        SessionFiles {
            session,
            log: self.root.join("logs").join(format!("{stem}_log.jsonl")),
            csv: self.root.join("data").join(format!("{stem}_data.csv")),
        }
    }

    /// Every session log in the folder, sorted.
    fn logs(&self) -> Vec<PathBuf> {
        let Ok(entries) = std::fs::read_dir(self.root.join("logs")) else {
            return Vec::new();
        };
        let mut out: Vec<PathBuf> = entries
            .filter_map(Result::ok)
            .map(|e| e.path())
            .filter(|p| p.to_string_lossy().ends_with("_log.jsonl"))
            .collect();
        out.sort();
        out
    }

    /// The headers of every readable session log in the folder.
    #[must_use]
    pub fn headers(&self) -> Vec<Header> {
        self.logs()
            .iter()
            .filter_map(|p| read_header(p).ok())
            .collect()
    }

    /// Sessions of `participant` for `protocol_id`, by number, refusing a
    /// participant id whose file name would collide with another's.
    ///
    /// # Errors
    /// A collision, or an unreadable log header.
    pub fn sessions(
        &self,
        protocol_id: &str,
        participant: &str,
    ) -> Result<Vec<SessionFiles>, ResultsError> {
        let prefix = format!(
            "study-{}_subject-{}_session-",
            file_key(protocol_id),
            file_key(participant)
        );
        let mut out = Vec::new();
        for path in self.logs() {
            let name = path
                .file_name()
                .map(|n| n.to_string_lossy().into_owned())
                .unwrap_or_default();
            let Some(n) = name
                .strip_prefix(&prefix)
                .and_then(|r| r.strip_suffix("_log.jsonl"))
            else {
                continue;
            };
            let Ok(n) = n.parse::<u32>() else { continue };
            let header = read_header(&path)?;
            if header.participant != participant {
                return Err(ResultsError::Input {
                    place: "--participant".into(),
                    message: format!(
                        "'{participant}' collides with participant '{}' in file names ({}); choose another id",
                        header.participant,
                        file_key(participant)
                    ),
                });
            }
            out.push(self.files(protocol_id, participant, n));
        }
        out.sort_by_key(|s| s.session);
        Ok(out)
    }

    /// How many distinct participants have sessions of `protocol_id` here,
    /// not counting `participant`: the default counterbalancing index of a
    /// new participant.
    #[must_use]
    pub fn other_participants(&self, protocol_id: &str, participant: &str) -> u32 {
        let prefix = format!("study-{}_subject-", file_key(protocol_id));
        let own = file_key(participant);
        let subjects: BTreeSet<String> = self
            .logs()
            .iter()
            .filter_map(|p| p.file_name().map(|n| n.to_string_lossy().into_owned()))
            .filter_map(|n| {
                n.strip_prefix(&prefix)
                    .and_then(|r| r.split('_').next())
                    .map(str::to_owned)
            })
            .filter(|s| *s != own)
            .collect();
        u32::try_from(subjects.len()).unwrap_or(u32::MAX)
    }
}

/// An open session log, appended to line by line.
#[derive(Debug)]
pub struct SessionLog {
    file: File,
    path: PathBuf,
}

impl SessionLog {
    /// Creates a new log at `path` (never overwriting) with its header line.
    ///
    /// # Errors
    /// The file exists, or any I/O error.
    pub fn create(path: &Path, header: Header) -> Result<Self, ResultsError> {
        if let Some(parent) = path.parent() {
            std::fs::create_dir_all(parent).map_err(io_err(parent))?;
        }
        let file = OpenOptions::new()
            .write(true)
            .create_new(true)
            .open(path)
            .map_err(io_err(path))?;
        let mut log = SessionLog {
            file,
            path: path.to_owned(),
        };
        log.append(&LogLine::Header(Box::new(header)))?;
        if let Some(parent) = path.parent() {
            // Make the new file's directory entry durable too.
            let _ = File::open(parent).and_then(|d| d.sync_all());
        }
        Ok(log)
    }

    /// Opens an existing log to append; a torn last line (no newline) is cut
    /// off first. Returns the log and the number of bytes cut.
    ///
    /// # Errors
    /// Any I/O error.
    pub fn reopen(path: &Path, valid_len: u64) -> Result<(Self, u64), ResultsError> {
        let mut file = OpenOptions::new()
            .read(true)
            .write(true)
            .open(path)
            .map_err(io_err(path))?;
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
    pub fn append(&mut self, line: &LogLine) -> Result<(), ResultsError> {
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
pub struct ReadLog {
    /// The header.
    pub header: Header,
    /// Trial records in log order.
    pub trials: Vec<TrialRecord>,
    /// Whether the session ended.
    pub ended: bool,
    /// Length of the valid part (up to the last complete line), bytes.
    pub valid_len: u64,
    /// Bytes of a torn last line, ignored.
    pub torn_bytes: u64,
}

impl ReadLog {
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
        crate::protocol::engine::next_position(&self.trials)
    }
}

fn read_header(path: &Path) -> Result<Header, ResultsError> {
    let file = File::open(path).map_err(io_err(path))?;
    let mut first = String::new();
    BufReader::new(file)
        .read_line(&mut first)
        .map_err(io_err(path))?;
    match serde_json::from_str::<LogLine>(first.trim_end()) {
        Ok(LogLine::Header(h)) => Ok(*h),
        Ok(_) => Err(log_error(
            path,
            1,
            1,
            "the first line is not a header".into(),
        )),
        Err(e) => Err(log_error(path, 1, e.column(), e.to_string())),
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
pub fn read_log(path: &Path) -> Result<ReadLog, ResultsError> {
    let bytes = std::fs::read(path).map_err(io_err(path))?;
    parse_log(path, &bytes)
}

/// [`read_log`] on bytes already read.
///
/// # Errors
/// As [`read_log`].
pub fn parse_log(path: &Path, bytes: &[u8]) -> Result<ReadLog, ResultsError> {
    let mut header = None;
    let mut trials = Vec::new();
    let mut ended = false;
    let mut offset = 0_usize;
    let mut valid_len = 0_usize;
    let mut line_no = 0;
    while offset < bytes.len() {
        line_no += 1;
        let end = bytes[offset..]
            .iter()
            .position(|&b| b == b'\n')
            .map(|p| offset + p);
        let (line, next, complete) = match end {
            Some(e) => (&bytes[offset..e], e + 1, true),
            None => (&bytes[offset..], bytes.len(), false),
        };
        let parsed = std::str::from_utf8(line)
            .map_err(|e| (e.valid_up_to() + 1, e.to_string()))
            .and_then(|s| {
                serde_json::from_str::<LogLine>(s).map_err(|e| (e.column(), e.to_string()))
            });
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
                    LogLine::Trial(r) => trials.push(r),
                    LogLine::End { .. } => ended = true,
                    LogLine::Resumed { .. } | LogLine::Note { .. } | LogLine::Loop(_) => {}
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
    Ok(ReadLog {
        header,
        trials,
        ended,
        valid_len: valid_len as u64,
        torn_bytes: (bytes.len() - valid_len) as u64,
    })
}

/// The data CSV columns every kind has.
pub const COMMON_COLUMNS: [&str; 10] = [
    "study",
    "kind",
    "participant",
    "session",
    "trial",
    "block",
    "status",
    "seed",
    "practice",
    "repetition",
];

/// Kind-specific data CSV columns.
#[must_use]
pub fn kind_columns(kind: Kind) -> &'static [&'static str] {
    match kind {
        Kind::PairedComparison => &["first", "second", "choice", "chosen"],
        Kind::MagnitudeEstimation => &[
            "display",
            "mu_s",
            "mu_k",
            "delta_mu",
            "magnitude",
            "response_time_s",
        ],
        Kind::Fitts => &[
            "condition",
            "amplitude_m",
            "width_m",
            "cursor_m",
            "effective_width_m",
            "id_bits",
            "completion_time_s",
            "taps",
            "errors",
            "mean_error_m",
            "tap_times_s",
            "tap_x_m",
            "target_x_m",
            "miss_x_m",
        ],
    }
}

fn csv_text(s: &str) -> String {
    if s.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_owned()
    }
}

fn opt<T: ToString>(x: Option<T>) -> String {
    x.map(|v| v.to_string()).unwrap_or_default()
}

fn list(xs: &[f64]) -> String {
    xs.iter().map(f64::to_string).collect::<Vec<_>>().join(";")
}

/// The data CSV of a session, from its log. Lists (`tap_x_m`, ...) are
/// `;`-separated; missing values are empty cells.
#[must_use]
pub fn data_csv(log: &ReadLog) -> String {
    let h = &log.header;
    let kind = h.protocol.design.kind();
    let mut out: Vec<&str> = COMMON_COLUMNS.to_vec();
    out.extend_from_slice(kind_columns(kind));
    let mut text = out.join(",");
    text.push('\n');
    for r in &log.trials {
        let mut row = vec![
            csv_text(&h.protocol_id),
            kind.as_str().to_owned(),
            csv_text(&h.participant),
            h.session.to_string(),
            r.trial.to_string(),
            csv_text(&r.block),
            r.status.as_str().to_owned(),
            h.plan_seed.to_string(),
            r.practice.to_string(),
            r.repetition.to_string(),
        ];
        match &r.data {
            TrialData::PairedComparison {
                first,
                second,
                choice,
                chosen,
            } => {
                row.extend([
                    csv_text(first),
                    csv_text(second),
                    opt(choice.map(super::protocol::engine::Choice::as_str)),
                    opt(chosen.as_deref()),
                ]);
            }
            TrialData::MagnitudeEstimation {
                display,
                mu_s,
                mu_k,
                delta_mu,
                magnitude,
                response_time_s,
            } => row.extend([
                csv_text(display),
                mu_s.to_string(),
                mu_k.to_string(),
                delta_mu.to_string(),
                opt(*magnitude),
                opt(*response_time_s),
            ]),
            TrialData::Fitts {
                condition,
                amplitude_m,
                width_m,
                cursor_m,
                effective_width_m,
                id_bits,
                completion_time_s,
                taps,
                errors,
                mean_error_m,
                tap_times_s,
                tap_x_m,
                target_x_m,
                miss_x_m,
            } => row.extend([
                csv_text(condition),
                amplitude_m.to_string(),
                width_m.to_string(),
                cursor_m.to_string(),
                effective_width_m.to_string(),
                id_bits.to_string(),
                opt(*completion_time_s),
                taps.to_string(),
                errors.to_string(),
                opt(*mean_error_m),
                list(tap_times_s),
                list(tap_x_m),
                list(target_x_m),
                list(miss_x_m),
            ]),
        }
        text.push_str(&row.join(","));
        text.push('\n');
    }
    text
}

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

/// Writes `dataset_description.json` listing every column of every data file
/// of the kinds present.
///
/// # Errors
/// Any I/O error.
pub fn write_dataset_description(
    dir: &ResultsDir,
    kinds: &BTreeSet<&'static str>,
) -> Result<(), ResultsError> {
    let mut columns: Vec<&str> = COMMON_COLUMNS.to_vec();
    for kind in [
        Kind::PairedComparison,
        Kind::MagnitudeEstimation,
        Kind::Fitts,
    ] {
        if kinds.contains(kind.as_str()) {
            columns.extend(
                kind_columns(kind)
                    .iter()
                    .filter(|c| !columns.contains(c))
                    .collect::<Vec<_>>(),
            );
        }
    }
    let doc = serde_json::json!({
        "@context": "https://schema.org/",
        "@type": "Dataset",
        "name": "frictionlab results",
        "description": format!(
            "Friction perception sessions recorded by frictionlab {} ({}). One row per trial; \
             units SI; see results-schema/ in the frictionlab sources.",
            env!("CARGO_PKG_VERSION"),
            kinds.iter().copied().collect::<Vec<_>>().join(", ")
        ),
        "variableMeasured": columns,
    });
    let text = serde_json::to_string_pretty(&doc).unwrap_or_default() + "\n";
    replace_file(
        &dir.root().join("dataset_description.json"),
        text.as_bytes(),
        true,
    )
}

/// The kinds of every session log in the folder.
#[must_use]
pub fn kinds_present(dir: &ResultsDir) -> BTreeSet<&'static str> {
    dir.logs()
        .iter()
        .filter_map(|p| read_header(p).ok())
        .map(|h| h.protocol.design.kind().as_str())
        .collect()
}

/// Whether a record counts as completed.
#[must_use]
pub fn is_completed(r: &TrialRecord) -> bool {
    r.status == Status::Completed
}
