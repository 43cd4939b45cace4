//! Speed of `simulate` (`cargo bench --bench simulate`): the full
//! magnitude-estimation protocol (60 trials at 5 kHz) with 10 simulated
//! participants, every trial logged and fsync'd as in a real session.
//! The real-time factor is the simulated session time divided by the median
//! wall time; the aim is >= 1,000x (stretch: 10,000x).

use std::hint::black_box;
use std::time::Duration;

use criterion::{Criterion, criterion_group, criterion_main};
use frictionlab::protocol::load::parse;
use frictionlab::results::ResultsDir;
use frictionlab::runner::simulate_participants;

/// Runs the study into a fresh folder under `root`; returns simulated seconds.
fn study(text: &str, root: &std::path::Path) -> f64 {
    let Ok(protocol) = parse(text) else {
        return 0.0;
    };
    let Ok(dir) = tempfile::tempdir_in(root) else {
        return 0.0;
    };
    simulate_participants(
        &ResultsDir::new(dir.path()),
        &protocol,
        text.as_bytes(),
        10,
        1,
        None,
        false,
        &mut |_| {},
    )
    .map_or(0.0, |outcomes| outcomes.iter().map(|o| o.simulated_s).sum())
}

fn simulate(c: &mut Criterion) {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/protocols/magnitude-estimation.json"
    );
    let text = std::fs::read_to_string(path).unwrap_or_default();
    let mut group = c.benchmark_group("simulate");
    group
        .sample_size(10)
        .measurement_time(Duration::from_secs(20));
    for (name, root) in [
        ("magnitude-10-participants/disk", std::env::temp_dir()),
        ("magnitude-10-participants/tmpfs", "/dev/shm".into()),
    ] {
        if !root.is_dir() {
            continue;
        }
        let simulated = study(&text, &root);
        eprintln!("{name}: {simulated:.1} s of session time per iteration");
        group.bench_function(name, |b| b.iter(|| black_box(study(&text, &root))));
    }
    group.finish();
}

criterion_group!(benches, simulate);
criterion_main!(benches);
