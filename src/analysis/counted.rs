//! The statistics power planning counts ([`crate::power`]): each kind's
//! analysis entry names its own ([`super::AnalysisEntry::counted`]), read
//! from its object of `summary.json`.

use std::collections::BTreeMap;

use serde_json::Value;

/// The counted statistics of one analysis: tests by their p values, and
/// intervals by their widths, each named `<kind>.<path in the kind's
/// summary object>`.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Counted {
    /// p values by test (`None`: n/a).
    pub p: BTreeMap<String, Option<f64>>,
    /// CI widths by statistic (`None`: n/a).
    pub ci_width: BTreeMap<String, Option<f64>>,
}

/// A kind's counted statistics, as its analysis entry names them: the
/// kind's summary object in, each test or interval out.
pub type CountStatistics = fn(summary: &Value, out: &mut KindCounted<'_>);

/// What one kind adds to a [`Counted`], its names under the kind's.
#[derive(Debug)]
pub struct KindCounted<'a> {
    kind: &'a str,
    out: &'a mut Counted,
}

impl<'a> KindCounted<'a> {
    /// The statistics of `kind`, into `out`.
    pub fn new(kind: &'a str, out: &'a mut Counted) -> Self {
        KindCounted { kind, out }
    }

    /// A test: its p value at `v` (a number, or n/a).
    pub fn test(&mut self, name: &str, v: &Value) {
        self.out
            .p
            .insert(format!("{}.{name}", self.kind), v.as_f64());
    }

    /// An interval: its width, from `ci` (`[low, high]`, or n/a).
    pub fn interval(&mut self, name: &str, ci: &Value) {
        let width = ci[1].as_f64().zip(ci[0].as_f64()).map(|(hi, lo)| hi - lo);
        self.out
            .ci_width
            .insert(format!("{}.{name}", self.kind), width);
    }
}

/// A condition's key in a statistic's name: its value, or `all` when the
/// summary pools it (null).
#[must_use]
pub fn key(v: &Value) -> String {
    if v.is_null() {
        "all".to_owned()
    } else {
        v.to_string()
    }
}
