//! The experimenter window and the participant's screens, driven headless
//! through egui_kittest: clicks on labels, typed text, the pointer over the
//! workspace, and the space bar. Time is the harness's stepped clock
//! (`STEP_S` per frame), so sessions run in a fraction of their real length.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    reason = "tests: a panic is a failure"
)]

use crate::common;

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
use frictionlab::session::{LiveSession, SessionState};

use common::window::click;

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
    if l.state() != SessionState::Running {
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
        Some(Screen::Targets { lit_m, .. }) => fitts_tap(h, lit_m),
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
    assert_eq!(l.state(), SessionState::Finished);
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
    assert_eq!(l.state(), SessionState::Finished);
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
    assert_eq!(l.state(), SessionState::Finished);
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
    assert_eq!(l.state(), SessionState::Finished);
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
    assert_eq!(live(&h).state(), SessionState::Paused);
    click(&mut h, "Resume");
    assert!(matches!(
        live(&h).view().screen,
        Some(Screen::Explore { .. })
    ));
    click(&mut h, "Abort session");
    assert_eq!(live(&h).state(), SessionState::Aborted);
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
    cut(&log, 0);
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
    assert_eq!(l.state(), SessionState::Finished);
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

/// The streams of a session folder, in trial order.
fn streams(out: &Path) -> Vec<std::path::PathBuf> {
    let mut files: Vec<_> = std::fs::read_dir(out.join("streams"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    files.sort_by_key(|p| {
        let name = p.file_name().unwrap().to_string_lossy().into_owned();
        let trial = name.split("_trial-").nth(1).unwrap();
        trial.split('_').next().unwrap().parse::<u32>().unwrap()
    });
    files
}

#[test]
fn dragging_the_handle_moves_the_hand_and_the_stream_follows_the_drag_issue_37() {
    let dir = tempfile::tempdir().unwrap();
    let mut h = harness(dir.path(), "p40", None);
    choose_protocol(&mut h, "magnitude-quick.json");
    start(&mut h);
    click(&mut h, "Continue");
    assert!(matches!(
        live(&h).view().screen,
        Some(Screen::Explore { .. })
    ));
    // Press on the handle (the device's cursor, at rest), then drag it to
    // +12 mm in steps, the button held all the way.
    let rect = h.state().workspace().unwrap();
    let x0 = live(&h).sample().x_m;
    let y = rect.center().y;
    h.drag_at(egui::pos2(to_screen(rect, x0), y));
    h.step();
    let mut followed = Vec::new();
    for k in 1..=12 {
        let aim = x0 + f64::from(k) * 1e-3;
        h.hover_at(egui::pos2(to_screen(rect, aim), y));
        for _ in 0..4 {
            h.step();
        }
        followed.push((aim, live(&h).sample().x_m));
    }
    // Held there, the device settles under the pointer.
    for _ in 0..10 {
        h.step();
    }
    let end = live(&h).sample().x_m;
    h.drop_at(egui::pos2(to_screen(rect, x0 + 0.012), y));
    h.step();
    assert!(
        (end - (x0 + 0.012)).abs() < 1e-3,
        "dragged to {} mm, the device is at {} mm ({followed:?})",
        (x0 + 0.012) * 1e3,
        end * 1e3
    );
    // The trial's stream has the position following the drag: rising
    // through the 12 mm, ending near it.
    for _ in 0..20 {
        h.step();
    }
    type_into(&mut h, "Your number", "3");
    click(&mut h, "Submit");
    let first = &streams(dir.path())[0];
    let rows = csv_rows(first);
    let x: Vec<f64> = column(&rows, "x_m")
        .iter()
        .map(|v| v.parse().unwrap())
        .collect();
    let last = *x.last().unwrap();
    assert!(
        (last - (x0 + 0.012)).abs() < 1e-3,
        "stream ends at {last} m"
    );
    let crossed = [0.003, 0.006, 0.009]
        .iter()
        .all(|d| x.iter().any(|&v| v > x0 + d));
    assert!(crossed, "the stream rises through the drag");
}

#[test]
fn space_or_enter_passes_an_instruction_screen_and_the_screen_says_so_issue_37() {
    for key in [Key::Space, Key::Enter] {
        let dir = tempfile::tempdir().unwrap();
        let mut h = harness(dir.path(), "p41", None);
        choose_protocol(&mut h, "magnitude-quick.json");
        start(&mut h);
        assert!(matches!(
            live(&h).view().screen,
            Some(Screen::Instructions(_))
        ));
        h.get_by_label("or press Space or Enter");
        h.key_press(key);
        h.step();
        h.step();
        assert!(
            matches!(live(&h).view().screen, Some(Screen::Explore { .. })),
            "{key:?}: {:?}",
            live(&h).view().screen
        );
    }
}

/// Every field of every CSV under `dir`, the longest's length and text.
fn longest_field(dir: &Path) -> (usize, String) {
    let mut longest = (0, String::new());
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                stack.push(p);
            } else if p.extension().is_some_and(|x| x == "csv") {
                for row in csv_rows(&p) {
                    for f in row {
                        if f.len() > longest.0 {
                            longest = (f.len(), format!("{}: {f}", p.display()));
                        }
                    }
                }
            }
        }
    }
    longest
}

