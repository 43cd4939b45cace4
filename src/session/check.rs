//! The bring-up check as its shells run it (`frictionlab check-device`,
//! the window's Setup tab): the device opened as a session opens it (the
//! simulated apparatus as its real-time backend), the check
//! ([`crate::device::check`]) run on its haptic loop, and its report kept
//! with the results (`DIR/device-checks/`, which later sessions' headers
//! name). A shell: it opens the device, reads the clock for the report's
//! time and writes the report.

use std::path::PathBuf;

use super::DeviceChoice;
use crate::device::check::{
    Ask, Check, Event, FORMAT, Options, Report, Stated, StepName, StepReport, Verdict,
};
use crate::results::{ResultsDir, ResultsError, device_checks};

/// A bring-up check under way.
pub struct DeviceCheck {
    /// The check on the device's loop; None when the device did not open.
    check: Option<Check>,
    /// The device, as `--device` names it.
    label: String,
    dir: ResultsDir,
    /// The failed handshake of a device that did not open.
    not_opened: Option<StepReport>,
    /// Events not yet taken.
    pending: Vec<Event>,
}

impl std::fmt::Debug for DeviceCheck {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("DeviceCheck")
            .field("label", &self.label)
            .finish_non_exhaustive()
    }
}

/// A check that has ended: its report and where it was kept.
#[derive(Debug, Clone, PartialEq)]
pub struct CheckDone {
    /// The report.
    pub report: Report,
    /// Its file.
    pub path: PathBuf,
}

impl DeviceCheck {
    /// Opens the device `choice` names and starts the check on it, its
    /// report to be kept in `dir`; `sim`: the simulated experimenter does
    /// what the prompts ask. A device that does not open (a service that
    /// does not answer) is a failed handshake: the check ends at once.
    ///
    /// # Errors
    /// The haptic loop's thread could not be started.
    pub fn start(
        choice: &DeviceChoice,
        dir: &ResultsDir,
        options: Options,
        sim: bool,
    ) -> std::io::Result<Self> {
        let opened = match choice {
            DeviceChoice::Simulated => Ok(Box::new(crate::device::sim::RealTime::new())
                as Box<dyn crate::device::backend::Backend>),
            DeviceChoice::Device(address) => address.open(),
        };
        let mut run = DeviceCheck {
            check: None,
            label: choice.label(),
            dir: dir.clone(),
            not_opened: None,
            pending: Vec::new(),
        };
        match opened {
            Ok(device) => run.check = Some(Check::start(device, options, sim)?),
            Err(why) => {
                let report = StepReport {
                    step: StepName::Handshake,
                    verdict: Verdict::Fail,
                    numbers: Vec::new(),
                    rule: "the device opens and answers".into(),
                    detail: why,
                };
                run.pending = vec![Event::Step(report.clone()), Event::Finished];
                run.not_opened = Some(report);
            }
        }
        Ok(run)
    }

    /// The device, as `--device` names it.
    #[must_use]
    pub fn device(&self) -> &str {
        &self.label
    }

    /// What happened since the last call.
    pub fn pump(&mut self) -> Vec<Event> {
        let mut events = std::mem::take(&mut self.pending);
        if let Some(check) = &mut self.check {
            events.extend(check.pump());
        }
        events
    }

    /// The experimenter did what the prompt asked.
    pub fn confirm(&mut self) -> Vec<Event> {
        let mut events = std::mem::take(&mut self.pending);
        if let Some(check) = &mut self.check {
            events.extend(check.confirm());
        }
        events
    }

    /// What the experimenter is asked now, if anything.
    #[must_use]
    pub fn asked(&self) -> Option<Ask> {
        self.check.as_ref().and_then(|c| c.bringup().asked())
    }

    /// The steps done so far.
    #[must_use]
    pub fn results(&self) -> &[StepReport] {
        match (&self.check, &self.not_opened) {
            (Some(c), _) => c.bringup().results(),
            (None, Some(r)) => std::slice::from_ref(r),
            (None, None) => &[],
        }
    }

    /// Whether every step is done.
    #[must_use]
    pub fn finished(&self) -> bool {
        self.check.as_ref().is_none_or(|c| c.bringup().finished())
    }

    /// Stops the device (force zeroed, closed) and keeps the report in
    /// `DIR/device-checks/`, stamped with the clock's time now.
    ///
    /// # Errors
    /// The report could not be written.
    pub fn finish(self) -> Result<CheckDone, ResultsError> {
        let time_utc = humantime::format_rfc3339_seconds(std::time::SystemTime::now()).to_string();
        let report = match (self.check, self.not_opened) {
            (Some(check), _) => check.stop(&self.label, &time_utc),
            (None, not_opened) => Report {
                format: FORMAT.into(),
                software_version: env!("CARGO_PKG_VERSION").into(),
                device: self.label.clone(),
                time_utc: time_utc.clone(),
                passed: false,
                responder: String::new(),
                stated: Stated {
                    axes: 0,
                    force_limit_n: 0.0,
                    travel_m: [0.0; 2],
                    rate_hz: 0.0,
                },
                track: None,
                settings: None,
                steps: not_opened.into_iter().collect(),
                loop_stats: crate::device::haptic::LoopStats::default(),
            },
        };
        let mut text = serde_json::to_vec_pretty(&report).unwrap_or_default();
        text.push(b'\n');
        let path = device_checks::write(&self.dir, &self.label, &time_utc, &text)?;
        Ok(CheckDone { report, path })
    }
}
