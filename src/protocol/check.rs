//! Stage 1's second half: value checks on a protocol whose structure
//! [`super::load`] has read (ranges, unique and valid ids, cross-references,
//! zero trials), each problem named by its JSON path. The design's checks
//! are its kind's ([`super::kind::StudyKind::check`]), made with [`ValueChecks`].

use std::collections::HashSet;

use super::Protocol;
use super::kind::Kinds;
use super::load::id_problem;
use crate::problem::Problem;
use crate::time::MAX_PROTOCOL_S;

/// The most trials a session may hold (issue 42): its plan's size is
/// computed from the protocol's fields before anything is allocated, and a
/// larger plan is refused with its place. At 2 s a trial, 100,000 trials
/// take more than 55 hours: no session a person sits through, and a plan a
/// few tens of megabytes large.
pub const MAX_TRIALS: u64 = 100_000;

/// Collects the problems of value checks, each at its JSON path under a
/// prefix (`design.` for a kind's checks).
#[derive(Debug)]
pub struct ValueChecks<'a> {
    errors: &'a mut Vec<Problem>,
    prefix: &'static str,
}

impl ValueChecks<'_> {
    /// A problem at `path` (under the prefix).
    pub fn err(&mut self, path: &str, message: impl Into<String>) {
        self.errors
            .push(Problem::new(format!("{}{path}", self.prefix), message));
    }

    /// `x` must be finite and greater than 0.
    pub fn positive(&mut self, path: &str, x: f64) {
        if !(x.is_finite() && x > 0.0) {
            self.err(path, format!("must be greater than 0, got {}", shown(x)));
        }
    }

    /// `x` must be finite and not negative.
    pub fn non_negative(&mut self, path: &str, x: f64) {
        if !(x.is_finite() && x >= 0.0) {
            self.err(path, format!("must not be negative, got {}", shown(x)));
        }
    }

    /// A duration `x`, s: not negative and at most [`MAX_PROTOCOL_S`] (one
    /// day), so the session's clock, in whole nanoseconds, holds it and
    /// every sum of them ([`crate::time::Time`]).
    pub fn duration(&mut self, path: &str, x: f64) {
        if !(x.is_finite() && x >= 0.0) {
            self.err(path, format!("must not be negative, got {}", shown(x)));
        } else if x > MAX_PROTOCOL_S {
            self.err(path, too_long(x));
        }
    }

    /// A duration `x`, s, greater than 0 and at most [`MAX_PROTOCOL_S`].
    pub fn positive_duration(&mut self, path: &str, x: f64) {
        if !(x.is_finite() && x > 0.0) {
            self.err(path, format!("must be greater than 0, got {}", shown(x)));
        } else if x > MAX_PROTOCOL_S {
            self.err(path, too_long(x));
        }
    }

    /// A count a kind's field makes grow (trials of an adaptive track,
    /// points of a grid): at most `max`.
    pub fn at_most(&mut self, path: &str, what: &str, n: u64, max: u64) {
        if n > max {
            self.err(path, format!("{what} would be {n}; at most {max}"));
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

fn too_long(x: f64) -> String {
    format!(
        "{} s is longer than a session's longest time, {MAX_PROTOCOL_S} s (one day)",
        shown(x)
    )
}

/// `x` as a message shows it: its shortest text, with an exponent where
/// that is shorter (`1e300`, not three hundred digits).
#[must_use]
pub fn shown(x: f64) -> String {
    let (plain, exponent) = (format!("{x}"), format!("{x:e}"));
    if exponent.len() < plain.len() {
        exponent
    } else {
        plain
    }
}

/// Value checks on a structurally valid protocol. The plan's size comes
/// first, from the fields alone; a plan over [`MAX_TRIALS`] is refused
/// before the design's own checks run.
pub(super) fn check<K: Kinds>(p: &Protocol<K>, errors: &mut Vec<Problem>) {
    let mut c = ValueChecks { errors, prefix: "" };
    if let Some(why) = id_problem(&p.id) {
        c.err("id", why);
    }
    if p.repetitions == 0 {
        c.err("repetitions", "must be at least 1");
    }
    let per = K::trials_per_repetition(&p.design);
    let trials = u128::from(per) * u128::from(p.repetitions);
    if trials > u128::from(MAX_TRIALS) {
        let (path, why) = if p.repetitions > 1 {
            (
                "repetitions",
                format!("{per} trials x {} repetitions", p.repetitions),
            )
        } else {
            ("design", format!("{per} trials in one repetition"))
        };
        c.err(
            path,
            format!(
                "the plan would hold {trials} trials ({why}); a session holds at most {MAX_TRIALS}"
            ),
        );
        return;
    }
    c.duration("break_s", p.break_s);
    if let Some(m) = &p.masking {
        use crate::audio::noise::{MAX_LEVEL_DBFS, MIN_LEVEL_DBFS};
        if !(MIN_LEVEL_DBFS..=MAX_LEVEL_DBFS).contains(&m.level_dbfs) {
            c.err(
                "masking.level_dbfs",
                format!(
                    "{} dBFS is outside {MIN_LEVEL_DBFS} to {MAX_LEVEL_DBFS} dBFS (RMS; the ceiling keeps the noise's peaks below full scale)",
                    m.level_dbfs
                ),
            );
        }
    }
    for (i, v) in p.validation.iter().enumerate() {
        super::validation::check(v, &format!("validation[{i}]"), &mut c);
    }
    K::check_design(
        &p.design,
        &mut ValueChecks {
            errors: c.errors,
            prefix: "design.",
        },
    );
}

/// The stretches of `protocol`'s design that lie beyond a device's travel
/// `travel_m` (m from its track's origin, lowest and highest), each a
/// problem at its JSON path naming where it reaches and the travel of
/// `device` (`the simulated apparatus`): a protocol the device cannot
/// perform (issue 63: a Fitts level at ±25 mm on the simulated
/// apparatus's ±16 mm ran, and its simulated participants made 2 to 4 of
/// 20 taps in 120 s).
#[must_use]
pub fn beyond_travel<K: Kinds>(
    protocol: &Protocol<K>,
    travel_m: [f64; 2],
    device: &str,
) -> Vec<Problem> {
    let mm = |x: f64| format!("{:.1}", x * 1e3);
    K::reach(&protocol.design)
        .into_iter()
        .filter(|r| r.span_m[0] < travel_m[0] || r.span_m[1] > travel_m[1])
        .map(|r| {
            Problem::new(
                format!("design.{}", r.path),
                format!(
                    "{} reach {} to {} mm along the track, beyond {device}'s travel of {} to {} mm",
                    r.what,
                    mm(r.span_m[0]),
                    mm(r.span_m[1]),
                    mm(travel_m[0]),
                    mm(travel_m[1])
                ),
            )
        })
        .collect()
}
