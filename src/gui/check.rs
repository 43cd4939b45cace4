//! The bring-up check in the Setup tab (issue 63): a thin shell over
//! [`crate::session::DeviceCheck`], the library the command line's
//! `check-device` runs. It lists what the check said (progress, each
//! prompt, each step's PASS or FAIL with its numbers), shows the prompt
//! standing with a "Done" button, and, once the check has ended, where its
//! report was kept. The app pumps it each frame ([`CheckPanel::pump`]).

use eframe::egui::{self, Color32, RichText};

use super::{Command, ERROR_RED};
use crate::device::check::{Ask, Event, Options, StepReport};
use crate::results::ResultsDir;
use crate::session::{DeviceCheck, DeviceChoice};

/// The colour of a passed step.
const PASS_GREEN: Color32 = Color32::from_rgb(60, 170, 90);

/// One line of what the check said.
enum Said {
    Progress(String),
    Prompt { text: String, by_sim: bool },
    Step(StepReport),
}

/// A check in the window: running, or ended with its report kept.
pub(super) struct CheckPanel {
    /// The check, while it runs.
    running: Option<DeviceCheck>,
    device: String,
    said: Vec<Said>,
    sim: bool,
    /// Once ended: whether it passed and where its report is, or why it
    /// could not be kept.
    ended: Option<Result<(bool, String), String>>,
}

impl CheckPanel {
    /// Starts the check of `device`, its report kept in `out`; `sim`: the
    /// simulated experimenter does what the prompts ask (an emulated
    /// device).
    ///
    /// # Errors
    /// The check could not start: the message to show.
    pub(super) fn start(
        device: &DeviceChoice,
        out: &str,
        duration_s: f64,
        sim: bool,
    ) -> Result<Self, String> {
        if let DeviceChoice::Device(address) = device {
            address
                .check()
                .and_then(|()| address.check_settings())
                .map_err(|e| format!("error: --device: {address}: {e}"))?;
        }
        let options = Options {
            duration_s,
            ..Options::default()
        };
        let running = DeviceCheck::start(device, &ResultsDir::new(out), options, sim)
            .map_err(|e| format!("error: the haptic loop: {e}"))?;
        Ok(CheckPanel {
            device: running.device().to_owned(),
            running: Some(running),
            said: Vec::new(),
            sim,
            ended: None,
        })
    }

    /// Whether the check still runs (the window repaints while it does).
    pub(super) fn running(&self) -> bool {
        self.running.is_some()
    }

    fn note(&mut self, events: Vec<Event>) {
        for e in events {
            match e {
                Event::Progress(text) => self.said.push(Said::Progress(text)),
                Event::Prompt(ask) => self.said.push(Said::Prompt {
                    text: ask.text(),
                    by_sim: self.sim,
                }),
                Event::Step(step) => self.said.push(Said::Step(step)),
                Event::Finished => {}
            }
        }
    }

    /// Takes what the check did since the last frame; keeps its report
    /// once it has ended.
    pub(super) fn pump(&mut self) {
        let Some(check) = &mut self.running else {
            return;
        };
        let events = check.pump();
        self.note(events);
        if self.running.as_ref().is_some_and(DeviceCheck::finished)
            && let Some(check) = self.running.take()
        {
            self.ended = Some(
                check
                    .finish()
                    .map(|done| (done.report.passed, done.path.display().to_string()))
                    .map_err(|e| format!("error: {e}")),
            );
        }
    }

    /// The experimenter pressed "Done".
    pub(super) fn confirm(&mut self) {
        if let Some(check) = &mut self.running {
            let events = check.confirm();
            self.note(events);
        }
    }

    fn asked(&self) -> Option<Ask> {
        self.running.as_ref().and_then(DeviceCheck::asked)
    }

    /// Draws the check.
    #[must_use]
    pub(super) fn ui(&self, ui: &mut egui::Ui) -> Vec<Command> {
        let mut commands = Vec::new();
        ui.heading(format!("Bring-up check of {}", self.device));
        ui.label(
            RichText::new(
                "Handshake, loop timing, encoder direction and scale, force direction, and the wall, through the haptic loop a session uses.",
            )
            .weak(),
        );
        ui.separator();
        for said in &self.said {
            match said {
                Said::Progress(text) => {
                    ui.label(RichText::new(text).weak());
                }
                Said::Prompt { text, by_sim } => {
                    let who = if *by_sim {
                        " (the simulated experimenter does it)"
                    } else {
                        ""
                    };
                    ui.label(RichText::new(format!("Asked: {text}{who}")).italics());
                }
                Said::Step(step) => {
                    let colour = if step.verdict.ok() {
                        PASS_GREEN
                    } else {
                        ERROR_RED
                    };
                    ui.label(RichText::new(step.line()).monospace().color(colour));
                }
            }
        }
        if let Some(ask) = self.asked()
            && !self.sim
        {
            ui.separator();
            ui.label(RichText::new(ask.text()).strong().size(16.0));
            if ui
                .button(RichText::new("Done").strong().size(16.0))
                .clicked()
            {
                commands.push(Command::CheckConfirm);
            }
        }
        ui.separator();
        match &self.ended {
            None => {
                if ui.button("Stop the check").clicked() {
                    commands.push(Command::CheckClose);
                }
            }
            Some(ended) => {
                match ended {
                    Ok((passed, path)) => {
                        let (text, colour) = if *passed {
                            ("Every step passed.", PASS_GREEN)
                        } else {
                            ("The check failed.", ERROR_RED)
                        };
                        ui.label(RichText::new(text).strong().color(colour));
                        ui.label(format!("Report kept in {path}"));
                    }
                    Err(e) => {
                        ui.label(RichText::new(e).color(ERROR_RED));
                    }
                }
                if ui.button("Back to the setup").clicked() {
                    commands.push(Command::CheckClose);
                }
            }
        }
        commands
    }
}
