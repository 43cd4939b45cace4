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
//!
//! The views follow egui's demo pattern: each panel is a struct holding its
//! own state, with a `ui` method that draws it and returns the commands.
//! This module is the app (state, commands, frame loop, [`run`]); the panels
//! are `setup` (protocol, participant, folder, seed, device, start or
//! resume), `session` (progress, controls, prompts, device status, notes) with
//! its live `plot`, and `participant` (the participant's screens); `frames`
//! keeps the frame-time statistics.

mod builder;
mod check;
mod choose;
mod frames;
pub(crate) mod participant;
mod plot;
mod results;
mod session;
mod setup;
mod sound;

use std::path::PathBuf;

use eframe::egui::{self, Color32, RichText};

pub use frames::FrameStats;
pub use participant::{WORKSPACE_HALF_M, to_m, to_screen};

use crate::protocol::engine::{Answer, Choice, Input};
use crate::session::{DeviceChoice, Feed, LiveSession, SessionState};
use builder::BuilderPanel;
use results::ResultsPanel;
use session::SessionPanel;
use setup::SetupPanel;

/// The colour of errors on the experimenter's screen.
const ERROR_RED: Color32 = Color32::from_rgb(230, 80, 60);

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
    /// Signals that end the window (issue 31): a session open is ended as
    /// [`Feed::Signal`] says, then the window closes.
    pub interrupt: Option<crate::interrupt::Interrupt>,
    /// liblsl, loaded by `--lsl`: the setup's "Publish on LSL" starts
    /// checked (issue 34).
    pub lsl: Option<std::sync::Arc<crate::lsl::Lsl>>,
    /// The liblsl `--lsl-lib` named, for a session published when the box
    /// is checked in the window.
    pub lsl_lib: Option<PathBuf>,
    /// The sound server, and the outputs `--masking-audio` and
    /// `--tactile-audio` chose (Setup's Sound starts with them).
    pub sound: crate::session::sound::SoundChoice,
}

/// A session started as the window opens.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct AutoStart {
    /// Resume the participant's unfinished session.
    pub resume: bool,
    /// Resume it if there is one, else start a new session (`gui --start`).
    pub or_resume: bool,
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
            interrupt: None,
            lsl: None,
            lsl_lib: None,
            sound: crate::session::sound::SoundChoice::default(),
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
#[must_use]
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
    /// The experimenter did what the device asked.
    ConfirmDevice,
    /// A typed magnitude.
    Magnitude(String),
    /// A paired-comparison answer.
    Paired(Choice),
    /// Explore the other paired stimulus.
    Switch(usize),
    /// A Fitts click.
    Click,
    /// An input a kind's own screen gave.
    Input(Input),
    /// The pointer's position over the workspace, m.
    HandTarget(Option<f64>),
    /// Save the note typed in into the session log.
    SaveNote,
    /// Show the setup, the results folder or the protocol builder.
    Show(Tab),
    /// Set up a session with the protocol file just saved by the builder.
    UseProtocol(PathBuf),
    /// Analyse the results folder in the background.
    Analyze,
    /// Open the analysis report in the system's browser.
    OpenReport,
    /// Resume the unfinished session with this log.
    ResumeLog(PathBuf),
    /// Start the bring-up check of the device chosen (issue 63).
    CheckDevice,
    /// The experimenter did what the check asked.
    CheckConfirm,
    /// Stop the check, or close the one that has ended.
    CheckClose,
    /// Setup's Sound: list the outputs, play a test tone.
    Sound(sound::SoundAction),
}

/// The experimenter's panels when no session is open.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Tab {
    /// Set up (and start or resume) a session.
    Setup,
    /// The results folder at a glance, and its analysis.
    Results,
    /// The protocol builder.
    Builder,
}

/// The application: the setup and session panels, the live session, and
/// the participant's view.
pub struct FrictionlabApp {
    setup: SetupPanel,
    session: SessionPanel,
    results: ResultsPanel,
    builder: BuilderPanel,
    /// The panel shown when no session is open.
    tab: Tab,
    /// egui's clock at the last frame, s.
    now: f64,
    live: Option<LiveSession>,
    error: Option<String>,
    /// The participant's magnitude being typed.
    answer: String,
    frames: FrameStats,
    /// The participant's workspace strip as last drawn.
    canvas: Option<egui::Rect>,
    interrupt: Option<crate::interrupt::Interrupt>,
    /// The bring-up check in the Setup tab, while it is shown.
    check: Option<check::CheckPanel>,
}

