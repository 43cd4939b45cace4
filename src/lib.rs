//! frictionlab: renders friction on a haptic device, runs friction-perception
//! experiments, and analyses them.
//!
//! See `ARCHITECTURE.md` for the map. The friction core ([`friction`]) and the
//! scenarios ([`scenario`]) read no clock and do no I/O; the command line
//! ([`cli`]) is a thin shell over them.
// `println!`/`eprintln!` panic on a broken pipe; the command line writes
// through `cli::emit` and `cli::say` instead.
#![deny(clippy::print_stdout, clippy::print_stderr)]

pub mod analysis;
pub mod audio;
pub mod claims;
pub mod cli;
pub mod device;
pub mod friction;
pub mod gui;
pub mod hand;
pub mod identify;
pub mod interrupt;
pub mod kinds;
pub mod lsl;
pub mod parallel;
pub mod participant;
pub mod power;
pub mod problem;
pub mod protocol;
pub mod realtime;
pub mod render;
pub mod rerender;
pub mod results;
pub mod scenario;
pub mod session;
pub mod settings;
pub mod time;
pub mod validation;
