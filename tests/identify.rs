//! `frictionlab identify` on data made by `frictionlab render` (the
//! servo-sinusoid scenario: seed 002's identification run) from known
//! parameters, plus seed 002's measurement noise: velocity SD 3.18e-3 m/s,
//! acceleration SD 0.2379 m/s^2, force SD 0.062 N.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    reason = "tests: a panic is a failure"
)]

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::Command;

use frictionlab::friction::{ModelParams, Validate};
use frictionlab::identify::{self, DEFAULT_DV_M_S, Record};
use frictionlab::kinds::Registry;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

const VEL_SD: f64 = 3.18e-3;
const ACC_SD: f64 = 0.2379;
const FORCE_SD: f64 = 0.062;
/// The Karnopp surface: F_dynamic 2 N, B 3 N s/m, a light block on a stiff
/// coupling, so the device carries the surface's friction.
const KARNOPP: &[&str] = &[
    "--set",
    "block_mass_kg=0.2",
    "--set",
    "coupling_stiffness_n_m=100000",
    "--set",
    "coupling_damping_n_s_m=200",
    "--set",
    "viscous_n_s_m=3",
];

fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_frictionlab"))
}

/// Renders `model` on the servo-sinusoid scenario into `dir`.
fn render(dir: &Path, model: &str, set: &[&str]) -> PathBuf {
    let out = dir.join(format!("{model}.csv"));
    let status = bin()
        .args([
            "render",
            "--model",
            model,
            "--scenario",
            "servo-sinusoid",
            "--out",
        ])
        .arg(&out)
        .args(set)
        .output()
        .unwrap();
    assert!(status.status.success(), "{status:?}");
    out
}

/// The render's record with seed 002's noise on v, a and the force.
fn noisy(clean: &Record, seed: u64) -> Record {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut add = |xs: &[f64], sd: f64| -> Vec<f64> {
        let n = Normal::new(0.0, sd).unwrap();
        xs.iter().map(|x| x + n.sample(&mut rng)).collect()
    };
    Record {
        v_m_s: add(&clean.v_m_s, VEL_SD),
        a_m_s2: add(&clean.a_m_s2, ACC_SD),
        force_n: add(&clean.force_n, FORCE_SD),
        ..clean.clone()
    }
}

fn write_csv(path: &Path, r: &Record) {
    let mut text = String::from("t_s,x_m,v_m_s,a_m_s2,applied_force_n\n");
    for i in 0..r.t_s.len() {
        writeln!(
            text,
            "{},{},{},{},{}",
            r.t_s[i], r.x_m[i], r.v_m_s[i], r.a_m_s2[i], r.force_n[i]
        )
        .unwrap();
    }
    std::fs::write(path, text).unwrap();
}

fn identify_json(path: &Path, args: &[&str]) -> serde_json::Value {
    let out = bin().arg("identify").arg(path).args(args).output().unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).unwrap()
}

fn within(value: f64, truth: f64, tolerance: f64) -> bool {
    (value - truth).abs() <= tolerance * truth.abs()
}

