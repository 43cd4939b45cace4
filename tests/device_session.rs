//! Whole sessions on the emulated device over a pseudo-terminal: a quick
//! session end to end, an emulator killed mid-trial and restarted, a
//! device that never comes back (exit 3, completed trials intact), one that
//! never answers (exit 3, nothing written), paths that are no port, and a
//! model felt from the builder on the emulated device.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    reason = "a failed unwrap is a failed test"
)]

use crate::common;

use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use frictionlab::kinds::{Action, LogLine, Registry};
use frictionlab::protocol::engine::Status;
use frictionlab::results::read_log;
use frictionlab::session::Feed;

fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_frictionlab"))
}

fn run(protocol: &str, out: &Path, dev: &Path, extra: &[&str]) -> Child {
    let p = format!("{}/protocols/{protocol}.json", env!("CARGO_MANIFEST_DIR"));
    let mut args = vec![
        "run",
        &p,
        "--participant",
        "dev",
        "--out",
        out.to_str().unwrap(),
        "--device",
        dev.to_str().unwrap(),
        "--responder",
        "sim",
        "--seed",
        "5",
    ];
    args.extend_from_slice(extra);
    bin()
        .args(&args)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap()
}

fn log_of(out: &Path, protocol: &str) -> std::path::PathBuf {
    out.join(format!(
        "logs/study-{}_subject-dev_session-1_log.jsonl",
        protocol.replace('-', "")
    ))
}

#[test]
fn a_quick_session_runs_end_to_end_on_the_emulated_device() {
    let dir = tempfile::tempdir().unwrap();
    let dev = dir.path().join("dev");
    let mut emu = common::emulator(&dev);
    let out = dir.path().join("results");
    let o = run("paired-quick", &out, &dev, &[])
        .wait_with_output()
        .unwrap();
    emu.kill().unwrap();
    emu.wait().unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let text = std::fs::read_to_string(log_of(&out, "paired-quick")).unwrap();
    let log = read_log::<Registry>(&log_of(&out, "paired-quick")).unwrap();
    assert!(log.ended && log.trials.len() == 1 && log.trials[0].status == Status::Completed);
    assert_eq!(log.header.device, dev.to_str().unwrap());
    let stats = text
        .lines()
        .filter_map(|l| match serde_json::from_str::<LogLine>(l) {
            Ok(LogLine::Loop(s)) => Some(s),
            _ => None,
        });
    let stats: Vec<_> = stats.collect();
    assert_eq!(stats.len(), 1, "loop statistics in the session log");
    assert!(stats[0].ticks > 1000 && stats[0].rate_hz == 1000.0);
    println!("{}", common::assert_whole_streams(&out, &log, 1000.0));
    // The emulator states the simulated apparatus's limit, 9.48 N in the
    // wire's f32, just below the loop's 9.48: that is the limit in force.
    let apparatus = frictionlab::device::sim::Apparatus::default();
    let stated = f64::from(apparatus.stated().max_force_n);
    assert!(stated < 9.48);
    println!(
        "{}",
        common::assert_force_limits(&log, stated, stated, apparatus.travel_m())
    );
}

#[test]
fn an_emulator_killed_mid_trial_and_restarted_costs_one_requeued_trial() {
    let dir = tempfile::tempdir().unwrap();
    let dev = dir.path().join("dev");
    let emu = common::emulator(&dev);
    let out = dir.path().join("results");
    let session = run("magnitude-quick", &out, &dev, &["--device-timeout", "20"]);
    // Unplugged 0.7 s into the trial after the first record (trials take
    // 2 s), counted from that record, not from the start of the process:
    // a start slowed by a loaded machine (CI: at a fixed 3.2 s from the
    // spawn, the unplug fell between trials and no trial was aborted) moves
    // it with the session.
    let path = log_of(&out, "magnitude-quick");
    common::lost_mid_trial(
        &path,
        session,
        || common::unplug(emu, &dev),
        || common::emulator(&dev),
    );
    let log = read_log::<Registry>(&path).unwrap();
    let aborted: Vec<_> = log
        .trials
        .iter()
        .filter(|r| r.status == Status::Aborted)
        .collect();
    assert_eq!(
        aborted.len(),
        1,
        "{:?}",
        log.trials
            .iter()
            .map(|r| (r.trial, r.status))
            .collect::<Vec<_>>()
    );
    assert!(aborted[0].requeued && aborted[0].abort_reason.as_deref() == Some("device lost"));
    assert_eq!(
        common::completed_trials(&log),
        (0..6).collect::<Vec<_>>(),
        "every planned trial completed once"
    );
}

