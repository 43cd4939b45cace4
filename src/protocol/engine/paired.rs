//! A paired-comparison trial live: the first stimulus is rendered, the
//! participant switches between the two until the exploration time (twice
//! each stimulus's) is up, then chooses; a choice may come at any time.

use std::collections::VecDeque;

use super::{
    Action, Answer, Choice, Exploration, Input, LiveTrial, Next, Question, Screen, TrialData,
};
use crate::protocol::Condition;
use crate::protocol::plan::PairedTrial;

/// The live state; `time` asks the question when the exploration is over.
#[derive(Debug, Clone)]
pub(super) struct Compare {
    conditions: [Condition; 2],
    time: Exploration,
    active: usize,
    choice: Option<Choice>,
}

impl Compare {
    /// Renders the first stimulus and shows the comparison screen until
    /// `now + 2 exploration_s`.
    pub(super) fn start(trial: &PairedTrial, now: f64, out: &mut VecDeque<Action>) -> Self {
        let PairedTrial { first, second, .. } = trial;
        let until = now + 2.0 * trial.exploration_s;
        out.push_back(Action::Render(Some(first.model.clone())));
        out.push_back(Action::Show(Screen::Paired {
            active: 0,
            until_s: until,
        }));
        Compare {
            conditions: [first.clone(), second.clone()],
            time: Exploration::until(until),
            active: 0,
            choice: None,
        }
    }
}

impl LiveTrial for Compare {
    fn timeout(&self) -> Option<f64> {
        self.time.timeout()
    }

    fn on_timeout(&mut self, _now: f64, out: &mut VecDeque<Action>) -> Next {
        self.time.expire(Question::PairedChoice, out)
    }

    fn on_input(&mut self, now: f64, input: Input, out: &mut VecDeque<Action>) -> Next {
        match input {
            Input::Switch(i) if i < 2 && now < self.time.until => {
                self.active = i;
                out.push_back(Action::Render(Some(self.conditions[i].model.clone())));
                out.push_back(Action::Show(Screen::Paired {
                    active: i,
                    until_s: self.time.until,
                }));
                Next::Stay
            }
            Input::Answer(Answer::Paired(c)) => {
                self.choice = Some(c);
                Next::Finish(None)
            }
            _ => Next::Stay,
        }
    }

    fn data(&self, _started: f64, _now: f64, _completed: bool) -> TrialData {
        let [first, second] = &self.conditions;
        TrialData::PairedComparison {
            first: first.id.clone(),
            second: second.id.clone(),
            choice: self.choice,
            chosen: self.choice.map(|c| match c {
                Choice::First => first.id.clone(),
                Choice::Second => second.id.clone(),
                Choice::NoDifference => "no_difference".to_owned(),
            }),
        }
    }
}
