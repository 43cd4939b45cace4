//! Maximum-likelihood fits of a psychometric function to forced-choice
//! answers, and parametric-bootstrap intervals on its threshold.
//!
//! # The likelihood
//! Data are [`Block`]s: `correct` of `n` trials at stimulus `x`. With
//! `psi` the [`Psychometric`] function (fixed guess rate, free threshold,
//! slope and lapse rate) the log-likelihood is
//! `sum over blocks of k ln psi(x) + (n - k) ln(1 - psi(x))`, without the
//! binomial coefficients, as Palamedes' `PAL_PFML_negLL` (so it is at most
//! 0, and the same as the sum over single trials). `1 - psi` is computed
//! from `1 - F` directly, so it keeps its precision where `psi` is near 1.
//!
//! # The bounds
//! The fit searches a box derived from the data alone, so that every data
//! set, even perfectly separated or flat at chance, has a finite maximum:
//! - `w` is the stimulus on the axis where the shape is a location-slope
//!   family: `x` for the logistic and cumulative normal, `ln x` for the
//!   Weibull (whose `F` is a Gumbel in `ln x` with the same slope), over the
//!   blocks with trials (and for the Weibull with `x > 0`; at `x <= 0` the
//!   Weibull's `F` is 0 whatever the parameters, so those blocks add a
//!   constant);
//! - the span `s = max w - min w`, or where that is 0 (one level): 1 for
//!   the Weibull (a factor e in `x`), `|x|` (1 if `x = 0`) otherwise;
//! - the location (the threshold; its log for the Weibull) lies in
//!   `[min w - s, max w + s]`;
//! - the slope lies in `[0.01 / s, 100 / s]` (so `slope * s`, how much of
//!   the sigmoid the data's span covers, is within 0.01..100: at 100 the
//!   logistic rises from 1 % to 99 % of `F` within 9 % of the span; steeper
//!   is not resolved by data spread over `s`. Perfectly separated data put
//!   the slope on this bound, and the threshold then lies where the tails
//!   of the steepest function allowed fit the two sides best);
//! - the lapse rate lies in `[0, max_lapse]` exactly (`max_lapse` may be 0).
//!
//! # The search
//! Deterministic (no randomness; the same input gives the same bits), in
//! the transformed parameters `u = (location, ln slope, lapse)`:
//! 1. a grid over the box: as locations the data's levels (at most 12,
//!    evenly among them where there are more) and the midpoints between
//!    neighbours, where steep functions sit; 7 points evenly across the
//!    data's range where it has fewer levels than that; and a quarter and
//!    half a span beyond each end; 9 slopes log-spaced across their bounds
//!    (a factor 3.16 apart); the lapse rate at 0 and `max_lapse`;
//! 2. starts: the grid's local maxima, and the best grid point at each
//!    slope (on a steep function's plateau the gradient vanishes, and a
//!    shallower start finds the way); from the 6 most likely, an ascent:
//!    damped Newton steps (Levenberg–Marquardt on the exact gradient and
//!    Hessian in `u`, Marquardt's diagonal scaling with a floor, and
//!    halving along a step before damping more), bounded (a coordinate on
//!    a bound whose gradient points out of the box is held there, the
//!    others are clamped into it), in rounds of 30 iterations. Near a
//!    maximum inside the box Newton converges within a round; a round
//!    that does not is creeping towards a maximum on a bound (the slope of
//!    separated data, the location of data at chance), where the
//!    likelihood flattens out super-exponentially: then each coordinate
//!    whose gradient heads for a bound is tried on that bound (held there,
//!    the others ascending), and the ascent goes on from the best of those
//!    if it beats the point reached. An ascent stops when a step moves no
//!    coordinate by more than `1e-14` of its box's width, when no step
//!    raises the likelihood (or, where rounding hides changes of the
//!    likelihood, shrinks the gradient), or when it comes within `1e-4` of
//!    the box's widths of where an earlier ascent ended (the same basin).
//!    A budget of evaluations bounds the work on any input;
//! 3. the most likely point reached.
//!
//! The result matches an independent reference (a dense grid, scipy's
//! L-BFGS-B and a Newton polish in 60-digit mpmath:
//! `tests/fixtures/psychometric_fits.py`) to better than `1e-6` relative on
//! every parameter (absolute where the value is below 1) and `1e-9` on the
//! log-likelihood (`tests/fit_cross_check.rs`; in practice to a few ulps
//! of the log-likelihood), and is never less likely than the fits of
//! psignifit 2.5.6 (J. Hill's engine) of the same data.

use rand::RngExt;
use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::psychometric::{Params, Psychometric, Shape, phi, phi_inverse};

/// Answers at one stimulus level.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct Block {
    /// The stimulus level.
    pub x: f64,
    /// How many trials were run at `x`.
    pub n: u32,
    /// How many of them were answered correctly (at most `n`).
    pub correct: u32,
}

/// Groups trials `(x, correct)` by exactly equal `x` (`==`, so `-0.0` and
/// `0.0` are one level and each NaN a level of its own), sorted by `x`.
#[must_use]
pub fn blocks(trials: &[(f64, bool)]) -> Vec<Block> {
    let mut sorted: Vec<(f64, bool)> = trials.to_vec();
    sorted.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut out: Vec<Block> = Vec::new();
    for (x, correct) in sorted {
        match out.last_mut() {
            Some(last) if last.x == x => {
                last.n = last.n.saturating_add(1);
                last.correct = last.correct.saturating_add(u32::from(correct));
            }
            _ => out.push(Block {
                x,
                n: 1,
                correct: u32::from(correct),
            }),
        }
    }
    out
}

/// What is fitted: the shape, the fixed guess rate, and the bound of the
/// free lapse rate (lapse in `[0, max_lapse]`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FitSpec {
    /// The sigmoid.
    pub shape: Shape,
    /// The guess rate, fixed ([`crate::psychometric::GUESS_2IFC`] for two
    /// intervals); in `[0, 1)`.
    pub guess: f64,
    /// The largest lapse rate allowed, in `[0, 1 - guess)`; 0 fixes the
    /// lapse rate at 0.
    pub max_lapse: f64,
}

/// A maximum-likelihood fit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Fit {
    /// The fitted parameters.
    pub params: Params,
    /// The log-likelihood of the data at `params` ([`log_likelihood`]).
    pub log_likelihood: f64,
}

