//! The float the models compute in: `f64` on the host, `f32` on a
//! microcontroller with a single-precision FPU (a Cortex-M4F does `f32` in
//! hardware and `f64` in software, about 8,000 instructions for a step with
//! an `exp` and a `sin`).
//!
//! Every function goes through `libm` (or, for `f32`'s `sin`, our own code
//! below), never the platform's C library, so a model computes the same
//! bits on every target: a host re-render in `f32` reproduces what the
//! device rendered exactly. Rust never fuses a multiply and an add on its
//! own, so plain arithmetic is the same everywhere too.
//!
//! `f32`'s `sin` is [`sin_f32`], in `f32` arithmetic only: `libm::sinf`
//! reduces its argument and sums its polynomial in `f64`, which a Cortex-M4F
//! does in software (the god object's slip vibration, a `sin` every step,
//! cost about 1,900 instructions a step with it).

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
        sin_f32(self)
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

/// `sin(x)` in `f32` arithmetic only (Cephes' `sinf`): `x` reduced by
/// multiples of pi/4 with pi/4 split in three (exact products up to
/// |x| = 8192), then a degree-7 odd or degree-8 even polynomial on
/// [-pi/4, pi/4]. Within 1.2e-7 (2 ulp near 1) of the true sine for |x| <= 8192 (tested
/// against `f64`); beyond that, and for NaN and infinities, `libm::sinf`.
#[must_use]
pub fn sin_f32(x: f32) -> f32 {
    const FOUR_OVER_PI: f32 = 1.273_239_5;
    const DP1: f32 = 0.785_156_25;
    const DP2: f32 = 2.418_756_5e-4;
    const DP3: f32 = 3.774_895e-8;
    let ax = libm::fabsf(x);
    if ax.is_nan() || ax > 8192.0 {
        return libm::sinf(x);
    }
    // The octant: a whole number below 2^14, exact in f32 and u32.
    #[expect(
        clippy::cast_possible_truncation,
        clippy::cast_sign_loss,
        reason = "0 <= ax * 4/pi < 2^14"
    )]
    let mut j = (ax * FOUR_OVER_PI) as u32;
    #[expect(clippy::cast_precision_loss, reason = "j < 2^14 is exact")]
    let mut y = j as f32;
    if j & 1 == 1 {
        j += 1;
        y += 1.0;
    }
    j &= 7;
    let mut negative = x.is_sign_negative();
    if j > 3 {
        negative = !negative;
        j -= 4;
    }
    let r = ((ax - y * DP1) - y * DP2) - y * DP3;
    let z = r * r;
    let v = if j == 1 || j == 2 {
        let p = ((2.443_315_7e-5 * z - 1.388_731_6e-3) * z + 4.166_664_6e-2) * z * z;
        (p - 0.5 * z) + 1.0
    } else {
        ((-1.951_529_6e-4 * z + 8.332_161e-3) * z - 1.666_665_5e-1) * z * r + r
    };
    if negative { -v } else { v }
}

#[cfg(test)]
mod tests {
    use super::sin_f32;

    #[test]
    fn sin_f32_is_within_1_2e_7_of_the_sine_up_to_8192_and_libm_beyond() {
        let mut worst = 0.0_f64;
        let mut x = -8192.0_f32;
        while x <= 8192.0 {
            let err = (f64::from(sin_f32(x)) - libm::sin(f64::from(x))).abs();
            worst = worst.max(err);
            x += 0.0137;
        }
        for k in 0..200_000 {
            let x = k as f32 * 1e-4;
            let err = (f64::from(sin_f32(x)) - libm::sin(f64::from(x))).abs();
            worst = worst.max(err);
        }
        assert!(worst < 1.2e-7, "worst error {worst:e}");
        assert_eq!(sin_f32(1e6), libm::sinf(1e6));
        assert!(sin_f32(f32::NAN).is_nan());
        assert_eq!(sin_f32(0.0), 0.0);
        assert_eq!(sin_f32(-0.0).to_bits(), (-0.0_f32).to_bits());
    }
}
