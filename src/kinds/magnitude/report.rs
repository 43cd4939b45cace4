//! The magnitude-estimation section of the report.

use std::fmt::Write as _;

use super::analysis::{GeoMean, Magnitude};
use super::scaling::ScalingResult;
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
                let x = if against == "mu_s" {
                    |g: &GeoMean| g.mu_s
                } else {
                    |g: &GeoMean| g.mu_k
                };
                let series: Vec<(String, Vec<(f64, f64)>)> =
                    delta_mu_series(&m.means, d, norm, x)
                        .into_iter()
                        .map(|(name, gs)| (name, gs.iter().map(|g| (x(g), g.value)).collect()))
                        .collect();
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

/// The geometric means of `display` under `normalization`, one series per
/// delta_mu (named `delta_mu <value>`, in the order they come), each
/// sorted by `x` (mu_s or mu_k): what the report's charts and the
/// window's figures draw.
#[must_use]
pub fn delta_mu_series<'a>(
    means: &'a [GeoMean],
    display: &str,
    normalization: &str,
    x: fn(&GeoMean) -> f64,
) -> Vec<(String, Vec<&'a GeoMean>)> {
    let mut series: Vec<(String, Vec<&GeoMean>)> = Vec::new();
    for g in means
        .iter()
        .filter(|g| g.display == display && g.normalization == normalization)
    {
        let name = format!("delta_mu {}", g.delta_mu);
        match series.iter_mut().find(|(n, _)| *n == name) {
            Some((_, gs)) => gs.push(g),
            None => series.push((name, vec![g])),
        }
    }
    for (_, gs) in &mut series {
        gs.sort_by(|a, b| x(a).total_cmp(&x(b)));
    }
    series
}

impl Magnitude {
    /// The tables (geometric means, correlations, trends).
    #[must_use]
    pub fn tables_ref(&self) -> &[Table] {
        &self.tables
    }
}

/// The section of the generic form: each scaling's exponent, its means on
/// log-log axes, and the tables.
#[must_use]
pub fn scaling_section(results: &[ScalingResult], tables: &[Table]) -> String {
    let mut s = String::from("<h2>Magnitude estimation: power laws</h2>");
    let mut charts = String::from("<div class=\"figs\">");
    for r in results {
        let exponent = r.exponent.map_or("n/a (fewer than two participants)".into(), |(m, lo, hi)| {
            format!("<b>{}</b> (95% CI {} to {})", fmt(m), fmt(lo), fmt(hi))
        });
        let _ = write!(
            s,
            "<p>{} ({}): Stevens exponent, mean of {} participants' slopes of ln(answer) on ln(level): {exponent}; slope of the geometric means: {}.</p>",
            esc(&r.display),
            esc(&r.parameter),
            r.exponents.len(),
            r.exponent_of_means.map_or("n/a".into(), |(b, r2)| format!("{} (r^2 {})", fmt(b), fmt(r2)))
        );
        let points: Vec<(f64, f64)> = r.means.iter().map(|m| (m.level.ln(), m.value.ln())).collect();
        charts.push_str(&line_chart(
            &format!("{}: ln geometric mean vs ln {}", r.display, r.parameter),
            &format!("ln {}", r.parameter),
            "ln geometric mean (equalized)",
            &[(r.display.clone(), points)],
            &[],
        ));
    }
    charts.push_str("</div>");
    s.push_str(&charts);
    for t in tables {
        s.push_str(&table_html(t));
    }
    s
}
