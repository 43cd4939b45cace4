//! What the kinds' window code (`src/kinds/<kind>/view.rs`) shares: how
//! they read their object of `summary.json` (every missing field a
//! message naming its path, never a panic), how a statistic is written in
//! a sentence (`r = 0.93, 95% CI [0.81, 0.97], p = 0.0003`), and the
//! window's figures (egui_plot) in one style, coloured as the HTML report's
//! charts are.
//!
//! A view draws from `summary.json` alone, as the window has it after
//! Analyze, so what it shows is what the file says.

use eframe::egui::{self, Color32, RichText};
use egui_plot::{Corner, Legend, Line, Plot, PlotPoints, PlotUi};
use serde_json::Value;

use crate::protocol::engine::{Input, OwnScreen, Question};
use crate::time::Time;

/// A kind's view of its results in the window (its `VIEW` in
/// `src/kinds/<kind>/view.rs`): its figures and key statistics, drawn
/// from its object of `summary.json`.
pub type ResultsView = fn(&mut egui::Ui, &Value);

/// A kind's drawing of its own screens in the participant's window (its
/// `SCREEN` in `src/kinds/<kind>/view.rs`; see
/// [`crate::protocol::engine::OwnScreen`]): it draws `screen` (the kind
/// gets its own value back with [`OwnScreen::get`]) at session time `now`,
/// with `question` open if one is, and returns what the participant did.
pub type ScreenView = fn(&mut egui::Ui, &OwnScreen, Time, Option<Question>) -> Vec<Input>;

/// The report's chart colours (plotters' `Palette99`, its first ten), so a
/// series has the same colour in the window and in `report.html`.
const PALETTE: [Color32; 10] = [
    Color32::from_rgb(230, 25, 75),
    Color32::from_rgb(60, 180, 75),
    Color32::from_rgb(255, 225, 25),
    Color32::from_rgb(0, 130, 200),
    Color32::from_rgb(245, 130, 48),
    Color32::from_rgb(145, 30, 180),
    Color32::from_rgb(70, 240, 240),
    Color32::from_rgb(240, 50, 230),
    Color32::from_rgb(210, 245, 60),
    Color32::from_rgb(250, 190, 190),
];

/// The colour of series `i`.
#[must_use]
pub fn colour(i: usize) -> Color32 {
    PALETTE[i % PALETTE.len()]
}

/// A place in a kind's object of `summary.json`, read with its path kept
/// for the message when what is there is not what a view expects.
#[derive(Debug, Clone)]
pub struct At<'a> {
    value: Option<&'a Value>,
    path: String,
}

/// What a view could not read: the message to show.
pub type Missing = String;

impl<'a> At<'a> {
    /// The kind's object, `key` its name in `summary.json`.
    #[must_use]
    pub fn root(value: &'a Value, key: &str) -> At<'a> {
        At {
            value: Some(value),
            path: key.to_owned(),
        }
    }

    /// The field `key` of this object.
    #[must_use]
    pub fn get(&self, key: &str) -> At<'a> {
        At {
            value: self.value.and_then(|v| v.get(key)),
            path: format!("{}.{key}", self.path),
        }
    }

    /// Whether the field is there (even as null).
    #[must_use]
    pub fn exists(&self) -> bool {
        self.value.is_some()
    }

    fn missing(&self, what: &str) -> Missing {
        match self.value {
            None => format!("summary.json has no {}", self.path),
            Some(v) => format!("summary.json: {} is {v}, not {what}", self.path),
        }
    }

    /// A number; null (a statistic that is n/a) is `None`.
    ///
    /// # Errors
    /// The field is missing or holds something else.
    pub fn num(&self) -> Result<Option<f64>, Missing> {
        match self.value {
            Some(Value::Null) => Ok(None),
            Some(v) => v.as_f64().map(Some).ok_or_else(|| self.missing("a number")),
            None => Err(self.missing("a number")),
        }
    }

    /// A number that must be there.
    ///
    /// # Errors
    /// The field is missing, null or not a number.
    pub fn required(&self) -> Result<f64, Missing> {
        self.num()?.ok_or_else(|| self.missing("a number"))
    }

    /// A count.
    ///
    /// # Errors
    /// The field is missing or not a whole number.
    pub fn count(&self) -> Result<u64, Missing> {
        self.value
            .and_then(Value::as_u64)
            .ok_or_else(|| self.missing("a count"))
    }

