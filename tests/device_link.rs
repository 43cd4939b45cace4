//! The device link over pseudo-terminals: handshake, clamping, the
//! watchdog, a lossy link, an emulator killed and restarted, and a link that
//! never comes back.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    reason = "a failed unwrap is a failed test"
)]

use crate::common;
use std::io::{Read, Write};

use std::path::Path;
use std::time::{Duration, Instant};

use frictionlab::device::frictionlab::emulator::EmulatorCore;
use frictionlab::device::frictionlab::link::{Incoming, Link, LinkState, Sample};
use frictionlab::device::frictionlab::wire::{Decoder, MAX_FRAME, Message, encode, frame, status};
use frictionlab::device::transport::Transport;

/// `TTYPort::pair` is not thread-safe: tests that make pairs take turns
/// (with every test of the binary).
use crate::common::PTY;

/// Runs the host side for `seconds` of wall time at about 1 kHz: sends what
/// the link asks for (rendering `force(t)`, plus a hand drive every 10 ms),
/// and returns every sample with its time and the link state after it.
struct Host {
    transport: Transport,
    link: Link,
    start: Instant,
    commanding: bool,
}

impl Host {
    fn new(path: &Path) -> Self {
        Host {
            transport: Transport::new(path),
            link: Link::new(),
            start: Instant::now(),
            commanding: true,
        }
    }

    fn now(&self) -> f64 {
        self.start.elapsed().as_secs_f64()
    }

    fn run(&mut self, seconds: f64, force: f64, hand: Option<f32>) -> Vec<(f64, Sample)> {
        let until = self.now() + seconds;
        let mut out = Vec::new();
        let mut buf = [0_u8; 1024];
        let mut last_hand = -1.0;
        while self.now() < until {
            let now = self.now();
            let n = self.transport.read(&mut buf);
            self.link.receive(now, &buf[..n], |i| {
                if let Incoming::Sample(s) = i {
                    out.push((now, s));
                }
            });
            if (self.commanding || self.link.state(now) != LinkState::Connected)
                && let Some(m) = self.link.transmit(now, force, 0.0)
            {
                self.transport.write(&frame(&m));
            }
            if let Some(x) = hand
                && now - last_hand > 0.01
            {
                last_hand = now;
                let drive = Message::HandDrive {
                    x_m: x,
                    v_m_s: 0.0,
                    stiffness_n_m: 500.0,
                    damping_n_s_m: 30.0,
                    integral: 0.0,
                    click: false,
                };
                self.transport.write(&frame(&drive));
            }
            std::thread::sleep(Duration::from_micros(900));
        }
        out
    }

    fn wait_for(&mut self, state: LinkState, seconds: f64) -> bool {
        let until = self.now() + seconds;
        while self.now() < until {
            self.run(0.01, 0.0, None);
            if self.link.state(self.now()) == state {
                return true;
            }
        }
        false
    }
}

#[test]
fn handshake_clamping_hand_and_watchdog_over_a_pty() {
    let _pty = PTY
        .lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner);
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("dev");
    let mut child = common::emulator(&path);
    let mut host = Host::new(&path);
    assert!(host.wait_for(LinkState::Connected, 5.0), "handshake");
    let caps = host.link.capabilities().unwrap();
    assert_eq!((caps.version, caps.dof, caps.force_rate_hz), (1, 1, 1000));
    assert!(
        (caps.max_force_n - 9.48).abs() < 1e-5 && (caps.counts_per_m - 1.0 / 2.57e-6).abs() < 1.0
    );
    // 20 N is more than the device can: clamped, reported; the hand pulls to
    // +5 mm and the device moves.
    let samples = host.run(0.4, 20.0, Some(0.005));
    assert!(samples.len() > 100, "{} samples", samples.len());
    assert!(samples.iter().any(|(_, s)| s.status & status::CLAMPED != 0));
    assert!(
        samples.last().unwrap().1.x_m > 0.004,
        "moved to {}",
        samples.last().unwrap().1.x_m
    );
    assert!(
        samples
            .iter()
            .all(|(_, s)| s.status & status::WATCHDOG == 0),
        "commands keep the watchdog quiet"
    );
    // No commands for 100 ms: the watchdog zeroes the force and says so.
    host.commanding = false;
    let quiet = host.run(0.1, 0.0, None);
    assert!(
        quiet.iter().any(|(_, s)| s.status & status::WATCHDOG != 0),
        "watchdog"
    );
    child.kill().unwrap();
    child.wait().unwrap();
}

