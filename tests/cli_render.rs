//! `frictionlab render` from the outside: files, columns, determinism, and
//! bad input (exit 2, `error: --set NAME: ...`, nothing written).

#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    reason = "a failed unwrap is a failed test"
)]

use std::path::Path;
use std::process::{Command, Output};

fn frictionlab(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_frictionlab"))
        .args(args)
        .output()
        .expect("runs")
}

fn render(dir: &Path, model: &str, scenario: &str, extra: &[&str]) -> Output {
    let out = dir.join("out.csv");
    let mut args = vec![
        "render",
        "--model",
        model,
        "--scenario",
        scenario,
        "--out",
        out.to_str().unwrap(),
    ];
    args.extend_from_slice(extra);
    frictionlab(&args)
}

#[test]
fn render_writes_the_time_series_and_its_figure() {
    let dir = tempfile::tempdir().unwrap();
    let plot = dir.path().join("fig/plot.svg");
    let o = render(
        dir.path(),
        "stick-slip-tactile",
        "sinusoidal-stroke",
        &["--plot", plot.to_str().unwrap()],
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let csv = std::fs::read_to_string(dir.path().join("out.csv")).unwrap();
    let mut lines = csv.lines();
    assert_eq!(
        lines.next(),
        Some("t_s,x_m,v_m_s,force_n,state,slip_onset,vibration")
    );
    assert_eq!(lines.count(), 5001, "1 s at 5 kHz, both ends");
    assert!(csv.contains(",stick,") && csv.contains(",slip,"));
    let svg = std::fs::read_to_string(&plot).unwrap();
    assert!(svg.starts_with("<svg") && svg.contains("vibration drive"));
    assert!(String::from_utf8_lossy(&o.stdout).contains("stick-to-slip transitions"));
}

#[test]
fn force_models_have_no_vibration_column() {
    let dir = tempfile::tempdir().unwrap();
    let o = render(dir.path(), "karnopp", "coupled-block", &[]);
    assert!(o.status.success());
    let csv = std::fs::read_to_string(dir.path().join("out.csv")).unwrap();
    assert_eq!(
        csv.lines().next(),
        Some("t_s,x_m,v_m_s,force_n,state,slip_onset")
    );
}

#[test]
fn the_same_render_gives_the_same_bytes() {
    let (a, b) = (tempfile::tempdir().unwrap(), tempfile::tempdir().unwrap());
    for d in [&a, &b] {
        assert!(
            render(
                d.path(),
                "god-object-time-varying",
                "spidar-slide",
                &["--set", "scenario.slide_speed_m_s=0.04"]
            )
            .status
            .success()
        );
    }
    let read = |d: &tempfile::TempDir| std::fs::read(d.path().join("out.csv")).unwrap();
    assert_eq!(read(&a), read(&b));
}

#[test]
fn set_changes_model_scenario_rate_and_limit() {
    let dir = tempfile::tempdir().unwrap();
    let o = render(
        dir.path(),
        "viscous",
        "coupled-block",
        &[
            "--set",
            "damping_n_s_m=10",
            "--set",
            "rate_hz=500",
            "--set",
            "force_limit_n=0.1",
            "--set",
            "scenario.reaches=1",
        ],
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let csv = std::fs::read_to_string(dir.path().join("out.csv")).unwrap();
    // 1 reach: 0.3 + 0.6 + 0.3 s at 500 Hz.
    assert_eq!(csv.lines().count(), 1 + 601);
    let max = csv
        .lines()
        .skip(1)
        .map(|l| l.split(',').nth(3).unwrap().parse::<f64>().unwrap().abs())
        .fold(0.0, f64::max);
    assert!((max - 0.1).abs() < 1e-12, "clamped at the limit: {max}");
}

#[test]
#[expect(clippy::too_many_lines, reason = "one table row per bad input")]
fn bad_input_exits_2_naming_the_flag_and_writes_nothing() {
    let cases: &[(&str, &str, &[&str], &str)] = &[
        (
            "karnopp",
            "coupled-block",
            &["--set", "mu_x=1"],
            "error: --set mu_x: unknown parameter of model karnopp; known: ",
        ),
        (
            "stick-slip-force",
            "sinusoidal-stroke",
            &["--set", "mu_s=0.3"],
            "error: --set mu_s: must be greater than mu_k (0.4), got 0.3",
        ),
        (
            "stick-slip-force",
            "sinusoidal-stroke",
            &["--set", "mass_kg=-0.1"],
            "error: --set mass_kg: must be greater than 0, got -0.1",
        ),
        (
            "dahl",
            "coupled-block",
            &["--set", "sigma_n_m=inf"],
            "error: --set sigma_n_m: must be finite, got inf",
        ),
        (
            "dahl",
            "coupled-block",
            &["--set", "sigma_n_m=NaN"],
            "error: --set sigma_n_m: must be finite, got NaN",
        ),
        (
            "dahl",
            "coupled-block",
            &["--set", "sigma_n_m"],
            "error: --set sigma_n_m: expected NAME=VALUE",
        ),
        (
            "dahl",
            "coupled-block",
            &["--set", "sigma_n_m=soft"],
            "error: --set sigma_n_m: expected a number, got 'soft'",
        ),
        (
            "god-object-constant",
            "spidar-slide",
            &["--set", "mu_s=0.5"],
            "error: --set static_friction.mu_s: must be greater than mu_d (0.6), got 0.5",
        ),
        (
            "karnopp",
            "spidar-slide",
            &["--set", "scenario.hand_mass_kg=0"],
            "error: --set scenario.hand_mass_kg: must be greater than 0, got 0",
        ),
        (
            "karnopp",
            "spidar-slide",
            &["--set", "rate_hz=-5"],
            "error: --set rate_hz: must be finite and greater than 0, got -5",
        ),
        (
            "karnopp",
            "spidar-slide",
            &["--set", "force_limit_n=0"],
            "error: --set force_limit_n: must be greater than 0, got 0",
        ),
        (
            "karnopp",
            "spidar-slide",
            &["--set", "scenario.after_onset_s=1e9"],
            "error: --scenario: the run would take",
        ),
        (
            "coulomb",
            "spidar-slide",
            &[],
            "error: --model: unknown model 'coulomb'; known: god-object-constant,",
        ),
        (
            "karnopp",
            "slide",
            &[],
            "error: --scenario: unknown scenario 'slide'; known: spidar-slide,",
        ),
        (
            "karnopp",
            "spidar-slide",
            &["--plot", "x.png"],
            "error: --plot: x.png: only SVG figures",
        ),
    ];
    for (model, scenario, extra, message) in cases {
        let dir = tempfile::tempdir().unwrap();
        let o = render(dir.path(), model, scenario, extra);
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{model} {extra:?}: {stderr}");
        assert!(stderr.starts_with(message), "{model} {extra:?}: {stderr}");
        assert!(!stderr.contains("panicked"));
        assert_eq!(
            std::fs::read_dir(dir.path()).unwrap().count(),
            0,
            "nothing written"
        );
    }
}

#[test]
fn several_bad_settings_are_all_reported() {
    let dir = tempfile::tempdir().unwrap();
    let o = render(
        dir.path(),
        "karnopp",
        "coupled-block",
        &[
            "--set",
            "a=1",
            "--set",
            "block_mass_kg=-1",
            "--set",
            "scenario.b=2",
        ],
    );
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2));
    assert_eq!(stderr.lines().count(), 3, "{stderr}");
    assert!(stderr.lines().all(|l| l.starts_with("error: --set ")));
}

