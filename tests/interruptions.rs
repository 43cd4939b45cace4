//! Issue 42: a session interrupted at any moment and resumed gives the data
//! an uninterrupted one gives (the simulated device), byte for byte apart
//! from the aborted rows: SIGINT, SIGTERM and kill -9 to `run` at moments
//! spread over magnitude-quick and fitts-quick sessions of several seeds,
//! and the window's Pause (the calls the window makes, frame by frame);
//! and sessions of log format 1 still read, analyse and resume.
//!
//! Why it holds, by design: session time counts whole nanoseconds, so a
//! trial lasts the same number of ticks wherever it starts; each trial
//! starts from rest with the participant's randomness, clock and movement
//! segments its own; a signal or pause aborts the trial under way, which
//! is presented again in full.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    reason = "a failed unwrap is a failed test"
)]

use std::os::unix::process::ExitStatusExt;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use frictionlab::kinds::{LogLine, Registry};
use frictionlab::protocol::engine::Status;
use frictionlab::results::{ResultsDir, data_csv, read_log};
use frictionlab::session::{
    DeviceChoice, Feed, SessionRequest, SessionState, participant_seed, sim_id, sim_participant,
};
use frictionlab::time::Time;

const BIN: &str = env!("CARGO_BIN_EXE_frictionlab");

fn protocol(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("protocols/{name}.json"))
}

/// `run PROTOCOL --participant s --responder sim --seed SEED` into `out`.
fn run(name: &str, out: &Path, seed: u64, extra: &[&str]) -> Command {
    let mut c = Command::new(BIN);
    c.arg("run")
        .arg(protocol(name))
        .args(["--participant", "s", "--responder", "sim"])
        .arg("--out")
        .arg(out)
        .args(["--seed", &seed.to_string()])
        .args(extra)
        .stdout(Stdio::null())
        .stderr(Stdio::piped());
    c
}

/// `o` is a success, or the test fails with `what` and its stderr.
fn succeeded(o: &std::process::Output, what: &str) {
    assert!(
        o.status.success(),
        "{what}: {}",
        String::from_utf8_lossy(&o.stderr)
    );
}

/// The one data CSV and log of a results folder, and the temporaries of
/// an atomic rewrite a kill -9 cut short (`.NAME.PID.N.partial`).
fn files(out: &Path) -> (PathBuf, PathBuf, Vec<PathBuf>) {
    let mut partials = Vec::new();
    let mut pick = |dir: &str| {
        let (temporaries, mut v): (Vec<PathBuf>, Vec<PathBuf>) = std::fs::read_dir(out.join(dir))
            .unwrap()
            .map(|e| e.unwrap().path())
            .partition(|p| p.to_string_lossy().ends_with(".partial"));
        partials.extend(temporaries);
        assert_eq!(v.len(), 1, "{v:?}");
        v.remove(0)
    };
    let (csv, log) = (pick("data"), pick("logs"));
    (csv, log, partials)
}

/// The data CSV of `read` without the rows of its aborted presentations
/// that were presented again (a signal's, a pause's): what an
/// uninterrupted run would have written. A CSV row per record, in order.
fn without_requeued(csv: &str, read: &frictionlab::kinds::ReadLog) -> String {
    let mut lines = csv.lines();
    let mut out = format!("{}\n", lines.next().unwrap());
    let rows: Vec<&str> = lines.collect();
    assert_eq!(rows.len(), read.trials.len(), "a CSV row per record");
    for (row, r) in rows.iter().zip(&read.trials) {
        if !r.requeued {
            out.push_str(row);
            out.push('\n');
        }
    }
    out
}

/// One interrupted run: which signal, how it ended, and whether the data
/// matched.
#[derive(Debug)]
struct Case {
    protocol: &'static str,
    seed: u64,
    signal: &'static str,
    at_s: f64,
}

