//! Fitts reciprocal targeting (seed 002): tapping tests between two
//! targets under friction conditions, each difficulty level (distance x
//! width) once per condition, after an optional practice block.
//!
//! Live: the condition's model is rendered, each hit switches the lit
//! target, and the test ends after its taps or at its time limit (aborted,
//! reason `timeout`). Targets are centred at `-A/2` and `+A/2`; the first
//! lit target is at `-A/2`. A click counts only if the cursor is inside the
//! lit target: `|x - centre| <= W'/2` (W' = W - D or W, see the protocol's
//! `tolerance`). A click outside is an error; its size is its distance
//! beyond the tolerance, `|x - centre| - W'/2`. Completion time runs from
//! the first hit to the last.

use std::collections::VecDeque;

use frictionlab_psychophysics::decimal::{self, Dec};
use schemars::JsonSchema;
use serde::{Deserialize, Serialize};
use serde_json::Value;

use crate::analysis::{AnalysisEntry, KindAnalysis, Section};
use crate::friction::ModelParams;
use crate::protocol::check::ValueChecks;
use crate::protocol::engine::{Action, Input, Screen};
use crate::protocol::kind::{
    Block, Holds, Kinds, LiveTrial, Next, Reach, StudyKind, WriteCells,
};
use crate::protocol::load::{Walk, read_object};
use crate::time::Time;

pub mod analysis;
pub mod report;
pub mod view;

/// The Fitts kind.
#[derive(Debug)]
pub struct Fitts;

/// Seed 002's Fitts reciprocal targeting.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct FittsDesign {
    /// Cursor diameter D, m.
    pub cursor_m: f64,
    /// Successful taps per test.
    pub taps: u32,
    /// Index of difficulty formula.
    #[serde(default)]
    pub id_formula: IdFormula,
    /// Target tolerance used for hits and the index of difficulty.
    #[serde(default)]
    pub tolerance: Tolerance,
    /// Longest time for one test before it is ended, s.
    #[serde(default = "fitts_timeout")]
    pub timeout_s: f64,
    /// Friction conditions.
    pub conditions: Vec<FittsCondition>,
    /// Difficulty levels (distance x width).
    pub levels: Vec<FittsLevel>,
    /// Practice block run first, excluded from analysis: condition ids, each
    /// with `practice_levels` (all levels if empty).
    #[serde(default)]
    pub practice: Vec<String>,
    /// Level indices used in practice (empty: all).
    #[serde(default)]
    pub practice_levels: Vec<usize>,
}

fn fitts_timeout() -> f64 {
    60.0
}

/// A Fitts friction condition.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct FittsCondition {
    /// Condition id (`baseline`, `real`, `simulated`, ...).
    pub id: String,
    /// The rendered model (`none` for a physical condition).
    pub model: ModelParams,
    /// A prompt to the experimenter before each test of this condition
    /// (e.g. to attach the aluminum block for `real`); the runner waits for
    /// the experimenter to continue.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub prompt: Option<String>,
    /// For the simulated device: the friction a physical condition adds
    /// (e.g. the aluminum block on rubber); it is not rendered, it is part of
    /// the simulated apparatus. Ignored on a real device.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub physical: Option<ModelParams>,
}

/// A Fitts difficulty level.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct FittsLevel {
    /// Distance A between target centres, m.
    pub amplitude_m: f64,
    /// Target width W, m (> cursor diameter).
    pub width_m: f64,
}

/// Index of difficulty formula (the seed's formula was lost in extraction).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum IdFormula {
    /// Shannon: log2(A / W' + 1) (ISO 9241-9).
    #[default]
    Shannon,
    /// Fitts: log2(2 A / W').
    Fitts,
}

/// Which width W' counts for hits and for the index of difficulty.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum Tolerance {
    /// W' = W - D: the whole cursor must be inside the target.
    #[default]
    WidthMinusCursor,
    /// W' = W: the cursor's centre must be inside the target.
    Width,
}

impl FittsDesign {
    /// Effective target width W' for hits and ID, m.
    #[must_use]
    pub fn effective_width(&self, width_m: f64) -> f64 {
        match self.tolerance {
            Tolerance::WidthMinusCursor => decimal::sub(width_m, self.cursor_m),
            Tolerance::Width => width_m,
        }
    }

