//! The experimenter's window and the participant's screens (eframe/egui).
//!
//! A thin shell: it shows what the library reports and turns clicks into
//! calls. The setup reads protocols ([`crate::protocol::load`]) and lists
//! sessions and ports; a running session is a [`LiveSession`], which owns
//! the device and writes the results. The GUI never opens a port or writes a
//! file itself.
//!
//! Each frame, [`FrictionlabApp`] advances the live session to the frame's
//! time (`egui`'s input time: the wall clock in the window, the harness's
//! stepped clock in tests), draws the experimenter view in the main window
//! and the participant view in a second window (embedded as an inner window
//! where the backend has only one), and applies the [`Command`]s the views
//! returned, after drawing.

mod participant;

use std::collections::VecDeque;
use std::path::PathBuf;

use eframe::egui::{self, Color32, RichText};

pub use participant::{WORKSPACE_HALF_M, to_m, to_screen};

use crate::device::PortInfo;
use crate::protocol::engine::{Answer, Choice, Input};
use crate::protocol::{Protocol, SHIPPED, load};
use crate::results::{ResultsDir, check_participant, read_log};
use crate::session::{DeviceChoice, LiveSession, Phase, SessionRequest, percentile};

/// Frames kept for the frame-time statistics.
const FRAMES_KEPT: usize = 100_000;

/// What the window opens with (from the command line).
#[derive(Debug, Clone)]
pub struct Launch {
    /// A protocol file to load instead of the first shipped protocol.
    pub protocol: Option<PathBuf>,
    /// Participant id.
    pub participant: String,
    /// Results folder.
    pub out: PathBuf,
    /// Device.
    pub device: DeviceChoice,
    /// Start the session at once (`run --responder gui`).
    pub start: Option<AutoStart>,
}

/// A session started as the window opens.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct AutoStart {
    /// Resume the participant's unfinished session.
    pub resume: bool,
    /// Plan seed of a new session (default: drawn at random).
    pub seed: Option<u64>,
    /// Counterbalancing index (default: participants already in the folder).
    pub participant_index: Option<u32>,
}

impl Default for Launch {
    fn default() -> Self {
        Launch {
            protocol: None,
            participant: String::new(),
            out: PathBuf::from("results"),
            device: DeviceChoice::Simulated,
            start: None,
        }
    }
}

/// Opens the window and runs until it is closed.
///
/// # Errors
/// The window cannot open (no display): the reason, in one line.
pub fn run(launch: Launch) -> Result<(), String> {
    let options = eframe::NativeOptions {
        viewport: egui::ViewportBuilder::default()
            .with_title("frictionlab: experimenter")
            .with_inner_size([1000.0, 820.0]),
        renderer: eframe::Renderer::Glow,
        ..Default::default()
    };
    eframe::run_native(
        "frictionlab",
        options,
        Box::new(|_cc| Ok(Box::new(FrictionlabApp::new(launch)))),
    )
    .map_err(|e| e.to_string().replace('\n', " "))
}

/// What a view asks for; applied after the frame is drawn.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum Command {
    /// Select shipped protocol i.
    Shipped(usize),
    /// Load the protocol file typed in.
    LoadFile,
    /// List the serial ports again.
    RefreshPorts,
    /// Start a new session, or resume the unfinished one.
    Start { resume: bool },
    /// Pause the session.
    Pause,
    /// Resume after a pause.
    Resume,
    /// Abort the session (it can be resumed).
    Abort,
    /// Close a finished or aborted session's panel.
    Close,
    /// Acknowledge instructions, a break or a prompt.
    Continue,
    /// A typed magnitude.
    Magnitude(String),
    /// A paired-comparison answer.
    Paired(Choice),
    /// Explore the other paired stimulus.
    Switch(usize),
    /// A Fitts click.
    Click,
    /// The pointer's position over the workspace, m.
    HandTarget(Option<f64>),
    /// Save the note typed in into the session log.
    SaveNote,
}

/// A protocol ready to run.
struct Loaded {
    label: String,
    protocol: Protocol,
    bytes: Vec<u8>,
}

