//! The command line: parses arguments, calls the library, and is the one place
//! that turns errors into `error: <where>: <what>` lines and exit codes.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use clap::{Parser, Subcommand};

use crate::friction::{ForceLimit, ModelParams};
use crate::protocol::{Protocol, load};
use crate::render;
use crate::results::{self, ResultsError};
// A problem with the user's input is the library's one `Problem`, printed by
// `finish` as `error: <place>: <message>`.
use crate::problem::Problem as UserError;
use crate::scenario::{self, ScenarioError, ScenarioParams};
use crate::session::{self, DeviceChoice, SessionError};
use crate::settings;

/// `--device`: `sim` (the simulated apparatus) or a serial port's path.
/// Whether the path is a port is checked with the other options
/// ([`check_run_args`]), so every problem is reported at once.
#[expect(
    clippy::unnecessary_wraps,
    reason = "clap's value_parser takes a fallible function"
)]
fn parse_device(text: &str) -> Result<DeviceChoice, String> {
    Ok(if text == "sim" {
        DeviceChoice::Simulated
    } else {
        DeviceChoice::Port(PathBuf::from(text))
    })
}

/// `--responder`: who answers.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
enum ResponderChoice {
    /// A person, in the experimenter window.
    Gui,
    /// A simulated participant.
    Sim,
}

/// Exit code for bad input (a flag, a parameter, a file).
pub const EXIT_BAD_INPUT: u8 = 2;

/// Renders friction on a haptic device, runs friction-perception experiments
/// and analyses them.
#[derive(Debug, Parser)]
#[command(name = "frictionlab", version)]
pub struct Cli {
    /// Without a command: the experimenter window (`gui`).
    #[command(subcommand)]
    command: Option<Command>,
}

/// `frictionlab gui` options: what the window opens with.
#[derive(Debug, clap::Args)]
struct GuiArgs {
    /// A protocol file (default: the first shipped protocol).
    #[arg(long)]
    protocol: Option<PathBuf>,
    /// Participant id.
    #[arg(long, default_value = "")]
    participant: String,
    /// Results folder.
    #[arg(long, default_value = "results")]
    out: PathBuf,
    /// `sim` (the simulated device) or a serial port's path.
    #[arg(long, default_value = "sim", value_parser = parse_device)]
    device: DeviceChoice,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Checks protocol files; exit 0 if all are valid.
    Validate {
        /// Protocol files.
        #[arg(required = true)]
        protocols: Vec<PathBuf>,
    },
    /// Opens the experimenter window (the default without a command).
    Gui(GuiArgs),
    /// Runs one session (headless with `--device sim --responder sim`).
    Run(RunArgs),
    /// Runs N whole sessions with simulated participants on the simulated
    /// device.
    Simulate(SimulateArgs),
    /// Reads a results folder and writes summary.json, report.html and the
    /// tables (CSV and Parquet).
    Analyze {
        /// The results folder.
        dir: PathBuf,
        /// Where to write the report (default: DIR/report).
        #[arg(long)]
        out: Option<PathBuf>,
    },
    /// Fits friction parameters to recorded motion and force (seed 002);
    /// prints JSON with a `protocol_model` block for a protocol.
    Identify(IdentifyArgs),
    /// Lists serial ports.
    Ports,
    /// Runs an emulated device (the simulated apparatus) on a serial port,
    /// or on a new pseudo-terminal linked at PATH if nothing is there (a
    /// link an earlier emulator left, to a pseudo-terminal now gone, is
    /// replaced). It stays silent until a host says Hello, and serves host
    /// after host until stopped.
    DeviceEmulator {
        /// A serial port (or a link to one, left in place), or where to link
        /// a new pseudo-terminal.
        path: PathBuf,
    },
    /// Prints a JSON Schema: of protocol files, or of session log lines.
    Schema {
        /// `protocol` or `log`.
        #[arg(value_parser = ["protocol", "log"])]
        which: String,
    },
    /// Runs one friction model through a scripted scenario and writes the time
    /// series (CSV) and optionally its figure (SVG).
    Render(RenderArgs),
    /// Lists the friction models and scenarios with their default parameters
    /// (the names `render --set` accepts), as JSON.
    Models,
}

