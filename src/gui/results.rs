//! The results panel: a results folder at a glance. Its sessions
//! (participant, protocol, trials done of planned, and status: complete,
//! unfinished, or open in another process) from
//! [`ResultsDir::overview`], with Resume where a session can be resumed;
//! Analyze, which runs the same analysis as `frictionlab analyze` (into the
//! same `<folder>/report`) on a thread of its own while a progress bar
//! runs, then shows each study's figures and key statistics (its kind's
//! results view, from `summary.json`) with the full tree one click away;
//! and Open report, which opens `report.html` in the system's browser.

use std::path::{Path, PathBuf};
use std::sync::mpsc;

use eframe::egui::{self, RichText};
use serde_json::Value;

use super::{Command, ERROR_RED};
use crate::kinds::{Registry, results_view};
use crate::results::{ResultsDir, SessionOverview, SessionStatus};

/// How often the folder is read again, s (a session open elsewhere ends
/// without telling).
const READ_EVERY_S: f64 = 1.0;

/// An analysis running or done.
enum Analysis {
    /// Running on its thread since `started` (egui's clock, s).
    Running {
        started: f64,
        done: mpsc::Receiver<Result<Value, String>>,
    },
    /// Done: the summary written to `report`.
    Done { summary: Value, report: PathBuf },
    /// Failed: why.
    Failed(String),
}

/// What the results panel keeps between frames.
#[derive(Default)]
pub(super) struct ResultsPanel {
    sessions: Vec<SessionOverview>,
    /// The folder and when it was read.
    read: Option<(String, f64)>,
    analysis: Option<Analysis>,
    /// Why the report could not be opened.
    open_error: Option<String>,
}

/// The analysis `frictionlab analyze <folder>` runs, written where it
/// writes it: `<folder>/report`. The summary, or the message.
fn analyze(folder: &Path) -> Result<Value, String> {
    use crate::analysis::{Check, analyze_with, write};
    let analysis = analyze_with::<Registry>(folder, Check::AgainstLogs)
        .map_err(|e| format!("error: {}: {}", e.place, e.message))?;
    write(&analysis, &folder.join("report"))
        .map_err(|(path, message)| format!("error: {path}: {message}"))?;
    Ok(analysis.summary)
}

impl ResultsPanel {
    /// Reads `folder` again when it changed or a second has passed.
    fn refresh(&mut self, folder: &str, now: f64) {
        if self
            .read
            .as_ref()
            .is_some_and(|(f, at)| f == folder && (0.0..READ_EVERY_S).contains(&(now - at)))
        {
            return;
        }
        self.sessions = ResultsDir::new(folder).overview::<Registry>();
        self.read = Some((folder.to_owned(), now));
    }

    /// Whether an analysis is running.
    pub(super) fn analysing(&self) -> bool {
        matches!(self.analysis, Some(Analysis::Running { .. }))
    }

    /// Starts the analysis of `folder` on a thread (at `now`, s).
    pub(super) fn start_analysis(&mut self, folder: &str, now: f64) {
        let (tx, rx) = mpsc::channel();
        let folder = PathBuf::from(folder);
        std::thread::spawn(move || {
            // The panel may be gone when the analysis ends.
            let _ = tx.send(analyze(&folder));
        });
        self.analysis = Some(Analysis::Running {
            started: now,
            done: rx,
        });
        self.open_error = None;
    }

    /// Takes the analysis's result when it has ended.
    fn poll(&mut self, folder: &str) {
        if let Some(Analysis::Running { done, .. }) = &self.analysis {
            match done.try_recv() {
                Ok(Ok(summary)) => {
                    self.analysis = Some(Analysis::Done {
                        summary,
                        report: PathBuf::from(folder).join("report"),
                    });
                }
                Ok(Err(e)) => self.analysis = Some(Analysis::Failed(e)),
                Err(mpsc::TryRecvError::Empty) => {}
                Err(mpsc::TryRecvError::Disconnected) => {
                    self.analysis = Some(Analysis::Failed(
                        "error: the analysis stopped without a result".to_owned(),
                    ));
                }
            }
        }
    }

    /// Opens the report in the system's browser.
    pub(super) fn open_report(&mut self) {
        if let Some(Analysis::Done { report, .. }) = &self.analysis {
            let page = report.join("report.html");
            self.open_error = open::that_detached(&page)
                .err()
                .map(|e| format!("error: {}: cannot open: {e}", page.display()));
        }
    }

