//! Where a session's trials come from: [`TrialSource`], and [`Plan`] as
//! the fixed case.

use super::TrialRecord;
use crate::protocol::kind::Kinds;
use crate::protocol::plan::{Plan, PlannedTrial};

/// Where a session's trials come from: the trial at each presentation
/// position, given every record logged so far. A fixed [`Plan`] ignores the
/// records; an adaptive source (a staircase) chooses its next stimulus from
/// the answers. A source is a pure function of its arguments: it keeps no
/// state of its own, so a resumed session rebuilds it exactly by handing it
/// the logged records.
pub trait TrialSource<K: Kinds>: std::fmt::Debug + Send + Sync {
    /// The trial to present at position `index` (0-based), given the
    /// session's records so far in log order (re-queued ones included);
    /// `None` when the session is over.
    fn trial(&self, index: usize, history: &[TrialRecord<K>]) -> Option<PlannedTrial<K>>;
    /// How many trials the session will have, if known in advance.
    fn planned(&self) -> Option<usize>;
    /// The haptic loop rate the session's models need, Hz.
    fn loop_rate_hz(&self) -> f64;
}

impl<K: Kinds> TrialSource<K> for Plan<K> {
    fn trial(&self, index: usize, _: &[TrialRecord<K>]) -> Option<PlannedTrial<K>> {
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
            .map(|t| K::loop_rate_hz(&t.spec))
            .fold(1000.0, f64::max)
    }
}

/// The first position not yet finally logged: where a resume starts. A
/// trial is final when completed, or aborted and not re-queued.
#[must_use]
pub fn next_position<'a, K: Kinds + 'a>(
    history: impl IntoIterator<Item = &'a TrialRecord<K>>,
) -> usize {
    history
        .into_iter()
        .filter(|r| !r.requeued)
        .map(|r| r.trial + 1)
        .max()
        .unwrap_or(0)
}