#[test]
fn a_still_hand_writes_a_stream_the_size_of_a_moving_one_issue_37() {
    // magnitude-quick with 10 s of exploration.
    let root = env!("CARGO_MANIFEST_DIR");
    let text = std::fs::read_to_string(format!("{root}/protocols/magnitude-quick.json")).unwrap();
    let mut p: serde_json::Value = serde_json::from_str(&text).unwrap();
    p.as_object_mut().unwrap().remove("$schema");
    p["design"]["exploration_s"] = serde_json::json!(10.0);
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("still.json");
    std::fs::write(&file, p.to_string()).unwrap();
    let out = dir.path().join("results");
    let mut h = harness(&out, "p42", Some(&file));
    start(&mut h);
    click(&mut h, "Continue");
    let rect = h.state().workspace().unwrap();
    let y = rect.center().y;
    // Trial 1: the pointer held still over the strip, the hand at rest; trial 2:
    // the hand moving back and forth over 20 mm. 10.5 s each.
    for trial in 0..2 {
        for i in 0..210 {
            if trial == 0 {
                h.hover_at(egui::pos2(to_screen(rect, 0.005), y));
            } else {
                let phase = f64::from(i) * 0.05 * std::f64::consts::TAU;
                h.hover_at(egui::pos2(to_screen(rect, 0.01 * phase.sin()), y));
            }
            h.step();
        }
        type_into(&mut h, "Your number", "2");
        click(&mut h, "Submit");
        if matches!(live(&h).view().screen, Some(Screen::Break { .. })) {
            click(&mut h, "Continue");
        }
    }
    let files = streams(&out);
    let (still, moving) = (
        std::fs::metadata(&files[0]).unwrap().len(),
        std::fs::metadata(&files[1]).unwrap().len(),
    );
    let rows = csv_rows(&files[0]).len();
    eprintln!("still hand: {still} bytes, moving: {moving} bytes, {rows} rows");
    // A still hand's numbers are shorter ("0" for a settled velocity), so
    // its stream is smaller, never larger: before issue 37 it was 7 times
    // larger (subnormal velocities written as 300-digit decimals).
    let ratio = still as f64 / moving as f64;
    assert!(
        ratio <= 1.2,
        "still {still} B vs moving {moving} B: {ratio:.3}"
    );
    assert!(
        still / (rows as u64) < 50,
        "{} bytes a row at rest",
        still / (rows as u64)
    );
    let v = column(&csv_rows(&files[0]), "v_m_s");
    assert!(
        v.iter().rev().take(1000).all(|x| x == "0"),
        "a still hand's velocity settles at 0"
    );
    for f in &files {
        let rows = csv_rows(f);
        for name in ["x_m", "v_m_s", "force_n", "vibration"] {
            let subnormal = column(&rows, name)
                .iter()
                .filter(|x| x.parse::<f64>().unwrap().is_subnormal())
                .count();
            assert_eq!(subnormal, 0, "{}: {name}", f.display());
        }
    }
    let (len, field) = longest_field(&out);
    assert!(len <= 25, "{len} characters: {field}");
}

