//! The toy staircase's analysis: each participant's threshold, the mean of
//! the differences at which their 1-up-1-down track reversed (Levitt 1971:
//! the track converges on the 50 % point), and the participants' mean
//! threshold with its 95 % t interval (the statistic `power` counts, by its
//! width).

use std::collections::BTreeMap;

use serde_json::{Value, json};

use crate::analysis::counted::KindCounted;
use crate::analysis::stats::{mean, one_sample_t};
use crate::analysis::{Rows, Table, opt, text};
use crate::problem::Problem;

/// The staircase's results.
#[derive(Debug, Clone)]
pub struct Thresholds {
    /// The kind's object of `summary.json`.
    pub summary: Value,
    /// One row per participant.
    pub tables: Vec<Table>,
    /// Why some statistics are n/a.
    pub notes: Vec<String>,
}

/// The mean of the differences where a track's direction turned (a
/// reversal: the difference went down then up, or up then down); `None`
/// before the first reversal.
#[must_use]
pub fn reversal_mean(track: &[f64]) -> Option<f64> {
    let mut at = Vec::new();
    let mut last_step = 0.0_f64;
    for pair in track.windows(2) {
        let step = pair[1] - pair[0];
        if step == 0.0 {
            continue;
        }
        if last_step != 0.0 && step.signum() != last_step.signum() {
            at.push(pair[0]);
        }
        last_step = step;
    }
    mean(&at)
}

/// Analyses the staircase rows: each participant's track in trial order.
///
/// # Errors
/// A `trial` or `delta_mu_s` that is not a number.
pub fn analyze(rows: &Rows) -> Result<Thresholds, Problem> {
    let mut tracks: BTreeMap<String, Vec<(f64, f64)>> = BTreeMap::new();
    for i in 0..rows.len() {
        let participant = rows.text("participant", i).to_owned();
        let trial = rows.number("trial", i)?;
        let delta = rows.number("delta_mu_s", i)?;
        tracks.entry(participant).or_default().push((trial, delta));
    }
    let mut notes = Vec::new();
    let mut participants = Vec::new();
    let mut rows_out = Vec::new();
    let mut thresholds = Vec::new();
    for (participant, mut track) in tracks {
        track.sort_by(|a, b| a.0.total_cmp(&b.0));
        let deltas: Vec<f64> = track.iter().map(|t| t.1).collect();
        let threshold = reversal_mean(&deltas);
        match threshold {
            Some(x) => thresholds.push(x),
            None => notes.push(format!(
                "toy_staircase: {participant}: no reversal in {} trials, no threshold",
                deltas.len()
            )),
        }
        rows_out.push(vec![
            text(&participant),
            text(deltas.len().to_string()),
            opt(threshold),
        ]);
        participants.push(json!({
            "participant": participant,
            "trials": deltas.len(),
            "threshold_mu_s": threshold,
        }));
    }
    let test = one_sample_t(&thresholds);
    if test.is_none() {
        notes.push(format!(
            "toy_staircase.threshold_mean_ci: n/a: {} thresholds (the interval needs two that differ)",
            thresholds.len()
        ));
    }
    let summary = json!({
        "participants": participants,
        "threshold_mean": mean(&thresholds),
        "threshold_mean_ci": test.map(|t| [t.ci_low, t.ci_high]),
    });
    Ok(Thresholds {
        summary,
        tables: vec![Table {
            name: "toy_staircase_thresholds".to_owned(),
            columns: ["participant", "trials", "threshold_mu_s"]
                .map(str::to_owned)
                .to_vec(),
            rows: rows_out,
        }],
        notes,
    })
}


/// What power counts: the mean threshold, by its interval's width.
pub fn counted(s: &Value, out: &mut KindCounted<'_>) {
    out.interval("threshold_mean_ci", &s["threshold_mean_ci"]);
}

#[cfg(test)]
mod tests {
    use super::reversal_mean;

    #[test]
    fn the_threshold_is_the_mean_of_the_reversal_points() {
        // Down, down, up (reversal at 0.2), up, down (reversal at 0.4).
        let track = [0.4, 0.3, 0.2, 0.3, 0.4, 0.3];
        let mean = reversal_mean(&track).unwrap();
        assert!((mean - 0.3).abs() < 1e-15, "{mean}");
        assert_eq!(reversal_mean(&[0.4, 0.3, 0.2]), None);
    }
}
