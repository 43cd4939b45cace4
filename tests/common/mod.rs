//! Helpers shared by the integration tests.

#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    reason = "a failed unwrap is a failed test"
)]
#![allow(dead_code, reason = "each test binary uses a different subset")]

use frictionlab::friction::{ForceLimit, Input, ModelParams, Output, Real, Stepper};
use frictionlab::scenario::{self, Sample, ScenarioParams};
use frictionlab::settings;

pub mod window;

/// `TTYPort::pair` is not thread-safe (it reads the new pseudo-terminal's
/// name from a static buffer: two at once can get each other's): the tests
/// of a binary that make pairs take turns here. (Issue 63: a 2DIY test's
/// session once read another test's noise.)
pub static PTY: std::sync::Mutex<()> = std::sync::Mutex::new(());

/// A new pseudo-terminal pair (master, slave), made in turn ([`PTY`]).
pub fn pty_pair() -> (serialport::TTYPort, serialport::TTYPort) {
    let _turn = PTY
        .lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner);
    serialport::TTYPort::pair().unwrap()
}

/// Default parameters of `model` with `overrides` applied.
pub fn model(name: &str, overrides: &[(&str, &str)]) -> ModelParams {
    let base = ModelParams::default_for(name).expect("known model");
    settings::apply(&base, "model", name, overrides).expect("valid overrides")
}

