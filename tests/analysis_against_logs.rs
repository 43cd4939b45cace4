//! Issue 31: `analyze` holds each data CSV against its session log, the
//! primary record, before it analyses anything. A simulated
//! magnitude-quick folder (3 participants, 18 trials) is tampered with in
//! each of the ways the issue found unnoticed; each is refused (exit 2,
//! file and line named, nothing written), except the torn last line of a
//! killed session, which is analysed up to it with a notice.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    reason = "a failed unwrap is a failed test"
)]

use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::sync::OnceLock;

use serde_json::Value;

const CSV: &str = "data/study-magnitudequick_subject-sim001_session-1_data.csv";
const LOG: &str = "logs/study-magnitudequick_subject-sim001_session-1_log.jsonl";

fn frictionlab(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_frictionlab"))
        .args(args)
        .output()
        .unwrap()
}

/// The intact folder, simulated once per test binary.
fn intact() -> &'static Path {
    static DIR: OnceLock<tempfile::TempDir> = OnceLock::new();
    DIR.get_or_init(|| {
        let dir = tempfile::tempdir().unwrap();
        let p = format!(
            "{}/protocols/magnitude-quick.json",
            env!("CARGO_MANIFEST_DIR")
        );
        let o = frictionlab(&[
            "simulate",
            &p,
            "--participants",
            "3",
            "--seed",
            "31",
            "--out",
            dir.path().join("results").to_str().unwrap(),
        ]);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        dir
    })
    .path()
}

/// A copy of the intact folder.
fn copy() -> tempfile::TempDir {
    let to = tempfile::tempdir().unwrap();
    let from = intact().join("results");
    for sub in ["data", "logs"] {
        std::fs::create_dir_all(to.path().join(sub)).unwrap();
        for e in std::fs::read_dir(from.join(sub)).unwrap() {
            let e = e.unwrap();
            std::fs::copy(e.path(), to.path().join(sub).join(e.file_name())).unwrap();
        }
    }
    to
}

fn analyze(dir: &Path, extra: &[&str]) -> Output {
    let report = dir.join("report");
    let mut args = vec![
        "analyze",
        dir.to_str().unwrap(),
        "--out",
        report.to_str().unwrap(),
    ];
    args.extend_from_slice(extra);
    frictionlab(&args)
}

fn edit(path: &Path, f: impl FnOnce(Vec<u8>) -> Vec<u8>) {
    let bytes = std::fs::read(path).unwrap();
    std::fs::write(path, f(bytes)).unwrap();
}

/// The lines of `bytes` (without their newlines), edited by `f`, joined
/// again with a final newline.
fn lines(f: impl FnOnce(&mut Vec<Vec<u8>>)) -> impl FnOnce(Vec<u8>) -> Vec<u8> {
    move |bytes| {
        let mut v: Vec<Vec<u8>> = bytes
            .strip_suffix(b"\n")
            .unwrap_or(&bytes)
            .split(|&b| b == b'\n')
            .map(<[u8]>::to_vec)
            .collect();
        f(&mut v);
        let mut out = v.join(&b'\n');
        out.push(b'\n');
        out
    }
}

fn summary(dir: &Path) -> Value {
    serde_json::from_str(&std::fs::read_to_string(dir.join("report/summary.json")).unwrap())
        .unwrap()
}

