//! `frictionlab analyze` on small hand-computed fixtures (every statistic
//! agrees to 1e-9 relative), and on unusable input. The fixtures are data
//! CSVs written by hand, without session logs, so they are analysed
//! CSV-only (`--csv-only`); `tests/analysis_against_logs.rs` holds
//! simulated folders against their logs.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    reason = "a failed unwrap is a failed test"
)]

use std::path::Path;
use std::process::{Command, Output};

use frictionlab::analysis::{Analysis, Check, analyze_with, stats};
use frictionlab::kinds::Registry;
use frictionlab::problem::Problem;
use frictionlab::protocol::kind::Kinds;
use frictionlab::results::COMMON_COLUMNS;
use serde_json::Value;

/// The fixtures' analysis: CSV-only, as they have no logs.
fn analyze(dir: &Path) -> Result<Analysis, Problem> {
    analyze_with::<Registry>(dir, Check::CsvOnly)
}

fn close(actual: f64, expected: f64) -> bool {
    (actual - expected).abs() <= 1e-9 * expected.abs().max(1e-300)
}

fn assert_close(actual: &Value, expected: f64, what: &str) {
    let a = actual
        .as_f64()
        .unwrap_or_else(|| panic!("{what}: {actual} is not a number"));
    assert!(close(a, expected), "{what}: {a} vs {expected}");
}

/// Writes a data CSV of `kind` with rows given as (column, value) pairs; the
/// common columns default to a completed, non-practice trial.
fn data(dir: &Path, name: &str, kind: &str, rows: &[Vec<(&str, String)>]) {
    let mut cols: Vec<&str> = COMMON_COLUMNS.to_vec();
    cols.extend_from_slice(Registry::columns(kind).unwrap());
    let mut text = cols.join(",") + "\n";
    for (i, row) in rows.iter().enumerate() {
        let get = |c: &str| row.iter().find(|(k, _)| *k == c).map(|(_, v)| v.clone());
        let line: Vec<String> = cols
            .iter()
            .map(|c| {
                get(c).unwrap_or_else(|| match *c {
                    "study" => "fixture".into(),
                    "kind" => kind.into(),
                    "session" | "seed" => "1".into(),
                    "trial" => i.to_string(),
                    "block" => "main".into(),
                    "status" => "completed".into(),
                    "practice" => "false".into(),
                    "repetition" => "0".into(),
                    _ => String::new(),
                })
            })
            .collect();
        text += &(line.join(",") + "\n");
    }
    std::fs::create_dir_all(dir.join("data")).unwrap();
    std::fs::write(dir.join("data").join(format!("{name}_data.csv")), text).unwrap();
}

fn magnitude_row(p: &str, display: &str, mu_s: f64, m: f64) -> Vec<(&'static str, String)> {
    vec![
        ("participant", p.into()),
        ("display", display.into()),
        ("mu_s", mu_s.to_string()),
        ("mu_k", (mu_s - 0.2).to_string()),
        ("delta_mu", (mu_s - (mu_s - 0.2)).to_string()),
        ("magnitude", m.to_string()),
    ]
}

/// Participant A: tactile 1, 2, 4 and force 4, 8, 16; participant B: tactile
/// 2, 4, 8 and force 8, 32 (no answer at mu_s 0.6): unbalanced, so the two
/// normalizations differ. Plus rows that must be ignored.
fn magnitude_fixture(dir: &Path) {
    let mut rows = Vec::new();
    for (p, display, answers) in [
        ("A", "tactile", vec![1.0, 2.0, 4.0]),
        ("A", "force", vec![4.0, 8.0, 16.0]),
        ("B", "tactile", vec![2.0, 4.0, 8.0]),
        ("B", "force", vec![8.0, 32.0]),
    ] {
        for (mu_s, m) in [0.4, 0.5, 0.6].into_iter().zip(answers) {
            rows.push(magnitude_row(p, display, mu_s, m));
        }
    }
    let mut practice = magnitude_row("A", "force", 0.4, 1000.0);
    practice.push(("practice", "true".into()));
    let mut aborted = magnitude_row("B", "force", 0.6, 1.0);
    aborted.extend([("status", "aborted".into()), ("magnitude", String::new())]);
    rows.extend([practice, aborted]);
    data(
        dir,
        "study-fixture_subject-AB_session-1",
        "magnitude_estimation",
        &rows,
    );
}