    /// Index of difficulty of a level, bits.
    #[must_use]
    pub fn id_bits(&self, level: FittsLevel) -> f64 {
        // The ratio on the design's decimals, so levels of one ratio have
        // one ID (issue 42).
        let (a, w) = (Dec::of(level.amplitude_m), Dec::of(level.width_m));
        let w = match self.tolerance {
            Tolerance::WidthMinusCursor => w - Dec::of(self.cursor_m),
            Tolerance::Width => w,
        };
        match self.id_formula {
            IdFormula::Shannon => (a / w + Dec::of(1.0)).to_f64().log2(),
            IdFormula::Fitts => (Dec::of(2.0) * a / w).to_f64().log2(),
        }
    }
}

/// One reciprocal tapping test of a Fitts study.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FittsTrial {
    /// Condition id.
    pub condition: String,
    /// The rendered model.
    pub model: ModelParams,
    /// Experimenter prompt before the test.
    pub prompt: Option<String>,
    /// Physical friction of the condition (simulated device only).
    pub physical: Option<ModelParams>,
    /// Distance between target centres A, m.
    pub amplitude_m: f64,
    /// Target width W, m.
    pub width_m: f64,
    /// Cursor diameter D, m.
    pub cursor_m: f64,
    /// Width that counts for hits, W' (W - D or W), m.
    pub effective_width_m: f64,
    /// Index of difficulty, bits.
    pub id_bits: f64,
    /// Successful taps to complete the test.
    pub taps: u32,
    /// Longest duration of the test, s.
    pub timeout_s: f64,
}

/// What a Fitts test logs.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct FittsData {
    /// Condition id.
    pub condition: String,
    /// A, m.
    pub amplitude_m: f64,
    /// W, m.
    pub width_m: f64,
    /// D, m.
    pub cursor_m: f64,
    /// W', m.
    pub effective_width_m: f64,
    /// Index of difficulty, bits.
    pub id_bits: f64,
    /// First to last hit, s.
    pub completion_time_s: Option<f64>,
    /// Hits.
    pub taps: u32,
    /// Clicks outside the lit target.
    pub errors: u32,
    /// Mean error size, m (None without errors).
    pub mean_error_m: Option<f64>,
    /// Time of each hit from the trial's start, s (a whole number of
    /// ticks; session time in a log of format 1).
    pub tap_times_s: Vec<f64>,
    /// Cursor position of each hit, m.
    pub tap_x_m: Vec<f64>,
    /// Centre of the target of each hit, m.
    pub target_x_m: Vec<f64>,
    /// Cursor position of each miss, m.
    pub miss_x_m: Vec<f64>,
    /// Time of every click from the trial's start, hits and misses in
    /// order, s (session time in a log of format 1; empty in logs written
    /// before these fields existed).
    #[serde(default)]
    pub click_times_s: Vec<f64>,
    /// Cursor position of every click, m.
    #[serde(default)]
    pub click_x_m: Vec<f64>,
    /// Centre of the lit target at every click, m.
    #[serde(default)]
    pub click_target_x_m: Vec<f64>,
    /// Whether each click hit.
    #[serde(default)]
    pub click_hit: Vec<bool>,
}

impl StudyKind for Fitts {
    type Design = FittsDesign;
    type Trial = FittsTrial;
    type Live = Tapping;
    type Data = FittsData;

