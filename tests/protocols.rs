//! Protocol files: the shipped designs, the schema, the two-stage loader's
//! errors, and the plan drawn from a seed.
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

use std::collections::{BTreeMap, BTreeSet};
use std::process::Command;

use frictionlab::kinds::{Design, Protocol, Registry, TrialSpec};
use frictionlab::problem::Problem as LoadError;
use frictionlab::protocol::load::parse;
use frictionlab::protocol::plan::resolve;
use frictionlab::protocol::{Randomization, json_schema};
use proptest::prelude::*;
use serde_json::{Value, json};

fn shipped(name: &str) -> (String, Protocol) {
    let text = std::fs::read_to_string(format!(
        "{}/protocols/{name}.json",
        env!("CARGO_MANIFEST_DIR")
    ))
    .unwrap();
    let p = parse::<Registry>(&text).unwrap_or_else(|e| panic!("{name}: {e:?}"));
    (text, p)
}

const SHIPPED: [&str; 6] = [
    "paired-comparison",
    "paired-quick",
    "magnitude-estimation",
    "magnitude-quick",
    "fitts",
    "fitts-quick",
];

#[test]
fn shipped_protocols_load_and_reproduce_the_studies_designs() {
    for name in SHIPPED {
        let (text, p) = shipped(name);
        // The loader agrees with plain serde on valid files.
        assert_eq!(
            serde_json::from_str::<Protocol>(&text).unwrap(),
            p,
            "{name}"
        );
    }
    let (_, p) = shipped("magnitude-estimation");
    let Design::MagnitudeEstimation(d) = &p.design else {
        panic!()
    };
    assert_eq!(
        d.sets
            .iter()
            .map(|s| s.display.as_str())
            .collect::<Vec<_>>(),
        ["tactile", "force"]
    );
    assert!((d.exploration_s - 10.0).abs() < 1e-12 && p.break_s > 0.0);
    for set in &d.sets {
        assert_eq!(set.stimuli.len(), 30);
        let dmu: BTreeSet<i64> = set
            .stimuli
            .iter()
            .map(|s| ((s.mu_s - s.mu_k) * 1000.0).round() as i64)
            .collect();
        assert_eq!(dmu, BTreeSet::from([100, 200, 300]));
        let mu_s: BTreeSet<i64> = set
            .stimuli
            .iter()
            .map(|s| (s.mu_s * 1000.0).round() as i64)
            .collect();
        assert_eq!(mu_s.len(), 10);
        assert_eq!((mu_s.first(), mu_s.last()), (Some(&375), Some(&600)));
    }
    let (_, p) = shipped("fitts");
    let Design::Fitts(d) = &p.design else {
        panic!()
    };
    assert_eq!(d.levels.len(), 9);
    let ids: Vec<&str> = d.conditions.iter().map(|c| c.id.as_str()).collect();
    assert_eq!(
        ids,
        ["baseline", "real", "simulated", "high_stiction", "viscous"]
    );
    assert!(d.conditions[1].prompt.is_some() && d.conditions[1].physical.is_some());
    let plan = resolve(&p, 1, 0);
    assert_eq!(plan.trials.iter().filter(|t| !t.practice).count(), 45);
    assert!(
        plan.trials.iter().take_while(|t| t.practice).count() >= 2,
        "practice first"
    );
    let (_, p) = shipped("paired-comparison");
    let Design::PairedComparison(d) = &p.design else {
        panic!()
    };
    assert!((d.reference_s - 60.0).abs() < 1e-12);
    assert_eq!(
        d.pairs,
        [["time_constant".to_owned(), "time_varying".to_owned()]]
    );
}

#[test]
fn schemas_are_up_to_date() {
    let root = env!("CARGO_MANIFEST_DIR");
    let fix = "regenerate with: cargo run -- schema protocol > protocols/protocol.schema.json; \
               cargo run -- schema log > results-schema/log-line.schema.json";
    let on_disk =
        std::fs::read_to_string(format!("{root}/protocols/protocol.schema.json")).unwrap();
    assert!(
        on_disk == json_schema::<Registry>(),
        "protocols/protocol.schema.json is stale; {fix}"
    );
    let on_disk =
        std::fs::read_to_string(format!("{root}/results-schema/log-line.schema.json")).unwrap();
    assert!(
        on_disk == frictionlab::results::log_json_schema::<Registry>(),
        "log-line.schema.json is stale; {fix}"
    );
}

/// The quick magnitude protocol as JSON, edited by `edit`, loaded.
fn broken(edit: impl FnOnce(&mut Value)) -> Vec<LoadError> {
    let (text, _) = shipped("magnitude-quick");
    let mut v: Value = serde_json::from_str(&text).unwrap();
    edit(&mut v);
    parse::<Registry>(&v.to_string()).expect_err("should be refused")
}

