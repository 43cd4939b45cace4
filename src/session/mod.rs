//! The session driver: the one loop that runs a session, whoever answers
//! and whatever renders.
//!
//! A [`Session`] owns the engine, the pending inputs, the open log (with its
//! CSV and streams), the [`Responder`] (a simulated participant, or a
//! [`Person`] at the window) and the device (the simulated apparatus, or the
//! haptic loop on a serial port). It reads no clock, never sleeps and
//! publishes nothing: it is a state machine fed from outside, in the manner
//! of quinn-proto's `Connection`:
//! - [`Session::handle`] takes each [`Feed`]: a tick of the simulated
//!   device, a poll of a port's loop, a window frame, an input, pause,
//!   resume, abort, a signal, a note;
//! - [`Session::poll_event`] hands out what happened ([`Event`]: inputs
//!   taken, actions carried out, trials started, records written, the
//!   device lost and back, the end), each with its session time;
//! - [`Session::poll_timeout`] says when it next wants feeding.
//!
//! The shells ([`run::Run`] under the headless runners and the window)
//! feed it: headless runs a [`Feed::Tick`] per tick of the simulated
//! device in virtual time (paced by the shell if asked), or a
//! [`Feed::Poll`] every millisecond on a port; the window a
//! [`Feed::Frame`] per frame plus the person's inputs. Pacing, sleeping
//! and publishing on LSL ([`lsl`]) live in the shells, which read the
//! events.
//!
//! # Order of work, each time the session is fed
//! 1. Device samples: each sample is recorded in the trial's stream (while
//!    a trial is presented), shown to the responder (whose inputs queue),
//!    and the engine's timeout ([`Engine::poll_timeout`]) queues once due.
//! 2. Settle: the engine's actions are carried out in order (render, show,
//!    write a record), the responder reacting to each; then the next
//!    pending input goes to the engine; repeat until nothing is pending.
//!    A record is on disk (stream, log line fsync'd, CSV) before
//!    `Recorded` queues, so the next trial starts only after it. On a
//!    port, `Recorded` also waits until the ticks the loop reported
//!    during the write are read, so the next trial starts at the present
//!    tick (its exploration is not shortened by the write, and its
//!    `trial_start` on LSL is when its stimulus is sent).
//!
//! # A shell that adds to the log
//! A shell that publishes ([`lsl`]) asks the session to wait for it
//! ([`Session::wait_for_shell`]): on a port the session starts only at
//! [`Feed::Go`], after [`Event::Ready`] (the streams open first); at the
//! run's end it writes its last line only at [`Feed::Close`], which brings
//! the shell's own lines; and the simulated device's samples come as
//! [`Event::Sample`]. What the shell adds to a trial's record (its LSL
//! times) it adds where the record is written
//! ([`Session::annotate_records`]).
//!
//! # One session clock, in whole ticks (issue 42)
//! Session time `t` ([`Time`], whole nanoseconds) starts at 0 for a new
//! session and at the last logged trial's end when resuming; trial times
//! and stream `t_s` are on it. The simulated device advances it by its
//! step, a whole number of nanoseconds (200,000 at 5 kHz), so every time
//! is a whole number of ticks and every deadline an integer: a trial lasts
//! the same number of ticks wherever it starts, and a resumed session
//! gives the data an uninterrupted one gives. A port's loop clock is only
//! mapped onto it (`t = start + loop time`, to the nearest tick of the
//! device's rate), so it never goes backwards across a resume. The window
//! steps the simulated device by whole ticks and carries the rest of a
//! frame to the next.
//!
//! # One lost-device rule
//! A device that stops answering at any point of a trial (stimulus,
//! exploration, answer, Fitts movement: whenever [`Engine::in_trial`]) has
//! that trial aborted and re-queued at once (before any later tick is
//! read, so its stream ends at the loss: a device that answers again has
//! started afresh, which no trial's stream can show; a device whose
//! telemetry shows it started afresh, a `Hello` the link delivered late,
//! is lost for that tick); every other input
//! waits until the device answers again. How long to wait is the shell's call
//! ([`Session::lost_for_s`]).
//!
//! A device that keeps failing ends the run: when
//! [`MAX_DEVICE_FAULTS_IN_A_ROW`] presentations in a row (the same trial,
//! re-queued each time) are aborted for device faults, the run stops
//! there ([`Session::device_failure`]), the completed trials kept and the
//! log left open for a resume. So does a device whose answers are judged
//! not its own once the session has started (a tick's `problem`), and a
//! haptic loop whose thread died. Pauses and signals are no device faults,
//! and a completed trial starts the count again.
//!
//! A device may ask the experimenter for something before it can go on
//! (a tick's `request`: a 2DIY that lost its setup wants its handle at its
//! calibration pose): the session passes it on once
//! ([`Event::DeviceRequest`]), the link counts as lost meanwhile (so the
//! trial under way was aborted), and the shell answers [`Feed::Confirm`],
//! which reaches the device and is noted in the log. The session then goes
//! on once the hand is back on the track, as it starts (a handle put at its
//! calibration pose is off the track).
//!
//! # Pause and abort (the window)
//! Pausing while a trial is presented aborts that trial with `requeue`
//! (logged as aborted, "paused by the experimenter"), so it is presented
//! again in full on resume; the device renders nothing while paused.
//! Aborting the session does the same, then stops the device and leaves the
//! log without an `end` line, so the session can be resumed later.
//!
//! # Files
//! With the simulated device the log opens at start; on a port only at the
//! first connected tick (with the hand held on the track, on a device with
//! more than one axis), so a device that never answers leaves no session
//! behind. Notes typed before then wait for the log, and so does every
//! input: no trial starts before the log is open, so each trial's stream
//! holds it from its first tick (issue 63).

pub mod check;
pub mod device;
pub mod event;
pub mod feel;
pub mod headless;
pub mod lsl;
pub mod open;
mod renders;
pub mod responder;
pub mod run;
pub mod sound;
pub mod stream;
pub mod view;

use std::collections::VecDeque;
use std::path::PathBuf;

