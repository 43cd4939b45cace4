//! The validation table: the simulated participant against human
//! experiments it was not built from (`frictionlab validation`, issue 35).
//!
//! Each protocol in `<dir>/validation/` carries `validation` rows
//! ([`crate::protocol::validation`]): the published result, the statistic
//! and the band, written before anything was run. For each protocol the
//! command replays the rows' simulated participants through the ordinary
//! engine and analysis (in memory, as `power` does), reads each
//! participant's value of the row's statistic from the summary, and judges
//! the mean against the band: "inside" when the mean is within it (ends
//! included), "outside" otherwise. The mean comes with its 95% t interval
//! over participants.
//!
//! # The sweep
//! Each row is replayed again with every range of the population
//! ([`Population`]) that spans more than one value pinned at its low end,
//! then at its high end (the other
//! constants at their defaults), and with the break-away weight at the ends
//! of its domain (0 and 1). The table gives the smallest and the largest
//! mean over these points and the constant whose two ends move the mean
//! most. The same participants' seeds are used at every point (common
//! random numbers), so differences are the constant's.
//!
//! # Calibration and validation
//! A row whose role is `calibration` measures an input of the participant
//! (the force Weber fraction): it checks the plumbing, and no constant may
//! be set from a validation row (ARCHITECTURE.md, "The simulated
//! participant").
//!
//! # Outputs
//! `<dir>/validation.md` (generated, never edited) and
//! `<dir>/validation.json` (the same numbers, for the sync test).

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};
use serde_json::Value;

use crate::analysis::stats::one_sample_t;
use crate::analysis::{Scope, Tables, analyze_tables};
use crate::kinds::{Protocol, ReadLog, Registry};
use crate::participant::Population;
use crate::problem::Problem;
use crate::protocol::validation::{Role, Validation, steps};
use crate::session::{Simulation, simulate_in_memory};

/// Scalar free constants swept at the ends of their domain (the ranges are
/// found in [`Population`] itself): the break-away weight `w` of the
/// friction percept, in [0, 1].
const SCALARS: [(&str, [f64; 2]); 1] = [("breakaway_weight", [0.0, 1.0])];

/// A point of the sweep: a constant and the value it is pinned at.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Point {
    /// The population field.
    pub constant: String,
    /// `low` or `high`.
    pub end: String,
    /// The value it was pinned at.
    pub value: f64,
    /// The row's mean there (`None`: no participant had a value).
    pub mean: Option<f64>,
}

/// A row's outcome.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Row {
    /// The protocol file's name.
    pub file: String,
    /// The row as written in the protocol.
    pub validation: Validation,
    /// Participants with a value.
    pub n: usize,
    /// Their mean.
    pub mean: Option<f64>,
    /// Its 95% t interval.
    pub ci: Option<[f64; 2]>,
    /// Each participant's value, in participant order.
    pub values: Vec<(String, f64)>,
    /// `inside` or `outside` (the mean against the band), or `no result`.
    pub verdict: String,
    /// The sweep (empty when not run).
    pub sweep: Vec<Point>,
}

/// How a run goes: which rows, which points.
#[derive(Debug, Clone, Copy)]
pub struct Options {
    /// Run the sweep.
    pub sweep: bool,
    /// Worker threads.
    pub jobs: usize,
}

/// The protocol files of `<dir>/validation/`, sorted by name.
///
/// # Errors
/// An unreadable folder.
pub fn protocol_files(dir: &Path) -> Result<Vec<PathBuf>, Problem> {
    let folder = dir.join("validation");
    let read = std::fs::read_dir(&folder)
        .map_err(|e| Problem::new(folder.display().to_string(), format!("cannot read: {e}")))?;
    let mut files: Vec<PathBuf> = read
        .filter_map(Result::ok)
        .map(|e| e.path())
        .filter(|p| p.extension().is_some_and(|x| x == "json"))
        .collect();
    files.sort();
    Ok(files)
}