#[test]
fn karnopp_fit_recovers_c_and_b_within_5_percent_under_seed_noise() {
    let dir = tempfile::tempdir().unwrap();
    let clean = identify::read_csv(&render(dir.path(), "karnopp", KARNOPP)).unwrap();
    let data = dir.path().join("noisy.csv");
    write_csv(&data, &noisy(&clean, 1));
    let json = identify_json(
        &data,
        &[
            "--model", "karnopp", "--vel-sd", "3.18e-3", "--acc-sd", "0.2379",
        ],
    );
    let fit = &json["fit"]["corrected"];
    let v = |k: &str| fit[k]["value"].as_f64().unwrap();
    eprintln!("corrected fit: {fit}");
    for (k, truth) in [
        ("c_pos_n", 2.0),
        ("c_neg_n", 2.0),
        ("b_pos_n_s_m", 3.0),
        ("b_neg_n_s_m", 3.0),
    ] {
        assert!(within(v(k), truth, 0.05), "{k} = {} (true {truth})", v(k));
        assert!(fit[k]["std_error"].as_f64().unwrap() > 0.0);
    }
    assert!(json["fit"]["excluded_in_band"].as_u64().unwrap() > 0);
    // The residual is the force noise (plus the noise on m a).
    let rms = fit["residual_rms_n"].as_f64().unwrap();
    assert!(rms > FORCE_SD && rms < 0.3, "residual RMS {rms}");
    // The model block pastes into a protocol.
    let model: ModelParams = serde_json::from_value(json["protocol_model"].clone()).unwrap();
    assert!(model.validate().is_empty());
    let ModelParams::Karnopp(k) = model else {
        panic!("not a karnopp block")
    };
    assert!(within(k.f_dynamic_n, 2.0, 0.05) && within(k.viscous_n_s_m, 3.0, 0.05));
}

#[test]
fn the_corrected_estimator_is_less_biased_than_plain_least_squares() {
    let dir = tempfile::tempdir().unwrap();
    let clean = identify::read_csv(&render(dir.path(), "karnopp", KARNOPP)).unwrap();
    // The noiseless fit is the reference: the device's effective mass
    // includes the coupled block's.
    let truth = identify::fit_karnopp(&clean, DEFAULT_DV_M_S, Some((0.0, 0.0)))
        .unwrap()
        .plain_least_squares;
    let runs = 20;
    let (mut plain, mut corrected) = ([0.0; 5], [0.0; 5]);
    for seed in 0..runs {
        let fit =
            identify::fit_karnopp(&noisy(&clean, seed), DEFAULT_DV_M_S, Some((VEL_SD, ACC_SD)))
                .unwrap();
        for (sum, e) in [
            (&mut plain, &fit.plain_least_squares),
            (&mut corrected, &fit.corrected),
        ] {
            let values = [
                e.mass_kg.value,
                e.c_pos_n.value,
                e.b_pos_n_s_m.value,
                e.c_neg_n.value,
                e.b_neg_n_s_m.value,
            ];
            for (s, v) in sum.iter_mut().zip(values) {
                *s += v / f64::from(u32::try_from(runs).unwrap());
            }
        }
    }
    let reference = [
        truth.mass_kg.value,
        truth.c_pos_n.value,
        truth.b_pos_n_s_m.value,
        truth.c_neg_n.value,
        truth.b_neg_n_s_m.value,
    ];
    let bias = |mean: &[f64; 5]| -> Vec<f64> {
        mean.iter()
            .zip(reference)
            .map(|(m, r)| (m - r) / r)
            .collect()
    };
    let (bp, bc) = (bias(&plain), bias(&corrected));
    eprintln!(
        "relative bias over {runs} runs (m, Cp, bp, Cn, bn): plain {bp:.4?}, corrected {bc:.4?}"
    );
    // The acceleration noise attenuates the mass in plain least squares.
    assert!(bp[0] < -0.02, "plain mass bias {}", bp[0]);
    assert!(
        bc[0].abs() < bp[0].abs() / 4.0,
        "corrected mass bias {}",
        bc[0]
    );
    let total = |b: &[f64]| b.iter().map(|x| x.abs()).sum::<f64>();
    assert!(total(&bc) < total(&bp));
}

#[test]
fn the_noise_is_estimated_from_the_data_when_not_given() {
    let dir = tempfile::tempdir().unwrap();
    let clean = identify::read_csv(&render(dir.path(), "karnopp", KARNOPP)).unwrap();
    let fit = identify::fit_karnopp(&noisy(&clean, 3), DEFAULT_DV_M_S, None).unwrap();
    assert_eq!(fit.noise.source, "estimated");
    assert!(
        within(fit.noise.velocity_sd_m_s, VEL_SD, 0.05),
        "{:?}",
        fit.noise
    );
    assert!(
        within(fit.noise.acceleration_sd_m_s2, ACC_SD, 0.05),
        "{:?}",
        fit.noise
    );
    assert!(within(fit.corrected.c_pos_n.value, 2.0, 0.05));
}