pub use check::{CheckDone, DeviceCheck};
pub use device::{DeviceStatus, HAND_EVERY_S, percentile};
pub use event::{Event, Feed};
pub use feel::Feel;
pub use headless::{
    Ask, NobodyToAsk, SessionOutcome, Simulation, participant_seed, run_device, run_device_asking,
    run_planned, run_simulated, sim_id, sim_participant, simulate_in_memory, simulate_participants,
};
use open::Log;
pub use open::{DeviceChoice, OpenLog, PlannedSession, SessionRequest, plan};
pub use renders::How;
pub use responder::{
    MOUSE_HAND_DAMPING_N_S_M, MOUSE_HAND_MASS_KG, MOUSE_HAND_STIFFNESS_N_M, Person, Reaction,
    Responder,
};
pub use run::{LiveSession, Run};
pub use stream::{RowMarks, StreamRecorder};
pub use view::{Progress, SessionState, TRACE_EVERY_S, TRACE_LENGTH_S, TracePoint, View};

use crate::device::DeviceSample;
use crate::device::LinkState;
use crate::friction::ModelParams;
use crate::kinds::{Action, Engine, Header, LogLine, LoggedTrial, ReadLog, Registry};
use crate::protocol::engine::Input;
use crate::protocol::engine::TrialSource;
use crate::results::RenderMode;
use crate::results::{ResultsDir, ResultsError};
use crate::time::Time;
use device::Device;
use renders::Renders;
use view::Trace;

/// How messages name the simulated apparatus.
pub const SIMULATED_APPARATUS: &str = "the simulated apparatus";

/// The abort reason of a trial ended by a signal (issue 31).
pub const INTERRUPTED: &str = "interrupted";

/// Longest session-time step one frame may take with the simulated device, s.
pub const MAX_FRAME_STEP_S: f64 = 0.5;

/// Presentations in a row aborted for device faults that end the run
/// ([`DeviceFailure::Faults`]): 3. A fault of its own kind (a replug, a
/// board that lost its setup, a link lost for a moment) costs the trial
/// under way one presentation, and a second in a row is still an
/// accident; a third means the device does not hold a trial, and every
/// further presentation would add one more aborted row and stream and
/// nothing else. The session stops instead (exit 3) and is resumed once
/// the device is seen to.
pub const MAX_DEVICE_FAULTS_IN_A_ROW: u32 = 3;

/// A render sent to a device is in effect there within this long, s, or
/// the trial under way is aborted for a device fault ("the device did not
/// render what it was sent"), presented again, and counted toward
/// [`MAX_DEVICE_FAULTS_IN_A_ROW`]. A device that renders on board shows
/// a render in effect in its telemetry; one the loop renders, at once.
/// Our choice: 1 s is far beyond any link that works (a USB board: a few
/// ms; our board in QEMU on a loaded machine: up to 0.6 s seen), and the
/// loop has resent it 4 times by then (after 50, 100, 200 and 400 ms). A
/// trial whose stimulus never took effect was kept as completed before
/// (issue 63: on the QEMU board under load, a magnitude trial rendered the
/// previous trial's stimulus for its whole 2 s).
pub const RENDER_IN_EFFECT_WITHIN_S: f64 = 1.0;

/// The abort reason of a trial under way when the run ends for a device
/// failure.
pub const DEVICE_FAILED: &str = "device failed";

/// Why a session's device could not go on: its run ended (the completed
/// trials kept, the log open for a resume).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum DeviceFailure {
    /// The same trial was presented `presentations` times in a row and
    /// aborted for a device fault each time.
    #[error(
        "trial {trial} was presented {presentations} times in a row and aborted for a device fault each time (the last: {fault}); the session stops rather than present it again"
    )]
    Faults {
        /// The trial (0-based).
        trial: usize,
        /// How many times in a row.
        presentations: u32,
        /// The last fault.
        fault: String,
    },
    /// The device's answers were judged not its own after the session had
    /// started.
    #[error("{0}")]
    NotTheDevice(&'static str),
    /// The haptic loop's thread ended without being told to.
    #[error("the haptic loop died ({0})")]
    LoopDied(String),
}

/// A session on a device with more than one axis starts once the hand is
/// within this of the track, m (it stays there: the stream shows it).
pub const ON_TRACK_M: f64 = 0.001;

/// ... and has been for this long, s (so it is held there, not passing).
pub const ON_TRACK_HOLD_S: f64 = 0.25;

/// Why a session could not start or go on.
#[derive(Debug, thiserror::Error)]
pub enum SessionError {
    /// Bad input or I/O on the results folder.
    #[error(transparent)]
    Results(#[from] ResultsError),
    /// Resuming, but the participant has no session of the protocol.
    #[error("participant '{participant}' has no session of '{protocol}' in {}", dir.display())]
    NothingToResume {
        /// The participant id.
        participant: String,
        /// The protocol id.
        protocol: String,
        /// The results folder.
        dir: PathBuf,
    },
    /// Resuming, but the participant's last session has ended.
    #[error("session {session} of participant '{participant}' has ended: nothing to resume")]
    Ended {
        /// The participant id.
        participant: String,
        /// The session number.
        session: u32,
    },
    /// The device gave no valid frame for the timeout. Completed trials are
    /// in the log.
    #[error(
        "no answer from the device for {timeout_s} s ({completed} trials completed are in the log)"
    )]
    Lost {
        /// The timeout, s.
        timeout_s: f64,
        /// Trials completed before.
        completed: usize,
    },
    /// The device never answered within the timeout; no session was
    /// started or resumed (nothing written).
    #[error("no answer from the device for {timeout_s} s; no session was started")]
    NeverConnected {
        /// The timeout, s.
        timeout_s: f64,
    },
    /// The device could not be opened (nothing written).
    #[error("--device: {0}: {1}")]
    Device(String, String),
    /// The port answered, but not as the device it was named as; no
    /// session was started (nothing written).
    #[error("--device: {0}: {1}; no session was started")]
    WrongDevice(String, &'static str),
    /// The device answered, but the hand stayed off the track; no session
    /// was started (nothing written).
    #[error(
        "the hand stayed {:.1} mm off the track for {timeout_s} s (a session starts with it within {:.0} mm; see docs/guide/devices.md); no session was started",
        off_m * 1e3,
        ON_TRACK_M * 1e3
    )]
    OffTrack {
        /// How far off it was last, m.
        off_m: f64,
        /// The timeout, s.
        timeout_s: f64,
    },
    /// The protocol asks for positions beyond the device's travel (each
    /// at its JSON path); nothing written (issue 63).
    #[error("{}", .0.iter().map(ToString::to_string).collect::<Vec<_>>().join("; "))]
    BeyondTravel(Vec<crate::problem::Problem>),
    /// After the experimenter confirmed a request, the hand stayed off the
    /// track. Completed trials are in the log.
    #[error(
        "the hand stayed {:.1} mm off the track for {timeout_s} s after the device was set up again (the session goes on with it within {:.0} mm); {completed} trials completed are in the log",
        off_m * 1e3,
        ON_TRACK_M * 1e3
    )]
    NotBackOnTrack {
        /// How far off it was last, m.
        off_m: f64,
        /// The timeout, s.
        timeout_s: f64,
        /// Trials completed.
        completed: usize,
    },
    /// The haptic loop could not start.
    #[error("cannot start the haptic loop: {0}")]
    Loop(std::io::Error),
    /// A sound output was lost and not back within the run's timeout
    /// ([`sound`]): the run stopped as for a device that failed, the trial
    /// under way aborted and the log open for a resume.
    #[error("{why} ({completed} trials completed are in the log)")]
    SoundLost {
        /// What was lost, and why it could not be opened again.
        why: String,
        /// Trials completed.
        completed: usize,
    },
    /// The device could not go on ([`Session::device_failure`]). Completed
    /// trials are in the log.
    #[error("{failure} ({completed} trials completed are in the log)")]
    DeviceFailed {
        /// What failed.
        failure: DeviceFailure,
        /// Trials completed.
        completed: usize,
    },
    /// The device asked the experimenter for something
    /// ([`Event::DeviceRequest`]) and nobody confirmed it: no one to ask
    /// (`within_s` None), or not within `within_s`. Completed trials are
    /// in the log.
    #[error(
        "{}; {}; {completed} trials completed are in the log",
        request.ask(),
        within_s.map_or_else(|| "there is no one to confirm it here".to_owned(), |s| format!("not confirmed within {s} s"))
    )]
    NotConfirmed {
        /// What the device asked.
        request: crate::device::haptic::Request,
        /// How long it waited, s (None: no one could be asked).
        within_s: Option<f64>,
        /// Trials completed.
        completed: usize,
    },
    /// The session could not be published on the Lab Streaming Layer.
    #[error("{0}")]
    Lsl(String),
}

