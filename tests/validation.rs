//! Issue 35: the validation suite. The protocols in `analysis/validation/`
//! are valid and each carries its rows; the committed table
//! (`analysis/validation.json`, `analysis/validation.md`) is what a fresh
//! replay gives; a statistic's path selects what it says; the sweep pins
//! one constant and leaves the participants' other traits as drawn; bad
//! rows are refused with their place.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    reason = "a failed unwrap is a failed test"
)]

use std::path::PathBuf;
use std::process::Command;

use frictionlab::kinds::Registry;
use frictionlab::participant::{Population, Traits};
use frictionlab::protocol::load::read;
use frictionlab::protocol::validation::Statistic;
use frictionlab::validation::{Options, Row, run, select, sweep_points, table, values, verdict};
use serde_json::json;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn committed() -> Vec<Row> {
    let text = std::fs::read_to_string(root().join("analysis/validation.json")).unwrap();
    serde_json::from_str(&text).unwrap()
}

fn close(a: f64, b: f64) -> bool {
    (a - b).abs() <= 1e-9 * a.abs().max(b.abs()).max(1e-300)
}

#[test]
fn every_validation_protocol_is_valid_and_judged_by_at_least_one_row() {
    let files = frictionlab::validation::protocol_files(&root().join("analysis")).unwrap();
    assert!(files.len() >= 4, "{files:?}");
    let mut rows = 0;
    for f in &files {
        let (p, _) = read::<Registry>(f).unwrap_or_else(|e| panic!("{}: {e:?}", f.display()));
        assert!(!p.validation.is_empty(), "{}", f.display());
        rows += p.validation.len();
    }
    assert!(rows >= 5);
}

#[test]
fn the_committed_validation_table_is_what_a_fresh_replay_gives() {
    let fresh = run(
        &root().join("analysis"),
        Options {
            sweep: false,
            jobs: 2,
        },
        &|_, _| {},
    )
    .unwrap();
    let old = committed();
    assert_eq!(fresh.len(), old.len());
    for (a, b) in fresh.iter().zip(&old) {
        let name = &a.validation.statistic.name;
        assert_eq!(
            a.validation, b.validation,
            "{name}: the row changed; rerun analysis/reproduce.sh"
        );
        assert_eq!(a.n, b.n, "{name}");
        assert!(
            close(a.mean.unwrap(), b.mean.unwrap()),
            "{name}: {:?} vs {:?}",
            a.mean,
            b.mean
        );
        let (ca, cb) = (a.ci.unwrap(), b.ci.unwrap());
        assert!(close(ca[0], cb[0]) && close(ca[1], cb[1]), "{name}");
        assert_eq!(a.verdict, b.verdict, "{name}");
        assert_eq!(a.verdict, verdict(a.mean, a.validation.band), "{name}");
        for ((p, x), (q, y)) in a.values.iter().zip(&b.values) {
            assert!(p == q && close(*x, *y), "{name}: {p} {x} vs {q} {y}");
        }
        assert!(
            !b.sweep.is_empty(),
            "{name}: the committed table has its sweep"
        );
    }
    // validation.md is generated from validation.json.
    let md = std::fs::read_to_string(root().join("analysis/validation.md")).unwrap();
    assert_eq!(
        md,
        table(&old),
        "analysis/validation.md is stale; rerun analysis/reproduce.sh"
    );
}

#[test]
fn a_verdict_follows_the_mean_and_the_band() {
    assert_eq!(verdict(Some(0.5), [0.3, 0.6]), "inside");
    assert_eq!(verdict(Some(0.6), [0.3, 0.6]), "inside");
    assert_eq!(verdict(Some(0.61), [0.3, 0.6]), "outside");
    assert_eq!(verdict(Some(0.29), [0.3, 0.6]), "outside");
    assert_eq!(verdict(None, [0.3, 0.6]), "no result");
}

