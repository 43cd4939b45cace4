//! Paired comparison (seed 000): two renderings per trial, presented in an
//! order drawn per trial; the participant says which is nearer to a real
//! surface, or no difference.
//!
//! Live: the first stimulus is rendered, the participant switches between
//! the two until the exploration time (twice each stimulus's) is up, then
//! chooses; a choice may come at any time.

use std::collections::VecDeque;

use rand::RngExt;
use rand_chacha::ChaCha8Rng;
use schemars::JsonSchema;
use serde::{Deserialize, Serialize};
use serde_json::Value;

use crate::analysis::{AnalysisEntry, KindAnalysis, Section};
use crate::protocol::Condition;
use crate::protocol::check::ValueChecks;
use crate::protocol::engine::{Action, Answer, Choice, Input, Question, Screen};
use crate::protocol::kind::{Block, WriteCells, Exploration, Holds, Kinds, LiveTrial, Next, StudyKind};
use crate::protocol::load::{Walk, read_object};
use crate::time::Time;

pub mod analysis;
pub mod report;
pub mod view;

/// The paired-comparison kind.
#[derive(Debug)]
pub struct Paired;

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

/// One paired-comparison trial: two renderings, in presentation order.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PairedTrial {
    /// Presented first.
    pub first: Condition,
    /// Presented second.
    pub second: Condition,
    /// Longest exploration of each, s.
    pub exploration_s: f64,
}

/// What a paired-comparison trial logs.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct PairedData {
    /// Condition presented first.
    pub first: String,
    /// Condition presented second.
    pub second: String,
    /// The answer.
    pub choice: Option<Choice>,
    /// The chosen condition id, or `no_difference`.
    pub chosen: Option<String>,
}

impl StudyKind for Paired {
    type Design = PairedDesign;
    type Trial = PairedTrial;
    type Live = Compare;
    type Data = PairedData;

    const COLUMNS: &'static [&'static str] = &["first", "second", "choice", "chosen"];

    fn read(w: &mut Walk, v: &Value, path: &str) -> Option<PairedDesign> {
        read_object!(w, v, path, ["kind"], PairedDesign {
            reference_s: required,
            reference_instructions: required,
            exploration_s: required,
            conditions: list(Walk::condition),
            pairs: list(Walk::value::<[String; 2]>),
        })
    }

    /// Seed 000's two god-object renderings (the quick protocol's pair).
    fn template() -> Value {
        serde_json::json!({
            "kind": "paired_comparison",
            "reference_s": 10.0,
            "reference_instructions": "Slide your finger on the real surface for a moment.",
            "exploration_s": 10.0,
            "conditions": [
                {"id": "time_constant", "model": {"model": "god-object-constant"}},
                {"id": "time_varying", "model": {"model": "god-object-time-varying"}}
            ],
            "pairs": [["time_constant", "time_varying"]]
        })
    }

    fn check(d: &PairedDesign, c: &mut ValueChecks) {
        c.duration("reference_s", d.reference_s);
        c.positive_duration("exploration_s", d.exploration_s);
        let ids = c.condition_ids("conditions", d.conditions.iter().map(|c| c.id.as_str()));
        if d.pairs.is_empty() {
            c.err("pairs", "no pairs: the protocol has zero trials");
        }
        for (i, [a, b]) in d.pairs.iter().enumerate() {
            for (j, id) in [a, b].iter().enumerate() {
                if !ids.contains(id.as_str()) {
                    c.err(
                        &format!("pairs[{i}][{j}]"),
                        format!("unknown condition '{id}'"),
                    );
                }
            }
            if a == b {
                c.err(
                    &format!("pairs[{i}]"),
                    "a pair needs two different conditions",
                );
            }
        }
    }

    fn trials_per_repetition(d: &PairedDesign) -> u64 {
        d.pairs.len() as u64
    }

    /// One block, `main`: the pairs as listed.
    fn blocks(d: &PairedDesign) -> Vec<Block<PairedTrial>> {
        let find = |id: &str| d.conditions.iter().find(|c| c.id == id).cloned();
        let trials = d
            .pairs
            .iter()
            .filter_map(|[a, b]| {
                Some(PairedTrial {
                    first: find(a)?,
                    second: find(b)?,
                    exploration_s: d.exploration_s,
                })
            })
            .collect();
        vec![Block {
            name: "main".into(),
            practice: false,
            trials,
        }]
    }

    /// The two members' presentation order, drawn per trial (the seed's
    /// "random order").
    fn draw(t: PairedTrial, rng: &mut ChaCha8Rng) -> PairedTrial {
        if rng.random_bool(0.5) {
            PairedTrial {
                first: t.second,
                second: t.first,
                exploration_s: t.exploration_s,
            }
        } else {
            t
        }
    }

    /// Its conditions: a participant may be set to prefer one of them.
    fn preferable(d: &PairedDesign) -> Option<Vec<&str>> {
        Some(d.conditions.iter().map(|c| c.id.as_str()).collect())
    }

    /// The pair, in presentation order.
    fn preferable_stimuli(t: &PairedTrial) -> Vec<&str> {
        vec![t.first.id.as_str(), t.second.id.as_str()]
    }

    fn reference(d: &PairedDesign) -> Option<(&str, f64)> {
        (d.reference_s > 0.0).then_some((d.reference_instructions.as_str(), d.reference_s))
    }

    fn loop_rate_hz(t: &PairedTrial) -> f64 {
        t.first
            .model
            .loop_rate_hz()
            .max(t.second.model.loop_rate_hz())
    }

    /// Renders the first stimulus and shows the comparison screen until
    /// `now + 2 exploration_s`.
    fn start<K: Kinds>(trial: &PairedTrial, now: Time, out: &mut VecDeque<Action<K>>) -> Compare {
        Compare::start(trial, None, now, out)
    }

    fn row<W: WriteCells>(d: &PairedData, out: &mut W) {
        out.text(&d.first);
        out.text(&d.second);
        out.opt_text(d.choice.map(Choice::as_str));
        out.opt_text(d.chosen.as_deref());
    }
}

