//! The live plot under the session panel: position, force and vibrotactile
//! envelope over the last seconds of [`LiveSession::trace`].

use eframe::egui;
use egui_plot::{Legend, Line, Plot, PlotPoints, Points};

use crate::kinds::Registry;
use crate::session::LiveSession;

/// Position (mm), force (N) and vibrotactile envelope over the last seconds, on
/// a shared time axis.
pub(super) fn show(ui: &mut egui::Ui, live: &LiveSession) {
    let trace = live.trace();
    let x: Vec<[f64; 2]> = trace.iter().map(|p| [p.t_s, p.x_m * 1e3]).collect();
    let f: Vec<[f64; 2]> = trace.iter().map(|p| [p.t_s, p.force_n]).collect();
    let vibration: Vec<[f64; 2]> = trace.iter().map(|p| [p.t_s, p.vibration]).collect();
    let link = egui::Id::unique("trace-time");
    let height = ((ui.available_height() - 30.0) / 2.0).max(80.0);
    // A fixed view: the plots follow the trace, not the pointer.
    let plot = |id: &str| {
        Plot::new(id)
            .height(height)
            .legend(Legend::default())
            .link_axis(link, [true, false])
            .allow_drag(false)
            .allow_zoom(false)
            .allow_scroll(false)
    };
    plot("position")
        .y_axis_label("position (mm)")
        .show(ui, |plot| {
            plot.line(Line::new("position (mm)", PlotPoints::from(x)));
        });
    plot("force")
        .x_axis_label("session time (s)")
        .y_axis_label("force (N), drive")
        .show(ui, |plot| {
            plot.line(Line::new("force (N)", PlotPoints::from(f)));
            plot.line(Line::new(
                "vibrotactile envelope (0..1)",
                PlotPoints::from(vibration),
            ));
        });
}

/// One colour per track, its line and its correct answers alike.
const TRACK_COLOURS: [egui::Color32; 6] = [
    egui::Color32::from_rgb(230, 120, 60),
    egui::Color32::from_rgb(80, 170, 230),
    egui::Color32::from_rgb(120, 200, 90),
    egui::Color32::from_rgb(220, 90, 180),
    egui::Color32::from_rgb(230, 200, 70),
    egui::Color32::from_rgb(160, 140, 230),
];

/// A session's adaptive tracks (a kind's, [`Registry::tracks`]): each
/// track's difference, trial by trial, the answers marked (filled:
/// correct). Nothing for a kind without tracks, or before the first answer.
pub(super) fn tracks(ui: &mut egui::Ui, live: &LiveSession) {
    let tracks = Registry::tracks(live.engine().history());
    if tracks.is_empty() {
        return;
    }
    Plot::new("tracks")
        .height(170.0)
        .legend(Legend::default())
        .x_axis_label("trial of the track")
        .y_axis_label("difference")
        .allow_drag(false)
        .allow_zoom(false)
        .allow_scroll(false)
        .show(ui, |plot| {
            for t in &tracks {
                #[expect(clippy::cast_precision_loss, reason = "trial numbers")]
                let at = |i: usize, x: f64| [(i + 1) as f64, x];
                let line: Vec<[f64; 2]> = t
                    .answers
                    .iter()
                    .enumerate()
                    .map(|(i, a)| at(i, a.0))
                    .collect();
                let correct: Vec<[f64; 2]> = t
                    .answers
                    .iter()
                    .enumerate()
                    .filter(|(_, a)| a.1)
                    .map(|(i, a)| at(i, a.0))
                    .collect();
                let name = t.name.clone();
                let colour = TRACK_COLOURS[t.track % TRACK_COLOURS.len()];
                plot.line(Line::new(name.clone(), PlotPoints::from(line)).color(colour));
                plot.points(
                    Points::new(name, PlotPoints::from(correct))
                        .radius(3.0)
                        .filled(true)
                        .color(colour),
                );
            }
        });
}
