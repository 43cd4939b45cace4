//! The human report: one self-contained HTML page with tables and inline SVG
//! figures (plotters): seed 001's perceived friction against mu_s and mu_k,
//! seed 000's choice counts, seed 002's quadrant scatter and MT-against-ID
//! lines.

use std::fmt::Write as _;

use plotters::prelude::*;
use serde_json::Value;

use super::Table;
use super::discrimination::Discrimination;
use super::fitts::Fitts;
use super::magnitude::Magnitude;
use super::paired::Paired;

pub(crate) fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

pub(crate) fn fmt(x: f64) -> String {
    if x == 0.0 || (1e-3..1e6).contains(&x.abs()) {
        format!("{x:.4}")
    } else {
        format!("{x:.4e}")
    }
}

/// A table as HTML.
#[must_use]
pub fn table_html(t: &Table) -> String {
    let mut s = format!("<table><caption>{}</caption><tr>", esc(&t.name));
    for c in &t.columns {
        let _ = write!(s, "<th>{}</th>", esc(c));
    }
    s.push_str("</tr>");
    for row in &t.rows {
        s.push_str("<tr>");
        for cell in row {
            let v = match cell {
                super::Cell::Text(x) => esc(x),
                super::Cell::Num(Some(x)) => fmt(*x),
                super::Cell::Num(None) => "n/a".into(),
            };
            let _ = write!(s, "<td>{v}</td>");
        }
        s.push_str("</tr>");
    }
    s.push_str("</table>");
    s
}

fn range(values: impl Iterator<Item = f64>, include_zero: bool) -> std::ops::Range<f64> {
    let (mut lo, mut hi) = values
        .filter(|v| v.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
            (a.min(v), b.max(v))
        });
    if include_zero {
        lo = lo.min(0.0);
        hi = hi.max(0.0);
    }
    if !lo.is_finite() || !hi.is_finite() {
        return 0.0..1.0;
    }
    if hi - lo < 1e-12 {
        return (lo - 1.0)..(hi + 1.0);
    }
    let pad = 0.08 * (hi - lo);
    (lo - pad)..(hi + pad)
}

/// A line chart: one line (with points) per series, and straight lines
/// `fits` (x0, y0, x1, y1).
pub(crate) fn line_chart(
    title: &str,
    x_label: &str,
    y_label: &str,
    series: &[(String, Vec<(f64, f64)>)],
    fits: &[(f64, f64, f64, f64)],
) -> String {
    let ys = range(series.iter().flat_map(|s| s.1.iter().map(|p| p.1)), false);
    line_chart_in(title, x_label, y_label, series, fits, ys)
}

/// [`line_chart`] over the y range `ys`.
pub(crate) fn line_chart_in(
    title: &str,
    x_label: &str,
    y_label: &str,
    series: &[(String, Vec<(f64, f64)>)],
    fits: &[(f64, f64, f64, f64)],
    ys: std::ops::Range<f64>,
) -> String {
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (460, 320)).into_drawing_area();
        let _ = root.fill(&WHITE);
        let xs = range(series.iter().flat_map(|s| s.1.iter().map(|p| p.0)), false);
        let Ok(mut chart) = ChartBuilder::on(&root)
            .caption(title, ("sans-serif", 15))
            .margin(8)
            .x_label_area_size(34)
            .y_label_area_size(52)
            .build_cartesian_2d(xs, ys)
        else {
            return svg_fallback(title);
        };
        let _ = chart
            .configure_mesh()
            .x_desc(x_label)
            .y_desc(y_label)
            .light_line_style(WHITE)
            .draw();
        for (i, (name, pts)) in series.iter().enumerate() {
            let color = Palette99::pick(i).to_rgba();
            if let Ok(s) =
                chart.draw_series(LineSeries::new(pts.iter().copied(), color.stroke_width(2)))
            {
                s.label(name.clone()).legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 16, y)], color.stroke_width(2))
                });
            }
            let _ = chart.draw_series(pts.iter().map(|&p| Circle::new(p, 3, color.filled())));
        }
        for (i, &(x0, y0, x1, y1)) in fits.iter().enumerate() {
            let color = Palette99::pick(i).to_rgba();
            let _ = chart.draw_series(LineSeries::new([(x0, y0), (x1, y1)], color.stroke_width(1)));
        }
        let _ = chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperLeft)
            .border_style(BLACK)
            .background_style(WHITE.mix(0.85))
            .draw();
        let _ = root.present();
    }
    svg
}

