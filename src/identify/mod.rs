//! Friction identification from recorded motion and force (seed 002,
//! STUDIES 1e): the Karnopp form by least squares with the
//! errors-in-variables correction, and the Dahl model by Levenberg-Marquardt.
//!
//! # Conventions
//! SI units. The applied force `F` is the force that drives the slide (the
//! motor's force, positive towards +x); it moves the mass and overcomes the
//! friction: `F = m a + friction(motion)`. Friction opposes motion, so its
//! Coulomb levels `C_p`, `C_n` and viscous terms `b_p`, `b_n` come out
//! positive.
//!
//! # Input (CSV, header row, comma separated)
//! - `t_s`: time, s, strictly increasing;
//! - `v_m_s` (velocity) or `x_m` (position), or both;
//! - `a_m_s2` (acceleration), optional;
//! - `applied_force_n` or, failing it, `force_n`: the force on the hand as
//!   `frictionlab render` and session device streams record it; then
//!   `F = -force_n`.
//!
//! Missing velocity is derived from position, and missing acceleration from
//! velocity, by central differences smoothed by a centred moving average over
//! [`SMOOTH_S`]. Other columns are ignored, so a render CSV or a session's
//! device stream can be read as it is.
//!
//! This module reads the CSV it is given (a shell's job, done here so `identify`
//! and its tests share one reader) and otherwise computes.

mod dahl;
mod karnopp;

use std::path::Path;

use serde::Serialize;

use crate::friction::ModelParams;
use crate::problem::Problem;

pub use dahl::{DahlEstimates, DahlFit, dahl_model, fit_dahl};
pub use karnopp::{KarnoppEstimates, KarnoppFit, fit_karnopp, karnopp_model};

/// Width of the moving average that smooths derived velocity and
/// acceleration, s (11 samples at 1 kHz; a 2 Hz motion loses 0.7% of its
/// amplitude per smoothing).
pub const SMOOTH_S: f64 = 0.01;
/// Default zero-velocity band DV of the identification, m/s. Wider than the
/// rendering's 5 mm/s: after each reversal the surface sticks (presliding)
/// until the pull reaches static friction, and those samples do not follow
/// `C sgn(v) + b v`. On a noiseless render of the Karnopp model on the
/// servo-sinusoid scenario (2 Hz, +-1 cm), DV = 0.005 / 0.01 / 0.03 / 0.06
/// m/s gave b = 5.8 / 3.8 / 3.00 / 3.00 N s/m for a true 3.0, and C = 1.73 /
/// 1.92 / 2.000 / 2.000 N for a true 2.0.
pub const DEFAULT_DV_M_S: f64 = 0.03;
/// Fewest samples a fit accepts (after the zero-velocity band).
pub const MIN_SAMPLES: usize = 50;
/// Fewest samples moving each way.
pub const MIN_PER_DIRECTION: usize = 20;

/// A record ready to fit.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Record {
    /// Where the record came from (the file), named in the fits' errors.
    pub file: String,
    /// Time, s.
    pub t_s: Vec<f64>,
    /// Position, m (integrated from velocity when the file has none).
    pub x_m: Vec<f64>,
    /// Velocity, m/s.
    pub v_m_s: Vec<f64>,
    /// Acceleration, m/s^2.
    pub a_m_s2: Vec<f64>,
    /// Applied force, N.
    pub force_n: Vec<f64>,
    /// How each signal was obtained (`read`, `derived from x_m`, ...).
    pub sources: Vec<String>,
}

/// Reads a record from a CSV file (see the module docs).
///
/// # Errors
/// Unreadable file, missing columns, unparsable or non-finite values (with
/// `line:col`), time not increasing, fewer than [`MIN_SAMPLES`] rows.
pub fn read_csv(path: &Path) -> Result<Record, Problem> {
    let file = path.display().to_string();
    let text = std::fs::read_to_string(path)
        .map_err(|e| Problem::new(&file, format!("cannot read: {e}")))?;
    parse_csv(&file, &text)
}