    /// A text.
    ///
    /// # Errors
    /// The field is missing or not a text.
    pub fn text(&self) -> Result<&'a str, Missing> {
        self.value
            .and_then(Value::as_str)
            .ok_or_else(|| self.missing("a text"))
    }

    /// A pair of numbers `[low, high]` (an interval); null is `None`.
    ///
    /// # Errors
    /// The field is missing or not a pair of numbers.
    pub fn pair(&self) -> Result<Option<(f64, f64)>, Missing> {
        match self.value {
            Some(Value::Null) => Ok(None),
            Some(Value::Array(a)) if a.len() == 2 => {
                Ok(Some((self.at(0).required()?, self.at(1).required()?)))
            }
            _ => Err(self.missing("a pair of numbers")),
        }
    }

    /// Item `i` of this list.
    #[must_use]
    pub fn at(&self, i: usize) -> At<'a> {
        At {
            value: self.value.and_then(|v| v.get(i)),
            path: format!("{}[{i}]", self.path),
        }
    }

    /// The items of this list.
    ///
    /// # Errors
    /// The field is missing or not a list.
    pub fn items(&self) -> Result<Vec<At<'a>>, Missing> {
        let n = self
            .value
            .and_then(Value::as_array)
            .ok_or_else(|| self.missing("a list"))?
            .len();
        Ok((0..n).map(|i| self.at(i)).collect())
    }

    /// The fields of this object, in the file's order.
    ///
    /// # Errors
    /// The field is missing or not an object.
    pub fn entries(&self) -> Result<Vec<(&'a str, At<'a>)>, Missing> {
        let map = self
            .value
            .and_then(Value::as_object)
            .ok_or_else(|| self.missing("an object"))?;
        Ok(map
            .iter()
            .map(|(k, v)| {
                (
                    k.as_str(),
                    At {
                        value: Some(v),
                        path: format!("{}.{k}", self.path),
                    },
                )
            })
            .collect())
    }
}

/// `x` to `digits` decimals, or `n/a`.
#[must_use]
pub fn fixed(x: Option<f64>, digits: usize) -> String {
    x.map_or_else(|| "n/a".to_owned(), |x| format!("{x:.digits$}"))
}

/// A p value as a paper writes it: three decimals, four below 0.001,
/// `p < 0.0001` below that.
#[must_use]
pub fn p_value(p: Option<f64>) -> String {
    match p {
        None => "p n/a".to_owned(),
        Some(p) if p < 1e-4 => "p < 0.0001".to_owned(),
        Some(p) if p < 1e-3 => format!("p = {p:.4}"),
        Some(p) => format!("p = {p:.3}"),
    }
}

/// A 95% interval, `95% CI [low, high]`, both to `digits` decimals.
#[must_use]
pub fn ci(interval: Option<(f64, f64)>, digits: usize) -> String {
    interval.map_or_else(
        || "95% CI n/a".to_owned(),
        |(lo, hi)| format!("95% CI [{lo:.digits$}, {hi:.digits$}]"),
    )
}

/// Both ends of an interval given as two fields, if both are numbers.
#[must_use]
pub fn both(lo: Option<f64>, hi: Option<f64>) -> Option<(f64, f64)> {
    lo.zip(hi)
}

/// A kind's view, drawn from its object `summary` of `summary.json`
/// (under `key`): its key statistics a sentence a line (selectable, so a
/// researcher can copy one), then its `figures`; what could not be read is
/// said in place, once.
pub fn view(
    ui: &mut egui::Ui,
    summary: &Value,
    key: &str,
    sentences: fn(&At<'_>) -> Vec<Result<String, Missing>>,
    figures: impl FnOnce(&mut egui::Ui, &At<'_>) -> Result<(), Missing>,
) {
    let at = At::root(summary, key);
    let said = sentences(&at);
    for s in &said {
        match s {
            Ok(s) => {
                ui.add(egui::Label::new(s.as_str()).selectable(true).wrap());
            }
            Err(e) => problem(ui, e),
        }
    }
    if let Err(e) = figures(ui, &at)
        && !said.iter().any(|s| s.as_ref().err() == Some(&e))
    {
        problem(ui, &e);
    }
}

/// A message of what a view could not read.
pub fn problem(ui: &mut egui::Ui, message: &str) {
    ui.label(RichText::new(message).color(Color32::from_rgb(230, 80, 60)));
}

/// Width of one figure, px: two side by side in the window.
pub const FIGURE_WIDTH: f32 = 450.0;
/// Height of one figure, px.
pub const FIGURE_HEIGHT: f32 = 300.0;

/// A figure with its axis labels (with their units) and a fixed view (the scroll wheel scrolls the panel, not the figure). `id` must
/// be unique in the window.
#[must_use]
pub fn figure(id: impl egui::AsIdSalt, x_label: &str, y_label: &str) -> Plot<'static> {
    Plot::new(id)
        .width(FIGURE_WIDTH)
        .height(FIGURE_HEIGHT)
        .x_axis_label(x_label.to_owned())
        .y_axis_label(y_label.to_owned())
        .allow_drag(false)
        .allow_zoom(false)
        .allow_scroll(false)
        .allow_boxed_zoom(false)
}

/// `plot` with categories on its x axis: `names[i]` at `x = i`, and no
/// other x mark.
#[must_use]
pub fn categories(plot: Plot<'static>, names: Vec<String>) -> Plot<'static> {
    let n = names.len();
    plot.x_grid_spacer(move |_| {
        (0..n)
            .map(|i| egui_plot::GridMark {
                #[expect(clippy::cast_precision_loss, reason = "a few categories")]
                value: i as f64,
                step_size: 1.0,
            })
            .collect()
    })
    .x_axis_formatter(move |mark, _| {
        let i = mark.value.round();
        if (mark.value - i).abs() < 1e-9 && i >= 0.0 {
            #[expect(
                clippy::cast_possible_truncation,
                clippy::cast_sign_loss,
                reason = "a whole, non-negative mark"
            )]
            names.get(i as usize).cloned().unwrap_or_default()
        } else {
            String::new()
        }
    })
}

