//! What the engine logs: a trial's record and its kind-specific data.

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

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
