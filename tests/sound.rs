//! Issue 64: sound against a real sound server. Each test starts its own
//! PulseAudio (`.ci/run` installs it) with null sinks in a folder of its
//! own, runs frictionlab against it, and records the sinks' monitors with
//! `parec`, the server's own recorder: the masking noise's spectrum and
//! level, the tactile display's burst against the session's stream, and
//! the faults (no server, no output, the server killed mid-session).
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::missing_panics_doc,
    clippy::cast_precision_loss,
    clippy::cast_possible_truncation,
    clippy::cast_sign_loss,
    clippy::cast_possible_wrap,
    reason = "tests"
)]

use std::io::Read;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use frictionlab::kinds::Registry;

const BIN: &str = env!("CARGO_BIN_EXE_frictionlab");
const RATE: f64 = 48_000.0;

/// A PulseAudio server of the test's own, with two stereo null sinks at
/// 48 kHz: `tactile` and `masking`. One at a time: see [`ONE_SERVER`].
struct Server {
    dir: tempfile::TempDir,
    child: Option<Child>,
    _alone: std::sync::MutexGuard<'static, ()>,
}

/// Held by each [`Server`] while it lives: the tests with a sound server
/// run one at a time, as a lab's machine runs one session. A server's
/// main thread and a session's players run at real-time priority (the
/// design: a busy core takes nothing from them), so a second test's server
/// and sessions beside a first compete with its sound at the same
/// priority or above, which no busy core does. Two at a time (the
/// realtime binary's tests, as CI runs them) with one core busy, the 60 s
/// session's server ran dry with no stall of the machine in the trial, in
/// 3 of 4 runs; one at a time (`.ci/repeat -n 5 sound`), in 1 of 5
/// (issue 64's note).
static ONE_SERVER: Mutex<()> = Mutex::new(());

impl Server {
    /// Started, or `None` (a skip outside CI, a failure under it) when
    /// PulseAudio is not installed.
    fn start() -> Option<Server> {
        let found = Command::new("pulseaudio")
            .arg("--version")
            .stdout(Stdio::null())
            .status()
            .is_ok_and(|s| s.success());
        assert!(
            found || std::env::var_os("CI").is_none(),
            "pulseaudio is not installed: .ci/run installs it"
        );
        if !found {
            eprintln!("skipped: pulseaudio is not installed (.ci/run installs it)");
            return None;
        }
        let mut server = Server {
            dir: tempfile::tempdir().unwrap(),
            child: None,
            // A test that failed while holding it left nothing behind: its
            // server was killed as it dropped.
            _alone: ONE_SERVER
                .lock()
                .unwrap_or_else(std::sync::PoisonError::into_inner),
        };
        std::fs::create_dir_all(server.dir.path().join("home")).unwrap();
        server.up();
        Some(server)
    }

    /// Starts (again) the daemon and waits for its socket and sinks.
    fn up(&mut self) {
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
                "module-null-sink sink_name=tactile rate=48000 channels=2 sink_properties=device.description=Tactor",
                "-L",
                "module-null-sink sink_name=masking rate=48000 channels=2 sink_properties=device.description=Headphones",
            ])
            .envs(self.env())
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .unwrap();
        // The server's main thread reads each client's sound from its
        // socket (this client has no shared memory): at real-time
        // priority, as the guide says to run it.
        let _ = Command::new("chrt")
            .args(["-f", "-p", "10", &child.id().to_string()])
            .status();
        self.child = Some(child);
        let start = Instant::now();
        while !self.answers() {
            assert!(
                start.elapsed() < Duration::from_secs(20),
                "pulseaudio did not start"
            );
            std::thread::sleep(Duration::from_millis(50));
        }
    }

    fn answers(&self) -> bool {
        Command::new("pactl")
            .args(["list", "short", "sinks"])
            .envs(self.env())
            .output()
            .is_ok_and(|o| String::from_utf8_lossy(&o.stdout).contains("masking"))
    }

    /// The environment a client finds it by.
    fn env(&self) -> Vec<(&'static str, PathBuf)> {
        vec![
            ("XDG_RUNTIME_DIR", self.dir.path().to_owned()),
            ("HOME", self.dir.path().join("home")),
            ("PULSE_SERVER", {
                let mut p = PathBuf::from("unix:");
                p.push(self.dir.path().join("pulse/native"));
                p
            }),
        ]
    }

    /// The server as the library takes it (the window's Setup).
    fn client(&self) -> frictionlab::audio::Server {
        frictionlab::audio::Server::at(
            self.dir.path().join("pulse/native"),
            self.dir.path().join("home/.config/pulse/cookie"),
        )
    }

    fn kill(&mut self) {
        if let Some(mut c) = self.child.take() {
            let _ = c.kill();
            let _ = c.wait();
        }
    }
}

impl Drop for Server {
    fn drop(&mut self) {
        self.kill();
    }
}

/// `parec` recording a sink's monitor, its reads stamped on the monotonic
/// clock.
struct Recording {
    child: Child,
    data: Arc<Mutex<(Vec<f32>, f64)>>,
    reader: Option<std::thread::JoinHandle<()>>,
}

/// The monotonic clock, s (`CLOCK_MONOTONIC`, as the log's
/// `clock_origin_monotonic_s`).
fn monotonic_s() -> f64 {
    let t = rustix::time::clock_gettime(rustix::time::ClockId::Monotonic);
    t.tv_sec as f64 + t.tv_nsec as f64 * 1e-9
}

