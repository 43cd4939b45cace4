//! An STM32F401 "Black Pill" (84 MHz from its 25 MHz crystal) driving a
//! 1-DOF device: the host link over USB CDC-ACM, the encoder on TIM2 in
//! encoder mode, the motor through an H-bridge from TIM1's PWM, the
//! vibrotactile drive on a second PWM channel. Wiring and calibration:
//! `docs/hardware.md`. **Not run on hardware here**: it builds in CI.
//!
//! Timers and pins are set up by their registers (reference manual RM0368),
//! each access with a SAFETY comment; the HAL sets the clocks and runs USB.

use frictionlab_core::friction::{Input, filtered_velocity};
use frictionlab_core::onboard::Apparatus;
use stm32f4xx_hal::otg_fs::{USB, UsbBus};
use stm32f4xx_hal::pac;
use stm32f4xx_hal::prelude::*;
use usb_device::bus::UsbBusAllocator;
use usb_device::device::{StringDescriptors, UsbDevice, UsbDeviceBuilder, UsbVidPid};
use usbd_serial::SerialPort;

use crate::board::{Board, Serial};

/// Encoder counts per metre of handle travel (calibrate: docs/hardware.md).
/// Seed 002's apparatus: 2.57 um a count.
const COUNTS_PER_M: f32 = 389_105.0;
/// Force at full PWM duty, N (calibrate: docs/hardware.md).
const NEWTONS_PER_DUTY: f32 = 12.0;
/// The device's maximum continuous force, N (seed 002: 9.48).
const MAX_FORCE_N: f32 = 9.48;
/// Cutoff of the velocity estimate, Hz (as the host's simulated device).
const VELOCITY_CUTOFF_HZ: f32 = 100.0;

/// Core clock, Hz.
const SYSCLK_HZ: u32 = 84_000_000;
/// TIM1's PWM period in timer clocks: 20 kHz at 84 MHz.
const PWM_TOP: u32 = SYSCLK_HZ / 20_000 - 1;
/// The same in f32 (4199: exact).
#[expect(clippy::cast_precision_loss, reason = "4199 is exact in f32")]
const PWM_TOP_F32: f32 = PWM_TOP as f32;

const RCC: usize = 0x4002_3800;
const RCC_AHB1ENR: usize = RCC + 0x30;
const RCC_APB1ENR: usize = RCC + 0x40;
const RCC_APB2ENR: usize = RCC + 0x44;
const GPIOA: usize = 0x4002_0000;
const GPIOB: usize = 0x4002_0400;
const MODER: usize = 0x00;
const PUPDR: usize = 0x0c;
const IDR: usize = 0x10;
const BSRR: usize = 0x18;
const AFRL: usize = 0x20;
const AFRH: usize = 0x24;
const TIM1: usize = 0x4001_0000;
const TIM2: usize = 0x4000_0000;
const CR1: usize = 0x00;
const SMCR: usize = 0x08;
const EGR: usize = 0x14;
const CCMR1: usize = 0x18;
const CCER: usize = 0x20;
const CNT: usize = 0x24;
const PSC: usize = 0x28;
const ARR: usize = 0x2c;
const CCR1: usize = 0x34;
const CCR2: usize = 0x38;
const BDTR: usize = 0x44;

/// PB0 direction, PB1 H-bridge enable, PB12 e-stop (open: high), PB13
/// button (pressed: low).
const DIR_PIN: u32 = 0;
const ENABLE_PIN: u32 = 1;
const ESTOP_PIN: u32 = 12;
const BUTTON_PIN: u32 = 13;

/// The board: encoder, motor and vibration outputs, and the velocity
/// estimate.
pub struct Hw {
    last_counts: i32,
    v_estimate: f32,
    alpha: f32,
}

/// The USB CDC-ACM link.
pub struct Usb {
    device: UsbDevice<'static, UsbBus<USB>>,
    serial: SerialPort<'static, UsbBus<USB>>,
}

