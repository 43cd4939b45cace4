//! Magnitude estimation (seed 001): one stick-slip stimulus per trial, in
//! random order within a set per display; the participant types any
//! positive number for how strong the friction felt.
//!
//! Two forms of design (issue 35): seed 001's `sets` (a stick-slip model
//! per display, stimuli given by their `mu_s` and `mu_k`), or a `scaling`:
//! one parameter of any model (a viscosity, a Coulomb level, a stick-slip
//! amplitude) at a list of levels, whose power law the analysis fits
//! (Stevens' exponent). Seed 001's form logs and writes what it always did.
//!
//! Live: the stimulus is rendered until the exploration time is up (then
//! the question is asked), and any time until then the participant may
//! type a number.

use std::collections::VecDeque;

use frictionlab_psychophysics::decimal;
use schemars::JsonSchema;
use serde::{Deserialize, Serialize};
use serde_json::Value;

use crate::analysis::{AnalysisEntry, KindAnalysis, Section, designs_of};
use crate::friction::{ModelParams, NakanoParams, Validate, parameter_problem, with_parameter};
use crate::protocol::check::ValueChecks;
use crate::protocol::engine::{Action, Answer, Input, Question, Screen};
use crate::protocol::kind::{
    Block, WriteCells, Exploration, Holds, Kinds, LiveTrial, Next, Quality, StudyKind,
};
use crate::protocol::load::{Walk, read_object};
use crate::time::Time;

pub mod analysis;
pub mod report;
pub mod scaling;
pub mod view;

/// The magnitude-estimation kind.
#[derive(Debug)]
pub struct Magnitude;

/// A magnitude estimation: seed 001's sets, or a scaling of one parameter.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct MagnitudeDesign {
    /// Longest exploration of a stimulus before the answer, s.
    pub exploration_s: f64,
    /// Seed 001's form: one set (block) per display.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub sets: Vec<MagnitudeSet>,
    /// The generic form (instead of `sets`): one parameter of a model at
    /// each of its levels, one block.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub scaling: Option<Scaling>,
}

/// One parameter of a model, scaled over levels.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Scaling {
    /// Display name (what is judged: `viscosity`), logged as `display`.
    pub display: String,
    /// The model; its `parameter` is set to each level.
    pub reference: ModelParams,
    /// The parameter scaled: a field of the model object (`damping_n_s_m`;
    /// nested fields joined by dots; several set together joined by `+`).
    pub parameter: String,
    /// Its levels, in the parameter's units, each presented `repetitions`
    /// times (the protocol's), in random order.
    pub levels: Vec<f64>,
    /// The quality the participant is asked to judge (`friction`, the
    /// default; `viscosity`; `stiffness`): what the simulated participant
    /// forms its percept of.
    #[serde(default)]
    pub judged: Quality,
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
    /// The rendered model, with the stimulus's coefficients (or level).
    pub model: ModelParams,
    /// What the stimulus is.
    pub stimulus: Level,
    /// Longest exploration, s.
    pub exploration_s: f64,
    /// The quality judged (seed 001's sets: friction).
    #[serde(default)]
    pub judged: Quality,
}

/// A stimulus: seed 001's coefficients, or a scaling's level.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum Level {
    /// Static and kinetic coefficients.
    Coefficients(Stimulus),
    /// The scaled parameter (its name) at this value.
    Scaled(String, f64),
}

/// What a magnitude-estimation trial logs.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct MagnitudeData {
    /// Display name.
    pub display: String,
    /// Static coefficient (seed 001's form).
    pub mu_s: Option<f64>,
    /// Kinetic coefficient (seed 001's form).
    pub mu_k: Option<f64>,
    /// mu_s - mu_k (seed 001's form).
    pub delta_mu: Option<f64>,
    /// The number given.
    pub magnitude: Option<f64>,
    /// Time from the start of the stimulus to the answer, s.
    pub response_time_s: Option<f64>,
    /// The parameter scaled (the generic form).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub parameter: Option<String>,
    /// Its value in this trial, in its units (the generic form).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub level: Option<f64>,
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

