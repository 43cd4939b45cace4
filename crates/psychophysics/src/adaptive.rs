//! Adaptive methods: each chooses the next trial's stimulus from the
//! answers so far.
//!
//! - [`Staircase`] under a [`StaircaseRule`]: a transformed up-down
//!   staircase (1-up-n-down, Levitt 1971) with optional weighted steps
//!   (Kaernbach 1991);
//! - [`QuestPlus`] from a [`QuestPlusSpec`]: QUEST+ (Watson 2017) over
//!   threshold, slope and lapse rate for a two-outcome task.
//!
//! Both are deterministic: no randomness, no clock. Their state is plain
//! data, and feeding the same answers through `update` in the same order
//! rebuilds it bit for bit, so a host can log only the answers and replay
//! them (on every trial, or after a kill -9) instead of saving the state.
//!
//! Neither panics on any rule or spec. The host checks a rule or spec
//! once, at protocol load ([`StaircaseRule::check`],
//! [`QuestPlusSpec::check`], each naming the offending field); a method
//! built from one that fails its check never offers a stimulus (`next`
//! is `None`).

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::psychometric::{Params, Shape};
use std::sync::Arc;

/// A problem with a rule or spec: the field at fault and what is wrong.
pub type Problem = (&'static str, String);

// ---------------------------------------------------------------------------
// Staircases
// ---------------------------------------------------------------------------

/// A transformed up-down staircase (1-up-n-down, Levitt 1971) with
/// optional weighted steps (Kaernbach 1991).
///
/// After `down` consecutive correct answers the stimulus steps down by the
/// current down step; after any wrong answer it steps up by `up_ratio`
/// times the current down step. The down step is `steps[k]` once the track
/// has made `k` reversals, and the last entry of `steps` thereafter (as
/// PsychoPy's `stepSizes`); a reversal is a step in the direction opposite
/// to the previous step. Steps are additive: for steps in dB or log units,
/// run the staircase on the log of the stimulus.
///
/// Unlike PsychoPy's `StairHandler` there is no initial 1-up-1-down phase
/// (its `applyInitialRule`), and the track stops when *either* stopping
/// rule is met (PsychoPy: both).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct StaircaseRule {
    /// Consecutive correct answers that step down (1, 2 or 3).
    pub down: u32,
    /// The first stimulus, in `[min, max]`.
    pub start: f64,
    /// Down-step size per phase: `steps[k]` applies after `k` reversals,
    /// the last one thereafter. Positive.
    pub steps: Vec<f64>,
    /// Up step = `up_ratio` × down step: 1 for the plain transformed rule,
    /// [`kaernbach_up_ratio`] for a weighted one.
    pub up_ratio: f64,
    /// The stimulus is clamped below at `min`.
    pub min: f64,
    /// The stimulus is clamped above at `max`.
    pub max: f64,
    /// Stop after this many trials.
    pub stop_trials: Option<u32>,
    /// Stop after this many reversals.
    pub stop_reversals: Option<u32>,
}

/// Kaernbach's (1991) weighted up step for a 1-up-`down`-down rule to
/// converge on proportion correct `target`, as a ratio to the down step:
/// `up / down = target^down / (1 - target^down)`.
///
/// 3 for `down = 1`, `target = 0.75`; 1 for `down = 2` at `sqrt(0.5)`.
#[must_use]
pub fn kaernbach_up_ratio(down: u32, target: f64) -> f64 {
    let q = target.powf(f64::from(down));
    q / (1.0 - q)
}

/// The proportion correct a 1-up-`down`-down rule with up step
/// `up_ratio` × down step converges on: the `p` at which a step down and a
/// step up balance, `p^down = up_ratio / (1 + up_ratio)` (Levitt 1971;
/// Kaernbach 1991). The inverse of [`kaernbach_up_ratio`].
#[must_use]
pub fn convergence(down: u32, up_ratio: f64) -> f64 {
    (up_ratio / (1.0 + up_ratio)).powf(1.0 / f64::from(down))
}

impl StaircaseRule {
    /// Whether the rule is usable; if not, the field at fault and why.
    ///
    /// # Errors
    /// `down` not in 1..=3; no steps, or a step not positive and finite;
    /// `up_ratio` not positive and finite; `min` or `max` not finite, or
    /// `min >= max`; `start` outside `[min, max]`; no stopping rule; a
    /// stopping rule of 0.
    pub fn check(&self) -> Result<(), Problem> {
        if !(1..=3).contains(&self.down) {
            return Err((
                "down",
                format!(
                    "{} consecutive correct answers to step down; the rule takes 1, 2 or 3",
                    self.down
                ),
            ));
        }
        if self.steps.is_empty() {
            return Err(("steps", "no step size given".to_owned()));
        }
        if let Some((k, s)) = self
            .steps
            .iter()
            .enumerate()
            .find(|(_, s)| !(s.is_finite() && **s > 0.0))
        {
            return Err((
                "steps",
                format!("step {k} is {s}; steps must be positive and finite"),
            ));
        }
        if !(self.up_ratio.is_finite() && self.up_ratio > 0.0) {
            return Err((
                "up_ratio",
                format!(
                    "{}; the up/down step ratio must be positive and finite",
                    self.up_ratio
                ),
            ));
        }
        if !self.min.is_finite() {
            return Err(("min", format!("{} is not finite", self.min)));
        }
        if !self.max.is_finite() {
            return Err(("max", format!("{} is not finite", self.max)));
        }
        if self.min >= self.max {
            return Err((
                "max",
                format!(
                    "max {} is not above min {}; the range is empty",
                    self.max, self.min
                ),
            ));
        }
        if !(self.start >= self.min && self.start <= self.max) {
            return Err((
                "start",
                format!(
                    "{} is outside [min, max] = [{}, {}]",
                    self.start, self.min, self.max
                ),
            ));
        }
        match (self.stop_trials, self.stop_reversals) {
            (None, None) => Err((
                "stop_trials",
                "no stopping rule: set stop_trials, stop_reversals or both".to_owned(),
            )),
            (Some(0), _) => Err((
                "stop_trials",
                "0 trials: the staircase would never start".to_owned(),
            )),
            (_, Some(0)) => Err((
                "stop_reversals",
                "0 reversals: the staircase would never start".to_owned(),
            )),
            _ => Ok(()),
        }
    }

    /// The down step after `reversals` reversals (NaN if there are no
    /// steps, which [`check`](Self::check) rejects).
    fn down_step(&self, reversals: usize) -> f64 {
        let k = reversals.min(self.steps.len().saturating_sub(1));
        self.steps.get(k).copied().unwrap_or(f64::NAN)
    }
}

/// The direction of a staircase step.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum Direction {
    /// The stimulus went up (after a wrong answer).
    Up,
    /// The stimulus went down (after `down` correct answers in a row).
    Down,
}

