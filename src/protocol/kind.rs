//! The seam between the protocol core and the study kinds.
//!
//! The protocol core (the loader, the plan, the engine, the trial record)
//! is written against two traits and names no kind:
//! - [`StudyKind`]: what one kind of study is (its design, how it is read
//!   and checked, its trials and where they come from, its live trial, its
//!   logged data and data-CSV cells). Each kind implements it in its own
//!   folder, `src/kinds/<kind>/`.
//! - [`Kinds`]: the set of kinds a program knows, as one type with the
//!   tagged unions of their designs, trials, data and live trials. Only the
//!   registry (`src/kinds/mod.rs`) implements it, from one line per kind,
//!   and hands it to the layers above by type parameter: `Protocol<K>`,
//!   `Plan<K>`, `Engine<K>`, `TrialRecord<K>`.
//!
//! [`Holds`] lets a kind find its own parts inside the unions (its trials
//! in a source it runs, its data in the records it replays, its design in
//! a log header) without naming the registry.
//!
//! Like the engine, nothing here reads a clock, draws unseeded randomness,
//! or touches a file or port.

use std::collections::VecDeque;
use std::fmt::Debug;
use std::sync::Arc;

use rand_chacha::ChaCha8Rng;
use schemars::JsonSchema;
use serde::Serialize;
use serde::de::DeserializeOwned;
use serde_json::Value;

use super::Protocol;
use super::check::ValueChecks;
use super::engine::{Action, Input, Question, TrialRecord, TrialSource};
use super::load::Walk;
use super::plan::resolve;
use crate::time::Time;

/// The quality of a stimulus a participant is asked to judge: what a
/// magnitude estimate or a forced choice is about. A person reads it in the
/// instructions; the simulated participant gets it from the protocol (and
/// forms the percept from the cues that quality is judged by).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, serde::Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum Quality {
    /// Friction: the force at break-away and while sliding (the default).
    #[default]
    Friction,
    /// Viscosity: force over velocity.
    Viscosity,
    /// Stiffness: force over displacement.
    Stiffness,
}

/// Plain data a kind hands around (a trial, in a plan): cloned, compared,
/// serialised, sent between threads.
pub trait Plain:
    Debug + Clone + PartialEq + Serialize + DeserializeOwned + Send + Sync + 'static
{
}

impl<T> Plain for T where
    T: Debug + Clone + PartialEq + Serialize + DeserializeOwned + Send + Sync + 'static
{
}

/// A part of a kind that files hold and describe (a design, a record's
/// data): [`Plain`] data with a JSON Schema.
pub trait Logged: Plain + JsonSchema {}

impl<T: Plain + JsonSchema> Logged for T {}

