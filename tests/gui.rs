//! The experimenter window and the participant's screens, driven headless
//! through egui_kittest: clicks on labels, typed text, the pointer over the
//! workspace, and the space bar. Time is the harness's stepped clock
//! (`STEP_S` per frame), so sessions run in a fraction of their real length.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    reason = "tests: a panic is a failure"
)]

mod common;

use std::path::Path;
use std::process::Command as Process;

use eframe::egui::{self, Key, accesskit::Role};
use egui_kittest::{
    Harness,
    kittest::{NodeT, Queryable},
};
use frictionlab::gui::{FrictionlabApp, Launch, to_screen};
use frictionlab::kinds::{LogLine, Registry};
use frictionlab::protocol::engine::Screen;
use frictionlab::results::read_log;
use frictionlab::session::{LiveSession, Phase};

const STEP_S: f32 = 0.05;

fn harness(
    out: &Path,
    participant: &str,
    protocol: Option<&Path>,
) -> Harness<'static, FrictionlabApp> {
    let launch = Launch {
        protocol: protocol.map(Path::to_path_buf),
        participant: participant.into(),
        out: out.to_path_buf(),
        ..Launch::default()
    };
    harness_with(launch)
}

fn harness_with(launch: Launch) -> Harness<'static, FrictionlabApp> {
    Harness::builder()
        .with_size(egui::vec2(1920.0, 1200.0))
        .with_step_dt(STEP_S)
        .build_eframe(move |_cc| FrictionlabApp::new(launch))
}

fn live<'a>(h: &'a Harness<'_, FrictionlabApp>) -> &'a LiveSession {
    h.state().live().expect("a session is open")
}

fn click(h: &mut Harness<'_, FrictionlabApp>, label: &str) {
    h.get_by_label(label).click();
    h.step();
    h.step();
}

/// Replaces the text of the field labelled `label` with `text`.
fn type_into(h: &mut Harness<'_, FrictionlabApp>, label: &str, text: &str) {
    type_into_role(h, Role::TextInput, label, text);
}

fn type_into_role(h: &mut Harness<'_, FrictionlabApp>, role: Role, label: &str, text: &str) {
    h.get_by_role_and_label(role, label).click();
    h.step();
    let old = h
        .get_by_role_and_label(role, label)
        .value()
        .unwrap_or_default();
    for _ in 0..=old.chars().count() {
        h.key_press(Key::End);
        h.key_press(Key::Backspace);
    }
    h.step();
    h.get_by_role_and_label(role, label).type_text(text);
    h.step();
}

fn choose_protocol(h: &mut Harness<'_, FrictionlabApp>, name: &str) {
    click(h, name);
}

fn start(h: &mut Harness<'_, FrictionlabApp>) {
    click(h, "Start new session");
    // A new window is sized in its first frame and shown in the next.
    h.step();
    assert!(h.state().error().is_none(), "{:?}", h.state().error());
    assert!(h.state().live().is_some(), "the session started");
}

/// One participant move for the current screen; returns false when the
/// session is over.
fn participant_step(h: &mut Harness<'_, FrictionlabApp>, magnitude: &str) -> bool {
    let l = live(h);
    if l.phase() != Phase::Running {
        return false;
    }
    if l.view().prompt.is_some() {
        click(h, "Done, continue");
        return true;
    }
    match l.view().screen.clone() {
        Some(Screen::Instructions(_) | Screen::Reference { .. } | Screen::Break { .. }) => {
            click(h, "Continue");
        }
        Some(Screen::Explore { .. }) => {
            type_into(h, "Your number", magnitude);
            click(h, "Submit");
        }
        Some(Screen::Paired { active, forced, .. }) => {
            if active == 0 {
                click(h, "Feel stimulus 2");
                assert!(matches!(
                    live(h).view().screen,
                    Some(Screen::Paired { active: 1, .. })
                ));
            }
            // A forced choice (discrimination) asks its own question, with
            // no "no difference".
            click(
                h,
                if forced.is_some() {
                    "Stimulus 2"
                } else {
                    "Stimulus 2 is nearer"
                },
            );
        }
        Some(Screen::Fitts { lit_m, .. }) => fitts_tap(h, lit_m),
        None => h.step(),
    }
    true
}