/// [`read_csv`] on text; `file` names it in errors.
///
/// # Errors
/// As [`read_csv`].
pub fn parse_csv(file: &str, text: &str) -> Result<Record, Problem> {
    let mut lines = text.lines();
    let header: Vec<&str> = lines
        .next()
        .ok_or_else(|| Problem::new(file, "empty file: expected a header row"))?
        .split(',')
        .map(str::trim)
        .collect();
    let find = |name: &str| header.iter().position(|c| *c == name);
    let t_col = find("t_s").ok_or_else(|| Problem::new(file, "column 't_s': missing"))?;
    let (f_col, negate) = match (find("applied_force_n"), find("force_n")) {
        (Some(c), _) => (c, false),
        (None, Some(c)) => (c, true),
        (None, None) => {
            return Err(Problem::new(
                file,
                "column 'applied_force_n' (or 'force_n'): missing",
            ));
        }
    };
    let (x_col, v_col, a_col) = (find("x_m"), find("v_m_s"), find("a_m_s2"));
    if x_col.is_none() && v_col.is_none() {
        return Err(Problem::new(file, "column 'v_m_s' (or 'x_m'): missing"));
    }
    let wanted: Vec<(usize, &str)> = [
        Some((t_col, "t_s")),
        Some((f_col, header[f_col])),
        x_col.map(|c| (c, "x_m")),
        v_col.map(|c| (c, "v_m_s")),
        a_col.map(|c| (c, "a_m_s2")),
    ]
    .into_iter()
    .flatten()
    .collect();
    let mut columns = read_columns(file, lines, &wanted, header.len())?;
    let t = std::mem::take(&mut columns[t_col]);
    if t.len() < MIN_SAMPLES {
        return Err(Problem::new(
            file,
            format!(
                "too few samples: {} rows, at least {MIN_SAMPLES} needed",
                t.len()
            ),
        ));
    }
    if let Some(i) = t.windows(2).position(|w| w[1] <= w[0]) {
        return Err(Problem::new(
            format!("{file}: {}:1", i + 3),
            "column 't_s': time must increase from row to row",
        ));
    }
    let force: Vec<f64> = columns[f_col]
        .iter()
        .map(|f| if negate { -f } else { *f })
        .collect();
    let mut sources = vec![if negate {
        "force: -force_n (force on the hand)".to_owned()
    } else {
        "force: applied_force_n".to_owned()
    }];
    let (x, v) = match (x_col, v_col) {
        (Some(xc), Some(vc)) => {
            sources.push("velocity: v_m_s".into());
            (columns[xc].clone(), columns[vc].clone())
        }
        (Some(xc), None) => {
            sources.push(format!(
                "velocity: derived from x_m (central differences, {} ms moving average)",
                SMOOTH_S * 1e3
            ));
            let x = columns[xc].clone();
            let v = smooth(&t, &derivative(&t, &x));
            (x, v)
        }
        (None, Some(vc)) => {
            sources.push("velocity: v_m_s; position integrated from it".into());
            let v = columns[vc].clone();
            (integrate(&t, &v), v)
        }
        (None, None) => return Err(Problem::new(file, "column 'v_m_s' (or 'x_m'): missing")),
    };
    let a = if let Some(ac) = a_col {
        sources.push("acceleration: a_m_s2".into());
        columns[ac].clone()
    } else {
        sources.push(format!(
            "acceleration: derived from velocity (central differences, {} ms moving average)",
            SMOOTH_S * 1e3
        ));
        smooth(&t, &derivative(&t, &v))
    };
    Ok(Record {
        file: file.to_owned(),
        t_s: t,
        x_m: x,
        v_m_s: v,
        a_m_s2: a,
        force_n: force,
        sources,
    })
}

/// The wanted columns' values, checked: a finite number in every row.
fn read_columns<'a>(
    file: &str,
    lines: impl Iterator<Item = &'a str>,
    wanted: &[(usize, &str)],
    width: usize,
) -> Result<Vec<Vec<f64>>, Problem> {
    let mut columns: Vec<Vec<f64>> = vec![Vec::new(); width];
    for (i, line) in lines.enumerate() {
        if line.trim().is_empty() {
            continue;
        }
        let fields: Vec<&str> = line.split(',').collect();
        for &(c, name) in wanted {
            let col = fields[..c.min(fields.len())]
                .iter()
                .map(|f| f.len() + 1)
                .sum::<usize>()
                + 1;
            let place = format!("{file}: {}:{col}", i + 2);
            let raw = fields
                .get(c)
                .ok_or_else(|| Problem::new(&place, format!("column '{name}': missing value")))?
                .trim();
            let value: f64 = raw
                .parse()
                .ok()
                .filter(|v: &f64| v.is_finite())
                .ok_or_else(|| {
                    Problem::new(
                        &place,
                        format!("column '{name}': '{raw}' is not a finite number"),
                    )
                })?;
            columns[c].push(value);
        }
    }
    Ok(columns)
}

