//! Setup's Sound (issue 64): the sound server's outputs, each with a test
//! tone (600 Hz, 0.5 s: [`crate::audio::tone`]) and a level meter, and the
//! outputs a session plays on: the protocol's masking noise, and the
//! tactile display's output and channel. It draws its state and returns
//! [`Command`]s; the app applies them after the frame ([`SoundPanel::apply`]).
//!
//! The meter shows the peak of what frictionlab plays on the output (the
//! test tone), in dBFS, held and falling 20 dB/s as a peak meter does.

use eframe::egui::{self, RichText};

use super::{Command, ERROR_RED};
use crate::audio::tone::TestTone;
use crate::audio::{Masking, Output, Server};
use crate::session::sound::SoundChoice;

/// The meter's floor, dBFS: quieter shows as empty.
const METER_FLOOR_DBFS: f32 = -60.0;

/// How fast the held peak falls, dB/s.
const METER_FALL_DB_PER_S: f32 = 20.0;

/// What Sound asks of the app.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) enum SoundAction {
    /// List the server's outputs again.
    Refresh,
    /// Play the test tone on an output: on a channel (0-based), or all.
    Tone {
        /// The output.
        output: String,
        /// Its channel, or every channel.
        channel: Option<usize>,
    },
}

/// A meter's held peak.
#[derive(Debug, Clone, Copy)]
struct Held {
    dbfs: f32,
    /// When it was last raised (egui's clock, s).
    at: f64,
}

/// What Sound keeps between frames.
pub(super) struct SoundPanel {
    server: Server,
    outputs: Result<Vec<Output>, String>,
    /// The output the masking noise plays on.
    masking: Option<String>,
    /// The tactile display's output and channel (0-based).
    tactile: Option<(String, usize)>,
    /// The test tones playing, by output.
    tones: Vec<(String, TestTone)>,
    /// The meters' held peaks, by output.
    meters: Vec<(String, Held)>,
    /// Why the last test tone did not play, if it did not.
    error: Option<String>,
    /// The meter's clock (egui's), s.
    now: f64,
}

impl SoundPanel {
    /// Sound as `choice` sets it up (`--masking-audio`, `--tactile-audio`),
    /// the server's outputs listed.
    pub(super) fn new(choice: SoundChoice) -> Self {
        let tactile = choice
            .tactile_audio
            .as_deref()
            .and_then(|t| crate::audio::output_and_channel(t).ok());
        let mut panel = SoundPanel {
            server: choice.server,
            outputs: Ok(Vec::new()),
            masking: choice.masking_audio,
            tactile,
            tones: Vec::new(),
            meters: Vec::new(),
            error: None,
            now: 0.0,
        };
        panel.refresh();
        panel
    }

    /// Lists the server's outputs again.
    fn refresh(&mut self) {
        self.outputs = self.server.outputs().map_err(|e| e.to_string());
    }

    /// What a session started now plays on.
    pub(super) fn choice(&self) -> SoundChoice {
        SoundChoice {
            server: self.server.clone(),
            masking_audio: self.masking.clone(),
            tactile_audio: self.tactile.as_ref().map(|(o, c)| format!("{o}:{}", c + 1)),
        }
    }

    /// What keeps a session of a protocol with `masking` from starting,
    /// on a device (`device`) or the simulated apparatus.
    pub(super) fn problems(&self, masking: Option<&Masking>, device: bool) -> Vec<String> {
        let mut problems = Vec::new();
        if masking.is_some() && self.masking.is_none() {
            problems.push("choose the output for the protocol's masking noise (Sound)".to_owned());
        }
        if self.tactile.is_some() && !device {
            problems.push(
                "the tactile display needs a device's haptic loop: choose a device, or no tactile output"
                    .to_owned(),
            );
        }
        problems
    }

    /// Applies `action`.
    pub(super) fn apply(&mut self, action: SoundAction) {
        match action {
            SoundAction::Refresh => self.refresh(),
            SoundAction::Tone { output, channel } => {
                self.tones.retain(|(o, _)| *o != output);
                match TestTone::play(&self.server, &output, channel) {
                    Ok(tone) => {
                        self.error = None;
                        self.tones.push((output, tone));
                    }
                    Err(e) => self.error = Some(format!("test tone on {output}: {e}")),
                }
            }
        }
    }

    /// Whether a test tone plays (the window repaints for its meter).
    pub(super) fn busy(&self) -> bool {
        !self.tones.is_empty() || !self.meters.is_empty()
    }

    /// The meters follow the tones at egui's time `now`; tones played out
    /// are closed.
    pub(super) fn pump(&mut self, now: f64) {
        self.now = now;
        for (output, tone) in &self.tones {
            let dbfs = 20.0 * tone.peak().max(1e-6).log10();
            match self.meters.iter_mut().find(|(o, _)| o == output) {
                Some((_, held)) if held.level(now) <= dbfs => *held = Held { dbfs, at: now },
                Some(_) => {}
                None => self.meters.push((output.clone(), Held { dbfs, at: now })),
            }
        }
        self.tones.retain(|(_, t)| !t.done());
        self.meters.retain(|(_, h)| h.level(now) > METER_FLOOR_DBFS);
    }

    /// The meter of `output` now, dBFS (`None`: at its floor).
    pub(super) fn meter_dbfs(&self, output: &str) -> Option<f32> {
        self.meters
            .iter()
            .find(|(o, _)| o == output)
            .map(|(_, h)| h.level(self.now))
    }

