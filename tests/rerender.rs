//! `frictionlab rerender` on a session recorded with the simulated device:
//! a stream re-renders exactly, and a damaged stream or one without its log
//! is refused with the file and place named (exit 2), never a panic.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    reason = "a failed unwrap is a failed test"
)]

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_frictionlab"))
}

fn rerender(stream: &Path) -> Output {
    bin().arg("rerender").arg(stream).output().unwrap()
}

/// The first stream of a magnitude-quick session run on the simulated
/// device into `out`.
fn a_recorded_stream(out: &Path) -> PathBuf {
    let protocol = format!(
        "{}/protocols/magnitude-quick.json",
        env!("CARGO_MANIFEST_DIR")
    );
    let o = bin()
        .args(["run", &protocol, "--participant", "p", "--out"])
        .arg(out)
        .args(["--responder", "sim", "--seed", "3"])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let mut streams: Vec<PathBuf> = std::fs::read_dir(out.join("streams"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    streams.sort();
    streams.swap_remove(0)
}

#[test]
fn a_simulated_trial_re_renders_exactly_and_counts_its_transitions() {
    let dir = tempfile::tempdir().unwrap();
    let stream = a_recorded_stream(dir.path());
    let o = rerender(&stream);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let r: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(r["bit_exact"], true, "{r}");
    assert_eq!(r["max_force_diff_n"], 0.0);
    assert_eq!(r["modes"], serde_json::json!(["simulated"]));
    // magnitude-quick explores each stimulus for 2 s of seed 001's
    // stick-slip, which slips many times.
    let replayed = r["replayed_s"].as_f64().unwrap();
    assert!((1.0..=2.5).contains(&replayed), "{r}");
    assert!(r["slip_onsets"].as_u64().unwrap() >= 5, "{r}");
}

#[test]
fn a_damaged_stream_or_one_without_its_log_is_refused_with_its_place() {
    let dir = tempfile::tempdir().unwrap();
    let stream = a_recorded_stream(dir.path());
    let text = std::fs::read_to_string(&stream).unwrap();
    let name = stream.file_name().unwrap().to_str().unwrap().to_owned();
    let stem = name
        .strip_suffix("_trial-0_run-1_stream.csv")
        .expect("the first stream is trial 0's");
    let edit_row = |row: usize, edit: &dyn Fn(&mut Vec<String>)| {
        let mut lines: Vec<String> = text.lines().map(str::to_owned).collect();
        let mut cells: Vec<String> = lines[row].split(',').map(str::to_owned).collect();
        edit(&mut cells);
        lines[row] = cells.join(",");
        lines.join("\n")
    };
    let cases: [(String, String, &str); 4] = [
        (
            name.clone(),
            edit_row(4, &|cells| cells[2] = "abc".into()),
            ": 5:3: column 'v_m_s': 'abc' is not a finite number",
        ),
        (
            name.clone(),
            edit_row(3, &|cells| cells[5] = "7".into()),
            ": 4:6: render 7 is not in the record's rendering",
        ),
        (
            "not-a-stream.csv".into(),
            text.clone(),
            ": not a session stream",
        ),
        (
            // Trial 0's stream as a ninth presentation, which the log lacks.
            format!("{stem}_trial-0_run-9_stream.csv"),
            text.clone(),
            "no record of trial 0, presentation 9",
        ),
    ];
    for (file, content, expected) in cases {
        let path = stream.with_file_name(&file);
        std::fs::write(&path, content).unwrap();
        let o = rerender(&path);
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{file}: {stderr}");
        assert!(
            stderr.starts_with("error: ") && stderr.contains(expected),
            "{file}: {stderr}"
        );
    }
}