/// An input waiting for the engine, or the engine's due timeout.
enum Pending {
    Input(Input),
    Timeout,
}

/// Whether the session waits for its shell ([`Session::wait_for_shell`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Gate {
    /// It does not.
    Open,
    /// It does (at the start on a port, at the end, and for the simulated
    /// device's samples): no [`Event::Ready`] yet.
    Waiting,
    /// [`Event::Ready`] went out; ticks are dropped until [`Feed::Go`].
    Asked,
    /// The shell said go (or the simulated device needs no start).
    Went,
}

/// What a shell adds to each trial's record where it is written.
pub type Annotate = Box<dyn FnMut(&mut LoggedTrial) + Send>;

/// A session being run: see the module docs.
pub struct Session<R: Responder> {
    engine: Engine,
    log: Log,
    device: Device,
    device_label: String,
    responder: R,
    sample: DeviceSample,
    t: Time,
    start_t: Time,
    pending: VecDeque<Pending>,
    timeout_queued: bool,
    /// The engine's [`Engine::poll_timeout`], kept after each call that
    /// can change it (`handle`, `handle_timeout`) so ticks need not ask.
    engine_deadline: Option<Time>,
    state: SessionState,
    view: View,
    trace: Option<Trace>,
    lost_since: Option<Time>,
    resumed_at: Option<usize>,
    records: usize,
    last_record: Option<usize>,
    done_this_run: usize,
    /// Wall-clock time of the window's last frame, s.
    last_frame_s: Option<f64>,
    /// Session time the window's frames have given the simulated device
    /// and its whole ticks have not yet taken ([`Feed::Frame`]).
    owed: Time,
    renders: Renders,
    /// The render in effect at the last device sample, and how it was
    /// stepped.
    row_render: (u32, How),
    /// The last device sample's row marks, and (the simulated device) whether
    /// a render takes effect at the next.
    row_marks: RowMarks,
    /// While the session waits to start: how far off the track the hand
    /// was at the last tick, if it was too far.
    off_track_m: Option<f64>,
    /// While the session waits to start: what is wrong with the device's
    /// answers, if anything.
    device_problem: Option<&'static str>,
    /// Since when the hand has been on the track, waiting to start.
    on_track_since: Option<Time>,
    /// What happened and no shell has polled yet (`None`: nobody asked,
    /// [`Session::with_events`]).
    events: Option<VecDeque<Event>>,
    /// Whether (and where) the session waits for its shell.
    gate: Gate,
    /// The log's last lines, waiting for the shell's ([`Feed::Close`]).
    closing: Option<Closing>,
    /// The trial the engine was in after its last input, if any.
    trial_seen: Option<usize>,
    annotate: Option<Annotate>,
    /// A port's ticks that came while a record was written wait to be
    /// read before the next trial starts ([`Session::poll_device`]).
    catching_up: bool,
    /// The plan's loop rate (its fastest model's), Hz.
    loop_rate_hz: f64,
    /// The device fault behind the abort queued for the trial under way.
    fault_queued: Option<String>,
    /// The newest render sent to a port that its ticks have not yet shown
    /// in effect, and when it was sent ([`RENDER_IN_EFFECT_WITHIN_S`]).
    render_due: Option<(u32, Time)>,
    /// Presentations in a row aborted for device faults.
    faults_in_a_row: u32,
    /// A device failure found while fed, to end the run with once the feed
    /// is handled; and the one that ended it.
    failing: Option<DeviceFailure>,
    failure: Option<DeviceFailure>,
    /// What the device asks of the experimenter, and whether the hand is
    /// to come back on the track after a confirmation.
    request: Asked,
}

/// Where the device's request stands.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Asked {
    /// It asks nothing.
    Nothing,
    /// It asks this ([`Event::DeviceRequest`] went out).
    Asks(crate::device::haptic::Request),
    /// The experimenter confirmed; ticks the loop sent before it heard so
    /// still ask, until one that does not.
    Confirmed,
    /// The device no longer asks: the session goes on once the hand is
    /// back on the track, as it starts.
    BackOnTrack,
}

/// The log's last lines, once the shell has added its own.
enum Closing {
    /// The session ended: its `end` line.
    End,
    /// The run stopped: this line, if any (`interrupted`).
    Stop(Option<Box<LogLine>>),
}

