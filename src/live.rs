//! A session run live by a person: the shell the GUI drives.
//!
//! [`LiveSession`] connects the engine to the device (the simulated device,
//! stepped in session time, or the haptic loop on a serial port) and to the
//! results folder. The GUI only calls it: each frame it passes the frame's
//! time to [`LiveSession::advance`], forwards the participant's answers and
//! clicks, and draws [`LiveSession::view`], [`LiveSession::progress`],
//! [`LiveSession::device_status`] and [`LiveSession::trace`]. It never opens a
//! port or writes a file itself; this module does, with the same rules as the
//! headless runner: each trial record is appended to the log and fsync'd,
//! and the CSV rewritten, before the engine hears `Recorded`.
//!
//! # Time
//! Session time `t` (s) starts at 0 for a new session and at the last
//! trial's end when resuming. With the simulated device it advances by the
//! frame's wall-clock step (at most [`MAX_FRAME_STEP_S`] per frame, so a
//! stalled window does not make the physics leap) and stops while paused.
//! With a device it follows the haptic loop's clock.
//!
//! # Pause and abort
//! Pausing while a trial is presented aborts that trial with `requeue`
//! (logged as aborted, "paused by the experimenter"), so it is presented
//! again in full on resume; the device renders nothing while paused.
//! Aborting the session does the same, then closes the log without an `end`
//! line, so the session can be resumed later (GUI or `run --resume`).

use std::collections::VecDeque;
use std::path::PathBuf;

use crate::device::DeviceSample;
use crate::device::haptic::{HapticLoop, ToLoop};
use crate::device::link::LinkState;
use crate::device::sim::{Apparatus, SimDevice};
use crate::device::wire::Message;
use crate::friction::ForceLimit;
use crate::protocol::engine::{Action, Engine, Input, Question, Screen};
use crate::results::{Header, LogLine, ReadLog, ResultsDir, ResultsError, SessionLog};
use crate::runner::{
    HAND_EVERY_S, Planned, Prepared, SessionRequest, StreamRecorder, loop_rate_hz, plan_session,
    write_end, write_record,
};

/// The hand a mouse drives on the simulated device: a spring-damper pulling
/// the device towards the pointer; with the pointer away, the hand only
/// damps. The mass is the STUDIES 1a hand's (1 kg). Its 300 N/m would leave
/// the device stuck 23 mm short of the pointer under the Fitts
/// `high_stiction` condition (7 N), farther than the 32 mm workspace allows,
/// so the mouse hand is stiffer: 2000 N/m breaks 7 N of stiction 3.5 mm
/// from the pointer, and 80 N s/m damps the 1.7 kg of hand and slide at
/// about 0.7 of critical.
pub const MOUSE_HAND_MASS_KG: f64 = 1.0;
/// See [`MOUSE_HAND_MASS_KG`]. N/m.
pub const MOUSE_HAND_STIFFNESS_N_M: f64 = 2000.0;
/// See [`MOUSE_HAND_MASS_KG`]. N s/m.
pub const MOUSE_HAND_DAMPING_N_S_M: f64 = 80.0;
/// Longest session-time step one frame may take with the simulated device, s.
pub const MAX_FRAME_STEP_S: f64 = 0.5;
/// Interval of the live trace, s (200 Hz).
pub const TRACE_EVERY_S: f64 = 0.005;
/// Length of the live trace kept, s.
pub const TRACE_LENGTH_S: f64 = 10.0;
/// Loop periods kept for the live p99, ticks.
const PERIODS_KEPT: usize = 5000;

/// Where the session renders friction.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum DeviceChoice {
    /// The simulated device, its hand driven by the mouse.
    Simulated,
    /// A haptic device on this serial port (or the emulator's pty).
    Port(PathBuf),
}

impl DeviceChoice {
    /// As logged: `sim` or the port's path.
    #[must_use]
    pub fn label(&self) -> String {
        match self {
            DeviceChoice::Simulated => "sim".into(),
            DeviceChoice::Port(p) => p.display().to_string(),
        }
    }
}

/// What the participant's screen shows now, from the engine's actions.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct View {
    /// The last screen shown.
    pub screen: Option<Screen>,
    /// The question open, if any.
    pub question: Option<Question>,
    /// Why the last answer was refused (cleared by the next screen).
    pub refused: Option<String>,
    /// An instruction for the experimenter awaiting Continue.
    pub prompt: Option<String>,
}

