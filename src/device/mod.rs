//! Haptic devices. [`sim`] is the simulated apparatus of seed 002, stepped in
//! virtual time. [`wire`] is the serial wire protocol (frames, sans-IO
//! decoder), [`link`] its host side (sans-IO), [`transport`] the serial port
//! that carries it, and [`emulator`] firmware for the simulated apparatus
//! that speaks it.

pub mod emulator;
pub mod haptic;
pub mod link;
pub mod sim;
pub mod transport;
pub mod wire;

/// What a device reports each loop tick.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct DeviceSample {
    /// Measured position (encoder resolution), m.
    pub x_m: f64,
    /// Estimated velocity, m/s.
    pub v_m_s: f64,
    /// Rendered force on the hand this tick, N.
    pub force_n: f64,
    /// Vibrotactile drive this tick, `[-1, 1]`.
    pub vibration: f64,
}