    const COLUMNS: &'static [&'static str] = &[
        "condition",
        "amplitude_m",
        "width_m",
        "cursor_m",
        "effective_width_m",
        "id_bits",
        "completion_time_s",
        "taps",
        "errors",
        "mean_error_m",
        "tap_times_s",
        "tap_x_m",
        "target_x_m",
        "miss_x_m",
        "click_times_s",
        "click_x_m",
        "click_target_x_m",
        "click_hit",
    ];

    fn read(w: &mut Walk, v: &Value, path: &str) -> Option<FittsDesign> {
        let condition = |w: &mut Walk, v: &Value, p: &str| {
            read_object!(w, v, p, [], FittsCondition {
                id: required,
                model: model_field,
                prompt: optional(None),
                physical: optional_model,
            })
        };
        read_object!(w, v, path, ["kind"], FittsDesign {
            cursor_m: required,
            taps: required,
            id_formula: optional(IdFormula::default()),
            tolerance: optional(Tolerance::default()),
            timeout_s: optional(fitts_timeout()),
            conditions: list(condition),
            levels: list(Walk::value::<FittsLevel>),
            practice: optional(Vec::new()),
            practice_levels: optional(Vec::new()),
        })
    }

    /// Seed 002's apparatus alone and its viscous condition, at one
    /// amplitude and width.
    fn template() -> Value {
        serde_json::json!({
            "kind": "fitts",
            "cursor_m": 0.001,
            "taps": 10,
            "id_formula": "shannon",
            "tolerance": "width_minus_cursor",
            "timeout_s": 60.0,
            "conditions": [
                {"id": "baseline", "model": {"model": "none"}},
                {"id": "viscous", "model": {"model": "viscous"}}
            ],
            "levels": [{"amplitude_m": 0.016, "width_m": 0.003}]
        })
    }

    /// Each level's two targets, centred at `±A/2`, `W` wide: the hand
    /// must reach both whole (their outer edges at `±(A + W)/2`).
    fn reach(d: &FittsDesign) -> Vec<Reach> {
        d.levels
            .iter()
            .enumerate()
            .map(|(i, level)| {
                let edge = decimal::add(level.amplitude_m, level.width_m) / 2.0;
                Reach {
                    path: format!("levels[{i}]"),
                    what: format!(
                        "targets at ±{} mm, {} mm wide",
                        decimal::mul(level.amplitude_m, 500.0),
                        decimal::mul(level.width_m, 1000.0)
                    ),
                    span_m: [-edge, edge],
                }
            })
            .collect()
    }

    fn check(d: &FittsDesign, c: &mut ValueChecks) {
        c.positive("cursor_m", d.cursor_m);
        c.positive_duration("timeout_s", d.timeout_s);
        if d.taps < 2 {
            c.err(
                "taps",
                format!(
                    "must be at least 2 (a completion time needs a first and a last tap), got {}",
                    d.taps
                ),
            );
        }
        let ids = c.condition_ids("conditions", d.conditions.iter().map(|c| c.id.as_str()));
        if d.levels.is_empty() {
            c.err("levels", "no levels: the protocol has zero trials");
        }
        for (i, level) in d.levels.iter().enumerate() {
            let path = format!("levels[{i}]");
            c.positive(&format!("{path}.amplitude_m"), level.amplitude_m);
            c.positive(&format!("{path}.width_m"), level.width_m);
            if level.width_m.is_finite() && d.effective_width(level.width_m) <= 0.0 {
                c.err(
                    &format!("{path}.width_m"),
                    format!(
                        "target width {} m must exceed the cursor diameter {} m",
                        level.width_m, d.cursor_m
                    ),
                );
            }
            if level.amplitude_m <= level.width_m {
                c.err(
                    &format!("{path}.amplitude_m"),
                    format!(
                        "targets overlap: distance {} m must exceed width {} m",
                        level.amplitude_m, level.width_m
                    ),
                );
            }
        }
        for (i, id) in d.practice.iter().enumerate() {
            if !ids.contains(id.as_str()) {
                c.err(
                    &format!("practice[{i}]"),
                    format!("unknown condition '{id}'"),
                );
            }
        }
        for (i, &l) in d.practice_levels.iter().enumerate() {
            if l >= d.levels.len() {
                c.err(
                    &format!("practice_levels[{i}]"),
                    format!("level {l} does not exist ({} levels)", d.levels.len()),
                );
            }
        }
    }

    fn trials_per_repetition(d: &FittsDesign) -> u64 {
        let levels = d.levels.len() as u64;
        let practice_levels = if d.practice_levels.is_empty() {
            levels
        } else {
            d.practice_levels.len() as u64
        };
        (d.practice.len() as u64)
            .saturating_mul(practice_levels)
            .saturating_add((d.conditions.len() as u64).saturating_mul(levels))
    }

    /// A `practice` block (if any: the practice conditions at
    /// `practice_levels`, all levels if empty), then `main`: every
    /// condition at every level.
    fn blocks(d: &FittsDesign) -> Vec<Block<FittsTrial>> {
        let test = |c: &FittsCondition, l: FittsLevel| FittsTrial {
            condition: c.id.clone(),
            model: c.model.clone(),
            prompt: c.prompt.clone(),
            physical: c.physical.clone(),
            amplitude_m: l.amplitude_m,
            width_m: l.width_m,
            cursor_m: d.cursor_m,
            effective_width_m: d.effective_width(l.width_m),
            id_bits: d.id_bits(l),
            taps: d.taps,
            timeout_s: d.timeout_s,
        };
        let mut out = Vec::new();
        if !d.practice.is_empty() {
            let levels: Vec<usize> = if d.practice_levels.is_empty() {
                (0..d.levels.len()).collect()
            } else {
                d.practice_levels.clone()
            };
            let trials = d
                .practice
                .iter()
                .filter_map(|id| d.conditions.iter().find(|c| &c.id == id))
                .flat_map(|c| {
                    levels
                        .iter()
                        .filter_map(|&l| d.levels.get(l))
                        .map(|&l| test(c, l))
                })
                .collect();
            out.push(Block {
                name: "practice".into(),
                practice: true,
                trials,
            });
        }
        let trials = d
            .conditions
            .iter()
            .flat_map(|c| d.levels.iter().map(move |&l| test(c, l)))
            .collect();
        out.push(Block {
            name: "main".into(),
            practice: false,
            trials,
        });
        out
    }

    fn prompt(t: &FittsTrial) -> Option<&str> {
        t.prompt.as_deref()
    }

    fn loop_rate_hz(t: &FittsTrial) -> f64 {
        t.model.loop_rate_hz()
    }

    fn start<K: Kinds>(trial: &FittsTrial, now: Time, out: &mut VecDeque<Action<K>>) -> Tapping {
        Tapping::begin(trial, now, out)
    }

    fn row<W: WriteCells>(d: &FittsData, out: &mut W) {
        out.text(&d.condition);
        out.num(d.amplitude_m);
        out.num(d.width_m);
        out.num(d.cursor_m);
        out.num(d.effective_width_m);
        out.num(d.id_bits);
        out.opt_num(d.completion_time_s);
        out.whole(u64::from(d.taps));
        out.whole(u64::from(d.errors));
        out.opt_num(d.mean_error_m);
        out.list(&d.tap_times_s);
        out.list(&d.tap_x_m);
        out.list(&d.target_x_m);
        out.list(&d.miss_x_m);
        out.list(&d.click_times_s);
        out.list(&d.click_x_m);
        out.list(&d.click_target_x_m);
        out.flags(&d.click_hit);
    }
}