#[test]
fn magnitude_statistics_match_hand_computation() {
    let dir = tempfile::tempdir().unwrap();
    magnitude_fixture(dir.path());
    let s = analyze(dir.path()).unwrap().summary;
    let m = &s["magnitude_estimation"];
    // Worked by hand in log2 units: grand mean 26/11; pooled shifts A +4/11,
    // B -24/55; per_display divides by each participant's geometric mean on
    // that display (tactile A 2^1, B 2^2; force A 2^3, B 2^4). No logs here,
    // so displays are in alphabetical order.
    let expected = [
        ("force", "pooled", 0.4, 271.0 / 110.0),
        ("force", "pooled", 0.5, 218.0 / 55.0),
        ("force", "pooled", 0.6, 48.0 / 11.0),
        ("force", "per_display", 0.4, -1.0),
        ("force", "per_display", 0.5, 0.5),
        ("force", "per_display", 0.6, 1.0),
        ("tactile", "pooled", 0.4, 51.0 / 110.0),
        ("tactile", "pooled", 0.5, 161.0 / 110.0),
        ("tactile", "pooled", 0.6, 271.0 / 110.0),
        ("tactile", "per_display", 0.4, -1.0),
        ("tactile", "per_display", 0.5, 0.0),
        ("tactile", "per_display", 0.6, 1.0),
    ];
    let gms = m["geometric_means"].as_array().unwrap();
    assert_eq!(gms.len(), expected.len());
    for (display, norm, mu_s, log2) in expected {
        let g = gms
            .iter()
            .find(|g| {
                g["display"] == display
                    && g["normalization"] == norm
                    && g["mu_s"].as_f64() == Some(mu_s)
            })
            .unwrap_or_else(|| panic!("{display} {norm} {mu_s}"));
        assert_close(
            &g["value"],
            2f64.powf(log2),
            &format!("{display} {norm} {mu_s}"),
        );
        assert_close(&g["delta_mu"], 0.2, "delta_mu");
    }
    // Displays alphabetical: force first. Ratio = 2^(mean force pooled log2 -
    // mean tactile pooled log2) = 2^(32/15).
    assert_eq!(m["displays"], serde_json::json!(["force", "tactile"]));
    assert_close(&m["display_ratio"], 2f64.powf(32.0 / 15.0), "display_ratio");
    // One delta_mu series (0.2): its ratio is the whole ratio.
    assert_eq!(m["display_ratio_by_delta_mu"].as_array().unwrap().len(), 1);
    assert_close(
        &m["display_ratio_by_delta_mu"][0]["ratio"],
        2f64.powf(32.0 / 15.0),
        "display_ratio_by_delta_mu",
    );
    // Force pooled at mu_s 0.5: A 2^(3 + 4/11), B 2^(5 - 24/55), 1.2 log2
    // units apart: SD 1.2/sqrt(2) log2 units, so gsd 2^(1.2/sqrt(2)); the CI
    // is the mean 218/55 +- t(0.975, 1 df) 1.2/2 (t = 12.706204736174705).
    let g = gms
        .iter()
        .find(|g| {
            g["display"] == "force"
                && g["normalization"] == "pooled"
                && g["mu_s"].as_f64() == Some(0.5)
        })
        .unwrap();
    assert_close(&g["gsd"], 2f64.powf(1.2 / 2f64.sqrt()), "gsd");
    let t = 12.706_204_736_174_705;
    assert_close(&g["ci_low"], 2f64.powf(218.0 / 55.0 - 0.6 * t), "ci_low");
    assert_close(&g["ci_high"], 2f64.powf(218.0 / 55.0 + 0.6 * t), "ci_high");
    // A single answer has no spread: force at mu_s 0.6 (A only).
    let single = gms
        .iter()
        .find(|g| g["display"] == "force" && g["mu_s"].as_f64() == Some(0.6))
        .unwrap();
    assert!(single["gsd"].is_null() && single["ci_low"].is_null());
    // Pearson of per_display values (force 2^-1, 2^0.5, 2^1 against tactile
    // 2^-1, 2^0, 2^1): r = 0.9505263865379904, n = 3; p from t with
    // 1 df: 2 (1/2 - atan(|t|)/pi) = 0.20108927655343978; no CI for n = 3.
    let c = &m["correlations"][0];
    assert_close(&c["r"], 0.950_526_386_537_990_4, "r");
    assert_eq!(c["n"], 3);
    assert_close(&c["p"], 0.201_089_276_553_439_78, "p");
    assert!(c["ci95_low"].is_null());
    // Trend of force per_display against mu_s: slope of (0.4, 2^-1),
    // (0.5, 2^0.5), (0.6, 2^1) = (2^1 - 2^-1) / 0.2 (x evenly spaced).
    let t = m["trends"]
        .as_array()
        .unwrap()
        .iter()
        .find(|t| {
            t["display"] == "force" && t["normalization"] == "per_display" && t["against"] == "mu_s"
        })
        .unwrap();
    assert_close(&t["slope"], (2.0 - 0.5) / 0.2, "trend slope");
    assert_eq!(
        s["inputs"]["analysed_rows"]["magnitude_estimation"], 11,
        "practice and aborted rows left out"
    );
}

