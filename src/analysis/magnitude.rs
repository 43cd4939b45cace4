//! Magnitude estimation (seed 001): normalized geometric means, trends
//! against mu_s and mu_k, display correlations, the display ratio.
//!
//! Definitions (CONTRACT.md's `summary.json`):
//! - `pooled`: each answer is scaled by (grand geometric mean of all answers)
//!   / (that participant's geometric mean over both displays);
//!   `per_display`: the same within each display.
//! - A stimulus's value is the geometric mean of its scaled answers (all
//!   participants, all repetitions).
//! - `correlations`: per delta_mu series, Pearson r between the two displays'
//!   `per_display` values across the series' mu_s values, with n, a 95% CI
//!   (Fisher z) and a two-sided p (t test).
//! - `display_ratio`: the geometric mean of the first display's `pooled`
//!   values over the second's. The first display is the protocol's first set
//!   (from the session logs). Without logs, the displays go in alphabetical
//!   order.
//! - `trends` (extra): per display and normalization, the least-squares slope
//!   of value against mu_s and against mu_k, with Pearson r: which
//!   coefficient drives perception.

use std::collections::BTreeMap;

use serde_json::{Value, json};

use super::stats::{geometric_mean, linear_fit, pearson};
use super::{AnalysisError, Cell, Rows, Table, num, opt, text};

/// One stimulus's normalized geometric mean.
#[derive(Debug, Clone, PartialEq)]
pub struct GeoMean {
    /// Display.
    pub display: String,
    /// Static coefficient.
    pub mu_s: f64,
    /// Kinetic coefficient.
    pub mu_k: f64,
    /// mu_s - mu_k (rounded to 1e-9 to group series).
    pub delta_mu: f64,
    /// `pooled` or `per_display`.
    pub normalization: &'static str,
    /// The geometric mean.
    pub value: f64,
    /// Answers behind it.
    pub n: usize,
}

/// The magnitude-estimation results.
#[derive(Debug, Clone)]
pub struct Magnitude {
    /// The `magnitude_estimation` object of `summary.json`.
    pub summary: Value,
    /// Tables.
    pub tables: Vec<Table>,
    /// Why some statistics are n/a.
    pub notes: Vec<String>,
    /// Displays in order.
    pub displays: Vec<String>,
    /// Every geometric mean.
    pub means: Vec<GeoMean>,
}

fn round9(x: f64) -> f64 {
    (x * 1e9).round() / 1e9
}

struct Answer {
    participant: String,
    display: String,
    mu_s: f64,
    mu_k: f64,
    delta_mu: f64,
    ln: f64,
}

