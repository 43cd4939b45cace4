//! Fitts targeting (seed 002): per participant x condition x ID means,
//! quadrant counts against each participant's own baseline, movement time
//! regressed on ID, and ISO 9241-9 effective throughput.
//!
//! Definitions:
//! - Per test: completion time (first to last hit), errors (misses), mean
//!   error size; movement time per movement `MT = completion / (taps - 1)`.
//! - Quadrants: for each condition other than `baseline`, and each ID (and
//!   all IDs pooled, `id_bits` null), each participant's change in mean
//!   completion time and in mean errors against the same participant's
//!   `baseline` at the same ID. Participants fall in the seed's four
//!   quadrants, or `ties` when either change is exactly zero.
//! - Regression: OLS of MT on ID over every test of the condition.
//! - Throughput: each test's ISO 9241-9 effective throughput
//!   ([`super::stats::effective_throughput`]), averaged per condition (the
//!   mean of per-sequence values).

use std::collections::BTreeMap;

use serde_json::{Value, json};

use super::stats::{effective_throughput, linear_fit, mean};
use super::{Cell, Rows, Table, num, opt, text};
use crate::problem::Problem;

/// One completed test.
#[derive(Debug, Clone, PartialEq)]
pub struct Test {
    /// Participant.
    pub participant: String,
    /// Condition.
    pub condition: String,
    /// Index of difficulty, bits.
    pub id_bits: f64,
    /// First to last hit, s.
    pub completion_s: f64,
    /// Hits.
    pub taps: f64,
    /// Misses.
    pub errors: f64,
    /// Mean miss size, m.
    pub mean_error_m: Option<f64>,
    /// Effective throughput, bits/s.
    pub throughput: Option<f64>,
}

/// Quadrant counts for one condition and ID (None: pooled).
#[derive(Debug, Clone, PartialEq)]
pub struct Quadrant {
    /// Condition.
    pub condition: String,
    /// ID, or None for all IDs pooled.
    pub id_bits: Option<f64>,
    /// Counts: slower & less accurate, faster & less accurate, faster & more
    /// accurate, slower & more accurate, ties.
    pub counts: [u32; 5],
    /// Each participant's (time change s, error change).
    pub points: Vec<(f64, f64)>,
}

/// The Fitts results.
#[derive(Debug, Clone)]
pub struct Fitts {
    /// The `fitts` object of `summary.json`.
    pub summary: Value,
    /// Tables.
    pub tables: Vec<Table>,
    /// Why some statistics are n/a.
    pub notes: Vec<String>,
    /// Quadrant counts.
    pub quadrants: Vec<Quadrant>,
    /// Per condition: (mean MT per movement at each ID, fit).
    pub mt_by_id: Vec<MtById>,
}

fn tests(rows: &Rows) -> Result<Vec<Test>, Problem> {
    (0..rows.len())
        .map(|i| {
            let times = rows.list("tap_times_s", i)?;
            let x = rows.list("tap_x_m", i)?;
            let targets = rows.list("target_x_m", i)?;
            Ok(Test {
                participant: rows.text("participant", i).to_owned(),
                condition: rows.text("condition", i).to_owned(),
                id_bits: rows.number("id_bits", i)?,
                completion_s: rows.number("completion_time_s", i)?,
                taps: rows.number("taps", i)?,
                errors: rows.number("errors", i)?,
                mean_error_m: rows.optional("mean_error_m", i)?,
                throughput: effective_throughput(&times, &x, &targets),
            })
        })
        .collect()
}

/// `f64` as a sortable map key.
fn key(x: f64) -> u64 {
    x.to_bits()
}

/// Per condition: mean MT per movement at each ID, and the OLS fit.
pub type MtById = (String, Vec<(f64, f64)>, Option<super::stats::Fit>);

fn columns(names: &[&str]) -> Vec<String> {
    names.iter().map(|s| (*s).to_owned()).collect()
}

fn sorted_unique<T: Clone + PartialOrd>(mut v: Vec<T>) -> Vec<T> {
    v.sort_by(|a, b| a.partial_cmp(b).unwrap_or(std::cmp::Ordering::Equal));
    v.dedup();
    v
}