/// A scatter of (time change, error change) per series, with axes at zero;
/// series `i` is drawn in palette colour `first_colour + i`.
fn quadrant_chart(
    title: &str,
    series: &[(String, Vec<(f64, f64)>)],
    first_colour: usize,
) -> String {
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (460, 360)).into_drawing_area();
        let _ = root.fill(&WHITE);
        let xs = range(series.iter().flat_map(|s| s.1.iter().map(|p| p.0)), true);
        let ys = range(series.iter().flat_map(|s| s.1.iter().map(|p| p.1)), true);
        let Ok(mut chart) = ChartBuilder::on(&root)
            .caption(title, ("sans-serif", 15))
            .margin(8)
            .x_label_area_size(34)
            .y_label_area_size(52)
            .build_cartesian_2d(xs.clone(), ys.clone())
        else {
            return svg_fallback(title);
        };
        let _ = chart
            .configure_mesh()
            .x_desc("change in completion time vs baseline (s)")
            .y_desc("change in mean error magnitude vs baseline (m)")
            .light_line_style(WHITE)
            .draw();
        let _ = chart.draw_series(LineSeries::new(
            [(xs.start, 0.0), (xs.end, 0.0)],
            BLACK.stroke_width(1),
        ));
        let _ = chart.draw_series(LineSeries::new(
            [(0.0, ys.start), (0.0, ys.end)],
            BLACK.stroke_width(1),
        ));
        for (i, (name, pts)) in series.iter().enumerate() {
            let color = Palette99::pick(first_colour + i).to_rgba();
            if let Ok(s) = chart.draw_series(pts.iter().map(|&p| Circle::new(p, 4, color.filled())))
            {
                s.label(name.clone())
                    .legend(move |(x, y)| Circle::new((x + 8, y), 4, color.filled()));
            }
        }
        let _ = chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperLeft)
            .border_style(BLACK)
            .background_style(WHITE.mix(0.85))
            .draw();
        let _ = root.present();
    }
    svg
}

/// A bar chart of counts.
fn bar_chart(title: &str, items: &[(String, u64)]) -> String {
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (460, 300)).into_drawing_area();
        let _ = root.fill(&WHITE);
        let top = items.iter().map(|i| i.1).max().unwrap_or(1).max(1);
        let labels: Vec<String> = items.iter().map(|i| i.0.clone()).collect();
        let Ok(mut chart) = ChartBuilder::on(&root)
            .caption(title, ("sans-serif", 15))
            .margin(8)
            .x_label_area_size(34)
            .y_label_area_size(40)
            .build_cartesian_2d(0.0..items.len().max(1) as f64, 0.0..(top as f64 * 1.15))
        else {
            return svg_fallback(title);
        };
        let _ = chart
            .configure_mesh()
            .disable_x_mesh()
            .x_labels(0)
            .y_desc("participants")
            .draw();
        let _ = chart.draw_series(items.iter().enumerate().map(|(i, (_, n))| {
            let x = i as f64;
            Rectangle::new(
                [(x + 0.15, 0.0), (x + 0.85, *n as f64)],
                Palette99::pick(i).filled(),
            )
        }));
        let style = ("sans-serif", 13).into_font().color(&BLACK);
        let _ = chart.draw_series(labels.iter().zip(items).enumerate().map(
            |(i, (label, (_, n)))| {
                Text::new(
                    format!("{label}: {n}"),
                    (i as f64 + 0.2, *n as f64 + top as f64 * 0.04),
                    style.clone(),
                )
            },
        ));
        let _ = root.present();
    }
    svg
}