/// Xvfb on a display of its own, or `None` (with a notice) where Xvfb,
/// xdotool or zenity (the desktop's file chooser here) is missing; under
/// CI they must be there (.ci/run installs them). The guard keeps the
/// tests with a real window one at a time.
fn xvfb() -> Option<(
    std::process::Child,
    String,
    std::sync::MutexGuard<'static, ()>,
)> {
    // One real window at a time: two, with their builds and sessions,
    // starve each other's first frames on a 2-core machine.
    static ONE: std::sync::Mutex<()> = std::sync::Mutex::new(());
    let held = ONE
        .lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner);
    let have = |tool: &str| {
        Process::new("sh")
            .args(["-c", &format!("command -v {tool}")])
            .output()
            .is_ok_and(|o| o.status.success())
    };
    let found = have("Xvfb") && have("xdotool") && have("zenity");
    assert!(
        found || std::env::var_os("CI").is_none(),
        "Xvfb, xdotool and zenity are not installed: .ci/run installs them"
    );
    if !found {
        eprintln!("skipped: Xvfb, xdotool or zenity is not installed (.ci/run installs them)");
        return None;
    }
    // -displayfd: Xvfb picks a free display and writes its number.
    let mut child = Process::new("Xvfb")
        .args(["-displayfd", "1", "-screen", "0", "1920x1080x24"])
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let mut line = String::new();
    std::io::BufRead::read_line(
        &mut std::io::BufReader::new(child.stdout.take().unwrap()),
        &mut line,
    )
    .unwrap();
    Some((child, format!(":{}", line.trim()), held))
}

/// `xdotool args` on X display `display`.
fn xdotool(display: &str, args: &[&str]) -> std::process::Output {
    Process::new("xdotool")
        .args(args)
        .env("DISPLAY", display)
        .output()
        .unwrap()
}

/// Waits up to `s` seconds for `ok`.
fn wait_for(s: f64, mut ok: impl FnMut() -> bool) -> bool {
    let end = std::time::Instant::now() + std::time::Duration::from_secs_f64(s);
    while std::time::Instant::now() < end {
        if ok() {
            return true;
        }
        std::thread::sleep(std::time::Duration::from_millis(100));
    }
    ok()
}

#[test]
fn gui_start_opens_straight_into_a_session_whose_trial_is_logged_issue_37() {
    let Some((mut x, display, _one)) = xvfb() else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("results");
    let root = env!("CARGO_MANIFEST_DIR");
    let xdotool = |args: &[&str]| xdotool(&display, args);
    let mut gui = Process::new(env!("CARGO_BIN_EXE_frictionlab"))
        .args(["gui", "--start", "--protocol"])
        .arg(format!("{root}/protocols/magnitude-quick.json"))
        .args(["--participant", "p43", "--out"])
        .arg(&out)
        .env("DISPLAY", &display)
        .env_remove("WAYLAND_DISPLAY")
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    // The session is open (its log exists) and the participant's window is
    // up, with no click on the setup screen.
    let participant_window = || {
        let o = xdotool(&["search", "--name", "frictionlab: participant"]);
        String::from_utf8_lossy(&o.stdout)
            .lines()
            .next()
            .map(str::to_owned)
    };
    let opened = wait_for(30.0, || {
        out.join("logs").is_dir() && participant_window().is_some()
    });
    let window = participant_window();
    let finish = |gui: &mut std::process::Child, x: &mut std::process::Child| {
        let _ = Process::new("kill").arg(gui.id().to_string()).status();
        let _ = gui.wait();
        let _ = x.kill();
        let _ = x.wait();
    };
    if !opened {
        finish(&mut gui, &mut x);
        let mut err = String::new();
        let _ = std::io::Read::read_to_string(&mut gui.stderr.take().unwrap(), &mut err);
        panic!("the session did not open: {err}");
    }
    let window = window.unwrap();
    // Space passes the instructions; after the 2 s exploration the number
    // entry has the keyboard: type 3, Enter.
    std::thread::sleep(std::time::Duration::from_millis(1500));
    xdotool(&["windowfocus", "--sync", &window]);
    xdotool(&["key", "space"]);
    std::thread::sleep(std::time::Duration::from_secs(3));
    xdotool(&["windowfocus", "--sync", &window]);
    xdotool(&["type", "--delay", "50", "3"]);
    xdotool(&["key", "Return"]);
    let data = || {
        common::session_logs(&out).first().map(|log| {
            let csv = log
                .to_string_lossy()
                .replace("/logs/", "/data/")
                .replace("_log.jsonl", "_data.csv");
            std::fs::read_to_string(csv).unwrap_or_default()
        })
    };
    let logged = wait_for(15.0, || data().is_some_and(|d| d.lines().count() >= 2));
    finish(&mut gui, &mut x);
    assert!(logged, "no trial logged: {:?}", data());
    let text = data().unwrap();
    let rows: Vec<Vec<String>> = text
        .lines()
        .map(|l| l.split(',').map(str::to_owned).collect())
        .collect();
    assert_eq!(column(&rows, "status")[0], "completed");
    assert_eq!(column(&rows, "magnitude")[0], "3");
}

