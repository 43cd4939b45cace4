//! Sessions on the Lab Streaming Layer (issue 34), received by pylsl, the
//! reference client (`tests/lsl/inlet.py`), not by our code.
//!
//! `.ci/run` installs pylsl from PyPI in a virtual environment
//! (`target/lsl-venv`) and these tests load the liblsl it ships. Without
//! it they fail under CI (`CI` set) and are skipped elsewhere; the tests
//! of a missing or too old liblsl need neither.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    reason = "a failed unwrap is a failed test"
)]

use crate::common;

use std::path::Path;
use std::process::{Child, Command, Output, Stdio};
use std::sync::Mutex;
use std::time::{Duration, Instant};

use frictionlab::kinds::{ReadLog, Registry};
use frictionlab::results::read_log;
use serde_json::Value;

/// The paced sessions of these tests run one at a time: each needs the
/// clock, and two cores are shared with the other tests.
static PACED: Mutex<()> = Mutex::new(());

const BIN: &str = env!("CARGO_BIN_EXE_frictionlab");

/// What a paced LSL test needs: pylsl, a folder, and its turn.
struct Paced {
    python: std::path::PathBuf,
    lib: std::path::PathBuf,
    dir: tempfile::TempDir,
    _one: std::sync::MutexGuard<'static, ()>,
}

/// pylsl (or a skip: [`common::need_pylsl`]) and this test's turn.
fn paced() -> Option<Paced> {
    let (python, lib) = common::need_pylsl()?;
    Some(Paced {
        python,
        lib,
        dir: tempfile::tempdir().unwrap(),
        _one: PACED
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner),
    })
}

/// Starts the pylsl inlet for the streams named `name`, writing to `out`
/// once `runs` runs have ended.
fn inlet(python: &Path, name: &str, out: &Path, runs: u32) -> Child {
    Command::new(python)
        .arg(Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/lsl/inlet.py"))
        .args([name, out.to_str().unwrap(), "--runs", &runs.to_string()])
        .args(["--timeout", "240"])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap()
}

/// Waits for the inlet and reads what it received.
fn received(mut inlet: Child, out: &Path) -> Value {
    let status = inlet.wait().unwrap();
    assert!(status.success(), "the inlet failed: {status}");
    serde_json::from_str(&std::fs::read_to_string(out).unwrap()).unwrap()
}

fn frictionlab(args: &[&str]) -> Output {
    Command::new(BIN).args(args).output().unwrap()
}

fn only_log(results: &Path) -> ReadLog {
    let logs = common::session_logs(results);
    assert_eq!(logs.len(), 1, "{logs:?}");
    read_log::<Registry>(&logs[0]).unwrap()
}

/// The log's lines of type `kind`.
fn log_lines(results: &Path, kind: &str) -> Vec<Value> {
    let logs = common::session_logs(results);
    std::fs::read_to_string(&logs[0])
        .unwrap()
        .lines()
        .filter_map(|l| serde_json::from_str::<Value>(l).ok())
        .filter(|v| v["type"] == kind)
        .collect()
}

/// The log's `lsl` lines.
fn lsl_lines(results: &Path) -> Vec<Value> {
    log_lines(results, "lsl")
}

/// The markers as (timestamp, object).
fn markers(got: &Value) -> Vec<(f64, Value)> {
    got["markers"]
        .as_array()
        .unwrap()
        .iter()
        .map(|m| {
            (
                m[0].as_f64().unwrap(),
                serde_json::from_str(m[1].as_str().unwrap()).unwrap(),
            )
        })
        .collect()
}

fn events<'a>(markers: &'a [(f64, Value)], event: &str) -> Vec<&'a (f64, Value)> {
    markers
        .iter()
        .filter(|(_, m)| m["event"] == event)
        .collect()
}

/// Every marker of one run, in order: `seq` runs 0, 1, ... with none
/// missing or doubled.
fn assert_in_order(markers: &[(f64, Value)]) {
    let seqs: Vec<u64> = markers
        .iter()
        .map(|(_, m)| m["seq"].as_u64().unwrap())
        .collect();
    assert_eq!(
        seqs,
        (0..seqs.len() as u64).collect::<Vec<_>>(),
        "{markers:?}"
    );
}

