//! Properties every friction model keeps: direction symmetry, finite output
//! within the force limit, robustness to bad input, and strict parameter
//! parsing and validation.

#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    reason = "a failed unwrap is a failed test"
)]

use crate::common;

use common::{drive, model, wiggle};
use frictionlab::friction::{ForceLimit, Friction, Input, ModelParams, Phase, Validate};
use proptest::prelude::*;

fn all_models() -> Vec<ModelParams> {
    ModelParams::NAMES
        .iter()
        .map(|n| ModelParams::default_for(n).unwrap())
        .collect()
}

in_both_floats! {
    fn every_model_is_direction_symmetric<T>() {
        for params in all_models() {
            let dt = 1.0 / params.loop_rate_hz();
            let inputs = wiggle(3000, dt, 0.01);
            let mirrored: Vec<Input> = inputs
                .iter()
                .map(|i| Input {
                    x_m: -i.x_m,
                    v_m_s: -i.v_m_s,
                })
                .collect();
            let a = drive::<T>(&params, dt, &inputs);
            let b = drive::<T>(&params, dt, &mirrored);
            let mut moving = 0;
            for (i, (p, q)) in a.iter().zip(&b).enumerate() {
                assert!(
                    (p.force_n + q.force_n).abs() < 1e-9,
                    "{} step {i}: {} vs {}",
                    params.name(),
                    p.force_n,
                    q.force_n
                );
                assert!(
                    (p.vibration - q.vibration).abs() < 1e-12,
                    "{} step {i}",
                    params.name()
                );
                assert_eq!(
                    (p.phase, p.slip_onset),
                    (q.phase, q.slip_onset),
                    "{} step {i}",
                    params.name()
                );
                moving += usize::from(p.force_n != 0.0 || p.vibration != 0.0);
            }
            if params.name() != "none" {
                assert!(moving > 100, "{} rendered something", params.name());
            }
        }
    }
}

#[test]
fn non_finite_input_renders_nothing_and_leaves_the_state_alone() {
    for params in all_models() {
        let dt = 1.0 / params.loop_rate_hz();
        let inputs = wiggle(500, dt, 0.01);
        let clean = drive::<f64>(&params, dt, &inputs);
        let mut f = Friction::new(&params, ForceLimit::default(), 0.0).unwrap();
        for (i, input) in inputs.iter().enumerate() {
            if i == 250 {
                for bad in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
                    let o = f.step(
                        dt,
                        Input {
                            x_m: bad,
                            v_m_s: 0.0,
                        },
                    );
                    assert_eq!(o.force_n, 0.0);
                    let o = f.step(
                        dt,
                        Input {
                            x_m: 0.0,
                            v_m_s: bad,
                        },
                    );
                    assert_eq!(o.force_n, 0.0);
                    let o = f.step(bad, *input);
                    assert_eq!(o.force_n, 0.0);
                    let o = f.step(-dt, *input);
                    assert_eq!(o.force_n, 0.0);
                }
            }
            let o = f.step(dt, *input);
            assert_eq!(o, clean[i], "{} step {i}", params.name());
        }
    }
}

#[test]
fn force_limit_clamps_every_model() {
    let limit = ForceLimit::new(0.5).unwrap();
    for params in all_models() {
        let dt = 1.0 / params.loop_rate_hz();
        let mut f = Friction::new(&params, limit, 0.0).unwrap();
        let mut hit = false;
        for input in wiggle(3000, dt, 0.03) {
            let o = f.step(dt, input);
            assert!(o.force_n.abs() <= 0.5, "{}", params.name());
            hit |= o.force_n.abs() == 0.5;
        }
        let renders_force = !matches!(params.name(), "none" | "stick-slip-tactile");
        assert_eq!(
            hit,
            renders_force,
            "{} reaches the 0.5 N limit",
            params.name()
        );
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 64, ..ProptestConfig::default() })]
    #[test]
    fn output_is_finite_and_limited_for_any_finite_input(
        which in 0_usize..8,
        dt in 1e-6_f64..0.05,
        xs in proptest::collection::vec((-1e3_f64..1e3, -1e3_f64..1e3), 1..300),
    ) {
        let params = all_models().swap_remove(which);
        let mut f = Friction::new(&params, ForceLimit::default(), 0.0).unwrap();
        for (x, v) in xs {
            let o = f.step(dt, Input { x_m: x, v_m_s: v });
            prop_assert!(o.force_n.is_finite() && o.force_n.abs() <= 9.48);
            prop_assert!(o.vibration.is_finite() && o.vibration.abs() <= 1.0);
            prop_assert!(matches!(o.phase, Phase::Stick | Phase::Slip));
        }
    }
}

