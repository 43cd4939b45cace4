//! Psychometric functions of a two-interval forced choice.
//!
//! The probability of a correct answer at stimulus `x` is
//! `psi(x) = guess + (1 - guess - lapse) F(x; threshold, slope)`, with
//! `guess` = 0.5 (two intervals) and `F` one of [`Shape`]:
//! - Weibull: `F = 1 - exp(-(x / threshold)^slope)` for `x > 0`, 0 below;
//! - logistic: `F = 1 / (1 + exp(-slope (x - threshold)))`;
//! - cumulative normal: `F = Phi(slope (x - threshold))`.
//!
//! These are Palamedes' parameterisations (`PAL_Weibull`, `PAL_Logistic`,
//! `PAL_CumulativeNormal`; Prins & Kingdom 2018), so a fit here can be
//! checked against theirs.

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

/// The guess rate of a two-interval forced choice.
pub const GUESS_2IFC: f64 = 0.5;

/// The sigmoid `F` of a psychometric function (module docs).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum Shape {
    /// `1 - exp(-(x / threshold)^slope)`, `x > 0`.
    Weibull,
    /// `1 / (1 + exp(-slope (x - threshold)))`.
    Logistic,
    /// `Phi(slope (x - threshold))`.
    CumulativeNormal,
}

/// The standard normal distribution function.
#[must_use]
pub fn phi(z: f64) -> f64 {
    0.5 * libm::erfc(-z / std::f64::consts::SQRT_2)
}

/// The inverse of [`phi`], for `p` in (0, 1) (bisection then Newton, to
/// the last bits).
#[must_use]
pub fn phi_inverse(p: f64) -> f64 {
    if !(p > 0.0 && p < 1.0) {
        return f64::NAN;
    }
    let (mut lo, mut hi) = (-40.0_f64, 40.0_f64);
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if phi(mid) < p {
            lo = mid;
        } else {
            hi = mid;
        }
        if hi - lo < 1e-15 * (1.0 + mid.abs()) {
            break;
        }
    }
    0.5 * (lo + hi)
}

impl Shape {
    /// `F(x)` for `threshold` and `slope`.
    #[must_use]
    pub fn f(self, x: f64, threshold: f64, slope: f64) -> f64 {
        match self {
            Shape::Weibull => {
                if x <= 0.0 {
                    0.0
                } else {
                    -(-(x / threshold).powf(slope)).exp_m1()
                }
            }
            Shape::Logistic => 1.0 / (1.0 + (-slope * (x - threshold)).exp()),
            Shape::CumulativeNormal => phi(slope * (x - threshold)),
        }
    }

    /// The `x` where `F(x) = p`, for `p` in (0, 1).
    #[must_use]
    pub fn f_inverse(self, p: f64, threshold: f64, slope: f64) -> f64 {
        if !(p > 0.0 && p < 1.0) {
            return f64::NAN;
        }
        match self {
            Shape::Weibull => threshold * (-(-p).ln_1p()).powf(1.0 / slope),
            Shape::Logistic => threshold - ((1.0 - p) / p).ln() / slope,
            Shape::CumulativeNormal => threshold + phi_inverse(p) / slope,
        }
    }
}

/// A psychometric function's parameters.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct Params {
    /// Location (`threshold` in the module docs), in stimulus units.
    pub threshold: f64,
    /// Slope.
    pub slope: f64,
    /// Lapse rate: the chance of a wrong answer however large the stimulus.
    pub lapse: f64,
}

/// A psychometric function: shape, parameters and guess rate.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Psychometric {
    /// The sigmoid.
    pub shape: Shape,
    /// Its parameters.
    pub params: Params,
    /// The guess rate (0.5 for two intervals).
    pub guess: f64,
}

impl Psychometric {
    /// The probability of a correct answer at `x`.
    #[must_use]
    pub fn p_correct(&self, x: f64) -> f64 {
        let Params {
            threshold,
            slope,
            lapse,
        } = self.params;
        self.guess + (1.0 - self.guess - lapse) * self.shape.f(x, threshold, slope)
    }

    /// The stimulus at which the probability of a correct answer is
    /// `criterion`; `None` where the function never reaches it (below the
    /// guess rate or above `1 - lapse`).
    #[must_use]
    pub fn threshold_at(&self, criterion: f64) -> Option<f64> {
        let Params {
            threshold,
            slope,
            lapse,
        } = self.params;
        let p = (criterion - self.guess) / (1.0 - self.guess - lapse);
        let x = self.shape.f_inverse(p, threshold, slope);
        x.is_finite().then_some(x)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_shape_inverts_and_the_threshold_at_a_criterion_gives_that_criterion() {
        for shape in [Shape::Weibull, Shape::Logistic, Shape::CumulativeNormal] {
            for p in [0.01, 0.3, 0.5, 0.77, 0.99] {
                let x = shape.f_inverse(p, 0.2, 3.5);
                assert!((shape.f(x, 0.2, 3.5) - p).abs() < 1e-12, "{shape:?} {p}");
            }
            let psi = Psychometric {
                shape,
                params: Params {
                    threshold: 0.2,
                    slope: 3.5,
                    lapse: 0.02,
                },
                guess: GUESS_2IFC,
            };
            let x = psi.threshold_at(0.75).unwrap();
            assert!((psi.p_correct(x) - 0.75).abs() < 1e-12, "{shape:?}");
            assert_eq!(psi.threshold_at(0.99), None, "above 1 - lapse");
            assert_eq!(psi.threshold_at(0.4), None, "below the guess rate");
        }
    }

    #[test]
    fn phi_and_its_inverse_match_known_values() {
        assert!((phi(1.959_963_984_540_054) - 0.975).abs() < 1e-15);
        assert!((phi_inverse(0.975) - 1.959_963_984_540_054).abs() < 1e-12);
        assert!((phi(0.0) - 0.5).abs() < 1e-16);
    }
}
