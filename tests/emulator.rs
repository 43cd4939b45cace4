//! `frictionlab device-emulator` as a user starts it (issue 13): left idle
//! before anyone connects, serving one session after another, given a link
//! to an existing pseudo-terminal, and behind a pseudo-terminal relay opened
//! late.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    reason = "a failed unwrap is a failed test"
)]

mod common;

use std::io::{Read, Write};
use std::path::Path;
use std::process::{Command, Output, Stdio};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Mutex, PoisonError, RwLock, RwLockReadGuard, RwLockWriteGuard};
use std::time::{Duration, Instant};

use frictionlab::device::frictionlab::wire::{Decoder, Message, PROTOCOL_VERSION, frame};
use frictionlab::kinds::Registry;
use frictionlab::results::read_log;
use serialport::{SerialPort, TTYPort};

/// `TTYPort::pair` is not thread-safe: tests that make pairs take turns.
static PTY: Mutex<()> = Mutex::new(());

fn pty_pair() -> (TTYPort, TTYPort) {
    let _pty = PTY.lock().unwrap_or_else(PoisonError::into_inner);
    TTYPort::pair().unwrap()
}

/// The latency test measures timing on a machine of two cores, where a
/// second session beside it (an emulator and a 5 kHz loop of its own) can
/// stall its link for 20 ms: it runs alone (the write lock), the other
/// tests side by side (read locks).
static TIMING: RwLock<()> = RwLock::new(());

fn side_by_side() -> RwLockReadGuard<'static, ()> {
    TIMING.read().unwrap_or_else(PoisonError::into_inner)
}

fn alone() -> RwLockWriteGuard<'static, ()> {
    TIMING.write().unwrap_or_else(PoisonError::into_inner)
}

/// Runs session `session` of `protocol` (with `trials` planned trials) with
/// a simulated participant on the device at `dev`, and checks that it ends
/// with exit 0 and every planned trial completed; returns how long the run
/// took.
fn a_whole_session_runs_on(
    dev: &Path,
    out: &Path,
    (protocol, trials, session): (&str, usize, u32),
) -> Duration {
    let path = format!("{}/protocols/{protocol}.json", env!("CARGO_MANIFEST_DIR"));
    a_session_of_runs_on(Path::new(&path), protocol, dev, out, (trials, session))
}

/// [`a_whole_session_runs_on`] for the protocol file at `path`, whose id is
/// `id`.
fn a_session_of_runs_on(
    path: &Path,
    id: &str,
    dev: &Path,
    out: &Path,
    (trials, session): (usize, u32),
) -> Duration {
    let started = Instant::now();
    let run = |resume: bool| -> Output {
        Command::new(env!("CARGO_BIN_EXE_frictionlab"))
            .arg("run")
            .arg(path)
            .args(["--participant", "p", "--out"])
            .arg(out)
            .arg("--device")
            .arg(dev)
            .args(["--responder", "sim", "--seed", "5"])
            .args(if resume { &["--resume"][..] } else { &[] })
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .output()
            .unwrap()
    };
    // A machine loaded beyond what the link's 100 ms lost-device time
    // allows (a build beside the tests, and the relays of these tests in
    // the test's own process) can lose the device for a trial 3 times in
    // a row: the run ends with exit 3, its completed trials kept (issue
    // 63's rule), and is resumed as a lab would, at most 20 times.
    let mut o = run(false);
    let mut resumed = 0;
    while o.status.code() == Some(3) && resumed < 20 {
        resumed += 1;
        o = run(true);
    }
    let took = started.elapsed();
    if resumed > 0 {
        eprintln!("{id}: the device's faults ended the run; resumed {resumed} times");
    }
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let log = out.join(format!(
        "logs/study-{}_subject-p_session-{session}_log.jsonl",
        id.replace('-', "")
    ));
    let log = read_log::<Registry>(&log).unwrap();
    assert!(log.ended);
    assert_eq!(
        common::completed_trials(&log),
        (0..trials).collect::<Vec<_>>(),
        "every trial logged"
    );
    took
}

