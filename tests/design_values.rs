//! Issue 42: the data CSV holds the design's values. Every shipped protocol
//! is replayed with simulated participants; in its data CSV
//! - each design column has exactly as many distinct values as the protocol
//!   has levels of it, so grouping by it in pandas or R gives the design's
//!   groups (before, `delta_mu` of three levels held nine values such as
//!   `0.09999999999999998` and `0.10000000000000003`);
//! - a value derived from the design's values (`delta_mu = mu_s - mu_k`,
//!   `W' = W - D`, a comparison `level (1 + x)`) is the nearest double to
//!   the exact decimal result, computed here independently of frictionlab
//!   (integers, from the numbers' text);
//! - every time (a response time, a Fitts test's taps and clicks) is a
//!   whole number of the session's ticks (200 us), written as its decimal.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    reason = "a failed unwrap is a failed test"
)]

use crate::common;

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};
use std::process::Command;

use serde_json::Value;

/// An exact decimal: `mantissa 10^exponent`, normalised (no trailing zero
/// in the mantissa), from a number's text.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
struct Dec {
    mantissa: i128,
    exponent: i32,
}

impl Dec {
    fn parse(text: &str) -> Dec {
        let text = text.trim();
        let (digits, exp) = match text.find(['e', 'E']) {
            Some(i) => (&text[..i], text[i + 1..].parse::<i32>().unwrap()),
            None => (text, 0),
        };
        let (int, frac) = digits.split_once('.').unwrap_or((digits, ""));
        let mantissa: i128 = format!("{int}{frac}").parse().unwrap();
        Dec {
            mantissa,
            exponent: exp - i32::try_from(frac.len()).unwrap(),
        }
        .normal()
    }

    fn of(x: f64) -> Dec {
        Dec::parse(&format!("{x:e}"))
    }

    fn normal(mut self) -> Dec {
        if self.mantissa == 0 {
            return Dec {
                mantissa: 0,
                exponent: 0,
            };
        }
        while self.mantissa % 10 == 0 {
            self.mantissa /= 10;
            self.exponent += 1;
        }
        self
    }

    fn aligned(a: Dec, b: Dec) -> (i128, i128, i32) {
        let e = a.exponent.min(b.exponent);
        let scale = |d: Dec| d.mantissa * 10_i128.pow(u32::try_from(d.exponent - e).unwrap());
        (scale(a), scale(b), e)
    }

    fn sub(self, b: Dec) -> Dec {
        let (x, y, e) = Dec::aligned(self, b);
        Dec {
            mantissa: x - y,
            exponent: e,
        }
        .normal()
    }

    fn add(self, b: Dec) -> Dec {
        let (x, y, e) = Dec::aligned(self, b);
        Dec {
            mantissa: x + y,
            exponent: e,
        }
        .normal()
    }

    fn mul(self, b: Dec) -> Dec {
        Dec {
            mantissa: self.mantissa * b.mantissa,
            exponent: self.exponent + b.exponent,
        }
        .normal()
    }

    /// The ratio `self / b` as a reduced fraction.
    fn ratio(self, b: Dec) -> (i128, i128) {
        let (x, y, _) = Dec::aligned(self, b);
        let g = gcd(x.abs(), y.abs());
        (x / g, y / g)
    }

    /// The nearest double (Rust's parser rounds correctly).
    fn double(self) -> f64 {
        format!("{}e{}", self.mantissa, self.exponent)
            .parse()
            .unwrap()
    }
}

fn gcd(a: i128, b: i128) -> i128 {
    if b == 0 { a } else { gcd(b, a % b) }
}

/// A data CSV: its header and rows (no shipped protocol's cells hold a
/// comma inside quotes in the columns read here).
struct Csv {
    columns: Vec<String>,
    rows: Vec<Vec<String>>,
}

impl Csv {
    fn read(path: &Path) -> Csv {
        let text = std::fs::read_to_string(path).unwrap();
        let mut lines = text.lines();
        let columns = lines
            .next()
            .unwrap()
            .split(',')
            .map(str::to_owned)
            .collect();
        let rows = lines
            .map(|l| l.split(',').map(str::to_owned).collect())
            .collect();
        Csv { columns, rows }
    }

    fn column(&self, name: &str) -> Vec<&str> {
        let i = self
            .columns
            .iter()
            .position(|c| c == name)
            .unwrap_or_else(|| panic!("no column {name}"));
        self.rows.iter().map(|r| r[i].as_str()).collect()
    }