/// The log-likelihood of `data` under `params` (module docs: no binomial
/// coefficients, so at most 0). `-inf` where the data are impossible
/// (e.g. an error where `psi = 1`); NaN for input a fit would reject (a
/// non-finite `x`, `correct > n`, an invalid spec) or invalid parameters
/// (a slope that is not positive and finite, a Weibull threshold that is
/// not, a lapse rate outside `[0, 1 - guess]`).
#[must_use]
pub fn log_likelihood(spec: &FitSpec, params: &Params, data: &[Block]) -> f64 {
    let Some(problem) = Problem::new(spec, data) else {
        return f64::NAN;
    };
    let Params {
        threshold,
        slope,
        lapse,
    } = *params;
    let location_ok = match spec.shape {
        Shape::Weibull => threshold > 0.0 && threshold.is_finite(),
        Shape::Logistic | Shape::CumulativeNormal => threshold.is_finite(),
    };
    if !(location_ok
        && slope > 0.0
        && slope.is_finite()
        && lapse >= 0.0
        && lapse <= 1.0 - spec.guess)
    {
        return f64::NAN;
    }
    problem.ll(spec.shape.to_w(threshold), slope, lapse)
}

/// The maximum-likelihood fit of `spec` to `data` (module docs: the
/// bounds and the search). Blocks with `n = 0` are ignored. `None` when
/// there is no trial, when the input is invalid (a non-finite `x`,
/// `correct > n`, a guess rate outside `[0, 1)`, `max_lapse` outside
/// `[0, 1 - guess)`), when the data's levels are so far apart (near
/// `f64::MAX`) that the box (module docs) is not finite, or when no
/// parameters in the box give a finite likelihood. Never panics.
#[must_use]
pub fn fit(spec: &FitSpec, data: &[Block]) -> Option<Fit> {
    let problem = Problem::new(spec, data)?;
    if !problem.searchable() {
        return None;
    }
    let u = problem.maximise()?;
    let params = problem.params(&u);
    let log_likelihood = log_likelihood(spec, &params, data);
    log_likelihood.is_finite().then_some(Fit {
        params,
        log_likelihood,
    })
}

/// An interval `[lo, hi]`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct Interval {
    /// Lower end.
    pub lo: f64,
    /// Upper end.
    pub hi: f64,
}

impl Interval {
    /// Whether `x` lies in `[lo, hi]`.
    #[must_use]
    pub fn contains(&self, x: f64) -> bool {
        self.lo <= x && x <= self.hi
    }
}

/// A parametric bootstrap of a threshold ([`bootstrap_threshold`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Bootstrap {
    /// The percentile interval of the refitted thresholds.
    pub interval: Interval,
    /// The standard deviation of the refitted thresholds (divisor
    /// `count - 1`).
    pub sd: f64,
    /// How many samples were drawn (successful and failed).
    pub samples: u32,
    /// How many samples were left out: their refit failed, or their fitted
    /// function never reaches the criterion.
    pub failed: u32,
}

/// Parametric bootstrap of the threshold at `criterion` (the `x` where
/// `psi(x) = criterion`, [`Psychometric::threshold_at`]): `samples` data
/// sets drawn from the fitted function at the data's `x` and `n` (each
/// trial a Bernoulli draw `rng.random::<f64>() < psi(x)`, blocks and
/// trials in order, so a seeded `rng` gives the same result), each refitted
/// with [`fit`]; the percentile interval at `confidence` (e.g. 0.95: the
/// 2.5 % and 97.5 % quantiles, interpolated linearly between order
/// statistics as R's default type 7). Samples whose refit or threshold
/// fails count in `failed`, and are left out. `None` when the input is
/// invalid (as for [`fit`], or `confidence` outside `(0, 1)`, or a `fit`
/// whose parameters are invalid) or fewer than 2 samples succeed.
pub fn bootstrap_threshold(
    spec: &FitSpec,
    fit: &Fit,
    data: &[Block],
    criterion: f64,
    samples: u32,
    confidence: f64,
    rng: &mut impl rand::Rng,
) -> Option<Bootstrap> {
    if !(confidence > 0.0 && confidence < 1.0) {
        return None;
    }
    if !log_likelihood(spec, &fit.params, data).is_finite() {
        // Invalid input or parameters (NaN), or data the fit cannot have
        // produced (-inf).
        return None;
    }
    let generator = Psychometric {
        shape: spec.shape,
        params: fit.params,
        guess: spec.guess,
    };
    let chances: Vec<f64> = data.iter().map(|b| generator.p_correct(b.x)).collect();
    let mut simulated: Vec<Block> = data.to_vec();
    let mut thresholds: Vec<f64> = Vec::with_capacity(samples.min(1 << 16) as usize);
    for _ in 0..samples {
        for (block, &p) in simulated.iter_mut().zip(&chances) {
            let mut correct = 0;
            for _ in 0..block.n {
                correct += u32::from(rng.random::<f64>() < p);
            }
            block.correct = correct;
        }
        let refit = self::fit(spec, &simulated).and_then(|f| {
            Psychometric {
                shape: spec.shape,
                params: f.params,
                guess: spec.guess,
            }
            .threshold_at(criterion)
        });
        if let Some(t) = refit {
            thresholds.push(t);
        }
    }
    let count = thresholds.len();
    if count < 2 {
        return None;
    }
    thresholds.sort_by(f64::total_cmp);
    let tail = 0.5 * (1.0 - confidence);
    let mean = thresholds.iter().sum::<f64>() / count as f64;
    let var = thresholds.iter().map(|t| (t - mean).powi(2)).sum::<f64>() / (count - 1) as f64;
    Some(Bootstrap {
        interval: Interval {
            lo: quantile(&thresholds, tail),
            hi: quantile(&thresholds, 1.0 - tail),
        },
        sd: var.sqrt(),
        samples,
        failed: samples - u32::try_from(count).unwrap_or(samples),
    })
}

/// A profile-likelihood interval of a threshold ([`profile_threshold`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Profile {
    /// The thresholds whose profile deviance is within the chi-square
    /// quantile.
    pub interval: Interval,
    /// Whether each end is the most extreme threshold of any function in
    /// the fit's box (module docs) rather than where the deviance reaches
    /// the quantile: the data do not bound the threshold on that side.
    pub open: [bool; 2],
}

