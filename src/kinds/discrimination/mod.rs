//! Friction discrimination (issue 17): how small a difference of one model
//! parameter a person can feel, at several reference levels.
//!
//! Each trial is a two-interval forced choice: a reference and a
//! comparison, in an order drawn per trial, each explored as in a paired
//! comparison (the participant switches between them); then the protocol's
//! question ("which felt like more friction?") is answered first or
//! second. The comparison differs from the reference in one parameter of
//! the model (`parameter`, a field of the model object such as `mu_s` or
//! `static_friction.mu_s`) by a difference given as a ratio
//! (`level (1 + x)`) or an offset (`level + x`). The correct answer is the
//! comparison: the question must ask for the stimulus with more of the
//! parameter.
//!
//! Each reference level is one track of the protocol's adaptive method
//! (`frictionlab_psychophysics::adaptive`): a transformed up-down
//! staircase (1-up-n-down, optionally with Kaernbach's weighted steps) or
//! QUEST+. Each trial draws one of the tracks not yet stopped, at random,
//! and presents the difference that track asks for. The session ends when
//! every track has stopped.
//!
//! # State and resume
//! A track's state is a pure function of its answers: the trial source
//! replays the logged, completed answers of each track through its method
//! whenever it chooses a trial, so a session resumed after `kill -9`
//! continues every track exactly. Each record also logs the state its
//! stimulus was chosen in (trials, reversals, the current estimate and its
//! SD) as plain data.

use std::collections::VecDeque;
use std::sync::Arc;

use frictionlab_psychophysics::adaptive::{
    QuestPlus, QuestPlusSpec, QuestPlusTable, Staircase, StaircaseRule, kaernbach_up_ratio,
};
use frictionlab_psychophysics::decimal::Dec;
use frictionlab_psychophysics::psychometric::Shape;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use schemars::JsonSchema;
use serde::{Deserialize, Serialize};
use serde_json::Value;

use crate::analysis::{AnalysisEntry, KindAnalysis, Scope, Section, designs_of};
use crate::friction::ModelParams;
use crate::kinds::paired::{Compare, Paired, PairedData, PairedTrial};
use crate::protocol::check::{ValueChecks, MAX_TRIALS};
use crate::protocol::engine::{Action, Choice, Input, Status, TrialRecord, TrialSource};
use crate::protocol::kind::{WriteCells, Holds, Kinds, LiveTrial, Next, Quality, StudyKind, TrackAnswers};
use crate::protocol::load::{Walk, read_object};
use crate::protocol::plan::PlannedTrial;
use crate::protocol::{Condition, Protocol};
use crate::time::Time;

pub mod analysis;
pub mod report;
pub mod view;

/// The discrimination kind.
#[derive(Debug)]
pub struct Discrimination;

/// How the comparison differs from the reference.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum Comparison {
    /// `level (1 + x)`: `x` is the Weber fraction itself.
    Ratio,
    /// `level + x`, in the parameter's units.
    Offset,
}

impl Comparison {
    /// The comparison's value for reference `level` and difference `x`,
    /// on their decimals (`0.7 (1 + 0.15)` is `0.805`).
    #[must_use]
    pub fn value(self, level: f64, x: f64) -> f64 {
        let (level, x) = (Dec::of(level), Dec::of(x));
        match self {
            Comparison::Ratio => (level * (Dec::of(1.0) + x)).to_f64(),
            Comparison::Offset => (level + x).to_f64(),
        }
    }

    /// The Weber fraction of a difference `x` at reference `level`.
    #[must_use]
    pub fn weber(self, level: f64, x: f64) -> f64 {
        match self {
            Comparison::Ratio => x,
            Comparison::Offset => x / level,
        }
    }
}

/// A grid of values: listed, or `count` values from `from` to `to`
/// (both included), evenly or log-evenly spaced.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(untagged)]
pub enum Grid {
    /// The values, ascending.
    List(Vec<f64>),
    /// A spaced range.
    Range {
        /// First value.
        from: f64,
        /// Last value.
        to: f64,
        /// How many values (at least 2).
        count: usize,
        /// `linear` or `log`.
        #[serde(default)]
        spacing: Spacing,
    },
}

