//! The hand on a device: the core's [`frictionlab_core::hand`], one model
//! for the simulated participant, the device emulator, the QEMU firmware,
//! the window's mouse hand and the scripted scenarios.

pub use frictionlab_core::hand::{Hand, HandDrive, INTEGRAL_LIMIT_N};