/// Likelihood-ratio interval of the threshold at `criterion`: the
/// thresholds `t` whose profile deviance `2 (ll(fit) - max ll over the
/// functions with threshold t at the criterion)` is at most the
/// chi-square quantile (1 degree of freedom) at `confidence` (3.84 for
/// 0.95). The maximum over the other parameters (slope and lapse rate)
/// is taken within the fit's box (module docs), the location following
/// from `t`, the slope and the lapse rate and staying in its box too.
///
/// Unlike [`bootstrap_threshold`], which redraws answers at the data's
/// own stimuli, the likelihood does not depend on how the stimuli were
/// chosen, so the interval is the same whether the data came from
/// constant stimuli or an adaptive track that chose each stimulus from
/// the answers before it (the likelihood principle; the chi-square
/// quantile is a large-sample approximation).
///
/// The search, deterministic: each end by bisection (on `ln t` for the
/// Weibull, `t` otherwise) between the fitted threshold and the most
/// extreme threshold of the box's functions, 48 halvings; the inner
/// maximum at each `t` over 9 lapse rates evenly across their bound, each
/// with the best of 24 log slopes evenly across those that keep the
/// location in its box, refined by golden section, then golden section on
/// the lapse rate between the best one's neighbours. `None` for invalid input
/// (as [`fit`]; `confidence` outside `(0, 1)`; a fit whose function never
/// reaches `criterion`).
#[must_use]
pub fn profile_threshold(
    spec: &FitSpec,
    fit: &Fit,
    data: &[Block],
    criterion: f64,
    confidence: f64,
) -> Option<Profile> {
    if !(confidence > 0.0 && confidence < 1.0) {
        return None;
    }
    let quantile = phi_inverse(0.5 + 0.5 * confidence).powi(2);
    profile_interval(spec, fit, data, criterion, quantile)
}

/// The profile deviance of threshold `t` at `criterion`:
/// `2 (ll(fit) - max ll over the functions in the box with threshold t)`
/// ([`profile_threshold`]); `+inf` where no function in the box has that
/// threshold. `None` for invalid input (as [`profile_threshold`]).
#[must_use]
pub fn profile_deviance(
    spec: &FitSpec,
    fit: &Fit,
    data: &[Block],
    criterion: f64,
    t: f64,
) -> Option<f64> {
    let (problem, ll_max, _) = profile_search(spec, fit, data, criterion)?;
    let tau = spec.shape.to_w(t);
    tau.is_finite()
        .then(|| 2.0 * (ll_max - problem.profile(tau, criterion)))
}

/// The thresholds whose profile deviance ([`profile_deviance`]) is at
/// most `cutoff` ([`profile_threshold`] with the chi-square quantile; a
/// cutoff calibrated by simulation otherwise). `None` for invalid input
/// or a `cutoff` that is not positive and finite.
#[must_use]
pub fn profile_interval(
    spec: &FitSpec,
    fit: &Fit,
    data: &[Block],
    criterion: f64,
    cutoff: f64,
) -> Option<Profile> {
    if !(cutoff > 0.0 && cutoff.is_finite()) {
        return None;
    }
    let (problem, ll_max, tau) = profile_search(spec, fit, data, criterion)?;
    let quantile = cutoff;
    let deviance = |tau: f64| 2.0 * (ll_max - problem.profile(tau, criterion));
    // Each end: the extreme threshold when the deviance is within the
    // quantile there, else where it crosses the quantile between there
    // and the fit.
    let end = |edge: f64| -> (f64, bool) {
        if deviance(edge) <= quantile {
            return (edge, true);
        }
        let (mut inside, mut outside) = (tau, edge);
        for _ in 0..BISECTIONS {
            let mid = 0.5 * (inside + outside);
            if deviance(mid) <= quantile {
                inside = mid;
            } else {
                outside = mid;
            }
        }
        (inside, false)
    };
    let (tau_lo, tau_hi) = problem.threshold_range(criterion);
    let ((lo, lo_open), (hi, hi_open)) = (end(tau_lo.min(tau)), end(tau_hi.max(tau)));
    Some(Profile {
        interval: Interval {
            lo: spec.shape.x_of_w(lo),
            hi: spec.shape.x_of_w(hi),
        },
        open: [lo_open, hi_open],
    })
}

/// The setting of a profile search: the problem, the largest
/// log-likelihood (the fit's, or the profile's at the fitted threshold
/// if the search finds one higher) and the fitted threshold on the `w`
/// axis.
fn profile_search(
    spec: &FitSpec,
    fit: &Fit,
    data: &[Block],
    criterion: f64,
) -> Option<(Problem, f64, f64)> {
    if !(criterion > spec.guess && criterion < 1.0) {
        return None;
    }
    let problem = Problem::new(spec, data)?;
    let ll_fit = log_likelihood(spec, &fit.params, data);
    if !problem.searchable() || !ll_fit.is_finite() {
        return None;
    }
    let t = Psychometric {
        shape: spec.shape,
        params: fit.params,
        guess: spec.guess,
    }
    .threshold_at(criterion)?;
    let tau = spec.shape.to_w(t);
    if !tau.is_finite() {
        return None;
    }
    let ll_max = ll_fit.max(problem.profile(tau, criterion));
    Some((problem, ll_max, tau))
}

/// The `q` quantile of sorted `v` (not empty), linear between order
/// statistics (R's type 7).
fn quantile(v: &[f64], q: f64) -> f64 {
    let h = (v.len() - 1) as f64 * q;
    let below = h.floor();
    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
    let i = below as usize;
    match v.get(i + 1) {
        Some(&next) => v[i] + (h - below) * (next - v[i]),
        None => v[i],
    }
}

/// The profile interval's search ([`profile_threshold`]): halvings of
/// each end's bracket; lapse rates and log slopes scanned at each
/// threshold; golden-section steps refining the best of each.
const BISECTIONS: usize = 48;
const PROFILE_LAPSES: usize = 9;
const PROFILE_SLOPES: usize = 24;
const GOLDEN_STEPS: usize = 36;