/// Moves the pointer until the device's cursor sits on the lit target, then
/// clicks. The pointer moves past the target as far as the
/// friction holds the device back (as a person's hand would).
fn fitts_tap(h: &mut Harness<'_, FrictionlabApp>, lit_m: f64) {
    let mut aim = lit_m;
    for _ in 0..80 {
        let rect = h.state().workspace().expect("the workspace is drawn");
        h.hover_at(egui::pos2(to_screen(rect, aim), rect.center().y));
        h.step();
        let l = live(h);
        let x = l.sample().x_m;
        let still = l.sample().v_m_s.abs() < 2e-3;
        if (x - lit_m).abs() < 4e-4 && still {
            break;
        }
        if still {
            aim = (aim + 0.5 * (lit_m - x)).clamp(-0.02, 0.02);
        }
    }
    let l = live(h);
    eprintln!(
        "tap at {:.4} (target {lit_m:.4}, aim {aim:.4}) t {:.2}",
        l.sample().x_m,
        l.now_s()
    );
    h.key_press(Key::Space);
    h.step();
}

fn run_to_end(h: &mut Harness<'_, FrictionlabApp>, magnitude: &str, max_moves: usize) {
    for _ in 0..max_moves {
        if !participant_step(h, magnitude) {
            return;
        }
    }
    let l = live(h);
    panic!(
        "the session did not end in {max_moves} moves: {:?} at trial {:?}",
        l.view(),
        l.progress()
    );
}

fn csv_rows(path: &Path) -> Vec<Vec<String>> {
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .map(|l| l.split(',').map(str::to_owned).collect())
        .collect()
}

fn column(rows: &[Vec<String>], name: &str) -> Vec<String> {
    let i = rows[0].iter().position(|c| c == name).unwrap();
    rows[1..].iter().map(|r| r[i].clone()).collect()
}

#[test]
fn a_quick_magnitude_session_runs_by_clicks_and_typed_numbers_and_ends_with_its_data_file() {
    let dir = tempfile::tempdir().unwrap();
    let mut h = harness(dir.path(), "", None);
    choose_protocol(&mut h, "magnitude-quick.json");
    // The id is checked as the command line checks it.
    type_into(&mut h, "Participant id", "p 01!");
    assert!(
        h.query_all_by_label_contains("use letters, digits")
            .next()
            .is_some()
    );
    assert!(
        h.get_by_label("Start new session")
            .accesskit_node()
            .is_disabled()
    );
    type_into(&mut h, "Participant id", "p01");
    type_into(&mut h, "Output folder", &dir.path().display().to_string());
    h.get_by_label("A new session will be session 1.");
    start(&mut h);
    // The first trial waits out its exploration (2 s) before the answer.
    click(&mut h, "Continue");
    assert!(matches!(
        live(&h).view().screen,
        Some(Screen::Explore { .. })
    ));
    for _ in 0..50 {
        h.step();
    }
    assert!(live(&h).view().question.is_some(), "asked after exploring");
    run_to_end(&mut h, "2.5", 40);

    let l = live(&h);
    assert_eq!(l.phase(), Phase::Finished);
    let rows = csv_rows(l.csv());
    assert_eq!(rows.len(), 1 + 6, "header and 6 trials");
    assert!(column(&rows, "status").iter().all(|s| s == "completed"));
    assert!(column(&rows, "magnitude").iter().all(|m| m == "2.5"));
    let read = read_log::<Registry>(l.log_path()).unwrap();
    assert!(read.ended);
    assert_eq!(read.header.responder, "gui");
    assert_eq!(read.header.device, "sim");
    h.get_by_label("Thank you! The session is complete.");
}

#[test]
fn bad_magnitude_entries_are_refused_with_a_message_and_never_logged() {
    let dir = tempfile::tempdir().unwrap();
    let mut h = harness(dir.path(), "p02", None);
    choose_protocol(&mut h, "magnitude-quick.json");
    start(&mut h);
    click(&mut h, "Continue");
    for (text, message) in [
        ("", "please type a number"),
        ("abc", "'abc' is not a number"),
        ("1,5", "'1,5' is not a number"),
        ("0", "please type a number greater than zero"),
        ("-3", "please type a number greater than zero"),
        ("inf", "please type a finite number"),
        ("NaN", "please type a finite number"),
        ("1e999", "please type a finite number"),
    ] {
        type_into(&mut h, "Your number", text);
        click(&mut h, "Submit");
        assert_eq!(
            live(&h).view().refused.as_deref(),
            Some(message),
            "entry {text:?}"
        );
        h.get_by_label(message);
        let read = read_log::<Registry>(live(&h).log_path()).unwrap();
        assert!(read.trials.is_empty(), "{text:?} was logged");
    }
    type_into(&mut h, "Your number", " 7 ");
    click(&mut h, "Submit");
    let read = read_log::<Registry>(live(&h).log_path()).unwrap();
    assert_eq!(read.trials.len(), 1);
    assert!(live(&h).view().refused.is_none());
}

