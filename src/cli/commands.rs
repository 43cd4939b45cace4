//! One function per command: checks its arguments, calls the library,
//! reports what was done.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use super::{
    DeviceChoice, EXIT_BAD_INPUT, EXIT_FAILURE, Failure, GuiArgs, IdentifyArgs, LslArgs, PowerArgs,
    RenderArgs, ResponderChoice, RunArgs, SimulateArgs, SoundArgs, UserError, device_failure, emit,
    say,
};
use crate::device::miswiring::Miswiring;
use crate::friction::Validate;
use crate::friction::{ForceLimit, ModelParams};
use crate::kinds::{Protocol, Registry};
use crate::protocol::load;
use crate::scenario::{self, ScenarioError, ScenarioParams};
use crate::session::{self, SessionError};
use crate::{render, results, settings};

/// Reads and checks a protocol file.
fn load_protocol(path: &Path) -> Result<(Protocol, Vec<u8>), Vec<UserError>> {
    load::read(path)
}

/// The problems (`problems`: places under the protocol's root) of the
/// protocol file at `path`, placed in it.
fn in_file(path: &Path, problems: Vec<UserError>) -> Vec<UserError> {
    problems
        .into_iter()
        .map(|p| UserError::new(format!("{}: {}", path.display(), p.place), p.message))
        .collect()
}

/// Where the protocol at `path` asks for positions beyond the simulated
/// apparatus's travel (issue 63), placed in the file.
fn beyond_simulated_travel(protocol: &Protocol, path: &Path) -> Vec<UserError> {
    in_file(
        path,
        crate::protocol::check::beyond_travel(
            protocol,
            crate::device::sim::Apparatus::default().travel_m(),
            session::SIMULATED_APPARATUS,
        ),
    )
}

/// A session's error, with the places of a protocol it does not fit put
/// in its file at `path`.
fn session_failure(path: &Path, e: SessionError) -> Failure {
    match e {
        SessionError::BeyondTravel(problems) => in_file(path, problems).into(),
        e => e.into(),
    }
}

