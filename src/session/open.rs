//! The two stages before a session runs: [`plan`] checks a request against
//! the results folder and draws the plan (it reads only), and
//! [`PlannedSession::open`] writes: a new session's header, empty CSV and dataset
//! description, or the unfinished session's `resumed` line. A device
//! session connects in between, so a device that never answers leaves no
//! session behind.

use std::path::PathBuf;
use std::sync::Arc;

use super::SessionError;
use super::stream::StreamRecorder;
use crate::kinds::{Engine, Protocol, Registry};
use crate::kinds::{Header, LogLine, LoggedTrial, ReadLog};
use crate::protocol::engine::TrialSource;
use crate::protocol::kind::Kinds;
use crate::results::{
    LOG_FORMAT, ResultsDir, ResultsError, SessionFiles, SessionLog, data_csv, kinds_present,
    read_log, remove_partials, replace_file, sha256_hex, write_dataset_description,
};
use crate::time::Time;

/// Where a session renders friction.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum DeviceChoice {
    /// The simulated apparatus, stepped in session time.
    Simulated,
    /// A haptic device (a port, an emulator's pty, a service).
    Device(crate::device::Address),
}

impl DeviceChoice {
    /// Our own board (or its emulator) on the port at `path`.
    #[must_use]
    pub fn port(path: impl AsRef<std::path::Path>) -> Self {
        DeviceChoice::Device(crate::device::Address::port(path.as_ref()))
    }

    /// As logged: `sim`, or the device as `--device` names it.
    #[must_use]
    pub fn label(&self) -> String {
        match self {
            DeviceChoice::Simulated => "sim".into(),
            DeviceChoice::Device(a) => a.to_string(),
        }
    }
}

/// What to run.
#[derive(Debug, Clone)]
pub struct SessionRequest<'a> {
    /// The checked protocol.
    pub protocol: &'a Protocol,
    /// The protocol file's bytes (hashed into the log header).
    pub protocol_bytes: &'a [u8],
    /// Participant id (already checked).
    pub participant: &'a str,
    /// Counterbalancing index; default: participants already in the folder.
    pub participant_index: Option<u32>,
    /// Plan seed of a new session (a resumed one keeps its own).
    pub seed: u64,
    /// Continue the participant's last unfinished session.
    pub resume: bool,
    /// Virtual time runs this many times faster than real time; `None`: as
    /// fast as possible (headless simulated sessions only).
    pub pace: Option<f64>,
    /// The device.
    pub device: &'a DeviceChoice,
    /// Publish the session on the Lab Streaming Layer with this liblsl
    /// (`--lsl`, issue 34).
    pub lsl: Option<&'a crate::lsl::Streaming>,
    /// Record each trial's device stream (`streams/`, see [`StreamRecorder`]).
    pub streams: bool,
    /// A simulated participant's population other than the default (kept
    /// in the log header, so a resumed session has the same participant).
    pub population: Option<&'a crate::participant::Population>,
    /// The sound outputs (`--masking-audio`, `--tactile-audio`), opened
    /// before the session (a missing server or output writes nothing);
    /// the shell plays them ([`super::sound`]).
    pub sound: super::sound::Sound,
}

/// A session checked and planned; nothing written yet.
#[derive(Debug)]
pub struct PlannedSession {
    /// Where the session's trials come from: the protocol's plan, drawn
    /// from the plan seed and participant index.
    pub source: Arc<dyn TrialSource<Registry>>,
    opening: Opening,
    streams: bool,
    /// Published on LSL: the data CSV gains [`crate::results::LSL_COLUMNS`],
    /// and the folder's description lists them.
    lsl: bool,
}

#[derive(Debug)]
enum Opening {
    /// The participant's unfinished session, read back, and its session
    /// lock (held from planning on; moved into the open log).
    Resume {
        read: Box<ReadLog>,
        files: SessionFiles,
        lock: Option<std::fs::File>,
    },
    /// A new session with this header.
    New {
        header: Box<Header>,
        files: SessionFiles,
    },
}

