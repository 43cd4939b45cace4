//! A device kind for tests only: the simulated apparatus's real-time
//! backend ([`super::sim::RealTime`]) registered as a kind of its own, with
//! faults to ask for by its target. It is here to show the seam: a kind
//! registered in one line of [`super::KINDS`] runs a whole session
//! (`src/session/headless.rs`'s test, which asks for `--device
//! loopback:test` by name), and no module names it. The targets `flaps`
//! (the link lost 0.15 s of every 0.6 s), `dies` (its loop panics at
//! 0.3 s) and `asks` (it asks for its calibration pose at 1 s, the link
//! lost until confirmed) make the device faults the session must end or
//! ride out (issue 63); `deaf` renders on board (in its own telemetry's
//! terms) and takes no render sent after 0.5 s: it goes on showing the one
//! it had, as a board whose link drops every select would.

use super::backend::{
    Backend, Capabilities, LinkState, Mode, OnBoard, Reading, Request, Tick, Vector,
};
use super::sim::RealTime;
use crate::friction::ModelParams;
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
    Deaf,
}

struct Loopback {
    apparatus: RealTime,
    behaviour: Behaviour,
    /// It asks for its calibration pose (`asks`), until confirmed.
    asking: bool,
    confirmed: bool,
    /// The render a `deaf` device shows in effect.
    in_effect: u32,
}

/// A `deaf` device takes the renders sent until then, s.
const DEAF_AFTER_S: f64 = 0.5;

impl Loopback {
    fn new(target: &str) -> Self {
        Loopback {
            apparatus: RealTime::new(),
            behaviour: match target {
                "flaps" => Behaviour::Flaps,
                "dies" => Behaviour::Dies,
                "asks" => Behaviour::Asks,
                "deaf" => Behaviour::Deaf,
                _ => Behaviour::Steady,
            },
            asking: false,
            confirmed: false,
            in_effect: super::backend::UNKNOWN_RENDER,
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

    fn on_board(&mut self) -> Option<&mut dyn OnBoard> {
        (self.behaviour == Behaviour::Deaf).then_some(self as &mut dyn OnBoard)
    }
}

impl OnBoard for Loopback {
    fn select(&mut self, now_s: f64, render: u32, _model: Option<&ModelParams>) -> bool {
        if now_s < DEAF_AFTER_S {
            self.in_effect = render;
        }
        true
    }

    /// One tick at the apparatus's position, rendering nothing: what it
    /// renders is not the point, which render it shows is.
    fn ticks(&mut self, now_s: f64, reading: &Reading, emit: &mut dyn FnMut(Tick)) -> bool {
        let limit_n = self.apparatus.capabilities().force_limit_n;
        emit(Tick {
            link: reading.link,
            render: self.in_effect,
            mode: Mode::OnBoard {
                rate_hz: 1000,
                float: crate::friction::Float::F64,
                #[expect(clippy::cast_possible_truncation, reason = "the wire's f32")]
                limit_n: limit_n as f32,
            },
            device_limit_n: limit_n,
            ..Tick::on_axis(now_s, reading.position_m[0], 0.0, 0.0, 0.0)
        });
        true
    }
}
