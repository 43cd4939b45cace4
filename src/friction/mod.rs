//! The friction core. The models live in the `frictionlab-core` crate
//! (`crates/core/`): `no_std`, no allocator, generic over the float, so the
//! same code renders friction here and on a device. This module re-exports
//! them (every type defaults to `f64`, the host's float) and turns their
//! parameter problems into located [`Problem`]s.
//!
//! See `frictionlab_core::friction` for the conventions (SI units, signs,
//! what the core never does) and the table of models.

pub use frictionlab_core::Real;
pub use frictionlab_core::check::{Checker, ParamProblem, Rule};
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
pub fn checked(checks: impl FnOnce(&mut Checker<'_>)) -> Vec<Problem> {
    let mut problems = Vec::new();
    checks(&mut Checker::new(&mut |p| problems.push(problem(p))));
    problems
}

/// `model` with `parameter` (a dotted field path) set to `value`; `None`
/// if the model has no such numeric field.
#[must_use]
pub fn with_parameter(model: &ModelParams, parameter: &str, value: f64) -> Option<ModelParams> {
    let mut v = serde_json::to_value(model).ok()?;
    let mut at = &mut v;
    for key in parameter.split('.') {
        if key == "model" {
            return None;
        }
        at = at.as_object_mut()?.get_mut(key)?;
    }
    if !at.is_number() {
        return None;
    }
    *at = serde_json::Number::from_f64(value).map(serde_json::Value::Number)?;
    serde_json::from_value(v).ok()
}

/// The value of `parameter` in `model`.
#[must_use]
pub fn parameter_value(model: &ModelParams, parameter: &str) -> Option<f64> {
    let v = serde_json::to_value(model).ok()?;
    let mut at = &v;
    for key in parameter.split('.') {
        at = at.as_object()?.get(key)?;
    }
    at.as_f64()
}
