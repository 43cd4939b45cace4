//! Friction discrimination (issue 17): a psychometric function fitted to
//! each participant's answers at each reference level, the threshold at the
//! protocol's criterion, JND and Weber fraction with parametric-bootstrap
//! intervals, and group summaries per level.
//!
//! # The fit
//! Maximum likelihood over every completed answer of a track (participant
//! and reference level), grouped by difference
//! (`frictionlab_psychophysics::fit`): the protocol's shape, guess rate 0.5
//! (two intervals), lapse rate free within `[0, fit.max_lapse]`. The
//! threshold is the difference where the fitted function reaches the
//! protocol's `criterion` (lapse included). JND = comparison - reference
//! at the threshold; Weber fraction = JND / reference.
//!
//! # Intervals
//! Two 95% intervals of the threshold (and so of JND and Weber fraction,
//! which are monotone in it):
//! - parametric bootstrap (`fit.bootstrap` samples): answers drawn from
//!   the fitted function at the track's differences and counts, refitted;
//!   the 2.5th and 97.5th percentiles of the refitted thresholds. Each
//!   track's bootstrap is seeded from its participant and level, so a
//!   report is the same on every run;
//! - profile likelihood (`fit::profile_threshold`): the thresholds whose
//!   likelihood-ratio deviance is within 3.84. The likelihood does not
//!   depend on how an adaptive track chose its differences, where the
//!   bootstrap's redraws at the track's own differences leave out how the
//!   track would have wandered; in the recovery test
//!   (`tests/discrimination.rs`) it covers the true threshold more often
//!   for every method. An end where the data do not bound the threshold
//!   is the fit box's edge, flagged in `profile_open`.

use std::collections::BTreeMap;
use std::path::Path;

use frictionlab_psychophysics::fit::{
    Block, Fit, FitSpec, Profile, blocks, bootstrap_threshold, fit, profile_threshold,
};
use frictionlab_psychophysics::psychometric::{GUESS_2IFC, Psychometric};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use serde_json::{Value, json};

use super::{Comparison, DiscriminationDesign};
use crate::analysis::counted::{KindCounted, key};
use crate::analysis::{Rows, Table, num, opt, text};
use crate::participant::id_hash;
use crate::problem::Problem;

/// One track's fit.
#[derive(Debug, Clone)]
pub struct TrackFit {
    /// The participant.
    pub participant: String,
    /// The reference level.
    pub level: f64,
    /// Its answers as `(difference, correct)`, in session order.
    pub answers: Vec<(f64, bool)>,
    /// Answers grouped by difference.
    pub blocks: Vec<Block>,
    /// The maximum-likelihood fit.
    pub fit: Option<Fit>,
    /// Threshold difference at the criterion, and its 95% interval.
    pub threshold: Option<f64>,
    /// Bootstrap interval of the threshold.
    pub threshold_ci: Option<(f64, f64)>,
    /// JND, parameter units.
    pub jnd: Option<f64>,
    /// Weber fraction and its interval.
    pub weber: Option<f64>,
    /// Bootstrap interval of the Weber fraction.
    pub weber_ci: Option<(f64, f64)>,
    /// Profile-likelihood interval of the threshold.
    pub threshold_profile: Option<Profile>,
    /// Profile-likelihood interval of the Weber fraction.
    pub weber_ci_profile: Option<(f64, f64)>,
}

/// The discrimination results.
#[derive(Debug, Clone)]
pub struct Discrimination {
    /// The `discrimination` object of `summary.json`.
    pub summary: Value,
    /// Tables.
    pub tables: Vec<Table>,
    /// Why some statistics are n/a.
    pub notes: Vec<String>,
    /// Every track's fit, by participant then level.
    pub tracks: Vec<TrackFit>,
    /// The design the fits follow.
    pub design: DiscriminationDesign,
}

/// Fits one track, with the threshold's bootstrap and profile-likelihood
/// intervals.
#[must_use]
pub fn fit_track(
    design: &DiscriminationDesign,
    participant: &str,
    level: f64,
    answers: Vec<(f64, bool)>,
) -> TrackFit {
    fit_track_with(design, participant, level, answers, true)
}

