//! A magnitude-estimation trial live: the stimulus is rendered until the
//! exploration time is up (then the question is asked), and any time until
//! then the participant may type a number.

use std::collections::VecDeque;

use super::{Action, Answer, Exploration, Input, LiveTrial, Next, Question, Screen, TrialData};
use crate::protocol::plan::MagnitudeTrial;

/// Checks a typed magnitude: a finite number greater than zero.
///
/// # Errors
/// Why the text is refused, for the participant.
pub fn parse_magnitude(text: &str) -> Result<f64, String> {
    let t = text.trim();
    if t.is_empty() {
        return Err("please type a number".into());
    }
    let x: f64 = t.parse().map_err(|_| format!("'{t}' is not a number"))?;
    if !x.is_finite() {
        Err("please type a finite number".into())
    } else if x <= 0.0 {
        Err("please type a number greater than zero".into())
    } else {
        Ok(x)
    }
}

/// The live state; `time` asks the question when the exploration is over.
#[derive(Debug, Clone)]
pub(super) struct Explore {
    display: String,
    mu_s: f64,
    mu_k: f64,
    time: Exploration,
    magnitude: Option<f64>,
}

impl Explore {
    /// Renders the stimulus's model and shows the exploration screen until
    /// `now + exploration_s`.
    pub(super) fn start(trial: &MagnitudeTrial, now: f64, out: &mut VecDeque<Action>) -> Self {
        let until = now + trial.exploration_s;
        out.push_back(Action::Render(Some(trial.model.clone())));
        out.push_back(Action::Show(Screen::Explore { until_s: until }));
        Explore {
            display: trial.display.clone(),
            mu_s: trial.mu_s,
            mu_k: trial.mu_k,
            time: Exploration::until(until),
            magnitude: None,
        }
    }
}

impl LiveTrial for Explore {
    fn timeout(&self) -> Option<f64> {
        self.time.timeout()
    }

    fn on_timeout(&mut self, _now: f64, out: &mut VecDeque<Action>) -> Next {
        self.time.expire(Question::Magnitude, out)
    }

    fn on_input(&mut self, _now: f64, input: Input, out: &mut VecDeque<Action>) -> Next {
        let Input::Answer(Answer::Magnitude(text)) = input else {
            return Next::Stay;
        };
        match parse_magnitude(&text) {
            Ok(x) => {
                self.magnitude = Some(x);
                Next::Finish(None)
            }
            Err(why) => {
                out.push_back(Action::Refused(why));
                out.push_back(Action::Ask(Question::Magnitude));
                Next::Stay
            }
        }
    }

    fn data(&self, started: f64, now: f64, _completed: bool) -> TrialData {
        TrialData::MagnitudeEstimation {
            display: self.display.clone(),
            mu_s: self.mu_s,
            mu_k: self.mu_k,
            delta_mu: self.mu_s - self.mu_k,
            magnitude: self.magnitude,
            response_time_s: self.magnitude.map(|_| now - started),
        }
    }
}
