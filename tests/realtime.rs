//! The integration tests against real clocks: devices and their emulators,
//! QEMU, LSL, real windows, Slurm, a sound server, and signals to live
//! sessions. They share the machine only with each other, two at a time
//! (Cargo.toml says why the tests are four binaries). `cargo test --test realtime lsl::`
//! runs one file's tests.
mod common;

mod check_device;
mod device_link;
mod device_session;
mod firmware_qemu;
mod gui;
mod haply2diy;
mod inverse3;
mod lsl;
mod one_process;
mod slurm;
mod sound;