impl<R: Responder> Session<R> {
    /// Plans (or resumes) a session and starts its device; `responder` makes
    /// the responder from the session's header (a simulated participant is
    /// drawn from its plan seed and id). With the simulated device the log
    /// opens now; on a port at the first connected tick.
    ///
    /// # Errors
    /// Bad input (resume without an unfinished session), I/O, or a haptic
    /// loop that cannot start.
    pub fn begin(
        dir: &ResultsDir,
        req: &SessionRequest<'_>,
        responder: impl FnOnce(&Header) -> R,
    ) -> Result<Self, SessionError> {
        let planned = open::plan(dir, req, R::LABEL)?;
        Session::from_planned(dir, planned, req.device, responder)
    }

    /// Starts a session already planned ([`open::plan`], perhaps with
    /// another trial source) on `device`.
    ///
    /// # Errors
    /// As [`Session::begin`].
    pub fn from_planned(
        dir: &ResultsDir,
        planned: PlannedSession,
        device: &DeviceChoice,
        responder: impl FnOnce(&Header) -> R,
    ) -> Result<Self, SessionError> {
        let responder = responder(planned.header());
        let start_t = planned.start_time();
        let resumed_at = planned.resumes_at();
        let engine = planned.engine();
        let rate_hz = planned.source.loop_rate_hz();
        let log = Log::Unopened {
            planned: Box::new(planned),
            dir: dir.clone(),
            notes: Vec::new(),
        };
        Session::assemble(
            log,
            engine,
            (start_t, resumed_at),
            rate_hz,
            device,
            responder,
        )
    }

    /// A new session on the simulated device whose records stay in memory
    /// (no file is written: [`Session::into_records`] hands them over),
    /// with the header and trial source of [`open::new_session`]. What it
    /// presents and records is what the same session run into a results
    /// folder would.
    ///
    /// # Errors
    /// None in practice (no I/O); the type is the other sessions'.
    pub fn in_memory(
        header: Header,
        source: std::sync::Arc<dyn TrialSource<Registry>>,
        responder: impl FnOnce(&Header) -> R,
    ) -> Result<Self, SessionError> {
        let responder = responder(&header);
        let rate_hz = source.loop_rate_hz();
        let engine = Engine::resume(header.protocol.clone(), source, Vec::new());
        let log = Log::Memory(Box::new(ReadLog {
            header,
            trials: Vec::new(),
            ended: false,
            valid_len: 0,
            torn_bytes: 0,
        }));
        Session::assemble(
            log,
            engine,
            (Time::ZERO, None),
            rate_hz,
            &DeviceChoice::Simulated,
            responder,
        )
    }

    /// The session's header and records (those kept in memory by
    /// [`Session::in_memory`], or those its log holds; none before its log
    /// opens).
    #[must_use]
    pub fn into_records(self) -> ReadLog {
        match self.log {
            Log::Memory(read) => *read,
            Log::Open(open) => open.read,
            Log::Unopened { planned, .. } => ReadLog {
                header: planned.header().clone(),
                trials: Vec::new(),
                ended: false,
                valid_len: 0,
                torn_bytes: 0,
            },
        }
    }

    /// Starts the device and the session around `log` and `engine`, at
    /// session time `start_t` (`resumed_at`: the trial a resume starts at),
    /// put on the tick grid of the plan's rate (a log of format 1 ended
    /// its trials at float sums, a nanosecond or so off its ticks).
    fn assemble(
        mut log: Log,
        engine: Engine,
        (start_t, resumed_at): (Time, Option<usize>),
        rate_hz: f64,
        device: &DeviceChoice,
        responder: R,
    ) -> Result<Self, SessionError> {
        let device_label = device.label();
        let simulated = matches!(device, DeviceChoice::Simulated);
        let device = Device::open(device, rate_hz, responder.hand_mass_kg())?;
        // Every position the protocol asks for within the device's travel,
        // before anything is written (issue 63).
        let beyond = crate::protocol::check::beyond_travel(
            &log.header().protocol,
            device.travel_m(),
            &if simulated {
                SIMULATED_APPARATUS.to_owned()
            } else {
                format!("the device {device_label}")
            },
        );
        if !beyond.is_empty() {
            return Err(SessionError::BeyondTravel(beyond));
        }
        log.set_device_settings(device.settings());
        if let Some(limits) = device.sim_limits() {
            log.set_device_limits(limits);
        }
        if simulated && !matches!(log, Log::Memory(_)) {
            log.open()?;
        }
        // How the simulated device steps, for its streams' rows (a port's
        // ticks say how each was stepped).
        let how = device.sim_how().unwrap_or(How {
            mode: RenderMode::Simulated,
            float: crate::friction::Float::F64,
            rate_hz: 0.0,
            ramp_s: 0.0,
            force_limit_n: 0.0,
        });
        let start_t = start_t.ceil_to(Time::period(rate_hz));
        Ok(Session {
            engine,
            log,
            device,
            device_label,
            responder,
            sample: DeviceSample::default(),
            t: start_t,
            start_t,
            pending: VecDeque::from([Pending::Input(Input::Start)]),
            timeout_queued: false,
            engine_deadline: None,
            state: SessionState::Running,
            view: View::default(),
            trace: None,
            lost_since: None,
            resumed_at,
            records: 0,
            last_record: None,
            done_this_run: 0,
            last_frame_s: None,
            owed: Time::ZERO,
            renders: Renders::default(),
            row_marks: RowMarks::default(),
            off_track_m: None,
            on_track_since: None,
            device_problem: None,
            row_render: (0, how),
            events: None,
            gate: Gate::Open,
            closing: None,
            trial_seen: None,
            annotate: None,
            catching_up: false,
            loop_rate_hz: rate_hz,
            fault_queued: None,
            render_due: None,
            faults_in_a_row: 0,
            failing: None,
            failure: None,
            request: Asked::Nothing,
        })
    }

    /// Keeps a live trace of the device (for the window).
    #[must_use]
    pub fn with_trace(mut self) -> Self {
        self.trace = Some(Trace::default());
        self
    }

    /// Keeps what happens for [`Session::poll_event`] (a session nobody
    /// polls keeps nothing).
    #[must_use]
    pub fn with_events(mut self) -> Self {
        self.events.get_or_insert_with(VecDeque::new);
        self
    }

    /// Has the session wait for its shell (module docs): on a port it
    /// starts at [`Feed::Go`] after [`Event::Ready`]; at the run's end its
    /// last log line waits for [`Feed::Close`]; the simulated device's
    /// samples come as [`Event::Sample`]. Keeps events.
    pub fn wait_for_shell(&mut self) {
        self.events.get_or_insert_with(VecDeque::new);
        self.gate = if self.device.is_sim() {
            Gate::Went
        } else {
            Gate::Waiting
        };
    }

