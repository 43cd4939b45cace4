//! The session panel: the experimenter's view of a running session
//! (progress, pause/abort/close, the experimenter's prompts, the device's
//! status, notes for the log, the live plot). It draws what the
//! [`LiveSession`] reports and returns [`Command`]s; the app applies them.

use eframe::egui::{self, Color32, RichText};

use super::{Command, plot};
use crate::session::{LiveSession, SessionState};

/// What the session panel keeps between frames.
#[derive(Debug, Default)]
pub(super) struct SessionPanel {
    /// The note being typed.
    note: String,
    /// Notes saved to this session's log.
    notes_saved: usize,
    /// Whether the participant's window is full screen.
    fullscreen: bool,
}

impl SessionPanel {
    /// Whether the participant's window should be full screen.
    pub(super) fn fullscreen(&self) -> bool {
        self.fullscreen
    }

    /// The note typed in, trimmed; `None` when there is nothing to save.
    pub(super) fn note_to_save(&self) -> Option<String> {
        let text = self.note.trim();
        (!text.is_empty()).then(|| text.to_owned())
    }

    /// The note was saved to the log: clears the field and counts it.
    pub(super) fn note_saved(&mut self) {
        self.note.clear();
        self.notes_saved += 1;
    }

    /// A session opened or closed: no note of it saved yet.
    pub(super) fn new_session(&mut self) {
        self.notes_saved = 0;
    }

    /// Draws the panel for `live`.
    #[must_use]
    pub(super) fn ui(&mut self, ui: &mut egui::Ui, live: &LiveSession) -> Vec<Command> {
        let mut commands = Vec::new();
        let p = live.progress();
        let state = live.state();
        let remaining = p
            .remaining_s
            .map_or("unknown until a trial ends".into(), |s| {
                format!("about {s:.0} s")
            });
        ui.heading(format!(
            "Session {}: {}",
            live.session(),
            match state {
                SessionState::Running => "running",
                SessionState::Paused => "paused",
                SessionState::Finished => "finished",
                SessionState::Aborted => "aborted (it can be resumed)",
            }
        ));
        ui.label(format!(
            "Trial {} of {} · block {} · elapsed {:.1} s · remaining {remaining}",
            p.trial, p.total, p.block, p.elapsed_s
        ));
        #[expect(clippy::cast_possible_truncation, reason = "a progress fraction")]
        let fraction = if state == SessionState::Finished {
            1.0
        } else {
            (p.trial.saturating_sub(1) as f64 / p.total.max(1) as f64) as f32
        };
        ui.add(egui::ProgressBar::new(fraction).show_percentage());
        ui.horizontal(|ui| match state {
            SessionState::Running => {
                if ui.button("Pause").clicked() {
                    commands.push(Command::Pause);
                }
                if ui.button("Abort session").clicked() {
                    commands.push(Command::Abort);
                }
            }
            SessionState::Paused => {
                if ui.button("Resume").clicked() {
                    commands.push(Command::Resume);
                }
                if ui.button("Abort session").clicked() {
                    commands.push(Command::Abort);
                }
            }
            SessionState::Finished | SessionState::Aborted => {
                ui.label(format!("Data: {}", live.csv().display()));
                if ui.button("Close session").clicked() {
                    commands.push(Command::Close);
                }
            }
        });
        if let Some(prompt) = &live.view().prompt {
            egui::Frame::group(ui.style())
                .fill(Color32::from_rgb(70, 60, 20))
                .show(ui, |ui| {
                    ui.label(RichText::new(format!("Experimenter: {prompt}")).strong());
                    if ui.button("Done, continue").clicked() {
                        commands.push(Command::Continue);
                    }
                });
        }
        device_line(ui, live);
        ui.checkbox(&mut self.fullscreen, "Participant window full screen");
        let label = ui.label("Note for the session log");
        ui.horizontal(|ui| {
            ui.add(
                egui::TextEdit::multiline(&mut self.note)
                    .desired_rows(2)
                    .desired_width(600.0),
            )
            .labelled_by(label.id);
            if ui.button("Save note").clicked() {
                commands.push(Command::SaveNote);
            }
        });
        if self.notes_saved > 0 {
            ui.label(
                RichText::new(format!("{} note(s) saved to the log", self.notes_saved)).weak(),
            );
        }
        plot::tracks(ui, live);
        plot::show(ui, live);
        commands
    }
}

/// The device's live status, one line.
fn device_line(ui: &mut egui::Ui, live: &LiveSession) {
    let d = live.device_status();
    ui.label(format!(
        "Device {} · {} · loop {:.0} Hz · period p99 {} · force {:.3} N · position {:.2} mm",
        d.device,
        if d.connected {
            "connected"
        } else {
            "NOT CONNECTED"
        },
        d.rate_hz,
        d.period_p99_s
            .map_or("n/a (simulated, session time)".into(), |s| format!(
                "{:.0} µs",
                s * 1e6
            )),
        d.force_n,
        d.x_m * 1e3
    ));
}
