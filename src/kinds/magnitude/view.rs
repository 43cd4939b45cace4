//! Magnitude estimation's results in the window: each display's
//! normalized geometric means against mu_s, one line per delta_mu series
//! with their 95% intervals (the report's charts, by
//! [`delta_mu_series`]); the display effect, the display ratio and the
//! displays' correlations in a sentence each; and for the generic form
//! each scaling's power law.

use eframe::egui;
use egui_plot::{Corner, Line, PlotPoints, Points};
use serde_json::Value;

use super::analysis::GeoMean;
use super::report::delta_mu_series;
use crate::kinds::figures::{self, Along, At, Missing, ResultsView, both, ci, fixed, p_value, ScreenView};
use crate::protocol::form::unit;

/// A geometric mean as `summary.json` lists it.
fn geo_mean(g: &At<'_>) -> Result<GeoMean, Missing> {
    let normalization = match g.get("normalization").text()? {
        "pooled" => "pooled",
        "per_display" => "per_display",
        other => return Err(format!("summary.json: unknown normalization '{other}'")),
    };
    Ok(GeoMean {
        display: g.get("display").text()?.to_owned(),
        mu_s: g.get("mu_s").required()?,
        mu_k: g.get("mu_k").required()?,
        delta_mu: g.get("delta_mu").required()?,
        normalization,
        value: g.get("value").required()?,
        gsd: g.get("gsd").num()?,
        ci_low: g.get("ci_low").num()?,
        ci_high: g.get("ci_high").num()?,
        n: usize::try_from(g.get("n").count()?).unwrap_or(usize::MAX),
    })
}

/// The displays, in the summary's (the protocol's) order.
fn displays(summary: &At<'_>) -> Result<Vec<String>, Missing> {
    summary
        .get("displays")
        .items()?
        .iter()
        .map(|d| d.text().map(str::to_owned))
        .collect()
}

/// The seed form's key statistics (display effect, display ratio,
/// correlations), a sentence each.
fn seed_sentences(summary: &At<'_>) -> Vec<Result<String, Missing>> {
    let names = || -> Result<(String, String), Missing> {
        let d = displays(summary)?;
        match d.as_slice() {
            [a, b] => Ok((a.clone(), b.clone())),
            _ => Err(format!(
                "Display effect, ratio and correlations n/a: {} display(s) ({}); two are needed.",
                d.len(),
                d.join(", ")
            )),
        }
    };
    let (first, second) = match names() {
        Ok(n) => n,
        Err(e) => return vec![Err(e)],
    };
    let effect = || -> Result<String, Missing> {
        let e = summary.get("display_effect");
        let n = e.get("n").count()?;
        let ratio = e.get("ratio").num()?;
        if ratio.is_none() {
            return Ok(format!(
                "Display effect, {first} over {second}: n/a ({n} participant(s) answered on both displays)."
            ));
        }
        Ok(format!(
            "Display effect, {first} over {second} (paired t test across participants): ratio {}, {}, t({}) = {}, {}.",
            fixed(ratio, 3),
            ci(both(e.get("ci_low").num()?, e.get("ci_high").num()?), 3),
            n.saturating_sub(1),
            fixed(e.get("t").num()?, 2),
            p_value(e.get("p").num()?),
        ))
    };
    let ratio = || -> Result<String, Missing> {
        Ok(format!(
            "Display ratio (geometric mean of {first}'s pooled values over {second}'s): {}.",
            fixed(summary.get("display_ratio").num()?, 3)
        ))
    };
    let mut out = vec![effect(), ratio()];
    match summary.get("correlations").items() {
        Ok(items) => out.extend(items.iter().map(|c| {
            Ok(format!(
                "delta_mu {}: {first} against {second} (per-display means): r = {}, {}, {} (n = {} stimuli).",
                c.get("delta_mu").required()?,
                fixed(c.get("r").num()?, 2),
                ci(both(c.get("ci95_low").num()?, c.get("ci95_high").num()?), 2),
                p_value(c.get("p").num()?),
                c.get("n").count()?,
            ))
        })),
        Err(e) => out.push(Err(e)),
    }
    out
}

/// A scaling's power law in a sentence.
fn scaling_sentence(s: &At<'_>) -> Result<String, Missing> {
    let n = s.get("n").count()?;
    let exponent = s.get("exponent").num()?;
    let of_means = s.get("exponent_of_means").num()?;
    Ok(format!(
        "{} ({}): Stevens exponent {}{} (mean of {n} participants' slopes of ln answer on ln level); slope of the geometric means {} (r² = {}).",
        s.get("display").text()?,
        s.get("parameter").text()?,
        fixed(exponent, 3),
        if exponent.is_some() {
            format!(", {}", ci(both(s.get("ci_low").num()?, s.get("ci_high").num()?), 3))
        } else {
            " (fewer than two participants)".to_owned()
        },
        fixed(of_means, 3),
        fixed(s.get("r2_of_means").num()?, 3),
    ))
}

/// The key statistics, a sentence each: the seed form's, then each
/// scaling's.
#[must_use]
pub fn sentences(summary: &At<'_>) -> Vec<Result<String, Missing>> {
    let (seed, scalings) = (
        summary.get("geometric_means").exists(),
        summary.get("scalings").exists(),
    );
    if !seed && !scalings {
        return vec![Err(
            "summary.json has neither magnitude_estimation.geometric_means nor magnitude_estimation.scalings".to_owned(),
        )];
    }
    let mut out = Vec::new();
    if seed {
        out.extend(seed_sentences(summary));
    }
    if scalings {
        match summary.get("scalings").items() {
            Ok(items) => out.extend(items.iter().map(scaling_sentence)),
            Err(e) => out.push(Err(e)),
        }
    }
    out
}

