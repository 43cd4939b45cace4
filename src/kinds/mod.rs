//! The registry of the study kinds: the one file that names them all.
//!
//! Each kind lives in its own folder, `src/kinds/<kind>/`: its design
//! (protocol part and checks), its trials and where they come from, its
//! live trial, its logged data and data-CSV cells (`mod.rs`, the
//! [`StudyKind`]), its analysis (`analysis.rs`, the [`KindAnalysis`]) and
//! its report section (`report.rs`). A kind imports only from the layers
//! below it (ARCHITECTURE.md), never from this file.
//!
//! The registry (`kinds!` at the end of this file) declares each kind's
//! folder and generates the tagged unions of their parts ([`Design`],
//! [`TrialSpec`], [`TrialData`], [`LiveState`]) and [`Registry`], the set
//! of kinds that implements the protocol core's [`Kinds`], each kind's
//! [`Holds`], and the analysis's [`AnalysedKinds`]. The layers above (the
//! session, power, the window, the command line) get the kinds from here,
//! through `Registry` and the type aliases below ([`Protocol`], [`Engine`],
//! [`TrialRecord`], ...). Adding a kind is a new folder and one registry
//! line.
//!
//! The simulated participant and the window answer what a trial shows and
//! asks (`Screen`, `Question`), not the kind: a kind that reuses existing
//! screens needs no participant or GUI code. A kind with a look of its own
//! shows its own screen (`OwnScreen`), which sets one of those tasks and is
//! drawn by its `view.rs`'s `SCREEN`, reached through [`screen_view`].
//!
//! A kind's results view (`view.rs`: its figures and key statistics, drawn
//! from its object of `summary.json`) is reached through
//! [`results_view`], which the registry line generates; [`figures`] holds
//! what the views share.

use std::collections::VecDeque;
use std::sync::Arc;

use rand_chacha::ChaCha8Rng;
use schemars::JsonSchema;
use serde::{Deserialize, Serialize};
use serde_json::Value;

use crate::analysis::{AnalysedKinds, AnalysisEntry, KindAnalysis};
use crate::protocol::check::ValueChecks;
use crate::protocol::engine::{self, Input, TrialSource};
use crate::protocol::kind::{
    Block, Holds, KindInfo, Kinds, LiveTrial, Next, Quality, Reach, StudyKind, TrackAnswers,
};
use crate::protocol::load::Walk;
use crate::protocol::{self, plan};
use crate::time::Time;

pub mod figures;
mod tagged;

/// A protocol of the registered kinds.
pub type Protocol = protocol::Protocol<Registry>;
/// A session plan of the registered kinds.
pub type Plan = plan::Plan<Registry>;
/// A planned trial of the registered kinds.
pub type PlannedTrial = plan::PlannedTrial<Registry>;
/// The session engine for the registered kinds.
pub type Engine = engine::Engine<Registry>;
/// What the engine asks the shell to do.
pub type Action = engine::Action<Registry>;
/// A trial's record of the registered kinds, as the engine decided it.
pub type TrialRecord = engine::TrialRecord<Registry>;
/// A trial's record as logged, with what the session added.
pub type LoggedTrial = crate::results::LoggedTrial<Registry>;
/// A session log's header.
pub type Header = crate::results::Header<Registry>;
/// One session-log line.
pub type LogLine = crate::results::LogLine<Registry>;
/// A session log as read back.
pub type ReadLog = crate::results::ReadLog<Registry>;

