//! The setup panel: what the experimenter chooses before a session (the
//! protocol, shipped or from a file; participant id; output folder; plan
//! seed; device), the participant's sessions so far in that folder, and the
//! Start and Resume buttons. It draws its state and returns [`Command`]s;
//! the app applies them after the frame, through the methods here.

use std::path::{Path, PathBuf};

use eframe::egui::{self, RichText};

use super::{Command, ERROR_RED, Launch};
use crate::device::Address;
use crate::kinds::{Protocol, Registry};
use crate::protocol::{SHIPPED, load};
use crate::results::{ResultsDir, check_participant, read_log};
use crate::session::{DeviceChoice, LiveSession, SessionRequest};

/// A protocol ready to run.
struct Loaded {
    label: String,
    protocol: Protocol,
    bytes: Vec<u8>,
    /// Trials in a session (its plan resolved once, at load).
    trials: String,
}

impl Loaded {
    fn new(label: String, protocol: Protocol, bytes: Vec<u8>) -> Self {
        let trials = protocol.trials_per_session();
        Loaded {
            label,
            protocol,
            bytes,
            trials,
        }
    }
}

/// The participant's sessions of the chosen protocol in the chosen folder.
#[derive(Debug, Clone, PartialEq)]
struct SessionsInfo {
    key: (String, String, String),
    next: u32,
    /// (session, trials logged, planned) of an unfinished last session.
    unfinished: Option<(u32, usize, usize)>,
    /// Why no session of the participant can start or resume here: one is
    /// open in another process (issue 31).
    busy: Option<String>,
    error: Option<String>,
    /// When this was read (egui's clock, s): a session open elsewhere
    /// ends without telling, so it is read again every second.
    read_at: f64,
}

/// How often the participant's sessions are read again, s.
const SESSIONS_EVERY_S: f64 = 1.0;

/// What the setup panel keeps between frames.
pub(super) struct SetupPanel {
    /// The shipped protocol chosen, if one is.
    choice: Option<usize>,
    /// The protocol file typed in.
    file: String,
    /// The protocol chosen or loaded, or why it cannot run.
    loaded: Result<Loaded, Vec<String>>,
    participant: String,
    out: String,
    seed: String,
    device: DeviceChoice,
    ports: Vec<(&'static crate::device::Kind, crate::device::Found)>,
    /// Recomputed when protocol, folder or participant change.
    sessions: Option<SessionsInfo>,
    /// Counterbalancing index given on the command line.
    participant_index: Option<u32>,
    /// Publish the session on the Lab Streaming Layer (issue 34).
    lsl: bool,
    /// liblsl loaded by `--lsl`, or the file `--lsl-lib` named.
    lsl_lib: (Option<std::sync::Arc<crate::lsl::Lsl>>, Option<PathBuf>),
    /// Why the desktop's chooser gave no path, if it did not.
    chooser: Option<String>,
    /// The bring-up check: the simulated experimenter does what it asks
    /// (an emulated device), and how long it measures the loop, s.
    check_sim: bool,
    check_duration_s: f64,
    /// The sound outputs, their test tones and meters, and what a session
    /// plays on (issue 64).
    pub(super) sound: super::sound::SoundPanel,
}

impl SetupPanel {
    /// The setup `launch` asks for, its protocol loaded.
    pub(super) fn new(launch: Launch) -> Self {
        let mut setup = SetupPanel {
            choice: Some(0),
            file: String::new(),
            loaded: Err(Vec::new()),
            participant: launch.participant,
            out: launch.out.display().to_string(),
            seed: String::new(),
            device: launch.device,
            ports: crate::device::find_all(),
            sessions: None,
            participant_index: None,
            lsl: launch.lsl.is_some(),
            lsl_lib: (launch.lsl, launch.lsl_lib),
            chooser: None,
            check_sim: false,
            check_duration_s: crate::device::check::DEFAULT_DURATION_S,
            sound: super::sound::SoundPanel::new(launch.sound),
        };
        match launch.protocol {
            Some(path) => {
                setup.file = path.display().to_string();
                setup.load_file();
            }
            None => setup.select_shipped(0),
        }
        if let Some(start) = launch.start {
            if let Some(seed) = start.seed {
                setup.seed = seed.to_string();
            }
            setup.participant_index = start.participant_index;
        }
        setup
    }

    /// The chosen protocol's label (shipped name or file path), or "".
    pub(super) fn protocol_label(&self) -> &str {
        self.loaded.as_ref().map_or("", |l| l.label.as_str())
    }