    fn distinct(&self, name: &str) -> BTreeSet<&str> {
        self.column(name).into_iter().collect()
    }
}

/// Replays `protocol` with two simulated participants; their data CSVs,
/// concatenated.
fn replay(protocol: &Path, out: &Path) -> Csv {
    let o = Command::new(env!("CARGO_BIN_EXE_frictionlab"))
        .args(["simulate", protocol.to_str().unwrap()])
        .args(["--participants", "2", "--seed", "42", "--out"])
        .arg(out)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let mut files: Vec<PathBuf> = std::fs::read_dir(out.join("data"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    files.sort();
    let mut all = Csv::read(&files[0]);
    for f in &files[1..] {
        all.rows.extend(Csv::read(f).rows);
    }
    all
}

/// Every time is a whole number of 200 us ticks, written as its decimal.
fn assert_whole_ticks(what: &str, cells: &[&str]) {
    for cell in cells
        .iter()
        .flat_map(|c| c.split(';'))
        .filter(|c| !c.is_empty())
    {
        let s: f64 = cell.parse().unwrap();
        let ns = Dec::parse(cell).mul(Dec::parse("1e9"));
        assert!(
            ns.exponent >= 0,
            "{what}: {cell} is not a whole number of ns"
        );
        let ns = ns.mantissa * 10_i128.pow(u32::try_from(ns.exponent).unwrap());
        assert_eq!(
            ns % 200_000,
            0,
            "{what}: {cell} s is not a whole number of ticks"
        );
        #[expect(clippy::cast_precision_loss, reason = "below 2^53")]
        let exact = ns as f64 / 1e9;
        assert_eq!(s, exact, "{what}: {cell}");
    }
}

/// The design values of a JSON list under `key` of each item, as decimals.
fn decimals<'a>(items: impl Iterator<Item = &'a Value>, key: &str) -> Vec<Dec> {
    items
        .map(|v| Dec::parse(&v[key].as_number().unwrap().to_string()))
        .collect()
}

fn check_magnitude(design: &Value, csv: &Csv) {
    let sets = design["sets"].as_array().unwrap();
    let stimuli: Vec<&Value> = sets
        .iter()
        .flat_map(|s| s["stimuli"].as_array().unwrap())
        .collect();
    let mu_s = decimals(stimuli.iter().copied(), "mu_s");
    let mu_k = decimals(stimuli.iter().copied(), "mu_k");
    let deltas: BTreeSet<Dec> = mu_s.iter().zip(&mu_k).map(|(s, k)| s.sub(*k)).collect();
    let levels = |v: &[Dec]| v.iter().collect::<BTreeSet<_>>().len();
    assert_eq!(csv.distinct("display").len(), sets.len(), "display");
    assert_eq!(csv.distinct("mu_s").len(), levels(&mu_s), "mu_s");
    assert_eq!(csv.distinct("mu_k").len(), levels(&mu_k), "mu_k");
    assert_eq!(
        csv.distinct("delta_mu").len(),
        deltas.len(),
        "delta_mu: {:?}",
        csv.distinct("delta_mu")
    );
    for ((s, k), d) in csv
        .column("mu_s")
        .iter()
        .zip(csv.column("mu_k"))
        .zip(csv.column("delta_mu"))
    {
        let exact = Dec::parse(s).sub(Dec::parse(k));
        assert_eq!(d.parse::<f64>().unwrap(), exact.double(), "{s} - {k} = {d}");
    }
    assert_whole_ticks("response_time_s", &csv.column("response_time_s"));
}

fn check_fitts(design: &Value, csv: &Csv) {
    let levels = design["levels"].as_array().unwrap();
    let a = decimals(levels.iter(), "amplitude_m");
    let w = decimals(levels.iter(), "width_m");
    let cursor = Dec::parse(&design["cursor_m"].to_string());
    let minus_cursor = design["tolerance"].as_str() != Some("width");
    let w_eff: Vec<Dec> = w
        .iter()
        .map(|w| if minus_cursor { w.sub(cursor) } else { *w })
        .collect();
    let ratios: BTreeSet<(i128, i128)> = a.iter().zip(&w_eff).map(|(a, w)| a.ratio(*w)).collect();
    let count = |v: &[Dec]| v.iter().collect::<BTreeSet<_>>().len();
    let conditions: BTreeSet<&str> = csv.column("condition").into_iter().collect();
    assert_eq!(
        conditions.len(),
        design["conditions"].as_array().unwrap().len(),
        "condition"
    );
    assert_eq!(csv.distinct("amplitude_m").len(), count(&a), "amplitude_m");
    assert_eq!(csv.distinct("width_m").len(), count(&w), "width_m");
    assert_eq!(csv.distinct("cursor_m").len(), 1, "cursor_m");
    assert_eq!(
        csv.distinct("effective_width_m").len(),
        count(&w_eff),
        "effective_width_m: {:?}",
        csv.distinct("effective_width_m")
    );
    assert_eq!(
        csv.distinct("id_bits").len(),
        ratios.len(),
        "id_bits: {:?}",
        csv.distinct("id_bits")
    );
    for (w, we) in csv
        .column("width_m")
        .iter()
        .zip(csv.column("effective_width_m"))
    {
        let exact = if minus_cursor {
            Dec::parse(w).sub(cursor)
        } else {
            Dec::parse(w)
        };
        assert_eq!(we.parse::<f64>().unwrap(), exact.double(), "{w} - D = {we}");
    }
    for column in ["completion_time_s", "tap_times_s", "click_times_s"] {
        assert_whole_ticks(column, &csv.column(column));
    }
}

fn check_paired(design: &Value, csv: &Csv) {
    let named: BTreeSet<&str> = design["pairs"]
        .as_array()
        .unwrap()
        .iter()
        .flat_map(|p| p.as_array().unwrap())
        .map(|c| c.as_str().unwrap())
        .collect();
    let presented: BTreeSet<&str> = csv
        .column("first")
        .into_iter()
        .chain(csv.column("second"))
        .collect();
    assert_eq!(presented, named, "first and second");
}

fn check_discrimination(design: &Value, csv: &Csv) {
    let levels = design["levels"].as_array().unwrap().len();
    assert_eq!(csv.distinct("level").len(), levels, "level");
    assert_eq!(csv.distinct("track").len(), levels, "track");
    let ratio = design["comparison"].as_str() == Some("ratio");
    let mut per_pair: BTreeMap<(&str, &str), BTreeSet<&str>> = BTreeMap::new();
    for ((l, x), c) in csv
        .column("level")
        .iter()
        .zip(csv.column("difference"))
        .zip(csv.column("comparison_value"))
    {
        let (level, difference) = (Dec::parse(l), Dec::parse(x));
        let exact = if ratio {
            level.mul(Dec::parse("1").add(difference))
        } else {
            level.add(difference)
        };
        assert_eq!(
            c.parse::<f64>().unwrap(),
            exact.double(),
            "{l} and {x}: {c}"
        );
        per_pair.entry((l, x)).or_default().insert(c);
    }
    assert!(per_pair.values().all(|c| c.len() == 1));
}

#[test]
fn every_design_column_has_as_many_values_as_the_design_has_levels_issue_42() {
    let tmp = tempfile::tempdir().unwrap();
    let protocols = common::shipped_protocols();
    let mut kinds = BTreeSet::new();
    for p in &protocols {
        let name = p.file_stem().unwrap().to_string_lossy().into_owned();
        let protocol: Value = serde_json::from_str(&std::fs::read_to_string(p).unwrap()).unwrap();
        let design = &protocol["design"];
        let csv = replay(p, &tmp.path().join(&name));
        let kind = design["kind"].as_str().unwrap();
        match kind {
            "magnitude_estimation" => check_magnitude(design, &csv),
            "fitts" => check_fitts(design, &csv),
            "paired_comparison" => check_paired(design, &csv),
            "discrimination" => check_discrimination(design, &csv),
            other => panic!("{name}: a kind this test does not know: {other}"),
        }
        kinds.insert(kind.to_owned());
    }
    assert_eq!(kinds.len(), 4, "every shipped kind checked: {kinds:?}");
}

#[test]
fn the_test_arithmetic_is_exact() {
    assert_eq!(Dec::parse("0.4").sub(Dec::parse("0.3")).double(), 0.1);
    assert_eq!(Dec::of(0.024).ratio(Dec::parse("0.001")), (24, 1));
    assert_eq!(
        Dec::parse("0.7").mul(Dec::parse("1.15")),
        Dec::parse("0.805")
    );
    assert_eq!(Dec::parse("2.5e-1"), Dec::parse("0.25"));
}
