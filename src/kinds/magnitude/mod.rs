//! Magnitude estimation (seed 001): one stick-slip stimulus per trial, in
//! random order within a set per display; the participant types any
//! positive number for how strong the friction felt.
//!
//! Live: the stimulus is rendered until the exploration time is up (then
//! the question is asked), and any time until then the participant may
//! type a number.

use std::collections::VecDeque;

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};
use serde_json::Value;

use crate::analysis::{AnalysisEntry, KindAnalysis, Section, designs_of};
use crate::friction::{ModelParams, NakanoParams, Validate};
use crate::protocol::check::Checks;
use crate::protocol::engine::{Action, Answer, Input, Question, Screen};
use crate::protocol::kind::{Block, Exploration, Holds, Kinds, LiveTrial, Next, StudyKind};
use crate::protocol::load::Walk;

pub mod analysis;
pub mod report;

/// The magnitude-estimation kind.
#[derive(Debug)]
pub struct Magnitude;

/// Seed 001's magnitude estimation.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct MagnitudeDesign {
    /// Longest exploration of a stimulus before the answer, s.
    pub exploration_s: f64,
    /// One set (block) per display.
    pub sets: Vec<MagnitudeSet>,
}

/// One display's set of stimuli.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct MagnitudeSet {
    /// Display name (`tactile`, `force`), logged as `display`.
    pub display: String,
    /// The model every stimulus of the set uses; each stimulus sets its
    /// `mu_s` and `mu_k` (a stick-slip model).
    pub model: ModelParams,
    /// The stimuli.
    pub stimuli: Vec<Stimulus>,
}

/// One magnitude-estimation stimulus.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Stimulus {
    /// Static coefficient (> `mu_k`).
    pub mu_s: f64,
    /// Kinetic coefficient.
    pub mu_k: f64,
}

/// One magnitude-estimation trial: one stimulus.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MagnitudeTrial {
    /// Display name.
    pub display: String,
    /// The rendered model, with the stimulus's coefficients.
    pub model: ModelParams,
    /// Static coefficient.
    pub mu_s: f64,
    /// Kinetic coefficient.
    pub mu_k: f64,
    /// Longest exploration, s.
    pub exploration_s: f64,
}

/// What a magnitude-estimation trial logs.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct MagnitudeData {
    /// Display name.
    pub display: String,
    /// Static coefficient.
    pub mu_s: f64,
    /// Kinetic coefficient.
    pub mu_k: f64,
    /// mu_s - mu_k.
    pub delta_mu: f64,
    /// The number given.
    pub magnitude: Option<f64>,
    /// Time from the start of the stimulus to the answer, s.
    pub response_time_s: Option<f64>,
}

/// The set's model with the stimulus's coefficients.
#[must_use]
pub fn stimulus_model(model: &ModelParams, s: Stimulus) -> ModelParams {
    let with = |p: &NakanoParams| NakanoParams {
        mu_s: s.mu_s,
        mu_k: s.mu_k,
        ..*p
    };
    match model {
        ModelParams::StickSlipTactile(p) => ModelParams::StickSlipTactile(with(p)),
        ModelParams::StickSlipForce(p) => ModelParams::StickSlipForce(with(p)),
        other => other.clone(),
    }
}

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

/// Display order for the analysis: the protocol's set order, from the
/// first magnitude-estimation design among the folder's sessions'; empty
/// if none.
fn display_order<K: Holds<Magnitude>>(designs: &[K::Design]) -> Vec<String> {
    designs_of::<Magnitude, K>(designs)
        .next()
        .map(|d| d.sets.iter().map(|s| s.display.clone()).collect())
        .unwrap_or_default()
}

impl StudyKind for Magnitude {
    type Design = MagnitudeDesign;
    type Trial = MagnitudeTrial;
    type Live = Explore;
    type Data = MagnitudeData;