/// The spacing of a [`Grid::Range`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum Spacing {
    /// Equal differences.
    #[default]
    Linear,
    /// Equal ratios (both ends > 0).
    Log,
}

impl Grid {
    /// The grid's values (a range with a bad count or a log range through 0
    /// gives what it can; the design checks report those).
    #[must_use]
    pub fn values(&self) -> Vec<f64> {
        match self {
            Grid::List(v) => v.clone(),
            Grid::Range {
                from,
                to,
                count,
                spacing,
            } => {
                let n = (*count).clamp(1, MAX_GRID);
                #[expect(clippy::cast_precision_loss, reason = "a small count")]
                let at = |i: usize| {
                    let (i, last) = (i as f64, n.saturating_sub(1).max(1) as f64);
                    match spacing {
                        // On the decimals: 0 to 1 in 11 is 0, 0.1, ..., 1.
                        Spacing::Linear => {
                            let (from, to) = (Dec::of(*from), Dec::of(*to));
                            (from + (to - from) * Dec::of(i) / Dec::of(last)).to_f64()
                        }
                        Spacing::Log => (from.ln() + (to.ln() - from.ln()) * (i / last)).exp(),
                    }
                };
                (0..n).map(at).collect()
            }
        }
    }
}

/// A transformed up-down staircase over the difference `x`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct StaircaseMethod {
    /// Correct answers in a row that step the difference down: 2
    /// (1-up-2-down, converging on 70.7% correct) or 3 (1-up-3-down,
    /// 79.4%); 1 with `target` for Kaernbach's weighted 1-up-1-down.
    pub down: u32,
    /// First difference.
    pub start: f64,
    /// Down-step per phase: `steps[k]` after `k` reversals, the last one
    /// thereafter.
    pub steps: Vec<f64>,
    /// Kaernbach's (1991) weighted steps: the up step is the down step
    /// times `p^down / (1 - p^down)`, so the track converges on proportion
    /// correct `p` = `target`. Without it, up and down steps are equal.
    #[serde(default)]
    pub target: Option<f64>,
    /// Smallest difference presented.
    pub min: f64,
    /// Largest difference presented.
    pub max: f64,
    /// Stop a track after this many trials.
    #[serde(default)]
    pub stop_trials: Option<u32>,
    /// Or after this many reversals.
    #[serde(default)]
    pub stop_reversals: Option<u32>,
}

impl StaircaseMethod {
    /// The staircase's rule.
    #[must_use]
    pub fn rule(&self) -> StaircaseRule {
        StaircaseRule {
            down: self.down,
            start: self.start,
            steps: self.steps.clone(),
            up_ratio: self.target.map_or(1.0, |p| kaernbach_up_ratio(self.down, p)),
            min: self.min,
            max: self.max,
            stop_trials: self.stop_trials,
            stop_reversals: self.stop_reversals,
        }
    }
}

/// QUEST+ (Watson 2017) over the difference `x`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct QuestPlusMethod {
    /// The psychometric function's shape.
    pub shape: Shape,
    /// The differences it may present.
    pub stimuli: Grid,
    /// Threshold (location) grid, in units of the difference.
    pub thresholds: Grid,
    /// Slope grid.
    pub slopes: Grid,
    /// Lapse-rate grid.
    pub lapses: Grid,
    /// Stop a track after this many trials.
    #[serde(default)]
    pub stop_trials: Option<u32>,
    /// Or once the threshold's posterior SD is at most this.
    #[serde(default)]
    pub stop_threshold_sd: Option<f64>,
    /// Always stop here.
    pub max_trials: u32,
}

impl QuestPlusMethod {
    /// The method's specification for a two-interval task.
    #[must_use]
    pub fn spec(&self) -> QuestPlusSpec {
        QuestPlusSpec {
            shape: self.shape,
            guess: frictionlab_psychophysics::psychometric::GUESS_2IFC,
            stimuli: self.stimuli.values(),
            thresholds: self.thresholds.values(),
            slopes: self.slopes.values(),
            lapses: self.lapses.values(),
            stop_trials: self.stop_trials,
            stop_threshold_sd: self.stop_threshold_sd,
            max_trials: self.max_trials,
        }
    }
}

