//! When the participant clicks (issue 65): from its own estimate of where
//! the cursor is, never from where the cursor is.
//!
//! The participant's estimate of the cursor's position is Gaussian: the
//! estimator's mean and the SD of its error ([`super::ofc`]'s filter
//! holds it). The probability that the cursor is inside the target is
//! then `Φ((c + h - x̂) / σ) - Φ((c - h - x̂) / σ)` for a target of centre
//! `c` and half-width `h`. The participant clicks once that probability
//! reaches its criterion: a confidence of its own, free and swept (how
//! sure people want to be before committing is a speed-accuracy setting
//! they choose; the ISO 9241-9 convention of about 4 % errors at the
//! nominal width, Soukoreff & MacKenzie 2004, is a validation row, not an
//! input). Misses then come from the estimate's error and from the cursor
//! moving on during the press; nothing here knows a miss rate.

use statrs::distribution::{ContinuousCDF, Normal};

/// The probability that a cursor estimated at `estimate_m` with an error
/// of SD `sd_m` lies within `half_width_m` of `centre_m`. An exact
/// estimate (`sd_m` 0) gives 1 inside and 0 outside.
#[must_use]
pub fn inside(estimate_m: f64, sd_m: f64, centre_m: f64, half_width_m: f64) -> f64 {
    let offset = estimate_m - centre_m;
    if sd_m <= 0.0 || !sd_m.is_finite() {
        return if offset.abs() <= half_width_m {
            1.0
        } else {
            0.0
        };
    }
    let Ok(unit) = Normal::new(0.0, 1.0) else {
        return 0.0;
    };
    (unit.cdf((half_width_m - offset) / sd_m) - unit.cdf((-half_width_m - offset) / sd_m))
        .clamp(0.0, 1.0)
}

/// Whether the participant clicks: the cursor is inside the target with
/// at least `criterion` probability, by its own estimate.
#[must_use]
pub fn clicks(
    estimate_m: f64,
    sd_m: f64,
    centre_m: f64,
    half_width_m: f64,
    criterion: f64,
) -> bool {
    inside(estimate_m, sd_m, centre_m, half_width_m) >= criterion
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_exact_estimate_clicks_inside_and_never_outside() {
        assert_eq!(inside(0.0105, 0.0, 0.01, 0.001), 1.0);
        assert_eq!(inside(0.0111, 0.0, 0.01, 0.001), 0.0);
        assert!(clicks(0.0105, 0.0, 0.01, 0.001, 0.99));
        assert!(!clicks(0.0111, 0.0, 0.01, 0.001, 0.01));
    }

    /// On the centre, with the half-width 1.96 SDs: 95 % inside; and at
    /// one edge, half the mass is inside, less the tail beyond the far
    /// edge 3.92 SDs away (4.4e-5).
    #[test]
    fn the_probability_inside_is_the_normals_mass_over_the_target() {
        let (h, sd) = (0.001, 0.001 / 1.959_963_984_540_054);
        assert!((inside(0.02, sd, 0.02, h) - 0.95).abs() < 1e-9);
        let edge = inside(0.021, sd, 0.02, h);
        assert!(edge < 0.5 && edge > 0.5 - 5e-5, "{edge}");
    }

    /// The click rule: with a criterion of 0.95 and that SD, only the
    /// centre itself is sure enough; a smaller error lets the participant
    /// click further off the centre, and never outside.
    #[test]
    fn a_surer_estimate_clicks_over_more_of_the_target_and_never_outside() {
        let (h, sd) = (0.001, 0.001 / 1.959_963_984_540_054);
        assert!(clicks(0.02, sd, 0.02, h, 0.95 - 1e-9));
        assert!(!clicks(0.0201, sd, 0.02, h, 0.95));
        assert!(clicks(0.0201, sd / 4.0, 0.02, h, 0.95));
        for i in 0..=100 {
            let x = 0.02 + 0.003 * f64::from(i) / 100.0;
            let outside = (x - 0.02).abs() > h;
            assert!(!(outside && clicks(x, sd / 10.0, 0.02, h, 0.95)), "{x}");
        }
    }
}