/// The kinds of study a program knows, as the registry lists them: the
/// tagged unions of their parts, and what the protocol core asks of them
/// (dispatched to each kind's [`StudyKind`]).
pub trait Kinds: Debug + Clone + Copy + PartialEq + Send + Sync + 'static {
    /// A protocol's design: one kind's, tagged `kind`.
    type Design: Logged;
    /// What one trial presents.
    type Trial: Plain;
    /// What a trial's record logs (its `data`), tagged `kind`.
    type Data: Logged;
    /// A trial live in the engine.
    type Live: Debug + Clone + Send + Sync + 'static;

    /// Every kind's name (its tag in protocol files, logs and data files)
    /// and data-CSV columns after the common ones, in registry order.
    const KINDS: &'static [KindInfo];

    /// The kind of a design.
    fn design_kind(design: &Self::Design) -> &'static str;
    /// Reads the design object `v` at `path`, dispatched on its `kind`,
    /// reporting every problem to `w`.
    fn read_design(w: &mut Walk, v: &Value, path: &str) -> Option<Self::Design>;
    /// Value checks on a read design.
    fn check_design(design: &Self::Design, c: &mut ValueChecks);
    /// A new design of the kind named `kind` ([`StudyKind::template`]).
    fn template(kind: &str) -> Option<Value>;
    /// The fixed plan's trials for one repetition of its blocks
    /// ([`StudyKind::trials_per_repetition`]).
    fn trials_per_repetition(design: &Self::Design) -> u64;
    /// The blocks of the fixed plan, before ordering.
    fn blocks(design: &Self::Design) -> Vec<Block<Self::Trial>>;
    /// A phase before the first trial: its instructions and duration, s.
    fn reference(design: &Self::Design) -> Option<(&str, f64)>;
    /// Where the trials of a session of `protocol` come from.
    fn source(
        protocol: &Protocol<Self>,
        seed: u64,
        participant_index: u32,
    ) -> Arc<dyn TrialSource<Self>>;
    /// The conditions a participant may be set to prefer when asked which
    /// of two renderings is nearer to a real surface; `None` when the
    /// design never asks it.
    fn preferable(design: &Self::Design) -> Option<Vec<&str>>;
    /// The stretches of the track a design asks the hand to reach
    /// ([`StudyKind::reach`]).
    fn reach(design: &Self::Design) -> Vec<Reach>;

    /// The haptic loop rate a trial's models need, Hz.
    fn loop_rate_hz(trial: &Self::Trial) -> f64;
    /// The experimenter's prompt before a trial, if any.
    fn prompt(trial: &Self::Trial) -> Option<&str>;
    /// What the plan draws for a trial once ordered.
    fn draw(trial: Self::Trial, rng: &mut ChaCha8Rng) -> Self::Trial;
    /// The conditions of a trial a set preference may name (see
    /// [`Kinds::preferable`]), in presentation order; empty for the others.
    fn preferable_stimuli(trial: &Self::Trial) -> Vec<&str>;
    /// The quality a trial asks the participant to judge.
    fn judged(trial: &Self::Trial) -> Quality;

    /// The kind of logged data.
    fn data_kind(data: &Self::Data) -> &'static str;
    /// Writes the data-CSV cells of logged data to `out`, one per column
    /// of its kind.
    fn row<W: WriteCells>(data: &Self::Data, out: &mut W);

    /// Starts `trial` at `now`, pushing what the shell must do.
    fn start(trial: &Self::Trial, now: Time, out: &mut VecDeque<Action<Self>>) -> Self::Live;
    /// When a live trial's timer is due (session time).
    fn timeout(live: &Self::Live) -> Option<Time>;
    /// A live trial's timer has fired at `now`.
    fn on_timeout(live: &mut Self::Live, now: Time, out: &mut VecDeque<Action<Self>>) -> Next;
    /// An input other than an abort, at `now`.
    fn on_input(
        live: &mut Self::Live,
        now: Time,
        input: Input,
        out: &mut VecDeque<Action<Self>>,
    ) -> Next;
    /// What a live trial logs, started at `started`, ended at `now`.
    fn data(live: &Self::Live, started: Time, now: Time, completed: bool) -> Self::Data;

    /// The data-CSV columns of the kind named `kind`, if it is one.
    #[must_use]
    fn columns(kind: &str) -> Option<&'static [&'static str]> {
        Self::KINDS
            .iter()
            .find(|k| k.name == kind)
            .map(|k| k.columns)
    }
}

/// A stretch of the track a design asks the hand to reach (issue 63), in
/// metres from the track's origin, where every device renders along its
/// track: every one must lie within the device's travel.
#[derive(Debug, Clone, PartialEq)]
pub struct Reach {
    /// Where the design asks for it: its JSON path under `design`
    /// (`levels[2]`).
    pub path: String,
    /// What is there, for the message (`targets at ±25 mm with their 4 mm
    /// width`).
    pub what: String,
    /// Its lowest and highest position, m.
    pub span_m: [f64; 2],
}

/// A kind's name and data-CSV columns.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct KindInfo {
    /// The tag in protocol files, logs and data files.
    pub name: &'static str,
    /// Its data-CSV columns, after the common ones.
    pub columns: &'static [&'static str],
}

/// A set of kinds that holds kind `S`: how `S` finds its own parts in the
/// unions (implemented by the registry for each kind it lists).
pub trait Holds<S: StudyKind>: Kinds {
    /// `S`'s trial as one of the set's.
    fn wrap_trial(trial: S::Trial) -> Self::Trial;
    /// `S`'s data in a record, if the record is `S`'s.
    fn data_of(data: &Self::Data) -> Option<&S::Data>;
    /// `S`'s design, if the design is `S`'s.
    fn design_of(design: &Self::Design) -> Option<&S::Design>;
}