/// Fits one track; with `intervals`, the threshold's bootstrap and
/// profile-likelihood intervals too (else they are `None`; the point
/// estimates are the same).
#[must_use]
pub fn fit_track_with(
    design: &DiscriminationDesign,
    participant: &str,
    level: f64,
    answers: Vec<(f64, bool)>,
    intervals: bool,
) -> TrackFit {
    let spec = FitSpec {
        shape: design.fit.shape,
        guess: GUESS_2IFC,
        max_lapse: design.fit.max_lapse,
    };
    let data = blocks(&answers);
    let fitted = fit(&spec, &data);
    let threshold = fitted.and_then(|f| {
        Psychometric {
            shape: spec.shape,
            params: f.params,
            guess: spec.guess,
        }
        .threshold_at(design.criterion)
    });
    let with_intervals = fitted.filter(|_| threshold.is_some() && intervals);
    let threshold_ci = with_intervals.and_then(|f| {
        let mut rng =
            ChaCha8Rng::seed_from_u64(id_hash(participant) ^ level.to_bits().rotate_left(17));
        bootstrap_threshold(
            &spec,
            &f,
            &data,
            design.criterion,
            design.fit.bootstrap,
            0.95,
            &mut rng,
        )
        .map(|b| (b.interval.lo, b.interval.hi))
    });
    let threshold_profile =
        with_intervals.and_then(|f| profile_threshold(&spec, &f, &data, design.criterion, 0.95));
    let c = design.comparison;
    let jnd = threshold.map(|x| c.value(level, x) - level);
    let weber = threshold.map(|x| c.weber(level, x));
    let weber_ci = threshold_ci.map(|(lo, hi)| (c.weber(level, lo), c.weber(level, hi)));
    let weber_ci_profile =
        threshold_profile.map(|p| (c.weber(level, p.interval.lo), c.weber(level, p.interval.hi)));
    TrackFit {
        participant: participant.to_owned(),
        level,
        answers,
        blocks: data,
        fit: fitted,
        threshold,
        threshold_ci,
        jnd,
        weber,
        weber_ci,
        threshold_profile,
        weber_ci_profile,
    }
}

/// A track: its participant and level (its bits), and its answers
/// (difference, correct).
type Track = ((String, u64), Vec<(f64, bool)>);

/// Fits each track (participant, level bits, answers), in their order, on
/// `jobs` threads when `intervals` are asked for. Each track's bootstrap
/// has its own seed (its participant and level), so the fits are the same
/// at any number of threads. Without intervals a fit is cheap, and `power`
/// already runs its studies on every core: one thread then.
fn fit_tracks(
    design: &DiscriminationDesign,
    tracks: &[Track],
    intervals: bool,
    jobs: usize,
) -> Vec<TrackFit> {
    let jobs = if intervals { jobs } else { 1 };
    crate::parallel::run(tracks, jobs, |((p, level), answers)| {
        Ok::<_, std::convert::Infallible>(fit_track_with(
            design,
            p,
            f64::from_bits(*level),
            answers.clone(),
            intervals,
        ))
    })
    .into_iter()
    .map(|fit| match fit {
        Ok(fit) => fit,
        Err(never) => match never {},
    })
    .collect()
}

/// Analyses the discrimination rows of `folder`, whose fits follow
/// `design` (the first of the folder's session logs that has one); with
/// `intervals`, each track's bootstrap and profile intervals too.
///
/// # Errors
/// No session log in the folder holds the discrimination protocol, or a
/// cell is not a number (`level`, `difference`) or 0/1 (`correct`).
pub fn analyze(
    rows: &Rows,
    folder: &Path,
    design: Option<&DiscriminationDesign>,
    intervals: bool,
) -> Result<Discrimination, Problem> {
    let design = design.cloned().ok_or_else(|| {
        Problem::new(
            folder.display().to_string(),
            "no session log holds the discrimination protocol, which the fits need (its criterion, shape and lapse bound)",
        )
    })?;
    let mut by_track: BTreeMap<(String, u64), Vec<(f64, bool)>> = BTreeMap::new();
    for i in 0..rows.len() {
        let level = rows.number("level", i)?;
        let difference = rows.number("difference", i)?;
        let correct = match rows.text("correct", i) {
            "1" => true,
            "0" => false,
            other => {
                return Err(rows.error("correct", i, &format!("'{other}': expected 0 or 1")));
            }
        };
        by_track
            .entry((rows.text("participant", i).to_owned(), level.to_bits()))
            .or_default()
            .push((difference, correct));
    }
    let jobs = std::thread::available_parallelism().map_or(1, std::num::NonZero::get);
    let by_track: Vec<Track> = by_track.into_iter().collect();
    let tracks = fit_tracks(&design, &by_track, intervals, jobs);
    let mut notes = Vec::new();
    for t in &tracks {
        if t.threshold.is_none() {
            notes.push(format!(
                "discrimination: participant {} at level {}: no threshold ({} answers): the fitted function does not reach the criterion {} within the differences",
                t.participant,
                t.level,
                t.answers.len(),
                design.criterion
            ));
        }
    }
    let groups = group_summary(&design, &tracks);
    let fits: Vec<Value> = tracks.iter().map(fit_json).collect();
    let summary = json!({
        "parameter": design.parameter,
        "comparison": match design.comparison {
            Comparison::Ratio => "ratio",
            Comparison::Offset => "offset",
        },
        "criterion": design.criterion,
        "shape": design.fit.shape,
        "guess": GUESS_2IFC,
        "max_lapse": design.fit.max_lapse,
        "bootstrap": design.fit.bootstrap,
        "levels": groups,
        "fits": fits,
    });
    let tables = tables(&tracks, &groups);
    Ok(Discrimination {
        summary,
        tables,
        notes,
        tracks,
        design,
    })
}