/// The open session: its log, what it holds, its CSV and stream recorder.
#[derive(Debug)]
pub struct OpenLog {
    /// The append-only log.
    pub log: SessionLog,
    /// The log as read back, with every record written since.
    pub read: ReadLog,
    /// The data CSV, rewritten from the log after each record.
    pub csv: PathBuf,
    /// The per-trial device streams.
    pub streams: StreamRecorder,
    /// Bytes of a torn last line cut before resuming.
    pub torn_bytes: u64,
}

/// Checks the request against the results folder and plans the session: a
/// new one, or the participant's unfinished one when resuming. Reads only.
/// `responder` is logged in a new header.
///
/// One process per session (issue 31): a resumed session is chosen under
/// the folder lock and its session lock is held from here on (released if
/// the plan is dropped); a new one is refused here if one of the
/// participant's sessions is open in another process, and checked again,
/// under the folder lock, when its log is created ([`PlannedSession::open`]).
///
/// # Errors
/// Resuming without an unfinished session; a session of the participant
/// open in another process; an unreadable log.
pub fn plan(
    dir: &ResultsDir,
    req: &SessionRequest<'_>,
    responder: &str,
) -> Result<PlannedSession, SessionError> {
    let id = &req.protocol.id;
    if req.resume {
        let folder = dir.lock_folder(false)?;
        let sessions = dir.sessions(id, req.participant)?;
        let Some(last) = sessions.into_iter().next_back() else {
            return Err(SessionError::NothingToResume {
                participant: req.participant.to_owned(),
                protocol: id.clone(),
                dir: dir.root().to_owned(),
            });
        };
        let lock = dir.lock_session(&last, req.participant)?;
        drop(folder);
        let read = read_log(&last.log)?;
        if read.ended {
            return Err(SessionError::Ended {
                participant: req.participant.to_owned(),
                session: last.session,
            });
        }
        let h = &read.header;
        return Ok(PlannedSession {
            source: Registry::source(&h.protocol, h.plan_seed, h.participant_index),
            opening: Opening::Resume {
                read: Box::new(read),
                files: last,
                lock: Some(lock),
            },
            streams: req.streams,
            lsl: req.lsl.is_some(),
        });
    }
    let sessions = dir.free_sessions(id, req.participant)?;
    let session = sessions.last().map_or(1, |s| s.session + 1);
    let files = dir.files(id, req.participant, session);
    let participant_index = req
        .participant_index
        .unwrap_or_else(|| dir.other_participants(id, req.participant));
    let (mut header, source) = new_session(req, session, participant_index, responder);
    header.device_check = crate::results::device_checks::last(dir, &req.device.label());
    Ok(PlannedSession {
        source,
        opening: Opening::New {
            header: Box::new(header),
            files,
        },
        streams: req.streams,
        lsl: req.lsl.is_some(),
    })
}

/// The header and trial source of a new session `session` of the request,
/// with counterbalancing index `participant_index`; `responder` as logged.
#[must_use]
pub fn new_session(
    req: &SessionRequest<'_>,
    session: u32,
    participant_index: u32,
    responder: &str,
) -> (Header, Arc<dyn TrialSource<Registry>>) {
    let source = Registry::source(req.protocol, req.seed, participant_index);
    let header = Header {
        format: LOG_FORMAT.into(),
        software_version: env!("CARGO_PKG_VERSION").into(),
        protocol_id: req.protocol.id.clone(),
        protocol_sha256: sha256_hex(req.protocol_bytes),
        protocol: req.protocol.clone(),
        plan_seed: req.seed,
        participant: req.participant.to_owned(),
        participant_index,
        session,
        device: req.device.label(),
        device_settings: None,
        device_limits: None,
        device_check: None,
        responder: responder.into(),
        planned_trials: source.planned().unwrap_or(0),
        population: req.population.cloned(),
        sound: req.sound.playing(),
    };
    (header, source)
}

