//! The Dahl model by Levenberg-Marquardt, refined on the errors-in-variables
//! objective, and the protocol `model` block it gives.

use levenberg_marquardt::{LeastSquaresProblem, LevenbergMarquardt};
use nalgebra::{DVector, Dyn, OMatrix, Owned, U4, VecStorage, Vector4};
use serde::Serialize;

use super::{Estimate, Noise, Record, count, finite_or_refused, fit_karnopp, noise_of};
use crate::friction::dahl::{Dahl, DahlParams};
use crate::friction::{ForceLimit, Input, ModelParams};
use crate::problem::Problem;

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
) -> Result<DahlFit, Problem> {
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
    let singular = || Problem::new(&rec.file, "the Dahl fit's Jacobian is singular");
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
        Ok::<_, Problem>(DahlEstimates {
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
