//! What the engine logs: a trial's record and its kind-specific data.

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

/// One trial's record, as logged.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, bound = "")]
#[schemars(rename = "TrialRecord", bound = "")]
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
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub abort_reason: Option<String>,
    /// Aborted and presented again later (this record is not final).
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub requeued: bool,
    /// The trial's seed.
    pub trial_seed: u64,
    /// Session time at the trial's start, s: a whole number of ticks
    /// (format 2; a format 1 log's float sum reads to the nearest ns).
    pub started_s: Time,
    /// Session time at its end, s.
    pub ended_s: Time,
    /// What was presented and answered.
    pub data: K::Data,
    /// What rendered the trial's friction, one entry per render the
    /// trial's stream shows, in order; the stream's `render` column indexes
    /// it. Filled by the session (the engine knows no device); absent in
    /// logs from before it existed.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub rendering: Vec<RenderEntry>,
    /// LSL time (`lsl_local_clock`) of the trial's start, s: the
    /// timestamp of its `trial_start` marker. Only in a session published
    /// on the Lab Streaming Layer (`--lsl`); filled by the session.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lsl_start_s: Option<f64>,
    /// LSL time of its end, s: the timestamp of its `trial_end` marker.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lsl_end_s: Option<f64>,
}

/// Who rendered a model: the simulated apparatus, the host's haptic loop
/// commanding force over the link, or the device itself.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum RenderMode {
    /// The simulated apparatus (no crossfade: models switch at once).
    Simulated,
    /// The host's haptic loop, one force command per tick.
    HostLoop,
    /// On board the device (wire protocol v2), from its telemetry.
    OnBoard,
}

/// One render of a trial: the model and how it was stepped, enough to
/// render it again over the recorded motion (`frictionlab rerender`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct RenderEntry {
    /// The model, or nothing.
    pub model: Option<crate::friction::ModelParams>,
    /// Who rendered it.
    pub mode: RenderMode,
    /// The float it was stepped in.
    pub float: crate::friction::Float,
    /// Loop rate, Hz.
    pub rate_hz: f64,
    /// Crossfade from the previous render, s (0: at once).
    pub ramp_s: f64,
    /// Force limit, N.
    pub force_limit_n: f64,
}
