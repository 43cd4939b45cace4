//! Parameter checks that allocate nothing: each problem is reported through
//! a callback, so the device can check an uploaded model and the host can
//! turn the same problems into located messages.

use crate::real::Real;

/// What is wrong with one parameter.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Rule {
    /// It must be finite and greater than 0.
    Positive,
    /// It must be finite and not negative.
    NonNegative,
    /// It must be greater than another field (or at least equal to it).
    Exceeds {
        /// The other field.
        other_field: &'static str,
        /// The other field's value.
        other: f64,
        /// Whether equal is allowed.
        allow_equal: bool,
    },
    /// It must be at most this.
    AtMost(f64),
    /// Seed 001's stick-slip needs an underdamped floor: damping ratio
    /// `zeta` = c / (2 sqrt(m k)) below 1, i.e. c below `critical`.
    Underdamped {
        /// The damping ratio the parameters give.
        zeta: f64,
        /// 2 sqrt(m k), N s/m.
        critical: f64,
    },
}

/// One invalid parameter.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ParamProblem {
    /// The enclosing object's field, if the parameter is nested
    /// (`static_friction`).
    pub within: Option<&'static str>,
    /// The field.
    pub field: &'static str,
    /// Its value.
    pub value: f64,
    /// The rule it breaks.
    pub rule: Rule,
}

/// The message, without the field's name (`must be greater than 0, got -1`).
impl core::fmt::Display for ParamProblem {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        let value = self.value;
        match self.rule {
            Rule::Positive | Rule::NonNegative if !value.is_finite() => {
                write!(f, "must be finite, got {value}")
            }
            Rule::Positive => write!(f, "must be greater than 0, got {value}"),
            Rule::NonNegative => write!(f, "must not be negative, got {value}"),
            Rule::Exceeds {
                other_field,
                other,
                allow_equal,
            } => {
                let relation = if allow_equal {
                    "must be at least"
                } else {
                    "must be greater than"
                };
                write!(f, "{relation} {other_field} ({other}), got {value}")
            }
            Rule::AtMost(max) => write!(f, "must be at most {max}, got {value}"),
            Rule::Underdamped { zeta, critical } => write!(
                f,
                "gives damping ratio {zeta:.3}; stick-slip needs c < 2 sqrt(m k) = {critical:.6}"
            ),
        }
    }
}

/// Collects the problems of one parameter object: `report` gets each.
pub struct ParamChecks<'a> {
    within: Option<&'static str>,
    report: &'a mut dyn FnMut(ParamProblem),
}

impl<'a> ParamChecks<'a> {
    /// Checks reporting each problem to `report`.
    pub fn new(report: &'a mut dyn FnMut(ParamProblem)) -> Self {
        ParamChecks {
            within: None,
            report,
        }
    }

    /// Reports fields from here on as inside `within`.
    pub fn within(&mut self, within: &'static str) {
        self.within = Some(within);
    }

    /// Reports a problem.
    pub fn report(&mut self, field: &'static str, value: f64, rule: Rule) {
        (self.report)(ParamProblem {
            within: self.within,
            field,
            value,
            rule,
        });
    }

    /// Reports `rule` for `field` unless `ok`; returns `ok`.
    fn require<T: Real>(&mut self, ok: bool, field: &'static str, value: T, rule: Rule) -> bool {
        if !ok {
            self.report(field, value.to_f64(), rule);
        }
        ok
    }

    /// `value` must be finite and greater than 0; returns whether it is.
    pub fn positive<T: Real>(&mut self, field: &'static str, value: T) -> bool {
        let ok = value.is_finite() && value > T::ZERO;
        self.require(ok, field, value, Rule::Positive)
    }

    /// `value` must be finite and not negative; returns whether it is.
    pub fn non_negative<T: Real>(&mut self, field: &'static str, value: T) -> bool {
        let ok = value.is_finite() && value >= T::ZERO;
        self.require(ok, field, value, Rule::NonNegative)
    }

    /// `value` must be at most `max`; returns whether it is.
    pub fn at_most<T: Real>(&mut self, field: &'static str, value: T, max: T) -> bool {
        self.require(value <= max, field, value, Rule::AtMost(max.to_f64()))
    }

    /// `value` must be greater than `other` (or equal, when `allow_equal`);
    /// returns whether it is.
    pub fn exceeds<T: Real>(
        &mut self,
        field: &'static str,
        value: T,
        other_field: &'static str,
        other: T,
        allow_equal: bool,
    ) -> bool {
        let ok = value > other || (allow_equal && value == other);
        let rule = Rule::Exceeds {
            other_field,
            other: other.to_f64(),
            allow_equal,
        };
        self.require(ok, field, value, rule)
    }
}