/// The live state: every click so far (the hits and misses logged are
/// derived from them).
#[derive(Debug, Clone)]
pub struct Tapping {
    trial: FittsTrial,
    lit: usize,
    centres: [f64; 2],
    started: Time,
    deadline: Time,
    /// Each click's time from the trial's start.
    times: Vec<Time>,
    x: Vec<f64>,
    target: Vec<f64>,
    hit: Vec<bool>,
}

impl Tapping {
    /// Sets the condition's physical friction, renders its model and lights
    /// the target at `-A/2`.
    fn begin<K: Kinds>(trial: &FittsTrial, now: Time, out: &mut VecDeque<Action<K>>) -> Self {
        let a = trial.amplitude_m;
        let t = Tapping {
            trial: trial.clone(),
            lit: 0,
            centres: [-a / 2.0, a / 2.0],
            started: now,
            deadline: now + Time::from_secs_saturating(trial.timeout_s),
            times: Vec::new(),
            x: Vec::new(),
            target: Vec::new(),
            hit: Vec::new(),
        };
        out.push_back(Action::Physical(trial.physical.clone()));
        out.push_back(Action::Render(Some(trial.model.clone())));
        out.push_back(t.screen(false));
        t
    }

    fn screen<K: Kinds>(&self, missed: bool) -> Action<K> {
        Action::Show(Screen::Targets {
            lit_m: self.centres[self.lit],
            other_m: self.centres[1 - self.lit],
            width_m: self.trial.width_m,
            cursor_m: self.trial.cursor_m,
            effective_width_m: self.trial.effective_width_m,
            missed,
        })
    }