    /// Has `annotate` add the shell's part to each trial's record (a
    /// [`LoggedTrial`]: the engine's record, the session's renders) just
    /// before it is written.
    pub fn annotate_records(&mut self, annotate: Annotate) {
        self.annotate = Some(annotate);
    }

    /// Has a port's haptic loop offer each connected tick to `sink`, on
    /// its thread. Nothing with the simulated device (see
    /// [`Event::Sample`]).
    pub fn offer_samples(&mut self, sink: crate::device::haptic::Offer) {
        if let Device::Port(port) = &mut self.device {
            port.offer(sink);
        }
    }

    /// The next thing that happened, oldest first (with
    /// [`Session::with_events`]).
    pub fn poll_event(&mut self) -> Option<Event> {
        self.events.as_mut()?.pop_front()
    }

    /// The session time at which the session next wants feeding: the
    /// simulated device's next tick while running, else the engine's next
    /// deadline (a port's ticks come from its loop).
    #[must_use]
    pub fn poll_timeout(&self) -> Option<Time> {
        match &self.device {
            Device::Stepped { dt, .. } if self.state == SessionState::Running => Some(self.t + *dt),
            _ => self.engine_deadline,
        }
    }

    /// The instant a port's loop counts its ticks' time from (`None` for
    /// the simulated device).
    #[must_use]
    pub fn loop_origin(&self) -> Option<std::time::Instant> {
        self.device.origin()
    }

    /// The device's label (`sim` or the port).
    #[must_use]
    pub fn device_label(&self) -> &str {
        &self.device_label
    }

    /// Why the device could not go on, once the run has ended for it
    /// (module docs: a device that keeps failing).
    #[must_use]
    pub fn device_failure(&self) -> Option<&DeviceFailure> {
        self.failure.as_ref()
    }

    /// What the device asks of the experimenter, until confirmed
    /// ([`Feed::Confirm`]).
    #[must_use]
    pub fn device_request(&self) -> Option<crate::device::haptic::Request> {
        match self.request {
            Asked::Asks(request) => Some(request),
            Asked::Nothing | Asked::Confirmed | Asked::BackOnTrack => None,
        }
    }

    /// Whether the device is the simulated one.
    #[must_use]
    pub fn is_sim(&self) -> bool {
        self.device.is_sim()
    }

    /// How the simulated device steps, at the plan's loop rate (its
    /// fastest model's): the device stream's nominal rate.
    #[must_use]
    pub fn sim_stepping(&self) -> Option<How> {
        self.device.is_sim().then_some(How {
            rate_hz: self.loop_rate_hz,
            ..self.row_render.1
        })
    }

    /// The trial a resume starts at, if this run resumes.
    #[must_use]
    pub fn resumed_at(&self) -> Option<usize> {
        self.resumed_at
    }

    /// The session's header.
    #[must_use]
    pub fn header(&self) -> &Header {
        self.log.header()
    }

    fn emit(&mut self, event: impl FnOnce() -> Event) {
        if let Some(events) = &mut self.events {
            events.push_back(event());
        }
    }

    /// The one way in: see [`Feed`].
    ///
    /// # Errors
    /// I/O on the log or CSV.
    pub fn handle(&mut self, feed: Feed) -> Result<(), ResultsError> {
        if !matches!(feed, Feed::Close(_)) {
            // A shell that did not close: the log's last lines as they are.
            self.close(&[])?;
        }
        let handled = match feed {
            Feed::Tick => self.step(),
            Feed::Poll => self.poll_device(),
            Feed::Frame(wall_s) => self.advance(wall_s),
            Feed::Input(input) => self.input(input),
            Feed::Click => {
                let x_m = self.sample.x_m;
                self.input(Input::Click { x_m })
            }
            Feed::Pause => self.pause("paused by the experimenter"),
            Feed::Hold(reason) => self.pause(&reason),
            Feed::Resume => self.resume(),
            Feed::Abort => self.stop_run("session aborted by the experimenter", None),
            Feed::Signal(signal) => self.stop_run(
                INTERRUPTED,
                Some(LogLine::Interrupted {
                    signal: signal.name().to_owned(),
                }),
            ),
            Feed::Note(text) => self.note(text),
            Feed::StopDevice => self.stop_device(),
            Feed::Go => {
                if self.gate == Gate::Asked {
                    self.gate = Gate::Went;
                    // The session starts at the next tick, not on the
                    // ticks queued while the shell got ready.
                    if let Device::Port(port) = &mut self.device {
                        port.skip_queued();
                    }
                }
                Ok(())
            }
            Feed::Close(lines) => self.close(&lines),
            Feed::Confirm => self.confirm(),
        };
        handled?;
        match self.failing.take() {
            Some(failure) => self.fail(&failure),
            None => Ok(()),
        }
    }

    /// The device failed: the run ends (the one rule for every device and
    /// shell), its reason noted in the log.
    fn fail(&mut self, failure: &DeviceFailure) -> Result<(), ResultsError> {
        if self.failure.is_some()
            || !matches!(self.state, SessionState::Running | SessionState::Paused)
        {
            return Ok(());
        }
        self.failure = Some(failure.clone());
        if self.log.opened().is_some() {
            self.note(format!("the run ended: {failure}"))?;
        }
        self.stop_run(DEVICE_FAILED, None)
    }

    /// The experimenter did what the device asked: it is told, and the log
    /// notes it.
    fn confirm(&mut self) -> Result<(), ResultsError> {
        let Asked::Asks(request) = self.request else {
            return Ok(());
        };
        self.request = Asked::Confirmed;
        if let Device::Port(port) = &mut self.device {
            port.confirm();
        }
        self.on_track_since = None;
        self.note(format!(
            "the device asked ({}); the experimenter confirmed",
            request.ask()
        ))
    }

    /// Writes `lines` and then the log's last line, if the run has ended
    /// and they wait ([`Feed::Close`]).
    fn close(&mut self, lines: &[LogLine]) -> Result<(), ResultsError> {
        let Some(closing) = self.closing.take() else {
            return Ok(());
        };
        if let Some(open) = self.log.opened() {
            for line in lines {
                open.log.append(line)?;
            }
        }
        match closing {
            Closing::End => self.log.write_end(),
            Closing::Stop(Some(line)) => match self.log.opened() {
                Some(open) => open.log.append(&line),
                None => Ok(()),
            },
            Closing::Stop(None) => Ok(()),
        }
    }