const MAGNITUDE_QUICK: (&str, usize, u32) = ("magnitude-quick", 6, 1);

/// Issue 13: the emulator streamed samples before anyone listened, filled
/// its pseudo-terminal's buffer and exited about 1.3 s after it started.
#[test]
fn an_emulator_left_idle_for_10_s_still_accepts_a_whole_session_issue_13() {
    let _turn = side_by_side();
    let dir = tempfile::tempdir().unwrap();
    let dev = dir.path().join("dev");
    let mut emu = common::emulator(&dev);
    std::thread::sleep(Duration::from_secs(10));
    assert!(
        emu.try_wait().unwrap().is_none(),
        "the emulator is still running after 10 s idle"
    );
    let took = a_whole_session_runs_on(&dev, &dir.path().join("results"), MAGNITUDE_QUICK);
    emu.kill().unwrap();
    emu.wait().unwrap();
    eprintln!("session after 10 s idle: {took:?}");
}

/// Issue 13: after a host went away the emulator kept streaming into a
/// buffer nobody read, and exited before the next host came. It must go
/// quiet and serve the next host after its Hello.
#[test]
fn an_emulator_serves_one_session_after_another_issue_13() {
    let _turn = side_by_side();
    let dir = tempfile::tempdir().unwrap();
    let dev = dir.path().join("dev");
    let mut emu = common::emulator(&dev);
    let out = dir.path().join("results");
    let first = a_whole_session_runs_on(&dev, &out, ("paired-quick", 1, 1));
    // Longer than HOST_GONE_S: the emulator has gone quiet.
    std::thread::sleep(Duration::from_secs(2));
    let second = a_whole_session_runs_on(&dev, &out, ("paired-quick", 1, 2));
    emu.kill().unwrap();
    emu.wait().unwrap();
    eprintln!("sessions one after the other: {first:?}, {second:?}");
}

/// Issue 13: given a link to an existing pseudo-terminal (as every
/// `/dev/serial/by-id/` name is a link to a port), the emulator removed the
/// link and put a pseudo-terminal of its own there. It must serve the port
/// the link points to and leave the link alone.
#[test]
fn an_emulator_given_a_link_to_an_existing_pty_serves_it_and_keeps_the_link_issue_13() {
    let _turn = side_by_side();
    let (mut master, slave) = pty_pair();
    let target = slave.name().unwrap();
    master.set_timeout(Duration::from_millis(10)).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let link = dir.path().join("by-id-link");
    std::os::unix::fs::symlink(&target, &link).unwrap();
    let emu = Command::new(env!("CARGO_BIN_EXE_frictionlab"))
        .arg("device-emulator")
        .arg(&link)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // The host side of the port: Hello every 50 ms until Capabilities come.
    let mut decoder = Decoder::new();
    let (mut capabilities, mut samples) = (None, 0);
    let mut buf = [0_u8; 1024];
    let started = Instant::now();
    let mut last_hello: Option<Instant> = None;
    while samples < 100 && started.elapsed() < Duration::from_secs(5) {
        if last_hello.is_none_or(|t| t.elapsed() > Duration::from_millis(50))
            && capabilities.is_none()
        {
            master
                .write_all(&frame(&Message::Hello {
                    version: PROTOCOL_VERSION,
                }))
                .unwrap();
            last_hello = Some(Instant::now());
        }
        let n = master.read(&mut buf).unwrap_or(0);
        decoder.feed(&buf[..n], |m| match m {
            Message::Capabilities { .. } => capabilities = Some(m),
            Message::Sample { .. } if capabilities.is_some() => samples += 1,
            _ => {}
        });
    }
    let link_now = std::fs::read_link(&link);
    let mut emu = emu;
    emu.kill().unwrap();
    let o = emu.wait_with_output().unwrap();
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert_eq!(
        link_now.ok().as_deref(),
        Some(Path::new(&target)),
        "the link is left in place, pointing at the same port; stdout: {stdout} stderr: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    assert!(
        matches!(
            capabilities,
            // Without --on-board the emulator is a version 1 device: it
            // answers a version 2 Hello in version 1.
            Some(Message::Capabilities { version: 1, .. })
        ),
        "Capabilities after Hello on the linked port: {capabilities:?}"
    );
    assert!(
        samples >= 100,
        "samples stream after the handshake: {samples}"
    );
    assert_eq!(stdout, format!("device emulator on {}\n", link.display()));
    drop(slave);
}