/// Runs `case` paced at `pace`, signals it `at_s` seconds after its log
/// appears, resumes it, and compares its data CSV with `reference`.
/// Whether the signal landed before the session's end.
fn interrupt_and_resume(case: &Case, pace: f64, reference: &str) -> bool {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path();
    let mut child = run(
        case.protocol,
        out,
        case.seed,
        &["--pace", &pace.to_string()],
    )
    .spawn()
    .unwrap();
    let start = Instant::now();
    // The session has started once its files are all there: the log is
    // written (and synced) before the data CSV is made, so under load a
    // signal sent when only the log exists would land before the session.
    let started =
        |dir: &str| std::fs::read_dir(out.join(dir)).is_ok_and(|mut d| d.next().is_some());
    while !(started("logs") && started("data")) {
        assert!(start.elapsed() < Duration::from_mins(1), "{case:?}: no log");
        std::thread::sleep(Duration::from_millis(2));
    }
    std::thread::sleep(Duration::from_secs_f64(case.at_s));
    let sent = Command::new("kill")
        .args([&format!("-{}", case.signal), &child.id().to_string()])
        .status()
        .unwrap()
        .success();
    let status = child.wait().unwrap();
    let stderr = {
        use std::io::Read;
        let mut s = String::new();
        child.stderr.take().unwrap().read_to_string(&mut s).unwrap();
        s
    };
    let (csv, log, partials) = files(out);
    // Only a kill -9 can leave a rewrite's temporary.
    assert!(
        partials.is_empty() || case.signal == "KILL",
        "{case:?}: {partials:?}"
    );
    let interrupted = if status.success() {
        false
    } else {
        assert!(sent, "{case:?}: the signal could not be sent");
        match case.signal {
            "KILL" => assert_eq!(status.signal(), Some(9), "{case:?}"),
            "INT" => assert_eq!(status.code(), Some(130), "{case:?}: {stderr}"),
            _ => assert_eq!(status.code(), Some(143), "{case:?}: {stderr}"),
        }
        let read = read_log::<Registry>(&log).unwrap();
        assert!(!read.ended, "{case:?}");
        if case.signal != "KILL" {
            // The trial under way is logged as aborted (interrupted), then
            // the signal.
            let text = std::fs::read_to_string(&log).unwrap();
            let last: LogLine = serde_json::from_str(text.lines().last().unwrap()).unwrap();
            assert_eq!(
                last,
                LogLine::Interrupted {
                    signal: format!("SIG{}", case.signal)
                },
                "{case:?}"
            );
            let r = read.trials.last().unwrap();
            assert_eq!(
                (r.status, r.abort_reason.as_deref(), r.requeued),
                (Status::Aborted, Some("interrupted"), true),
                "{case:?}"
            );
        }
        let o = run(
            case.protocol,
            out,
            case.seed,
            &["--resume", "--pace", "1e6"],
        )
        .output()
        .unwrap();
        succeeded(&o, &format!("{case:?}"));
        true
    };
    let read = read_log::<Registry>(&log).unwrap();
    assert!(read.ended, "{case:?}");
    // The resume removed what the kill left.
    assert_eq!(files(out).2, Vec::<PathBuf>::new(), "{case:?}");
    let got = without_requeued(&std::fs::read_to_string(&csv).unwrap(), &read);
    assert_eq!(
        got, reference,
        "{case:?}: the resumed session's data differ from the uninterrupted run's"
    );
    interrupted
}

