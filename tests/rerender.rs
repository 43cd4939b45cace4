//! `frictionlab rerender` on a session recorded with the simulated device:
//! a stream re-renders exactly, and a damaged stream or one without its log
//! is refused with the file and place named (exit 2), never a panic.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    reason = "a failed unwrap is a failed test"
)]

use crate::common;

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_frictionlab"))
}

fn rerender(stream: &Path) -> Output {
    bin().arg("rerender").arg(stream).output().unwrap()
}

/// The first stream of a magnitude-quick session run on the simulated
/// device into `out`, 1000 times faster than real time (the simulated
/// device's files are the same at any pace).
fn a_recorded_stream(out: &Path) -> PathBuf {
    let protocol = format!(
        "{}/protocols/magnitude-quick.json",
        env!("CARGO_MANIFEST_DIR")
    );
    let o = bin()
        .args(["run", &protocol, "--participant", "p", "--out"])
        .arg(out)
        .args(["--responder", "sim", "--seed", "3", "--pace", "1000"])
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

/// A trial aborted before the device's first tick (a device lost again
/// right as the trial started) leaves a stream of its header alone and a
/// record without `rendering`: it re-renders as nothing to replay, which
/// shows nothing (exit 2, `compared` 0, not `bit_exact`; issue 63). A
/// stream with rows whose record lacks `rendering` is still refused.
#[test]
fn a_stream_without_rows_re_renders_as_nothing_to_replay() {
    let dir = tempfile::tempdir().unwrap();
    let stream = a_recorded_stream(dir.path());
    let [log]: [PathBuf; 1] = common::session_logs(dir.path()).try_into().unwrap();
    let lines: Vec<String> = std::fs::read_to_string(&log)
        .unwrap()
        .lines()
        .map(|line| {
            let mut v: serde_json::Value = serde_json::from_str(line).unwrap();
            if v["type"] == "trial" && v["trial"] == 0 {
                v.as_object_mut().unwrap().remove("rendering").unwrap();
            }
            v.to_string()
        })
        .collect();
    std::fs::write(&log, lines.join("\n") + "\n").unwrap();
    let o = rerender(&stream);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        String::from_utf8_lossy(&o.stderr).contains("trial 0: the record has no 'rendering'"),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    let text = std::fs::read_to_string(&stream).unwrap();
    std::fs::write(&stream, format!("{}\n", text.lines().next().unwrap())).unwrap();
    let o = rerender(&stream);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        String::from_utf8_lossy(&o.stderr).contains("no row compared"),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    let r: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(
        (
            r["rows"].as_u64(),
            r["compared"].as_u64(),
            r["bit_exact"].as_bool()
        ),
        (Some(0), Some(0), Some(false)),
        "{r}"
    );
}

/// Issue 63: a stream that lost its start (before, trial 0 on a Haply
/// device began 0.5-0.9 s into its trial, without the row where its
/// model was selected) has no row the replay can start from. `rerender`
/// skipped every row and still said `bit_exact`; now it prints how many
/// rows it compared, 0, and exits 2. The whole stream compares every row
/// from its select on.
#[test]
fn a_stream_without_its_start_compares_no_row_and_exits_2() {
    let dir = tempfile::tempdir().unwrap();
    let stream = a_recorded_stream(dir.path());
    let o = rerender(&stream);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let whole: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let rows = whole["rows"].as_u64().unwrap();
    let compared = whole["compared"].as_u64().unwrap();
    assert_eq!(
        compared,
        rows - whole["skipped"].as_u64().unwrap(),
        "{whole}"
    );
    assert!(compared > 1000, "{whole}");

    // The same stream from its 500th row: the select is gone.
    let text = std::fs::read_to_string(&stream).unwrap();
    let mut lines: Vec<&str> = text.lines().collect();
    lines.drain(1..500);
    std::fs::write(&stream, lines.join("\n") + "\n").unwrap();
    let o = rerender(&stream);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{stderr}");
    assert!(
        stderr.starts_with("error: ") && stderr.contains("no row compared"),
        "{stderr}"
    );
    let cut: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    println!(
        "whole: {rows} rows, {compared} compared; without its first 499 rows: {} rows, {} compared, bit_exact {}",
        cut["rows"], cut["compared"], cut["bit_exact"]
    );
    assert_eq!(
        (
            cut["rows"].as_u64(),
            cut["compared"].as_u64(),
            cut["skipped"].as_u64(),
            cut["bit_exact"].as_bool()
        ),
        (Some(rows - 499), Some(0), Some(rows - 499), Some(false)),
        "{cut}"
    );
}

/// Streams of a [`BoardLoop`] rendering on board at 5 kHz, as the host records
/// them.
mod on_board {
    use frictionlab::friction::{Float, Input, ModelParams};
    use frictionlab::rerender::Row;
    use frictionlab::results::{RenderEntry, RenderMode};
    use frictionlab_core::onboard::BoardLoop;
    use frictionlab_core::wire::{Message, status};

    pub const RATE_HZ: u16 = 5000;

    /// Tick `k` of `board` on a stroke of 0.03 m at `w` rad/s: its
    /// telemetry as a stream row. The host knows label 1 as its render 0;
    /// any other label is render 1.
    pub fn tick_row(board: &mut BoardLoop<f32>, k: u32, w: f64) -> Row {
        tick_row_as(board, k, w, |label| usize::from(label != 1))
    }

    /// [`tick_row`] with the host's render for each label.
    pub fn tick_row_as(
        board: &mut BoardLoop<f32>,
        k: u32,
        w: f64,
        render_of: impl Fn(u8) -> usize,
    ) -> Row {
        let t = f64::from(k) / f64::from(RATE_HZ);
        #[expect(clippy::cast_possible_truncation, reason = "the device's f32")]
        let input = Input {
            x_m: (0.03 * (w * t).sin()) as f32,
            v_m_s: (0.03 * w * (w * t).cos()) as f32,
        };
        let Some(Message::Telemetry {
            tick,
            x_m,
            v_m_s,
            force_n,
            vibration,
            render,
            flags,
        }) = board.tick(input, false, false).telemetry
        else {
            panic!("telemetry every tick");
        };
        Row {
            t_s: t,
            x_m: f64::from(x_m),
            v_m_s: f64::from(v_m_s),
            force_n: f64::from(force_n),
            vibration: f64::from(vibration),
            render: render_of(render),
            selected: flags & status::SELECTED != 0,
            watchdog: flags & status::WATCHDOG != 0,
            tick: Some(tick),
            normal_n: None,
        }
    }

    /// The record's entry of an on-board render of `model`.
    pub fn entry(model: Option<ModelParams>) -> RenderEntry {
        RenderEntry {
            model,
            mode: RenderMode::OnBoard,
            float: Float::F32,
            rate_hz: f64::from(RATE_HZ),
            ramp_s: frictionlab_core::render::RAMP_S,
            force_limit_n: 8.0,
        }
    }
}

/// A device rendering on board keeps stepping its model while its watchdog
/// holds the output at 0 (the host silent for 20 ms, as a stalled link
/// under load can be), and takes a model the host sends again for the
/// resend it is (no restart). Its stream, with the watchdog marked,
/// re-renders exactly; with the watchdog marks
/// removed it does not, so the marks are what make the audit exact. With
/// telemetry lost, the replay is exact up to the loss and stops there.
#[test]
fn an_on_board_stream_with_a_tripped_watchdog_a_resent_model_and_lost_telemetry_re_renders_exactly_up_to_the_loss()
 {
    use frictionlab::friction::{ForceLimit, ModelParams};
    use frictionlab::rerender::rerender;
    use frictionlab_core::onboard::{BoardLoop, upload};
    use frictionlab_core::wire::Message;
    use on_board::{RATE_HZ, entry, tick_row};

    let model = ModelParams::default_for("stick-slip-tactile").unwrap();
    let mut board = BoardLoop::<f32>::new(RATE_HZ, ForceLimit::new(8.0).unwrap());
    let send_model = |board: &mut BoardLoop<f32>| upload(&model, 1, |m| board.receive(&m));
    send_model(&mut board);
    // The host goes silent from 0.60 s to 0.66 s (its heartbeats are 1 ms
    // apart otherwise) and sends the model again at 1.4 s.
    let silent = 3000..3300;
    let mut rows = Vec::new();
    for k in 0..10_000_u32 {
        if k % 5 == 0 && !silent.contains(&k) {
            board.receive(&Message::Heartbeat { seq: k });
        }
        if k == 7000 {
            send_model(&mut board);
        }
        // A stroke back and forth, peaking at 0.094 m/s.
        rows.push(tick_row(&mut board, k, std::f64::consts::PI));
    }
    let entries = [entry(Some(model.clone()))];
    assert_eq!(
        rows.iter().filter(|r| r.selected).count(),
        1,
        "the select; the resend restarts nothing"
    );
    let r = rerender(&rows, &entries);
    assert!(r.bit_exact, "{r:?}");
    assert!(r.bursts >= 10, "{r:?}");
    // The last heartbeat before the silence is at tick 2995; the watchdog
    // trips once more than 100 ticks (20 ms) pass without one, at tick
    // 3096, and holds until the heartbeat at tick 3300: 204 ticks.
    assert_eq!(r.watchdog_rows, 204, "{r:?}");
    assert!(
        rows.iter()
            .filter(|r| r.watchdog)
            .all(|r| r.vibration == 0.0),
        "nothing rendered while the watchdog holds"
    );

    assert_eq!((r.missing_ticks, r.unreplayed_rows), (0, 0));

    let mut unmarked = rows.clone();
    for row in &mut unmarked {
        row.watchdog = false;
    }
    let unmarked = rerender(&unmarked, &entries);
    assert!(!unmarked.bit_exact, "{unmarked:?}");
    let worst = unmarked.worst_vibration_row.unwrap();
    assert!(
        silent.contains(&u32::try_from(worst).unwrap()),
        "{unmarked:?}"
    );

    // The host's clock jumps 0.1 s ahead of the device's at 1.2 s (it
    // re-anchors a device that runs slow): the ticks are all there, so the
    // replay goes on.
    let mut jumped = rows.clone();
    for row in &mut jumped[6000..] {
        row.t_s += 0.1;
    }
    let jumped = rerender(&jumped, &entries);
    assert!(jumped.bit_exact, "{jumped:?}");
    assert_eq!((jumped.missing_ticks, jumped.unreplayed_rows), (0, 0));

    // 40 ticks (8 ms) of telemetry lost at 1.0 s, found by the tick
    // numbers and, in a stream from before they were recorded, by `t_s`.
    rows.drain(5000..5040);
    let mut untimed = rows.clone();
    for row in &mut untimed {
        row.tick = None;
    }
    for rows in [rows, untimed] {
        let lost = rerender(&rows, &entries);
        assert!(lost.bit_exact, "{lost:?}");
        assert_eq!((lost.missing_ticks, lost.unreplayed_rows), (40, 4960));
        assert!((lost.replayed_s - 0.9998).abs() < 1e-9, "{lost:?}");
    }
}

/// A device rendering on board that a new connection's `Hello` starts
/// afresh mid-stream drops its model at once, without a select, under a
/// render label the host does not know. The replay is exact up to that row
/// and stops there, rather than crossfade out of the model as a select of
/// nothing would.
#[test]
fn an_on_board_stream_of_a_device_started_afresh_re_renders_exactly_up_to_the_restart() {
    use frictionlab::friction::{ForceLimit, ModelParams};
    use frictionlab::rerender::rerender;
    use frictionlab_core::onboard::{BoardLoop, upload};
    use frictionlab_core::wire::Message;
    use on_board::{RATE_HZ, entry, tick_row};

    let model = ModelParams::default_for("karnopp").unwrap();
    let mut board = BoardLoop::<f32>::new(RATE_HZ, ForceLimit::new(8.0).unwrap());
    upload(&model, 1, |m| board.receive(&m));
    let mut rows = Vec::new();
    for k in 0..4000_u32 {
        board.receive(&Message::Heartbeat { seq: k });
        if k == 2500 {
            board.reset();
        }
        rows.push(tick_row(&mut board, k, 2.0 * std::f64::consts::PI));
    }
    let before = rows[2499].force_n;
    assert!(before.abs() > 0.1, "a force to lose: {before} N");
    assert_eq!(rows[2500].force_n, 0.0, "nothing rendered afresh");
    let r = rerender(&rows, &[entry(Some(model)), entry(None)]);
    assert!(r.bit_exact, "{r:?}");
    assert_eq!(
        (r.restarted_row, r.unreplayed_rows, r.missing_ticks),
        (Some(2500), 1500, 0),
        "{r:?}"
    );
}

/// Over a lagging link the previous trial's selects can take effect after
/// the next trial's stream has begun: here a paired trial's second model,
/// crossfading from its first, in a state the stream does not show. The
/// replay starts at the trial's own model, selected after the clear, and
/// is exact from there.
#[test]
fn an_on_board_stream_opening_with_the_previous_trials_late_select_re_renders_exactly_from_its_own_model()
 {
    use frictionlab::friction::{ForceLimit, ModelParams};
    use frictionlab::rerender::rerender;
    use frictionlab_core::onboard::{BoardLoop, upload};
    use frictionlab_core::wire::Message;
    use on_board::{RATE_HZ, entry, tick_row_as};

    let first = ModelParams::default_for("karnopp").unwrap();
    let second = ModelParams::default_for("god-object-constant").unwrap();
    let own = ModelParams::default_for("stick-slip-force").unwrap();
    let mut board = BoardLoop::<f32>::new(RATE_HZ, ForceLimit::new(8.0).unwrap());
    upload(&first, 1, |m| board.receive(&m));
    // Labels 1 to 4 are the trial's renders 0 to 3.
    let render_of = |label: u8| usize::from(label) - 1;
    let mut rows = Vec::new();
    for k in 0..6000_u32 {
        board.receive(&Message::Heartbeat { seq: k });
        match k {
            1200 => upload(&second, 2, |m| board.receive(&m)),
            1500 => board.receive(&Message::Clear { render: 3 }),
            1600 => upload(&own, 4, |m| board.receive(&m)),
            _ => {}
        }
        let row = tick_row_as(&mut board, k, 2.0 * std::f64::consts::PI, render_of);
        // The trial's stream begins at tick 1000.
        if k >= 1000 {
            rows.push(row);
        }
    }
    let entries = [
        entry(Some(first)),
        entry(Some(second)),
        entry(None),
        entry(Some(own)),
    ];
    let r = rerender(&rows, &entries);
    assert!(r.bit_exact, "{r:?}");
    assert_eq!((r.skipped, r.unreplayed_rows), (600, 0), "{r:?}");
    assert!(r.restarted_row.is_none(), "{r:?}");
    // A stream opening exactly at the late select is replayed from it, as
    // from nothing: the difference shows (the first model's state, which
    // the second crossfades from, is not in the stream); it never passes
    // unseen.
    let late = rerender(&rows[200..], &entries);
    assert_eq!(late.skipped, 0, "{late:?}");
    assert!(!late.bit_exact && late.max_force_diff_n > 0.1, "{late:?}");
}

/// A stream that renders nothing throughout (a Fitts baseline trial: its
/// condition renders no model, and the device never shows a select) is
/// compared from a crossfade after its first row on, where nothing is
/// what the replay renders: zero force. A force there (a model left on)
/// shows as a difference; before, such a stream compared no row (issue 63:
/// `rerender` exits 2 when none is compared).
#[test]
fn a_stream_that_renders_nothing_is_compared_from_a_crossfade_after_its_start() {
    use frictionlab::rerender::{Row, rerender};
    let ramp_s = frictionlab_core::render::RAMP_S;
    let row = |k: u32, force_n: f64| Row {
        t_s: 1.0 + f64::from(k) / f64::from(on_board::RATE_HZ),
        x_m: 0.001 * f64::from(k % 7),
        v_m_s: 0.0,
        force_n,
        vibration: 0.0,
        render: 0,
        selected: false,
        watchdog: false,
        tick: Some(k),
        normal_n: None,
    };
    let entries = [on_board::entry(None)];
    let n = 2000;
    // The previous trial's model fading out in the first rows.
    let rows: Vec<Row> = (0..n)
        .map(|k| row(k, if k < 100 { 0.5 } else { 0.0 }))
        .collect();
    let r = rerender(&rows, &entries);
    // The first row a crossfade after the first (250 at 5 kHz).
    let fade_rows = rows
        .iter()
        .position(|r| r.t_s - rows[0].t_s >= ramp_s)
        .unwrap();
    assert!((249..=251).contains(&fade_rows), "{fade_rows}");
    println!(
        "{} rows, {} skipped (a crossfade of {ramp_s} s), {} compared, bit_exact {}",
        r.rows, r.skipped, r.compared, r.bit_exact
    );
    assert_eq!(
        (r.skipped, r.compared, r.bit_exact),
        (fade_rows, 2000 - fade_rows, true)
    );
    // A force after the crossfade is no rendering of nothing.
    let mut bad = rows.clone();
    bad[1500].force_n = 0.25;
    let r = rerender(&bad, &entries);
    assert_eq!(
        (r.bit_exact, r.max_force_diff_n, r.worst_row),
        (false, 0.25, Some(1500))
    );
}