/// The design's `sets` (`key`) in its object `m` at `path`: exactly one of
/// `sets` (seed 001's form) and `scaling` must be given; with `scaling`,
/// none.
fn read_sets(
    w: &mut Walk,
    m: &serde_json::Map<String, Value>,
    key: &str,
    path: &str,
) -> Option<Vec<MagnitudeSet>> {
    let scaling = m.contains_key("scaling");
    if scaling == m.contains_key(key) {
        w.err(
            crate::protocol::load::join(path, key),
            "give either `sets` (seed 001's form) or `scaling` (one parameter at its levels), not both or neither",
        );
        return None;
    }
    if scaling {
        return Some(Vec::new());
    }
    w.list(m, key, path, |w, v, p| {
        read_object!(w, v, p, [], MagnitudeSet {
            display: required,
            model: model_field,
            stimuli: list(Walk::value::<Stimulus>),
        })
    })
}

/// The design's `scaling` object `v` at `path`.
fn read_scaling(w: &mut Walk, v: &Value, path: &str) -> Option<Scaling> {
    read_object!(w, v, path, [], Scaling {
        display: required,
        reference: model_field,
        parameter: required,
        levels: required,
        judged: optional(Quality::Friction),
    })
}

/// Checks a scaling: the reference has the parameter, and every level is
/// a valid value of it.
fn check_scaling(sc: &Scaling, c: &mut ValueChecks) {
    if sc.display.trim().is_empty() {
        c.err("scaling.display", "must not be empty");
    }
    if let Some(why) = parameter_problem(&sc.reference, &sc.parameter) {
        c.err("scaling.parameter", why);
        return;
    }
    if sc.levels.len() < 2 {
        c.err(
            "scaling.levels",
            format!(
                "at least 2 levels are needed for a power law, got {}",
                sc.levels.len()
            ),
        );
    }
    for (i, &level) in sc.levels.iter().enumerate() {
        let path = format!("scaling.levels[{i}]");
        if !(level.is_finite() && level > 0.0) {
            c.err(
                &path,
                format!("must be a number greater than 0 (a power law is fitted on its logarithm), got {level}"),
            );
            continue;
        }
        match with_parameter(&sc.reference, &sc.parameter, level) {
            None => c.err(&path, format!("{level} is not a valid value of '{}'", sc.parameter)),
            Some(m) => {
                for e in m.validate() {
                    c.err(&path, format!("{}: {}", e.place, e.message));
                }
            }
        }
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
        .find(|d| !d.sets.is_empty())
        .map(|d| d.sets.iter().map(|s| s.display.clone()).collect())
        .unwrap_or_default()
}

impl StudyKind for Magnitude {
    type Design = MagnitudeDesign;
    type Trial = MagnitudeTrial;
    type Live = Estimate;
    type Data = MagnitudeData;

    const COLUMNS: &'static [&'static str] = &[
        "display",
        "mu_s",
        "mu_k",
        "delta_mu",
        "magnitude",
        "response_time_s",
        "parameter",
        "level",
    ];

    fn read(w: &mut Walk, v: &Value, path: &str) -> Option<MagnitudeDesign> {
        read_object!(w, v, path, ["kind"], MagnitudeDesign {
            exploration_s: required,
            sets: with(read_sets),
            scaling: optional_object(read_scaling),
        })
    }

    /// Seed 001's tactile stick-slip display at three coefficient pairs.
    fn template() -> Value {
        serde_json::json!({
            "kind": "magnitude_estimation",
            "exploration_s": 10.0,
            "sets": [{
                "display": "tactile",
                "model": {"model": "stick-slip-tactile"},
                "stimuli": [
                    {"mu_s": 0.4, "mu_k": 0.2},
                    {"mu_s": 0.5, "mu_k": 0.3},
                    {"mu_s": 0.6, "mu_k": 0.4}
                ]
            }]
        })
    }

    fn check(d: &MagnitudeDesign, c: &mut ValueChecks) {
        c.positive_duration("exploration_s", d.exploration_s);
        if let Some(scaling) = &d.scaling {
            check_scaling(scaling, c);
            return;
        }
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

    fn trials_per_repetition(d: &MagnitudeDesign) -> u64 {
        match &d.scaling {
            Some(sc) => sc.levels.len() as u64,
            None => d.sets.iter().map(|s| s.stimuli.len() as u64).sum(),
        }
    }

    /// One block per set, named by its display; a scaling is one block.
    fn blocks(d: &MagnitudeDesign) -> Vec<Block<MagnitudeTrial>> {
        if let Some(sc) = &d.scaling {
            return vec![Block {
                name: sc.display.clone(),
                practice: false,
                trials: sc
                    .levels
                    .iter()
                    .filter_map(|&level| {
                        Some(MagnitudeTrial {
                            display: sc.display.clone(),
                            model: with_parameter(&sc.reference, &sc.parameter, level)?,
                            stimulus: Level::Scaled(sc.parameter.clone(), level),
                            exploration_s: d.exploration_s,
                            judged: sc.judged,
                        })
                    })
                    .collect(),
            }];
        }
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
                        stimulus: Level::Coefficients(s),
                        exploration_s: d.exploration_s,
                        judged: Quality::Friction,
                    })
                    .collect(),
            })
            .collect()
    }

    fn judged(t: &MagnitudeTrial) -> Quality {
        t.judged
    }

    fn loop_rate_hz(t: &MagnitudeTrial) -> f64 {
        t.model.loop_rate_hz()
    }

    /// Renders the stimulus's model and shows the exploration screen until
    /// `now + exploration_s`.
    fn start<K: Kinds>(
        trial: &MagnitudeTrial,
        now: Time,
        out: &mut VecDeque<Action<K>>,
    ) -> Estimate {
        let time = Exploration::from(now, trial.exploration_s);
        out.push_back(Action::Render(Some(trial.model.clone())));
        out.push_back(Action::Show(Screen::Explore { until: time.until }));
        Estimate {
            display: trial.display.clone(),
            stimulus: trial.stimulus.clone(),
            time,
            magnitude: None,
        }
    }

    fn row<W: WriteCells>(d: &MagnitudeData, out: &mut W) {
        out.text(&d.display);
        out.opt_num(d.mu_s);
        out.opt_num(d.mu_k);
        out.opt_num(d.delta_mu);
        out.opt_num(d.magnitude);
        out.opt_num(d.response_time_s);
        out.text(d.parameter.as_deref().unwrap_or_default());
        out.opt_num(d.level);
    }
}