/// SIGINT, SIGTERM and kill -9, each at 36 moments: 2 protocols x 3 seeds
/// x 6 moments spread over the session's paced length (5% to 90% of it).
/// At least 30 of each signal must land before the session's end; every
/// resumed session's data CSV equals the uninterrupted run's, byte for
/// byte, apart from the rows of the presentations the signal cut short.
#[test]
fn a_signal_at_any_moment_then_resume_gives_the_uninterrupted_data_issue_42() {
    // Paced so each session lasts about a second of wall time.
    let protocols = [("magnitude-quick", 10.0), ("fitts-quick", 25.0)];
    let seeds = [11_u64, 12, 13];
    let mut references = Vec::new();
    for (name, pace) in protocols {
        for seed in seeds {
            let dir = tempfile::tempdir().unwrap();
            let o = run(name, dir.path(), seed, &["--pace", "1e6"])
                .output()
                .unwrap();
            assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
            let (csv, log, _) = files(dir.path());
            let read = read_log::<Registry>(&log).unwrap();
            let length_s = read.trials.last().unwrap().ended_s.secs() / pace;
            let text = std::fs::read_to_string(csv).unwrap();
            assert!(read.trials.iter().all(|r| !r.requeued));
            references.push((name, pace, seed, length_s, text));
        }
    }
    let mut cases = Vec::new();
    for signal in ["INT", "TERM", "KILL"] {
        for (r, &(name, pace, seed, length_s, _)) in references.iter().enumerate() {
            for k in 0..6 {
                let at_s = length_s * (0.05 + 0.85 * f64::from(k) / 5.0);
                cases.push((
                    r,
                    pace,
                    Case {
                        protocol: name,
                        seed,
                        signal,
                        at_s,
                    },
                ));
            }
        }
    }
    let results = frictionlab::parallel::run(&cases, 3, |(r, pace, case)| {
        Ok::<_, ()>((
            case.signal,
            interrupt_and_resume(case, *pace, &references[*r].4),
        ))
    });
    let mut landed = std::collections::BTreeMap::new();
    for (signal, interrupted) in results.into_iter().map(Result::unwrap) {
        let e = landed.entry(signal).or_insert((0, 0));
        e.0 += usize::from(interrupted);
        e.1 += 1;
    }
    eprintln!("interrupted before the end / runs: {landed:?}");
    for (signal, (interrupted, runs)) in &landed {
        assert!(
            *interrupted >= 30,
            "SIG{signal}: only {interrupted} of {runs} runs were interrupted"
        );
    }
}

/// The window's Pause at any moment: the session is driven as the window
/// drives it (`advance` once per 60 Hz frame), paused at a frame, left
/// paused for a while, resumed, and run to its end. Its records, made
/// into a data CSV, are an uninterrupted session's apart from the aborted
/// presentations a pause cut short: 30 pause moments over magnitude-quick and
/// fitts-quick.
#[test]
fn a_pause_at_any_moment_gives_the_uninterrupted_data_issue_42() {
    for (name, frames_long) in [("magnitude-quick", 800_u32), ("fitts-quick", 1500)] {
        let (p, bytes) = frictionlab::protocol::load::read::<Registry>(&protocol(name)).unwrap();
        let session = |pause_at: Option<u32>| {
            let dir = tempfile::tempdir().unwrap();
            let results = ResultsDir::new(dir.path());
            let req = SessionRequest {
                protocol: &p,
                protocol_bytes: &bytes,
                participant: &sim_id(0),
                participant_index: Some(0),
                seed: participant_seed(7, 0),
                resume: false,
                pace: None,
                device: &DeviceChoice::Simulated,
                streams: false,
                population: None,
                sound: frictionlab::session::sound::Sound::default(),
                lsl: None,
            };
            let mut s =
                frictionlab::session::Session::begin(&results, &req, sim_participant).unwrap();
            let mut frame = 0_u32;
            let mut paused = 0;
            while s.state() != SessionState::Finished {
                frame += 1;
                let wall = f64::from(frame) / 60.0;
                if Some(frame) == pause_at {
                    s.handle(Feed::Pause).unwrap();
                }
                if s.state() == SessionState::Paused {
                    paused += 1;
                    if paused == 40 {
                        s.handle(Feed::Resume).unwrap();
                    }
                }
                s.handle(Feed::Frame(wall)).unwrap();
                assert!(frame < 100_000, "{name}: the session never ended");
            }
            let read = read_log::<Registry>(s.log_path()).unwrap();
            (without_requeued(&data_csv(&read), &read), read.trials.len())
        };
        let (reference, trials) = session(None);
        let mut aborted = 0;
        for k in 0..15 {
            let at = 10 + k * (frames_long - 20) / 15;
            let (got, n) = session(Some(at));
            aborted += n - trials;
            assert_eq!(got, reference, "{name}: paused at frame {at}");
        }
        eprintln!("{name}: 15 pauses, {aborted} of them in a trial, each the uninterrupted data");
        assert!(
            aborted >= 10,
            "{name}: only {aborted} pauses landed in a trial"
        );
    }
}

