//! Issue 37: numbers written as they are. Every shipped protocol replayed
//! with its device streams, then analysed: no field of any CSV (data,
//! streams, analysis tables; each number of a `;`-separated list cell) is
//! longer than 25 characters, and none is a subnormal number.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    reason = "a failed unwrap is a failed test"
)]

use crate::common;

use std::path::{Path, PathBuf};
use std::process::Command;

fn csvs(dir: &Path, out: &mut Vec<PathBuf>) {
    for e in std::fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        if p.is_dir() {
            csvs(&p, out);
        } else if p.extension().is_some_and(|x| x == "csv") {
            out.push(p);
        }
    }
}

#[test]
fn no_csv_field_of_any_shipped_protocol_is_longer_than_25_characters_issue_37() {
    let tmp = tempfile::tempdir().unwrap();
    let protocols = common::shipped_protocols();
    assert!(protocols.len() >= 8);
    // The protocols are independent: two at a time (each `simulate` of
    // one participant runs on one thread), on the project's thread pool.
    frictionlab::parallel::run(&protocols, 2, |p| {
        check_protocol(tmp.path(), p);
        Ok::<(), std::convert::Infallible>(())
    });
}

/// Replays and analyses protocol `p` in `tmp`, and checks every CSV field.
fn check_protocol(tmp: &Path, p: &Path) {
    let name = p.file_stem().unwrap().to_string_lossy().into_owned();
    let results = tmp.join(&name);
    let run = |args: &[&str]| {
        let out = Command::new(env!("CARGO_BIN_EXE_frictionlab"))
            .args(args)
            .output()
            .unwrap();
        assert!(
            out.status.success(),
            "{name}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
    };
    let r = results.to_str().unwrap();
    run(&[
        "simulate",
        p.to_str().unwrap(),
        "--participants",
        "1",
        "--seed",
        "5",
        "--streams",
        "--out",
        r,
    ]);
    let a = tmp.join(format!("{name}-analysis"));
    run(&["analyze", r, "--out", a.to_str().unwrap()]);
    let mut files = Vec::new();
    csvs(&results, &mut files);
    csvs(&a, &mut files);
    assert!(
        files
            .iter()
            .any(|f| f.to_string_lossy().contains("streams")),
        "{name}"
    );
    let (mut longest, mut fields) = ((0, String::new()), 0_u64);
    for f in &files {
        let text = std::fs::read_to_string(f).unwrap();
        for line in text.lines().skip(1) {
            // A list cell (Fitts' tap times) holds `;`-separated
            // numbers: each is a field here.
            for field in line.split([',', ';']) {
                fields += 1;
                if field.len() > longest.0 {
                    longest = (field.len(), format!("{}: {field}", f.display()));
                }
                if let Ok(x) = field.parse::<f64>() {
                    assert!(!x.is_subnormal(), "{}: {field}", f.display());
                }
            }
        }
    }
    eprintln!(
        "{name}: {} files, {fields} fields, longest {} ({})",
        files.len(),
        longest.0,
        longest.1
    );
    assert!(longest.0 <= 25, "{name}: {}", longest.1);
    std::fs::remove_dir_all(&results).unwrap();
}
