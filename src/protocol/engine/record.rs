//! What the engine decides of a trial: its record (the session adds its
//! renders and LSL times where it logs it, `results::LoggedTrial`), with the
//! answer and status types the kinds' data use.

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::protocol::kind::Kinds;
use crate::time::Time;

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

/// One trial's record: what the engine decided. As logged, a session adds
/// what only it knows where it writes the record
/// (`results::LoggedTrial`).
#[derive(Debug, Clone, PartialEq)]
pub struct TrialRecord<K: Kinds> {
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
    pub abort_reason: Option<String>,
    /// Aborted and presented again later (this record is not final).
    pub requeued: bool,
    /// The trial's seed.
    pub trial_seed: u64,
    /// Session time at the trial's start, s: a whole number of ticks.
    pub started_s: Time,
    /// Session time at its end, s.
    pub ended_s: Time,
    /// What was presented and answered.
    pub data: K::Data,
}