#[test]
fn magnitude_drivers_separate_mu_s_from_mu_k() {
    let dir = tempfile::tempdir().unwrap();
    // One participant, one display; magnitudes per (mu_s, delta_mu).
    let grid = [
        (0.1, [1.0, 2.0, 3.0]),
        (0.2, [3.0, 1.0, 2.0]),
        (0.3, [2.0, 2.0, 5.0]),
    ];
    let mut rows = Vec::new();
    for (delta, answers) in grid {
        for (mu_s, m) in [0.4, 0.5, 0.6].into_iter().zip(answers) {
            rows.push(vec![
                ("participant", "A".to_owned()),
                ("display", "force".to_owned()),
                ("mu_s", mu_s.to_string()),
                ("mu_k", (mu_s - delta).to_string()),
                ("delta_mu", delta.to_string()),
                ("magnitude", m.to_string()),
            ]);
        }
    }
    data(
        dir.path(),
        "study-fixture_subject-A_session-1",
        "magnitude_estimation",
        &rows,
    );
    let s = analyze(dir.path()).unwrap().summary;
    let drivers = s["magnitude_estimation"]["drivers"].as_array().unwrap();
    let r = |against: &str, key: &str, at: f64| {
        drivers
            .iter()
            .find(|d| d["against"] == against && d[key].as_f64().is_some_and(|x| close(x, at)))
            .unwrap_or_else(|| panic!("{against} at {key} {at}"))["r"]
            .clone()
    };
    // Against mu_s within each series (x 0.4, 0.5, 0.6; per_display only
    // rescales, r is unchanged): y (1, 2, 3) r 1; (3, 1, 2) r -0.5;
    // (2, 2, 5) r sqrt(3)/2.
    assert_close(&r("mu_s", "delta_mu", 0.1), 1.0, "mu_s, delta_mu 0.1");
    assert_close(&r("mu_s", "delta_mu", 0.2), -0.5, "mu_s, delta_mu 0.2");
    assert_close(
        &r("mu_s", "delta_mu", 0.3),
        3f64.sqrt() / 2.0,
        "mu_s, delta_mu 0.3",
    );
    // Against mu_k at each mu_s: at 0.4, (0.3, 1), (0.2, 3), (0.1, 2): r
    // -0.5; at 0.5, (0.4, 2), (0.3, 1), (0.2, 2): r 0; at 0.6, (0.5, 3),
    // (0.4, 2), (0.3, 5): r -sqrt(3/7).
    assert_close(&r("mu_k", "mu_s", 0.4), -0.5, "mu_k at mu_s 0.4");
    assert!(r("mu_k", "mu_s", 0.5).as_f64().unwrap().abs() < 1e-9);
    assert_close(
        &r("mu_k", "mu_s", 0.6),
        -(3.0f64 / 7.0).sqrt(),
        "mu_k at mu_s 0.6",
    );
}

