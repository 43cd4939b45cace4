//! The command line: parses arguments, calls the library, and is the one place
//! that turns errors into `error: <where>: <what>` lines and exit codes.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use clap::{Parser, Subcommand};

// A problem with the user's input is the library's one `Problem`, printed by
// `finish` as `error: <place>: <message>`.
use crate::problem::Problem as UserError;
use crate::results::ResultsError;
use crate::session::{DeviceChoice, SessionError};

mod check_device;
mod commands;

use check_device::check_device_command;
use commands::{
    analyze_command, audio_command, claims_command, emulator_command, firmware_qemu_command,
    gui_command, haply2diy_emulator_command, identify_command, inverse3_emulator_command,
    models_json, ports_command, power_command, power_merge_command, render_command,
    rerender_command, run_command, simulate_command, validate_command, validation_command,
};

/// `--device`: `sim` (the simulated apparatus), a serial port's path (our
/// own board) or `KIND:TARGET` (`haply2diy:/dev/ttyACM0`). Whether the
/// device is there is checked with the other options ([`check_run_args`]),
/// so every problem is reported at once.
fn parse_device(text: &str) -> Result<DeviceChoice, String> {
    if text == "sim" {
        Ok(DeviceChoice::Simulated)
    } else {
        crate::device::Address::parse(text).map(DeviceChoice::Device)
    }
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
    /// Open straight into a session of --protocol for --participant, with
    /// no click on the setup screen: the participant's unfinished session
    /// of that protocol is resumed, else a new one starts (so a lab can
    /// launch each participant from a script).
    #[arg(long, requires = "protocol")]
    start: bool,
    #[command(flatten)]
    lsl: LslArgs,
    #[command(flatten)]
    sound: SoundArgs,
}

/// Publishing on the Lab Streaming Layer (issue 34).
#[derive(Debug, Clone, Default, clap::Args)]
struct LslArgs {
    /// Publish the session on the Lab Streaming Layer: a marker stream of
    /// its events and the device's stream (docs/guide/lsl.md).
    #[arg(long)]
    lsl: bool,
    /// liblsl to load (default: FRICTIONLAB_LSL_LIB, then the system's
    /// liblsl).
    #[arg(long, value_name = "PATH", requires = "lsl")]
    lsl_lib: Option<PathBuf>,
    /// Hold the session's start until a recorder (LabRecorder, any inlet)
    /// listens to its markers, at most this long, s; markers sent before a
    /// recorder connects are not in its recording (`run`, `simulate`).
    #[arg(long, value_name = "S", default_value_t = 0.0, requires = "lsl")]
    lsl_wait: f64,
}

/// Sound outputs a session plays on (issue 64; `frictionlab audio` lists
/// them).
#[derive(Debug, Clone, Default, clap::Args)]
struct SoundArgs {
    /// Play the protocol's masking noise (its `masking`) on this output of
    /// the sound server (PulseAudio or PipeWire): headphones. A protocol
    /// with masking does not run without it.
    #[arg(long, value_name = "OUTPUT")]
    masking_audio: Option<String>,
    /// The tactile display: play every model's vibrotactile drive on this
    /// output's channel (from 1; default 1), to an amplifier and a tactor,
    /// as well as to a device with a vibration channel. Needs a device's
    /// haptic loop (not `--device sim`).
    #[arg(long, value_name = "OUTPUT[:CHANNEL]")]
    tactile_audio: Option<String>,
}

impl SoundArgs {
    /// What they ask to play, on the server the environment names.
    fn choice(&self) -> crate::session::sound::SoundChoice {
        crate::session::sound::SoundChoice {
            server: crate::audio::Server::from_env(),
            masking_audio: self.masking_audio.clone(),
            tactile_audio: self.tactile_audio.clone(),
        }
    }
}

/// `run --pace` when not given: real time.
pub(crate) const DEFAULT_PACE: f64 = 1.0;

