//! Discrimination's results in the window: the fitted psychometric
//! functions of the first tracks (as the report's figure, by its
//! [`curve`]) with each threshold and its 95% interval at the criterion;
//! the Weber fractions against the reference level (each participant's,
//! and their mean with its 95% interval); the fit's terms and each level's
//! Weber fraction in a sentence each.

use eframe::egui;
use egui_plot::{Corner, Line, PlotPoints, Points};
use frictionlab_psychophysics::psychometric::{Params, Shape};
use serde_json::Value;

use super::report::{TRACKS_SHOWN, curve};
use crate::kinds::figures::{self, Along, At, Missing, ResultsView, ci, fixed, ScreenView};
use crate::protocol::form::unit;

/// The unit of the parameter `design.parameter` names (a path such as
/// `static_friction.mu_s`), as an axis label says it.
fn units(parameter: &str) -> String {
    let field = parameter.rsplit('.').next().unwrap_or(parameter);
    unit(field).map_or_else(|| "no unit".to_owned(), str::to_owned)
}

/// The fit's terms in a sentence.
fn method(summary: &At<'_>) -> Result<String, Missing> {
    Ok(format!(
        "Threshold at {}% correct (two intervals, guess rate {}, lapse rate fitted within [0, {}]), {} functions, {} fits of {}, 95% parametric-bootstrap intervals ({} samples).",
        fixed(Some(summary.get("criterion").required()? * 100.0), 1),
        summary.get("guess").required()?,
        summary.get("max_lapse").required()?,
        summary.get("shape").text()?,
        summary.get("fits").items()?.len(),
        summary.get("parameter").text()?,
        summary.get("bootstrap").count()?,
    ))
}

/// One level's Weber fraction in a sentence.
fn level(l: &At<'_>, parameter: &str, units: &str) -> Result<String, Missing> {
    let n = l.get("participants").count()?;
    let jnd = match units {
        "no unit" => fixed(l.get("jnd_mean").num()?, 4),
        u => format!("{} {u}", fixed(l.get("jnd_mean").num()?, 4)),
    };
    Ok(format!(
        "Reference {parameter} = {}: Weber fraction {}, {} (mean of {n} participants; SD {}, median {}); mean JND {jnd}.",
        l.get("level").required()?,
        fixed(l.get("weber_mean").num()?, 3),
        ci(l.get("weber_mean_ci").pair()?, 3),
        fixed(l.get("weber_sd").num()?, 3),
        fixed(l.get("weber_median").num()?, 3),
    ))
}

/// The key statistics, a sentence each: the fit's terms, then each
/// reference level's Weber fraction.
#[must_use]
pub fn sentences(summary: &At<'_>) -> Vec<Result<String, Missing>> {
    let mut out = vec![method(summary)];
    let parameter = match summary.get("parameter").text() {
        Ok(p) => p,
        Err(e) => {
            out.push(Err(e));
            return out;
        }
    };
    match summary.get("levels").items() {
        Ok(levels) => out.extend(
            levels
                .iter()
                .map(|l| level(l, parameter, &units(parameter))),
        ),
        Err(e) => out.push(Err(e)),
    }
    out
}

/// One track's fit as the figures need it.
struct Track {
    name: String,
    level: f64,
    params: Option<Params>,
    threshold: Option<f64>,
    threshold_ci: Option<(f64, f64)>,
    weber: Option<f64>,
}

fn tracks(summary: &At<'_>) -> Result<Vec<Track>, Missing> {
    summary
        .get("fits")
        .items()?
        .iter()
        .map(|f| {
            let level = f.get("level").required()?;
            let params = match (
                f.get("location").num()?,
                f.get("slope").num()?,
                f.get("lapse").num()?,
            ) {
                (Some(threshold), Some(slope), Some(lapse)) => Some(Params {
                    threshold,
                    slope,
                    lapse,
                }),
                _ => None,
            };
            Ok(Track {
                // The report's legend names a track so.
                name: format!(
                    "{} @ {}",
                    f.get("participant").text()?,
                    crate::analysis::report::fmt(level)
                ),
                level,
                params,
                threshold: f.get("threshold").num()?,
                threshold_ci: f.get("threshold_ci").pair()?,
                weber: f.get("weber").num()?,
            })
        })
        .collect()
}

