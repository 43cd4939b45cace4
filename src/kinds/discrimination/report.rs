//! The discrimination section of the report.

use frictionlab_psychophysics::psychometric::{GUESS_2IFC, Params, Psychometric, Shape};

use super::analysis::{Discrimination, TrackFit};
use crate::analysis::report::{esc, fmt, line_chart, scatter_curves, table_html};

/// A track's fitted function over its differences, 61 points.
fn fitted_curve(d: &Discrimination, t: &TrackFit) -> Vec<(f64, f64)> {
    let (lo, hi) = t.blocks.iter().fold((f64::INFINITY, 0.0_f64), |(a, b), k| {
        (a.min(k.x), b.max(k.x))
    });
    t.fit
        .map_or_else(Vec::new, |f| curve(d.design.fit.shape, f.params, (lo, hi)))
}

/// A fitted function of `shape` with `params` (two intervals), 61 points
/// from `lo` to `hi`: the report's and the window's curves.
#[must_use]
pub fn curve(shape: Shape, params: Params, (lo, hi): (f64, f64)) -> Vec<(f64, f64)> {
    let psi = Psychometric {
        shape,
        params,
        guess: GUESS_2IFC,
    };
    (0..=60)
        .map(|k| {
            let x = lo + (hi - lo) * f64::from(k) / 60.0;
            (x, psi.p_correct(x))
        })
        .collect()
}

/// Tracks shown in the track and fit figures (the first participants'),
/// in the report and in the window.
pub const TRACKS_SHOWN: usize = 6;

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
        |t: &TrackFit| format!("{} @ {}", t.participant, fmt(t.level));
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