/// One kind of study. Implemented by a unit type in the kind's folder
/// (`src/kinds/<kind>/`) and listed once in the registry.
pub trait StudyKind: Sized + 'static {
    /// The study's design: a protocol's `design` object (tagged `kind`).
    type Design: Logged;
    /// What one trial presents.
    type Trial: Plain;
    /// A trial live in the engine, from its start to its record.
    type Live: LiveTrial<Data = Self::Data>;
    /// What a trial's record logs for this kind (its `data`).
    type Data: Logged;

    /// The kind's data-CSV columns, after the common ones.
    const COLUMNS: &'static [&'static str];

    /// Reads the design object `v` at JSON path `path` (its `kind` is
    /// already known), reporting every problem to `w`.
    fn read(w: &mut Walk, v: &Value, path: &str) -> Option<Self::Design>;

    /// Value checks on a read design (ranges, references, zero trials).
    fn check(design: &Self::Design, c: &mut ValueChecks);

    /// A new design of this kind (its `design` object, tagged `kind`), valid
    /// as it stands and small: where the window's protocol builder starts a
    /// new protocol of this kind. The builder's form is the kind's design
    /// schema (its fields, their doc comments and units), so this and the
    /// design's type are all a kind says about its form.
    fn template() -> Value;

    /// How many trials one repetition of [`StudyKind::blocks`] holds,
    /// computed from the design's fields alone (nothing built, saturating
    /// at `u64::MAX`): the plan's size is known, and a plan over the limit
    /// refused ([`super::check::MAX_TRIALS`]), before anything is
    /// allocated for it. 0 for a kind with its own [`StudyKind::source`],
    /// whose own checks bound what its fields make grow.
    fn trials_per_repetition(design: &Self::Design) -> u64;

    /// The blocks of the fixed plan, before ordering; a kind with its own
    /// [`StudyKind::source`] needs none.
    fn blocks(_design: &Self::Design) -> Vec<Block<Self::Trial>> {
        Vec::new()
    }

    /// What is drawn for each trial of the plan once ordered (the paired
    /// comparison's presentation order); by default nothing, and no random
    /// number is drawn.
    fn draw(trial: Self::Trial, _rng: &mut ChaCha8Rng) -> Self::Trial {
        trial
    }

    /// Where a session's trials come from; by default the fixed plan drawn
    /// from `seed` (`protocol::plan::resolve`).
    fn source<K: Holds<Self>>(
        protocol: &Protocol<K>,
        _design: &Self::Design,
        seed: u64,
        participant_index: u32,
    ) -> Arc<dyn TrialSource<K>> {
        Arc::new(resolve(protocol, seed, participant_index))
    }

    /// A phase before the first trial: its instructions and duration, s.
    fn reference(_design: &Self::Design) -> Option<(&str, f64)> {
        None
    }

    /// A prompt the experimenter acknowledges before the trial starts.
    fn prompt(_trial: &Self::Trial) -> Option<&str> {
        None
    }

    /// The conditions a participant may be set to prefer when asked which
    /// of two renderings is nearer to a real surface (`Question::PairedChoice`);
    /// `None` (the default) for a kind that never asks it.
    fn preferable(_design: &Self::Design) -> Option<Vec<&str>> {
        None
    }

    /// The stretches of the track the design asks the hand to reach (a
    /// Fitts level's targets, a slide's travel), each of which must lie
    /// within the device's travel (issue 63); by default none (the hand
    /// explores where it is).
    fn reach(_design: &Self::Design) -> Vec<Reach> {
        Vec::new()
    }

    /// The conditions of a trial a set preference may name (see
    /// [`StudyKind::preferable`]), in presentation order; by default none.
    fn preferable_stimuli(_trial: &Self::Trial) -> Vec<&str> {
        Vec::new()
    }

    /// The quality the trial asks the participant to judge; by default
    /// friction.
    fn judged(_trial: &Self::Trial) -> Quality {
        Quality::Friction
    }

    /// The adaptive tracks of a session's records so far (none for
    /// another kind's records), for the experimenter's live plot; by
    /// default none.
    fn tracks<K: Holds<Self>>(_history: &[TrialRecord<K>]) -> Vec<TrackAnswers> {
        Vec::new()
    }

    /// The haptic loop rate the trial's models need, Hz.
    fn loop_rate_hz(trial: &Self::Trial) -> f64;

    /// Starts the trial at session time `now`, pushing what the shell must
    /// do (render, show, ask).
    fn start<K: Kinds>(trial: &Self::Trial, now: Time, out: &mut VecDeque<Action<K>>)
    -> Self::Live;

    /// Writes the data-CSV cells of `data` to `out`, one per
    /// [`StudyKind::COLUMNS`] entry.
    fn row<W: WriteCells>(data: &Self::Data, out: &mut W);
}