#[test]
fn an_emulator_killed_mid_session_is_found_lost_then_again_and_a_dead_link_stays_lost() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("dev");
    let child = common::emulator(&path);
    let mut host = Host::new(&path);
    assert!(host.wait_for(LinkState::Connected, 5.0));
    common::unplug(child, &path); // SIGKILL, mid-stream
    let killed = host.now();
    assert!(host.wait_for(LinkState::Lost, 2.0), "lost after the kill");
    assert!(
        host.now() - killed < 1.0,
        "noticed within {} s",
        host.now() - killed
    );
    let child = common::emulator(&path);
    assert!(
        host.wait_for(LinkState::Connected, 5.0),
        "reconnected after restart"
    );
    assert!(host.transport.opens() >= 2, "the port was reopened");
    common::unplug(child, &path);
    assert!(host.wait_for(LinkState::Lost, 2.0));
    // Nobody comes back: it stays lost.
    assert!(!host.wait_for(LinkState::Connected, 1.0));
}

#[test]
fn a_link_that_drops_bytes_and_flips_bits_keeps_working() {
    let _pty = PTY
        .lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner);
    let (mut master, slave) = serialport::TTYPort::pair().unwrap();
    let slave_path = serialport::SerialPort::name(&slave).unwrap();
    serialport::SerialPort::set_timeout(&mut master, Duration::from_millis(1)).unwrap();
    let stop = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
    let flag = stop.clone();
    // The emulator core behind a noisy line: about 1 byte in 300 dropped and
    // 1 in 300 bit-flipped, in both directions.
    let emulator = std::thread::spawn(move || {
        let mut core = EmulatorCore::new();
        let mut decoder = Decoder::new();
        let mut rng: u64 = 0x9e37_79b9_7f4a_7c15;
        let mut noise = move |bytes: &[u8]| -> Vec<u8> {
            bytes
                .iter()
                .filter_map(|&b| {
                    rng ^= rng << 13;
                    rng ^= rng >> 7;
                    rng ^= rng << 17;
                    match rng % 300 {
                        0 => None,
                        1 => Some(b ^ (1 << ((rng >> 20) % 8))),
                        _ => Some(b),
                    }
                })
                .collect()
        };
        let (mut buf, mut out) = ([0_u8; 512], [0_u8; MAX_FRAME]);
        while !flag.load(std::sync::atomic::Ordering::Relaxed) {
            let n = master.read(&mut buf).unwrap_or(0);
            let heard = noise(&buf[..n]);
            let mut replies = Vec::new();
            decoder.feed(&heard, |m| replies.extend(core.receive(m)));
            replies.extend(core.tick(0.001));
            for m in replies {
                let len = encode(&m, &mut out).unwrap();
                let _ = master.write_all(&noise(&out[..len]));
            }
            std::thread::sleep(Duration::from_micros(900));
        }
        drop(slave);
    });
    let mut host = Host::new(Path::new(&slave_path));
    assert!(host.wait_for(LinkState::Connected, 5.0));
    let samples = host.run(1.5, 1.0, Some(0.003));
    let stats = host.link.stats();
    stop.store(true, std::sync::atomic::Ordering::Relaxed);
    emulator.join().unwrap();
    assert!(
        stats.resyncs() > 0,
        "the noise did damage frames: {stats:?}"
    );
    assert!(stats.frames > 500, "{stats:?}");
    assert!(
        samples.len() > 500,
        "{} samples through the noise",
        samples.len()
    );
    assert!(
        samples.iter().all(|(_, s)| s.x_m.abs() < 0.02),
        "no corrupted sample got through"
    );
}

/// A version 2 on-board device's `Capabilities`, stating `max_force_n`.
fn capabilities_v2(max_force_n: f32) -> Message {
    Message::Capabilities {
        version: 2,
        dof: 1,
        max_force_n,
        counts_per_m: 389_105.0,
        force_rate_hz: 5000,
        vibration_rate_hz: 5000,
    }
}