#[test]
fn a_statistic_path_selects_participants_by_filter_and_divides_by_over() {
    let summary = json!({
        "discrimination": {"fits": [
            {"participant": "b", "level": 1.0, "weber": 0.2},
            {"participant": "a", "level": 1.0, "weber": 0.1},
            {"participant": "a", "level": 4.0, "weber": 0.05},
            {"participant": "b", "level": 4.0, "weber": 0.3},
            {"participant": "c", "level": 4.0, "weber": null},
        ]},
        "fitts": {"regression": [
            {"condition": "viscous", "participant_fits": [{"participant": "a", "intercept_s": 9.0}]},
            {"condition": "baseline", "participant_fits": [{"participant": "a", "intercept_s": 0.1}]},
        ]},
    });
    let stat = |values: &str, field: &str, over: Option<&str>| Statistic {
        name: "x".into(),
        unit: String::new(),
        values: values.into(),
        field: field.into(),
        over: over.map(Into::into),
    };
    let v = values(
        &summary,
        &stat("discrimination.fits[level=4]", "weber", None),
    )
    .unwrap();
    assert_eq!(v, vec![("a".into(), 0.05), ("b".into(), 0.3)]);
    let v = values(
        &summary,
        &stat(
            "discrimination.fits[level=4]",
            "weber",
            Some("discrimination.fits[level=1]"),
        ),
    )
    .unwrap();
    assert_eq!(v, vec![("a".into(), 0.05 / 0.1), ("b".into(), 0.3 / 0.2)]);
    let v = values(
        &summary,
        &stat(
            "fitts.regression[condition=baseline].participant_fits",
            "intercept_s",
            None,
        ),
    )
    .unwrap();
    assert_eq!(v, vec![("a".into(), 0.1)]);
    let e = select(&summary, "discrimination.fits[level=2]").unwrap_err();
    assert!(e.contains("no element of 'fits' has level = 2"), "{e}");
    let e = select(&summary, "discrimination.fits[level=1].weber").unwrap_err();
    assert!(e.contains("2 elements before 'weber'"), "{e}");
    let e = select(&summary, "fitts.nothing").unwrap_err();
    assert!(e.contains("no 'nothing'"), "{e}");
}

#[test]
fn a_sweep_point_pins_one_constant_and_leaves_every_other_trait_as_drawn() {
    let points = sweep_points();
    let base = Traits::draw(7, "sim-003", &Population::default());
    let mut seen = Vec::new();
    for (constant, end, value, population) in &points {
        let t = Traits::draw(7, "sim-003", population);
        // Exactly the pinned trait differs (or nothing, if it is not a
        // drawn trait's range).
        let changed = [
            ("stevens_exponent", t.exponent != base.exponent),
            ("answer_noise", t.answer_noise != base.answer_noise),
            ("hand_mass_kg", t.hand_mass_kg != base.hand_mass_kg),
            (
                "hand_stiffness_n_m",
                t.hand_stiffness_n_m != base.hand_stiffness_n_m,
            ),
            (
                "hand_damping_n_s_m",
                t.hand_damping_n_s_m != base.hand_damping_n_s_m,
            ),
            ("motor_noise_s", t.motor_noise_s != base.motor_noise_s),
            ("feedback_s", t.feedback_s != base.feedback_s),
            ("position_sd_m", t.position_sd_m != base.position_sd_m),
            ("force_weber", t.acuity.force != base.acuity.force),
            (
                "vibration_weber",
                t.acuity.vibration != base.acuity.vibration,
            ),
            (
                "displacement_weber",
                t.acuity.displacement != base.acuity.displacement,
            ),
            ("velocity_weber", t.acuity.velocity != base.acuity.velocity),
            (
                "viscosity_exponent",
                t.viscosity_exponent != base.viscosity_exponent,
            ),
            (
                "stiffness_exponent",
                t.stiffness_exponent != base.stiffness_exponent,
            ),
            (
                "breakaway_weight",
                t.breakaway_weight != base.breakaway_weight,
            ),
        ];
        let others: Vec<&str> = changed
            .iter()
            .filter(|(c, d)| *d && c != constant)
            .map(|(c, _)| *c)
            .collect();
        assert!(
            others.is_empty(),
            "{constant} {end}: {others:?} changed too"
        );
        assert!(
            changed.iter().any(|(c, d)| c == constant && *d),
            "{constant} {end}: pinned at {value} but unchanged"
        );
        assert_eq!(
            (t.modulus, t.stroke_m, t.explore_s),
            (base.modulus, base.stroke_m, base.explore_s),
            "{constant}"
        );
        seen.push(constant.clone());
    }
    for c in [
        "hand_damping_n_s_m",
        "stevens_exponent",
        "force_weber",
        "breakaway_weight",
    ] {
        assert_eq!(
            seen.iter().filter(|s| *s == c).count(),
            2,
            "{c}: low and high"
        );
    }
}

