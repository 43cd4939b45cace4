//! Haptic devices. [`sim`] is the simulated apparatus of seed 002, stepped in
//! virtual time; a real device on a serial port comes with the device-link
//! work.

pub mod sim;

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