/// Sessions written before issue 42 (log format 1, float session times,
/// Fitts times on the session clock; `tests/fixtures/log-v1/`, each ended
/// by SIGINT mid-trial) still analyse as they are, and resume: the resume
/// starts where the last record ended (on the tick grid), presents the
/// interrupted trial again, marks its `resumed` line with the records'
/// new format, and the folder analyses again.
#[test]
fn sessions_of_log_format_1_still_read_analyse_and_resume_issue_42() {
    for name in ["magnitude-quick", "fitts-quick"] {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path();
        let fixture = Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("tests/fixtures/log-v1")
            .join(name);
        copy_dir(&fixture, out);
        let analyze = |report: &str| {
            let o = Command::new(BIN)
                .arg("analyze")
                .arg(out)
                .arg("--out")
                .arg(out.join(report))
                .output()
                .unwrap();
            succeeded(&o, name);
        };
        analyze("report-before");
        let (_, log, _) = files(out);
        let before = read_log::<Registry>(&log).unwrap();
        assert_eq!(before.header.format, "frictionlab-log/1");
        let last_end = before.trials.last().unwrap().ended_s;
        let interrupted = before.trials.last().unwrap().trial;
        let o = Command::new(BIN)
            .arg("run")
            .arg(protocol(name))
            .args(["--participant", "old", "--responder", "sim", "--resume"])
            .args(["--pace", "1e6", "--out"])
            .arg(out)
            .output()
            .unwrap();
        succeeded(&o, name);
        let after = read_log::<Registry>(&log).unwrap();
        assert!(after.ended);
        let new = &after.trials[before.trials.len()..];
        assert_eq!(new[0].trial, interrupted, "the interrupted trial again");
        let tick = Time::from_ns(200_000);
        assert!(new[0].started_s >= last_end, "the clock goes on");
        for r in new {
            assert_eq!(r.started_s.ceil_to(tick), r.started_s, "on the tick grid");
            assert_eq!(r.ended_s.ceil_to(tick), r.ended_s, "on the tick grid");
        }
        let text = std::fs::read_to_string(&log).unwrap();
        let resumed = text
            .lines()
            .filter_map(|l| serde_json::from_str::<LogLine>(l).ok())
            .find(|l| matches!(l, LogLine::Resumed { .. }))
            .unwrap();
        assert!(
            matches!(resumed, LogLine::Resumed { format: Some(ref f), .. } if f == "frictionlab-log/2"),
            "{resumed:?}"
        );
        analyze("report-after");
    }
}

fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for e in std::fs::read_dir(from).unwrap() {
        let e = e.unwrap();
        let target = to.join(e.file_name());
        if e.file_type().unwrap().is_dir() {
            copy_dir(&e.path(), &target);
        } else {
            std::fs::copy(e.path(), target).unwrap();
        }
    }
}

/// A kill -9 in the middle of a file's atomic rewrite leaves its
/// temporary (`.NAME.PID.N.partial`; the file itself is whole). The resume,
/// which holds the session's lock, removes those of its own session's CSV
/// and streams, and nothing else.
#[test]
fn a_resume_removes_the_temporaries_a_kill_left_of_its_own_files_only() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path();
    let fixture =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/log-v1/magnitude-quick");
    copy_dir(&fixture, out);
    let (csv, _, _) = files(out);
    let name = csv.file_name().unwrap().to_string_lossy().into_owned();
    let stem = name.trim_end_matches("_data.csv");
    std::fs::create_dir_all(out.join("streams")).unwrap();
    let ours = [
        out.join("data").join(format!(".{name}.999999.3.partial")),
        out.join("streams")
            .join(format!(".{stem}_trial-2_run-1_stream.csv.999999.4.partial")),
    ];
    let others = [
        out.join("data")
            .join(".study-other_subject-old_session-1_data.csv.999999.1.partial"),
        out.join("streams").join(format!(
            ".{stem}x_trial-2_run-1_stream.csv.999999.5.partial"
        )),
    ];
    for p in ours.iter().chain(&others) {
        std::fs::write(p, "half a fil").unwrap();
    }
    let o = Command::new(BIN)
        .arg("run")
        .arg(protocol("magnitude-quick"))
        .args(["--participant", "old", "--responder", "sim", "--resume"])
        .args(["--pace", "1e6", "--out"])
        .arg(out)
        .output()
        .unwrap();
    succeeded(&o, "resume");
    for p in &ours {
        assert!(!p.exists(), "{} left", p.display());
    }
    for p in &others {
        assert!(p.exists(), "{} removed", p.display());
    }
}
