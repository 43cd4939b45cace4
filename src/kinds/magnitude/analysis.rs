//! Magnitude estimation (seed 001): normalized geometric means, trends
//! against mu_s and mu_k, display correlations, the display ratio.
//!
//! Definitions (CONTRACT.md's `summary.json`):
//! - `pooled`: each answer is scaled by (grand geometric mean of all answers)
//!   / (that participant's geometric mean over both displays);
//!   `per_display`: each display on its own scale: each answer is divided by
//!   that participant's geometric mean on that display (each display's
//!   grand geometric mean is then 1).
//! - A stimulus's value is the geometric mean of its scaled answers (all
//!   participants, all repetitions), with `gsd` (the geometric standard
//!   deviation of the scaled answers) and a 95% CI (t interval on the
//!   logarithms).
//! - `correlations`: per delta_mu series, Pearson r between the two displays'
//!   `per_display` values across the series' mu_s values, with n, a 95% CI
//!   (Fisher z) and a two-sided p (t test).
//! - `display_ratio`: the geometric mean of the first display's `pooled`
//!   values over the second's; `display_ratio_by_delta_mu` the same within
//!   each delta_mu series. The first display is the protocol's first set
//!   (from the session logs). Without logs, the displays go in alphabetical
//!   order.
//! - `display_effect`: whether the displays differ in felt strength, tested
//!   across participants: each participant's difference of mean log answer
//!   (first display minus second; the participant's own modulus cancels),
//!   then a one-sample two-sided t test of those differences against 0
//!   (n - 1 degrees of freedom): `{ratio, ci_low, ci_high, t, p, n}`, the
//!   ratio and its 95% CI as exp of the mean difference and its t interval.
//!   Participants who answered on one display only are left out.
//! - `trends` (extra): per display and normalization, the least-squares slope
//!   of value against mu_s and against mu_k, with Pearson r, over every
//!   stimulus (where mu_s and mu_k move together, so they cannot be told
//!   apart there).
//! - `drivers` (extra): which coefficient drives each display, the two
//!   separated: on the `per_display` values, r and slope against mu_s within
//!   each delta_mu series, and against mu_k within each mu_s level (the
//!   series at that mu_s).

use std::collections::HashMap;

use foldhash::fast::RandomState;
use serde_json::{Value, json};

use crate::analysis::counted::{KindCounted, key};
use crate::analysis::stats::{GeoSummary, geometric_mean, linear_fit, log_summary, one_sample_t, pearson};
use crate::analysis::{Cell, Rows, Table, num, opt, text};
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
    /// Geometric standard deviation of the normalized answers (n >= 2).
    pub gsd: Option<f64>,
    /// 95% confidence interval of the geometric mean, low (t interval on
    /// the logarithms; n >= 2).
    pub ci_low: Option<f64>,
    /// The interval's high end.
    pub ci_high: Option<f64>,
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
        delta_mu: rows.numbers("delta_mu")?,
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

/// One stimulus's normalized answers (natural logs), per normalization.
struct Stimulus {
    display: u32,
    mu_s: f64,
    mu_k: f64,
    delta_mu: f64,
    pooled: Vec<f64>,
    per_display: Vec<f64>,
}