/// Which normalization the figures show (the window remembers the choice).
fn normalization_choice(ui: &mut egui::Ui) -> &'static str {
    let id = ui.make_persistent_id("magnitude-normalization");
    let mut per_display = ui.data_mut(|d| *d.get_persisted_mut_or_default::<bool>(id));
    ui.horizontal(|ui| {
        ui.label("Normalization:");
        ui.radio_value(&mut per_display, false, "pooled (one scale)");
        ui.radio_value(&mut per_display, true, "per display");
    });
    ui.data_mut(|d| d.insert_persisted(id, per_display));
    if per_display { "per_display" } else { "pooled" }
}

/// The geometric means against mu_s, one figure per display.
fn means_figures(ui: &mut egui::Ui, summary: &At<'_>) -> Result<(), Missing> {
    let means = summary
        .get("geometric_means")
        .items()?
        .iter()
        .map(geo_mean)
        .collect::<Result<Vec<_>, Missing>>()?;
    let displays = displays(summary)?;
    let norm = normalization_choice(ui);
    let cap = figures::cap_width(means.iter().map(|g| g.mu_s));
    ui.horizontal_wrapped(|ui| {
        for d in &displays {
            ui.vertical(|ui| {
                figures::title(
                    ui,
                    &format!("{d}: geometric means against mu_s ({norm}), 95% CIs"),
                );
                figures::legend(
figures::figure(
                    ("magnitude-means", d),
                    "mu_s (static friction coefficient, no unit)",
                    "geometric mean (normalized, no unit)",
                ), Corner::LeftTop)
                .show(ui, |plot| {
                    for (i, (name, gs)) in delta_mu_series(&means, d, norm, |g| g.mu_s)
                        .into_iter()
                        .enumerate()
                    {
                        let colour = figures::colour(i);
                        let pts: Vec<[f64; 2]> = gs.iter().map(|g| [g.mu_s, g.value]).collect();
                        plot.line(
                            Line::new(name.clone(), PlotPoints::from(pts.clone()))
                                .color(colour)
                                .width(2.0),
                        );
                        plot.points(
                            Points::new(name.clone(), PlotPoints::from(pts))
                                .color(colour)
                                .radius(3.5)
                                .filled(true),
                        );
                        for g in gs {
                            if let Some((lo, hi)) = both(g.ci_low, g.ci_high) {
                                figures::interval(
                                    plot,
                                    &name,
                                    Along::Y,
                                    (g.mu_s, lo, hi),
                                    cap,
                                    colour,
                                );
                            }
                        }
                    }
                });
            });
        }
    });
    Ok(())
}

/// Each scaling's equalized geometric means on log-log axes, with their
/// 95% intervals.
fn scaling_figures(ui: &mut egui::Ui, summary: &At<'_>) -> Result<(), Missing> {
    let scalings = summary.get("scalings").items()?;
    let mut drawn = Vec::new();
    for s in &scalings {
        let parameter = s.get("parameter").text()?;
        let means = s
            .get("geometric_means")
            .items()?
            .iter()
            .map(|m| {
                Ok((
                    m.get("level").required()?,
                    m.get("value").required()?,
                    both(m.get("ci_low").num()?, m.get("ci_high").num()?),
                ))
            })
            .collect::<Result<Vec<_>, Missing>>()?;
        drawn.push((s.get("display").text()?, parameter, means));
    }
    ui.horizontal_wrapped(|ui| {
        for (i, (display, parameter, means)) in drawn.iter().enumerate() {
            let field = parameter.rsplit('.').next().unwrap_or(parameter);
            let x_label = unit(field).map_or_else(
                || format!("ln {parameter} (no unit)"),
                |u| format!("ln {parameter} (level in {u})"),
            );
            let points: Vec<[f64; 2]> = means.iter().map(|m| [m.0.ln(), m.1.ln()]).collect();
            let cap = figures::cap_width(points.iter().map(|p| p[0]));
            ui.vertical(|ui| {
                figures::title(
                    ui,
                    &format!("{display}: ln geometric mean against ln {parameter}, 95% CIs"),
                );
                figures::legend(
figures::figure(
                    ("magnitude-scaling", i),
                    &x_label,
                    "ln geometric mean (equalized)",
                ), Corner::LeftTop)
                .show(ui, |plot| {
                    let colour = figures::colour(i);
                    plot.line(
                        Line::new(display.to_string(), PlotPoints::from(points.clone()))
                            .color(colour)
                            .width(2.0),
                    );
                    plot.points(
                        Points::new(display.to_string(), PlotPoints::from(points.clone()))
                            .color(colour)
                            .radius(3.5)
                            .filled(true),
                    );
                    for (m, p) in means.iter().zip(&points) {
                        if let Some((lo, hi)) = m.2.filter(|(lo, _)| *lo > 0.0) {
                            figures::interval(
                                plot,
                                display,
                                Along::Y,
                                (p[0], lo.ln(), hi.ln()),
                                cap,
                                colour,
                            );
                        }
                    }
                });
            });
        }
    });
    Ok(())
}

/// The kind's results view ([`show`]).
pub const VIEW: Option<ResultsView> = Some(show);

/// No screen of its own: its trials show the shared screens.
pub const SCREEN: Option<ScreenView> = None;

/// The view: the sentences, then the figures of each form present.
pub fn show(ui: &mut egui::Ui, summary: &Value) {
    figures::view(ui, summary, "magnitude_estimation", sentences, |ui, at| {
        if at.get("geometric_means").exists() {
            means_figures(ui, at)?;
        }
        if at.get("scalings").exists() {
            scaling_figures(ui, at)?;
        }
        Ok(())
    });
}
