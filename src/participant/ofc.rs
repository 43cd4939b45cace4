//! Stochastic optimal feedback control with signal-dependent noise, in
//! steady state (issue 65): the controller and the estimator the simulated
//! participant's aimed movements are to run on.
//!
//! # Mechanism and source
//! Todorov (2005), "Stochastic optimal control and estimation methods
//! adapted to the noise characteristics of the sensorimotor system",
//! Neural Computation 17(5):1084-1108, extends linear-quadratic-gaussian
//! control to the noise of the sensorimotor system. In discrete time, with
//! state `x`, command `u`, observation `y`:
//!
//! - plant: `x' = A x + B u + B Σ_i ε_i c_i u_i e_i + ξ`: the command's
//!   own noise, of SD `c_i |u_i|` in control `i` (signal-dependent motor
//!   noise: Harris & Wolpert 1998), beside additive noise `ξ ~ N(0, Ω_ξ)`;
//! - sensing: `y = H x + ω`, `ω ~ N(0, Ω_ω)` (a sensory delay is states
//!   of the plant that carry the past: the caller's matrices hold it);
//! - estimate: `x̂' = A x̂ + B u + K (y - H x̂) + η`, with internal noise
//!   `η ~ N(0, Ω_η)`;
//! - command: `u = -L x̂`;
//! - cost per step: `x' Q x + u' R u`.
//!
//! The controller `L` optimal for a given filter `K`, and the filter `K`
//! optimal for a given controller `L`, depend on each other once the noise
//! depends on the command; Todorov's algorithm alternates the two (a
//! backward pass for `L`, a forward pass for `K`) and converges. Here every
//! pass runs to its fixed point, which gives the steady-state (infinite
//! horizon) controller and filter: applied continuously, they take the
//! state to the target and hold it there, with no movement duration set in
//! advance (the infinite-horizon formulation of Qian, Jiang, Jiang &
//! Mazzoni 2013, Neural Computation 25(3):697-724). Nothing here knows
//! about targets, widths or Fitts' law: the task is the caller's `Q`.
//!
//! Pure: no clock, no randomness (noise draws are the caller's).

use nalgebra::{DMatrix, DVector};

/// A linear plant with Todorov's noise model (see the module docs). `m`
/// states, `p` controls, `k` observations.
#[derive(Debug, Clone, PartialEq)]
pub struct Plant {
    /// `A`, m × m.
    pub a: DMatrix<f64>,
    /// `B`, m × p.
    pub b: DMatrix<f64>,
    /// `c_i`: the SD of control `i`'s noise per unit of its command
    /// (length p).
    pub control_noise: Vec<f64>,
    /// `Ω_ξ`, m × m: the plant's additive noise.
    pub process: DMatrix<f64>,
    /// `H`, k × m.
    pub h: DMatrix<f64>,
    /// `Ω_ω`, k × k: the senses' noise.
    pub sensor: DMatrix<f64>,
    /// `Ω_η`, m × m: the estimator's internal noise.
    pub internal: DMatrix<f64>,
}

/// The quadratic cost per step.
#[derive(Debug, Clone, PartialEq)]
pub struct Cost {
    /// `Q`, m × m, on the state.
    pub q: DMatrix<f64>,
    /// `R`, p × p, on the command.
    pub r: DMatrix<f64>,
}

/// The steady-state controller and filter, and the covariances they hold
/// the loop at.
#[derive(Debug, Clone, PartialEq)]
pub struct Gains {
    /// `L`, p × m: the command is `-L x̂`.
    pub control: DMatrix<f64>,
    /// `K`, m × k.
    pub filter: DMatrix<f64>,
    /// The estimation error's covariance `E[e e']`, `e = x - x̂`, m × m,
    /// of the one-step prediction.
    pub error: DMatrix<f64>,
}