    /// Draws Sound, for a protocol with `masking`.
    pub(super) fn ui(&mut self, ui: &mut egui::Ui, masking: Option<&Masking>) -> Vec<Command> {
        let mut commands = Vec::new();
        ui.vertical(|ui| {
            let outputs = match &self.outputs {
                Ok(o) => o.clone(),
                Err(e) => {
                    ui.horizontal(|ui| {
                        ui.label(RichText::new(e).color(ERROR_RED));
                        if ui.button("Refresh outputs").clicked() {
                            commands.push(Command::Sound(SoundAction::Refresh));
                        }
                    });
                    return;
                }
            };
            self.outputs_grid(ui, &outputs, &mut commands);
            if let Some(e) = &self.error {
                ui.label(RichText::new(e).color(ERROR_RED));
            }
            self.masking_choice(ui, &outputs, masking);
            self.tactile_choice(ui, &outputs);
        });
        commands
    }

    /// The outputs, a row each: test tone and meter.
    fn outputs_grid(&self, ui: &mut egui::Ui, outputs: &[Output], commands: &mut Vec<Command>) {
        ui.horizontal(|ui| {
            ui.label(format!("{} outputs on the sound server", outputs.len()));
            if ui.button("Refresh outputs").clicked() {
                commands.push(Command::Sound(SoundAction::Refresh));
            }
        });
        egui::Grid::new("sound outputs")
            .num_columns(4)
            .spacing([12.0, 4.0])
            .show(ui, |ui| {
                for o in outputs {
                    ui.label(RichText::new(&o.name).monospace());
                    ui.label(format!(
                        "{} ({} ch, {} Hz)",
                        o.description, o.channels, o.rate_hz
                    ));
                    // On the tactile display's channel only, when it is
                    // this output: the tactor alone buzzes.
                    let channel = self
                        .tactile
                        .as_ref()
                        .filter(|(t, _)| *t == o.name)
                        .map(|(_, c)| *c);
                    let text = match channel {
                        Some(c) => format!("Test tone (channel {})", c + 1),
                        None => "Test tone".to_owned(),
                    };
                    if ui
                        .button(text)
                        .on_hover_text("600 Hz for 0.5 s at -20 dBFS RMS")
                        .clicked()
                    {
                        commands.push(Command::Sound(SoundAction::Tone {
                            output: o.name.clone(),
                            channel,
                        }));
                    }
                    let level = self.meter_dbfs(&o.name);
                    let fraction = level.map_or(0.0, |l| {
                        ((l - METER_FLOOR_DBFS) / -METER_FLOOR_DBFS).clamp(0.0, 1.0)
                    });
                    ui.add(egui::ProgressBar::new(fraction).desired_width(200.0).text(
                        level.map_or("level: silent".to_owned(), |l| {
                            format!("level {l:.1} dBFS peak")
                        }),
                    ));
                    ui.end_row();
                }
            });
    }

    fn masking_choice(&mut self, ui: &mut egui::Ui, outputs: &[Output], masking: Option<&Masking>) {
        ui.horizontal(|ui| {
            let label = ui.label("Masking noise on");
            let Some(m) = masking else {
                ui.label(RichText::new("(the protocol plays none)").weak());
                return;
            };
            pick(ui, label.id, "masking output", &mut self.masking, outputs);
            ui.label(
                RichText::new(format!(
                    "{} noise at {} dBFS RMS, during {}",
                    match m.noise {
                        crate::audio::NoiseColor::Pink => "pink",
                        crate::audio::NoiseColor::White => "white",
                    },
                    m.level_dbfs,
                    match m.during {
                        crate::audio::During::Session => "the session",
                        crate::audio::During::Trials => "trials",
                    }
                ))
                .weak(),
            );
        });
    }

    fn tactile_choice(&mut self, ui: &mut egui::Ui, outputs: &[Output]) {
        ui.horizontal(|ui| {
            let label = ui.label("Tactile display on");
            let mut output = self.tactile.as_ref().map(|(o, _)| o.clone());
            pick(ui, label.id, "tactile output", &mut output, outputs);
            let channels = output
                .as_ref()
                .and_then(|o| outputs.iter().find(|x| x.name == *o))
                .map_or(1, |o| o.channels.max(1));
            self.tactile = output.map(|o| {
                let c = self.tactile.as_ref().map_or(0, |(_, c)| *c);
                (o, c.min(channels - 1))
            });
            if let Some((_, c)) = &mut self.tactile {
                let mut one_based = *c + 1;
                let label = ui.label("channel");
                ui.add(egui::DragValue::new(&mut one_based).range(1..=channels))
                    .labelled_by(label.id);
                *c = one_based - 1;
            }
            ui.label(RichText::new("every model's 600 Hz drive, with a device").weak());
        });
    }
}

/// A combo box of `outputs` and "(none)" into `chosen`, labelled by the
/// widget `label`.
fn pick(
    ui: &mut egui::Ui,
    label: egui::Id,
    id: &str,
    chosen: &mut Option<String>,
    outputs: &[Output],
) {
    egui::ComboBox::from_id_salt(id)
        .selected_text(chosen.clone().unwrap_or_else(|| "(none)".to_owned()))
        .show_ui(ui, |ui| {
            ui.selectable_value(chosen, None, "(none)");
            for o in outputs {
                ui.selectable_value(chosen, Some(o.name.clone()), &o.name);
            }
        })
        .response
        .labelled_by(label);
}

impl Held {
    /// The held peak at `now`, falling since it was raised.
    fn level(self, now: f64) -> f32 {
        #[allow(clippy::cast_possible_truncation)]
        let since = (now - self.at).max(0.0) as f32;
        self.dbfs - METER_FALL_DB_PER_S * since
    }
}