impl FrictionlabApp {
    /// A window set up from `launch`.
    #[must_use]
    pub fn new(launch: Launch) -> Self {
        let start = launch.start;
        let interrupt = launch.interrupt.clone();
        let mut app = FrictionlabApp {
            setup: SetupPanel::new(launch),
            session: SessionPanel::default(),
            results: ResultsPanel::default(),
            builder: BuilderPanel::default(),
            tab: Tab::Setup,
            now: 0.0,
            live: None,
            error: None,
            answer: String::new(),
            frames: FrameStats::default(),
            canvas: None,
            interrupt,
            check: None,
        };
        if let Some(start) = start {
            let resume = start.resume || (start.or_resume && app.setup.has_unfinished());
            app.apply(Command::Start { resume });
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

    /// Setup's level meter of the sound output `output`, dBFS peak
    /// (`None`: silent).
    #[must_use]
    pub fn sound_meter_dbfs(&self, output: &str) -> Option<f32> {
        self.setup.sound.meter_dbfs(output)
    }

    /// Frame-time statistics.
    #[must_use]
    pub fn frames(&self) -> &FrameStats {
        &self.frames
    }

    fn apply(&mut self, command: Command) {
        let result = match command {
            Command::Shipped(i) => {
                self.setup.select_shipped(i);
                Ok(())
            }
            Command::LoadFile => {
                self.setup.load_file();
                Ok(())
            }
            Command::RefreshPorts => {
                self.setup.refresh_ports();
                Ok(())
            }
            Command::Start { resume } => self.setup.start(resume).map(|live| {
                self.live = Some(live);
                self.error = None;
                self.answer.clear();
                self.session.new_session();
            }),
            Command::Pause => self.with_live(|l| l.feed(Feed::Pause)),
            Command::Resume => self.with_live(|l| l.feed(Feed::Resume)),
            Command::Abort => self.with_live(|l| l.feed(Feed::Abort)),
            Command::Close => {
                self.live = None;
                self.setup.forget_sessions();
                self.session.new_session();
                Ok(())
            }
            Command::Continue => self.with_live(|l| l.feed(Feed::Input(Input::Continue))),
            Command::ConfirmDevice => self.with_live(|l| l.feed(Feed::Confirm)),
            Command::Magnitude(text) => {
                let r =
                    self.with_live(|l| l.feed(Feed::Input(Input::Answer(Answer::Magnitude(text)))));
                if self
                    .live
                    .as_ref()
                    .is_some_and(|l| l.view().refused.is_none())
                {
                    self.answer.clear();
                }
                r
            }
            Command::Paired(c) => {
                self.with_live(|l| l.feed(Feed::Input(Input::Answer(Answer::Paired(c)))))
            }
            Command::Switch(i) => self.with_live(|l| l.feed(Feed::Input(Input::Switch(i)))),
            Command::Click => self.with_live(|l| l.feed(Feed::Click)),
            Command::Input(input) => self.with_live(|l| l.feed(Feed::Input(input))),
            Command::HandTarget(x) => {
                if let Some(l) = &mut self.live {
                    l.set_hand_target(x);
                }
                Ok(())
            }
            Command::Show(tab) => {
                self.tab = tab;
                Ok(())
            }
            Command::UseProtocol(path) => {
                self.setup.use_file(&path);
                self.tab = Tab::Setup;
                Ok(())
            }
            Command::Analyze => {
                self.results.start_analysis(self.setup.folder(), self.now);
                Ok(())
            }
            Command::OpenReport => {
                self.results.open_report();
                Ok(())
            }
            Command::ResumeLog(log) => self.setup.use_session(&log).and_then(|()| {
                self.tab = Tab::Setup;
                self.setup.start(true).map(|live| {
                    self.live = Some(live);
                    self.error = None;
                    self.answer.clear();
                    self.session.new_session();
                })
            }),
            Command::CheckDevice
            | Command::CheckConfirm
            | Command::CheckClose
            | Command::Sound(_) => self.apply_setup(&command),
            Command::SaveNote => match self.session.note_to_save() {
                None => Ok(()),
                Some(text) => {
                    let r = self.with_live(|l| l.feed(Feed::Note(text)));
                    if r.is_ok() {
                        self.session.note_saved();
                    }
                    r
                }
            },
        };
        if let Err(e) = result {
            self.error = Some(e);
        }
    }

    /// The commands of the bring-up check and of Setup's Sound.
    fn apply_setup(&mut self, command: &Command) -> Result<(), String> {
        match command {
            Command::Sound(action) => {
                self.setup.sound.apply(action.clone());
                Ok(())
            }
            Command::CheckDevice => self.setup.start_check().map(|c| {
                self.check = Some(c);
                self.error = None;
            }),
            Command::CheckConfirm => {
                if let Some(c) = &mut self.check {
                    c.confirm();
                }
                Ok(())
            }
            _ => {
                self.check = None;
                Ok(())
            }
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

    /// The experimenter's view: the setup panel, or the open session's.
    #[must_use]
    fn experimenter(&mut self, ui: &mut egui::Ui) -> Vec<Command> {
        ui.heading("frictionlab: experimenter");
        if let Some(e) = &self.error {
            ui.label(RichText::new(e).color(ERROR_RED));
        }
        ui.separator();
        let commands = if let Some(live) = &self.live {
            ui.label(format!(
                "Protocol {} · participant {} · folder {} · plan seed {}",
                self.setup.protocol_label(),
                live.participant(),
                self.setup.folder(),
                live.plan_seed()
            ));
            ui.separator();
            self.session.ui(ui, live)
        } else {
            let mut commands = Vec::new();
            ui.horizontal(|ui| {
                for (tab, text) in [
                    (Tab::Setup, "Set up a session"),
                    (Tab::Results, "Results"),
                    (Tab::Builder, "Build a protocol"),
                ] {
                    if ui
                        .selectable_label(self.tab == tab, RichText::new(text).size(16.0))
                        .clicked()
                    {
                        commands.push(Command::Show(tab));
                    }
                }
            });
            ui.separator();
            match self.tab {
                Tab::Setup => match &self.check {
                    Some(check) => commands.extend(check.ui(ui)),
                    None => commands.extend(self.setup.ui(ui)),
                },
                Tab::Results => {
                    let folder = self.setup.folder().to_owned();
                    commands.extend(self.results.ui(ui, &folder, self.now));
                }
                Tab::Builder => {
                    let device = self.setup.device().clone();
                    commands.extend(self.builder.ui(ui, self.now, &device));
                }
            }
            commands
        };
        ui.separator();
        ui.label(RichText::new(self.frames.summary()).small().weak());
        commands
    }
}

impl eframe::App for FrictionlabApp {
    fn logic(&mut self, ctx: &egui::Context, frame: &mut eframe::Frame) {
        let (now, dt) = ctx.input(|i| (i.time, f64::from(i.unstable_dt)));
        self.now = now;
        if let Some(cpu) = frame.info().cpu_usage {
            self.frames.record(f64::from(cpu), dt);
        }
        if let Some(signal) = self
            .interrupt
            .as_ref()
            .and_then(crate::interrupt::Interrupt::signal)
        {
            // Ended by a signal: the trial under way is logged as aborted,
            // then the window closes (the caller reports the signal).
            if let Some(live) = &mut self.live
                && let Err(e) = live.feed(Feed::Signal(signal))
            {
                self.error = Some(format!("error: {e}"));
            }
            ctx.send_viewport_cmd(egui::ViewportCommand::Close);
            return;
        }
        if let Some(live) = &mut self.live {
            if let Err(e) = live.feed(Feed::Frame(now)) {
                self.error = Some(format!("error: {e}"));
            }
            if matches!(live.state(), SessionState::Running | SessionState::Paused) {
                ctx.request_repaint();
            }
        }
        self.setup.sound.pump(now);
        if self.setup.sound.busy() {
            // The meter falls as time passes.
            ctx.request_repaint();
        }
        if let Some(check) = &mut self.check {
            check.pump();
            if check.running() {
                ctx.request_repaint();
            }
        }
        if self.interrupt.is_some() {
            // An idle window still notices a signal.
            ctx.request_repaint_after(std::time::Duration::from_millis(100));
        }
    }

    fn ui(&mut self, ui: &mut egui::Ui, _frame: &mut eframe::Frame) {
        if ui.input_mut(|i| i.consume_key(egui::Modifiers::COMMAND, egui::Key::Q)) {
            // Quit as the window's close button does (on_exit runs).
            ui.ctx().send_viewport_cmd(egui::ViewportCommand::Close);
        }
        let mut commands = Vec::new();
        egui::CentralPanel::default_margins().show(ui, |ui| {
            egui::ScrollArea::vertical().show(ui, |ui| commands = self.experimenter(ui));
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
                    .with_fullscreen(self.session.fullscreen());
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
            && let Err(e) = live.feed(Feed::Abort)
        {
            let _ = writeln!(err, "error: {e}");
        }
        let _ = writeln!(err, "{}", self.frames.summary());
    }
}