#[test]
fn a_device_that_never_comes_back_ends_the_run_with_exit_3() {
    let dir = tempfile::tempdir().unwrap();
    let dev = dir.path().join("dev");
    let emu = common::emulator(&dev);
    let out = dir.path().join("results");
    let session = run("magnitude-quick", &out, &dev, &["--device-timeout", "1.5"]);
    // Unplugged once a trial is on disk (a fixed wait can come before the
    // first trial ends on a loaded machine).
    let log = log_of(&out, "magnitude-quick");
    let waited = Instant::now();
    while !read_log::<Registry>(&log)
        .is_ok_and(|l| l.trials.iter().any(|r| r.status == Status::Completed))
    {
        assert!(
            waited.elapsed() < Duration::from_mins(1),
            "no trial completed"
        );
        std::thread::sleep(Duration::from_millis(50));
    }
    common::unplug(emu, &dev);
    let started = Instant::now();
    let o = session.wait_with_output().unwrap();
    assert_eq!(
        o.status.code(),
        Some(3),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    assert!(started.elapsed() < Duration::from_secs(10));
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(
        stderr.contains("no answer from the device for 1.5 s"),
        "{stderr}"
    );
    let log = read_log::<Registry>(&log_of(&out, "magnitude-quick")).unwrap();
    assert!(!log.ended);
    let completed = log
        .trials
        .iter()
        .filter(|r| r.status == Status::Completed)
        .count();
    assert!(completed >= 1, "completed trials kept: {completed}");
    let csv = std::fs::read_to_string(
        out.join("data/study-magnitudequick_subject-dev_session-1_data.csv"),
    )
    .unwrap();
    assert!(csv.lines().count() > completed, "the CSV has them too");
}

#[test]
fn a_device_that_never_answers_starts_no_session_and_exits_3() {
    // A port that is there but silent (a powered-off device): a
    // pseudo-terminal whose other end never speaks.
    let (_master, slave) = common::pty_pair();
    let port = serialport::SerialPort::name(&slave).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("results");
    let started = Instant::now();
    let o = run(
        "paired-quick",
        &out,
        Path::new(&port),
        &["--device-timeout", "1"],
    )
    .wait_with_output()
    .unwrap();
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(3), "{stderr}");
    assert!(
        stderr.contains("no answer from the device for 1 s; no session was started"),
        "{stderr}"
    );
    assert!(started.elapsed() < Duration::from_secs(8));
    assert!(!out.exists(), "nothing written");

    // An unfinished session (a real-time run on the simulated device,
    // killed) resumed on the silent port stays exactly as it was.
    let mut first = run("paired-quick", &out, Path::new("sim"), &["--pace", "1"]);
    std::thread::sleep(Duration::from_millis(1500));
    first.kill().unwrap();
    first.wait().unwrap();
    let log = log_of(&out, "paired-quick");
    let before = std::fs::read(&log).unwrap();
    let o = run(
        "paired-quick",
        &out,
        Path::new(&port),
        &["--device-timeout", "1", "--resume"],
    )
    .wait_with_output()
    .unwrap();
    assert_eq!(o.status.code(), Some(3));
    assert_eq!(std::fs::read(&log).unwrap(), before, "the log is untouched");
    drop(slave);
}

/// Issue 63: `run` holds the protocol against the connected device's
/// travel before the first trial: our board (built as seed 002's
/// apparatus, ±16 mm) refuses a Fitts level at ±25 mm, exit 2, naming the
/// level, the device and its travel, and nothing is written.
#[test]
fn a_protocol_beyond_the_boards_travel_is_refused_before_the_first_trial() {
    let dir = tempfile::tempdir().unwrap();
    let dev = dir.path().join("dev");
    let emu = common::emulator(&dev);
    let out = dir.path().join("results");
    let wide = format!(
        "{}/tests/fixtures/fitts-wide.json",
        env!("CARGO_MANIFEST_DIR")
    );
    let o = bin()
        .args([
            "run",
            &wide,
            "--participant",
            "dev",
            "--responder",
            "sim",
            "--out",
        ])
        .arg(&out)
        .arg("--device")
        .arg(&dev)
        .output()
        .unwrap();
    common::unplug(emu, &dev);
    let stderr = String::from_utf8_lossy(&o.stderr);
    println!("exit {:?}: {stderr}", o.status.code());
    assert_eq!(o.status.code(), Some(2), "{stderr}");
    assert_eq!(
        stderr,
        format!(
            "error: {wide}: design.levels[1]: targets at ±25 mm, 4 mm wide reach -27.0 to 27.0 mm \
             along the track, beyond the device {}'s travel of -16.0 to 16.0 mm\n",
            dev.display()
        )
    );
    assert!(!out.exists(), "nothing written");
}

