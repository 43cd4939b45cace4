//! frictionlab's friction core: every friction model the studies use,
//! `no_std` and without an allocator, so the same code renders friction on
//! the host and on a haptic device's microcontroller.
//!
//! - [`friction`]: the models, their parameters and checks, and
//!   [`friction::Friction`], the one enum a loop steps.
//! - [`real`]: the float they compute in, `f64` on the host or `f32` on a
//!   Cortex-M4F, with `libm` maths on both, so a host re-render in `f32`
//!   matches the device bit for bit.
//! - [`check`]: parameter checks that report through a callback.
//! - [`render`]: a model's parameters as numbers, and the renderer that
//!   crossfades between models and clamps the force.
//! - [`onboard`]: a device rendering models itself (wire protocol v2).
//! - [`plant`] and [`hand`]: seed 002's apparatus with a hand on it, the
//!   simulated device that the host, the emulator and the QEMU firmware
//!   move.
//! - [`wire`]: the device wire protocol's messages, framing (COBS + CRC)
//!   and sans-IO decoder, for the host and the firmware alike.
//! - [`tx`]: the device's transmit queue of whole frames, which a new
//!   host's `Hello` clears for its replies.
//!
//! Nothing here reads a clock, does I/O, allocates or keeps global state:
//! time enters only as a step's `dt`.
#![no_std]
#![forbid(unsafe_code)]

pub mod check;
pub mod friction;
pub mod hand;
pub mod onboard;
pub mod plant;
pub mod real;
pub mod render;
pub mod tx;
pub mod wire;

pub use real::Real;