/// Runs `session` on a relay to the device at `dev`: a new pseudo-terminal
/// whose bytes are copied both ways to the device's port, each chunk
/// `delay` after it was read (a link with that much added latency each
/// way). The relay stops when `session` returns.
fn through_relay<T>(dev: &Path, delay: Duration, session: impl FnOnce(&Path) -> T) -> T {
    let device_port = serialport::new(dev.to_string_lossy(), 115_200)
        .timeout(Duration::from_millis(10))
        .open_native()
        .unwrap_or_else(|e| panic!("{}: {e}", dev.display()));
    let (mut relay_master, relay_slave) = pty_pair();
    relay_master.set_timeout(Duration::from_millis(10)).unwrap();
    let stop = Arc::new(AtomicBool::new(false));
    let copying = relay(device_port, relay_master, delay, &stop);
    let out = session(Path::new(&relay_slave.name().unwrap()));
    stop.store(true, Ordering::Relaxed);
    for t in copying {
        t.join().unwrap();
    }
    out
}

/// Copies bytes both ways between `a` and `b`, each chunk `delay` after it
/// was read, until `stop` is set.
///
/// The relay stands for a cable: its threads ask for SCHED_FIFO, as the
/// emulators do, and a write that times out is retried, never dropped.
/// Under a concurrent build, at normal priority, it stalled for 873 ticks
/// and the device's queue dropped 215 telemetry frames (the on-board
/// rendering stayed bit exact): a cable that stops is not what this test
/// is about (`device_session` stalls links on purpose).
fn relay(
    a: TTYPort,
    b: TTYPort,
    delay: Duration,
    stop: &Arc<AtomicBool>,
) -> Vec<std::thread::JoinHandle<()>> {
    let one_way = |mut from: TTYPort, mut to: TTYPort, stop: Arc<AtomicBool>| {
        let (queue, due) = std::sync::mpsc::channel::<(Instant, Vec<u8>)>();
        let reading = stop.clone();
        let reader = std::thread::spawn(move || {
            let _ = frictionlab::device::realtime::ask_fifo();
            let mut buf = [0_u8; 4096];
            while !reading.load(Ordering::Relaxed) {
                if let Ok(n) = from.read(&mut buf)
                    && n > 0
                {
                    let _ = queue.send((Instant::now() + delay, buf[..n].to_vec()));
                }
            }
        });
        // Ends when the reader does (the channel closes).
        let writer = std::thread::spawn(move || {
            let _ = frictionlab::device::realtime::ask_fifo();
            for (at, bytes) in due {
                spin_sleep::sleep_until(at);
                let mut rest = &bytes[..];
                while !rest.is_empty() && !stop.load(Ordering::Relaxed) {
                    match to.write(rest) {
                        Ok(n) => rest = &rest[n..],
                        Err(e)
                            if matches!(
                                e.kind(),
                                std::io::ErrorKind::TimedOut
                                    | std::io::ErrorKind::WouldBlock
                                    | std::io::ErrorKind::Interrupted
                            ) => {}
                        Err(_) => break,
                    }
                }
            }
        });
        [reader, writer]
    };
    let (a2, b2) = (a.try_clone_native().unwrap(), b.try_clone_native().unwrap());
    let mut threads = Vec::from(one_way(a, b2, stop.clone()));
    threads.extend(one_way(b, a2, stop.clone()));
    threads
}

