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

use std::collections::HashMap;

use serde_json::{Value, json};

use super::stats::{geometric_mean, linear_fit, pearson};
use super::{Cell, Rows, Table, num, opt, text};
use crate::problem::Problem;

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

/// The analysed answers, column-wise with coded names.
struct Answers {
    participant: Vec<u32>,
    participants: usize,
    display: Vec<u32>,
    display_names: Vec<String>,
    mu_s: Vec<f64>,
    mu_k: Vec<f64>,
    delta_mu: Vec<f64>,
    ln: Vec<f64>,
}

/// Parses and checks the rows.
fn answers(rows: &Rows) -> Result<Answers, Problem> {
    let magnitude = rows.numbers("magnitude")?;
    if let Some(bad) = magnitude.iter().find(|m| **m <= 0.0) {
        let i = magnitude.iter().position(|m| m == bad).unwrap_or(0);
        return Err(rows.error(
            "magnitude",
            i,
            &format!("{bad} is not greater than 0 (magnitudes must be positive)"),
        ));
    }
    let (participant, names) = rows.codes("participant");
    let (display, display_names) = rows.codes("display");
    Ok(Answers {
        participant,
        participants: names.len(),
        display,
        display_names,
        mu_s: rows.numbers("mu_s")?,
        mu_k: rows.numbers("mu_k")?,
        delta_mu: rows.numbers("delta_mu")?.into_iter().map(round9).collect(),
        ln: magnitude.iter().map(|m| m.ln()).collect(),
    })
}

/// Displays in protocol order, then any others alphabetically.
fn display_list(a: &Answers, order: &[String]) -> Vec<String> {
    let mut displays: Vec<String> = order
        .iter()
        .filter(|d| a.display_names.contains(d))
        .cloned()
        .collect();
    let mut rest: Vec<String> = a
        .display_names
        .iter()
        .filter(|d| !displays.contains(d))
        .cloned()
        .collect();
    rest.sort();
    displays.extend(rest);
    displays
}

/// Both normalizations' geometric means per stimulus, sorted by display
/// order, normalization, delta_mu, mu_s.
fn normalized_means(a: &Answers, displays: &[String]) -> Vec<GeoMean> {
    let (np, nd) = (a.participants, a.display_names.len());
    // Sums and counts of logs: per participant, per participant x display,
    // per display.
    let (mut p_sum, mut p_n) = (vec![0.0; np], vec![0.0; np]);
    let (mut pd_sum, mut pd_n) = (vec![0.0; np * nd], vec![0.0; np * nd]);
    let (mut d_sum, mut d_n) = (vec![0.0; nd], vec![0.0; nd]);
    for i in 0..a.ln.len() {
        let (p, d) = (a.participant[i] as usize, a.display[i] as usize);
        p_sum[p] += a.ln[i];
        p_n[p] += 1.0;
        pd_sum[p * nd + d] += a.ln[i];
        pd_n[p * nd + d] += 1.0;
        d_sum[d] += a.ln[i];
        d_n[d] += 1.0;
    }
    let grand = a.ln.iter().sum::<f64>() / a.ln.len().max(1) as f64;
    // Per stimulus: (mu_s, mu_k, delta_mu, sum pooled, sum per_display, n).
    let mut stimuli: HashMap<(u32, u64, u64), usize> = HashMap::new();
    let mut acc: Vec<(u32, f64, f64, f64, f64, f64, usize)> = Vec::new();
    for i in 0..a.ln.len() {
        let (p, d) = (a.participant[i] as usize, a.display[i] as usize);
        let pooled = a.ln[i] + grand - p_sum[p] / p_n[p];
        let per_display = a.ln[i] + d_sum[d] / d_n[d] - pd_sum[p * nd + d] / pd_n[p * nd + d];
        let k = *stimuli
            .entry((a.display[i], a.mu_s[i].to_bits(), a.mu_k[i].to_bits()))
            .or_insert_with(|| {
                acc.push((
                    a.display[i],
                    a.mu_s[i],
                    a.mu_k[i],
                    a.delta_mu[i],
                    0.0,
                    0.0,
                    0,
                ));
                acc.len() - 1
            });
        acc[k].4 += pooled;
        acc[k].5 += per_display;
        acc[k].6 += 1;
    }
    let mut means: Vec<GeoMean> = Vec::with_capacity(2 * acc.len());
    for (d, mu_s, mu_k, delta_mu, pooled, per_display, n) in acc {
        for (normalization, sum) in [("pooled", pooled), ("per_display", per_display)] {
            means.push(GeoMean {
                display: a.display_names[d as usize].clone(),
                mu_s,
                mu_k,
                delta_mu,
                normalization,
                value: (sum / n as f64).exp(),
                n,
            });
        }
    }
    let rank = |d: &str| displays.iter().position(|x| x == d).unwrap_or(usize::MAX);
    means.sort_by(|x, y| {
        (
            rank(&x.display),
            x.normalization != "pooled",
            x.delta_mu,
            x.mu_s,
            x.mu_k,
        )
            .partial_cmp(&(
                rank(&y.display),
                y.normalization != "pooled",
                y.delta_mu,
                y.mu_s,
                y.mu_k,
            ))
            .unwrap_or(std::cmp::Ordering::Equal)
    });
    means
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
pub fn analyze(rows: &Rows, order: &[String]) -> Result<Magnitude, Problem> {
    let answers = answers(rows)?;
    let mut notes = Vec::new();
    if answers.ln.is_empty() {
        notes.push("magnitude_estimation: no completed trials".to_owned());
    }
    let displays = display_list(&answers, order);
    let means = normalized_means(&answers, &displays);
    let participants = answers.participants;
    let (correlations, corr_rows) = if displays.len() == 2 {
        correlations(&means, &displays, &mut notes)
    } else {
        if !answers.ln.is_empty() {
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
