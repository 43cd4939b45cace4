//! The simulated apparatus (seed 002's 1-DOF device with a hand on it):
//! the core's [`frictionlab_core::plant`], shared with the emulator and the
//! QEMU firmware. A session steps it in virtual time ([`SimDevice`]);
//! [`RealTime`] is the same apparatus as one more [`Backend`], stepped to
//! the haptic loop's clock, for the bring-up check on `sim` (issue 63) and
//! for tests of the seam.

pub use frictionlab_core::plant::{Apparatus, SimDevice};

use super::backend::{Backend, Capabilities, LinkState, Reading, Vector};
use crate::hand::HandDrive;
use frictionlab_core::plant::Rig;

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
