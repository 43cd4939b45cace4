//! The magnitude-estimation section of the report.

use std::fmt::Write as _;

use super::analysis::Magnitude;
use crate::analysis::Table;
use crate::analysis::report::{esc, fmt, line_chart, table_html};

/// The magnitude-estimation section.
#[must_use]
pub fn magnitude_section(m: &Magnitude) -> String {
    let mut s = String::from("<h2>Magnitude estimation (seed 001)</h2>");
    let ratio = m.summary["display_ratio"].as_f64();
    let _ = write!(
        s,
        "<p>Displays: {}. Display ratio (geometric mean of the first display's pooled values over the second's): <b>{}</b> (seed: about 1/7).</p>",
        esc(&m.displays.join(", ")),
        ratio.map_or("n/a".into(), fmt)
    );
    let effect = &m.summary["display_effect"];
    if let (Some(r), Some(p)) = (effect["ratio"].as_f64(), effect["p"].as_f64()) {
        let _ = write!(
            s,
            "<p>Display effect across participants (paired t test of each participant's first-over-second display mean log answer): ratio {} (95% CI {} to {}), t = {}, p = {}, n = {}.</p>",
            fmt(r),
            effect["ci_low"].as_f64().map_or("n/a".into(), fmt),
            effect["ci_high"].as_f64().map_or("n/a".into(), fmt),
            effect["t"].as_f64().map_or("n/a".into(), fmt),
            fmt(p),
            effect["n"]
        );
    }
    s.push_str("<div class=\"figs\">");
    for d in &m.displays {
        for norm in ["pooled", "per_display"] {
            for against in ["mu_s", "mu_k"] {
                let mut series: Vec<(String, Vec<(f64, f64)>)> = Vec::new();
                for g in m
                    .means
                    .iter()
                    .filter(|g| &g.display == d && g.normalization == norm)
                {
                    let name = format!("delta_mu {}", g.delta_mu);
                    let x = if against == "mu_s" { g.mu_s } else { g.mu_k };
                    match series.iter_mut().find(|(n, _)| *n == name) {
                        Some((_, pts)) => pts.push((x, g.value)),
                        None => series.push((name, vec![(x, g.value)])),
                    }
                }
                for (_, pts) in &mut series {
                    pts.sort_by(|a, b| a.0.total_cmp(&b.0));
                }
                let title = format!("{d}, {norm}: perceived friction vs {against}");
                s.push_str(&line_chart(&title, against, "geometric mean", &series, &[]));
            }
        }
    }
    s.push_str("</div>");
    for t in [1, 2, 0] {
        if let Some(t) = m.tables_ref().get(t) {
            s.push_str(&table_html(t));
        }
    }
    s
}

impl Magnitude {
    /// The tables (geometric means, correlations, trends).
    #[must_use]
    pub fn tables_ref(&self) -> &[Table] {
        &self.tables
    }
}