/// The live state; `time` asks the question when the exploration is over.
#[derive(Debug, Clone)]
pub struct Compare {
    conditions: [Condition; 2],
    time: Exploration,
    choice: Option<Choice>,
    /// A forced choice's question (no "no difference"), or `None`.
    forced: Option<String>,
}

impl Compare {
    /// Renders the first stimulus and shows the two stimuli until `now + 2
    /// exploration_s`; `forced`: a two-interval forced choice asking this
    /// question, else the paired comparison's.
    pub fn start<K: Kinds>(
        trial: &PairedTrial,
        forced: Option<String>,
        now: Time,
        out: &mut VecDeque<Action<K>>,
    ) -> Self {
        let PairedTrial { first, second, .. } = trial;
        let time = Exploration::from(now, 2.0 * trial.exploration_s);
        out.push_back(Action::Render(Some(first.model.clone())));
        out.push_back(Action::Show(Screen::Paired {
            active: 0,
            until: time.until,
            forced: forced.clone(),
        }));
        Compare {
            conditions: [first.clone(), second.clone()],
            time,
            choice: None,
            forced,
        }
    }
}

impl LiveTrial for Compare {
    type Data = PairedData;

    fn timeout(&self) -> Option<Time> {
        self.time.timeout()
    }

    fn on_timeout<K: Kinds>(&mut self, _now: Time, out: &mut VecDeque<Action<K>>) -> Next {
        let question = if self.forced.is_some() {
            Question::ForcedChoice
        } else {
            Question::PairedChoice
        };
        self.time.expire(question, out)
    }

    fn on_input<K: Kinds>(
        &mut self,
        now: Time,
        input: Input,
        out: &mut VecDeque<Action<K>>,
    ) -> Next {
        match input {
            Input::Switch(i) if i < 2 && now < self.time.until => {
                out.push_back(Action::Render(Some(self.conditions[i].model.clone())));
                out.push_back(Action::Show(Screen::Paired {
                    active: i,
                    until: self.time.until,
                    forced: self.forced.clone(),
                }));
                Next::Stay
            }
            // A forced choice has no "no difference".
            Input::Answer(Answer::Paired(Choice::NoDifference)) if self.forced.is_some() => {
                out.push_back(Action::Refused(
                    "choose stimulus 1 or stimulus 2".into(),
                ));
                Next::Stay
            }
            Input::Answer(Answer::Paired(c)) => {
                self.choice = Some(c);
                Next::Finish(None)
            }
            _ => Next::Stay,
        }
    }

    fn data(&self, _started: Time, _now: Time, _completed: bool) -> PairedData {
        let [first, second] = &self.conditions;
        PairedData {
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

impl KindAnalysis for Paired {
    fn analysis<K: Holds<Self>>() -> Option<AnalysisEntry<K>> {
        Some(AnalysisEntry {
            marker: "choice",
            unread: &[],
            optional: &[],
            counts_aborted: false,
            counted: analysis::counted,
            run: |rows, context| {
                let p = analysis::analyze(rows)?;
                Ok(Section::new(context.report(|| report::paired_section(&p)), p.summary, p.notes, p.tables))
            },
        })
    }
}
