//! The committed study reproductions in `analysis/` match a fresh simulated
//! replay (the same command as `analysis/reproduce.sh`, run in-process).
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    reason = "a failed unwrap is a failed test"
)]

use frictionlab::analysis::analyze;
use frictionlab::kinds::Registry;
use frictionlab::protocol::load::parse;
use frictionlab::results::ResultsDir;
use frictionlab::session::{Simulation, simulate_participants};
use serde_json::Value;

/// Numbers equal to 1e-9 relative; everything else equal.
fn same(a: &Value, b: &Value, path: &str) -> Result<(), String> {
    match (a, b) {
        (Value::Number(x), Value::Number(y)) => {
            let (x, y) = (x.as_f64().unwrap(), y.as_f64().unwrap());
            if (x - y).abs() <= 1e-9 * x.abs().max(y.abs()).max(1e-300) {
                Ok(())
            } else {
                Err(format!("{path}: {x} vs {y}"))
            }
        }
        (Value::Array(x), Value::Array(y)) if x.len() == y.len() => x
            .iter()
            .zip(y)
            .enumerate()
            .try_for_each(|(i, (x, y))| same(x, y, &format!("{path}[{i}]"))),
        (Value::Object(x), Value::Object(y)) if x.len() == y.len() => {
            x.iter().try_for_each(|(k, v)| {
                y.get(k)
                    .ok_or_else(|| format!("{path}.{k}: missing"))
                    .and_then(|w| same(v, w, &format!("{path}.{k}")))
            })
        }
        _ if a == b => Ok(()),
        _ => Err(format!("{path}: {a} vs {b}")),
    }
}

fn check(study: &str, participants: u32, seed: u64) {
    check_against(
        study,
        participants,
        seed,
        None,
        &format!("{study}/summary.json"),
    );
    let root = env!("CARGO_MANIFEST_DIR");
    assert!(std::path::Path::new(&format!("{root}/analysis/{study}/report.html")).is_file());
}

/// Replays `study` (with the population file `population`, under
/// `analysis/`) and compares its summary with `analysis/<committed>`.
fn check_against(
    study: &str,
    participants: u32,
    seed: u64,
    population: Option<&str>,
    committed_path: &str,
) {
    let root = env!("CARGO_MANIFEST_DIR");
    let population = population.map(|p| {
        frictionlab::participant::population::read(std::path::Path::new(&format!(
            "{root}/analysis/{p}"
        )))
        .unwrap()
    });
    let text = std::fs::read_to_string(format!("{root}/protocols/{study}.json")).unwrap();
    let protocol = parse(&text).unwrap();
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("results");
    simulate_participants(
        &ResultsDir::new(&out),
        &Simulation {
            protocol: &protocol,
            protocol_bytes: text.as_bytes(),
            participants,
            seed,
            pace: None,
            streams: false,
            jobs: 2,
            population: population.as_ref(),
            stop: None,
            lsl: None,
        },
        &|_| {},
    )
    .unwrap();
    let fresh = analyze::<Registry>(&out).unwrap().summary;
    let committed: Value = serde_json::from_str(
        &std::fs::read_to_string(format!("{root}/analysis/{committed_path}")).unwrap(),
    )
    .unwrap();
    if let Err(e) = same(&fresh, &committed, study) {
        panic!(
            "analysis/{committed_path} is out of date ({e}); regenerate with: bash analysis/reproduce.sh"
        );
    }
}

#[test]
fn paired_comparison_reproduction_is_in_sync() {
    check("paired-comparison", 6, 2000);
}

#[test]
fn magnitude_estimation_reproduction_is_in_sync() {
    check("magnitude-estimation", 10, 2001);
}

#[test]
fn fitts_reproduction_is_in_sync() {
    check("fitts", 20, 2002);
}

#[test]
fn robustness_replays_are_in_sync() {
    check_against(
        "paired-comparison",
        60,
        2000,
        Some("robustness/hand-k150-b5/population.json"),
        "robustness/hand-k150-b5/paired-comparison.json",
    );
    check_against(
        "magnitude-estimation",
        10,
        2001,
        Some("robustness/breakaway-weight-1/population.json"),
        "robustness/breakaway-weight-1/magnitude-estimation.json",
    );
    check_against(
        "fitts",
        20,
        2002,
        Some("robustness/motor-noise-high/population.json"),
        "robustness/motor-noise-high/fitts.json",
    );
}

#[test]
fn the_claims_table_is_generated_from_the_committed_summaries() {
    let root = env!("CARGO_MANIFEST_DIR");
    let text = std::fs::read_to_string(format!("{root}/protocols/fitts.json")).unwrap();
    let ids = frictionlab::claims::narrowest_ids(&parse(&text).unwrap()).unwrap();
    assert_eq!(ids.len(), 3, "seed 002 has three 2 mm levels");
    let fresh =
        frictionlab::claims::claims(std::path::Path::new(&format!("{root}/analysis")), &ids)
            .unwrap();
    let committed = std::fs::read_to_string(format!("{root}/analysis/claims.md")).unwrap();
    assert!(
        fresh == committed,
        "analysis/claims.md is out of date; regenerate with: bash analysis/reproduce.sh"
    );
    for verdict in ["| reproduced |", "| not reproduced |", "| not applicable |"] {
        assert!(committed.contains(verdict), "no '{verdict}' row");
    }
}
