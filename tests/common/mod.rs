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
    emulator_until(path.to_str().unwrap(), options, || {
        std::fs::read_link(path).is_ok()
    })
}

/// Starts `frictionlab device-emulator TARGET OPTIONS` (any kind) and waits
/// until `ready` (at most 10 s).
pub fn emulator_until(
    target: &str,
    options: &[&str],
    ready: impl Fn() -> bool,
) -> std::process::Child {
    let child = std::process::Command::new(env!("CARGO_BIN_EXE_frictionlab"))
        .args(["device-emulator", target])
        .args(options)
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let start = std::time::Instant::now();
    while !ready() && start.elapsed() < std::time::Duration::from_secs(10) {
        std::thread::sleep(std::time::Duration::from_millis(10));
    }
    child
}

/// Unplugs the emulated device at `path` mid-session: its link is removed,
/// as unplugging a USB device removes its port, then the emulator is
/// killed (SIGKILL). In that order: a link left behind points at a freed
/// pseudo-terminal number, which the next emulator started on this
/// machine (a test running alongside) takes, and a host reopening the
/// path would reach that one.
pub fn unplug(mut child: std::process::Child, path: &std::path::Path) {
    std::fs::remove_file(path).unwrap();
    child.kill().unwrap();
    child.wait().unwrap();
}

/// Stops a child process started by a test.
pub fn stop(mut child: std::process::Child) {
    let _ = child.kill();
    let _ = child.wait();
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
        let r: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        // Every completed presentation compares rows; an aborted one may
        // have ended before its model took effect (`rerender` exits 2 for
        // a stream with nothing compared).
        assert!(
            o.status.success() || (r["status"] == "aborted" && r["compared"] == 0),
            "{r}\n{}",
            String::from_utf8_lossy(&o.stderr)
        );
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

/// The stream of the `i`-th record of the session whose log is `log`,
/// under the results folder `out` (trial k, run r: the r-th record of
/// trial k).
pub fn stream_of(
    out: &std::path::Path,
    log: &frictionlab::kinds::ReadLog,
    i: usize,
) -> std::path::PathBuf {
    let letters = |s: &str| {
        s.chars()
            .filter(char::is_ascii_alphanumeric)
            .collect::<String>()
    };
    let record = &log.trials[i];
    let run = log.trials[..=i]
        .iter()
        .filter(|r| r.trial == record.trial)
        .count();
    out.join(format!(
        "streams/study-{}_subject-{}_session-{}_trial-{}_run-{run}_stream.csv",
        letters(&log.header.protocol_id),
        letters(&log.header.participant),
        log.header.session,
        record.trial
    ))
}

/// Issue 63: every stream of the session whose log is `log`, under the
/// results folder `out`, holds its trial whole. A completed
/// presentation's stream begins after its trial's start (no row from
/// before it), has the select of its first model (no row before the
/// select renders a model: the stream did not lose its start) and ends
/// at the trial's end. Before, trial 0's stream on the Haply devices
/// began 0.5 to 0.9 s into its trial, without its select: the trial
/// started while the session still waited for the hand to be held on the
/// track. Returns a line for trial 0's first presentation: its rows
/// against its duration times `rate_hz`, and how long after its start
/// its first row came.
pub fn assert_whole_streams(
    out: &std::path::Path,
    log: &frictionlab::kinds::ReadLog,
    rate_hz: f64,
) -> String {
    let mut line = String::new();
    for (i, record) in log.trials.iter().enumerate() {
        let path = stream_of(out, log, i);
        let text = std::fs::read_to_string(&path).unwrap();
        let rows = frictionlab::rerender::parse_stream("stream", &text).unwrap();
        let (start, end) = (record.started_s.secs(), record.ended_s.secs());
        let name = path.display();
        if let Some(first) = rows.first() {
            assert!(
                first.t_s > start,
                "{name}: a row at {} s, before its start {start} s",
                first.t_s
            );
        }
        if record.status.as_str() != "completed" {
            continue;
        }
        let last = rows.last().unwrap_or_else(|| panic!("{name}: no rows"));
        assert_eq!(last.t_s, end, "{name}: the stream ends before its trial");
        let model = |r: &frictionlab::rerender::Row| record.rendering[r.render].model.is_some();
        let select = rows
            .iter()
            .position(|r| r.selected && model(r))
            .unwrap_or_else(|| panic!("{name}: no select of a model: the stream lost its start"));
        assert!(
            rows[..select].iter().all(|r| !model(r)),
            "{name}: a model rendered before the stream's first select"
        );
        if line.is_empty() {
            #[expect(clippy::cast_precision_loss, reason = "a row count")]
            let n = rows.len() as f64;
            line = format!(
                "trial {} ({}): {} rows for {:.3} s x {rate_hz} Hz = {:.0}, first row {:.1} ms after its start, its select at row {select}",
                record.trial,
                name,
                n,
                end - start,
                (end - start) * rate_hz,
                (rows[0].t_s - start) * 1e3
            );
        }
    }
    line
}

/// Issue 63: every render of every trial of `log` was stepped with the
/// force limit in force, `limit_n` (the smaller of the model's clamp and
/// the device's), and the header states the device's own limit and travel.
/// Before, every host-loop render said 9.48 N (the simulated apparatus's)
/// on the 2DIY and the Inverse3. Returns a line for the test's output.
pub fn assert_force_limits(
    log: &frictionlab::kinds::ReadLog,
    device_limit_n: f64,
    limit_n: f64,
    travel_m: [f64; 2],
) -> String {
    let stated = log
        .header
        .device_limits
        .expect("the device's limits in the header");
    assert_eq!(
        (stated.force_limit_n, stated.travel_m),
        (device_limit_n, travel_m),
        "the header's device limits"
    );
    let mut renders = 0;
    for r in &log.trials {
        for e in &r.rendering {
            assert_eq!(
                e.force_limit_n, limit_n,
                "trial {}: a render stepped with {} N, not the limit in force",
                r.trial, e.force_limit_n
            );
            renders += 1;
        }
    }
    assert!(renders > 0, "no render recorded");
    format!(
        "{renders} renders at {limit_n} N; the header: the device's limit {device_limit_n} N, travel {travel_m:?} m"
    )
}

/// A free loopback port.
pub fn free_port() -> u16 {
    std::net::TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port()
}