/// Issue 13: behind a relay (a pseudo-terminal whose master is copied to
/// the emulator's port) started 2 s after the emulator, a session got no
/// answer: the emulator had filled its buffer and exited.
#[test]
fn a_session_through_a_pty_relay_opened_2_s_after_the_emulator_completes_issue_13() {
    let _turn = side_by_side();
    let dir = tempfile::tempdir().unwrap();
    let dev = dir.path().join("dev");
    let mut emu = common::emulator(&dev);
    std::thread::sleep(Duration::from_secs(2));
    let took = through_relay(&dev, Duration::ZERO, |relay| {
        a_whole_session_runs_on(relay, &dir.path().join("results"), MAGNITUDE_QUICK)
    });
    emu.kill().unwrap();
    emu.wait().unwrap();
    eprintln!("session through the relay: {took:?}");
}

/// Issue 15: the three quick protocols run end to end on an emulator that
/// renders on board (magnitude-quick's stick-slip at 5 kHz on the device),
/// every trial logged as rendered on board, and every stream re-renders on
/// the host bit for bit.
#[test]
fn sessions_on_an_on_board_emulator_complete_and_rerender_bit_exact_issue_15() {
    let _turn = side_by_side();
    let dir = tempfile::tempdir().unwrap();
    let dev = dir.path().join("dev");
    let mut emu = common::emulator_with(&dev, &["--on-board"]);
    for (protocol, trials) in [
        ("magnitude-quick", 6),
        ("paired-quick", 1),
        ("fitts-quick", 3),
    ] {
        let out = dir.path().join(protocol);
        a_whole_session_runs_on(&dev, &out, (protocol, trials, 1));
        let log = out.join(format!(
            "logs/study-{}_subject-p_session-1_log.jsonl",
            protocol.replace('-', "")
        ));
        let log = read_log::<Registry>(&log).unwrap();
        for r in &log.trials {
            assert!(
                !r.rendering.is_empty(),
                "trial {} states its rendering",
                r.trial
            );
            for e in &r.rendering {
                assert_eq!(e.mode, frictionlab::results::RenderMode::OnBoard);
                assert_eq!(e.float, frictionlab::friction::Float::F32);
                assert_eq!(e.rate_hz, 5000.0, "the device's loop rate");
            }
        }
        let r = common::rerender_all(&out);
        eprintln!(
            "{protocol} on board: {} streams, {} rows re-rendered, max |dF| {} N, max |dvib| {}, modes {:?}",
            r.streams, r.rows, r.force, r.vibration, r.modes
        );
        assert!(r.rows > 10_000, "{} rows re-rendered", r.rows);
        assert_eq!((r.force, r.vibration), (0.0, 0.0), "bit-exact");
        assert_eq!(r.modes, ["on_board"]);
    }
    emu.kill().unwrap();
    emu.wait().unwrap();
}

/// Issue 15: a version 1 device (the emulator without --on-board) still
/// serves a version 2 host, which renders on its own loop; its streams
/// re-render too (the host loop's difference is reported).
#[test]
fn a_version_1_device_is_rendered_by_the_host_loop_and_its_streams_rerender_issue_15() {
    let _turn = side_by_side();
    let dir = tempfile::tempdir().unwrap();
    let dev = dir.path().join("dev");
    let mut emu = common::emulator(&dev);
    let out = dir.path().join("results");
    a_whole_session_runs_on(&dev, &out, MAGNITUDE_QUICK);
    emu.kill().unwrap();
    emu.wait().unwrap();
    let r = common::rerender_all(&out);
    eprintln!(
        "host loop: {} streams, {} rows re-rendered, max |dF| {} N, max |dvib| {}",
        r.streams, r.rows, r.force, r.vibration
    );
    assert_eq!(r.modes, ["host_loop"]);
    assert!(r.rows > 10_000, "{} rows re-rendered", r.rows);
    assert!(r.force < 1e-9, "{}", r.force);
}