/// The adaptive method of every track.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Method {
    /// A transformed up-down staircase.
    Staircase(StaircaseMethod),
    /// QUEST+.
    QuestPlus(QuestPlusMethod),
}

/// How the analysis fits each track's answers.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct FitSettings {
    /// The psychometric function's shape.
    pub shape: Shape,
    /// Upper bound of the free lapse rate (guess rate 0.5).
    pub max_lapse: f64,
    /// Parametric-bootstrap samples for the confidence intervals.
    pub bootstrap: u32,
}

/// A discrimination study's design.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct DiscriminationDesign {
    /// Why the study is set up as it is (free text, kept in the protocol).
    #[serde(default)]
    pub reasons: Option<String>,
    /// The model; its `parameter` is set to each level and comparison.
    pub reference: ModelParams,
    /// The parameter varied: a field of the model object, nested fields
    /// joined by dots (`static_friction.mu_s`), or several fields set
    /// together joined by `+` (`fc_pos_n+fc_neg_n`).
    pub parameter: String,
    /// The reference levels of the parameter, one track each.
    pub levels: Vec<f64>,
    /// How the comparison differs from the reference.
    pub comparison: Comparison,
    /// The question, asking for the stimulus with more of the parameter.
    pub question: String,
    /// The quality the question asks about (`friction`, the default;
    /// `viscosity`; `stiffness`): what the simulated participant forms its
    /// percept of.
    #[serde(default)]
    pub judged: Quality,
    /// Longest exploration of each stimulus, s.
    pub exploration_s: f64,
    /// The proportion correct that defines the threshold (0.5-1).
    pub criterion: f64,
    /// The adaptive method of every track.
    pub method: Method,
    /// The analysis's psychometric fit.
    pub fit: FitSettings,
}

/// One discrimination trial.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DiscriminationTrial {
    /// The two stimuli, in presentation order (ids `reference`,
    /// `comparison`).
    pub pair: PairedTrial,
    /// The question.
    pub question: String,
    /// The quality the question asks about.
    #[serde(default)]
    pub judged: Quality,
    /// The track (index of its level).
    pub track: usize,
    /// The reference level.
    pub level: f64,
    /// The difference presented.
    pub difference: f64,
    /// The comparison's parameter value.
    pub comparison_value: f64,
    /// The track's state its difference was chosen in.
    pub state: TrackState,
}

/// A track's state as plain data.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct TrackState {
    /// Completed trials of the track before this one.
    pub trials: u32,
    /// Staircase reversals so far (0 for QUEST+).
    pub reversals: u32,
    /// The current estimate of the threshold difference: the mean of the
    /// reversals so far (staircase; none before the first), or the
    /// posterior mean (QUEST+).
    pub estimate: Option<f64>,
    /// QUEST+: the threshold's posterior SD.
    pub estimate_sd: Option<f64>,
}

/// What a discrimination trial logs.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct DiscriminationData {
    /// The track (index of its level).
    pub track: usize,
    /// The reference level.
    pub level: f64,
    /// The difference presented.
    pub difference: f64,
    /// The comparison's parameter value.
    pub comparison_value: f64,
    /// The answer, as a paired comparison logs it.
    pub answer: PairedData,
    /// Whether the comparison was chosen (none before an answer).
    pub correct: Option<bool>,
    /// The track's state the difference was chosen in.
    pub state: TrackState,
}

/// The live trial: a forced-choice comparison that remembers its track.
#[derive(Debug, Clone)]
pub struct TwoIntervals {
    compare: Compare,
    trial: DiscriminationTrial,
}

pub use crate::friction::{parameter_problem, parameter_value, with_parameter};