#[test]
fn a_device_path_that_is_not_a_serial_port_is_bad_input() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("notes.txt");
    std::fs::write(&file, "not a port").unwrap();
    let out = dir.path().join("results");
    for (dev, what) in [
        (file.as_path(), "a regular file, not a serial port"),
        (dir.path(), "a directory, not a serial port"),
    ] {
        let o = run("paired-quick", &out, dev, &[])
            .wait_with_output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{stderr}");
        assert!(
            stderr.starts_with(&format!("error: --device: {}: {what}", dev.display())),
            "{stderr}"
        );
        assert!(!out.exists(), "nothing written");
    }
}

/// The session the GUI drives, on the emulated device: the pointer's hand
/// drive moves the device, answers go in, the live status reports the loop,
/// and every trial is logged with the responder `gui`.
#[test]
fn a_live_gui_session_runs_on_the_emulated_device() {
    use frictionlab::protocol::engine::{Answer, Input, Screen};
    use frictionlab::session::SessionRequest;
    use frictionlab::session::{DeviceChoice, Feed, LiveSession, SessionState};

    let dir = tempfile::tempdir().unwrap();
    let dev = dir.path().join("dev");
    let mut emu = common::emulator(&dev);
    let path = format!(
        "{}/protocols/magnitude-quick.json",
        env!("CARGO_MANIFEST_DIR")
    );
    let (protocol, bytes) =
        frictionlab::protocol::load::read::<Registry>(Path::new(&path)).unwrap();
    let results = frictionlab::results::ResultsDir::new(dir.path().join("results"));
    let device = DeviceChoice::port(dev.clone());
    let req = SessionRequest {
        protocol: &protocol,
        protocol_bytes: &bytes,
        participant: "gui-dev",
        participant_index: None,
        seed: 9,
        resume: false,
        pace: None,
        device: &device,
        streams: true,
        population: None,
        sound: frictionlab::session::sound::Sound::default(),
        lsl: None,
    };
    let mut live = LiveSession::start(&results, &req).unwrap();
    // Typed before the device has answered: kept until the log exists.
    live.feed(Feed::Note("typed while connecting".into()))
        .unwrap();
    let start = Instant::now();
    let mut followed = false;
    let mut p99 = None;
    while live.state() != SessionState::Finished && start.elapsed() < Duration::from_secs(40) {
        live.feed(Feed::Frame(start.elapsed().as_secs_f64()))
            .unwrap();
        live.set_hand_target(Some(0.004));
        let status = live.device_status();
        if status.connected && (status.x_m - 0.004).abs() < 1e-3 {
            followed = true;
            p99 = p99.or(status.period_p99_s);
        }
        let input = match live.view().screen {
            Some(Screen::Instructions(_) | Screen::Break { .. }) => Some(Input::Continue),
            Some(Screen::Explore { .. }) if followed => {
                Some(Input::Answer(Answer::Magnitude("2".into())))
            }
            _ => None,
        };
        if let Some(input) = input {
            live.feed(Feed::Input(input)).unwrap();
        }
        std::thread::sleep(Duration::from_millis(5));
    }
    emu.kill().unwrap();
    emu.wait().unwrap();
    assert_eq!(live.state(), SessionState::Finished, "{:?}", live.view());
    assert!(followed, "the device followed the pointer's hand drive");
    let p99 = p99.expect("the loop period is reported");
    assert!(p99 > 0.0 && p99.is_finite());
    assert_eq!(
        live.device_status().rate_hz,
        5000.0,
        "stick-slip needs 5 kHz"
    );
    let read = read_log::<Registry>(live.log_path()).unwrap();
    assert!(read.ended);
    assert_eq!(read.header.responder, "gui");
    assert_eq!(read.header.device, device.label());
    assert_eq!(read.trials.len(), 6);
    assert!(read.trials.iter().all(|r| r.status == Status::Completed));
    let text = std::fs::read_to_string(live.log_path()).unwrap();
    let lines: Vec<LogLine> = text
        .lines()
        .filter_map(|l| serde_json::from_str::<LogLine>(l).ok())
        .collect();
    assert!(lines.iter().any(|l| matches!(l, LogLine::Loop(_))));
    assert!(
        lines
            .iter()
            .any(|l| matches!(l, LogLine::Note { text } if text == "typed while connecting"))
    );
}