impl Recording {
    /// Records `sink`'s monitor, `channels` channels, float, 48 kHz.
    fn start(server: &Server, sink: &str, channels: u32) -> Recording {
        let mut child = Command::new("parec")
            .args([
                "-d",
                &format!("{sink}.monitor"),
                "--format=float32le",
                "--rate=48000",
                &format!("--channels={channels}"),
                "--raw",
                "--latency-msec=2",
            ])
            .envs(server.env())
            .stdout(Stdio::piped())
            .spawn()
            .unwrap();
        let mut out = child.stdout.take().unwrap();
        // The samples, and the earliest (read time - samples so far / rate):
        // sample 0's time, give or take the shortest delivery delay.
        let data = Arc::new(Mutex::new((Vec::new(), f64::INFINITY)));
        let shared = data.clone();
        let reader = std::thread::spawn(move || {
            let mut buf = vec![0u8; 4096];
            let mut pending = Vec::new();
            while let Ok(n) = out.read(&mut buf) {
                if n == 0 {
                    break;
                }
                let at = monotonic_s();
                pending.extend_from_slice(&buf[..n]);
                let whole = pending.len() / 4 * 4;
                let mut d = shared.lock().unwrap();
                d.0.extend(
                    pending[..whole]
                        .chunks_exact(4)
                        .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]])),
                );
                pending.drain(..whole);
                let frames = d.0.len() as f64 / f64::from(channels);
                d.1 = d.1.min(at - frames / RATE);
            }
        });
        Recording {
            child,
            data,
            reader: Some(reader),
        }
    }

    /// Waits until samples come, then 0.5 s more: `parec` took 0.7 s to
    /// deliver its first samples here, and delivered its first reads late
    /// and in bursts (a recording started 0.3 s before a session lacked
    /// 200 ms of its first trial's burst and showed it 200 ms late, its
    /// reads' times no guide to its samples' yet).
    fn wait_for_samples(&self) {
        let start = Instant::now();
        while self.data.lock().unwrap().0.is_empty() {
            assert!(
                start.elapsed() < Duration::from_secs(20),
                "parec records nothing"
            );
            std::thread::sleep(Duration::from_millis(10));
        }
        std::thread::sleep(Duration::from_millis(500));
    }

    /// Stops and returns the samples and sample 0's monotonic time.
    fn stop(mut self) -> (Vec<f32>, f64) {
        let _ = self.child.kill();
        let _ = self.child.wait();
        if let Some(r) = self.reader.take() {
            r.join().unwrap();
        }
        let d = self.data.lock().unwrap();
        (d.0.clone(), d.1)
    }
}

fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

/// magnitude-quick with `masking` added (and repeated `repetitions`
/// times), written to `dir`.
fn masked_protocol(dir: &Path, masking: &str, repetitions: u32) -> PathBuf {
    let text = std::fs::read_to_string(root().join("protocols/magnitude-quick.json")).unwrap();
    let mut p: serde_json::Value = serde_json::from_str(&text).unwrap();
    p.as_object_mut().unwrap().remove("$schema");
    p["masking"] = serde_json::from_str(masking).unwrap();
    p["repetitions"] = repetitions.into();
    let path = dir.join("masked.json");
    std::fs::write(&path, serde_json::to_string_pretty(&p).unwrap()).unwrap();
    path
}

fn frictionlab(server: Option<&Server>, args: &[&str]) -> Command {
    let mut c = Command::new(BIN);
    c.args(args);
    match server {
        Some(s) => {
            c.envs(s.env());
        }
        None => {
            c.env_remove("PULSE_SERVER")
                .env_remove("PULSE_RUNTIME_PATH");
        }
    }
    c
}

fn run_args<'a>(protocol: &'a str, out: &'a str) -> Vec<&'a str> {
    vec![
        "run",
        protocol,
        "--participant",
        "p1",
        "--responder",
        "sim",
        "--seed",
        "3",
        "--out",
        out,
    ]
}

/// Exit 2 and one line on standard error, naming `place`, and nothing
/// written under `out`.
fn refused(o: &Output, place: &str, out: &Path) -> String {
    let err = String::from_utf8_lossy(&o.stderr).into_owned();
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert_eq!(err.lines().count(), 1, "one line: {err}");
    assert!(err.starts_with(&format!("error: {place}")), "{err}");
    assert!(!out.exists(), "nothing written: {err}");
    err.trim_end().to_owned()
}