/// Checks the adaptive method; returns the smallest and largest difference
/// it may present.
fn method_range(method: &Method, c: &mut ValueChecks) -> (f64, f64) {
    match method {
        Method::Staircase(s) => {
            for (k, &step) in s.steps.iter().enumerate() {
                c.positive(&format!("method.steps[{k}]"), step);
            }
            if let Err((field, message)) = s.rule().check()
                && field != "steps"
            {
                c.err(&format!("method.{field}"), message);
            }
            if let Some(p) = s.target
                && !(p > 0.5 && p < 1.0)
            {
                c.err(
                    "method.target",
                    format!("a two-interval target lies between 0.5 and 1, got {p}"),
                );
            }
            (s.min, s.max)
        }
        Method::QuestPlus(q) => {
            if let Err((field, message)) = q.spec().check() {
                c.err(&format!("method.{field}"), message);
            }
            let v = q.stimuli.values();
            (
                v.iter().copied().fold(f64::INFINITY, f64::min),
                v.iter().copied().fold(f64::NEG_INFINITY, f64::max),
            )
        }
    }
}

/// The most points a grid's range may have.
pub const MAX_GRID: usize = 10_000;

/// What the method's fields make grow, bounded (issue 42): a grid's
/// points ([`MAX_GRID`]), and the session's trials, `levels` tracks of at
/// most `max_trials` (QUEST+) or `stop_trials` (a staircase, when set; one
/// stopped by reversals alone ends when its answers say).
fn method_size(method: &Method, levels: u64, c: &mut ValueChecks) {
    let most = match method {
        Method::QuestPlus(q) => {
            for (name, grid) in [
                ("stimuli", &q.stimuli),
                ("thresholds", &q.thresholds),
                ("slopes", &q.slopes),
                ("lapses", &q.lapses),
            ] {
                if let Grid::Range { count, .. } = grid {
                    c.at_most(
                        &format!("method.{name}.count"),
                        "the grid's points",
                        *count as u64,
                        MAX_GRID as u64,
                    );
                }
            }
            Some(("method.max_trials", q.max_trials))
        }
        Method::Staircase(s) => s.stop_trials.map(|n| ("method.stop_trials", n)),
    };
    if let Some((path, per_track)) = most {
        c.at_most(
            path,
            "the session's trials (levels x trials per track)",
            levels.saturating_mul(u64::from(per_track)),
            MAX_TRIALS,
        );
    }
}

impl StudyKind for Discrimination {
    type Design = DiscriminationDesign;
    type Trial = DiscriminationTrial;
    type Live = TwoIntervals;
    type Data = DiscriminationData;

