//! Speed of `simulate` (`cargo bench --bench simulate`): the full
//! magnitude-estimation protocol (60 trials at 5 kHz) with 10 simulated
//! participants, every trial logged and fsync'd as in a real session.
//! The real-time factor is the simulated session time divided by the median
//! wall time; the aim is >= 1,000x (stretch: 10,000x). One session at a time
//! (`jobs-1`), and one per core (`jobs-all`, as `simulate` does by default).
//! And `protocols/fitts-quick.json` with 10 participants, one session at a
//! time: the Fitts movements' planner (issue 44) runs there.
//!
//! `cargo test` runs this bench once as a test (criterion's test mode,
//! without cargo bench's `--bench`), on a debug build: there each study
//! has 1 participant, enough to run every step once.

use std::hint::black_box;
use std::time::Duration;

use criterion::{Criterion, criterion_group, criterion_main};
use frictionlab::protocol::load::parse;
use frictionlab::results::ResultsDir;
use frictionlab::session::{Simulation, simulate_participants};

/// Participants in each study: 10, or 1 when run as a test (module docs).
fn participants() -> u32 {
    if std::env::args().any(|a| a == "--bench") {
        10
    } else {
        1
    }
}

/// Runs the study into a fresh folder under `root`; returns simulated
/// seconds. A run that fails stops the bench with its error.
fn study(text: &str, root: &std::path::Path, jobs: usize) -> f64 {
    let protocol = parse(text).unwrap_or_else(|errors| {
        let errors: Vec<String> = errors.iter().map(ToString::to_string).collect();
        panic!("protocol: {}", errors.join("; "))
    });
    let dir = tempfile::tempdir_in(root)
        .unwrap_or_else(|e| panic!("{}: cannot create a folder: {e}", root.display()));
    simulate_participants(
        &ResultsDir::new(dir.path()),
        &Simulation {
            protocol: &protocol,
            protocol_bytes: text.as_bytes(),
            participants: participants(),
            seed: 1,
            pace: None,
            streams: false,
            jobs,
            population: None,
            stop: None,
            lsl: None,
        },
        &|_| {},
    )
    .unwrap_or_else(|e| panic!("simulate: {e}"))
    .iter()
    .map(|o| o.simulated_s)
    .sum()
}

fn simulate(c: &mut Criterion) {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/protocols/magnitude-estimation.json"
    );
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{path}: {e}"));
    let mut group = c.benchmark_group("simulate");
    group
        .sample_size(10)
        .measurement_time(Duration::from_secs(20));
    let cores = std::thread::available_parallelism().map_or(1, std::num::NonZero::get);
    for (name, root, jobs) in [
        (
            "magnitude-10-participants/disk/jobs-1",
            std::env::temp_dir(),
            1,
        ),
        (
            "magnitude-10-participants/tmpfs/jobs-1",
            "/dev/shm".into(),
            1,
        ),
        (
            "magnitude-10-participants/disk/jobs-all",
            std::env::temp_dir(),
            cores,
        ),
        (
            "magnitude-10-participants/tmpfs/jobs-all",
            "/dev/shm".into(),
            cores,
        ),
    ] {
        if !root.is_dir() {
            eprintln!("{name}: skipped, {} is not a folder here", root.display());
            continue;
        }
        let simulated = study(&text, &root, jobs);
        eprintln!("{name} ({jobs} jobs): {simulated:.1} s of session time per iteration");
        group.bench_function(name, |b| {
            b.iter(|| black_box(study(&text, &root, jobs)));
        });
    }
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/protocols/fitts-quick.json");
    let fitts = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{path}: {e}"));
    let root = std::env::temp_dir();
    let simulated = study(&fitts, &root, 1);
    eprintln!(
        "fitts-quick-10-participants/disk/jobs-1: {simulated:.1} s of session time per iteration"
    );
    group.bench_function("fitts-quick-10-participants/disk/jobs-1", |b| {
        b.iter(|| black_box(study(&fitts, &root, 1)));
    });
    group.finish();
}

criterion_group!(benches, simulate);
criterion_main!(benches);