    /// Draws the panel for `folder` (egui's clock `now`, s).
    pub(super) fn ui(&mut self, ui: &mut egui::Ui, folder: &str, now: f64) -> Vec<Command> {
        let mut commands = Vec::new();
        self.refresh(folder, now);
        self.poll(folder);
        ui.label(format!("Results folder: {folder}"));
        if self.sessions.is_empty() {
            ui.label(RichText::new("No sessions in this folder yet.").weak());
        } else {
            sessions_table(ui, &self.sessions, &mut commands);
        }
        ui.add_space(8.0);
        ui.horizontal(|ui| {
            let analyse = ui.add_enabled(
                !self.analysing() && !self.sessions.is_empty(),
                egui::Button::new("Analyze"),
            );
            if analyse.clicked() {
                commands.push(Command::Analyze);
            }
            if matches!(self.analysis, Some(Analysis::Done { .. }))
                && ui.button("Open report").clicked()
            {
                commands.push(Command::OpenReport);
            }
        });
        match &self.analysis {
            None => {}
            Some(Analysis::Running { started, .. }) => {
                let t = now - started;
                // The analysis reports no fraction done: the bar sweeps
                // every 2 s while it runs.
                #[expect(clippy::cast_possible_truncation, reason = "a fraction in [0, 1)")]
                let sweep = (t * 0.5).fract() as f32;
                ui.add(
                    egui::ProgressBar::new(sweep)
                        .animate(true)
                        .text(format!("Analysing ({t:.0} s)")),
                );
                ui.ctx().request_repaint();
            }
            Some(Analysis::Failed(e)) => {
                ui.label(RichText::new(e).color(ERROR_RED));
            }
            Some(Analysis::Done { summary, report }) => {
                ui.label(format!(
                    "Analysis written to {}",
                    report.join("summary.json").display()
                ));
                summary_view(ui, summary);
            }
        }
        if let Some(e) = &self.open_error {
            ui.label(RichText::new(e).color(ERROR_RED));
        }
        commands
    }
}

/// The sessions as a table, with Resume where it applies.
fn sessions_table(ui: &mut egui::Ui, sessions: &[SessionOverview], commands: &mut Vec<Command>) {
    egui::Grid::new("results-sessions")
        .striped(true)
        .num_columns(6)
        .show(ui, |ui| {
            for h in ["Participant", "Protocol", "Session", "Trials", "Status", ""] {
                ui.label(RichText::new(h).strong());
            }
            ui.end_row();
            for s in sessions {
                ui.label(&s.participant);
                ui.label(&s.protocol_id).on_hover_text(&s.protocol_title);
                ui.label(s.session.to_string());
                // A kind whose trials adapt to the answers plans none.
                ui.label(if s.planned == 0 {
                    format!("{} (adaptive)", s.done)
                } else {
                    format!("{} of {}", s.done, s.planned)
                });
                ui.label(s.status.describe());
                if s.status == SessionStatus::Unfinished {
                    if ui
                        .button(format!(
                            "Resume {} session {} of {}",
                            s.participant, s.session, s.protocol_id
                        ))
                        .clicked()
                    {
                        commands.push(Command::ResumeLog(s.log.clone()));
                    }
                } else {
                    ui.label("");
                }
                ui.end_row();
            }
        });
}

/// `summary.json`, a section per study: the study's figures and key
/// statistics from its kind's results view ([`results_view`]), with its
/// full tree one click away; a study without a view, and the notes, as a
/// tree (numbers to four decimals, long lists folded).
fn summary_view(ui: &mut egui::Ui, summary: &Value) {
    let Some(map) = summary.as_object() else {
        ui.label(RichText::new("error: summary.json is not an object").color(ERROR_RED));
        return;
    };
    for (key, value) in map {
        if key == "inputs" {
            continue;
        }
        let view = results_view(key);
        egui::CollapsingHeader::new(RichText::new(key).strong())
            .default_open(key != "notes")
            .show(ui, |ui| {
                if let Some(view) = view {
                    view(ui, value);
                    egui::CollapsingHeader::new(format!("Full tree of {key}"))
                        .id_salt(("full-tree", key))
                        .show(ui, |ui| tree(ui, value, 0));
                } else {
                    if key != "notes" {
                        ui.label(
                            RichText::new(format!(
                                "No figures for {key}: its kind has no results view."
                            ))
                            .weak(),
                        );
                    }
                    tree(ui, value, 0);
                }
            });
    }
}

fn tree(ui: &mut egui::Ui, value: &Value, depth: usize) {
    match value {
        Value::Object(map) => {
            for (k, v) in map {
                if v.is_object() || v.is_array() {
                    egui::CollapsingHeader::new(k)
                        .id_salt((k, depth, v.to_string().len()))
                        .default_open(depth == 0 && size(v) <= 12)
                        .show(ui, |ui| tree(ui, v, depth + 1));
                } else {
                    ui.label(format!("{k}: {}", leaf(v)));
                }
            }
        }
        Value::Array(items) => {
            for (i, v) in items.iter().enumerate() {
                if v.is_object() || v.is_array() {
                    egui::CollapsingHeader::new(format!("[{i}]"))
                        .id_salt((i, depth, v.to_string().len()))
                        .show(ui, |ui| tree(ui, v, depth + 1));
                } else {
                    ui.label(leaf(v));
                }
            }
        }
        v => {
            ui.label(leaf(v));
        }
    }
}

