//! The board-support traits: what the firmware needs of a board. QEMU's
//! mps2-an386 with a simulated plant (`qemu`) and an STM32F401 "Black
//! Pill" driving a motor (`stm32f401`) implement them.

use frictionlab_core::friction::Input;
use frictionlab_core::onboard::Apparatus;
use frictionlab_core::wire::Message;

/// A board: sensing and actuation for the loop interrupt.
pub trait Board {
    /// Core clock, Hz: what SysTick counts.
    const CORE_HZ: u32;

    /// The loop rate, Hz (a divisor of the core clock).
    const LOOP_RATE_HZ: u16;

    /// What the device states in its `Capabilities`.
    fn apparatus(&self) -> Apparatus;

    /// The largest force the board outputs, N (the firmware clamps to it).
    fn force_limit_n(&self) -> f32;

    /// One loop tick of `dt_s`: senses, lets `control` compute the force
    /// and vibration from the sensed position and velocity, the button and
    /// the end stop, and outputs them.
    fn tick(&mut self, dt_s: f64, control: impl FnOnce(Input<f32>, bool, bool) -> (f32, f32));

    /// A valid message from the host, after the firmware has handled it
    /// (the QEMU board's simulated hand follows `HandDrive`).
    fn host_message(&mut self, _message: &Message) {}
}

/// The board's link to the host. Neither call waits.
pub trait Serial {
    /// Reads what has arrived into `buf`; returns how many bytes.
    fn read(&mut self, buf: &mut [u8]) -> usize;

    /// Writes as much of `bytes` as the link takes now; returns how many.
    fn write(&mut self, bytes: &[u8]) -> usize;
}
