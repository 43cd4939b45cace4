//! frictionlab's firmware: the friction core rendering on board at
//! its board's loop rate ([`board::Board::LOOP_RATE_HZ`]) on a Cortex-M4F 1-DOF haptic device, speaking wire
//! protocol v2 (`docs/wire-protocol.md`) to the host.
//!
//! SysTick interrupts at the loop rate; its handler runs one tick of the
//! core's on-board firmware ([`app::Shared::tick`]): sense, model, force
//! clamp, watchdog, output, telemetry into the transmit queue. It measures
//! its own duration (SysTick's count) and whether the next tick came due
//! before it ended (a missed tick), for the `LoopReport`. The main loop
//! moves bytes between the link and the firmware. No allocation.
//!
//! The board is a cargo feature: `qemu-mps2-an386` (the default) or
//! `stm32f401` (`--no-default-features --features stm32f401`).
#![no_std]
#![no_main]

mod app;
mod board;
#[cfg(all(feature = "qemu-mps2-an386", feature = "stm32f401"))]
compile_error!("choose one board: --no-default-features --features stm32f401");

#[cfg(feature = "qemu-mps2-an386")]
mod qemu;
#[cfg(feature = "stm32f401")]
mod stm32f401;

use core::cell::RefCell;

use cortex_m::peripheral::SYST;
use cortex_m::peripheral::syst::SystClkSource;
use cortex_m_rt::{entry, exception};
use critical_section::Mutex;
use frictionlab_core::wire::Decoder;

use app::Shared;
use board::{Board, Serial};

#[cfg(feature = "qemu-mps2-an386")]
use qemu as hw;
#[cfg(feature = "stm32f401")]
use stm32f401 as hw;

/// The firmware's state, shared by the loop interrupt and the main loop.
static SHARED: Mutex<RefCell<Option<Shared<hw::Hw>>>> = Mutex::new(RefCell::new(None));

/// SysTick's reload value: core clock cycles per loop tick, minus one.
const RELOAD: u32 = hw::Hw::CORE_HZ / hw::Hw::LOOP_RATE_HZ as u32 - 1;

#[entry]
fn main() -> ! {
    let Some(mut cp) = cortex_m::Peripherals::take() else {
        hw::halt()
    };
    let (board, mut serial) = hw::init();
    critical_section::with(|cs| SHARED.borrow(cs).replace(Some(Shared::new(board))));
    cp.SYST.set_clock_source(SystClkSource::Core);
    cp.SYST.set_reload(RELOAD);
    cp.SYST.clear_current();
    cp.SYST.enable_interrupt();
    cp.SYST.enable_counter();

    let mut decoder = Decoder::new();
    let mut rx = [0_u8; 64];
    let mut tx = [0_u8; 256];
    loop {
        let n = serial.read(&mut rx);
        decoder.feed(&rx[..n], |message| {
            critical_section::with(|cs| {
                if let Some(shared) = SHARED.borrow_ref_mut(cs).as_mut() {
                    shared.receive(&message);
                }
            });
        });
        let queued = critical_section::with(|cs| {
            SHARED
                .borrow_ref(cs)
                .as_ref()
                .map_or(0, |shared| shared.peek_tx(&mut tx))
        });
        let sent = if queued > 0 {
            let sent = serial.write(&tx[..queued]);
            critical_section::with(|cs| {
                if let Some(shared) = SHARED.borrow_ref_mut(cs).as_mut() {
                    shared.pop_tx(sent);
                }
            });
            sent
        } else {
            0
        };
        if n == 0 && (queued < tx.len() || sent == 0) {
            // Nothing more to move, or the port takes no more for now:
            // sleep until the next tick or byte. Polling a full port
            // instead starves QEMU's thread that delivers the host's bytes
            // (a Hello answered seconds late under load).
            cortex_m::asm::wfi();
        }
    }
}

#[exception]
fn SysTick() {
    // Reading the control register clears its COUNTFLAG: set again at the
    // end means the counter wrapped during this tick (the next one is late).
    syst_wrapped();
    critical_section::with(|cs| {
        if let Some(shared) = SHARED.borrow_ref_mut(cs).as_mut() {
            shared.tick();
            let elapsed = RELOAD - SYST::get_current();
            let missed = syst_wrapped();
            let cycles_per_us = hw::Hw::CORE_HZ / 1_000_000;
            let loop_us = if missed {
                // At least a whole period.
                (RELOAD + 1 + elapsed) / cycles_per_us
            } else {
                elapsed / cycles_per_us
            };
            shared.firmware.note_loop(loop_us, missed);
        }
    });
}

/// Whether SysTick has wrapped since the last call (its COUNTFLAG).
fn syst_wrapped() -> bool {
    // SAFETY: a read of SysTick's control and status register; the only
    // side effect is clearing COUNTFLAG, which only this function reads.
    let csr = unsafe { (*SYST::PTR).csr.read() };
    csr & (1 << 16) != 0
}
