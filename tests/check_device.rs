//! Issue 63: `frictionlab check-device`, the bring-up check, on each
//! emulator and on the simulated apparatus. Clean, every step passes (exit
//! 0); with each wiring fault the emulators can be started with
//! (`--flip-encoder`, `--flip-motor`, `--encoder-scale X`) the step it
//! breaks fails, naming it (exit 3). The loop's timing is held to the
//! check's own rule, whatever this machine's load made of it: its verdict
//! must be what the rule says of the numbers it printed. Each check keeps
//! its report in `DIR/device-checks/`, and a session begun after it names
//! it in its header.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::missing_panics_doc,
    reason = "tests"
)]

use std::path::Path;
use std::process::{Command, Stdio};

use crate::common;
use std::time::{Duration, Instant};

use frictionlab::device::check::{
    MISSED_SHARE, PERIOD_P99_PERIODS, RATE_TOLERANCE, Report, StepName, StepReport, Verdict,
};

const BIN: &str = env!("CARGO_BIN_EXE_frictionlab");

/// What a check printed and wrote.
struct Checked {
    code: i32,
    stdout: String,
    stderr: String,
    report: Report,
}

impl Checked {
    fn step(&self, step: StepName) -> &StepReport {
        self.report
            .steps
            .iter()
            .find(|s| s.step == step)
            .unwrap_or_else(|| panic!("no {step:?} in\n{}", self.stdout))
    }

    /// The step's line on standard output.
    fn line(&self, step: StepName) -> &str {
        self.stdout
            .lines()
            .find(|l| {
                l.get(5..)
                    .is_some_and(|rest| rest.starts_with(step.title()))
            })
            .unwrap_or_else(|| panic!("no line for {step:?} in\n{}", self.stdout))
    }
}

/// Runs `check-device --device DEVICE --responder sim` with results in
/// `out`; reads back the report it names.
fn check(device: &str, out: &Path) -> Checked {
    let output = Command::new(BIN)
        .args(["check-device", "--device", device, "--responder", "sim"])
        .args(["--duration-s", "1", "--device-timeout", "10", "--out"])
        .arg(out)
        .stdin(Stdio::null())
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&output.stdout).into_owned();
    let stderr = String::from_utf8_lossy(&output.stderr).into_owned();
    eprintln!("check-device --device {device}:\n{stdout}");
    let path = stdout
        .lines()
        .last()
        .and_then(|l| l.rsplit_once(" -> "))
        .map_or_else(
            || panic!("no report named in\n{stdout}\n{stderr}"),
            |(_, p)| p.to_owned(),
        );
    let report: Report = serde_json::from_slice(&std::fs::read(&path).unwrap()).unwrap();
    assert!(path.starts_with(out.join("device-checks").to_str().unwrap()));
    Checked {
        code: output.status.code().unwrap(),
        stdout,
        stderr,
        report,
    }
}

/// The timing step's verdict is what the check's rule says of its
/// numbers (a loaded machine may fail it; the rule must still hold).
fn assert_timing_by_its_rule(c: &Checked) {
    let t = c.step(StepName::Timing);
    let n = |name: &str| t.number(name).unwrap();
    let (rate, nominal) = (n("rate_hz"), n("nominal_rate_hz"));
    let by_rule = (rate / nominal - 1.0).abs() <= RATE_TOLERANCE
        && n("period_p99_us") <= PERIOD_P99_PERIODS * 1e6 / nominal
        && n("missed_ticks") <= MISSED_SHARE * n("ticks")
        && n("lost_link_ticks") == 0.0;
    assert_eq!(t.verdict == Verdict::Pass, by_rule, "{}", t.line());
    assert!(
        n("ticks") >= 0.99 * nominal,
        "a second measured: {}",
        t.line()
    );
}