#[derive(Debug, clap::Args)]
struct RunArgs {
    /// The protocol file.
    protocol: PathBuf,
    /// Participant id: letters, digits, '-' and '_'.
    #[arg(long)]
    participant: String,
    /// Results folder.
    #[arg(long)]
    out: PathBuf,
    /// `sim` (the simulated apparatus) or a serial port path.
    #[arg(long, default_value = "sim", value_parser = parse_device)]
    device: DeviceChoice,
    /// Who answers: `gui` (a person) or `sim` (a simulated participant).
    #[arg(long, value_enum, default_value_t = ResponderChoice::Gui)]
    responder: ResponderChoice,
    /// Plan seed (default: drawn at random and logged).
    #[arg(long)]
    seed: Option<u64>,
    /// Continue the participant's last unfinished session.
    #[arg(long)]
    resume: bool,
    /// Simulated time runs X times faster than real time (default 1).
    #[arg(long, default_value_t = 1.0)]
    pace: f64,
    /// Counterbalancing index (default: participants already in the folder).
    #[arg(long)]
    participant_index: Option<u32>,
    /// With a device: give up (exit 3) after it has not answered for this
    /// long, s.
    #[arg(long, default_value_t = 10.0)]
    device_timeout: f64,
}

#[derive(Debug, clap::Args)]
struct IdentifyArgs {
    /// CSV with t_s, x_m and/or v_m_s, optional a_m_s2, and applied_force_n
    /// (or force_n, the force on the hand): a render of the servo-sinusoid
    /// scenario or a session's device stream reads as it is.
    data: PathBuf,
    /// `karnopp` or `dahl`.
    #[arg(long)]
    model: String,
    /// Zero-velocity band DV: samples with |v| <= DV are left out, m/s.
    /// The default, 0.03, also leaves out the presliding around reversals
    /// (see `frictionlab::identify::DEFAULT_DV_M_S`).
    #[arg(long, default_value_t = crate::identify::DEFAULT_DV_M_S)]
    dv: f64,
    /// Velocity noise SD for the errors-in-variables correction, m/s
    /// (default: estimated from the data; give both SDs or neither).
    #[arg(long)]
    vel_sd: Option<f64>,
    /// Acceleration noise SD for the errors-in-variables correction, m/s^2.
    #[arg(long)]
    acc_sd: Option<f64>,
    /// Dahl: the fixed rest stiffness sigma, N/m.
    #[arg(long, default_value_t = 2e4)]
    sigma: f64,
    /// Dahl: the fixed shape exponent.
    #[arg(long, default_value_t = 1.0)]
    exponent: f64,
}

#[derive(Debug, clap::Args)]
struct SimulateArgs {
    /// The protocol file.
    protocol: PathBuf,
    /// Number of simulated participants (ids sim-001, sim-002, ...).
    #[arg(long)]
    participants: u32,
    /// Study seed: participant i's plan seed and traits derive from it.
    #[arg(long)]
    seed: u64,
    /// Results folder.
    #[arg(long)]
    out: PathBuf,
    /// Simulated time runs X times faster than real time (default: as fast
    /// as possible).
    #[arg(long)]
    pace: Option<f64>,
    /// Record each trial's device stream in `streams/` (as `run` and the
    /// window always do; off by default here: a whole simulated study at
    /// 5 kHz is gigabytes).
    #[arg(long)]
    streams: bool,
    /// Sessions run at once, one per thread (default: every core; 1 with
    /// `--pace`). The files are the same byte for byte for any number.
    #[arg(long)]
    jobs: Option<usize>,
}