/// magnitude-quick's tactile display alone (seed 001's stick-slip driving
/// its 600 Hz burst) with 5 s of exploration per trial, 3 trials: 15 s of
/// stick-slip per session, about 225 transitions (the test's bounds are
/// shares of the model's steps, tens of thousands a session, so 3 trials
/// hold them as 6 did, in half the time). Written into `dir`.
fn stick_slip_protocol(dir: &Path) -> std::path::PathBuf {
    let quick = format!(
        "{}/protocols/magnitude-quick.json",
        env!("CARGO_MANIFEST_DIR")
    );
    let mut p: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(quick).unwrap()).unwrap();
    p["id"] = "stick-slip-latency".into();
    p["repetitions"] = 1.into();
    p["design"]["exploration_s"] = 5.0.into();
    let tactile = p["design"]["sets"][0].clone();
    assert_eq!(tactile["display"], "tactile");
    p["design"]["sets"] = serde_json::json!([tactile]);
    p.as_object_mut().unwrap().remove("$schema");
    let path = dir.join("stick-slip-latency.json");
    std::fs::write(&path, serde_json::to_string_pretty(&p).unwrap()).unwrap();
    path
}

/// Seed 001's stimulus in a session of [`stick_slip_protocol`], counted by
/// re-rendering every stream.
#[derive(Debug)]
struct StickSlip {
    /// The share of the model's steps on the position of the step before.
    held: f64,
    /// Streams, and the model's steps in them (rows after the first).
    streams: usize,
    steps: usize,
    /// Stick-to-slip transitions per second of exploration.
    transitions_per_s: f64,
    /// Bursts the model started.
    bursts: usize,
    modes: Vec<String>,
    bit_exact: bool,
    /// The reports of the streams that did not re-render exactly (shown
    /// when a test fails).
    inexact: Vec<serde_json::Value>,
    /// Device ticks whose telemetry never arrived (on board).
    telemetry_gaps: Option<u64>,
    /// Replayed rows where the device reported its watchdog tripped (a
    /// stall of 20 ms on the link, which a loaded machine can cause).
    watchdog_rows: u64,
}

/// Runs a session of `protocol` on the emulator at `dev`, through a relay
/// that adds `latency` each way (none: directly), into `out`.
fn stick_slip_through(
    protocol: &Path,
    dev: &Path,
    latency: Option<Duration>,
    out: &Path,
) -> StickSlip {
    let run = |dev: &Path| {
        a_session_of_runs_on(protocol, "stick-slip-latency", dev, out, (3, 1));
    };
    match latency {
        Some(latency) => through_relay(dev, latency, run),
        None => run(dev),
    }
    let r = common::rerender_all(out);
    let count = |key: &str| -> u64 { r.reports.iter().map(|r| r[key].as_u64().unwrap()).sum() };
    let seconds: f64 = r
        .reports
        .iter()
        .map(|r| r["replayed_s"].as_f64().unwrap())
        .sum();
    let log = std::fs::read_to_string(
        out.join("logs/study-sticksliplatency_subject-p_session-1_log.jsonl"),
    )
    .unwrap();
    let stats = log
        .lines()
        .map(|l| serde_json::from_str::<serde_json::Value>(l).unwrap())
        .find(|l| l["type"] == "loop")
        .unwrap();
    // The positions the model stepped on, in every stream.
    let (mut held, mut steps, mut streams) = (0_usize, 0_usize, 0_usize);
    for e in std::fs::read_dir(out.join("streams")).unwrap() {
        streams += 1;
        let text = std::fs::read_to_string(e.unwrap().path()).unwrap();
        let xs: Vec<f64> = text
            .lines()
            .skip(1)
            .filter_map(|l| l.split(',').nth(1)?.parse().ok())
            .collect();
        held += xs.windows(2).filter(|w| w[1] == w[0]).count();
        steps += xs.len().saturating_sub(1);
    }
    #[expect(clippy::cast_precision_loss, reason = "small counts")]
    StickSlip {
        held: held as f64 / steps as f64,
        streams,
        steps,
        transitions_per_s: count("slip_onsets") as f64 / seconds,
        bursts: usize::try_from(count("bursts")).unwrap(),
        modes: r.modes,
        bit_exact: r.force == 0.0 && r.vibration == 0.0,
        inexact: r
            .reports
            .iter()
            .filter(|r| r["bit_exact"] != true)
            .cloned()
            .collect(),
        telemetry_gaps: stats["telemetry_gaps"].as_u64(),
        watchdog_rows: count("watchdog_rows"),
    }
}