#[test]
fn paired_statistics_match_hand_computation() {
    let dir = tempfile::tempdir().unwrap();
    let row = |p: &str, first: &str, second: &str, choice: &str, chosen: &str| {
        vec![
            ("participant", p.into()),
            ("first", first.into()),
            ("second", second.into()),
            ("choice", choice.to_owned()),
            ("chosen", chosen.to_owned()),
        ]
    };
    let (tc, tv) = ("time_constant", "time_varying");
    let rows = vec![
        row("p1", tc, tv, "second", tv),
        row("p2", tv, tc, "first", tv),
        row("p3", tv, tc, "first", tv),
        row("p4", tc, tv, "second", tv),
        row("p5", tc, tv, "second", tv),
        row("p6", tv, tc, "no_difference", "no_difference"),
    ];
    data(
        dir.path(),
        "study-fixture_subject-all_session-1",
        "paired_comparison",
        &rows,
    );
    let p = &analyze(dir.path()).unwrap().summary["paired_comparison"];
    assert_eq!(
        p["counts"],
        serde_json::json!({"time_constant": 0, "time_varying": 5})
    );
    assert_eq!(p["no_difference"], 1);
    // 5 of 5 decisive: 2 * 0.5^5 = 0.0625.
    assert_close(&p["binomial_p"], 0.0625, "binomial_p");
    // Order: first chosen 2, second 3: 2 * P(X <= 2 | 5) = 2 * 16/32 = 1.
    assert_eq!(
        (
            p["order"]["first_chosen"].as_u64(),
            p["order"]["second_chosen"].as_u64()
        ),
        (Some(2), Some(3))
    );
    assert_close(&p["order"]["binomial_p"], 1.0, "order p");
}

fn fitts_row(p: &str, cond: &str, id: f64, t: f64, errors: u32) -> Vec<(&'static str, String)> {
    vec![
        ("participant", p.into()),
        ("condition", cond.into()),
        ("id_bits", id.to_string()),
        ("amplitude_m", "0.016".into()),
        ("width_m", "0.003".into()),
        ("completion_time_s", t.to_string()),
        ("taps", "4".into()),
        ("errors", errors.to_string()),
        (
            "mean_error_m",
            if errors > 0 {
                "0.0005".into()
            } else {
                String::new()
            },
        ),
    ]
}

#[test]
fn fitts_statistics_match_hand_computation() {
    let dir = tempfile::tempdir().unwrap();
    let mut worked = fitts_row("P1", "baseline", 2.0, 1.2, 0);
    worked.extend([
        ("tap_times_s", "10;10.4;10.8;11.2".into()),
        ("tap_x_m", "-0.0081;0.0083;-0.0078;0.008".into()),
        ("target_x_m", "-0.008;0.008;-0.008;0.008".into()),
    ]);
    let rows = vec![
        worked,
        fitts_row("P1", "baseline", 3.0, 1.8, 1),
        fitts_row("P1", "stiction", 2.0, 1.5, 1),
        fitts_row("P1", "stiction", 3.0, 2.4, 2),
        fitts_row("P2", "baseline", 2.0, 1.0, 1),
        fitts_row("P2", "baseline", 3.0, 1.6, 0),
        fitts_row("P2", "stiction", 2.0, 0.9, 1),
        fitts_row("P2", "stiction", 3.0, 1.5, 1),
    ];
    data(
        dir.path(),
        "study-fixture_subject-P_session-1",
        "fitts",
        &rows,
    );
    let f = &analyze(dir.path()).unwrap().summary["fitts"];
    // Error-count quadrants (time change, error change) against own baseline:
    // ID 2: P1 (+0.3, +1) slower/less accurate; P2 (-0.1, 0) tie.
    // ID 3: P1 (+0.6, +1) slower/less; P2 (-0.1, +1) faster/less.
    // Pooled: P1 (+0.45, +1); P2 (-0.1, +0.5).
    let q = |id: Value| {
        f["quadrants_error_count"]
            .as_array()
            .unwrap()
            .iter()
            .find(|q| q["id_bits"] == id)
            .unwrap()
            .clone()
    };
    let counts = |q: Value| {
        [
            "slower_less_accurate",
            "faster_less_accurate",
            "faster_more_accurate",
            "slower_more_accurate",
            "ties",
        ]
        .map(|k| q[k].as_u64().unwrap())
    };
    assert_eq!(counts(q(serde_json::json!(2.0))), [1, 0, 0, 0, 1]);
    assert_eq!(counts(q(serde_json::json!(3.0))), [1, 1, 0, 0, 0]);
    assert_eq!(counts(q(Value::Null)), [1, 1, 0, 0, 0]);
    // Sign tests against an even split, two-sided exact: ID 2, time: P1
    // slower, P2 faster (p = 1); errors: P1 more, P2 unchanged and left
    // out (0 of 1 fewer: p = min(1, 2 * 0.5) = 1). ID 3, errors: both
    // more (0 of 2 fewer: p = 2 * 0.25 = 0.5).
    assert_close(&q(serde_json::json!(2.0))["time_sign_p"], 1.0, "time p");
    assert_close(
        &q(serde_json::json!(2.0))["accuracy_sign_p"],
        1.0,
        "accuracy p",
    );
    assert_close(
        &q(serde_json::json!(3.0))["accuracy_sign_p"],
        0.5,
        "accuracy p",
    );
    // Baseline MT per movement = t / 3: (2, 2/5), (3, 3/5), (2, 1/3), (3, 8/15):
    // slope 1/5, intercept -1/30, r^2 9/10.
    let reg = f["regression"]
        .as_array()
        .unwrap()
        .iter()
        .find(|r| r["condition"] == "baseline")
        .unwrap();
    assert_close(&reg["slope_s_per_bit"], 0.2, "slope");
    assert_close(&reg["intercept_s"], -1.0 / 30.0, "intercept");
    assert_close(&reg["r2"], 0.9, "r2");
    // Worked ISO 9241-9 example: amplitudes 0.0164, 0.0161, 0.0158 (Ae
    // 0.0161); deviations along each movement 0.0003, -0.0002, 0 (SD
    // 2.5166114784235856e-4); We = 4.133 SD = 1.040115524032468e-3;
    // IDe = log2(Ae/We + 1) = 4.042561152919676; MT = 1.2/3 = 0.4 s.
    assert_close(
        &f["throughput_bits_per_s"]["baseline"],
        4.042_561_152_919_676 / 0.4,
        "throughput",
    );
    assert!(
        f["throughput_bits_per_s"]["stiction"].is_null(),
        "no tap endpoints, no throughput"
    );
    let direct = stats::effective_throughput(
        &[0.0, 0.5, 1.0, 1.5],
        &[-0.0081, 0.0083, -0.0078, 0.008],
        &[-0.008, 0.008, -0.008, 0.008],
        &[true; 4],
    );
    assert!(close(direct.unwrap(), 8.085_122_305_839_352));
}