/// The markers a finished magnitude session's log implies: its start,
/// instructions and their Continue, per block a start, per break a break
/// and its Continue, per record a start, a stimulus on and off and an
/// end, per completed one an answer, and the session's end. A break comes
/// before a presentation of another block than the last record finally
/// logged (the engine's rule: a re-presented first trial of a block, its
/// first presentation aborted, has its break again).
fn implied_markers(log: &ReadLog) -> usize {
    let mut blocks = log.trials.iter().map(|r| r.block_index).collect::<Vec<_>>();
    blocks.dedup();
    let (mut breaks, mut last_final) = (0, None);
    for r in &log.trials {
        if last_final.is_some_and(|b| b != r.block_index) {
            breaks += 1;
        }
        if !r.requeued {
            last_final = Some(r.block_index);
        }
    }
    let completed = log
        .trials
        .iter()
        .filter(|r| r.status == frictionlab::protocol::engine::Status::Completed)
        .count();
    4 + blocks.len() + 2 * breaks + 4 * log.trials.len() + completed
}

/// The markers of `marks` but a device's losses: each `device_lost` with
/// its `device_back` after it (a device lost at least once per trial
/// aborted for it).
fn but_losses<'a>(log: &ReadLog, marks: &'a [(f64, Value)]) -> Vec<&'a (f64, Value)> {
    let mut lost = false;
    let mut losses = 0;
    for (_, m) in marks {
        match m["event"].as_str() {
            Some("device_lost") => {
                assert!(!lost, "device_lost twice: {m}");
                (lost, losses) = (true, losses + 1);
            }
            Some("device_back") => {
                assert!(lost, "device_back with no device_lost: {m}");
                lost = false;
            }
            _ => {}
        }
    }
    assert!(!lost, "a device_lost with no device_back");
    let aborted_for_it = log
        .trials
        .iter()
        .filter(|r| {
            r.abort_reason
                .as_deref()
                .is_some_and(|a| a.starts_with("device lost"))
        })
        .count();
    assert!(
        losses >= aborted_for_it,
        "{losses} losses, {aborted_for_it} trials aborted for one"
    );
    marks
        .iter()
        .filter(|(_, m)| m["event"] != "device_lost" && m["event"] != "device_back")
        .collect()
}

/// A finished run's log and what the inlet got: every marker in order, as
/// many as the log implies.
fn session_received(
    run: &Output,
    listener: Child,
    out: &Path,
    results: &Path,
) -> (Value, ReadLog, Vec<(f64, Value)>) {
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let got = received(listener, out);
    let log = only_log(results);
    let marks = markers(&got);
    assert_in_order(&marks);
    assert_eq!(
        but_losses(&log, &marks).len(),
        implied_markers(&log),
        "{marks:?}"
    );
    (got, log, marks)
}

/// Each record's LSL start and end are its trial's `trial_start` and
/// `trial_end` marker timestamps, bit for bit.
fn assert_trial_times(log: &ReadLog, markers: &[(f64, Value)]) {
    let starts = events(markers, "trial_start");
    let ends = events(markers, "trial_end");
    assert_eq!(starts.len(), log.trials.len());
    assert_eq!(ends.len(), log.trials.len());
    for ((r, (ts, s)), (te, e)) in log.trials.iter().zip(starts).zip(ends) {
        assert_eq!(s["trial"].as_u64(), Some(r.trial as u64));
        assert_eq!(e["trial"].as_u64(), Some(r.trial as u64));
        assert_eq!(r.lsl_start_s, Some(*ts), "trial {}", r.trial);
        assert_eq!(r.lsl_end_s, Some(*te), "trial {}", r.trial);
        assert!(te > ts);
    }
}