/// The population at each sweep point, as (constant, end, value, population).
#[must_use]
pub fn sweep_points() -> Vec<(String, &'static str, f64, Population)> {
    let base = serde_json::to_value(Population::default()).unwrap_or(Value::Null);
    let mut out = Vec::new();
    let mut pin = |key: &str, end: &'static str, value: Value, shown: f64| {
        let mut v = base.clone();
        if let Some(m) = v.as_object_mut() {
            m.insert(key.to_owned(), value);
        }
        if let Ok(p) = serde_json::from_value::<Population>(v) {
            out.push((key.to_owned(), end, shown, p));
        }
    };
    if let Some(m) = base.as_object() {
        for (key, v) in m {
            let Some([lo, hi]) = v.as_array().and_then(|a| match a.as_slice() {
                [lo, hi] => Some([lo.as_f64()?, hi.as_f64()?]),
                _ => None,
            }) else {
                continue;
            };
            if lo >= hi {
                // A single value (a cited constant): nothing to sweep.
                continue;
            }
            pin(key, "low", serde_json::json!([lo, lo]), lo);
            pin(key, "high", serde_json::json!([hi, hi]), hi);
        }
    }
    for (key, [lo, hi]) in SCALARS {
        pin(key, "low", serde_json::json!(lo), lo);
        pin(key, "high", serde_json::json!(hi), hi);
    }
    out
}

/// The objects `path` selects in `summary` (module docs of
/// [`crate::protocol::validation`]).
///
/// # Errors
/// A step that is missing, a filter on something not a list, a filter that
/// keeps no element or (before the last step) more than one, or an end
/// that is not a list of objects.
pub fn select<'a>(summary: &'a Value, path: &str) -> Result<Vec<&'a Value>, String> {
    let steps = steps(path)?;
    let mut at: Vec<&Value> = vec![summary];
    for (i, step) in steps.iter().enumerate() {
        let [one] = at.as_slice() else {
            return Err(format!(
                "'{path}': {} elements before '{}' (a filter must keep one to go on)",
                at.len(),
                step.key
            ));
        };
        let v = one
            .get(step.key)
            .ok_or_else(|| format!("'{path}': no '{}'", step.key))?;
        at = match step.filter {
            None => vec![v],
            Some((k, want)) => {
                let list = v
                    .as_array()
                    .ok_or_else(|| format!("'{path}': '{}' is not a list", step.key))?;
                let kept: Vec<&Value> = list.iter().filter(|e| matches(e.get(k), want)).collect();
                if kept.is_empty() {
                    return Err(format!(
                        "'{path}': no element of '{}' has {k} = {want}",
                        step.key
                    ));
                }
                kept
            }
        };
        if i + 1 == steps.len()
            && let [one] = at.as_slice()
            && let Some(list) = one.as_array()
        {
            at = list.iter().collect();
        }
    }
    if at.iter().all(|v| v.is_object()) {
        Ok(at)
    } else {
        Err(format!("'{path}': does not end in a list of objects"))
    }
}

fn matches(v: Option<&Value>, want: &str) -> bool {
    match (v, want.parse::<f64>()) {
        (Some(Value::Number(n)), Ok(w)) => n.as_f64() == Some(w),
        (Some(Value::String(s)), _) => s == want,
        _ => false,
    }
}

/// Each participant's value of `statistic` in `summary`, in participant
/// order; participants whose value is null (or, for a ratio, missing on
/// either side or over 0) are left out.
///
/// # Errors
/// A path that selects nothing usable ([`select`]).
pub fn values(
    summary: &Value,
    statistic: &crate::protocol::validation::Statistic,
) -> Result<Vec<(String, f64)>, String> {
    let read = |path: &str| -> Result<Vec<(String, f64)>, String> {
        Ok(select(summary, path)?
            .into_iter()
            .filter_map(|o| {
                let p = o.get("participant")?.as_str()?.to_owned();
                Some((p, o.get(&statistic.field)?.as_f64()?))
            })
            .collect())
    };
    let mut top = read(&statistic.values)?;
    if let Some(over) = &statistic.over {
        let below = read(over)?;
        top = top
            .into_iter()
            .filter_map(|(p, x)| {
                let y = below.iter().find(|(q, _)| *q == p)?.1;
                (y != 0.0).then(|| (p, x / y))
            })
            .collect();
    }
    top.sort_by(|a, b| a.0.cmp(&b.0));
    Ok(top)
}

