//! QEMU's mps2-an386 (Cortex-M4 with FPU, 25 MHz): the host link on the
//! CMSDK APB UART0 (which `-serial pty` puts on a host pseudo-terminal),
//! and seed 002's apparatus simulated in place of motor and encoder: the
//! core's [`Rig`], whose hand follows the host's `HandDrive` messages, as
//! in the device emulator.

use core::cell::RefCell;

use cortex_m::interrupt::InterruptNumber;
use cortex_m_rt::exception;
use critical_section::Mutex;
use frictionlab_core::friction::Input;
use frictionlab_core::onboard::Apparatus as Stated;
use frictionlab_core::plant::{Apparatus, Rig};
use frictionlab_core::wire::Message;
use heapless::Deque;

use crate::board::{Board, Serial};

/// Hand mass on the simulated device, kg (as the device emulator's).
const HAND_MASS_KG: f64 = 0.4;

/// CMSDK APB UART0.
const UART0: usize = 0x4000_4000;
const DATA: usize = 0x00;
const STATE: usize = 0x04;
const CTRL: usize = 0x08;
const INTSTATUS: usize = 0x0c;
const BAUDDIV: usize = 0x10;
const TX_FULL: u32 = 1;
const RX_FULL: u32 = 2;
/// CTRL: transmit enable, receive enable, receive interrupt enable.
const TX_EN: u32 = 1;
const RX_EN: u32 = 2;
const RX_INT_EN: u32 = 8;
/// INTSTATUS: the receive interrupt (write 1 to clear).
const RX_INT: u32 = 2;

/// UART0's receive interrupt on mps2-an386 (QEMU's `hw/arm/mps2.c`: UART
/// n's receive line is IRQ 2n).
#[derive(Clone, Copy)]
struct Uart0Rx;

// SAFETY: 0 is an interrupt of this board's NVIC.
unsafe impl InterruptNumber for Uart0Rx {
    fn number(self) -> u16 {
        0
    }
}

/// Bytes received, from the receive interrupt to the main loop. The UART
/// holds one byte; taking each as it comes keeps the host's frames whole
/// while the main loop sleeps between ticks (polling the UART instead
/// keeps QEMU's device lock busy and stalls its own I/O).
static RX: Mutex<RefCell<Deque<u8, 1024>>> = Mutex::new(RefCell::new(Deque::new()));

/// The board: the simulated apparatus with a hand on it.
pub struct Hw {
    rig: Rig,
    p: Apparatus,
}

/// UART0, the link to the host.
pub struct Uart;

/// Starts the UART (transmit and receive enabled).
pub fn init() -> (Hw, Uart) {
    // 25 MHz / 217: 115200 baud (QEMU passes bytes at any rate; it wants a
    // divider of at least 16).
    write(BAUDDIV, 217);
    write(CTRL, TX_EN | RX_EN | RX_INT_EN);
    // SAFETY: the receive interrupt's handler only moves bytes into `RX`
    // in a critical section; unmasking it breaks no critical section.
    unsafe { cortex_m::peripheral::NVIC::unmask(Uart0Rx) };
    let p = Apparatus::default();
    (
        Hw {
            rig: Rig::new(p, HAND_MASS_KG),
            p,
        },
        Uart,
    )
}

/// Stops here for good.
pub fn halt() -> ! {
    loop {
        cortex_m::asm::wfi();
    }
}

impl Board for Hw {
    const CORE_HZ: u32 = 25_000_000;

    /// 5 kHz, seed 001's stick-slip rate. QEMU's UART passes one byte per
    /// register write under QEMU's device lock: at 10 kHz, with every tick's
    /// telemetry (about 27 bytes), QEMU on 2 cores passed 8,235 to 8,987
    /// frames a second, and a tick lost from a stream ends its bit-exact
    /// re-render. The firmware runs at 10 kHz on a real board.
    const LOOP_RATE_HZ: u16 = 5_000;

    fn apparatus(&self) -> Stated {
        self.p.stated()
    }

    fn force_limit_n(&self) -> f32 {
        self.p.stated().max_force_n
    }

    fn tick(&mut self, dt_s: f64, control: impl FnOnce(Input<f32>, bool, bool) -> (f32, f32)) {
        self.rig.step(dt_s, |sensed| {
            let input = sensed.input_f32();
            let (force_n, _vibration) = control(input, sensed.button, sensed.end_stop);
            f64::from(force_n)
        });
    }

    fn host_message(&mut self, message: &Message) {
        self.rig.follow(message);
    }
}

impl Serial for Uart {
    fn read(&mut self, buf: &mut [u8]) -> usize {
        critical_section::with(|cs| {
            let mut rx = RX.borrow_ref_mut(cs);
            let mut n = 0;
            while n < buf.len()
                && let Some(byte) = rx.pop_front()
            {
                buf[n] = byte;
                n += 1;
            }
            n
        })
    }

    fn write(&mut self, bytes: &[u8]) -> usize {
        let mut n = 0;
        for byte in bytes {
            if read(STATE) & TX_FULL != 0 {
                break;
            }
            write(DATA, u32::from(*byte));
            n += 1;
        }
        n
    }
}

/// Every interrupt without a handler of its own; UART0's receive one takes
/// the received bytes.
#[exception]
unsafe fn DefaultHandler(irqn: i16) {
    if irqn != 0 {
        return;
    }
    write(INTSTATUS, RX_INT);
    critical_section::with(|cs| {
        let mut rx = RX.borrow_ref_mut(cs);
        while read(STATE) & RX_FULL != 0 {
            #[expect(
                clippy::cast_possible_truncation,
                reason = "the data register's low byte"
            )]
            let byte = read(DATA) as u8;
            // A full queue drops the byte; the host's frame check drops
            // the frame.
            let _ = rx.push_back(byte);
        }
    });
}

fn read(offset: usize) -> u32 {
    // SAFETY: a UART0 register of the mps2-an386 memory map, read as a
    // 32-bit word.
    unsafe { core::ptr::read_volatile((UART0 + offset) as *const u32) }
}

fn write(offset: usize, value: u32) {
    // SAFETY: a UART0 register of the mps2-an386 memory map, written as a
    // 32-bit word.
    unsafe { core::ptr::write_volatile((UART0 + offset) as *mut u32, value) }
}

#[panic_handler]
fn panic(info: &core::panic::PanicInfo) -> ! {
    // The simulated motor stops with the loop; say why on the semihosting
    // console and end QEMU with a failure.
    cortex_m_semihosting::hprintln!("firmware panic: {}", info);
    cortex_m_semihosting::debug::exit(cortex_m_semihosting::debug::EXIT_FAILURE);
    halt()
}
