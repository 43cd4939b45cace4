//! Simulated participants reproduce the directions of the seeds' results
//! from what their hands felt: magnitude rises with mu_s (and tactile
//! answers are about a seventh of force answers), the time-varying
//! rendering is chosen as nearer to the real surface, and high stiction
//! degrades Fitts performance against baseline.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    reason = "a failed unwrap is a failed test"
)]
#![allow(
    clippy::cast_possible_truncation,
    clippy::cast_sign_loss,
    reason = "index and rounding arithmetic on small, known, non-negative test values"
)]

use std::collections::BTreeMap;

use frictionlab::protocol::load::parse;
use frictionlab::results::ResultsDir;
use frictionlab::session::{Simulation, simulate_participants};
use serde_json::{Value, json};

type Row = BTreeMap<String, String>;

/// Simulates `n` participants of the shipped protocol `name` (edited by
/// `edit`) and returns every completed, non-practice row.
fn simulate(name: &str, n: u32, seed: u64, edit: impl FnOnce(&mut Value)) -> Vec<Row> {
    let text = std::fs::read_to_string(format!(
        "{}/protocols/{name}.json",
        env!("CARGO_MANIFEST_DIR")
    ))
    .unwrap();
    let mut v: Value = serde_json::from_str(&text).unwrap();
    edit(&mut v);
    let text = v.to_string();
    let protocol = parse(&text).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let outcomes = simulate_participants(
        &ResultsDir::new(dir.path()),
        &Simulation {
            protocol: &protocol,
            protocol_bytes: text.as_bytes(),
            participants: n,
            seed,
            pace: None,
            streams: false,
            jobs: 2,
        },
        &|_| {},
    )
    .unwrap();
    let mut rows = Vec::new();
    for outcome in outcomes {
        let csv = std::fs::read_to_string(outcome.csv).unwrap();
        let mut lines = csv.lines();
        let header: Vec<&str> = lines.next().unwrap().split(',').collect();
        rows.extend(lines.map(|l| {
            header
                .iter()
                .map(|h| (*h).to_owned())
                .zip(l.split(',').map(str::to_owned))
                .collect::<Row>()
        }));
    }
    rows.retain(|r| r["status"] == "completed" && r["practice"] == "false");
    rows
}

fn num(r: &Row, k: &str) -> f64 {
    r[k].parse().unwrap()
}

fn pearson(xy: &[(f64, f64)]) -> f64 {
    let n = xy.len() as f64;
    let (mx, my) = (
        xy.iter().map(|p| p.0).sum::<f64>() / n,
        xy.iter().map(|p| p.1).sum::<f64>() / n,
    );
    let sxy: f64 = xy.iter().map(|(x, y)| (x - mx) * (y - my)).sum();
    let sxx: f64 = xy.iter().map(|(x, _)| (x - mx).powi(2)).sum();
    let syy: f64 = xy.iter().map(|(_, y)| (y - my).powi(2)).sum();
    sxy / (sxx * syy).sqrt()
}

#[test]
fn magnitude_rises_with_mu_s_on_both_displays() {
    let rows = simulate("magnitude-estimation", 6, 21, |v| {
        v["design"]["exploration_s"] = json!(4.0);
    });
    let ln_gm = |display: &str| {
        let mut by: BTreeMap<i64, Vec<f64>> = BTreeMap::new();
        for r in rows.iter().filter(|r| r["display"] == display) {
            by.entry((num(r, "mu_s") * 1000.0).round() as i64)
                .or_default()
                .push(num(r, "magnitude").ln());
        }
        by.into_iter()
            .map(|(mu, logs)| {
                (
                    mu as f64 / 1000.0,
                    logs.iter().sum::<f64>() / logs.len() as f64,
                )
            })
            .collect::<Vec<_>>()
    };
    for display in ["tactile", "force"] {
        let series = ln_gm(display);
        assert_eq!(series.len(), 10);
        let r = pearson(&series);
        assert!(r > 0.8, "{display}: r(mu_s, geometric mean) = {r}");
        let mut positive = 0;
        for p in 0..6 {
            let own: Vec<(f64, f64)> = rows
                .iter()
                .filter(|r| {
                    r["display"] == display && r["participant"] == format!("sim-{:03}", p + 1)
                })
                .map(|r| (num(r, "mu_s"), num(r, "magnitude").ln()))
                .collect();
            positive += usize::from(pearson(&own) > 0.0);
        }
        assert!(
            positive >= 5,
            "{display}: {positive} of 6 participants rise with mu_s"
        );
    }
    let mean = |display: &str| {
        let l: Vec<f64> = rows
            .iter()
            .filter(|r| r["display"] == display)
            .map(|r| num(r, "magnitude").ln())
            .collect();
        l.iter().sum::<f64>() / l.len() as f64
    };
    let ratio = (mean("tactile") - mean("force")).exp();
    assert!(
        (1.0 / 10.0..1.0 / 4.5).contains(&ratio),
        "tactile/force {ratio} (seed: about 1/7)"
    );
}

#[test]
fn the_time_varying_rendering_is_chosen_as_nearer_to_the_real_surface() {
    let rows = simulate("paired-quick", 12, 4, |_| {});
    let chosen = |id: &str| rows.iter().filter(|r| r["chosen"] == id).count();
    let firsts = rows.iter().filter(|r| r["first"] == "time_varying").count();
    assert!(firsts > 0 && firsts < 12, "both presentation orders occur");
    assert!(
        chosen("time_varying") >= 10,
        "{} of 12",
        chosen("time_varying")
    );
    assert!(chosen("time_varying") > chosen("time_constant"));
}

#[test]
fn high_stiction_degrades_fitts_performance_for_most_participants() {
    let rows = simulate("fitts", 10, 8, |v| {
        let conds = v["design"]["conditions"].as_array().unwrap().clone();
        v["design"]["conditions"] = json!(
            conds
                .into_iter()
                .filter(|c| c["id"] == "baseline" || c["id"] == "high_stiction")
                .collect::<Vec<_>>()
        );
        v["design"]["levels"] = json!([{"amplitude_m": 0.024, "width_m": 0.002}, {"amplitude_m": 0.016, "width_m": 0.004}, {"amplitude_m": 0.010, "width_m": 0.006}]);
        v["design"]["taps"] = json!(6);
        v["design"]["practice"] = json!([]);
        v["design"]["practice_levels"] = json!([]);
    });
    let mut degraded = 0;
    for p in 0..10 {
        let mean = |cond: &str, k: &str| {
            let v: Vec<f64> = rows
                .iter()
                .filter(|r| {
                    r["participant"] == format!("sim-{:03}", p + 1) && r["condition"] == cond
                })
                .map(|r| num(r, k))
                .collect();
            v.iter().sum::<f64>() / v.len() as f64
        };
        let slower =
            mean("high_stiction", "completion_time_s") > mean("baseline", "completion_time_s");
        let not_more_accurate = mean("high_stiction", "errors") >= mean("baseline", "errors");
        degraded += usize::from(slower && not_more_accurate);
    }
    assert!(
        degraded >= 7,
        "{degraded} of 10 participants slower and no more accurate with high stiction"
    );
}
