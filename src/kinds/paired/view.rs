//! The paired comparison's results in the window: which rendering was
//! chosen how often (the report's bar chart), the binomial test and the
//! presentation-order check in a sentence each.

use eframe::egui;
use egui_plot::{Bar, BarChart, PlotPoint, Text};
use serde_json::Value;

use crate::kinds::figures::{self, At, Missing, ResultsView, p_value, ScreenView};

/// The answers by what was chosen, as the report's chart lists them: each
/// rendering, then `no_difference`.
///
/// # Errors
/// `counts` or `no_difference` is missing.
pub fn chosen(summary: &At<'_>) -> Result<Vec<(String, u64)>, Missing> {
    let mut list = summary
        .get("counts")
        .entries()?
        .into_iter()
        .map(|(name, n)| Ok((name.to_owned(), n.count()?)))
        .collect::<Result<Vec<_>, Missing>>()?;
    list.push((
        "no_difference".to_owned(),
        summary.get("no_difference").count()?,
    ));
    Ok(list)
}

/// The key statistics, a sentence each.
#[must_use]
pub fn sentences(summary: &At<'_>) -> Vec<Result<String, Missing>> {
    let test = || -> Result<String, Missing> {
        let counts = summary.get("counts").entries()?;
        let decisive = summary.get("decisive").count()?;
        let trials = summary.get("trials").count()?;
        let none = summary.get("no_difference").count()?;
        let p = summary.get("binomial_p").num()?;
        let chosen = counts
            .iter()
            .map(|(name, n)| Ok(format!("{name} chosen {}", n.count()?)))
            .collect::<Result<Vec<_>, Missing>>()?
            .join(", ");
        let test = if counts.len() == 2 {
            format!("two-sided exact binomial test, {}", p_value(p))
        } else {
            format!(
                "binomial test n/a: {} renderings compared, it needs two",
                counts.len()
            )
        };
        Ok(format!(
            "{chosen} ({decisive} decisive of {trials} trials, no difference {none}): {test}."
        ))
    };
    let order = || -> Result<String, Missing> {
        let o = summary.get("order");
        Ok(format!(
            "Presentation order: first chosen {}, second chosen {}, two-sided exact binomial test, {}.",
            o.get("first_chosen").count()?,
            o.get("second_chosen").count()?,
            p_value(o.get("binomial_p").num()?)
        ))
    };
    vec![test(), order()]
}

/// The kind's results view ([`show`]).
pub const VIEW: Option<ResultsView> = Some(show);

/// No screen of its own: its trials show the shared screens.
pub const SCREEN: Option<ScreenView> = None;

/// The view: the sentences, then the counts' chart.
pub fn show(ui: &mut egui::Ui, summary: &Value) {
    figures::view(ui, summary, "paired_comparison", sentences, counts_figure);
}

/// The answers by what was chosen.
fn counts_figure(ui: &mut egui::Ui, at: &At<'_>) -> Result<(), Missing> {
    let list = chosen(at)?;
    figures::title(
        ui,
        "Which rendering is nearer to the real surface: answers by what was chosen",
    );
    let names = list.iter().map(|(n, _)| n.clone()).collect();
    figures::categories(
        figures::figure("paired-counts", "", "answers (trials)"),
        names,
    )
    .include_y(0.0)
    // Room above the highest bar for its count.
    .include_y(1.12 * list.iter().map(|(_, n)| *n as f64).fold(1.0, f64::max))
    .show(ui, |plot| {
        for (i, (name, n)) in list.iter().enumerate() {
            #[expect(clippy::cast_precision_loss, reason = "counts of trials")]
            let (x, y) = (i as f64, *n as f64);
            let bar = Bar::new(x, y)
                .width(0.7)
                .name(format!("{name}: {n}"))
                .fill(figures::colour(i));
            plot.bar_chart(BarChart::new(name.clone(), vec![bar]).color(figures::colour(i)));
            plot.text(
                Text::new(
                    name.clone(),
                    PlotPoint::new(x, y),
                    egui::RichText::new(n.to_string()).size(15.0),
                )
                    .anchor(egui::Align2::CENTER_BOTTOM),
            );
        }
    });
    Ok(())
}