/// One click: (time s, x m, lit target m, hit).
type Click = (f64, f64, f64, bool);

/// A Fitts row with every click logged.
fn clicks_row(
    p: &str,
    cond: &str,
    completion: f64,
    clicks: &[Click],
) -> Vec<(&'static str, String)> {
    let join = |f: &dyn Fn(&Click) -> String| clicks.iter().map(f).collect::<Vec<_>>().join(";");
    let errors = clicks.iter().filter(|c| !c.3).count();
    let mut row = fitts_row(p, cond, 2.0, completion, u32::try_from(errors).unwrap());
    row.extend([
        ("click_times_s", join(&|c| c.0.to_string())),
        ("click_x_m", join(&|c| c.1.to_string())),
        ("click_target_x_m", join(&|c| c.2.to_string())),
        ("click_hit", join(&|c| c.3.to_string())),
    ]);
    row
}

#[test]
fn fitts_accuracy_and_throughput_use_every_click_and_aborted_tests_are_counted() {
    let dir = tempfile::tempdir().unwrap();
    // Targets at -0.05 and +0.05 m. Sequence A misses once (overshoot) and
    // corrects; sequence B hits 2 mm short each time.
    let a = [
        (0.0, -0.051, -0.05, true),
        (1.0, 0.062, 0.05, false),
        (1.4, 0.049, 0.05, true),
        (2.4, -0.047, -0.05, true),
        (3.5, 0.053, 0.05, true),
    ];
    let b = [
        (0.0, -0.052, -0.05, true),
        (1.0, 0.048, 0.05, true),
        (2.0, -0.052, -0.05, true),
        (3.0, 0.048, 0.05, true),
    ];
    let exact = [
        (0.0, -0.05, -0.05, true),
        (1.0, 0.05, 0.05, true),
        (2.0, -0.05, -0.05, true),
        (3.0, 0.05, 0.05, true),
    ];
    let off_by_1mm = [
        (0.0, -0.049, -0.05, true),
        (1.0, 0.051, 0.05, true),
        (2.0, -0.049, -0.05, true),
        (3.0, 0.051, 0.05, true),
    ];
    let mut aborted = clicks_row("P2", "stiction", 60.0, &b[..2]);
    aborted.push(("status", "aborted".into()));
    let rows = vec![
        clicks_row("P1", "baseline", 3.5, &a),
        clicks_row("P1", "baseline", 3.0, &b),
        clicks_row("P2", "baseline", 3.0, &b),
        clicks_row("P1", "stiction", 3.0, &exact),
        clicks_row("P2", "stiction", 4.0, &off_by_1mm),
        aborted,
    ];
    data(
        dir.path(),
        "study-fixture_subject-P_session-1",
        "fitts",
        &rows,
    );
    let analysis = analyze(dir.path()).unwrap();
    let f = &analysis.summary["fitts"];
    // Throughput of A: deviations after the first hit 0.012, -0.001,
    // -0.003, 0.003 (squared residuals 1.3275e-4 over 3); hit to hit
    // 0.100, 0.096, 0.100 m in 3.5 s. Of B: deviations -0.002, 0.002,
    // -0.002 (squared residuals 1.0666...e-5 over 2), 0.1 m each, MT 1 s.
    let tp_a = (0.296 / 3.0 / (4.133 * (1.3275e-4_f64 / 3.0).sqrt()) + 1.0).log2() / (3.5 / 3.0);
    let tp_b = (0.1 / (4.133 * (3.2e-5_f64 / 3.0 / 2.0).sqrt()) + 1.0).log2();
    // The mean of each participant's sequences, then of participants.
    assert_close(
        &f["throughput_bits_per_s"]["baseline"],
        f64::midpoint(f64::midpoint(tp_a, tp_b), tp_b),
        "throughput",
    );
    let pooled = |key: &str| {
        let q = f[key]
            .as_array()
            .unwrap()
            .iter()
            .find(|q| q["condition"] == "stiction" && q["id_bits"].is_null())
            .unwrap()
            .clone();
        [
            "slower_less_accurate",
            "faster_less_accurate",
            "faster_more_accurate",
            "slower_more_accurate",
            "ties",
        ]
        .map(|k| q[k].as_u64().unwrap())
    };
    // Error magnitude over every click: P1 baseline (0.004 + 0.002) / 2,
    // stiction 0: faster, more accurate. P2 baseline 0.002, stiction 0.001,
    // 1 s slower: slower, more accurate.
    assert_eq!(pooled("quadrants"), [0, 0, 1, 1, 0]);
    // Error counts: P1 0.5 -> 0, faster; P2 0 -> 0: a tie.
    assert_eq!(pooled("quadrants_error_count"), [0, 0, 1, 0, 1]);
    assert_eq!(f["tests"], 5, "the aborted test is not analysed");
    let notes: Vec<&str> = analysis.summary["notes"]
        .as_array()
        .unwrap()
        .iter()
        .filter_map(Value::as_str)
        .collect();
    assert!(
        notes.contains(
            &"fitts: tests aborted or timed out, not analysed: 1 (stiction at ID 2.000 bits: 1)"
        ),
        "{notes:?}"
    );
}