#[test]
fn dahl_fit_recovers_fc_within_5_percent_under_seed_noise() {
    let dir = tempfile::tempdir().unwrap();
    let clean = identify::read_csv(&render(dir.path(), "dahl", &[])).unwrap();
    let data = dir.path().join("noisy.csv");
    write_csv(&data, &noisy(&clean, 2));
    let json = identify_json(
        &data,
        &[
            "--model", "dahl", "--sigma", "20000", "--vel-sd", "3.18e-3", "--acc-sd", "0.2379",
        ],
    );
    let fit = &json["fit"];
    eprintln!("dahl fit: {fit}");
    assert_eq!(fit["converged"], true);
    assert_eq!(fit["corrected_converged"], true);
    let v = |which: &str, k: &str| fit[which][k]["value"].as_f64().unwrap();
    for k in ["fc_pos_n", "fc_neg_n"] {
        assert!(
            within(v("corrected", k), 2.0, 0.05),
            "{k} = {}",
            v("corrected", k)
        );
        assert!(fit["corrected"][k]["std_error"].as_f64().unwrap() > 0.0);
    }
    // Least squares attenuates the mass (the acceleration noise); the
    // correction restores it, and with it b.
    assert!(v("least_squares", "mass_kg") < 0.692 * 0.97);
    assert!(
        within(v("corrected", "mass_kg"), 0.692, 0.02),
        "{}",
        v("corrected", "mass_kg")
    );
    let b_error = |which: &str| (v(which, "viscous_n_s_m") - 0.5).abs();
    assert!(b_error("corrected") < b_error("least_squares"));
    let model: ModelParams = serde_json::from_value(json["protocol_model"].clone()).unwrap();
    assert!(model.validate().is_empty());
}

#[test]
fn velocity_and_acceleration_are_derived_from_position_when_missing() {
    let dir = tempfile::tempdir().unwrap();
    let clean = identify::read_csv(&render(dir.path(), "karnopp", KARNOPP)).unwrap();
    let mut text = String::from("t_s,x_m,applied_force_n\n");
    for i in 0..clean.t_s.len() {
        writeln!(
            text,
            "{},{},{}",
            clean.t_s[i], clean.x_m[i], clean.force_n[i]
        )
        .unwrap();
    }
    let path = dir.path().join("position-only.csv");
    std::fs::write(&path, text).unwrap();
    let json = identify_json(
        &path,
        &["--model", "karnopp", "--vel-sd", "0", "--acc-sd", "0"],
    );
    let signals = json["signals"].to_string();
    assert!(signals.contains("derived from x_m"), "{signals}");
    let fit = &json["fit"]["corrected"];
    for (k, truth) in [
        ("c_pos_n", 2.0),
        ("c_neg_n", 2.0),
        ("b_pos_n_s_m", 3.0),
        ("b_neg_n_s_m", 3.0),
    ] {
        let v = fit[k]["value"].as_f64().unwrap();
        assert!(within(v, truth, 0.05), "{k} = {v}");
    }
}

