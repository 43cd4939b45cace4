//! Every command whose output goes to a reader that already went away
//! (`frictionlab ... | head`) finishes its work and exits as it would have,
//! without a panic: the broken pipe drops the output, nothing else.

#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    reason = "a failed unwrap is a failed test"
)]

use std::path::Path;
use std::process::{Command, Output, Stdio};

/// Runs the binary with standard output a pipe whose reader is closed before
/// the process starts, so every write to it fails with a broken pipe.
/// Standard error is captured, or broken the same way when `break_stderr`.
fn with_closed_stdout(args: &[&str], break_stderr: bool) -> Output {
    let closed = || {
        let (reader, writer) = std::io::pipe().unwrap();
        drop(reader);
        Stdio::from(writer)
    };
    let mut command = Command::new(env!("CARGO_BIN_EXE_frictionlab"));
    command.args(args).stdout(closed());
    if break_stderr {
        command.stderr(closed());
    }
    command.output().expect("runs")
}

fn assert_no_panic(o: &Output, code: i32) {
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(!stderr.contains("panicked"), "{stderr}");
    assert_eq!(o.status.code(), Some(code), "{stderr}");
}

fn protocol(name: &str) -> String {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("protocols")
        .join(name)
        .display()
        .to_string()
}

#[test]
fn printing_commands_exit_0_when_their_reader_is_gone() {
    let fitts = protocol("fitts-quick.json");
    for args in [
        vec!["validate", fitts.as_str()],
        vec!["models"],
        vec!["schema", "protocol"],
        vec!["schema", "log"],
        vec!["ports"],
        vec!["--help"],
    ] {
        assert_no_panic(&with_closed_stdout(&args, false), 0);
        assert_no_panic(&with_closed_stdout(&args, true), 0);
    }
}

#[test]
fn the_work_is_done_even_when_the_report_line_cannot_be_printed() {
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("slide.csv");
    let o = with_closed_stdout(
        &[
            "render",
            "--model",
            "dahl",
            "--scenario",
            "servo-sinusoid",
            "--out",
            csv.to_str().unwrap(),
        ],
        true,
    );
    assert_no_panic(&o, 0);
    assert!(std::fs::read_to_string(&csv).unwrap().lines().count() > 1000);

    let identify = with_closed_stdout(
        &["identify", csv.to_str().unwrap(), "--model", "karnopp"],
        false,
    );
    assert_no_panic(&identify, 0);

    let results = dir.path().join("results");
    let o = with_closed_stdout(
        &[
            "simulate",
            &protocol("paired-quick.json"),
            "--participants",
            "2",
            "--seed",
            "5",
            "--out",
            results.to_str().unwrap(),
        ],
        true,
    );
    assert_no_panic(&o, 0);
    let data: Vec<_> = std::fs::read_dir(results.join("data")).unwrap().collect();
    assert_eq!(data.len(), 2);

    let report = dir.path().join("report");
    let o = with_closed_stdout(
        &[
            "analyze",
            results.to_str().unwrap(),
            "--out",
            report.to_str().unwrap(),
        ],
        true,
    );
    assert_no_panic(&o, 0);
    assert!(report.join("summary.json").is_file());
}

#[test]
fn bad_input_still_exits_2_when_standard_error_is_broken() {
    let o = with_closed_stdout(&["validate", "no-such-protocol.json"], true);
    assert_no_panic(&o, 2);
    let o = with_closed_stdout(&["validate", "no-such-protocol.json"], false);
    assert_no_panic(&o, 2);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(
        stderr.starts_with("error: no-such-protocol.json"),
        "{stderr}"
    );
}

#[test]
fn a_full_disk_behind_standard_output_is_a_failure_not_silence() {
    let full = std::fs::OpenOptions::new()
        .write(true)
        .open("/dev/full")
        .unwrap();
    let o = Command::new(env!("CARGO_BIN_EXE_frictionlab"))
        .arg("models")
        .stdout(full)
        .output()
        .unwrap();
    assert_no_panic(&o, 1);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(stderr.starts_with("error: stdout: "), "{stderr}");
}
