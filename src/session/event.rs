//! What a shell feeds a session ([`Feed`]) and what the session reports
//! back ([`Event`]): the session's one way in and one way out.

use crate::device::DeviceSample;
use crate::interrupt::Signal;
use crate::kinds::{Action, LogLine, LoggedTrial, PlannedTrial};
use crate::protocol::engine::Input;
use crate::time::Time;

use super::renders::How;

/// One thing a shell hands a session ([`super::Session::handle`]).
#[derive(Debug)]
pub enum Feed {
    /// One tick of the simulated device, in virtual time: the pending
    /// inputs settle, then the hand and device advance by the model's
    /// step. Nothing on a port.
    Tick,
    /// Read every tick the haptic loop has reported, then settle. Nothing
    /// more with the simulated device.
    Poll,
    /// The window's frame at wall-clock time `.0` (any monotonic clock,
    /// s): the simulated device steps by the frame's time (at most
    /// [`super::MAX_FRAME_STEP_S`]; not while paused) in whole ticks, the
    /// rest carried to the next frame; a port's ticks are read.
    Frame(f64),
    /// An input from the participant or experimenter (an answer,
    /// Continue, a stimulus switch). Ignored unless running.
    Input(Input),
    /// A Fitts click (mouse, space bar) at the device's current position.
    Click,
    /// Pause: a trial being presented is aborted and presented again on
    /// resume; nothing is rendered while paused.
    Pause,
    /// Pause for a fault outside the device (a sound output lost): as
    /// [`Feed::Pause`], the trial under way aborted with this reason.
    Hold(String),
    /// Resume after [`Feed::Pause`] or [`Feed::Hold`].
    Resume,
    /// Abort the session: a trial being presented is logged as aborted
    /// (and re-queued), the device stops, and the log stays open-ended so
    /// the session can be resumed.
    Abort,
    /// End the run on a signal: as [`Feed::Abort`], with the reason
    /// [`super::INTERRUPTED`] and an `interrupted` line naming the signal.
    Signal(Signal),
    /// The experimenter's note, for the log (held until the log opens).
    Note(String),
    /// Stop the haptic loop, its statistics in the log (a shell giving up
    /// on a device).
    StopDevice,
    /// The experimenter did what the device asked ([`Event::DeviceRequest`]):
    /// the device is told, and the log notes it. Nothing when no request
    /// stands.
    Confirm,
    /// A session that waits for its shell ([`super::Session::wait_for_shell`])
    /// may start: the shell has done what it does at [`Event::Ready`].
    Go,
    /// A session that waits for its shell and has ended its run
    /// ([`Event::Finished`], [`Event::Stopped`]): these lines go in the log
    /// before its last (`end`, or `interrupted`).
    Close(Vec<LogLine>),
}

/// Something that happened in a session, at session time `t`, in the
/// order it happened ([`super::Session::poll_event`]).
#[derive(Debug, Clone)]
pub enum Event {
    /// A session waiting for its shell, on a port: the device answers and
    /// the hand is on the track, stepping as `how`. It starts at
    /// [`Feed::Go`]; ticks until then are dropped.
    Ready {
        /// How the device steps.
        how: How,
    },
    /// The window's frame reaches session time `end` now: the simulated
    /// device's samples of the frame end there.
    Frame {
        /// Session time at the frame's end.
        end: Time,
    },
    /// An input about to reach the engine, in the trial under way if any.
    Input {
        /// Session time.
        t: Time,
        /// The trial under way.
        trial: Option<usize>,
        /// The input.
        input: Input,
    },
    /// A trial started.
    TrialStarted {
        /// Session time.
        t: Time,
        /// The trial.
        trial: Box<PlannedTrial>,
    },
    /// An action the session carried out (a record is [`Event::Written`],
    /// the end [`Event::Finished`]); a render with its number.
    Action {
        /// Session time.
        t: Time,
        /// The trial under way.
        trial: Option<usize>,
        /// The action.
        action: Box<Action>,
        /// The number a `Render` was given.
        render: Option<u32>,
    },
    /// A trial's record is on disk (or kept in memory), as written.
    Written {
        /// Session time.
        t: Time,
        /// The record.
        record: Box<LoggedTrial>,
    },
    /// The device stopped answering (after it had answered).
    DeviceLost {
        /// Session time.
        t: Time,
    },
    /// The device asks the experimenter for something before it can go on
    /// (its link is lost meanwhile); the shell puts it to the experimenter
    /// and answers [`Feed::Confirm`] once it is done. Once per request.
    DeviceRequest {
        /// Session time.
        t: Time,
        /// What it asks.
        request: crate::device::haptic::Request,
    },
    /// The device answers again.
    DeviceBack {
        /// Session time.
        t: Time,
    },
    /// The experimenter paused.
    Paused {
        /// Session time.
        t: Time,
    },
    /// The experimenter resumed.
    Resumed {
        /// Session time.
        t: Time,
    },
    /// The experimenter's note.
    Note {
        /// Session time.
        t: Time,
        /// Its text.
        text: String,
    },
    /// The session ran its last trial.
    Finished {
        /// Session time.
        t: Time,
        /// Trials completed.
        completed: usize,
        /// Trials aborted.
        aborted: usize,
    },
    /// The run stopped before the end (abort, signal).
    Stopped {
        /// Session time.
        t: Time,
        /// Why.
        reason: String,
        /// The signal, if one stopped it.
        signal: Option<String>,
    },
    /// A sample of the simulated device (only when asked for:
    /// [`super::Session::wait_for_shell`]); a port's loop offers its own.
    Sample {
        /// Session time.
        t: Time,
        /// The sample.
        sample: DeviceSample,
    },
}
