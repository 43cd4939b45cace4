//! The friction core. The models live in the `frictionlab-core` crate
//! (`crates/core/`): `no_std`, no allocator, generic over the float, so the
//! same code renders friction here and on a device. This module re-exports
//! them (every type defaults to `f64`, the host's float) and turns their
//! parameter problems into located [`Problem`]s.
//!
//! See `frictionlab_core::friction` for the conventions (SI units, signs,
//! what the core never does) and the table of models.

pub use frictionlab_core::Real;
pub use frictionlab_core::check::{ParamChecks, ParamProblem, Rule};
pub use frictionlab_core::friction::*;

use crate::problem::Problem;

/// A core parameter problem as a [`Problem`] placed at its field
/// (`static_friction.b`).
#[must_use]
pub fn problem(p: ParamProblem) -> Problem {
    let place = match p.within {
        Some(within) => format!("{within}.{}", p.field),
        None => p.field.to_owned(),
    };
    Problem::new(place, p.to_string())
}

/// Checks of model parameters with every problem collected.
pub trait Validate {
    /// Every invalid parameter, with field names relative to this object.
    fn validate(&self) -> Vec<Problem>;
}

impl Validate for ModelParams {
    fn validate(&self) -> Vec<Problem> {
        let mut problems = Vec::new();
        self.check(&mut |p| problems.push(problem(p)));
        problems
    }
}

/// The problems the checks in `checks` report, located at their fields.
pub fn checked(checks: impl FnOnce(&mut ParamChecks<'_>)) -> Vec<Problem> {
    let mut problems = Vec::new();
    checks(&mut ParamChecks::new(&mut |p| problems.push(problem(p))));
    problems
}

/// `model` with `parameter` set to `value`; `None` if the model has no
/// such numeric field. `parameter` is a dotted field path
/// (`static_friction.mu_s`), or several joined by `+`
/// (`fc_pos_n+fc_neg_n`: each set to `value`, for a level that is written
/// as more than one field, such as Dahl's Coulomb level in each
/// direction).
#[must_use]
pub fn with_parameter(model: &ModelParams, parameter: &str, value: f64) -> Option<ModelParams> {
    let mut v = serde_json::to_value(model).ok()?;
    for path in parameter.split('+') {
        let mut at = &mut v;
        for key in path.split('.') {
            if key == "model" {
                return None;
            }
            at = at.as_object_mut()?.get_mut(key)?;
        }
        if !at.is_number() {
            return None;
        }
        *at = serde_json::Number::from_f64(value).map(serde_json::Value::Number)?;
    }
    serde_json::from_value(v).ok()
}

/// Why `parameter` cannot be varied on `model` (for a protocol check), or
/// `None` when it can.
#[must_use]
pub fn parameter_problem(model: &ModelParams, parameter: &str) -> Option<String> {
    parameter_value(model, parameter).is_none().then(|| {
        let joined = if parameter.contains('+') {
            " (the fields joined by '+' must each be numeric, and equal)"
        } else {
            ""
        };
        format!(
            "the reference model ('{}') has no numeric parameter '{parameter}'{joined}",
            model.name()
        )
    })
}

/// The value of `parameter` in `model` (see [`with_parameter`]); with
/// several fields joined by `+`, `None` unless they are all equal.
#[must_use]
pub fn parameter_value(model: &ModelParams, parameter: &str) -> Option<f64> {
    let v = serde_json::to_value(model).ok()?;
    let mut value = None;
    for path in parameter.split('+') {
        let mut at = &v;
        for key in path.split('.') {
            at = at.as_object()?.get(key)?;
        }
        let x = at.as_f64()?;
        match value {
            Some(first) if first != x => return None,
            _ => value = Some(x),
        }
    }
    value
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_parameter_joined_by_plus_sets_every_field_and_reads_back_only_when_equal() {
        let dahl = ModelParams::default_for("dahl").unwrap();
        let both = "fc_pos_n+fc_neg_n";
        assert_eq!(parameter_value(&dahl, both), Some(2.0));
        let m = with_parameter(&dahl, both, 3.5).unwrap();
        assert_eq!(parameter_value(&m, "fc_pos_n"), Some(3.5));
        assert_eq!(parameter_value(&m, "fc_neg_n"), Some(3.5));
        let one = with_parameter(&dahl, "fc_pos_n", 3.0).unwrap();
        assert_eq!(parameter_value(&one, both), None);
        assert!(
            parameter_problem(&one, both)
                .unwrap()
                .contains("must each be numeric, and equal")
        );
        assert!(parameter_problem(&dahl, "fc_pos_n+nothing").is_some());
        assert!(with_parameter(&dahl, "fc_pos_n+nothing", 1.0).is_none());
        assert!(parameter_problem(&dahl, both).is_none());
    }
}