/// The slope bounds as multiples of `1 / span` (module docs).
const SLOPE_SPAN_MIN: f64 = 0.01;
const SLOPE_SPAN_MAX: f64 = 100.0;
/// Grid points on the location (across the data's range where it has
/// fewer levels; [`Problem::grid_locations`]), on the log slope and on the
/// lapse rate; data levels on the location grid at most.
const LOCATIONS: usize = 7;
const LEVELS: usize = 12;
const SLOPES: usize = 9;
const LAPSES: usize = 2;
/// An ascent that comes this close (in each coordinate, as a fraction of
/// the box's width) to where an earlier one ended stops there.
const SAME_BASIN: f64 = 1e-4;
/// Local ascents started, from the best grid points.
const STARTS: usize = 6;
/// Evaluations of the gradient and Hessian a fit may make (a safety net:
/// fits of the test and validation data sets took at most about 4000).
const MAX_EVALUATIONS: u32 = 20_000;
/// Newton iterations in a round of an ascent, and rounds at most.
const ROUND_ITERATIONS: usize = 30;
const ROUNDS: usize = 6;
/// An ascent stops when no parameter moved by more than this fraction of
/// its box's width.
const STEP_TOLERANCE: f64 = 1e-14;

/// The data, reduced for the search, and the box.
struct Problem {
    shape: Shape,
    guess: f64,
    /// Blocks whose `F` depends on the parameters: `w` (module docs),
    /// correct and wrong counts.
    w: Vec<f64>,
    right: Vec<f64>,
    wrong: Vec<f64>,
    /// The log-likelihood of the blocks where the Weibull's `F` is 0.
    constant: f64,
    /// Whether any block has trials.
    has_trials: bool,
    /// The box on `u = (location, ln slope, lapse)`.
    lo: [f64; 3],
    hi: [f64; 3],
    /// The span `s` (module docs).
    span: f64,
    /// The slope bounds themselves (reported exactly at a bound).
    slope_lo: f64,
    slope_hi: f64,
    /// Evaluations of the gradient and Hessian so far.
    evaluations: std::cell::Cell<u32>,
}

/// The log-likelihood, its gradient and Hessian in `u`.
struct Eval {
    ll: f64,
    grad: [f64; 3],
    hess: [[f64; 3]; 3],
}

impl Problem {
    /// `None` for invalid input (see [`fit`]).
    fn new(spec: &FitSpec, data: &[Block]) -> Option<Problem> {
        let FitSpec {
            shape,
            guess,
            max_lapse,
        } = *spec;
        if !((0.0..1.0).contains(&guess) && max_lapse >= 0.0 && max_lapse < 1.0 - guess) {
            return None;
        }
        if data.iter().any(|b| !b.x.is_finite() || b.correct > b.n) {
            return None;
        }
        let mut w = Vec::with_capacity(data.len());
        let mut right = Vec::with_capacity(data.len());
        let mut wrong = Vec::with_capacity(data.len());
        let mut constant = 0.0;
        let mut has_trials = false;
        for b in data.iter().filter(|b| b.n > 0) {
            has_trials = true;
            let (k, m) = (f64::from(b.correct), f64::from(b.n - b.correct));
            let wi = match shape {
                Shape::Weibull if b.x <= 0.0 => {
                    constant += xlny(k, guess) + xlny(m, 1.0 - guess);
                    continue;
                }
                Shape::Weibull => b.x.ln(),
                Shape::Logistic | Shape::CumulativeNormal => b.x,
            };
            w.push(wi);
            right.push(k);
            wrong.push(m);
        }
        let (w_min, w_max) = w
            .iter()
            .fold(None, |acc: Option<(f64, f64)>, &v| match acc {
                None => Some((v, v)),
                Some((lo, hi)) => Some((lo.min(v), hi.max(v))),
            })
            .unwrap_or((0.0, 0.0));
        let mut span = w_max - w_min;
        if span == 0.0 {
            span = match shape {
                Shape::Weibull => 1.0,
                Shape::Logistic | Shape::CumulativeNormal => {
                    if w_min == 0.0 {
                        1.0
                    } else {
                        w_min.abs()
                    }
                }
            };
        }
        // Not finite where |x| nears f64::MAX (no box to search then:
        // [`Problem::searchable`]).
        let (slope_lo, slope_hi) = (SLOPE_SPAN_MIN / span, SLOPE_SPAN_MAX / span);
        let lo = [w_min - span, slope_lo.ln(), 0.0];
        let hi = [w_max + span, slope_hi.ln(), max_lapse];
        Some(Problem {
            shape,
            guess,
            w,
            right,
            wrong,
            constant,
            has_trials,
            lo,
            hi,
            span,
            slope_lo,
            slope_hi,
            evaluations: std::cell::Cell::new(0),
        })
    }

    /// Whether there are trials, and a finite box to search.
    fn searchable(&self) -> bool {
        self.has_trials
            && self.span.is_finite()
            && self.slope_lo > 0.0
            && self.lo.iter().chain(&self.hi).all(|v| v.is_finite())
    }

    /// The slope at `u[1] = ln slope`, exactly the bound at a bound.
    fn slope(&self, ln_slope: f64) -> f64 {
        if ln_slope <= self.lo[1] {
            self.slope_lo
        } else if ln_slope >= self.hi[1] {
            self.slope_hi
        } else {
            ln_slope.exp()
        }
    }

    /// The parameters at `u`.
    fn params(&self, u: &[f64; 3]) -> Params {
        Params {
            threshold: self.shape.x_of_w(u[0]),
            slope: self.slope(u[1]),
            lapse: u[2],
        }
    }

    /// The log-likelihood at location `a`, slope `s`, lapse `lapse`.
    fn ll(&self, a: f64, s: f64, lapse: f64) -> f64 {
        let sigmoids = self.w.iter().map(|&w| {
            let (f, cf, _) = self.shape.sigmoid(s * (w - a));
            (f, cf)
        });
        self.ll_of(sigmoids, lapse)
    }

    /// The log-likelihood given `(F, 1 - F)` at each block.
    fn ll_of(&self, sigmoids: impl IntoIterator<Item = (f64, f64)>, lapse: f64) -> f64 {
        let h = 1.0 - self.guess - lapse;
        let mut ll = self.constant;
        for (((f, cf), &k), &m) in sigmoids.into_iter().zip(&self.right).zip(&self.wrong) {
            ll += xlny(k, self.guess + h * f) + xlny(m, h * cf + lapse);
        }
        if ll.is_nan() { f64::NEG_INFINITY } else { ll }
    }

    /// The largest lapse rate at which a function can reach `criterion`
    /// (just below `1 - criterion`), within the box.
    fn profile_lapse_hi(&self, criterion: f64) -> f64 {
        self.hi[2].min((1.0 - criterion) * (1.0 - 1e-9)).max(0.0)
    }

