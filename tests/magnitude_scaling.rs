//! Magnitude estimation's generic form (issue 35): one parameter of any
//! model at several levels, and the power law `analyze` fits to it.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    reason = "a failed unwrap is a failed test"
)]

use crate::common;

use std::path::Path;

use frictionlab::kinds::Registry;
use frictionlab::participant::Population;
use frictionlab::protocol::load::parse;
use frictionlab::results::ResultsDir;
use frictionlab::session::{Simulation, simulate_participants};
use serde_json::{Value, json};

/// A viscosity scaling: the viscous model's damping at `levels`, each
/// presented twice, 3 s of exploration.
fn viscosity(levels: &[f64]) -> Value {
    json!({
        "id": "viscosity-scaling",
        "title": "Viscosity scaling",
        "description": "Magnitude estimation of viscosity, the generic form.",
        "randomization": "random",
        "repetitions": 2,
        "block_order": "fixed",
        "break_s": 0.0,
        "instructions": "Stir, then type how strong the resistance felt.",
        "design": {
            "kind": "magnitude_estimation",
            "exploration_s": 3.0,
            "scaling": {
                "display": "viscosity",
                "reference": {"model": "viscous", "damping_n_s_m": 1.0},
                "parameter": "damping_n_s_m",
                "levels": levels,
            }
        }
    })
}

/// Simulates `participants` on `protocol` with `population` and analyses
/// the folder: `summary.json`'s `magnitude_estimation`.
fn replay(protocol: &Value, participants: u32, population: &Population, out: &Path) -> Value {
    let text = protocol.to_string();
    let p = parse::<Registry>(&text).unwrap();
    simulate_participants(
        &ResultsDir::new(out),
        &Simulation {
            protocol: &p,
            protocol_bytes: text.as_bytes(),
            participants,
            seed: 2,
            pace: None,
            streams: false,
            population: Some(population),
            jobs: 2,
            stop: None,
            lsl: None,
        },
        &|_| {},
    )
    .unwrap();
    let analysis = frictionlab::analysis::analyze::<Registry>(out).unwrap();
    analysis.summary["magnitude_estimation"].clone()
}

/// The known answer: participants whose Stevens exponent is set, judging a
/// viscosity low enough not to slow their hand (the force they feel is
/// then in proportion to the damping), give their exponent back within the
/// analysis's 95% interval.
#[test]
fn a_participant_with_a_set_exponent_gets_it_back_from_a_viscosity_scaling() {
    let protocol = viscosity(&[0.01, 0.02, 0.04, 0.08, 0.16, 0.32]);
    for beta in [0.5, 0.8, 1.1] {
        let dir = tempfile::tempdir().unwrap();
        let population: Population = serde_json::from_value(json!({
            "stevens_exponent": [beta, beta]
        }))
        .unwrap();
        let m = replay(&protocol, 12, &population, dir.path());
        let s = &m["scalings"][0];
        let (mean, lo, hi) = (
            s["exponent"].as_f64().unwrap(),
            s["ci_low"].as_f64().unwrap(),
            s["ci_high"].as_f64().unwrap(),
        );
        assert!(
            lo <= beta && beta <= hi,
            "set {beta}: {mean} ({lo} to {hi})"
        );
        assert!(hi - lo < 0.15, "set {beta}: interval {lo} to {hi} too wide");
        assert_eq!(s["parameter"], "damping_n_s_m");
        assert_eq!(s["n"], 12);
        assert_eq!(s["geometric_means"].as_array().unwrap().len(), 6);
        // Seed 001's statistics are not computed on a scaling.
        assert!(m.get("geometric_means").is_none(), "{m}");
    }
}

/// The data of the generic form: `parameter` and `level` filled, seed
/// 001's coefficients empty; seed 001's form logs no `parameter` or
/// `level` and leaves their CSV cells empty.
#[test]
fn a_scaling_logs_its_parameter_and_level_and_seed_001_logs_what_it_did() {
    let dir = tempfile::tempdir().unwrap();
    let protocol = viscosity(&[0.5, 2.0]);
    let _ = replay(&protocol, 1, &Population::default(), dir.path());
    let csv = std::fs::read_to_string(
        dir.path()
            .join("data/study-viscosityscaling_subject-sim001_session-1_data.csv"),
    )
    .unwrap();
    let mut lines = csv.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let at = |c: &str| header.iter().position(|h| *h == c).unwrap();
    for line in lines {
        let cells: Vec<&str> = line.split(',').collect();
        assert_eq!(cells[at("parameter")], "damping_n_s_m");
        assert!(["0.5", "2"].contains(&cells[at("level")]), "{line}");
        assert_eq!(cells[at("mu_s")], "");
    }
    let seed001 = std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("protocols/magnitude-quick.json"),
    )
    .unwrap();
    let dir = tempfile::tempdir().unwrap();
    let m = replay(
        &serde_json::from_str(&seed001).unwrap(),
        1,
        &Population::default(),
        dir.path(),
    );
    assert!(m["geometric_means"].is_array());
    assert!(m.get("scalings").is_none());
    let log = std::fs::read_to_string(&common::session_logs(dir.path())[0]).unwrap();
    assert!(!log.contains("\"parameter\"") && !log.contains("\"level\""));
    assert!(log.contains("\"mu_s\":0.4"));
}

/// The loader's checks of a scaling, each at its JSON path.
#[test]
fn a_bad_scaling_is_refused_at_its_json_path() {
    let refused = |edit: &dyn Fn(&mut Value)| -> Vec<String> {
        let mut v = viscosity(&[0.5, 1.0, 2.0]);
        edit(&mut v);
        parse::<Registry>(&v.to_string())
            .expect_err("should be refused")
            .iter()
            .map(|e| format!("{}: {}", e.place, e.message))
            .collect()
    };
    let e = refused(&|v| v["design"]["scaling"]["levels"][1] = json!(-1.0));
    assert!(
        e.iter()
            .any(|e| e.starts_with("design.scaling.levels[1]: ")),
        "{e:?}"
    );
    let e = refused(&|v| v["design"]["scaling"]["parameter"] = json!("mu_s"));
    assert!(
        e.iter().any(|e| e.starts_with("design.scaling.parameter: ")
            && e.contains("no numeric parameter 'mu_s'")),
        "{e:?}"
    );
    let e = refused(&|v| v["design"]["scaling"]["levels"] = json!([1.0]));
    assert!(
        e.iter().any(|e| e.starts_with("design.scaling.levels: ")),
        "{e:?}"
    );
    let e = refused(&|v| v["design"]["sets"] = json!([]));
    assert!(e.iter().any(|e| e.contains("either `sets`")), "{e:?}");
    // A bad scaling is the one error: `sets`, rightly absent, is not
    // reported missing.
    let e = refused(&|v| v["design"]["scaling"]["display"] = json!(3));
    assert_eq!(
        e,
        ["design.scaling.display: invalid type: integer `3`, expected a string"]
    );
}