/// Where the session stands.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Phase {
    /// Running.
    Running,
    /// Paused by the experimenter.
    Paused,
    /// Every planned trial is done; the log has its `end` line.
    Finished,
    /// Aborted by the experimenter; the session can be resumed.
    Aborted,
}

/// Progress, for the experimenter.
#[derive(Debug, Clone, PartialEq)]
pub struct Progress {
    /// Current (or next) trial, 1-based, at most `total`.
    pub trial: usize,
    /// Planned trials.
    pub total: usize,
    /// Block of the current trial.
    pub block: String,
    /// Session time, s.
    pub elapsed_s: f64,
    /// Estimate from this run's pace (None before a trial has ended), s.
    pub remaining_s: Option<f64>,
}

/// The device's live state, for the experimenter.
#[derive(Debug, Clone, PartialEq)]
pub struct DeviceStatus {
    /// `sim` or the port's path.
    pub device: String,
    /// Whether frames arrive (always true for the simulated device).
    pub connected: bool,
    /// Loop rate, Hz.
    pub rate_hz: f64,
    /// 99th percentile of the measured loop period over the last ticks, s
    /// (None for the simulated device, which steps in session time).
    pub period_p99_s: Option<f64>,
    /// Rendered force, N.
    pub force_n: f64,
    /// Device position, m.
    pub x_m: f64,
}

/// One point of the live trace.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TracePoint {
    /// Session time, s.
    pub t_s: f64,
    /// Device position, m.
    pub x_m: f64,
    /// Rendered force, N.
    pub force_n: f64,
    /// Peak |vibrotactile drive| since the previous point, `[0, 1]`: the
    /// burst's envelope (its 600 Hz carrier would alias at the trace's
    /// 200 Hz).
    pub vibration: f64,
}

/// The live trace: one point per [`TRACE_EVERY_S`], the last
/// [`TRACE_LENGTH_S`] kept.
#[derive(Debug, Clone, Default)]
struct Trace {
    points: VecDeque<TracePoint>,
    last_t: Option<f64>,
    peak_vibration: f64,
}

impl Trace {
    fn observe(&mut self, t: f64, sample: &DeviceSample) {
        self.peak_vibration = self.peak_vibration.max(sample.vibration.abs());
        if self
            .last_t
            .is_some_and(|last| t - last < TRACE_EVERY_S - 1e-9)
        {
            return;
        }
        self.last_t = Some(t);
        while self
            .points
            .front()
            .is_some_and(|p| t - p.t_s > TRACE_LENGTH_S)
        {
            self.points.pop_front();
        }
        self.points.push_back(TracePoint {
            t_s: t,
            x_m: sample.x_m,
            force_n: sample.force_n,
            vibration: self.peak_vibration,
        });
        self.peak_vibration = 0.0;
    }
}

/// Why a live session could not start.
#[derive(Debug, thiserror::Error)]
pub enum LiveError {
    /// Bad input or I/O on the results folder.
    #[error(transparent)]
    Results(#[from] ResultsError),
    /// The haptic loop could not start.
    #[error("cannot start the haptic loop: {0}")]
    Loop(std::io::Error),
}

enum Device {
    Sim {
        device: Box<SimDevice>,
        dt: f64,
    },
    Haptic {
        haptic: HapticLoop,
        rate_hz: f64,
        offset_s: f64,
        periods: VecDeque<f64>,
        last_tick_s: Option<f64>,
        link: LinkState,
        button: bool,
        last_hand_s: f64,
    },
    /// The haptic loop has stopped (session finished or aborted).
    Stopped {
        rate_hz: f64,
    },
}

/// The session's files. On the simulated device they are opened at start;
/// on a serial port only once the device has answered, so a device that
/// never answers leaves no session behind.
enum Files {
    /// Planned, nothing written yet; notes wait for the log.
    Planned {
        planned: Box<Planned>,
        dir: ResultsDir,
        notes: Vec<String>,
    },
    Open(Box<OpenFiles>),
}

struct OpenFiles {
    log: SessionLog,
    read: ReadLog,
    csv: PathBuf,
    streams: StreamRecorder,
}

impl Files {
    /// Opens planned files, writing the notes that waited; open files stay.
    fn open(&mut self) -> Result<&mut OpenFiles, ResultsError> {
        if let Files::Planned {
            planned,
            dir,
            notes,
        } = self
        {
            let Prepared {
                mut log,
                read,
                csv,
                streams,
                ..
            } = planned.open(dir)?;
            for text in notes.drain(..) {
                log.append(&LogLine::Note { text })?;
            }
            *self = Files::Open(Box::new(OpenFiles {
                log,
                read,
                csv,
                streams,
            }));
        }
        Ok(match self {
            Files::Open(open) => open,
            Files::Planned { .. } => {
                return Err(ResultsError::input(
                    "session",
                    "the session's files are not open",
                ));
            }
        })
    }