    const COLUMNS: &'static [&'static str] = &[
        "track",
        "level",
        "difference",
        "comparison_value",
        "first",
        "second",
        "choice",
        "chosen",
        "correct",
    ];

    fn read(w: &mut Walk, v: &Value, path: &str) -> Option<DiscriminationDesign> {
        read_object!(w, v, path, ["kind"], DiscriminationDesign {
            reasons: optional(None),
            reference: model_field,
            parameter: required,
            levels: required,
            comparison: required,
            question: required,
            judged: optional(Quality::Friction),
            exploration_s: required,
            criterion: required,
            method: required,
            fit: required,
        })
    }

    /// The static coefficient of seed 000's god object against one
    /// reference, one up two down (70.7% correct).
    fn template() -> Value {
        serde_json::json!({
            "kind": "discrimination",
            "reference": {"model": "god-object-constant"},
            "parameter": "static_friction.mu_s",
            "levels": [1.0],
            "comparison": "ratio",
            "question": "Which stimulus felt like more friction?",
            "exploration_s": 3.0,
            "criterion": 0.75,
            "method": {
                "kind": "staircase",
                "start": 0.4,
                "steps": [0.1, 0.05],
                "down": 2,
                "min": 0.01,
                "max": 1.0,
                "stop_reversals": 8,
                "stop_trials": 60
            },
            "fit": {"shape": "weibull", "max_lapse": 0.06, "bootstrap": 200}
        })
    }

    fn check(d: &DiscriminationDesign, c: &mut ValueChecks) {
        c.positive_duration("exploration_s", d.exploration_s);
        method_size(&d.method, d.levels.len() as u64, c);
        if d.question.trim().is_empty() {
            c.err("question", "the participant needs a question");
        }
        if !(d.criterion > 0.5 && d.criterion < 1.0) {
            c.err(
                "criterion",
                format!(
                    "a two-interval criterion lies between 0.5 (chance) and 1, got {}",
                    d.criterion
                ),
            );
        }
        if !(d.fit.max_lapse >= 0.0 && d.fit.max_lapse < 1.0 - d.criterion) {
            c.err(
                "fit.max_lapse",
                format!(
                    "must be at least 0 and below 1 - criterion ({}), or the fitted function may never reach the criterion; got {}",
                    1.0 - d.criterion,
                    d.fit.max_lapse
                ),
            );
        }
        if !(100..=MAX_BOOTSTRAP).contains(&d.fit.bootstrap) {
            c.err(
                "fit.bootstrap",
                format!(
                    "from 100 samples (for a 95% interval) to {MAX_BOOTSTRAP} (each refits every track), got {}",
                    d.fit.bootstrap
                ),
            );
        }
        if let Some(why) = parameter_problem(&d.reference, &d.parameter) {
            c.err("parameter", why);
            return;
        }
        if d.levels.is_empty() {
            c.err("levels", "no reference levels: the protocol has zero trials");
        }
        let (lo, hi) = method_range(&d.method, c);
        if lo <= 0.0 {
            c.err(
                "method",
                format!("differences must be greater than 0 (the comparison has more of the parameter), got {lo}"),
            );
        }
        for (i, &level) in d.levels.iter().enumerate() {
            let path = format!("levels[{i}]");
            let problem = |value: f64| match with_parameter(&d.reference, &d.parameter, value) {
                None => Some(format!("{value} is not a valid value of '{}'", d.parameter)),
                Some(m) => m.first_problem().map(|p| {
                    let within = p.within.map_or(String::new(), |w| format!("{w}."));
                    format!("{within}{} {p}", p.field)
                }),
            };
            if !level.is_finite() {
                c.err(&path, format!("must be a finite number, got {level}"));
                continue;
            }
            if let Some(p) = problem(level) {
                c.err(
                    &path,
                    format!(
                        "reference {level} is outside the model's valid range: {p}"
                    ),
                );
                continue;
            }
            let top = d.comparison.value(level, hi);
            if let Some(p) = problem(top) {
                c.err(
                    &path,
                    format!(
                        "the comparison at the largest difference ({hi}) is {top}, outside the model's valid range: {p}"
                    ),
                );
            }
        }
    }

    /// None: the tracks make their trials (bounded by
    /// [`method_size`]).
    fn trials_per_repetition(_: &DiscriminationDesign) -> u64 {
        0
    }

    fn source<K: Holds<Self>>(
        _protocol: &Protocol<K>,
        design: &DiscriminationDesign,
        seed: u64,
        _participant_index: u32,
    ) -> Arc<dyn TrialSource<K>> {
        Arc::new(Source {
            design: design.clone(),
            seed,
            start: MethodStart::new(&design.method),
            memo: std::sync::Mutex::default(),
        })
    }

    fn judged(t: &DiscriminationTrial) -> Quality {
        t.judged
    }

    fn tracks<K: Holds<Self>>(history: &[TrialRecord<K>]) -> Vec<TrackAnswers> {
        tracks(history)
    }

    fn loop_rate_hz(t: &DiscriminationTrial) -> f64 {
        Paired::loop_rate_hz(&t.pair)
    }

    fn start<K: Kinds>(
        t: &DiscriminationTrial,
        now: Time,
        out: &mut VecDeque<Action<K>>,
    ) -> TwoIntervals {
        TwoIntervals {
            compare: Compare::start(&t.pair, Some(t.question.clone()), now, out),
            trial: t.clone(),
        }
    }

    fn row<W: WriteCells>(d: &DiscriminationData, out: &mut W) {
        out.whole(d.track as u64);
        out.num(d.level);
        out.num(d.difference);
        out.num(d.comparison_value);
        Paired::row(&d.answer, out);
        out.opt_text(d.correct.map(|c| if c { "1" } else { "0" }));
    }
}