/// A clean device: every step passes but the timing, which follows its
/// rule; the exit code says whether all did.
fn assert_clean(c: &Checked, axes: usize) {
    assert_timing_by_its_rule(c);
    for step in [
        StepName::Handshake,
        StepName::Encoder,
        StepName::ForceDirection,
    ] {
        assert_eq!(c.step(step).verdict, Verdict::Pass, "{}", c.line(step));
        assert!(c.line(step).starts_with("PASS"), "{}", c.line(step));
    }
    let wall = if axes > 1 {
        Verdict::Pass
    } else {
        Verdict::NotApplicable
    };
    assert_eq!(
        c.step(StepName::Wall).verdict,
        wall,
        "{}",
        c.line(StepName::Wall)
    );
    let all = c.report.steps.iter().all(|s| s.verdict.ok());
    assert_eq!(c.report.passed, all);
    assert_eq!(c.code, if all { 0 } else { 3 }, "{}", c.stderr);
    // The encoder read each end within the rule's share of the stated.
    let scale = c.step(StepName::Encoder).number("scale").unwrap();
    assert!((scale - 1.0).abs() <= 0.1, "{scale}");
}

/// A fault: `broken` fails, named on its line; the check fails (exit 3).
fn assert_caught(c: &Checked, broken: StepName) {
    assert_eq!(c.step(broken).verdict, Verdict::Fail, "{}", c.stdout);
    assert!(c.line(broken).starts_with("FAIL"), "{}", c.line(broken));
    assert!(!c.report.passed);
    assert_eq!(c.code, 3, "{}", c.stderr);
    assert!(
        c.stderr.contains(broken.title()),
        "the error names the step: {}",
        c.stderr
    );
    // The handshake still passed: the device answered.
    assert_eq!(c.step(StepName::Handshake).verdict, Verdict::Pass);
}

/// The faults an emulator is started with, and the step each breaks.
const FAULTS: [(&[&str], StepName); 3] = [
    (&["--flip-encoder"], StepName::Encoder),
    (&["--flip-motor"], StepName::ForceDirection),
    (&["--encoder-scale", "2"], StepName::Encoder),
];

/// The emulators.
#[derive(Clone, Copy)]
enum Emulated {
    OurBoard,
    Haply2Diy,
    Inverse3,
}

/// The check on a new emulator of `kind` started with `options` (the
/// Haply ones in lockstep: what the host reads back follows from what it
/// sent, whatever the load).
fn on(kind: Emulated, options: &[&str]) -> Checked {
    let tmp = tempfile::tempdir().unwrap();
    let dev = tmp.path().join("dev");
    let port = crate::common::free_port();
    let address = format!("127.0.0.1:{port}");
    let (target, mut all) = match kind {
        Emulated::OurBoard => (dev.display().to_string(), vec![]),
        Emulated::Haply2Diy => (format!("haply2diy:{}", dev.display()), vec!["--lockstep"]),
        Emulated::Inverse3 => (format!("inverse3:{address}"), vec!["--lockstep"]),
    };
    all.extend(options);
    let child = common::emulator_until(&target, &all, || match kind {
        Emulated::Inverse3 => std::net::TcpStream::connect(&address).is_ok(),
        _ => std::fs::read_link(&dev).is_ok(),
    });
    let c = check(&target, &tmp.path().join("results"));
    common::stop(child);
    c
}

/// Clean, every step passes; each fault fails the step it breaks, and a
/// device with a wall never has it turned on with a direction or the scale
/// wrong.
fn clean_then_each_fault(kind: Emulated, axes: usize) {
    assert_clean(&on(kind, &[]), axes);
    for (options, broken) in FAULTS {
        let c = on(kind, options);
        assert_caught(&c, broken);
        let wall = if axes > 1 {
            Verdict::Skipped
        } else {
            Verdict::NotApplicable
        };
        assert_eq!(c.step(StepName::Wall).verdict, wall);
    }
}

#[test]
fn the_check_passes_on_our_boards_emulator_and_catches_each_fault_issue_63() {
    clean_then_each_fault(Emulated::OurBoard, 1);
}

#[test]
fn the_check_passes_on_the_2diys_emulator_and_catches_each_fault_issue_63() {
    clean_then_each_fault(Emulated::Haply2Diy, 2);
}

#[test]
fn the_check_passes_on_the_inverse3s_emulator_and_catches_each_fault_issue_63() {
    clean_then_each_fault(Emulated::Inverse3, 3);
}

