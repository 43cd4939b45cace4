//! The simulated apparatus (seed 002's 1-DOF device with a hand on it):
//! the core's [`frictionlab_core::plant`], shared with the emulator and the
//! QEMU firmware, as one more [`Backend`] behind the seam. [`Simulated`]
//! is the apparatus a session steps in its own time (a [`Virtual`] device,
//! the simulated participant's hand pushing on it), rendered by the loop
//! core like every device ([`super::stepped`]); [`RealTime`] is the same
//! apparatus stepped to the haptic loop's clock, its hand following the
//! drive it is sent, for the bring-up check on `sim` and tests of the seam.

pub use frictionlab_core::plant::{Apparatus, SimDevice};

use super::backend::{Backend, Capabilities, LinkState, Reading, Vector, Virtual};
use crate::friction::{ModelParams, StepParams};
use crate::hand::HandDrive;
use frictionlab_core::plant::Rig;

/// What the simulated apparatus can do: one axis, its maximum continuous
/// force and its travel, at any rate.
fn capabilities(apparatus: &Apparatus) -> Capabilities {
    Capabilities {
        axes: 1,
        vertical_axis: None,
        force_limit_n: apparatus.max_force_n,
        travel_m: apparatus.travel_m(),
        max_rate_hz: f64::INFINITY,
        on_board: false,
    }
}

/// What the simulated apparatus reports with its slide at `x_m`: it always
/// answers, and has no button.
fn at(x_m: f64) -> Reading {
    Reading {
        link: LinkState::Connected,
        position_m: [x_m, 0.0, 0.0],
        button: false,
        watchdog: false,
        problem: None,
    }
}

/// The simulated apparatus with a hand on it, in session time: it moves
/// only when told ([`Virtual::elapse`]), under the force last sent and
/// the hand's push.
#[derive(Debug, Clone)]
pub struct Simulated {
    device: SimDevice,
    force_n: f64,
}

impl Simulated {
    /// `apparatus` at rest at its middle with a hand of `hand_mass_kg` on it.
    #[must_use]
    pub fn new(apparatus: Apparatus, hand_mass_kg: f64) -> Self {
        Simulated {
            device: SimDevice::new(apparatus, hand_mass_kg, StepParams::default()),
            force_n: 0.0,
        }
    }
}

impl Backend for Simulated {
    fn capabilities(&self) -> Capabilities {
        capabilities(self.device.apparatus())
    }

    fn read(&mut self, _now_s: f64) -> Reading {
        at(self.device.measured_m())
    }

    fn send_force(&mut self, _now_s: f64, force_n: Vector, _vibration: f64) {
        self.force_n = force_n[0];
    }

    fn close(&mut self) {
        self.force_n = 0.0;
    }
}

impl Virtual for Simulated {
    fn elapse(&mut self, dt: f64, hand_force_n: f64) {
        self.device.advance(dt, hand_force_n, self.force_n);
    }

    fn place(&mut self, x_m: f64) {
        self.device.reset(x_m);
    }

    fn set_physical(&mut self, model: Option<&ModelParams>) {
        self.device.set_physical(model);
    }
}

/// The real-time apparatus's physics step, s.
pub const STEP_S: f64 = 0.0005;

/// The hand's mass on the real-time apparatus, kg (as the simulated
/// participant's).
pub const HAND_MASS_KG: f64 = 0.4;

/// The simulated apparatus with a hand on it, in this process, stepped to
/// the loop's clock in steps of [`STEP_S`]: a [`Backend`] like a device's.
#[derive(Debug, Clone)]
pub struct RealTime {
    rig: Rig,
    force_n: f64,
    t_s: f64,
    x_m: f64,
}

impl Default for RealTime {
    fn default() -> Self {
        Self::new()
    }
}

impl RealTime {
    /// The apparatus at rest at its middle, the hand relaxed.
    #[must_use]
    pub fn new() -> Self {
        RealTime {
            rig: Rig::new(Apparatus::default(), HAND_MASS_KG),
            force_n: 0.0,
            t_s: 0.0,
            x_m: 0.0,
        }
    }
}

impl Backend for RealTime {
    fn capabilities(&self) -> Capabilities {
        capabilities(&Apparatus::default())
    }

    fn read(&mut self, now_s: f64) -> Reading {
        while self.t_s + STEP_S <= now_s {
            let force = self.force_n;
            self.x_m = self.rig.step(STEP_S, |_| force).x_m;
            self.t_s += STEP_S;
        }
        at(self.x_m)
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
