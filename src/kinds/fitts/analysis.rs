//! Fitts targeting (seed 002): per participant x condition x ID means,
//! quadrant counts against each participant's own baseline, movement time
//! regressed on ID, and ISO 9241-9 effective throughput.
//!
//! Tests that did not complete (aborted, timed out) are left out of every
//! statistic and counted per condition and ID in `notes`.
//!
//! Definitions:
//! - Per test: completion time (first to last hit), errors (misses), mean
//!   error size; movement time per movement `MT = completion / (taps - 1)`.
//! - Quadrants: for each condition other than `baseline`, and each ID (and
//!   all IDs pooled, `id_bits` null), each participant's change in mean
//!   completion time and in mean error magnitude (over every click: the
//!   distance from the lit target's centre along the axis, seed 002's
//!   accuracy axis) against the same participant's `baseline` at the same
//!   ID. Participants fall in the seed's four quadrants, or `ties` when
//!   either change is exactly zero (neither faster nor slower, or neither
//!   more nor less accurate). `quadrants_error_count` does the same with
//!   the number of errors as the accuracy axis.
//! - Sign tests, per quadrant entry: `time_sign_p`, the two-sided exact
//!   binomial test of the participants faster against those slower
//!   (participants with no time change left out), and `accuracy_sign_p`
//!   likewise of those more accurate against those less accurate; each
//!   against an even split. `null` when no participant changed.
//! - Regression: OLS of MT on ID over every test of the condition, and
//!   each participant's own (`participant_fits`: slope, intercept, r², and
//!   the participant's mean throughput).
//! - Throughput: each test's ISO 9241-9 effective throughput, its endpoint
//!   spread from every click, hits and misses
//!   ([`crate::analysis::stats::effective_throughput`]; from the hits alone for data
//!   files written before clicks were logged),
//!   averaged per condition: the mean of each participant's sequences,
//!   then the mean of participants.

use std::collections::BTreeMap;

use serde_json::{Value, json};

use crate::analysis::counted::{self, KindCounted};
use crate::analysis::stats::{binomial_two_sided, effective_throughput, linear_fit, mean};
use crate::analysis::{Cell, Rows, Table, num, opt, text};
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
    /// Mean error magnitude over every click: the distance of each click
    /// from the lit target's centre along the axis, m (over the hits only
    /// in data files written before clicks were logged).
    pub error_magnitude_m: Option<f64>,
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
    /// Each participant's (time change s, accuracy change).
    pub points: Vec<(f64, f64)>,
}

impl Quadrant {
    /// Participants faster and slower than their baseline.
    #[must_use]
    pub fn faster_slower(&self) -> (u64, u64) {
        signs(self.points.iter().map(|p| p.0))
    }

    /// Participants more and less accurate than their baseline (a smaller
    /// error is more accurate).
    #[must_use]
    pub fn more_less_accurate(&self) -> (u64, u64) {
        signs(self.points.iter().map(|p| p.1))
    }

    /// The sign test of the time changes (module docs).
    #[must_use]
    pub fn time_sign_p(&self) -> Option<f64> {
        let (down, up) = self.faster_slower();
        binomial_two_sided(down, down + up)
    }

    /// The sign test of the accuracy changes (module docs).
    #[must_use]
    pub fn accuracy_sign_p(&self) -> Option<f64> {
        let (down, up) = self.more_less_accurate();
        binomial_two_sided(down, down + up)
    }
}

/// How many of `changes` are negative and how many positive.
fn signs(changes: impl Iterator<Item = f64>) -> (u64, u64) {
    changes.fold((0, 0), |(down, up), c| {
        (down + u64::from(c < 0.0), up + u64::from(c > 0.0))
    })
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
            // Every click when logged; hits only in data files written
            // before clicks were logged.
            let clicks = rows.list("click_times_s", i)?;
            let (times, x, targets, hit) = if clicks.is_empty() {
                let times = rows.list("tap_times_s", i)?;
                let hit = vec![true; times.len()];
                (
                    times,
                    rows.list("tap_x_m", i)?,
                    rows.list("target_x_m", i)?,
                    hit,
                )
            } else {
                let hit = rows.text("click_hit", i).split(';').map(|h| h == "true");
                (
                    clicks,
                    rows.list("click_x_m", i)?,
                    rows.list("click_target_x_m", i)?,
                    hit.collect(),
                )
            };
            Ok(Test {
                participant: rows.text("participant", i).to_owned(),
                condition: rows.text("condition", i).to_owned(),
                id_bits: rows.number("id_bits", i)?,
                completion_s: rows.number("completion_time_s", i)?,
                taps: rows.number("taps", i)?,
                errors: rows.number("errors", i)?,
                mean_error_m: rows.optional("mean_error_m", i)?,
                error_magnitude_m: mean(
                    &x.iter()
                        .zip(&targets)
                        .map(|(x, c)| (x - c).abs())
                        .collect::<Vec<_>>(),
                ),
                throughput: effective_throughput(&times, &x, &targets, &hit),
            })
        })
        .collect()
}

