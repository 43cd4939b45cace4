//! Which render each stream row shows: the session numbers every model it
//! sends to the device (and every restart of the simulated device's
//! model), the device reports the number in effect each tick, and each
//! trial's record lists the renders its stream shows ([`RenderEntry`]),
//! which the stream's `render` column indexes. That is what
//! `frictionlab rerender` renders again.

use std::collections::VecDeque;

use crate::friction::ModelParams;
use crate::results::{RenderEntry, RenderMode};

/// Renders sent that a tick may still report.
const KEPT: usize = 16;

/// How a tick's render was stepped.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct How {
    /// Who rendered it.
    pub mode: RenderMode,
    /// The float it was stepped in.
    pub float: crate::friction::Float,
    /// Loop rate, Hz.
    pub rate_hz: f64,
    /// Crossfade from the previous render, s.
    pub ramp_s: f64,
    /// Force limit, N.
    pub force_limit_n: f64,
}

/// The session's renders: see the module docs.
#[derive(Debug, Clone)]
pub(super) struct Renders {
    next: u32,
    sent: VecDeque<(u32, Option<ModelParams>)>,
    trial: Vec<RenderEntry>,
    numbers: Vec<u32>,
}

impl Default for Renders {
    fn default() -> Self {
        Renders {
            next: 0,
            sent: VecDeque::from([(0, None)]),
            trial: Vec::new(),
            numbers: Vec::new(),
        }
    }
}

impl Renders {
    /// Numbers a render of `model` about to be sent.
    pub fn send(&mut self, model: Option<ModelParams>) -> u32 {
        self.next += 1;
        if self.sent.len() == KEPT {
            self.sent.pop_front();
        }
        self.sent.push_back((self.next, model));
        self.next
    }

    /// The model last sent.
    pub fn last_model(&self) -> Option<ModelParams> {
        self.sent.back().and_then(|(_, m)| m.clone())
    }

    /// The index in this trial's renders of render `render`, stepped as
    /// `how` (a render no longer known rendered nothing: a device that
    /// restarted).
    #[inline]
    pub fn row(&mut self, render: u32, how: How) -> usize {
        // Every tick asks; the render seldom changes.
        if self.numbers.last() == Some(&render) {
            return self.numbers.len() - 1;
        }
        self.add_row(render, how)
    }

    fn add_row(&mut self, render: u32, how: How) -> usize {
        let model = self
            .sent
            .iter()
            .find(|(r, _)| *r == render)
            .and_then(|(_, m)| m.clone());
        self.numbers.push(render);
        self.trial.push(RenderEntry {
            model,
            mode: how.mode,
            float: how.float,
            rate_hz: how.rate_hz,
            ramp_s: how.ramp_s,
            force_limit_n: how.force_limit_n,
        });
        self.trial.len() - 1
    }

    /// This trial's renders; the next trial starts afresh.
    pub fn take(&mut self) -> Vec<RenderEntry> {
        self.numbers.clear();
        std::mem::take(&mut self.trial)
    }
}