    /// The run ends with `closing`: now, or at the shell's [`Feed::Close`].
    fn end_with(&mut self, closing: Closing) -> Result<(), ResultsError> {
        self.closing = Some(closing);
        if self.gate == Gate::Open {
            self.close(&[])
        } else {
            Ok(())
        }
    }

    fn step(&mut self) -> Result<(), ResultsError> {
        self.settle()?;
        if self.state == SessionState::Running {
            self.tick_sim();
        }
        Ok(())
    }

    fn tick_sim(&mut self) {
        let Some(dt) = self.device.stepped_dt() else {
            return;
        };
        let force = self.responder.hand_force(self.t, dt.secs(), &self.sample);
        let Some(tick) = self.device.step(self.t, force) else {
            return;
        };
        self.sample = tick.sample();
        self.row_marks = RowMarks {
            selected: tick.selected,
            watchdog: false,
            device_tick: None,
            axes: None,
        };
        // How the stepped device steps changes only with its model
        // (`Session::render`).
        self.row_render.0 = tick.render;
        self.t += dt;
        if self.gate != Gate::Open {
            let (t, sample) = (self.t, self.sample);
            self.emit(|| Event::Sample { t, sample });
        }
        self.observe();
    }

    fn poll_device(&mut self) -> Result<(), ResultsError> {
        while let Device::Port(port) = &mut self.device
            && let Some((tick, pressed)) = port.recv()
        {
            // The loop's clock on the session's, to the nearest tick of
            // the device's rate, never going back.
            let how = port.how(&tick);
            let period = Time::period(how.rate_hz);
            let at = self.start_t + Time::from_secs_saturating(tick.now_s).round_to(period);
            self.t = self.t.max(at);
            if matches!(self.log, Log::Unopened { .. }) {
                self.device_problem = tick.problem;
            } else if let Some(problem) = tick.problem {
                // Its answers are judged not its own: the run ends.
                self.failing = Some(DeviceFailure::NotTheDevice(problem));
                return Ok(());
            }
            match (tick.request, self.request) {
                (Some(request), Asked::Nothing | Asked::BackOnTrack) => {
                    self.request = Asked::Asks(request);
                    let t = self.t;
                    self.emit(|| Event::DeviceRequest { t, request });
                }
                (None, Asked::Confirmed) => self.request = Asked::BackOnTrack,
                (None, Asked::Asks(_)) => self.request = Asked::Nothing,
                _ => {}
            }
            if tick.link != LinkState::Connected {
                // The abort takes effect now: ticks read after this one
                // (the device back, started afresh) are no part of the
                // trial.
                self.lost(tick.problem, tick.request);
                self.settle()?;
                continue;
            }
            if self.lost_since.take().is_some() {
                let t = self.t;
                self.emit(|| Event::DeviceBack { t });
            }
            if self.request == Asked::BackOnTrack && self.on_track(&tick) {
                self.request = Asked::Nothing;
            }
            if matches!(self.log, Log::Unopened { .. }) {
                // A session starts with the hand on the track, held
                // there for ON_TRACK_HOLD_S (not passing through it), on
                // a device with no problem.
                if tick.problem.is_some() {
                    self.on_track_since = None;
                    continue;
                }
                if !self.on_track(&tick) {
                    continue;
                }
                match self.gate {
                    Gate::Waiting => {
                        // Its shell gets ready first (its streams open,
                        // perhaps waiting for a recorder).
                        self.gate = Gate::Asked;
                        self.emit(|| Event::Ready { how });
                        continue;
                    }
                    Gate::Asked => continue,
                    Gate::Open | Gate::Went => {}
                }
                // The session starts (its files are written) once the
                // device answers, its header with what it states.
                if let Device::Port(port) = &self.device {
                    self.log.set_device_limits(port.limits(&tick));
                }
                self.log.open()?;
                if self.device.axes() > 1
                    && let Some(open) = self.log.opened()
                {
                    open.streams.multi_axis();
                }
            }
            if self.render_late(tick.render) {
                // The abort takes effect now, as a lost device's.
                self.settle()?;
                continue;
            }
            let Device::Port(port) = &mut self.device else {
                break;
            };
            self.sample = tick.sample();
            self.row_render = (tick.render, how);
            self.row_marks = RowMarks {
                selected: tick.selected,
                watchdog: tick.watchdog,
                device_tick: tick.device_tick,
                axes: (port.axes > 1).then_some((
                    tick.position_m,
                    tick.force_vector_n,
                    tick.normal_n,
                )),
            };
            if let Some(drive) = self.responder.drive(self.t, &self.sample) {
                port.drive_hand(tick.now_s, &drive);
            }
            if pressed && self.state == SessionState::Running {
                self.queue(Input::Click { x_m: tick.x_m });
            }
            self.observe();
        }
        // Every tick the loop has reported is read: a trial waiting for
        // the present (after a record's write) may start.
        self.catching_up = false;
        if let Device::Port(port) = &mut self.device
            && let Some(why) = port.died()
        {
            self.failing = Some(DeviceFailure::LoopDied(why));
            return Ok(());
        }
        self.settle()
    }

    fn advance(&mut self, wall_s: f64) -> Result<(), ResultsError> {
        let step = self
            .last_frame_s
            .map_or(0.0, |w| (wall_s - w).clamp(0.0, MAX_FRAME_STEP_S));
        self.last_frame_s = Some(wall_s);
        if !matches!(self.state, SessionState::Running | SessionState::Paused) {
            return Ok(());
        }
        let most = Time::from_secs_saturating(MAX_FRAME_STEP_S);
        if self.state == SessionState::Running {
            self.owed = (self.owed + Time::from_secs_saturating(step)).min(most);
        }
        if self.device.is_sim() {
            let end = self.t + self.owed;
            self.emit(|| Event::Frame { end });
        }
        loop {
            self.settle()?;
            match &self.device {
                Device::Stepped { dt, .. }
                    if self.state == SessionState::Running && *dt <= self.owed =>
                {
                    self.owed = self.owed - *dt;
                    self.tick_sim();
                }
                Device::Port(_) => return self.poll_device(),
                _ => {
                    if self.state != SessionState::Running {
                        // Paused: the frame's time is not owed later.
                        self.owed = Time::ZERO;
                    }
                    return Ok(());
                }
            }
        }
    }