#[test]
fn an_intact_folder_is_analysed_with_no_notice() {
    let dir = copy();
    let o = analyze(dir.path(), &[]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(
        o.stderr.is_empty(),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    let s = summary(dir.path());
    assert_eq!(s["inputs"]["analysed_rows"]["magnitude_estimation"], 18);
    assert_eq!(s["notes"], serde_json::json!([]));
    assert!(s["inputs"].get("checked_against_logs").is_none());
}

/// Each tampering: (what, file, edit, place, what the message says).
type Tamper = (
    &'static str,
    &'static str,
    Box<dyn FnOnce(&Path)>,
    &'static str,
    &'static str,
);

/// The tamperings the issue found unnoticed, and the ways a log can be
/// damaged.
fn tamperings() -> Vec<Tamper> {
    vec![
        (
            "a trial's row written twice",
            CSV,
            Box::new(|p| edit(p, lines(|v| v.insert(3, v[2].clone())))),
            "4:1",
            "trial 1: the same row as line 3; its log records it once",
        ),
        (
            "a row naming another participant",
            CSV,
            Box::new(|p| {
                edit(p, |b| {
                    String::from_utf8(b)
                        .unwrap()
                        .replacen(",sim-001,1,1,", ",sim-002,1,1,", 1)
                        .into_bytes()
                });
            }),
            "3:38",
            "trial 1: participant is 'sim-002', but this is the CSV of session 1 of 'sim-001'",
        ),
        (
            "a row unlike its log record",
            CSV,
            Box::new(|p| {
                edit(
                    p,
                    lines(|v| {
                        let row = String::from_utf8(v[2].clone()).unwrap();
                        let mut cells: Vec<&str> = row.split(',').collect();
                        cells[14] = "99";
                        v[2] = cells.join(",").into_bytes();
                    }),
                );
            }),
            "3:",
            "trial 1: magnitude is '99', but its log (line 3) records",
        ),
        (
            "a row missing",
            CSV,
            Box::new(|p| edit(p, lines(|v| drop(v.remove(3))))),
            "4:1",
            "trial 2 (log line 4) is missing from the CSV before this row",
        ),
        (
            "a log line torn in the middle",
            LOG,
            Box::new(|p| edit(p, lines(|v| v[2].truncate(60)))),
            "3:",
            "EOF while parsing",
        ),
        (
            "a line of binary junk",
            LOG,
            Box::new(|p| {
                edit(
                    p,
                    lines(|v| v.insert(3, vec![0, 0xff, 0x13, b'j', b'u', b'n', b'k'])),
                );
            }),
            "4:",
            "(after trial 1's record)",
        ),
        (
            "a junk last line (with its newline: no torn write)",
            LOG,
            Box::new(|p| edit(p, lines(|v| v.push(b"#junk".to_vec())))),
            "9:1",
            "not a whole log record (after trial 5's record)",
        ),
        (
            "the header removed",
            LOG,
            Box::new(|p| edit(p, lines(|v| drop(v.remove(0))))),
            "1:1",
            "the first line is not a header",
        ),
        (
            "the log emptied",
            LOG,
            Box::new(|p| std::fs::write(p, b"").unwrap()),
            "1:1",
            "empty log: no header",
        ),
        (
            "the log deleted",
            CSV,
            Box::new(|p| {
                let root = p.parent().unwrap().parent().unwrap();
                std::fs::remove_file(root.join(LOG)).unwrap();
            }),
            "",
            "no session log",
        ),
    ]
}

#[test]
fn every_tampering_of_csv_or_log_is_refused_naming_file_line_and_trial() {
    for (what, file, tamper, place, message) in tamperings() {
        let dir = copy();
        let target = dir.path().join(file);
        tamper(&target);
        let o = analyze(dir.path(), &[]);
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{what}: {stderr}");
        let head = format!("error: {}: {place}", target.display());
        assert!(
            stderr.starts_with(&head),
            "{what}: {stderr} (expected {head})"
        );
        assert!(stderr.contains(message), "{what}: {stderr}");
        assert_eq!(stderr.lines().count(), 1, "{what}: one line");
        assert!(
            !dir.path().join("report").exists(),
            "{what}: nothing written"
        );
    }
}

/// A session killed mid-write: the log ends in half a trial record (no
/// newline, no `end`), and the CSV, rewritten only after a record, lacks
/// that trial. It is analysed up to the torn line, with a one-line notice
/// (also in summary.json's notes).
#[test]
fn the_torn_last_line_of_a_killed_session_is_analysed_up_to_it_with_a_notice() {
    let dir = copy();
    let log = dir.path().join(LOG);
    edit(&log, |b| {
        let text = String::from_utf8(b).unwrap();
        let mut v: Vec<&str> = text.lines().collect();
        v.pop(); // the `end` line
        let last = v.pop().unwrap();
        format!("{}\n{}", v.join("\n"), &last[..last.len() / 2]).into_bytes()
    });
    edit(&dir.path().join(CSV), lines(|v| drop(v.pop())));
    let o = analyze(dir.path(), &[]);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{stderr}");
    assert_eq!(stderr.lines().count(), 1, "{stderr}");
    assert!(
        stderr.starts_with(&format!("note: {}: 7:1: a torn last line (", log.display())),
        "{stderr}"
    );
    let s = summary(dir.path());
    assert_eq!(s["inputs"]["analysed_rows"]["magnitude_estimation"], 17);
    assert!(s["notes"][0].as_str().unwrap().contains("torn last line"));
}

/// `--csv-only` analyses hand-edited CSVs alone and says so in
/// summary.json.
#[test]
fn csv_only_analyses_the_csvs_alone_and_says_so() {
    let dir = copy();
    edit(&dir.path().join(CSV), lines(|v| v.insert(3, v[2].clone())));
    let o = analyze(dir.path(), &["--csv-only"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let s = summary(dir.path());
    assert_eq!(s["inputs"]["checked_against_logs"], false);
    assert_eq!(s["inputs"]["analysed_rows"]["magnitude_estimation"], 19);
    assert!(
        s["notes"][0]
            .as_str()
            .unwrap()
            .contains("not held against their session logs")
    );
}

/// A session open in another process is left out, with a notice: its
/// files are still being written.
#[test]
fn a_session_open_in_another_process_is_left_out_with_a_notice() {
    let dir = copy();
    let log: PathBuf = dir.path().join(LOG);
    let held = std::fs::OpenOptions::new().append(true).open(&log).unwrap();
    held.lock().unwrap();
    let o = analyze(dir.path(), &[]);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{stderr}");
    assert!(
        stderr.contains(&format!(
            "note: {}: the session is open in another process (pid {})",
            log.display(),
            std::process::id()
        )),
        "{stderr}"
    );
    assert_eq!(
        summary(dir.path())["inputs"]["analysed_rows"]["magnitude_estimation"],
        12
    );
    drop(held);
}

/// Each file is read once: a CSV that is its log's byte for byte gets its
/// rows from the log, one in another notation from its own records, and
/// `--csv-only` from the CSVs alone; the statistics are the same.
#[test]
fn rows_from_the_log_or_from_the_csv_give_the_same_statistics() {
    let stats = |s: &Value| s["magnitude_estimation"].clone();
    let dir = copy();
    let o = analyze(dir.path(), &[]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let from_log = summary(dir.path());
    assert!(from_log["magnitude_estimation"].is_object(), "{from_log}");

    let o = analyze(dir.path(), &["--csv-only"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert_eq!(stats(&summary(dir.path())), stats(&from_log));

    // Quoted cells: the same values to a CSV reader, not the same bytes.
    let text = std::fs::read_to_string(dir.path().join(CSV)).unwrap();
    let quoted = text.replace(",sim-001,", ",\"sim-001\",");
    assert_ne!(quoted, text);
    std::fs::write(dir.path().join(CSV), quoted).unwrap();
    let o = analyze(dir.path(), &[]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let from_csv = summary(dir.path());
    assert_eq!(stats(&from_csv), stats(&from_log));
    assert_eq!(from_csv["inputs"], from_log["inputs"]);
}

#[test]
fn a_csv_made_from_its_log_places_each_quoted_cell_as_a_csv_reader_reads_it_and_is_matched_byte_for_byte()
 {
    // Displays whose names the CSV must quote (a comma, a quote).
    let protocol = std::fs::read_to_string(format!(
        "{}/protocols/magnitude-quick.json",
        env!("CARGO_MANIFEST_DIR")
    ))
    .unwrap()
    .replace("\"tactile\"", r#""tactile, \"fine\"""#);
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("quoted.json");
    std::fs::write(&path, protocol).unwrap();
    let results = dir.path().join("results");
    let o = frictionlab(&[
        "simulate",
        path.to_str().unwrap(),
        "--participants",
        "2",
        "--seed",
        "45",
        "--out",
        results.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let mut logs = 0;
    for e in std::fs::read_dir(results.join("logs")).unwrap() {
        let log =
            frictionlab::results::read_log::<frictionlab::kinds::Registry>(&e.unwrap().path())
                .unwrap();
        let made = frictionlab::results::DataText::of(&log);
        let read = frictionlab::results::reader::records(&made.text, true).unwrap();
        assert_eq!(made.records().len(), log.trials.len());
        assert_eq!(read.len(), log.trials.len() + 1);
        let mut quoted = 0;
        for (cells, record) in made.records().zip(&read[1..]) {
            assert_eq!(record.cells.len(), made.columns.len());
            for (i, cell) in record.cells.iter().enumerate() {
                let written = frictionlab::results::csv::text(cell);
                quoted += usize::from(written.starts_with('"'));
                assert_eq!(cells.get(i), Some(written.as_str()), "cell {i}");
            }
            assert_eq!(cells.get(made.columns.len()), None);
        }
        assert!(quoted > 0, "no quoted cell to place");
        // The log check's way to it: each record made in turn and held
        // against the CSV's text, which it keeps; any other text back.
        assert_eq!(
            frictionlab::results::DataText::matching(&log, made.text.clone()).as_ref(),
            Ok(&made)
        );
        let last = made.text.trim_end().rfind('\n').unwrap() + 1;
        for other in [
            made.text.replacen("tactile", "tactilE", 1),
            made.text[..last].to_owned(),
            format!("{}{}", made.text, &made.text[last..]),
            made.text.replacen(',', ";", 1),
        ] {
            assert_eq!(
                frictionlab::results::DataText::matching(&log, other.clone()),
                Err(other)
            );
        }
        logs += 1;
    }
    assert_eq!(logs, 2);
    // The analysis takes those rows from the log, the display's name as
    // the protocol has it.
    let o = analyze(&results, &[]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let s = summary(&results);
    assert!(s.to_string().contains(r#"tactile, \"fine\""#), "{s}");
}
