//! The session driver: the one loop that runs a session, whoever answers
//! and whatever renders.
//!
//! A [`Session`] owns the engine, the pending inputs, the open log (with its
//! CSV and streams), the [`Responder`] (a simulated participant, or a
//! [`Person`] at the window) and the device (the simulated apparatus, or the
//! haptic loop on a serial port). The shells only feed it time and read its
//! outputs:
//! - headless runs ([`headless`]): [`Session::step`] once per tick of the
//!   simulated device, in virtual time; or [`Session::poll_device`] every
//!   millisecond on a port;
//! - the window: [`Session::advance`] once per frame with the wall clock,
//!   plus the person's inputs ([`Session::input`], [`Session::click`]).
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
//! # Lab Streaming Layer
//! With [`Session::publish`] ([`lsl`]), each event is also a marker,
//! stamped with its session time on LSL's clock, and each device sample
//! goes to the device stream (a port's from its haptic loop's thread).
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
//! started afresh, which no trial's stream can show); every other input
//! waits until the device answers again. How long to wait is the shell's call
//! ([`Session::lost_for_s`]).
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
//! first connected tick, so a device that never answers leaves no session
//! behind. Notes typed before then wait for the log.

pub mod device;
pub mod feel;
pub mod headless;
pub mod lsl;
pub mod open;
pub mod record;
mod renders;
pub mod responder;
pub mod view;

use std::collections::VecDeque;
use std::path::PathBuf;

pub use device::{DeviceStatus, HAND_EVERY_S, percentile};
pub use feel::Feel;
pub use headless::{
    SessionOutcome, Simulation, participant_seed, run_device, run_planned, run_simulated, sim_id,
    sim_participant, simulate_in_memory, simulate_participants,
};
use open::Log;
pub use open::{DeviceChoice, OpenLog, Planned, SessionRequest, plan};
pub use record::{RowMarks, StreamRecorder};
pub use responder::{
    MOUSE_HAND_DAMPING_N_S_M, MOUSE_HAND_MASS_KG, MOUSE_HAND_STIFFNESS_N_M, Person, Reaction,
    Responder,
};
pub use view::{Phase, Progress, TRACE_EVERY_S, TRACE_LENGTH_S, TracePoint, View};

use crate::device::DeviceSample;
use crate::device::LinkState;
use crate::friction::ModelParams;
use crate::kinds::{Action, Engine, Header, LogLine, ReadLog, Registry};
use crate::protocol::engine::TrialSource;
use crate::protocol::engine::{Input, RenderMode};
use crate::results::{ResultsDir, ResultsError};
use crate::time::Time;
use device::Device;
use renders::{How, Renders};
use view::Trace;

/// The session a person runs from the window.
pub type LiveSession = Session<Person>;

/// The abort reason of a trial ended by a signal (issue 31).
pub const INTERRUPTED: &str = "interrupted";

/// Longest session-time step one frame may take with the simulated device, s.
pub const MAX_FRAME_STEP_S: f64 = 0.5;

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
        "the hand stayed {:.1} mm off the track for {timeout_s} s (a session starts with it within {:.0} mm; see README, Devices); no session was started",
        off_m * 1e3,
        ON_TRACK_M * 1e3
    )]
    OffTrack {
        /// How far off it was last, m.
        off_m: f64,
        /// The timeout, s.
        timeout_s: f64,
    },
    /// The haptic loop could not start.
    #[error("cannot start the haptic loop: {0}")]
    Loop(std::io::Error),
    /// The session could not be published on the Lab Streaming Layer.
    #[error("{0}")]
    Lsl(String),
}