#[derive(Debug, clap::Args)]
struct RenderArgs {
    /// Friction model: god-object-constant, god-object-time-varying,
    /// stick-slip-tactile, stick-slip-force, karnopp, dahl, viscous, none.
    #[arg(long)]
    model: String,
    /// Scenario: spidar-slide, sinusoidal-stroke, coupled-block.
    #[arg(long)]
    scenario: String,
    /// Override a parameter: a model parameter (`mu_s=1.2`), a scenario
    /// parameter (`scenario.slide_speed_m_s=0.05`), the step rate
    /// (`rate_hz=5000`; default: the model's loop rate) or the device's force
    /// limit (`force_limit_n=9.48`). Repeatable.
    #[arg(long = "set", value_name = "NAME=VALUE")]
    set: Vec<String>,
    /// The time series, CSV.
    #[arg(long)]
    out: PathBuf,
    /// A figure of force (and vibration) over time, SVG.
    #[arg(long)]
    plot: Option<PathBuf>,
}

/// Runs the command line and returns the process exit code.
#[must_use]
pub fn main() -> ExitCode {
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) => {
            // clap prints help/version to stdout (exit 0) and usage errors
            // to stderr (exit 2).
            let _ = e.print();
            return ExitCode::from(u8::try_from(e.exit_code()).unwrap_or(EXIT_BAD_INPUT));
        }
    };
    let Some(command) = cli.command else {
        return finish(gui_command(
            GuiArgs {
                protocol: None,
                participant: String::new(),
                out: PathBuf::from("results"),
                device: DeviceChoice::Simulated,
            },
            None,
        ));
    };
    let result = match command {
        Command::Gui(args) => gui_command(args, None),
        Command::Validate { protocols } => validate_command(&protocols),
        Command::Run(args) => run_command(&args),
        Command::Simulate(args) => simulate_command(&args),
        Command::Analyze { dir, out } => analyze_command(&dir, out.as_deref()),
        Command::Identify(args) => identify_command(&args),
        Command::Ports => ports_command(),
        Command::DeviceEmulator { path } => emulator_command(&path),
        Command::Schema { which } => emit(&if which == "log" {
            crate::results::log_json_schema()
        } else {
            crate::protocol::json_schema()
        }),
        Command::Render(args) => render_command(&args),
        Command::Models => emit(&format!("{}\n", models_json())),
    };
    finish(result)
}

fn finish(result: Result<(), Failure>) -> ExitCode {
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(failure) => {
            for e in failure.errors {
                say(&format!("error: {e}"));
            }
            ExitCode::from(failure.code)
        }
    }
}

/// Exit code for an unexpected failure (an I/O error writing results).
pub const EXIT_FAILURE: u8 = 1;

/// Writes `text` to standard output. A reader that went away
/// (`frictionlab ... | head`) is not an error: the rest is dropped and the
/// command finishes its work (exit 0). Any other write error (a full disk
/// behind `>`) is a failure, exit 1.
fn emit(text: &str) -> Result<(), Failure> {
    use std::io::Write as _;
    let mut out = std::io::stdout().lock();
    match out.write_all(text.as_bytes()).and_then(|()| out.flush()) {
        Err(e) if e.kind() != std::io::ErrorKind::BrokenPipe => Err(Failure {
            code: EXIT_FAILURE,
            errors: vec![UserError::new("stdout", e.to_string())],
        }),
        _ => Ok(()),
    }
}

/// Writes a line to standard error; a closed or broken standard error has
/// nowhere left to be reported, so it is ignored.
fn say(line: &str) {
    use std::io::Write as _;
    let _ = writeln!(std::io::stderr().lock(), "{line}");
}

/// Errors to print and the exit code.
struct Failure {
    code: u8,
    errors: Vec<UserError>,
}

impl From<Vec<UserError>> for Failure {
    fn from(errors: Vec<UserError>) -> Self {
        Failure {
            code: EXIT_BAD_INPUT,
            errors,
        }
    }
}