/// The window's session on a port that never answers: the trials wait,
/// the status says not connected, and an abort leaves no session behind.
#[test]
fn a_live_session_on_a_silent_device_writes_nothing() {
    use frictionlab::session::SessionRequest;
    use frictionlab::session::{DeviceChoice, Feed, LiveSession, SessionState};

    let (_master, slave) = common::pty_pair();
    let port = serialport::SerialPort::name(&slave).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let path = format!("{}/protocols/paired-quick.json", env!("CARGO_MANIFEST_DIR"));
    let (protocol, bytes) =
        frictionlab::protocol::load::read::<Registry>(Path::new(&path)).unwrap();
    let out = dir.path().join("results");
    let results = frictionlab::results::ResultsDir::new(&out);
    let req = SessionRequest {
        protocol: &protocol,
        protocol_bytes: &bytes,
        participant: "silent",
        participant_index: None,
        seed: 2,
        resume: false,
        pace: None,
        device: &DeviceChoice::port(&port),
        streams: true,
        population: None,
        sound: frictionlab::session::sound::Sound::default(),
        lsl: None,
    };
    let mut live = LiveSession::start(&results, &req).unwrap();
    assert_eq!(live.session(), 1);
    live.feed(Feed::Note("waiting for the device".into()))
        .unwrap();
    let start = Instant::now();
    while start.elapsed() < Duration::from_millis(1500) {
        live.feed(Feed::Frame(start.elapsed().as_secs_f64()))
            .unwrap();
        std::thread::sleep(Duration::from_millis(10));
    }
    assert!(!live.device_status().connected);
    assert!(live.view().screen.is_none(), "no trial started");
    assert!(!out.exists(), "nothing written while waiting");
    live.feed(Feed::Abort).unwrap();
    assert_eq!(live.state(), SessionState::Aborted);
    assert!(!out.exists(), "nothing written after the abort");
    assert!(!live.log_path().exists());
    drop(slave);
}

/// Issue 13: a resumed `run --device` session went on from session time 0
/// (trial 3 started at 0.002 s after trial 2 ended at 6.006 s, and its
/// stream restarted too). The device's clock is now only mapped onto the
/// session clock: trial and stream times never go backwards across a
/// kill -9 and a resume.
#[test]
fn a_resumed_device_session_keeps_its_clock_going() {
    let dir = tempfile::tempdir().unwrap();
    let dev = dir.path().join("dev");
    let mut emu = common::emulator(&dev);
    let out = dir.path().join("results");
    let mut first = run("magnitude-quick", &out, &dev, &[]);
    // Instructions, then 2 s trials: two trials are logged after about 4.5 s.
    let log = log_of(&out, "magnitude-quick");
    let start = Instant::now();
    while read_log::<Registry>(&log).map_or(0, |l| l.trials.len()) < 2
        && start.elapsed().as_secs() < 30
    {
        std::thread::sleep(Duration::from_millis(20));
    }
    first.kill().unwrap(); // SIGKILL
    first.wait().unwrap();
    let o = run("magnitude-quick", &out, &dev, &["--resume"])
        .wait_with_output()
        .unwrap();
    emu.kill().unwrap();
    emu.wait().unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let read = read_log::<Registry>(&log).unwrap();
    assert!(read.ended && read.trials.len() >= 6, "{:?}", read.trials);
    let mut last_end = 0.0_f64;
    let mut runs = std::collections::HashMap::new();
    for r in &read.trials {
        let (started_s, ended_s) = (r.started_s.secs(), r.ended_s.secs());
        assert!(
            started_s >= last_end && ended_s >= started_s,
            "trial {} runs {started_s}..{ended_s} s after a trial that ended at {last_end} s",
            r.trial,
        );
        last_end = ended_s;
        let run_no = runs.entry(r.trial).and_modify(|n| *n += 1).or_insert(1);
        let stream = out.join(format!(
            "streams/study-magnitudequick_subject-dev_session-1_trial-{}_run-{run_no}_stream.csv",
            r.trial
        ));
        let Ok(text) = std::fs::read_to_string(&stream) else {
            continue; // killed before its stream was written
        };
        let times: Vec<f64> = text
            .lines()
            .skip(1)
            .map(|l| l.split(',').next().unwrap().parse().unwrap())
            .collect();
        assert!(!times.is_empty());
        assert!(
            times.windows(2).all(|w| w[1] >= w[0])
                && times[0] >= started_s - 0.01
                && times[times.len() - 1] <= ended_s + 0.01,
            "trial {}: stream {}..{} s outside the trial's {}..{} s",
            r.trial,
            times[0],
            times[times.len() - 1],
            r.started_s,
            r.ended_s
        );
    }
}