impl PlannedSession {
    /// The engine that runs the session from where it stands.
    #[must_use]
    pub fn engine(&self) -> Engine {
        let history = match &self.opening {
            Opening::Resume { read, .. } => read.trials.iter().map(|t| t.record.clone()).collect(),
            Opening::New { .. } => Vec::new(),
        };
        Engine::resume(self.header().protocol.clone(), self.source.clone(), history)
    }

    /// The session's header (a new one's, or the resumed one's).
    #[must_use]
    pub fn header(&self) -> &Header {
        match &self.opening {
            Opening::Resume { read, .. } => &read.header,
            Opening::New { header, .. } => header,
        }
    }

    /// Records the device's settings in a new session's header (a resumed
    /// session keeps its own header).
    pub(super) fn set_device_settings(&mut self, settings: Option<serde_json::Value>) {
        if let Opening::New { header, .. } = &mut self.opening {
            header.device_settings = settings;
        }
    }

    pub(super) fn set_device_limits(&mut self, limits: crate::device::backend::DeviceLimits) {
        if let Opening::New { header, .. } = &mut self.opening {
            header.device_limits = Some(limits);
        }
    }

    /// The session's number and files.
    #[must_use]
    pub fn files(&self) -> &SessionFiles {
        match &self.opening {
            Opening::Resume { files, .. } | Opening::New { files, .. } => files,
        }
    }

    /// Session time where this run starts: 0 for a new session, the last
    /// logged trial's end for a resumed one (the session clock goes on).
    #[must_use]
    pub fn start_time(&self) -> Time {
        match &self.opening {
            Opening::Resume { read, .. } => read.trials.last().map_or(Time::ZERO, |r| r.ended_s),
            Opening::New { .. } => Time::ZERO,
        }
    }

    /// The first trial this run presents, when it resumes a session.
    #[must_use]
    pub fn resumes_at(&self) -> Option<usize> {
        match &self.opening {
            Opening::Resume { read, .. } => Some(read.next_trial()),
            Opening::New { .. } => None,
        }
    }

    /// Opens the session's log: a new session (header, empty CSV, dataset
    /// description) or the unfinished one (torn last line cut, a `resumed`
    /// line appended, the CSV rewritten from the log). The open log holds
    /// the session lock.
    ///
    /// A new session's number is taken here, under the folder lock: it is
    /// the next free one now (another process may have taken the planned
    /// one meanwhile), and a session of the participant open in another
    /// process refuses it.
    ///
    /// # Errors
    /// [`ResultsError::Busy`]; the log exists (a new session never
    /// overwrites); or any I/O error.
    pub fn open(&mut self, dir: &ResultsDir) -> Result<OpenLog, ResultsError> {
        match &mut self.opening {
            Opening::Resume { read, files, lock } => {
                let file = match lock.take() {
                    Some(file) => file,
                    None => dir.lock_session(files, &read.header.participant)?,
                };
                let (mut log, torn_bytes) = SessionLog::reopen(file, &files.log, read.valid_len)?;
                log.append(&LogLine::Resumed {
                    at_trial: read.next_trial(),
                    torn_bytes,
                    format: (read.header.format != LOG_FORMAT).then(|| LOG_FORMAT.to_owned()),
                })?;
                // The CSV follows the log: a kill between a trial's log
                // line and its CSV rewrite left the CSV a trial short,
                // which no later trial would mend after the last one.
                replace_file(&files.csv, data_csv(read).as_bytes(), false)?;
                // A kill -9 during a rewrite (of the CSV, of a stream) left
                // its temporary; this session's files are ours alone now.
                StreamRecorder::remove_partials(dir, &read.header)?;
                if let (Some(data), Some(name)) = (files.csv.parent(), files.csv.file_name()) {
                    remove_partials(data, &name.to_string_lossy())?;
                }
                if self.lsl {
                    write_dataset_description::<Registry>(
                        dir,
                        &kinds_present::<Registry>(dir),
                        true,
                    )?;
                }
                Ok(OpenLog {
                    log,
                    streams: StreamRecorder::new(dir, &read.header, self.streams),
                    read: (**read).clone(),
                    csv: files.csv.clone(),
                    torn_bytes,
                })
            }
            Opening::New { header, files } => {
                let folder = dir.lock_folder(true)?;
                let sessions = dir.free_sessions(&header.protocol_id, &header.participant)?;
                let session = sessions.last().map_or(1, |s| s.session + 1);
                if session != header.session {
                    header.session = session;
                    *files = dir.files(&header.protocol_id, &header.participant, session);
                }
                let log = SessionLog::create(&files.log, (**header).clone())?;
                drop(folder);
                let read = ReadLog {
                    header: (**header).clone(),
                    trials: Vec::new(),
                    ended: false,
                    valid_len: 0,
                    torn_bytes: 0,
                };
                replace_file(&files.csv, data_csv(&read).as_bytes(), false)?;
                write_dataset_description::<Registry>(
                    dir,
                    &kinds_present::<Registry>(dir),
                    self.lsl,
                )?;
                Ok(OpenLog {
                    log,
                    streams: StreamRecorder::new(dir, &read.header, self.streams),
                    read,
                    csv: files.csv.clone(),
                    torn_bytes: 0,
                })
            }
        }
    }
}