/// Per participant x condition x ID means, as table rows.
fn means_rows(tests: &[Test]) -> Vec<Vec<Cell>> {
    let mut cells: BTreeMap<(String, String, u64), Vec<&Test>> = BTreeMap::new();
    for t in tests {
        cells
            .entry((t.participant.clone(), t.condition.clone(), key(t.id_bits)))
            .or_default()
            .push(t);
    }
    cells
        .iter()
        .map(|((p, c, id), ts)| {
            let of = |f: fn(&Test) -> f64| mean(&ts.iter().map(|t| f(t)).collect::<Vec<_>>());
            let errs: Vec<f64> = ts.iter().filter_map(|t| t.mean_error_m).collect();
            vec![
                text(p.clone()),
                text(c.clone()),
                num(f64::from_bits(*id)),
                opt(of(|t| t.completion_s)),
                opt(of(|t| t.errors)),
                opt(mean(&errs)),
                opt(mean(
                    &ts.iter().filter_map(|t| t.throughput).collect::<Vec<_>>(),
                )),
                num(ts.len() as f64),
            ]
        })
        .collect()
}

/// Quadrant counts of each condition against baseline, per ID and pooled.
fn quadrants(
    tests: &[Test],
    conditions: &[String],
    ids: &[f64],
    participants: &[String],
) -> Vec<Quadrant> {
    let per = |p: &str, c: &str, id: Option<f64>| -> Option<(f64, f64)> {
        let ts: Vec<&Test> = tests
            .iter()
            .filter(|t| t.participant == p && t.condition == c && id.is_none_or(|i| t.id_bits == i))
            .collect();
        Some((
            mean(&ts.iter().map(|t| t.completion_s).collect::<Vec<_>>())?,
            mean(&ts.iter().map(|t| t.errors).collect::<Vec<_>>())?,
        ))
    };
    let mut out = Vec::new();
    for c in conditions.iter().filter(|c| *c != "baseline") {
        for id in ids.iter().map(|&i| Some(i)).chain([None]) {
            let mut q = Quadrant {
                condition: c.clone(),
                id_bits: id,
                counts: [0; 5],
                points: Vec::new(),
            };
            for p in participants {
                let (Some((tc, ec)), Some((tb, eb))) = (per(p, c, id), per(p, "baseline", id))
                else {
                    continue;
                };
                let (dt, de) = (tc - tb, ec - eb);
                q.points.push((dt, de));
                let slot = match (dt, de) {
                    (t, e) if t == 0.0 || e == 0.0 => 4,
                    (t, e) if t > 0.0 && e > 0.0 => 0,
                    (t, e) if t < 0.0 && e > 0.0 => 1,
                    (t, _) if t < 0.0 => 2,
                    _ => 3,
                };
                q.counts[slot] += 1;
            }
            out.push(q);
        }
    }
    out
}

/// MT-on-ID fits, throughput and their table rows, per condition.
struct Regressions {
    regression: Vec<Value>,
    mt_by_id: Vec<MtById>,
    throughput: serde_json::Map<String, Value>,
    rows: Vec<Vec<Cell>>,
}

