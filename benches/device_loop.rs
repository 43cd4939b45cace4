//! The haptic loop over a pseudo-terminal to the device emulator
//! (`cargo bench --bench device_loop`).
//!
//! 1. Loop timing: the loop runs 10 s at 1 kHz and at 5 kHz on our own
//!    emulator, and 10 s at 1 kHz on the emulated 2DIY and the emulated
//!    Inverse Service, each with and without SCHED_FIFO. It prints the
//!    period between ticks (p50/p99), the lateness of ticks against their
//!    deadlines (p50/p99/max) and the miss rate (ticks later than half a
//!    period). Aim: p99 under 100 us at 1 kHz.
//! 2. Round trip (criterion): host sends a Command, the emulator applies it
//!    on its next 1 kHz tick and answers with a Sample acknowledging it; the
//!    time until the host has that Sample.

use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use criterion::{Criterion, criterion_group, criterion_main};
use frictionlab::device::frictionlab::link::{Incoming, Link, LinkState};
use frictionlab::device::frictionlab::wire::{Message, frame};
use frictionlab::device::haptic::HapticLoop;
use frictionlab::device::transport::Transport;

/// The emulator process, stopped when dropped (also when a failed run
/// stops the bench).
struct Emulator(Child);

impl Drop for Emulator {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// Starts the emulator on a pseudo-terminal linked at `path`; one that does
/// not start, or links no port within 10 s, stops the bench.
fn emulator(path: &Path) -> Emulator {
    let child = Command::new(env!("CARGO_BIN_EXE_frictionlab"))
        .args(["device-emulator", &path.to_string_lossy()])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap_or_else(|e| panic!("device-emulator: cannot run: {e}"));
    let start = Instant::now();
    while std::fs::read_link(path).is_err() && start.elapsed() < Duration::from_secs(10) {
        std::thread::sleep(Duration::from_millis(10));
    }
    let emulator = Emulator(child);
    assert!(
        std::fs::read_link(path).is_ok(),
        "device-emulator: no port at {} after 10 s",
        path.display()
    );
    emulator
}

/// Starts `frictionlab device-emulator SPEC` and waits until `ready`.
fn emulator_of(spec: &str, ready: impl Fn() -> bool) -> Emulator {
    let child = Command::new(env!("CARGO_BIN_EXE_frictionlab"))
        .args(["device-emulator", spec])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap_or_else(|e| panic!("device-emulator {spec}: cannot run: {e}"));
    let start = Instant::now();
    while !ready() && start.elapsed() < Duration::from_secs(10) {
        std::thread::sleep(Duration::from_millis(10));
    }
    assert!(ready(), "device-emulator {spec}: not ready after 10 s");
    Emulator(child)
}

/// Runs the loop on `device` for 10 s at `rate` Hz and prints its timing.
fn time_loop(what: &str, address: &str, rate: f64, fifo: bool) {
    let device = frictionlab::device::Address::parse(address)
        .and_then(|a| a.open())
        .unwrap_or_else(|e| panic!("{what}: {e}"));
    let haptic = HapticLoop::start(
        device,
        frictionlab::friction::StepParams {
            rate_hz: rate,
            ..Default::default()
        },
        fifo,
    )
    .unwrap_or_else(|e| panic!("haptic loop at {rate} Hz: {e}"));
    std::thread::sleep(Duration::from_secs(10));
    let s = haptic.stop();
    eprintln!(
        "{what}: loop {rate} Hz, SCHED_FIFO requested {fifo}, granted {}: {} ticks, period p50 {} us, p99 {} us; lateness p50 {} us, p99 {} us, max {:.0} us; missed {} ({:.4}%), CRC errors {}, resyncs {}",
        s.sched_fifo,
        s.ticks,
        s.period_p50_us.unwrap_or(f64::NAN),
        s.period_p99_us.unwrap_or(f64::NAN),
        s.period_error_p50_us,
        s.period_error_p99_us,
        s.period_error_max_us,
        s.missed_deadlines,
        100.0 * s.missed_deadlines as f64 / s.ticks.max(1) as f64,
        s.crc_errors,
        s.resyncs
    );
}

fn loop_timing() {
    let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("cannot create a folder: {e}"));
    let path = dir.path().join("dev");
    let port = path.to_string_lossy().into_owned();
    {
        let _emulator = emulator(&path);
        for (rate, fifo) in [
            (1000.0, false),
            (1000.0, true),
            (5000.0, false),
            (5000.0, true),
        ] {
            time_loop("frictionlab emulator", &port, rate, fifo);
        }
    }
    let path = dir.path().join("2diy");
    let _emulator = emulator_of(&format!("haply2diy:{}", path.display()), || {
        std::fs::read_link(&path).is_ok()
    });
    for fifo in [false, true] {
        time_loop(
            "2DIY emulator",
            &format!("haply2diy:{}", path.display()),
            1000.0,
            fifo,
        );
    }
    let address = std::net::TcpListener::bind("127.0.0.1:0")
        .and_then(|l| l.local_addr())
        .map_or_else(|e| panic!("no free port: {e}"), |a| a.to_string());
    let _service = emulator_of(&format!("inverse3:{address}"), || {
        std::net::TcpStream::connect(&address).is_ok()
    });
    for fifo in [false, true] {
        time_loop(
            "Inverse Service emulator",
            &format!("inverse3:{address}"),
            1000.0,
            fifo,
        );
    }
}

fn round_trip(c: &mut Criterion) {
    // `cargo bench` passes --bench; `cargo test --all-targets` runs this
    // binary once as a smoke test, without the 40 s timing sweep.
    if std::env::args().any(|a| a == "--bench") {
        loop_timing();
    }
    let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("cannot create a folder: {e}"));
    let path = dir.path().join("dev");
    let _emulator = emulator(&path);
    let mut transport = Transport::new(&path);
    let mut link = Link::new();
    let start = Instant::now();
    let mut buf = [0_u8; 1024];
    while link.state(start.elapsed().as_secs_f64()) != LinkState::Connected
        && start.elapsed() < Duration::from_secs(5)
    {
        let now = start.elapsed().as_secs_f64();
        let n = transport.read(&mut buf);
        link.receive(now, &buf[..n], |_| {});
        if let Some(m) = link.transmit(now, 0.0, 0.0) {
            transport.write(&frame(&m));
        }
        std::thread::sleep(Duration::from_millis(1));
    }
    assert!(
        link.state(start.elapsed().as_secs_f64()) == LinkState::Connected,
        "device-emulator at {}: no connection after 5 s",
        path.display()
    );
    let mut seq = 1_000_000_u32;
    c.bench_function("device/round-trip-command-to-acked-sample", |b| {
        b.iter(|| {
            seq += 1;
            transport.write(&frame(&Message::Command {
                seq,
                force_n: 0.0,
                vibration: 0.0,
            }));
            let sent = Instant::now();
            let mut acked = false;
            while !acked && sent.elapsed() < Duration::from_millis(50) {
                let n = transport.read(&mut buf);
                link.receive(start.elapsed().as_secs_f64(), &buf[..n], |i| {
                    acked |= matches!(i, Incoming::Sample(s) if s.ack_seq == seq);
                });
            }
            assert!(acked, "command {seq}: no acknowledging sample within 50 ms");
        });
    });
}

criterion_group!(benches, round_trip);
criterion_main!(benches);