fn fitts_broken(edit: impl FnOnce(&mut Value)) -> Vec<LoadError> {
    let (text, _) = shipped("fitts-quick");
    let mut v: Value = serde_json::from_str(&text).unwrap();
    edit(&mut v);
    parse::<Registry>(&v.to_string()).expect_err("should be refused")
}

fn has(errors: &[LoadError], path: &str, needle: &str) -> bool {
    errors
        .iter()
        .any(|e| e.place == path && e.message.contains(needle))
}

#[test]
fn broken_protocols_name_the_json_path_and_reason() {
    let e = parse::<Registry>("{\"id\": \"x\",\n  \"title\": }").unwrap_err();
    assert_eq!(e[0].place, "2:12", "syntax errors give line:column: {e:?}");

    let e = broken(|v| v["repetitions"] = json!("two"));
    assert!(
        has(
            &e,
            "repetitions",
            "invalid type: string \"two\", expected u32"
        ),
        "{e:?}"
    );
    let e = broken(|v| {
        v.as_object_mut().unwrap().remove("title");
    });
    assert!(has(&e, "title", "missing required field"), "{e:?}");
    let e = broken(|v| v["design"]["sets"][1]["stimuli"][2]["mu_k"] = json!(0.9));
    assert!(
        has(
            &e,
            "design.sets[1].stimuli[2].mu_s",
            "must be greater than mu_k (0.9)"
        ),
        "{e:?}"
    );
    let e = broken(|v| v["design"]["sets"] = json!([]));
    assert!(has(&e, "design.sets", "zero trials"), "{e:?}");
    let e = broken(|v| v["design"]["sets"][0]["stimuli"] = json!([]));
    assert!(has(&e, "design.sets[0].stimuli", "zero trials"), "{e:?}");
    let e = broken(|v| v["design"]["sets"][0]["model"]["model"] = json!("coulomb"));
    assert!(
        has(&e, "design.sets[0].model.model", "unknown model 'coulomb'"),
        "{e:?}"
    );
    let e = broken(|v| v["design"]["sets"][0]["model"]["mass"] = json!(1.0));
    assert!(
        has(&e, "design.sets[0].model.mass", "unknown field `mass`"),
        "{e:?}"
    );
    let e = broken(|v| v["design"]["sets"][0]["model"]["mass_kg"] = json!(-1.0));
    assert!(
        has(&e, "design.sets[0].model.mass_kg", "must be greater than 0"),
        "{e:?}"
    );
    let e = broken(|v| v["colour"] = json!("red"));
    assert!(has(&e, "colour", "unknown field"), "{e:?}");
    let e = broken(|v| v["design"]["kind"] = json!("staircase"));
    assert!(has(&e, "design.kind", "unknown kind 'staircase'"), "{e:?}");

    let e = fitts_broken(|v| v["design"]["levels"][0]["width_m"] = json!(0.001));
    assert!(
        has(
            &e,
            "design.levels[0].width_m",
            "must exceed the cursor diameter"
        ),
        "{e:?}"
    );
    let e = fitts_broken(|v| v["design"]["levels"] = json!([]));
    assert!(has(&e, "design.levels", "zero trials"), "{e:?}");
    let e = fitts_broken(|v| v["design"]["practice"] = json!(["nope"]));
    assert!(
        has(&e, "design.practice[0]", "unknown condition 'nope'"),
        "{e:?}"
    );
    let (text, _) = shipped("discrimination-quick");
    let mut v: Value = serde_json::from_str(&text).unwrap();
    v["design"]["judged"] = json!("hardness");
    let e = parse::<Registry>(&v.to_string()).expect_err("should be refused");
    assert!(
        has(&e, "design.judged", "unknown variant `hardness`"),
        "{e:?}"
    );
    let e = fitts_broken(|v| v["design"]["conditions"][2]["model"]["f_static_n"] = json!("big"));
    assert!(
        has(&e, "design.conditions[2].model.f_static_n", "invalid type"),
        "{e:?}"
    );
}

#[test]
fn every_error_is_reported_at_once() {
    let e = broken(|v| {
        v["colour"] = json!("red");
        v["repetitions"] = json!(-1);
        v["design"]["sets"][0]["model"]["mu_s"] = json!(0.1);
        v["design"]["sets"][1]["stimuli"][0]["mu_s"] = json!("high");
    });
    let paths: BTreeSet<&str> = e.iter().map(|e| e.place.as_str()).collect();
    assert_eq!(
        paths,
        BTreeSet::from([
            "colour",
            "repetitions",
            "design.sets[0].model.mu_s",
            "design.sets[1].stimuli[0].mu_s"
        ]),
        "{e:?}"
    );
}