/// The live state; `time` asks the question when the exploration is over.
#[derive(Debug, Clone)]
pub struct Estimate {
    display: String,
    stimulus: Level,
    time: Exploration,
    magnitude: Option<f64>,
}

impl LiveTrial for Estimate {
    type Data = MagnitudeData;

    fn timeout(&self) -> Option<Time> {
        self.time.timeout()
    }

    fn on_timeout<K: Kinds>(&mut self, _now: Time, out: &mut VecDeque<Action<K>>) -> Next {
        self.time.expire(Question::Magnitude, out)
    }

    fn on_input<K: Kinds>(
        &mut self,
        _now: Time,
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

    fn data(&self, started: Time, now: Time, _completed: bool) -> MagnitudeData {
        let (coefficients, scaled) = match &self.stimulus {
            Level::Coefficients(s) => (Some(*s), None),
            Level::Scaled(parameter, level) => (None, Some((parameter.clone(), *level))),
        };
        MagnitudeData {
            display: self.display.clone(),
            mu_s: coefficients.map(|s| s.mu_s),
            mu_k: coefficients.map(|s| s.mu_k),
            // The difference of the design's decimals (issue 42).
            delta_mu: coefficients.map(|s| decimal::sub(s.mu_s, s.mu_k)),
            magnitude: self.magnitude,
            response_time_s: self.magnitude.map(|_| (now - started).secs()),
            parameter: scaled.as_ref().map(|(p, _)| p.clone()),
            level: scaled.map(|(_, l)| l),
        }
    }
}

impl KindAnalysis for Magnitude {
    fn analysis<K: Holds<Self>>() -> Option<AnalysisEntry<K>> {
        Some(AnalysisEntry {
            marker: "display",
            unread: &["response_time_s", "parameter", "level"],
            optional: &["parameter", "level"],
            counts_aborted: false,
            counted: analysis::counted,
            run: |rows, context| {
                // Seed 001's form (no level), and the generic form's
                // scalings; a folder may hold both.
                let seed = rows.where_filled("level", false);
                let scaled = rows.where_filled("level", true);
                let mut section = if !seed.is_empty() || scaled.is_empty() {
                    let m = analysis::analyze(&seed, &display_order::<K>(context.designs))?;
                    let html = context.report(|| report::magnitude_section(&m));
                    Section::new(html, m.summary, m.notes, m.tables)
                } else {
                    Section::new(String::new(), Value::Null, Vec::new(), Vec::new())
                };
                if !scaled.is_empty() {
                    let results = scaling::scalings(&scaled)?;
                    let tables = scaling::tables(&results);
                    section
                        .html
                        .push_str(&context.report(|| report::scaling_section(&results, &tables)));
                    if !section.summary.is_object() {
                        section.summary = Value::Object(serde_json::Map::new());
                    }
                    section.summary["scalings"] = scaling::summary(&results);
                    section.tables.extend(tables);
                }
                Ok(section)
            },
        })
    }
}
