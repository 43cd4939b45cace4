//! Stage 1's second half: value checks on a protocol whose structure
//! [`super::load`] has read (ranges, unique and valid ids, cross-references,
//! zero trials), each problem named by its JSON path. The design's checks
//! are its kind's ([`super::kind::StudyKind::check`]), made with [`Checks`].

use std::collections::HashSet;

use super::Protocol;
use super::kind::Kinds;
use super::load::id_problem;
use crate::problem::Problem;

/// Collects the problems of value checks, each at its JSON path under a
/// prefix (`design.` for a kind's checks).
#[derive(Debug)]
pub struct Checks<'a> {
    errors: &'a mut Vec<Problem>,
    prefix: &'static str,
}

impl Checks<'_> {
    /// A problem at `path` (under the prefix).
    pub fn err(&mut self, path: &str, message: impl Into<String>) {
        self.errors
            .push(Problem::new(format!("{}{path}", self.prefix), message));
    }

    /// `x` must be finite and greater than 0.
    pub fn positive(&mut self, path: &str, x: f64) {
        if !(x.is_finite() && x > 0.0) {
            self.err(path, format!("must be greater than 0, got {x}"));
        }
    }

    /// `x` must be finite and not negative.
    pub fn non_negative(&mut self, path: &str, x: f64) {
        if !(x.is_finite() && x >= 0.0) {
            self.err(path, format!("must not be negative, got {x}"));
        }
    }

    /// Checks the condition ids listed at `path` (valid, unique, at least
    /// one) and returns them.
    pub fn condition_ids<'i>(
        &mut self,
        path: &str,
        ids: impl Iterator<Item = &'i str>,
    ) -> HashSet<&'i str> {
        let mut seen = HashSet::new();
        for (i, id) in ids.enumerate() {
            if let Some(why) = id_problem(id) {
                self.err(&format!("{path}[{i}].id"), why);
            }
            if !seen.insert(id) {
                self.err(
                    &format!("{path}[{i}].id"),
                    format!("duplicate condition id '{id}'"),
                );
            }
        }
        if seen.is_empty() {
            self.err(path, "no conditions: the protocol has zero trials");
        }
        seen
    }
}

/// Value checks on a structurally valid protocol.
pub(super) fn check<K: Kinds>(p: &Protocol<K>, errors: &mut Vec<Problem>) {
    let mut c = Checks { errors, prefix: "" };
    if let Some(why) = id_problem(&p.id) {
        c.err("id", why);
    }
    if p.repetitions == 0 {
        c.err("repetitions", "must be at least 1");
    }
    c.non_negative("break_s", p.break_s);
    for (i, v) in p.validation.iter().enumerate() {
        super::validation::check(v, &format!("validation[{i}]"), &mut c);
    }
    K::check_design(
        &p.design,
        &mut Checks {
            errors: c.errors,
            prefix: "design.",
        },
    );
}
