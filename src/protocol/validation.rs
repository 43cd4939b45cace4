//! A protocol's optional `validation` rows: each a human experiment the
//! protocol redoes, its published result, and the band a replay with
//! simulated participants is judged by. `frictionlab validation` reads it
//! (the protocols in `analysis/validation/`); a session ignores it.
//!
//! The statistic is named without naming a kind: a path into the
//! analysis's `summary.json` that selects a list of per-participant
//! objects, and the numeric field read from each. A path is dotted keys,
//! and a list step may filter its elements by one key's value:
//! `discrimination.fits[level=2]` is the entries of `discrimination.fits`
//! whose `level` is 2 (numbers compare as numbers, anything else as
//! text). `over`, when given, is a second such path: each participant's
//! value is then the ratio of the two, paired by `participant`.

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use super::check::ValueChecks;

/// What a validation row judges (see the module docs).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Validation {
    /// The human experiment redone, in a few words.
    pub experiment: String,
    /// `validation`: the participant was not built from it; `calibration`:
    /// it checks an input of the participant (the plumbing), and validates
    /// nothing.
    pub role: Role,
    /// The published human result, as published.
    pub published: Published,
    /// The simulated statistic compared with the band.
    pub statistic: Statistic,
    /// `[low, high]`: the replay's mean is "inside" when within it (ends
    /// included). Written before the replay was run.
    pub band: [f64; 2],
    /// Why this band.
    pub band_reasons: String,
    /// Simulated participants in the replay (at least 2).
    pub participants: u32,
    /// The replay's seed.
    pub seed: u64,
}

/// The most simulated participants a row replays (issue 42: what a
/// protocol's number makes grow is bounded): each is a whole session, and
/// the sweep replays them again per point.
pub const MAX_PARTICIPANTS: u64 = 1000;

/// Whether a row validates the participant or calibrates it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum Role {
    /// The participant was not built from this experiment.
    Validation,
    /// The experiment measures an input of the participant.
    Calibration,
}

/// A published result, in the source's words and numbers.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Published {
    /// The result.
    pub result: String,
    /// Its spread, as published (or what is known of it).
    pub spread: String,
    /// Number of participants, as published (or what is known of it).
    pub participants: String,
    /// The source.
    pub source: String,
}

/// A per-participant statistic read from the analysis summary.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Statistic {
    /// What it is, for the table ("Weber fraction at 2 N").
    pub name: String,
    /// Its unit ("" when dimensionless).
    #[serde(default)]
    pub unit: String,
    /// Path to the list of per-participant objects (module docs).
    pub values: String,
    /// The numeric field of each object.
    pub field: String,
    /// A second path: each participant's value is `values`' over this one's.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub over: Option<String>,
}

/// One step of a statistic's path: a key, and an optional filter of the
/// list it holds.
#[derive(Debug, Clone, PartialEq)]
pub struct Step<'a> {
    /// The key.
    pub key: &'a str,
    /// `(key, value)`: keep the list's elements whose `key` is `value`.
    pub filter: Option<(&'a str, &'a str)>,
}

/// The steps of a statistic's path, or what is wrong with it.
///
/// # Errors
/// An empty step, or a filter that is not `[key=value]`.
pub fn steps(path: &str) -> Result<Vec<Step<'_>>, String> {
    let mut out = Vec::new();
    let mut rest = path;
    while !rest.is_empty() {
        let (step, tail) = match rest.find(['.', '[']) {
            Some(i) if rest.as_bytes()[i] == b'[' => {
                let close = rest[i..]
                    .find(']')
                    .ok_or_else(|| format!("'{path}': '[' without ']'"))?;
                let inner = &rest[i + 1..i + close];
                let (k, v) = inner
                    .split_once('=')
                    .filter(|(k, v)| !k.is_empty() && !v.is_empty())
                    .ok_or_else(|| format!("'{path}': a filter is [key=value], got [{inner}]"))?;
                let after = &rest[i + close + 1..];
                let after = after.strip_prefix('.').unwrap_or(after);
                if !after.is_empty() && after.len() == rest[i + close + 1..].len() {
                    return Err(format!("'{path}': expected '.' after ']'"));
                }
                (
                    Step {
                        key: &rest[..i],
                        filter: Some((k, v)),
                    },
                    after,
                )
            }
            Some(i) => (
                Step {
                    key: &rest[..i],
                    filter: None,
                },
                &rest[i + 1..],
            ),
            None => (
                Step {
                    key: rest,
                    filter: None,
                },
                "",
            ),
        };
        if step.key.is_empty() {
            return Err(format!("'{path}': empty key"));
        }
        out.push(step);
        rest = tail;
    }
    if out.is_empty() {
        return Err("empty path".to_owned());
    }
    Ok(out)
}

/// A row's value checks, at `at` (`validation[i]`).
pub(super) fn check(v: &Validation, at: &str, c: &mut ValueChecks<'_>) {
    for (path, text) in [
        ("experiment", &v.experiment),
        ("band_reasons", &v.band_reasons),
        ("published.result", &v.published.result),
        ("published.source", &v.published.source),
        ("statistic.name", &v.statistic.name),
        ("statistic.field", &v.statistic.field),
    ] {
        if text.trim().is_empty() {
            c.err(&format!("{at}.{path}"), "must not be empty");
        }
    }
    let [lo, hi] = v.band;
    if !(lo.is_finite() && hi.is_finite() && lo < hi) {
        c.err(
            &format!("{at}.band"),
            format!("must be [low, high] with low < high, got [{lo}, {hi}]"),
        );
    }
    if v.participants < 2 {
        c.err(
            &format!("{at}.participants"),
            format!(
                "must be at least 2 (a 95% interval needs two), got {}",
                v.participants
            ),
        );
    }
    c.at_most(
        &format!("{at}.participants"),
        "the replay's participants",
        u64::from(v.participants),
        MAX_PARTICIPANTS,
    );
    if let Err(why) = steps(&v.statistic.values) {
        c.err(&format!("{at}.statistic.values"), why);
    }
    if let Some(Err(why)) = v.statistic.over.as_deref().map(steps) {
        c.err(&format!("{at}.statistic.over"), why);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_path_splits_into_keys_and_filters() {
        let s = steps("fitts.regression[condition=baseline].participant_fits").unwrap();
        assert_eq!(s.len(), 3);
        assert_eq!(s[1].key, "regression");
        assert_eq!(s[1].filter, Some(("condition", "baseline")));
        assert_eq!(s[2].key, "participant_fits");
        let s = steps("discrimination.fits[level=2]").unwrap();
        assert_eq!(s[1].filter, Some(("level", "2")));
    }

    #[test]
    fn a_malformed_path_is_refused_with_its_reason() {
        assert!(steps("a..b").unwrap_err().contains("empty key"));
        assert!(steps("a[level]").unwrap_err().contains("[key=value]"));
        assert!(steps("a[level=1").unwrap_err().contains("without ']'"));
        assert!(steps("a[k=1]b").unwrap_err().contains("expected '.'"));
        assert!(steps("").is_err());
    }
}
