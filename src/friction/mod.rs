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