/// `plot` with a legend of its series, in the corner `corner`.
#[must_use]
pub fn legend(plot: Plot<'static>, corner: Corner) -> Plot<'static> {
    plot.legend(Legend::default().position(corner))
}

/// A figure's title above it.
pub fn title(ui: &mut egui::Ui, text: &str) {
    ui.add_space(6.0);
    ui.label(RichText::new(text).strong());
    ui.add_space(4.0);
}

/// Which way an interval runs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Along {
    /// Up the y axis, at an x.
    Y,
    /// Along the x axis, at a y.
    X,
}

/// An interval from `lo` to `hi` at `at` (an x for [`Along::Y`], a y for
/// [`Along::X`]), with caps `cap` across (in the other axis' units), in
/// `colour`, named `name` in the legend (one entry with the points of the
/// same name).
pub fn interval(
    plot: &mut PlotUi<'_>,
    name: &str,
    along: Along,
    (at, lo, hi): (f64, f64, f64),
    cap: f64,
    colour: Color32,
) {
    let h = cap / 2.0;
    for segment in [
        [[at, lo], [at, hi]],
        [[at - h, lo], [at + h, lo]],
        [[at - h, hi], [at + h, hi]],
    ] {
        let points: Vec<[f64; 2]> = segment
            .iter()
            .map(|&[across, on]| match along {
                Along::Y => [across, on],
                Along::X => [on, across],
            })
            .collect();
        plot.line(
            Line::new(name.to_owned(), PlotPoints::from(points))
                .color(colour)
                .width(1.5),
        );
    }
}

/// A cap's width for intervals over the x values `xs`: 2% of their span.
#[must_use]
pub fn cap_width(xs: impl Iterator<Item = f64>) -> f64 {
    let (lo, hi) = xs
        .filter(|x| x.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), x| {
            (a.min(x), b.max(x))
        });
    if hi > lo { 0.02 * (hi - lo) } else { 0.02 }
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    #[test]
    fn a_field_reads_or_names_its_path_and_what_is_wrong() {
        let v = json!({"a": {"b": [1.5, null, "x"]}, "p": [0.1, 0.2], "n": 4});
        let at = At::root(&v, "kind");
        assert_eq!(at.get("a").get("b").at(0).num(), Ok(Some(1.5)));
        assert_eq!(at.get("a").get("b").at(1).num(), Ok(None));
        assert_eq!(
            at.get("a").get("b").at(1).required(),
            Err("summary.json: kind.a.b[1] is null, not a number".to_owned())
        );
        assert_eq!(
            at.get("a").get("b").at(2).num(),
            Err("summary.json: kind.a.b[2] is \"x\", not a number".to_owned())
        );
        assert_eq!(
            at.get("a").get("c").num(),
            Err("summary.json has no kind.a.c".to_owned())
        );
        assert_eq!(at.get("p").pair(), Ok(Some((0.1, 0.2))));
        assert!(at.get("n").pair().is_err());
        assert_eq!(at.get("n").count(), Ok(4));
        assert_eq!(at.get("a").get("b").items().map(|i| i.len()), Ok(3));
        assert!(at.get("n").items().is_err());
        assert_eq!(at.entries().map(|e| e.len()), Ok(3));
    }

    #[test]
    fn statistics_are_written_as_a_paper_writes_them() {
        assert_eq!(p_value(Some(0.0752)), "p = 0.075");
        assert_eq!(p_value(Some(0.000_31)), "p = 0.0003");
        assert_eq!(p_value(Some(5e-8)), "p < 0.0001");
        assert_eq!(p_value(None), "p n/a");
        assert_eq!(ci(Some((-0.0695, 0.8879)), 2), "95% CI [-0.07, 0.89]");
        assert_eq!(ci(None, 2), "95% CI n/a");
        assert_eq!(fixed(Some(0.586), 2), "0.59");
        assert_eq!(fixed(None, 2), "n/a");
        assert!((cap_width([1.0, 3.0].into_iter()) - 0.04).abs() < 1e-12);
        assert!((cap_width(std::iter::empty()) - 0.02).abs() < 1e-12);
    }
}
