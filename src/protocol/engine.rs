//! The session engine: a sans-IO state machine that runs a [`Plan`].
//!
//! The session driver (`crate::session`) calls [`Engine::handle`] with the
//! current session time and an [`Input`], then drains [`Engine::poll`] for
//! [`Action`]s and carries them out: load a friction model, show or ask
//! something, write a trial record. The engine reads no clock, touches no
//! file or port, and draws no random numbers: the same inputs give the same
//! actions.
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
//! # Fitts targets
//! Targets are centred at `-A/2` and `+A/2`; the first lit target is at
//! `-A/2`. A click counts only if the cursor is inside the lit target:
//! `|x - centre| <= W'/2` (W' = W - D or W, see the protocol's `tolerance`).
//! A click outside is an error; its size is its distance beyond the
//! tolerance, `|x - centre| - W'/2`. The lit target switches after each hit;
//! completion time runs from the first hit to the last.

use std::collections::VecDeque;
use std::sync::Arc;

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use super::plan::{Plan, PlannedTrial, TrialSpec};
use super::{Design, Protocol};
use crate::friction::ModelParams;

/// A paired-comparison answer.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum Choice {
    /// The stimulus presented first is nearer to the real surface.
    First,
    /// The stimulus presented second is nearer.
    Second,
    /// No difference.
    NoDifference,
}

impl Choice {
    /// `first`, `second` or `no_difference`.
    #[must_use]
    pub fn as_str(self) -> &'static str {
        match self {
            Choice::First => "first",
            Choice::Second => "second",
            Choice::NoDifference => "no_difference",
        }
    }
}

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
    /// Paired comparison's reference phase (real surface) until `until_s`.
    Reference {
        /// What to do.
        instructions: String,
        /// End of the phase, s.
        until_s: f64,
    },
    /// A break between blocks until `until_s` (may be ended early).
    Break {
        /// End of the break, s.
        until_s: f64,
    },
    /// Magnitude estimation: explore until `until_s`, answer any time.
    Explore {
        /// End of the exploration, s.
        until_s: f64,
    },
    /// Paired comparison: stimulus `active` (0 first, 1 second) is rendered.
    Paired {
        /// Active stimulus.
        active: usize,
        /// End of the exploration, s.
        until_s: f64,
    },
    /// Fitts: the lit target and the other one.
    Fitts {
        /// Centre of the lit target, m.
        lit_m: f64,
        /// Centre of the other target, m.
        other_m: f64,
        /// Target width W, m.
        width_m: f64,
        /// Cursor diameter D, m.
        cursor_m: f64,
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
}

/// What the engine asks the shell to do.
#[derive(Debug, Clone, PartialEq)]
pub enum Action {
    /// Render this model from now on (`None`: render nothing).
    Render(Option<ModelParams>),
    /// For the simulated device: the physical friction of the apparatus from
    /// now on (a Fitts `real` condition's block), `None` for none.
    Physical(Option<ModelParams>),
    /// Show this to the participant.
    Show(Screen),
    /// Ask the participant this.
    Ask(Question),
    /// An answer was refused: say why and ask again. Nothing is logged.
    Refused(String),
    /// Ask the experimenter to do this, then [`Input::Continue`].
    Prompt(String),
    /// Write this record to disk, then send [`Input::Recorded`].
    Record(TrialRecord),
    /// Every planned trial is done.
    Finished,
}

/// Outcome of a trial.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum Status {
    /// Answered / all taps done.
    Completed,
    /// Ended early (device lost, experimenter, Fitts timeout).
    Aborted,
}

impl Status {
    /// `completed` or `aborted`.
    #[must_use]
    pub fn as_str(self) -> &'static str {
        match self {
            Status::Completed => "completed",
            Status::Aborted => "aborted",
        }
    }
}