fn cli(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_frictionlab"))
        .args(args)
        .output()
        .unwrap()
}

/// A folder `<tmp>/validation/` holding `protocol` as `row.json`.
fn folder_with(protocol: &serde_json::Value) -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    std::fs::create_dir(dir.path().join("validation")).unwrap();
    std::fs::write(dir.path().join("validation/row.json"), protocol.to_string()).unwrap();
    dir
}

fn pointing() -> serde_json::Value {
    let text = std::fs::read_to_string(root().join("analysis/validation/pointing.json")).unwrap();
    let mut p: serde_json::Value = serde_json::from_str(&text).unwrap();
    p.as_object_mut().unwrap().remove("$schema");
    p["validation"].as_array_mut().unwrap().truncate(1);
    p["validation"][0]["participants"] = json!(3);
    p
}

#[test]
fn the_command_writes_the_table_and_its_json_and_prints_each_verdict() {
    let dir = folder_with(&pointing());
    let out = cli(&["validation", dir.path().to_str().unwrap(), "--jobs", "2"]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        stdout.contains("row.json: effective throughput, apparatus alone = "),
        "{stdout}"
    );
    let md = std::fs::read_to_string(dir.path().join("validation.md")).unwrap();
    let rows: Vec<Row> =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("validation.json")).unwrap())
            .unwrap();
    assert_eq!(rows.len(), 1);
    assert_eq!(rows[0].n, 3);
    assert!(stdout.contains(&format!("({})", rows[0].verdict)));
    assert_eq!(md, table(&rows));
    assert!(md.contains("## The sweep"));
    assert_eq!(rows[0].sweep.len(), sweep_points().len());
}

fn refused(protocol: &serde_json::Value) -> String {
    let dir = folder_with(protocol);
    let out = cli(&["validation", dir.path().to_str().unwrap(), "--no-sweep"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(
        !dir.path().join("validation.md").exists(),
        "nothing written"
    );
    assert!(
        !dir.path().join("validation.json").exists(),
        "nothing written"
    );
    String::from_utf8_lossy(&out.stderr).into_owned()
}

#[test]
fn a_bad_row_is_refused_with_its_file_and_place_and_nothing_is_written() {
    let mut p = pointing();
    p["validation"][0]["statistic"]["values"] = json!("fitts.regression[condition=nowhere]");
    let err = refused(&p);
    assert!(
        err.contains("row.json: validation[0].statistic: 'fitts.regression[condition=nowhere]': no element of 'regression' has condition = nowhere"),
        "{err}"
    );
    let mut p = pointing();
    p["validation"][0]["band"] = json!([5.0, 4.0]);
    let err = refused(&p);
    assert!(
        err.contains("row.json: validation[0].band: must be [low, high] with low < high"),
        "{err}"
    );
    let mut p = pointing();
    p.as_object_mut().unwrap().remove("validation");
    let err = refused(&p);
    assert!(
        err.contains("row.json: $.validation: no validation rows"),
        "{err}"
    );
}

#[test]
fn reproduce_sh_regenerates_the_validation_table() {
    let script = std::fs::read_to_string(root().join("analysis/reproduce.sh")).unwrap();
    assert!(script.contains("\"$bin\" validation analysis"));
}