impl From<SessionError> for Failure {
    fn from(e: SessionError) -> Self {
        match e {
            SessionError::Results(e) => e.into(),
            SessionError::NothingToResume { .. } | SessionError::Ended { .. } => {
                vec![UserError::new("--resume", e.to_string())].into()
            }
            SessionError::Lost { .. }
            | SessionError::NeverConnected { .. }
            | SessionError::Loop(_) => device_failure("--device", e.to_string()),
        }
    }
}

impl From<ResultsError> for Failure {
    fn from(e: ResultsError) -> Self {
        match e {
            ResultsError::Input(problem) => vec![problem].into(),
            ResultsError::Log {
                path,
                line,
                column,
                message,
            } => vec![UserError::new(path, format!("{line}:{column}: {message}"))].into(),
            ResultsError::Io { path, source } => Failure {
                code: EXIT_FAILURE,
                errors: vec![UserError::new(path, source.to_string())],
            },
        }
    }
}

/// Reads and checks a protocol file.
fn load_protocol(path: &Path) -> Result<(Protocol, Vec<u8>), Vec<UserError>> {
    load::read(path)
}

fn validate_command(paths: &[PathBuf]) -> Result<(), Failure> {
    let mut errors = Vec::new();
    for path in paths {
        match load_protocol(path) {
            Ok((p, _)) => {
                let plan = crate::protocol::plan::resolve(&p, 0, 0);
                emit(&format!(
                    "ok: {}: {} '{}', {} trials per session\n",
                    path.display(),
                    p.design.kind().as_str(),
                    p.id,
                    plan.trials.len()
                ))?;
            }
            Err(e) => errors.extend(e),
        }
    }
    if errors.is_empty() {
        Ok(())
    } else {
        Err(errors.into())
    }
}

fn analyze_command(dir: &Path, out: Option<&Path>) -> Result<(), Failure> {
    let analysis = crate::analysis::analyze(dir).map_err(|e| Failure::from(vec![e]))?;
    let out = out.map_or_else(|| dir.join("report"), Path::to_path_buf);
    crate::analysis::write(&analysis, &out).map_err(|(path, message)| Failure {
        code: EXIT_FAILURE,
        errors: vec![UserError::new(path, message)],
    })?;
    for note in analysis.summary["notes"].as_array().into_iter().flatten() {
        say(&format!("note: {}", note.as_str().unwrap_or_default()));
    }
    let peak = peak_memory_mib()
        .map(|m| format!(", peak memory {m} MiB"))
        .unwrap_or_default();
    emit(&format!(
        "analysed {} -> {} (summary.json, report.html, {} tables as CSV and Parquet{peak})\n",
        dir.display(),
        out.display(),
        analysis.tables.len()
    ))
}

/// Exit code for a device problem the command could not ride out.
pub const EXIT_DEVICE: u8 = 3;

fn device_failure(place: &str, message: impl Into<String>) -> Failure {
    Failure {
        code: EXIT_DEVICE,
        errors: vec![UserError::new(place, message)],
    }
}