#[test]
fn a_paired_comparison_session_switches_stimuli_takes_the_answer_and_finishes() {
    let dir = tempfile::tempdir().unwrap();
    let mut h = harness(dir.path(), "p03", None);
    choose_protocol(&mut h, "paired-quick.json");
    start(&mut h);
    run_to_end(&mut h, "1", 20);
    let l = live(&h);
    assert_eq!(l.phase(), Phase::Finished);
    let read = read_log::<Registry>(l.log_path()).unwrap();
    assert_eq!(read.trials.len(), 1);
    let rows = csv_rows(l.csv());
    assert_eq!(column(&rows, "choice"), ["second"]);
}

/// Issue 17: a discrimination session by clicks: the two stimuli, the
/// protocol's question answered "stimulus 2" on every trial, to the end;
/// every track stops after its 8 trials, and the experimenter's window
/// has the tracks to plot.
#[test]
fn a_discrimination_session_is_answered_by_clicks_to_the_end_issue_17() {
    let dir = tempfile::tempdir().unwrap();
    let mut h = harness(dir.path(), "p17", None);
    choose_protocol(&mut h, "discrimination-quick.json");
    start(&mut h);
    run_to_end(&mut h, "1", 200);
    let l = live(&h);
    assert_eq!(l.phase(), Phase::Finished);
    let rows = csv_rows(l.csv());
    assert_eq!(column(&rows, "choice"), vec!["second"; 24]);
    let tracks = frictionlab::kinds::discrimination::tracks(l.engine().history());
    assert_eq!(
        tracks.iter().map(|t| t.answers.len()).collect::<Vec<_>>(),
        [8, 8, 8]
    );
    // Choosing the second is right when the comparison came second.
    let second: Vec<String> = column(&rows, "second");
    let correct: Vec<String> = column(&rows, "correct");
    for (s, c) in second.iter().zip(&correct) {
        assert_eq!(c, if s == "comparison" { "1" } else { "0" });
    }
}

#[test]
fn a_fitts_session_follows_the_mouse_takes_mouse_and_space_bar_clicks_and_finishes() {
    let dir = tempfile::tempdir().unwrap();
    let mut h = harness(dir.path(), "p04", None);
    choose_protocol(&mut h, "fitts-quick.json");
    start(&mut h);
    // The cursor follows the pointer over the workspace.
    click(&mut h, "Continue");
    let rect = h.state().workspace().unwrap();
    h.hover_at(egui::pos2(to_screen(rect, 0.005), rect.center().y));
    for _ in 0..20 {
        h.step();
    }
    let x = live(&h).sample().x_m;
    assert!((x - 0.005).abs() < 1e-3, "device at {x} m, pointer at 5 mm");
    run_to_end(&mut h, "1", 200);
    let l = live(&h);
    assert_eq!(l.phase(), Phase::Finished);
    let rows = csv_rows(l.csv());
    assert_eq!(rows.len(), 1 + 4);
    let status = column(&rows, "status");
    let taps = column(&rows, "taps");
    let conditions = column(&rows, "condition");
    for ((c, s), t) in conditions.iter().zip(&status).zip(&taps) {
        assert_eq!(s, "completed", "{c}: {t} taps");
        assert_eq!(t, "4", "{c}");
    }
    // The `real` condition's prompt was answered by the experimenter.
    assert!(conditions.iter().any(|c| c == "real"));
}