impl LiveTrial for TwoIntervals {
    type Data = DiscriminationData;

    fn timeout(&self) -> Option<Time> {
        self.compare.timeout()
    }

    fn on_timeout<K: Kinds>(&mut self, now: Time, out: &mut VecDeque<Action<K>>) -> Next {
        self.compare.on_timeout(now, out)
    }

    fn on_input<K: Kinds>(
        &mut self,
        now: Time,
        input: Input,
        out: &mut VecDeque<Action<K>>,
    ) -> Next {
        self.compare.on_input(now, input, out)
    }

    fn data(&self, started: Time, now: Time, completed: bool) -> DiscriminationData {
        let answer = self.compare.data(started, now, completed);
        let correct = answer
            .choice
            .filter(|c| *c != Choice::NoDifference)
            .map(|_| answer.chosen.as_deref() == Some(COMPARISON));
        let t = &self.trial;
        DiscriminationData {
            track: t.track,
            level: t.level,
            difference: t.difference,
            comparison_value: t.comparison_value,
            answer,
            correct,
            state: t.state,
        }
    }
}

/// The most bootstrap samples a protocol may ask for: each refits every
/// track (about 0.15 ms a fit), so 100,000 take 15 s a track.
pub const MAX_BOOTSTRAP: u32 = 100_000;

/// The comparison's condition id.
pub const COMPARISON: &str = "comparison";
/// The reference's condition id.
pub const REFERENCE: &str = "reference";

/// One track's method, live.
#[derive(Debug, Clone)]
pub enum TrackMethod {
    /// A staircase and its rule.
    Staircase(Staircase, StaircaseRule),
    /// QUEST+.
    QuestPlus(Box<QuestPlus>),
}

/// A design's method made ready to start tracks: a staircase's rule, or
/// QUEST+'s likelihood table, computed once and shared by every track.
#[derive(Debug, Clone)]
pub enum MethodStart {
    /// A staircase's rule.
    Staircase(StaircaseRule),
    /// QUEST+'s table.
    QuestPlus(Arc<QuestPlusTable>),
}

impl MethodStart {
    /// `method`, ready.
    #[must_use]
    pub fn new(method: &Method) -> Self {
        match method {
            Method::Staircase(s) => MethodStart::Staircase(s.rule()),
            Method::QuestPlus(q) => MethodStart::QuestPlus(Arc::new(QuestPlusTable::new(&q.spec()))),
        }
    }

    /// A fresh track.
    #[must_use]
    pub fn track(&self) -> TrackMethod {
        match self {
            MethodStart::Staircase(rule) => {
                TrackMethod::Staircase(Staircase::new(rule), rule.clone())
            }
            MethodStart::QuestPlus(table) => {
                TrackMethod::QuestPlus(Box::new(QuestPlus::on(table.clone())))
            }
        }
    }
}

impl TrackMethod {
    /// A fresh track of `method`.
    #[must_use]
    pub fn new(method: &Method) -> Self {
        MethodStart::new(method).track()
    }

    /// The next difference, `None` once stopped.
    #[must_use]
    pub fn next(&self) -> Option<f64> {
        match self {
            TrackMethod::Staircase(s, rule) => s.next(rule),
            TrackMethod::QuestPlus(q) => q.next(),
        }
    }

    /// Takes one answer at difference `x`.
    pub fn update(&mut self, x: f64, correct: bool) {
        match self {
            TrackMethod::Staircase(s, rule) => s.update(rule, correct),
            TrackMethod::QuestPlus(q) => q.update(x, correct),
        }
    }

    /// The state as plain data.
    #[must_use]
    pub fn state(&self) -> TrackState {
        match self {
            TrackMethod::Staircase(s, _) => TrackState {
                trials: s.trials(),
                reversals: u32::try_from(s.reversals().len()).unwrap_or(u32::MAX),
                estimate: s.estimate(0),
                estimate_sd: None,
            },
            TrackMethod::QuestPlus(q) => TrackState {
                trials: q.trials(),
                reversals: 0,
                estimate: Some(q.mean().threshold),
                estimate_sd: Some(q.threshold_sd()),
            },
        }
    }
}

