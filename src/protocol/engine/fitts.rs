//! A Fitts reciprocal tapping test live (the hit and miss rules are in the
//! engine's module docs): the condition's model is rendered, each hit
//! switches the lit target, the test ends after its taps or at its time
//! limit (aborted, reason `timeout`).

use std::collections::VecDeque;

use super::{Action, Input, LiveTrial, Next, Screen, TrialData};
use crate::protocol::plan::FittsTrial;

/// The live state.
#[derive(Debug, Clone)]
pub(super) struct Tapping {
    trial: FittsTrial,
    lit: usize,
    centres: [f64; 2],
    deadline: f64,
    tap_times: Vec<f64>,
    tap_x: Vec<f64>,
    target_x: Vec<f64>,
    miss_x: Vec<f64>,
    miss_size: Vec<f64>,
}

impl Tapping {
    /// Sets the condition's physical friction, renders its model and lights
    /// the target at `-A/2`.
    pub(super) fn start(trial: &FittsTrial, now: f64, out: &mut VecDeque<Action>) -> Self {
        let a = trial.amplitude_m;
        let t = Tapping {
            trial: trial.clone(),
            lit: 0,
            centres: [-a / 2.0, a / 2.0],
            deadline: now + trial.timeout_s,
            tap_times: Vec::new(),
            tap_x: Vec::new(),
            target_x: Vec::new(),
            miss_x: Vec::new(),
            miss_size: Vec::new(),
        };
        out.push_back(Action::Physical(trial.physical.clone()));
        out.push_back(Action::Render(Some(trial.model.clone())));
        out.push_back(t.screen(false));
        t
    }

    fn screen(&self, missed: bool) -> Action {
        Action::Show(Screen::Fitts {
            lit_m: self.centres[self.lit],
            other_m: self.centres[1 - self.lit],
            width_m: self.trial.width_m,
            cursor_m: self.trial.cursor_m,
            missed,
        })
    }

    fn click(&mut self, now: f64, x: f64, out: &mut VecDeque<Action>) -> Next {
        let half = self.trial.effective_width_m / 2.0;
        let centre = self.centres[self.lit];
        let distance = (x - centre).abs();
        let hit = distance <= half;
        if hit {
            self.tap_times.push(now);
            self.tap_x.push(x);
            self.target_x.push(centre);
            if self.tap_times.len() >= self.trial.taps as usize {
                return Next::Finish(None);
            }
            self.lit = 1 - self.lit;
        } else {
            self.miss_x.push(x);
            self.miss_size.push(distance - half);
        }
        out.push_back(self.screen(!hit));
        Next::Stay
    }
}

impl LiveTrial for Tapping {
    fn timeout(&self) -> Option<f64> {
        Some(self.deadline)
    }

    fn on_timeout(&mut self, _now: f64, _out: &mut VecDeque<Action>) -> Next {
        Next::Finish(Some("timeout".into()))
    }

    fn on_input(&mut self, now: f64, input: Input, out: &mut VecDeque<Action>) -> Next {
        match input {
            Input::Click { x_m } if x_m.is_finite() => self.click(now, x_m, out),
            _ => Next::Stay,
        }
    }

    fn data(&self, _started: f64, _now: f64, completed: bool) -> TrialData {
        let g = &self.trial;
        let errors = self.miss_size.len();
        TrialData::Fitts {
            condition: g.condition.clone(),
            amplitude_m: g.amplitude_m,
            width_m: g.width_m,
            cursor_m: g.cursor_m,
            effective_width_m: g.effective_width_m,
            id_bits: g.id_bits,
            completion_time_s: match (self.tap_times.first(), self.tap_times.last()) {
                (Some(a), Some(b)) if completed => Some(b - a),
                _ => None,
            },
            taps: u32::try_from(self.tap_times.len()).unwrap_or(u32::MAX),
            errors: u32::try_from(errors).unwrap_or(u32::MAX),
            mean_error_m: (errors > 0).then(|| self.miss_size.iter().sum::<f64>() / errors as f64),
            tap_times_s: self.tap_times.clone(),
            tap_x_m: self.tap_x.clone(),
            target_x_m: self.target_x.clone(),
            miss_x_m: self.miss_x.clone(),
        }
    }
}