fn identify_command(args: &IdentifyArgs) -> Result<(), Failure> {
    use crate::identify;
    let mut errors = Vec::new();
    if args.model != "karnopp" && args.model != "dahl" {
        errors.push(UserError::new(
            "--model",
            format!("'{}': 'karnopp' or 'dahl'", args.model),
        ));
    }
    let positive = |name: &str, v: f64, errors: &mut Vec<UserError>| {
        if !(v.is_finite() && v > 0.0) {
            errors.push(UserError::new(
                name,
                format!("must be a number greater than 0, got {v}"),
            ));
        }
    };
    positive("--sigma", args.sigma, &mut errors);
    positive("--exponent", args.exponent, &mut errors);
    if !(args.dv.is_finite() && args.dv >= 0.0) {
        errors.push(UserError::new(
            "--dv",
            format!("must be a number of at least 0, got {}", args.dv),
        ));
    }
    let noise = match (args.vel_sd, args.acc_sd) {
        (Some(v), Some(a)) => {
            for (name, x) in [("--vel-sd", v), ("--acc-sd", a)] {
                if !(x.is_finite() && x >= 0.0) {
                    errors.push(UserError::new(
                        name,
                        format!("must be a number of at least 0, got {x}"),
                    ));
                }
            }
            Some((v, a))
        }
        (None, None) => None,
        _ => {
            errors.push(UserError::new(
                "--vel-sd/--acc-sd",
                "give both noise SDs, or neither to estimate them",
            ));
            None
        }
    };
    if !errors.is_empty() {
        return Err(errors.into());
    }
    let failure = |e: UserError| -> Failure { vec![e].into() };
    let record = identify::read_csv(&args.data).map_err(failure)?;
    let file = args.data.display().to_string();
    let json = if args.model == "karnopp" {
        let fit = identify::fit_karnopp(&record, args.dv, noise).map_err(failure)?;
        let model = identify::karnopp_model(&fit.corrected);
        identify::report_json(&file, &record, &serde_json::json!(fit), &model)
    } else {
        let fit = identify::fit_dahl(&record, args.sigma, args.exponent, args.dv, noise)
            .map_err(failure)?;
        let model = identify::dahl_model(&fit);
        identify::report_json(&file, &record, &serde_json::json!(fit), &model)
    };
    emit(&format!("{json}\n"))
}

/// Opens the experimenter window; without a display, says so (exit 2).
fn gui_command(args: GuiArgs, start: Option<crate::gui::AutoStart>) -> Result<(), Failure> {
    let headless = "run sessions without a window with `frictionlab run PROTOCOL --participant ID --out DIR --responder sim` or `frictionlab simulate`";
    let no_display = |why: &str| -> Failure {
        vec![UserError::new(
            "gui",
            format!("cannot open the window: {why}; {headless}"),
        )]
        .into()
    };
    if cfg!(target_os = "linux")
        && ["DISPLAY", "WAYLAND_DISPLAY"]
            .iter()
            .all(|v| std::env::var_os(v).is_none_or(|s| s.is_empty()))
    {
        return Err(no_display(
            "no display (DISPLAY and WAYLAND_DISPLAY are unset)",
        ));
    }
    crate::gui::run(crate::gui::Launch {
        protocol: args.protocol,
        participant: args.participant,
        out: args.out,
        device: args.device,
        start,
    })
    .map_err(|e| no_display(&e))
}

fn ports_command() -> Result<(), Failure> {
    let ports = crate::device::list_ports().map_err(|e| device_failure("ports", e))?;
    if ports.is_empty() {
        return emit("no serial ports found\n");
    }
    let mut lines = String::new();
    for p in ports {
        let _ = writeln!(lines, "{}\t{}", p.path, p.kind);
    }
    emit(&lines)
}

fn emulator_command(path: &Path) -> Result<(), Failure> {
    use crate::device::emulator::{self, Endpoint, OpenError};
    let place = path.display().to_string();
    let mut emulator = emulator::open(path).map_err(|e| match e {
        OpenError::NotAPort(_) => Failure::from(vec![UserError::new(&place, e.to_string())]),
        _ => device_failure(&place, e.to_string()),
    })?;
    emit(&match emulator.endpoint() {
        Endpoint::Port => format!("device emulator on {place}\n"),
        Endpoint::Pty { slave, replaced } => format!(
            "device emulator on {place} (pseudo-terminal {}{})\n",
            slave.display(),
            replaced.as_ref().map_or_else(String::new, |old| format!(
                "; replaced the link to {}, which was gone",
                old.display()
            ))
        ),
    })?;
    emulator
        .serve(|_| {})
        .map_err(|e| device_failure(&place, e.to_string()))
}

/// This process's peak resident memory, MiB (Linux: `VmHWM`).
fn peak_memory_mib() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib / 1024)
}

fn check_pace(pace: f64) -> Result<(), Vec<UserError>> {
    if pace.is_finite() && pace > 0.0 {
        Ok(())
    } else {
        Err(vec![UserError::new(
            "--pace",
            format!("must be a number greater than 0, got {pace}"),
        )])
    }
}

