//! Issue 31: a session is open in one process at a time, a signal ends a
//! run with the trial under way logged as aborted (`interrupted`), and ids
//! too long for a file name are refused up front. Every case runs the
//! command line as a user would, from separate processes.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    reason = "a failed unwrap is a failed test"
)]

use crate::common;

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};
use std::time::{Duration, Instant};

use frictionlab::kinds::{LogLine, Registry};
use frictionlab::protocol::engine::Status;
use frictionlab::results::read_log;

fn protocol(name: &str) -> String {
    format!("{}/protocols/{name}.json", env!("CARGO_MANIFEST_DIR"))
}

fn command(args: &[&str]) -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_frictionlab"));
    c.args(args);
    c
}

/// `run magnitude-quick --responder sim` for `participant` into `out`.
fn run_args<'a>(out: &'a str, participant: &'a str, extra: &[&'a str]) -> Vec<&'a str> {
    let mut args = vec!["run", "", "--participant", participant, "--out", out];
    args.extend(["--responder", "sim"]);
    args.extend_from_slice(extra);
    args
}

fn run(out: &Path, participant: &str, extra: &[&str]) -> Output {
    let p = protocol("magnitude-quick");
    let out = out.to_str().unwrap();
    let mut args = run_args(out, participant, extra);
    args[1] = &p;
    command(&args).output().unwrap()
}

fn spawn_run(out: &Path, participant: &str, extra: &[&str]) -> Child {
    let p = protocol("magnitude-quick");
    let out = out.to_str().unwrap();
    let mut args = run_args(out, participant, extra);
    args[1] = &p;
    command(&args)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap()
}

fn log_of(out: &Path, participant: &str, session: u32) -> PathBuf {
    out.join(format!(
        "logs/study-magnitudequick_subject-{}_session-{session}_log.jsonl",
        participant.replace(['-', '_'], "")
    ))
}

fn csv_of(out: &Path, participant: &str) -> PathBuf {
    out.join(format!(
        "data/study-magnitudequick_subject-{}_session-1_data.csv",
        participant.replace(['-', '_'], "")
    ))
}

/// Waits until the session's log holds `n` trial records (the run keeps
/// going meanwhile).
fn wait_for_records(log: &Path, n: usize) {
    let start = Instant::now();
    loop {
        if read_log::<Registry>(log).is_ok_and(|r| r.trials.len() >= n) {
            return;
        }
        assert!(
            start.elapsed() < Duration::from_secs(30),
            "{} never reached {n} records",
            log.display()
        );
        std::thread::sleep(Duration::from_millis(5));
    }
}

fn signal(child: &Child, name: &str) {
    let ok = Command::new("kill")
        .args([&format!("-{name}"), &child.id().to_string()])
        .status()
        .unwrap()
        .success();
    assert!(ok, "kill -{name}");
}

/// Every file under `dir`, with its length, sorted: what a refused process
/// must leave as it was.
fn files(dir: &Path) -> Vec<(PathBuf, u64)> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let e = e.unwrap();
            if e.file_type().unwrap().is_dir() {
                stack.push(e.path());
            } else {
                out.push((e.path(), e.metadata().unwrap().len()));
            }
        }
    }
    out.sort();
    out
}

/// The data CSV's lines without its aborted rows (magnitude-quick has no
/// other aborted rows than those a signal cuts short).
fn completed_rows(text: &str) -> Vec<&str> {
    text.lines().filter(|l| !l.contains(",aborted,")).collect()
}

