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
                // Held for a lost sound output: it resumes when the output
                // is back.
                let held = live.sound_lost_for_s().is_some();
                if ui.add_enabled(!held, egui::Button::new("Resume")).clicked() {
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
        device_asks(ui, live, &mut commands);
        if let Some(s) = live.sound_lost_for_s() {
            ui.label(
                RichText::new(format!(
                    "A sound output is lost ({s:.0} s): the trial under way was aborted and will be presented again; the session goes on when the output is back"
                ))
                .color(super::ERROR_RED)
                .strong(),
            );
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

/// What the device asks of the experimenter, with the button that
/// confirms it; why it failed, once it has.
fn device_asks(ui: &mut egui::Ui, live: &LiveSession, commands: &mut Vec<Command>) {
    if let Some(request) = live.device_request() {
        egui::Frame::group(ui.style())
            .fill(Color32::from_rgb(90, 40, 20))
            .show(ui, |ui| {
                ui.label(RichText::new(format!("Device: {}.", request.ask())).strong());
                if ui
                    .button("The handle is at its calibration pose: confirm")
                    .clicked()
                {
                    commands.push(Command::ConfirmDevice);
                }
            });
    }
    if let Some(failure) = live.device_failure() {
        ui.label(
            RichText::new(format!("The device failed: {failure}"))
                .color(super::ERROR_RED)
                .strong(),
        );
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

#[cfg(test)]
mod tests {
    use eframe::egui;
    use egui_kittest::{Harness, kittest::Queryable};

    use crate::gui::{AutoStart, FrictionlabApp, Launch};
    use crate::session::DeviceChoice;

    const CONFIRM: &str = "The handle is at its calibration pose: confirm";

    /// Issue 63: what the device asks is shown in the session panel with a
    /// button; clicking it confirms, and the device answers again (the
    /// test-only device `loopback:asks` asks from 1 s in, until confirmed).
    #[test]
    fn the_window_shows_what_the_device_asks_and_its_button_confirms_it() {
        let tmp = tempfile::tempdir().unwrap();
        let launch = Launch {
            protocol: Some(
                std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
                    .join("protocols/magnitude-quick.json"),
            ),
            participant: "win".into(),
            out: tmp.path().to_path_buf(),
            device: DeviceChoice::Device(crate::device::Address::parse("loopback:asks").unwrap()),
            start: Some(AutoStart {
                resume: false,
                or_resume: false,
                seed: Some(1),
                participant_index: None,
            }),
            ..Launch::default()
        };
        let mut h = Harness::builder()
            .with_size(egui::vec2(1920.0, 1200.0))
            .build_eframe(move |_cc| FrictionlabApp::new(launch));
        let start = std::time::Instant::now();
        while h.query_by_label(CONFIRM).is_none() && start.elapsed().as_secs() < 10 {
            h.step();
            std::thread::sleep(std::time::Duration::from_millis(5));
        }
        let live = h.state().live().expect("a session is open");
        assert!(live.device_request().is_some(), "{:?}", h.state().error());
        assert!(!live.device_status().connected);
        assert!(
            h.query_by_label_contains("put the handle at its calibration pose")
                .is_some()
        );
        h.get_by_label(CONFIRM).click();
        let clicked = std::time::Instant::now();
        while !h.state().live().unwrap().device_status().connected
            && clicked.elapsed().as_secs() < 5
        {
            h.step();
            std::thread::sleep(std::time::Duration::from_millis(5));
        }
        let live = h.state().live().unwrap();
        assert!(live.device_status().connected, "the device answers again");
        assert!(live.device_request().is_none());
        assert!(h.query_by_label(CONFIRM).is_none(), "the request is gone");
    }
}