/// Central differences (one-sided at the ends).
fn derivative(t: &[f64], y: &[f64]) -> Vec<f64> {
    let n = y.len();
    (0..n)
        .map(|i| {
            let (a, b) = (i.saturating_sub(1), (i + 1).min(n - 1));
            (y[b] - y[a]) / (t[b] - t[a])
        })
        .collect()
}

/// Centred moving average over [`SMOOTH_S`] (odd window, at least 3).
fn smooth(t: &[f64], y: &[f64]) -> Vec<f64> {
    let n = y.len();
    let dt = (t[n - 1] - t[0]) / count(n - 1);
    #[expect(
        clippy::cast_possible_truncation,
        clippy::cast_sign_loss,
        reason = "a small positive sample count"
    )]
    let half = ((SMOOTH_S / dt / 2.0).round() as usize).max(1);
    (0..n)
        .map(|i| {
            let (a, b) = (i.saturating_sub(half), (i + half).min(n - 1));
            y[a..=b].iter().sum::<f64>() / count(b - a + 1)
        })
        .collect()
}

/// Trapezoidal integral starting at 0.
fn integrate(t: &[f64], v: &[f64]) -> Vec<f64> {
    let mut x = Vec::with_capacity(v.len());
    let mut acc = 0.0;
    x.push(acc);
    for i in 1..v.len() {
        acc += 0.5 * (v[i] + v[i - 1]) * (t[i] - t[i - 1]);
        x.push(acc);
    }
    x
}

fn count(n: usize) -> f64 {
    f64::from(u32::try_from(n).unwrap_or(u32::MAX))
}

/// White measurement noise SD of a densely sampled smooth signal, from its
/// second differences: `Var(y[i+1] - 2 y[i] + y[i-1]) = 6 s^2` when the
/// signal itself barely changes its slope between samples (true for a 2 Hz
/// motion sampled at 1 kHz). Derived (smoothed) signals have correlated
/// noise: give their SDs instead.
#[must_use]
pub fn noise_sd(y: &[f64]) -> f64 {
    if y.len() < 3 {
        return 0.0;
    }
    let sum: f64 = y
        .windows(3)
        .map(|w| (w[2] - 2.0 * w[1] + w[0]).powi(2))
        .sum();
    (sum / count(y.len() - 2) / 6.0).sqrt()
}

/// The noise SDs as given, or estimated from the record.
fn noise_of(rec: &Record, given: Option<(f64, f64)>) -> Noise {
    match given {
        Some((velocity_sd_m_s, acceleration_sd_m_s2)) => Noise {
            velocity_sd_m_s,
            acceleration_sd_m_s2,
            source: "given",
        },
        None => Noise {
            velocity_sd_m_s: noise_sd(&rec.v_m_s),
            acceleration_sd_m_s2: noise_sd(&rec.a_m_s2),
            source: "estimated",
        },
    }
}

/// A fitted value and its standard error.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Estimate {
    /// The value.
    pub value: f64,
    /// Its standard error.
    pub std_error: f64,
}

impl Estimate {
    fn is_finite(self) -> bool {
        self.value.is_finite() && self.std_error.is_finite()
    }
}

/// A fit whose arithmetic overflowed (values far outside any apparatus's
/// range) is refused rather than printed as `null`s.
fn finite_or_refused(rec: &Record, finite: bool, noise: &Noise) -> Result<(), Problem> {
    if finite && noise.velocity_sd_m_s.is_finite() && noise.acceleration_sd_m_s2.is_finite() {
        Ok(())
    } else {
        Err(Problem::new(
            &rec.file,
            "the fit is not finite: the values overflow (are the columns in SI units: s, m, m/s, m/s^2, N?)",
        ))
    }
}

/// The noise the Karnopp correction assumed.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Noise {
    /// Velocity noise SD, m/s.
    pub velocity_sd_m_s: f64,
    /// Acceleration noise SD, m/s^2.
    pub acceleration_sd_m_s2: f64,
    /// `given` or `estimated` (from second differences).
    pub source: &'static str,
}

/// The `identify` output: the record's provenance, the fit, and a `model`
/// block that pastes into a protocol.
#[must_use]
pub fn report_json(
    file: &str,
    rec: &Record,
    fit: &serde_json::Value,
    model: &ModelParams,
) -> String {
    let value = serde_json::json!({
        "file": file,
        "rows": rec.t_s.len(),
        "signals": rec.sources,
        "fit": fit,
        "protocol_model": model,
    });
    serde_json::to_string_pretty(&value).unwrap_or_default()
}