    fn click<K: Kinds>(&mut self, now: Time, x: f64, out: &mut VecDeque<Action<K>>) -> Next {
        let half = self.trial.effective_width_m / 2.0;
        let centre = self.centres[self.lit];
        let distance = (x - centre).abs();
        let hit = distance <= half;
        self.times.push(now - self.started);
        self.x.push(x);
        self.target.push(centre);
        self.hit.push(hit);
        if hit {
            if self.hit.iter().filter(|&&h| h).count() >= self.trial.taps as usize {
                return Next::Finish(None);
            }
            self.lit = 1 - self.lit;
        }
        out.push_back(self.screen(!hit));
        Next::Stay
    }
}

impl LiveTrial for Tapping {
    type Data = FittsData;

    fn timeout(&self) -> Option<Time> {
        Some(self.deadline)
    }

    fn on_timeout<K: Kinds>(&mut self, _now: Time, _out: &mut VecDeque<Action<K>>) -> Next {
        Next::Finish(Some("timeout".into()))
    }

    fn on_input<K: Kinds>(
        &mut self,
        now: Time,
        input: Input,
        out: &mut VecDeque<Action<K>>,
    ) -> Next {
        match input {
            Input::Click { x_m } if x_m.is_finite() => self.click(now, x_m, out),
            _ => Next::Stay,
        }
    }

    fn data(&self, _started: Time, _now: Time, completed: bool) -> FittsData {
        let g = &self.trial;
        let of = |hit: bool, v: &[f64]| -> Vec<f64> {
            v.iter()
                .zip(&self.hit)
                .filter(|&(_, &h)| h == hit)
                .map(|(&v, _)| v)
                .collect()
        };
        let taps: Vec<Time> = self
            .times
            .iter()
            .zip(&self.hit)
            .filter(|&(_, &h)| h)
            .map(|(&t, _)| t)
            .collect();
        let tap_times: Vec<f64> = taps.iter().map(|t| t.secs()).collect();
        let miss_x = of(false, &self.x);
        let half = g.effective_width_m / 2.0;
        let miss_size: Vec<f64> = miss_x
            .iter()
            .zip(of(false, &self.target))
            .map(|(x, c)| (x - c).abs() - half)
            .collect();
        let errors = miss_size.len();
        FittsData {
            condition: g.condition.clone(),
            amplitude_m: g.amplitude_m,
            width_m: g.width_m,
            cursor_m: g.cursor_m,
            effective_width_m: g.effective_width_m,
            id_bits: g.id_bits,
            completion_time_s: match (taps.first(), taps.last()) {
                (Some(&a), Some(&b)) if completed => Some((b - a).secs()),
                _ => None,
            },
            taps: u32::try_from(tap_times.len()).unwrap_or(u32::MAX),
            errors: u32::try_from(errors).unwrap_or(u32::MAX),
            mean_error_m: (errors > 0).then(|| miss_size.iter().sum::<f64>() / errors as f64),
            tap_x_m: of(true, &self.x),
            target_x_m: of(true, &self.target),
            tap_times_s: tap_times,
            miss_x_m: miss_x,
            click_times_s: self.times.iter().map(|t| t.secs()).collect(),
            click_x_m: self.x.clone(),
            click_target_x_m: self.target.clone(),
            click_hit: self.hit.clone(),
        }
    }
}

impl KindAnalysis for Fitts {
    fn analysis<K: Holds<Self>>() -> Option<AnalysisEntry<K>> {
        Some(AnalysisEntry {
            marker: "id_bits",
            unread: &[
                "cursor_m",
                "effective_width_m",
                "miss_x_m",
                "click_times_s",
                "click_x_m",
                "click_target_x_m",
                "click_hit",
            ],
            optional: &["click_times_s", "click_x_m", "click_target_x_m", "click_hit"],
            counts_aborted: true,
            counted: analysis::counted,
            run: |rows, context| {
                let f = analysis::analyze(rows)?;
                Ok(Section::new(context.report(|| report::fitts_section(&f)), f.summary, f.notes, f.tables))
            },
        })
    }
}