/// The state of a staircase run under a [`StaircaseRule`]: plain data,
/// rebuilt exactly by [`Staircase::replay`] from the answers.
///
/// The rule is not part of the state: pass the same rule to every call.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct Staircase {
    /// The stimulus of the next trial (before the stopping rule).
    x: f64,
    /// Consecutive correct answers since the last step or wrong answer.
    run: u32,
    /// Answers so far.
    trials: u32,
    /// The direction of the last step; `None` before the first.
    direction: Option<Direction>,
    /// The stimulus at each reversal (that of the trial whose answer
    /// reversed the track).
    reversals: Vec<f64>,
    /// The 1-based number of the trial whose answer made each reversal.
    reversal_trials: Vec<u32>,
}

impl Staircase {
    /// A staircase before its first trial, at `rule.start`.
    #[must_use]
    pub fn new(rule: &StaircaseRule) -> Self {
        Self {
            x: rule.start,
            run: 0,
            trials: 0,
            direction: None,
            reversals: Vec::new(),
            reversal_trials: Vec::new(),
        }
    }

    /// The staircase after `answers` (correct or not, in trial order)
    /// from [`new`](Self::new).
    #[must_use]
    pub fn replay(rule: &StaircaseRule, answers: impl IntoIterator<Item = bool>) -> Self {
        let mut s = Self::new(rule);
        for correct in answers {
            s.update(rule, correct);
        }
        s
    }

    /// The next trial's stimulus; `None` once a stopping rule is met, or
    /// if the rule fails [`StaircaseRule::check`].
    #[must_use]
    pub fn next(&self, rule: &StaircaseRule) -> Option<f64> {
        (rule.check().is_ok() && !self.stopped(rule)).then_some(self.x)
    }

    /// Whether a stopping rule is met.
    #[must_use]
    pub fn stopped(&self, rule: &StaircaseRule) -> bool {
        rule.stop_trials.is_some_and(|n| self.trials >= n)
            || rule
                .stop_reversals
                .is_some_and(|n| self.reversals.len() >= n as usize)
    }

    /// Takes the answer to a trial at the current stimulus ([`x`](Self::x),
    /// the one [`next`](Self::next) offered) and moves the stimulus.
    ///
    /// Answers are taken even after a stopping rule is met (the state stays
    /// a function of the answers alone); `next` is what stops.
    pub fn update(&mut self, rule: &StaircaseRule, correct: bool) {
        let x = self.x;
        self.trials = self.trials.saturating_add(1);
        let direction = if correct {
            self.run = self.run.saturating_add(1);
            if self.run < rule.down {
                return;
            }
            Direction::Down
        } else {
            Direction::Up
        };
        self.run = 0;
        if self.direction.is_some_and(|d| d != direction) {
            self.reversals.push(x);
            self.reversal_trials.push(self.trials);
        }
        self.direction = Some(direction);
        let down = rule.down_step(self.reversals.len());
        // On the design's decimals: a track that steps down and back up
        // returns to the very value it left (issue 42).
        let moved = match direction {
            Direction::Down => crate::decimal::sub(x, down),
            Direction::Up => {
                use crate::decimal::Dec;
                (Dec::of(x) + Dec::of(rule.up_ratio) * Dec::of(down)).to_f64()
            }
        };
        // Not f64::clamp, which panics on min > max or NaN bounds.
        self.x = moved.max(rule.min).min(rule.max);
    }

    /// The current stimulus (the next trial's, unless the track stopped).
    #[must_use]
    pub fn x(&self) -> f64 {
        self.x
    }

    /// Consecutive correct answers since the last step or wrong answer.
    #[must_use]
    pub fn run(&self) -> u32 {
        self.run
    }

    /// Answers taken so far.
    #[must_use]
    pub fn trials(&self) -> u32 {
        self.trials
    }

    /// The direction of the last step; `None` before the first.
    #[must_use]
    pub fn direction(&self) -> Option<Direction> {
        self.direction
    }

    /// The stimulus at each reversal: that of the trial whose answer
    /// reversed the track (as PsychoPy's `reversalIntensities`).
    #[must_use]
    pub fn reversals(&self) -> &[f64] {
        &self.reversals
    }

    /// The 1-based number of the trial whose answer made each reversal.
    #[must_use]
    pub fn reversal_trials(&self) -> &[u32] {
        &self.reversal_trials
    }

    /// The mean of the reversal stimuli after the first `discard`; `None`
    /// if there are none.
    #[must_use]
    pub fn estimate(&self, discard: usize) -> Option<f64> {
        let late = self.reversals.get(discard..)?;
        (!late.is_empty()).then(|| late.iter().sum::<f64>() / late.len() as f64)
    }
}

// ---------------------------------------------------------------------------
// QUEST+
// ---------------------------------------------------------------------------

/// The largest likelihood table [`QuestPlus`] builds: stimuli × thresholds
/// × slopes × lapses entries (two tables of `f64`, 64 MiB at this size).
/// A realistic grid (30 × 30 × 6 × 4) has 21 600.
pub const MAX_TABLE: usize = 1 << 22;

/// QUEST+ (Watson 2017) over threshold, slope and lapse rate for a
/// two-outcome task, with the psychometric function
/// `guess + (1 - guess - lapse) F(x; threshold, slope)` of
/// [`crate::psychometric`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct QuestPlusSpec {
    /// The sigmoid `F`.
    pub shape: Shape,
    /// The guess rate, in `[0, 1)` (0.5 for two intervals).
    pub guess: f64,
    /// The stimuli to choose from, strictly increasing.
    pub stimuli: Vec<f64>,
    /// The threshold grid, strictly increasing.
    pub thresholds: Vec<f64>,
    /// The slope grid, strictly increasing, positive.
    pub slopes: Vec<f64>,
    /// The lapse-rate grid, strictly increasing, in `[0, 1 - guess)`.
    pub lapses: Vec<f64>,
    /// Stop after this many trials.
    pub stop_trials: Option<u32>,
    /// Or once the posterior SD of the threshold is at most this.
    pub stop_threshold_sd: Option<f64>,
    /// Always stop here (guarantees an end).
    pub max_trials: u32,
}

/// A grid is non-empty, finite and strictly increasing.
fn check_grid(field: &'static str, grid: &[f64]) -> Result<(), Problem> {
    if grid.is_empty() {
        return Err((field, "the grid is empty".to_owned()));
    }
    if let Some((i, v)) = grid.iter().enumerate().find(|(_, v)| !v.is_finite()) {
        return Err((field, format!("entry {i} is {v}, not finite")));
    }
    if let Some(i) = grid.windows(2).position(|w| w[0] >= w[1]) {
        return Err((
            field,
            format!(
                "not strictly increasing: entry {} is {} after {}",
                i + 1,
                grid[i + 1],
                grid[i]
            ),
        ));
    }
    Ok(())
}

