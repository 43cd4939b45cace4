//! The float the models compute in: `f64` on the host, `f32` on a
//! microcontroller with a single-precision FPU (a Cortex-M4F does `f32` in
//! hardware and `f64` in software, about 8,000 instructions for a step with
//! an `exp` and a `sin`).
//!
//! Every function goes through `libm`, never the platform's C library, so a
//! model computes the same bits on every target: a host re-render in `f32`
//! reproduces what the device rendered exactly. Rust never fuses a multiply
//! and an add on its own, so plain arithmetic is the same everywhere too.

use core::fmt::Debug;
use core::ops::{Add, AddAssign, Div, DivAssign, Mul, MulAssign, Neg, Rem, Sub, SubAssign};

/// A float the friction models can run in: `f32` or `f64`.
pub trait Real:
    Copy
    + Debug
    + Default
    + PartialOrd
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Rem<Output = Self>
    + Neg<Output = Self>
    + AddAssign
    + SubAssign
    + MulAssign
    + DivAssign
    + Send
    + Sync
    + 'static
{
    /// 0.
    const ZERO: Self;
    /// 1.
    const ONE: Self;
    /// 2 pi.
    const TAU: Self;
    /// Which float this is.
    const FLOAT: crate::friction::Float;
    /// The nearest value to `x` (rounded to nearest for `f32`).
    fn of(x: f64) -> Self;
    /// As `f64` (exact).
    fn to_f64(self) -> f64;
    /// As `f32` (rounded to nearest; exact for `f32`): the wire's float.
    #[must_use]
    #[expect(clippy::cast_possible_truncation, reason = "the wire carries f32")]
    fn to_f32(self) -> f32 {
        self.to_f64() as f32
    }
    /// e^self.
    #[must_use]
    fn exp(self) -> Self;
    /// Sine (radians).
    #[must_use]
    fn sin(self) -> Self;
    /// Cosine (radians).
    #[must_use]
    fn cos(self) -> Self;
    /// Base-10 logarithm.
    #[must_use]
    fn log10(self) -> Self;
    /// self^e.
    #[must_use]
    fn powf(self, e: Self) -> Self;
    /// Smallest integer not below self.
    #[must_use]
    fn ceil(self) -> Self;
    /// |self|.
    #[must_use]
    fn abs(self) -> Self;
    /// Neither infinite nor NaN.
    fn is_finite(self) -> bool;
    /// A whole number of at least 0 as a count (saturating at `u32::MAX`;
    /// NaN gives 0).
    fn to_count(self) -> u32;

    /// The larger of the two (`other` if `self` is NaN).
    #[must_use]
    fn max(self, other: Self) -> Self {
        if self >= other { self } else { other }
    }

    /// The smaller of the two (`other` if `self` is NaN).
    #[must_use]
    fn min(self, other: Self) -> Self {
        if self <= other { self } else { other }
    }

    /// `self` limited to `[lo, hi]`.
    #[must_use]
    fn clamp(self, lo: Self, hi: Self) -> Self {
        self.max(lo).min(hi)
    }

    /// `+1`, `-1`, or `0` for zero (unlike `f64::signum`).
    #[must_use]
    fn sign(self) -> Self {
        if self > Self::ZERO {
            Self::ONE
        } else if self < Self::ZERO {
            -Self::ONE
        } else {
            Self::ZERO
        }
    }
}

impl Real for f64 {
    const ZERO: Self = 0.0;
    const ONE: Self = 1.0;
    const TAU: Self = core::f64::consts::TAU;
    const FLOAT: crate::friction::Float = crate::friction::Float::F64;
    fn of(x: f64) -> Self {
        x
    }
    fn to_f64(self) -> f64 {
        self
    }
    fn exp(self) -> Self {
        libm::exp(self)
    }
    fn sin(self) -> Self {
        libm::sin(self)
    }
    fn cos(self) -> Self {
        libm::cos(self)
    }
    fn log10(self) -> Self {
        libm::log10(self)
    }
    fn powf(self, e: Self) -> Self {
        libm::pow(self, e)
    }
    fn ceil(self) -> Self {
        libm::ceil(self)
    }
    fn abs(self) -> Self {
        libm::fabs(self)
    }
    fn is_finite(self) -> bool {
        f64::is_finite(self)
    }
    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
    fn to_count(self) -> u32 {
        // `as` saturates and maps NaN to 0.
        self as u32
    }
}

impl Real for f32 {
    const ZERO: Self = 0.0;
    const ONE: Self = 1.0;
    const TAU: Self = core::f32::consts::TAU;
    const FLOAT: crate::friction::Float = crate::friction::Float::F32;
    #[allow(clippy::cast_possible_truncation)]
    fn of(x: f64) -> Self {
        x as f32
    }
    fn to_f64(self) -> f64 {
        f64::from(self)
    }
    fn exp(self) -> Self {
        libm::expf(self)
    }
    fn sin(self) -> Self {
        libm::sinf(self)
    }
    fn cos(self) -> Self {
        libm::cosf(self)
    }
    fn log10(self) -> Self {
        libm::log10f(self)
    }
    fn powf(self, e: Self) -> Self {
        libm::powf(self, e)
    }
    fn ceil(self) -> Self {
        libm::ceilf(self)
    }
    fn abs(self) -> Self {
        libm::fabsf(self)
    }
    fn is_finite(self) -> bool {
        f32::is_finite(self)
    }
    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
    fn to_count(self) -> u32 {
        // `as` saturates and maps NaN to 0.
        self as u32
    }
}