    const COLUMNS: &'static [&'static str] = &[
        "display",
        "mu_s",
        "mu_k",
        "delta_mu",
        "magnitude",
        "response_time_s",
    ];

    fn read(w: &mut Walk, v: &Value, path: &str) -> Option<MagnitudeDesign> {
        let m = w.object(v, path, &["kind", "exploration_s", "sets"])?;
        let exploration_s = w.required(m, "exploration_s", path);
        let sets = w.list(m, "sets", path, |w, v, p| {
            let m = w.object(v, p, &["display", "model", "stimuli"])?;
            let display = w.required::<String>(m, "display", p);
            let model = w.model_field(m, "model", p);
            let stimuli = w.list(m, "stimuli", p, Walk::value::<Stimulus>);
            Some(MagnitudeSet {
                display: display?,
                model: model?,
                stimuli: stimuli?,
            })
        });
        Some(MagnitudeDesign {
            exploration_s: exploration_s?,
            sets: sets?,
        })
    }

    fn check(d: &MagnitudeDesign, c: &mut Checks) {
        c.positive("exploration_s", d.exploration_s);
        if d.sets.is_empty() {
            c.err("sets", "no sets: the protocol has zero trials");
        }
        for (i, set) in d.sets.iter().enumerate() {
            let path = format!("sets[{i}]");
            if !matches!(
                set.model,
                ModelParams::StickSlipTactile(_) | ModelParams::StickSlipForce(_)
            ) {
                c.err(
                    &format!("{path}.model.model"),
                    "a magnitude set needs stick-slip-tactile or stick-slip-force",
                );
                continue;
            }
            if set.stimuli.is_empty() {
                c.err(
                    &format!("{path}.stimuli"),
                    "no stimuli: the set has zero trials",
                );
            }
            for (j, s) in set.stimuli.iter().enumerate() {
                for e in stimulus_model(&set.model, *s).validate() {
                    c.err(&format!("{path}.stimuli[{j}].{}", e.place), e.message);
                }
            }
        }
    }

    /// One block per set, named by its display.
    fn blocks(d: &MagnitudeDesign) -> Vec<Block<MagnitudeTrial>> {
        d.sets
            .iter()
            .map(|set| Block {
                name: set.display.clone(),
                practice: false,
                trials: set
                    .stimuli
                    .iter()
                    .map(|&s| MagnitudeTrial {
                        display: set.display.clone(),
                        model: stimulus_model(&set.model, s),
                        mu_s: s.mu_s,
                        mu_k: s.mu_k,
                        exploration_s: d.exploration_s,
                    })
                    .collect(),
            })
            .collect()
    }

    fn loop_rate_hz(t: &MagnitudeTrial) -> f64 {
        t.model.loop_rate_hz()
    }

    /// Renders the stimulus's model and shows the exploration screen until
    /// `now + exploration_s`.
    fn start<K: Kinds>(
        trial: &MagnitudeTrial,
        now: f64,
        out: &mut VecDeque<Action<K>>,
    ) -> Explore {
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

    fn row(d: &MagnitudeData) -> Vec<String> {
        use crate::results::csv::{opt, text};
        vec![
            text(&d.display),
            d.mu_s.to_string(),
            d.mu_k.to_string(),
            d.delta_mu.to_string(),
            opt(d.magnitude),
            opt(d.response_time_s),
        ]
    }
}

/// The live state; `time` asks the question when the exploration is over.
#[derive(Debug, Clone)]
pub struct Explore {
    display: String,
    mu_s: f64,
    mu_k: f64,
    time: Exploration,
    magnitude: Option<f64>,
}

impl LiveTrial for Explore {
    type Data = MagnitudeData;

    fn timeout(&self) -> Option<f64> {
        self.time.timeout()
    }

    fn on_timeout<K: Kinds>(&mut self, _now: f64, out: &mut VecDeque<Action<K>>) -> Next {
        self.time.expire(Question::Magnitude, out)
    }

    fn on_input<K: Kinds>(
        &mut self,
        _now: f64,
        input: Input,
        out: &mut VecDeque<Action<K>>,
    ) -> Next {
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

    fn data(&self, started: f64, now: f64, _completed: bool) -> MagnitudeData {
        MagnitudeData {
            display: self.display.clone(),
            mu_s: self.mu_s,
            mu_k: self.mu_k,
            delta_mu: self.mu_s - self.mu_k,
            magnitude: self.magnitude,
            response_time_s: self.magnitude.map(|_| now - started),
        }
    }
}

impl KindAnalysis for Magnitude {
    fn analysis<K: Holds<Self>>() -> Option<AnalysisEntry<K>> {
        Some(AnalysisEntry {
            marker: "display",
            unread: &["response_time_s"],
            optional: &[],
            counts_aborted: false,
            run: |rows, context| {
                let m = analysis::analyze(rows, &display_order::<K>(context.designs))?;
                Ok(Section {
                    html: context.report(|| report::magnitude_section(&m)),
                    summary: m.summary,
                    notes: m.notes,
                    tables: m.tables,
                })
            },
        })
    }
}
