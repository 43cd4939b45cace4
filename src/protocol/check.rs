//! Stage 1's second half: value checks on a protocol whose structure
//! [`super::load`] has read (ranges, unique and valid ids, cross-references,
//! zero trials), each problem named by its JSON path.

use std::collections::HashSet;

use super::load::{is_valid_id, stimulus_model};
use super::{Design, FittsDesign, Protocol};
use crate::friction::ModelParams;
use crate::problem::Problem;

/// Value checks on a structurally valid protocol.
pub(super) fn check(p: &Protocol, errors: &mut Vec<Problem>) {
    let mut err = |path: String, message: String| errors.push(Problem::new(path, message));
    if !is_valid_id(&p.id) {
        err(
            "id".into(),
            format!("'{}': use letters, digits, '-' and '_'", p.id),
        );
    }
    if p.repetitions == 0 {
        err("repetitions".into(), "must be at least 1".into());
    }
    non_negative(&mut err, "break_s", p.break_s);
    match &p.design {
        Design::PairedComparison(d) => {
            non_negative(&mut err, "design.reference_s", d.reference_s);
            positive(&mut err, "design.exploration_s", d.exploration_s);
            let ids = condition_ids(
                &mut err,
                "design.conditions",
                d.conditions.iter().map(|c| c.id.as_str()),
            );
            if d.pairs.is_empty() {
                err(
                    "design.pairs".into(),
                    "no pairs: the protocol has zero trials".into(),
                );
            }
            for (i, [a, b]) in d.pairs.iter().enumerate() {
                for (j, id) in [a, b].iter().enumerate() {
                    if !ids.contains(id.as_str()) {
                        err(
                            format!("design.pairs[{i}][{j}]"),
                            format!("unknown condition '{id}'"),
                        );
                    }
                }
                if a == b {
                    err(
                        format!("design.pairs[{i}]"),
                        "a pair needs two different conditions".into(),
                    );
                }
            }
        }
        Design::MagnitudeEstimation(d) => {
            positive(&mut err, "design.exploration_s", d.exploration_s);
            if d.sets.is_empty() {
                err(
                    "design.sets".into(),
                    "no sets: the protocol has zero trials".into(),
                );
            }
            for (i, set) in d.sets.iter().enumerate() {
                let path = format!("design.sets[{i}]");
                if !matches!(
                    set.model,
                    ModelParams::StickSlipTactile(_) | ModelParams::StickSlipForce(_)
                ) {
                    err(
                        format!("{path}.model.model"),
                        "a magnitude set needs stick-slip-tactile or stick-slip-force".into(),
                    );
                    continue;
                }
                if set.stimuli.is_empty() {
                    err(
                        format!("{path}.stimuli"),
                        "no stimuli: the set has zero trials".into(),
                    );
                }
                for (j, s) in set.stimuli.iter().enumerate() {
                    for e in stimulus_model(&set.model, *s).validate() {
                        err(format!("{path}.stimuli[{j}].{}", e.place), e.message);
                    }
                }
            }
        }
        Design::Fitts(d) => check_fitts(d, &mut err),
    }
}

fn check_fitts(d: &FittsDesign, err: &mut impl FnMut(String, String)) {
    positive(err, "design.cursor_m", d.cursor_m);
    positive(err, "design.timeout_s", d.timeout_s);
    if d.taps < 2 {
        err(
            "design.taps".into(),
            format!(
                "must be at least 2 (a completion time needs a first and a last tap), got {}",
                d.taps
            ),
        );
    }
    let ids = condition_ids(
        err,
        "design.conditions",
        d.conditions.iter().map(|c| c.id.as_str()),
    );
    if d.levels.is_empty() {
        err(
            "design.levels".into(),
            "no levels: the protocol has zero trials".into(),
        );
    }
    for (i, level) in d.levels.iter().enumerate() {
        let path = format!("design.levels[{i}]");
        positive(err, &format!("{path}.amplitude_m"), level.amplitude_m);
        positive(err, &format!("{path}.width_m"), level.width_m);
        if level.width_m.is_finite() && d.effective_width(level.width_m) <= 0.0 {
            err(
                format!("{path}.width_m"),
                format!(
                    "target width {} m must exceed the cursor diameter {} m",
                    level.width_m, d.cursor_m
                ),
            );
        }
        if level.amplitude_m <= level.width_m {
            err(
                format!("{path}.amplitude_m"),
                format!(
                    "targets overlap: distance {} m must exceed width {} m",
                    level.amplitude_m, level.width_m
                ),
            );
        }
    }
    for (i, id) in d.practice.iter().enumerate() {
        if !ids.contains(id.as_str()) {
            err(
                format!("design.practice[{i}]"),
                format!("unknown condition '{id}'"),
            );
        }
    }
    for (i, &l) in d.practice_levels.iter().enumerate() {
        if l >= d.levels.len() {
            err(
                format!("design.practice_levels[{i}]"),
                format!("level {l} does not exist ({} levels)", d.levels.len()),
            );
        }
    }
}

fn positive(err: &mut impl FnMut(String, String), path: &str, x: f64) {
    if !(x.is_finite() && x > 0.0) {
        err(path.into(), format!("must be greater than 0, got {x}"));
    }
}

fn non_negative(err: &mut impl FnMut(String, String), path: &str, x: f64) {
    if !(x.is_finite() && x >= 0.0) {
        err(path.into(), format!("must not be negative, got {x}"));
    }
}

/// Checks condition ids (valid, unique, at least one) and returns them.
fn condition_ids<'a>(
    err: &mut impl FnMut(String, String),
    path: &str,
    ids: impl Iterator<Item = &'a str>,
) -> HashSet<&'a str> {
    let mut seen = HashSet::new();
    for (i, id) in ids.enumerate() {
        if !is_valid_id(id) {
            err(
                format!("{path}[{i}].id"),
                format!("'{id}': use letters, digits, '-' and '_'"),
            );
        }
        if !seen.insert(id) {
            err(
                format!("{path}[{i}].id"),
                format!("duplicate condition id '{id}'"),
            );
        }
    }
    if seen.is_empty() {
        err(
            path.into(),
            "no conditions: the protocol has zero trials".into(),
        );
    }
    seen
}