/// Runs `protocol` (a shipped one) for `participant` with the simulated
/// participant, to the end, into `out`.
fn run_to_completion(out: &Path, protocol: &str, participant: &str) -> std::path::PathBuf {
    let o = Process::new(env!("CARGO_BIN_EXE_frictionlab"))
        .arg("run")
        .arg(format!(
            "{}/protocols/{protocol}",
            env!("CARGO_MANIFEST_DIR")
        ))
        .args([
            "--participant",
            participant,
            "--responder",
            "sim",
            "--pace",
            "1000",
            "--seed",
            "4",
        ])
        .arg("--out")
        .arg(out)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    common::session_logs(out)
        .into_iter()
        .find(|l| {
            l.to_string_lossy()
                .contains(&format!("_subject-{participant}_"))
        })
        .unwrap()
}

/// Cuts a log's `end` line and its last `n` trial lines: an unfinished
/// session.
fn cut(log: &Path, n: usize) {
    let text = std::fs::read_to_string(log).unwrap();
    let mut kept: Vec<&str> = text
        .lines()
        .filter(|l| !l.contains("\"type\":\"end\""))
        .collect();
    for _ in 0..n {
        let last = kept
            .iter()
            .rposition(|l| l.contains("\"type\":\"trial\""))
            .unwrap();
        kept.remove(last);
    }
    std::fs::write(log, kept.join("\n") + "\n").unwrap();
}

#[test]
fn the_results_panel_shows_complete_unfinished_and_open_sessions_and_resumes_issue_37() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path();
    run_to_completion(out, "magnitude-quick.json", "p01");
    let unfinished = run_to_completion(out, "magnitude-quick.json", "p02");
    cut(&unfinished, 1);
    let open = run_to_completion(out, "paired-quick.json", "p03");
    cut(&open, 0);
    // Another process's hold, as the OS sees it (this one's lock).
    let held = std::fs::OpenOptions::new()
        .append(true)
        .open(&open)
        .unwrap();
    held.lock().unwrap();
    let mut h = harness(out, "", None);
    click(&mut h, "Results");
    h.get_by_label("complete");
    h.get_by_label("unfinished");
    h.get_by_label(&format!(
        "open in another process (pid {})",
        std::process::id()
    ));
    h.get_by_label("5 of 6");
    assert_eq!(h.query_all_by_label("6 of 6").count(), 1, "p01 complete");
    // Resume only where it applies: the unfinished session, not the one
    // open elsewhere, nor the complete one.
    let resumes: Vec<String> = h
        .query_all_by_role(Role::Button)
        .filter_map(|n| n.accesskit_node().label())
        .filter(|l| l.starts_with("Resume"))
        .collect();
    assert_eq!(
        resumes,
        vec!["Resume p02 session 1 of magnitude-quick".to_owned()]
    );
    drop(held);
    click(&mut h, "Resume p02 session 1 of magnitude-quick");
    assert!(h.state().error().is_none(), "{:?}", h.state().error());
    let l = live(&h);
    assert_eq!(l.participant(), "p02");
    assert_eq!(l.session(), 1);
    assert_eq!(l.completed(), 5, "the 5 trials logged");
    assert_eq!(l.progress().trial, 6, "resumed at the sixth");
}