/// The `run` options' problems, all at once.
fn check_run_args(args: &RunArgs) -> Vec<UserError> {
    let mut errors = Vec::new();
    if let DeviceChoice::Port(path) = &args.device
        && let Err(e) = crate::device::check_port(path)
    {
        errors.push(UserError::new(
            "--device",
            format!("{}: {e}", path.display()),
        ));
    }
    if !(args.device_timeout.is_finite() && args.device_timeout > 0.0) {
        errors.push(UserError::new(
            "--device-timeout",
            format!(
                "must be a number greater than 0, got {}",
                args.device_timeout
            ),
        ));
    }
    if let Err(m) = results::check_participant(&args.participant) {
        errors.push(UserError::new("--participant", m));
    }
    if let Err(e) = check_pace(args.pace) {
        errors.extend(e);
    }
    errors
}

fn run_command(args: &RunArgs) -> Result<(), Failure> {
    let mut errors = check_run_args(args);
    let loaded = load_protocol(&args.protocol);
    let (protocol, bytes) = match loaded {
        Ok(ok) if errors.is_empty() => ok,
        Ok(_) => return Err(errors.into()),
        Err(e) => {
            errors.extend(e);
            return Err(errors.into());
        }
    };
    if args.responder == ResponderChoice::Gui {
        // A person answers: the experimenter window opens with this session
        // started (or resumed).
        return gui_command(
            GuiArgs {
                protocol: Some(args.protocol.clone()),
                participant: args.participant.clone(),
                out: args.out.clone(),
                device: args.device.clone(),
            },
            Some(crate::gui::AutoStart {
                resume: args.resume,
                seed: args.seed,
                participant_index: args.participant_index,
            }),
        );
    }
    let seed = args.seed.unwrap_or_else(rand::random::<u64>);
    let dir = results::ResultsDir::new(&args.out);
    let req = session::SessionRequest {
        protocol: &protocol,
        protocol_bytes: &bytes,
        participant: &args.participant,
        participant_index: args.participant_index,
        seed,
        resume: args.resume,
        pace: Some(args.pace),
        device: &args.device,
        streams: true,
    };
    let outcome = match &args.device {
        DeviceChoice::Simulated => {
            session::run_simulated(&dir, &req, &mut |_, _| {}).map_err(Failure::from)
        }
        DeviceChoice::Port(path) => session::run_device(
            &dir,
            &req,
            args.device_timeout,
            session::sim_participant,
            &mut |_, _| {},
        )
        .map_err(|e| match e {
            SessionError::Results(_)
            | SessionError::NothingToResume { .. }
            | SessionError::Ended { .. } => e.into(),
            e => device_failure(&format!("--device {}", path.display()), e.to_string()),
        }),
    }?;
    if outcome.torn_bytes > 0 {
        say(&format!(
            "note: {}: a torn last line ({} bytes) was ignored and cut before resuming",
            outcome.log.display(),
            outcome.torn_bytes
        ));
    }
    emit(&format!(
        "session {} of '{}': {} trials completed, {} aborted{} -> {}\n",
        outcome.session,
        args.participant,
        outcome.completed,
        outcome.aborted,
        outcome
            .resumed_at
            .map(|t| format!(" (resumed at trial {t})"))
            .unwrap_or_default(),
        outcome.csv.display()
    ))
}

