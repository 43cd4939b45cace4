//! The firmware (`firmware/`) on QEMU's mps2-an386, its UART on a host
//! pseudo-terminal: a board to run sessions against without hardware
//! (`frictionlab firmware-qemu`). A shell: it starts a process.

use std::io::{BufRead, BufReader, Write};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::mpsc;
use std::time::Duration;

/// Where `cargo build --release -p frictionlab-firmware --target
/// thumbv7em-none-eabihf` puts the firmware, from the repository.
pub const FIRMWARE_ELF: &str = "target/thumbv7em-none-eabihf/release/frictionlab-firmware";

/// The QEMU that runs it.
pub const QEMU: &str = "qemu-system-arm";

/// How long QEMU may take to say where its UART is.
const BOOT_TIMEOUT: Duration = Duration::from_secs(20);

/// The firmware running in QEMU.
#[derive(Debug)]
pub struct Qemu {
    /// QEMU's process.
    pub child: Child,
    /// The pseudo-terminal QEMU put the firmware's UART on.
    pub pty: PathBuf,
}

/// Why [`boot`] failed; displays as the `<what>` of an error line.
#[derive(Debug, thiserror::Error)]
pub enum BootError {
    /// No firmware file.
    #[error(
        "no firmware there: build it with `cargo build --release -p frictionlab-firmware --target thumbv7em-none-eabihf`"
    )]
    NoFirmware,
    /// QEMU would not start.
    #[error(
        "cannot start {QEMU} (install QEMU's ARM system emulator, Debian's qemu-system-arm): {0}"
    )]
    Start(std::io::Error),
    /// QEMU ended or went quiet before saying where its UART is.
    #[error("{QEMU} did not put the UART on a pseudo-terminal{0}")]
    NoPty(String),
}

/// `name` found on the `PATH`.
fn on_path(name: &str) -> Option<PathBuf> {
    std::env::split_paths(&std::env::var_os("PATH")?)
        .map(|dir| dir.join(name))
        .find(|p| p.is_file())
}

/// The command that starts QEMU so that it dies with this process (issue
/// 31): in its own process group (a terminal's Ctrl-C reaches this process
/// alone, which stops QEMU itself), and on Linux under `setpriv
/// --pdeathsig KILL` (util-linux, on every Debian system), which sets
/// `PR_SET_PDEATHSIG`: the kernel kills QEMU when the thread that started
/// it ends, even under kill -9. Without `setpriv`, QEMU starts plainly.
fn qemu_command() -> Result<Command, BootError> {
    use std::os::unix::process::CommandExt;
    let qemu = on_path(QEMU).ok_or_else(|| {
        BootError::Start(std::io::Error::new(
            std::io::ErrorKind::NotFound,
            "not found on the PATH",
        ))
    })?;
    let mut command = match on_path("setpriv").filter(|_| cfg!(target_os = "linux")) {
        Some(setpriv) => {
            let mut c = Command::new(setpriv);
            c.args(["--pdeathsig", "KILL", "--"]).arg(qemu);
            c
        }
        None => Command::new(qemu),
    };
    command.process_group(0);
    Ok(command)
}

/// Boots the firmware `elf` on mps2-an386 with its UART0 on a new
/// pseudo-terminal. QEMU's standard error, and its standard output but for
/// that line, go to this process's standard error. QEMU dies with the
/// thread that calls this (see `qemu_command`).
///
/// # Errors
/// No firmware at `elf`, no QEMU, or QEMU gave no pseudo-terminal.
pub fn boot(elf: &Path) -> Result<Qemu, BootError> {
    if !elf.is_file() {
        return Err(BootError::NoFirmware);
    }
    let mut child = qemu_command()?
        .args(["-M", "mps2-an386", "-nographic", "-monitor", "none"])
        .args(["-serial", "pty"])
        .args(["-semihosting-config", "enable=on,target=native"])
        .arg("-kernel")
        .arg(elf)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .spawn()
        .map_err(BootError::Start)?;
    let Some(stdout) = child.stdout.take() else {
        let _ = child.kill();
        return Err(BootError::NoPty(String::new()));
    };
    // QEMU says "char device redirected to /dev/pts/N (label serial0)" on
    // its standard output; the rest of it (the firmware's semihosting
    // console) goes to this process's standard error.
    let (tx, rx) = mpsc::channel();
    std::thread::spawn(move || {
        let mut tx = Some(tx);
        for line in BufReader::new(stdout).lines().map_while(Result::ok) {
            let pty = line
                .strip_prefix("char device redirected to ")
                .and_then(|rest| rest.split_whitespace().next());
            match (pty, tx.take()) {
                (Some(pty), Some(tx)) => {
                    let _ = tx.send(PathBuf::from(pty));
                }
                (_, kept) => {
                    tx = kept;
                    // The firmware's console: passed on, as QEMU would.
                    let _ = writeln!(std::io::stderr(), "{line}");
                }
            }
        }
    });
    if let Ok(pty) = rx.recv_timeout(BOOT_TIMEOUT) {
        return Ok(Qemu { child, pty });
    }
    let _ = child.kill();
    let status = child.wait().ok().and_then(|s| s.code());
    Err(BootError::NoPty(status.map_or_else(String::new, |c| {
        format!(" (it exited with {c})")
    })))
}