impl QuestPlusSpec {
    /// Whether the spec is usable; if not, the field at fault and why.
    ///
    /// # Errors
    /// `guess` outside `[0, 1)`; a grid empty, not finite or not strictly
    /// increasing; a slope not positive; a lapse rate outside
    /// `[0, 1 - guess)`; for the Weibull, a threshold or stimulus not
    /// positive; `stop_trials` 0; `stop_threshold_sd` not positive and
    /// finite; `max_trials` 0; a likelihood table over [`MAX_TABLE`].
    pub fn check(&self) -> Result<(), Problem> {
        if !(self.guess >= 0.0 && self.guess < 1.0) {
            return Err(("guess", format!("{} is outside [0, 1)", self.guess)));
        }
        check_grid("stimuli", &self.stimuli)?;
        check_grid("thresholds", &self.thresholds)?;
        check_grid("slopes", &self.slopes)?;
        check_grid("lapses", &self.lapses)?;
        if let Some(s) = self.slopes.first().filter(|s| **s <= 0.0) {
            return Err(("slopes", format!("slope {s} is not positive")));
        }
        if let Some(l) = self
            .lapses
            .iter()
            .find(|l| !(**l >= 0.0 && **l < 1.0 - self.guess))
        {
            return Err((
                "lapses",
                format!(
                    "lapse rate {l} is outside [0, 1 - guess) = [0, {})",
                    1.0 - self.guess
                ),
            ));
        }
        if self.shape == Shape::Weibull {
            if let Some(t) = self.thresholds.first().filter(|t| **t <= 0.0) {
                return Err((
                    "thresholds",
                    format!("threshold {t} is not positive, as the Weibull needs"),
                ));
            }
            if let Some(x) = self.stimuli.first().filter(|x| **x <= 0.0) {
                return Err((
                    "stimuli",
                    format!("stimulus {x} is not positive, as the Weibull needs"),
                ));
            }
        }
        if self.stop_trials == Some(0) {
            return Err((
                "stop_trials",
                "0 trials: QUEST+ would never start".to_owned(),
            ));
        }
        if let Some(sd) = self.stop_threshold_sd
            && !(sd.is_finite() && sd > 0.0)
        {
            return Err((
                "stop_threshold_sd",
                format!("{sd}; the stopping SD must be positive and finite"),
            ));
        }
        if self.max_trials == 0 {
            return Err((
                "max_trials",
                "0 trials: QUEST+ would never start".to_owned(),
            ));
        }
        let table = [self.thresholds.len(), self.slopes.len(), self.lapses.len()]
            .iter()
            .try_fold(self.stimuli.len(), |n, m| n.checked_mul(*m));
        if table.is_none_or(|n| n > MAX_TABLE) {
            return Err((
                "stimuli",
                format!(
                    "{} stimuli × {} thresholds × {} slopes × {} lapses is over the {MAX_TABLE} entries a likelihood table may have",
                    self.stimuli.len(),
                    self.thresholds.len(),
                    self.slopes.len(),
                    self.lapses.len()
                ),
            ));
        }
        Ok(())
    }
}

/// What a QUEST+ run logs after each trial.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct QuestPlusState {
    /// Answers taken so far.
    pub trials: u32,
    /// The posterior mean of each parameter's marginal.
    pub mean: Params,
    /// The SD of the threshold's marginal posterior.
    pub threshold_sd: f64,
}

/// `v ln v`, 0 at 0 (the entropy convention).
fn xlnx(v: f64) -> f64 {
    if v > 0.0 { v * v.ln() } else { 0.0 }
}

/// The likelihood table of a QUEST+ spec's grid: `P(correct | stimulus,
/// params)` and the answer's entropy for each entry. Computed once
/// ([`QuestPlusTable::new`]) and shared by every run on the spec
/// ([`QuestPlus::on`]): a run's state is its posterior alone.
#[derive(Debug, Clone, PartialEq)]
pub struct QuestPlusTable {
    spec: QuestPlusSpec,
    problem: Option<Problem>,
    /// Parameter sets in the grid.
    n_params: usize,
    /// `P(correct | stimulus, params)`, stimulus-major.
    p_correct: Vec<f64>,
    /// `pc ln pc + (1 - pc) ln(1 - pc)` of each entry of `p_correct`: minus
    /// the entropy of the answer given the parameters.
    neg_entropy: Vec<f64>,
}

impl QuestPlusTable {
    /// The table of `spec` (empty, with the spec's problem, if it fails
    /// [`QuestPlusSpec::check`]).
    #[must_use]
    pub fn new(spec: &QuestPlusSpec) -> Self {
        let mut t = Self {
            spec: spec.clone(),
            problem: spec.check().err(),
            n_params: 0,
            p_correct: Vec::new(),
            neg_entropy: Vec::new(),
        };
        if t.problem.is_some() {
            return t;
        }
        let n_params = spec.thresholds.len() * spec.slopes.len() * spec.lapses.len();
        let n = spec.stimuli.len() * n_params;
        t.n_params = n_params;
        t.p_correct.reserve_exact(n);
        t.neg_entropy.reserve_exact(n);
        for &x in &spec.stimuli {
            for &threshold in &spec.thresholds {
                for &slope in &spec.slopes {
                    let f = spec.shape.f(x, threshold, slope);
                    for &lapse in &spec.lapses {
                        // As Psychometric::p_correct, to the bit.
                        let pc = spec.guess + (1.0 - spec.guess - lapse) * f;
                        t.p_correct.push(pc);
                        t.neg_entropy.push(xlnx(pc) + xlnx(1.0 - pc));
                    }
                }
            }
        }
        t
    }
}

/// A QUEST+ run: the likelihood table of the spec's grid (shared) and the
/// posterior over it after the answers so far.
///
/// The parameter sets are indexed threshold-major, lapse-minor:
/// `(threshold_index * slopes + slope_index) * lapses + lapse_index`.
/// The posterior is kept normalised, multiplied by each answer's likelihood
/// and divided by its sum (no logs), so it is a plain function of the
/// answers: replaying them gives the same bits.
#[derive(Debug, Clone, PartialEq)]
pub struct QuestPlus {
    table: Arc<QuestPlusTable>,
    /// The posterior over the parameter sets, summing to 1.
    posterior: Vec<f64>,
    trials: u32,
}

impl QuestPlus {
    /// A run before its first trial, with a uniform prior over the grid.
    ///
    /// From a spec that fails [`QuestPlusSpec::check`] it is inert:
    /// [`next`](Self::next) is `None`, [`update`](Self::update) does
    /// nothing, the estimates are NaN and [`problem`](Self::problem) says
    /// why.
    #[must_use]
    pub fn new(spec: &QuestPlusSpec) -> Self {
        Self::on(Arc::new(QuestPlusTable::new(spec)))
    }

    /// A run before its first trial on a table already made (many runs on
    /// one spec share it), with a uniform prior over the grid.
    #[must_use]
    pub fn on(table: Arc<QuestPlusTable>) -> Self {
        let posterior = if table.problem.is_some() {
            Vec::new()
        } else {
            vec![1.0 / table.n_params as f64; table.n_params]
        };
        Self {
            table,
            posterior,
            trials: 0,
        }
    }

    /// The run after `answers` (stimulus, correct; in trial order) from
    /// [`new`](Self::new).
    #[must_use]
    pub fn replay(spec: &QuestPlusSpec, answers: impl IntoIterator<Item = (f64, bool)>) -> Self {
        let mut q = Self::new(spec);
        for (x, correct) in answers {
            q.update(x, correct);
        }
        q
    }