pub(super) fn validate_command(paths: &[PathBuf]) -> Result<(), Failure> {
    let mut errors = Vec::new();
    for path in paths {
        match load_protocol(path) {
            Ok((p, _)) => {
                let beyond = beyond_simulated_travel(&p, path);
                if !beyond.is_empty() {
                    errors.extend(beyond);
                    continue;
                }
                emit(&format!(
                    "ok: {}: {} '{}', {}\n",
                    path.display(),
                    p.kind(),
                    p.id,
                    p.trials_per_session()
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

pub(super) fn claims_command(dir: &Path, fitts_protocol: &Path) -> Result<(), Failure> {
    let (protocol, _) = load_protocol(fitts_protocol)?;
    let Some(ids) = crate::claims::narrowest_ids(&protocol) else {
        return Err(vec![UserError::new(
            format!("{}: $.design.kind", fitts_protocol.display()),
            "not a fitts protocol",
        )]
        .into());
    };
    let table = crate::claims::claims(dir, &ids).map_err(|e| Failure::from(vec![e]))?;
    let path = dir.join("claims.md");
    crate::render::write_atomically(&path, table.as_bytes()).map_err(|e| {
        Failure::from(vec![UserError::new(
            path.display().to_string(),
            format!("cannot write: {e}"),
        )])
    })?;
    emit(&format!("wrote {}\n", path.display()))
}

pub(super) fn validation_command(
    dir: &Path,
    no_sweep: bool,
    jobs: Option<usize>,
) -> Result<(), Failure> {
    let options = crate::validation::Options {
        sweep: !no_sweep,
        jobs: jobs.unwrap_or_else(|| {
            std::thread::available_parallelism().map_or(1, std::num::NonZero::get)
        }),
    };
    let bar = indicatif::ProgressBar::new(0);
    bar.set_style(
        indicatif::ProgressStyle::with_template("{bar:40} {pos}/{len} replays, ETA {eta}")
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    let rows = crate::validation::run(dir, options, &|done, total| {
        bar.set_length(total as u64);
        bar.set_position(done as u64);
    })
    .map_err(Failure::from)?;
    bar.finish_and_clear();
    let json = serde_json::to_vec_pretty(&rows)
        .map_err(|e| Failure::from(vec![UserError::new("validation.json", e.to_string())]))?;
    for (name, bytes) in [
        ("validation.json", json),
        (
            "validation.md",
            crate::validation::table(&rows).into_bytes(),
        ),
    ] {
        let path = dir.join(name);
        crate::render::write_atomically(&path, &bytes).map_err(|e| {
            Failure::from(vec![UserError::new(
                path.display().to_string(),
                format!("cannot write: {e}"),
            )])
        })?;
        emit(&format!("wrote {}\n", path.display()))?;
    }
    for r in &rows {
        emit(&format!(
            "{}: {} = {} ({})\n",
            r.file,
            r.validation.statistic.name,
            r.mean
                .map_or_else(|| "n/a".to_owned(), |m| format!("{m:.4}")),
            r.verdict
        ))?;
    }
    Ok(())
}

pub(super) fn analyze_command(
    dir: &Path,
    out: Option<&Path>,
    csv_only: bool,
) -> Result<(), Failure> {
    use crate::analysis::Check;
    let check = if csv_only {
        Check::CsvOnly
    } else {
        Check::AgainstLogs
    };
    let out = out.map_or_else(|| dir.join("report"), Path::to_path_buf);
    // Told before the analysis, which can take minutes, not after it.
    if out.exists() && !out.is_dir() {
        return Err(Failure {
            code: EXIT_BAD_INPUT,
            errors: vec![UserError::new(
                out.display().to_string(),
                "exists and is not a folder: the report is written into a folder (--out)",
            )],
        });
    }
    let analysis = crate::analysis::analyze_with::<Registry>(dir, check).map_err(|mut e| {
        if e.message.starts_with(results::NO_LOG) {
            e.message
                .push_str("; to analyse CSVs alone, unchecked, give --csv-only");
        }
        Failure::from(vec![e])
    })?;
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

pub(super) fn identify_command(args: &IdentifyArgs) -> Result<(), Failure> {
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
pub(super) fn gui_command(
    args: GuiArgs,
    start: Option<crate::gui::AutoStart>,
) -> Result<(), Failure> {
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
    let mut errors = Vec::new();
    if args.start {
        if args.participant.trim().is_empty() {
            errors.push(UserError::new(
                "--start",
                "needs --participant (and --protocol): the session to open",
            ));
        } else if let Err(why) = crate::results::check_participant(args.participant.trim()) {
            errors.push(UserError::new("--participant", why));
        }
    }
    let lsl = load_lsl(&args.lsl, &mut errors);
    if !errors.is_empty() {
        return Err(errors.into());
    }
    let start = start.or(args.start.then_some(crate::gui::AutoStart {
        resume: false,
        or_resume: true,
        seed: None,
        participant_index: None,
    }));
    let interrupt = install_interrupt()?;
    crate::gui::run(crate::gui::Launch {
        protocol: args.protocol,
        participant: args.participant,
        out: args.out,
        device: args.device,
        start,
        interrupt: Some(interrupt.clone()),
        lsl: lsl.map(|s| s.lib),
        lsl_lib: args.lsl.lsl_lib,
        sound: args.sound.choice(),
    })
    .map_err(|e| no_display(&e))?;
    match interrupt.signal() {
        Some(signal) => {
            say(&format!(
                "interrupted by {}: the window closed; a trial under way is logged as aborted ({}), and the session can be resumed from the window or with `frictionlab run ... --resume`",
                signal.name(),
                session::INTERRUPTED
            ));
            Err(Failure {
                code: signal.exit_code(),
                errors: Vec::new(),
            })
        }
        None => Ok(()),
    }
}

pub(super) fn ports_command() -> Result<(), Failure> {
    let found = crate::device::find_all();
    if found.is_empty() {
        return emit("no devices found\n");
    }
    let mut lines = String::new();
    for (kind, f) in found {
        let address = crate::device::Address {
            kind: kind.name,
            target: f.address,
            settings: crate::device::Settings::default(),
        };
        let _ = writeln!(lines, "{address}\t{}\t{}", f.what, kind.name);
    }
    emit(&lines)
}

/// The sound a run plays ([`session::sound::Sound::open`]), opened
/// before anything is written: a protocol with masking and no
/// `--masking-audio`, an output and no masking, `--tactile-audio` on the
/// simulated apparatus or with a bad channel, no server or no such output
/// is exit 2, one line. The noise is seeded by the session's plan seed.
fn open_sound(
    file: &Path,
    protocol: &crate::kinds::Protocol,
    args: &SoundArgs,
    device: &DeviceChoice,
    seed: u64,
    timeout_s: f64,
) -> Result<session::sound::Sound, Failure> {
    use session::sound::SoundError;
    let choice = args.choice();
    let on_device = *device != DeviceChoice::Simulated;
    session::sound::Sound::open(protocol.masking, &choice, on_device, seed, timeout_s).map_err(
        |e| {
            let (place, what) = match &e {
                SoundError::NoMaskingOutput { noise, level_dbfs } => (
                    format!("{}: masking", file.display()),
                    format!(
                        "the protocol plays {noise} noise at {level_dbfs} dBFS on headphones; give --masking-audio OUTPUT (`frictionlab audio` lists the outputs)"
                    ),
                ),
                SoundError::NoMasking => ("--masking-audio".to_owned(), format!("{}: {e}", file.display())),
                SoundError::Masking(_) => ("--masking-audio".to_owned(), e.to_string()),
                SoundError::TactileWithoutDevice => (
                    "--tactile-audio".to_owned(),
                    format!("{e}; give --device (the Inverse3 emulator will do)"),
                ),
                SoundError::Tactile(_) => ("--tactile-audio".to_owned(), e.to_string()),
            };
            Failure::from(vec![UserError::new(&place, what)])
        },
    )
}

/// `audio`: the sound server's outputs, a line each; no server is exit 2.
pub(super) fn audio_command() -> Result<(), Failure> {
    let outputs = crate::audio::outputs()
        .map_err(|e| Failure::from(vec![UserError::new("audio", e.to_string())]))?;
    if outputs.is_empty() {
        return emit("no outputs on the sound server\n");
    }
    let mut lines = String::new();
    for o in outputs {
        let _ = writeln!(
            lines,
            "{}\t{}\t{}\t{}",
            o.name, o.channels, o.rate_hz, o.description
        );
    }
    emit(&lines)
}

/// `device-emulator inverse3[:HOST:PORT]`.
pub(super) fn inverse3_emulator_command(
    target: &str,
    version: Option<String>,
    no_device: bool,
    lockstep: bool,
    miswiring: Miswiring,
) -> Result<(), Failure> {
    use crate::device::inverse3::{self, emulator};
    let place = format!("inverse3:{target}");
    let address =
        inverse3::address(target).map_err(|e| Failure::from(vec![UserError::new(&place, e)]))?;
    let listener = std::net::TcpListener::bind(&address)
        .map_err(|e| device_failure(&place, format!("cannot listen on {address}: {e}")))?;
    let options = emulator::Options {
        version: version.unwrap_or_else(|| emulator::VERSION.to_owned()),
        with_device: !no_device,
        lockstep,
        miswiring,
    };
    emit(&format!(
        "Inverse Service emulator {} on {address}{}\n",
        options.version,
        if no_device {
            " (no Inverse3 on it)"
        } else {
            ""
        }
    ))?;
    let track = inverse3::Config::default().track;
    emulator::serve(&listener, track, &options).map_err(|e| device_failure(&place, e.to_string()))
}

/// `device-emulator haply2diy:PATH`.
pub(super) fn haply2diy_emulator_command(
    path: &Path,
    lockstep: bool,
    transcript: Option<&Path>,
    miswiring: Miswiring,
) -> Result<(), Failure> {
    use crate::device::haply2diy::{Config, emulator};
    use crate::device::pty::{self, Endpoint, OpenError};
    let place = format!("haply2diy:{}", path.display());
    let open = || {
        pty::open(path).map_err(|e| match e {
            OpenError::NotAPort(_) => Failure::from(vec![UserError::new(&place, e.to_string())]),
            _ => device_failure(&place, e.to_string()),
        })
    };
    let mut port = open()?;
    let mut log = match transcript {
        Some(t) => Some(
            std::fs::OpenOptions::new()
                .create(true)
                .append(true)
                .open(t)
                .map_err(|e| {
                    Failure::from(vec![UserError::new(t.display().to_string(), e.to_string())])
                })?,
        ),
        None => None,
    };
    let hand = crate::device::hand_link::Receiver::bind(path)
        .map_err(|e| device_failure(&place, format!("cannot bind the hand's socket: {e}")))?;
    emit(&match port.endpoint() {
        Endpoint::Port => format!("haply2diy emulator on {place}\n"),
        Endpoint::Pty { slave, .. } => {
            format!(
                "haply2diy emulator on {place} (pseudo-terminal {})\n",
                slave.display()
            )
        }
    })?;
    let mut core = emulator::BoardCore::new(&Config::vendor(3)).miswired(&miswiring);
    let clock = if lockstep {
        emulator::Clock::Lockstep
    } else {
        emulator::Clock::Real
    };
    let faults = emulator::Faults::default();
    #[cfg(unix)]
    for (signal, flag) in [
        (signal_hook::consts::SIGUSR1, &faults.lose_setup),
        (signal_hook::consts::SIGUSR2, &faults.replug),
    ] {
        signal_hook::flag::register(signal, std::sync::Arc::clone(flag))
            .map_err(|e| device_failure(&place, format!("cannot handle signals: {e}")))?;
    }
    loop {
        let served = emulator::serve(
            port.port(),
            &mut core,
            clock,
            Some(&hand),
            &faults,
            |from_host, bytes| {
                if let Some(f) = log.as_mut() {
                    use std::io::Write as _;
                    let mut line = String::from(if from_host { "> " } else { "< " });
                    for b in bytes {
                        let _ = write!(line, "{b:02x}");
                    }
                    let _ = writeln!(f, "{line}");
                }
            },
        )
        .map_err(|e| device_failure(&place, e.to_string()))?;
        match served {
            emulator::Served::LoseSetup if core.is_set_up() => {
                // A restart: the port goes away as the board's USB starts
                // again, and comes back with the board not set up.
                port.unplug(path);
                core.lose_setup();
                core.replugged();
                std::thread::sleep(std::time::Duration::from_secs_f64(emulator::REPLUG_GAP_S));
                port = open()?;
                emit("haply2diy emulator: the board lost its setup (SIGUSR1)\n")?;
            }
            emulator::Served::LoseSetup => {
                core.park();
                emit("haply2diy emulator: the handle put at its calibration pose (SIGUSR1)\n")?;
            }
            emulator::Served::Replug => {
                // The port goes away (its link removed, its pseudo-terminal
                // closed) and comes back, the board as it was.
                port.unplug(path);
                core.replugged();
                std::thread::sleep(std::time::Duration::from_secs_f64(emulator::REPLUG_GAP_S));
                port = open()?;
                emit(&format!(
                    "haply2diy emulator: port replugged (SIGUSR2), the board still set up, on {place}\n"
                ))?;
            }
        }
    }
}

pub(super) fn emulator_command(
    path: &Path,
    on_board: bool,
    link_delay_ms: u16,
    miswiring: Miswiring,
) -> Result<(), Failure> {
    use crate::device::frictionlab::emulator::{self, Endpoint, OpenError};
    let place = path.display().to_string();
    let mut emulator = emulator::open(path).map_err(|e| match e {
        OpenError::NotAPort(_) => Failure::from(vec![UserError::new(&place, e.to_string())]),
        _ => device_failure(&place, e.to_string()),
    })?;
    let mode = if on_board {
        " (on-board rendering, wire protocol v2)"
    } else {
        ""
    };
    emit(&match emulator.endpoint() {
        Endpoint::Port => format!("device emulator{mode} on {place}\n"),
        Endpoint::Pty { slave, replaced } => format!(
            "device emulator{mode} on {place} (pseudo-terminal {}{})\n",
            slave.display(),
            replaced.as_ref().map_or_else(String::new, |old| format!(
                "; replaced the link to {}, which was gone",
                old.display()
            ))
        ),
    })?;
    let core = if on_board {
        emulator::EmulatorCore::on_board()
    } else {
        emulator::EmulatorCore::new()
    }
    .miswired(miswiring);
    emulator
        .serve(
            core,
            std::time::Duration::from_millis(link_delay_ms.into()),
            |_| {},
        )
        .map_err(|e| device_failure(&place, e.to_string()))
}

pub(super) fn firmware_qemu_command(elf: &Path, link: Option<&Path>) -> Result<(), Failure> {
    use crate::device::frictionlab::{emulator, qemu};
    let place = elf.display().to_string();
    let interrupt = install_interrupt()?;
    let mut board = qemu::boot(elf).map_err(|e| match e {
        qemu::BootError::NoFirmware => Failure::from(vec![UserError::new(&place, e.to_string())]),
        _ => device_failure(&place, e.to_string()),
    })?;
    let mut linked = String::new();
    if let Some(link) = link {
        // A link to a pseudo-terminal (an earlier QEMU's: a host may still
        // hold it open) is this command's to replace.
        if std::fs::read_link(link).is_ok_and(|t| t.parent() == board.pty.parent()) {
            let _ = std::fs::remove_file(link);
        }
        if let Err(e) = emulator::link_pty(link, &board.pty) {
            let _ = board.child.kill();
            return Err(Failure::from(vec![UserError::new(
                link.display().to_string(),
                e.to_string(),
            )]));
        }
        linked = format!(", linked at {}", link.display());
    }
    emit(&format!(
        "firmware on QEMU mps2-an386: {}{linked} (QEMU pid {})\n",
        board.pty.display(),
        board.child.id()
    ))?;
    // QEMU runs until it ends or a signal ends this command: then QEMU is
    // stopped and waited for, so no QEMU outlives it holding the link.
    let status = loop {
        if let Some(signal) = interrupt.signal() {
            let _ = board.child.kill();
            let _ = board.child.wait();
            say(&format!(
                "interrupted by {}: {} (pid {}) stopped",
                signal.name(),
                qemu::QEMU,
                board.child.id()
            ));
            return Err(Failure {
                code: signal.exit_code(),
                errors: Vec::new(),
            });
        }
        match board.child.try_wait() {
            Ok(Some(status)) => break status,
            Ok(None) => std::thread::sleep(std::time::Duration::from_millis(50)),
            Err(e) => return Err(device_failure(&place, e.to_string())),
        }
    };
    if status.success() {
        Ok(())
    } else {
        Err(device_failure(
            &place,
            format!("{} ended: {status}", qemu::QEMU),
        ))
    }
}

/// This process's peak resident memory, MiB (Linux: `VmHWM`).
fn peak_memory_mib() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib / 1024)
}

/// liblsl, with `--lsl` (issue 34): found and checked before anything is
/// written; not found, too old or not liblsl is an error of `--lsl`.
fn load_lsl(args: &LslArgs, errors: &mut Vec<UserError>) -> Option<crate::lsl::Streaming> {
    if !args.lsl {
        return None;
    }
    if !(args.lsl_wait.is_finite() && args.lsl_wait >= 0.0) {
        errors.push(UserError::new(
            "--lsl-wait",
            format!(
                "must be a number of seconds, 0 or more, got {}",
                args.lsl_wait
            ),
        ));
    }
    crate::lsl::load(args.lsl_lib.as_deref())
        .map_err(|e| errors.push(UserError::new("--lsl", e.to_string())))
        .ok()
        .map(|lib| crate::lsl::Streaming {
            lib,
            wait_s: args.lsl_wait,
        })
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
    if let DeviceChoice::Device(address) = &args.device
        && let Err(e) = address.check()
    {
        errors.push(UserError::new("--device", format!("{address}: {e}")));
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

/// Says how a run a signal stopped can be resumed; its exit.
fn interrupted_run(
    args: &RunArgs,
    outcome: &session::SessionOutcome,
    signal: crate::interrupt::Signal,
) -> Failure {
    let stopped = if outcome.log.exists() {
        format!(
            "session {} of '{}' stopped with {} trials completed; the trial under way, if any, is logged as aborted ({}). Resume with: {}",
            outcome.session,
            args.participant,
            outcome.completed,
            session::INTERRUPTED,
            resume_command(args)
        )
    } else {
        "stopped before the device answered: nothing was written".to_owned()
    };
    say(&format!("interrupted by {}: {stopped}", signal.name()));
    Failure {
        code: signal.exit_code(),
        errors: Vec::new(),
    }
}

pub(super) fn run_command(args: &RunArgs) -> Result<(), Failure> {
    let mut errors = check_run_args(args);
    let lsl = load_lsl(&args.lsl, &mut errors);
    let (protocol, bytes) = match load_protocol(&args.protocol) {
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
                start: false,
                lsl: args.lsl.clone(),
                sound: args.sound.clone(),
            },
            Some(crate::gui::AutoStart {
                resume: args.resume,
                or_resume: false,
                seed: args.seed,
                participant_index: args.participant_index,
            }),
        );
    }
    let seed = args.seed.unwrap_or_else(rand::random::<u64>);
    let sound = open_sound(
        &args.protocol,
        &protocol,
        &args.sound,
        &args.device,
        seed,
        args.device_timeout,
    )?;
    let interrupt = install_interrupt()?;
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
        population: None,
        sound,
        lsl: lsl.as_ref(),
    };
    let outcome = match &args.device {
        DeviceChoice::Simulated => {
            session::run_simulated(&dir, &req, Some(&interrupt), &mut |_, _| {})
                .map_err(|e| session_failure(&args.protocol, e))
        }
        DeviceChoice::Device(address) => session::run_device_asking(
            &dir,
            &req,
            args.device_timeout,
            session::sim_participant,
            Some(&interrupt),
            &mut |_, _| {},
            &mut Terminal::default(),
        )
        .map_err(|e| device_run_failure(&args.protocol, address, e)),
    }?;
    if outcome.torn_bytes > 0 {
        say(&format!(
            "note: {}: a torn last line ({} bytes) was ignored and cut before resuming",
            outcome.log.display(),
            outcome.torn_bytes
        ));
    }
    if let Some(signal) = outcome.interrupted {
        return Err(interrupted_run(args, &outcome, signal));
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

/// How a run on a device failed, as the command line says it: a device
/// the run could not ride out is exit 3, its line naming the device.
fn device_run_failure(
    protocol: &Path,
    address: &crate::device::Address,
    e: SessionError,
) -> Failure {
    match e {
        SessionError::Results(_)
        | SessionError::NothingToResume { .. }
        | SessionError::Ended { .. }
        | SessionError::Device(..)
        | SessionError::WrongDevice(..)
        | SessionError::BeyondTravel(_)
        | SessionError::Lsl(_)
        | SessionError::SoundLost { .. } => session_failure(protocol, e),
        e => device_failure(&format!("--device {address}"), e.to_string()),
    }
}

/// What a device asks of the experimenter, put on the terminal: the
/// request on standard error, Enter on standard input confirms. No one can
/// be asked where standard input is no terminal.
#[derive(Default)]
struct Terminal {
    /// A line read from standard input, by a thread that reads them as
    /// they come (started at the first request).
    lines: Option<std::sync::mpsc::Receiver<()>>,
}

impl session::Ask for Terminal {
    fn ask(&mut self, request: crate::device::haptic::Request, within_s: f64) -> bool {
        use std::io::{BufRead as _, IsTerminal as _};
        if !std::io::stdin().is_terminal() {
            return false;
        }
        let lines = self.lines.get_or_insert_with(|| {
            let (tx, rx) = std::sync::mpsc::channel();
            std::thread::spawn(move || {
                for line in std::io::stdin().lock().lines() {
                    if line.is_err() || tx.send(()).is_err() {
                        break;
                    }
                }
            });
            rx
        });
        // Lines typed before the request answer nothing.
        while lines.try_recv().is_ok() {}
        say(&format!(
            "device: {}; press Enter when it is there (within {within_s} s)",
            request.ask()
        ));
        true
    }

    fn confirmed(&mut self) -> bool {
        self.lines.as_ref().is_some_and(|l| l.try_recv().is_ok())
    }
}

/// Installs the SIGINT/SIGTERM/SIGHUP handlers a session's run reads
/// (issue 31).
fn install_interrupt() -> Result<crate::interrupt::Interrupt, Failure> {
    crate::interrupt::Interrupt::install().map_err(|e| Failure {
        code: EXIT_FAILURE,
        errors: vec![UserError::new("signals", format!("cannot handle: {e}"))],
    })
}

/// A word for a shell: quoted unless it is plain.
fn shell_word(text: &str) -> String {
    let plain = !text.is_empty()
        && text
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || "-_./=:,+@%".contains(c));
    if plain {
        text.to_owned()
    } else {
        format!("'{}'", text.replace('\'', "'\\''"))
    }
}

/// The command that resumes `args`' session.
fn resume_command(args: &RunArgs) -> String {
    let mut words = vec![
        "frictionlab".to_owned(),
        "run".to_owned(),
        shell_word(&args.protocol.display().to_string()),
        "--participant".to_owned(),
        shell_word(&args.participant),
        "--out".to_owned(),
        shell_word(&args.out.display().to_string()),
    ];
    if let DeviceChoice::Device(address) = &args.device {
        words.push("--device".to_owned());
        words.push(shell_word(&address.to_string()));
        for set in &address.settings.set {
            words.push("--device-set".to_owned());
            words.push(shell_word(set));
        }
    }
    if args.responder == ResponderChoice::Sim {
        words.extend(["--responder".to_owned(), "sim".to_owned()]);
    }
    // How it ran (no data depends on these, but a resume should run alike).
    if args.device_timeout != super::DEFAULT_DEVICE_TIMEOUT_S {
        words.extend([
            "--device-timeout".to_owned(),
            args.device_timeout.to_string(),
        ]);
    }
    if args.pace != super::DEFAULT_PACE {
        words.extend(["--pace".to_owned(), args.pace.to_string()]);
    }
    if args.lsl.lsl {
        words.push("--lsl".to_owned());
        if let Some(lib) = &args.lsl.lsl_lib {
            words.extend([
                "--lsl-lib".to_owned(),
                shell_word(&lib.display().to_string()),
            ]);
        }
        if args.lsl.lsl_wait > 0.0 {
            words.extend(["--lsl-wait".to_owned(), args.lsl.lsl_wait.to_string()]);
        }
    }
    words.push("--resume".to_owned());
    words.join(" ")
}

/// Reads `--population FILE` if given; its problems go to `errors`.
fn read_population(
    path: Option<&Path>,
    errors: &mut Vec<UserError>,
) -> Option<crate::participant::Population> {
    match crate::participant::population::read(path?) {
        Ok(p) => Some(p),
        Err(e) => {
            errors.extend(e);
            None
        }
    }
}

pub(super) fn simulate_command(args: &SimulateArgs) -> Result<(), Failure> {
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
    if args.lsl.lsl && args.pace.is_none() {
        errors.push(UserError::new(
            "--lsl",
            "needs --pace: a session published on LSL runs against the clock (`--pace 1` is real time)",
        ));
    }
    let population = read_population(args.population.as_deref(), &mut errors);
    let lsl = load_lsl(&args.lsl, &mut errors);
    let (protocol, bytes) = match load_protocol(&args.protocol) {
        Ok(ok) if errors.is_empty() => ok,
        Ok(_) => return Err(errors.into()),
        Err(e) => {
            errors.extend(e);
            return Err(errors.into());
        }
    };
    let beyond = beyond_simulated_travel(&protocol, &args.protocol);
    if !beyond.is_empty() {
        return Err(beyond.into());
    }
    if let (Some(pop), Some(file)) = (&population, &args.population) {
        let problems = preference_problems(pop, &protocol, file);
        if !problems.is_empty() {
            return Err(problems.into());
        }
    }
    let dir = results::ResultsDir::new(&args.out);
    let planned = <Registry as crate::protocol::kind::Kinds>::source(&protocol, 0, 0)
        .planned()
        .unwrap_or(0) as u64;
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
    let interrupt = install_interrupt()?;
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
            population: population.as_ref(),
            stop: Some(&interrupt),
            lsl: lsl.as_ref(),
        },
        &|done| bar.set_position(done as u64),
    )?;
    bar.finish_and_clear();
    if let Some(signal) = interrupt.signal() {
        return Err(simulate_interrupted(args, &outcomes, signal));
    }
    let simulated: f64 = outcomes.iter().map(|o| o.simulated_s).sum();
    let trials: usize = outcomes.iter().map(|o| o.completed + o.aborted).sum();
    let elapsed = wall.elapsed().as_secs_f64();
    emit(&format!(
        "simulated {} sessions of '{}' ({jobs} at a time): {trials} trials, {simulated:.1} s of session time in {elapsed:.2} s ({:.0}x real time) -> {}\n",
        args.participants,
        protocol.id,
        simulated / elapsed.max(1e-9),
        dir.root().display()
    ))
}

/// Says which simulated sessions a signal stopped and how to resume them,
/// and which never started (nothing written for them).
fn simulate_interrupted(
    args: &SimulateArgs,
    outcomes: &[session::SessionOutcome],
    signal: crate::interrupt::Signal,
) -> Failure {
    let stopped: Vec<&str> = outcomes
        .iter()
        .filter(|o| o.interrupted.is_some())
        .map(|o| o.participant.as_str())
        .collect();
    let mut line = format!(
        "interrupted by {}: {} of {} sessions finished",
        signal.name(),
        outcomes.len() - stopped.len(),
        args.participants
    );
    if !stopped.is_empty() {
        let _ = write!(
            line,
            "; {} stopped (the trial under way logged as aborted, {}): resume each with frictionlab run {} --participant ID --out {} --responder sim --resume",
            stopped.join(", "),
            session::INTERRUPTED,
            shell_word(&args.protocol.display().to_string()),
            shell_word(&args.out.display().to_string())
        );
    }
    let unstarted = args.participants as usize - outcomes.len();
    if unstarted > 0 {
        let _ = write!(line, "; {unstarted} not started (nothing written for them)");
    }
    say(&line);
    Failure {
        code: signal.exit_code(),
        errors: Vec::new(),
    }
}

impl From<crate::power::PowerError> for Failure {
    fn from(e: crate::power::PowerError) -> Self {
        use crate::power::PowerError;
        match e {
            PowerError::Input(errors) => errors.into(),
            PowerError::Io(e) => Failure {
                code: EXIT_FAILURE,
                errors: vec![e],
            },
            PowerError::Session(e) => e.into(),
        }
    }
}

/// A population's problems with the protocol, located in its file.
fn preference_problems(
    population: &crate::participant::Population,
    protocol: &Protocol,
    file: &Path,
) -> Vec<UserError> {
    population
        .protocol_problems(protocol)
        .into_iter()
        .map(|(field, what)| UserError::new(format!("{}: $.{field}", file.display()), what))
        .collect()
}

pub(super) fn power_command(args: &PowerArgs) -> Result<(), Failure> {
    use crate::power::{Plan, PlanHeader, Shard};
    let mut errors = Vec::new();
    if args.jobs == Some(0) {
        errors.push(UserError::new("--jobs", "must be at least 1"));
    }
    let shard = match &args.shard {
        Some(text) => Shard::parse(text, "--shard").map(Some),
        None => Shard::from_slurm(|name| std::env::var(name).ok()),
    };
    let shard = match shard {
        Ok(s) => s.unwrap_or(Shard::ALL),
        Err(e) => {
            errors.push(e);
            Shard::ALL
        }
    };
    let population = read_population(args.population.as_deref(), &mut errors);
    let loaded = load_protocol(&args.protocol)
        .map_err(|e| errors.extend(e))
        .ok();
    let (Some((protocol, bytes)), true) = (loaded, errors.is_empty()) else {
        return Err(errors.into());
    };
    if let (Some(pop), Some(file)) = (&population, &args.population) {
        errors.extend(preference_problems(pop, &protocol, file));
    }
    let header = PlanHeader {
        protocol: protocol.id.clone(),
        kind: protocol.kind().to_owned(),
        protocol_sha256: crate::results::sha256_hex(&bytes),
        participants: args.participants.clone(),
        studies: args.studies,
        seed: args.seed,
        alpha: args.alpha,
        target_power: args.power,
        max_ci_width: args.max_ci_width,
        population: population.filter(|p| *p != crate::participant::Population::default()),
    };
    errors.extend(header.problems());
    if !errors.is_empty() {
        return Err(errors.into());
    }
    let plan = Plan {
        header,
        protocol: &protocol,
        protocol_bytes: &bytes,
    };
    let jobs = args
        .jobs
        .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, std::num::NonZero::get));
    let bar = indicatif::ProgressBar::new(0);
    bar.set_style(
        indicatif::ProgressStyle::with_template(
            "{bar:40} {pos}/{len} studies, ETA {eta} [{elapsed_precise}]",
        )
        .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    let wall = std::time::Instant::now();
    let started = std::sync::atomic::AtomicBool::new(false);
    let outcome = crate::power::run_shard(&plan, shard, &args.out, jobs, &|done, total| {
        bar.set_length(total as u64);
        bar.set_position(done as u64);
        // The first call counts the studies found done (a rerun): the ETA
        // follows the studies run from now on.
        if !started.swap(true, std::sync::atomic::Ordering::Relaxed) {
            bar.reset_eta();
        }
    })?;
    bar.finish_and_clear();
    let elapsed = wall.elapsed().as_secs_f64();
    let per_study = if outcome.ran > 0 {
        format!(
            ", {:.3} s per study ({:.3} s of one thread's time)",
            elapsed / outcome.ran as f64,
            elapsed * jobs.min(outcome.ran) as f64 / outcome.ran as f64
        )
    } else {
        String::new()
    };
    emit(&format!(
        "power: shard {}/{} of '{}': {} studies run, {} found done, in {elapsed:.2} s on {jobs} thread(s){per_study} -> {}\n",
        shard.k,
        shard.n,
        protocol.id,
        outcome.ran,
        outcome.resumed,
        outcome.file.display()
    ))?;
    if shard.n == 1 {
        let power = crate::power::summarize(&plan.header, &outcome.studies);
        crate::power::write(&args.out, &power)?;
        report_power(&args.out, &power)?;
    }
    Ok(())
}

/// Prints where power.json went and each test's smallest sample size.
fn report_power(out: &Path, power: &serde_json::Value) -> Result<(), Failure> {
    let tests = power["tests"].as_array().map_or(&[][..], Vec::as_slice);
    let reached = tests.iter().filter(|t| t["smallest_n"].is_u64()).count();
    let mut text = format!(
        "wrote {} and power.html: {} tests, {reached} reach power {} within the sizes\n",
        out.join("power.json").display(),
        tests.len(),
        power["plan"]["target_power"]
    );
    for t in tests.iter().take(12) {
        let _ = writeln!(
            text,
            "  {}: smallest n {}",
            t["name"].as_str().unwrap_or("?"),
            t["smallest_n"]
                .as_u64()
                .map_or_else(|| "not reached".to_owned(), |n| n.to_string())
        );
    }
    if tests.len() > 12 {
        let _ = writeln!(text, "  ... and {} more in power.json", tests.len() - 12);
    }
    emit(&text)
}

pub(super) fn power_merge_command(dirs: &[PathBuf], out: Option<&Path>) -> Result<(), Failure> {
    let (plan, studies) = crate::power::merge(dirs)?;
    let out = out.map_or_else(|| dirs[0].clone(), Path::to_path_buf);
    let power = crate::power::summarize(&plan, &studies);
    crate::power::write(&out, &power)?;
    report_power(&out, &power)
}

/// Every model's and scenario's default parameters, pretty JSON.
pub(super) fn models_json() -> String {
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

/// Re-renders a stream and prints the report; a stream with no row
/// compared shows nothing, and exits 2 after its report (issue 63).
pub(super) fn rerender_command(stream: &Path) -> Result<(), Failure> {
    let r = crate::rerender::rerender_file(stream).map_err(|e| Failure::from(vec![e]))?;
    emit(&format!(
        "{}\n",
        serde_json::to_string_pretty(&r).unwrap_or_default()
    ))?;
    if r.compared == 0 {
        return Err(Failure::from(vec![UserError::new(
            &r.stream,
            format!(
                "no row compared: none of its {} rows follows the select of a model from rest{}",
                r.rows,
                if r.rows == 0 {
                    " (the stream is empty)"
                } else {
                    ""
                }
            ),
        )]));
    }
    Ok(())
}

pub(super) fn render_command(args: &RenderArgs) -> Result<(), Failure> {
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
    let mut plan = render_plan(&args.model, &args.scenario, &args.set)?;
    if args.float == "f32" {
        plan.settings.float = crate::friction::Float::F32;
    }
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
    let float = match plan.settings.float {
        crate::friction::Float::F64 => "",
        crate::friction::Float::F32 => " in f32",
    };
    emit(&format!(
        "{} / {}: {} samples at {} Hz{float}, t = {t0:.3} .. {t1:.3} s, {onsets} stick-to-slip transitions -> {}\n",
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
            errors.push(set_error("", crate::friction::problem(e)));
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

#[cfg(test)]
mod tests {
    use super::*;

    /// Issue 63: a run whose haptic loop died, or whose device kept
    /// failing, exits 3 with one line naming the device.
    #[test]
    fn a_device_failure_is_exit_3_with_one_line_naming_the_device() {
        let address = crate::device::Address::parse("haply2diy:/dev/ttyACM0").unwrap();
        for failure in [
            session::DeviceFailure::LoopDied("its thread panicked: oops".into()),
            session::DeviceFailure::Faults {
                trial: 4,
                presentations: 3,
                fault: "device lost".into(),
            },
        ] {
            let f = device_run_failure(
                Path::new("p.json"),
                &address,
                SessionError::DeviceFailed {
                    failure,
                    completed: 2,
                },
            );
            let line = f.errors[0].to_string();
            assert_eq!((f.code, f.errors.len()), (super::super::EXIT_DEVICE, 1));
            assert!(
                line.starts_with("--device haply2diy:/dev/ttyACM0: "),
                "{line}"
            );
            assert!(
                line.ends_with("(2 trials completed are in the log)"),
                "{line}"
            );
        }
    }
}