/// `frictionlab ARGS --csv-only` (the fixtures have no logs).
fn frictionlab(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_frictionlab"))
        .args(args)
        .arg("--csv-only")
        .output()
        .unwrap()
}

#[test]
fn analyze_writes_summary_report_and_tables() {
    let dir = tempfile::tempdir().unwrap();
    magnitude_fixture(dir.path());
    let out = dir.path().join("out");
    let o = frictionlab(&[
        "analyze",
        dir.path().to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let summary: Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    assert!(summary["magnitude_estimation"]["geometric_means"].is_array());
    let html = std::fs::read_to_string(out.join("report.html")).unwrap();
    assert!(
        html.contains("<svg")
            && html.contains("perceived friction vs mu_s")
            && html.contains("perceived friction vs mu_k")
    );
    for t in [
        "magnitude_geometric_means",
        "magnitude_correlations",
        "magnitude_trends",
    ] {
        let csv = std::fs::read_to_string(out.join(format!("tables/{t}.csv"))).unwrap();
        assert!(csv.lines().count() > 1, "{t}");
        let parquet = std::fs::read(out.join(format!("tables/{t}.parquet"))).unwrap();
        assert_eq!(&parquet[..4], b"PAR1", "{t} is Parquet");
    }
}

/// An edit of a fixture CSV's text.
type Edit = Box<dyn Fn(&mut String)>;

#[test]
fn unusable_input_exits_2_with_place_and_reason() {
    let empty = tempfile::tempdir().unwrap();
    let o = frictionlab(&["analyze", empty.path().to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("no data files"));

    let cases: Vec<(&str, Edit, &str)> = vec![
        (
            "missing column",
            Box::new(|t: &mut String| *t = t.replacen(",magnitude,", ",size,", 1)),
            "1:1: missing column 'magnitude'",
        ),
        (
            "non-numeric",
            Box::new(|t: &mut String| *t = t.replacen(",2,", ",two,", 1)),
            "magnitude: 'two' is not a finite number",
        ),
        (
            "zero",
            Box::new(|t: &mut String| *t = t.replacen(",2,", ",0,", 1)),
            "magnitude: 0 is not greater than 0",
        ),
        (
            "negative",
            Box::new(|t: &mut String| *t = t.replacen(",2,", ",-2,", 1)),
            "magnitude: -2 is not greater than 0",
        ),
        (
            // The kind is the rows' `kind` cell; its columns must be there.
            "a kind's column renamed",
            Box::new(|t: &mut String| *t = t.replace("display", "screen")),
            "1:1: missing column 'display'",
        ),
        (
            "unknown kind",
            Box::new(|t: &mut String| *t = t.replace(",magnitude_estimation,", ",tapping,")),
            "2:9: no analysis for the kind of session 'tapping'",
        ),
    ];
    for (name, edit, message) in cases {
        let dir = tempfile::tempdir().unwrap();
        magnitude_fixture(dir.path());
        let file = dir
            .path()
            .join("data/study-fixture_subject-AB_session-1_data.csv");
        let mut text = std::fs::read_to_string(&file).unwrap();
        edit(&mut text);
        std::fs::write(&file, text).unwrap();
        let o = frictionlab(&["analyze", dir.path().to_str().unwrap()]);
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{name}: {stderr}");
        assert!(
            stderr.starts_with(&format!("error: {}", file.display())),
            "{name}: {stderr}"
        );
        assert!(stderr.contains(message), "{name}: {stderr}");
        assert!(!stderr.contains("panicked"));
        assert!(
            !dir.path().join("report").exists(),
            "{name}: nothing written"
        );
    }
    // A report folder that is a file is refused before the analysis, the
    // file left as it was.
    let dir = tempfile::tempdir().unwrap();
    magnitude_fixture(dir.path());
    let out = dir.path().join("report.txt");
    std::fs::write(&out, "mine").unwrap();
    let o = frictionlab(&[
        "analyze",
        dir.path().to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert_eq!(
        String::from_utf8_lossy(&o.stderr).lines().next(),
        Some(
            format!(
                "error: {}: exists and is not a folder: the report is written into a folder (--out)",
                out.display()
            )
            .as_str()
        )
    );
    assert_eq!(std::fs::read_to_string(&out).unwrap(), "mine");
    // The bad value's place is its line and column.
    let dir = tempfile::tempdir().unwrap();
    magnitude_fixture(dir.path());
    let file = dir
        .path()
        .join("data/study-fixture_subject-AB_session-1_data.csv");
    let text = std::fs::read_to_string(&file)
        .unwrap()
        .replacen(",2,", ",two,", 1);
    let line = text.lines().position(|l| l.contains(",two,")).unwrap() + 1;
    let column = text.lines().nth(line - 1).unwrap().find(",two,").unwrap() + 2;
    std::fs::write(&file, text).unwrap();
    let o = frictionlab(&["analyze", dir.path().to_str().unwrap()]);
    assert!(String::from_utf8_lossy(&o.stderr).contains(&format!(": {line}:{column}: magnitude")));
}

#[test]
fn statistics_that_cannot_be_computed_are_marked_n_a() {
    // One display only: no correlations, no ratio.
    let dir = tempfile::tempdir().unwrap();
    let rows: Vec<_> = [0.4, 0.5, 0.6]
        .iter()
        .map(|&mu| magnitude_row("A", "force", mu, mu * 10.0))
        .collect();
    data(
        dir.path(),
        "study-x_subject-A_session-1",
        "magnitude_estimation",
        &rows,
    );
    let s = analyze(dir.path()).unwrap().summary;
    assert!(s["magnitude_estimation"]["display_ratio"].is_null());
    assert_eq!(
        s["magnitude_estimation"]["correlations"],
        serde_json::json!([])
    );
    assert!(
        s["notes"]
            .as_array()
            .unwrap()
            .iter()
            .any(|n| n.as_str().unwrap().contains("display_ratio: n/a"))
    );
    // One participant, two displays, two stimuli: a ratio, but no correlation
    // (2 points).
    let dir = tempfile::tempdir().unwrap();
    let rows: Vec<_> = ["force", "tactile"]
        .iter()
        .flat_map(|d| [0.4, 0.5].map(|mu| magnitude_row("A", d, mu, mu * 10.0)))
        .collect();
    data(
        dir.path(),
        "study-x_subject-A_session-1",
        "magnitude_estimation",
        &rows,
    );
    let s = analyze(dir.path()).unwrap().summary;
    assert!(s["magnitude_estimation"]["display_ratio"].is_number());
    assert!(s["magnitude_estimation"]["correlations"][0]["r"].is_null());
    assert_eq!(s["magnitude_estimation"]["correlations"][0]["n"], 2);
    // Fitts without a baseline: no quadrants.
    let dir = tempfile::tempdir().unwrap();
    data(
        dir.path(),
        "study-y_subject-A_session-1",
        "fitts",
        &[fitts_row("A", "viscous", 2.0, 1.0, 0)],
    );
    let s = analyze(dir.path()).unwrap().summary;
    assert_eq!(s["fitts"]["quadrants"], serde_json::json!([]));
    assert!(s["fitts"]["regression"][0]["slope_s_per_bit"].is_null());
}

/// The display effect is a paired t test across participants of their
/// first-minus-second display mean log answers, worked by hand: in log2
/// units the differences (force minus tactile; alphabetical without logs)
/// are 1, 2 and 3, so the mean is 2, the SD 1 and t = 2 sqrt(3) with 2 df,
/// whose two-sided p is 1 - sqrt(6/7). A participant who answered on one
/// display only is left out.
#[test]
fn the_display_effect_is_a_paired_t_test_across_participants() {
    let dir = tempfile::tempdir().unwrap();
    let mut rows = Vec::new();
    for (p, display, answers) in [
        ("A", "force", vec![2.0, 2.0]),
        ("A", "tactile", vec![1.0, 1.0]),
        ("B", "force", vec![4.0, 4.0]),
        ("B", "tactile", vec![1.0, 1.0]),
        ("C", "force", vec![8.0]),
        ("C", "tactile", vec![1.0, 1.0]),
        ("D", "tactile", vec![5.0, 7.0]),
    ] {
        for (mu_s, m) in [0.4, 0.5].into_iter().zip(answers) {
            rows.push(magnitude_row(p, display, mu_s, m));
        }
    }
    data(
        dir.path(),
        "study-fixture_subject-ABCD_session-1",
        "magnitude_estimation",
        &rows,
    );
    let s = analyze(dir.path()).unwrap().summary;
    let e = &s["magnitude_estimation"]["display_effect"];
    assert_eq!(e["n"], 3);
    assert_close(&e["ratio"], 4.0, "ratio");
    assert_close(&e["t"], 2.0 * 3f64.sqrt(), "t");
    assert_close(&e["p"], 1.0 - (6.0f64 / 7.0).sqrt(), "p");
    let half = 4.302_652_729_911_275 / 3f64.sqrt();
    assert_close(&e["ci_low"], 2f64.powf(2.0 - half), "ci_low");
    assert_close(&e["ci_high"], 2f64.powf(2.0 + half), "ci_high");
    // Alike differences have no spread: n/a, with the reason.
    let dir = tempfile::tempdir().unwrap();
    magnitude_fixture(dir.path());
    let s = analyze(dir.path()).unwrap().summary;
    assert!(s["magnitude_estimation"]["display_effect"]["p"].is_null());
    assert!(
        s["notes"]
            .as_array()
            .unwrap()
            .iter()
            .any(|n| n.as_str().unwrap().contains("display_effect: n/a"))
    );
}