#[test]
fn params_round_trip_through_json_with_their_model_name() {
    for params in all_models() {
        let json = serde_json::to_string(&params).unwrap();
        assert!(
            json.contains(&format!("\"model\":\"{}\"", params.name())),
            "{json}"
        );
        let back: ModelParams = serde_json::from_str(&json).unwrap();
        assert_eq!(back, params);
    }
}

#[test]
fn omitted_fields_take_the_seeds_defaults_and_unknown_fields_are_refused() {
    let p: ModelParams =
        serde_json::from_str(r#"{"model": "karnopp", "f_static_n": 3.0}"#).unwrap();
    assert_eq!(p, model("karnopp", &[("f_static_n", "3.0")]));
    let e = serde_json::from_str::<ModelParams>(r#"{"model": "karnopp", "mu_x": 1}"#).unwrap_err();
    assert!(e.to_string().contains("unknown field `mu_x`"), "{e}");
    let e = serde_json::from_str::<ModelParams>(
        r#"{"model": "god-object-constant", "static_friction": {"mu_s": 1.0, "b": 2}}"#,
    )
    .unwrap_err();
    assert!(e.to_string().contains("unknown field `b`"), "{e}");
    let e = serde_json::from_str::<ModelParams>(r#"{"model": "coulomb"}"#).unwrap_err();
    assert!(e.to_string().contains("unknown variant `coulomb`"), "{e}");
}

#[test]
fn invalid_parameters_are_named_with_a_reason() {
    let cases = [
        (
            "stick-slip-force",
            vec![("mu_s", "0.3")],
            "mu_s",
            "must be greater than mu_k",
        ),
        (
            "stick-slip-tactile",
            vec![("mass_kg", "-1")],
            "mass_kg",
            "must be greater than 0",
        ),
        (
            "stick-slip-tactile",
            vec![("damping_n_s_m", "1")],
            "damping_n_s_m",
            "stick-slip needs c <",
        ),
        (
            "god-object-constant",
            vec![("mu_s", "0.6")],
            "static_friction.mu_s",
            "must be greater than mu_d",
        ),
        (
            "god-object-time-varying",
            vec![("c_per_s", "0")],
            "static_friction.c_per_s",
            "must be greater than 0",
        ),
        (
            "karnopp",
            vec![("f_static_n", "1")],
            "f_static_n",
            "must be at least f_dynamic_n",
        ),
        (
            "dahl",
            vec![("sigma_n_m", "0")],
            "sigma_n_m",
            "must be greater than 0",
        ),
        (
            "viscous",
            vec![("damping_n_s_m", "-35")],
            "damping_n_s_m",
            "must not be negative",
        ),
    ];
    for (name, sets, field, message) in cases {
        let errors = model(name, &sets).validate();
        assert_eq!(errors.len(), 1, "{name}: {errors:?}");
        assert_eq!(errors[0].place, field);
        assert!(
            errors[0].message.contains(message),
            "{name}: {}",
            errors[0].message
        );
        assert!(Friction::new(&model(name, &sets), ForceLimit::default(), 0.0).is_err());
    }
    assert!(ForceLimit::new(f64::NAN).is_err() && ForceLimit::new(0.0).is_err());
}

in_both_floats! {
    /// Issue 37: a velocity estimate that decays, and a stick-slip burst
    /// that dies out, end at exactly 0, never in subnormal numbers.
    fn a_decaying_velocity_estimate_and_burst_end_at_zero_not_in_subnormals_issue_37<T>() {
        use frictionlab::friction::{StepParams, filtered_velocity};
        let dt = 1.0 / 5000.0;
        let alpha = T::of(StepParams::default().velocity_alpha(dt));
        let (mut v, mut steps) = (T::of(0.1), 0);
        while v != T::ZERO {
            v = filtered_velocity(alpha, v, T::ZERO);
            assert!(v == T::ZERO || v.abs() >= T::of(1e-9), "{v:?}");
            steps += 1;
            assert!(steps < 1000, "still {v:?} after {steps} steps");
        }
        // Stick-slip with its burst, then the finger still for 10 s.
        let model = common::model("stick-slip-tactile", &[]);
        let mut inputs = common::wiggle(5000, dt, 0.01);
        let last = *inputs.last().unwrap();
        inputs.extend(std::iter::repeat_n(
            frictionlab::friction::Input { x_m: last.x_m, v_m_s: 0.0 },
            50_000,
        ));
        let out = common::drive::<T>(&model, dt, &inputs);
        assert!(out[..5000].iter().any(|o| o.vibration.abs() > 0.01), "a burst");
        for o in &out {
            assert!(!o.vibration.is_subnormal() && !o.force_n.is_subnormal());
        }
        assert!(out[out.len() - 1000..].iter().all(|o| o.vibration == 0.0));
    }
}