#[test]
fn abort_then_resume_continues_where_the_session_stopped() {
    let dir = tempfile::tempdir().unwrap();
    let mut h = harness(dir.path(), "p05", None);
    choose_protocol(&mut h, "magnitude-quick.json");
    start(&mut h);
    click(&mut h, "Continue");
    for _ in 0..2 {
        type_into(&mut h, "Your number", "3");
        click(&mut h, "Submit");
        if matches!(live(&h).view().screen, Some(Screen::Break { .. })) {
            click(&mut h, "Continue");
        }
    }
    // A note, then a pause mid-trial: the trial is logged as aborted and
    // presented again on resume.
    type_into_role(
        &mut h,
        Role::MultilineTextInput,
        "Note for the session log",
        "participant sneezed",
    );
    click(&mut h, "Save note");
    click(&mut h, "Pause");
    assert_eq!(live(&h).phase(), Phase::Paused);
    click(&mut h, "Resume");
    assert!(matches!(
        live(&h).view().screen,
        Some(Screen::Explore { .. })
    ));
    click(&mut h, "Abort session");
    assert_eq!(live(&h).phase(), Phase::Aborted);
    let log = live(&h).log_path().to_owned();
    let read = read_log::<Registry>(&log).unwrap();
    assert!(!read.ended);
    assert_eq!(read.next_trial(), 2);
    let aborted: Vec<_> = read.trials.iter().filter(|r| r.requeued).collect();
    assert_eq!(aborted.len(), 2, "the paused and the aborted presentation");
    assert!(aborted.iter().all(|r| r.trial == 2));
    let text = std::fs::read_to_string(&log).unwrap();
    assert!(text.contains("participant sneezed"));

    click(&mut h, "Close session");
    h.get_by_label("Session 1 is unfinished: 2 of 6 trials done.");
    click(&mut h, "Resume session 1");
    assert_eq!(live(&h).session(), 1);
    assert_eq!(live(&h).log_path(), log);
    run_to_end(&mut h, "4", 40);
    let read = read_log::<Registry>(&log).unwrap();
    assert!(read.ended);
    let completed: Vec<usize> = read
        .trials
        .iter()
        .filter(|r| !r.requeued)
        .map(|r| r.trial)
        .collect();
    assert_eq!(completed, [0, 1, 2, 3, 4, 5], "each trial once, in order");
    let lines = std::fs::read_to_string(&log).unwrap();
    let resumed = lines
        .lines()
        .filter_map(|l| serde_json::from_str::<LogLine>(l).ok())
        .filter(|l| matches!(l, LogLine::Resumed { .. }))
        .count();
    assert_eq!(resumed, 1);
    // Next time the window offers a new session, 2.
    click(&mut h, "Close session");
    h.get_by_label("A new session will be session 2.");
}

#[test]
fn a_broken_protocol_file_shows_its_errors_with_json_paths() {
    let dir = tempfile::tempdir().unwrap();
    let bad = dir.path().join("bad.json");
    let good = include_str!("../protocols/magnitude-quick.json");
    std::fs::write(
        &bad,
        good.replace("\"exploration_s\": 2.0", "\"exploration_s\": -1"),
    )
    .unwrap();
    let mut h = harness(dir.path(), "p06", None);
    type_into(&mut h, "Protocol file", &bad.display().to_string());
    click(&mut h, "Load file");
    let shown = h
        .get_by_label_contains("design.exploration_s")
        .value()
        .unwrap_or_default();
    assert_eq!(
        shown,
        format!(
            "{}: design.exploration_s: must be greater than 0, got -1",
            bad.display()
        )
    );
    assert!(
        h.get_by_label("Start new session")
            .accesskit_node()
            .is_disabled()
    );
}

#[test]
fn without_a_display_the_window_says_so_in_one_line_and_exits_2() {
    for args in [&[][..], &["gui"][..]] {
        let out = Process::new(env!("CARGO_BIN_EXE_frictionlab"))
            .args(args)
            .env_remove("DISPLAY")
            .env_remove("WAYLAND_DISPLAY")
            .output()
            .unwrap();
        assert_eq!(out.status.code(), Some(2), "{args:?}");
        let err = String::from_utf8(out.stderr).unwrap();
        assert_eq!(err.lines().count(), 1, "{err}");
        assert!(
            err.starts_with("error: gui: cannot open the window: no display"),
            "{err}"
        );
        assert!(err.contains("frictionlab simulate"), "{err}");
    }
}