    /// The spec's problem if it failed [`QuestPlusSpec::check`].
    #[must_use]
    pub fn problem(&self) -> Option<&Problem> {
        self.table.problem.as_ref()
    }

    /// The spec the run was built from.
    #[must_use]
    pub fn spec(&self) -> &QuestPlusSpec {
        &self.table.spec
    }

    /// The posterior over the parameter sets (indexing in the type's docs).
    #[must_use]
    pub fn posterior(&self) -> &[f64] {
        &self.posterior
    }

    /// Answers taken so far.
    #[must_use]
    pub fn trials(&self) -> u32 {
        self.trials
    }

    /// Whether a stopping rule is met (or the spec is unusable).
    #[must_use]
    pub fn stopped(&self) -> bool {
        self.table.problem.is_some()
            || self.trials >= self.table.spec.max_trials
            || self
                .table
                .spec
                .stop_trials
                .is_some_and(|n| self.trials >= n)
            || self
                .table
                .spec
                .stop_threshold_sd
                .is_some_and(|sd| self.threshold_sd() <= sd)
    }

    /// The next trial's stimulus: the one minimising the expected entropy
    /// of the posterior after its answer (Watson 2017), the lowest such on
    /// ties; `None` once a stopping rule is met.
    #[must_use]
    pub fn next(&self) -> Option<f64> {
        if self.stopped() {
            return None;
        }
        let mut best: Option<(usize, f64)> = None;
        for (i, h) in self.entropy_scores().enumerate() {
            if best.is_none_or(|(_, b)| h < b) {
                best = Some((i, h));
            }
        }
        best.and_then(|(i, _)| self.table.spec.stimuli.get(i).copied())
    }

    /// The expected entropy (nats) of the posterior after a trial at each
    /// stimulus, in the spec's order: what [`next`](Self::next) minimises.
    #[must_use]
    pub fn expected_entropies(&self) -> Vec<f64> {
        let h: f64 = -self.posterior.iter().map(|&p| xlnx(p)).sum::<f64>();
        self.entropy_scores().map(|s| h + s).collect()
    }

