//! Fitts targeting's results in the window: each condition's regression
//! of movement time on ID (its line over the IDs tested), the quadrant
//! counts of each condition against baseline (all IDs pooled, as the
//! report's quadrant chart), and each regression, throughput and quadrant
//! count in a sentence.

use eframe::egui;
use egui_plot::{Bar, BarChart, Corner, Line, PlotPoints};
use serde_json::Value;

use crate::kinds::figures::{self, At, Missing, ResultsView, fixed, p_value, ScreenView};

/// The quadrants, as `summary.json` names them, and as the figure says
/// them (ties, last, are counted in the sentences, not drawn).
const QUADRANTS: [(&str, &str); 5] = [
    ("slower_less_accurate", "slower,\nless accurate"),
    ("faster_less_accurate", "faster,\nless accurate"),
    ("faster_more_accurate", "faster,\nmore accurate"),
    ("slower_more_accurate", "slower,\nmore accurate"),
    ("ties", "ties"),
];

/// The quadrants the figure draws: the seed's four.
const DRAWN: usize = 4;

/// One condition's regression.
struct Regression {
    condition: String,
    intercept_s: Option<f64>,
    slope_s_per_bit: Option<f64>,
    r2: Option<f64>,
    n: u64,
}

fn regressions(summary: &At<'_>) -> Result<Vec<Regression>, Missing> {
    summary
        .get("regression")
        .items()?
        .iter()
        .map(|r| {
            Ok(Regression {
                condition: r.get("condition").text()?.to_owned(),
                intercept_s: r.get("intercept_s").num()?,
                slope_s_per_bit: r.get("slope_s_per_bit").num()?,
                r2: r.get("r2").num()?,
                n: r.get("n").count()?,
            })
        })
        .collect()
}

/// One condition's counts against baseline, all IDs pooled (the report's
/// quadrant chart: `id_bits` null).
struct Pooled {
    condition: String,
    counts: [u64; 5],
    time_p: Option<f64>,
    accuracy_p: Option<f64>,
}

fn pooled(summary: &At<'_>) -> Result<Vec<Pooled>, Missing> {
    let mut out = Vec::new();
    for q in summary.get("quadrants").items()? {
        if q.get("id_bits").num()?.is_some() {
            continue;
        }
        let mut counts = [0; 5];
        for (c, (key, _)) in counts.iter_mut().zip(QUADRANTS) {
            *c = q.get(key).count()?;
        }
        out.push(Pooled {
            condition: q.get("condition").text()?.to_owned(),
            counts,
            time_p: q.get("time_sign_p").num()?,
            accuracy_p: q.get("accuracy_sign_p").num()?,
        });
    }
    Ok(out)
}

/// The IDs tested, from the per-ID quadrant entries (bits, ascending).
fn ids(summary: &At<'_>) -> Result<Vec<f64>, Missing> {
    let mut ids = Vec::new();
    for q in summary.get("quadrants").items()? {
        if let Some(id) = q.get("id_bits").num()? {
            ids.push(id);
        }
    }
    ids.sort_by(f64::total_cmp);
    ids.dedup();
    Ok(ids)
}

/// The key statistics, a sentence each: each condition's regression and
/// throughput, then each condition's quadrant counts against baseline.
#[must_use]
pub fn sentences(summary: &At<'_>) -> Vec<Result<String, Missing>> {
    let mut out = Vec::new();
    match regressions(summary) {
        Ok(rs) if rs.is_empty() => out.push(
            summary
                .get("tests")
                .count()
                .map(|n| format!("No condition to regress: {n} tests analysed.")),
        ),
        Ok(rs) => out.extend(rs.iter().map(|r| {
            let tp = summary
                .get("throughput_bits_per_s")
                .get(&r.condition)
                .num()?;
            let fit = match (r.intercept_s, r.slope_s_per_bit) {
                (Some(a), Some(b)) => format!(
                    "MT = {a:.3} s + {b:.3} s/bit × ID, r² = {}",
                    fixed(r.r2, 2)
                ),
                _ => "regression n/a (fewer than two distinct IDs)".to_owned(),
            };
            Ok(format!(
                "{}: {fit} (n = {} tests); throughput {} bits/s.",
                r.condition,
                r.n,
                fixed(tp, 2),
            ))
        })),
        Err(e) => out.push(Err(e)),
    }
    match pooled(summary) {
        Ok(qs) => out.extend(qs.iter().map(|q| {
            let [sl, fl, fm, sm, ties] = q.counts;
            Ok(format!(
                "{} against baseline, all IDs: of {} participants, {sl} slower and less accurate, {fl} faster and less accurate, {fm} faster and more accurate, {sm} slower and more accurate, {ties} tied; sign tests: time {}, accuracy {}.",
                q.condition,
                q.counts.iter().sum::<u64>(),
                p_value(q.time_p),
                p_value(q.accuracy_p),
            ))
        })),
        Err(e) => out.push(Err(e)),
    }
    out
}

