//! The session engine: a sans-IO state machine that presents a session's
//! trials, as its [`TrialSource`] gives them (a fixed [`Plan`], or an
//! adaptive source that chooses each trial from the answers so far).
//!
//! The session (`crate::session`) calls [`Engine::handle`] with the
//! current session time and an [`Input`], then drains [`Engine::poll`] for
//! [`Action`]s and carries them out: load a friction model, show or ask
//! something, write a trial record. The engine reads no clock, touches no
//! file or port, and draws no random numbers: the same inputs give the same
//! actions.
//!
//! # Kinds
//! What every kind shares (instructions, the reference phase, breaks,
//! experimenter prompts, aborts, the write rule) is here. A live trial of
//! each kind is its kind's [`super::kind::LiveTrial`] (its start, timer,
//! inputs and logged data), in the kind's folder under `src/kinds/`; the
//! engine reaches it through the set of kinds `K` ([`Kinds`]).
//!
//! # Timers
//! The engine owns its timers, as quinn-proto does: [`Engine::poll_timeout`]
//! says when it next wants to be woken (the end of a reference phase, a
//! break, an exploration, a Fitts test's time limit), derived from the stage
//! it is in, and the driver calls [`Engine::handle_timeout`] once its clock
//! has reached that time. A timeout that is no longer due does nothing.
//!
//! # Device samples
//! The engine needs only the moments that matter to the protocol: the shell
//! turns a button press (device button, mouse, space bar) into
//! [`Input::Click`] carrying the sampled cursor position. The continuous
//! sample stream stays in the shell (haptic loop, cursor display) and does
//! not pass through the engine.
//!
//! # The write rule
//! After [`Action::Record`] the engine waits for [`Input::Recorded`]: the
//! shell sends it once the record is on disk (flushed and synced), and only
//! then does the next trial start.
//!

use std::collections::VecDeque;
use std::sync::Arc;

use super::Protocol;
use super::kind::{Kinds, Next};
use super::plan::{Plan, PlannedTrial};
use crate::friction::ModelParams;
use crate::time::Time;

mod own;
mod record;
mod source;

pub use own::{KindScreen, OwnScreen};
pub use record::{Choice, Status, TrialRecord};
pub use source::{TrialSource, next_position};

/// A participant's answer.
#[derive(Debug, Clone, PartialEq)]
pub enum Answer {
    /// Magnitude estimation: the text typed (checked by the engine).
    Magnitude(String),
    /// Paired comparison.
    Paired(Choice),
}

/// What happens to the session.
#[derive(Debug, Clone, PartialEq)]
pub enum Input {
    /// Begin the session (or continue a resumed one).
    Start,
    /// Acknowledge instructions, a break or an experimenter prompt.
    Continue,
    /// An answer.
    Answer(Answer),
    /// Paired comparison: explore stimulus 0 (first) or 1 (second).
    Switch(usize),
    /// Fitts: a click with the cursor at `x_m`.
    Click {
        /// Cursor position, m.
        x_m: f64,
    },
    /// The last [`Action::Record`] is on disk.
    Recorded,
    /// End the current trial as aborted (device lost, experimenter); with
    /// `requeue` it is presented again, else the session moves on.
    Abort {
        /// Why, for the log.
        reason: String,
        /// Present the trial again.
        requeue: bool,
    },
}