#[test]
fn outputs_are_listed_and_a_missing_server_output_or_flag_is_one_line_exit_2() {
    let Some(server) = Server::start() else {
        return;
    };
    let o = frictionlab(Some(&server), &["audio"]).output().unwrap();
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success());
    assert!(
        text.lines().any(|l| l == "tactile\t2\t48000\tTactor"),
        "{text}"
    );
    assert!(
        text.lines().any(|l| l == "masking\t2\t48000\tHeadphones"),
        "{text}"
    );

    let dir = tempfile::tempdir().unwrap();
    let protocol = masked_protocol(dir.path(), r#"{"noise": "pink"}"#, 1);
    let p = protocol.to_str().unwrap();
    let out = dir.path().join("out");
    let o_ = out.to_str().unwrap();
    let empty = tempfile::tempdir().unwrap();
    let mut lines = Vec::new();
    // No server at all.
    let o = frictionlab(None, &["audio"])
        .env("XDG_RUNTIME_DIR", empty.path())
        .output()
        .unwrap();
    lines.push(refused(&o, "audio: no sound server", &out));
    let mut args = run_args(p, o_);
    args.extend(["--masking-audio", "masking"]);
    let o = frictionlab(None, &args)
        .env("XDG_RUNTIME_DIR", empty.path())
        .output()
        .unwrap();
    lines.push(refused(&o, "--masking-audio: no sound server", &out));
    // No such output.
    let mut args = run_args(p, o_);
    args.extend(["--masking-audio", "speakers"]);
    let o = frictionlab(Some(&server), &args).output().unwrap();
    lines.push(refused(&o, "--masking-audio: no output 'speakers'", &out));
    // Masking asked for, no output given.
    let o = frictionlab(Some(&server), &run_args(p, o_))
        .output()
        .unwrap();
    lines.push(refused(&o, &format!("{p}: masking: "), &out));
    // A channel the output lacks; the simulated apparatus.
    let mut args = run_args(p, o_);
    args.extend(["--masking-audio", "masking", "--tactile-audio", "tactile:3"]);
    args.extend(["--device", "inverse3:127.0.0.1:9"]);
    let o = frictionlab(Some(&server), &args).output().unwrap();
    lines.push(refused(
        &o,
        "--tactile-audio: sound server: output 'tactile' has 2 channels",
        &out,
    ));
    let mut args = run_args(p, o_);
    args.extend(["--masking-audio", "masking", "--tactile-audio", "tactile"]);
    let o = frictionlab(Some(&server), &args).output().unwrap();
    lines.push(refused(
        &o,
        "--tactile-audio: the tactile display plays a device's",
        &out,
    ));
    eprintln!("{}", lines.join("\n"));
}

/// The level, dBFS RMS, and the slope of the power spectrum from 100 Hz
/// to 8 kHz, dB per octave (Welch: Hann windows of 8192, half overlapping,
/// and a line fitted to 10 log10 P against log2 f over the bins).
fn level_and_slope(x: &[f32]) -> (f64, f64) {
    let rms = (x.iter().map(|&v| f64::from(v).powi(2)).sum::<f64>() / x.len() as f64).sqrt();
    let n = 8192;
    let mut planner = rustfft::FftPlanner::<f64>::new();
    let fft = planner.plan_fft_forward(n);
    let window: Vec<f64> = (0..n)
        .map(|i| 0.5 - 0.5 * (std::f64::consts::TAU * i as f64 / n as f64).cos())
        .collect();
    let mut power = vec![0.0; n / 2];
    let mut start = 0;
    while start + n <= x.len() {
        let mut buf: Vec<rustfft::num_complex::Complex<f64>> = (0..n)
            .map(|i| rustfft::num_complex::Complex::new(f64::from(x[start + i]) * window[i], 0.0))
            .collect();
        fft.process(&mut buf);
        for (p, c) in power.iter_mut().zip(&buf) {
            *p += c.norm_sqr();
        }
        start += n / 2;
    }
    let points: Vec<(f64, f64)> = (1..n / 2)
        .map(|k| (k as f64 * RATE / n as f64, power[k]))
        .filter(|&(f, _)| (100.0..=8000.0).contains(&f))
        .map(|(f, p)| (f.log2(), 10.0 * p.log10()))
        .collect();
    let m = points.len() as f64;
    let (sx, sy) = points
        .iter()
        .fold((0.0, 0.0), |(a, b), &(x, y)| (a + x, b + y));
    let (mx, my) = (sx / m, sy / m);
    let (sxy, sxx) = points.iter().fold((0.0, 0.0), |(a, b), &(x, y)| {
        (a + (x - mx) * (y - my), b + (x - mx).powi(2))
    });
    (20.0 * rms.log10(), sxy / sxx)
}

/// Seed 001's masking: pink noise at -20 dBFS through a whole session on
/// the simulated apparatus, recorded from the headphones' sink: 3 dB per
/// octave down (±0.5) from 100 Hz to 8 kHz, at the set level (±1 dB), and
/// no underrun.
#[test]
fn masking_noise_falls_3_db_per_octave_at_its_level() {
    let Some(server) = Server::start() else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let protocol = masked_protocol(
        dir.path(),
        r#"{"noise": "pink", "level_dbfs": -20, "during": "session"}"#,
        1,
    );
    let out = dir.path().join("out");
    let rec = Recording::start(&server, "masking", 1);
    rec.wait_for_samples();
    let mut args = run_args(protocol.to_str().unwrap(), out.to_str().unwrap());
    args.extend(["--masking-audio", "masking", "--pace", "1"]);
    let o = frictionlab(Some(&server), &args).output().unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    std::thread::sleep(Duration::from_millis(300));
    let (x, _) = rec.stop();
    // The noise between its ramps (the first and last 0.25 s cut off).
    let on: Vec<usize> = (0..x.len()).filter(|&i| x[i].abs() > 1e-4).collect();
    let (a, b) = (on[0] + 12_000, on[on.len() - 1] - 12_000);
    assert!(b > a + 5 * 48_000, "{} s of noise", (b - a) as f64 / RATE);
    let (level, slope) = level_and_slope(&x[a..b]);
    eprintln!(
        "masking: {:.1} s recorded, level {level:.2} dBFS, slope {slope:.3} dB/octave",
        (b - a) as f64 / RATE
    );
    assert!((level + 20.0).abs() <= 1.0, "level {level} dBFS");
    assert!((slope + 3.0).abs() <= 0.5, "slope {slope} dB/octave");
    let log = frictionlab::results::read_log::<Registry>(&common_log(&out)).unwrap();
    assert_eq!(log.header.sound.len(), 1);
    assert!(sound_line(&common_log(&out)).contains("\"underruns\":0"));
}

