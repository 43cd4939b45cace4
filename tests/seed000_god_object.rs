//! Seed 000 (STUDIES 1a): the time-varying static coefficient makes the
//! stick-slip oscillation of a slide die out; constant coefficients do not.

#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    reason = "a failed unwrap is a failed test"
)]

use crate::common;

use common::{model, onsets, peak_to_peak, render};
use frictionlab::friction::{StaticFrictionLaw, TimeVaryingStatic};
use frictionlab::scenario::Sample;

/// (late peak-to-peak over 0.7-1.0 s) / (early peak-to-peak over 0.1-0.3 s).
fn late_over_early(samples: &[Sample]) -> f64 {
    peak_to_peak(samples, 0.7, 1.0, |s| s.force_n) / peak_to_peak(samples, 0.1, 0.3, |s| s.force_n)
}

fn slips_after(samples: &[Sample], t: f64) -> usize {
    onsets(samples).iter().filter(|&&o| o > t).count()
}

in_both_floats! {
    fn time_varying_stick_slip_dies_out_and_stops_by_0_7_s<T>() {
        let s = render::<T>(&model("god-object-time-varying", &[]), "spidar-slide");
        let ratio = late_over_early(&s);
        assert!(ratio < 0.2, "late/early peak-to-peak {ratio}");
        assert_eq!(slips_after(&s, 0.7), 0, "onsets {:?}", onsets(&s));
        assert!(
            s.last().unwrap().t_s >= 1.2,
            "runs to at least 1.2 s after onset"
        );
    }
}

in_both_floats! {
    fn constant_coefficients_keep_stick_slip_going<T>() {
        let s = render::<T>(&model("god-object-constant", &[]), "spidar-slide");
        let ratio = late_over_early(&s);
        assert!(ratio > 0.6, "late/early peak-to-peak {ratio}");
        assert!(slips_after(&s, 0.7) >= 3, "onsets {:?}", onsets(&s));
    }
}

in_both_floats! {
    fn the_claim_holds_over_the_documented_coupling_range<T>() {
        // docs/friction-models.md: with b = 2 N s/m the claim holds for
        // k = 400..4000 N/m.
        for k in ["400", "1000", "2000", "4000"] {
            let set = [
                ("coupling_stiffness_n_m", k),
                ("coupling_damping_n_s_m", "2"),
            ];
            let tv = render::<T>(&model("god-object-time-varying", &set), "spidar-slide");
            let c = render::<T>(&model("god-object-constant", &set), "spidar-slide");
            assert!(
                late_over_early(&tv) < 0.2 && slips_after(&tv, 0.7) == 0,
                "k={k} time-varying"
            );
            assert!(
                late_over_early(&c) > 0.6 && slips_after(&c, 0.7) > 0,
                "k={k} constant"
            );
        }
    }
}

in_both_floats! {
    fn strong_coupling_damping_suppresses_stick_slip_in_both_models<T>() {
        // The effect depends on the coupling: at b = 5 N s/m even the constant
        // model slides smoothly after onset (docs/friction-models.md).
        let set = [("coupling_damping_n_s_m", "5")];
        let c = render::<T>(&model("god-object-constant", &set), "spidar-slide");
        assert_eq!(slips_after(&c, 0.7), 0);
    }
}

#[test]
fn static_coefficient_grows_with_stick_time_as_dieterich() {
    let law = TimeVaryingStatic::default();
    assert!((law.mu_s(0.0) - 0.6).abs() < 1e-15);
    let one_second = 0.6 + 0.3 * 501.0_f64.log10();
    assert!((law.mu_s(1.0) - one_second).abs() < 1e-12);
    assert!(law.mu_s(0.01) < law.mu_s(0.1) && law.mu_s(0.1) < law.mu_s(1.0));
}

in_both_floats! {
    fn slip_vibration_never_pushes_force_past_the_device_limit<T>() {
        let s = render::<T>(&model("god-object-constant", &[]), "spidar-slide");
        let max = s.iter().map(|x| x.force_n.abs()).fold(0.0, f64::max);
        assert!(max <= 9.48 + 1e-12, "max |force| {max}");
        // The vibration is there: the force right after onset swings beyond the
        // coupling force alone (mu_s F_N = 3 N).
        assert!(peak_to_peak(&s, 0.0, 0.05, |x| x.force_n) > 3.0);
    }
}
