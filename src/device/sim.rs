//! The simulated apparatus (seed 002's 1-DOF device with a hand on it):
//! the core's [`frictionlab_core::plant`], shared with the emulator and the
//! QEMU firmware.

pub use frictionlab_core::plant::{Apparatus, SimDevice};