/// Setup's Sound (issue 64): the server's outputs listed, each with a test
/// tone and a level meter. The test tone of the output chosen for the
/// tactile display, on its channel 2, recorded from the sink: sample for
/// sample the tone, 600 Hz for 0.5 s at -20 dBFS RMS (less the head the
/// monitor misses: below), on channel 2, nothing on channel 1;
/// the meter shows its peak, -17.0 dBFS (±0.5 dB: a sine's peak is 3.0 dB
/// over its RMS).
#[test]
fn setup_lists_the_outputs_and_its_600_hz_test_tone_plays_on_the_tactile_channel_and_the_meter() {
    use egui_kittest::kittest::Queryable;
    let Some(server) = Server::start() else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let launch = frictionlab::gui::Launch {
        participant: "p1".into(),
        out: dir.path().join("out"),
        sound: frictionlab::session::sound::SoundChoice {
            server: server.client(),
            masking_audio: None,
            tactile_audio: Some("tactile:2".into()),
        },
        ..frictionlab::gui::Launch::default()
    };
    let mut h = egui_kittest::Harness::builder()
        .with_size(eframe::egui::vec2(1400.0, 1000.0))
        .build_eframe(move |_cc| frictionlab::gui::FrictionlabApp::new(launch));
    h.step();
    assert!(h.query_by_label("2 outputs on the sound server").is_some());
    assert!(h.query_by_label("Tactor (2 ch, 48000 Hz)").is_some());
    assert!(h.query_by_label("Headphones (2 ch, 48000 Hz)").is_some());
    // Both rows have a test tone; the tactile display's is on its channel.
    assert_eq!(h.query_all_by_label("Test tone").count(), 1);
    let rec = Recording::start(&server, "tactile", 2);
    rec.wait_for_samples();
    h.get_by_label("Test tone (channel 2)").click();
    let mut loudest = f32::NEG_INFINITY;
    let start = Instant::now();
    while start.elapsed() < Duration::from_millis(1200) {
        h.step();
        if let Some(l) = h.state().sound_meter_dbfs("tactile") {
            loudest = loudest.max(l);
        }
        std::thread::sleep(Duration::from_millis(10));
    }
    assert!(h.state().error().is_none(), "{:?}", h.state().error());
    let (x, _) = rec.stop();
    let left: Vec<f64> = x.iter().step_by(2).map(|v| f64::from(*v)).collect();
    let right: Vec<f64> = x.iter().skip(1).step_by(2).map(|v| f64::from(*v)).collect();
    let silent = left.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    // The tone as it should be: 600 Hz at -20 dBFS RMS for 0.5 s, with
    // raised-cosine ramps of 10 ms; `k` its sample.
    let tone = |k: i64| -> f64 {
        let t = k as f64 / RATE;
        if !(0.0..0.5).contains(&t) {
            return 0.0;
        }
        let e = (t.min(0.5 - t) / 0.01).min(1.0);
        let ramp = 0.5 - 0.5 * (std::f64::consts::PI * e).cos();
        0.1 * std::f64::consts::SQRT_2 * ramp * (2.0 * std::f64::consts::PI * 600.0 * t).sin()
    };
    // Aligned on its end: the recording against the tone, sample by
    // sample, from the first sample recorded (`head`: below).
    let last = right.iter().rposition(|v| v.abs() > 1e-4).expect("a tone") as i64;
    let sample = |i: i64| usize::try_from(i).ok().and_then(|i| right.get(i)).copied();
    let differs = |end: i64, from: i64| {
        (from..24_000)
            .map(|k| sample(end - 23_999 + k).map_or(1.0, |r| (r - tone(k)).abs()))
            .fold(0.0f64, f64::max)
    };
    let end = (last - 40..=last + 40)
        .min_by(|a, b| differs(*a, 2_400).total_cmp(&differs(*b, 2_400)))
        .unwrap();
    let start = end - 23_999;
    let head = (start..end)
        .take_while(|i| sample(*i).is_none_or(|r| r == 0.0))
        .count();
    let error = differs(end, head as i64);
    let steady = &right[(start + 960) as usize..(end - 960) as usize];
    let rms = (steady.iter().map(|v| v * v).sum::<f64>() / steady.len() as f64).sqrt();
    let level = 20.0 * rms.log10();
    eprintln!(
        "test tone: 0.5 s at 600 Hz against the recording: largest difference {error:.2e} over the {} samples recorded, first {head} samples not recorded; {level:.2} dBFS RMS on channel 2, channel 1 peak {silent:e}; meter peak {loudest:.2} dBFS",
        24_000 - head
    );
    // Every sample recorded is the tone's (to the null sink's 16 bits:
    // 1.5e-5 of full scale), in order,
    // and the tone ends whole. PulseAudio's monitor misses the head of a
    // stream that joins a playing sink, the part of the sink's buffer it
    // had already recorded when the sink was rewound to mix the new
    // stream in (6, 34 and 103 samples in runs here; a sound card plays
    // it): at most the stream's buffer, 2048 frames.
    assert!(error < 1e-4, "differs from the tone by {error}");
    assert!(head <= 2_048, "{head} samples missing");
    assert!((level + 20.0).abs() <= 0.1, "{level} dBFS");
    assert!(silent < 1e-6, "channel 1 plays {silent}");
    assert!((f64::from(loudest) + 17.0).abs() <= 0.5, "meter {loudest}");
}