fn svg_fallback(title: &str) -> String {
    format!("<p>(figure '{}' could not be drawn)</p>", esc(title))
}

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

/// Points (`scatter`, markers) and lines (`curves`) on shared axes; the
/// `i`th of each in palette colour `i`.
fn scatter_curves(
    title: &str,
    labels: (&str, &str),
    scatter: &[(String, Vec<(f64, f64)>)],
    curves: &[(String, Vec<(f64, f64)>)],
) -> String {
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (460, 320)).into_drawing_area();
        let _ = root.fill(&WHITE);
        let all = || scatter.iter().chain(curves).flat_map(|s| s.1.iter());
        let xs = range(all().map(|p| p.0), false);
        let ys = range(all().map(|p| p.1), true);
        let Ok(mut chart) = ChartBuilder::on(&root)
            .caption(title, ("sans-serif", 15))
            .margin(8)
            .x_label_area_size(34)
            .y_label_area_size(52)
            .build_cartesian_2d(xs, ys)
        else {
            return svg_fallback(title);
        };
        let _ = chart
            .configure_mesh()
            .x_desc(labels.0)
            .y_desc(labels.1)
            .light_line_style(WHITE)
            .draw();
        for (i, (name, pts)) in curves.iter().enumerate() {
            let color = Palette99::pick(i).to_rgba();
            if let Ok(s) =
                chart.draw_series(LineSeries::new(pts.iter().copied(), color.stroke_width(2)))
                && !name.is_empty()
            {
                s.label(name.clone()).legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 16, y)], color.stroke_width(2))
                });
            }
        }
        for (i, (name, pts)) in scatter.iter().enumerate() {
            let color = Palette99::pick(i).to_rgba();
            if let Ok(s) = chart.draw_series(pts.iter().map(|&p| Circle::new(p, 3, color.filled())))
                && !name.is_empty()
                && curves.get(i).is_none_or(|c| c.0.is_empty())
            {
                s.label(name.clone())
                    .legend(move |(x, y)| Circle::new((x + 8, y), 3, color.filled()));
            }
        }
        let _ = chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperLeft)
            .border_style(BLACK)
            .background_style(WHITE.mix(0.85))
            .draw();
        let _ = root.present();
    }
    svg
}

/// A track's fitted function over its differences, 61 points.
fn fitted_curve(d: &Discrimination, t: &super::discrimination::TrackFit) -> Vec<(f64, f64)> {
    let (lo, hi) = t.blocks.iter().fold((f64::INFINITY, 0.0_f64), |(a, b), k| {
        (a.min(k.x), b.max(k.x))
    });
    t.fit.map_or_else(Vec::new, |f| {
        let psi = frictionlab_psychophysics::psychometric::Psychometric {
            shape: d.design.fit.shape,
            params: f.params,
            guess: frictionlab_psychophysics::psychometric::GUESS_2IFC,
        };
        (0..=60)
            .map(|k| {
                let x = lo + (hi - lo) * f64::from(k) / 60.0;
                (x, psi.p_correct(x))
            })
            .collect()
    })
}

/// Tracks shown in the track and fit figures (the first participants').
const TRACKS_SHOWN: usize = 6;