/// The device stream as received: labels, units, count and order, and
/// its rate: `count` samples over the span at the nominal rate, within 1%.
/// `writes`: the simulated device's virtual time stands still while a
/// record is written (synced), so its stream may pause once per write;
/// those pauses leave the span and the rest must be the exact grid.
fn assert_device(got: &Value, channels: &[&str], writes: Option<usize>) -> f64 {
    let d = &got["device"];
    assert_channels(d, channels);
    let rate = d["nominal_srate"].as_f64().unwrap();
    let span = d["last"].as_f64().unwrap() - d["first"].as_f64().unwrap();
    let count = d["count"].as_f64().unwrap();
    if let Some(writes) = writes {
        let gaps = d["gaps"].as_u64().unwrap();
        let gap_s = d["gap_s"].as_f64().unwrap();
        assert!(
            gaps <= u64::try_from(writes).unwrap(),
            "{gaps} pauses, {writes} writes"
        );
        let expected = rate * (span - gap_s) + 1.0;
        assert!(
            (count - expected).abs() <= 2.0,
            "{count} samples over {span} s less {gap_s} s of {gaps} pauses \
             at {rate} Hz (expected {expected})"
        );
    } else {
        let expected = rate * span + 1.0;
        assert!(
            (count - expected).abs() <= 0.01 * expected,
            "{count} samples over {span} s at {rate} Hz (expected {expected})"
        );
    }
    count
}

/// The device stream's type, labels and units, in order, with increasing
/// timestamps.
fn assert_channels(d: &Value, channels: &[&str]) {
    assert_eq!(d["type"], "Haptics");
    let each = |key: &str| -> Vec<String> {
        d["channels"]
            .as_array()
            .unwrap()
            .iter()
            .map(|c| c[key].as_str().unwrap().to_owned())
            .collect()
    };
    let (labels, units) = (each("label"), each("unit"));
    assert_eq!(labels, channels);
    assert_eq!(&units[..4], ["m", "m/s", "N", "normalized"]);
    assert_eq!(d["increasing"], true, "timestamps not increasing");
}

#[test]
fn a_pylsl_inlet_receives_every_marker_and_the_device_stream_of_a_simulated_session() {
    let Some(t) = paced() else {
        return;
    };
    let (results, out) = (t.dir.path().join("r"), t.dir.path().join("got.json"));
    let listener = inlet(&t.python, "frictionlab magnitude-quick lsl-sim", &out, 1);
    let args = sim_run(&results, "lsl-sim", &t.lib);
    let run = Command::new(BIN).args(&args).output().unwrap();
    let (got, log, marks) = session_received(&run, listener, &out, &results);
    let stats = &lsl_lines(&results)[0];
    assert_eq!(stats["markers"].as_u64(), Some(marks.len() as u64));
    assert_eq!(stats["dropped_samples"], 0);
    assert_eq!(events(&marks, "answer").len(), 6);
    assert_trial_times(&log, &marks);
    assert_eq!(got["marker_type"], "Markers");
    assert_eq!(
        got["marker_source_id"],
        "frictionlab/magnitude-quick/lsl-sim/session-1/seed-3/markers"
    );
    let count = assert_device(
        &got,
        &["position_m", "velocity_m_s", "force_n", "vibration"],
        Some(log.trials.len()),
    );
    assert_eq!(got["device"]["nominal_srate"], 5000.0);
    assert_eq!(got["device"]["mode"], "simulated");
    // Some 12 s of session: 5 kHz samples from the inlet's connection on.
    assert!(count > 50_000.0, "{count}");
    // The data CSV carries the same LSL times.
    let csv = results.join("data/study-magnitudequick_subject-lslsim_session-1_data.csv");
    let csv = std::fs::read_to_string(csv).unwrap();
    let header: Vec<&str> = csv.lines().next().unwrap().split(',').collect();
    let at = header.iter().position(|c| *c == "lsl_start_s").unwrap();
    for (line, r) in csv.lines().skip(1).zip(&log.trials) {
        let cell: f64 = line.split(',').nth(at).unwrap().parse().unwrap();
        assert_eq!(Some(cell), r.lsl_start_s);
    }
}

