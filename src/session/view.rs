//! What a session shows: the participant's screen as the engine's actions
//! left it, the phase, progress, and the live trace of the device.

use std::collections::VecDeque;

use crate::device::DeviceSample;
use crate::protocol::engine::{Action, Question, Screen};

/// Interval of the live trace, s (200 Hz).
pub const TRACE_EVERY_S: f64 = 0.005;
/// Length of the live trace kept, s.
pub const TRACE_LENGTH_S: f64 = 10.0;

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

impl View {
    /// Follows an action of the engine.
    pub(super) fn follow(&mut self, action: &Action) {
        match action {
            Action::Show(screen) => {
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
    last_t: Option<f64>,
    peak_vibration: f64,
}

impl Trace {
    pub(super) fn observe(&mut self, t: f64, sample: &DeviceSample) {
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