/// One track's fit as `summary.json` has it.
fn fit_json(t: &TrackFit) -> Value {
    json!({
        "participant": t.participant,
        "level": t.level,
        "trials": t.answers.len(),
        "proportion_correct": proportion(&t.answers),
        "threshold": t.threshold,
        "threshold_ci": t.threshold_ci.map(|(a, b)| [a, b]),
        "slope": t.fit.map(|f| f.params.slope),
        "location": t.fit.map(|f| f.params.threshold),
        "lapse": t.fit.map(|f| f.params.lapse),
        "log_likelihood": t.fit.map(|f| f.log_likelihood),
        "jnd": t.jnd,
        "weber": t.weber,
        "weber_ci": t.weber_ci.map(|(a, b)| [a, b]),
        "threshold_ci_profile": t.threshold_profile.map(|p| [p.interval.lo, p.interval.hi]),
        "weber_ci_profile": t.weber_ci_profile.map(|(a, b)| [a, b]),
        "profile_open": t.threshold_profile.map(|p| p.open),
    })
}

/// The per-level and per-track tables.
fn tables(tracks: &[TrackFit], groups: &[Value]) -> Vec<Table> {
    let table = Table {
        name: "discrimination_fits".into(),
        columns: [
            "participant",
            "level",
            "trials",
            "threshold",
            "threshold_lo",
            "threshold_hi",
            "slope",
            "lapse",
            "jnd",
            "weber",
            "weber_lo",
            "weber_hi",
            "weber_profile_lo",
            "weber_profile_hi",
        ]
        .map(String::from)
        .to_vec(),
        rows: tracks
            .iter()
            .map(|t| {
                #[expect(clippy::cast_precision_loss, reason = "a trial count")]
                let n = t.answers.len() as f64;
                vec![
                    text(t.participant.clone()),
                    num(t.level),
                    num(n),
                    opt(t.threshold),
                    opt(t.threshold_ci.map(|c| c.0)),
                    opt(t.threshold_ci.map(|c| c.1)),
                    opt(t.fit.map(|f| f.params.slope)),
                    opt(t.fit.map(|f| f.params.lapse)),
                    opt(t.jnd),
                    opt(t.weber),
                    opt(t.weber_ci.map(|c| c.0)),
                    opt(t.weber_ci.map(|c| c.1)),
                    opt(t.weber_ci_profile.map(|c| c.0)),
                    opt(t.weber_ci_profile.map(|c| c.1)),
                ]
            })
            .collect(),
    };
    let group_table = Table {
        name: "discrimination_levels".into(),
        columns: [
            "level",
            "participants",
            "weber_mean",
            "weber_mean_lo",
            "weber_mean_hi",
            "weber_sd",
            "weber_median",
            "jnd_mean",
        ]
        .map(String::from)
        .to_vec(),
        rows: groups
            .iter()
            .map(|g| {
                vec![
                    num(g["level"].as_f64().unwrap_or(f64::NAN)),
                    num(g["participants"].as_f64().unwrap_or(0.0)),
                    opt(g["weber_mean"].as_f64()),
                    opt(g["weber_mean_ci"][0].as_f64()),
                    opt(g["weber_mean_ci"][1].as_f64()),
                    opt(g["weber_sd"].as_f64()),
                    opt(g["weber_median"].as_f64()),
                    opt(g["jnd_mean"].as_f64()),
                ]
            })
            .collect(),
    };
    vec![group_table, table]
}