/// Issue 42: the real LabRecorder (its recording code, from PyPI), started
/// before the session as a lab starts it, with the session's two streams
/// on its watch list. Both streams exist while the session waits for a
/// reader on each (`--lsl-wait`), so the recorder takes both before the
/// first marker: the XDF holds every marker once and in order, its device
/// stream starts at or before `session_start` and holds every sample the
/// log says was pushed, and the trials' LSL times are their markers'.
#[test]
fn labrecorder_started_before_the_session_records_both_streams_from_the_first_marker_issue_42() {
    let Some(t) = paced() else {
        return;
    };
    if !common::need_labrecorder(&t.python) {
        return;
    }
    let dir = t.dir.path();
    let results = dir.join("r");
    let (out, ready, stop) = (dir.join("got.json"), dir.join("ready"), dir.join("stop"));
    let mut recorder = Command::new(&t.python)
        .arg(Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/lsl/record.py"))
        .args(["frictionlab magnitude-quick lab", out.to_str().unwrap()])
        .args(["--xdf", dir.join("rec.xdf").to_str().unwrap()])
        .args(["--ready", ready.to_str().unwrap()])
        .args(["--stop", stop.to_str().unwrap(), "--timeout", "240"])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    // The recorder records before the session exists.
    let start = Instant::now();
    while !ready.exists() {
        assert!(
            start.elapsed() < Duration::from_mins(1),
            "the recorder never started"
        );
        std::thread::sleep(Duration::from_millis(20));
    }
    let mut args = sim_run(&results, "lab", &t.lib);
    let pace = args.iter().position(|a| a == "--pace").unwrap();
    args[pace + 1] = "2".into();
    let run = Command::new(BIN).args(&args).output().unwrap();
    std::fs::write(&stop, b"").unwrap();
    let status = recorder.wait().unwrap();
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    assert!(status.success(), "the recorder failed: {status}");
    let got: Value = serde_json::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
    let log = only_log(&results);
    let stats = &lsl_lines(&results)[0];
    let marks = markers(&got);
    assert_in_order(&marks);
    assert_eq!(stats["markers"].as_u64(), Some(marks.len() as u64));
    assert_eq!(marks.len(), implied_markers(&log), "{marks:?}");
    assert_eq!(marks[0].1["event"], "session_start");
    assert_trial_times(&log, &marks);
    let device = &got["device"];
    assert_eq!(device["channels"], 4);
    assert_eq!(device["increasing"], true);
    assert!(
        device["first"].as_f64().unwrap() <= marks[0].0,
        "the device stream starts at {} s, after session_start at {} s",
        device["first"],
        marks[0].0
    );
    assert_eq!(stats["dropped_samples"], 0);
    assert_eq!(
        device["count"], stats["samples"],
        "every sample pushed is recorded"
    );
}

/// At most this many sessions for the on-board test: each one that a
/// loaded host ends for device faults is checked against that promise.
const BOARD_SESSIONS: usize = 5;

#[test]
fn a_device_rendering_on_board_publishes_its_telemetry_with_the_tick_channel() {
    let Some(t) = paced() else {
        return;
    };
    // Under a concurrent build the kernel's tty work (its flush of a pty's
    // bytes runs in workqueue threads at normal priority, as a USB serial
    // port's does) held the emulated board's telemetry for 0.1-1.5 s,
    // although the board and the haptic loop run at SCHED_FIFO: with those
    // threads raised to FIFO the loop's worst period error was 1.4-3.8 ms,
    // without it 106 ms to 1.49 s. A board silent that long is lost: the
    // design's promise is that the trial is aborted and presented again,
    // never kept, and that a run whose trial is aborted
    // MAX_DEVICE_FAULTS_IN_A_ROW times in a row ends with exit 3 (issue
    // 63). Such a run is checked for exactly that, and a new session is
    // run; one must finish for the stream's own checks.
    let mut runs = None;
    for attempt in 0..BOARD_SESSIONS {
        let participant = format!("lsl-board-{attempt}");
        let dev = t.dir.path().join(format!("dev-{attempt}"));
        let mut emu = common::emulator_with(&dev, &["--on-board"]);
        let results = t.dir.path().join(format!("r-{attempt}"));
        let out = t.dir.path().join(format!("got-{attempt}.json"));
        let mut listener = inlet(
            &t.python,
            &format!("frictionlab magnitude-quick {participant}"),
            &out,
            1,
        );
        let run = frictionlab(&[
            "run",
            "protocols/magnitude-quick.json",
            "--participant",
            &participant,
            "--out",
            results.to_str().unwrap(),
            "--device",
            dev.to_str().unwrap(),
            "--responder",
            "sim",
            "--seed",
            "3",
            "--lsl",
            "--lsl-lib",
            t.lib.to_str().unwrap(),
            "--lsl-wait",
            "60",
        ]);
        let _ = emu.kill();
        let _ = emu.wait();
        if run.status.code() == Some(3) {
            let _ = listener.kill();
            let _ = listener.wait();
            let stderr = String::from_utf8_lossy(&run.stderr);
            assert!(stderr.contains("times in a row"), "{stderr}");
            let log = only_log(&results);
            assert!(!log.ended, "{stderr}");
            let aborted: Vec<_> = log
                .trials
                .iter()
                .filter(|r| r.status != frictionlab::protocol::engine::Status::Completed)
                .collect();
            assert!(aborted.len() >= 3, "{stderr}");
            // Each aborted for a device fault (lost, or its render not
            // shown in effect in time) and presented again.
            for r in aborted {
                assert!(
                    r.requeued
                        && r.abort_reason.as_deref().is_some_and(|a| {
                            a.starts_with("device lost")
                                || a.starts_with("the device did not render")
                        }),
                    "trial {}: {:?}",
                    r.trial,
                    r.abort_reason
                );
            }
            eprintln!("session {attempt}: ended for device faults under load (exit 3): {stderr}");
            continue;
        }
        runs = Some((run, listener, out, results));
        break;
    }
    let (run, listener, out, results) = runs
        .unwrap_or_else(|| panic!("{BOARD_SESSIONS} sessions in a row ended for device faults"));
    let (got, log, marks) = session_received(&run, listener, &out, &results);
    assert_trial_times(&log, &marks);
    // The board's own loop sets this stream's rate, not the host's clock:
    // the emulator renders it in real time and falls behind on a loaded
    // machine (one core busy: 62,201 ticks in 12.566 s of host time, 1.0%
    // under 5 kHz). The rule is that every tick that reached the host is
    // published, once and in order: a tick is missing only where the
    // link lost its telemetry (the loop counts those gaps: under a
    // concurrent build the board's queue overflowed while the kernel
    // held its bytes) or the device was lost.
    let d = &got["device"];
    assert_channels(
        d,
        &["position_m", "velocity_m_s", "force_n", "vibration", "tick"],
    );
    assert_eq!(d["mode"], "on_board");
    assert_eq!(d["ticks_increasing"], true, "device ticks out of order");
    assert_eq!(d["ticks"], d["count"]);
    let gaps = log_lines(&results, "loop")[0]["telemetry_gaps"]
        .as_u64()
        .unwrap();
    if gaps == 0 && events(&marks, "device_lost").is_empty() {
        assert_eq!(d["ticks_consecutive"], true, "device ticks skipped");
    } else {
        eprintln!(
            "{} ticks missing from the stream; the link lost {gaps} and the device was lost {} times",
            d["ticks_skipped"],
            events(&marks, "device_lost").len()
        );
    }
    let stats = &lsl_lines(&results)[0];
    assert_eq!(stats["dropped_samples"], 0);
    assert_eq!(stats["device_stream"], true);
}

/// `run` of magnitude-quick for `participant` on the simulated device
/// with a simulated participant, in real time, published on LSL with `lib`
/// (waiting for the inlet).
fn sim_run(results: &Path, participant: &str, lib: &Path) -> Vec<String> {
    [
        "run",
        "protocols/magnitude-quick.json",
        "--participant",
        participant,
        "--out",
        results.to_str().unwrap(),
        "--device",
        "sim",
        "--responder",
        "sim",
        "--pace",
        "1",
        "--seed",
        "3",
        "--lsl",
        "--lsl-lib",
        lib.to_str().unwrap(),
        "--lsl-wait",
        "60",
    ]
    .into_iter()
    .map(str::to_owned)
    .collect()
}

/// Waits until the one session log in `results` holds `n` records.
fn wait_for_trials(results: &Path, n: usize) {
    let start = Instant::now();
    loop {
        let logged = if results.join("logs").exists() {
            common::session_logs(results)
                .first()
                .and_then(|p| read_log::<Registry>(p).ok())
                .map_or(0, |l| l.trials.len())
        } else {
            0
        };
        if logged >= n {
            return;
        }
        assert!(
            start.elapsed() < Duration::from_mins(2),
            "{n} trials not logged"
        );
        std::thread::sleep(Duration::from_millis(20));
    }
}

#[test]
fn a_killed_session_resumed_with_lsl_continues_the_same_stream_and_trial_numbering() {
    let Some(t) = paced() else {
        return;
    };
    let (results, out) = (t.dir.path().join("r"), t.dir.path().join("got.json"));
    let args = |resume: bool| {
        let mut a = sim_run(&results, "lsl-kill", &t.lib);
        if resume {
            a.push("--resume".into());
        }
        a
    };
    // The killed run sends no end; only the resumed one does.
    let listener = inlet(&t.python, "frictionlab magnitude-quick lsl-kill", &out, 1);
    let mut first = Command::new(BIN)
        .args(args(false))
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    // Killed mid-trial 2, after two trials are logged.
    wait_for_trials(&results, 2);
    std::thread::sleep(Duration::from_millis(700));
    first.kill().unwrap();
    first.wait().unwrap();
    let resumed = Command::new(BIN).args(args(true)).output().unwrap();
    assert!(
        resumed.status.success(),
        "{}",
        String::from_utf8_lossy(&resumed.stderr)
    );
    let got = received(listener, &out);
    let marks = markers(&got);
    // Two runs: each numbers its markers from 0.
    let split = marks
        .iter()
        .position(|(_, m)| m["event"] == "session_resume")
        .expect("no session_resume marker");
    assert_in_order(&marks[..split]);
    assert_in_order(&marks[split..]);
    assert_eq!(
        got["marker_source_id"],
        "frictionlab/magnitude-quick/lsl-kill/session-1/seed-3/markers"
    );
    let lines = lsl_lines(&results);
    assert_eq!(lines.len(), 1, "the killed run wrote no lsl line");
    assert_eq!(lines[0]["source_id"], got["marker_source_id"]);
    let at = marks[split].1["at_trial"].as_u64().unwrap();
    let before: Vec<u64> = events(&marks[..split], "trial_start")
        .iter()
        .map(|(_, m)| m["trial"].as_u64().unwrap())
        .collect();
    let after: Vec<u64> = events(&marks[split..], "trial_start")
        .iter()
        .map(|(_, m)| m["trial"].as_u64().unwrap())
        .collect();
    assert_eq!(before, (0..=at).collect::<Vec<_>>(), "killed in trial {at}");
    assert_eq!(after, (at..6).collect::<Vec<_>>());
    // Each record's LSL start is its run's trial_start marker: the resumed
    // run's from trial `at` on, the killed run's before.
    let log = only_log(&results);
    assert_eq!(log.trials.len(), 6);
    for r in &log.trials {
        let run = if r.trial as u64 >= at {
            &marks[split..]
        } else {
            &marks[..split]
        };
        let start = events(run, "trial_start")
            .into_iter()
            .find(|(_, m)| m["trial"].as_u64() == Some(r.trial as u64))
            .map(|(t, _)| *t);
        assert_eq!(r.lsl_start_s, start, "trial {}", r.trial);
    }
}

#[test]
fn publishing_with_no_listener_loses_no_trial_and_changes_no_data() {
    let Some(t) = paced() else {
        return;
    };
    let sim = |out: &Path, lsl: bool| {
        let mut a = vec![
            "simulate",
            "protocols/magnitude-quick.json",
            "--participants",
            "1",
            "--seed",
            "5",
            "--pace",
            "4",
            "--out",
            out.to_str().unwrap(),
        ];
        if lsl {
            a.extend(["--lsl", "--lsl-lib", t.lib.to_str().unwrap()]);
        }
        let o = frictionlab(&a);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    };
    let (with, without) = (t.dir.path().join("with"), t.dir.path().join("without"));
    sim(&with, true);
    sim(&without, false);
    let (a, b) = (only_log(&with), only_log(&without));
    assert_eq!(a.trials.len(), 6);
    assert!(a.ended);
    for (x, y) in a.trials.iter().zip(&b.trials) {
        assert!(x.lsl_start_s.is_some() && y.lsl_start_s.is_none());
        let mut x = x.clone();
        (x.lsl_start_s, x.lsl_end_s) = (None, None);
        assert_eq!(
            &x, y,
            "the published session presented or answered otherwise"
        );
    }
    assert_eq!(lsl_lines(&with)[0]["dropped_samples"], 0);
}

/// `run --lsl` with liblsl nowhere: exit 2, one line saying where it
/// looked and how to install it, nothing written.
#[test]
fn without_liblsl_lsl_exits_2_naming_where_it_looked_and_writes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let results = dir.path().join("r");
    for (flag, env) in [
        (Some("/nonexistent/liblsl.so"), None),
        (None, Some("/nowhere/liblsl.so")),
    ] {
        let mut c = Command::new(BIN);
        c.args([
            "run",
            "protocols/magnitude-quick.json",
            "--participant",
            "p",
        ])
        .args([
            "--out",
            results.to_str().unwrap(),
            "--responder",
            "sim",
            "--lsl",
        ]);
        if let Some(path) = flag {
            c.args(["--lsl-lib", path]);
        }
        match env {
            Some(path) => c.env("FRICTIONLAB_LSL_LIB", path),
            None => c.env_remove("FRICTIONLAB_LSL_LIB"),
        };
        let o = c.output().unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{err}");
        assert_eq!(err.lines().count(), 1, "{err}");
        let place = flag.or(env).unwrap();
        assert!(
            err.starts_with("error: --lsl: liblsl not found (tried "),
            "{err}"
        );
        assert!(err.contains(place), "{err}");
        assert!(err.contains("pip install pylsl"), "{err}");
        assert!(!results.exists(), "something was written");
    }
}