/// `f64` as a sortable map key.
fn key(x: f64) -> u64 {
    x.to_bits()
}

/// Per condition: mean MT per movement at each ID, and the OLS fit.
pub type MtById = (String, Vec<(f64, f64)>, Option<crate::analysis::stats::Fit>);

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
                opt(mean(
                    &ts.iter()
                        .filter_map(|t| t.error_magnitude_m)
                        .collect::<Vec<_>>(),
                )),
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
    accuracy: fn(&Test) -> Option<f64>,
) -> Vec<Quadrant> {
    let per = |p: &str, c: &str, id: Option<f64>| -> Option<(f64, f64)> {
        let ts: Vec<&Test> = tests
            .iter()
            .filter(|t| t.participant == p && t.condition == c && id.is_none_or(|i| t.id_bits == i))
            .collect();
        Some((
            mean(&ts.iter().map(|t| t.completion_s).collect::<Vec<_>>())?,
            mean(&ts.iter().filter_map(|t| accuracy(t)).collect::<Vec<_>>())?,
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
        let of_means = linear_fit(&by_id);
        let mut own: BTreeMap<&str, Vec<(f64, f64)>> = BTreeMap::new();
        for t in tests.iter().filter(|t| &t.condition == c && t.taps >= 2.0) {
            own.entry(&t.participant)
                .or_default()
                .push((t.id_bits, t.completion_s / (t.taps - 1.0)));
        }
        // The mean of each participant's sequences, then of participants.
        let mut by_participant: BTreeMap<&str, Vec<f64>> = BTreeMap::new();
        for t in tests.iter().filter(|t| &t.condition == c) {
            if let Some(tp) = t.throughput {
                by_participant.entry(&t.participant).or_default().push(tp);
            }
        }
        let participant_fits: Vec<Value> = own
            .iter()
            .map(|(p, pts)| {
                let f = linear_fit(pts);
                let tp = by_participant.get(p).and_then(|v| mean(v));
                json!({
                    "participant": p, "slope_s_per_bit": f.map(|f| f.slope),
                    "intercept_s": f.map(|f| f.intercept), "r2": f.map(|f| f.r2),
                    "throughput_bits_per_s": tp,
                })
            })
            .collect();
        mt_by_id.push((c.clone(), by_id, fit));
        regression.push(json!({
            "condition": c, "intercept_s": fit.map(|f| f.intercept), "slope_s_per_bit": fit.map(|f| f.slope),
            "r2": fit.map(|f| f.r2), "n": pts.len(),
            "means_r2": of_means.map(|f| f.r2), "means_slope_s_per_bit": of_means.map(|f| f.slope),
            "means_intercept_s": of_means.map(|f| f.intercept),
            "participant_fits": participant_fits,
        }));
        let tp = mean(
            &by_participant
                .values()
                .filter_map(|v| mean(v))
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

/// The tests left out because they did not complete, counted per
/// condition and ID.
fn aborted_note(aborted: &Rows) -> Result<Option<String>, Problem> {
    let mut cells: BTreeMap<(String, u64), usize> = BTreeMap::new();
    for i in 0..aborted.len() {
        let id = aborted.number("id_bits", i)?;
        *cells
            .entry((aborted.text("condition", i).to_owned(), key(id)))
            .or_default() += 1;
    }
    if cells.is_empty() {
        return Ok(None);
    }
    let list: Vec<String> = cells
        .iter()
        .map(|((c, id), n)| format!("{c} at ID {:.3} bits: {n}", f64::from_bits(*id)))
        .collect();
    Ok(Some(format!(
        "fitts: tests aborted or timed out, not analysed: {} ({})",
        aborted.len(),
        list.join("; ")
    )))
}

/// The quadrant counts as `summary.json` lists them.
fn quadrant_json(quadrants: &[Quadrant]) -> Vec<Value> {
    quadrants
        .iter()
        .map(|q| {
            json!({
                "condition": q.condition, "id_bits": q.id_bits,
                "slower_less_accurate": q.counts[0], "faster_less_accurate": q.counts[1],
                "faster_more_accurate": q.counts[2], "slower_more_accurate": q.counts[3], "ties": q.counts[4],
                "time_sign_p": q.time_sign_p(), "accuracy_sign_p": q.accuracy_sign_p(),
            })
        })
        .collect()
}

/// The quadrant counts as a table.
fn quadrant_table(name: &str, quadrants: &[Quadrant]) -> Table {
    Table {
        name: name.into(),
        columns: columns(&[
            "condition",
            "id_bits",
            "slower_less_accurate",
            "faster_less_accurate",
            "faster_more_accurate",
            "slower_more_accurate",
            "ties",
            "time_sign_p",
            "accuracy_sign_p",
        ]),
        rows: quadrants
            .iter()
            .map(|q| {
                let mut r = vec![text(q.condition.clone()), opt(q.id_bits)];
                r.extend(q.counts.iter().map(|&n| num(f64::from(n))));
                r.extend([opt(q.time_sign_p()), opt(q.accuracy_sign_p())]);
                r
            })
            .collect(),
    }
}

/// Analyses the Fitts rows.
///
/// # Errors
/// A value that is not a number.
pub fn analyze(rows: &Rows) -> Result<Fitts, Problem> {
    let tests = tests(rows)?;
    let mut notes = Vec::new();
    if let Some(note) = aborted_note(&rows.aborted())? {
        notes.push(note);
    }
    let mut conditions = sorted_unique(tests.iter().map(|t| t.condition.clone()).collect());
    if let Some(i) = conditions.iter().position(|c| c == "baseline") {
        let b = conditions.remove(i);
        conditions.insert(0, b);
    }
    let ids = sorted_unique(tests.iter().map(|t| t.id_bits).collect());
    let participants = sorted_unique(tests.iter().map(|t| t.participant.clone()).collect());
    let has_baseline = conditions.first().map(String::as_str) == Some("baseline");
    let quadrants_on = |accuracy: fn(&Test) -> Option<f64>| {
        if has_baseline {
            quadrants(&tests, &conditions, &ids, &participants, accuracy)
        } else {
            Vec::new()
        }
    };
    let quadrants = quadrants_on(|t| t.error_magnitude_m);
    let by_count = quadrants_on(|t| Some(t.errors));
    if !has_baseline && !tests.is_empty() {
        notes.push("fitts.quadrants: n/a: no 'baseline' condition to compare against".to_owned());
    }

    let Regressions {
        regression,
        mt_by_id,
        throughput,
        rows: reg_rows,
    } = regressions(&tests, &conditions, &ids, &mut notes);

    let summary = json!({
        "quadrants": quadrant_json(&quadrants),
        "quadrants_error_count": quadrant_json(&by_count),
        "regression": regression,
        "throughput_bits_per_s": throughput,
        "participants": participants.len(),
        "tests": tests.len(),
    });
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
                "error_magnitude_m",
            ]),
            rows: means_rows(&tests),
        },
        quadrant_table("fitts_quadrants", &quadrants),
        quadrant_table("fitts_quadrants_error_count", &by_count),
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

/// What power counts: each quadrant count's sign tests.
pub fn counted(s: &Value, out: &mut KindCounted<'_>) {
    for (list, tests) in [
        ("quadrants", &["time_sign_p", "accuracy_sign_p"][..]),
        ("quadrants_error_count", &["accuracy_sign_p"][..]),
    ] {
        for q in s[list].as_array().into_iter().flatten() {
            for t in tests {
                out.test(
                    &format!(
                        "{list}[condition={},id_bits={}].{t}",
                        q["condition"].as_str().unwrap_or("?"),
                        counted::key(&q["id_bits"])
                    ),
                    &q[*t],
                );
            }
        }
    }
}