    /// The open files, if they are.
    fn opened(&mut self) -> Option<&mut OpenFiles> {
        match self {
            Files::Open(open) => Some(open),
            Files::Planned { .. } => None,
        }
    }
}

/// A session run by a person from the GUI.
pub struct LiveSession {
    engine: Engine,
    files: Files,
    device: Device,
    device_label: String,
    sample: DeviceSample,
    t: f64,
    run_start_t: f64,
    done_this_run: usize,
    wall: Option<f64>,
    pending: VecDeque<Input>,
    timers: Vec<f64>,
    phase: Phase,
    view: View,
    trace: Trace,
    hand_target: Option<f64>,
}

impl LiveSession {
    /// Starts (or resumes) a session: opens the log (as the headless runner
    /// does) and the device. The responder is logged as `gui`.
    ///
    /// # Errors
    /// Bad input (resume without an unfinished session), I/O, or a device
    /// loop that cannot start.
    pub fn start(
        dir: &ResultsDir,
        req: &SessionRequest<'_>,
        device: &DeviceChoice,
    ) -> Result<Self, LiveError> {
        let planned = plan_session(dir, req, "gui")?;
        let (plan, start_at, start_time) = (
            planned.plan.clone(),
            planned.start_at(),
            planned.start_time(),
        );
        let mut files = Files::Planned {
            planned: Box::new(planned),
            dir: dir.clone(),
            notes: Vec::new(),
        };
        let device = match device {
            DeviceChoice::Simulated => {
                files.open()?;
                Device::Sim {
                    device: Box::new(SimDevice::new(Apparatus::default(), MOUSE_HAND_MASS_KG)),
                    dt: 1e-3,
                }
            }
            DeviceChoice::Port(path) => {
                let rate_hz = loop_rate_hz(&plan);
                let haptic = HapticLoop::start(path.clone(), rate_hz, true, ForceLimit::default())
                    .map_err(LiveError::Loop)?;
                Device::Haptic {
                    haptic,
                    rate_hz,
                    offset_s: start_time,
                    periods: VecDeque::with_capacity(PERIODS_KEPT),
                    last_tick_s: None,
                    link: LinkState::Connecting,
                    button: false,
                    last_hand_s: f64::NEG_INFINITY,
                }
            }
        };
        Ok(LiveSession {
            engine: Engine::new(plan, start_at),
            files,
            device,
            device_label: req.device.to_owned(),
            sample: DeviceSample::default(),
            t: start_time,
            run_start_t: start_time,
            done_this_run: 0,
            wall: None,
            pending: VecDeque::from([Input::Start]),
            timers: Vec::new(),
            phase: Phase::Running,
            view: View::default(),
            trace: Trace::default(),
            hand_target: None,
        })
    }

    /// Advances the session to the frame at wall-clock time `wall_s` (any
    /// monotonic clock, s): steps the device, fires due timers, and carries
    /// out the engine's actions (writing records).
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
        match self.device {
            Device::Haptic { .. } => self.drain_ticks(),
            Device::Sim { .. } if self.phase == Phase::Running => self.step_sim(step)?,
            Device::Sim { .. } | Device::Stopped { .. } => {}
        }
        self.pump()
    }

    fn step_sim(&mut self, step: f64) -> Result<(), ResultsError> {
        let end = self.t + step;
        loop {
            let Device::Sim { device, dt } = &mut self.device else {
                return Ok(());
            };
            if self.t + *dt > end + 1e-12 {
                return Ok(());
            }
            let hand = self
                .hand_target
                .map_or(0.0, |x| MOUSE_HAND_STIFFNESS_N_M * (x - self.sample.x_m))
                - MOUSE_HAND_DAMPING_N_S_M * self.sample.v_m_s;
            self.sample = device.step(*dt, hand);
            self.t += *dt;
            if self.engine.in_trial()
                && let Some(files) = self.files.opened()
            {
                files.streams.push(self.t, &self.sample);
            }
            self.trace.observe(self.t, &self.sample);
            if self.timers.iter().any(|&w| w <= self.t) {
                self.timers.retain(|&w| w > self.t);
                self.pending.push_back(Input::Timer);
                // Timers change what is rendered: act before the next tick.
                self.pump()?;
            }
        }
    }