#[test]
fn analyze_from_the_window_writes_the_summary_the_command_line_writes_issue_37() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("results");
    run_to_completion(&out, "magnitude-quick.json", "p01");
    run_to_completion(&out, "magnitude-quick.json", "p02");
    let mut h = harness(&out, "", None);
    common::window::analyze_in_results_tab(&mut h);
    h.get_by_label("magnitude_estimation");
    let window = std::fs::read(out.join("report/summary.json")).unwrap();
    let cli = dir.path().join("cli");
    let o = Process::new(env!("CARGO_BIN_EXE_frictionlab"))
        .arg("analyze")
        .arg(&out)
        .arg("--out")
        .arg(&cli)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let line = std::fs::read(cli.join("summary.json")).unwrap();
    assert!(
        window == line,
        "summary.json differs between the window and the command line"
    );
    assert!(out.join("report/report.html").is_file());
}

/// Opens the builder tab.
fn builder(h: &mut Harness<'_, FrictionlabApp>) {
    click(h, "Build a protocol");
}

/// `frictionlab validate file`: its exit status and its output.
fn validate(file: &Path) -> (bool, String) {
    let o = Process::new(env!("CARGO_BIN_EXE_frictionlab"))
        .args(["validate", file.to_str().unwrap()])
        .output()
        .unwrap();
    let text =
        String::from_utf8_lossy(&o.stdout).into_owned() + &String::from_utf8_lossy(&o.stderr);
    (o.status.success(), text)
}

#[test]
fn a_protocol_built_new_of_each_kind_is_saved_valid_and_simulates_issue_37() {
    use frictionlab::protocol::kind::Kinds;
    let dir = tempfile::tempdir().unwrap();
    let mut h = harness(&dir.path().join("results"), "p50", None);
    builder(&mut h);
    for kind in Registry::KINDS {
        click(&mut h, kind.name);
        h.get_by_label(&format!("Editing: new {}", kind.name));
        let file = dir.path().join(format!("built-{}.json", kind.name));
        type_into(&mut h, "Protocol file", file.to_str().unwrap());
        click(&mut h, "Save");
        h.get_by_label(&format!("saved {}", file.display()));
        let (ok, said) = validate(&file);
        assert!(ok, "{}: {said}", kind.name);
        assert!(
            said.starts_with(&format!("ok: {}: {} ", file.display(), kind.name)),
            "{said}"
        );
        let out = dir.path().join(format!("sim-{}", kind.name));
        let o = Process::new(env!("CARGO_BIN_EXE_frictionlab"))
            .args([
                "simulate",
                file.to_str().unwrap(),
                "--participants",
                "1",
                "--seed",
                "5",
            ])
            .args(["--out", out.to_str().unwrap()])
            .output()
            .unwrap();
        assert!(
            o.status.success(),
            "{}: {}",
            kind.name,
            String::from_utf8_lossy(&o.stderr)
        );
        let data: Vec<_> = std::fs::read_dir(out.join("data")).unwrap().collect();
        assert!(!data.is_empty(), "{}: simulate wrote no data", kind.name);
        // Saved again, the same protocol is the same text.
        let first = std::fs::read_to_string(&file).unwrap();
        click(&mut h, "Save");
        assert_eq!(std::fs::read_to_string(&file).unwrap(), first);
    }
    // A file it did not open or save is never replaced.
    let other = dir.path().join("other.json");
    std::fs::write(&other, "{}").unwrap();
    type_into(&mut h, "Protocol file", other.to_str().unwrap());
    click(&mut h, "Save");
    assert_eq!(std::fs::read_to_string(&other).unwrap(), "{}");
    h.get_by_label(&format!(
        "not saved: {} exists (open it to edit it, or choose another name)",
        other.display()
    ));
}