/// `run --device-timeout` when not given, s.
pub(crate) const DEFAULT_DEVICE_TIMEOUT_S: f64 = 10.0;

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
    /// Power by simulation: replays whole studies at each sample size with
    /// simulated participants, analyses each as `analyze` does, and writes
    /// power.json and power.html (with `--shard`, or in a Slurm array, only
    /// that shard's power-shard-K-of-N.json; `power-merge` combines them).
    Power(PowerArgs),
    /// Combines the shards of a power run (power-shard-K-of-N.json in the
    /// folders) into power.json and power.html, byte-identical to an
    /// unsharded run; refuses a missing or duplicated shard.
    PowerMerge {
        /// Folders holding the shards.
        #[arg(required = true)]
        dirs: Vec<PathBuf>,
        /// Where to write (default: the first folder).
        #[arg(long)]
        out: Option<PathBuf>,
    },
    /// Reads a results folder and writes summary.json, report.html and the
    /// tables (CSV and Parquet). Each data CSV is first held against its
    /// session log; any difference is an error (exit 2, nothing written).
    Analyze {
        /// The results folder.
        dir: PathBuf,
        /// Where to write the report (default: DIR/report).
        #[arg(long)]
        out: Option<PathBuf>,
        /// Analyse the data CSVs alone, without holding each against its
        /// session log (the primary record): for data edited by hand or
        /// without logs. summary.json says so.
        #[arg(long)]
        csv_only: bool,
    },
    /// Writes DIR/claims.md: every seed claim against the replays in the
    /// analysis folder DIR (`analysis/`), with the robustness tables.
    Claims {
        /// The analysis folder (the main replays' summaries and
        /// `robustness/`).
        dir: PathBuf,
        /// The Fitts protocol replayed (its narrowest targets are the
        /// seed's hardest tasks).
        #[arg(long)]
        fitts_protocol: PathBuf,
    },
    /// Replays the validation protocols in DIR/validation/ with simulated
    /// participants and writes DIR/validation.md and DIR/validation.json:
    /// each human experiment's published result, its band, the simulated
    /// mean with its 95% interval, the verdict, and the sweep over the
    /// participant's constants.
    Validation {
        /// The analysis folder (`analysis/`).
        dir: PathBuf,
        /// The main replays only, without the sweep.
        #[arg(long)]
        no_sweep: bool,
        /// Worker threads (default: the machine's cores).
        #[arg(long)]
        jobs: Option<usize>,
    },
    /// Fits friction parameters to recorded motion and force (seed 002);
    /// prints JSON with a `protocol_model` block for a protocol.
    Identify(IdentifyArgs),
    /// Lists the devices this machine has, of every kind, as `--device`
    /// names them.
    Ports,
    /// Lists the sound server's outputs (PulseAudio, or PipeWire's pulse
    /// server), as `--masking-audio` names them:
    /// `NAME\tCHANNELS\tRATE\tDESCRIPTION`.
    Audio,
    /// The bring-up check of a device before its first session, through
    /// the haptic loop a session uses: the handshake, the loop's rate and
    /// jitter, the encoder's direction and scale against the stated travel
    /// (the experimenter moves the handle to each end when told), the
    /// force's direction (a small push with the handle let go) and the
    /// wall that holds the hand on the track. Prints each step's PASS or
    /// FAIL with its numbers, and keeps a report in
    /// DIR/device-checks/<device>_<time>.json, which later sessions' log
    /// headers name. Exit 0 when every step passed, 3 when one failed or
    /// the device did not answer (docs/guide/devices.md, "Bring-up
    /// check").
    CheckDevice(CheckDeviceArgs),
    /// Runs an emulated device on a serial port, or on a new
    /// pseudo-terminal linked at PATH if nothing is there (a link an
    /// earlier emulator left, to a pseudo-terminal now gone, is replaced).
    /// `PATH`: frictionlab's own board (the simulated apparatus), silent
    /// until a host says Hello, serving host after host until stopped.
    /// `haply2diy:PATH`: a Haply 2DIY board (its firmware's protocol) on a
    /// pantograph, powered up at the vendor's calibration pose; a reset
    /// leaves the handle where it is. For tests, SIGUSR1 makes the board
    /// lose its setup (as one that restarted: torque frames answered with
    /// its id alone, the handle where it is), and SIGUSR1 again, while it
    /// is not set up, puts the handle at its calibration pose (as the
    /// experimenter is asked to); SIGUSR2 takes its port away for 0.5 s
    /// and brings it back, the board still set up (a USB replug it rode
    /// out).
    /// `inverse3[:HOST:PORT]`: a Haply Inverse Service (default
    /// 127.0.0.1:10001) with one Inverse3 on it.
    DeviceEmulator {
        /// `PATH`, `haply2diy:PATH` (a serial port, or a link to one, left
        /// in place, or where to link a new pseudo-terminal), or
        /// `inverse3[:HOST:PORT]` (where to listen).
        path: String,
        /// inverse3: the version the service states (to try a host against
        /// another version).
        #[arg(long, value_name = "VERSION")]
        service_version: Option<String>,
        /// inverse3: a service with no Inverse3 on it.
        #[arg(long)]
        no_device: bool,
        /// haply2diy, inverse3: advance the physics 1 ms (one host period)
        /// per torque frame or client message instead of in real time (two
        /// hosts that send the same bytes read the same angles back, and a
        /// host the machine stalls stalls the device with it); haply2diy:
        /// frames that arrive together count once, so an emulator the
        /// machine stalls stalls the physics too; inverse3: a message that
        /// echoes an older state frame's number than the newest adds none.
        #[arg(long)]
        lockstep: bool,
        /// haply2diy: append every frame the board takes and every reply,
        /// in hex, one per line (`> ` from the host, `< ` to it), to FILE.
        #[arg(long, value_name = "FILE")]
        transcript: Option<PathBuf>,
        /// Render friction on board (wire protocol v2): the host uploads
        /// each trial's model, the emulator steps it itself in f32 at
        /// 5 kHz and streams telemetry. Without it, a version 1 device
        /// that applies the host's force commands.
        #[arg(long)]
        on_board: bool,
        /// Delivers what the host sends this many milliseconds late, in
        /// order: a backed-up link, as QEMU's UART on a loaded machine (to
        /// test how a host copes).
        #[arg(long, value_name = "MS", default_value_t = 0, value_parser = clap::value_parser!(u16).range(0..=10_000))]
        link_delay_ms: u16,
        #[command(flatten)]
        miswiring: MiswiringArgs,
    },
    /// Boots the firmware (`firmware/`) in QEMU's mps2-an386 and prints the
    /// pseudo-terminal its UART is on, for `run --device PATH`; runs until
    /// stopped (Ctrl-C) or QEMU ends.
    FirmwareQemu {
        /// The firmware: by default where `cargo build --release -p
        /// frictionlab-firmware --target thumbv7em-none-eabihf` puts it.
        #[arg(long, default_value = crate::device::frictionlab::qemu::FIRMWARE_ELF)]
        elf: PathBuf,
        /// Also link the pseudo-terminal here (nothing may be there but a
        /// link to a pseudo-terminal, which is replaced): a path that stays
        /// the same when QEMU is started again.
        #[arg(long)]
        link: Option<PathBuf>,
    },
    /// Renders a recorded trial stream again, its models taken from the
    /// session log, and prints (JSON) the largest difference from the
    /// recorded force and vibration: 0 for on-board trials, which the host
    /// renders with the device's own code, float and maths.
    Rerender {
        /// A stream: `<results>/streams/..._trial-<k>_run-<r>_stream.csv`.
        stream: PathBuf,
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
    /// `sim` (the simulated apparatus), a serial port's path (frictionlab's
    /// own board or emulator), or `KIND:TARGET` for another kind of device
    /// (`frictionlab ports` lists them).
    #[arg(long, default_value = "sim", value_parser = parse_device)]
    device: DeviceChoice,
    /// A device setting, `NAME=VALUE` (repeatable): the track and its wall,
    /// a device's calibration (docs/guide/devices.md).
    #[arg(long = "device-set", value_name = "NAME=VALUE")]
    device_set: Vec<String>,
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
    #[arg(long, default_value_t = DEFAULT_PACE)]
    pace: f64,
    /// Counterbalancing index (default: participants already in the folder).
    #[arg(long)]
    participant_index: Option<u32>,
    /// With a device: give up (exit 3) after it has not answered for this
    /// long, s.
    #[arg(long, default_value_t = DEFAULT_DEVICE_TIMEOUT_S)]
    device_timeout: f64,
    #[command(flatten)]
    lsl: LslArgs,
    #[command(flatten)]
    sound: SoundArgs,
}