/// `--device sim`: the simulated apparatus through its real-time backend.
/// The report is kept; a session begun after it names it in its header,
/// and a second check is kept beside the first, which a later session
/// names instead.
#[test]
fn the_check_passes_on_the_simulated_apparatus_and_the_next_session_names_its_report_issue_63() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("results");
    let first = check("sim", &out);
    assert_clean(&first, 1);
    let session = |participant: &str| {
        let status = Command::new(BIN)
            .arg("run")
            .arg(Path::new(env!("CARGO_MANIFEST_DIR")).join("protocols/magnitude-quick.json"))
            .args(["--participant", participant, "--responder", "sim"])
            .args(["--device", "sim", "--pace", "1000", "--out"])
            .arg(&out)
            .stdout(Stdio::null())
            .status()
            .unwrap();
        assert!(status.success());
        let log = out.join(format!(
            "logs/study-magnitudequick_subject-{participant}_session-1_log.jsonl"
        ));
        let read = frictionlab::results::read_log::<frictionlab::kinds::Registry>(&log).unwrap();
        read.header.device_check.unwrap()
    };
    let named = session("a");
    let file = |c: &Checked| {
        let p = c
            .stdout
            .lines()
            .last()
            .unwrap()
            .rsplit_once(" -> ")
            .unwrap()
            .1;
        Path::new(p)
            .strip_prefix(&out)
            .unwrap()
            .display()
            .to_string()
    };
    assert_eq!(named.file, file(&first));
    assert_eq!(named.time_utc, first.report.time_utc);
    assert_eq!(named.passed, first.report.passed);
    // A second check: the first is kept, the next session names the new.
    let second = check("sim", &out);
    assert_ne!(file(&second), file(&first));
    assert!(out.join(file(&first)).exists());
    assert_eq!(session("b").file, file(&second));
    // A device with no check in the folder: no device_check in its header.
    let other = frictionlab::results::device_checks::last(
        &frictionlab::results::ResultsDir::new(&out),
        "haply2diy:/dev/ttyACM0",
    );
    assert_eq!(other, None);
}

/// Bad input is exit 2 with nothing written; a device that never answers
/// is a failed handshake, exit 3, and its report is kept.
#[test]
fn bad_input_writes_nothing_and_a_silent_device_fails_the_handshake_issue_63() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("results");
    let run = |args: &[&str]| {
        Command::new(BIN)
            .arg("check-device")
            .args(args)
            .arg("--out")
            .arg(&out)
            .stdin(Stdio::null())
            .output()
            .unwrap()
    };
    let bad = run(&["--device", tmp.path().to_str().unwrap()]);
    assert_eq!(bad.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&bad.stderr).contains("error: --device:"));
    let bad = run(&["--device", "sim", "--duration-s", "0"]);
    assert_eq!(bad.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&bad.stderr).contains("error: --duration-s:"));
    let bad = run(&[
        "--device",
        "inverse3:127.0.0.1:1",
        "--device-set",
        "nonsense=1",
    ]);
    assert_eq!(bad.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&bad.stderr).contains("error: --device-set:"));
    assert!(!out.exists(), "bad input wrote {}", out.display());
    // A pseudo-terminal nobody answers on.
    let (_master, slave) = serialport::TTYPort::pair().unwrap();
    let silent = serialport::SerialPort::name(&slave).unwrap();
    let started = Instant::now();
    let c = run(&[
        "--device",
        &silent,
        "--device-timeout",
        "1",
        "--responder",
        "sim",
    ]);
    let stdout = String::from_utf8_lossy(&c.stdout);
    assert_eq!(c.status.code(), Some(3), "{stdout}");
    assert!(stdout.contains("FAIL handshake"), "{stdout}");
    assert!(stdout.contains("the device did not answer"), "{stdout}");
    assert!(started.elapsed() < Duration::from_secs(10));
    assert_eq!(
        std::fs::read_dir(out.join("device-checks"))
            .unwrap()
            .count(),
        1
    );
}