    /// The standard sigmoid's `z` at the criterion for lapse rate `lapse`:
    /// a function's threshold at the criterion is `location + z / slope`
    /// on the `w` axis.
    fn criterion_z(&self, criterion: f64, lapse: f64) -> f64 {
        self.shape
            .standard_inverse((criterion - self.guess) / (1.0 - self.guess - lapse))
    }

    /// The thresholds at `criterion` (on the `w` axis) of the functions in
    /// the box: `location + z / slope` at its extremes (`z` grows with the
    /// lapse rate).
    fn threshold_range(&self, criterion: f64) -> (f64, f64) {
        let z_min = self.criterion_z(criterion, 0.0);
        let z_max = self.criterion_z(criterion, self.profile_lapse_hi(criterion));
        let lo = self.lo[0]
            + if z_min < 0.0 {
                z_min / self.slope_lo
            } else {
                z_min / self.slope_hi
            };
        let hi = self.hi[0]
            + if z_max > 0.0 {
                z_max / self.slope_lo
            } else {
                z_max / self.slope_hi
            };
        (lo, hi)
    }

    /// The largest log-likelihood of the functions in the box whose
    /// threshold at `criterion` is at `tau` (on the `w` axis)
    /// ([`profile_threshold`]): at lapse rate `l` and slope `s` the
    /// location is `tau - z / s` ([`Problem::criterion_z`]), which must lie
    /// in the box, so the slopes searched are those that put it there.
    /// `-inf` where no function in the box has that threshold.
    fn profile(&self, tau: f64, criterion: f64) -> f64 {
        let at_lapse = |lapse: f64| -> f64 {
            let z = self.criterion_z(criterion, lapse);
            let Some((ln_lo, ln_hi)) = self.feasible_ln_slopes(tau, z) else {
                return f64::NEG_INFINITY;
            };
            let at = |ln_slope: f64| -> f64 {
                let s = ln_slope
                    .clamp(ln_lo, ln_hi)
                    .exp()
                    .clamp(self.slope_lo, self.slope_hi);
                self.ll(tau - z / s, s, lapse)
            };
            scan_and_refine(ln_lo, ln_hi, PROFILE_SLOPES, &at).1
        };
        let lapse_hi = self.profile_lapse_hi(criterion);
        if lapse_hi <= 0.0 {
            return at_lapse(0.0);
        }
        scan_and_refine(0.0, lapse_hi, PROFILE_LAPSES, &at_lapse).1
    }

    /// The log slopes within the box for which `tau - z / slope` is in the
    /// location's box; `None` if there are none.
    fn feasible_ln_slopes(&self, tau: f64, z: f64) -> Option<(f64, f64)> {
        // With u = 1 / slope: tau - hi <= z u <= tau - lo.
        let (a, b) = (tau - self.hi[0], tau - self.lo[0]);
        let (mut u_lo, mut u_hi) = (1.0 / self.slope_hi, 1.0 / self.slope_lo);
        if z > 0.0 {
            (u_lo, u_hi) = (u_lo.max(a / z), u_hi.min(b / z));
        } else if z < 0.0 {
            (u_lo, u_hi) = (u_lo.max(b / z), u_hi.min(a / z));
        } else if !(a <= 0.0 && 0.0 <= b) {
            return None;
        }
        // At the range's ends (threshold_range) one slope remains, which
        // rounding may leave a hair outside.
        if u_lo > u_hi && u_lo - u_hi <= 1e-12 * u_hi {
            u_lo = u_hi;
        }
        (u_lo <= u_hi && u_lo > 0.0).then(|| (-u_hi.ln(), -u_lo.ln()))
    }

    /// The log-likelihood with its gradient and Hessian in `u`.
    fn eval(&self, u: &[f64; 3]) -> Eval {
        self.evaluations
            .set(self.evaluations.get().saturating_add(1));
        let (a, s, lapse) = (u[0], self.slope(u[1]), u[2]);
        let h = 1.0 - self.guess - lapse;
        let mut e = Eval {
            ll: self.constant,
            grad: [0.0; 3],
            hess: [[0.0; 3]; 3],
        };
        for ((&w, &k), &m) in self.w.iter().zip(&self.right).zip(&self.wrong) {
            let z = s * (w - a);
            let (f, cf, ez) = self.shape.sigmoid(z);
            let (d1, d2) = self.shape.derivatives(z, f, cf, ez);
            let p = self.guess + h * f;
            let q = h * cf + lapse;
            e.ll += xlny(k, p) + xlny(m, q);
            if !e.ll.is_finite() {
                break;
            }
            // d(ll)/dp and d2(ll)/dp2 (with 0 counts contributing 0).
            let r1 = (if k > 0.0 { k / p } else { 0.0 }) - (if m > 0.0 { m / q } else { 0.0 });
            let r2 = -(if k > 0.0 { k / (p * p) } else { 0.0 })
                - (if m > 0.0 { m / (q * q) } else { 0.0 });
            // p's derivatives in (location, ln slope, lapse): z_a = -s,
            // z_b = z, z_ab = -s, z_bb = z.
            let dp = [-h * s * d1, h * z * d1, -f];
            let zd = z * d2 + d1;
            let ddp = [
                [h * s * s * d2, -h * s * zd, s * d1],
                [-h * s * zd, h * z * zd, -z * d1],
                [s * d1, -z * d1, 0.0],
            ];
            for i in 0..3 {
                e.grad[i] += r1 * dp[i];
                for j in 0..3 {
                    e.hess[i][j] += r1 * ddp[i][j] + r2 * dp[i] * dp[j];
                }
            }
        }
        if !e.ll.is_finite()
            || e.grad
                .iter()
                .chain(e.hess.iter().flatten())
                .any(|v| v.is_nan())
        {
            e.ll = f64::NEG_INFINITY;
        }
        e
    }

    /// The box's width along each of `u`'s coordinates (1 where fixed).
    fn width(&self, i: usize) -> f64 {
        let w = self.hi[i] - self.lo[i];
        if w > 0.0 { w } else { 1.0 }
    }

