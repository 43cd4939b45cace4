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
//! Nothing here reads a clock, draws unseeded randomness, or touches a port.
//! One function touches a file: [`load::read`], the shells' way to read a
//! protocol file (it reads it, and nothing else); [`load::parse`] is the
//! same check on text.
//!
//! # Units
//! SI throughout: seconds, metres, newtons. Friction conditions are the model
//! objects of [`crate::friction::ModelParams`] (`frictionlab models` lists
//! them).

mod check;
pub mod engine;
pub mod load;
pub mod plan;

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::friction::ModelParams;

/// One session design: what a protocol file holds.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Protocol {
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
    /// The study-specific design.
    pub design: Design,
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

/// The design of one of the three kinds of study.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Design {
    /// Seed 000: two renderings, which is nearer to a real surface.
    PairedComparison(PairedDesign),
    /// Seed 001: type a number for how strong the friction felt.
    MagnitudeEstimation(MagnitudeDesign),
    /// Seed 002: reciprocal tapping under friction conditions.
    Fitts(FittsDesign),
}

impl Design {
    /// The kind's name as used in data files.
    #[must_use]
    pub fn kind(&self) -> Kind {
        match self {
            Design::PairedComparison(_) => Kind::PairedComparison,
            Design::MagnitudeEstimation(_) => Kind::MagnitudeEstimation,
            Design::Fitts(_) => Kind::Fitts,
        }
    }
}

/// The three kinds of session.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum Kind {
    /// Paired comparison.
    PairedComparison,
    /// Magnitude estimation.
    MagnitudeEstimation,
    /// Fitts targeting.
    Fitts,
}

impl Kind {
    /// `paired_comparison`, `magnitude_estimation` or `fitts`.
    #[must_use]
    pub fn as_str(self) -> &'static str {
        match self {
            Kind::PairedComparison => "paired_comparison",
            Kind::MagnitudeEstimation => "magnitude_estimation",
            Kind::Fitts => "fitts",
        }
    }
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

/// Seed 000's paired comparison.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct PairedDesign {
    /// Reference phase before the first trial (sliding on a real surface), s.
    pub reference_s: f64,
    /// What the participant does in the reference phase.
    pub reference_instructions: String,
    /// Longest exploration of each stimulus of a pair, s.
    pub exploration_s: f64,
    /// The renderings compared.
    pub conditions: Vec<Condition>,
    /// The pairs, by condition id; each is one trial, its two members
    /// presented in random order.
    pub pairs: Vec<[String; 2]>,
}

/// Seed 001's magnitude estimation.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct MagnitudeDesign {
    /// Longest exploration of a stimulus before the answer, s.
    pub exploration_s: f64,
    /// One set (block) per display.
    pub sets: Vec<MagnitudeSet>,
}

/// One display's set of stimuli.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct MagnitudeSet {
    /// Display name (`tactile`, `force`), logged as `display`.
    pub display: String,
    /// The model every stimulus of the set uses; each stimulus sets its
    /// `mu_s` and `mu_k` (a stick-slip model).
    pub model: ModelParams,
    /// The stimuli.
    pub stimuli: Vec<Stimulus>,
}

/// One magnitude-estimation stimulus.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Stimulus {
    /// Static coefficient (> `mu_k`).
    pub mu_s: f64,
    /// Kinetic coefficient.
    pub mu_k: f64,
}

/// Seed 002's Fitts reciprocal targeting.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct FittsDesign {
    /// Cursor diameter D, m.
    pub cursor_m: f64,
    /// Successful taps per test.
    pub taps: u32,
    /// Index of difficulty formula.
    #[serde(default)]
    pub id_formula: IdFormula,
    /// Target tolerance used for hits and the index of difficulty.
    #[serde(default)]
    pub tolerance: Tolerance,
    /// Longest time for one test before it is ended, s.
    #[serde(default = "fitts_timeout")]
    pub timeout_s: f64,
    /// Friction conditions.
    pub conditions: Vec<FittsCondition>,
    /// Difficulty levels (distance x width).
    pub levels: Vec<FittsLevel>,
    /// Practice block run first, excluded from analysis: condition ids, each
    /// with `practice_levels` (all levels if empty).
    #[serde(default)]
    pub practice: Vec<String>,
    /// Level indices used in practice (empty: all).
    #[serde(default)]
    pub practice_levels: Vec<usize>,
}

fn fitts_timeout() -> f64 {
    60.0
}

/// A Fitts friction condition.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct FittsCondition {
    /// Condition id (`baseline`, `real`, `simulated`, ...).
    pub id: String,
    /// The rendered model (`none` for a physical condition).
    pub model: ModelParams,
    /// A prompt to the experimenter before each test of this condition
    /// (e.g. to attach the aluminum block for `real`); the runner waits for
    /// the experimenter to continue.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub prompt: Option<String>,
    /// For the simulated device: the friction a physical condition adds
    /// (e.g. the aluminum block on rubber); it is not rendered, it is part of
    /// the simulated apparatus. Ignored on a real device.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub physical: Option<ModelParams>,
}

/// A Fitts difficulty level.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct FittsLevel {
    /// Distance A between target centres, m.
    pub amplitude_m: f64,
    /// Target width W, m (> cursor diameter).
    pub width_m: f64,
}

/// Index of difficulty formula (the seed's formula was lost in extraction).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum IdFormula {
    /// Shannon: log2(A / W' + 1) (ISO 9241-9).
    #[default]
    Shannon,
    /// Fitts: log2(2 A / W').
    Fitts,
}

/// Which width W' counts for hits and for the index of difficulty.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum Tolerance {
    /// W' = W - D: the whole cursor must be inside the target.
    #[default]
    WidthMinusCursor,
    /// W' = W: the cursor's centre must be inside the target.
    Width,
}

impl FittsDesign {
    /// Effective target width W' for hits and ID, m.
    #[must_use]
    pub fn effective_width(&self, width_m: f64) -> f64 {
        match self.tolerance {
            Tolerance::WidthMinusCursor => width_m - self.cursor_m,
            Tolerance::Width => width_m,
        }
    }

    /// Index of difficulty of a level, bits.
    #[must_use]
    pub fn id_bits(&self, level: FittsLevel) -> f64 {
        let w = self.effective_width(level.width_m);
        match self.id_formula {
            IdFormula::Shannon => (level.amplitude_m / w + 1.0).log2(),
            IdFormula::Fitts => (2.0 * level.amplitude_m / w).log2(),
        }
    }
}

/// The JSON Schema of protocol files, pretty-printed (as shipped in
/// `protocols/protocol.schema.json`).
#[must_use]
pub fn json_schema() -> String {
    let schema = schemars::schema_for!(Protocol);
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
];