/// Replays `participants` simulated participants of `protocol` with
/// `population` and returns the analysis summary.
fn replay(
    protocol: &Protocol,
    bytes: &[u8],
    participants: u32,
    seed: u64,
    population: Option<&Population>,
) -> Result<Value, Problem> {
    let sim = Simulation {
        protocol,
        protocol_bytes: bytes,
        participants,
        seed,
        pace: None,
        streams: false,
        population,
        jobs: 1,
        stop: None,
        lsl: None,
    };
    let logs = (0..participants)
        .map(|i| simulate_in_memory(&sim, i))
        .collect::<Result<Vec<_>, _>>()
        .map_err(|e| Problem::new(format!("{}: replay", protocol.id), e.to_string()))?;
    let study: Vec<&ReadLog> = logs.iter().collect();
    let folder = PathBuf::from(format!("validation-{}", protocol.id));
    let tables = Tables::from_logs(&folder, &study)?;
    Ok(analyze_tables::<Registry>(&tables, Scope::Counted)?.summary)
}

/// The mean of the row's values at one replay, and the values.
fn row_values(
    file: &str,
    summary: &Value,
    v: &Validation,
    i: usize,
) -> Result<Vec<(String, f64)>, Problem> {
    values(summary, &v.statistic)
        .map_err(|e| Problem::new(format!("{file}: validation[{i}].statistic"), e))
}

/// A validation protocol: its file name, its path as shown in errors, the
/// protocol, its bytes.
type Loaded = (String, String, Protocol, Vec<u8>);

/// The protocols of `<dir>/validation/`.
fn load_all(dir: &Path) -> Result<Vec<Loaded>, Vec<Problem>> {
    let files = protocol_files(dir).map_err(|e| vec![e])?;
    let mut protocols = Vec::new();
    for path in &files {
        let (p, bytes) = crate::protocol::load::read::<Registry>(path)?;
        let name = path
            .file_name()
            .map_or_else(String::new, |n| n.to_string_lossy().into_owned());
        if p.validation.is_empty() {
            return Err(vec![Problem::new(
                format!("{}: $.validation", path.display()),
                "no validation rows: a protocol in the validation folder must say what it is judged by",
            )]);
        }
        protocols.push((name, path.display().to_string(), p, bytes));
    }
    Ok(protocols)
}

/// The verdict of a mean against a band: `inside` when within it (ends
/// included), `outside` otherwise, `no result` without a mean.
#[must_use]
pub fn verdict(mean: Option<f64>, [lo, hi]: [f64; 2]) -> &'static str {
    match mean {
        Some(m) if (lo..=hi).contains(&m) => "inside",
        Some(_) => "outside",
        None => "no result",
    }
}