/// An input waiting for the engine, or the engine's due timeout.
enum Pending {
    Input(Input),
    Timeout,
}

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
    due: Option<Time>,
    phase: Phase,
    view: View,
    trace: Option<Trace>,
    lost_since: Option<Time>,
    resumed_at: Option<usize>,
    records: usize,
    last_record: Option<usize>,
    done_this_run: usize,
    wall: Option<f64>,
    /// Session time the window's frames have given the simulated device
    /// and its whole ticks have not yet taken ([`Session::advance`]).
    owed: Time,
    renders: Renders,
    /// The render in effect at the last device sample, and how it was
    /// stepped.
    row_render: (u32, How),
    /// The last device sample's marks, and (the simulated device) whether
    /// a render takes effect at the next.
    marks: RowMarks,
    /// While the session waits to start: how far off the track the hand
    /// was at the last tick, if it was too far.
    off_track_m: Option<f64>,
    /// While the session waits to start: what is wrong with the device's
    /// answers, if anything.
    device_problem: Option<&'static str>,
    /// Since when the hand has been on the track, waiting to start.
    on_track_since: Option<Time>,
    sim_selected: bool,
    /// Publishing on the Lab Streaming Layer ([`lsl`]).
    lsl: Option<Box<lsl::Tap>>,
    /// A port's ticks that came while a record was written wait to be
    /// read before the next trial starts ([`Session::poll_device`]).
    catching_up: bool,
    /// The plan's loop rate (its fastest model's), Hz.
    loop_rate_hz: f64,
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
        let mut session = Session::from_planned(dir, planned, req.device, responder)?;
        if let Some(lsl) = req.lsl {
            session.publish(lsl)?;
        }
        Ok(session)
    }

    /// Starts a session already planned ([`open::plan`], perhaps with
    /// another trial source) on `device`.
    ///
    /// # Errors
    /// As [`Session::begin`].
    pub fn from_planned(
        dir: &ResultsDir,
        planned: Planned,
        device: &DeviceChoice,
        responder: impl FnOnce(&Header) -> R,
    ) -> Result<Self, SessionError> {
        let responder = responder(planned.header());
        let start_t = planned.start_time();
        let resumed_at = planned.resumes_at();
        let engine = planned.engine();
        let rate_hz = planned.source.loop_rate_hz();
        let log = Log::Planned {
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
            Log::Planned { planned, .. } => ReadLog {
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
        if matches!(device, DeviceChoice::Simulated) && !matches!(log, Log::Memory(_)) {
            log.open()?;
        }
        let device = Device::open(device, rate_hz, responder.hand_mass_kg())?;
        log.set_device_settings(device.settings());
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
            due: None,
            phase: Phase::Running,
            view: View::default(),
            trace: None,
            lost_since: None,
            resumed_at,
            records: 0,
            last_record: None,
            done_this_run: 0,
            wall: None,
            owed: Time::ZERO,
            renders: Renders::default(),
            marks: RowMarks::default(),
            off_track_m: None,
            on_track_since: None,
            device_problem: None,
            sim_selected: false,
            row_render: (0, how),
            lsl: None,
            catching_up: false,
            loop_rate_hz: rate_hz,
        })
    }

    /// Keeps a live trace of the device (for the window).
    #[must_use]
    pub fn with_trace(mut self) -> Self {
        self.trace = Some(Trace::default());
        self
    }

    /// One tick of the simulated device, in virtual time: the pending
    /// inputs settle, then the hand and device advance by the model's step.
    /// Does nothing on a port (see [`Session::poll_device`]).
    ///
    /// # Errors
    /// I/O on the log or CSV.
    pub fn step(&mut self) -> Result<(), ResultsError> {
        self.settle()?;
        if self.phase == Phase::Running {
            if self.lsl.is_some() {
                // Paced on LSL's clock: the tick waits for its time.
                self.lsl_hold();
            }
            self.tick_sim();
        }
        Ok(())
    }

    fn tick_sim(&mut self) {
        let Device::Sim { device, dt, render } = &mut self.device else {
            return;
        };
        let dt = *dt;
        let force = self.responder.hand_force(self.t, dt.secs(), &self.sample);
        self.sample = device.step(dt.secs(), force);
        self.marks = RowMarks {
            selected: std::mem::take(&mut self.sim_selected),
            watchdog: false,
            device_tick: None,
            axes: None,
        };
        // How the simulated device steps changes only with its model
        // (`Session::render`).
        self.row_render.0 = *render;
        self.t += dt;
        self.observe();
    }

    /// Reads every tick the haptic loop has reported, then settles. Does
    /// nothing more with the simulated device.
    ///
    /// # Errors
    /// I/O on the log or CSV.
    pub fn poll_device(&mut self) -> Result<(), ResultsError> {
        while let Device::Port(port) = &mut self.device
            && let Some((tick, pressed)) = port.recv()
        {
            // The loop's clock on the session's, to the nearest tick of
            // the device's rate, never going back.
            let how = port.how(&tick);
            let period = Time::period(how.rate_hz);
            let at = self.start_t + Time::from_secs_saturating(tick.now_s).round_to(period);
            self.t = self.t.max(at);
            if matches!(self.log, Log::Planned { .. }) {
                self.device_problem = tick.problem;
            }
            if tick.link != LinkState::Connected {
                // The abort takes effect now: ticks read after this one
                // (the device back, started afresh) are no part of the
                // trial.
                self.lost();
                self.settle()?;
                continue;
            }
            if self.lost_since.take().is_some() {
                lsl::device_lost(self.lsl.as_deref_mut(), self.t, false);
            }
            if matches!(self.log, Log::Planned { .. }) {
                // A session starts with the hand on the track, held
                // there for ON_TRACK_HOLD_S (not passing through it).
                if tick.off_track_m > ON_TRACK_M {
                    self.off_track_m = Some(tick.off_track_m);
                    self.on_track_since = None;
                    continue;
                }
                let since = *self.on_track_since.get_or_insert(self.t);
                if self.device.axes() > 1 && (self.t - since).secs() < ON_TRACK_HOLD_S {
                    continue;
                }
                self.off_track_m = None;
                if self.lsl.as_ref().is_some_and(|tap| !tap.is_open()) {
                    // Its streams open first (issue 42), and may have
                    // waited for a recorder: the session starts at the
                    // next tick, not on the ticks queued meanwhile.
                    self.lsl_open(how).map_err(|e| ResultsError::Io {
                        path: String::new(),
                        source: std::io::Error::other(e.to_string()),
                    })?;
                    if let Device::Port(port) = &mut self.device {
                        port.skip_queued();
                    }
                    continue;
                }
                // The session starts (its files are written) once the
                // device answers.
                self.log.open()?;
                if self.device.axes() > 1
                    && let Some(open) = self.log.opened()
                {
                    open.streams.multi_axis();
                }
            }
            let Device::Port(port) = &mut self.device else {
                break;
            };
            self.sample = tick.sample();
            self.row_render = (tick.render, how);
            self.marks = RowMarks {
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
            if pressed && self.phase == Phase::Running {
                self.queue(Input::Click { x_m: tick.x_m });
            }
            self.observe();
        }
        // Every tick the loop has reported is read: a trial waiting for
        // the present (after a record's write) may start.
        self.catching_up = false;
        self.settle()
    }

    /// Advances the session to the window's frame at wall-clock time
    /// `wall_s` (any monotonic clock, s): the simulated device steps by the
    /// frame's time (at most [`MAX_FRAME_STEP_S`]; not while paused) in
    /// whole ticks, the rest carried to the next frame; a port's ticks are
    /// read.
    ///
    /// # Errors
    /// I/O on the log or CSV.
    pub fn advance(&mut self, wall_s: f64) -> Result<(), ResultsError> {
        let step = self
            .wall
            .map_or(0.0, |w| (wall_s - w).clamp(0.0, MAX_FRAME_STEP_S));
        self.wall = Some(wall_s);
        if !matches!(self.phase, Phase::Running | Phase::Paused) {
            return Ok(());
        }
        let most = Time::from_secs_saturating(MAX_FRAME_STEP_S);
        if self.phase == Phase::Running {
            self.owed = (self.owed + Time::from_secs_saturating(step)).min(most);
        }
        if self.device.is_sim() {
            self.lsl_frame(self.t + self.owed);
        }
        loop {
            self.settle()?;
            match &self.device {
                Device::Sim { dt, .. } if self.phase == Phase::Running && *dt <= self.owed => {
                    self.owed = self.owed - *dt;
                    self.tick_sim();
                }
                Device::Port(_) => return self.poll_device(),
                _ => {
                    if self.phase != Phase::Running {
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
                .push(self.t.secs(), &self.sample, index, self.marks);
        }
        if self.lsl.is_some() {
            self.lsl_sample();
        }
        if let Some(trace) = &mut self.trace {
            trace.observe(self.t.secs(), &self.sample);
        }
        let reaction = self.responder.decide(self.t, &self.sample);
        self.apply(reaction);
        if !self.timeout_queued && self.due.is_some_and(|due| due <= self.t) {
            self.timeout_queued = true;
            self.pending.push_back(Pending::Timeout);
        }
    }

    /// The one lost-device rule (module docs).
    fn lost(&mut self) {
        if self.lost_since.is_none() && matches!(self.log, Log::Open(_)) {
            // Lost after it had answered (not still connecting).
            lsl::device_lost(self.lsl.as_deref_mut(), self.t, true);
        }
        self.lost_since.get_or_insert(self.t);
        if self.engine.in_trial() {
            self.interrupt_trial("device lost");
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
            self.device.reset(x_m, render);
            self.sim_selected = true;
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
            let flows = self.phase == Phase::Running && self.device.connected();
            let next = match front {
                Pending::Input(Input::Abort { .. }) => self.pending.pop_front(),
                Pending::Input(Input::Recorded) if self.catching_up => None,
                _ if flows => self.pending.pop_front(),
                _ => None,
            };
            match next {
                None => return Ok(()),
                Some(Pending::Input(input)) => {
                    if self.lsl.is_some() {
                        self.lsl_input(&input);
                    }
                    self.engine.handle(self.t, input);
                }
                Some(Pending::Timeout) => {
                    self.timeout_queued = false;
                    self.engine.handle_timeout(self.t);
                }
            }
            if self.lsl.is_some() {
                self.lsl_after_engine();
            }
            self.due = self.engine.poll_timeout();
        }
    }

    fn act(&mut self, action: &Action) -> Result<(), ResultsError> {
        self.view.follow(action);
        if self.lsl.is_some() && !matches!(action, Action::Render(_)) {
            self.lsl_action(action, None);
        }
        match action {
            Action::Render(model) => {
                let render = self.render(model.as_ref());
                if self.lsl.is_some() {
                    self.lsl_action(action, Some(render));
                }
            }
            Action::Physical(model) => self.device.set_physical(model.as_ref()),
            Action::Record(record) => {
                let mut record = record.clone();
                record.rendering = self.renders.take();
                self.lsl_record(&mut record);
                self.log.write_record(&record)?;
                self.lsl_written();
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
                let (completed, aborted) = (outcome.completed, outcome.aborted);
                self.lsl_event("session_end", |m| {
                    m.insert("completed".into(), completed.into());
                    m.insert("aborted".into(), aborted.into());
                });
                self.lsl_close()?;
                self.log.write_end()?;
                self.phase = Phase::Finished;
                return Ok(());
            }
            Action::Show(_) | Action::Ask(_) | Action::Refused(_) | Action::Prompt(_) => {}
        }
        let reaction = self
            .responder
            .on_action(self.t, action, self.engine.trial());
        self.apply(reaction);
        Ok(())
    }

    /// Stops the haptic loop, putting its statistics in the log (a session
    /// whose device never answered has no log to hold them).
    ///
    /// # Errors
    /// I/O on the log.
    pub fn stop_device(&mut self) -> Result<(), ResultsError> {
        if let Some(stats) = self.device.stop()
            && let Some(open) = self.log.opened()
        {
            open.log.append(&LogLine::Loop(stats))?;
        }
        Ok(())
    }

    /// Sends an input from the participant or experimenter (an answer,
    /// Continue, a stimulus switch) and carries out what follows. Ignored
    /// unless running.
    ///
    /// # Errors
    /// I/O on the log or CSV.
    pub fn input(&mut self, input: Input) -> Result<(), ResultsError> {
        if self.phase != Phase::Running {
            return Ok(());
        }
        self.queue(input);
        self.settle()
    }

    /// A Fitts click (mouse, space bar) at the device's current position.
    ///
    /// # Errors
    /// I/O on the log or CSV.
    pub fn click(&mut self) -> Result<(), ResultsError> {
        let x_m = self.sample.x_m;
        self.input(Input::Click { x_m })
    }

    /// Pauses: a trial being presented is aborted and presented again on
    /// resume; nothing is rendered while paused.
    ///
    /// # Errors
    /// I/O on the log or CSV.
    pub fn pause(&mut self) -> Result<(), ResultsError> {
        if self.phase != Phase::Running {
            return Ok(());
        }
        self.phase = Phase::Paused;
        self.lsl_event("pause", |_| {});
        self.interrupt("paused by the experimenter")
    }

    /// Resumes after [`Session::pause`].
    ///
    /// # Errors
    /// I/O on the log or CSV.
    pub fn resume(&mut self) -> Result<(), ResultsError> {
        if self.phase != Phase::Paused {
            return Ok(());
        }
        self.phase = Phase::Running;
        self.lsl_event("resume", |_| {});
        self.settle()
    }

    /// Aborts the session: a trial being presented is logged as aborted
    /// (and re-queued), the device stops, and the log stays open-ended so
    /// the session can be resumed.
    ///
    /// # Errors
    /// I/O on the log or CSV.
    pub fn abort(&mut self) -> Result<(), ResultsError> {
        self.stop_run("session aborted by the experimenter", None)
    }

    /// Ends the run on a signal (issue 31): a trial being presented is
    /// logged as aborted with the reason [`INTERRUPTED`] (and re-queued, so
    /// a resume presents it again), the device stops, and an `interrupted`
    /// line records the signal; the log stays open-ended for a resume.
    ///
    /// # Errors
    /// I/O on the log or CSV.
    pub fn interrupted(&mut self, signal: crate::interrupt::Signal) -> Result<(), ResultsError> {
        self.stop_run(
            INTERRUPTED,
            Some(LogLine::Interrupted {
                signal: signal.name().to_owned(),
            }),
        )
    }

    fn stop_run(&mut self, reason: &str, line: Option<LogLine>) -> Result<(), ResultsError> {
        if !matches!(self.phase, Phase::Running | Phase::Paused) {
            return Ok(());
        }
        // Hold the engine where it is: the aborted trial's `Recorded` is
        // not delivered, so no next trial starts.
        self.phase = Phase::Paused;
        self.interrupt(reason)?;
        self.stop_device()?;
        let signal = match &line {
            Some(LogLine::Interrupted { signal }) => Some(signal.clone()),
            _ => None,
        };
        self.lsl_event("session_stop", |m| {
            m.insert("reason".into(), reason.into());
            if let Some(signal) = signal {
                m.insert("signal".into(), signal.into());
            }
        });
        self.lsl_close()?;
        if let (Some(line), Some(open)) = (line, self.log.opened()) {
            open.log.append(&line)?;
        }
        self.phase = Phase::Aborted;
        self.view = View::default();
        Ok(())
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
        self.device.render(render, model);
        self.sim_selected = self.device.is_sim();
        if let Some(how) = self.device.sim_how() {
            self.row_render.1 = how;
        }
        render
    }

    /// Appends the experimenter's note to the session log (held until the
    /// log opens).
    ///
    /// # Errors
    /// I/O on the log.
    pub fn note(&mut self, text: &str) -> Result<(), ResultsError> {
        self.lsl_event("note", |m| {
            m.insert("text".into(), text.into());
        });
        match &mut self.log {
            Log::Open(open) => open.log.append(&LogLine::Note {
                text: text.to_owned(),
            }),
            Log::Planned { notes, .. } => {
                notes.push(text.to_owned());
                Ok(())
            }
            // A session in memory is a simulated one: no experimenter.
            Log::Memory(_) => Ok(()),
        }
    }
}