/// A responder that continues past instructions and breaks but never
/// answers: it holds a trial in its answer phase.
struct Waiting;

impl frictionlab::session::Responder for Waiting {
    const LABEL: &'static str = "sim";
    fn hand_mass_kg(&self) -> f64 {
        0.4
    }
    fn on_action(
        &mut self,
        _: frictionlab::time::Time,
        action: &frictionlab::kinds::Action,
        _: Option<&frictionlab::kinds::PlannedTrial>,
    ) -> frictionlab::session::Reaction {
        use frictionlab::protocol::engine::{Input, Screen};
        let inputs = match action {
            Action::Show(Screen::Instructions(_) | Screen::Break { .. }) => vec![Input::Continue],
            _ => vec![],
        };
        frictionlab::session::Reaction {
            inputs,
            reset_to: None,
        }
    }
    fn decide(
        &mut self,
        _: frictionlab::time::Time,
        _: &frictionlab::device::DeviceSample,
    ) -> frictionlab::session::Reaction {
        frictionlab::session::Reaction::default()
    }
    fn drive(
        &self,
        _: frictionlab::time::Time,
        _: &frictionlab::device::DeviceSample,
    ) -> Option<frictionlab::hand::HandDrive> {
        None
    }
    fn hand_force(
        &mut self,
        _: frictionlab::time::Time,
        _: f64,
        _: &frictionlab::device::DeviceSample,
    ) -> f64 {
        0.0
    }
}

fn magnitude_quick() -> (frictionlab::kinds::Protocol, Vec<u8>) {
    let path = format!(
        "{}/protocols/magnitude-quick.json",
        env!("CARGO_MANIFEST_DIR")
    );
    frictionlab::protocol::load::read::<Registry>(Path::new(&path)).unwrap()
}

/// The one record of a session whose device was lost in trial 0's answer
/// phase: aborted, re-queued, "device lost", after the 2 s exploration.
fn assert_lost_in_answer_phase(log: &Path) {
    let read = read_log::<Registry>(log).unwrap();
    assert_eq!(read.trials.len(), 1, "{:?}", read.trials);
    let r = &read.trials[0];
    assert_eq!(
        (r.trial, r.status, r.requeued, r.abort_reason.as_deref()),
        (0, Status::Aborted, true, Some("device lost"))
    );
    assert!(
        r.ended_s > r.started_s + frictionlab::time::Time::from_whole_secs(2),
        "lost after the exploration"
    );
}

/// Issue 13: headless device runs counted a trial as live only while a
/// model was rendered, so a device lost while the participant was answering
/// aborted nothing. The one lost-device rule aborts and re-queues it.
#[test]
fn a_device_lost_in_the_answer_phase_costs_that_trial_headless() {
    use frictionlab::session::{DeviceChoice, SessionError, SessionRequest, run_device};
    let dir = tempfile::tempdir().unwrap();
    let dev = dir.path().join("dev");
    let emu = common::emulator(&dev);
    let results = frictionlab::results::ResultsDir::new(dir.path().join("results"));
    let device = DeviceChoice::port(dev.clone());
    let runner = std::thread::spawn(move || {
        let (protocol, bytes) = magnitude_quick();
        let req = SessionRequest {
            protocol: &protocol,
            protocol_bytes: &bytes,
            participant: "waits",
            participant_index: None,
            seed: 3,
            resume: false,
            pace: None,
            device: &device,
            streams: true,
            population: None,
            sound: frictionlab::session::sound::Sound::default(),
            lsl: None,
        };
        run_device(&results, &req, 1.0, |_| Waiting, None, &mut |_, _| {})
    });
    // Exploration 0-2 s, then the question waits.
    std::thread::sleep(Duration::from_millis(3500));
    common::unplug(emu, &dev);
    let e = runner.join().unwrap().unwrap_err();
    assert!(matches!(e, SessionError::Lost { completed: 0, .. }), "{e}");
    assert_lost_in_answer_phase(
        &dir.path()
            .join("results/logs/study-magnitudequick_subject-waits_session-1_log.jsonl"),
    );
}

