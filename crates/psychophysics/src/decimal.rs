//! Values as the decimals a design writes (issue 42).
//!
//! A protocol gives its values as decimals (`0.4`, `0.3`, a staircase's
//! step `0.1`). A value derived from them by addition, subtraction,
//! multiplication or division (a staircase's next difference, `mu_s -
//! mu_k`, `W - D`, a comparison `level (1 + x)`, a grid's points) is
//! computed here on those decimals and only then rounded to the nearest
//! double. So `sub(0.4, 0.3)` is `0.1`, where `0.4 - 0.3` in binary
//! floating point is `0.10000000000000003`, and a column of such values
//! has exactly as many distinct values as the design has levels: grouping
//! by it in pandas or R gives the design's groups.
//!
//! Each operand is read as the shortest decimal that reads back as the
//! same double (what `Display` prints, and what a JSON protocol holds);
//! sums, differences and products are then exact, quotients exact to 28
//! significant digits. An operand outside the decimal type's range (above
//! about 7.9e28, or with more than 28 decimal places) or a result that
//! overflows falls back to the floating-point operation, as does a
//! non-finite operand.

use std::str::FromStr;

use rust_decimal::Decimal;

/// A value computed on decimals (module docs): build it with [`Dec::of`],
/// combine with `+`, `-`, `*` and `/`, and round once at the end with [`Dec::to_f64`]. Where the decimal type
/// cannot hold an operand or a result it falls back to the double.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Dec(Repr);

#[derive(Debug, Clone, Copy, PartialEq)]
enum Repr {
    Decimal(Decimal),
    Float(f64),
}

impl Dec {
    /// `x` as the shortest decimal that reads back as it (the double
    /// itself where the decimal type would round it).
    #[must_use]
    pub fn of(x: f64) -> Dec {
        let exact = x
            .is_finite()
            .then(|| Decimal::from_str(&x.to_string()).ok())
            .flatten()
            .filter(|d| double(*d) == Some(x));
        Dec(exact.map_or(Repr::Float(x), Repr::Decimal))
    }

    /// The nearest double.
    #[must_use]
    pub fn to_f64(self) -> f64 {
        match self.0 {
            Repr::Decimal(d) => double(d).unwrap_or(f64::NAN),
            Repr::Float(x) => x,
        }
    }

    fn combine(
        self,
        other: Dec,
        op: fn(Decimal, Decimal) -> Option<Decimal>,
        float: fn(f64, f64) -> f64,
    ) -> Dec {
        if let (Repr::Decimal(a), Repr::Decimal(b)) = (self.0, other.0)
            && let Some(d) = op(a, b)
        {
            return Dec(Repr::Decimal(d));
        }
        Dec(Repr::Float(float(self.to_f64(), other.to_f64())))
    }
}

impl std::ops::Add for Dec {
    type Output = Dec;
    fn add(self, other: Dec) -> Dec {
        self.combine(other, Decimal::checked_add, |a, b| a + b)
    }
}

impl std::ops::Sub for Dec {
    type Output = Dec;
    fn sub(self, other: Dec) -> Dec {
        self.combine(other, Decimal::checked_sub, |a, b| a - b)
    }
}

impl std::ops::Mul for Dec {
    type Output = Dec;
    fn mul(self, other: Dec) -> Dec {
        self.combine(other, Decimal::checked_mul, |a, b| a * b)
    }
}

/// To 28 significant digits; the double quotient for a zero divisor.
impl std::ops::Div for Dec {
    type Output = Dec;
    fn div(self, other: Dec) -> Dec {
        self.combine(other, Decimal::checked_div, |a, b| a / b)
    }
}

/// The nearest double to `d` (Rust's parser rounds correctly).
fn double(d: Decimal) -> Option<f64> {
    d.to_string().parse().ok()
}

/// `a + b` on their decimals.
#[must_use]
pub fn add(a: f64, b: f64) -> f64 {
    (Dec::of(a) + Dec::of(b)).to_f64()
}

/// `a - b` on their decimals.
#[must_use]
pub fn sub(a: f64, b: f64) -> f64 {
    (Dec::of(a) - Dec::of(b)).to_f64()
}

/// `a b` on their decimals.
#[must_use]
pub fn mul(a: f64, b: f64) -> f64 {
    (Dec::of(a) * Dec::of(b)).to_f64()
}

/// `a / b` on their decimals.
#[must_use]
pub fn div(a: f64, b: f64) -> f64 {
    (Dec::of(a) / Dec::of(b)).to_f64()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn derived_values_are_the_decimals_the_design_means() {
        assert_eq!(0.4 - 0.3, 0.100_000_000_000_000_03);
        assert_eq!(sub(0.4, 0.3), 0.1);
        assert_eq!(sub(0.6, 0.4), 0.2);
        assert_eq!(sub(0.5, 0.3), 0.2);
        assert_eq!(sub(0.003, 0.001), 0.002);
        assert_eq!(add(0.1, 0.2), 0.3);
        assert_eq!(mul(0.7, add(1.0, 0.15)), 0.805);
        // One rounding, at the end: 0.7 (1 + x) is the nearest double to
        // the exact product, not to 0.7 times the rounded 1 + x.
        let x = 0.151_177_507_061_566_24;
        let exact = (Dec::of(0.7) * (Dec::of(1.0) + Dec::of(x))).to_f64();
        assert_eq!(exact, 0.805_824_254_943_096_4);
        assert_eq!(mul(0.7, add(1.0, x)), 0.805_824_254_943_096_3);
        assert_eq!(div(0.024, 0.001), 24.0);
        assert_eq!(div(0.048, 0.002), 24.0);
        assert_eq!(div(1.0, 3.0), 1.0 / 3.0);
        // A staircase walked down and up again lands on its grid.
        let mut x = 0.4;
        for _ in 0..3 {
            x = sub(x, 0.1);
        }
        for _ in 0..2 {
            x = add(x, 0.1);
        }
        assert_eq!(x, 0.3);
    }

    #[test]
    fn out_of_range_operands_fall_back_to_floating_point() {
        assert_eq!(sub(1e300, 1e299), 1e300 - 1e299);
        assert_eq!(mul(1e-30, 3.0), 1e-30 * 3.0);
        assert!(div(1.0, 0.0).is_infinite());
        assert!(add(f64::NAN, 1.0).is_nan());
        assert_eq!(sub(-0.25, 0.5), -0.75);
    }
}