/// Issue 42: typing a number that would make a plan of a billion trials
/// (or an exploration of 1e300 s) into the builder: the frame that checks
/// it ends within a second (the plan's size is computed, not built), the
/// refusal shows under the field, and Save waits.
#[test]
fn a_huge_number_typed_into_the_builder_is_refused_at_its_field_at_once_issue_42() {
    let dir = tempfile::tempdir().unwrap();
    let mut h = harness(&dir.path().join("results"), "p52", None);
    builder(&mut h);
    click(&mut h, "magnitude_estimation");
    for (field, huge, said) in [
        (
            "repetitions",
            "1000000000",
            "repetitions: the plan would hold 3000000000 trials",
        ),
        (
            "exploration_s (s)",
            "1e300",
            "design.exploration_s: 1e300 s is longer than a session's longest time",
        ),
    ] {
        type_into(&mut h, field, huge);
        // The check runs after the frame that took the edit.
        let start = std::time::Instant::now();
        h.step();
        let took = start.elapsed();
        assert!(
            took < std::time::Duration::from_secs(1),
            "{field}: {took:?}"
        );
        h.get_by_label_contains(said);
        assert!(h.get_by_label("Save").accesskit_node().is_disabled());
        type_into(&mut h, field, "1");
        h.step();
        assert!(h.query_by_label_contains(said).is_none(), "{field}");
    }
}

#[test]
fn an_invalid_edit_shows_validates_message_at_its_field_and_save_waits_for_the_fix_issue_37() {
    let dir = tempfile::tempdir().unwrap();
    let mut h = harness(&dir.path().join("results"), "p51", None);
    builder(&mut h);
    click(&mut h, "magnitude_estimation");
    let file = dir.path().join("edited.json");
    type_into(&mut h, "Protocol file", file.to_str().unwrap());
    for bad in ["-2", "2 s"] {
        type_into(&mut h, "exploration_s (s)", bad);
        // The check runs after the frame that took the edit.
        h.step();
        // What validate says of the same protocol, written by hand.
        let by_hand = dir.path().join("by-hand.json");
        let mut v: serde_json::Value = serde_json::from_str(
            &serde_json::to_string(&frictionlab::protocol::form::new_protocol::<Registry>(
                "magnitude_estimation",
            ))
            .unwrap(),
        )
        .unwrap();
        v["design"]["exploration_s"] = match bad.parse::<f64>() {
            Ok(x) => x.into(),
            Err(_) => bad.into(),
        };
        std::fs::write(&by_hand, v.to_string()).unwrap();
        let (ok, said) = validate(&by_hand);
        assert!(!ok);
        let prefix = format!("error: {}: ", by_hand.display());
        let line = said.lines().find(|l| l.starts_with(&prefix)).unwrap();
        let message = line.strip_prefix(&prefix).unwrap();
        assert!(message.starts_with("design.exploration_s: "), "{message}");
        // The window shows it right under the field.
        let field = h
            .get_by_role_and_label(Role::TextInput, "exploration_s (s)")
            .rect();
        let shown = h.get_by_label(message).rect();
        assert!(
            shown.top() >= field.bottom() - 1.0 && shown.top() - field.bottom() < 20.0,
            "{message} at {shown:?}, its field at {field:?}"
        );
        assert!(h.get_by_label("Save").accesskit_node().is_disabled());
        h.get_by_label("Save").click();
        h.step();
        assert!(!file.exists(), "saved while invalid");
    }
    type_into(&mut h, "exploration_s (s)", "4.5");
    h.step();
    assert!(
        h.query_by_label_contains("design.exploration_s: ")
            .is_none()
    );
    h.get_by_label("ok: magnitude_estimation 'new-magnitude-estimation', 3 trials per session");
    click(&mut h, "Save");
    let (ok, said) = validate(&file);
    assert!(ok, "{said}");
    let saved: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&file).unwrap()).unwrap();
    assert_eq!(saved["design"]["exploration_s"], 4.5);
    // Straight to a session with it.
    click(&mut h, "Use for a session");
    h.get_by_label("Start new session");
    h.get_by_label_contains(&file.display().to_string());
}