type StimulusKey = (String, u64, u64, &'static str);

/// Parses and checks the rows.
fn answers(rows: &Rows) -> Result<Vec<Answer>, AnalysisError> {
    (0..rows.len())
        .map(|i| {
            let m = rows.number("magnitude", i)?;
            if m <= 0.0 {
                return Err(rows.error(
                    "magnitude",
                    i,
                    &format!("{m} is not greater than 0 (magnitudes must be positive)"),
                ));
            }
            Ok(Answer {
                participant: rows.text("participant", i).to_owned(),
                display: rows.text("display", i).to_owned(),
                mu_s: rows.number("mu_s", i)?,
                mu_k: rows.number("mu_k", i)?,
                delta_mu: round9(rows.number("delta_mu", i)?),
                ln: m.ln(),
            })
        })
        .collect()
}

/// Displays in protocol order, then any others alphabetically.
fn display_list(answers: &[Answer], order: &[String]) -> Vec<String> {
    let mut displays: Vec<String> = order
        .iter()
        .filter(|d| answers.iter().any(|a| &a.display == *d))
        .cloned()
        .collect();
    let mut rest: Vec<String> = answers
        .iter()
        .map(|a| a.display.clone())
        .filter(|d| !displays.contains(d))
        .collect();
    rest.sort();
    rest.dedup();
    displays.extend(rest);
    displays
}

/// Both normalizations' geometric means per stimulus, sorted by display
/// order, normalization, delta_mu, mu_s; and the number of participants.
fn normalized_means(answers: &[Answer], displays: &[String]) -> (Vec<GeoMean>, usize) {
    // Mean logs: per participant (""), per participant x display, per display ("").
    let mut sums: BTreeMap<(&str, &str), (f64, f64)> = BTreeMap::new();
    for a in answers {
        for key in [
            (a.participant.as_str(), ""),
            (a.participant.as_str(), a.display.as_str()),
            ("", a.display.as_str()),
        ] {
            let e = sums.entry(key).or_insert((0.0, 0.0));
            e.0 += a.ln;
            e.1 += 1.0;
        }
    }
    let avg = |key: (&str, &str)| sums.get(&key).map_or(0.0, |(s, n)| s / n);
    let grand = answers.iter().map(|a| a.ln).sum::<f64>() / answers.len().max(1) as f64;
    let mut groups: BTreeMap<StimulusKey, (f64, f64, f64, Vec<f64>)> = BTreeMap::new();
    for a in answers {
        let pooled = a.ln + grand - avg((&a.participant, ""));
        let per_display = a.ln + avg(("", &a.display)) - avg((&a.participant, &a.display));
        for (norm, ln) in [("pooled", pooled), ("per_display", per_display)] {
            groups
                .entry((a.display.clone(), a.mu_s.to_bits(), a.mu_k.to_bits(), norm))
                .or_insert((a.mu_s, a.mu_k, a.delta_mu, Vec::new()))
                .3
                .push(ln);
        }
    }
    let mut means: Vec<GeoMean> = groups
        .into_iter()
        .map(
            |((display, _, _, normalization), (mu_s, mu_k, delta_mu, lns))| GeoMean {
                display,
                mu_s,
                mu_k,
                delta_mu,
                normalization,
                n: lns.len(),
                value: (lns.iter().sum::<f64>() / lns.len() as f64).exp(),
            },
        )
        .collect();
    let rank = |d: &str| displays.iter().position(|x| x == d).unwrap_or(usize::MAX);
    means.sort_by(|a, b| {
        (
            rank(&a.display),
            a.normalization != "pooled",
            a.delta_mu,
            a.mu_s,
        )
            .partial_cmp(&(
                rank(&b.display),
                b.normalization != "pooled",
                b.delta_mu,
                b.mu_s,
            ))
            .unwrap_or(std::cmp::Ordering::Equal)
    });
    let participants = sums
        .keys()
        .filter(|(p, d)| d.is_empty() && !p.is_empty())
        .count();
    (means, participants)
}

/// Per delta_mu series: Pearson r between the two displays' per_display
/// values across mu_s. JSON entries and table rows.
fn correlations(
    means: &[GeoMean],
    displays: &[String],
    notes: &mut Vec<String>,
) -> (Vec<Value>, Vec<Vec<Cell>>) {
    let (mut json_rows, mut rows) = (Vec::new(), Vec::new());
    let mut series: Vec<f64> = means.iter().map(|m| m.delta_mu).collect();
    series.sort_by(f64::total_cmp);
    series.dedup();
    for dm in series {
        let of = |d: &String| -> Vec<&GeoMean> {
            means
                .iter()
                .filter(|m| &m.display == d && m.normalization == "per_display" && m.delta_mu == dm)
                .collect()
        };
        let (first, second) = (of(&displays[0]), of(&displays[1]));
        let pairs: Vec<(f64, f64)> = first
            .iter()
            .filter_map(|a| Some((a.value, second.iter().find(|b| b.mu_s == a.mu_s)?.value)))
            .collect();
        let c = pearson(&pairs);
        if c.is_none() {
            notes.push(format!(
                "magnitude_estimation.correlations: n/a for delta_mu {dm}: {} paired stimuli (3 or more with spread needed)",
                pairs.len()
            ));
        }
        json_rows.push(json!({
            "delta_mu": dm, "r": c.map(|c| c.r), "n": pairs.len(),
            "ci95_low": c.and_then(|c| c.ci_low), "ci95_high": c.and_then(|c| c.ci_high), "p": c.and_then(|c| c.p),
        }));
        rows.push(vec![
            num(dm),
            opt(c.map(|c| c.r)),
            num(pairs.len() as f64),
            opt(c.and_then(|c| c.ci_low)),
            opt(c.and_then(|c| c.ci_high)),
            opt(c.and_then(|c| c.p)),
        ]);
    }
    (json_rows, rows)
}

/// Value against mu_s and against mu_k, per display and normalization.
fn trends(means: &[GeoMean], displays: &[String]) -> (Vec<Value>, Vec<Vec<Cell>>) {
    let (mut json_rows, mut rows) = (Vec::new(), Vec::new());
    for d in displays {
        for norm in ["pooled", "per_display"] {
            for against in ["mu_s", "mu_k"] {
                let pts: Vec<(f64, f64)> = means
                    .iter()
                    .filter(|m| &m.display == d && m.normalization == norm)
                    .map(|m| (if against == "mu_s" { m.mu_s } else { m.mu_k }, m.value))
                    .collect();
                let fit = linear_fit(&pts);
                let r = pearson(&pts).map(|c| c.r);
                json_rows.push(json!({
                    "display": d, "normalization": norm, "against": against,
                    "slope": fit.map(|f| f.slope), "intercept": fit.map(|f| f.intercept), "r": r, "n": pts.len(),
                }));
                rows.push(vec![
                    text(d.clone()),
                    text(norm),
                    text(against),
                    opt(fit.map(|f| f.slope)),
                    opt(fit.map(|f| f.intercept)),
                    opt(r),
                    num(pts.len() as f64),
                ]);
            }
        }
    }
    (json_rows, rows)
}

fn columns(names: &[&str]) -> Vec<String> {
    names.iter().map(|s| (*s).to_owned()).collect()
}

/// Analyses the magnitude-estimation rows. `order` is the protocol's display
/// order (may be empty).
///
/// # Errors
/// A magnitude or coefficient that is not a number, or a magnitude <= 0.
pub fn analyze(rows: &Rows, order: &[String]) -> Result<Magnitude, AnalysisError> {
    let answers = answers(rows)?;
    let mut notes = Vec::new();
    if answers.is_empty() {
        notes.push("magnitude_estimation: no completed trials".to_owned());
    }
    let displays = display_list(&answers, order);
    let (means, participants) = normalized_means(&answers, &displays);
    let (correlations, corr_rows) = if displays.len() == 2 {
        correlations(&means, &displays, &mut notes)
    } else {
        if !answers.is_empty() {
            notes.push(format!(
                "magnitude_estimation.correlations and display_ratio: n/a: {} display(s) ({}); two are needed",
                displays.len(),
                displays.join(", ")
            ));
        }
        (Vec::new(), Vec::new())
    };
    let pooled = |d: &str| -> Vec<f64> {
        means
            .iter()
            .filter(|m| m.display == d && m.normalization == "pooled")
            .map(|m| m.value)
            .collect()
    };
    let display_ratio = (displays.len() == 2)
        .then(|| {
            geometric_mean(&pooled(&displays[0]))
                .zip(geometric_mean(&pooled(&displays[1])))
                .map(|(a, b)| a / b)
        })
        .flatten();
    let (trends, trend_rows) = trends(&means, &displays);
    let summary = json!({
        "displays": displays,
        "geometric_means": means.iter().map(|m| json!({
            "display": m.display, "mu_s": m.mu_s, "mu_k": m.mu_k, "delta_mu": m.delta_mu,
            "normalization": m.normalization, "value": m.value, "n": m.n,
        })).collect::<Vec<_>>(),
        "correlations": correlations,
        "display_ratio": display_ratio,
        "trends": trends,
        "participants": participants,
    });
    let tables = vec![
        Table {
            name: "magnitude_geometric_means".into(),
            columns: columns(&[
                "display",
                "mu_s",
                "mu_k",
                "delta_mu",
                "normalization",
                "value",
                "n",
            ]),
            rows: means
                .iter()
                .map(|m| {
                    vec![
                        text(m.display.clone()),
                        num(m.mu_s),
                        num(m.mu_k),
                        num(m.delta_mu),
                        text(m.normalization),
                        num(m.value),
                        num(m.n as f64),
                    ]
                })
                .collect(),
        },
        Table {
            name: "magnitude_correlations".into(),
            columns: columns(&["delta_mu", "r", "n", "ci95_low", "ci95_high", "p"]),
            rows: corr_rows,
        },
        Table {
            name: "magnitude_trends".into(),
            columns: columns(&[
                "display",
                "normalization",
                "against",
                "slope",
                "intercept",
                "r",
                "n",
            ]),
            rows: trend_rows,
        },
    ];
    Ok(Magnitude {
        summary,
        tables,
        notes,
        displays,
        means,
    })
}