#[test]
fn bad_input_names_the_place_and_exits_2() {
    let dir = tempfile::tempdir().unwrap();
    let rows = |f: &dyn Fn(usize) -> String| -> String { (0..100).map(f).collect() };
    let cases: Vec<(&str, String, &str)> = vec![
        (
            "no-force.csv",
            format!("t_s,v_m_s\n{}", rows(&|i| format!("{i},0.1\n"))),
            "column 'applied_force_n' (or 'force_n'): missing",
        ),
        (
            "no-motion-column.csv",
            format!("t_s,force_n\n{}", rows(&|i| format!("{i},1\n"))),
            "column 'v_m_s' (or 'x_m'): missing",
        ),
        (
            "short.csv",
            "t_s,v_m_s,a_m_s2,force_n\n0,1,0,1\n1,1,0,1\n".into(),
            "too few samples: 2 rows, at least 50 needed",
        ),
        (
            "one-way.csv",
            format!(
                "t_s,v_m_s,a_m_s2,applied_force_n\n{}",
                rows(&|i| format!("{},{},0,2\n", i as f64 * 1e-3, 0.05 + i as f64 * 1e-3))
            ),
            "no motion towards -x: 0 samples faster than DV = 0.03 m/s, at least 20 needed",
        ),
        (
            "nan.csv",
            format!(
                "t_s,v_m_s,a_m_s2,applied_force_n\n0,0.1,0,1\n0.001,NaN,0,1\n{}",
                rows(&|i| format!("{},0.1,0,1\n", 0.002 + i as f64 * 1e-3))
            ),
            ": 3:7: column 'v_m_s': 'NaN' is not a finite number",
        ),
        (
            "text.csv",
            format!(
                "t_s,v_m_s,a_m_s2,applied_force_n\n{}0.5,0.1,0,abc\n",
                rows(&|i| format!("{},0.1,0,1\n", i as f64 * 1e-3))
            ),
            ": 102:11: column 'applied_force_n': 'abc' is not a finite number",
        ),
        (
            "time.csv",
            format!(
                "t_s,v_m_s,a_m_s2,applied_force_n\n{}",
                rows(&|i| format!("{},0.1,0,1\n", (i % 60) as f64 * 1e-3))
            ),
            ": 62:1: column 't_s': time must increase from row to row",
        ),
        (
            // Finite numbers whose products overflow: refused, not nulls.
            "huge.csv",
            format!(
                "t_s,x_m,v_m_s,a_m_s2,applied_force_n\n{}",
                rows(&|i| format!(
                    "{},{},{},1e300,1e300\n",
                    i as f64 * 1e-3,
                    1e300 * (i % 3) as f64,
                    1e300 * ((i % 3) as f64 - 1.0)
                ))
            ),
            "the fit is not finite: the values overflow",
        ),
    ];
    for (name, text, message) in cases {
        let path = dir.path().join(name);
        std::fs::write(&path, text).unwrap();
        let out = bin()
            .arg("identify")
            .arg(&path)
            .args(["--model", "karnopp"])
            .output()
            .unwrap();
        assert_eq!(out.status.code(), Some(2), "{name}");
        let err = String::from_utf8(out.stderr).unwrap();
        let place = format!("error: {}: ", path.display());
        assert!(err.starts_with(&place), "{name}: {err}");
        assert!(err.contains(message), "{name}: {err}");
        assert!(out.stdout.is_empty(), "{name}");
    }
    let out = bin()
        .args(["identify", "x.csv", "--model", "lugre"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("error: --model: 'lugre'"));
}

#[test]
fn sessions_record_each_trials_device_stream_and_identify_reads_it() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("results");
    let protocol = format!("{}/protocols/fitts-quick.json", env!("CARGO_MANIFEST_DIR"));
    let status = bin()
        .args([
            "run",
            &protocol,
            "--participant",
            "s1",
            "--responder",
            "sim",
        ])
        .args(["--pace", "1000", "--seed", "2", "--out"])
        .arg(&out)
        .output()
        .unwrap();
    assert!(status.status.success(), "{status:?}");
    let log = out.join("logs/study-fittsquick_subject-s1_session-1_log.jsonl");
    let read = frictionlab::results::read_log::<Registry>(&log).unwrap();
    assert_eq!(read.trials.len(), 4);
    let mut identified = 0;
    for r in &read.trials {
        let path = out.join(format!(
            "streams/study-fittsquick_subject-s1_session-1_trial-{}_run-1_stream.csv",
            r.trial
        ));
        let text = std::fs::read_to_string(&path).unwrap();
        let mut lines = text.lines();
        assert_eq!(
            lines.next(),
            Some("t_s,x_m,v_m_s,force_n,vibration,render,selected,watchdog,tick")
        );
        // The simulated device has no device tick: `tick` is empty.
        let rows: Vec<Vec<f64>> = lines
            .map(|l| {
                let (values, tick) = l.rsplit_once(',').unwrap();
                assert_eq!(tick, "", "{l}");
                values.split(',').map(|x| x.parse().unwrap()).collect()
            })
            .collect();
        // Every loop tick of the trial, at 1 kHz.
        let expected = (r.ended_s - r.started_s).secs() * 1000.0;
        assert!(
            (rows.len() as f64 - expected).abs() <= 2.0,
            "trial {}: {} rows for {expected} ticks",
            r.trial,
            rows.len()
        );
        assert!((rows[0][0] - r.started_s.secs()).abs() <= 1.5e-3);
        let data = serde_json::to_value(&r.data).unwrap();
        if data["condition"] == "high_stiction" {
            let json = identify_json(&path, &["--model", "karnopp"]);
            assert_eq!(json["rows"].as_u64(), u64::try_from(rows.len()).ok());
            assert_eq!(json["signals"][0], "force: -force_n (force on the hand)");
            assert!(json["fit"]["corrected"]["c_pos_n"]["value"].is_f64());
            identified += 1;
        }
    }
    assert_eq!(identified, 1, "the high_stiction trial's stream");
}

