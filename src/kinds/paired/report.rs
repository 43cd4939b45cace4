//! The paired-comparison section of the report.

use std::fmt::Write as _;

use super::analysis::Paired;
use crate::analysis::report::{bar_chart, fmt, table_html};

/// The paired-comparison section.
#[must_use]
pub fn paired_section(p: &Paired) -> String {
    let mut s = String::from("<h2>Paired comparison (seed 000)</h2>");
    let _ = write!(
        s,
        "<p>Two-sided exact binomial test on decisive answers: p = <b>{}</b>. Presentation order: first chosen {}, second chosen {} (p = {}).</p>",
        p.summary["binomial_p"].as_f64().map_or("n/a".into(), fmt),
        p.summary["order"]["first_chosen"],
        p.summary["order"]["second_chosen"],
        p.summary["order"]["binomial_p"]
            .as_f64()
            .map_or("n/a".into(), fmt),
    );
    s.push_str(&bar_chart(
        "Which rendering is nearer to the real surface",
        &p.counts,
    ));
    for t in &p.tables {
        s.push_str(&table_html(t));
    }
    s
}