    /// After each device sample: its stream, the trace, the responder, and
    /// the engine's timeout when due.
    fn observe(&mut self) {
        if self.engine.in_trial()
            && let Some(open) = self.log.opened()
        {
            let (render, how) = self.row_render;
            let index = self.renders.row(render, how);
            open.streams
                .push(self.t.secs(), &self.sample, index, self.row_marks);
        }
        if let Some(trace) = &mut self.trace {
            trace.observe(self.t.secs(), &self.sample);
        }
        let reaction = self.responder.decide(self.t, &self.sample);
        self.apply(reaction);
        if !self.timeout_queued && self.engine_deadline.is_some_and(|due| due <= self.t) {
            self.timeout_queued = true;
            self.pending.push_back(Pending::Timeout);
        }
    }

    /// Whether the hand is on the track and has been for
    /// [`ON_TRACK_HOLD_S`] (on a device with more than one axis), by
    /// `tick`; how far off it is, if too far.
    fn on_track(&mut self, tick: &crate::device::haptic::Tick) -> bool {
        if tick.off_track_m > ON_TRACK_M {
            self.off_track_m = Some(tick.off_track_m);
            self.on_track_since = None;
            return false;
        }
        let since = *self.on_track_since.get_or_insert(self.t);
        if self.device.axes() > 1 && (self.t - since).secs() < ON_TRACK_HOLD_S {
            return false;
        }
        self.off_track_m = None;
        self.on_track_since = None;
        true
    }

    /// Whether a tick showing `render` in effect finds the render last
    /// sent late ([`RENDER_IN_EFFECT_WITHIN_S`]) during a trial: if so,
    /// that trial's abort is queued, for a device fault.
    fn render_late(&mut self, render: u32) -> bool {
        let Some((due, since)) = self.render_due else {
            return false;
        };
        if render != crate::device::haptic::UNKNOWN_RENDER && render >= due {
            self.render_due = None;
            return false;
        }
        if (self.t - since).secs() <= RENDER_IN_EFFECT_WITHIN_S || !self.engine.in_trial() {
            return false;
        }
        self.render_due = None;
        let fault = format!(
            "the device did not render what it was sent within {RENDER_IN_EFFECT_WITHIN_S} s"
        );
        self.interrupt_trial(&fault);
        self.fault_queued.get_or_insert(fault);
        true
    }

    /// The one lost-device rule (module docs); `problem` and `request`
    /// are what the device said of itself, for the fault's description.
    fn lost(&mut self, problem: Option<&str>, request: Option<crate::device::haptic::Request>) {
        if self.lost_since.is_none() && matches!(self.log, Log::Open(_)) {
            // Lost after it had answered (not still connecting).
            let t = self.t;
            self.emit(|| Event::DeviceLost { t });
        }
        self.lost_since.get_or_insert(self.t);
        if self.engine.in_trial() {
            self.interrupt_trial("device lost");
            if self.fault_queued.is_none() {
                self.fault_queued = Some(match (request, problem) {
                    (Some(r), _) => format!("device lost: {}", r.ask()),
                    (None, Some(p)) => format!("device lost: {p}"),
                    (None, None) => "device lost".to_owned(),
                });
            }
        }
    }

    /// Counts a record toward [`MAX_DEVICE_FAULTS_IN_A_ROW`]: an abort for
    /// a device fault adds one, any other record starts again. At the
    /// bound the run is held (no next presentation) and ends once the
    /// feed is handled.
    fn count_fault(&mut self, record: &LoggedTrial) {
        let fault = self.fault_queued.take();
        match fault {
            Some(fault) if record.status != crate::protocol::engine::Status::Completed => {
                self.faults_in_a_row += 1;
                if self.faults_in_a_row >= MAX_DEVICE_FAULTS_IN_A_ROW {
                    self.failing = Some(DeviceFailure::Faults {
                        trial: record.trial,
                        presentations: self.faults_in_a_row,
                        fault,
                    });
                    self.state = SessionState::Paused;
                }
            }
            _ => self.faults_in_a_row = 0,
        }
    }
    /// Queues an abort (re-queued) of the trial under way, ahead of every
    /// other input, unless one is queued already.
    fn interrupt_trial(&mut self, reason: &str) {
        if !matches!(
            self.pending.front(),
            Some(Pending::Input(Input::Abort { .. }))
        ) {
            self.pending.push_front(Pending::Input(Input::Abort {
                reason: reason.into(),
                requeue: true,
            }));
        }
    }

    fn queue(&mut self, input: Input) {
        self.pending.push_back(Pending::Input(input));
    }