#[test]
fn feeling_a_condition_moves_the_hand_under_the_pointer_issue_37() {
    let dir = tempfile::tempdir().unwrap();
    let mut h = harness(&dir.path().join("results"), "p52", None);
    builder(&mut h);
    click(&mut h, "fitts");
    // The new Fitts protocol's first condition: the apparatus alone.
    click(&mut h, "Feel it on the simulated device");
    let readout = |h: &Harness<'_, FrictionlabApp>| {
        let node = h.get_by_label_contains(" · position ");
        let text = node.accesskit_node().value().unwrap_or_default();
        let mm: f64 = text
            .split(" · position ")
            .nth(1)
            .and_then(|t| t.split(' ').next())
            .and_then(|t| t.parse().ok())
            .unwrap();
        (text, mm, node.rect())
    };
    let (text, at_rest, below) = readout(&h);
    assert!(text.starts_with("none"), "{text}");
    assert!(at_rest.abs() < 0.5, "{text}");
    // The strip is above the readout: the pointer on it, right of centre,
    // holds the hand there.
    let button = h.get_by_label("Stop feeling").rect();
    let y = f32::midpoint(button.bottom(), below.top());
    h.hover_at(egui::pos2(button.left() + 400.0, y));
    for _ in 0..20 {
        h.step();
    }
    let (text, moved, _) = readout(&h);
    assert!(moved > 2.0, "{text}");
    click(&mut h, "Stop feeling");
    assert!(h.query_by_label_contains(" · position ").is_none());
}

#[test]
fn the_desktops_file_chooser_opens_a_protocol_in_the_builder_issue_37() {
    let Some((mut x, display, _one)) = xvfb() else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    // A protocol written by hand on one line, where the builder's file
    // field points when it opens (a copy of the first shipped protocol,
    // relative to the window's folder): the chooser opens on it.
    let file = dir.path().join("protocols/my-magnitude-quick.json");
    std::fs::create_dir_all(file.parent().unwrap()).unwrap();
    let shipped = std::fs::read_to_string(format!(
        "{}/protocols/fitts-quick.json",
        env!("CARGO_MANIFEST_DIR")
    ))
    .unwrap();
    let value: serde_json::Value = serde_json::from_str(&shipped).unwrap();
    std::fs::write(&file, value.to_string()).unwrap();
    let xdotool = |args: &[&str]| xdotool(&display, args);
    let window = |how: &[&str]| {
        let o = xdotool(&[&["search"], how].concat());
        String::from_utf8_lossy(&o.stdout)
            .lines()
            .last()
            .map(str::to_owned)
    };
    let mut gui = Process::new(env!("CARGO_BIN_EXE_frictionlab"))
        .args(["gui", "--participant", "p53", "--out"])
        .arg(dir.path().join("results"))
        .current_dir(dir.path())
        .env("DISPLAY", &display)
        .env_remove("WAYLAND_DISPLAY")
        .env_remove("DBUS_SESSION_BUS_ADDRESS")
        .stdout(std::process::Stdio::null())
        .stderr(std::fs::File::create(dir.path().join("gui.err")).unwrap())
        .spawn()
        .unwrap();
    let finish = |gui: &mut std::process::Child, x: &mut std::process::Child| {
        let _ = gui.kill();
        let _ = gui.wait();
        let _ = x.kill();
        let _ = x.wait();
    };
    let up = wait_for(30.0, || {
        window(&["--name", "frictionlab: experimenter"]).is_some()
    });
    // The experimenter's window sits at (0, 0) (no window manager): the
    // builder's tab, then its Browse button (as docs/screenshots.sh).
    // A click before the window's first frames is lost: the builder's tab
    // is clicked a few times (clicking it again changes nothing), then
    // Browse, again only if no chooser came up in 30 s.
    for _ in 0..3 {
        std::thread::sleep(std::time::Duration::from_secs(1));
        xdotool(&["mousemove", "290", "52", "click", "1"]);
    }
    let zenity = || window(&["--class", "zenity"]);
    let mut chooser = false;
    for _ in 0..2 {
        if !up {
            break;
        }
        std::thread::sleep(std::time::Duration::from_secs(1));
        xdotool(&["mousemove", "567", "108", "click", "1"]);
        chooser = wait_for(30.0, || zenity().is_some());
        if chooser {
            break;
        }
    }
    if !(up && chooser) {
        finish(&mut gui, &mut x);
        // The window's own account, which goes with the temporary folder.
        let err = std::fs::read_to_string(dir.path().join("gui.err")).unwrap_or_default();
        panic!("window up: {up}, chooser up: {chooser}; the window's stderr:\n{err}");
    }
    // The chooser selects the file once it has read its folder; a Return
    // before that selects nothing and leaves it open. Return is pressed
    // until the chooser closes (once it has, there is nothing to press).
    let mut returns = 0;
    let closed = wait_for(60.0, || match zenity() {
        None => true,
        Some(z) => {
            std::thread::sleep(std::time::Duration::from_secs(1));
            xdotool(&["windowfocus", "--sync", &z]);
            xdotool(&["key", "Return"]);
            returns += 1;
            wait_for(5.0, || zenity().is_none())
        }
    });
    let form = frictionlab::protocol::form::Form::of::<Registry>();
    let expected = form.text(&value);
    // Opened from the chooser, it may be saved over: Save (clicked until
    // it lands) rewrites it in the builder's stable order.
    // A chooser opened by a late second click is cancelled.
    let saved = closed
        && wait_for(30.0, || {
            if let Some(late) = zenity() {
                xdotool(&["windowfocus", "--sync", &late]);
                xdotool(&["key", "Escape"]);
            } else {
                xdotool(&["mousemove", "632", "108", "click", "1"]);
            }
            std::thread::sleep(std::time::Duration::from_millis(500));
            std::fs::read_to_string(&file).is_ok_and(|t| t == expected)
        });
    finish(&mut gui, &mut x);
    assert!(
        saved,
        "the file chosen was not opened and saved (chooser closed: {closed}, \
         after {returns} Return presses): {}\nthe window's stderr: {}",
        std::fs::read_to_string(&file).unwrap(),
        std::fs::read_to_string(dir.path().join("gui.err")).unwrap_or_default()
    );
}