/// `device-emulator`: the device wired wrong, to try the bring-up check
/// (`check-device`) on the faults it is there to catch (issue 63).
#[derive(Debug, Clone, Copy, clap::Args)]
struct MiswiringArgs {
    /// The encoder counts the other way: our board's count, both of the
    /// 2DIY's encoders against its setup, the Inverse3's position along
    /// the track (mirrored about the track's origin).
    #[arg(long)]
    flip_encoder: bool,
    /// The motor turns the other way: our board's force, both of the
    /// 2DIY's motors against its setup, the Inverse3's force along the
    /// track.
    #[arg(long)]
    flip_motor: bool,
    /// The encoder counts X times the steps per metre (our board, the
    /// Inverse3 along the track) or per turn (the 2DIY) the device states.
    #[arg(long, value_name = "X", default_value_t = 1.0)]
    encoder_scale: f64,
}

impl MiswiringArgs {
    fn miswiring(self) -> Result<crate::device::miswiring::Miswiring, Failure> {
        let m = crate::device::miswiring::Miswiring {
            flip_encoder: self.flip_encoder,
            flip_motor: self.flip_motor,
            encoder_scale: self.encoder_scale,
        };
        match m.problem() {
            Some(p) => Err(vec![UserError::new("--encoder-scale", p)].into()),
            None => Ok(m),
        }
    }
}