/// The participant's sessions of the chosen protocol in the chosen folder.
#[derive(Debug, Clone, PartialEq, Eq)]
struct SessionsInfo {
    key: (String, String, String),
    next: u32,
    /// (session, trials logged, planned) of an unfinished last session.
    unfinished: Option<(u32, usize, usize)>,
    error: Option<String>,
}

/// Frame-time statistics from egui's own timing.
#[derive(Debug, Clone, Default)]
pub struct FrameStats {
    /// CPU time of each frame (eframe's `cpu_usage`: UI and painting, not
    /// vsync), s.
    pub cpu_s: VecDeque<f64>,
    /// Time between frames (egui's `unstable_dt`), s.
    pub interval_s: VecDeque<f64>,
}

impl FrameStats {
    fn push(list: &mut VecDeque<f64>, value: f64) {
        if list.len() == FRAMES_KEPT {
            list.pop_front();
        }
        list.push_back(value);
    }

    /// `median / p99 over n frames` of CPU time and interval, in ms.
    #[must_use]
    pub fn summary(&self) -> String {
        let ms = |v: Option<f64>| v.map_or("-".into(), |s| format!("{:.2}", s * 1e3));
        format!(
            "frame time: cpu median {} ms, p99 {} ms; interval median {} ms, p99 {} ms ({} frames)",
            ms(percentile(&self.cpu_s, 0.5)),
            ms(percentile(&self.cpu_s, 0.99)),
            ms(percentile(&self.interval_s, 0.5)),
            ms(percentile(&self.interval_s, 0.99)),
            self.cpu_s.len()
        )
    }
}

/// The application: setup, the live session, and the two views.
pub struct FrictionlabApp {
    choice: Option<usize>,
    file: String,
    loaded: Result<Loaded, Vec<String>>,
    participant: String,
    out: String,
    seed: String,
    device: DeviceChoice,
    ports: Result<Vec<PortInfo>, String>,
    sessions: Option<SessionsInfo>,
    live: Option<LiveSession>,
    error: Option<String>,
    note: String,
    notes_saved: usize,
    answer: String,
    frames: FrameStats,
    canvas: Option<egui::Rect>,
    fullscreen: bool,
    participant_index: Option<u32>,
}

impl FrictionlabApp {
    /// A window set up from `launch`.
    #[must_use]
    pub fn new(launch: Launch) -> Self {
        let mut app = FrictionlabApp {
            choice: Some(0),
            file: String::new(),
            loaded: Err(Vec::new()),
            participant: launch.participant,
            out: launch.out.display().to_string(),
            seed: String::new(),
            device: launch.device,
            ports: crate::device::list_ports(),
            sessions: None,
            live: None,
            error: None,
            note: String::new(),
            notes_saved: 0,
            answer: String::new(),
            frames: FrameStats::default(),
            canvas: None,
            fullscreen: false,
            participant_index: None,
        };
        match launch.protocol {
            Some(path) => {
                app.file = path.display().to_string();
                app.apply(Command::LoadFile);
            }
            None => app.apply(Command::Shipped(0)),
        }
        if let Some(start) = launch.start {
            if let Some(seed) = start.seed {
                app.seed = seed.to_string();
            }
            app.participant_index = start.participant_index;
            app.apply(Command::Start {
                resume: start.resume,
            });
        }
        app
    }

    /// The live session, if one is open.
    #[must_use]
    pub fn live(&self) -> Option<&LiveSession> {
        self.live.as_ref()
    }

    /// The last error shown, if any.
    #[must_use]
    pub fn error(&self) -> Option<&str> {
        self.error.as_deref()
    }

    /// The participant's workspace strip as last drawn (pointer position
    /// there drives the simulated hand).
    #[must_use]
    pub fn workspace(&self) -> Option<egui::Rect> {
        self.canvas
    }

    /// Frame-time statistics.
    #[must_use]
    pub fn frames(&self) -> &FrameStats {
        &self.frames
    }

