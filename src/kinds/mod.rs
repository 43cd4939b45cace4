//! Study kinds: each kind of study is one module behind one trait,
//! [`StudyKind`], and one line of the registry at the end of this file.
//!
//! A kind's module holds everything that differs between kinds:
//! - its **design** (the protocol's `design` object), how it is read with
//!   every problem at its JSON path, and its value checks;
//! - its **trial specification** and where trials come from: the blocks of a
//!   fixed plan (ordered and randomized by `protocol::plan`), or a
//!   [`TrialSource`] of its own that adapts to the answers;
//! - its **live trial** in the engine ([`LiveTrial`]): what it renders,
//!   shows and asks, its timer, and when it ends;
//! - its **logged data** (the record's `data`) and its data-CSV columns;
//! - its **analysis entry** (optional).
//!
//! The simulated participant and the window answer what a trial shows and
//! asks (`Screen`, `Question`), not the kind: a kind that reuses existing
//! screens needs no participant or GUI code. A kind with a screen of its own
//! adds it to `Screen`/`Question` and teaches the participant and the window.
//!
//! The registry (`kinds!`) generates the tagged enums the rest of the
//! program uses ([`Design`], [`Kind`], [`TrialSpec`], [`TrialData`], and the
//! engine's live state) and their dispatch, so adding a kind touches its
//! module and one registry line.
//!
//! Like the engine, nothing here reads a clock, draws unseeded randomness,
//! or touches a file or port. The one exception is an analysis entry, run
//! only by `analysis::analyze`: magnitude estimation's reads the folder's
//! log headers for the protocol's display order.

use std::collections::VecDeque;
use std::fmt::Debug;
use std::path::Path;
use std::sync::Arc;

use rand_chacha::ChaCha8Rng;
use schemars::JsonSchema;
use serde::de::DeserializeOwned;
use serde::{Deserialize, Serialize};
use serde_json::Value;

use crate::analysis::{Rows, Section};
use crate::problem::Problem;
use crate::protocol::Protocol;
use crate::protocol::check::Checks;
use crate::protocol::engine::{Action, Input, Question, TrialSource};
use crate::protocol::load::Walk;
use crate::protocol::plan::resolve;

/// One kind of study. Implemented by a unit type in the kind's module and
/// listed once in the registry (`kinds!` at the end of `kinds/mod.rs`).
pub trait StudyKind {
    /// The study's design: a protocol's `design` object (tagged `kind`).
    type Design: Debug + Clone + PartialEq + Serialize + DeserializeOwned + JsonSchema;
    /// What one trial presents.
    type Trial: Debug + Clone + PartialEq + Serialize + DeserializeOwned;
    /// A trial live in the engine, from its start to its record.
    type Live: LiveTrial<Data = Self::Data>;
    /// What a trial's record logs for this kind (its `data`).
    type Data: Debug + Clone + PartialEq + Serialize + DeserializeOwned + JsonSchema;

    /// The kind's data-CSV columns, after the common ones.
    const COLUMNS: &'static [&'static str];

    /// The kind's analysis, if it has one.
    const ANALYSIS: Option<AnalysisEntry> = None;

    /// Reads the design object `v` at JSON path `path` (its `kind` is
    /// already known), reporting every problem to `w`.
    fn read(w: &mut Walk, v: &Value, path: &str) -> Option<Self::Design>;

    /// Value checks on a read design (ranges, references, zero trials).
    fn check(design: &Self::Design, c: &mut Checks);

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
    fn source(
        protocol: &Protocol,
        _design: &Self::Design,
        seed: u64,
        participant_index: u32,
    ) -> Arc<dyn TrialSource> {
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

    /// The haptic loop rate the trial's models need, Hz.
    fn loop_rate_hz(trial: &Self::Trial) -> f64;

    /// Starts the trial at session time `now`, pushing what the shell must
    /// do (render, show, ask).
    fn start(trial: &Self::Trial, now: f64, out: &mut VecDeque<Action>) -> Self::Live;

    /// The data-CSV cells of `data`, one per [`StudyKind::COLUMNS`] entry.
    fn row(data: &Self::Data) -> Vec<String>;
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
    fn map<U>(self, f: impl FnMut(T) -> U) -> Block<U> {
        Block {
            name: self.name,
            practice: self.practice,
            trials: self.trials.into_iter().map(f).collect(),
        }
    }
}