/// The registry: one line per kind, `Variant("name") => module::Type`
/// (doc comment first, `#[cfg(...)]` allowed), which also declares the
/// kind's folder (`src/kinds/<module>/`). `name` is the kind's tag in
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

        // Read tag first, without serde's buffering (`tagged.rs`); its
        // doc comment below is the log schema's description of it.
        /// The kind-specific part of a record.
        #[derive(Debug, Clone, PartialEq, Serialize, JsonSchema)]
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

        /// [`TrialData`] read the general way (serde's tagged union), for
        /// data whose `kind` is not its first key.
        #[derive(Deserialize)]
        #[serde(tag = "kind")]
        #[allow(
            clippy::large_enum_variant,
            reason = "read once, then moved into a TrialData"
        )]
        enum TaggedData {
            $(
                $(#[cfg($cfg)])?
                #[serde(rename = $name)]
                $variant(<$module::$kind as StudyKind>::Data),
            )*
        }

        impl From<TaggedData> for TrialData {
            fn from(data: TaggedData) -> Self {
                match data {
                    $($(#[cfg($cfg)])? TaggedData::$variant(d) => TrialData::$variant(d),)*
                }
            }
        }

        impl<'de> Deserialize<'de> for TrialData {
            fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
                const NAMES: &[&str] = &[$($(#[cfg($cfg)])? $name,)*];
                struct Data;
                impl<'de> serde::de::Visitor<'de> for Data {
                    type Value = TrialData;
                    fn expecting(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                        f.write_str("a trial's data, tagged by its kind")
                    }
                    fn visit_map<A: serde::de::MapAccess<'de>>(self, map: A) -> Result<TrialData, A::Error> {
                        tagged::read_tagged(
                            map,
                            NAMES,
                            |kind, rest| match kind {
                                $($(#[cfg($cfg)])? $name => Deserialize::deserialize(rest).map(TrialData::$variant),)*
                                other => Err(serde::de::Error::unknown_variant(other, NAMES)),
                            },
                            |object| serde_json::from_value::<TaggedData>(object).map(TrialData::from),
                        )
                    }
                }
                d.deserialize_map(Data)
            }
        }

        /// A live trial of each kind, for the engine.
        #[derive(Debug, Clone)]
        pub enum LiveState {
            $(
                $(#[doc = $doc])*
                $(#[cfg($cfg)])?
                $variant(Box<<$module::$kind as StudyKind>::Live>),
            )*
        }

        /// The registered kinds, as one set ([`Kinds`]).
        #[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
        pub struct Registry;

        impl Design {
            /// The kind of study.
            #[must_use]
            pub fn kind(&self) -> &'static str {
                match self {
                    $($(#[cfg($cfg)])? Design::$variant(_) => $name,)*
                }
            }
        }

        impl TrialSpec {
            /// The haptic loop rate its models need, Hz.
            #[must_use]
            pub fn loop_rate_hz(&self) -> f64 {
                Registry::loop_rate_hz(self)
            }
        }

        impl Registry {
            /// The adaptive tracks of a session's records so far, each
            /// kind's ([`StudyKind::tracks`]): the experimenter's live plot.
            #[must_use]
            pub fn tracks(history: &[TrialRecord]) -> Vec<TrackAnswers> {
                let mut out = Vec::new();
                $(
                    $(#[cfg($cfg)])?
                    out.extend(<$module::$kind as StudyKind>::tracks::<Registry>(history));
                )*
                out
            }
        }

        impl TrialData {
            /// The data-CSV cells, one per column of its kind.
            #[must_use]
            pub fn row(&self) -> Vec<String> {
                crate::results::csv::cells(|out| Registry::row(self, out))
            }
        }

        impl Kinds for Registry {
            type Design = Design;
            type Trial = TrialSpec;
            type Data = TrialData;
            type Live = LiveState;

            const KINDS: &'static [KindInfo] = &[$(
                $(#[cfg($cfg)])?
                KindInfo { name: $name, columns: <$module::$kind as StudyKind>::COLUMNS },
            )*];

            fn design_kind(design: &Design) -> &'static str {
                design.kind()
            }

            fn read_design(w: &mut Walk, v: &Value, path: &str) -> Option<Design> {
                let kind = v.get("kind").and_then(Value::as_str);
                match kind {
                    $(
                        $(#[cfg($cfg)])?
                        Some($name) => <$module::$kind as StudyKind>::read(w, v, path).map(Design::$variant),
                    )*
                    _ => {
                        w.unknown_kind::<Registry>(path, kind);
                        None
                    }
                }
            }

            fn template(kind: &str) -> Option<Value> {
                match kind {
                    $($(#[cfg($cfg)])? $name => Some(<$module::$kind as StudyKind>::template()),)*
                    _ => None,
                }
            }

            fn check_design(design: &Design, c: &mut ValueChecks) {
                match design {
                    $($(#[cfg($cfg)])? Design::$variant(d) => <$module::$kind as StudyKind>::check(d, c),)*
                }
            }

            fn trials_per_repetition(design: &Design) -> u64 {
                match design {
                    $($(#[cfg($cfg)])? Design::$variant(d) => <$module::$kind as StudyKind>::trials_per_repetition(d),)*
                }
            }

            fn blocks(design: &Design) -> Vec<Block<TrialSpec>> {
                match design {
                    $(
                        $(#[cfg($cfg)])?
                        Design::$variant(d) => <$module::$kind as StudyKind>::blocks(d)
                            .into_iter()
                            .map(|b| b.map(TrialSpec::$variant))
                            .collect(),
                    )*
                }
            }

            fn reference(design: &Design) -> Option<(&str, f64)> {
                match design {
                    $($(#[cfg($cfg)])? Design::$variant(d) => <$module::$kind as StudyKind>::reference(d),)*
                }
            }

            fn source(
                protocol: &Protocol,
                seed: u64,
                participant_index: u32,
            ) -> Arc<dyn TrialSource<Registry>> {
                match &protocol.design {
                    $(
                        $(#[cfg($cfg)])?
                        Design::$variant(d) => {
                            <$module::$kind as StudyKind>::source(protocol, d, seed, participant_index)
                        }
                    )*
                }
            }

            fn preferable(design: &Design) -> Option<Vec<&str>> {
                match design {
                    $($(#[cfg($cfg)])? Design::$variant(d) => <$module::$kind as StudyKind>::preferable(d),)*
                }
            }

            fn reach(design: &Design) -> Vec<Reach> {
                match design {
                    $($(#[cfg($cfg)])? Design::$variant(d) => <$module::$kind as StudyKind>::reach(d),)*
                }
            }

            fn loop_rate_hz(trial: &TrialSpec) -> f64 {
                match trial {
                    $($(#[cfg($cfg)])? TrialSpec::$variant(t) => <$module::$kind as StudyKind>::loop_rate_hz(t),)*
                }
            }

            fn prompt(trial: &TrialSpec) -> Option<&str> {
                match trial {
                    $($(#[cfg($cfg)])? TrialSpec::$variant(t) => <$module::$kind as StudyKind>::prompt(t),)*
                }
            }

            fn draw(trial: TrialSpec, rng: &mut ChaCha8Rng) -> TrialSpec {
                match trial {
                    $(
                        $(#[cfg($cfg)])?
                        TrialSpec::$variant(t) => TrialSpec::$variant(<$module::$kind as StudyKind>::draw(t, rng)),
                    )*
                }
            }

            fn preferable_stimuli(trial: &TrialSpec) -> Vec<&str> {
                match trial {
                    $($(#[cfg($cfg)])? TrialSpec::$variant(t) => <$module::$kind as StudyKind>::preferable_stimuli(t),)*
                }
            }

            fn judged(trial: &TrialSpec) -> Quality {
                match trial {
                    $($(#[cfg($cfg)])? TrialSpec::$variant(t) => <$module::$kind as StudyKind>::judged(t),)*
                }
            }

            fn data_kind(data: &TrialData) -> &'static str {
                match data {
                    $($(#[cfg($cfg)])? TrialData::$variant(_) => $name,)*
                }
            }

            fn row<W: crate::protocol::kind::WriteCells>(data: &TrialData, out: &mut W) {
                match data {
                    $($(#[cfg($cfg)])? TrialData::$variant(d) => <$module::$kind as StudyKind>::row(d, out),)*
                }
            }

            fn start(trial: &TrialSpec, now: Time, out: &mut VecDeque<Action>) -> LiveState {
                match trial {
                    $(
                        $(#[cfg($cfg)])?
                        TrialSpec::$variant(t) => {
                            LiveState::$variant(Box::new(<$module::$kind as StudyKind>::start(t, now, out)))
                        }
                    )*
                }
            }

            fn timeout(live: &LiveState) -> Option<Time> {
                match live {
                    $($(#[cfg($cfg)])? LiveState::$variant(t) => t.timeout(),)*
                }
            }

            fn on_timeout(live: &mut LiveState, now: Time, out: &mut VecDeque<Action>) -> Next {
                match live {
                    $($(#[cfg($cfg)])? LiveState::$variant(t) => t.on_timeout(now, out),)*
                }
            }

            fn on_input(
                live: &mut LiveState,
                now: Time,
                input: Input,
                out: &mut VecDeque<Action>,
            ) -> Next {
                match live {
                    $($(#[cfg($cfg)])? LiveState::$variant(t) => t.on_input(now, input, out),)*
                }
            }

            fn data(live: &LiveState, started: Time, now: Time, completed: bool) -> TrialData {
                match live {
                    $(
                        $(#[cfg($cfg)])?
                        LiveState::$variant(t) => TrialData::$variant(t.data(started, now, completed)),
                    )*
                }
            }
        }

        $(
            $(#[cfg($cfg)])?
            impl Holds<$module::$kind> for Registry {
                fn wrap_trial(trial: <$module::$kind as StudyKind>::Trial) -> TrialSpec {
                    TrialSpec::$variant(trial)
                }

                #[allow(unreachable_patterns, reason = "a registry of one kind")]
                fn data_of(data: &TrialData) -> Option<&<$module::$kind as StudyKind>::Data> {
                    match data {
                        TrialData::$variant(d) => Some(d),
                        _ => None,
                    }
                }

                #[allow(unreachable_patterns, reason = "a registry of one kind")]
                fn design_of(design: &Design) -> Option<&<$module::$kind as StudyKind>::Design> {
                    match design {
                        Design::$variant(d) => Some(d),
                        _ => None,
                    }
                }
            }
        )*

        /// The results view of the kind whose object of `summary.json` is
        /// under `key` (its name), from its folder's `view.rs`; `None` for
        /// another key, or a kind without one (the window shows the object
        /// as a tree).
        #[must_use]
        pub fn results_view(key: &str) -> Option<figures::ResultsView> {
            match key {
                $($(#[cfg($cfg)])? $name => $module::view::VIEW,)*
                _ => None,
            }
        }

        /// How the kind named `kind` draws its own screens, from its
        /// folder's `view.rs`; `None` for a kind without (it shows only
        /// shared screens).
        #[must_use]
        pub fn screen_view(kind: &str) -> Option<figures::ScreenView> {
            match kind {
                $($(#[cfg($cfg)])? $name => $module::view::SCREEN,)*
                _ => None,
            }
        }

        impl AnalysedKinds for Registry {
            #[allow(clippy::vec_init_then_push, reason = "a push per kind, some under cfg")]
            fn analyses() -> Vec<(&'static str, Option<AnalysisEntry<Registry>>)> {
                let mut all = Vec::new();
                $(
                    $(#[cfg($cfg)])?
                    all.push(($name, <$module::$kind as KindAnalysis>::analysis::<Registry>()));
                )*
                all
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