/// Where a kind's [`StudyKind::row`] writes a record's data-CSV cells, one
/// call a cell, in column order. The results layer writes them as text
/// (`results::csv::Row`: quoted, and numbers written, as in every CSV)
/// straight into the CSV's text: no string per cell.
pub trait WriteCells {
    /// Text (quoted where it must be).
    fn text(&mut self, s: &str);
    /// A name as it is (no `,`, `"` or line break in it), or an empty
    /// cell.
    fn opt_text(&mut self, s: Option<&str>);
    /// A float.
    fn num(&mut self, x: f64);
    /// A float, or an empty cell.
    fn opt_num(&mut self, x: Option<f64>);
    /// A whole number.
    fn whole(&mut self, n: u64);
    /// Floats, `;`-separated.
    fn list(&mut self, xs: &[f64]);
    /// Yes/no values, `;`-separated (`true;false`).
    fn flags(&mut self, xs: &[bool]);
}

/// One adaptive track's answers so far, for the experimenter's live plot
/// ([`StudyKind::tracks`]).
#[derive(Debug, Clone, PartialEq)]
pub struct TrackAnswers {
    /// The track (its index in the session).
    pub track: usize,
    /// Its name in the plot's legend (a discrimination track's reference
    /// level).
    pub name: String,
    /// `(difference, correct)` of each completed trial, in order.
    pub answers: Vec<(f64, bool)>,
}

/// One block of a fixed plan before ordering: its name, whether it is
/// practice, and its trial list.
#[derive(Debug, Clone, PartialEq)]
pub struct Block<T> {
    /// Block name (logged).
    pub name: String,
    /// Practice trials are excluded from analysis.
    pub practice: bool,
    /// The trials, as listed.
    pub trials: Vec<T>,
}

impl<T> Block<T> {
    /// The block with each trial mapped by `f`.
    pub fn map<U>(self, f: impl FnMut(T) -> U) -> Block<U> {
        Block {
            name: self.name,
            practice: self.practice,
            trials: self.trials.into_iter().map(f).collect(),
        }
    }
}

/// What a live trial does after an input or its timeout.
#[derive(Debug)]
pub enum Next {
    /// Goes on.
    Stay,
    /// Ends, aborted for this reason or (`None`) completed.
    Finish(Option<String>),
}

/// A trial of one kind, live: its state from start to record. The engine
/// handles what every kind shares (instructions, breaks, prompts, aborts,
/// the write rule).
pub trait LiveTrial: Debug + Clone + Send + Sync + 'static {
    /// What the trial logs.
    type Data;
    /// When the trial's timer is due (session time).
    fn timeout(&self) -> Option<Time>;
    /// The timer has fired at `now`.
    fn on_timeout<K: Kinds>(&mut self, now: Time, out: &mut VecDeque<Action<K>>) -> Next;
    /// An input other than an abort, at `now`.
    fn on_input<K: Kinds>(
        &mut self,
        now: Time,
        input: Input,
        out: &mut VecDeque<Action<K>>,
    ) -> Next;
    /// The data logged for the trial, started at `started`, ended at `now`
    /// (times inside a trial are logged from its start: `now - started`).
    fn data(&self, started: Time, now: Time, completed: bool) -> Self::Data;
}

/// An exploration with a time limit, shared by the kinds that ask a
/// question: at `until` the stimulus stops and the question is asked (once;
/// `expired` marks it asked).
#[derive(Debug, Clone)]
pub struct Exploration {
    /// End of the exploration (session time).
    pub until: Time,
    expired: bool,
}

impl Exploration {
    /// An exploration of `duration_s` from `now`: it ends a whole number
    /// of nanoseconds later, the same wherever it starts.
    #[must_use]
    pub fn from(now: Time, duration_s: f64) -> Self {
        Exploration::until(now + Time::from_secs_saturating(duration_s))
    }

    /// An exploration ending at `until`.
    #[must_use]
    pub fn until(until: Time) -> Self {
        Exploration {
            until,
            expired: false,
        }
    }

    /// When it is due (`None` once asked).
    #[must_use]
    pub fn timeout(&self) -> Option<Time> {
        (!self.expired).then_some(self.until)
    }

    /// The time is up: render nothing and ask `question`.
    pub fn expire<K: Kinds>(&mut self, question: Question, out: &mut VecDeque<Action<K>>) -> Next {
        self.expired = true;
        out.push_back(Action::Render(None));
        out.push_back(Action::Ask(question));
        Next::Stay
    }
}
