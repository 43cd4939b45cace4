//! The Fitts section of the report.

use super::analysis::Fitts;
use crate::analysis::report::{line_chart, quadrant_chart, table_html};

/// The Fitts section.
#[must_use]
pub fn fitts_section(f: &Fitts) -> String {
    let mut s = String::from("<h2>Fitts targeting (seed 002)</h2><div class=\"figs\">");
    let pooled: Vec<(String, Vec<(f64, f64)>)> = f
        .quadrants
        .iter()
        .filter(|q| q.id_bits.is_none())
        .map(|q| (q.condition.clone(), q.points.clone()))
        .collect();
    if !pooled.is_empty() {
        // Colours match the MT chart, where baseline is the first series.
        s.push_str(&quadrant_chart(
            "Each participant against own baseline (all IDs)",
            (
                "change in completion time vs baseline (s)",
                "change in mean error magnitude vs baseline (m)",
            ),
            &pooled,
            1,
        ));
    }
    let series: Vec<(String, Vec<(f64, f64)>)> = f
        .mt_by_id
        .iter()
        .map(|(c, pts, _)| (c.clone(), pts.clone()))
        .collect();
    let fits: Vec<(f64, f64, f64, f64)> = f
        .mt_by_id
        .iter()
        .map(|(_, pts, fit)| {
            let (x0, x1) = pts
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| {
                    (a.min(p.0), b.max(p.0))
                });
            fit.map_or((0.0, 0.0, 0.0, 0.0), |f| {
                (
                    x0,
                    f.intercept + f.slope * x0,
                    x1,
                    f.intercept + f.slope * x1,
                )
            })
        })
        .collect();
    s.push_str(&line_chart(
        "Movement time against ID (means, OLS lines)",
        "ID (bits)",
        "MT per movement (s)",
        &series,
        &fits,
    ));
    s.push_str("</div>");
    for t in f.tables.iter().skip(1).chain(f.tables.first()) {
        s.push_str(&table_html(t));
    }
    s
}
