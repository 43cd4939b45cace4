//! The tactile display's delay from a haptic tick to the sound output
//! (`cargo bench --bench tactile_delay`; issue 64), on a PulseAudio of its
//! own with a null sink at 48 kHz (PulseAudio must be installed; the bench
//! says so and stops otherwise).
//!
//! A thread plays the haptic loop: seed 001's 600 Hz burst at 1 kHz (the
//! Inverse3's rate), a tick each millisecond on the clock, pushed to a
//! [`Tactor`] at SCHED_FIFO. Each buffer the player fills records its
//! delay: how far the play time is behind the loop's clock, plus the
//! latency the server reports for what is queued ahead of it. Criterion
//! times each 1 s run by the median of the delays recorded so far (its
//! median over runs); each buffer's delays are then printed as p50 and
//! p99, with the underruns, for 256 frames (the goal: p99 at
//! most 10 ms) and 512 (the tactor's buffer).
//!
//! Measured (2026-11-29, this 2-core machine idle, PulseAudio 16.1): 256
//! frames p50 9.00 ms, p99 11.00 ms, 3 underruns in 24 s; 512 frames p50
//! 15.75 ms, p99 15.90 ms, 1 underrun. The goal is not met.

use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use criterion::{Criterion, criterion_group, criterion_main};
use frictionlab::audio::Tactor;

/// The sound server, stopped when dropped.
struct Server(Child, tempfile::TempDir);

impl Drop for Server {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

fn server() -> Option<Server> {
    let dir = tempfile::tempdir().ok()?;
    std::fs::create_dir_all(dir.path().join("home")).ok()?;
    let child = Command::new("pulseaudio")
        .args([
            "-n",
            "--daemonize=no",
            "--exit-idle-time=-1",
            "--use-pid-file=no",
            "--disable-shm=yes",
            "--realtime=yes",
            "--high-priority=yes",
            "-L",
            "module-native-protocol-unix",
            "-L",
            "module-null-sink sink_name=tactile rate=48000 channels=2",
        ])
        .env("XDG_RUNTIME_DIR", dir.path())
        .env("HOME", dir.path().join("home"))
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .ok()?;
    let _ = Command::new("chrt")
        .args(["-f", "-p", "10", &child.id().to_string()])
        .status();
    let socket = dir.path().join("pulse/native");
    let start = Instant::now();
    while !socket.exists() && start.elapsed() < Duration::from_secs(10) {
        std::thread::sleep(Duration::from_millis(20));
    }
    std::thread::sleep(Duration::from_millis(300));
    Some(Server(child, dir))
}

/// Plays seed 001's burst at 1 kHz into `tactor` for `run`.
fn feed(tactor: &Tactor, origin: Instant, run: Duration) {
    let (hz, decay) = (600.0, 1.0 / 0.08);
    let until = Instant::now() + run;
    let mut next = Instant::now();
    while Instant::now() < until {
        let t = origin.elapsed().as_secs_f64();
        // A burst every 100 ms.
        let since = t % 0.1;
        let a = (-decay * since).exp();
        let phase = std::f64::consts::TAU * hz * since;
        tactor.push(t, a * phase.sin(), a * phase.cos(), Some((hz, decay)));
        next += Duration::from_millis(1);
        spin_sleep::sleep_until(next);
    }
}

/// The bench itself, in a process that finds the server through
/// `PULSE_SERVER` (the process without it starts the server and this
/// bench again with it: the environment is set for a child, not changed
/// in a running process).
fn bench(c: &mut Criterion) {
    if std::env::var_os("PULSE_SERVER").is_none() {
        let Some(server) = server() else {
            eprintln!("tactile_delay: pulseaudio is not installed; nothing measured");
            return;
        };
        let pulse = format!("unix:{}", server.1.path().join("pulse/native").display());
        let exe = std::env::current_exe().unwrap_or_else(|e| panic!("the bench's path: {e}"));
        let status = Command::new(exe)
            .args(std::env::args_os().skip(1))
            .env("PULSE_SERVER", pulse)
            .env(
                "PULSE_COOKIE",
                server.1.path().join("home/.config/pulse/cookie"),
            )
            .status()
            .unwrap_or_else(|e| panic!("the bench again: {e}"));
        assert!(status.success(), "tactile_delay failed");
        return;
    }
    let _ = frictionlab::realtime::ask_fifo();
    let mut lines = Vec::new();
    for frames in [256u32, 512] {
        let tactor = Tactor::open_with(
            &frictionlab::audio::Server::from_env(),
            "tactile",
            0,
            frames,
        )
        .unwrap_or_else(|e| panic!("the null sink: {e}"));
        let origin = Instant::now();
        tactor.set_origin(origin);
        feed(&tactor, origin, Duration::from_millis(500));
        c.bench_function(
            &format!("tactile delay, {frames}-frame buffer (median, 1 s runs)"),
            |b| {
                b.iter_custom(|iters| {
                    let mut total = Duration::ZERO;
                    for _ in 0..iters {
                        let before = tactor.delay_quantiles_s();
                        feed(&tactor, origin, Duration::from_secs(1));
                        let (p50, _) = tactor.delay_quantiles_s().or(before).unwrap_or((0.0, 0.0));
                        total += Duration::from_secs_f64(p50);
                    }
                    total
                });
            },
        );
        let (p50, p99) = tactor.delay_quantiles_s().unwrap_or((f64::NAN, f64::NAN));
        lines.push(format!(
            "{frames} frames: delay p50 {:.2} ms, p99 {:.2} ms, underruns {}",
            p50 * 1e3,
            p99 * 1e3,
            tactor.underruns()
        ));
        tactor.finish();
    }
    for l in lines {
        println!("tactile_delay: {l}");
    }
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(10).measurement_time(Duration::from_secs(12));
    targets = bench
}
criterion_main!(benches);