fn regressions(
    tests: &[Test],
    conditions: &[String],
    ids: &[f64],
    notes: &mut Vec<String>,
) -> Regressions {
    let (mut regression, mut mt_by_id, mut reg_rows) = (Vec::new(), Vec::new(), Vec::new());
    let mut throughput = serde_json::Map::new();
    for c in conditions {
        let pts: Vec<(f64, f64)> = tests
            .iter()
            .filter(|t| &t.condition == c && t.taps >= 2.0)
            .map(|t| (t.id_bits, t.completion_s / (t.taps - 1.0)))
            .collect();
        let fit = linear_fit(&pts);
        if fit.is_none() {
            notes.push(format!(
                "fitts.regression: n/a for {c}: fewer than two distinct IDs"
            ));
        }
        let by_id: Vec<(f64, f64)> = ids
            .iter()
            .filter_map(|&i| {
                Some((
                    i,
                    mean(
                        &pts.iter()
                            .filter(|p| p.0 == i)
                            .map(|p| p.1)
                            .collect::<Vec<_>>(),
                    )?,
                ))
            })
            .collect();
        mt_by_id.push((c.clone(), by_id, fit));
        regression.push(json!({
            "condition": c, "intercept_s": fit.map(|f| f.intercept), "slope_s_per_bit": fit.map(|f| f.slope),
            "r2": fit.map(|f| f.r2), "n": pts.len(),
        }));
        let tp = mean(
            &tests
                .iter()
                .filter(|t| &t.condition == c)
                .filter_map(|t| t.throughput)
                .collect::<Vec<_>>(),
        );
        throughput.insert(c.clone(), json!(tp));
        reg_rows.push(vec![
            text(c.clone()),
            opt(fit.map(|f| f.intercept)),
            opt(fit.map(|f| f.slope)),
            opt(fit.map(|f| f.r2)),
            num(pts.len() as f64),
            opt(tp),
        ]);
    }

    Regressions {
        regression,
        mt_by_id,
        throughput,
        rows: reg_rows,
    }
}

/// Analyses the Fitts rows.
///
/// # Errors
/// A value that is not a number.
pub fn analyze(rows: &Rows) -> Result<Fitts, Problem> {
    let tests = tests(rows)?;
    let mut notes = Vec::new();
    let mut conditions = sorted_unique(tests.iter().map(|t| t.condition.clone()).collect());
    if let Some(i) = conditions.iter().position(|c| c == "baseline") {
        let b = conditions.remove(i);
        conditions.insert(0, b);
    }
    let ids = sorted_unique(tests.iter().map(|t| t.id_bits).collect());
    let participants = sorted_unique(tests.iter().map(|t| t.participant.clone()).collect());
    let quadrants = if conditions.first().map(String::as_str) == Some("baseline") {
        quadrants(&tests, &conditions, &ids, &participants)
    } else {
        if !tests.is_empty() {
            notes.push(
                "fitts.quadrants: n/a: no 'baseline' condition to compare against".to_owned(),
            );
        }
        Vec::new()
    };

    let Regressions {
        regression,
        mt_by_id,
        throughput,
        rows: reg_rows,
    } = regressions(&tests, &conditions, &ids, &mut notes);

    let quad_json: Vec<Value> = quadrants
        .iter()
        .map(|q| {
            json!({
                "condition": q.condition, "id_bits": q.id_bits,
                "slower_less_accurate": q.counts[0], "faster_less_accurate": q.counts[1],
                "faster_more_accurate": q.counts[2], "slower_more_accurate": q.counts[3], "ties": q.counts[4],
            })
        })
        .collect();
    let summary = json!({
        "quadrants": quad_json,
        "regression": regression,
        "throughput_bits_per_s": throughput,
        "participants": participants.len(),
        "tests": tests.len(),
    });
    let quadrant_rows = quadrants
        .iter()
        .map(|q| {
            let mut r = vec![text(q.condition.clone()), opt(q.id_bits)];
            r.extend(q.counts.iter().map(|&n| num(f64::from(n))));
            r
        })
        .collect();
    let tables = vec![
        Table {
            name: "fitts_means".into(),
            columns: columns(&[
                "participant",
                "condition",
                "id_bits",
                "completion_time_s",
                "errors",
                "mean_error_m",
                "throughput_bits_per_s",
                "n",
            ]),
            rows: means_rows(&tests),
        },
        Table {
            name: "fitts_quadrants".into(),
            columns: columns(&[
                "condition",
                "id_bits",
                "slower_less_accurate",
                "faster_less_accurate",
                "faster_more_accurate",
                "slower_more_accurate",
                "ties",
            ]),
            rows: quadrant_rows,
        },
        Table {
            name: "fitts_regression".into(),
            columns: columns(&[
                "condition",
                "intercept_s",
                "slope_s_per_bit",
                "r2",
                "n",
                "throughput_bits_per_s",
            ]),
            rows: reg_rows,
        },
    ];
    Ok(Fitts {
        summary,
        tables,
        notes,
        quadrants,
        mt_by_id,
    })
}
