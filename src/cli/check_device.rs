//! `frictionlab check-device`: the bring-up check on the command line.
//! Each step's result on standard output; prompts and progress on standard
//! error; the experimenter's "done" is Enter on standard input (or the
//! simulated experimenter's, `--responder sim`).

use std::sync::mpsc;
use std::time::Duration;

use super::{
    CheckDeviceArgs, DeviceChoice, EXIT_FAILURE, Experimenter, Failure, UserError, device_failure,
    emit, say,
};
use crate::device::check::{Event, Options};
use crate::results::ResultsDir;
use crate::session::DeviceCheck;

/// How often the check is pumped while it runs.
const PUMP_EVERY: Duration = Duration::from_millis(5);

fn check_args(args: &CheckDeviceArgs) -> Vec<UserError> {
    let mut errors = Vec::new();
    if let DeviceChoice::Device(address) = &args.device {
        if let Err(e) = address.check() {
            errors.push(UserError::new("--device", format!("{address}: {e}")));
        }
        if let Err(e) = address.check_settings() {
            errors.push(UserError::new("--device-set", e));
        }
    }
    for (flag, value) in [
        ("--device-timeout", args.device_timeout),
        ("--duration-s", args.duration_s),
    ] {
        if !(value.is_finite() && value > 0.0) {
            errors.push(UserError::new(
                flag,
                format!("expected a number of seconds above 0, got {value}"),
            ));
        }
    }
    errors
}

/// Lines of standard input, one message each, on a thread of their own
/// (the check goes on while it waits); the channel closes at its end.
fn stdin_lines() -> mpsc::Receiver<()> {
    let (tx, rx) = mpsc::channel();
    let _ = std::thread::Builder::new()
        .name("stdin".into())
        .spawn(move || {
            let mut line = String::new();
            while std::io::stdin().read_line(&mut line).is_ok_and(|n| n > 0) {
                line.clear();
                if tx.send(()).is_err() {
                    break;
                }
            }
        });
    rx
}

/// Shows `events`: steps on standard output, the rest on standard error.
fn show(events: Vec<Event>, person: bool) -> Result<(), Failure> {
    for e in events {
        match e {
            Event::Progress(text) => say(&format!("check-device: {text}")),
            Event::Prompt(ask) => say(&format!(
                "check-device: {} {}",
                ask.text(),
                if person {
                    "[press Enter when done]"
                } else {
                    "[the simulated experimenter does it]"
                }
            )),
            Event::Step(step) => emit(&format!("{}\n", step.line()))?,
            Event::Finished => {}
        }
    }
    Ok(())
}

pub(super) fn check_device_command(args: &CheckDeviceArgs) -> Result<(), Failure> {
    let errors = check_args(args);
    if !errors.is_empty() {
        return Err(errors.into());
    }
    let interrupt = crate::interrupt::Interrupt::install().map_err(|e| Failure {
        code: EXIT_FAILURE,
        errors: vec![UserError::new("signals", format!("cannot handle: {e}"))],
    })?;
    let person = args.responder == Experimenter::Person;
    let options = Options {
        timeout_s: args.device_timeout,
        duration_s: args.duration_s,
    };
    let dir = ResultsDir::new(&args.out);
    let mut check = DeviceCheck::start(&args.device, &dir, options, !person)
        .map_err(|e| device_failure("--device", format!("the haptic loop: {e}")))?;
    emit(&format!("check-device {}\n", check.device()))?;
    let lines = person.then(stdin_lines);
    loop {
        show(check.pump(), person)?;
        if check.finished() {
            break;
        }
        if let Some(signal) = interrupt.signal() {
            drop(check);
            say(&format!(
                "interrupted by {}: the check stopped, no report written",
                signal.name()
            ));
            return Err(Failure {
                code: signal.exit_code(),
                errors: Vec::new(),
            });
        }
        if let Some(lines) = &lines {
            match lines.try_recv() {
                Ok(()) if check.asked().is_some() => show(check.confirm(), person)?,
                Err(mpsc::TryRecvError::Disconnected) if check.asked().is_some() => {
                    drop(check);
                    return Err(vec![UserError::new(
                        "stdin",
                        "closed before the prompt was confirmed; nothing written (--responder sim does what the prompts ask on an emulated device)",
                    )]
                    .into());
                }
                Ok(()) | Err(mpsc::TryRecvError::Empty | mpsc::TryRecvError::Disconnected) => {}
            }
        }
        std::thread::sleep(PUMP_EVERY);
    }
    let done = check.finish()?;
    let failed: Vec<&str> = done
        .report
        .steps
        .iter()
        .filter(|s| !s.verdict.ok())
        .map(|s| s.step.title())
        .collect();
    emit(&format!(
        "{}: {} -> {}\n",
        if done.report.passed {
            "passed"
        } else {
            "FAILED"
        },
        if failed.is_empty() {
            "every step".to_owned()
        } else {
            failed.join(", ")
        },
        done.path.display()
    ))?;
    if done.report.passed {
        Ok(())
    } else {
        Err(device_failure(
            "--device",
            format!(
                "{}: the check failed: {}",
                check_label(&args.device),
                failed.join(", ")
            ),
        ))
    }
}

fn check_label(device: &DeviceChoice) -> String {
    device.label()
}