/// Its `OnBoard` statement, framed.
fn on_board_frame() -> Vec<u8> {
    frame(&Message::OnBoard {
        models: 0x7f,
        loop_rate_hz: 5000,
        float_bytes: 4,
    })
}

/// A version 2 device answers `Capabilities` and then `OnBoard`; the link
/// counts as connected only once `OnBoard` is in (or, from a device that
/// never sends it, 100 ms after `Capabilities`), so a session cannot start
/// its first trial on the host's loop because `OnBoard` came a read later.
#[test]
fn a_version_2_device_is_connected_once_its_on_board_statement_is_in() {
    use frictionlab::device::frictionlab::link::ON_BOARD_WAIT_S;
    let caps = frame(&capabilities_v2(9.48));
    let on_board = on_board_frame();
    let sample = frame(&Message::Sample {
        ack_seq: 0,
        time_us: 0,
        position_counts: 0,
        button: false,
        status: 0,
    });

    let mut link = Link::new();
    link.receive(0.0, &caps, |_| {});
    assert_eq!(link.state(0.0), LinkState::Connecting);
    assert_eq!(link.on_board(), None);
    link.receive(0.002, &on_board, |_| {});
    assert_eq!(link.state(0.002), LinkState::Connected);
    assert_eq!(link.on_board().map(|o| o.loop_rate_hz), Some(5000));

    // A device that never states it: connected after the wait, nothing on
    // board (the host renders).
    let mut link = Link::new();
    link.receive(0.0, &caps, |_| {});
    link.receive(0.09, &sample, |_| {});
    assert_eq!(link.state(0.09), LinkState::Connecting);
    assert_eq!(link.state(ON_BOARD_WAIT_S + 0.001), LinkState::Connected);
    assert_eq!(link.on_board(), None);
}

/// Issue 63: over a link that lags (QEMU's UART on a loaded machine, or
/// `--link-delay-ms 200`), the host connects on the answer to its first
/// `Hello` while the `Hello`s it sent after it are still on their way.
/// Their answers, the same `Capabilities` (with `OnBoard` a read later under
/// load), come while connected: the link stays connected and sends no
/// `Hello` (each of those started the device afresh before anything sent
/// since the connection reached it). Before, each was a new handshake: the
/// link went back to connecting until its `OnBoard` came, the session lost
/// its device, and the `Hello` sent meanwhile restarted the device in the
/// next trial (trial 0 presented 5 times in a row beside a busy machine).
/// Capabilities that differ are a new handshake still.
#[test]
fn issue_63_a_late_hellos_answer_while_connected_keeps_the_link() {
    let capabilities = capabilities_v2;
    let on_board = on_board_frame();
    let mut link = Link::new();
    assert!(matches!(
        link.transmit(0.0, 0.0, 0.0),
        Some(Message::Hello { .. })
    ));
    link.receive(0.2, &frame(&capabilities(9.48)), |_| {});
    link.receive(0.2, &on_board, |_| {});
    assert_eq!(link.state(0.2), LinkState::Connected);
    for k in 1..=3 {
        let t = 0.2 + 0.05 * f64::from(k);
        link.receive(t, &frame(&capabilities(9.48)), |_| {});
        assert_eq!(link.state(t), LinkState::Connected, "answer {k}");
        assert!(link.on_board().is_some(), "answer {k}");
        assert!(
            matches!(link.transmit(t, 0.0, 0.0), Some(Message::Command { .. })),
            "answer {k}: no Hello"
        );
        link.receive(t + 0.001, &on_board, |_| {});
        assert_eq!(link.state(t + 0.001), LinkState::Connected);
    }
    // Another device's statement is a handshake.
    link.receive(0.5, &frame(&capabilities(3.0)), |_| {});
    assert_eq!(link.state(0.5), LinkState::Connecting);
    link.receive(0.501, &on_board, |_| {});
    assert_eq!(link.state(0.501), LinkState::Connected);
    assert_eq!(link.capabilities().map(|c| c.max_force_n), Some(3.0));
}