/// `check-device --responder`: who does what the check asks.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
enum Experimenter {
    /// A person: prompts on standard error, Enter on standard input.
    Person,
    /// A simulated experimenter, for an emulated device: it drives the
    /// emulated hand as each prompt asks.
    Sim,
}

#[derive(Debug, clap::Args)]
struct CheckDeviceArgs {
    /// `sim` (the simulated apparatus in real time), a serial port's path
    /// (frictionlab's own board) or `KIND:TARGET` (`frictionlab ports`
    /// lists them).
    #[arg(long, value_parser = parse_device)]
    device: DeviceChoice,
    /// A device setting, `NAME=VALUE` (repeatable), as for `run`.
    #[arg(long = "device-set", value_name = "NAME=VALUE")]
    device_set: Vec<String>,
    /// The results folder the report is kept in (DIR/device-checks/).
    #[arg(long)]
    out: PathBuf,
    /// Who does what the prompts ask.
    #[arg(long, value_enum, default_value_t = Experimenter::Person)]
    responder: Experimenter,
    /// Give up (exit 3) when the device has not answered for this long, s.
    #[arg(long, default_value_t = DEFAULT_DEVICE_TIMEOUT_S)]
    device_timeout: f64,
    /// How long the loop's rate and jitter are measured, s.
    #[arg(long, default_value_t = crate::device::check::DEFAULT_DURATION_S)]
    duration_s: f64,
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
    /// The simulated participants' population: a JSON file with any of
    /// its fields (hand impedance, motor and perceptual noise ranges, the
    /// free constants; see ARCHITECTURE.md); the rest keep their defaults.
    /// Kept in each log header.
    #[arg(long)]
    population: Option<PathBuf>,
    /// With `--pace`: each session publishes on the Lab Streaming Layer,
    /// as `run --lsl` does (for trying a recording setup).
    #[command(flatten)]
    lsl: LslArgs,
}