    fn apply(&mut self, command: Command) {
        let result = match command {
            Command::Shipped(i) => {
                self.choice = Some(i);
                self.loaded = SHIPPED
                    .get(i)
                    .ok_or_else(|| vec![format!("no shipped protocol {i}")])
                    .and_then(|(name, text)| {
                        load::parse(text)
                            .map(|protocol| Loaded {
                                label: (*name).to_owned(),
                                protocol,
                                bytes: text.as_bytes().to_vec(),
                            })
                            .map_err(|errors| {
                                errors
                                    .iter()
                                    .map(|e| format!("{name}: {}: {}", e.place, e.message))
                                    .collect()
                            })
                    });
                Ok(())
            }
            Command::LoadFile => {
                self.choice = None;
                let path = PathBuf::from(self.file.trim());
                self.loaded = load::read(&path)
                    .map(|(protocol, bytes)| Loaded {
                        label: path.display().to_string(),
                        protocol,
                        bytes,
                    })
                    .map_err(|errors| {
                        errors
                            .iter()
                            .map(|e| format!("{}: {}", e.place, e.message))
                            .collect()
                    });
                Ok(())
            }
            Command::RefreshPorts => {
                self.ports = crate::device::list_ports();
                Ok(())
            }
            Command::Start { resume } => self.start(resume),
            Command::Pause => self.with_live(LiveSession::pause),
            Command::Resume => self.with_live(LiveSession::resume),
            Command::Abort => self.with_live(LiveSession::abort),
            Command::Close => {
                self.live = None;
                self.sessions = None;
                self.notes_saved = 0;
                Ok(())
            }
            Command::Continue => self.with_live(|l| l.input(Input::Continue)),
            Command::Magnitude(text) => {
                let r = self.with_live(|l| l.input(Input::Answer(Answer::Magnitude(text))));
                if self
                    .live
                    .as_ref()
                    .is_some_and(|l| l.view().refused.is_none())
                {
                    self.answer.clear();
                }
                r
            }
            Command::Paired(c) => self.with_live(|l| l.input(Input::Answer(Answer::Paired(c)))),
            Command::Switch(i) => self.with_live(|l| l.input(Input::Switch(i))),
            Command::Click => self.with_live(LiveSession::click),
            Command::HandTarget(x) => {
                if let Some(l) = &mut self.live {
                    l.set_hand_target(x);
                }
                Ok(())
            }
            Command::SaveNote => {
                let text = self.note.trim().to_owned();
                if text.is_empty() {
                    Ok(())
                } else {
                    let r = self.with_live(|l| l.note(&text));
                    if r.is_ok() {
                        self.note.clear();
                        self.notes_saved += 1;
                    }
                    r
                }
            }
        };
        if let Err(e) = result {
            self.error = Some(e);
        }
    }

    fn with_live(
        &mut self,
        f: impl FnOnce(&mut LiveSession) -> Result<(), crate::results::ResultsError>,
    ) -> Result<(), String> {
        match &mut self.live {
            Some(live) => f(live).map_err(|e| format!("error: {e}")),
            None => Ok(()),
        }
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
        if let DeviceChoice::Port(p) = &self.device
            && p.as_os_str().is_empty()
        {
            problems.push("choose a serial port".to_owned());
        }
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

    fn start(&mut self, resume: bool) -> Result<(), String> {
        let problems = self.start_problems();
        if !problems.is_empty() {
            return Err(format!("cannot start: {}", problems.join("; ")));
        }
        let Ok(loaded) = &self.loaded else {
            return Ok(());
        };
        let seed = self.parsed_seed()?.unwrap_or_else(rand::random::<u64>);
        let participant = self.participant.trim().to_owned();
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
        };
        let dir = ResultsDir::new(self.out.trim());
        let live = LiveSession::start(&dir, &req).map_err(|e| format!("error: {e}"))?;
        self.live = Some(live);
        self.error = None;
        self.answer.clear();
        self.notes_saved = 0;
        Ok(())
    }

