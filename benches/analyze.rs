//! Speed and memory of `analyze` (`cargo bench --bench analyze`): one
//! million magnitude-estimation trials (1000 participants x 1000 trials, two
//! displays, 30 stimuli). Goal: under 2 s and at most 1 GB.
//!
//! Each session has its log (the primary record) and the data CSV made
//! from it, as `run` writes them, so `analyze` holds every CSV against its
//! log first (issue 31); `magnitude-1M-trials-csv-only` is the same folder
//! analysed CSV-only, for the cost of that check.
//!
//! `cargo test` runs this bench once as a test (criterion's test mode,
//! without cargo bench's `--bench`), on a debug build: there the folder
//! has 10 sessions (10,000 trials), enough to run every step once.
//!
//! The time is criterion's median of the library call. With
//! `FRICTIONLAB_BENCH_KEEP=DIR` the folder is also copied to `DIR`, for the
//! independent peer `analysis/peers/pandas_magnitude.py` to read. The memory is the
//! peak resident size (`VmHWM`) that the `frictionlab analyze` binary reports
//! for the same folder, printed once.

use std::hint::black_box;
use std::path::Path;
use std::time::Duration;

use criterion::{Criterion, criterion_group, criterion_main};
use frictionlab::analysis::{Check, analyze, analyze_with};
use frictionlab::kinds::TrialData;
use frictionlab::kinds::magnitude::MagnitudeData;
use frictionlab::kinds::{Header, LogLine, LoggedTrial, ReadLog, Registry, TrialRecord};
use frictionlab::protocol::engine::Status;
use frictionlab::results::{LOG_FORMAT, ResultsDir, data_csv};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Writes each of `participants` sessions' log and its data CSV (made
/// from the log, as a session does); a file that cannot be written stops
/// the bench.
fn generate(dir: &Path, participants: u32) {
    let text = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/protocols/magnitude-estimation.json"
    ))
    .unwrap_or_else(|e| panic!("the protocol: {e}"));
    let mut protocol = frictionlab::protocol::load::parse::<Registry>(&text)
        .unwrap_or_else(|e| panic!("the protocol: {e:?}"));
    protocol.id = "bench".into();
    let results = ResultsDir::new(dir);
    for sub in ["data", "logs"] {
        let path = dir.join(sub);
        std::fs::create_dir_all(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    }
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    for p in 0..participants {
        let header = Header {
            format: LOG_FORMAT.into(),
            software_version: env!("CARGO_PKG_VERSION").into(),
            protocol_id: "bench".into(),
            protocol_sha256: String::new(),
            protocol: protocol.clone(),
            plan_seed: 1,
            participant: format!("p{p}"),
            participant_index: p,
            session: 1,
            device: "sim".into(),
            device_settings: None,
            device_limits: None,
            device_check: None,
            responder: "sim".into(),
            planned_trials: 1000,
            population: None,
            sound: Vec::new(),
        };
        let trials: Vec<LoggedTrial> = (0..1000_usize)
            .map(|trial| {
                let display = if trial < 500 { "tactile" } else { "force" };
                let stimulus = trial % 30;
                let delta = [0.1, 0.2, 0.3][stimulus / 10];
                let mu_s = 0.375 + 0.025 * (stimulus % 10) as f64;
                LoggedTrial::new(TrialRecord {
                    trial,
                    block: display.into(),
                    block_index: usize::from(trial >= 500),
                    practice: false,
                    repetition: u32::try_from(trial / 30).unwrap_or(0),
                    status: Status::Completed,
                    abort_reason: None,
                    requeued: false,
                    trial_seed: 1,
                    started_s: frictionlab::time::Time::from_whole_secs(trial as u64 * 4),
                    ended_s: frictionlab::time::Time::from_secs_saturating(
                        trial as f64 * 4.0 + 3.2,
                    ),
                    data: TrialData::MagnitudeEstimation(MagnitudeData {
                        display: display.into(),
                        mu_s: Some(mu_s),
                        mu_k: Some(mu_s - delta),
                        delta_mu: Some(delta),
                        magnitude: Some(rng.random_range(0.5..20.0)),
                        response_time_s: Some(3.2),
                        parameter: None,
                        level: None,
                    }),
                })
            })
            .collect();
        let line = |l: &LogLine| {
            serde_json::to_string(l).unwrap_or_else(|e| panic!("a log line: {e}")) + "\n"
        };
        let mut log = line(&LogLine::Header(Box::new(header.clone())));
        for t in &trials {
            log += &line(&LogLine::Trial(t.clone()));
        }
        log += &line(&LogLine::End {
            completed: 1000,
            aborted: 0,
        });
        let files = results.files("bench", &header.participant, 1);
        let read = ReadLog {
            header,
            trials,
            ended: true,
            valid_len: 0,
            torn_bytes: 0,
        };
        for (path, text) in [(&files.log, log), (&files.csv, data_csv(&read))] {
            std::fs::write(path, text).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        }
    }
}

fn million(c: &mut Criterion) {
    // Measured (`cargo bench`), or run once as a test (module docs).
    let measured = std::env::args().any(|a| a == "--bench");
    let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("cannot create a folder: {e}"));
    generate(dir.path(), if measured { 1000 } else { 10 });
    // The folder kept for a peer to read (analysis/peers/pandas_magnitude.py).
    if let Some(keep) = std::env::var_os("FRICTIONLAB_BENCH_KEEP") {
        let keep = Path::new(&keep);
        for sub in ["data", "logs"] {
            let to = keep.join(sub);
            std::fs::create_dir_all(&to).unwrap_or_else(|e| panic!("{}: {e}", to.display()));
            for f in std::fs::read_dir(dir.path().join(sub))
                .unwrap_or_else(|e| panic!("{sub}: {e}"))
                .filter_map(Result::ok)
            {
                std::fs::copy(f.path(), to.join(f.file_name()))
                    .unwrap_or_else(|e| panic!("{}: {e}", f.path().display()));
            }
        }
    }
    let report = dir.path().join("report");
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_frictionlab"))
        .args([
            "analyze",
            &dir.path().to_string_lossy(),
            "--out",
            &report.to_string_lossy(),
        ])
        .output()
        .unwrap_or_else(|e| panic!("frictionlab analyze: cannot run: {e}"));
    assert!(
        o.status.success(),
        "frictionlab analyze failed ({}): {}",
        o.status,
        String::from_utf8_lossy(&o.stderr).trim()
    );
    eprintln!(
        "frictionlab analyze ({} trials): {}",
        if measured { "1,000,000" } else { "10,000" },
        String::from_utf8_lossy(&o.stdout).trim()
    );
    let mut group = c.benchmark_group("analyze");
    group
        .sample_size(10)
        .measurement_time(Duration::from_secs(20));
    group.bench_function("magnitude-1M-trials", |b| {
        b.iter(|| {
            black_box(analyze::<Registry>(dir.path()).unwrap_or_else(|e| panic!("analyze: {e}")))
        });
    });
    group.bench_function("magnitude-1M-trials-csv-only", |b| {
        b.iter(|| {
            black_box(
                analyze_with::<Registry>(dir.path(), Check::CsvOnly)
                    .unwrap_or_else(|e| panic!("analyze: {e}")),
            )
        });
    });
    group.finish();
}

criterion_group!(benches, million);
criterion_main!(benches);
