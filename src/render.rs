//! Output of `frictionlab render`: the time-series CSV and its SVG figure.
//! Files are written whole or not at all, by the results' one atomic write
//! ([`crate::results::replace_file`]).

use std::fmt::Write as _;
use std::io;
use std::path::Path;

use plotters::prelude::*;

use crate::results::ResultsError;
use crate::results::csv::Num;
use crate::scenario::Sample;

/// The CSV columns, in order; `vibration` only for tactile models,
/// `a_m_s2` and `applied_force_n` only for identification runs.
#[must_use]
pub fn columns(vibration: bool, applied: bool) -> Vec<&'static str> {
    let mut c = vec!["t_s", "x_m", "v_m_s", "force_n", "state", "slip_onset"];
    if vibration {
        c.push("vibration");
    }
    if applied {
        c.extend(["a_m_s2", "applied_force_n"]);
    }
    c
}

/// The time series as CSV text (header row, comma separated, numbers as
/// [`crate::results::csv::Num`] writes them, so equal runs give equal
/// bytes).
#[must_use]
pub fn csv(samples: &[Sample], vibration: bool) -> String {
    let applied = samples.first().is_some_and(|s| s.applied.is_some());
    let mut out = columns(vibration, applied).join(",");
    out.push('\n');
    for s in samples {
        let _ = write!(
            out,
            "{},{},{},{},{},{}",
            Num(s.t_s),
            Num(s.x_m),
            Num(s.v_m_s),
            Num(s.force_n),
            s.phase.as_str(),
            u8::from(s.slip_onset)
        );
        if vibration {
            let _ = write!(out, ",{}", Num(s.vibration));
        }
        if let Some((a, f)) = s.applied {
            let _ = write!(out, ",{},{}", Num(a), Num(f));
        }
        out.push('\n');
    }
    out
}

/// Writes `contents` to `path` atomically and durably, by
/// [`crate::results::replace_file`]. Creates missing parent folders.
///
/// # Errors
/// The I/O error; `path` is then untouched.
pub fn write_atomically(path: &Path, contents: &[u8]) -> io::Result<()> {
    crate::results::replace_file(path, contents, true).map_err(|e| match e {
        ResultsError::Io { source, .. } => source,
        other => io::Error::other(other.to_string()),
    })
}

/// An SVG figure over time of the force, the vibration (tactile models) and
/// the hand velocity, stick-to-slip transitions marked in red.
///
/// # Errors
/// A drawing error, as text.
pub fn plot_svg(samples: &[Sample], title: &str, vibration: bool) -> Result<String, String> {
    let mut svg = String::new();
    let height = if vibration { 900 } else { 640 };
    {
        let root = SVGBackend::with_string(&mut svg, (960, height)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| e.to_string())?;
        let root = root
            .titled(title, ("sans-serif", 20))
            .map_err(|e| e.to_string())?;
        let panels = root.split_evenly((if vibration { 3 } else { 2 }, 1));
        let t0 = samples.first().map_or(0.0, |s| s.t_s);
        let t1 = samples.last().map_or(1.0, |s| s.t_s).max(t0 + 1e-9);
        draw_panel(&panels[0], samples, t0..t1, "force on hand (N)", |s| {
            s.force_n
        })?;
        if vibration {
            draw_panel(&panels[1], samples, t0..t1, "vibration drive", |s| {
                s.vibration
            })?;
        }
        let last = &panels[panels.len() - 1];
        draw_panel(last, samples, t0..t1, "hand velocity (m/s)", |s| s.v_m_s)?;
        panels[0].present().map_err(|e| e.to_string())?;
    }
    Ok(svg)
}

fn draw_panel(
    area: &DrawingArea<SVGBackend<'_>, plotters::coord::Shift>,
    samples: &[Sample],
    t: std::ops::Range<f64>,
    label: &str,
    value: impl Fn(&Sample) -> f64,
) -> Result<(), String> {
    let (lo, hi) = samples
        .iter()
        .map(&value)
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
            (lo.min(v), hi.max(v))
        });
    let (lo, hi) = if lo.is_finite() && hi > lo {
        let pad = 0.05 * (hi - lo);
        (lo - pad, hi + pad)
    } else {
        (-1.0, 1.0)
    };
    let mut chart = ChartBuilder::on(area)
        .margin(10)
        .x_label_area_size(40)
        .y_label_area_size(60)
        .build_cartesian_2d(t, lo..hi)
        .map_err(|e| e.to_string())?;
    chart
        .configure_mesh()
        .x_desc("t (s)")
        .y_desc(label)
        .draw()
        .map_err(|e| e.to_string())?;
    chart
        .draw_series(LineSeries::new(
            samples.iter().map(|s| (s.t_s, value(s))),
            &BLUE,
        ))
        .map_err(|e| e.to_string())?;
    chart
        .draw_series(
            samples
                .iter()
                .filter(|s| s.slip_onset)
                .map(|s| Circle::new((s.t_s, value(s)), 3, RED.filled())),
        )
        .map_err(|e| e.to_string())?;
    Ok(())
}