/// Why no gains came out.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum OfcError {
    /// The matrices do not fit together.
    #[error("optimal control: {0}")]
    Shape(String),
    /// A matrix to invert was singular.
    #[error("optimal control: {0} is singular")]
    Singular(&'static str),
    /// A pass did not settle: the plant is not stabilisable, or its
    /// command's noise is too large for any controller to hold it.
    #[error("optimal control: the {0} did not converge in {1} iterations")]
    NoConvergence(&'static str, usize),
}

/// Relative change below which a pass has settled. 1e-7: the gains to
/// within about 5e-5 (a slow mode, the load's memory, converges at 0.998 a step),
/// far finer than any noise they meet; 1e-10 took 13 times the steps.
const TOLERANCE: f64 = 1e-7;
/// Most steps of one pass.
const MAX_STEPS: usize = 100_000;
/// Most alternations of the two passes.
const MAX_ALTERNATIONS: usize = 200;

/// Whether `new` is within [`TOLERANCE`] of `old`, relative to `scale`'s
/// size (a matrix that tends to zero settles against its scale).
fn settled(old: &DMatrix<f64>, new: &DMatrix<f64>, scale: f64) -> bool {
    (old - new).norm() <= TOLERANCE * scale.max(1e-300)
}

/// The forward pass's second moments: the estimation error's `E[e e']`,
/// the estimate's `E[x̂ x̂']`, and their cross moment.
#[derive(Debug, Clone)]
struct Moments {
    e: DMatrix<f64>,
    x: DMatrix<f64>,
    xe: DMatrix<f64>,
}

impl Plant {
    fn check(&self, cost: &Cost) -> Result<(), OfcError> {
        let (m, p, k) = (self.a.nrows(), self.b.ncols(), self.h.nrows());
        let shapes = [
            ("A", self.a.shape(), (m, m)),
            ("B", self.b.shape(), (m, p)),
            ("Ω_ξ", self.process.shape(), (m, m)),
            ("H", self.h.shape(), (k, m)),
            ("Ω_ω", self.sensor.shape(), (k, k)),
            ("Ω_η", self.internal.shape(), (m, m)),
            ("Q", cost.q.shape(), (m, m)),
            ("R", cost.r.shape(), (p, p)),
        ];
        for (name, got, want) in shapes {
            if got != want {
                return Err(OfcError::Shape(format!(
                    "{name} is {}×{}, not {}×{}",
                    got.0, got.1, want.0, want.1
                )));
            }
        }
        if self.control_noise.len() != p {
            return Err(OfcError::Shape(format!(
                "{} control noise SDs for {p} controls",
                self.control_noise.len()
            )));
        }
        Ok(())
    }

    /// `Σ_i c_i² B e_i e_i' M e_i e_i' B'`: the covariance the command's
    /// noise adds, for `M` the second moment of the command.
    fn command_noise(&self, command_moment: &DMatrix<f64>) -> DMatrix<f64> {
        let mut d = DMatrix::zeros(self.b.ncols(), self.b.ncols());
        for (i, c) in self.control_noise.iter().enumerate() {
            d[(i, i)] = c * c * command_moment[(i, i)];
        }
        &self.b * d * self.b.transpose()
    }

    /// The filter that is optimal for controller `l`, at its fixed point,
    /// and the prediction error's covariance (Todorov 2005's forward pass,
    /// run until it settles).
    /// Starts from `moments` (the last pass's fixed point, when there
    /// was one: the passes of successive alternations settle near each
    /// other) and leaves its own fixed point there.
    fn filter_for(
        &self,
        l: &DMatrix<f64>,
        moments: &mut Moments,
    ) -> Result<(DMatrix<f64>, DMatrix<f64>), OfcError> {
        let m = self.a.nrows();
        let closed = &self.a - &self.b * l;
        let Moments {
            mut e,
            mut x,
            mut xe,
        } = moments.clone();
        let mut k = DMatrix::zeros(m, self.h.nrows());
        for _ in 0..MAX_STEPS {
            let innovation = &self.h * &e * self.h.transpose() + &self.sensor;
            let inverse = innovation
                .try_inverse()
                .ok_or(OfcError::Singular("the innovation's covariance"))?;
            let new_k = &self.a * &e * self.h.transpose() * inverse;
            let kh = &new_k * &self.h;
            let gap = &self.a - &kh;
            let new_e = &self.internal
                + &self.process
                + &gap * &e * self.a.transpose()
                + self.command_noise(&(l * &x * l.transpose()));
            let new_x = &self.internal
                + &kh * &e * self.a.transpose()
                + &closed * &x * closed.transpose()
                + &closed * &xe * kh.transpose()
                + &kh * xe.transpose() * closed.transpose();
            let new_xe = &closed * &xe * gap.transpose() - &self.internal;
            let done =
                settled(&k, &new_k, new_k.norm().max(1.0)) && settled(&e, &new_e, new_e.norm());
            (k, e, x, xe) = (new_k, new_e, new_x, new_xe);
            if !e.iter().all(|v| v.is_finite()) {
                break;
            }
            if done {
                *moments = Moments {
                    e: e.clone(),
                    x,
                    xe,
                };
                return Ok((k, e));
            }
        }
        Err(OfcError::NoConvergence("filter", MAX_STEPS))
    }

    /// The controller that is optimal for filter `k`, at its fixed point
    /// (Todorov 2005's backward pass, run until it settles), from and to
    /// `to_go` as [`Plant::filter_for`] does with its moments.
    fn controller_for(
        &self,
        cost: &Cost,
        k: &DMatrix<f64>,
        to_go: &mut (DMatrix<f64>, DMatrix<f64>),
    ) -> Result<DMatrix<f64>, OfcError> {
        let m = self.a.nrows();
        let gap = &self.a - k * &self.h;
        let (mut sx, mut se) = to_go.clone();
        let mut l = DMatrix::zeros(self.b.ncols(), m);
        for _ in 0..MAX_STEPS {
            let bt = self.b.transpose();
            let mut weight = &cost.r + &bt * &sx * &self.b;
            let both = &bt * (&sx + &se) * &self.b;
            for (i, c) in self.control_noise.iter().enumerate() {
                weight[(i, i)] += c * c * both[(i, i)];
            }
            let new_l = weight
                .try_inverse()
                .ok_or(OfcError::Singular("the command's weight"))?
                * &bt
                * &sx
                * &self.a;
            let new_se = self.a.transpose() * &sx * &self.b * &new_l + gap.transpose() * &se * &gap;
            let new_sx = &cost.q + self.a.transpose() * &sx * (&self.a - &self.b * &new_l);
            // Settled when the gain and the cost-to-go have stopped
            // changing; the first steps can leave the gain at zero while
            // the cost on the position works its way to the command.
            let done = settled(&l, &new_l, new_l.norm()) && settled(&sx, &new_sx, new_sx.norm());
            (l, sx, se) = (new_l, new_sx, new_se);
            if !sx.iter().all(|v| v.is_finite()) {
                break;
            }
            if done {
                *to_go = (sx, se);
                return Ok(l);
            }
        }
        Err(OfcError::NoConvergence("controller", MAX_STEPS))
    }
}

/// The steady-state controller and filter of `plant` under `cost`,
/// optimal with respect to each other (see the module docs).
///
/// # Errors
/// Matrices that do not fit, a singular weight or innovation, or passes
/// that do not settle.
pub fn solve(plant: &Plant, cost: &Cost) -> Result<Gains, OfcError> {
    plant.check(cost)?;
    let m = plant.a.nrows();
    // Todorov's initialisation: the filter of the loop with no command
    // (L = 0), then alternate.
    let mut l = DMatrix::zeros(plant.b.ncols(), m);
    let mut moments = Moments {
        e: DMatrix::identity(m, m) * 1e-6,
        x: DMatrix::zeros(m, m),
        xe: DMatrix::zeros(m, m),
    };
    let mut to_go = (cost.q.clone(), DMatrix::zeros(m, m));
    for _ in 0..MAX_ALTERNATIONS {
        let (k, _) = plant.filter_for(&l, &mut moments)?;
        let new_l = plant.controller_for(cost, &k, &mut to_go)?;
        if settled(&l, &new_l, new_l.norm()) {
            let (filter, error) = plant.filter_for(&new_l, &mut moments)?;
            return Ok(Gains {
                control: new_l,
                filter,
                error,
            });
        }
        l = new_l;
    }
    Err(OfcError::NoConvergence(
        "alternation of controller and filter",
        MAX_ALTERNATIONS,
    ))
}

/// The participant's running estimate of the plant's state.
#[derive(Debug, Clone, PartialEq)]
pub struct Estimate(pub DVector<f64>);

impl Estimate {
    /// The command for the estimate: `-L x̂`.
    #[must_use]
    pub fn command(&self, gains: &Gains) -> DVector<f64> {
        -(&gains.control * &self.0)
    }

    /// One step: the command `u` that was sent (without its noise, which
    /// the participant does not know), the observation `y`, and a draw of
    /// the internal noise `eta`.
    pub fn step(
        &mut self,
        plant: &Plant,
        gains: &Gains,
        u: &DVector<f64>,
        y: &DVector<f64>,
        eta: &DVector<f64>,
    ) {
        let innovation = y - &plant.h * &self.0;
        self.0 = &plant.a * &self.0 + &plant.b * u + &gains.filter * innovation + eta;
    }
}

#[cfg(test)]
mod tests {
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;
    use rand_distr::{Distribution, StandardNormal};

    use super::*;

    /// How close a settled pass is to its fixed point, relative: a pass
    /// stops when a step changes it by less than [`TOLERANCE`]; these
    /// plants converge geometrically at rates well under 0.99, so the
    /// distance left is under a hundred such steps.
    const SETTLED: f64 = 100.0 * TOLERANCE;

    fn scalar(v: f64) -> DMatrix<f64> {
        DMatrix::from_element(1, 1, v)
    }

    /// A scalar plant `x' = a x + b u`, sensed with noise of variance
    /// `sensor`, driven by noise of variance `process`.
    fn plant(a: f64, b: f64, c: f64, process: f64, sensor: f64) -> Plant {
        Plant {
            a: scalar(a),
            b: scalar(b),
            control_noise: vec![c],
            process: scalar(process),
            h: scalar(1.0),
            sensor: scalar(sensor),
            internal: scalar(0.0),
        }
    }

    fn cost(q: f64, r: f64) -> Cost {
        Cost {
            q: scalar(q),
            r: scalar(r),
        }
    }

    /// With no noise on the command, the controller is the classical
    /// one: for `x' = x + b u` the discrete Riccati equation
    /// `P = q + P - b² P² / (r + b² P)` gives
    /// `P = (q b² + sqrt(q² b⁴ + 4 q r b²)) / (2 b²)` and
    /// `L = b P / (r + b² P)`.
    #[test]
    fn without_command_noise_the_controller_is_the_riccati_equations() {
        let (b, q, r) = (0.1, 1.0, 0.01);
        let gains = solve(&plant(1.0, b, 0.0, 1e-6, 1e-6), &cost(q, r)).unwrap();
        let p = (q * b * b + (q * q * b.powi(4) + 4.0 * q * r * b * b).sqrt()) / (2.0 * b * b);
        let l = b * p / (r + b * b * p);
        assert!(
            (gains.control[(0, 0)] - l).abs() < SETTLED * l,
            "{} vs {l}",
            gains.control[(0, 0)]
        );
    }

    /// The filter of a sensed random walk (`x' = x + ξ`, `y = x + ω`) is
    /// the classical Kalman filter: the prediction's error variance
    /// solves `P = W + P V / (P + V)`, so `P = (W + sqrt(W² + 4 W V)) / 2`,
    /// and `K = P / (P + V)`.
    #[test]
    fn the_filter_of_a_sensed_random_walk_is_kalmans() {
        let (w, v) = (0.04, 0.25);
        let gains = solve(&plant(1.0, 1.0, 0.0, w, v), &cost(0.0, 1.0)).unwrap();
        let p = f64::midpoint(w, (w * w + 4.0 * w * v).sqrt());
        assert!(
            (gains.error[(0, 0)] - p).abs() < SETTLED * p,
            "{}",
            gains.error
        );
        let k = p / (p + v);
        assert!((gains.filter[(0, 0)] - k).abs() < SETTLED * k);
    }

    /// The estimator's error against the noise it was given: 200,000
    /// steps of the random walk above, estimated with the solved filter;
    /// the error's variance is the solver's `P` (SE of a variance over
    /// 200,000 correlated draws: well under 2 %).
    #[test]
    fn the_estimators_error_has_the_variance_of_the_noise_it_was_given() {
        let (w, v) = (0.04, 0.25);
        let p = plant(1.0, 1.0, 0.0, w, v);
        let gains = solve(&p, &cost(0.0, 1.0)).unwrap();
        let mut rng = ChaCha8Rng::seed_from_u64(65);
        let mut draw = |sd: f64| {
            let z: f64 = StandardNormal.sample(&mut rng);
            sd * z
        };
        let (mut x, mut est) = (0.0, Estimate(DVector::from_element(1, 0.0)));
        let zero = DVector::from_element(1, 0.0);
        let n = 200_000;
        let mut sum = 0.0;
        for _ in 0..n {
            let y = DVector::from_element(1, x + draw(v.sqrt()));
            est.step(&p, &gains, &zero, &y, &zero);
            x += draw(w.sqrt());
            sum += (x - est.0[0]).powi(2);
        }
        let variance = sum / f64::from(n);
        let want = gains.error[(0, 0)];
        assert!((variance / want - 1.0).abs() < 0.05, "{variance} vs {want}");
    }

    /// The controller's response to a step, without noise: sensed
    /// perfectly, the estimate is the state one step on, so the loop is
    /// `x' = (1 - b L) x`: after `n` steps `(1 - b L)^n` of the step.
    #[test]
    fn a_step_decays_as_the_closed_loop_says_without_noise() {
        let p = plant(1.0, 0.1, 0.0, 1e-12, 1e-12);
        let gains = solve(&p, &cost(1.0, 0.01)).unwrap();
        let l = gains.control[(0, 0)];
        let (mut x, mut est) = (1.0, Estimate(DVector::from_element(1, 1.0)));
        let zero = DVector::from_element(1, 0.0);
        for n in 1..=20 {
            let u = est.command(&gains);
            let y = DVector::from_element(1, x);
            est.step(&p, &gains, &u, &y, &zero);
            x += 0.1 * u[0];
            let want = (1.0 - 0.1 * l).powi(n);
            assert!((x - want).abs() < 1e-6, "step {n}: {x} vs {want}");
            assert!((est.0[0] - x).abs() < 1e-6);
        }
    }

    /// Noise that grows with the command makes the controller gentler
    /// (Todorov 2005: the optimal response to signal-dependent noise is a
    /// smaller command), and more so the larger the noise.
    #[test]
    fn command_noise_makes_the_controller_gentler() {
        let gain = |c: f64| {
            solve(&plant(1.0, 0.1, c, 1e-6, 1e-4), &cost(1.0, 0.01))
                .unwrap()
                .control[(0, 0)]
        };
        let (none, some, more) = (gain(0.0), gain(0.5), gain(1.0));
        assert!(none > some && some > more, "{none} {some} {more}");
    }

    #[test]
    fn matrices_that_do_not_fit_are_refused_with_their_names() {
        let mut p = plant(1.0, 0.1, 0.0, 0.0, 1.0);
        p.h = DMatrix::zeros(1, 2);
        let e = solve(&p, &cost(1.0, 1.0)).unwrap_err();
        assert_eq!(e.to_string(), "optimal control: H is 1×2, not 1×1");
    }
}