    /// The coordinates free to move at `u` with gradient `g`: not held,
    /// not fixed by the box, and not on a bound with the gradient pointing
    /// out.
    fn free(&self, u: &[f64; 3], g: &[f64; 3], held: [bool; 3]) -> Vec<usize> {
        (0..3)
            .filter(|&i| {
                let fixed = held[i] || self.hi[i] <= self.lo[i];
                let out_below = u[i] <= self.lo[i] && g[i] <= 0.0;
                let out_above = u[i] >= self.hi[i] && g[i] >= 0.0;
                !(fixed || out_below || out_above)
            })
            .collect()
    }

    /// The squared norm of the projected gradient, each coordinate scaled
    /// by its box's width.
    fn projected_gradient(&self, u: &[f64; 3], g: &[f64; 3], held: [bool; 3]) -> f64 {
        self.free(u, g, held)
            .into_iter()
            .map(|i| (g[i] * self.width(i)).powi(2))
            .sum()
    }

    /// `count` points evenly across coordinate `i`'s box (its lower bound
    /// alone where the box is a point).
    fn grid_axis(&self, i: usize, count: usize) -> Vec<f64> {
        if self.hi[i] <= self.lo[i] {
            return vec![self.lo[i]];
        }
        (0..count)
            .map(|j| self.lo[i] + (self.hi[i] - self.lo[i]) * j as f64 / (count - 1) as f64)
            .collect()
    }

    /// The grid's locations: the data's levels and the midpoints between
    /// neighbours (where steep functions sit; at most [`LEVELS`] levels,
    /// evenly among them where there are more), [`LOCATIONS`] evenly
    /// across the data's range where there are fewer than that many
    /// levels, and quarter and half a span beyond the range on each side.
    fn grid_locations(&self) -> Vec<f64> {
        let (w_min, w_max, s) = (self.lo[0] + self.span, self.hi[0] - self.span, self.span);
        let mut out = vec![
            w_min - 0.5 * s,
            w_min - 0.25 * s,
            w_max + 0.25 * s,
            w_max + 0.5 * s,
        ];
        let mut levels = self.w.clone();
        levels.sort_by(f64::total_cmp);
        levels.dedup();
        if levels.len() < LOCATIONS {
            out.extend(
                (0..LOCATIONS).map(|j| w_min + (w_max - w_min) * j as f64 / (LOCATIONS - 1) as f64),
            );
        }
        if levels.len() > LEVELS {
            let last = levels.len() - 1;
            levels = (0..LEVELS)
                .map(|j| levels[(j * last + (LEVELS - 1) / 2) / (LEVELS - 1)])
                .collect();
        }
        out.extend(levels.windows(2).map(|p| 0.5 * (p[0] + p[1])));
        out.extend(levels);
        out.sort_by(f64::total_cmp);
        out.dedup();
        out
    }