/// The session's log under `out`.
fn common_log(out: &Path) -> PathBuf {
    let logs: Vec<PathBuf> = std::fs::read_dir(out.join("logs"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.to_string_lossy().ends_with("_log.jsonl"))
        .collect();
    assert_eq!(logs.len(), 1);
    logs[0].clone()
}

/// The log's `sound` line.
fn sound_line(log: &Path) -> String {
    std::fs::read_to_string(log)
        .unwrap()
        .lines()
        .find(|l| l.starts_with("{\"type\":\"sound\""))
        .expect("a sound line")
        .to_owned()
}

/// An emulated Inverse Service on a free port, and its address.
fn inverse3() -> (Child, String) {
    let port = crate::common::free_port();
    let address = format!("127.0.0.1:{port}");
    let child = Command::new(BIN)
        .args([
            "device-emulator",
            &format!("inverse3:{address}"),
            "--lockstep",
        ])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let start = Instant::now();
    while std::net::TcpStream::connect(&address).is_err() {
        assert!(start.elapsed() < Duration::from_secs(10));
        std::thread::sleep(Duration::from_millis(10));
    }
    (child, format!("inverse3:{address}"))
}

/// A 10 ms moving mean of |x| every 0.25 ms (every sample of a slower
/// `x`, each repeated to 0.25 ms): the burst's envelope. 10 ms spans six
/// cycles of the 600 Hz carrier, and ten of the stream's 1 kHz samples of
/// it, whose phases its alias cycles through.
fn envelope(x: &[f64], rate: f64) -> Vec<f64> {
    let w = (0.010 * rate).round() as usize;
    let (hop, repeat) = if rate >= 4000.0 {
        ((0.000_25 * rate).round() as usize, 1)
    } else {
        (1, (0.001 / (1.0 / rate) * 4.0).round() as usize)
    };
    let mut out = Vec::new();
    let mut i = 0;
    while i + w <= x.len() {
        let m = x[i..i + w].iter().map(|v| v.abs()).sum::<f64>() / w as f64;
        out.extend(std::iter::repeat_n(m, repeat.max(1)));
        i += hop;
    }
    out
}

fn correlation(a: &[f64], b: &[f64]) -> f64 {
    let n = a.len().min(b.len()) as f64;
    let (ma, mb) = (a.iter().sum::<f64>() / n, b.iter().sum::<f64>() / n);
    let (mut ab, mut aa, mut bb) = (0.0, 0.0, 0.0);
    for (x, y) in a.iter().zip(b) {
        ab += (x - ma) * (y - mb);
        aa += (x - ma).powi(2);
        bb += (y - mb).powi(2);
    }
    ab / (aa * bb).sqrt()
}

/// Seed 001's tactile display on the emulated Inverse3, with masking:
/// the recording of the tactor's channel follows each completed tactile
/// trial's stream. Its 600 Hz burst envelope (2 ms mean of |x|) against
/// the stream's drive envelope, both on the monotonic clock (the log's
/// `clock_origin_monotonic_s` and parec's reads): correlation >= 0.9 at
/// the best lag, and that lag within the latency the header reports plus
/// one buffer, either way: parec's timestamps, taken from its reads, put
/// the recording a few milliseconds early (seen: lags of -4.75 to -0.75
/// ms where the player measures 9 ms from tick to output), which this
/// test does not resolve.
#[test]
fn the_tactile_recording_follows_the_streams_drive() {
    let Some(server) = Server::start() else {
        return;
    };
    let (emulator, device) = inverse3();
    let dir = tempfile::tempdir().unwrap();
    let protocol = masked_protocol(dir.path(), r#"{"noise": "pink", "level_dbfs": -30}"#, 1);
    let out = dir.path().join("out");
    let rec = Recording::start(&server, "tactile", 2);
    rec.wait_for_samples();
    let mut args = run_args(protocol.to_str().unwrap(), out.to_str().unwrap());
    args.extend(["--masking-audio", "masking", "--tactile-audio", "tactile:2"]);
    args.extend(["--device", &device]);
    let o = frictionlab(Some(&server), &args).output().unwrap();
    let _ = Command::new("kill").arg(emulator.id().to_string()).status();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    std::thread::sleep(Duration::from_millis(300));
    let (x, t0) = rec.stop();
    let right: Vec<f64> = x.chunks_exact(2).map(|f| f64::from(f[1])).collect();
    assert!(
        x.chunks_exact(2).all(|f| f[0] == 0.0),
        "only channel 2 plays"
    );
    let log_path = common_log(&out);
    let log = frictionlab::results::read_log::<Registry>(&log_path).unwrap();
    let tactile = log
        .header
        .sound
        .iter()
        .find(|p| p.role == frictionlab::audio::Role::Tactile)
        .unwrap();
    let bound = tactile.stream.latency_s
        + f64::from(tactile.stream.buffer_frames) / f64::from(tactile.stream.rate_hz);
    let line: serde_json::Value = serde_json::from_str(&sound_line(&log_path)).unwrap();
    let origin = line["streams"][1]["clock_origin_monotonic_s"]
        .as_f64()
        .unwrap();
    let rec_env = envelope(&right, RATE);
    let mut report = Vec::new();
    let (mut worst, mut widest) = (f64::INFINITY, 0.0_f64);
    for (i, r) in log.trials.iter().enumerate() {
        if r.status != frictionlab::protocol::engine::Status::Completed
            || !serde_json::to_string(&r.record.data)
                .unwrap()
                .contains("\"tactile\"")
        {
            continue;
        }
        let stream = std::fs::read_to_string(crate::common::stream_of(&out, &log, i)).unwrap();
        let rows: Vec<(f64, f64)> = stream
            .lines()
            .skip(1)
            .map(|l| {
                let c: Vec<f64> = l.split(',').take(5).map(|v| v.parse().unwrap()).collect();
                (c[0], c[4])
            })
            .collect();
        let rate = 1.0 / (rows[1].0 - rows[0].0);
        let drive: Vec<f64> = rows.iter().map(|r| r.1).collect();
        let drive_env = envelope(&drive, rate);
        // The recording's envelope at the stream's times plus `lag`.
        let at = |lag: f64| -> Vec<f64> {
            (0..drive_env.len())
                .map(|k| {
                    let t = origin + rows[0].0 + k as f64 * 0.000_25 + lag;
                    let idx = ((t - t0) / 0.000_25).round();
                    if idx < 0.0 {
                        0.0
                    } else {
                        rec_env.get(idx as usize).copied().unwrap_or(0.0)
                    }
                })
                .collect()
        };
        let (best_lag, best_r) = (-160..=160)
            .map(|k| f64::from(k) * 0.000_25)
            .map(|lag| (lag, correlation(&drive_env, &at(lag))))
            .fold(
                (0.0, f64::NEG_INFINITY),
                |b, c| if c.1 > b.1 { c } else { b },
            );
        // Should r be undefined (one run in about a dozen, once: trial 1
        // r = -inf, not seen again), say of which envelope.
        let about = |v: &[f64]| {
            let nan = v.iter().filter(|x| x.is_nan()).count();
            let peak = v.iter().fold(0.0f64, |m, x| m.max(*x));
            format!("{} values, {nan} NaN, peak {peak:.3}", v.len())
        };
        report.push(format!(
            "trial {}: r {best_r:.3} at lag {:.2} ms (bound {:.2} ms); drive envelope {}; recording's {}",
            r.trial,
            best_lag * 1e3,
            bound * 1e3,
            about(&drive_env),
            about(&at(best_lag))
        ));
        worst = worst.min(best_r);
        widest = widest.max(best_lag.abs() / bound);
    }
    eprintln!("{}\n{}", report.join("\n"), sound_line(&log_path));
    assert!(!report.is_empty());
    assert!(worst >= 0.9, "{}", report.join("\n"));
    assert!(widest <= 1.0, "{}", report.join("\n"));
}

/// Stalls of the machine itself: a thread on each core at real-time
/// priority 80 (above everything of the session's), waking every
/// millisecond, notes each wake-up later than `least_s`, on the monotonic clock (start, s;
/// length, s). A guest of a virtual machine stops when its host takes the
/// processor: cyclictest (priority 80, memory locked, one core busy) saw
/// wake-ups 27.7 and 28.6 ms late in 60 s on this 2-core VM, so no sound
/// buffer under 28 ms could be free of underruns here whatever the design.
struct Stalls {
    stop: Arc<std::sync::atomic::AtomicBool>,
    threads: Vec<std::thread::JoinHandle<Vec<(f64, f64)>>>,
}

impl Stalls {
    fn watch(least_s: f64) -> Stalls {
        let stop = Arc::new(std::sync::atomic::AtomicBool::new(false));
        let cores = std::thread::available_parallelism().map_or(2, usize::from);
        let threads = (0..cores)
            .map(|core| {
                let stop = stop.clone();
                std::thread::spawn(move || {
                    // One on each core: a core stalls alone.
                    let mut on = nix::sched::CpuSet::new();
                    on.set(core).unwrap();
                    nix::sched::sched_setaffinity(nix::unistd::Pid::from_raw(0), &on).unwrap();
                    assert!(
                        frictionlab::realtime::ask_fifo_at(80) || std::env::var_os("CI").is_none(),
                        "the stall watch needs real-time priority"
                    );
                    let mut stalls = Vec::new();
                    while !stop.load(std::sync::atomic::Ordering::Relaxed) {
                        let before = monotonic_s();
                        std::thread::sleep(Duration::from_millis(1));
                        let late = monotonic_s() - before - 0.001;
                        if late > least_s {
                            stalls.push((before + 0.001, late));
                        }
                    }
                    stalls
                })
            })
            .collect();
        Stalls { stop, threads }
    }

    fn stop(self) -> Vec<(f64, f64)> {
        self.stop.store(true, std::sync::atomic::Ordering::Relaxed);
        let mut all: Vec<(f64, f64)> = self
            .threads
            .into_iter()
            .flat_map(|t| t.join().unwrap())
            .collect();
        all.sort_by(|a, b| a.0.total_cmp(&b.0));
        all
    }
}

/// A paced session of about 60 s on the emulated Inverse3 with the tactile
/// display and masking, one core kept busy: no underrun and no trial
/// aborted, but where the machine itself stopped for longer than the
/// display's slack. The rule is the design's: the player's thread and the
/// server run at real-time priority and the drive plays a fixed delay
/// ([`frictionlab::audio::tactile::DELAY_S`], 5.3 ms) behind the loop, so
/// a busy core takes nothing from either; only a stall of the whole
/// machine longer than that delay (see [`Stalls`]) may make the server run
/// dry or the play time slip. So every trial aborted for those overlaps
/// such a stall, and with no stall neither happens. The haptic loop late
/// by more than the delay runs the drive out (the loop's own timing is the
/// device tests'): the display says so and the trial is presented again.
/// With one core busy and the machine otherwise idle nothing at all was
/// aborted here; with both cores busy the loop ran late (issue 64's note).
/// Beside another test's sound server the rule does not hold: its threads
/// take the processor at the same real-time priority ([`ONE_SERVER`]).
/// With both cores busy it still failed now and then, with no stall
/// of the machine in the trial (not even one over 0.3 ms): the cause is
/// open (issue 64's note), and the test is ignored meanwhile.
#[test]
#[ignore = "issue 64: with both cores busy (.ci/repeat's load beside the test's own spinner) the server still ran dry with no stall of the machine, in 1 of 5 runs one at a time (3 of 4 two at a time, before ONE_SERVER); with one core busy it has not failed; the cause is not found"]
fn a_paced_60_s_session_underruns_only_where_the_machine_or_the_loop_stalled() {
    let Some(server) = Server::start() else {
        return;
    };
    let (emulator, device) = inverse3();
    let dir = tempfile::tempdir().unwrap();
    let protocol = masked_protocol(dir.path(), r#"{"noise": "pink", "level_dbfs": -30}"#, 5);
    let out = dir.path().join("out");
    let stop = Arc::new(std::sync::atomic::AtomicBool::new(false));
    let busy = {
        let stop = stop.clone();
        std::thread::spawn(move || {
            let mut x = 0u64;
            while !stop.load(std::sync::atomic::Ordering::Relaxed) {
                x = x.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1);
                std::hint::black_box(x);
            }
        })
    };
    let slack_s = frictionlab::audio::tactile::DELAY_S;
    let watch = Stalls::watch(slack_s);
    let started = Instant::now();
    let mut args = run_args(protocol.to_str().unwrap(), out.to_str().unwrap());
    args.extend(["--masking-audio", "masking", "--tactile-audio", "tactile"]);
    args.extend(["--device", &device]);
    let o = frictionlab(Some(&server), &args).output().unwrap();
    let stalls = watch.stop();
    stop.store(true, std::sync::atomic::Ordering::Relaxed);
    busy.join().unwrap();
    let _ = Command::new("kill").arg(emulator.id().to_string()).status();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let log_path = common_log(&out);
    let line = sound_line(&log_path);
    let log = frictionlab::results::read_log::<Registry>(&log_path).unwrap();
    let v: serde_json::Value = serde_json::from_str(&line).unwrap();
    let origin = v["streams"][1]["clock_origin_monotonic_s"]
        .as_f64()
        .unwrap();
    // Each aborted trial, on the monotonic clock, and the stalls within
    // it (a stall's sound plays up to a buffer and the delay later).
    let reach = slack_s + 512.0 / RATE;
    let aborted: Vec<(String, usize)> = log
        .trials
        .iter()
        .filter_map(|r| {
            let why = r.abort_reason.clone()?;
            let (a, b) = (origin + r.started_s.secs(), origin + r.ended_s.secs());
            let within = stalls
                .iter()
                .filter(|(t, len)| t + len >= a - reach && *t <= b)
                .count();
            Some((why, within))
        })
        .collect();
    let longest = stalls.iter().fold(0.0f64, |m, s| m.max(s.1));
    eprintln!(
        "{:.0} s, {} records; the machine stalled over {:.1} ms {} times (longest {:.1} ms); aborted (with the stalls in the trial): {aborted:?}\n{line}",
        started.elapsed().as_secs_f64(),
        log.trials.len(),
        slack_s * 1e3,
        stalls.len(),
        longest * 1e3
    );
    assert!(started.elapsed() >= Duration::from_secs(55));
    // The causes an abort names: the server ran dry, the loop's drive ran
    // out, the play time slipped.
    let causes = |why: &str| -> Vec<u64> {
        why.split(' ')
            .filter_map(|w| w.parse::<u64>().ok())
            .collect()
    };
    for (why, within) in &aborted {
        assert!(why.starts_with("tactile underrun"), "{why}");
        let c = causes(why);
        // The sound's own causes only where the machine stopped; the
        // loop's drive running out is the haptic loop late by more than
        // the delay (its own rule is the device tests'), and the display
        // says so and the trial is presented again.
        assert!(
            (c[0] == 0 && c[2] == 0) || *within > 0,
            "the sound broke with no stall of the machine: {why}"
        );
    }
    if stalls.is_empty() {
        let (masking, tactile) = (&v["streams"][0], &v["streams"][1]);
        assert_eq!(masking["underruns"], 0, "{line}");
        assert_eq!(tactile["underrun_causes"][0], 0, "{line}");
        assert_eq!(tactile["underrun_causes"][2], 0, "{line}");
    }
    // Whatever broke, every trial was completed in the end.
    let completed = log
        .trials
        .iter()
        .filter(|r| r.status == frictionlab::protocol::engine::Status::Completed)
        .count();
    assert_eq!(completed + aborted.len(), log.trials.len());
}

/// The server killed mid-session (masking on the simulated apparatus,
/// paced): the trial under way is aborted ("sound output lost") and
/// presented again, the session holds, and goes on when the server is
/// back; every trial is completed once, exit 0.
#[test]
fn a_killed_server_aborts_the_trial_and_the_session_goes_on_when_it_is_back() {
    let Some(mut server) = Server::start() else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let child = kill_in_the_third_trial(&mut server, dir.path(), "30");
    // Back 2 s later.
    std::thread::sleep(Duration::from_secs(2));
    server.up();
    let o = child.wait_with_output().unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let log = frictionlab::results::read_log::<Registry>(&common_log(&out)).unwrap();
    let lost = lost_trials(&log);
    eprintln!(
        "records {}, aborted for the lost output: {lost:?}; {}",
        log.trials.len(),
        sound_line(&common_log(&out))
    );
    assert_eq!(lost.len(), 1, "one trial aborted");
    let completed = completed_trials(&log);
    assert_eq!(completed.len(), log.header.planned_trials);
    assert!(completed.contains(&lost[0]), "presented again");
}

/// The trials aborted for a lost output.
fn lost_trials(log: &frictionlab::kinds::ReadLog) -> Vec<usize> {
    log.trials
        .iter()
        .filter(|r| r.abort_reason.as_deref() == Some("sound output lost"))
        .map(|r| r.trial)
        .collect()
}

fn completed_trials(log: &frictionlab::kinds::ReadLog) -> Vec<usize> {
    log.trials
        .iter()
        .filter(|r| r.status == frictionlab::protocol::engine::Status::Completed)
        .map(|r| r.trial)
        .collect()
}

/// A paced masked session (magnitude-quick, white noise, the simulated
/// apparatus) with `--device-timeout timeout`, under `dir/out`, its
/// server killed 0.5 s into its third trial: the run, still going.
fn kill_in_the_third_trial(server: &mut Server, dir: &Path, timeout: &str) -> Child {
    let protocol = masked_protocol(dir, r#"{"noise": "white", "level_dbfs": -30}"#, 1);
    let out = dir.join("out");
    let mut args = run_args(protocol.to_str().unwrap(), out.to_str().unwrap());
    args.extend([
        "--masking-audio",
        "masking",
        "--pace",
        "1",
        "--device-timeout",
        timeout,
    ]);
    let child = frictionlab(Some(server), &args)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let start = Instant::now();
    // The log, once it is there (its folder comes first).
    let records = |out: &Path| {
        let log = std::fs::read_dir(out.join("logs"))
            .ok()?
            .filter_map(Result::ok)
            .map(|e| e.path())
            .find(|p| p.to_string_lossy().ends_with("_log.jsonl"))?;
        frictionlab::results::read_log::<Registry>(&log)
            .ok()
            .map(|l| l.trials.len())
    };
    while records(&out).unwrap_or(0) < 2 {
        assert!(start.elapsed() < Duration::from_mins(1));
        std::thread::sleep(Duration::from_millis(20));
    }
    std::thread::sleep(Duration::from_millis(500));
    server.kill();
    child
}

/// An output lost for longer than `--device-timeout` (2 s) stops the run
/// as a device that failed: exit 3, one line saying so, the trial under
/// way aborted; `--resume` once the server is back completes the session.
#[test]
fn a_server_gone_past_the_timeout_stops_the_run_with_exit_3_and_it_resumes() {
    let Some(mut server) = Server::start() else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let child = kill_in_the_third_trial(&mut server, dir.path(), "2");
    let killed = Instant::now();
    let o = child.wait_with_output().unwrap();
    let waited = killed.elapsed();
    let err = String::from_utf8_lossy(&o.stderr).into_owned();
    let log = frictionlab::results::read_log::<Registry>(&common_log(&out)).unwrap();
    eprintln!(
        "exit {:?} {:.1} s after the kill: {err}records {}, aborted for the lost output: {:?}",
        o.status.code(),
        waited.as_secs_f64(),
        log.trials.len(),
        lost_trials(&log)
    );
    assert_eq!(o.status.code(), Some(3), "{err}");
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(
        err.contains("a sound output was lost and not back within 2 s"),
        "{err}"
    );
    assert!(waited >= Duration::from_secs(2), "held for the timeout");
    assert_eq!(lost_trials(&log).len(), 1);
    // Back, and resumed: every trial completed.
    server.up();
    let protocol = dir.path().join("masked.json");
    let mut args = run_args(protocol.to_str().unwrap(), out.to_str().unwrap());
    args.extend(["--masking-audio", "masking", "--pace", "20", "--resume"]);
    let o = frictionlab(Some(&server), &args).output().unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let log = frictionlab::results::read_log::<Registry>(&common_log(&out)).unwrap();
    assert_eq!(completed_trials(&log).len(), log.header.planned_trials);
}