/// A paced run of `sim-001` holds its session open; a second process on it
/// is refused (exit 2, one line naming the log, the session and the
/// holder's pid) and writes nothing: as `run --resume`, as a new `run`,
/// and as `simulate` into the same folder. The holder's log stays whole:
/// valid JSON lines, every trial exactly once.
#[test]
fn a_second_process_on_an_open_session_is_refused_and_writes_nothing_issue_31() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path();
    // Six 2 s trials at pace 2: about 6 s of wall time.
    let mut holder = spawn_run(out, "sim-001", &["--seed", "3", "--pace", "2"]);
    let log = log_of(out, "sim-001", 1);
    wait_for_records(&log, 1);
    let expected = format!(
        "error: {}: session 1 of 'sim-001' is open in another process (pid {}); wait for it to end, or resume it there",
        log.display(),
        holder.id()
    );
    let p = protocol("magnitude-quick");
    let o = out.to_str().unwrap();
    let seconds: Vec<(&str, Vec<&str>)> = vec![
        (
            "run --resume",
            run_args(o, "sim-001", &["--resume", "--pace", "50"]),
        ),
        ("a new run", run_args(o, "sim-001", &["--pace", "50"])),
        (
            "simulate",
            vec![
                "simulate",
                "",
                "--participants",
                "2",
                "--seed",
                "9",
                "--out",
                o,
            ],
        ),
    ];
    // The holder's own files grow meanwhile (its log, CSV and streams).
    let others = || -> Vec<(PathBuf, u64)> {
        files(out)
            .into_iter()
            .filter(|(p, _)| !p.to_string_lossy().contains("subject-sim001_session-1"))
            .collect()
    };
    for (what, mut args) in seconds {
        args[1] = &p;
        let before = others();
        let second = command(&args).output().unwrap();
        let stderr = String::from_utf8_lossy(&second.stderr);
        assert_eq!(second.status.code(), Some(2), "{what}: {stderr}");
        assert_eq!(stderr.trim_end(), expected, "{what}");
        assert_eq!(others(), before, "{what} wrote nothing");
    }
    assert!(holder.wait().unwrap().success());
    let read = read_log::<Registry>(&log).unwrap();
    assert!(read.ended);
    assert_eq!(read.torn_bytes, 0);
    let mut trials: Vec<usize> = read.trials.iter().map(|r| r.trial).collect();
    trials.sort_unstable();
    assert_eq!(
        trials,
        (0..6).collect::<Vec<_>>(),
        "every trial exactly once"
    );
    assert_eq!(
        common::session_logs(out),
        vec![log],
        "no second session was started"
    );
}

/// Two new sessions of one participant started at the same moment: one
/// runs, the other is refused with the one clear line (never a raw `os
/// error`), and nothing of it is written.
#[test]
fn two_new_sessions_started_at_once_one_runs_and_one_is_refused_issue_31() {
    let dir = tempfile::tempdir().unwrap();
    let a = spawn_run(dir.path(), "P2", &["--seed", "1", "--pace", "4"]);
    let b = spawn_run(dir.path(), "P2", &["--seed", "1", "--pace", "4"]);
    let (a, b) = (a.wait_with_output().unwrap(), b.wait_with_output().unwrap());
    let mut codes = [a.status.code(), b.status.code()];
    codes.sort_unstable();
    assert_eq!(codes, [Some(0), Some(2)]);
    let refused = if a.status.success() { &b } else { &a };
    let stderr = String::from_utf8_lossy(&refused.stderr);
    assert!(
        stderr.contains("session 1 of 'P2' is open in another process (pid "),
        "{stderr}"
    );
    assert!(!stderr.contains("os error"), "{stderr}");
    assert_eq!(
        common::session_logs(dir.path()),
        vec![log_of(dir.path(), "P2", 1)]
    );
}