fn proportion(answers: &[(f64, bool)]) -> Option<f64> {
    #[expect(clippy::cast_precision_loss, reason = "trial counts")]
    let p = answers.iter().filter(|a| a.1).count() as f64 / answers.len() as f64;
    (!answers.is_empty()).then_some(p)
}

/// Per level (in the design's order): the participants with a Weber
/// fraction, their mean with its 95% t interval (across participants; null
/// below 2 participants or without spread), SD and median, and the mean
/// JND.
fn group_summary(design: &DiscriminationDesign, tracks: &[TrackFit]) -> Vec<Value> {
    design
        .levels
        .iter()
        .map(|&level| {
            let mut webers: Vec<f64> = tracks
                .iter()
                .filter(|t| t.level.to_bits() == level.to_bits())
                .filter_map(|t| t.weber)
                .collect();
            let jnds: Vec<f64> = tracks
                .iter()
                .filter(|t| t.level.to_bits() == level.to_bits())
                .filter_map(|t| t.jnd)
                .collect();
            webers.sort_by(f64::total_cmp);
            #[expect(clippy::cast_precision_loss, reason = "participant counts")]
            let n = webers.len() as f64;
            let mean = (n > 0.0).then(|| webers.iter().sum::<f64>() / n);
            let sd = mean
                .filter(|_| n > 1.0)
                .map(|m| (webers.iter().map(|w| (w - m).powi(2)).sum::<f64>() / (n - 1.0)).sqrt());
            let median = (!webers.is_empty()).then(|| {
                let k = webers.len();
                if k % 2 == 1 {
                    webers[k / 2]
                } else {
                    0.5 * (webers[k / 2 - 1] + webers[k / 2])
                }
            });
            #[expect(clippy::cast_precision_loss, reason = "participant counts")]
            let jnd_mean = (!jnds.is_empty()).then(|| jnds.iter().sum::<f64>() / jnds.len() as f64);
            let ci = crate::analysis::stats::one_sample_t(&webers).map(|t| [t.ci_low, t.ci_high]);
            json!({
                "level": level,
                "participants": webers.len(),
                "weber_mean": mean,
                "weber_mean_ci": ci,
                "weber_sd": sd,
                "weber_median": median,
                "jnd_mean": jnd_mean,
            })
        })
        .collect()
}

/// What power counts: each level's mean Weber fraction, by its interval's
/// width.
pub fn counted(s: &Value, out: &mut KindCounted<'_>) {
    for l in s["levels"].as_array().into_iter().flatten() {
        out.interval(
            &format!("levels[level={}].weber_mean_ci", key(&l["level"])),
            &l["weber_mean_ci"],
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The shipped quick protocol's design, with `bootstrap` samples.
    fn design(bootstrap: u32) -> DiscriminationDesign {
        let protocol: Value = serde_json::from_str(include_str!(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/protocols/discrimination-quick.json"
        )))
        .unwrap_or_else(|e| panic!("the protocol: {e}"));
        let mut design = protocol["design"].clone();
        if let Some(d) = design.as_object_mut() {
            d.remove("kind");
        }
        design["fit"]["bootstrap"] = bootstrap.into();
        serde_json::from_value(design).unwrap_or_else(|e| panic!("the design: {e}"))
    }

    #[test]
    fn tracks_fitted_on_two_threads_are_the_tracks_fitted_on_one() {
        let design = design(40);
        // Three participants at two levels, answers more often right the
        // larger the difference.
        let mut tracks = Vec::new();
        for (k, p) in ["a", "b", "c"].into_iter().enumerate() {
            for level in [0.7_f64, 1.3] {
                let answers = (0..40_usize)
                    .map(|i| {
                        let difference = 0.02 * (1 + i % 10) as f64;
                        (difference, (i * 7 + 3 * k) % 10 < 5 + i % 10 / 2)
                    })
                    .collect();
                tracks.push(((p.to_owned(), level.to_bits()), answers));
            }
        }
        let json = |fits: Vec<TrackFit>| fits.iter().map(fit_json).collect::<Vec<Value>>();
        let one = json(fit_tracks(&design, &tracks, true, 1));
        let two = json(fit_tracks(&design, &tracks, true, 2));
        assert_eq!(one.len(), 6);
        assert!(
            one.iter().any(|f| f["weber_ci"].is_array()),
            "no track has a bootstrap interval: {one:?}"
        );
        assert_eq!(one, two);
    }
}