/// What the participant's screen shows.
#[derive(Debug, Clone, PartialEq)]
pub enum Screen {
    /// Text to read, then continue.
    Instructions(String),
    /// Paired comparison's reference phase (real surface) until `until`.
    Reference {
        /// What to do.
        instructions: String,
        /// End of the phase (session time).
        until: Time,
    },
    /// A break between blocks until `until` (may be ended early).
    Break {
        /// End of the break (session time).
        until: Time,
    },
    /// Magnitude estimation: explore until `until`, answer any time.
    Explore {
        /// End of the exploration (session time).
        until: Time,
    },
    /// Two stimuli, `active` (0 first, 1 second) rendered: a paired
    /// comparison, or a discrimination's two intervals.
    Paired {
        /// Active stimulus.
        active: usize,
        /// End of the exploration (session time).
        until: Time,
        /// A two-interval forced choice asking this question (answered
        /// first or second, [`Question::ForcedChoice`]); `None`: the paired
        /// comparison's nearness to the real surface.
        forced: Option<String>,
    },
    /// Two targets to tap in turn (a Fitts test): the lit one and the
    /// other.
    Targets {
        /// Centre of the lit target, m.
        lit_m: f64,
        /// Centre of the other target, m.
        other_m: f64,
        /// Target width W, m.
        width_m: f64,
        /// Cursor diameter D, m.
        cursor_m: f64,
        /// Width that counts for a hit, W' (W - D or W), m.
        effective_width_m: f64,
        /// The last click missed.
        missed: bool,
    },
}

/// A question for the participant.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Question {
    /// Type a positive number.
    Magnitude,
    /// First, second or no difference.
    PairedChoice,
    /// First or second: the question of the [`Screen::Paired`] shown.
    ForcedChoice,
}

/// What the engine asks the shell to do.
#[derive(Debug, Clone, PartialEq)]
pub enum Action<K: Kinds> {
    /// Render this model from now on (`None`: render nothing).
    Render(Option<ModelParams>),
    /// For the simulated device: the physical friction of the apparatus from
    /// now on (a Fitts `real` condition's block), `None` for none.
    Physical(Option<ModelParams>),
    /// Show this to the participant.
    Show(Screen),
    /// Show the kind's own screen ([`OwnScreen`]), drawn by the kind's
    /// window code; to everything else it is its task, a shared screen.
    ShowOwn(OwnScreen),
    /// Ask the participant this.
    Ask(Question),
    /// An answer was refused: say why and ask again. Nothing is logged.
    Refused(String),
    /// Ask the experimenter to do this, then [`Input::Continue`].
    Prompt(String),
    /// Write this record to disk, then send [`Input::Recorded`].
    Record(TrialRecord<K>),
    /// Every planned trial is done.
    Finished,
}

#[derive(Debug, Clone)]
enum Stage<K: Kinds> {
    Idle,
    Instructions,
    Reference { until: Time },
    Break { until: Time },
    Prompt,
    Trial(Live<K>),
    AwaitWrite { requeue: bool },
    Finished,
}

#[derive(Debug, Clone)]
struct Live<K: Kinds> {
    started: Time,
    state: K::Live,
}

/// The session engine, for the set of kinds `K`.
#[derive(Debug, Clone)]
pub struct Engine<K: Kinds> {
    protocol: Protocol<K>,
    source: Arc<dyn TrialSource<K>>,
    history: Vec<TrialRecord<K>>,
    next: usize,
    current: Option<PlannedTrial<K>>,
    /// Block of the last trial finally logged (a break comes before the
    /// first trial of another block).
    previous_block: Option<usize>,
    stage: Stage<K>,
    out: VecDeque<Action<K>>,
}

impl<K: Kinds> Engine<K> {
    /// An engine that will run `plan` from trial `start_at` (0 for a new
    /// session).
    #[must_use]
    pub fn new(plan: Plan<K>, start_at: usize) -> Self {
        let previous_block = start_at
            .checked_sub(1)
            .and_then(|i| plan.trials.get(i))
            .map(|t| t.block_index);
        let mut e = Engine::resume(plan.protocol.clone(), Arc::new(plan), Vec::new());
        e.next = start_at;
        e.previous_block = previous_block;
        e.current = e.source.trial(start_at, &e.history);
        e
    }