/// A magnitude-quick session in the window on the device at `dev`, its
/// results under `dir/results`, advanced every 2 ms (its first screen
/// continued) until `until(session, when it was continued)` or 20 s.
/// Returns it and the wall clock it was advanced on.
fn live_magnitude_quick(
    dir: &Path,
    dev: &Path,
    participant: &str,
    mut until: impl FnMut(&frictionlab::session::LiveSession, Option<Instant>) -> bool,
) -> (frictionlab::session::LiveSession, Instant) {
    use frictionlab::session::{DeviceChoice, Feed, LiveSession, SessionRequest};
    let (protocol, bytes) = magnitude_quick();
    let results = frictionlab::results::ResultsDir::new(dir.join("results"));
    let req = SessionRequest {
        protocol: &protocol,
        protocol_bytes: &bytes,
        participant,
        participant_index: None,
        seed: 3,
        resume: false,
        pace: None,
        device: &DeviceChoice::port(dev),
        streams: true,
        population: None,
        sound: frictionlab::session::sound::Sound::default(),
        lsl: None,
    };
    let mut live = LiveSession::start(&results, &req).unwrap();
    let start = Instant::now();
    let mut continued = None;
    while !until(&live, continued) && start.elapsed().as_secs() < 20 {
        live.feed(Feed::Frame(start.elapsed().as_secs_f64()))
            .unwrap();
        if continued.is_none() && live.view().screen.is_some() {
            live.feed(Feed::Input(frictionlab::protocol::engine::Input::Continue))
                .unwrap();
            continued = Some(Instant::now());
        }
        std::thread::sleep(Duration::from_millis(2));
    }
    (live, start)
}

/// Issue 13: the same rule in the window: a device lost while the person
/// is typing the answer aborts and re-queues the trial.
#[test]
fn a_device_lost_in_the_answer_phase_costs_that_trial_in_the_window() {
    use frictionlab::protocol::engine::Question;
    let dir = tempfile::tempdir().unwrap();
    let dev = dir.path().join("dev");
    let emu = common::emulator(&dev);
    let (mut live, start) = live_magnitude_quick(dir.path(), &dev, "typist", |live, _| {
        live.view().question == Some(Question::Magnitude)
    });
    assert_eq!(live.view().question, Some(Question::Magnitude));
    common::unplug(emu, &dev);
    let lost = Instant::now();
    while live.device_status().connected && lost.elapsed().as_secs() < 5 {
        live.feed(Feed::Frame(start.elapsed().as_secs_f64()))
            .unwrap();
        std::thread::sleep(Duration::from_millis(5));
    }
    live.feed(Feed::Frame(start.elapsed().as_secs_f64()))
        .unwrap();
    assert!(!live.device_status().connected);
    assert_lost_in_answer_phase(live.log_path());
    live.feed(Feed::Abort).unwrap();
}