    fn drain_ticks(&mut self) {
        let Device::Haptic {
            haptic,
            offset_s,
            periods,
            last_tick_s,
            link,
            button,
            last_hand_s,
            ..
        } = &mut self.device
        else {
            return;
        };
        let mut clicks = Vec::new();
        let mut lost = false;
        while let Some(tick) = haptic.recv() {
            self.t = *offset_s + tick.now_s;
            if let Some(last) = last_tick_s.replace(tick.now_s) {
                if periods.len() == PERIODS_KEPT {
                    periods.pop_front();
                }
                periods.push_back(tick.now_s - last);
            }
            *link = tick.link;
            if tick.link != LinkState::Connected {
                lost = true;
                continue;
            }
            self.sample = DeviceSample {
                x_m: tick.x_m,
                v_m_s: tick.v_m_s,
                force_n: tick.force_n,
                vibration: tick.vibration,
            };
            if self.engine.in_trial()
                && let Some(files) = self.files.opened()
            {
                files.streams.push(self.t, &self.sample);
            }
            if tick.button && !*button {
                clicks.push(tick.x_m);
            }
            *button = tick.button;
            if let Some(x) = self.hand_target
                && self.t - *last_hand_s >= HAND_EVERY_S
            {
                *last_hand_s = self.t;
                // Only the emulator has a hand to drive; real firmware
                // ignores this message.
                haptic.send(ToLoop::Device(mouse_hand_drive(x)));
            }
            self.trace.observe(self.t, &self.sample);
        }
        if lost && self.engine.in_trial() {
            self.pending.push_front(Input::Abort {
                reason: "device lost".into(),
                requeue: true,
            });
        }
        if self.phase == Phase::Running {
            self.pending
                .extend(clicks.into_iter().map(|x_m| Input::Click { x_m }));
        }
        if self.timers.iter().any(|&w| w <= self.t) {
            self.timers.retain(|&w| w > self.t);
            self.pending.push_back(Input::Timer);
        }
    }

    /// Feeds pending inputs to the engine and carries out its actions.
    fn pump(&mut self) -> Result<(), ResultsError> {
        loop {
            while let Some(action) = self.engine.poll() {
                self.act(action)?;
            }
            let connected = match &self.device {
                Device::Sim { .. } => true,
                Device::Haptic { link, .. } => *link == LinkState::Connected,
                Device::Stopped { .. } => false,
            };
            if connected {
                // The session starts (its files are written) once the
                // device answers.
                self.files.open()?;
            }
            let next = match self.pending.front() {
                // An abort goes through even while paused or lost.
                Some(Input::Abort { .. }) => self.pending.pop_front(),
                Some(_) if self.phase == Phase::Running && connected => self.pending.pop_front(),
                _ => None,
            };
            let Some(input) = next else {
                return Ok(());
            };
            self.engine.handle(self.t, input);
        }
    }

    fn act(&mut self, action: Action) -> Result<(), ResultsError> {
        match action {
            Action::Render(model) => match &mut self.device {
                Device::Sim { device, dt } => {
                    device.set_model(model.as_ref());
                    if let Some(m) = &model {
                        *dt = 1.0 / m.loop_rate_hz();
                    }
                }
                Device::Haptic { haptic, .. } => haptic.send(ToLoop::Model(model)),
                Device::Stopped { .. } => {}
            },
            Action::Physical(model) => {
                if let Device::Sim { device, .. } = &mut self.device {
                    device.set_physical(model.as_ref());
                }
            }
            Action::Show(screen) => {
                self.view.screen = Some(screen);
                self.view.refused = None;
                self.view.prompt = None;
                if !matches!(
                    self.view.screen,
                    Some(Screen::Explore { .. } | Screen::Paired { .. })
                ) {
                    self.view.question = None;
                }
            }
            Action::Ask(q) => self.view.question = Some(q),
            Action::Refused(why) => self.view.refused = Some(why),
            Action::Prompt(text) => {
                self.view.prompt = Some(text);
                self.view.question = None;
            }
            Action::Record(record) => {
                let files = self.files.open()?;
                write_record(
                    &mut files.log,
                    &mut files.read,
                    &files.csv,
                    &mut files.streams,
                    &record,
                )?;
                self.view.question = None;
                self.view.refused = None;
                if !record.requeued {
                    self.done_this_run += 1;
                }
                self.pending.push_front(Input::Recorded);
            }
            Action::WakeAt(at) => self.timers.push(at),
            Action::Finished => {
                self.stop_device()?;
                let files = self.files.open()?;
                write_end(&mut files.log, &files.read)?;
                self.phase = Phase::Finished;
                self.view = View::default();
            }
        }
        Ok(())
    }

