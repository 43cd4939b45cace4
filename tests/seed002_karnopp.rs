//! Seed 002 (STUDIES 1c): the modified Karnopp model behind a virtual
//! coupling: stuck force bounded by F_static, presliding displacement
//! F_static/Kp, Kp too low is soft, Kp too high is unstable at 1 kHz.

#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    reason = "a failed unwrap is a failed test"
)]

use crate::common;

use common::{model, render};
use frictionlab::friction::{Float, ForceLimit, Input, Karnopp, KarnoppParams, Phase, Real};

const DT: f64 = 1e-3;

/// The device ramps at `speed` from rest for `steps` ms; returns the model and
/// the block's largest stuck-phase speed before the first break-away, and the
/// block displacement at break-away.
fn pull<T: Real>(p: KarnoppParams, speed: f64, steps: u32) -> (Karnopp<T>, f64, Option<f64>) {
    let mut k = Karnopp::<T>::new(p, ForceLimit::default(), T::ZERO);
    let mut max_stuck_speed: f64 = 0.0;
    let mut breakaway = None;
    for i in 0..steps {
        let t = f64::from(i) * DT;
        let before = k.block_position_m().to_f64();
        let out = k.step(
            T::of(DT),
            Input {
                x_m: T::of(speed * t),
                v_m_s: T::of(speed),
            },
        );
        if out.slip_onset && breakaway.is_none() {
            breakaway = Some(before);
        }
        if breakaway.is_none() {
            max_stuck_speed = max_stuck_speed.max(k.block_velocity_m_s().abs().to_f64());
        }
        if out.phase == Phase::Stick {
            assert!(
                k.friction_n().abs() <= T::of(p.f_static_n),
                "stuck friction {:?} at t={t}",
                k.friction_n()
            );
        }
    }
    (k, max_stuck_speed, breakaway)
}

in_both_floats! {
    fn stuck_force_never_exceeds_f_static<T>() {
        // Slow and fast pulls, and user-like reaches through the coupling.
        for speed in [0.001, 0.02, 0.1] {
            pull::<T>(KarnoppParams::default(), speed, 1000);
        }
        let p = KarnoppParams::default();
        let mut k = Karnopp::<T>::new(p, ForceLimit::default(), T::ZERO);
        for x in render::<T>(&model("karnopp", &[]), "coupled-block") {
            let out = k.step(
                T::of(DT),
                Input {
                    x_m: T::of(x.x_m),
                    v_m_s: T::of(x.v_m_s),
                },
            );
            if out.phase == Phase::Stick {
                assert!(k.friction_n().abs() <= T::of(p.f_static_n));
            }
        }
    }
}

in_both_floats! {
    fn presliding_displacement_is_f_static_over_kp<T>() {
    let p = KarnoppParams::default();
    let (_, _, breakaway) = pull::<T>(p, 0.001, 2000);
    let moved = breakaway.expect("breaks away");
    let expected = p.f_static_n / p.presliding_stiffness_n_m;
    assert!(
        (moved - expected).abs() < 0.02 * expected,
        "moved {moved} m, expected {expected} m"
    );
    }
}

in_both_floats! {
    fn kp_too_low_lets_velocity_pass_dv_before_the_static_limit<T>() {
    let tuned = KarnoppParams::default();
    let soft = KarnoppParams {
        presliding_stiffness_n_m: 500.0,
        ..tuned
    };
    // An exploring hand at 5 cm/s.
    let (_, tuned_speed, b1) = pull::<T>(tuned, 0.05, 1000);
    let (_, soft_speed, b2) = pull::<T>(soft, 0.05, 1000);
    assert!(b1.is_some() && b2.is_some());
    assert!(
        tuned_speed < tuned.zero_velocity_band_m_s,
        "tuned: {tuned_speed} m/s"
    );
    assert!(
        soft_speed > soft.zero_velocity_band_m_s,
        "soft: {soft_speed} m/s"
    );
    }
}

/// With the device held still against a loaded stuck block, whether the
/// rendered force has settled after 1 s (change over the last 100 ms).
fn settles<T: Real>(kp: f64) -> bool {
    let p = KarnoppParams {
        presliding_stiffness_n_m: kp,
        ..KarnoppParams::default()
    };
    let mut k = Karnopp::<T>::new(p, ForceLimit::new(T::of(1e9)).unwrap(), T::ZERO);
    // Device displaced 1 mm: the coupling pulls with 2 N < F_static.
    let hold = Input {
        x_m: T::of(0.001),
        v_m_s: T::ZERO,
    };
    let forces: Vec<f64> = (0..2000)
        .map(|_| k.step(T::of(DT), hold).force_n.to_f64())
        .collect();
    let tail = &forces[1900..];
    let spread = tail.iter().fold(f64::NEG_INFINITY, |a, &b| a.max(b))
        - tail.iter().fold(f64::INFINITY, |a, &b| a.min(b));
    spread < 1e-6
}

in_both_floats! {
    fn kp_too_high_goes_unstable_at_1_khz<T>() {
        let limit = KarnoppParams::default().max_stable_presliding_stiffness(DT);
        assert!((limit - 3.958e6).abs() < 1.0, "documented limit {limit}");
        assert!(settles::<T>(KarnoppParams::default().presliding_stiffness_n_m));
        assert!(settles::<T>(0.9 * limit), "just inside the stable range");
        assert!(!settles::<T>(1.1 * limit), "just outside the stable range");
    }
}

in_both_floats! {
    fn sliding_friction_is_dynamic_plus_viscous<T>() {
        let p = KarnoppParams::default();
        let (k, _, _) = pull::<T>(p, 0.05, 2000);
        // Steady sliding: the block moves with the device; friction -F_d - B v
        // (to the float's rounding: 1e-9 N in f64, 1e-6 N in f32).
        let v = k.block_velocity_m_s();
        assert!((v.to_f64() - 0.05).abs() < 1e-3);
        let residual = k.friction_n() + T::of(p.f_dynamic_n) + T::of(p.viscous_n_s_m) * v;
        let tolerance = if T::FLOAT == Float::F32 { 1e-6 } else { 1e-9 };
        assert!(residual.abs().to_f64() < tolerance, "{residual:?}");
    }
}