    /// Recomputes the participant's sessions when protocol, folder or id
    /// changed.
    fn refresh_sessions(&mut self) {
        let Ok(loaded) = &self.loaded else {
            self.sessions = None;
            return;
        };
        let key = (
            self.out.trim().to_owned(),
            loaded.protocol.id.clone(),
            self.participant.trim().to_owned(),
        );
        if self.sessions.as_ref().is_some_and(|s| s.key == key) {
            return;
        }
        let mut info = SessionsInfo {
            key: key.clone(),
            next: 1,
            unfinished: None,
            error: None,
        };
        if check_participant(&key.2).is_ok() {
            match ResultsDir::new(&key.0).sessions(&key.1, &key.2) {
                Ok(sessions) => {
                    if let Some(last) = sessions.last() {
                        info.next = last.session + 1;
                        match read_log(&last.log) {
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

    fn experimenter(&mut self, ui: &mut egui::Ui, commands: &mut Vec<Command>) {
        ui.heading("frictionlab: experimenter");
        if let Some(e) = &self.error {
            ui.label(RichText::new(e).color(Color32::from_rgb(230, 80, 60)));
        }
        ui.separator();
        if let Some(live) = &self.live {
            let protocol = self.loaded.as_ref().map_or("", |l| l.label.as_str());
            ui.label(format!(
                "Protocol {protocol} · participant {} · folder {} · plan seed {}",
                live.participant(),
                self.out.trim(),
                live.plan_seed()
            ));
            ui.separator();
            self.session_panel(ui, commands);
        } else {
            self.setup(ui, commands);
        }
        ui.separator();
        ui.label(RichText::new(self.frames.summary()).small().weak());
    }

    fn setup(&mut self, ui: &mut egui::Ui, commands: &mut Vec<Command>) {
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
                });
                ui.end_row();
                ui.label("");
                match &self.loaded {
                    Ok(l) => {
                        let plan = crate::protocol::plan::resolve(&l.protocol, 0, 0);
                        ui.label(format!(
                            "{}: {} ({}, {} trials per session)",
                            l.label,
                            l.protocol.title,
                            l.protocol.design.kind().as_str(),
                            plan.trials.len()
                        ));
                    }
                    Err(errors) => {
                        ui.vertical(|ui| {
                            for e in errors {
                                ui.label(
                                    RichText::new(e)
                                        .monospace()
                                        .color(Color32::from_rgb(230, 80, 60)),
                                );
                            }
                        });
                    }
                }
                ui.end_row();
                let label = ui.label("Participant id");
                ui.horizontal(|ui| {
                    ui.add(egui::TextEdit::singleline(&mut self.participant).desired_width(200.0))
                        .labelled_by(label.id);
                    let id = self.participant.trim();
                    if !id.is_empty()
                        && let Err(m) = check_participant(id)
                    {
                        ui.label(RichText::new(m).color(Color32::from_rgb(230, 80, 60)));
                    }
                });
                ui.end_row();
                let label = ui.label("Output folder");
                ui.add(egui::TextEdit::singleline(&mut self.out).desired_width(420.0))
                    .labelled_by(label.id);
                ui.end_row();
                let label = ui.label("Plan seed");
                ui.horizontal(|ui| {
                    ui.add(egui::TextEdit::singleline(&mut self.seed).desired_width(200.0))
                        .labelled_by(label.id);
                    ui.label(RichText::new("empty: drawn at random and logged").weak());
                });
                ui.end_row();
                ui.label("Device");
                self.device_picker(ui, commands);
                ui.end_row();
                ui.label("Session");
                self.session_choice(ui, commands);
                ui.end_row();
            });
    }

    fn device_picker(&mut self, ui: &mut egui::Ui, commands: &mut Vec<Command>) {
        ui.vertical(|ui| {
            ui.radio_value(
                &mut self.device,
                DeviceChoice::Simulated,
                "Simulated device (the mouse is the hand)",
            );
            ui.horizontal(|ui| {
                let on_port = matches!(self.device, DeviceChoice::Port(_));
                if ui.radio(on_port, "Serial port").clicked() && !on_port {
                    let first = self
                        .ports
                        .as_ref()
                        .ok()
                        .and_then(|p| p.first())
                        .map(|p| PathBuf::from(&p.path))
                        .unwrap_or_default();
                    self.device = DeviceChoice::Port(first);
                }
                let current = match &self.device {
                    DeviceChoice::Port(p) => p.display().to_string(),
                    DeviceChoice::Simulated => String::new(),
                };
                egui::ComboBox::from_label("port")
                    .selected_text(if current.is_empty() {
                        "(none)".into()
                    } else {
                        current
                    })
                    .show_ui(ui, |ui| {
                        if let Ok(ports) = &self.ports {
                            for p in ports {
                                let text = format!("{}  {}", p.path, p.kind);
                                if ui.selectable_label(false, text).clicked() {
                                    self.device = DeviceChoice::Port(PathBuf::from(&p.path));
                                }
                            }
                        }
                    });
                if ui.button("Refresh ports").clicked() {
                    commands.push(Command::RefreshPorts);
                }
                match &self.ports {
                    Ok(p) if p.is_empty() => {
                        ui.label(RichText::new("no serial ports found").weak());
                    }
                    Ok(_) => {}
                    Err(e) => {
                        ui.label(RichText::new(format!("cannot list ports: {e}")).weak());
                    }
                }
            });
        });
    }

    fn session_choice(&mut self, ui: &mut egui::Ui, commands: &mut Vec<Command>) {
        self.refresh_sessions();
        let problems = self.start_problems();
        ui.vertical(|ui| {
            if let Some(info) = &self.sessions {
                if let Some(e) = &info.error {
                    ui.label(RichText::new(e).color(Color32::from_rgb(230, 80, 60)));
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
            if !problems.is_empty() && self.live.is_none() {
                ui.label(RichText::new(format!("To start: {}.", problems.join("; "))).weak());
            }
        });
    }

    fn session_panel(&mut self, ui: &mut egui::Ui, commands: &mut Vec<Command>) {
        let Some(live) = &self.live else {
            return;
        };
        let p = live.progress();
        let phase = live.phase();
        let remaining = p
            .remaining_s
            .map_or("unknown until a trial ends".into(), |s| {
                format!("about {s:.0} s")
            });
        ui.heading(format!(
            "Session {}: {}",
            live.session(),
            match phase {
                Phase::Running => "running",
                Phase::Paused => "paused",
                Phase::Finished => "finished",
                Phase::Aborted => "aborted (it can be resumed)",
            }
        ));
        ui.label(format!(
            "Trial {} of {} · block {} · elapsed {:.1} s · remaining {remaining}",
            p.trial, p.total, p.block, p.elapsed_s
        ));
        #[expect(clippy::cast_possible_truncation, reason = "a progress fraction")]
        let fraction = if phase == Phase::Finished {
            1.0
        } else {
            (p.trial.saturating_sub(1) as f64 / p.total.max(1) as f64) as f32
        };
        ui.add(egui::ProgressBar::new(fraction).show_percentage());
        ui.horizontal(|ui| match phase {
            Phase::Running => {
                if ui.button("Pause").clicked() {
                    commands.push(Command::Pause);
                }
                if ui.button("Abort session").clicked() {
                    commands.push(Command::Abort);
                }
            }
            Phase::Paused => {
                if ui.button("Resume").clicked() {
                    commands.push(Command::Resume);
                }
                if ui.button("Abort session").clicked() {
                    commands.push(Command::Abort);
                }
            }
            Phase::Finished | Phase::Aborted => {
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
        trace_plot(ui, live);
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

/// Position (mm), force (N) and vibrotactile envelope over the last seconds, on
/// a shared time axis.
fn trace_plot(ui: &mut egui::Ui, live: &LiveSession) {
    use egui_plot::{Legend, Line, Plot, PlotPoints};
    let trace = live.trace();
    let x: Vec<[f64; 2]> = trace.iter().map(|p| [p.t_s, p.x_m * 1e3]).collect();
    let f: Vec<[f64; 2]> = trace.iter().map(|p| [p.t_s, p.force_n]).collect();
    let vibration: Vec<[f64; 2]> = trace.iter().map(|p| [p.t_s, p.vibration]).collect();
    let link = egui::Id::unique("trace-time");
    let height = ((ui.available_height() - 30.0) / 2.0).max(80.0);
    // A fixed view: the plots follow the trace, not the pointer.
    let plot = |id: &str| {
        Plot::new(id)
            .height(height)
            .legend(Legend::default())
            .link_axis(link, [true, false])
            .allow_drag(false)
            .allow_zoom(false)
            .allow_scroll(false)
    };
    plot("position")
        .y_axis_label("position (mm)")
        .show(ui, |plot| {
            plot.line(Line::new("position (mm)", PlotPoints::from(x)));
        });
    plot("force")
        .x_axis_label("session time (s)")
        .y_axis_label("force (N), drive")
        .show(ui, |plot| {
            plot.line(Line::new("force (N)", PlotPoints::from(f)));
            plot.line(Line::new(
                "vibrotactile envelope (0..1)",
                PlotPoints::from(vibration),
            ));
        });
}

impl eframe::App for FrictionlabApp {
    fn logic(&mut self, ctx: &egui::Context, frame: &mut eframe::Frame) {
        let (now, dt) = ctx.input(|i| (i.time, f64::from(i.unstable_dt)));
        if let Some(cpu) = frame.info().cpu_usage {
            FrameStats::push(&mut self.frames.cpu_s, f64::from(cpu));
            FrameStats::push(&mut self.frames.interval_s, dt);
        }
        if let Some(live) = &mut self.live {
            if let Err(e) = live.advance(now) {
                self.error = Some(format!("error: {e}"));
            }
            if matches!(live.phase(), Phase::Running | Phase::Paused) {
                ctx.request_repaint();
            }
        }
    }

    fn ui(&mut self, ui: &mut egui::Ui, _frame: &mut eframe::Frame) {
        if ui.input_mut(|i| i.consume_key(egui::Modifiers::COMMAND, egui::Key::Q)) {
            // Quit as the window's close button does (on_exit runs).
            ui.ctx().send_viewport_cmd(egui::ViewportCommand::Close);
        }
        let mut commands = Vec::new();
        egui::CentralPanel::default_margins().show(ui, |ui| {
            egui::ScrollArea::vertical().show(ui, |ui| self.experimenter(ui, &mut commands));
        });
        if let Some(live) = &self.live {
            let answer = &mut self.answer;
            let canvas = &mut self.canvas;
            let commands = &mut commands;
            let mut draw = |ui: &mut egui::Ui| {
                egui::CentralPanel::default_margins().show(ui, |ui| {
                    participant::show(ui, live, answer, commands, canvas);
                });
            };
            let title = "frictionlab: participant";
            let size = [900.0, 560.0];
            // Beside the experimenter's 1000 px wide window.
            let position = [1010.0, 0.0];
            let ctx = ui.ctx().clone();
            if ctx.embed_viewports() {
                // One native window only (tests, some platforms): an inner
                // window, placed beside the experimenter's controls.
                egui::Window::new(title)
                    .default_pos(position)
                    .default_size(size)
                    .collapsible(false)
                    .show(&ctx, |ui| draw(ui));
            } else {
                let builder = egui::ViewportBuilder::default()
                    .with_title(title)
                    .with_inner_size(size)
                    .with_position(position)
                    .with_fullscreen(self.fullscreen);
                ctx.show_viewport_immediate(
                    egui::ViewportId::from_hash_of("participant"),
                    builder,
                    |ui, _class| draw(ui),
                );
            }
        }
        for c in commands {
            self.apply(c);
        }
    }

    fn on_exit(&mut self, _gl: Option<&eframe::glow::Context>) {
        use std::io::Write as _;
        // A broken standard error has nowhere left to be reported.
        let mut err = std::io::stderr().lock();
        if let Some(live) = &mut self.live
            && let Err(e) = live.abort()
        {
            let _ = writeln!(err, "error: {e}");
        }
        let _ = writeln!(err, "{}", self.frames.summary());
    }
}
