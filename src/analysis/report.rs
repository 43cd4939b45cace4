//! The human report's building blocks: one self-contained HTML page
//! ([`page`]) of the kinds' sections, tables ([`table_html`]) and inline
//! SVG charts (plotters). Each kind writes its own section from these, in
//! its folder (`src/kinds/<kind>/report.rs`).

use std::fmt::Write as _;

use plotters::prelude::*;
use serde_json::Value;

use super::table::Table;

/// `s` escaped for HTML text and attributes.
#[must_use]
pub fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// A number for the report: four decimals, or four significant digits
/// with an exponent when very small or large.
#[must_use]
pub fn fmt(x: f64) -> String {
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

/// The axis range of `values` (finite ones), padded by 8%, with 0 in it
/// when `include_zero`.
pub fn range(values: impl Iterator<Item = f64>, include_zero: bool) -> std::ops::Range<f64> {
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
#[must_use]
pub fn line_chart(
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
#[must_use]
pub fn line_chart_in(
    title: &str,
    x_label: &str,
    y_label: &str,
    series: &[(String, Vec<(f64, f64)>)],
    fits: &[(f64, f64, f64, f64)],
    ys: std::ops::Range<f64>,
) -> String {
    let xs = range(series.iter().flat_map(|s| s.1.iter().map(|p| p.0)), false);
    xy_chart(title, 320, (x_label, y_label), (xs, ys), |chart| {
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
    })
}

/// An x-y chart's drawing area.
type XyChart<'a, 'b> = ChartContext<
    'a,
    SVGBackend<'b>,
    Cartesian2d<plotters::coord::types::RangedCoordf64, plotters::coord::types::RangedCoordf64>,
>;

/// The SVG of a chart 460 pixels wide and `height` high over `xs` x `ys`
/// (`ranges`), captioned `title`, its axes labelled `labels` (x, y), drawn
/// by `draw`, with the legend of its labelled series upper left.
fn xy_chart(
    title: &str,
    height: u32,
    labels: (&str, &str),
    (xs, ys): (std::ops::Range<f64>, std::ops::Range<f64>),
    draw: impl FnOnce(&mut XyChart<'_, '_>),
) -> String {
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (460, height)).into_drawing_area();
        let _ = root.fill(&WHITE);
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
        draw(&mut chart);
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

/// A scatter of points per series with the axes through zero (changes
/// against a baseline, by quadrant), axis labels `labels` (x, y); series
/// `i` is drawn in palette colour `first_colour + i`.
#[must_use]
pub fn quadrant_chart(
    title: &str,
    labels: (&str, &str),
    series: &[(String, Vec<(f64, f64)>)],
    first_colour: usize,
) -> String {
    let xs = range(series.iter().flat_map(|s| s.1.iter().map(|p| p.0)), true);
    let ys = range(series.iter().flat_map(|s| s.1.iter().map(|p| p.1)), true);
    xy_chart(title, 360, labels, (xs.clone(), ys.clone()), |chart| {
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
    })
}

/// A bar chart of counts.
#[must_use]
pub fn bar_chart(title: &str, items: &[(String, u64)]) -> String {
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

/// What stands in for a figure that could not be drawn.
#[must_use]
pub fn svg_fallback(title: &str) -> String {
    format!("<p>(figure '{}' could not be drawn)</p>", esc(title))
}

/// Points (`scatter`, markers) and lines (`curves`) on shared axes; the
/// `i`th of each in palette colour `i`.
#[must_use]
pub fn scatter_curves(
    title: &str,
    labels: (&str, &str),
    scatter: &[(String, Vec<(f64, f64)>)],
    curves: &[(String, Vec<(f64, f64)>)],
) -> String {
    let all = || scatter.iter().chain(curves).flat_map(|s| s.1.iter());
    let xs = range(all().map(|p| p.0), false);
    let ys = range(all().map(|p| p.1), true);
    xy_chart(title, 320, labels, (xs, ys), |chart| {
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
    })
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
