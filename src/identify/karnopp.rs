//! The Karnopp form by least squares, with the errors-in-variables
//! correction of STUDIES 1e, and the protocol `model` block it gives.

use nalgebra::{SMatrix, SVector};
use serde::Serialize;

use super::{Estimate, MIN_PER_DIRECTION, Noise, Record, count, finite_or_refused, noise_of};
use crate::friction::ModelParams;
use crate::friction::karnopp::KarnoppParams;
use crate::problem::Problem;

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
) -> Result<KarnoppFit, Problem> {
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
        Problem::new(
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

fn karnopp_rows(rec: &Record, dv: f64) -> Result<Rows, Problem> {
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
            return Err(Problem::new(
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