/// One trial's record, as logged.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct TrialRecord {
    /// Planned trial index (0-based presentation order).
    pub trial: usize,
    /// Block name.
    pub block: String,
    /// Block position in the session.
    pub block_index: usize,
    /// Practice trial (excluded from analysis).
    pub practice: bool,
    /// Repetition of the block's list.
    pub repetition: u32,
    /// Completed or aborted.
    pub status: Status,
    /// Why it was aborted.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub abort_reason: Option<String>,
    /// Aborted and presented again later (this record is not final).
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub requeued: bool,
    /// The trial's seed.
    pub trial_seed: u64,
    /// Session time at the trial's start, s.
    pub started_s: f64,
    /// Session time at its end, s.
    pub ended_s: f64,
    /// What was presented and answered.
    pub data: TrialData,
}

/// The kind-specific part of a record.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum TrialData {
    /// Paired comparison.
    PairedComparison {
        /// Condition presented first.
        first: String,
        /// Condition presented second.
        second: String,
        /// The answer.
        choice: Option<Choice>,
        /// The chosen condition id, or `no_difference`.
        chosen: Option<String>,
    },
    /// Magnitude estimation.
    MagnitudeEstimation {
        /// Display name.
        display: String,
        /// Static coefficient.
        mu_s: f64,
        /// Kinetic coefficient.
        mu_k: f64,
        /// mu_s - mu_k.
        delta_mu: f64,
        /// The number given.
        magnitude: Option<f64>,
        /// Time from the start of the stimulus to the answer, s.
        response_time_s: Option<f64>,
    },
    /// Fitts test.
    Fitts {
        /// Condition id.
        condition: String,
        /// A, m.
        amplitude_m: f64,
        /// W, m.
        width_m: f64,
        /// D, m.
        cursor_m: f64,
        /// W', m.
        effective_width_m: f64,
        /// Index of difficulty, bits.
        id_bits: f64,
        /// First to last hit, s.
        completion_time_s: Option<f64>,
        /// Hits.
        taps: u32,
        /// Clicks outside the lit target.
        errors: u32,
        /// Mean error size, m (None without errors).
        mean_error_m: Option<f64>,
        /// Session time of each hit, s.
        tap_times_s: Vec<f64>,
        /// Cursor position of each hit, m.
        tap_x_m: Vec<f64>,
        /// Centre of the target of each hit, m.
        target_x_m: Vec<f64>,
        /// Cursor position of each miss, m.
        miss_x_m: Vec<f64>,
    },
}

/// Checks a typed magnitude: a finite number greater than zero.
///
/// # Errors
/// Why the text is refused, for the participant.
pub fn parse_magnitude(text: &str) -> Result<f64, String> {
    let t = text.trim();
    if t.is_empty() {
        return Err("please type a number".into());
    }
    let x: f64 = t.parse().map_err(|_| format!("'{t}' is not a number"))?;
    if !x.is_finite() {
        Err("please type a finite number".into())
    } else if x <= 0.0 {
        Err("please type a number greater than zero".into())
    } else {
        Ok(x)
    }
}

#[derive(Debug, Clone)]
enum Stage {
    Idle,
    Instructions,
    Reference { until: f64 },
    Break { until: f64 },
    Prompt,
    Trial(Live),
    AwaitWrite { requeue: bool },
    Finished,
}

#[derive(Debug, Clone)]
struct Live {
    started: f64,
    state: LiveState,
}

/// A live trial's state. `expired` marks an exploration whose time is up
/// (its timeout has fired: the question is asked).
#[derive(Debug, Clone)]
enum LiveState {
    Magnitude {
        until: f64,
        expired: bool,
    },
    Paired {
        until: f64,
        active: usize,
        expired: bool,
    },
    Fitts(FittsTest),
}

#[derive(Debug, Clone, Default)]
struct FittsTest {
    lit: usize,
    centres: [f64; 2],
    deadline: f64,
    tap_times: Vec<f64>,
    tap_x: Vec<f64>,
    target_x: Vec<f64>,
    miss_x: Vec<f64>,
    miss_size: Vec<f64>,
}