/// Runs every row of every protocol in `<dir>/validation/`.
/// `progress(done, total)` is called after each replay.
///
/// # Errors
/// An unreadable or invalid protocol, a failed replay, or a statistic's
/// path that selects nothing, each named by file and place.
pub fn run(
    dir: &Path,
    options: Options,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Result<Vec<Row>, Vec<Problem>> {
    let protocols = load_all(dir)?;
    let points = if options.sweep {
        sweep_points()
    } else {
        Vec::new()
    };
    // One replay per protocol, row sample (participants, seed) and point.
    let mut work: Vec<(usize, u32, u64, Option<usize>)> = Vec::new();
    for (pi, (_, _, p, _)) in protocols.iter().enumerate() {
        let mut samples: Vec<(u32, u64)> = p
            .validation
            .iter()
            .map(|v| (v.participants, v.seed))
            .collect();
        samples.dedup();
        for (n, seed) in samples {
            work.push((pi, n, seed, None));
            work.extend((0..points.len()).map(|k| (pi, n, seed, Some(k))));
        }
    }
    let done = std::sync::atomic::AtomicUsize::new(0);
    let summaries = crate::parallel::run(&work, options.jobs, |&(pi, n, seed, point)| {
        let (_, _, p, bytes) = &protocols[pi];
        let population = point.map(|k| &points[k].3);
        let s = replay(p, bytes, n, seed, population);
        progress(
            done.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1,
            work.len(),
        );
        s
    });
    let summaries: Vec<Value> = summaries
        .into_iter()
        .collect::<Result<_, _>>()
        .map_err(|e| vec![e])?;
    let find = |pi: usize, n: u32, seed: u64, point: Option<usize>| {
        work.iter()
            .position(|w| *w == (pi, n, seed, point))
            .map(|i| &summaries[i])
    };
    let mut rows = Vec::new();
    let mut problems = Vec::new();
    for (pi, (file, shown, p, _)) in protocols.iter().enumerate() {
        for (i, v) in p.validation.iter().enumerate() {
            let Some(main) = find(pi, v.participants, v.seed, None) else {
                continue;
            };
            let vals = match row_values(shown, main, v, i) {
                Ok(x) => x,
                Err(e) => {
                    problems.push(e);
                    continue;
                }
            };
            let xs: Vec<f64> = vals.iter().map(|x| x.1).collect();
            let t = one_sample_t(&xs);
            let mean = crate::analysis::stats::mean(&xs);
            let verdict = verdict(mean, v.band);
            let mut sweep = Vec::new();
            for (k, (constant, end, value, _)) in points.iter().enumerate() {
                let Some(s) = find(pi, v.participants, v.seed, Some(k)) else {
                    continue;
                };
                let m = row_values(shown, s, v, i).ok().and_then(|vals| {
                    crate::analysis::stats::mean(&vals.iter().map(|x| x.1).collect::<Vec<_>>())
                });
                sweep.push(Point {
                    constant: constant.clone(),
                    end: (*end).to_owned(),
                    value: *value,
                    mean: m,
                });
            }
            rows.push(Row {
                file: file.clone(),
                validation: v.clone(),
                n: xs.len(),
                mean,
                ci: t.map(|t| [t.ci_low, t.ci_high]),
                values: vals,
                verdict: verdict.to_owned(),
                sweep,
            });
        }
    }
    if problems.is_empty() {
        Ok(rows)
    } else {
        Err(problems)
    }
}

/// The sweep's smallest and largest mean, each with its point, and the
/// constant whose ends differ most (with that difference).
#[must_use]
pub fn sweep_extremes(row: &Row) -> Option<(&Point, &Point, (&str, f64))> {
    let with: Vec<(&Point, f64)> = row
        .sweep
        .iter()
        .filter_map(|p| Some((p, p.mean?)))
        .collect();
    let min = with.iter().min_by(|a, b| a.1.total_cmp(&b.1))?.0;
    let max = with.iter().max_by(|a, b| a.1.total_cmp(&b.1))?.0;
    let mut most: Option<(&str, f64)> = None;
    for (p, m) in &with {
        if p.end != "low" {
            continue;
        }
        let Some((_, h)) = with
            .iter()
            .find(|(q, _)| q.constant == p.constant && q.end == "high")
        else {
            continue;
        };
        let d = h - m;
        if most.is_none_or(|(_, b)| d.abs() > b.abs()) {
            most = Some((&p.constant, d));
        }
    }
    Some((min, max, most?))
}

fn num(x: f64) -> String {
    let a = x.abs();
    if a != 0.0 && !(0.01..10_000.0).contains(&a) {
        format!("{x:.3e}")
    } else {
        format!("{x:.3}")
    }
}

fn opt(x: Option<f64>) -> String {
    x.map_or_else(|| "n/a".to_owned(), num)
}

fn cell(s: &str) -> String {
    s.replace('|', "\\|").replace('\n', " ")
}

/// `validation.md` for `rows`.
#[must_use]
pub fn table(rows: &[Row]) -> String {
    let mut out = String::new();
    let w = &mut out;
    let _ = writeln!(w, "# The simulated participant against human experiments\n");
    let _ = writeln!(
        w,
        "Generated by `frictionlab validation` from the protocols in `validation/` (`bash analysis/reproduce.sh`); do not edit. Each row's band was written in its protocol file, and committed, before the replay was run. A row is **inside** when the simulated mean lies within its band. The interval is the 95% t interval of the mean over simulated participants. **Calibration** rows measure an input of the participant, so they check the plumbing and validate nothing.\n"
    );
    let _ = writeln!(
        w,
        "| experiment | role | published (spread; participants; source) | band | simulated: mean [95% CI] (n) | verdict | sweep: smallest to largest | moved most by |"
    );
    let _ = writeln!(w, "|---|---|---|---|---|---|---|---|");
    for r in rows {
        let v = &r.validation;
        let unit = if v.statistic.unit.is_empty() {
            String::new()
        } else {
            format!(" {}", v.statistic.unit)
        };
        let ci =
            r.ci.map_or_else(String::new, |[a, b]| format!(" [{}, {}]", num(a), num(b)));
        let (range, most) = match sweep_extremes(r) {
            Some((lo, hi, (c, d))) => (
                format!(
                    "{} (`{}` {} = {}) to {} (`{}` {} = {})",
                    opt(lo.mean),
                    lo.constant,
                    lo.end,
                    num(lo.value),
                    opt(hi.mean),
                    hi.constant,
                    hi.end,
                    num(hi.value)
                ),
                format!("`{c}` (low to high end: {d:+.3})"),
            ),
            None => ("not run".to_owned(), "-".to_owned()),
        };
        let role = match v.role {
            Role::Validation => "validation",
            Role::Calibration => "calibration",
        };
        let _ = writeln!(
            w,
            "| {} ({}: {}) | {role} | {} ({}; {}; {}) | {} to {}{unit} | {}{unit}{ci} ({}) | **{}** | {range} | {most} |",
            cell(&v.experiment),
            cell(&r.file),
            cell(&v.statistic.name),
            cell(&v.published.result),
            cell(&v.published.spread),
            cell(&v.published.participants),
            cell(&v.published.source),
            num(v.band[0]),
            num(v.band[1]),
            opt(r.mean),
            r.n,
            r.verdict,
        );
    }
    let _ = writeln!(w, "\n## Why each band\n");
    for r in rows {
        let _ = writeln!(
            w,
            "- {} ({}): {}",
            cell(&r.validation.experiment),
            r.file,
            cell(&r.validation.band_reasons)
        );
    }
    if rows.iter().any(|r| !r.sweep.is_empty()) {
        sweep_section(w, rows);
    }
    out
}

/// The sweep's table: each constant's low and high end, per row.
fn sweep_section(w: &mut String, rows: &[Row]) {
    let _ = writeln!(w, "\n## The sweep\n");
    let _ = writeln!(
        w,
        "Each row replayed with one constant of the population pinned at the low or the high end of its range (the break-away weight at 0 and 1), the rest at their defaults; the same seeds at every point. Cells: the mean at the low end / at the high end.\n"
    );
    let _ = write!(w, "| constant | low / high |");
    for r in rows {
        let _ = write!(w, " {} |", cell(&r.validation.statistic.name));
    }
    let _ = writeln!(w);
    let _ = write!(w, "|---|---|");
    for _ in rows {
        let _ = write!(w, "---|");
    }
    let _ = writeln!(w);
    let constants: Vec<(&str, f64, f64)> = rows[0]
        .sweep
        .iter()
        .filter(|p| p.end == "low")
        .filter_map(|p| {
            let hi = rows[0]
                .sweep
                .iter()
                .find(|q| q.constant == p.constant && q.end == "high")?;
            Some((p.constant.as_str(), p.value, hi.value))
        })
        .collect();
    for (c, lo, hi) in constants {
        let _ = write!(w, "| `{c}` | {} / {} |", num(lo), num(hi));
        for r in rows {
            let at = |end: &str| {
                r.sweep
                    .iter()
                    .find(|p| p.constant == c && p.end == end)
                    .and_then(|p| p.mean)
            };
            let _ = write!(w, " {} / {} |", opt(at("low")), opt(at("high")));
        }
        let _ = writeln!(w);
    }
}
