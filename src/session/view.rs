//! What a session shows: the participant's screen as the engine's actions
//! left it, the session's state, progress, and the live trace of the device.

use std::collections::VecDeque;

use std::path::Path;

use super::device::count_f64;
use super::{DeviceStatus, Log, Responder, Session, SessionOutcome};
use crate::device::DeviceSample;
use crate::kinds::{Action, Engine, ReadLog};
use crate::protocol::engine::{OwnScreen, Question, Screen};

/// Interval of the live trace, s (200 Hz).
pub const TRACE_EVERY_S: f64 = 0.005;
/// Length of the live trace kept, s.
pub const TRACE_LENGTH_S: f64 = 10.0;

/// What the participant's screen shows now, from the engine's actions.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct View {
    /// The last screen shown (a kind's own screen's task).
    pub screen: Option<Screen>,
    /// The kind's own screen, when the last screen shown is one: the
    /// window draws it with the kind's code.
    pub own: Option<OwnScreen>,
    /// The question open, if any.
    pub question: Option<Question>,
    /// Why the last answer was refused (cleared by the next screen).
    pub refused: Option<String>,
    /// An instruction for the experimenter awaiting Continue.
    pub prompt: Option<String>,
}

impl View {
    /// Follows an action of the engine.
    pub(super) fn follow(&mut self, action: &Action) {
        match action {
            Action::ShowOwn(own) => {
                self.follow(&Action::Show(own.task()));
                self.own = Some(own.clone());
            }
            Action::Show(screen) => {
                self.own = None;
                self.screen = Some(screen.clone());
                self.refused = None;
                self.prompt = None;
                if !matches!(screen, Screen::Explore { .. } | Screen::Paired { .. }) {
                    self.question = None;
                }
            }
            Action::Ask(q) => self.question = Some(*q),
            Action::Refused(why) => self.refused = Some(why.clone()),
            Action::Prompt(text) => {
                self.prompt = Some(text.clone());
                self.question = None;
            }
            Action::Record(_) => {
                self.question = None;
                self.refused = None;
            }
            Action::Finished => *self = View::default(),
            Action::Render(_) | Action::Physical(_) => {}
        }
    }
}

/// Where the session stands.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SessionState {
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
    /// Trials planned.
    pub total: usize,
    /// Block of the current trial.
    pub block: String,
    /// Session time, s.
    pub elapsed_s: f64,
    /// Estimate from this run's pace (None before a trial has ended), s.
    pub remaining_s: Option<f64>,
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
pub(super) struct Trace {
    pub(super) points: VecDeque<TracePoint>,
    peak_vibration: f64,
}