/// Where a session's trials come from: the trial at each presentation
/// position, given every record logged so far. A fixed [`Plan`] ignores the
/// records; an adaptive source (a staircase) chooses its next stimulus from
/// the answers. A source is a pure function of its arguments: it keeps no
/// state of its own, so a resumed session rebuilds it exactly by handing it
/// the logged records.
pub trait TrialSource: std::fmt::Debug + Send + Sync {
    /// The trial to present at position `index` (0-based), given the
    /// session's records so far in log order (re-queued ones included);
    /// `None` when the session is over.
    fn trial(&self, index: usize, history: &[TrialRecord]) -> Option<PlannedTrial>;
    /// How many trials the session will have, if known in advance.
    fn planned(&self) -> Option<usize>;
    /// The haptic loop rate the session's models need, Hz.
    fn loop_rate_hz(&self) -> f64;
}

impl TrialSource for Plan {
    fn trial(&self, index: usize, _: &[TrialRecord]) -> Option<PlannedTrial> {
        self.trials.get(index).cloned()
    }

    fn planned(&self) -> Option<usize> {
        Some(self.trials.len())
    }

    /// The highest loop rate of any model the plan renders (5 kHz for seed
    /// 001's stick-slip models, else 1 kHz).
    fn loop_rate_hz(&self) -> f64 {
        self.trials
            .iter()
            .map(|t| match &t.spec {
                TrialSpec::MagnitudeEstimation { model, .. } | TrialSpec::Fitts { model, .. } => {
                    model.loop_rate_hz()
                }
                TrialSpec::PairedComparison { first, second, .. } => {
                    first.model.loop_rate_hz().max(second.model.loop_rate_hz())
                }
            })
            .fold(1000.0, f64::max)
    }
}

/// The first position not yet finally logged: where a resume starts. A
/// trial is final when completed, or aborted and not re-queued.
#[must_use]
pub fn next_position(history: &[TrialRecord]) -> usize {
    history
        .iter()
        .filter(|r| !r.requeued)
        .map(|r| r.trial + 1)
        .max()
        .unwrap_or(0)
}

/// The session engine.
#[derive(Debug, Clone)]
pub struct Engine {
    protocol: Protocol,
    source: Arc<dyn TrialSource>,
    history: Vec<TrialRecord>,
    next: usize,
    current: Option<PlannedTrial>,
    /// Block of the last trial finally logged (a break comes before the
    /// first trial of another block).
    previous_block: Option<usize>,
    stage: Stage,
    out: VecDeque<Action>,
}