/// Defines each test twice, with the friction core computing in `f64`
/// (the host) and in `f32` (what the device runs): `name::f64`,
/// `name::f32`. The body is generic over the float `T`.
#[macro_export]
macro_rules! in_both_floats {
    ($($(#[doc = $doc:literal])* fn $name:ident<$t:ident>() $body:block)*) => {
        $(
            $(#[doc = $doc])*
            mod $name {
                #[allow(unused_imports)]
                use super::*;
                fn run<$t: frictionlab::friction::Real>() $body
                #[test]
                fn f64() {
                    run::<f64>();
                }
                #[test]
                fn f32() {
                    run::<f32>();
                }
            }
        )*
    };
}

/// Runs `model` through the default `scenario` at the model's loop rate,
/// the model computing in `T`.
pub fn render<T: Real>(model: &ModelParams, scenario: &str) -> Vec<Sample> {
    let scenario = ScenarioParams::default_for(scenario).expect("known scenario");
    let settings = frictionlab::friction::StepParams {
        rate_hz: model.loop_rate_hz(),
        float: T::FLOAT,
        ..Default::default()
    };
    scenario::run(model, &scenario, settings).expect("scenario runs")
}

/// Times of the stick-to-slip transitions.
pub fn onsets(samples: &[Sample]) -> Vec<f64> {
    samples
        .iter()
        .filter(|s| s.slip_onset)
        .map(|s| s.t_s)
        .collect()
}

/// Peak-to-peak of `value` over samples with `t0 <= t_s <= t1`.
pub fn peak_to_peak(samples: &[Sample], t0: f64, t1: f64, value: impl Fn(&Sample) -> f64) -> f64 {
    let (lo, hi) = samples
        .iter()
        .filter(|s| s.t_s >= t0 && s.t_s <= t1)
        .map(value)
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
            (lo.min(v), hi.max(v))
        });
    hi - lo
}

/// Steps a fresh model in `T` at `dt` through `inputs`.
pub fn drive<T: Real>(params: &ModelParams, dt: f64, inputs: &[Input]) -> Vec<Output> {
    let mut f = Stepper::new(
        params,
        T::FLOAT,
        ForceLimit::default(),
        inputs.first().map_or(0.0, |i| i.x_m),
    )
    .expect("valid params");
    inputs.iter().map(|&i| f.step(dt, i)).collect()
}

/// A smooth back-and-forth motion with rests: `n` samples at `dt`, amplitude
/// `a` metres.
pub fn wiggle(n: usize, dt: f64, a: f64) -> Vec<Input> {
    (0..n)
        .map(|i| {
            let t = i as f64 * dt;
            let w1 = std::f64::consts::TAU * 1.3;
            let w2 = std::f64::consts::TAU * 3.1;
            Input {
                x_m: a * ((w1 * t).sin() + 0.3 * (w2 * t).sin()),
                v_m_s: a * (w1 * (w1 * t).cos() + 0.3 * w2 * (w2 * t).cos()),
            }
        })
        .collect()
}

/// Starts `frictionlab device-emulator PATH` and waits until it has linked
/// its pseudo-terminal at `path`.
pub fn emulator(path: &std::path::Path) -> std::process::Child {
    emulator_with(path, &[])
}

/// [`emulator`] with more options (`--on-board`).
pub fn emulator_with(path: &std::path::Path, options: &[&str]) -> std::process::Child {
    let child = std::process::Command::new(env!("CARGO_BIN_EXE_frictionlab"))
        .args(["device-emulator", path.to_str().unwrap()])
        .args(options)
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let start = std::time::Instant::now();
    while std::fs::read_link(path).is_err() && start.elapsed() < std::time::Duration::from_secs(10)
    {
        std::thread::sleep(std::time::Duration::from_millis(10));
    }
    child
}

/// The completed trials of a session log, in plan order.
pub fn completed_trials(log: &frictionlab::kinds::ReadLog) -> Vec<usize> {
    let mut completed: Vec<usize> = log
        .trials
        .iter()
        .filter(|r| r.status == frictionlab::protocol::engine::Status::Completed)
        .map(|r| r.trial)
        .collect();
    completed.sort_unstable();
    completed
}

/// What re-rendering a results folder's streams found.
pub struct Rerenders {
    pub streams: usize,
    /// Rows replayed.
    pub rows: usize,
    /// Largest force and vibration differences.
    pub force: f64,
    pub vibration: f64,
    /// Who rendered (each mode once).
    pub modes: Vec<String>,
    /// Each stream's report.
    pub reports: Vec<serde_json::Value>,
}

/// Re-renders every stream of a results folder.
pub fn rerender_all(out: &std::path::Path) -> Rerenders {
    let mut streams: Vec<_> = std::fs::read_dir(out.join("streams"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    streams.sort();
    let mut all = Rerenders {
        streams: streams.len(),
        rows: 0,
        force: 0.0,
        vibration: 0.0,
        modes: Vec::new(),
        reports: Vec::new(),
    };
    for s in &streams {
        let o = std::process::Command::new(env!("CARGO_BIN_EXE_frictionlab"))
            .arg("rerender")
            .arg(s)
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let r: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        all.rows +=
            usize::try_from(r["rows"].as_u64().unwrap() - r["skipped"].as_u64().unwrap()).unwrap();
        all.force = all.force.max(r["max_force_diff_n"].as_f64().unwrap());
        all.vibration = all.vibration.max(r["max_vibration_diff"].as_f64().unwrap());
        for m in r["modes"].as_array().unwrap() {
            let m = m.as_str().unwrap().to_owned();
            if !all.modes.contains(&m) {
                all.modes.push(m);
            }
        }
        all.reports.push(r);
    }
    all
}

/// The session logs of a results folder, sorted by name.
pub fn session_logs(results: &std::path::Path) -> Vec<std::path::PathBuf> {
    let mut logs: Vec<std::path::PathBuf> = std::fs::read_dir(results.join("logs"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    logs.sort();
    logs
}

/// The venv's Python and the liblsl its pylsl ships, if installed.
pub fn pylsl() -> Option<(std::path::PathBuf, std::path::PathBuf)> {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    let venv = std::env::var_os("FRICTIONLAB_TEST_VENV")
        .map_or_else(|| root.join("target/lsl-venv"), std::path::PathBuf::from);
    let python = venv.join("bin/python");
    let lib = std::fs::read_dir(venv.join("lib"))
        .ok()?
        .filter_map(Result::ok)
        .map(|d| d.path().join("site-packages/pylsl/lib/liblsl.so"))
        .find(|p| p.exists())?;
    python.exists().then_some((python, lib))
}

/// LabRecorder's recording code and pyxdf beside pylsl in `python`'s
/// environment: true, or a skip (outside CI) or a failure (under CI).
pub fn need_labrecorder(python: &std::path::Path) -> bool {
    let found = std::process::Command::new(python)
        .args(["-c", "import labrecorder, pyxdf"])
        .stderr(std::process::Stdio::null())
        .status()
        .is_ok_and(|s| s.success());
    assert!(
        found || std::env::var_os("CI").is_none(),
        "labrecorder and pyxdf are not installed in target/lsl-venv: .ci/run installs them"
    );
    if !found {
        eprintln!("skipped: labrecorder and pyxdf are not installed in target/lsl-venv");
    }
    found
}

/// pylsl, or a skip (outside CI) or a failure (under CI).
pub fn need_pylsl() -> Option<(std::path::PathBuf, std::path::PathBuf)> {
    let found = pylsl();
    assert!(
        found.is_some() || std::env::var_os("CI").is_none(),
        "pylsl is not installed in target/lsl-venv: .ci/run installs it"
    );
    if found.is_none() {
        eprintln!("skipped: pylsl is not installed in target/lsl-venv (.ci/run installs it)");
    }
    found
}

/// Every shipped protocol file (`protocols/*.json` but the schema), sorted.
pub fn shipped_protocols() -> Vec<std::path::PathBuf> {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("protocols");
    let mut protocols: Vec<std::path::PathBuf> = std::fs::read_dir(root)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| {
            p.extension().is_some_and(|x| x == "json")
                && !p.to_string_lossy().ends_with(".schema.json")
        })
        .collect();
    protocols.sort();
    protocols
}

/// Waits (up to a minute) until the session log at `log` holds `n` trial
/// records.
pub fn wait_for_records(log: &std::path::Path, n: usize) {
    use frictionlab::kinds::Registry;
    let start = std::time::Instant::now();
    while frictionlab::results::read_log::<Registry>(log).map_or(0, |l| l.trials.len()) < n
        && start.elapsed() < std::time::Duration::from_mins(1)
    {
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
}

/// Kills `first` (SIGKILL) once its log at `log` holds two records, runs
/// `resume` to the end, and checks that the session ended with every
/// planned trial completed exactly once; returns the log as it was before
/// the resume and after.
pub fn kill_9_and_resume(
    protocol: &str,
    log: &std::path::Path,
    mut first: std::process::Child,
    resume: impl FnOnce() -> std::process::Child,
) -> (frictionlab::kinds::ReadLog, frictionlab::kinds::ReadLog) {
    use frictionlab::kinds::Registry;
    use frictionlab::results::read_log;
    wait_for_records(log, 2);
    first.kill().unwrap(); // SIGKILL
    first.wait().unwrap();
    let before = read_log::<Registry>(log).unwrap();
    assert!(
        !before.ended && before.trials.len() >= 2,
        "{protocol}: killed after 2 trials"
    );
    let o = resume().wait_with_output().unwrap();
    assert!(
        o.status.success(),
        "{protocol}: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    let read = read_log::<Registry>(log).unwrap();
    assert!(read.ended, "{protocol}");
    assert_eq!(
        completed_trials(&read),
        (0..read.header.planned_trials).collect::<Vec<_>>(),
        "{protocol}: every planned trial completed exactly once"
    );
    (before, read)
}

/// A session on a device that is lost mid-trial: once `session`'s log at
/// `log` holds one record and 0.7 s more have passed (the next trial under
/// way), `stop` stops the device; 0.6 s later `restart` starts it again.
/// Checks that the session ended, the trial under way was aborted, and
/// every planned trial completed exactly once.
pub fn lost_mid_trial(
    log: &std::path::Path,
    session: std::process::Child,
    stop: impl FnOnce(),
    restart: impl FnOnce() -> std::process::Child,
) {
    use frictionlab::kinds::Registry;
    wait_for_records(log, 1);
    std::thread::sleep(std::time::Duration::from_millis(700)); // into the next trial
    stop();
    std::thread::sleep(std::time::Duration::from_millis(600));
    let mut device = restart();
    let o = session.wait_with_output().unwrap();
    let _ = device.kill();
    let _ = device.wait();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let read = frictionlab::results::read_log::<Registry>(log).unwrap();
    let aborted: Vec<_> = read
        .trials
        .iter()
        .filter(|r| r.status.as_str() != "completed")
        .collect();
    println!(
        "{} records: {} aborted ({:?}), every planned trial completed once",
        read.trials.len(),
        aborted.len(),
        aborted
            .iter()
            .map(|r| r.abort_reason.clone())
            .collect::<Vec<_>>()
    );
    assert!(read.ended);
    assert!(!aborted.is_empty(), "the trial under way was aborted");
    assert_eq!(
        completed_trials(&read),
        (0..read.header.planned_trials).collect::<Vec<_>>()
    );
}