fn size(v: &Value) -> usize {
    match v {
        Value::Object(m) => m.len(),
        Value::Array(a) => a.len(),
        _ => 1,
    }
}

fn leaf(v: &Value) -> String {
    match v {
        Value::Number(n) => n.as_f64().map_or_else(
            || n.to_string(),
            |x| {
                if x.fract() == 0.0 && x.abs() < 1e15 {
                    format!("{x}")
                } else {
                    format!("{x:.4}")
                }
            },
        ),
        Value::String(s) => s.clone(),
        Value::Null => "n/a".to_owned(),
        v => v.to_string(),
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, reason = "tests: a panic is a failure")]

    use egui_kittest::{Harness, kittest::Queryable};
    use serde_json::{Value, json};

    fn shown(summary: Value) -> Harness<'static> {
        let mut h = Harness::new_ui(move |ui| super::summary_view(ui, &summary));
        h.run();
        h
    }

    /// A kind without a results view (the test-only staircase has no
    /// analysis) shows its object as the tree, and says why.
    #[test]
    fn a_study_of_a_kind_without_a_view_is_shown_as_its_tree() {
        let h = shown(json!({"toy_staircase": {"reversals": 6}, "notes": []}));
        h.get_by_label("No figures for toy_staircase: its kind has no results view.");
        h.get_by_label("reversals: 6");
    }

    /// A summary.json with fields missing or of the wrong type: each view
    /// says which, and nothing panics; the tree is still one click away.
    #[test]
    fn missing_or_wrong_fields_are_named_not_panicked_on() {
        let mut h = shown(json!({
            "paired_comparison": {"counts": {"a": 1, "b": "x"}},
            "magnitude_estimation": {"displays": ["tactile", "visual"], "geometric_means": [{}]},
            "fitts": {"regression": 3},
            "discrimination": {"fits": [{"level": 0.4}], "levels": null},
        }));
        h.get_by_label("summary.json: paired_comparison.counts.b is \"x\", not a count");
        h.get_by_label("summary.json has no paired_comparison.order.first_chosen");
        h.get_by_label("summary.json has no magnitude_estimation.display_effect.n");
        h.get_by_label("summary.json has no magnitude_estimation.geometric_means[0].normalization");
        h.get_by_label("summary.json: fitts.regression is 3, not a list");
        h.get_by_label("summary.json has no discrimination.criterion");
        h.get_by_label("summary.json has no discrimination.fits[0].location");
        h.get_by_label("Full tree of fitts").click();
        h.run();
        h.get_by_label("regression: 3");
    }

    /// A regression that is n/a (one ID tested) says so in its sentence;
    /// lines without the IDs tested (no quadrants) say what they span.
    #[test]
    fn a_regression_that_is_n_a_says_why() {
        let regression = |condition: &str, fit: Option<f64>| {
            json!({"condition": condition, "intercept_s": fit, "slope_s_per_bit": fit,
                "r2": fit, "n": 8})
        };
        let h = shown(json!({"fitts": {
            "regression": [regression("baseline", None), regression("real", Some(0.5))],
            "throughput_bits_per_s": {"baseline": 3.6236, "real": 2.0},
            "quadrants": [],
        }}));
        h.get_by_label(
            "baseline: regression n/a (fewer than two distinct IDs) (n = 8 tests); throughput 3.62 bits/s.",
        );
        h.get_by_label(
            "real: MT = 0.500 s + 0.500 s/bit × ID, r² = 0.50 (n = 8 tests); throughput 2.00 bits/s.",
        );
        h.get_by_label(
            "summary.json lists the IDs tested only with the quadrants (baseline and another condition): the lines run from 0 to 6 bits.",
        );
    }

    /// A Fitts study with no test analysed (only the practice done) says
    /// so.
    #[test]
    fn a_fitts_study_without_tests_says_so() {
        let h = shown(json!({"fitts": {"regression": [], "quadrants": [],
            "throughput_bits_per_s": {}, "tests": 0}}));
        h.get_by_label("No condition to regress: 0 tests analysed.");
    }

    /// A summary that is not an object says so.
    #[test]
    fn a_summary_that_is_not_an_object_says_so() {
        let h = shown(json!([1, 2]));
        h.get_by_label("error: summary.json is not an object");
    }
}