/// Sets the clocks, the timers and pins, and USB.
pub fn init() -> (Hw, Usb) {
    let Some(dp) = pac::Peripherals::take() else {
        halt()
    };
    let mut rcc = dp.RCC.freeze(
        stm32f4xx_hal::rcc::Config::hse(25.MHz())
            .sysclk(SYSCLK_HZ.Hz())
            .require_pll48clk(),
    );
    let gpioa = dp.GPIOA.split(&mut rcc);
    let usb = USB::new(
        (dp.OTG_FS_GLOBAL, dp.OTG_FS_DEVICE, dp.OTG_FS_PWRCLK),
        (gpioa.pa11, gpioa.pa12),
        &rcc.clocks,
    );
    let (Some(memory), Some(bus)) = (
        cortex_m::singleton!(: [u32; 1024] = [0; 1024]),
        cortex_m::singleton!(: Option<UsbBusAllocator<UsbBus<USB>>> = None),
    ) else {
        halt()
    };
    let bus: &'static UsbBusAllocator<UsbBus<USB>> = bus.insert(UsbBus::new(usb, memory));
    let serial = SerialPort::new(bus);
    let device = UsbDeviceBuilder::new(bus, UsbVidPid(0x16c0, 0x27dd))
        .strings(&[StringDescriptors::default()
            .manufacturer("frictionlab")
            .product("frictionlab haptic device")
            .serial_number("1")])
        .map_or_else(
            |_| halt(),
            |b| b.device_class(usbd_serial::USB_CLASS_CDC).build(),
        );
    setup_io();
    let dt = 1.0 / f32::from(Hw::LOOP_RATE_HZ);
    (
        Hw {
            last_counts: 0,
            v_estimate: 0.0,
            alpha: libm::expf(-core::f32::consts::TAU * VELOCITY_CUTOFF_HZ * dt),
        },
        Usb { device, serial },
    )
}

/// Encoder mode on TIM2 (PA0/PA1), PWM on TIM1 CH1 (PA8, motor) and CH2
/// (PA9, vibration), the H-bridge's direction and enable (PB0, PB1, enable
/// low), the e-stop and button inputs (PB12, PB13, pulled up).
fn setup_io() {
    // Clocks: GPIOA, GPIOB; TIM2; TIM1.
    set(RCC_AHB1ENR, 0b11);
    set(RCC_APB1ENR, 1);
    set(RCC_APB2ENR, 1);
    // PA0, PA1: alternate function 1 (TIM2), pulled up. PA8, PA9:
    // alternate function 1 (TIM1).
    modify(GPIOA + MODER, 0b1111, 0b1010);
    modify(GPIOA + PUPDR, 0b1111, 0b0101);
    modify(GPIOA + AFRL, 0xff, 0x11);
    modify(GPIOA + MODER, 0b1111 << 16, 0b1010 << 16);
    modify(GPIOA + AFRH, 0xff, 0x11);
    // PB0, PB1 outputs, low (the bridge off); PB12, PB13 inputs pulled up.
    write(
        GPIOB + BSRR,
        (1 << (DIR_PIN + 16)) | (1 << (ENABLE_PIN + 16)),
    );
    modify(GPIOB + MODER, 0b1111, 0b0101);
    modify(GPIOB + MODER, 0b1111 << 24, 0);
    modify(GPIOB + PUPDR, 0b1111 << 24, 0b0101 << 24);
    // TIM2: encoder mode 3 (both edges of both inputs), inputs filtered
    // (8 samples), the whole 32-bit range.
    write(TIM2 + CCMR1, 0x3131);
    write(TIM2 + CCER, 0);
    write(TIM2 + SMCR, 0b011);
    write(TIM2 + ARR, u32::MAX);
    write(TIM2 + CNT, 0);
    write(TIM2 + CR1, 1);
    // TIM1: 20 kHz PWM mode 1 on CH1 and CH2, preloaded; main output on.
    write(TIM1 + PSC, 0);
    write(TIM1 + ARR, PWM_TOP);
    write(TIM1 + CCMR1, 0x6868);
    write(TIM1 + CCR1, 0);
    write(TIM1 + CCR2, PWM_TOP / 2);
    write(TIM1 + CCER, 0b1_0001);
    write(TIM1 + BDTR, 1 << 15);
    write(TIM1 + EGR, 1);
    write(TIM1 + CR1, (1 << 7) | 1);
}

/// Zero force, the bridge off, and stops here for good.
pub fn halt() -> ! {
    write(TIM1 + CCR1, 0);
    write(GPIOB + BSRR, 1 << (ENABLE_PIN + 16));
    loop {
        cortex_m::asm::wfi();
    }
}

