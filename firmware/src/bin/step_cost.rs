//! Counts the instructions of one step of each friction model as the
//! firmware runs it (`f32`, at the loop rate), and of a whole loop tick of
//! the on-board firmware, on QEMU's mps2-an386.
//!
//! Run under `qemu-system-arm -M mps2-an386 -icount shift=0`: one
//! instruction then takes 1 ns of virtual time and SysTick, on the 25 MHz
//! core clock, counts once per 40 instructions (STACK-NOTES). Each figure is
//! the SysTick count of `STEPS` steps over a recorded-style stroke, less
//! that of the same loop without the step, times 40, over `STEPS`. Prints
//! one `cost <name> <instructions per step>` line per model on the
//! semihosting console, then exits.
#![no_std]
#![no_main]

#[path = "../board.rs"]
#[expect(dead_code, reason = "the board's link is not used here")]
mod board;
#[path = "../qemu.rs"]
#[expect(dead_code, reason = "only the panic handler is used here")]
mod qemu;

use core::hint::black_box;

use cortex_m::peripheral::SYST;
use cortex_m::peripheral::syst::SystClkSource;
use cortex_m_rt::entry;
use cortex_m_semihosting::{debug, hprintln};
use frictionlab_core::friction::{ForceLimit, Friction, Input, ModelParams};
use frictionlab_core::onboard::{Apparatus, Firmware, upload};
use frictionlab_core::wire::{MAX_FRAME, Message, encode};

/// Steps per measurement.
const STEPS: usize = 2000;
/// Instructions per SysTick count under `-icount shift=0`.
const INSTRUCTIONS_PER_COUNT: u32 = 40;
/// The firmware's loop rate, Hz.
const RATE_HZ: u16 = 10_000;

#[entry]
fn main() -> ! {
    let Some(mut cp) = cortex_m::Peripherals::take() else {
        qemu::halt()
    };
    cp.SYST.set_clock_source(SystClkSource::Core);
    cp.SYST.set_reload(0x00ff_ffff);
    cp.SYST.clear_current();
    cp.SYST.enable_counter();

    let dt = 1.0 / f32::from(RATE_HZ);
    // A 2 cm, 2 Hz stroke through the stick-slip range, as the hand moves.
    let inputs: [Input<f32>; STEPS] = core::array::from_fn(|k| {
        let w = core::f32::consts::TAU * 2.0;
        #[expect(clippy::cast_precision_loss, reason = "k < 2000 is exact in f32")]
        let t = k as f32 * dt;
        Input {
            x_m: 0.01 * libm::sinf(w * t),
            v_m_s: 0.01 * w * libm::cosf(w * t),
        }
    });
    let baseline = counts(|| {
        for input in &inputs {
            black_box(black_box(*input).x_m);
        }
    });
    let limit = ForceLimit::new(9.48).unwrap_or_default();
    for name in ModelParams::NAMES {
        let Some(params) = ModelParams::default_for(name) else {
            continue;
        };
        let Ok(mut model) = Friction::<f32>::new(&params, limit, 0.0) else {
            continue;
        };
        let c = counts(|| {
            for input in &inputs {
                black_box(model.step(dt, black_box(*input)).force_n);
            }
        });
        report(name, c, baseline);
    }

    // The whole loop tick of the firmware rendering stick-slip: crossfade,
    // clamp, watchdog, telemetry, and the telemetry frame's encoding.
    let mut firmware = Firmware::<f32>::new(
        RATE_HZ,
        limit,
        Apparatus {
            max_force_n: 9.48,
            counts_per_m: 389_105.0,
        },
    );
    firmware.receive(&Message::Hello { version: 2 }, |_| {});
    if let Some(params) = ModelParams::default_for("stick-slip-tactile") {
        upload(&params, 1, |m| firmware.receive(&m, |_| {}));
    }
    let mut frame = [0_u8; MAX_FRAME];
    let c = counts(|| {
        for (k, input) in inputs.iter().enumerate() {
            if k % 50 == 0 {
                // The host's heartbeat (5 ms), so the watchdog stays off.
                firmware.receive(&Message::Heartbeat { seq: 0 }, |_| {});
            }
            let (force, _) = firmware.tick(*input, false, false, |m| {
                black_box(encode(&m, &mut frame).unwrap_or(0));
            });
            black_box(force);
        }
    });
    report("firmware-tick (stick-slip-tactile)", c, baseline);
    debug::exit(debug::EXIT_SUCCESS);
    qemu::halt()
}

/// SysTick counts that `f` takes (it counts down).
fn counts(mut f: impl FnMut()) -> u32 {
    let start = SYST::get_current();
    f();
    let end = SYST::get_current();
    start.wrapping_sub(end) & 0x00ff_ffff
}

fn report(name: &str, counts: u32, baseline: u32) {
    let net = counts.saturating_sub(baseline);
    #[expect(clippy::cast_possible_truncation, reason = "STEPS is small")]
    let per_step = net * INSTRUCTIONS_PER_COUNT / STEPS as u32;
    hprintln!("cost {} {}", name, per_step);
}