/// Issue 15: behind a link with 2 ms of added latency each way (a USB
/// round trip), the host loop cannot render seed 001's stick-slip as the
/// seed does: it steps the 5 kHz model on positions a 1 kHz device sent
/// 2 ms ago, and the device applies the result 2 ms later still. On board
/// the model closes its loop on the device, and the stimulus is what it is
/// without the relay.
#[test]
fn a_link_with_2_ms_latency_leaves_the_on_board_stick_slip_exact_and_the_host_loop_on_stale_positions_issue_15()
 {
    let _turn = alone();
    let dir = tempfile::tempdir().unwrap();
    let protocol = stick_slip_protocol(dir.path());
    let latency = Some(Duration::from_millis(2));
    let on_board_dev = dir.path().join("on-board");
    let mut on_board = common::emulator_with(&on_board_dev, &["--on-board"]);
    let direct = stick_slip_through(&protocol, &on_board_dev, None, &dir.path().join("direct"));
    let relayed = stick_slip_through(
        &protocol,
        &on_board_dev,
        latency,
        &dir.path().join("relayed"),
    );
    on_board.kill().unwrap();
    on_board.wait().unwrap();
    let host_dev = dir.path().join("v1");
    let mut v1 = common::emulator(&host_dev);
    let host = stick_slip_through(&protocol, &host_dev, latency, &dir.path().join("host"));
    v1.kill().unwrap();
    v1.wait().unwrap();
    for (name, run) in [
        ("on board, direct", &direct),
        ("on board, 2 ms each way", &relayed),
        ("host loop, 2 ms each way", &host),
    ] {
        eprintln!(
            "{name}: {:.2} transitions/s, {:.3} of the steps on a held position, {} bursts started, {} rows under the device's watchdog",
            run.transitions_per_s, run.held, run.bursts, run.watchdog_rows
        );
    }

    // On board, latency or not, every tick rendered is the model on the
    // device's own motion, bit for bit (rows where a stalled link tripped
    // the device's watchdog are marked, and rendered nothing), and every
    // tick reached the host.
    for run in [&direct, &relayed] {
        assert_eq!(run.modes, ["on_board"]);
        assert!(run.bit_exact, "{run:?}: {:#?}", run.inexact);
        assert_eq!(run.telemetry_gaps, Some(0), "{run:?}");
    }
    // The host loop renders its own model (its stream re-renders exactly),
    // but its 5 kHz model steps on positions a 1 kHz device sent: at most
    // one step in five has a new one, so at least 0.8 of its steps are on
    // the position of the step before (less one step per stream at the
    // ends), however the link's timing falls. On board the model steps on
    // the device's own position each tick: only a hand at rest repeats
    // one. The transitions this adds are printed above: over fifteen
    // sessions from issue 15 to 45 the host loop had 1.03 to 1.54 times
    // the on-board rate, too spread between sessions for a bound.
    assert_eq!(host.modes, ["host_loop"]);
    assert!(host.bit_exact, "{host:?}: {:#?}", host.inexact);
    assert!(
        host.held >= 0.8 - host.streams as f64 / host.steps as f64,
        "host loop: {:.3} of its steps on a held position",
        host.held
    );
    for run in [&direct, &relayed] {
        assert!(
            run.held < host.held,
            "on board {:.3} vs host loop {:.3} steps on a held position",
            run.held,
            host.held
        );
    }
}