    /// The output folder typed in, trimmed.
    pub(super) fn folder(&self) -> &str {
        self.out.trim()
    }

    /// Selects shipped protocol `i`.
    pub(super) fn select_shipped(&mut self, i: usize) {
        self.choice = Some(i);
        self.loaded = SHIPPED
            .get(i)
            .ok_or_else(|| vec![format!("no shipped protocol {i}")])
            .and_then(|(name, text)| {
                load::parse(text)
                    .map(|protocol| {
                        Loaded::new((*name).to_owned(), protocol, text.as_bytes().to_vec())
                    })
                    .map_err(|errors| {
                        errors
                            .iter()
                            .map(|e| format!("{name}: {}: {}", e.place, e.message))
                            .collect()
                    })
            });
    }

    /// Loads the protocol file typed in.
    pub(super) fn load_file(&mut self) {
        self.choice = None;
        let path = PathBuf::from(self.file.trim());
        self.loaded = load::read(&path)
            .map(|(protocol, bytes)| Loaded::new(path.display().to_string(), protocol, bytes))
            .map_err(|errors| {
                errors
                    .iter()
                    .map(|e| format!("{}: {}", e.place, e.message))
                    .collect()
            });
    }

    /// Loads the protocol file at `path` (one the builder saved).
    pub(super) fn use_file(&mut self, path: &std::path::Path) {
        self.file = path.display().to_string();
        self.load_file();
    }

    /// The device sessions run on.
    pub(super) fn device(&self) -> &DeviceChoice {
        &self.device
    }

    /// Sets the protocol and participant of a session found in the
    /// results folder (its log's), to resume it.
    pub(super) fn use_session(&mut self, log: &std::path::Path) -> Result<(), String> {
        let read = read_log::<Registry>(log).map_err(|e| format!("error: {e}"))?;
        let h = read.header;
        let bytes = serde_json::to_vec_pretty(&h.protocol).map_err(|e| format!("error: {e}"))?;
        self.choice = None;
        self.file.clear();
        self.participant.clone_from(&h.participant);
        self.sessions = None;
        self.loaded = Ok(Loaded::new(
            format!("{} (from {})", h.protocol_id, log.display()),
            h.protocol,
            bytes,
        ));
        Ok(())
    }

    /// Starts the bring-up check of the device chosen, its report kept in
    /// the output folder.
    ///
    /// # Errors
    /// No device or folder chosen, or the check cannot start.
    pub(super) fn start_check(&self) -> Result<super::check::CheckPanel, String> {
        if let DeviceChoice::Device(a) = &self.device
            && a.target.is_empty()
            && a.kind().bare
        {
            return Err("cannot check: choose a device".into());
        }
        if self.out.trim().is_empty() {
            return Err("cannot check: choose an output folder".into());
        }
        super::check::CheckPanel::start(
            &self.device,
            self.out.trim(),
            self.check_duration_s,
            self.check_sim,
        )
    }

    /// Lists the serial ports again.
    pub(super) fn refresh_ports(&mut self) {
        self.ports = crate::device::find_all();
    }

    /// Forgets the participant's sessions, so they are listed again (a
    /// session was closed).
    pub(super) fn forget_sessions(&mut self) {
        self.sessions = None;
    }

    /// The problems that keep Start disabled.
    fn start_problems(&self) -> Vec<String> {
        let mut problems = Vec::new();
        if self.loaded.is_err() {
            problems.push("choose a valid protocol".to_owned());
        }
        if let Err(m) = check_participant(self.participant.trim()) {
            problems.push(format!("participant id {m}"));
        }
        if self.out.trim().is_empty() {
            problems.push("choose an output folder".to_owned());
        }
        if let Err(m) = self.parsed_seed() {
            problems.push(m);
        }
        if let DeviceChoice::Device(a) = &self.device
            && a.target.is_empty()
            && a.kind().bare
        {
            problems.push("choose a device".to_owned());
        }
        let masking = self
            .loaded
            .as_ref()
            .ok()
            .and_then(|l| l.protocol.masking.as_ref());
        let device = matches!(self.device, DeviceChoice::Device(_));
        problems.extend(self.sound.problems(masking, device));
        problems
    }

    fn parsed_seed(&self) -> Result<Option<u64>, String> {
        let t = self.seed.trim();
        if t.is_empty() {
            return Ok(None);
        }
        t.parse()
            .map(Some)
            .map_err(|_| format!("plan seed '{t}': a whole number from 0 to 2^64-1"))
    }

