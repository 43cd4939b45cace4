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

use std::path::Path;

use levenberg_marquardt::{LeastSquaresProblem, LevenbergMarquardt};
use nalgebra::{DVector, Dyn, OMatrix, Owned, SMatrix, SVector, U4, VecStorage, Vector4};
use serde::Serialize;

use crate::friction::dahl::{Dahl, DahlParams};
use crate::friction::karnopp::KarnoppParams;
use crate::friction::{ForceLimit, Input, ModelParams};

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

/// A problem with the input: where and what.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{place}: {message}")]
pub struct IdentifyError {
    /// File, with `line:col` or column name where known; or an option.
    pub place: String,
    /// What is wrong.
    pub message: String,
}

fn err(place: impl Into<String>, message: impl Into<String>) -> IdentifyError {
    IdentifyError {
        place: place.into(),
        message: message.into(),
    }
}

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
pub fn read_csv(path: &Path) -> Result<Record, IdentifyError> {
    let file = path.display().to_string();
    let text =
        std::fs::read_to_string(path).map_err(|e| err(&file, format!("cannot read: {e}")))?;
    parse_csv(&file, &text)
}

/// [`read_csv`] on text; `file` names it in errors.
///
/// # Errors
/// As [`read_csv`].
pub fn parse_csv(file: &str, text: &str) -> Result<Record, IdentifyError> {
    let mut lines = text.lines();
    let header: Vec<&str> = lines
        .next()
        .ok_or_else(|| err(file, "empty file: expected a header row"))?
        .split(',')
        .map(str::trim)
        .collect();
    let find = |name: &str| header.iter().position(|c| *c == name);
    let t_col = find("t_s").ok_or_else(|| err(file, "column 't_s': missing"))?;
    let (f_col, negate) = match (find("applied_force_n"), find("force_n")) {
        (Some(c), _) => (c, false),
        (None, Some(c)) => (c, true),
        (None, None) => {
            return Err(err(
                file,
                "column 'applied_force_n' (or 'force_n'): missing",
            ));
        }
    };
    let (x_col, v_col, a_col) = (find("x_m"), find("v_m_s"), find("a_m_s2"));
    if x_col.is_none() && v_col.is_none() {
        return Err(err(file, "column 'v_m_s' (or 'x_m'): missing"));
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
        return Err(err(
            file,
            format!(
                "too few samples: {} rows, at least {MIN_SAMPLES} needed",
                t.len()
            ),
        ));
    }
    if let Some(i) = t.windows(2).position(|w| w[1] <= w[0]) {
        return Err(err(
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
        (None, None) => return Err(err(file, "column 'v_m_s' (or 'x_m'): missing")),
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
) -> Result<Vec<Vec<f64>>, IdentifyError> {
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
                .ok_or_else(|| err(&place, format!("column '{name}': missing value")))?
                .trim();
            let value: f64 = raw
                .parse()
                .ok()
                .filter(|v: &f64| v.is_finite())
                .ok_or_else(|| {
                    err(
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
fn finite_or_refused(rec: &Record, finite: bool, noise: &Noise) -> Result<(), IdentifyError> {
    if finite && noise.velocity_sd_m_s.is_finite() && noise.acceleration_sd_m_s2.is_finite() {
        Ok(())
    } else {
        Err(err(
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

/// Karnopp-form parameters.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct KarnoppEstimates {
    /// Moving mass m, kg.
    pub mass_kg: Estimate,
    /// Coulomb level moving towards +x, C_p, N.
    pub c_pos_n: Estimate,
    /// Viscous term moving towards +x, b_p, N s/m.
    pub b_pos_n_s_m: Estimate,
    /// Coulomb level moving towards -x, C_n, N.
    pub c_neg_n: Estimate,
    /// Viscous term moving towards -x, b_n, N s/m.
    pub b_neg_n_s_m: Estimate,
    /// RMS of the residual force, N.
    pub residual_rms_n: f64,
}

impl KarnoppEstimates {
    fn is_finite(&self) -> bool {
        [
            self.mass_kg,
            self.c_pos_n,
            self.b_pos_n_s_m,
            self.c_neg_n,
            self.b_neg_n_s_m,
        ]
        .into_iter()
        .all(Estimate::is_finite)
            && self.residual_rms_n.is_finite()
    }
}

/// A Karnopp identification.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct KarnoppFit {
    /// The errors-in-variables estimate (STUDIES 1e).
    pub corrected: KarnoppEstimates,
    /// Plain least squares, for comparison.
    pub plain_least_squares: KarnoppEstimates,
    /// The noise corrected for.
    pub noise: Noise,
    /// Samples fitted (outside the zero-velocity band).
    pub samples: usize,
    /// Samples moving towards +x / -x.
    pub samples_pos: usize,
    /// See `samples_pos`.
    pub samples_neg: usize,
    /// Samples inside the band, excluded.
    pub excluded_in_band: usize,
    /// The zero-velocity band DV, m/s.
    pub dv_m_s: f64,
}

/// Fits `F = m a + C_p sgn(v_p) + b_p v_p + C_n sgn(v_n) + b_n v_n` to the
/// samples with `|v| > dv`, by least squares and with the
/// errors-in-variables correction `theta = (X^T X - D)^-1 X^T F`.
///
/// STUDIES 1e writes `D = N S`, `S = diag(s_acc^2, 0, s_vel^2, 0, s_vel^2)`.
/// Split by sign, the `v_p` column carries velocity noise only in its `N_p`
/// rows (and `v_n` in `N_n`), so `D = diag(N s_acc^2, 0, N_p s_vel^2, 0,
/// N_n s_vel^2)`: the expected noise part of `X^T X`. Standard errors: plain,
/// `s^2 (X^T X)^-1`; corrected, the sandwich `s^2 M^-1 X^T X M^-1` with
/// `M = X^T X - D`, where `s^2` is the residual variance.
///
/// # Errors
/// Too few samples moving either way, or a singular system.
pub fn fit_karnopp(
    rec: &Record,
    dv: f64,
    noise: Option<(f64, f64)>,
) -> Result<KarnoppFit, IdentifyError> {
    let noise = noise_of(rec, noise);
    let rows = karnopp_rows(rec, dv)?;
    let mut xtx = SMatrix::<f64, 5, 5>::zeros();
    let mut xtf = SVector::<f64, 5>::zeros();
    for (x, f) in &rows.samples {
        xtx += x * x.transpose();
        xtf += x * *f;
    }
    let n = count(rows.samples.len());
    let d = SMatrix::<f64, 5, 5>::from_diagonal(&SVector::<f64, 5>::from([
        n * noise.acceleration_sd_m_s2.powi(2),
        0.0,
        count(rows.pos) * noise.velocity_sd_m_s.powi(2),
        0.0,
        count(rows.neg) * noise.velocity_sd_m_s.powi(2),
    ]));
    let singular = || {
        err(
            &rec.file,
            "the regressors are singular (too little motion to separate mass and friction)",
        )
    };
    let plain_inv = xtx.try_inverse().ok_or_else(singular)?;
    let corrected_inv = (xtx - d).try_inverse().ok_or_else(singular)?;
    let estimates = |theta: SVector<f64, 5>, cov_unscaled: SMatrix<f64, 5, 5>| {
        let rss: f64 = rows
            .samples
            .iter()
            .map(|(x, f)| (f - x.dot(&theta)).powi(2))
            .sum();
        let s2 = rss / (n - 5.0).max(1.0);
        let se = |i: usize| (s2 * cov_unscaled[(i, i)]).max(0.0).sqrt();
        let e = |i: usize| Estimate {
            value: theta[i],
            std_error: se(i),
        };
        KarnoppEstimates {
            mass_kg: e(0),
            c_pos_n: e(1),
            b_pos_n_s_m: e(2),
            c_neg_n: e(3),
            b_neg_n_s_m: e(4),
            residual_rms_n: (rss / n).sqrt(),
        }
    };
    let corrected = estimates(corrected_inv * xtf, corrected_inv * xtx * corrected_inv);
    let plain_least_squares = estimates(plain_inv * xtf, plain_inv);
    finite_or_refused(
        rec,
        corrected.is_finite() && plain_least_squares.is_finite(),
        &noise,
    )?;
    Ok(KarnoppFit {
        corrected,
        plain_least_squares,
        noise,
        samples: rows.samples.len(),
        samples_pos: rows.pos,
        samples_neg: rows.neg,
        excluded_in_band: rec.v_m_s.len() - rows.samples.len(),
        dv_m_s: dv,
    })
}

struct Rows {
    samples: Vec<(SVector<f64, 5>, f64)>,
    pos: usize,
    neg: usize,
}

fn karnopp_rows(rec: &Record, dv: f64) -> Result<Rows, IdentifyError> {
    let mut rows = Vec::with_capacity(rec.v_m_s.len());
    let (mut pos, mut neg) = (0, 0);
    for i in 0..rec.v_m_s.len() {
        let (v, a, f) = (rec.v_m_s[i], rec.a_m_s2[i], rec.force_n[i]);
        let x = if v > dv {
            pos += 1;
            SVector::<f64, 5>::from([a, 1.0, v, 0.0, 0.0])
        } else if v < -dv {
            neg += 1;
            SVector::<f64, 5>::from([a, 0.0, 0.0, -1.0, v])
        } else {
            continue;
        };
        rows.push((x, f));
    }
    for (n, way) in [(pos, "+x"), (neg, "-x")] {
        if n < MIN_PER_DIRECTION {
            return Err(err(
                &rec.file,
                format!(
                    "no motion towards {way}: {n} samples faster than DV = {dv} m/s, at least {MIN_PER_DIRECTION} needed"
                ),
            ));
        }
    }
    Ok(Rows {
        samples: rows,
        pos,
        neg,
    })
}

/// Dahl parameters.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct DahlEstimates {
    /// Moving mass m, kg.
    pub mass_kg: Estimate,
    /// Coulomb level towards +x, N.
    pub fc_pos_n: Estimate,
    /// Coulomb level towards -x, N.
    pub fc_neg_n: Estimate,
    /// Viscous term b, N s/m.
    pub viscous_n_s_m: Estimate,
    /// RMS of the residual force, N.
    pub residual_rms_n: f64,
}

impl DahlEstimates {
    fn is_finite(&self) -> bool {
        [
            self.mass_kg,
            self.fc_pos_n,
            self.fc_neg_n,
            self.viscous_n_s_m,
        ]
        .into_iter()
        .all(Estimate::is_finite)
            && self.residual_rms_n.is_finite()
    }
}

/// A Dahl identification.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct DahlFit {
    /// The errors-in-variables estimate: the least-squares solution refined
    /// by Gauss-Newton steps on the corrected objective.
    pub corrected: DahlEstimates,
    /// Levenberg-Marquardt's least-squares estimate.
    pub least_squares: DahlEstimates,
    /// The noise corrected for.
    pub noise: Noise,
    /// The fixed rest stiffness sigma, N/m.
    pub sigma_n_m: f64,
    /// The fixed shape exponent.
    pub exponent: f64,
    /// Levenberg-Marquardt's verdict.
    pub converged: bool,
    /// Why it stopped.
    pub termination: String,
    /// Residual evaluations.
    pub evaluations: usize,
    /// Whether the corrected refinement's steps shrank below 1e-9 relative.
    pub corrected_converged: bool,
    /// Gauss-Newton steps of the refinement.
    pub corrected_iterations: usize,
    /// Samples fitted.
    pub samples: usize,
}

/// The Dahl friction force along the record for Coulomb levels `fc`.
fn dahl_force(rec: &Record, sigma: f64, exponent: f64, fc_pos: f64, fc_neg: f64) -> Vec<f64> {
    let p = DahlParams {
        sigma_n_m: sigma,
        fc_pos_n: fc_pos.max(1e-9),
        fc_neg_n: fc_neg.max(1e-9),
        exponent,
        viscous_n_s_m: 0.0,
        ..DahlParams::default()
    };
    let limit = ForceLimit::new(f64::MAX).unwrap_or_default();
    let mut model = Dahl::new(p, limit, rec.x_m[0]);
    (0..rec.x_m.len())
        .map(|i| {
            let dt = if i == 0 {
                0.0
            } else {
                rec.t_s[i] - rec.t_s[i - 1]
            };
            -model
                .step(
                    dt,
                    Input {
                        x_m: rec.x_m[i],
                        v_m_s: rec.v_m_s[i],
                    },
                )
                .force_n
        })
        .collect()
}

struct DahlProblem<'a> {
    rec: &'a Record,
    sigma: f64,
    exponent: f64,
    p: Vector4<f64>,
    fd: Vec<f64>,
}

impl DahlProblem<'_> {
    fn residual_vec(&self, fd: &[f64], p: &Vector4<f64>) -> DVector<f64> {
        DVector::from_iterator(
            fd.len(),
            (0..fd.len()).map(|i| {
                self.rec.force_n[i] - (p[0] * self.rec.a_m_s2[i] + fd[i] + p[3] * self.rec.v_m_s[i])
            }),
        )
    }
}

impl LeastSquaresProblem<f64, Dyn, U4> for DahlProblem<'_> {
    type ResidualStorage = VecStorage<f64, Dyn, nalgebra::U1>;
    type JacobianStorage = VecStorage<f64, Dyn, U4>;
    type ParameterStorage = Owned<f64, U4>;

    fn set_params(&mut self, p: &Vector4<f64>) {
        self.p = *p;
        self.fd = dahl_force(self.rec, self.sigma, self.exponent, p[1], p[2]);
    }

    fn params(&self) -> Vector4<f64> {
        self.p
    }

    fn residuals(&self) -> Option<DVector<f64>> {
        Some(self.residual_vec(&self.fd, &self.p))
    }

    fn jacobian(&self) -> Option<OMatrix<f64, Dyn, U4>> {
        let n = self.fd.len();
        let mut j = OMatrix::<f64, Dyn, U4>::zeros(n);
        for i in 0..n {
            j[(i, 0)] = -self.rec.a_m_s2[i];
            j[(i, 3)] = -self.rec.v_m_s[i];
        }
        // The Coulomb levels act through the Dahl state: forward differences.
        for k in [1, 2] {
            let h = 1e-6 * self.p[k].abs().max(1e-3);
            let mut q = self.p;
            q[k] += h;
            let fd = dahl_force(self.rec, self.sigma, self.exponent, q[1], q[2]);
            for i in 0..n {
                j[(i, k)] = -(fd[i] - self.fd[i]) / h;
            }
        }
        Some(j)
    }
}

/// Fits `F = m a + F_dahl(x; sigma, Fc+, Fc-, i) + b v` by
/// Levenberg-Marquardt over m, Fc+, Fc- and b, with `sigma` and the
/// exponent fixed, starting from the Karnopp fit's plain estimates (band
/// `dv`).
///
/// Noise on `a` and `v` biases least squares as in the Karnopp form (the
/// mass is attenuated, and the Dahl levels and b absorb the rest). The
/// corrected estimate minimises `sum r^2 - N (m^2 s_acc^2 + b^2 s_vel^2)`,
/// the expected noise part taken out, by Gauss-Newton steps from the
/// least-squares solution: `p -= (J^T J - N S)^-1 (J^T r - N S p)` with
/// `S = diag(s_acc^2, 0, 0, s_vel^2)`. Standard errors: `s^2 (J^T J)^-1`
/// for least squares, the sandwich `s^2 H^-1 J^T J H^-1`, `H = J^T J - N S`,
/// for the corrected estimate.
///
/// # Errors
/// As [`fit_karnopp`] for the start; a singular Jacobian.
pub fn fit_dahl(
    rec: &Record,
    sigma: f64,
    exponent: f64,
    dv: f64,
    noise: Option<(f64, f64)>,
) -> Result<DahlFit, IdentifyError> {
    let noise = noise_of(rec, noise);
    let start = fit_karnopp(rec, dv, Some((0.0, 0.0)))?.plain_least_squares;
    let p0 = Vector4::new(
        start.mass_kg.value,
        start.c_pos_n.value.max(1e-3),
        start.c_neg_n.value.max(1e-3),
        0.5 * (start.b_pos_n_s_m.value + start.b_neg_n_s_m.value),
    );
    let mut problem = DahlProblem {
        rec,
        sigma,
        exponent,
        p: p0,
        fd: Vec::new(),
    };
    problem.set_params(&p0);
    let (mut problem, report) = LevenbergMarquardt::new().minimize(problem);
    let singular = || err(&rec.file, "the Dahl fit's Jacobian is singular");
    let n = count(rec.t_s.len());
    let s = nalgebra::Matrix4::from_diagonal(&Vector4::new(
        n * noise.acceleration_sd_m_s2.powi(2),
        0.0,
        0.0,
        n * noise.velocity_sd_m_s.powi(2),
    ));
    let estimates = |problem: &DahlProblem<'_>, corrected: bool| {
        let p = problem.p;
        let r = problem.residual_vec(&problem.fd, &p);
        let jac = problem.jacobian().ok_or_else(singular)?;
        let jtj = jac.transpose() * &jac;
        let inv = jtj.try_inverse().ok_or_else(singular)?;
        let cov = if corrected {
            let h = (jtj - s).try_inverse().ok_or_else(singular)?;
            h * jtj * h
        } else {
            inv
        };
        let rss = r.norm_squared();
        let s2 = rss / (n - 4.0).max(1.0);
        let e = |i: usize| Estimate {
            value: p[i],
            std_error: (s2 * cov[(i, i)]).max(0.0).sqrt(),
        };
        Ok::<_, IdentifyError>(DahlEstimates {
            mass_kg: e(0),
            fc_pos_n: e(1),
            fc_neg_n: e(2),
            viscous_n_s_m: e(3),
            residual_rms_n: (rss / n).sqrt(),
        })
    };
    let least_squares = estimates(&problem, false)?;
    let (mut corrected_converged, mut corrected_iterations) = (false, 0);
    for _ in 0..30 {
        let p = problem.p;
        let r = problem.residual_vec(&problem.fd, &p);
        let jac = problem.jacobian().ok_or_else(singular)?;
        let h = (jac.transpose() * &jac - s)
            .try_inverse()
            .ok_or_else(singular)?;
        let step = h * (jac.transpose() * r - s * p);
        problem.set_params(&(p - step));
        corrected_iterations += 1;
        if step.norm() <= 1e-9 * p.norm().max(1e-9) {
            corrected_converged = true;
            break;
        }
    }
    let corrected = estimates(&problem, true)?;
    finite_or_refused(
        rec,
        corrected.is_finite() && least_squares.is_finite(),
        &noise,
    )?;
    Ok(DahlFit {
        corrected,
        least_squares,
        noise,
        sigma_n_m: sigma,
        exponent,
        converged: report.termination.was_successful(),
        termination: format!("{:?}", report.termination),
        evaluations: report.number_of_evaluations,
        corrected_converged,
        corrected_iterations,
        samples: rec.t_s.len(),
    })
}

/// A protocol `model` block for a Karnopp fit: the mean Coulomb level as
/// `f_dynamic_n` and the mean viscous term. The Karnopp form does not
/// identify static friction: `f_static_n` keeps the default model's ratio
/// to the dynamic level (2.5 / 2.0), to be edited after a break-away test.
/// The virtual block keeps its default mass: the identified mass is the
/// apparatus's, which the device already has.
#[must_use]
pub fn karnopp_model(fit: &KarnoppEstimates) -> ModelParams {
    let d = KarnoppParams::default();
    let c = 0.5 * (fit.c_pos_n.value + fit.c_neg_n.value);
    let b = 0.5 * (fit.b_pos_n_s_m.value + fit.b_neg_n_s_m.value);
    ModelParams::Karnopp(KarnoppParams {
        f_dynamic_n: c.max(0.0),
        f_static_n: (c * d.f_static_n / d.f_dynamic_n).max(0.0),
        viscous_n_s_m: b.max(0.0),
        ..d
    })
}

/// A protocol `model` block for a Dahl fit's corrected estimate (sigma and
/// exponent as fixed).
#[must_use]
pub fn dahl_model(fit: &DahlFit) -> ModelParams {
    let c = &fit.corrected;
    ModelParams::Dahl(DahlParams {
        sigma_n_m: fit.sigma_n_m,
        fc_pos_n: c.fc_pos_n.value.max(0.0),
        fc_neg_n: c.fc_neg_n.value.max(0.0),
        exponent: fit.exponent,
        viscous_n_s_m: c.viscous_n_s_m.value.max(0.0),
        ..DahlParams::default()
    })
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
