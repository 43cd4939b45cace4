//! The folder's layout: [`ResultsDir`], each session's file names
//! ([`SessionFiles`], with the ids reduced to file-name keywords by
//! [`file_key`]), session numbering and participant ids.

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

use super::ResultsError;
use super::lock::{self, FolderLock};
use super::session_log::{Header, header_participant, read_header};
use crate::protocol::kind::Kinds;

pub use crate::protocol::load::MAX_ID_CHARS;

/// Participant ids: letters, digits, `-`, `_`, with at least one letter or
/// digit, at most [`MAX_ID_CHARS`] (issue 31: a longer one failed only at
/// its first file, with the OS's "File name too long").
///
/// # Errors
/// Why the id is refused.
pub fn check_participant(id: &str) -> Result<(), String> {
    crate::protocol::load::id_problem(id).map_or(Ok(()), Err)
}

/// An id with everything but letters and digits left out (psych-DS keyword
/// values).
#[must_use]
pub fn file_key(id: &str) -> String {
    id.chars().filter(char::is_ascii_alphanumeric).collect()
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

/// One session of a results folder ([`ResultsDir::overview`]).
#[derive(Debug, Clone, PartialEq)]
pub struct SessionOverview {
    /// Its log.
    pub log: PathBuf,
    /// The protocol's id.
    pub protocol_id: String,
    /// The protocol's title.
    pub protocol_title: String,
    /// The participant.
    pub participant: String,
    /// Session number.
    pub session: u32,
    /// Trials done (where a resume would start).
    pub done: usize,
    /// Trials planned.
    pub planned: usize,
    /// Complete, unfinished, open elsewhere, or unreadable.
    pub status: SessionStatus,
}

/// Where a session stands.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum SessionStatus {
    /// It ended: every trial done, or ended by the experimenter.
    Complete,
    /// It stopped before its end and can be resumed.
    Unfinished,
    /// Another process has it open (its process id where the OS tells).
    Open {
        /// The holder's process id.
        pid: Option<u32>,
    },
    /// Its log cannot be read (why).
    Unreadable(String),
}

impl SessionStatus {
    /// For a person: `complete`, `unfinished`, `open in another process
    /// (pid N)`, `unreadable: ...`.
    #[must_use]
    pub fn describe(&self) -> String {
        match self {
            SessionStatus::Complete => "complete".to_owned(),
            SessionStatus::Unfinished => "unfinished".to_owned(),
            SessionStatus::Open { pid } => format!(
                "open in another process{}",
                lock::Holder { pid: *pid }.pid_text()
            ),
            SessionStatus::Unreadable(e) => format!("unreadable: {e}"),
        }
    }
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
    pub fn logs(&self) -> Vec<PathBuf> {
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

    /// Every session in the folder, as the results view lists it: whose,
    /// of which protocol, how far, and whether it is complete, unfinished
    /// (it can be resumed) or open in another process. Writes nothing.
    #[must_use]
    pub fn overview<K: Kinds>(&self) -> Vec<SessionOverview> {
        self.logs()
            .into_iter()
            .map(|log| {
                let busy = lock::open_elsewhere(&log);
                match super::read_log::<K>(&log) {
                    Ok(read) => SessionOverview {
                        protocol_id: read.header.protocol_id.clone(),
                        protocol_title: read.header.protocol.title.clone(),
                        participant: read.header.participant.clone(),
                        session: read.header.session,
                        done: read.next_trial(),
                        planned: read.header.planned_trials,
                        status: match busy {
                            Some(h) => SessionStatus::Open { pid: h.pid },
                            None if read.ended => SessionStatus::Complete,
                            None => SessionStatus::Unfinished,
                        },
                        log,
                    },
                    Err(e) => SessionOverview {
                        protocol_id: String::new(),
                        protocol_title: String::new(),
                        participant: String::new(),
                        session: 0,
                        done: 0,
                        planned: 0,
                        status: match busy {
                            Some(h) => SessionStatus::Open { pid: h.pid },
                            None => SessionStatus::Unreadable(e.to_string()),
                        },
                        log,
                    },
                }
            })
            .collect()
    }

    /// The headers of every readable session log in the folder.
    #[must_use]
    pub fn headers<K: Kinds>(&self) -> Vec<Header<K>> {
        self.logs()
            .iter()
            .filter_map(|p| read_header::<K>(p).ok())
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
            let other = header_participant(&path)?;
            if other != participant {
                return Err(ResultsError::Collision {
                    participant: participant.to_owned(),
                    other,
                    key: file_key(participant),
                });
            }
            out.push(self.files(protocol_id, participant, n));
        }
        out.sort_by_key(|s| s.session);
        Ok(out)
    }

    /// The participant's sessions, as [`ResultsDir::sessions`], refusing
    /// when one of them is open in another process (issue 31). Writes
    /// nothing.
    ///
    /// # Errors
    /// [`ResultsError::Busy`], a collision, or an unreadable log header.
    pub fn free_sessions(
        &self,
        protocol_id: &str,
        participant: &str,
    ) -> Result<Vec<SessionFiles>, ResultsError> {
        let sessions = self.sessions(protocol_id, participant)?;
        for s in &sessions {
            if let Some(holder) = lock::open_elsewhere(&s.log) {
                return Err(lock::busy(&s.log, (s.session, participant), holder.pid));
            }
        }
        Ok(sessions)
    }

    /// Opens session `files` of `participant` to continue it and takes its
    /// session lock, held for as long as the file is.
    ///
    /// # Errors
    /// [`ResultsError::Busy`] when another process has it open, or I/O.
    pub fn lock_session(
        &self,
        files: &SessionFiles,
        participant: &str,
    ) -> Result<std::fs::File, ResultsError> {
        lock::open_locked(&files.log, (files.session, participant))
    }

    /// Takes the folder lock (see `lock.rs`) for the moment a session is
    /// chosen and opened; with `create`, makes `logs/` first. `None`: no
    /// `logs/` yet (and `create` is false), so no session to choose.
    ///
    /// # Errors
    /// I/O.
    pub fn lock_folder(&self, create: bool) -> Result<Option<FolderLock>, ResultsError> {
        FolderLock::take(&self.root.join("logs"), create)
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
