//! A device kind for tests only: the simulated apparatus's real-time
//! backend ([`super::sim::RealTime`]) registered as a kind of its own, with
//! faults to ask for by its target. It is here to show the seam: a kind
//! registered in one line of [`super::KINDS`] runs a whole session
//! (`src/session/headless.rs`'s test, which asks for `--device
//! loopback:test` by name), and no module names it. The targets `flaps`
//! (the link lost 0.15 s of every 0.6 s), `dies` (its loop panics at
//! 0.3 s) and `asks` (it asks for its calibration pose at 1 s, the link
//! lost until confirmed) make the device faults the session must end or
//! ride out (issue 63).

use super::backend::{Backend, Capabilities, LinkState, Reading, Request, Vector};
use super::sim::RealTime;
use crate::hand::HandDrive;

/// The device kind: `loopback:` with any target.
pub const KIND: super::Kind = super::Kind {
    name: "loopback",
    about: "an apparatus in this process (tests only)",
    target: "NAME",
    bare: false,
    check: |_| Ok(()),
    check_settings: |_| Ok(()),
    open: |target, _| Ok(Box::new(Loopback::new(target))),
    find: Vec::new,
};

/// How a loopback device behaves (its target).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Behaviour {
    Steady,
    Flaps,
    Dies,
    Asks,
}

struct Loopback {
    apparatus: RealTime,
    behaviour: Behaviour,
    /// It asks for its calibration pose (`asks`), until confirmed.
    asking: bool,
    confirmed: bool,
}

impl Loopback {
    fn new(target: &str) -> Self {
        Loopback {
            apparatus: RealTime::new(),
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
        self.apparatus.capabilities()
    }

    fn read(&mut self, now_s: f64) -> Reading {
        let reading = self.apparatus.read(now_s);
        let link = match self.behaviour {
            Behaviour::Flaps if now_s % 0.6 >= 0.45 => LinkState::Lost,
            Behaviour::Dies if now_s >= 0.3 => panic!("the loopback device's loop died, as asked"),
            Behaviour::Asks if now_s >= 1.0 && !self.confirmed => {
                self.asking = true;
                LinkState::Lost
            }
            _ => reading.link,
        };
        Reading { link, ..reading }
    }

    fn send_force(&mut self, now_s: f64, force_n: Vector, vibration: f64) {
        self.apparatus.send_force(now_s, force_n, vibration);
    }

    fn close(&mut self) {
        self.apparatus.close();
    }

    fn drive_hand(&mut self, drive: &HandDrive) {
        self.apparatus.drive_hand(drive);
    }

    fn request(&self) -> Option<Request> {
        self.asking.then_some(Request::CalibrationPose)
    }

    fn confirm(&mut self, _now_s: f64) {
        self.asking = false;
        self.confirmed = true;
    }
}