    /// An engine that runs `protocol` with trials from `source`, going on
    /// after the records of `history` (empty for a new session).
    #[must_use]
    pub fn resume(
        protocol: Protocol<K>,
        source: Arc<dyn TrialSource<K>>,
        history: Vec<TrialRecord<K>>,
    ) -> Self {
        let next = next_position(&history);
        let previous_block = history
            .iter()
            .rev()
            .find(|r| !r.requeued)
            .map(|r| r.block_index);
        let current = source.trial(next, &history);
        Engine {
            protocol,
            source,
            history,
            next,
            current,
            previous_block,
            stage: Stage::Idle,
            out: VecDeque::new(),
        }
    }

    /// The protocol.
    #[must_use]
    pub fn protocol(&self) -> &Protocol<K> {
        &self.protocol
    }

    /// How many trials the session has, if known in advance.
    #[must_use]
    pub fn planned_trials(&self) -> Option<usize> {
        self.source.planned()
    }

    /// Every record of the session so far, in log order.
    #[must_use]
    pub fn history(&self) -> &[TrialRecord<K>] {
        &self.history
    }

    /// Position of the current (or next) trial.
    #[must_use]
    pub fn trial_index(&self) -> usize {
        self.next
    }

    /// The current (or next) trial, if any is left.
    #[must_use]
    pub fn trial(&self) -> Option<&PlannedTrial<K>> {
        self.current.as_ref()
    }

    /// Whether a trial is being presented (stimulus on, answer or taps
    /// awaited): an abort now logs it as aborted.
    #[must_use]
    pub fn in_trial(&self) -> bool {
        matches!(self.stage, Stage::Trial(_))
    }

    /// Whether every trial is done.
    #[must_use]
    pub fn is_finished(&self) -> bool {
        matches!(self.stage, Stage::Finished)
    }

    /// Whether actions wait for [`Engine::poll`].
    #[must_use]
    pub fn has_actions(&self) -> bool {
        !self.out.is_empty()
    }

    /// The next action for the shell, if any.
    pub fn poll(&mut self) -> Option<Action<K>> {
        self.out.pop_front()
    }

    /// Feeds one input at session time `now`. Inputs that make no sense in
    /// the current stage are ignored.
    pub fn handle(&mut self, now: Time, input: Input) {
        let stage = std::mem::replace(&mut self.stage, Stage::Idle);
        self.stage = match (stage, input) {
            (Stage::Idle, Input::Start) => self.start(now),
            (Stage::Instructions, Input::Continue) => self.after_instructions(now),
            (Stage::Reference { .. }, Input::Continue) => self.begin_trial(now, false),
            (Stage::Break { .. }, Input::Continue) => self.begin_trial(now, true),
            (Stage::Prompt, Input::Continue) => self.start_live(now),
            (Stage::Trial(live), input) => self.live(now, live, input),
            (Stage::AwaitWrite { requeue }, Input::Recorded) => {
                if !requeue {
                    self.previous_block = self.current.as_ref().map(|t| t.block_index);
                    self.next += 1;
                }
                self.current = self.source.trial(self.next, &self.history);
                self.begin_trial(now, false)
            }
            (stage, _) => stage,
        };
    }

    /// When the engine next wants [`Engine::handle_timeout`], in session
    /// time (`None`: nothing is timed now). Every timer is a whole number
    /// of nanoseconds from the moment it was set, so a driver whose clock
    /// counts whole ticks fires it at the same tick of the trial wherever
    /// the trial started.
    #[must_use]
    pub fn poll_timeout(&self) -> Option<Time> {
        match &self.stage {
            Stage::Reference { until } | Stage::Break { until } => Some(*until),
            Stage::Trial(live) => K::timeout(&live.state),
            _ => None,
        }
    }

    /// The driver's clock has reached `now`: fires the timeout of
    /// [`Engine::poll_timeout`] if it is due (else does nothing).
    pub fn handle_timeout(&mut self, now: Time) {
        if self.poll_timeout().is_none_or(|due| now < due) {
            return;
        }
        let stage = std::mem::replace(&mut self.stage, Stage::Idle);
        self.stage = match stage {
            Stage::Reference { .. } => self.begin_trial(now, false),
            Stage::Break { .. } => self.begin_trial(now, true),
            Stage::Trial(mut live) => {
                let next = K::on_timeout(&mut live.state, now, &mut self.out);
                self.after(now, live, next)
            }
            stage => stage,
        };
    }