    /// Starts a new session, or resumes the unfinished one, as set up.
    ///
    /// # Errors
    /// The setup is incomplete, or the session cannot open: the message
    /// to show.
    pub(super) fn start(&self, resume: bool) -> Result<LiveSession, String> {
        let problems = self.start_problems();
        // A protocol that did not load is one of the problems.
        let (true, Ok(loaded)) = (problems.is_empty(), &self.loaded) else {
            return Err(format!("cannot start: {}", problems.join("; ")));
        };
        let seed = self.parsed_seed()?.unwrap_or_else(rand::random::<u64>);
        // The outputs open before anything is written. A lost output holds
        // the session until it is back, however long: the experimenter
        // sees why and may abort it.
        let sound = crate::session::sound::Sound::open(
            loaded.protocol.masking,
            &self.sound.choice(),
            matches!(self.device, DeviceChoice::Device(_)),
            seed,
            f64::INFINITY,
        )
        .map_err(|e| format!("cannot start: sound: {e}"))?;
        let participant = self.participant.trim().to_owned();
        let lsl = match (&self.lsl, &self.lsl_lib) {
            (false, _) => None,
            (true, (Some(lsl), _)) => Some(lsl.clone()),
            (true, (None, path)) => {
                Some(crate::lsl::load(path.as_deref()).map_err(|e| format!("error: --lsl: {e}"))?)
            }
        }
        // The window does not wait for a recorder: the instructions wait
        // for the participant, and the experimenter starts LabRecorder
        // before pressing Start.
        .map(|lib| crate::lsl::Streaming { lib, wait_s: 0.0 });
        let req = SessionRequest {
            protocol: &loaded.protocol,
            protocol_bytes: &loaded.bytes,
            participant: &participant,
            participant_index: self.participant_index,
            seed,
            resume,
            pace: None,
            device: &self.device,
            streams: true,
            population: None,
            sound,
            lsl: lsl.as_ref(),
        };
        let dir = ResultsDir::new(self.out.trim());
        LiveSession::start(&dir, &req).map_err(|e| format!("error: {e}"))
    }

    /// Whether the participant has an unfinished session of the protocol
    /// in the folder, as the setup screen would offer to resume.
    pub(super) fn has_unfinished(&mut self) -> bool {
        self.refresh_sessions(f64::NEG_INFINITY);
        self.sessions
            .as_ref()
            .is_some_and(|s| s.unfinished.is_some())
    }

    /// Recomputes the participant's sessions when protocol, folder or id
    /// changed, or a second has passed (at `now`, s).
    fn refresh_sessions(&mut self, now: f64) {
        let Ok(loaded) = &self.loaded else {
            self.sessions = None;
            return;
        };
        let key = (
            self.out.trim().to_owned(),
            loaded.protocol.id.clone(),
            self.participant.trim().to_owned(),
        );
        if self
            .sessions
            .as_ref()
            .is_some_and(|s| s.key == key && (0.0..SESSIONS_EVERY_S).contains(&(now - s.read_at)))
        {
            return;
        }
        let mut info = SessionsInfo {
            key: key.clone(),
            next: 1,
            unfinished: None,
            busy: None,
            error: None,
            read_at: now,
        };
        if check_participant(&key.2).is_ok() {
            let dir = ResultsDir::new(&key.0);
            if let Err(e) = dir.free_sessions(&key.1, &key.2) {
                info.busy = Some(format!("error: {e}"));
            }
            match dir.sessions(&key.1, &key.2) {
                Ok(sessions) => {
                    if let Some(last) = sessions.last() {
                        info.next = last.session + 1;
                        match read_log::<Registry>(&last.log) {
                            Ok(read) if !read.ended => {
                                info.unfinished = Some((
                                    last.session,
                                    read.next_trial(),
                                    read.header.planned_trials,
                                ));
                            }
                            Ok(_) => {}
                            Err(e) => info.error = Some(format!("error: {e}")),
                        }
                    }
                }
                Err(e) => info.error = Some(format!("error: {e}")),
            }
        }
        self.sessions = Some(info);
    }