/// Issue 63: the bring-up check in the Setup tab. With the simulated
/// experimenter, the check of the simulated apparatus shows each step
/// passed with its numbers and keeps its report in the output folder; with
/// a person, each prompt stands with a "Done" button, and a check stopped
/// before its end keeps no report.
#[test]
fn the_setup_tab_runs_the_bring_up_check_with_its_prompts_and_keeps_its_report_issue_63() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("results");
    let mut h = harness(&out, "p01", None);
    type_into_role(&mut h, Role::SpinButton, "loop timing over", "1");
    click(&mut h, "simulated experimenter (an emulated device)");
    click(&mut h, "Check device");
    assert!(h.state().error().is_none(), "{:?}", h.state().error());
    let has = |h: &Harness<'_, FrictionlabApp>, text: &str| {
        h.query_all_by_label_contains(text).next().is_some()
    };
    let wait_for = |h: &mut Harness<'_, FrictionlabApp>, text: &str| {
        let start = std::time::Instant::now();
        while !has(h, text) {
            assert!(
                start.elapsed() < std::time::Duration::from_mins(1),
                "no '{text}' in the window"
            );
            h.step();
            std::thread::sleep(std::time::Duration::from_millis(10));
        }
    };
    wait_for(&mut h, "Every step passed.");
    for line in [
        "PASS handshake",
        "PASS encoder direction and scale: plus end",
        "PASS force direction",
        "N/A  wall",
        "Asked: Move the handle along the track to its + end",
    ] {
        assert!(has(&h, line), "{line}");
    }
    let kept = std::fs::read_dir(out.join("device-checks"))
        .unwrap()
        .count();
    assert_eq!(kept, 1);
    click(&mut h, "Back to the setup");
    // A person: the prompt stands with Done until it is pressed.
    click(&mut h, "simulated experimenter (an emulated device)");
    click(&mut h, "Check device");
    wait_for(&mut h, "hold it there, then confirm");
    assert!(h.query_by_label("Done").is_some(), "Done stands");
    assert!(has(&h, "to its + end"), "the first prompt");
    click(&mut h, "Done");
    wait_for(&mut h, "to its - end");
    click(&mut h, "Stop the check");
    h.step();
    assert!(
        h.query_by_label("Check device").is_some(),
        "back to the setup"
    );
    let kept = std::fs::read_dir(out.join("device-checks"))
        .unwrap()
        .count();
    assert_eq!(kept, 1, "a stopped check keeps no report");
}
