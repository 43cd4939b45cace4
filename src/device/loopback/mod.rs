//! A device for tests only: the simulated apparatus of seed 002 with the
//! simulated participant's hand on it, in this process, stepped to the
//! loop's clock. It is here to show the seam: a backend in its own folder,
//! registered in one line of [`super::KINDS`], runs a whole session
//! (`src/session/headless.rs`'s test, which asks for `--device
//! loopback:test` by name), and no module names it.

use super::backend::{Backend, Capabilities, LinkState, Reading, Request, Vector};
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
    open: |target, _| Ok(Box::new(Loopback::new(target))),
    find: Vec::new,
};

/// Physics step, s.
const STEP_S: f64 = 0.0005;

/// How a loopback device behaves (its target).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Behaviour {
    Steady,
    Flaps,
    Dies,
    Asks,
}

struct Loopback {
    rig: Rig,
    force_n: f64,
    t_s: f64,
    x_m: f64,
    behaviour: Behaviour,
    /// It asks for its calibration pose (`asks`), until confirmed.
    asking: bool,
    confirmed: bool,
}

impl Loopback {
    fn new(target: &str) -> Self {
        Loopback {
            rig: Rig::new(Apparatus::default(), 0.4),
            force_n: 0.0,
            t_s: 0.0,
            x_m: 0.0,
            behaviour: match target {
                "flaps" => Behaviour::Flaps,
                "dies" => Behaviour::Dies,
                "asks" => Behaviour::Asks,
                _ => Behaviour::Steady,
            },
            asking: false,
            confirmed: false,
        }
    }
}

impl Backend for Loopback {
    fn capabilities(&self) -> Capabilities {
        Capabilities {
            axes: 1,
            vertical_axis: None,
            force_limit_n: Apparatus::default().max_force_n,
            travel_m: Apparatus::default().travel_m(),
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
        let link = match self.behaviour {
            Behaviour::Flaps if now_s % 0.6 >= 0.45 => LinkState::Lost,
            Behaviour::Dies if now_s >= 0.3 => panic!("the loopback device's loop died, as asked"),
            Behaviour::Asks if now_s >= 1.0 && !self.confirmed => {
                self.asking = true;
                LinkState::Lost
            }
            _ => LinkState::Connected,
        };
        Reading {
            link,
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

    fn request(&self) -> Option<Request> {
        self.asking.then_some(Request::CalibrationPose)
    }

    fn confirm(&mut self, _now_s: f64) {
        self.asking = false;
        self.confirmed = true;
    }
}