/// A device that stalls mid-trial (its process stopped for 0.4 s) while the
/// session is not reading, then answers again: the trial is aborted for the
/// loss, and its stream ends there. The device's telemetry after it came
/// back (a new `Hello` started it afresh: nothing rendered, without a
/// select) belongs to no trial. Before, every tick read in the same poll as
/// the loss went into the trial being aborted, and its re-render differed
/// from the recorded force where the device had started afresh (the
/// fresh-clone CI once saw 3.30 N on QEMU).
///
/// The stall comes 0.8 s of session time into the presentation under way.
/// On a loaded machine the emulator, a process like any other, can itself
/// fall silent for 100 ms before that: a lost device too, whose
/// presentation is aborted and presented again (issue 63: the test then
/// took that first presentation for the stalled one, 5 rows long). Every
/// presentation aborted for a lost device is held to the rule.
#[test]
fn a_trial_aborted_for_a_stalled_device_records_nothing_from_after_the_stall() {
    use frictionlab::time::Time;
    use std::cell::Cell;
    let dir = tempfile::tempdir().unwrap();
    let dev = dir.path().join("dev");
    let emu = common::emulator_with(&dev, &["--on-board"]);
    // The presentation under way: the records written before it, and when
    // it started (session time).
    let under_way: Cell<Option<(usize, Time)>> = Cell::new(None);
    let (mut live, start) = live_magnitude_quick(dir.path(), &dev, "stall", |live, _| {
        let records = live.records().0;
        if !live.engine().in_trial() {
            under_way.set(None);
            return false;
        }
        let (before, since) = match under_way.get() {
            Some((before, since)) if before == records => (before, since),
            _ => (records, live.now()),
        };
        under_way.set(Some((before, since)));
        (live.now() - since).secs() > 0.8
    });
    let (stalled, _) = under_way.get().expect("a presentation 0.8 s under way");
    let signal = |s: &str| {
        let ok = Command::new("kill")
            .args([s, &emu.id().to_string()])
            .status()
            .unwrap();
        assert!(ok.success());
    };
    // The device stalls; the session reads nothing until it is back.
    signal("-STOP");
    std::thread::sleep(Duration::from_millis(400));
    signal("-CONT");
    std::thread::sleep(Duration::from_millis(400));
    live.feed(Feed::Frame(start.elapsed().as_secs_f64()))
        .unwrap();
    live.feed(Feed::Abort).unwrap();
    common::unplug(emu, &dev);

    let read = read_log::<Registry>(live.log_path()).unwrap();
    let summary: Vec<_> = read
        .trials
        .iter()
        .map(|r| (r.trial, r.status, r.abort_reason.as_deref()))
        .collect();
    println!("records {summary:?}; the stall came in record {stalled}");
    let r = &read.trials[stalled];
    assert_eq!(
        (r.status, r.requeued, r.abort_reason.as_deref()),
        (Status::Aborted, true, Some("device lost")),
        "{summary:?}"
    );
    for (i, r) in read.trials.iter().enumerate() {
        if r.abort_reason.as_deref() != Some("device lost") {
            continue;
        }
        let stream = common::stream_of(&dir.path().join("results"), &read, i);
        let text = std::fs::read_to_string(&stream).unwrap();
        let rows = frictionlab::rerender::parse_stream("stream", &text).unwrap();
        if i == stalled {
            assert!(rows.len() > 2000, "{} rows before the stall", rows.len());
        }
        for w in rows.windows(2) {
            assert!(
                w[1].selected || w[1].render == w[0].render,
                "record {i}: the render changed without a select at t = {} s: the device \
                 started afresh after the loss, and its telemetry went into the aborted trial",
                w[1].t_s
            );
        }
        let report = frictionlab::rerender::rerender_file(&stream).unwrap();
        println!(
            "record {i}: {} rows, {} compared, bit_exact {}",
            report.rows, report.compared, report.bit_exact
        );
        // A presentation lost before its model took effect has nothing to
        // compare; the stalled one had 0.8 s of it.
        assert!(
            report.bit_exact || (i != stalled && report.compared == 0),
            "record {i}: {report:?}"
        );
    }
}