impl Board for Hw {
    const CORE_HZ: u32 = SYSCLK_HZ;

    /// 10 kHz.
    const LOOP_RATE_HZ: u16 = 10_000;

    fn apparatus(&self) -> Apparatus {
        Apparatus {
            max_force_n: MAX_FORCE_N,
            counts_per_m: COUNTS_PER_M,
        }
    }

    fn force_limit_n(&self) -> f32 {
        MAX_FORCE_N
    }

    fn tick(&mut self, dt_s: f64, control: impl FnOnce(Input<f32>, bool, bool) -> (f32, f32)) {
        #[expect(
            clippy::cast_possible_wrap,
            reason = "the counter is a signed position"
        )]
        let counts = read(TIM2 + CNT) as i32;
        #[expect(
            clippy::cast_possible_truncation,
            reason = "the device computes in f32"
        )]
        let dt = dt_s as f32;
        #[expect(clippy::cast_precision_loss, reason = "counts over the range fit f32")]
        let moved = counts.wrapping_sub(self.last_counts) as f32;
        self.last_counts = counts;
        let raw_v = moved / COUNTS_PER_M / dt;
        self.v_estimate = filtered_velocity(self.alpha, self.v_estimate, raw_v);
        #[expect(clippy::cast_precision_loss, reason = "counts over the range fit f32")]
        let x_m = counts as f32 / COUNTS_PER_M;
        let inputs = read(GPIOB + IDR);
        let stopped = inputs & (1 << ESTOP_PIN) != 0;
        let button = inputs & (1 << BUTTON_PIN) == 0;
        let input = Input {
            x_m,
            v_m_s: self.v_estimate,
        };
        let (force_n, vibration) = control(input, button, false);
        let force_n = if stopped || !force_n.is_finite() {
            0.0
        } else {
            force_n
        };
        let duty = (force_n.abs() / NEWTONS_PER_DUTY).min(1.0);
        #[expect(
            clippy::cast_possible_truncation,
            clippy::cast_sign_loss,
            reason = "0 <= duty <= 1 of the PWM period"
        )]
        let ccr = (duty * PWM_TOP_F32) as u32;
        let direction = if force_n < 0.0 { DIR_PIN } else { DIR_PIN + 16 };
        let enable = if stopped { ENABLE_PIN + 16 } else { ENABLE_PIN };
        write(GPIOB + BSRR, (1 << direction) | (1 << enable));
        write(TIM1 + CCR1, ccr);
        let v = if vibration.is_finite() {
            vibration.clamp(-1.0, 1.0)
        } else {
            0.0
        };
        #[expect(
            clippy::cast_possible_truncation,
            clippy::cast_sign_loss,
            reason = "0 <= (1 + v) / 2 <= 1 of the PWM period"
        )]
        write(TIM1 + CCR2, (f32::midpoint(1.0, v) * PWM_TOP_F32) as u32);
    }
}

impl Serial for Usb {
    fn read(&mut self, buf: &mut [u8]) -> usize {
        self.device.poll(&mut [&mut self.serial]);
        self.serial.read(buf).unwrap_or(0)
    }

    fn write(&mut self, bytes: &[u8]) -> usize {
        self.device.poll(&mut [&mut self.serial]);
        self.serial.write(bytes).unwrap_or(0)
    }
}

fn read(address: usize) -> u32 {
    // SAFETY: a peripheral register of the STM32F401 memory map (RM0368),
    // read as a 32-bit word.
    unsafe { core::ptr::read_volatile(address as *const u32) }
}

fn write(address: usize, value: u32) {
    // SAFETY: a peripheral register of the STM32F401 memory map (RM0368),
    // written as a 32-bit word; only this module touches these peripherals.
    unsafe { core::ptr::write_volatile(address as *mut u32, value) }
}

/// Sets `bits` in the register at `address`.
fn set(address: usize, bits: u32) {
    write(address, read(address) | bits);
}

/// Replaces the bits under `mask` in the register at `address`.
fn modify(address: usize, mask: u32, bits: u32) {
    write(address, (read(address) & !mask) | (bits & mask));
}

#[panic_handler]
fn panic(_: &core::panic::PanicInfo) -> ! {
    halt()
}
