//! Seed 001 (STUDIES 1b): Nakano's stick-slip model drives a 600 Hz burst at
//! each stick-to-slip transition, decaying with 80 ms; stick-slip stops at
//! high finger speed; transitions peak near 100 Hz.

#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    reason = "a failed unwrap is a failed test"
)]

use crate::common;

use common::{model, onsets, render};
use frictionlab::friction::{Float, ForceLimit, Input, Nakano, NakanoDisplay, NakanoParams, Phase};
use frictionlab::scenario::{Sample, SinusoidalStroke};

fn stroke<T: frictionlab::friction::Real>() -> Vec<Sample> {
    render::<T>(&model("stick-slip-tactile", &[]), "sinusoidal-stroke")
}

/// Largest |vibration| over `t0 <= t < t1`.
fn peak(s: &[Sample], t0: f64, t1: f64) -> f64 {
    s.iter()
        .filter(|x| x.t_s >= t0 && x.t_s < t1)
        .map(|x| x.vibration.abs())
        .fold(0.0, f64::max)
}

in_both_floats! {
    fn a_burst_starts_at_each_transition<T>() {
        let p = NakanoParams::default();
        let mut m = Nakano::<T>::new(p, NakanoDisplay::Tactile, ForceLimit::default());
        let dt = 1.0 / 5000.0;
        let sp = SinusoidalStroke::default();
        let w = std::f64::consts::TAU * sp.frequency_hz;
        let mut bursts = 0;
        for i in 0..5000 {
            let t = f64::from(i) * dt;
            let out = m.step(
                T::of(dt),
                Input {
                    x_m: T::of(sp.amplitude_m * (1.0 - (w * t).cos())),
                    v_m_s: T::of(sp.amplitude_m * w * (w * t).sin()),
                },
            );
            if out.slip_onset {
                bursts += 1;
                // The envelope jumped to alpha k |y| at the transition (then one
                // step of decay), to the float's rounding.
                let envelope = m.envelope().to_f64();
                let expected = p.alpha_per_n
                    * m.elastic_force_at_onset_n().abs().to_f64()
                    * (-dt / p.envelope_time_constant_s).exp();
                let tolerance = if T::FLOAT == Float::F32 { 1e-6 } else { 1e-12 };
                assert!((envelope - expected).abs() < tolerance, "t={t}");
                assert!(envelope > 0.5, "a full burst, envelope {envelope}");
            }
        }
        assert!(bursts >= 10, "{bursts} bursts");
    }
}

in_both_floats! {
    fn carrier_is_600_hz<T>() {
        let s = stroke::<T>();
        // Between the first bursts' decay and the next transition (0.06-0.2 s)
        // the drive is a pure decaying carrier: count sign changes.
        let window: Vec<&Sample> = s.iter().filter(|x| x.t_s >= 0.06 && x.t_s < 0.2).collect();
        assert!(onsets(&s).iter().all(|&o| !(0.06..0.2).contains(&o)));
        let crossings = window
            .windows(2)
            .filter(|w| w[0].vibration.signum() != w[1].vibration.signum())
            .count();
        let hz = crossings as f64 / 2.0 / 0.14;
        assert!((hz - 600.0).abs() < 600.0 * 0.01, "{hz} Hz");
    }
}

in_both_floats! {
    fn envelope_decays_with_80_ms_time_constant<T>() {
        let s = stroke::<T>();
        // Per-window peaks 80 ms apart in the quiet stretch after the first burst.
        let (a, b) = (peak(&s, 0.07, 0.08), peak(&s, 0.15, 0.16));
        let tau = 0.08 / (a / b).ln();
        assert!((tau - 0.080).abs() < 0.080 * 0.03, "tau {tau} s");
    }
}

in_both_floats! {
    fn no_transition_near_the_strokes_peak_speed<T>() {
        let s = stroke::<T>();
        let peak_v = SinusoidalStroke::default().peak_speed_m_s();
        let fastest = s
            .iter()
            .filter(|x| x.slip_onset)
            .map(|x| x.v_m_s.abs())
            .fold(0.0, f64::max);
        assert!(
            fastest < 0.7 * peak_v,
            "a transition at {fastest} m/s of {peak_v}"
        );
        // And the object stays in slip through the fast part of the stroke.
        let fast: Vec<&Sample> = s.iter().filter(|x| x.v_m_s.abs() > 0.8 * peak_v).collect();
        assert!(!fast.is_empty() && fast.iter().all(|x| x.phase == Phase::Slip));
    }
}

in_both_floats! {
    fn transition_rate_peaks_near_100_hz_and_under_150_hz<T>() {
        let o = onsets(&stroke::<T>());
        let rate = o
            .windows(2)
            .map(|w| 1.0 / (w[1] - w[0]))
            .fold(0.0, f64::max);
        assert!((80.0..=120.0).contains(&rate), "peak rate {rate} Hz");
        assert!(rate < 150.0);
        // Bounded by the natural frequency, as the physics says.
        assert!(rate <= NakanoParams::default().natural_frequency_hz() * 1.05);
    }
}

in_both_floats! {
    fn force_display_renders_the_same_models_friction<T>() {
        let p = NakanoParams::default();
        let s = render::<T>(&model("stick-slip-force", &[]), "sinusoidal-stroke");
        let tactile_onsets = onsets(&stroke::<T>());
        assert_eq!(onsets(&s), tactile_onsets, "same model, same transitions");
        let kinetic = p.force_scale * p.mu_k * p.normal_load_n;
        let static_max = p.force_scale * p.mu_s * p.normal_load_n;
        // To the float's rounding of the parameters and their products.
        let tolerance = if T::FLOAT == Float::F32 { 1e-6 } else { 1e-12 };
        for x in &s {
            assert_eq!(x.vibration, 0.0);
            match x.phase {
                Phase::Slip => assert!((x.force_n.abs() - kinetic).abs() < tolerance),
                Phase::Stick => assert!(x.force_n.abs() <= static_max + tolerance),
            }
        }
    }
}
