//! A trial as logged: the engine's record ([`TrialRecord`]) and what the
//! session adds where it writes it (the renders that ran the trial, its LSL
//! times). On disk it is one flat object (`"type": "trial"` and the fields
//! of `TrialLine`, the log schema's `TrialRecord`).

use std::borrow::Cow;

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::protocol::engine::{Status, TrialRecord};
use crate::protocol::kind::Kinds;
use crate::time::Time;

/// A trial's record as the log keeps it: what the engine decided, and what
/// the session added where it wrote it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(from = "TrialLine<K>", into = "TrialLine<K>", bound = "")]
pub struct LoggedTrial<K: Kinds> {
    /// What the engine decided.
    pub record: TrialRecord<K>,
    /// What rendered the trial's friction, one entry per render, in order
    /// (the stream's `render` column indexes it); empty in logs from
    /// before it existed.
    pub rendering: Vec<RenderEntry>,
    /// LSL time of the trial's start, s (a session published on LSL).
    pub lsl_start_s: Option<f64>,
    /// LSL time of its end, s.
    pub lsl_end_s: Option<f64>,
}

impl<K: Kinds> LoggedTrial<K> {
    /// The engine's record, with nothing added yet.
    #[must_use]
    pub fn new(record: TrialRecord<K>) -> Self {
        Self {
            record,
            rendering: Vec::new(),
            lsl_start_s: None,
            lsl_end_s: None,
        }
    }
}

impl<K: Kinds> std::ops::Deref for LoggedTrial<K> {
    type Target = TrialRecord<K>;

    fn deref(&self) -> &TrialRecord<K> {
        &self.record
    }
}

/// The log's schema of a trial line is [`TrialLine`]'s (named `TrialRecord`).
impl<K: Kinds> JsonSchema for LoggedTrial<K> {
    fn schema_name() -> Cow<'static, str> {
        TrialLine::<K>::schema_name()
    }

    fn schema_id() -> Cow<'static, str> {
        TrialLine::<K>::schema_id()
    }

    fn inline_schema() -> bool {
        TrialLine::<K>::inline_schema()
    }

    fn json_schema(generator: &mut schemars::SchemaGenerator) -> schemars::Schema {
        TrialLine::<K>::json_schema(generator)
    }
}

impl<K: Kinds> From<TrialLine<K>> for LoggedTrial<K> {
    fn from(l: TrialLine<K>) -> Self {
        Self {
            record: TrialRecord {
                trial: l.trial,
                block: l.block,
                block_index: l.block_index,
                practice: l.practice,
                repetition: l.repetition,
                status: l.status,
                abort_reason: l.abort_reason,
                requeued: l.requeued,
                trial_seed: l.trial_seed,
                started_s: l.started_s,
                ended_s: l.ended_s,
                data: l.data,
            },
            rendering: l.rendering,
            lsl_start_s: l.lsl_start_s,
            lsl_end_s: l.lsl_end_s,
        }
    }
}

impl<K: Kinds> From<LoggedTrial<K>> for TrialLine<K> {
    fn from(t: LoggedTrial<K>) -> Self {
        let r = t.record;
        Self {
            trial: r.trial,
            block: r.block,
            block_index: r.block_index,
            practice: r.practice,
            repetition: r.repetition,
            status: r.status,
            abort_reason: r.abort_reason,
            requeued: r.requeued,
            trial_seed: r.trial_seed,
            started_s: r.started_s,
            ended_s: r.ended_s,
            data: r.data,
            rendering: t.rendering,
            lsl_start_s: t.lsl_start_s,
            lsl_end_s: t.lsl_end_s,
        }
    }
}

// One trial's line in the log, field by field: the on-disk form of a
// `LoggedTrial`. Its doc comments are the log schema's descriptions.
/// One trial's record, as logged.
#[derive(Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, bound = "")]
#[schemars(rename = "TrialRecord", bound = "")]
struct TrialLine<K: Kinds> {
    /// Planned trial index (0-based presentation order).
    trial: usize,
    /// Block name.
    block: String,
    /// Block position in the session.
    block_index: usize,
    /// Practice trial (excluded from analysis).
    practice: bool,
    /// Repetition of the block's list.
    repetition: u32,
    /// Completed or aborted.
    status: Status,
    /// Why it was aborted.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    abort_reason: Option<String>,
    /// Aborted and presented again later (this record is not final).
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    requeued: bool,
    /// The trial's seed.
    trial_seed: u64,
    /// Session time at the trial's start, s: a whole number of ticks
    /// (format 2; a format 1 log's float sum reads to the nearest ns).
    started_s: Time,
    /// Session time at its end, s.
    ended_s: Time,
    /// What was presented and answered.
    data: K::Data,
    /// What rendered the trial's friction, one entry per render the
    /// trial's stream shows, in order; the stream's `render` column indexes
    /// it. Filled by the session (the engine knows no device); absent in
    /// logs from before it existed.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    rendering: Vec<RenderEntry>,
    /// LSL time (`lsl_local_clock`) of the trial's start, s: the
    /// timestamp of its `trial_start` marker. Only in a session published
    /// on the Lab Streaming Layer (`--lsl`); filled by the session.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    lsl_start_s: Option<f64>,
    /// LSL time of its end, s: the timestamp of its `trial_end` marker.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    lsl_end_s: Option<f64>,
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