/// The kernel releases the lock when its holder dies: after kill -9 an
/// immediate `--resume` opens the session and finishes it.
#[test]
fn the_lock_dies_with_its_holder_under_kill_9_issue_31() {
    let dir = tempfile::tempdir().unwrap();
    let mut holder = spawn_run(dir.path(), "k9", &["--seed", "5", "--pace", "2"]);
    wait_for_records(&log_of(dir.path(), "k9", 1), 1);
    holder.kill().unwrap(); // SIGKILL
    holder.wait().unwrap();
    let o = run(dir.path(), "k9", &["--resume", "--pace", "100"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(
        read_log::<Registry>(&log_of(dir.path(), "k9", 1))
            .unwrap()
            .ended
    );
}

/// SIGTERM and SIGINT mid-trial: the trial is logged as aborted with the
/// reason `interrupted` (re-queued), an `interrupted` line names the
/// signal, the exit code is 128 + the signal's number, one line says how
/// to resume; the resume presents the trial again, and the data CSV's
/// completed rows are an uninterrupted run's, byte for byte (issue 42:
/// whichever trial the signal lands in; `tests/interruptions.rs` lands
/// signals at many moments).
#[test]
fn a_signal_mid_trial_logs_it_as_interrupted_and_the_resume_presents_it_again_issue_31() {
    let reference = tempfile::tempdir().unwrap();
    let o = run(reference.path(), "s", &["--seed", "77", "--pace", "1000"]);
    assert!(o.status.success());
    let expected = std::fs::read_to_string(csv_of(reference.path(), "s")).unwrap();
    for (name, code) in [("TERM", 143), ("INT", 130)] {
        let dir = tempfile::tempdir().unwrap();
        let log = log_of(dir.path(), "s", 1);
        // Trials of 2 s back to back at pace 4: 0.5 s of wall time each.
        let child = spawn_run(dir.path(), "s", &["--seed", "77", "--pace", "4"]);
        wait_for_records(&log, 2);
        std::thread::sleep(Duration::from_millis(200));
        signal(&child, name);
        let o = child.wait_with_output().unwrap();
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(code), "SIG{name}: {stderr}");
        assert!(
            stderr.starts_with(&format!(
                "interrupted by SIG{name}: session 1 of 's' stopped"
            )),
            "{stderr}"
        );
        assert!(stderr.contains("--resume"), "{stderr}");
        let read = read_log::<Registry>(&log).unwrap();
        let last = read.trials.last().unwrap();
        // Every tick of a running magnitude session is in a trial: the
        // signal lands in the first not completed.
        let under_way = read.completed();
        assert_eq!(
            last.trial, under_way,
            "SIG{name} landed in trial {under_way}"
        );
        assert_eq!(last.status, Status::Aborted);
        assert_eq!(last.abort_reason.as_deref(), Some("interrupted"));
        assert!(last.requeued);
        let lines = std::fs::read_to_string(&log).unwrap();
        let closing: LogLine = serde_json::from_str(lines.lines().last().unwrap()).unwrap();
        assert_eq!(
            closing,
            LogLine::Interrupted {
                signal: format!("SIG{name}")
            }
        );
        assert!(
            std::fs::read_to_string(csv_of(dir.path(), "s"))
                .unwrap()
                .lines()
                .last()
                .unwrap()
                .contains(&format!(",{under_way},{},aborted,", last.block)),
            "the CSV is whole, with the aborted trial"
        );
        let o = run(dir.path(), "s", &["--resume", "--pace", "1000"]);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        assert!(
            String::from_utf8_lossy(&o.stdout).contains(&format!("resumed at trial {under_way}"))
        );
        let read = read_log::<Registry>(&log).unwrap();
        assert!(read.ended);
        assert_eq!(common::completed_trials(&read), (0..6).collect::<Vec<_>>());
        assert_eq!(
            completed_rows(&std::fs::read_to_string(csv_of(dir.path(), "s")).unwrap()),
            completed_rows(&expected),
            "SIG{name}: the completed rows of an uninterrupted run"
        );
    }
}

/// A signal to `simulate` stops the sessions running (each resumable) and
/// starts no new one; it says which.
#[test]
fn a_signal_to_simulate_stops_its_sessions_and_starts_no_more_issue_31() {
    let dir = tempfile::tempdir().unwrap();
    let p = protocol("magnitude-quick");
    let out = dir.path().to_str().unwrap();
    let child = command(&[
        "simulate",
        &p,
        "--participants",
        "4",
        "--seed",
        "2",
        "--out",
        out,
        "--pace",
        "4",
    ])
    .stdout(Stdio::piped())
    .stderr(Stdio::piped())
    .spawn()
    .unwrap();
    wait_for_records(&log_of(dir.path(), "sim-001", 1), 2);
    std::thread::sleep(Duration::from_millis(200));
    signal(&child, "TERM");
    let o = child.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(143), "{stderr}");
    assert!(
        stderr.contains("interrupted by SIGTERM: 0 of 4 sessions finished; sim-001 stopped"),
        "{stderr}"
    );
    assert!(stderr.contains("3 not started"), "{stderr}");
    assert_eq!(common::session_logs(dir.path()).len(), 1, "one started");
    let o = run(dir.path(), "sim-001", &["--resume", "--pace", "1000"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
}

/// Issue 31: a 300-letter participant id passed the id check and failed at
/// its first file with the OS's "File name too long". Now it is refused
/// with the limit named, and nothing is written.
#[test]
fn a_participant_id_over_the_length_limit_is_refused_up_front_issue_31() {
    let dir = tempfile::tempdir().unwrap();
    let long = "a".repeat(300);
    let o = run(dir.path(), &long, &["--pace", "1000"]);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{stderr}");
    assert!(
        stderr.starts_with(
            "error: --participant: 'aaaaaaaaaaaaaaaa...' is 300 characters long: at most 64"
        ),
        "{stderr}"
    );
    assert!(!stderr.contains("os error"), "{stderr}");
    assert!(files(dir.path()).is_empty());
    let o = run(dir.path(), &"a".repeat(64), &["--pace", "1000"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
}