/// Where a session's records go: its files, planned (nothing written;
/// notes wait) or open; or memory (no file: the records are kept for the
/// caller, as a power study replays them).
pub(super) enum Log {
    Unopened {
        planned: Box<PlannedSession>,
        dir: ResultsDir,
        notes: Vec<String>,
    },
    Open(Box<OpenLog>),
    Memory(Box<ReadLog>),
}

impl Log {
    /// A trial record, on disk ([`OpenLog::write_record`]) or kept.
    pub(super) fn write_record(&mut self, record: &LoggedTrial) -> Result<(), ResultsError> {
        match self {
            Log::Memory(read) => {
                read.trials.push(record.clone());
                Ok(())
            }
            _ => self.open()?.write_record(record),
        }
    }

    /// The session's end ([`OpenLog::write_end`]).
    pub(super) fn write_end(&mut self) -> Result<(), ResultsError> {
        match self {
            Log::Memory(read) => {
                read.ended = true;
                Ok(())
            }
            _ => self.open()?.write_end().map(|_| ()),
        }
    }

    /// The records so far (none of a session whose files are not open).
    pub(super) fn read(&self) -> Option<&ReadLog> {
        match self {
            Log::Open(open) => Some(&open.read),
            Log::Memory(read) => Some(read),
            Log::Unopened { .. } => None,
        }
    }

    /// Opens planned files, writing the notes that waited; open files stay.
    /// A session in memory has none: an error (no caller asks).
    pub(super) fn open(&mut self) -> Result<&mut OpenLog, ResultsError> {
        match self {
            Log::Open(open) => Ok(open),
            Log::Memory(_) => Err(ResultsError::Io {
                path: String::new(),
                source: std::io::Error::other("a session in memory has no files"),
            }),
            Log::Unopened {
                planned,
                dir,
                notes,
            } => {
                let mut open = planned.open(dir)?;
                for text in notes.drain(..) {
                    open.log.append(&LogLine::Note { text })?;
                }
                *self = Log::Open(Box::new(open));
                self.open()
            }
        }
    }

    /// Records the device's settings in the header of a session not yet
    /// written.
    pub(super) fn set_device_settings(&mut self, settings: Option<serde_json::Value>) {
        if let Log::Unopened { planned, .. } = self {
            planned.set_device_settings(settings);
        }
    }

    pub(super) fn set_device_limits(&mut self, limits: crate::device::backend::DeviceLimits) {
        if let Log::Unopened { planned, .. } = self {
            planned.set_device_limits(limits);
        }
    }

    pub(super) fn opened(&mut self) -> Option<&mut OpenLog> {
        match self {
            Log::Open(open) => Some(open),
            Log::Unopened { .. } | Log::Memory(_) => None,
        }
    }

    pub(super) fn header(&self) -> &Header {
        match self {
            Log::Open(open) => &open.read.header,
            Log::Memory(read) => &read.header,
            Log::Unopened { planned, .. } => planned.header(),
        }
    }
}