    /// Draws the setup form.
    #[must_use]
    pub(super) fn ui(&mut self, ui: &mut egui::Ui) -> Vec<Command> {
        let mut commands = Vec::new();
        egui::Grid::new("setup")
            .num_columns(2)
            .spacing([12.0, 8.0])
            .show(ui, |ui| {
                ui.label("Protocol");
                ui.horizontal_wrapped(|ui| {
                    for (i, (name, _)) in SHIPPED.iter().enumerate() {
                        if ui.selectable_label(self.choice == Some(i), *name).clicked() {
                            commands.push(Command::Shipped(i));
                        }
                    }
                });
                ui.end_row();
                let label = ui.label("Protocol file");
                ui.horizontal(|ui| {
                    ui.add(egui::TextEdit::singleline(&mut self.file).desired_width(420.0))
                        .labelled_by(label.id);
                    if ui.button("Load file").clicked() {
                        commands.push(Command::LoadFile);
                    }
                    if ui.button("Browse…").clicked() {
                        match super::choose::choose(super::choose::Choose::Protocol, &self.file) {
                            Ok(path) => {
                                self.file = path.display().to_string();
                                commands.push(Command::LoadFile);
                            }
                            Err(m) => self.chooser = Some(m),
                        }
                    }
                });
                ui.end_row();
                ui.label("");
                self.protocol_summary(ui);
                ui.end_row();
                let label = ui.label("Participant id");
                ui.horizontal(|ui| {
                    ui.add(egui::TextEdit::singleline(&mut self.participant).desired_width(200.0))
                        .labelled_by(label.id);
                    let id = self.participant.trim();
                    if !id.is_empty()
                        && let Err(m) = check_participant(id)
                    {
                        ui.label(RichText::new(m).color(ERROR_RED));
                    }
                });
                ui.end_row();
                let label = ui.label("Output folder");
                ui.horizontal(|ui| {
                    ui.add(egui::TextEdit::singleline(&mut self.out).desired_width(420.0))
                        .labelled_by(label.id);
                    if ui.button("Choose folder…").clicked() {
                        match super::choose::choose(super::choose::Choose::Folder, &self.out) {
                            Ok(path) => self.out = path.display().to_string(),
                            Err(m) => self.chooser = Some(m),
                        }
                    }
                });
                ui.end_row();
                if let Some(m) = &self.chooser {
                    ui.label("");
                    ui.label(RichText::new(m).weak());
                    ui.end_row();
                }
                let label = ui.label("Plan seed");
                ui.horizontal(|ui| {
                    ui.add(egui::TextEdit::singleline(&mut self.seed).desired_width(200.0))
                        .labelled_by(label.id);
                    ui.label(RichText::new("empty: drawn at random and logged").weak());
                });
                ui.end_row();
                ui.label("Device");
                self.device_picker(ui, &mut commands);
                ui.end_row();
                ui.label("Sound");
                let masking = self.loaded.as_ref().ok().and_then(|l| l.protocol.masking);
                commands.extend(self.sound.ui(ui, masking.as_ref()));
                ui.end_row();
                ui.label("Session");
                self.session_choice(ui, &mut commands);
                ui.end_row();
            });
        commands
    }

    /// The loaded protocol in one line, or its errors.
    fn protocol_summary(&self, ui: &mut egui::Ui) {
        match &self.loaded {
            Ok(l) => {
                ui.label(format!(
                    "{}: {} ({}, {})",
                    l.label,
                    l.protocol.title,
                    l.protocol.kind(),
                    l.trials
                ));
            }
            Err(errors) => {
                ui.vertical(|ui| {
                    for e in errors {
                        ui.label(RichText::new(e).monospace().color(ERROR_RED));
                    }
                });
            }
        }
    }

