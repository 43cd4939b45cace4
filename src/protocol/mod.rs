//! Protocols: the design of a session, loaded in two stages, and the engine
//! that runs it.
//!
//! 1. [`load`]: the raw file is parsed and checked, and *every* error is
//!    reported with its JSON path (`design.conditions[2].model.mu_s`) and reason.
//! 2. [`plan`]: the checked protocol is resolved into a [`plan::Plan`]
//!    holding every trial in presentation order, drawn from the seed before
//!    the first trial starts.
//! 3. [`engine`]: a sans-IO state machine that runs a session's trials
//!    (from a [`engine::TrialSource`]: the plan, or a source that adapts to
//!    the answers): inputs (time, clicks, answers, experimenter commands)
//!    in, actions (render this model, show or ask this, write this record)
//!    out, and the time it next wants to be woken.
//!
//! What differs between kinds of study (each kind's design, its checks,
//! its trials, its live trial) is in the kinds' folders above this layer.
//! The loader, the plan and the engine are written against the traits of
//! [`kind`] and name no kind: the registry hands them its set of kinds as
//! the type parameter `K` ([`kind::Kinds`]).
//!
//! Nothing here reads a clock, draws unseeded randomness, or touches a port.
//! One function touches a file: [`load::read`], the shells' way to read a
//! protocol file (it reads it, and nothing else); [`load::parse`] is the
//! same check on text.
//!
//! # Units
//! SI throughout: seconds, metres, newtons. Friction conditions are the model
//! objects of [`crate::friction::ModelParams`] (`frictionlab models` lists
//! them).

pub mod check;
pub mod engine;
pub mod form;
pub mod kind;
pub mod load;
pub mod plan;
pub mod validation;

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::friction::ModelParams;
use kind::Kinds;

// `K` is the set of kinds the design may be of: the registry's
// (`Registry` in `src/kinds/mod.rs`), handed down from above.
/// One session design: what a protocol file holds.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, bound = "")]
#[schemars(rename = "Protocol", bound = "")]
pub struct Protocol<K: Kinds> {
    /// Optional pointer to the JSON Schema, for editors.
    #[serde(rename = "$schema", default, skip_serializing_if = "Option::is_none")]
    pub schema: Option<String>,
    /// Study id, used in result file names (letters and digits kept).
    pub id: String,
    /// Human title.
    pub title: String,
    /// What the study is for; where its design comes from.
    #[serde(default)]
    pub description: String,
    /// Order of trials within a block.
    #[serde(default)]
    pub randomization: Randomization,
    /// How often each block's trial list is presented (>= 1).
    #[serde(default = "one")]
    pub repetitions: u32,
    /// Order of the (non-practice) blocks across participants.
    #[serde(default)]
    pub block_order: BlockOrder,
    /// Break between blocks, s (0: none).
    #[serde(default)]
    pub break_s: f64,
    /// Instructions shown before the first trial.
    #[serde(default)]
    pub instructions: String,
    /// Masking noise on headphones (seed 001: pink noise), played on
    /// `--masking-audio`; a session that asks for it does not run without
    /// it. The simulated participant hears nothing: `simulate` and the
    /// replays ignore it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub masking: Option<crate::audio::Masking>,
    /// The study-specific design.
    pub design: K::Design,
    /// The human experiments this protocol redoes, one row each, and the
    /// bands a replay with simulated participants is judged by
    /// (`frictionlab validation`); a session ignores them.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub validation: Vec<validation::Validation>,
}

impl<K: Kinds> Protocol<K> {
    /// The kind of study (its design's `kind`).
    #[must_use]
    pub fn kind(&self) -> &'static str {
        K::design_kind(&self.design)
    }

    /// "`n` trials per session", or, for a kind whose trials adapt to the
    /// answers, that they decide.
    #[must_use]
    pub fn trials_per_session(&self) -> String {
        match K::source(self, 0, 0).planned() {
            Some(1) => "1 trial per session".to_owned(),
            Some(n) => format!("{n} trials per session"),
            None => "trials set by the answers".to_owned(),
        }
    }
}

fn one() -> u32 {
    1
}

/// Order of trials within a block.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum Randomization {
    /// As listed, every repetition.
    Sequential,
    /// Shuffled, reshuffled for each repetition.
    #[default]
    Random,
    /// All repetitions of the block's trials shuffled together.
    FullRandom,
}

/// Order of the non-practice blocks.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum BlockOrder {
    /// As listed.
    #[default]
    Fixed,
    /// Counterbalanced: a balanced Latin square (Williams design) row chosen by
    /// the participant index.
    LatinSquare,
}

/// A named friction rendering.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Condition {
    /// Condition id (letters, digits, `-`, `_`).
    pub id: String,
    /// The friction model and its parameters.
    pub model: ModelParams,
}

/// The JSON Schema of protocol files, pretty-printed (as shipped in
/// `protocols/protocol.schema.json`).
#[must_use]
pub fn json_schema<K: Kinds>() -> String {
    let schema = schemars::schema_for!(Protocol<K>);
    serde_json::to_string_pretty(&schema).unwrap_or_default() + "\n"
}

/// The protocols shipped in `protocols/`, built into the binary so the GUI
/// lists them wherever it runs: (file name, file text).
pub const SHIPPED: &[(&str, &str)] = &[
    (
        "magnitude-quick.json",
        include_str!("../../protocols/magnitude-quick.json"),
    ),
    (
        "magnitude-estimation.json",
        include_str!("../../protocols/magnitude-estimation.json"),
    ),
    (
        "paired-quick.json",
        include_str!("../../protocols/paired-quick.json"),
    ),
    (
        "paired-comparison.json",
        include_str!("../../protocols/paired-comparison.json"),
    ),
    (
        "fitts-quick.json",
        include_str!("../../protocols/fitts-quick.json"),
    ),
    ("fitts.json", include_str!("../../protocols/fitts.json")),
    (
        "discrimination-quick.json",
        include_str!("../../protocols/discrimination-quick.json"),
    ),
    (
        "discrimination.json",
        include_str!("../../protocols/discrimination.json"),
    ),
];