impl Trace {
    pub(super) fn observe(&mut self, t: f64, sample: &DeviceSample) {
        self.peak_vibration = self.peak_vibration.max(sample.vibration.abs());
        if self
            .points
            .back()
            .is_some_and(|last| t - last.t_s < TRACE_EVERY_S - 1e-9)
        {
            return;
        }
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

/// What a session shows and reports.
impl<R: Responder> Session<R> {
    /// What the participant's screen shows.
    #[must_use]
    pub fn view(&self) -> &View {
        &self.view
    }

    /// Where the session stands.
    #[must_use]
    pub fn state(&self) -> SessionState {
        self.state
    }

    /// Whether the log is open (on a port: the device has answered); a
    /// session in memory always is.
    #[must_use]
    pub fn is_open(&self) -> bool {
        !matches!(self.log, Log::Unopened { .. })
    }

    /// While the session waits to start (or to go on after the device was
    /// set up again) on a device with more than one axis: how far off the
    /// track the hand is, m, if too far.
    #[must_use]
    pub fn off_track_m(&self) -> Option<f64> {
        self.off_track_m
    }

    /// While the session waits to start: what is wrong with the device's
    /// answers, if anything.
    #[must_use]
    pub fn device_problem(&self) -> Option<&'static str> {
        self.device_problem
    }

    /// How long the device has not answered, s (None while it answers).
    #[must_use]
    pub fn lost_for_s(&self) -> Option<f64> {
        self.lost_since.map(|since| (self.t - since).secs())
    }

    /// Records written by this run, and the planned index of the last.
    #[must_use]
    pub fn records(&self) -> (usize, Option<usize>) {
        (self.records, self.last_record)
    }

    /// Trials completed in the whole session so far.
    #[must_use]
    pub fn completed(&self) -> usize {
        self.log.read().map_or(0, ReadLog::completed)
    }

    /// Session number.
    #[must_use]
    pub fn session(&self) -> u32 {
        self.log.header().session
    }

    /// The plan seed (logged in the header).
    #[must_use]
    pub fn plan_seed(&self) -> u64 {
        self.log.header().plan_seed
    }

    /// The participant id.
    #[must_use]
    pub fn participant(&self) -> &str {
        &self.log.header().participant
    }

    /// The data CSV (empty for a session in memory).
    #[must_use]
    pub fn csv(&self) -> &Path {
        match &self.log {
            Log::Open(open) => &open.csv,
            Log::Unopened { planned, .. } => &planned.files().csv,
            Log::Memory(_) => Path::new(""),
        }
    }

    /// The session log (empty for a session in memory).
    #[must_use]
    pub fn log_path(&self) -> &Path {
        match &self.log {
            Log::Open(open) => open.log.path(),
            Log::Unopened { planned, .. } => &planned.files().log,
            Log::Memory(_) => Path::new(""),
        }
    }

    /// Session time, s.
    #[must_use]
    pub fn now_s(&self) -> f64 {
        self.t.secs()
    }

    /// Session time, whole nanoseconds.
    #[must_use]
    pub fn now(&self) -> crate::time::Time {
        self.t
    }

    /// The latest device sample.
    #[must_use]
    pub fn sample(&self) -> DeviceSample {
        self.sample
    }

    /// The last [`TRACE_LENGTH_S`] of position and force (empty without
    /// [`Session::with_trace`]).
    #[must_use]
    pub fn trace(&self) -> &VecDeque<TracePoint> {
        static EMPTY: VecDeque<TracePoint> = VecDeque::new();
        self.trace.as_ref().map_or(&EMPTY, |t| &t.points)
    }

    /// The engine (plan, current trial).
    #[must_use]
    pub fn engine(&self) -> &Engine {
        &self.engine
    }

    /// Progress.
    #[must_use]
    pub fn progress(&self) -> Progress {
        let index = self.engine.trial_index();
        let total = self.engine.planned_trials().unwrap_or(index);
        let left = total.saturating_sub(index);
        let remaining_s = (self.done_this_run > 0).then(|| {
            (self.t - self.start_t).secs() / count_f64(self.done_this_run) * count_f64(left)
        });
        Progress {
            trial: (index + 1).min(total),
            total,
            block: self
                .engine
                .trial()
                .map(|t| t.block.clone())
                .unwrap_or_default(),
            elapsed_s: self.t.secs(),
            remaining_s: if self.state == SessionState::Finished {
                Some(0.0)
            } else {
                remaining_s
            },
        }
    }

    /// The device's live state.
    #[must_use]
    pub fn device_status(&self) -> DeviceStatus {
        let (connected, rate_hz, period_p99_s) = self.device.status();
        DeviceStatus {
            device: self.device_label.clone(),
            connected,
            rate_hz,
            period_p99_s,
            force_n: self.sample.force_n,
            x_m: self.sample.x_m,
        }
    }

    /// How the run went so far.
    #[must_use]
    pub fn outcome(&self) -> SessionOutcome {
        let completed = self.completed();
        let aborted = self.log.read().map_or(0, |r| r.trials.len() - completed);
        let torn_bytes = match &self.log {
            Log::Open(open) => open.torn_bytes,
            Log::Unopened { .. } | Log::Memory(_) => 0,
        };
        SessionOutcome {
            session: self.session(),
            completed,
            aborted,
            resumed_at: self.resumed_at,
            torn_bytes,
            simulated_s: (self.t - self.start_t).secs(),
            csv: self.csv().to_owned(),
            log: self.log_path().to_owned(),
            participant: self.participant().to_owned(),
            interrupted: None,
        }
    }
}