/// Issue 31: a session open in another process cannot be resumed (or a new
/// one started) from the window: both buttons are disabled, with the
/// command line's reason shown. Once the other process lets go, Resume
/// works again (the window reads the folder again each second).
#[test]
fn a_session_open_in_another_process_disables_resume_with_the_reason_issue_31() {
    let dir = tempfile::tempdir().unwrap();
    let o = Process::new(env!("CARGO_BIN_EXE_frictionlab"))
        .args([
            "run",
            &format!(
                "{}/protocols/magnitude-quick.json",
                env!("CARGO_MANIFEST_DIR")
            ),
        ])
        .args([
            "--participant",
            "p06",
            "--responder",
            "sim",
            "--pace",
            "1000",
        ])
        .arg("--out")
        .arg(dir.path())
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    // Unfinished: the `end` line cut off.
    let log = dir
        .path()
        .join("logs/study-magnitudequick_subject-p06_session-1_log.jsonl");
    let text = std::fs::read_to_string(&log).unwrap();
    let kept: Vec<&str> = text
        .lines()
        .filter(|l| !l.contains("\"type\":\"end\""))
        .collect();
    std::fs::write(&log, kept.join("\n") + "\n").unwrap();
    // Another process's hold, as the OS sees it (this one's lock).
    let held = std::fs::OpenOptions::new().append(true).open(&log).unwrap();
    held.lock().unwrap();
    let mut h = harness(dir.path(), "p06", None);
    choose_protocol(&mut h, "magnitude-quick.json");
    h.get_by_label("Session 1 is unfinished: 6 of 6 trials done.");
    let reason = format!(
        "error: {}: session 1 of 'p06' is open in another process (pid {}); wait for it to end, or resume it there",
        log.display(),
        std::process::id()
    );
    h.get_by_label(&reason);
    for button in ["Resume session 1", "Start new session"] {
        assert!(
            h.get_by_label(button).accesskit_node().is_disabled(),
            "{button} is disabled"
        );
    }
    click(&mut h, "Resume session 1");
    assert!(h.state().live().is_none(), "nothing opened");
    drop(held);
    for _ in 0..30 {
        h.step();
    }
    assert!(h.query_by_label(&reason).is_none(), "the reason is gone");
    assert!(
        !h.get_by_label("Resume session 1")
            .accesskit_node()
            .is_disabled()
    );
}

/// The setup's "Publish on LSL" box (issue 34): with no liblsl where
/// `--lsl-lib` points, Start says so and opens nothing; with pylsl's
/// liblsl (`--lsl` loaded it: the box starts checked), the session's
/// records carry their LSL times and the log its `lsl` line.
#[test]
fn the_lsl_box_publishes_the_session_or_says_why_it_cannot_issue_34() {
    let dir = tempfile::tempdir().unwrap();
    let launch = Launch {
        participant: "p01".into(),
        out: dir.path().to_path_buf(),
        lsl_lib: Some(dir.path().join("no-liblsl.so")),
        ..Launch::default()
    };
    let mut h = harness_with(launch);
    choose_protocol(&mut h, "magnitude-quick.json");
    click(
        &mut h,
        "Publish on LSL (markers and device stream, for LabRecorder)",
    );
    click(&mut h, "Start new session");
    let error = h.state().error().unwrap_or_default().to_owned();
    assert!(error.contains("liblsl not found"), "{error}");
    assert!(error.contains("no-liblsl.so"), "{error}");
    assert!(h.state().live().is_none());
    assert!(!dir.path().join("logs").exists(), "nothing written");

    let Some((_, lib)) = common::need_pylsl() else {
        return;
    };
    let launch = Launch {
        participant: "p02".into(),
        out: dir.path().to_path_buf(),
        lsl: Some(frictionlab::lsl::load(Some(&lib)).unwrap()),
        ..Launch::default()
    };
    let mut h = harness_with(launch);
    choose_protocol(&mut h, "magnitude-quick.json");
    start(&mut h);
    click(&mut h, "Continue");
    run_to_end(&mut h, "2.5", 40);
    let l = live(&h);
    assert_eq!(l.phase(), Phase::Finished);
    let read = read_log::<Registry>(l.log_path()).unwrap();
    assert_eq!(read.trials.len(), 6);
    for pair in read.trials.windows(2) {
        let (a, b) = (&pair[0], &pair[1]);
        assert!(a.lsl_start_s.unwrap() < a.lsl_end_s.unwrap());
        assert!(a.lsl_end_s.unwrap() <= b.lsl_start_s.unwrap());
    }
    let text = std::fs::read_to_string(l.log_path()).unwrap();
    assert!(text.contains(r#""type":"lsl""#), "{text}");
}