proptest::proptest! {
    #![proptest_config(proptest::test_runner::Config::with_cases(64))]

    /// Any record that parses, however odd its numbers (tiny, huge, constant,
    /// alternating), gets a fit with finite values or an error naming its
    /// file: never a panic, never a `null` in the report.
    #[test]
    fn any_parsed_record_gets_a_finite_fit_or_an_error(
        rows in proptest::collection::vec(
            (-1.0_f64..1.0, -1.0_f64..1.0, -1.0_f64..1.0, -1.0_f64..1.0), 50..200),
        scale in proptest::sample::select(vec![1e-300, 1e-6, 1.0, 1e6, 1e150, 1e300]),
        sigma in proptest::sample::select(vec![1.0, 2e4, 1e9]),
        exponent in proptest::sample::select(vec![0.3, 1.0, 4.0]),
        dv in proptest::sample::select(vec![0.0, 0.03, 0.5]),
    ) {
        let mut text = String::from("t_s,x_m,v_m_s,a_m_s2,applied_force_n\n");
        for (i, (x, v, a, f)) in rows.iter().enumerate() {
            let t = i as f64 * 1e-3;
            writeln!(text, "{t},{},{},{},{}", x * scale, v * scale, a * scale, f * scale).unwrap();
        }
        let record = identify::parse_csv("odd.csv", &text).unwrap();
        let check = |values: Vec<f64>| {
            for v in values {
                proptest::prop_assert!(v.is_finite(), "{v}");
            }
            Ok(())
        };
        match identify::fit_karnopp(&record, dv, None) {
            Ok(fit) => {
                let json = serde_json::to_string(&fit).unwrap();
                proptest::prop_assert!(!json.contains("null"), "{json}");
                check(vec![fit.corrected.c_pos_n.value, fit.corrected.mass_kg.std_error])?;
            }
            Err(e) => proptest::prop_assert_eq!(e.place, "odd.csv"),
        }
        match identify::fit_dahl(&record, sigma, exponent, dv, None) {
            Ok(fit) => {
                let json = serde_json::to_string(&fit).unwrap();
                proptest::prop_assert!(!json.contains("null"), "{json}");
                check(vec![fit.corrected.fc_pos_n.value, fit.least_squares.mass_kg.value])?;
            }
            Err(e) => proptest::prop_assert_eq!(e.place, "odd.csv"),
        }
    }
}
