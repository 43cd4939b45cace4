//! Speed and memory of `analyze` (`cargo bench --bench analyze`): one
//! million magnitude-estimation trials (1000 participants x 1000 trials, two
//! displays, 30 stimuli). Goal: under 2 s and at most 1 GB.
//!
//! The time is criterion's median of the library call. The memory is the
//! peak resident size (`VmHWM`) that the `frictionlab analyze` binary reports
//! for the same folder, printed once.

use std::fmt::Write as _;
use std::hint::black_box;
use std::path::Path;
use std::time::Duration;

use criterion::{Criterion, criterion_group, criterion_main};
use frictionlab::analysis::analyze;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

const HEADER: &str = "study,kind,participant,session,trial,block,status,seed,practice,repetition,display,mu_s,mu_k,delta_mu,magnitude,response_time_s";

/// Writes the data CSVs; a file that cannot be written stops the bench.
fn generate(dir: &Path) {
    let data = dir.join("data");
    std::fs::create_dir_all(&data).unwrap_or_else(|e| panic!("{}: {e}", data.display()));
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    for p in 0..1000 {
        let mut text = String::from(HEADER);
        text.push('\n');
        for trial in 0..1000 {
            let display = if trial < 500 { "tactile" } else { "force" };
            let stimulus = trial % 30;
            let delta = [0.1, 0.2, 0.3][stimulus / 10];
            let mu_s = 0.375 + 0.025 * (stimulus % 10) as f64;
            let magnitude: f64 = rng.random_range(0.5..20.0);
            let _ = writeln!(
                text,
                "bench,magnitude_estimation,p{p},1,{trial},{display},completed,1,false,{},{display},{mu_s},{},{delta},{magnitude},3.2",
                trial / 30,
                mu_s - delta
            );
        }
        let path = data.join(format!("study-bench_subject-p{p}_session-1_data.csv"));
        std::fs::write(&path, text).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    }
}

fn million(c: &mut Criterion) {
    let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("cannot create a folder: {e}"));
    generate(dir.path());
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
        "frictionlab analyze (1,000,000 trials): {}",
        String::from_utf8_lossy(&o.stdout).trim()
    );
    let mut group = c.benchmark_group("analyze");
    group
        .sample_size(10)
        .measurement_time(Duration::from_secs(20));
    group.bench_function("magnitude-1M-trials", |b| {
        b.iter(|| black_box(analyze(dir.path()).unwrap_or_else(|e| panic!("analyze: {e}"))));
    });
    group.finish();
}

criterion_group!(benches, million);
criterion_main!(benches);