#[test]
fn missing_flags_and_no_arguments_exit_2_without_a_panic() {
    for args in [
        &[][..],
        &["render"][..],
        &["render", "--model", "dahl"][..],
        &["bogus"][..],
    ] {
        let o = frictionlab(args);
        assert_eq!(o.status.code(), Some(2), "{args:?}");
        assert!(!String::from_utf8_lossy(&o.stderr).contains("panicked"));
    }
}

#[test]
fn models_lists_every_model_and_scenario_with_defaults() {
    let o = frictionlab(&["models"]);
    assert!(o.status.success());
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["models"].as_array().unwrap().len(), 8);
    assert_eq!(v["scenarios"].as_array().unwrap().len(), 4);
    assert_eq!(v["scenarios"][3]["scenario"], "servo-sinusoid");
    assert_eq!(v["models"][4]["model"], "karnopp");
    assert_eq!(v["models"][4]["f_dynamic_n"], 2.0);
}

#[test]
fn render_in_f32_runs_the_devices_arithmetic_and_refuses_other_widths() {
    let dir = tempfile::tempdir().unwrap();
    let read = |o: &Output| {
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        std::fs::read_to_string(dir.path().join("out.csv")).unwrap()
    };
    let wide = read(&render(
        dir.path(),
        "god-object-time-varying",
        "spidar-slide",
        &[],
    ));
    let o = render(
        dir.path(),
        "god-object-time-varying",
        "spidar-slide",
        &["--float", "f32"],
    );
    let narrow = read(&o);
    assert!(String::from_utf8_lossy(&o.stdout).contains("Hz in f32"));
    // Same run, other arithmetic: same shape, not the same bits.
    assert_eq!(wide.lines().count(), narrow.lines().count());
    assert_ne!(wide, narrow);
    let o = render(dir.path(), "karnopp", "coupled-block", &["--float", "f16"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("f16"));
}