/// A kind's analysis: how its data files are told, what it reads, and
/// the entry that turns the rows into a report section.
#[derive(Debug, Clone, Copy)]
pub struct AnalysisEntry {
    /// A column only this kind's data CSVs have.
    pub marker: &'static str,
    /// The kind's columns the analysis does not need (they may be
    /// missing; every other column must be present).
    pub unread: &'static [&'static str],
    /// Of those, the ones it reads when every data file of the kind has
    /// them (columns added after older files were written).
    pub optional: &'static [&'static str],
    /// It also reads the rows that did not complete, to count them
    /// (`Rows::aborted`).
    pub counts_aborted: bool,
    /// The analysis of the folder's completed, non-practice rows of this
    /// kind (`folder` for what the data CSVs do not hold, such as the
    /// protocol's display order).
    pub run: fn(rows: &Rows, folder: &Path) -> Result<Section, Problem>,
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
pub trait LiveTrial: Debug + Clone {
    /// What the trial logs.
    type Data;
    /// When the trial's timer is due, session time in s.
    fn timeout(&self) -> Option<f64>;
    /// The timer has fired at `now`.
    fn on_timeout(&mut self, now: f64, out: &mut VecDeque<Action>) -> Next;
    /// An input other than an abort, at `now`.
    fn on_input(&mut self, now: f64, input: Input, out: &mut VecDeque<Action>) -> Next;
    /// The data logged for the trial, started at `started`, ended at `now`.
    fn data(&self, started: f64, now: f64, completed: bool) -> Self::Data;
}

/// An exploration with a time limit, shared by the kinds that ask a
/// question: at `until` the stimulus stops and the question is asked (once;
/// `expired` marks it asked).
#[derive(Debug, Clone)]
pub struct Exploration {
    /// End of the exploration, s.
    pub until: f64,
    expired: bool,
}

impl Exploration {
    /// An exploration ending at `until`.
    #[must_use]
    pub fn until(until: f64) -> Self {
        Exploration {
            until,
            expired: false,
        }
    }

    /// When it is due (`None` once asked).
    #[must_use]
    pub fn timeout(&self) -> Option<f64> {
        (!self.expired).then_some(self.until)
    }

    /// The time is up: render nothing and ask `question`.
    pub fn expire(&mut self, question: Question, out: &mut VecDeque<Action>) -> Next {
        self.expired = true;
        out.push_back(Action::Render(None));
        out.push_back(Action::Ask(question));
        Next::Stay
    }
}