#[derive(Debug, clap::Args)]
struct PowerArgs {
    /// The protocol file.
    protocol: PathBuf,
    /// Sample sizes, increasing, comma separated.
    #[arg(long, value_delimiter = ',', default_value = "4,6,8,12,16,20")]
    participants: Vec<u32>,
    /// Studies replayed per sample size.
    #[arg(long, default_value_t = 1000)]
    studies: u32,
    /// Plan seed: study s's participants derive from it and s alone.
    #[arg(long)]
    seed: u64,
    /// Significance level.
    #[arg(long, default_value_t = 0.05)]
    alpha: f64,
    /// The power a sample size must reach to be reported as enough.
    #[arg(long, default_value_t = 0.8)]
    power: f64,
    /// A confidence interval (discrimination: of the group mean Weber
    /// fraction) reaches its target at most this wide.
    #[arg(long, default_value_t = 0.05)]
    max_ci_width: f64,
    /// Output folder.
    #[arg(long)]
    out: PathBuf,
    /// Run only shard K of N (0-based), writing power-shard-K-of-N.json.
    /// Default: from SLURM_ARRAY_TASK_ID/SLURM_ARRAY_TASK_COUNT in a Slurm
    /// array, else the whole plan.
    #[arg(long, value_name = "K/N")]
    shard: Option<String>,
    /// Studies replayed at once, one per thread (default: every core). The
    /// numbers are the same for any value.
    #[arg(long)]
    jobs: Option<usize>,
    /// The simulated participants' population (as `simulate --population`);
    /// its `paired_preference` sets an assumed paired-comparison effect.
    #[arg(long)]
    population: Option<PathBuf>,
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
    /// The float the model computes in: `f64` (the host) or `f32` (what a
    /// device with a single-precision FPU runs, the same code).
    #[arg(long, default_value = "f64", value_parser = ["f64", "f32"])]
    float: String,
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
                start: false,
                lsl: LslArgs::default(),
                sound: SoundArgs::default(),
            },
            None,
        ));
    };
    let result = match command {
        Command::Gui(args) => gui_command(args, None),
        Command::Validate { protocols } => validate_command(&protocols),
        Command::Run(mut args) => {
            if let DeviceChoice::Device(address) = &mut args.device {
                address.settings.set.clone_from(&args.device_set);
            }
            run_command(&args)
        }
        Command::Simulate(args) => simulate_command(&args),
        Command::Analyze { dir, out, csv_only } => analyze_command(&dir, out.as_deref(), csv_only),
        Command::Power(args) => power_command(&args),
        Command::PowerMerge { dirs, out } => power_merge_command(&dirs, out.as_deref()),
        Command::Claims {
            dir,
            fitts_protocol,
        } => claims_command(&dir, &fitts_protocol),
        Command::Validation {
            dir,
            no_sweep,
            jobs,
        } => validation_command(&dir, no_sweep, jobs),
        Command::Identify(args) => identify_command(&args),
        Command::Ports => ports_command(),
        Command::Audio => audio_command(),
        Command::CheckDevice(mut args) => {
            if let DeviceChoice::Device(address) = &mut args.device {
                address.settings.set.clone_from(&args.device_set);
            }
            check_device_command(&args)
        }
        Command::DeviceEmulator {
            path,
            service_version,
            no_device,
            lockstep,
            transcript,
            on_board,
            link_delay_ms,
            miswiring,
        } => match (path.strip_prefix("haply2diy:"), miswiring.miswiring()) {
            (_, Err(e)) => Err(e),
            (_, Ok(m)) if path == "inverse3" || path.starts_with("inverse3:") => {
                inverse3_emulator_command(
                    path.trim_start_matches("inverse3").trim_start_matches(':'),
                    service_version,
                    no_device,
                    lockstep,
                    m,
                )
            }
            (Some(path), Ok(m)) => {
                haply2diy_emulator_command(Path::new(path), lockstep, transcript.as_deref(), m)
            }
            (None, _) if lockstep || transcript.is_some() => {
                let (flag, only) = if lockstep {
                    ("--lockstep", "haply2diy:PATH or inverse3")
                } else {
                    ("--transcript", "haply2diy:PATH")
                };
                Err(Failure::from(vec![UserError::new(
                    flag,
                    format!("only for an emulated {only}"),
                )]))
            }
            (None, Ok(m)) => emulator_command(Path::new(&path), on_board, link_delay_ms, m),
        },
        Command::FirmwareQemu { elf, link } => firmware_qemu_command(&elf, link.as_deref()),
        Command::Schema { which } => emit(&if which == "log" {
            crate::results::log_json_schema::<crate::kinds::Registry>()
        } else {
            crate::protocol::json_schema::<crate::kinds::Registry>()
        }),
        Command::Render(args) => render_command(&args),
        Command::Models => emit(&format!("{}\n", models_json())),
        Command::Rerender { stream } => rerender_command(&stream),
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
            SessionError::Device(ref device, ref what) => {
                vec![UserError::new("--device", format!("{device}: {what}"))].into()
            }
            SessionError::WrongDevice(ref device, what) => vec![UserError::new(
                "--device",
                format!("{device}: {what}; no session was started"),
            )]
            .into(),
            SessionError::BeyondTravel(problems) => problems.into(),
            SessionError::Lost { .. }
            | SessionError::NeverConnected { .. }
            | SessionError::OffTrack { .. }
            | SessionError::Loop(_)
            | SessionError::DeviceFailed { .. }
            | SessionError::NotConfirmed { .. }
            | SessionError::NotBackOnTrack { .. } => device_failure("--device", e.to_string()),
            SessionError::SoundLost { .. } => device_failure("sound", e.to_string()),
            SessionError::Lsl(message) => Failure {
                code: EXIT_FAILURE,
                errors: vec![UserError::new("--lsl", message)],
            },
        }
    }
}

impl From<ResultsError> for Failure {
    fn from(e: ResultsError) -> Self {
        match e {
            ResultsError::Collision { .. } => {
                vec![UserError::new("--participant", e.to_string())].into()
            }
            ResultsError::Log {
                path,
                line,
                column,
                message,
            } => vec![UserError::new(path, format!("{line}:{column}: {message}"))].into(),
            ResultsError::Busy { ref path, .. } => {
                let message = e.to_string();
                let message = message
                    .strip_prefix(&format!("{path}: "))
                    .unwrap_or(&message)
                    .to_owned();
                vec![UserError::new(path.clone(), message)].into()
            }
            ResultsError::Io { path, source } => Failure {
                code: EXIT_FAILURE,
                errors: vec![UserError::new(path, source.to_string())],
            },
        }
    }
}

/// Exit code for a device problem the command could not ride out.
pub const EXIT_DEVICE: u8 = 3;

fn device_failure(place: &str, message: impl Into<String>) -> Failure {
    Failure {
        code: EXIT_DEVICE,
        errors: vec![UserError::new(place, message)],
    }
}