    /// The search (module docs): the grid; as starts its local maxima and
    /// its best point at each slope; the ascents from the most likely
    /// starts; the best point reached, put on the bounds it is within
    /// rounding of.
    fn maximise(&self) -> Option<[f64; 3]> {
        let axes = [
            self.grid_locations(),
            self.grid_axis(1, SLOPES),
            self.grid_axis(2, LAPSES),
        ];
        let [na, nb, nl] = [axes[0].len(), axes[1].len(), axes[2].len()];
        let index = |ia: usize, ib: usize, il: usize| (ia * nb + ib) * nl + il;
        let mut grid = vec![f64::NEG_INFINITY; na * nb * nl];
        let mut sigmoids = vec![(0.0, 0.0); self.w.len()];
        for (ia, &a) in axes[0].iter().enumerate() {
            for (ib, &b) in axes[1].iter().enumerate() {
                let s = self.slope(b);
                for (slot, &w) in sigmoids.iter_mut().zip(&self.w) {
                    let (f, cf, _) = self.shape.sigmoid(s * (w - a));
                    *slot = (f, cf);
                }
                for (il, &lapse) in axes[2].iter().enumerate() {
                    grid[index(ia, ib, il)] = self.ll_of(sigmoids.iter().copied(), lapse);
                }
            }
        }
        // The grid's local maxima (no neighbour more likely; of equals, the
        // first in grid order), best first: one start a basin.
        let mut starts: Vec<(f64, [f64; 3])> = Vec::new();
        for ia in 0..na {
            for ib in 0..nb {
                for il in 0..nl {
                    let here = index(ia, ib, il);
                    let ll = grid[here];
                    if !ll.is_finite() {
                        continue;
                    }
                    let mut local_max = true;
                    'neighbours: for ja in ia.saturating_sub(1)..=(ia + 1).min(na - 1) {
                        for jb in ib.saturating_sub(1)..=(ib + 1).min(nb - 1) {
                            for jl in il.saturating_sub(1)..=(il + 1).min(nl - 1) {
                                let there = index(ja, jb, jl);
                                if grid[there] > ll || (grid[there] == ll && there < here) {
                                    local_max = false;
                                    break 'neighbours;
                                }
                            }
                        }
                    }
                    if local_max {
                        starts.push((ll, [axes[0][ia], axes[1][ib], axes[2][il]]));
                    }
                }
            }
        }
        // And the best point at each slope: on a steep function's plateau
        // the gradient vanishes, and a shallower start may find the way.
        for ib in 0..nb {
            let mut best: Option<(f64, [f64; 3])> = None;
            for ia in 0..na {
                for il in 0..nl {
                    let ll = grid[index(ia, ib, il)];
                    if ll.is_finite() && best.is_none_or(|(b, _)| ll > b) {
                        best = Some((ll, [axes[0][ia], axes[1][ib], axes[2][il]]));
                    }
                }
            }
            if let Some(b) = best
                && !starts.iter().any(|s| s.1 == b.1)
            {
                starts.push(b);
            }
        }
        // Ties keep grid order (a stable sort).
        starts.sort_by(|x, y| y.0.total_cmp(&x.0));
        let mut best: Option<(f64, [f64; 3])> = None;
        let mut found: Vec<[f64; 3]> = Vec::with_capacity(STARTS);
        for &(_, start) in starts.iter().take(STARTS) {
            let (ll, u) = self.ascend(start, [false; 3], &found);
            found.push(u);
            if ll.is_finite() && best.is_none_or(|(b, _)| ll > b) {
                best = Some((ll, u));
            }
        }
        best.map(|(ll, u)| self.snap_to_bounds(ll, u))
    }

    /// `u` with each coordinate within `1e-10` of its box's width of a
    /// bound put on the bound, where the likelihood does not drop by more
    /// than rounding (so a maximum on a bound is reported on it exactly).
    fn snap_to_bounds(&self, ll: f64, mut u: [f64; 3]) -> [f64; 3] {
        for i in 0..3 {
            for bound in [self.lo[i], self.hi[i]] {
                if u[i] != bound && (u[i] - bound).abs() <= 1e-10 * self.width(i) {
                    let mut snapped = u;
                    snapped[i] = bound;
                    let p = self.params(&snapped);
                    let location = match self.shape {
                        Shape::Weibull => snapped[0],
                        Shape::Logistic | Shape::CumulativeNormal => p.threshold,
                    };
                    if self.ll(location, p.slope, p.lapse) >= ll - 1e-13 * (1.0 + ll.abs()) {
                        u = snapped;
                    }
                }
            }
        }
        u
    }

    /// A bounded damped Newton ascent from `u` (module docs, step 2), the
    /// `held` coordinates kept where they are, in rounds of
    /// [`ROUND_ITERATIONS`]. Near a maximum inside the box Newton converges
    /// within a round; one that does not is creeping towards a maximum on
    /// a bound (the slope of separated data, the location of data at
    /// chance), where the likelihood flattens out super-exponentially.
    /// Then each coordinate whose gradient heads for a bound is tried on
    /// that bound (held there, the others ascending: recursively), and the
    /// ascent goes on from the best of those if it beats the point
    /// reached.
    fn ascend(&self, u: [f64; 3], held: [bool; 3], found: &[[f64; 3]]) -> (f64, [f64; 3]) {
        let mut at = self.newton(u, held, found);
        for _ in 0..ROUNDS {
            let (ll, u, converged) = at;
            if converged {
                break;
            }
            let e = self.eval(&u);
            let mut best: Option<(f64, [f64; 3])> = None;
            for i in 0..3 {
                if held[i] || self.hi[i] <= self.lo[i] || e.grad[i] == 0.0 {
                    continue;
                }
                let bound = if e.grad[i] > 0.0 {
                    self.hi[i]
                } else {
                    self.lo[i]
                };
                if u[i] == bound {
                    continue;
                }
                let mut start = u;
                start[i] = bound;
                let mut hold = held;
                hold[i] = true;
                let (lb, ub) = self.ascend(start, hold, &[]);
                if lb > best.map_or(ll, |(b, _)| b) {
                    best = Some((lb, ub));
                }
            }
            at = self.newton(best.map_or(u, |(_, ub)| ub), held, found);
            if best.is_none() && !at.2 {
                // Nothing better on a bound, and still not converged:
                // keep the point reached.
                break;
            }
        }
        (at.0, at.1)
    }

    /// One round of the damped Newton ascent: the log-likelihood and point
    /// reached, and whether it converged (module docs, step 2).
    fn newton(
        &self,
        mut u: [f64; 3],
        held: [bool; 3],
        found: &[[f64; 3]],
    ) -> (f64, [f64; 3], bool) {
        let mut e = self.eval(&u);
        if !e.ll.is_finite() {
            return (f64::NEG_INFINITY, u, true);
        }
        let mut mu = 1e-3_f64;
        let widths = [self.width(0), self.width(1), self.width(2)];
        for _ in 0..ROUND_ITERATIONS {
            if self.evaluations.get() > MAX_EVALUATIONS {
                return (e.ll, u, true);
            }
            let free = self.free(&u, &e.grad, held);
            if free.is_empty() {
                return (e.ll, u, true);
            }
            let mut moved = None;
            'damping: while mu <= 1e20 {
                let Some(d) = damped_newton_step(&e, &free, &widths, mu) else {
                    mu = (mu * 10.0).max(1e-12);
                    continue;
                };
                // The step, then (where the quadratic model overshoots, as
                // on a flattening ridge) fractions of it along the same
                // direction, before more damping turns the direction.
                for (halvings, t) in [1.0, 0.5, 0.25, 0.125].into_iter().enumerate() {
                    let mut next = u;
                    let mut step = 0.0_f64;
                    for (&i, &di) in free.iter().zip(&d) {
                        next[i] = (u[i] + t * di).clamp(self.lo[i], self.hi[i]);
                        step = step.max((next[i] - u[i]).abs() / widths[i]);
                    }
                    if step == 0.0 {
                        break 'damping;
                    }
                    let en = self.eval(&next);
                    let rounding = 1e-13 * (1.0 + e.ll.abs());
                    let better = en.ll > e.ll
                        || (en.ll >= e.ll - rounding
                            && self.projected_gradient(&next, &en.grad, held)
                                < self.projected_gradient(&u, &e.grad, held));
                    if better {
                        u = next;
                        e = en;
                        if halvings == 0 {
                            mu = if mu > 1e-12 { mu * 0.1 } else { 0.0 };
                        }
                        moved = Some(step);
                        break 'damping;
                    }
                }
                mu = (mu * 10.0).max(1e-12);
            }
            match moved {
                Some(step) if step > STEP_TOLERANCE => {}
                // Converged, or no step raises the likelihood any more.
                _ => return (e.ll, u, true),
            }
            // Close to a maximum an earlier ascent reached: the same
            // basin, so no need to go on.
            if found
                .iter()
                .any(|f| (0..3).all(|i| (u[i] - f[i]).abs() <= SAME_BASIN * widths[i]))
            {
                return (e.ll, u, true);
            }
        }
        (e.ll, u, false)
    }
}