/// Every track of `design` after the completed answers of `history`
/// (re-queued and aborted trials change nothing).
#[must_use]
pub fn replay<K: Holds<Discrimination>>(
    design: &DiscriminationDesign,
    history: &[TrialRecord<K>],
) -> Vec<TrackMethod> {
    replay_from(&MethodStart::new(&design.method), design.levels.len(), history)
}

/// [`replay`] of `levels` tracks started from `start`.
fn replay_from<K: Holds<Discrimination>>(
    start: &MethodStart,
    levels: usize,
    history: &[TrialRecord<K>],
) -> Vec<TrackMethod> {
    let mut tracks: Vec<TrackMethod> = (0..levels).map(|_| start.track()).collect();
    for r in history {
        answer(&mut tracks, r);
    }
    tracks
}

/// Takes record `r`'s answer into its track, if it is a completed, final
/// answer of this kind; returns the track it moved.
fn answer<K: Holds<Discrimination>>(
    tracks: &mut [TrackMethod],
    r: &TrialRecord<K>,
) -> Option<usize> {
    if r.requeued || r.status != Status::Completed {
        return None;
    }
    let d = K::data_of(&r.data)?;
    let (track, correct) = (tracks.get_mut(d.track)?, d.correct?);
    track.update(d.difference, correct);
    Some(d.track)
}