/// The discrimination section: each track's differences, the fitted
/// functions over the binned answers, and the Weber fraction against the
/// reference level.
#[must_use]
pub fn discrimination_section(d: &Discrimination) -> String {
    let mut s = format!(
        "<h2>Discrimination of {}</h2><p>Threshold at {}% correct (two intervals, guess rate 0.5, lapse rate fitted within [0, {}]), {} fits, 95% parametric-bootstrap intervals ({} samples).</p><div class=\"figs\">",
        esc(&d.design.parameter),
        fmt(d.design.criterion * 100.0),
        fmt(d.design.fit.max_lapse),
        d.tracks.len(),
        d.design.fit.bootstrap,
    );
    let shown: Vec<_> = d.tracks.iter().take(TRACKS_SHOWN).collect();
    let name =
        |t: &super::discrimination::TrackFit| format!("{} @ {}", t.participant, fmt(t.level));
    #[expect(clippy::cast_precision_loss, reason = "trial numbers")]
    let tracks: Vec<(String, Vec<(f64, f64)>)> = shown
        .iter()
        .map(|t| {
            (
                name(t),
                t.answers
                    .iter()
                    .enumerate()
                    .map(|(i, a)| ((i + 1) as f64, a.0))
                    .collect(),
            )
        })
        .collect();
    s.push_str(&line_chart(
        "Each track's difference, trial by trial",
        "trial of the track",
        "difference",
        &tracks,
        &[],
    ));
    let binned: Vec<(String, Vec<(f64, f64)>)> = shown
        .iter()
        .map(|t| {
            (
                String::new(),
                t.blocks
                    .iter()
                    .map(|b| (b.x, f64::from(b.correct) / f64::from(b.n.max(1))))
                    .collect(),
            )
        })
        .collect();
    let curves: Vec<(String, Vec<(f64, f64)>)> = shown
        .iter()
        .map(|t| (name(t), fitted_curve(d, t)))
        .collect();
    s.push_str(&scatter_curves(
        "Fitted functions over the answers at each difference",
        ("difference", "proportion correct"),
        &binned,
        &curves,
    ));
    let participants: Vec<(String, Vec<(f64, f64)>)> = vec![(
        "each participant".into(),
        d.tracks
            .iter()
            .filter_map(|t| t.weber.map(|w| (t.level, w)))
            .collect(),
    )];
    let means: Vec<(String, Vec<(f64, f64)>)> = vec![(
        "mean".into(),
        d.summary["levels"]
            .as_array()
            .map(|ls| {
                ls.iter()
                    .filter_map(|l| Some((l["level"].as_f64()?, l["weber_mean"].as_f64()?)))
                    .collect()
            })
            .unwrap_or_default(),
    )];
    s.push_str(&scatter_curves(
        "Weber fraction against the reference level",
        ("reference level", "Weber fraction"),
        &participants,
        &means,
    ));
    s.push_str("</div>");
    for t in &d.tables {
        s.push_str(&table_html(t));
    }
    s
}

/// The whole page.
#[must_use]
pub fn page(folder: &str, summary: &Value, sections: &[String], notes: &[String]) -> String {
    let mut s = String::from(
        "<!DOCTYPE html><html lang=\"en\"><head><meta charset=\"utf-8\"><title>frictionlab report</title><style>\
         body{font-family:sans-serif;margin:2em;max-width:1500px;color:#222}\
         table{border-collapse:collapse;margin:1em 0;font-size:13px}caption{text-align:left;font-weight:bold;padding:4px 0}\
         td,th{border:1px solid #bbb;padding:3px 7px;text-align:right}th{background:#eee}\
         .figs{display:flex;flex-wrap:wrap;gap:8px}.notes{color:#8a5300}</style></head><body>",
    );
    let _ = write!(
        s,
        "<h1>frictionlab analysis</h1><p>Results folder: <code>{}</code>. Analysed rows (completed, non-practice): <code>{}</code>. \
         frictionlab {}.</p>",
        esc(folder),
        esc(&summary["inputs"]["analysed_rows"].to_string()),
        env!("CARGO_PKG_VERSION")
    );
    if !notes.is_empty() {
        s.push_str("<ul class=\"notes\">");
        for n in notes {
            let _ = write!(s, "<li>{}</li>", esc(n));
        }
        s.push_str("</ul>");
    }
    for section in sections {
        s.push_str(section);
    }
    s.push_str("</body></html>\n");
    s
}