/// The step `d` on the `free` coordinates solving `(-H + mu D) d = g` by
/// Cholesky, `D` Marquardt's diagonal `|H_ii|` plus a floor so that no
/// coordinate goes undamped where its curvature vanishes: `1e-6` of the
/// largest curvature across a box's width, over the coordinate's box width
/// squared; `None` where that matrix is not positive definite.
#[allow(clippy::needless_range_loop)] // Cholesky reads best with indices.
fn damped_newton_step(e: &Eval, free: &[usize], width: &[f64; 3], mu: f64) -> Option<Vec<f64>> {
    let n = free.len();
    let across = free
        .iter()
        .map(|&i| e.hess[i][i].abs() * width[i] * width[i])
        .fold(f64::MIN_POSITIVE, f64::max);
    let mut a = [[0.0_f64; 3]; 3];
    let mut b = [0.0_f64; 3];
    for (r, &i) in free.iter().enumerate() {
        b[r] = e.grad[i];
        for (c, &j) in free.iter().enumerate() {
            a[r][c] = -e.hess[i][j];
        }
        let scale = e.hess[i][i].abs() + 1e-6 * across / (width[i] * width[i]);
        a[r][r] += mu * scale;
    }
    // Cholesky a = L L^T, in place in the lower triangle.
    for r in 0..n {
        for c in 0..=r {
            let mut sum = a[r][c];
            for k in 0..c {
                sum -= a[r][k] * a[c][k];
            }
            if r == c {
                if !(sum > 0.0 && sum.is_finite()) {
                    return None;
                }
                a[r][r] = sum.sqrt();
            } else {
                a[r][c] = sum / a[c][c];
            }
        }
    }
    let mut y = [0.0_f64; 3];
    for r in 0..n {
        let mut sum = b[r];
        for k in 0..r {
            sum -= a[r][k] * y[k];
        }
        y[r] = sum / a[r][r];
    }
    let mut d = vec![0.0_f64; n];
    for r in (0..n).rev() {
        let mut sum = y[r];
        for k in r + 1..n {
            sum -= a[k][r] * d[k];
        }
        d[r] = sum / a[r][r];
    }
    d.iter().all(|v| v.is_finite()).then_some(d)
}

/// `x ln y`, 0 where `x = 0` (whatever `y`), `-inf` where `y <= 0 < x`.
fn xlny(x: f64, y: f64) -> f64 {
    if x == 0.0 {
        0.0
    } else if y > 0.0 {
        x * y.ln()
    } else {
        f64::NEG_INFINITY
    }
}

impl Shape {
    /// The sigmoid `G(z)` of which `F` is a location-slope family in `w`
    /// (module docs), as `(G, 1 - G, e^z)`, `G` and `1 - G` each to full
    /// relative precision (the smaller one computed, the other its
    /// complement): logistic; standard normal; for the Weibull, the Gumbel
    /// `1 - exp(-e^z)` with `z = slope (ln x - ln threshold)` (`e^z` is
    /// returned for its derivatives; 0 for the other shapes).
    fn sigmoid(self, z: f64) -> (f64, f64, f64) {
        match self {
            Shape::Logistic => {
                if z >= 0.0 {
                    let e = (-z).exp();
                    let g = 1.0 / (1.0 + e);
                    (g, e * g, 0.0)
                } else {
                    let e = z.exp();
                    let cg = 1.0 / (1.0 + e);
                    (e * cg, cg, 0.0)
                }
            }
            Shape::CumulativeNormal => {
                if z < 0.0 {
                    let g = phi(z);
                    (g, 1.0 - g, 0.0)
                } else {
                    let cg = phi(-z);
                    (1.0 - cg, cg, 0.0)
                }
            }
            Shape::Weibull => {
                let ez = z.exp();
                if ez < std::f64::consts::LN_2 {
                    let g = -(-ez).exp_m1();
                    (g, 1.0 - g, ez)
                } else {
                    let cg = (-ez).exp();
                    (1.0 - cg, cg, ez)
                }
            }
        }
    }

    /// `G'(z)` and `G''(z)`, given [`Shape::sigmoid`]'s `(G, 1 - G, e^z)`.
    fn derivatives(self, z: f64, g: f64, cg: f64, ez: f64) -> (f64, f64) {
        match self {
            Shape::Logistic => {
                let d1 = g * cg;
                (d1, d1 * (cg - g))
            }
            Shape::CumulativeNormal => {
                let d1 = (-0.5 * z * z).exp() * FRAC_1_SQRT_2PI;
                (d1, -z * d1)
            }
            Shape::Weibull => {
                if cg == 0.0 {
                    (0.0, 0.0)
                } else {
                    let d1 = ez * cg;
                    (d1, d1 * (1.0 - ez))
                }
            }
        }
    }
}

/// The maximum of `f` over `[lo, hi]`: the best of `count` points evenly
/// across it (both ends included), refined by golden section between its
/// neighbours; `(argmax, max)`. Deterministic.
fn scan_and_refine(lo: f64, hi: f64, count: usize, f: &impl Fn(f64) -> f64) -> (f64, f64) {
    #[allow(clippy::cast_precision_loss)]
    let point = |i: usize| lo + (hi - lo) * i as f64 / (count - 1) as f64;
    let (mut best_i, mut best) = (0, f64::NEG_INFINITY);
    for i in 0..count {
        let v = f(point(i));
        if v > best {
            (best_i, best) = (i, v);
        }
    }
    let mut best_x = point(best_i);
    let (mut a, mut b) = (
        point(best_i.saturating_sub(1)),
        point((best_i + 1).min(count - 1)),
    );
    let ratio = 0.5 * (5.0_f64.sqrt() - 1.0);
    let (mut c, mut d) = (b - ratio * (b - a), a + ratio * (b - a));
    let (mut fc, mut fd) = (f(c), f(d));
    for _ in 0..GOLDEN_STEPS {
        if fc >= fd {
            (b, d, fd) = (d, c, fc);
            c = b - ratio * (b - a);
            fc = f(c);
        } else {
            (a, c, fc) = (c, d, fd);
            d = a + ratio * (b - a);
            fd = f(d);
        }
    }
    for (x, v) in [(c, fc), (d, fd)] {
        if v > best {
            (best_x, best) = (x, v);
        }
    }
    (best_x, best)
}

impl Shape {
    /// A stimulus or location on the `w` axis (module docs): `ln x` for
    /// the Weibull, `x` otherwise.
    fn to_w(self, x: f64) -> f64 {
        match self {
            Shape::Weibull => x.ln(),
            Shape::Logistic | Shape::CumulativeNormal => x,
        }
    }

    /// [`Shape::to_w`]'s inverse.
    fn x_of_w(self, w: f64) -> f64 {
        match self {
            Shape::Weibull => w.exp(),
            Shape::Logistic | Shape::CumulativeNormal => w,
        }
    }

    /// The standard sigmoid's inverse: the `z` where [`Shape::sigmoid`]'s
    /// `G(z) = p`, for `p` in (0, 1).
    fn standard_inverse(self, p: f64) -> f64 {
        match self {
            Shape::Weibull => (-(-p).ln_1p()).ln(),
            Shape::Logistic => (p / (1.0 - p)).ln(),
            Shape::CumulativeNormal => phi_inverse(p),
        }
    }
}

/// `1 / sqrt(2 pi)`.
const FRAC_1_SQRT_2PI: f64 = 0.398_942_280_401_432_7;