impl Engine {
    /// An engine that will run `plan` from trial `start_at` (0 for a new
    /// session).
    #[must_use]
    pub fn new(plan: Plan, start_at: usize) -> Self {
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
        protocol: Protocol,
        source: Arc<dyn TrialSource>,
        history: Vec<TrialRecord>,
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
    pub fn protocol(&self) -> &Protocol {
        &self.protocol
    }

    /// How many trials the session has, if known in advance.
    #[must_use]
    pub fn planned_trials(&self) -> Option<usize> {
        self.source.planned()
    }

    /// Every record of the session so far, in log order.
    #[must_use]
    pub fn history(&self) -> &[TrialRecord] {
        &self.history
    }

    /// Position of the current (or next) trial.
    #[must_use]
    pub fn trial_index(&self) -> usize {
        self.next
    }

    /// The current (or next) trial, if any is left.
    #[must_use]
    pub fn trial(&self) -> Option<&PlannedTrial> {
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
    pub fn poll(&mut self) -> Option<Action> {
        self.out.pop_front()
    }

    /// Feeds one input at session time `now_s`. Inputs that make no sense in
    /// the current stage are ignored.
    pub fn handle(&mut self, now_s: f64, input: Input) {
        let stage = std::mem::replace(&mut self.stage, Stage::Idle);
        self.stage = match (stage, input) {
            (Stage::Idle, Input::Start) => self.start(now_s),
            (Stage::Instructions, Input::Continue) => self.after_instructions(now_s),
            (Stage::Reference { .. }, Input::Continue) => self.begin_trial(now_s, false),
            (Stage::Break { .. }, Input::Continue) => self.begin_trial(now_s, true),
            (Stage::Prompt, Input::Continue) => self.start_live(now_s),
            (Stage::Trial(live), input) => self.live(now_s, live, input),
            (Stage::AwaitWrite { requeue }, Input::Recorded) => {
                if !requeue {
                    self.previous_block = self.current.as_ref().map(|t| t.block_index);
                    self.next += 1;
                }
                self.current = self.source.trial(self.next, &self.history);
                self.begin_trial(now_s, false)
            }
            (stage, _) => stage,
        };
    }

    /// When the engine next wants [`Engine::handle_timeout`], session time
    /// in s (`None`: nothing is timed now).
    #[must_use]
    pub fn poll_timeout(&self) -> Option<f64> {
        match &self.stage {
            Stage::Reference { until } | Stage::Break { until } => Some(*until),
            Stage::Trial(Live { state, .. }) => match state {
                LiveState::Magnitude { until, expired }
                | LiveState::Paired { until, expired, .. } => (!expired).then_some(*until),
                LiveState::Fitts(t) => Some(t.deadline),
            },
            _ => None,
        }
    }

    /// The driver's clock has reached `now_s`: fires the timeout of
    /// [`Engine::poll_timeout`] if it is due (else does nothing).
    pub fn handle_timeout(&mut self, now_s: f64) {
        if self.poll_timeout().is_none_or(|due| now_s < due) {
            return;
        }
        let stage = std::mem::replace(&mut self.stage, Stage::Idle);
        self.stage = match stage {
            Stage::Reference { .. } => self.begin_trial(now_s, false),
            Stage::Break { .. } => self.begin_trial(now_s, true),
            Stage::Trial(mut live) => match &mut live.state {
                LiveState::Magnitude { expired, .. } => {
                    *expired = true;
                    self.out.push_back(Action::Render(None));
                    self.out.push_back(Action::Ask(Question::Magnitude));
                    Stage::Trial(live)
                }
                LiveState::Paired { expired, .. } => {
                    *expired = true;
                    self.out.push_back(Action::Render(None));
                    self.out.push_back(Action::Ask(Question::PairedChoice));
                    Stage::Trial(live)
                }
                LiveState::Fitts(_) => {
                    self.finish(now_s, &live, Some("timeout".into()), None, false)
                }
            },
            stage => stage,
        };
    }

    fn start(&mut self, now: f64) -> Stage {
        if self.next == 0 && !self.protocol.instructions.is_empty() {
            self.out.push_back(Action::Show(Screen::Instructions(
                self.protocol.instructions.clone(),
            )));
            return Stage::Instructions;
        }
        self.after_instructions(now)
    }

    fn after_instructions(&mut self, now: f64) -> Stage {
        if let Design::PairedComparison(d) = &self.protocol.design
            && self.next == 0
            && d.reference_s > 0.0
        {
            let until = now + d.reference_s;
            self.out.push_back(Action::Show(Screen::Reference {
                instructions: d.reference_instructions.clone(),
                until_s: until,
            }));
            return Stage::Reference { until };
        }
        self.begin_trial(now, true)
    }

    /// Starts the next trial, with a break first at a block boundary (unless
    /// `break_done`).
    fn begin_trial(&mut self, now: f64, break_done: bool) -> Stage {
        let Some(trial) = &self.current else {
            self.out.push_back(Action::Render(None));
            self.out.push_back(Action::Finished);
            return Stage::Finished;
        };
        let block_start = self.previous_block.is_some_and(|b| b != trial.block_index);
        if block_start && !break_done && self.protocol.break_s > 0.0 {
            let until = now + self.protocol.break_s;
            self.out.push_back(Action::Render(None));
            self.out
                .push_back(Action::Show(Screen::Break { until_s: until }));
            return Stage::Break { until };
        }
        if let TrialSpec::Fitts {
            prompt: Some(text), ..
        } = &trial.spec
        {
            self.out.push_back(Action::Prompt(text.clone()));
            return Stage::Prompt;
        }
        self.start_live(now)
    }

    fn start_live(&mut self, now: f64) -> Stage {
        let Some(trial) = &self.current else {
            return Stage::Finished;
        };
        let state = match &trial.spec {
            TrialSpec::MagnitudeEstimation {
                model,
                exploration_s,
                ..
            } => {
                let until = now + exploration_s;
                self.out.push_back(Action::Render(Some(model.clone())));
                self.out
                    .push_back(Action::Show(Screen::Explore { until_s: until }));
                LiveState::Magnitude {
                    until,
                    expired: false,
                }
            }
            TrialSpec::PairedComparison {
                first,
                exploration_s,
                ..
            } => {
                let until = now + 2.0 * exploration_s;
                self.out
                    .push_back(Action::Render(Some(first.model.clone())));
                self.out.push_back(Action::Show(Screen::Paired {
                    active: 0,
                    until_s: until,
                }));
                LiveState::Paired {
                    until,
                    active: 0,
                    expired: false,
                }
            }
            TrialSpec::Fitts {
                model,
                physical,
                amplitude_m,
                width_m,
                cursor_m,
                timeout_s,
                ..
            } => {
                let t = FittsTest {
                    lit: 0,
                    centres: [-amplitude_m / 2.0, amplitude_m / 2.0],
                    deadline: now + timeout_s,
                    ..FittsTest::default()
                };
                self.out.push_back(Action::Physical(physical.clone()));
                self.out.push_back(Action::Render(Some(model.clone())));
                self.out.push_back(Action::Show(Screen::Fitts {
                    lit_m: t.centres[0],
                    other_m: t.centres[1],
                    width_m: *width_m,
                    cursor_m: *cursor_m,
                    missed: false,
                }));
                LiveState::Fitts(t)
            }
        };
        Stage::Trial(Live {
            started: now,
            state,
        })
    }

    fn live(&mut self, now: f64, mut live: Live, input: Input) -> Stage {
        match (&mut live.state, input) {
            (_, Input::Abort { reason, requeue }) => {
                self.finish(now, &live, Some(reason), None, requeue)
            }
            (LiveState::Magnitude { .. }, Input::Answer(Answer::Magnitude(text))) => {
                match parse_magnitude(&text) {
                    Ok(x) => self.finish(now, &live, None, Some(Reply::Magnitude(x)), false),
                    Err(why) => {
                        self.out.push_back(Action::Refused(why));
                        self.out.push_back(Action::Ask(Question::Magnitude));
                        Stage::Trial(live)
                    }
                }
            }
            (LiveState::Paired { active, until, .. }, Input::Switch(i))
                if i < 2 && now < *until =>
            {
                *active = i;
                if let Some(TrialSpec::PairedComparison { first, second, .. }) =
                    self.trial().map(|t| &t.spec)
                {
                    let model = if i == 0 { &first.model } else { &second.model };
                    self.out.push_back(Action::Render(Some(model.clone())));
                }
                self.out.push_back(Action::Show(Screen::Paired {
                    active: i,
                    until_s: *until,
                }));
                Stage::Trial(live)
            }
            (LiveState::Paired { .. }, Input::Answer(Answer::Paired(c))) => {
                self.finish(now, &live, None, Some(Reply::Paired(c)), false)
            }
            (LiveState::Fitts(_), Input::Click { x_m }) if x_m.is_finite() => {
                self.click(now, live, x_m)
            }
            _ => Stage::Trial(live),
        }
    }

    fn click(&mut self, now: f64, mut live: Live, x: f64) -> Stage {
        let Some(TrialSpec::Fitts {
            effective_width_m,
            width_m,
            cursor_m,
            taps,
            ..
        }) = self.trial().map(|t| t.spec.clone())
        else {
            return Stage::Trial(live);
        };
        let LiveState::Fitts(t) = &mut live.state else {
            return Stage::Trial(live);
        };
        let centre = t.centres[t.lit];
        let distance = (x - centre).abs();
        let hit = distance <= effective_width_m / 2.0;
        if hit {
            t.tap_times.push(now);
            t.tap_x.push(x);
            t.target_x.push(centre);
            if t.tap_times.len() >= taps as usize {
                return self.finish(now, &live, None, None, false);
            }
            t.lit = 1 - t.lit;
        } else {
            t.miss_x.push(x);
            t.miss_size.push(distance - effective_width_m / 2.0);
        }
        self.out.push_back(Action::Show(Screen::Fitts {
            lit_m: t.centres[t.lit],
            other_m: t.centres[1 - t.lit],
            width_m,
            cursor_m,
            missed: !hit,
        }));
        Stage::Trial(live)
    }

    /// Ends the live trial: record it and wait for the write.
    fn finish(
        &mut self,
        now: f64,
        live: &Live,
        abort: Option<String>,
        reply: Option<Reply>,
        requeue: bool,
    ) -> Stage {
        let Some(trial) = &self.current else {
            return Stage::Finished;
        };
        let status = if abort.is_some() {
            Status::Aborted
        } else {
            Status::Completed
        };
        let data = trial_data(&trial.spec, live, now, status, reply);
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

/// The kind-specific data of a trial that ends at `now`.
fn trial_data(
    spec: &TrialSpec,
    live: &Live,
    now: f64,
    status: Status,
    reply: Option<Reply>,
) -> TrialData {
    match (spec, &live.state) {
        (TrialSpec::PairedComparison { first, second, .. }, _) => {
            let choice = match reply {
                Some(Reply::Paired(c)) => Some(c),
                _ => None,
            };
            let chosen = choice.map(|c| match c {
                Choice::First => first.id.clone(),
                Choice::Second => second.id.clone(),
                Choice::NoDifference => "no_difference".to_owned(),
            });
            TrialData::PairedComparison {
                first: first.id.clone(),
                second: second.id.clone(),
                choice,
                chosen,
            }
        }
        (
            TrialSpec::MagnitudeEstimation {
                display,
                mu_s,
                mu_k,
                ..
            },
            _,
        ) => {
            let magnitude = match reply {
                Some(Reply::Magnitude(x)) => Some(x),
                _ => None,
            };
            TrialData::MagnitudeEstimation {
                display: display.clone(),
                mu_s: *mu_s,
                mu_k: *mu_k,
                delta_mu: mu_s - mu_k,
                magnitude,
                response_time_s: magnitude.map(|_| now - live.started),
            }
        }
        (
            TrialSpec::Fitts {
                condition,
                amplitude_m,
                width_m,
                cursor_m,
                effective_width_m,
                id_bits,
                ..
            },
            state,
        ) => {
            let empty = FittsTest::default();
            let t = if let LiveState::Fitts(t) = state {
                t
            } else {
                &empty
            };
            let errors = t.miss_size.len();
            TrialData::Fitts {
                condition: condition.clone(),
                amplitude_m: *amplitude_m,
                width_m: *width_m,
                cursor_m: *cursor_m,
                effective_width_m: *effective_width_m,
                id_bits: *id_bits,
                completion_time_s: match (t.tap_times.first(), t.tap_times.last()) {
                    (Some(a), Some(b)) if status == Status::Completed => Some(b - a),
                    _ => None,
                },
                taps: u32::try_from(t.tap_times.len()).unwrap_or(u32::MAX),
                errors: u32::try_from(errors).unwrap_or(u32::MAX),
                mean_error_m: (errors > 0).then(|| t.miss_size.iter().sum::<f64>() / errors as f64),
                tap_times_s: t.tap_times.clone(),
                tap_x_m: t.tap_x.clone(),
                target_x_m: t.target_x.clone(),
                miss_x_m: t.miss_x.clone(),
            }
        }
    }
}

#[derive(Debug, Clone, Copy)]
enum Reply {
    Magnitude(f64),
    Paired(Choice),
}