    fn start(&mut self, now: Time) -> Stage<K> {
        if self.next == 0 && !self.protocol.instructions.is_empty() {
            self.out.push_back(Action::Show(Screen::Instructions(
                self.protocol.instructions.clone(),
            )));
            return Stage::Instructions;
        }
        self.after_instructions(now)
    }

    fn after_instructions(&mut self, now: Time) -> Stage<K> {
        if let Some((instructions, duration)) = K::reference(&self.protocol.design)
            && self.next == 0
        {
            let until = now + Time::from_secs_saturating(duration);
            self.out.push_back(Action::Show(Screen::Reference {
                instructions: instructions.to_owned(),
                until,
            }));
            return Stage::Reference { until };
        }
        self.begin_trial(now, true)
    }

    /// Starts the next trial, with a break first at a block boundary (unless
    /// `break_done`).
    fn begin_trial(&mut self, now: Time, break_done: bool) -> Stage<K> {
        let Some(trial) = &self.current else {
            self.out.push_back(Action::Render(None));
            self.out.push_back(Action::Finished);
            return Stage::Finished;
        };
        let block_start = self.previous_block.is_some_and(|b| b != trial.block_index);
        if block_start && !break_done && self.protocol.break_s > 0.0 {
            let until = now + Time::from_secs_saturating(self.protocol.break_s);
            self.out.push_back(Action::Render(None));
            self.out.push_back(Action::Show(Screen::Break { until }));
            return Stage::Break { until };
        }
        if let Some(text) = K::prompt(&trial.spec) {
            self.out.push_back(Action::Prompt(text.to_owned()));
            return Stage::Prompt;
        }
        self.start_live(now)
    }

    fn start_live(&mut self, now: Time) -> Stage<K> {
        let Some(state) = self
            .current
            .as_ref()
            .map(|trial| K::start(&trial.spec, now, &mut self.out))
        else {
            return Stage::Finished;
        };
        Stage::Trial(Live {
            started: now,
            state,
        })
    }

    fn live(&mut self, now: Time, mut live: Live<K>, input: Input) -> Stage<K> {
        if let Input::Abort { reason, requeue } = input {
            return self.finish(now, &live, Some(reason), requeue);
        }
        let next = K::on_input(&mut live.state, now, input, &mut self.out);
        self.after(now, live, next)
    }

    /// Goes on with the live trial, or ends it as its kind says.
    fn after(&mut self, now: Time, live: Live<K>, next: Next) -> Stage<K> {
        match next {
            Next::Stay => Stage::Trial(live),
            Next::Finish(abort) => self.finish(now, &live, abort, false),
        }
    }

    /// Ends the live trial: record it and wait for the write.
    fn finish(
        &mut self,
        now: Time,
        live: &Live<K>,
        abort: Option<String>,
        requeue: bool,
    ) -> Stage<K> {
        let Some(trial) = &self.current else {
            return Stage::Finished;
        };
        let status = if abort.is_some() {
            Status::Aborted
        } else {
            Status::Completed
        };
        let data = K::data(&live.state, live.started, now, status == Status::Completed);
        let record = TrialRecord {
            trial: trial.index,
            block: trial.block.clone(),
            block_index: trial.block_index,
            practice: trial.practice,
            repetition: trial.repetition,
            status,
            abort_reason: abort,
            requeued: requeue,
            trial_seed: trial.seed,
            started_s: live.started,
            ended_s: now,
            data,
        };
        self.history.push(record.clone());
        self.out.push_back(Action::Render(None));
        self.out.push_back(Action::Physical(None));
        self.out.push_back(Action::Record(record));
        Stage::AwaitWrite { requeue }
    }
}