    fn stop_device(&mut self) -> Result<(), ResultsError> {
        let Device::Haptic { rate_hz, .. } = self.device else {
            return Ok(());
        };
        if let Device::Haptic { haptic, .. } =
            std::mem::replace(&mut self.device, Device::Stopped { rate_hz })
        {
            let stats = haptic.stop();
            // A session whose device never answered has no log to hold them.
            if let Some(files) = self.files.opened() {
                files.log.append(&LogLine::Loop(stats))?;
            }
        }
        Ok(())
    }

    /// Sends an input from the participant or experimenter (an answer,
    /// Continue, a stimulus switch) and carries out what follows.
    ///
    /// # Errors
    /// I/O on the log or CSV.
    pub fn input(&mut self, input: Input) -> Result<(), ResultsError> {
        if self.phase != Phase::Running {
            return Ok(());
        }
        self.pending.push_back(input);
        self.pump()
    }

    /// A Fitts click (mouse, space bar) at the device's current position.
    ///
    /// # Errors
    /// I/O on the log or CSV.
    pub fn click(&mut self) -> Result<(), ResultsError> {
        let x_m = self.sample.x_m;
        self.input(Input::Click { x_m })
    }

    /// Where the mouse holds the hand, m (`None`: the pointer is away).
    pub fn set_hand_target(&mut self, x_m: Option<f64>) {
        self.hand_target = x_m.filter(|x| x.is_finite());
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
        self.interrupt("paused by the experimenter")
    }

    /// Resumes after [`LiveSession::pause`].
    ///
    /// # Errors
    /// I/O on the log or CSV.
    pub fn resume(&mut self) -> Result<(), ResultsError> {
        if self.phase != Phase::Paused {
            return Ok(());
        }
        self.phase = Phase::Running;
        self.pump()
    }

    /// Aborts the session: a trial being presented is logged as aborted
    /// (and re-queued), the device stops, and the log stays open-ended so
    /// the session can be resumed.
    ///
    /// # Errors
    /// I/O on the log or CSV.
    pub fn abort(&mut self) -> Result<(), ResultsError> {
        if !matches!(self.phase, Phase::Running | Phase::Paused) {
            return Ok(());
        }
        // Hold the engine where it is: the aborted trial's `Recorded` is
        // not delivered, so no next trial starts.
        self.phase = Phase::Paused;
        self.interrupt("session aborted by the experimenter")?;
        self.stop_device()?;
        self.phase = Phase::Aborted;
        self.view = View::default();
        Ok(())
    }

    fn interrupt(&mut self, reason: &str) -> Result<(), ResultsError> {
        if self.engine.in_trial() {
            self.pending.push_front(Input::Abort {
                reason: reason.into(),
                requeue: true,
            });
            self.pump()?;
        }
        self.act(Action::Render(None))
    }

    /// Appends the experimenter's note to the session log.
    ///
    /// # Errors
    /// I/O on the log.
    pub fn note(&mut self, text: &str) -> Result<(), ResultsError> {
        match &mut self.files {
            Files::Open(files) => files.log.append(&LogLine::Note {
                text: text.to_owned(),
            }),
            Files::Planned { notes, .. } => {
                notes.push(text.to_owned());
                Ok(())
            }
        }
    }

    /// What the participant's screen shows.
    #[must_use]
    pub fn view(&self) -> &View {
        &self.view
    }

    /// Where the session stands.
    #[must_use]
    pub fn phase(&self) -> Phase {
        self.phase
    }

