//! A device for tests only: the simulated apparatus of seed 002 with the
//! simulated participant's hand on it, in this process, stepped to the
//! loop's clock. It is here to show the seam: a backend in its own folder,
//! registered in one line of [`super::KINDS`], runs a whole session, and
//! nothing else names it.

use super::backend::{Backend, Capabilities, LinkState, Reading, Vector};
use super::sim::Apparatus;
use crate::hand::HandDrive;
use frictionlab_core::plant::Rig;

/// The device kind: `loopback:` with any target.
pub const KIND: super::Kind = super::Kind {
    name: "loopback",
    about: "an apparatus in this process (tests only)",
    target: "NAME",
    bare: false,
    check: |_| Ok(()),
    open: |_, _| Ok(Box::new(Loopback::new())),
    find: Vec::new,
};

/// Physics step, s.
const STEP_S: f64 = 0.0005;

struct Loopback {
    rig: Rig,
    force_n: f64,
    t_s: f64,
    x_m: f64,
}

impl Loopback {
    fn new() -> Self {
        Loopback {
            rig: Rig::new(Apparatus::default(), 0.4),
            force_n: 0.0,
            t_s: 0.0,
            x_m: 0.0,
        }
    }
}

impl Backend for Loopback {
    fn capabilities(&self) -> Capabilities {
        Capabilities {
            axes: 1,
            vertical_axis: None,
            force_limit_n: Apparatus::default().max_force_n,
            max_rate_hz: f64::INFINITY,
            on_board: false,
        }
    }

    fn read(&mut self, now_s: f64) -> Reading {
        while self.t_s + STEP_S <= now_s {
            let force = self.force_n;
            self.x_m = self.rig.step(STEP_S, |_| force).x_m;
            self.t_s += STEP_S;
        }
        Reading {
            link: LinkState::Connected,
            position_m: [self.x_m, 0.0, 0.0],
            button: false,
            watchdog: false,
            problem: None,
        }
    }

    fn send_force(&mut self, _now_s: f64, force_n: Vector, _vibration: f64) {
        self.force_n = force_n[0];
    }

    fn close(&mut self) {
        self.force_n = 0.0;
    }

    fn drive_hand(&mut self, drive: &HandDrive) {
        self.rig.drive(*drive);
    }
}

#[cfg(test)]
mod tests {
    use crate::kinds::Registry;
    use crate::results::{ResultsDir, read_log};
    use crate::session::{DeviceChoice, SessionRequest, run_device, sim_participant};

    /// A session of magnitude-quick on the test-only device, with the
    /// simulated participant: every trial completes, its stream written.
    #[test]
    fn a_backend_registered_in_one_line_runs_a_whole_session() {
        let bytes = std::fs::read(
            std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("protocols/magnitude-quick.json"),
        )
        .unwrap();
        let protocol =
            crate::protocol::load::parse::<Registry>(std::str::from_utf8(&bytes).unwrap()).unwrap();
        let tmp = tempfile::tempdir().unwrap();
        let dir = ResultsDir::new(tmp.path());
        let device = DeviceChoice::Device(crate::device::Address::parse("loopback:test").unwrap());
        let req = SessionRequest {
            protocol: &protocol,
            protocol_bytes: &bytes,
            participant: "loop",
            participant_index: Some(0),
            seed: 7,
            resume: false,
            pace: Some(1.0),
            device: &device,
            streams: true,
            population: None,
            lsl: None,
        };
        let outcome = run_device(&dir, &req, 5.0, sim_participant, None, &mut |_, _| {}).unwrap();
        let log = tmp
            .path()
            .join("logs/study-magnitudequick_subject-loop_session-1_log.jsonl");
        let read = read_log::<Registry>(&log).unwrap();
        assert!(read.ended, "{outcome:?}");
        assert_eq!(read.header.device, "loopback:test");
        assert_eq!(read.trials.len(), read.header.planned_trials);
        let streams = std::fs::read_dir(tmp.path().join("streams"))
            .unwrap()
            .count();
        assert_eq!(streams, read.trials.len());
    }
}