/// Both normalizations' geometric means per stimulus, sorted by display
/// order, normalization, delta_mu, mu_s.
fn normalized_means(a: &Answers, displays: &[String]) -> Vec<GeoMean> {
    let (np, nd) = (a.participants, a.display_names.len());
    // Sums and counts of logs: per participant, per participant x display.
    let (mut p_sum, mut p_n) = (vec![0.0; np], vec![0.0; np]);
    let (mut pd_sum, mut pd_n) = (vec![0.0; np * nd], vec![0.0; np * nd]);
    for i in 0..a.ln.len() {
        let (p, d) = (a.participant[i] as usize, a.display[i] as usize);
        p_sum[p] += a.ln[i];
        p_n[p] += 1.0;
        pd_sum[p * nd + d] += a.ln[i];
        pd_n[p * nd + d] += 1.0;
    }
    let grand = a.ln.iter().sum::<f64>() / a.ln.len().max(1) as f64;
    let mut index: HashMap<(u32, u64, u64), usize, RandomState> = HashMap::default();
    let mut stimuli: Vec<Stimulus> = Vec::new();
    for i in 0..a.ln.len() {
        let (p, d) = (a.participant[i] as usize, a.display[i] as usize);
        let k = *index
            .entry((a.display[i], a.mu_s[i].to_bits(), a.mu_k[i].to_bits()))
            .or_insert_with(|| {
                stimuli.push(Stimulus {
                    display: a.display[i],
                    mu_s: a.mu_s[i],
                    mu_k: a.mu_k[i],
                    delta_mu: a.delta_mu[i],
                    pooled: Vec::new(),
                    per_display: Vec::new(),
                });
                stimuli.len() - 1
            });
        stimuli[k].pooled.push(a.ln[i] + grand - p_sum[p] / p_n[p]);
        stimuli[k]
            .per_display
            .push(a.ln[i] - pd_sum[p * nd + d] / pd_n[p * nd + d]);
    }
    let mut means: Vec<GeoMean> = Vec::with_capacity(2 * stimuli.len());
    for st in stimuli {
        for (normalization, ln) in [("pooled", &st.pooled), ("per_display", &st.per_display)] {
            let Some(GeoSummary {
                value,
                gsd,
                ci_low,
                ci_high,
            }) = log_summary(ln)
            else {
                continue;
            };
            means.push(GeoMean {
                display: a.display_names[st.display as usize].clone(),
                mu_s: st.mu_s,
                mu_k: st.mu_k,
                delta_mu: st.delta_mu,
                normalization,
                value,
                gsd,
                ci_low,
                ci_high,
                n: ln.len(),
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

/// The delta_mu series present, ascending.
fn delta_mu_series(means: &[GeoMean]) -> Vec<f64> {
    let mut series: Vec<f64> = means.iter().map(|m| m.delta_mu).collect();
    series.sort_by(f64::total_cmp);
    series.dedup();
    series
}

/// The display effect (module docs): a paired t test across participants
/// of their first-display minus second-display mean log answers.
fn display_effect(a: &Answers, displays: &[String], notes: &mut Vec<String>) -> Value {
    let code = |name: &String| a.display_names.iter().position(|d| d == name);
    let (Some(first), Some(second)) = (
        displays.first().and_then(code),
        displays.get(1).and_then(code),
    ) else {
        return Value::Null;
    };
    // Per participant: [sum, count] of logs on the first and second display.
    let mut sums = vec![[[0.0, 0.0]; 2]; a.participants];
    for i in 0..a.ln.len() {
        let d = a.display[i] as usize;
        let slot = if d == first {
            0
        } else if d == second {
            1
        } else {
            continue;
        };
        let s = &mut sums[a.participant[i] as usize][slot];
        s[0] += a.ln[i];
        s[1] += 1.0;
    }
    let differences: Vec<f64> = sums
        .iter()
        .filter(|[f, s]| f[1] > 0.0 && s[1] > 0.0)
        .map(|[f, s]| f[0] / f[1] - s[0] / s[1])
        .collect();
    let test = one_sample_t(&differences);
    if test.is_none() {
        notes.push(format!(
            "magnitude_estimation.display_effect: n/a: {} participant(s) answered on both displays (2 or more, not all alike, needed)",
            differences.len()
        ));
    }
    json!({
        "ratio": test.map(|t| t.mean.exp()),
        "ci_low": test.map(|t| t.ci_low.exp()),
        "ci_high": test.map(|t| t.ci_high.exp()),
        "t": test.map(|t| t.t),
        "p": test.map(|t| t.p),
        "n": differences.len(),
    })
}

/// Per delta_mu series: Pearson r between the two displays' per_display
/// values across mu_s. JSON entries and table rows.
fn correlations(
    means: &[GeoMean],
    displays: &[String],
    notes: &mut Vec<String>,
) -> (Vec<Value>, Vec<Vec<Cell>>) {
    let (mut json_rows, mut rows) = (Vec::new(), Vec::new());
    for dm in delta_mu_series(means) {
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

/// What drives each display's answers, with mu_s and mu_k separated: per
/// display, on the `per_display` values, the Pearson r and slope against
/// mu_s within each delta_mu series (mu_k moves with it there), and against
/// mu_k within each mu_s level (across the series, mu_s fixed).
fn drivers(means: &[GeoMean], displays: &[String]) -> Vec<Value> {
    let mut out = Vec::new();
    for d in displays {
        let of = |keep: &dyn Fn(&GeoMean) -> bool, x: fn(&GeoMean) -> f64| -> Vec<(f64, f64)> {
            means
                .iter()
                .filter(|m| &m.display == d && m.normalization == "per_display" && keep(m))
                .map(|m| (x(m), m.value))
                .collect()
        };
        let entry = |against: &str,
                     delta_mu: Option<f64>,
                     mu_s: Option<f64>,
                     pts: &[(f64, f64)]| {
            json!({
                "display": d, "against": against, "delta_mu": delta_mu, "mu_s": mu_s,
                "r": pearson(pts).map(|c| c.r), "slope": linear_fit(pts).map(|f| f.slope), "n": pts.len(),
            })
        };
        for dm in delta_mu_series(means) {
            out.push(entry(
                "mu_s",
                Some(dm),
                None,
                &of(&|m| m.delta_mu == dm, |m| m.mu_s),
            ));
        }
        let mut levels: Vec<f64> = means.iter().map(|m| m.mu_s).collect();
        levels.sort_by(f64::total_cmp);
        levels.dedup();
        for mu_s in levels {
            out.push(entry(
                "mu_k",
                None,
                Some(mu_s),
                &of(&|m| m.mu_s == mu_s, |m| m.mu_k),
            ));
        }
    }
    out
}

fn columns(names: &[&str]) -> Vec<String> {
    names.iter().map(|s| (*s).to_owned()).collect()
}

/// The geometric means, correlations and trends as tables.
fn tables(means: &[GeoMean], corr_rows: Vec<Vec<Cell>>, trend_rows: Vec<Vec<Cell>>) -> Vec<Table> {
    vec![
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
                "gsd",
                "ci_low",
                "ci_high",
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
                        opt(m.gsd),
                        opt(m.ci_low),
                        opt(m.ci_high),
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
    ]
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
    let ratio = |series: Option<f64>| -> Option<f64> {
        let pooled = |d: &str| -> Vec<f64> {
            means
                .iter()
                .filter(|m| m.display == d && m.normalization == "pooled")
                .filter(|m| series.is_none_or(|dm| m.delta_mu == dm))
                .map(|m| m.value)
                .collect()
        };
        (displays.len() == 2)
            .then(|| {
                geometric_mean(&pooled(&displays[0]))
                    .zip(geometric_mean(&pooled(&displays[1])))
                    .map(|(a, b)| a / b)
            })
            .flatten()
    };
    let display_ratio = ratio(None);
    let display_effect = if displays.len() == 2 {
        display_effect(&answers, &displays, &mut notes)
    } else {
        Value::Null
    };
    let ratio_by_delta_mu: Vec<Value> = delta_mu_series(&means)
        .iter()
        .map(|&dm| json!({"delta_mu": dm, "ratio": ratio(Some(dm))}))
        .collect();
    let (trends, trend_rows) = trends(&means, &displays);
    let summary = json!({
        "displays": displays,
        "geometric_means": means.iter().map(|m| json!({
            "display": m.display, "mu_s": m.mu_s, "mu_k": m.mu_k, "delta_mu": m.delta_mu,
            "normalization": m.normalization, "value": m.value, "gsd": m.gsd,
            "ci_low": m.ci_low, "ci_high": m.ci_high, "n": m.n,
        })).collect::<Vec<_>>(),
        "correlations": correlations,
        "display_ratio": display_ratio,
        "display_ratio_by_delta_mu": ratio_by_delta_mu,
        "display_effect": display_effect,
        "trends": trends,
        "drivers": drivers(&means, &displays),
        "participants": participants,
    });
    let tables = tables(&means, corr_rows, trend_rows);
    Ok(Magnitude {
        summary,
        tables,
        notes,
        displays,
        means,
    })
}

/// What power counts: each correlation's test and the display effect's.
pub fn counted(s: &Value, out: &mut KindCounted<'_>) {
    for c in s["correlations"].as_array().into_iter().flatten() {
        out.test(
            &format!("correlations[delta_mu={}].p", key(&c["delta_mu"])),
            &c["p"],
        );
    }
    if !s["display_effect"].is_null() {
        out.test("display_effect.p", &s["display_effect"]["p"]);
    }
}