/// The regression lines over the IDs tested; nothing when no condition
/// has one (its sentence says n/a).
fn regression_figure(ui: &mut egui::Ui, rs: &[Regression], ids: &[f64]) {
    if rs
        .iter()
        .all(|r| r.intercept_s.is_none() || r.slope_s_per_bit.is_none())
    {
        return;
    }
    // The IDs are listed only with the per-ID quadrant entries.
    let (x0, x1) = if let (Some(&a), Some(&b)) = (ids.first(), ids.last()) {
        (a, b)
    } else {
        figures::problem(
            ui,
            "summary.json lists the IDs tested only with the quadrants (baseline and another condition): the lines run from 0 to 6 bits.",
        );
        (0.0, 6.0)
    };
    figures::title(ui, "Movement time against ID (OLS line per condition)");
    figures::legend(
figures::figure(
        "fitts-regression",
        "index of difficulty, ID (bits)",
        "movement time per movement, MT (s)",
    ), Corner::LeftTop)
    .show(ui, |plot| {
        for (i, r) in rs.iter().enumerate() {
            let (Some(a), Some(b)) = (r.intercept_s, r.slope_s_per_bit) else {
                continue;
            };
            let line = vec![[x0, a + b * x0], [x1, a + b * x1]];
            plot.line(
                Line::new(r.condition.clone(), PlotPoints::from(line))
                    .color(figures::colour(i))
                    .width(2.0),
            );
        }
    });
}

/// The pooled quadrant counts, one bar per condition in each quadrant,
/// coloured as in the regression figure.
fn quadrant_figure(ui: &mut egui::Ui, qs: &[Pooled], rs: &[Regression]) {
    figures::title(
        ui,
        "Participants by change in time and accuracy against own baseline (all IDs)",
    );
    let names = QUADRANTS[..DRAWN]
        .iter()
        .map(|(_, s)| (*s).to_owned())
        .collect();
    #[expect(clippy::cast_precision_loss, reason = "a few conditions")]
    let width = 0.8 / qs.len().max(1) as f64;
    figures::categories(
        figures::legend(
figures::figure(
            "fitts-quadrants",
            "",
            "participants",
        ), Corner::RightTop),
        names,
    )
    .include_y(0.0)
    // Room above the bars for the legend.
    .include_y(
        1.5 * qs
            .iter()
            .flat_map(|q| q.counts[..DRAWN].iter())
            .map(|&n| n as f64)
            .fold(1.0, f64::max),
    )
    .show(ui, |plot| {
        for (j, q) in qs.iter().enumerate() {
            let colour = figures::colour(
                rs.iter()
                    .position(|r| r.condition == q.condition)
                    .unwrap_or(j + 1),
            );
            #[expect(clippy::cast_precision_loss, reason = "counts and positions")]
            let bars: Vec<Bar> = q.counts[..DRAWN]
                .iter()
                .enumerate()
                .map(|(k, &n)| {
                    let x = k as f64 - 0.4 + width * (j as f64 + 0.5);
                    Bar::new(x, n as f64).width(width * 0.9).fill(colour)
                })
                .collect();
            plot.bar_chart(BarChart::new(q.condition.clone(), bars).color(colour));
        }
    });
}

/// The kind's results view ([`show`]).
pub const VIEW: Option<ResultsView> = Some(show);

/// No screen of its own: its trials show the shared screens.
pub const SCREEN: Option<ScreenView> = None;

/// The view: the sentences, then the regression and quadrant figures.
pub fn show(ui: &mut egui::Ui, summary: &Value) {
    figures::view(ui, summary, "fitts", sentences, |ui, at| {
        let (rs, qs, ids) = (regressions(at)?, pooled(at)?, ids(at)?);
        ui.horizontal_wrapped(|ui| {
            ui.vertical(|ui| regression_figure(ui, &rs, &ids));
            if !qs.is_empty() {
                ui.vertical(|ui| quadrant_figure(ui, &qs, &rs));
            }
        });
        Ok(())
    });
}