    fn device_picker(&mut self, ui: &mut egui::Ui, commands: &mut Vec<Command>) {
        ui.vertical(|ui| {
            ui.radio_value(
                &mut self.device,
                DeviceChoice::Simulated,
                "Simulated device (the mouse is the hand)",
            );
            ui.horizontal(|ui| {
                let on_port = matches!(self.device, DeviceChoice::Device(_));
                if ui.radio(on_port, "Device").clicked() && !on_port {
                    self.device = DeviceChoice::Device(
                        self.ports
                            .first()
                            .map_or_else(|| Address::port(Path::new("")), |(k, f)| address(k, f)),
                    );
                }
                let current = match &self.device {
                    DeviceChoice::Device(a) => a.to_string(),
                    DeviceChoice::Simulated => String::new(),
                };
                egui::ComboBox::from_label("device")
                    .selected_text(if current.is_empty() {
                        "(none)".into()
                    } else {
                        current
                    })
                    .show_ui(ui, |ui| {
                        for (kind, found) in &self.ports {
                            let a = address(kind, found);
                            let text = format!("{a}  {}", found.what);
                            if ui.selectable_label(false, text).clicked() {
                                self.device = DeviceChoice::Device(a);
                            }
                        }
                    });
                if ui.button("Refresh devices").clicked() {
                    commands.push(Command::RefreshPorts);
                }
                if self.ports.is_empty() {
                    ui.label(RichText::new("no devices found").weak());
                }
            });
            ui.horizontal(|ui| {
                if ui.button("Check device").clicked() {
                    commands.push(Command::CheckDevice);
                }
                let label = ui.label("loop timing over");
                ui.add(
                    egui::DragValue::new(&mut self.check_duration_s)
                        .range(1.0..=60.0)
                        .suffix(" s"),
                )
                .labelled_by(label.id);
                ui.checkbox(
                    &mut self.check_sim,
                    "simulated experimenter (an emulated device)",
                );
            });
            ui.checkbox(
                &mut self.lsl,
                "Publish on LSL (markers and device stream, for LabRecorder)",
            );
        });
    }

    /// The participant's sessions so far, and the Start and Resume buttons.
    /// (The setup is shown only while no session is open.)
    fn session_choice(&mut self, ui: &mut egui::Ui, commands: &mut Vec<Command>) {
        self.refresh_sessions(ui.input(|i| i.time));
        let mut problems = self.start_problems();
        ui.vertical(|ui| {
            if let Some(info) = &self.sessions {
                if let Some(e) = &info.error {
                    ui.label(RichText::new(e).color(ERROR_RED));
                }
                if let Some(busy) = &info.busy {
                    // Neither a resume nor a new session of this
                    // participant can open while one is open elsewhere.
                    ui.label(RichText::new(busy).color(ERROR_RED));
                    problems.push("wait until the session open elsewhere has ended".to_owned());
                }
                if let Some((session, done, total)) = info.unfinished {
                    ui.label(format!(
                        "Session {session} is unfinished: {done} of {total} trials done."
                    ));
                    if ui
                        .add_enabled(
                            problems.is_empty(),
                            egui::Button::new(format!("Resume session {session}")),
                        )
                        .clicked()
                    {
                        commands.push(Command::Start { resume: true });
                    }
                }
                ui.label(format!("A new session will be session {}.", info.next));
            }
            let start = ui.add_enabled(
                problems.is_empty(),
                egui::Button::new(RichText::new("Start new session").strong()),
            );
            if start.clicked() {
                commands.push(Command::Start { resume: false });
            }
            if !problems.is_empty() {
                ui.label(RichText::new(format!("To start: {}.", problems.join("; "))).weak());
            }
        });
    }
}

/// The address of a device found.
fn address(kind: &'static crate::device::Kind, found: &crate::device::Found) -> Address {
    Address {
        kind: kind.name,
        target: found.address.clone(),
        settings: crate::device::Settings::default(),
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, reason = "tests: a panic is a failure")]

    use egui_kittest::{Harness, kittest::Queryable};

    use super::*;

    /// Issue 13: the setup panel only returns what was clicked; the session
    /// opens (and its files appear) only when the app applies the command.
    #[test]
    fn a_start_click_is_returned_as_a_command_and_opens_nothing_itself() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("results");
        let launch = Launch {
            participant: "p01".into(),
            out: out.clone(),
            ..Launch::default()
        };
        let mut h = Harness::new_ui_state(
            |ui, (panel, commands): &mut (SetupPanel, Vec<Command>)| {
                commands.extend(panel.ui(ui));
            },
            (SetupPanel::new(launch), Vec::new()),
        );
        h.get_by_label("Start new session").click();
        h.step();
        h.step();
        assert_eq!(h.state().1, vec![Command::Start { resume: false }]);
        assert!(!out.exists(), "the panel wrote {}", out.display());
        let live = h.state().0.start(false).unwrap();
        assert_eq!(live.participant(), "p01");
        assert!(out.exists());
    }

    /// Issue 13: the trials per session, now counted once at load, are
    /// shown as before (the shipped quick protocol plans 6).
    #[test]
    fn the_loaded_protocol_is_shown_with_its_trials_per_session() {
        let mut panel = SetupPanel::new(Launch::default());
        let h = Harness::new_ui(move |ui| {
            let _ = panel.ui(ui);
        });
        h.get_by_label(
            "magnitude-quick.json: Quick magnitude estimation (magnitude_estimation, 6 trials per session)",
        );
    }
}