    /// Session number.
    #[must_use]
    pub fn session(&self) -> u32 {
        self.header().session
    }

    fn header(&self) -> &Header {
        match &self.files {
            Files::Open(files) => &files.read.header,
            Files::Planned { planned, .. } => planned.header(),
        }
    }

    /// The plan seed (logged in the header).
    #[must_use]
    pub fn plan_seed(&self) -> u64 {
        self.header().plan_seed
    }

    /// The participant id.
    #[must_use]
    pub fn participant(&self) -> &str {
        &self.header().participant
    }

    /// The data CSV.
    #[must_use]
    pub fn csv(&self) -> &std::path::Path {
        match &self.files {
            Files::Open(files) => &files.csv,
            Files::Planned { planned, .. } => &planned.files().csv,
        }
    }

    /// The session log.
    #[must_use]
    pub fn log_path(&self) -> &std::path::Path {
        match &self.files {
            Files::Open(files) => files.log.path(),
            Files::Planned { planned, .. } => &planned.files().log,
        }
    }

    /// Session time, s.
    #[must_use]
    pub fn now_s(&self) -> f64 {
        self.t
    }

    /// The latest device sample.
    #[must_use]
    pub fn sample(&self) -> DeviceSample {
        self.sample
    }

    /// The last [`TRACE_LENGTH_S`] of position and force.
    #[must_use]
    pub fn trace(&self) -> &VecDeque<TracePoint> {
        &self.trace.points
    }

    /// The engine (plan, current trial).
    #[must_use]
    pub fn engine(&self) -> &Engine {
        &self.engine
    }

    /// Progress.
    #[must_use]
    pub fn progress(&self) -> Progress {
        let total = self.engine.plan().trials.len();
        let index = self.engine.trial_index();
        let left = total.saturating_sub(index);
        let remaining_s = (self.done_this_run > 0)
            .then(|| (self.t - self.run_start_t) / count_f64(self.done_this_run) * count_f64(left));
        Progress {
            trial: (index + 1).min(total),
            total,
            block: self
                .engine
                .trial()
                .map(|t| t.block.clone())
                .unwrap_or_default(),
            elapsed_s: self.t,
            remaining_s: if self.phase == Phase::Finished {
                Some(0.0)
            } else {
                remaining_s
            },
        }
    }

    /// The device's live state.
    #[must_use]
    pub fn device_status(&self) -> DeviceStatus {
        let (connected, rate_hz, period_p99_s) = match &self.device {
            Device::Sim { dt, .. } => (true, 1.0 / dt, None),
            Device::Stopped { rate_hz } => (false, *rate_hz, None),
            Device::Haptic {
                rate_hz,
                periods,
                link,
                ..
            } => (
                *link == LinkState::Connected,
                *rate_hz,
                percentile(periods, 0.99),
            ),
        };
        DeviceStatus {
            device: self.device_label.clone(),
            connected,
            rate_hz,
            period_p99_s,
            force_n: self.sample.force_n,
            x_m: self.sample.x_m,
        }
    }
}

/// The emulator's hand held at the pointer: the mouse hand's spring-damper.
#[expect(clippy::cast_possible_truncation, reason = "f32 is the wire's type")]
fn mouse_hand_drive(x_m: f64) -> Message {
    Message::HandDrive {
        x_m: x_m as f32,
        v_m_s: 0.0,
        stiffness_n_m: MOUSE_HAND_STIFFNESS_N_M as f32,
        damping_n_s_m: MOUSE_HAND_DAMPING_N_S_M as f32,
        integral: 0.0,
        click: false,
    }
}

/// `q`-quantile (nearest rank) of `values`, None if empty.
#[must_use]
pub fn percentile<'a>(values: impl IntoIterator<Item = &'a f64>, q: f64) -> Option<f64> {
    let mut v: Vec<f64> = values.into_iter().copied().collect();
    if v.is_empty() {
        return None;
    }
    v.sort_by(f64::total_cmp);
    #[expect(
        clippy::cast_possible_truncation,
        clippy::cast_sign_loss,
        reason = "a rank within the slice"
    )]
    let rank = ((q * count_f64(v.len())).ceil() as usize).clamp(1, v.len());
    Some(v[rank - 1])
}

fn count_f64(n: usize) -> f64 {
    f64::from(u32::try_from(n).unwrap_or(u32::MAX))
}