/// The first tracks' fitted functions, with each threshold and its
/// interval at the criterion.
fn functions_figure(ui: &mut egui::Ui, summary: &At<'_>, tracks: &[Track]) -> Result<(), Missing> {
    let shape: Shape = serde_json::from_value(Value::String(
        summary.get("shape").text()?.to_owned(),
    ))
    .map_err(|e| format!("summary.json: discrimination.shape: {e}"))?;
    let criterion = summary.get("criterion").required()?;
    let parameter = summary.get("parameter").text()?;
    let x_label = match summary.get("comparison").text()? {
        "ratio" => format!("difference of {parameter} (fraction of the reference)"),
        _ => format!("difference of {parameter} ({})", units(parameter)),
    };
    let shown = &tracks[..tracks.len().min(TRACKS_SHOWN)];
    // The summary holds no differences tested: the view runs from 0 to
    // twice the largest threshold shown (an interval may run beyond it).
    let largest = |of: &dyn Fn(&Track) -> Option<f64>| {
        shown
            .iter()
            .filter_map(of)
            .filter(|x| x.is_finite())
            .fold(0.0_f64, f64::max)
    };
    let top = match largest(&|t| t.threshold) {
        t if t > 0.0 => 2.0 * t,
        _ => match largest(&|t| t.threshold_ci.map(|c| c.1)) {
            t if t > 0.0 => 1.2 * t,
            _ => 1.0,
        },
    };
    let range = (0.0, top);
    figures::title(
        ui,
        &format!(
            "Fitted functions (first {} tracks), thresholds with 95% CIs",
            shown.len()
        ),
    );
    figures::legend(
figures::figure("discrimination-functions", &x_label, "proportion correct"), Corner::RightBottom)
        .default_x_bounds(range.0, range.1)
        .include_y(0.45)
        .include_y(1.02)
        .show(ui, |plot| {
            for (i, t) in shown.iter().enumerate() {
                let colour = figures::colour(i);
                if let Some(params) = t.params {
                    let pts: Vec<[f64; 2]> = curve(shape, params, range)
                        .into_iter()
                        .map(|(x, p)| [x, p])
                        .collect();
                    plot.line(
                        Line::new(t.name.clone(), PlotPoints::from(pts))
                            .color(colour)
                            .width(2.0),
                    );
                }
                if let Some(x) = t.threshold {
                    plot.points(
                        Points::new(t.name.clone(), PlotPoints::from(vec![[x, criterion]]))
                            .color(colour)
                            .radius(4.0)
                            .filled(true),
                    );
                }
                if let Some((lo, hi)) = t.threshold_ci {
                    figures::interval(
                        plot,
                        &t.name,
                        Along::X,
                        (criterion, lo, hi),
                        0.02,
                        colour,
                    );
                }
            }
        });
    Ok(())
}

/// The Weber fractions against the reference level: each participant's,
/// and each level's mean with its interval.
fn weber_figure(ui: &mut egui::Ui, summary: &At<'_>, tracks: &[Track]) -> Result<(), Missing> {
    let parameter = summary.get("parameter").text()?;
    let means = summary
        .get("levels")
        .items()?
        .iter()
        .map(|l| {
            Ok((
                l.get("level").required()?,
                l.get("weber_mean").num()?,
                l.get("weber_mean_ci").pair()?,
            ))
        })
        .collect::<Result<Vec<_>, Missing>>()?;
    let each: Vec<[f64; 2]> = tracks
        .iter()
        .filter_map(|t| Some([t.level, t.weber?]))
        .collect();
    let cap = figures::cap_width(means.iter().map(|m| m.0));
    figures::title(ui, "Weber fraction against the reference level, 95% CIs");
    figures::legend(
figures::figure(
        "discrimination-weber",
        &format!("reference {parameter} ({})", units(parameter)),
        "Weber fraction (no unit)",
    ), Corner::LeftTop)
    .include_y(0.0)
    .show(ui, |plot| {
        plot.points(
            Points::new("each participant", PlotPoints::from(each))
                .color(figures::colour(0))
                .radius(3.0)
                .filled(true),
        );
        let mean_colour = figures::colour(3);
        let line: Vec<[f64; 2]> = means
            .iter()
            .filter_map(|m| Some([m.0, m.1?]))
            .collect();
        plot.line(
            Line::new("mean", PlotPoints::from(line.clone()))
                .color(mean_colour)
                .width(2.0),
        );
        plot.points(
            Points::new("mean", PlotPoints::from(line))
                .color(mean_colour)
                .radius(4.5)
                .filled(true),
        );
        for (level, _, interval) in &means {
            if let Some((lo, hi)) = interval {
                figures::interval(
                    plot,
                    "mean",
                    Along::Y,
                    (*level, *lo, *hi),
                    cap,
                    mean_colour,
                );
            }
        }
    });
    Ok(())
}

/// The kind's results view ([`show`]).
pub const VIEW: Option<ResultsView> = Some(show);

/// No screen of its own: its trials show the shared screens.
pub const SCREEN: Option<ScreenView> = None;

/// The view: the sentences, then the functions and the Weber fractions.
pub fn show(ui: &mut egui::Ui, summary: &Value) {
    figures::view(ui, summary, "discrimination", sentences, |ui, at| {
        let tracks = tracks(at)?;
        ui.horizontal_wrapped(|ui| {
            let functions = ui.vertical(|ui| functions_figure(ui, at, &tracks)).inner;
            let weber = ui.vertical(|ui| weber_figure(ui, at, &tracks)).inner;
            functions.and(weber)
        })
        .inner
    });
}