/// The registry: one line per kind, `Variant("name") => module::Type`
/// (doc comment first, `#[cfg(...)]` allowed), which also declares the
/// kind's module (`src/kinds/<module>.rs`). `name` is the kind's tag in
/// protocol files, logs and data files.
macro_rules! kinds {
    ($(
        $(#[doc = $doc:literal])*
        $(#[cfg($cfg:meta)])?
        $variant:ident($name:literal) => $module:ident::$kind:ident,
    )*) => {
        $(
            $(#[doc = $doc])*
            $(#[cfg($cfg)])?
            pub mod $module;
        )*

        /// The design of one of the kinds of study.
        #[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
        #[serde(tag = "kind")]
        #[allow(
            clippy::large_enum_variant,
            reason = "one design per protocol, read once; boxing would change every match on it"
        )]
        pub enum Design {
            $(
                $(#[doc = $doc])*
                $(#[cfg($cfg)])?
                #[serde(rename = $name)]
                $variant(<$module::$kind as StudyKind>::Design),
            )*
        }

        /// The kinds of study.
        #[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize, JsonSchema)]
        pub enum Kind {
            $(
                $(#[doc = $doc])*
                $(#[cfg($cfg)])?
                #[serde(rename = $name)]
                $variant,
            )*
        }

        /// What one trial presents, by kind.
        #[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
        #[serde(tag = "kind")]
        pub enum TrialSpec {
            $(
                $(#[doc = $doc])*
                $(#[cfg($cfg)])?
                #[serde(rename = $name)]
                $variant(<$module::$kind as StudyKind>::Trial),
            )*
        }

        /// The kind-specific part of a record.
        #[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
        #[serde(tag = "kind")]
        #[allow(
            clippy::large_enum_variant,
            reason = "one record per trial, moved a few times; boxing would change every match on it"
        )]
        pub enum TrialData {
            $(
                $(#[doc = $doc])*
                $(#[cfg($cfg)])?
                #[serde(rename = $name)]
                $variant(<$module::$kind as StudyKind>::Data),
            )*
        }

        /// A live trial of each kind, for the engine.
        #[derive(Debug, Clone)]
        pub(crate) enum LiveState {
            $(
                $(#[cfg($cfg)])?
                $variant(Box<<$module::$kind as StudyKind>::Live>),
            )*
        }

        impl Kind {
            /// Every kind, in registry order.
            pub const ALL: &'static [Kind] = &[$($(#[cfg($cfg)])? Kind::$variant,)*];

            /// The kind's name in protocol files, logs and data files.
            #[must_use]
            pub fn as_str(self) -> &'static str {
                match self {
                    $($(#[cfg($cfg)])? Kind::$variant => $name,)*
                }
            }

            /// The kind's data-CSV columns, after the common ones.
            #[must_use]
            pub fn columns(self) -> &'static [&'static str] {
                match self {
                    $($(#[cfg($cfg)])? Kind::$variant => <$module::$kind as StudyKind>::COLUMNS,)*
                }
            }

            /// The kind's analysis, if it has one.
            #[must_use]
            pub fn analysis(self) -> Option<AnalysisEntry> {
                match self {
                    $($(#[cfg($cfg)])? Kind::$variant => <$module::$kind as StudyKind>::ANALYSIS,)*
                }
            }
        }

        impl Design {
            /// The kind of study.
            #[must_use]
            pub fn kind(&self) -> Kind {
                match self {
                    $($(#[cfg($cfg)])? Design::$variant(_) => Kind::$variant,)*
                }
            }

            /// Reads the design object `v` at `path`, dispatched on its
            /// `kind`, reporting every problem to `w`.
            pub(crate) fn read(w: &mut Walk, v: &Value, path: &str) -> Option<Self> {
                let kind = v.get("kind").and_then(Value::as_str);
                match kind {
                    $(
                        $(#[cfg($cfg)])?
                        Some($name) => <$module::$kind as StudyKind>::read(w, v, path).map(Design::$variant),
                    )*
                    _ => {
                        w.unknown_kind(path, kind);
                        None
                    }
                }
            }

            /// Value checks, each problem at its JSON path.
            pub(crate) fn check(&self, c: &mut Checks) {
                match self {
                    $($(#[cfg($cfg)])? Design::$variant(d) => <$module::$kind as StudyKind>::check(d, c),)*
                }
            }

            /// The blocks of the fixed plan, before ordering.
            pub(crate) fn blocks(&self) -> Vec<Block<TrialSpec>> {
                match self {
                    $(
                        $(#[cfg($cfg)])?
                        Design::$variant(d) => <$module::$kind as StudyKind>::blocks(d)
                            .into_iter()
                            .map(|b| b.map(TrialSpec::$variant))
                            .collect(),
                    )*
                }
            }

            /// A phase before the first trial: instructions and duration, s.
            #[must_use]
            pub fn reference(&self) -> Option<(&str, f64)> {
                match self {
                    $($(#[cfg($cfg)])? Design::$variant(d) => <$module::$kind as StudyKind>::reference(d),)*
                }
            }
        }

        /// Where the trials of a session of `protocol` come from: its kind's
        /// source (by default the fixed plan drawn from `seed`).
        #[must_use]
        pub fn source(protocol: &Protocol, seed: u64, participant_index: u32) -> Arc<dyn TrialSource> {
            match &protocol.design {
                $(
                    $(#[cfg($cfg)])?
                    Design::$variant(d) => {
                        <$module::$kind as StudyKind>::source(protocol, d, seed, participant_index)
                    }
                )*
            }
        }

        impl TrialSpec {
            /// The haptic loop rate its models need, Hz.
            #[must_use]
            pub fn loop_rate_hz(&self) -> f64 {
                match self {
                    $($(#[cfg($cfg)])? TrialSpec::$variant(t) => <$module::$kind as StudyKind>::loop_rate_hz(t),)*
                }
            }

            /// The experimenter's prompt before the trial, if any.
            #[must_use]
            pub fn prompt(&self) -> Option<&str> {
                match self {
                    $($(#[cfg($cfg)])? TrialSpec::$variant(t) => <$module::$kind as StudyKind>::prompt(t),)*
                }
            }

            /// What the plan draws for the trial once ordered.
            pub(crate) fn draw(self, rng: &mut ChaCha8Rng) -> Self {
                match self {
                    $(
                        $(#[cfg($cfg)])?
                        TrialSpec::$variant(t) => TrialSpec::$variant(<$module::$kind as StudyKind>::draw(t, rng)),
                    )*
                }
            }
        }

        impl TrialData {
            /// The data-CSV cells, one per column of its kind.
            #[must_use]
            pub fn row(&self) -> Vec<String> {
                match self {
                    $($(#[cfg($cfg)])? TrialData::$variant(d) => <$module::$kind as StudyKind>::row(d),)*
                }
            }
        }

        impl LiveState {
            /// Starts `spec` at `now`, pushing what the shell must do.
            pub(crate) fn start(spec: &TrialSpec, now: f64, out: &mut VecDeque<Action>) -> Self {
                match spec {
                    $(
                        $(#[cfg($cfg)])?
                        TrialSpec::$variant(t) => {
                            LiveState::$variant(Box::new(<$module::$kind as StudyKind>::start(t, now, out)))
                        }
                    )*
                }
            }

            pub(crate) fn timeout(&self) -> Option<f64> {
                match self {
                    $($(#[cfg($cfg)])? LiveState::$variant(t) => t.timeout(),)*
                }
            }

            pub(crate) fn on_timeout(&mut self, now: f64, out: &mut VecDeque<Action>) -> Next {
                match self {
                    $($(#[cfg($cfg)])? LiveState::$variant(t) => t.on_timeout(now, out),)*
                }
            }

            pub(crate) fn on_input(&mut self, now: f64, input: Input, out: &mut VecDeque<Action>) -> Next {
                match self {
                    $($(#[cfg($cfg)])? LiveState::$variant(t) => t.on_input(now, input, out),)*
                }
            }

            pub(crate) fn data(&self, started: f64, now: f64, completed: bool) -> TrialData {
                match self {
                    $(
                        $(#[cfg($cfg)])?
                        LiveState::$variant(t) => TrialData::$variant(t.data(started, now, completed)),
                    )*
                }
            }
        }
    };
}

kinds! {
    /// Seed 000: two renderings, which is nearer to a real surface.
    PairedComparison("paired_comparison") => paired::Paired,
    /// Seed 001: type a number for how strong the friction felt.
    MagnitudeEstimation("magnitude_estimation") => magnitude::Magnitude,
    /// Seed 002: reciprocal tapping under friction conditions.
    Fitts("fitts") => fitts::Fitts,
    /// Issue 17: the smallest felt difference of a model parameter, by an
    /// adaptive two-interval forced choice.
    Discrimination("discrimination") => discrimination::Discrimination,
    /// Issue 13's toy kind, for tests only: a 1-up-1-down staircase.
    #[cfg(test)]
    Staircase("toy_staircase") => staircase::Staircase,
}