/// A liblsl older than 1.14 is refused with its version.
#[test]
fn a_liblsl_too_old_is_refused_with_its_version() {
    let dir = tempfile::tempdir().unwrap();
    let (src, lib) = (dir.path().join("old.c"), dir.path().join("liblsl.so"));
    // A library that says it is liblsl 1.12 (and has nothing else).
    std::fs::write(&src, "int lsl_library_version(void) { return 112; }\n").unwrap();
    let cc = Command::new("cc")
        .args(["-shared", "-fPIC", "-o"])
        .arg(&lib)
        .arg(&src)
        .status();
    if !cc.is_ok_and(|s| s.success()) {
        assert!(
            std::env::var_os("CI").is_none(),
            "no C compiler (cc) under CI"
        );
        eprintln!("skipped: no C compiler (cc) to build an old liblsl");
        return;
    }
    let results = dir.path().join("r");
    let o = frictionlab(&[
        "run",
        "protocols/magnitude-quick.json",
        "--participant",
        "p",
        "--out",
        results.to_str().unwrap(),
        "--responder",
        "sim",
        "--lsl",
        "--lsl-lib",
        lib.to_str().unwrap(),
    ]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.contains("liblsl 1.12 is too old: frictionlab needs 1.14 or newer"),
        "{err}"
    );
    assert!(!results.exists());
}