    #[expect(
        clippy::inline_always,
        reason = "called every tick with nothing to do; left out of line it costs 2.4% of a simulated session's instructions (callgrind)"
    )]
    #[inline(always)]
    fn apply(&mut self, reaction: Reaction) {
        if let Some(x_m) = reaction.reset_to
            && self.device.is_sim()
        {
            let render = self.renders.send(self.renders.last_model());
            self.device.reset(self.t, x_m, render);
            self.sample = DeviceSample {
                x_m,
                ..DeviceSample::default()
            };
        }
        if !reaction.inputs.is_empty() {
            self.pending
                .extend(reaction.inputs.into_iter().map(Pending::Input));
        }
    }

    /// Carries out the engine's actions and feeds it pending inputs until
    /// nothing moves. Inputs wait while paused or while the device is lost;
    /// an abort goes through.
    #[expect(
        clippy::inline_always,
        reason = "called every tick; left out of line it costs 2% of a simulated session (callgrind)"
    )]
    #[inline(always)]
    fn settle(&mut self) -> Result<(), ResultsError> {
        // Most ticks nothing is waiting.
        if self.pending.is_empty() && !self.engine.has_actions() {
            return Ok(());
        }
        self.settle_all()
    }

    fn settle_all(&mut self) -> Result<(), ResultsError> {
        loop {
            while let Some(action) = self.engine.poll() {
                self.act(&action)?;
            }
            let Some(front) = self.pending.front() else {
                return Ok(());
            };
            // On a port nothing flows before the session has started (its
            // log open: the device answers, the hand on the track), so no
            // trial is presented, and no record written, before then.
            let flows = self.state == SessionState::Running
                && self.device.connected()
                && !matches!(self.request, Asked::Confirmed | Asked::BackOnTrack)
                && !matches!(self.log, Log::Unopened { .. });
            let next = match front {
                Pending::Input(Input::Abort { .. }) => self.pending.pop_front(),
                Pending::Input(Input::Recorded) if self.catching_up => None,
                _ if flows => self.pending.pop_front(),
                _ => None,
            };
            match next {
                None => return Ok(()),
                Some(Pending::Input(input)) => {
                    if self.events.is_some() {
                        let (t, trial) = (self.t, self.trial_under_way());
                        let input = input.clone();
                        self.emit(|| Event::Input { t, trial, input });
                    }
                    self.engine.handle(self.t, input);
                }
                Some(Pending::Timeout) => {
                    self.timeout_queued = false;
                    self.engine.handle_timeout(self.t);
                }
            }
            let in_trial = self.trial_under_way();
            if in_trial.is_some()
                && self.trial_seen.is_none()
                && self.events.is_some()
                && let Some(trial) = self.engine.trial()
            {
                let (t, trial) = (self.t, Box::new(trial.clone()));
                self.emit(|| Event::TrialStarted { t, trial });
            }
            self.trial_seen = in_trial;
            self.engine_deadline = self.engine.poll_timeout();
        }
    }

    /// The trial under way, if any.
    fn trial_under_way(&self) -> Option<usize> {
        self.engine.in_trial().then(|| self.engine.trial_index())
    }

    fn act(&mut self, action: &Action) -> Result<(), ResultsError> {
        self.view.follow(action);
        let mut render = None;
        match action {
            Action::Render(model) => render = Some(self.render(model.as_ref())),
            Action::Physical(model) => self.device.set_physical(model.as_ref()),
            Action::Record(record) => {
                let mut record = LoggedTrial::new(record.clone());
                record.rendering = self.renders.take();
                if let Some(annotate) = &mut self.annotate {
                    annotate(&mut record);
                }
                self.log.write_record(&record)?;
                self.count_fault(&record);
                // The next trial starts after this one's record.
                self.trial_seen = None;
                if self.events.is_some() {
                    let (t, record) = (self.t, Box::new(record.clone()));
                    self.emit(|| Event::Written { t, record });
                }
                // On a port the loop ran on while the record was written:
                // the next trial starts once those ticks are read, at the
                // present, not at the tick before the write.
                self.catching_up = matches!(self.device, Device::Port(_));
                self.records += 1;
                self.last_record = Some(record.trial);
                if !record.requeued {
                    self.done_this_run += 1;
                }
                self.queue(Input::Recorded);
            }
            Action::Finished => {
                self.stop_device()?;
                let outcome = self.outcome();
                let (t, completed, aborted) = (self.t, outcome.completed, outcome.aborted);
                self.emit(|| Event::Finished {
                    t,
                    completed,
                    aborted,
                });
                self.state = SessionState::Finished;
                return self.end_with(Closing::End);
            }
            Action::Show(_)
            | Action::ShowOwn(_)
            | Action::Ask(_)
            | Action::Refused(_)
            | Action::Prompt(_) => {}
        }
        if self.events.is_some() && !matches!(action, Action::Physical(_) | Action::Record(_)) {
            let (t, trial) = (self.t, self.engine.trial().map(|p| p.index));
            let action = Box::new(action.clone());
            self.emit(|| Event::Action {
                t,
                trial,
                action,
                render,
            });
        }
        let reaction = self
            .responder
            .on_action(self.t, action, self.engine.trial());
        self.apply(reaction);
        Ok(())
    }

    /// Stops the haptic loop, putting its statistics in the log (a session
    /// whose device never answered has no log to hold them).
    fn stop_device(&mut self) -> Result<(), ResultsError> {
        if let Some(stats) = self.device.stop()
            && let Some(open) = self.log.opened()
        {
            open.log.append(&LogLine::Loop(stats))?;
        }
        Ok(())
    }

    fn input(&mut self, input: Input) -> Result<(), ResultsError> {
        if self.state != SessionState::Running {
            return Ok(());
        }
        self.queue(input);
        self.settle()
    }

    fn pause(&mut self, reason: &str) -> Result<(), ResultsError> {
        if self.state != SessionState::Running {
            return Ok(());
        }
        self.state = SessionState::Paused;
        let t = self.t;
        self.emit(|| Event::Paused { t });
        self.interrupt(reason)
    }

    fn resume(&mut self) -> Result<(), ResultsError> {
        if self.state != SessionState::Paused {
            return Ok(());
        }
        self.state = SessionState::Running;
        let t = self.t;
        self.emit(|| Event::Resumed { t });
        self.settle()
    }

    /// Aborts the run (the experimenter, or a signal: its `interrupted`
    /// line): a trial being presented is logged as aborted with `reason`
    /// (and re-queued, so a resume presents it again), the device stops,
    /// and the log stays open-ended for a resume.
    fn stop_run(&mut self, reason: &str, line: Option<LogLine>) -> Result<(), ResultsError> {
        if !matches!(self.state, SessionState::Running | SessionState::Paused) {
            return Ok(());
        }
        // Hold the engine where it is: the aborted trial's `Recorded` is
        // not delivered, so no next trial starts.
        self.state = SessionState::Paused;
        self.interrupt(reason)?;
        self.stop_device()?;
        let signal = match &line {
            Some(LogLine::Interrupted { signal }) => Some(signal.clone()),
            _ => None,
        };
        let (t, reason) = (self.t, reason.to_owned());
        self.emit(|| Event::Stopped { t, reason, signal });
        self.state = SessionState::Aborted;
        self.view = View::default();
        self.end_with(Closing::Stop(line.map(Box::new)))
    }

    fn interrupt(&mut self, reason: &str) -> Result<(), ResultsError> {
        if self.engine.in_trial() {
            self.interrupt_trial(reason);
            self.settle()?;
        }
        let _ = self.render(None);
        Ok(())
    }

    /// Renders `model` from now on, numbered (see [`renders`]).
    fn render(&mut self, model: Option<&ModelParams>) -> u32 {
        let render = self.renders.send(model.cloned());
        self.device.render(self.t, render, model);
        if matches!(self.device, Device::Port(_)) {
            self.render_due = Some((render, self.t));
        }
        if let Some(how) = self.device.sim_how() {
            self.row_render.1 = how;
        }
        render
    }

    /// Appends the experimenter's note to the session log (held until the
    /// log opens).
    fn note(&mut self, text: String) -> Result<(), ResultsError> {
        if self.events.is_some() {
            let (t, text) = (self.t, text.clone());
            self.emit(|| Event::Note { t, text });
        }
        match &mut self.log {
            Log::Open(open) => open.log.append(&LogLine::Note { text }),
            Log::Unopened { notes, .. } => {
                notes.push(text);
                Ok(())
            }
            // A session in memory is a simulated one: no experimenter.
            Log::Memory(_) => Ok(()),
        }
    }
}