/// A link that delivers the host's messages 200 ms late (QEMU's UART on a
/// loaded 2-core machine lagged so): the host resends a select its device
/// has not yet shown in effect, and those resends arrive after the select
/// itself, some in the next trial. A resend must not restart the model in
/// effect, and every stream with rows to compare must still re-render bit
/// for bit. (The fresh-clone CI once saw 0.45 N on QEMU: a stale resend
/// restarted the previous trial's model at the start of the next trial's
/// stream.)
#[test]
fn resends_over_a_lagging_link_restart_nothing_and_rerender_bit_exact() {
    let dir = tempfile::tempdir().unwrap();
    let dev = dir.path().join("dev");
    let emu = common::emulator_with(&dev, &["--on-board", "--link-delay-ms", "200"]);
    let out = dir.path().join("results");
    let o = run("magnitude-quick", &out, &dev, &[])
        .wait_with_output()
        .unwrap();
    common::unplug(emu, &dev);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let log = read_log::<Registry>(&log_of(&out, "magnitude-quick")).unwrap();
    assert_eq!(common::completed_trials(&log), (0..6).collect::<Vec<_>>());

    let r = common::rerender_all(&out);
    assert_eq!(r.modes, ["on_board"]);
    for x in &r.reports {
        // A presentation aborted before its model took effect (the device
        // lost: on a loaded machine a 200 ms link costs some) has nothing
        // to compare, and rerender says so (bit_exact false, exit 2), as
        // common::rerender_all allows; every other stream re-renders bit
        // for bit. Issue 63: this test held those to bit_exact too and
        // failed 8 of 10 runs beside a busy loop.
        if x["status"] == "aborted" && x["compared"] == 0 {
            continue;
        }
        assert_eq!(x["bit_exact"], true, "{x}");
        assert!(x["restarted_row"].is_null(), "{x}");
    }
    let nothing = r.reports.iter().filter(|x| x["compared"] == 0).count();
    println!(
        "{} streams ({nothing} of them presentations aborted before their model took effect), {} rows re-rendered, largest force difference {} N",
        r.streams, r.rows, r.force
    );
    assert!(r.rows > 20_000, "{} rows re-rendered", r.rows);
    // Each presentation's stream against its record (trial k, run r: the
    // r-th record of trial k).
    let mut selects = 0;
    for (i, record) in log.trials.iter().enumerate() {
        let path = common::stream_of(&out, &log, i);
        let text = std::fs::read_to_string(&path).unwrap();
        let rows = frictionlab::rerender::parse_stream("stream", &text).unwrap();
        // A completed trial's own model shows in effect within its stream
        // (its select arrives 200 ms late, inside the 2 s exploration).
        // The previous trial's clear may land between two streams, and a
        // run aborted early (a late `Hello` on a loaded machine restarts
        // the device while connecting) may end before its model is sent.
        assert!(
            record.status.as_str() != "completed"
                || rows
                    .iter()
                    .any(|r| r.selected && record.rendering[r.render].model.is_some()),
            "{}: the trial's model never showed in effect",
            path.display()
        );
        for w in rows.windows(2).filter(|w| w[1].selected) {
            selects += 1;
            // (A device that a late `Hello` started afresh while connecting
            // takes a clear again: nothing restarts.)
            assert!(
                w[1].render != w[0].render || record.rendering[w[1].render].model.is_none(),
                "{}: the model in effect selected again at t = {} s (a resend restarted it)",
                path.display(),
                w[1].t_s
            );
        }
    }
    assert!(
        selects >= 6,
        "{selects} selects: at least a model per trial"
    );
}

/// The builder's "Feel a condition" on a connected device (issue 37): the
/// emulator renders the model, the mouse's hand drive reaches it, and the
/// ticks come back; a viscous model resists where no model does not.
#[test]
fn feeling_a_condition_on_the_emulated_device_renders_it_under_the_hand() {
    use frictionlab::friction::ModelParams;
    use frictionlab::session::{DeviceChoice, Feel};

    let mut peaks = Vec::new();
    for name in ["none", "viscous"] {
        let dir = tempfile::tempdir().unwrap();
        let dev = dir.path().join("dev");
        let emu = common::emulator(&dev);
        let model = ModelParams::default_for(name).unwrap();
        let mut feel = Feel::start(&DeviceChoice::port(dev.clone()), &model, 0.0).unwrap();
        let start = Instant::now();
        let (mut connected, mut reached, mut peak) = (false, false, 0.0_f64);
        // The pointer sweeps 0 to 8 mm and back, twice a second.
        while start.elapsed() < Duration::from_secs(6) {
            let t = start.elapsed().as_secs_f64();
            let target = 0.004 * (1.0 - (std::f64::consts::TAU * t).cos());
            feel.advance(t, Some(target));
            connected |= feel.connected();
            let s = *feel.sample();
            reached |= s.x_m > 0.004;
            if connected {
                peak = peak.max(s.force_n.abs());
            }
            std::thread::sleep(Duration::from_millis(10));
        }
        drop(feel);
        common::unplug(emu, &dev);
        assert!(connected, "{name}: the device never answered");
        assert!(reached, "{name}: the hand never followed the pointer");
        peaks.push(peak);
    }
    assert!(peaks[0] < 0.05, "no model, yet {} N", peaks[0]);
    assert!(peaks[1] > 0.2, "the damper rendered {} N at most", peaks[1]);
}