fn simulate_command(args: &SimulateArgs) -> Result<(), Failure> {
    let mut errors = Vec::new();
    if args.participants == 0 {
        errors.push(UserError::new("--participants", "must be at least 1"));
    }
    if args.jobs == Some(0) {
        errors.push(UserError::new("--jobs", "must be at least 1"));
    }
    if let Some(p) = args.pace
        && let Err(e) = check_pace(p)
    {
        errors.extend(e);
    }
    let (protocol, bytes) = match load_protocol(&args.protocol) {
        Ok(ok) if errors.is_empty() => ok,
        Ok(_) => return Err(errors.into()),
        Err(e) => {
            errors.extend(e);
            return Err(errors.into());
        }
    };
    let dir = results::ResultsDir::new(&args.out);
    let planned = crate::protocol::plan::resolve(&protocol, 0, 0).trials.len() as u64;
    let bar = indicatif::ProgressBar::new(planned * u64::from(args.participants));
    bar.set_style(
        indicatif::ProgressStyle::with_template(
            "{bar:40} {pos}/{len} trials, {msg} [{elapsed_precise}]",
        )
        .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    let wall = std::time::Instant::now();
    let jobs = args.jobs.unwrap_or_else(|| {
        if args.pace.is_some() {
            1
        } else {
            std::thread::available_parallelism().map_or(1, std::num::NonZero::get)
        }
    });
    let outcomes = session::simulate_participants(
        &dir,
        &session::Simulation {
            protocol: &protocol,
            protocol_bytes: &bytes,
            participants: args.participants,
            seed: args.seed,
            pace: args.pace,
            streams: args.streams,
            jobs,
        },
        &|done| bar.set_position(done as u64),
    )?;
    let simulated: f64 = outcomes.iter().map(|o| o.simulated_s).sum();
    let trials: usize = outcomes.iter().map(|o| o.completed + o.aborted).sum();
    bar.finish_and_clear();
    let elapsed = wall.elapsed().as_secs_f64();
    emit(&format!(
        "simulated {} sessions of '{}' ({jobs} at a time): {trials} trials, {simulated:.1} s of session time in {elapsed:.2} s ({:.0}x real time) -> {}\n",
        args.participants,
        protocol.id,
        simulated / elapsed.max(1e-9),
        dir.root().display()
    ))
}

/// Every model's and scenario's default parameters, pretty JSON.
fn models_json() -> String {
    let models: Vec<_> = ModelParams::NAMES
        .iter()
        .filter_map(|n| ModelParams::default_for(n))
        .collect();
    let scenarios: Vec<_> = ScenarioParams::NAMES
        .iter()
        .filter_map(|n| ScenarioParams::default_for(n))
        .collect();
    serde_json::to_string_pretty(&serde_json::json!({
        "models": models,
        "scenarios": scenarios,
    }))
    .unwrap_or_default()
}

/// What `render` runs, after every flag was checked.
struct RenderPlan {
    model: ModelParams,
    scenario: ScenarioParams,
    settings: crate::friction::StepParams,
}

fn render_command(args: &RenderArgs) -> Result<(), Failure> {
    if let Some(plot) = &args.plot
        && plot.extension().and_then(|e| e.to_str()) != Some("svg")
    {
        return Err(vec![UserError::new(
            "--plot",
            format!(
                "{}: only SVG figures are written (use a .svg name)",
                plot.display()
            ),
        )]
        .into());
    }
    let plan = render_plan(&args.model, &args.scenario, &args.set)?;
    let samples = scenario::run(&plan.model, &plan.scenario, plan.settings).map_err(|e| {
        vec![match e {
            ScenarioError::Model(p) => set_error("", p),
            ScenarioError::Scenario(p) => set_error("scenario.", p),
            ScenarioError::Rate(r) => UserError::new(
                "--set rate_hz",
                format!("must be finite and greater than 0, got {r}"),
            ),
            ScenarioError::TooLong(_) => UserError::new("--scenario", e.to_string()),
        }]
    })?;
    let vibration = plan.model.has_vibration();
    let text = render::csv(&samples, vibration);
    render::write_atomically(&args.out, text.as_bytes()).map_err(|e| {
        vec![UserError::new(
            "--out",
            format!("{}: {e}", args.out.display()),
        )]
    })?;
    if let Some(plot) = &args.plot {
        let title = format!("{} / {}", plan.model.name(), plan.scenario.name());
        let svg = render::plot_svg(&samples, &title, vibration)
            .map_err(|e| vec![UserError::new("--plot", e)])?;
        render::write_atomically(plot, svg.as_bytes())
            .map_err(|e| vec![UserError::new("--plot", format!("{}: {e}", plot.display()))])?;
    }
    let onsets = samples.iter().filter(|s| s.slip_onset).count();
    let (t0, t1) = (
        samples.first().map_or(0.0, |s| s.t_s),
        samples.last().map_or(0.0, |s| s.t_s),
    );
    emit(&format!(
        "{} / {}: {} samples at {} Hz, t = {t0:.3} .. {t1:.3} s, {onsets} stick-to-slip transitions -> {}\n",
        plan.model.name(),
        plan.scenario.name(),
        samples.len(),
        plan.settings.rate_hz,
        args.out.display()
    ))
}

/// A parameter's problem as one of `--set`'s: `--set <prefix><place>`.
fn set_error(prefix: &str, e: UserError) -> UserError {
    UserError::new(format!("--set {prefix}{}", e.place), e.message)
}

/// Resolves the model, the scenario and every `--set`, reporting every error.
fn render_plan(model: &str, scenario: &str, sets: &[String]) -> Result<RenderPlan, Vec<UserError>> {
    let mut errors = Vec::new();
    let model_base = ModelParams::default_for(model);
    if model_base.is_none() {
        errors.push(UserError::new(
            "--model",
            format!(
                "unknown model '{model}'; known: {}",
                ModelParams::NAMES.join(", ")
            ),
        ));
    }
    let scenario_base = ScenarioParams::default_for(scenario);
    if scenario_base.is_none() {
        errors.push(UserError::new(
            "--scenario",
            format!(
                "unknown scenario '{scenario}'; known: {}",
                ScenarioParams::NAMES.join(", ")
            ),
        ));
    }
    let (mut model_sets, mut scenario_sets) = (Vec::new(), Vec::new());
    let (mut rate_hz, mut limit_n) = (None, None);
    for text in sets {
        let (name, value) = match settings::split_setting(text) {
            Ok(pair) => pair,
            Err(e) => {
                errors.push(set_error("", e));
                continue;
            }
        };
        match name {
            "rate_hz" | "force_limit_n" => match value.parse::<f64>() {
                Ok(x) if name == "rate_hz" => rate_hz = Some(x),
                Ok(x) => limit_n = Some(x),
                Err(_) => errors.push(UserError::new(
                    format!("--set {name}"),
                    format!("expected a number, got '{value}'"),
                )),
            },
            _ => match name.strip_prefix("scenario.") {
                Some(rest) => scenario_sets.push((rest, value)),
                None => model_sets.push((name, value)),
            },
        }
    }
    let limit = match ForceLimit::new(limit_n.unwrap_or(crate::friction::DEFAULT_FORCE_LIMIT_N)) {
        Ok(l) => Some(l),
        Err(e) => {
            errors.push(set_error("", e));
            None
        }
    };
    let model = model_base.and_then(|base| {
        let what = format!("model {}", base.name());
        let (model, errs) = settings::apply_all(&base, "model", &what, &model_sets);
        errors.extend(errs.into_iter().map(|e| set_error("", e)));
        model
    });
    if let Some(m) = &model {
        errors.extend(m.validate().into_iter().map(|p| set_error("", p)));
    }
    let scenario = scenario_base.and_then(|base| {
        let what = format!("scenario {}", base.name());
        let (scenario, errs) = settings::apply_all(&base, "scenario", &what, &scenario_sets);
        errors.extend(errs.into_iter().map(|e| set_error("scenario.", e)));
        scenario
    });
    if let Some(s) = &scenario {
        errors.extend(s.validate().into_iter().map(|p| set_error("scenario.", p)));
    }
    match (model, scenario, limit) {
        (Some(model), Some(scenario), Some(limit)) if errors.is_empty() => {
            let rate_hz = rate_hz.unwrap_or_else(|| model.loop_rate_hz());
            Ok(RenderPlan {
                model,
                scenario,
                settings: crate::friction::StepParams {
                    rate_hz,
                    force_limit: limit,
                    ..Default::default()
                },
            })
        }
        _ => Err(errors),
    }
}