/// What a record holds that a replay reads, folded into a running
/// fingerprint (`SplitMix64` steps): a source tells the history it replayed
/// by it.
fn fold<K: Holds<Discrimination>>(mut h: u64, r: &TrialRecord<K>) -> u64 {
    let d = K::data_of(&r.data);
    for v in [
        r.trial as u64,
        u64::from(r.requeued) | u64::from(r.status == Status::Completed) << 1,
        d.map_or(u64::MAX, |d| d.track as u64),
        d.map_or(0, |d| d.difference.to_bits()),
        d.and_then(|d| d.correct).map_or(2, u64::from),
    ] {
        h = (h ^ v).wrapping_add(0x9e37_79b9_7f4a_7c15);
        h = (h ^ (h >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        h = (h ^ (h >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        h ^= h >> 31;
    }
    h
}

/// The tracks a source last replayed: the records they took (a prefix of
/// the history, told by its fingerprint), the tracks, and each track's next
/// difference. A session's history only grows, so each trial replays only
/// the records since the last: a track's state is the same as a full replay
/// of the history gives (the same updates in the same order), and its next
/// difference is computed once per answer it takes.
#[derive(Debug, Default)]
struct Memo {
    taken: usize,
    fingerprint: u64,
    tracks: Vec<TrackMethod>,
    next: Vec<Option<f64>>,
}

/// The tracks of a discrimination session's records (none for another
/// kind's), by track index.
#[must_use]
pub fn tracks<K: Holds<Discrimination>>(history: &[TrialRecord<K>]) -> Vec<TrackAnswers> {
    let mut out: Vec<TrackAnswers> = Vec::new();
    for r in history
        .iter()
        .filter(|r| !r.requeued && r.status == Status::Completed)
    {
        let Some(d) = K::data_of(&r.data) else {
            continue;
        };
        let Some(correct) = d.correct else {
            continue;
        };
        if let Some(t) = out.iter_mut().find(|t| t.track == d.track) {
            t.answers.push((d.difference, correct));
        } else {
            out.push(TrackAnswers {
                track: d.track,
                name: format!("level {}", d.level),
                answers: vec![(d.difference, correct)],
            });
        }
    }
    out.sort_by_key(|t| t.track);
    out
}

/// The trials of a discrimination session: a pure function of the design,
/// the plan seed and the logged answers.
#[derive(Debug)]
struct Source {
    design: DiscriminationDesign,
    seed: u64,
    /// The design's method, ready (QUEST+'s table made once a session).
    start: MethodStart,
    memo: std::sync::Mutex<Memo>,
}

impl Source {
    /// Calls `f` with every track after the records of `history`, and each
    /// track's next difference (from the memo where it holds a prefix of
    /// `history`, else from a replay from the start).
    fn tracks<K: Holds<Discrimination>, R>(
        &self,
        history: &[TrialRecord<K>],
        f: impl FnOnce(&[TrackMethod], &[Option<f64>]) -> R,
    ) -> R {
        let mut memo = self
            .memo
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        let prefix = history.get(..memo.taken).unwrap_or_default();
        let same = memo.taken <= history.len()
            && !memo.tracks.is_empty()
            && prefix.iter().fold(0, fold) == memo.fingerprint;
        if !same {
            let tracks: Vec<TrackMethod> = (0..self.design.levels.len())
                .map(|_| self.start.track())
                .collect();
            *memo = Memo {
                taken: 0,
                fingerprint: 0,
                next: tracks.iter().map(TrackMethod::next).collect(),
                tracks,
            };
        }
        let Memo {
            taken,
            fingerprint,
            tracks,
            next,
        } = &mut *memo;
        for r in &history[*taken..] {
            if let Some(i) = answer(tracks, r) {
                next[i] = tracks[i].next();
            }
            *fingerprint = fold(*fingerprint, r);
        }
        *taken = history.len();
        f(tracks, next)
    }
}

/// `SplitMix64` of the plan seed and a trial position: the trial's seed.
fn trial_seed(seed: u64, index: usize) -> u64 {
    let mut z = seed.wrapping_add((index as u64 + 1).wrapping_mul(0x9e37_79b9_7f4a_7c15));
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

impl<K: Holds<Discrimination>> TrialSource<K> for Source {
    fn trial(&self, index: usize, history: &[TrialRecord<K>]) -> Option<PlannedTrial<K>> {
        let d = &self.design;
        let seed = trial_seed(self.seed, index);
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let (track, difference, state) = self.tracks(history, |tracks, next| {
            let open: Vec<(usize, f64)> = next
                .iter()
                .enumerate()
                .filter_map(|(i, x)| x.map(|x| (i, x)))
                .collect();
            if open.is_empty() {
                return None;
            }
            let (track, difference) = open[rng.random_range(0..open.len())];
            Some((track, difference, tracks[track].state()))
        })?;
        let level = d.levels[track];
        let comparison_value = d.comparison.value(level, difference);
        let with = |id: &str, value: f64| {
            with_parameter(&d.reference, &d.parameter, value).map(|model| Condition {
                id: id.into(),
                model,
            })
        };
        let (reference, comparison) = (with(REFERENCE, level)?, with(COMPARISON, comparison_value)?);
        let (first, second) = if rng.random_bool(0.5) {
            (comparison, reference)
        } else {
            (reference, comparison)
        };
        Some(PlannedTrial {
            index,
            block: "discrimination".into(),
            block_index: 0,
            practice: false,
            repetition: 0,
            seed,
            spec: K::wrap_trial(DiscriminationTrial {
                pair: PairedTrial {
                    first,
                    second,
                    exploration_s: d.exploration_s,
                },
                question: d.question.clone(),
                judged: d.judged,
                track,
                level,
                difference,
                comparison_value,
                state,
            }),
        })
    }

    fn planned(&self) -> Option<usize> {
        None
    }

    fn loop_rate_hz(&self) -> f64 {
        self.design.reference.loop_rate_hz()
    }
}

impl KindAnalysis for Discrimination {
    fn analysis<K: Holds<Self>>() -> Option<AnalysisEntry<K>> {
        Some(AnalysisEntry {
            marker: "comparison_value",
            unread: &["first", "second", "choice", "chosen"],
            optional: &[],
            counts_aborted: false,
            counted: analysis::counted,
            run: |rows, context| {
                let design = designs_of::<Self, K>(context.designs).next();
                let intervals = context.scope == Scope::Report;
                let d = analysis::analyze(rows, context.folder, design, intervals)?;
                Ok(Section::new(context.report(|| report::discrimination_section(&d)), d.summary, d.notes, d.tables))
            },
        })
    }
}