    /// The expected posterior entropy at each stimulus less the current
    /// posterior entropy (the same for all stimuli): minus the mutual
    /// information of the answer and the parameters.
    ///
    /// With `P_o` the chance of outcome `o` and `L_o` its likelihood,
    /// `sum_o P_o H(post L_o / P_o) = H(post) + sum_o P_o ln P_o -
    /// sum_params post sum_o L_o ln L_o`, so each stimulus costs two dot
    /// products with precomputed rows and no logarithm of the posterior.
    fn entropy_scores(&self) -> impl Iterator<Item = f64> + '_ {
        let n = self.table.n_params.max(1);
        self.table
            .p_correct
            .chunks_exact(n)
            .zip(self.table.neg_entropy.chunks_exact(n))
            .map(|(pc, ne)| {
                let mut p1 = 0.0;
                let mut info = 0.0;
                for ((&w, &l), &e) in self.posterior.iter().zip(pc).zip(ne) {
                    p1 += w * l;
                    info += w * e;
                }
                let p1 = p1.clamp(0.0, 1.0);
                xlnx(p1) + xlnx(1.0 - p1) - info
            })
    }

    /// The index of the grid stimulus nearest `x` (the lower on a tie).
    fn nearest(&self, x: f64) -> usize {
        let s = &self.table.spec.stimuli;
        let k = s.partition_point(|&v| v < x);
        if k == 0 {
            0
        } else if k >= s.len() {
            s.len() - 1
        } else if x - s[k - 1] <= s[k] - x {
            k - 1
        } else {
            k
        }
    }

    /// Takes the answer to a trial at `x`, matched to the nearest grid
    /// stimulus: multiplies the posterior by the answer's likelihood and
    /// normalises it.
    ///
    /// A NaN `x`, or any answer to an inert run, is ignored (not counted).
    /// An answer impossible under every parameter set (possible only with
    /// lapse rate 0 alone on the grid) leaves the posterior as it was but
    /// counts as a trial.
    pub fn update(&mut self, x: f64, correct: bool) {
        if self.table.problem.is_some() || x.is_nan() {
            return;
        }
        let n = self.table.n_params;
        let i = self.nearest(x);
        let Some(row) = self.table.p_correct.get(i * n..(i + 1) * n) else {
            return;
        };
        let likelihood = |pc: f64| if correct { pc } else { 1.0 - pc };
        let sum: f64 = self
            .posterior
            .iter()
            .zip(row)
            .map(|(&w, &pc)| w * likelihood(pc))
            .sum();
        if sum > 0.0 && sum.is_finite() {
            for (w, &pc) in self.posterior.iter_mut().zip(row) {
                *w = *w * likelihood(pc) / sum;
            }
        }
        self.trials = self.trials.saturating_add(1);
    }

    /// The posterior means of each parameter's marginal (NaN if inert).
    #[must_use]
    pub fn mean(&self) -> Params {
        if self.table.problem.is_some() {
            return Params {
                threshold: f64::NAN,
                slope: f64::NAN,
                lapse: f64::NAN,
            };
        }
        let (mut threshold, mut slope, mut lapse) = (0.0, 0.0, 0.0);
        let mut w = self.posterior.iter();
        for &t in &self.table.spec.thresholds {
            for &s in &self.table.spec.slopes {
                for &l in &self.table.spec.lapses {
                    let p = w.next().copied().unwrap_or(0.0);
                    threshold += p * t;
                    slope += p * s;
                    lapse += p * l;
                }
            }
        }
        Params {
            threshold,
            slope,
            lapse,
        }
    }

    /// The marginal posterior of the threshold, over the spec's thresholds.
    #[must_use]
    pub fn threshold_marginal(&self) -> Vec<f64> {
        let per = self.table.spec.slopes.len() * self.table.spec.lapses.len();
        if per == 0 {
            return Vec::new();
        }
        self.posterior
            .chunks_exact(per)
            .map(|c| c.iter().sum())
            .collect()
    }

    /// The SD of the threshold's marginal posterior (NaN if inert).
    #[must_use]
    pub fn threshold_sd(&self) -> f64 {
        if self.table.problem.is_some() {
            return f64::NAN;
        }
        let marginal = self.threshold_marginal();
        let t = &self.table.spec.thresholds;
        let mean: f64 = marginal.iter().zip(t).map(|(p, t)| p * t).sum();
        let var: f64 = marginal
            .iter()
            .zip(t)
            .map(|(p, t)| p * (t - mean) * (t - mean))
            .sum();
        var.sqrt()
    }

    /// What to log after a trial.
    #[must_use]
    pub fn state(&self) -> QuestPlusState {
        QuestPlusState {
            trials: self.trials,
            mean: self.mean(),
            threshold_sd: self.threshold_sd(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::psychometric::{GUESS_2IFC, Psychometric};
    use rand::{RngExt, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// Breaks one field of a valid rule or spec.
    type Breaker<T> = Box<dyn Fn(&mut T)>;

    // --- staircases -------------------------------------------------------

    /// Runs `answers` through a staircase, checking before each that `next`
    /// offers the current stimulus, and after each the expected stimulus.
    fn walk(rule: &StaircaseRule, answers: &[(bool, f64)]) -> Staircase {
        let mut s = Staircase::new(rule);
        for (i, &(correct, after)) in answers.iter().enumerate() {
            assert_eq!(s.next(rule), Some(s.x()), "trial {}", i + 1);
            s.update(rule, correct);
            assert_eq!(s.x(), after, "after trial {}", i + 1);
            assert_eq!(s.trials() as usize, i + 1);
        }
        s
    }

    #[test]
    fn one_up_two_down_follows_the_hand_worked_sequence_with_step_phases_clamping_and_a_trial_stop()
    {
        let rule = StaircaseRule {
            down: 2,
            start: 10.0,
            steps: vec![4.0, 2.0, 1.0],
            up_ratio: 1.0,
            min: 1.0,
            max: 10.0,
            stop_trials: Some(17),
            stop_reversals: None,
        };
        rule.check().unwrap();
        let (c, w) = (true, false);
        let s = walk(
            &rule,
            &[
                (c, 10.0),
                (c, 6.0), // first step: down by steps[0] = 4, no reversal
                (c, 6.0),
                (c, 2.0),
                (c, 2.0),
                (c, 1.0), // 2 - 4 clamped at min
                (w, 3.0), // reversal 1 at 1: steps[1] = 2 from now
                (w, 5.0),
                (c, 5.0),
                (w, 7.0), // a wrong answer resets the run of correct ones
                (c, 7.0),
                (c, 6.0), // reversal 2 at 7: steps[2] = 1
                (w, 7.0), // reversal 3 at 6: still the last step, 1
                (w, 8.0),
                (w, 9.0),
                (w, 10.0),
                (w, 10.0), // 11 clamped at max
            ],
        );
        assert_eq!(s.reversals(), &[1.0, 7.0, 6.0]);
        assert_eq!(s.reversal_trials(), &[7, 12, 13]);
        assert_eq!(s.direction(), Some(Direction::Up));
        assert_eq!(s.next(&rule), None, "stops after 17 trials");
        assert_eq!(s.estimate(0), Some(14.0 / 3.0));
        assert_eq!(s.estimate(1), Some(6.5));
        assert_eq!(s.estimate(3), None);
        assert_eq!(s.estimate(9), None);
    }

    #[test]
    fn one_up_three_down_weighted_follows_the_hand_worked_sequence_and_stops_on_reversals() {
        // Dyadic numbers: every step is exact, so the stimuli compare with ==.
        let rule = StaircaseRule {
            down: 3,
            start: 1.0,
            steps: vec![0.25, 0.125],
            up_ratio: 1.5,
            min: 0.0,
            max: 2.0,
            stop_trials: None,
            stop_reversals: Some(3),
        };
        rule.check().unwrap();
        let (c, w) = (true, false);
        let s = walk(
            &rule,
            &[
                (c, 1.0),
                (c, 1.0),
                (c, 0.75),   // three right: down by steps[0]
                (w, 0.9375), // reversal 1 at 0.75; up 1.5 × steps[1]
                (c, 0.9375),
                (c, 0.9375),
                (w, 1.125), // two right then wrong: up again, no reversal
                (c, 1.125),
                (c, 1.125),
                (c, 1.0),    // reversal 2 at 1.125
                (w, 1.1875), // reversal 3 at 1.0
            ],
        );
        assert_eq!(s.reversals(), &[0.75, 1.125, 1.0]);
        assert_eq!(s.reversal_trials(), &[4, 10, 11]);
        assert_eq!(s.next(&rule), None, "stops at 3 reversals");
        assert_eq!(s.estimate(1), Some(1.0625));
    }

    #[test]
    fn kaernbach_ratio_for_one_down_at_75_percent_is_3_and_convergence_inverts_it() {
        assert_eq!(kaernbach_up_ratio(1, 0.75), 3.0);
        assert_eq!(convergence(1, 3.0), 0.75);
        assert!((convergence(2, 1.0) - 0.5_f64.sqrt()).abs() < 1e-15);
        assert!((convergence(3, 1.0) - 0.5_f64.powf(1.0 / 3.0)).abs() < 1e-15);
        for down in 1..=3 {
            for target in [0.6, 0.75, 0.8, 0.9] {
                let r = kaernbach_up_ratio(down, target);
                assert!(
                    (convergence(down, r) - target).abs() < 1e-14,
                    "{down} {target}"
                );
            }
        }
    }

    #[test]
    fn simulated_observers_converge_near_where_p_correct_equals_the_rules_convergence() {
        // Observer: cumulative normal, threshold 5, slope 1 (SD 1 stimulus
        // unit), no lapse, 2IFC. 400 seeded runs a rule, each to 60
        // reversals from 8 (3 above threshold); the estimate is the mean of
        // the last 48 (the first 12 discarded, well past the step phases).
        //
        // Tolerance: half the final down step (0.0625, about 1.2 points of
        // proportion correct at these targets). The run-to-run SD of an
        // estimate is 0.14 to 0.22, so the grand mean's SE is about 0.01;
        // what remains is the known step-size bias of up-down rules
        // (García-Pérez 1998), which scales with the step: for 1-up-2-down
        // the mean sits 0.12, 0.067 and 0.034 below the target at final
        // steps 0.5, 0.25 and 0.125 (measured with this test).
        let observer = Psychometric {
            shape: Shape::CumulativeNormal,
            params: Params {
                threshold: 5.0,
                slope: 1.0,
                lapse: 0.0,
            },
            guess: GUESS_2IFC,
        };
        let final_step = 0.125;
        for (down, up_ratio) in [
            (2, 1.0),
            (3, 1.0),
            (1, kaernbach_up_ratio(1, 0.75)),
            (2, kaernbach_up_ratio(2, 0.8)),
        ] {
            let rule = StaircaseRule {
                down,
                start: 8.0,
                steps: vec![1.0, 0.5, 0.25, final_step],
                up_ratio,
                min: 0.0,
                max: 12.0,
                stop_trials: None,
                stop_reversals: Some(60),
            };
            rule.check().unwrap();
            let target_p = convergence(down, up_ratio);
            let target = observer.threshold_at(target_p).unwrap();
            let runs = 400;
            let mut estimates = Vec::with_capacity(runs);
            for seed in 0..runs as u64 {
                let mut rng = ChaCha8Rng::seed_from_u64(seed);
                let mut s = Staircase::new(&rule);
                while let Some(x) = s.next(&rule) {
                    s.update(&rule, rng.random::<f64>() < observer.p_correct(x));
                }
                assert_eq!(s.reversals().len(), 60);
                estimates.push(s.estimate(12).unwrap());
            }
            let n = estimates.len() as f64;
            let mean = estimates.iter().sum::<f64>() / n;
            let sd = (estimates.iter().map(|e| (e - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
            println!(
                "1-up-{down}-down, up/down {up_ratio:.4}: target p {target_p:.4} at x {target:.4}; \
                 mean of late reversals {mean:.4} (SD {sd:.3}, SE {:.4}; p there {:.4})",
                sd / n.sqrt(),
                observer.p_correct(mean)
            );
            assert!(
                (mean - target).abs() < final_step / 2.0,
                "1-up-{down}-down, ratio {up_ratio}: {mean} vs {target}"
            );
        }
    }

    fn valid_rule() -> StaircaseRule {
        StaircaseRule {
            down: 2,
            start: 5.0,
            steps: vec![1.0, 0.5],
            up_ratio: 1.0,
            min: 0.0,
            max: 10.0,
            stop_trials: Some(50),
            stop_reversals: None,
        }
    }

    #[test]
    fn staircase_rule_check_names_each_problem_and_an_invalid_rule_gives_no_stimulus_and_no_panic()
    {
        valid_rule().check().unwrap();
        let cases: Vec<(&str, Breaker<StaircaseRule>)> = vec![
            ("down", Box::new(|r| r.down = 0)),
            ("down", Box::new(|r| r.down = 4)),
            ("steps", Box::new(|r| r.steps.clear())),
            ("steps", Box::new(|r| r.steps = vec![1.0, 0.0])),
            ("steps", Box::new(|r| r.steps = vec![-1.0])),
            ("steps", Box::new(|r| r.steps = vec![f64::NAN])),
            ("steps", Box::new(|r| r.steps = vec![f64::INFINITY])),
            ("up_ratio", Box::new(|r| r.up_ratio = 0.0)),
            ("up_ratio", Box::new(|r| r.up_ratio = -2.0)),
            ("up_ratio", Box::new(|r| r.up_ratio = f64::NAN)),
            ("min", Box::new(|r| r.min = f64::NAN)),
            ("max", Box::new(|r| r.max = f64::INFINITY)),
            ("max", Box::new(|r| r.max = r.min)),
            ("max", Box::new(|r| (r.min, r.max) = (10.0, 0.0))),
            ("start", Box::new(|r| r.start = 11.0)),
            ("start", Box::new(|r| r.start = f64::NAN)),
            ("stop_trials", Box::new(|r| r.stop_trials = None)),
            ("stop_trials", Box::new(|r| r.stop_trials = Some(0))),
            (
                "stop_reversals",
                Box::new(|r| (r.stop_trials, r.stop_reversals) = (None, Some(0))),
            ),
        ];
        for (field, break_it) in cases {
            let mut rule = valid_rule();
            break_it(&mut rule);
            let (got, why) = rule.check().unwrap_err();
            assert_eq!(got, field, "{rule:?}: {why}");
            let mut s = Staircase::new(&rule);
            for i in 0..20 {
                assert_eq!(s.next(&rule), None, "{rule:?}");
                s.update(&rule, i % 3 != 0);
                let _ = s.estimate(0);
            }
        }
        let mut both = valid_rule();
        both.stop_reversals = Some(4);
        both.check().unwrap();
    }

    #[test]
    fn staircase_replayed_or_read_back_from_json_is_identical() {
        let rule = StaircaseRule {
            steps: vec![1.0, 0.3, 0.1],
            up_ratio: kaernbach_up_ratio(2, 0.8),
            ..valid_rule()
        };
        let observer = Psychometric {
            shape: Shape::Logistic,
            params: Params {
                threshold: 4.0,
                slope: 2.0,
                lapse: 0.02,
            },
            guess: GUESS_2IFC,
        };
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        let mut s = Staircase::new(&rule);
        let mut answers = Vec::new();
        while let Some(x) = s.next(&rule) {
            let correct = rng.random::<f64>() < observer.p_correct(x);
            answers.push(correct);
            s.update(&rule, correct);
            let replayed = Staircase::replay(&rule, answers.iter().copied());
            assert_eq!(replayed, s);
            assert_eq!(replayed.x().to_bits(), s.x().to_bits());
            let json = serde_json::to_string(&s).unwrap();
            assert_eq!(serde_json::from_str::<Staircase>(&json).unwrap(), s);
        }
        assert_eq!(s.trials(), 50);
        let json = serde_json::to_string(&rule).unwrap();
        assert_eq!(serde_json::from_str::<StaircaseRule>(&json).unwrap(), rule);
        let _ = schemars::schema_for!(Staircase);
        let _ = schemars::schema_for!(StaircaseRule);
    }

    // --- QUEST+ -----------------------------------------------------------

    fn logspace(lo: f64, hi: f64, n: usize) -> Vec<f64> {
        (0..n)
            .map(|i| lo * (hi / lo).powf(i as f64 / (n - 1) as f64))
            .collect()
    }

    /// 30 stimuli, 30 thresholds, 6 slopes, 4 lapse rates; Weibull, 2IFC.
    fn realistic() -> QuestPlusSpec {
        QuestPlusSpec {
            shape: Shape::Weibull,
            guess: GUESS_2IFC,
            stimuli: logspace(0.01, 1.0, 30),
            thresholds: logspace(0.01, 1.0, 30),
            slopes: vec![1.5, 2.0, 2.5, 3.0, 4.0, 5.0],
            lapses: vec![0.0, 0.01, 0.02, 0.04],
            stop_trials: None,
            stop_threshold_sd: None,
            max_trials: 150,
        }
    }

    /// Threshold 0.12 (between grid points), slope 3, lapse 0.02.
    fn realistic_observer() -> Psychometric {
        Psychometric {
            shape: Shape::Weibull,
            params: Params {
                threshold: 0.12,
                slope: 3.0,
                lapse: 0.02,
            },
            guess: GUESS_2IFC,
        }
    }

    /// Runs QUEST+ against `observer` to its stop or `trials`, returning the
    /// run and its answers.
    fn simulate(
        spec: &QuestPlusSpec,
        observer: &Psychometric,
        seed: u64,
        trials: u32,
    ) -> (QuestPlus, Vec<(f64, bool)>) {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut q = QuestPlus::new(spec);
        let mut answers = Vec::new();
        while q.trials() < trials {
            let Some(x) = q.next() else { break };
            let correct = rng.random::<f64>() < observer.p_correct(x);
            answers.push((x, correct));
            q.update(x, correct);
        }
        (q, answers)
    }

    /// Every psychometric function of the grid, in the posterior's order
    /// (threshold, then slope, then lapse).
    fn grid_functions(spec: &QuestPlusSpec) -> impl Iterator<Item = Psychometric> + '_ {
        spec.thresholds.iter().flat_map(move |&threshold| {
            spec.slopes.iter().flat_map(move |&slope| {
                spec.lapses.iter().map(move |&lapse| Psychometric {
                    shape: spec.shape,
                    params: Params {
                        threshold,
                        slope,
                        lapse,
                    },
                    guess: spec.guess,
                })
            })
        })
    }

    /// The expected posterior entropy after a trial at each stimulus, the
    /// long way: both posteriors built, normalised and their entropies
    /// taken, with the likelihoods from `Psychometric::p_correct`.
    fn brute_expected_entropies(spec: &QuestPlusSpec, posterior: &[f64]) -> Vec<f64> {
        let mut out = Vec::new();
        for &x in &spec.stimuli {
            let mut expected = 0.0;
            for correct in [true, false] {
                let joint: Vec<f64> = grid_functions(spec)
                    .zip(posterior)
                    .map(|(psi, w)| {
                        let pc = psi.p_correct(x);
                        w * if correct { pc } else { 1.0 - pc }
                    })
                    .collect();
                let p_outcome: f64 = joint.iter().sum();
                if p_outcome > 0.0 {
                    let h: f64 = joint
                        .iter()
                        .map(|j| j / p_outcome)
                        .filter(|q| *q > 0.0)
                        .map(|q| -q * q.ln())
                        .sum();
                    expected += p_outcome * h;
                }
            }
            out.push(expected);
        }
        out
    }

    #[test]
    fn next_equals_a_brute_force_expected_entropy_minimisation_on_a_tiny_grid() {
        let weibull = QuestPlusSpec {
            shape: Shape::Weibull,
            guess: GUESS_2IFC,
            stimuli: vec![0.05, 0.1, 0.2, 0.4, 0.8],
            thresholds: vec![0.08, 0.15, 0.3],
            slopes: vec![2.0, 4.0],
            lapses: vec![0.0, 0.04],
            stop_trials: None,
            stop_threshold_sd: None,
            max_trials: 40,
        };
        // Guess 0 and lapse 0: likelihoods of exactly 0 and 1 at the ends.
        let normal = QuestPlusSpec {
            shape: Shape::CumulativeNormal,
            guess: 0.0,
            stimuli: vec![-20.0, -1.0, 0.0, 0.5, 1.0, 2.0, 40.0],
            thresholds: vec![-0.5, 0.0, 0.5, 1.0],
            slopes: vec![1.0, 3.0],
            lapses: vec![0.0, 0.1],
            ..weibull.clone()
        };
        for spec in [weibull, normal] {
            let observer = Psychometric {
                shape: spec.shape,
                params: Params {
                    threshold: spec.thresholds[1],
                    slope: spec.slopes[1],
                    lapse: spec.lapses[1],
                },
                guess: spec.guess,
            };
            let mut rng = ChaCha8Rng::seed_from_u64(3);
            let mut q = QuestPlus::new(&spec);
            // The same posterior the long way: the product of every
            // answer's likelihood, normalised once at the end.
            let mut product = vec![1.0; q.posterior().len()];
            while let Some(x) = q.next() {
                let brute = brute_expected_entropies(&spec, q.posterior());
                let fast = q.expected_entropies();
                for (b, f) in brute.iter().zip(&fast) {
                    assert!((b - f).abs() < 1e-12, "{spec:?}: {brute:?} vs {fast:?}");
                }
                let mut best = 0;
                for (i, b) in brute.iter().enumerate() {
                    if *b < brute[best] {
                        best = i;
                    }
                }
                assert_eq!(x, spec.stimuli[best], "trial {}: {brute:?}", q.trials() + 1);
                // Answer at a stimulus of our own choosing too, so the
                // posterior moves around the grid.
                let x = if q.trials() % 3 == 2 {
                    spec.stimuli[q.trials() as usize % spec.stimuli.len()]
                } else {
                    x
                };
                let correct = rng.random::<f64>() < observer.p_correct(x);
                q.update(x, correct);
                for (psi, p) in grid_functions(&spec).zip(&mut product) {
                    let pc = psi.p_correct(x);
                    *p *= if correct { pc } else { 1.0 - pc };
                }
                let total: f64 = product.iter().sum();
                for (p, w) in product.iter().zip(q.posterior()) {
                    assert!((p / total - w).abs() < 1e-12);
                }
            }
            assert_eq!(q.trials(), 40);
        }
    }

    #[test]
    fn the_posterior_stays_normalised() {
        let spec = realistic();
        let (_, answers) = simulate(&spec, &realistic_observer(), 11, 150);
        let mut q = QuestPlus::new(&spec);
        let n = q.posterior().len();
        assert_eq!(n, 30 * 6 * 4);
        assert!(q.posterior().iter().all(|w| *w == 1.0 / n as f64));
        for (x, correct) in answers {
            q.update(x, correct);
            let sum: f64 = q.posterior().iter().sum();
            assert!((sum - 1.0).abs() < 1e-12, "trial {}: {sum}", q.trials());
            assert!(q.posterior().iter().all(|w| *w >= 0.0 && w.is_finite()));
            let marginal: f64 = q.threshold_marginal().iter().sum();
            assert!((marginal - 1.0).abs() < 1e-12);
        }
        assert_eq!(q.trials(), 150);
    }

    #[test]
    fn a_simulated_observer_s_posterior_mean_threshold_lands_near_the_truth_after_80_trials_and_its_sd_shrinks()
     {
        // 40 seeded runs of 80 trials on the realistic grid. "Near": within
        // a factor 1.25 (|ln(mean / truth)| < 0.223). After 80 trials the
        // posterior SD of the threshold is about 0.015, i.e. 12% of the
        // truth, so 1.25 is about two posterior SDs: most runs, not all,
        // should land inside; we ask 36 of 40 (90%).
        let spec = realistic();
        let observer = realistic_observer();
        let truth = observer.params.threshold;
        let runs: u32 = 40;
        let mut near = 0;
        let mut errors = Vec::new();
        let mut sd_means = [0.0; 4];
        for seed in 0..u64::from(runs) {
            let (q, answers) = simulate(&spec, &observer, seed, 80);
            assert_eq!(q.trials(), 80);
            let error = (q.mean().threshold / truth).ln();
            errors.push(error);
            if error.abs() < 1.25_f64.ln() {
                near += 1;
            }
            // The SD at 0, 10, 30 and 80 trials.
            let sds: Vec<f64> = [0, 10, 30, 80]
                .iter()
                .map(|&n| QuestPlus::replay(&spec, answers[..n].iter().copied()).threshold_sd())
                .collect();
            assert!(
                sds.windows(2).all(|w| w[1] < w[0]),
                "seed {seed}: SD {sds:?} does not shrink"
            );
            for (m, sd) in sd_means.iter_mut().zip(&sds) {
                *m += sd / f64::from(runs);
            }
        }
        errors.sort_by(|a, b| a.abs().total_cmp(&b.abs()));
        println!(
            "QUEST+ after 80 trials: {near}/{runs} within a factor 1.25 of the true threshold; \
             median |ln error| {:.3}, worst {:.3}; mean threshold SD at 0/10/30/80 trials {sd_means:.4?}",
            errors[errors.len() / 2].abs(),
            errors[errors.len() - 1].abs()
        );
        assert!(near >= 36, "{near} of {runs}: {errors:?}");
        let mean_error = errors.iter().sum::<f64>() / errors.len() as f64;
        assert!(mean_error.abs() < 0.05, "bias {mean_error}");
    }

    #[test]
    fn the_stop_rules_stop() {
        let observer = realistic_observer();
        let spec = QuestPlusSpec {
            stop_trials: Some(12),
            ..realistic()
        };
        let (q, _) = simulate(&spec, &observer, 1, 1000);
        assert_eq!(q.trials(), 12);
        assert_eq!(q.next(), None);

        let spec = QuestPlusSpec {
            max_trials: 9,
            ..realistic()
        };
        let (q, _) = simulate(&spec, &observer, 1, 1000);
        assert_eq!(q.trials(), 9);
        assert_eq!(q.next(), None);

        let spec = QuestPlusSpec {
            stop_trials: Some(500),
            max_trials: 30,
            ..realistic()
        };
        assert_eq!(simulate(&spec, &observer, 1, 1000).0.trials(), 30);

        let spec = QuestPlusSpec {
            stop_threshold_sd: Some(0.02),
            ..realistic()
        };
        let (q, answers) = simulate(&spec, &observer, 2, 1000);
        assert!(q.trials() > 5 && q.trials() < 150, "{}", q.trials());
        assert!(q.threshold_sd() <= 0.02);
        assert_eq!(q.next(), None);
        let before = QuestPlus::replay(&spec, answers[..answers.len() - 1].iter().copied());
        assert!(before.threshold_sd() > 0.02);
        assert!(before.next().is_some());
        println!(
            "SD stop at 0.02: after {} trials (SD {:.4})",
            q.trials(),
            q.threshold_sd()
        );
    }

    #[test]
    fn update_replayed_from_the_same_answers_gives_an_identical_state() {
        let spec = realistic();
        let (q, answers) = simulate(&spec, &realistic_observer(), 5, 150);
        assert_eq!(q.trials(), 150);
        let mut again = QuestPlus::new(&spec);
        for (i, &(x, correct)) in answers.iter().enumerate() {
            again.update(x, correct);
            let prefix = QuestPlus::replay(&spec, answers[..=i].iter().copied());
            assert_eq!(prefix, again);
            assert_eq!(prefix.state(), again.state());
        }
        assert_eq!(again, q);
        assert!(
            again
                .posterior()
                .iter()
                .zip(q.posterior())
                .all(|(a, b)| a.to_bits() == b.to_bits())
        );
        assert_eq!(again.next(), q.next());
        let state = q.state();
        let json = serde_json::to_string(&state).unwrap();
        assert_eq!(
            serde_json::from_str::<QuestPlusState>(&json).unwrap(),
            state
        );
        let json = serde_json::to_string(&spec).unwrap();
        assert_eq!(serde_json::from_str::<QuestPlusSpec>(&json).unwrap(), spec);
        let _ = schemars::schema_for!(QuestPlusState);
        let _ = schemars::schema_for!(QuestPlusSpec);
    }

    #[test]
    fn update_takes_the_nearest_grid_stimulus_and_ignores_nan() {
        let spec = QuestPlusSpec {
            shape: Shape::Logistic,
            stimuli: vec![0.0, 1.0, 2.0, 4.0],
            thresholds: vec![0.5, 1.5, 2.5],
            slopes: vec![1.0, 2.0],
            lapses: vec![0.0, 0.02],
            ..realistic()
        };
        let at = |x: f64| QuestPlus::replay(&spec, [(x, false)]);
        assert_eq!(at(1.2), at(1.0));
        assert_eq!(at(1.5), at(1.0), "tie: the lower");
        assert_eq!(at(1.6), at(2.0));
        assert_eq!(at(3.1), at(4.0));
        assert_eq!(at(-7.0), at(0.0));
        assert_eq!(at(f64::INFINITY), at(4.0));
        assert_eq!(at(f64::NEG_INFINITY), at(0.0));
        assert_ne!(at(1.0), at(2.0));
        let nan = at(f64::NAN);
        assert_eq!(nan, QuestPlus::new(&spec));
        assert_eq!(nan.trials(), 0);
    }

    #[test]
    fn quest_plus_spec_check_names_each_problem_and_an_invalid_spec_never_panics() {
        realistic().check().unwrap();
        let cases: Vec<(&str, Breaker<QuestPlusSpec>)> = vec![
            ("guess", Box::new(|s| s.guess = 1.0)),
            ("guess", Box::new(|s| s.guess = -0.1)),
            ("guess", Box::new(|s| s.guess = f64::NAN)),
            ("stimuli", Box::new(|s| s.stimuli.clear())),
            ("stimuli", Box::new(|s| s.stimuli[3] = f64::NAN)),
            ("stimuli", Box::new(|s| s.stimuli.swap(3, 4))),
            ("stimuli", Box::new(|s| s.stimuli[4] = s.stimuli[3])),
            ("thresholds", Box::new(|s| s.thresholds.clear())),
            ("thresholds", Box::new(|s| s.thresholds.reverse())),
            (
                "thresholds",
                Box::new(|s| s.thresholds[0] = f64::NEG_INFINITY),
            ),
            ("slopes", Box::new(|s| s.slopes.clear())),
            ("slopes", Box::new(|s| s.slopes[0] = 0.0)),
            ("slopes", Box::new(|s| s.slopes[0] = -1.0)),
            ("lapses", Box::new(|s| s.lapses.clear())),
            ("lapses", Box::new(|s| s.lapses[0] = -0.01)),
            ("lapses", Box::new(|s| s.lapses.push(0.5))),
            ("lapses", Box::new(|s| s.lapses = vec![0.0, 0.3, 0.6])),
            ("thresholds", Box::new(|s| s.thresholds[0] = 0.0)),
            ("stimuli", Box::new(|s| s.stimuli[0] = -0.01)),
            ("stop_trials", Box::new(|s| s.stop_trials = Some(0))),
            (
                "stop_threshold_sd",
                Box::new(|s| s.stop_threshold_sd = Some(0.0)),
            ),
            (
                "stop_threshold_sd",
                Box::new(|s| s.stop_threshold_sd = Some(-1.0)),
            ),
            (
                "stop_threshold_sd",
                Box::new(|s| s.stop_threshold_sd = Some(f64::NAN)),
            ),
            ("max_trials", Box::new(|s| s.max_trials = 0)),
            (
                "stimuli",
                Box::new(|s| {
                    s.stimuli = logspace(0.01, 1.0, 2000);
                    s.thresholds = logspace(0.01, 1.0, 2000);
                }),
            ),
        ];
        for (field, break_it) in cases {
            let mut spec = realistic();
            break_it(&mut spec);
            let (got, why) = spec.check().unwrap_err();
            assert_eq!(got, field, "{why}");
            let mut q = QuestPlus::new(&spec);
            assert_eq!(q.problem().map(|p| p.0), Some(field));
            assert_eq!(q.next(), None);
            q.update(0.1, true);
            q.update(f64::NAN, false);
            assert_eq!(q.trials(), 0);
            assert!(q.mean().threshold.is_nan() && q.threshold_sd().is_nan());
            let _ = q.state();
            let _ = q.expected_entropies();
        }
        // Non-positive stimuli and thresholds are fine away from the Weibull.
        let logistic = QuestPlusSpec {
            shape: Shape::Logistic,
            stimuli: vec![-1.0, 0.0, 1.0],
            thresholds: vec![-0.5, 0.0, 0.5],
            ..realistic()
        };
        logistic.check().unwrap();
        assert!(QuestPlus::new(&logistic).next().is_some());
    }
}