#[test]
fn validate_exits_2_with_file_path_and_reason() {
    let dir = tempfile::tempdir().unwrap();
    let bad = dir.path().join("bad.json");
    let (text, _) = shipped("fitts-quick");
    let mut v: Value = serde_json::from_str(&text).unwrap();
    v["design"]["levels"][0]["width_m"] = json!(0.0005);
    std::fs::write(&bad, v.to_string()).unwrap();
    let good = format!("{}/protocols/paired-quick.json", env!("CARGO_MANIFEST_DIR"));
    let o = Command::new(env!("CARGO_BIN_EXE_frictionlab"))
        .args(["validate", &good, bad.to_str().unwrap()])
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2));
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(
        stderr.starts_with(&format!(
            "error: {}: design.levels[0].width_m: target width",
            bad.display()
        )),
        "{stderr}"
    );
    assert!(String::from_utf8_lossy(&o.stdout).contains("ok: "));
    let o = Command::new(env!("CARGO_BIN_EXE_frictionlab"))
        .args(["validate", &good])
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(0));
}

/// Issue 63: a protocol whose positions lie beyond the device's travel is
/// refused by `validate`, `simulate` and `run` against the simulated
/// apparatus's ±16 mm, each with exit 2, the level, where it reaches and
/// the travel, and nothing written. Before, a Fitts level at ±25 mm passed
/// and its simulated participants made 2 to 4 of 20 taps in 120 s.
#[test]
fn a_protocol_beyond_the_devices_travel_is_refused_naming_the_level_and_the_travel() {
    let dir = tempfile::tempdir().unwrap();
    let wide = format!(
        "{}/tests/fixtures/fitts-wide.json",
        env!("CARGO_MANIFEST_DIR")
    );
    let out = dir.path().join("results");
    let expected = format!(
        "error: {wide}: design.levels[1]: targets at ±25 mm, 4 mm wide reach -27.0 to 27.0 mm \
         along the track, beyond the simulated apparatus's travel of -16.0 to 16.0 mm\n"
    );
    let out_arg = out.to_str().unwrap();
    for args in [
        vec!["validate", &wide],
        vec![
            "simulate",
            &wide,
            "--participants",
            "2",
            "--seed",
            "1",
            "--out",
            out_arg,
        ],
        vec![
            "run",
            &wide,
            "--participant",
            "p1",
            "--responder",
            "sim",
            "--out",
            out_arg,
        ],
    ] {
        let o = Command::new(env!("CARGO_BIN_EXE_frictionlab"))
            .args(&args)
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&o.stderr);
        println!("{}: exit {:?}: {stderr}", args[0], o.status.code());
        assert_eq!(o.status.code(), Some(2), "{}: {stderr}", args[0]);
        assert_eq!(stderr, expected, "{}", args[0]);
        assert!(!out.exists(), "{}: nothing written", args[0]);
    }
    // The level that fits, alone, passes.
    let (text, _) = shipped("fitts-quick");
    let mut v: Value = serde_json::from_str(&text).unwrap();
    v["design"]["levels"] = json!([{"amplitude_m": 0.028, "width_m": 0.004}]);
    let edge = dir.path().join("edge.json");
    std::fs::write(&edge, v.to_string()).unwrap();
    let o = Command::new(env!("CARGO_BIN_EXE_frictionlab"))
        .args(["validate", edge.to_str().unwrap()])
        .output()
        .unwrap();
    assert_eq!(
        o.status.code(),
        Some(0),
        "targets reaching ±16 mm exactly fit: {}",
        String::from_utf8_lossy(&o.stderr)
    );
}

fn order(p: &Protocol, seed: u64, participant: u32) -> Vec<String> {
    resolve(p, seed, participant)
        .trials
        .iter()
        .map(|t| match &t.spec {
            TrialSpec::MagnitudeEstimation(m) => format!("{}:{:?}", m.display, m.stimulus),
            TrialSpec::Fitts(f) => format!("{}:{}:{}", f.condition, f.amplitude_m, f.width_m),
            TrialSpec::PairedComparison(p) => format!("{}>{}", p.first.id, p.second.id),
            TrialSpec::Discrimination(d) => format!("{}:{}", d.track, d.difference),
        })
        .collect()
}

#[test]
fn the_plan_is_drawn_from_the_seed() {
    let (_, p) = shipped("magnitude-estimation");
    assert_eq!(resolve(&p, 9, 0), resolve(&p, 9, 0));
    assert_ne!(
        order(&p, 9, 0),
        order(&p, 10, 0),
        "different seeds, different orders"
    );
    let plan = resolve(&p, 9, 0);
    let seeds: BTreeSet<u64> = plan.trials.iter().map(|t| t.seed).collect();
    assert_eq!(
        seeds.len(),
        plan.trials.len(),
        "each trial has its own seed"
    );
    // Random order within a set: sets stay whole.
    let blocks: Vec<&str> = plan.trials.iter().map(|t| t.block.as_str()).collect();
    assert!(
        blocks[..30].iter().all(|b| *b == blocks[0])
            && blocks[30..].iter().all(|b| *b == blocks[30])
    );
}

