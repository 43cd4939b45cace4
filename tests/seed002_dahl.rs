//! Seed 002 (STUDIES 1d): the Dahl model: force tends to +-Fc, hysteresis on
//! reversal, sound over a wide range of sigma.

#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    reason = "a failed unwrap is a failed test"
)]

use crate::common;

use common::drive;
use frictionlab::friction::{DahlParams, Float, Input, ModelParams};
use proptest::prelude::*;

fn no_viscous(p: DahlParams) -> ModelParams {
    ModelParams::Dahl(DahlParams {
        viscous_n_s_m: 0.0,
        ..p
    })
}

fn ramp(from: f64, to: f64, n: usize) -> Vec<Input> {
    (0..=n)
        .map(|i| Input {
            x_m: from + (to - from) * i as f64 / n as f64,
            v_m_s: (to - from).signum(),
        })
        .collect()
}

in_both_floats! {
    fn force_tends_to_plus_minus_fc<T>() {
        let p = DahlParams {
            fc_pos_n: 2.0,
            fc_neg_n: 1.5,
            ..DahlParams::default()
        };
        let travel = 20.0 * p.fc_pos_n / p.sigma_n_m;
        let out = drive::<T>(&no_viscous(p), 1e-3, &ramp(0.0, travel, 1000));
        // In f32 F stalls within Fc 2^-24 / u of Fc (u = sigma |dx| / Fc per
        // step; core's dahl docs): 3 uN here.
        let tolerance = if T::FLOAT == Float::F32 { 1e-5 } else { 1e-6 };
        // The device feels -F: friction opposes motion.
        let last = out.last().unwrap().force_n;
        assert!((last + 2.0).abs() < tolerance, "{last}");
        let back = drive::<T>(&no_viscous(p), 1e-3, &ramp(0.0, -travel, 1000));
        let last = back.last().unwrap().force_n;
        assert!((last - 1.5).abs() < tolerance, "{last}");
    }
}

in_both_floats! {
    fn hysteresis_on_reversal<T>() {
        let p = DahlParams::default();
        let a = 10.0 * p.fc_pos_n / p.sigma_n_m;
        let n: i32 = 4000;
        let inputs: Vec<Input> = (0..n)
            .map(|i| {
                let w = std::f64::consts::TAU * f64::from(i) / 2000.0;
                Input {
                    x_m: a * w.sin(),
                    v_m_s: a * w.cos(),
                }
            })
            .collect();
        let out = drive::<T>(&no_viscous(p), 1e-3, &inputs);
        // At x = 0 in the second cycle: moving up the force is near -Fc, moving
        // down near +Fc: the loop is open.
        let up = out[2000].force_n;
        let down = out[3000].force_n;
        assert!(
            up < -0.9 * p.fc_pos_n && down > 0.9 * p.fc_neg_n,
            "up {up}, down {down}"
        );
        // Right after the reversal at the trough (step 1500), F leaves -Fc at
        // dF/dx = sigma (1 + 1) = 2 sigma: the device feels -F, slope -2 sigma.
        let x = |i: usize| inputs[i].x_m;
        let slope = (out[1502].force_n - out[1501].force_n) / (x(1502) - x(1501));
        assert!(
            (slope / (-2.0 * p.sigma_n_m) - 1.0).abs() < 0.01,
            "slope {slope}"
        );
    }
}

proptest! {
    #[test]
    fn force_stays_within_its_limits_for_any_sigma_and_motion(
        log_sigma in 2.0_f64..8.0,
        exponent in 0.3_f64..3.0,
        steps in proptest::collection::vec(-0.05_f64..0.05, 1..200),
    ) {
        let p = DahlParams { sigma_n_m: 10f64.powf(log_sigma), exponent, viscous_n_s_m: 0.0, ..DahlParams::default() };
        let mut x = 0.0;
        let inputs: Vec<Input> = steps.iter().map(|dx| { x += dx; Input { x_m: x, v_m_s: dx / 1e-3 } }).collect();
        for o in drive::<f64>(&no_viscous(p), 1e-3, &inputs) {
            prop_assert!(o.force_n.is_finite());
            prop_assert!(o.force_n.abs() <= p.fc_pos_n.max(p.fc_neg_n) + 1e-9);
        }
    }
}