#[test]
fn set_order_is_counterbalanced_by_a_latin_square() {
    let (_, p) = shipped("magnitude-estimation");
    let first: Vec<String> = (0..4)
        .map(|i| resolve(&p, 1, i).trials[0].block.clone())
        .collect();
    assert_eq!(first, ["tactile", "force", "tactile", "force"]);
}

#[test]
fn randomization_modes_and_repetitions() {
    let (_, mut p) = shipped("fitts-quick");
    p.repetitions = 3;
    p.randomization = Randomization::Sequential;
    let main: Vec<String> = order(&p, 1, 0).into_iter().skip(3).collect();
    assert_eq!(main.len(), 9);
    assert_eq!(main[0..3], main[3..6], "sequential repeats the list");
    let plan = resolve(&p, 1, 0);
    assert_eq!(
        plan.trials.iter().map(|t| t.repetition).collect::<Vec<_>>(),
        [0, 1, 2, 0, 0, 0, 1, 1, 1, 2, 2, 2]
    );

    p.randomization = Randomization::Random;
    for seed in 0..20 {
        let plan = resolve(&p, seed, 0);
        let main: Vec<_> = plan.trials.iter().filter(|t| !t.practice).collect();
        for r in 0..3 {
            // Each repetition holds every test once.
            let rep: BTreeSet<String> = main
                .iter()
                .filter(|t| t.repetition == r)
                .map(|t| format!("{:?}", t.spec))
                .collect();
            assert_eq!(rep.len(), 3);
        }
    }
    p.randomization = Randomization::FullRandom;
    let mixed = (0..30).any(|seed| {
        let reps: Vec<u32> = resolve(&p, seed, 0)
            .trials
            .iter()
            .filter(|t| !t.practice)
            .map(|t| t.repetition)
            .collect();
        reps.windows(2).any(|w| w[1] < w[0])
    });
    assert!(mixed, "full_random mixes repetitions");
}

#[test]
fn paired_members_are_presented_in_both_orders() {
    let (_, p) = shipped("paired-comparison");
    let firsts: BTreeMap<String, usize> = (0..40).fold(BTreeMap::new(), |mut m, seed| {
        *m.entry(order(&p, seed, 0)[0].clone()).or_default() += 1;
        m
    });
    assert_eq!(firsts.len(), 2, "{firsts:?}");
}

fn mutate(node: &mut Value, path: &[usize], replacement: &Value) {
    let Some((&i, rest)) = path.split_first() else {
        *node = replacement.clone();
        return;
    };
    match node {
        Value::Object(m) if !m.is_empty() => {
            let k = m.keys().nth(i % m.len()).cloned().unwrap();
            mutate(m.get_mut(&k).unwrap(), rest, replacement);
        }
        Value::Array(a) if !a.is_empty() => {
            let n = a.len();
            mutate(&mut a[i % n], rest, replacement);
        }
        _ => *node = replacement.clone(),
    }
}

fn any_json() -> impl Strategy<Value = Value> {
    prop_oneof![
        Just(Value::Null),
        any::<bool>().prop_map(Value::Bool),
        any::<f64>()
            .prop_map(|x| serde_json::Number::from_f64(x).map_or(Value::Null, Value::Number)),
        any::<i64>().prop_map(|x| json!(x)),
        "[a-z_-]{0,8}".prop_map(Value::String),
        Just(json!([])),
        Just(json!({})),
        Just(json!({"model": "karnopp"})),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 200, ..ProptestConfig::default() })]

    #[test]
    fn the_loader_never_panics_and_accepted_files_round_trip(
        which in 0_usize..8,
        path in proptest::collection::vec(0_usize..40, 0..6),
        replacement in any_json(),
    ) {
        let name = SHIPPED
            .get(which)
            .copied()
            .unwrap_or_else(|| ["discrimination", "discrimination-quick"][which - SHIPPED.len()]);
        let (text, _) = shipped(name);
        let mut v: Value = serde_json::from_str(&text).unwrap();
        mutate(&mut v, &path, &replacement);
        if let Ok(p) = parse::<Registry>(&v.to_string()) {
            let again = parse::<Registry>(&serde_json::to_string(&p).unwrap()).unwrap();
            prop_assert_eq!(again, p);
        }
    }

    #[test]
    fn the_loader_never_panics_on_arbitrary_text(text in "\\PC{0,200}") {
        let _ = parse::<Registry>(&text);
    }
}
