//! The limb and the handle as the participant's controller sees them
//! (issue 65): the linear plant and cost its stochastic optimal feedback
//! control ([`super::ofc`]) runs on, along the device's axis.
//!
//! # Model and sources
//! - **Mass.** The hand and the handle move together as one mass (the
//!   caller's: the hand's and the device's).
//! - **Impedance.** The limb pulls the handle towards its equilibrium
//!   point `λ` through its own stiffness `k` and damping `b`:
//!   `F = k (λ - x) - b v`. A spring whose rest position the nervous
//!   system sets is the equilibrium-point account of muscle (Feldman
//!   1986, J. Motor Behavior 18:17-54); the hand's stiffness and damping
//!   are measured ones (Mussa-Ivaldi, Hogan & Bizzi 1985, J. Neurosci.
//!   5:2732-2743; the participant's traits). The impedance acts at once:
//!   it is what holds the handle between the controller's delayed
//!   corrections. It is exactly what [`crate::hand::HandDrive`] renders
//!   (reference `λ`, reference velocity 0), so every device's hand can
//!   carry it.
//! - **Command.** The controller sets the speed `u` of its central command
//!   `ν`; the equilibrium point follows `ν` through two first-order
//!   stages of equal time constant, the muscle-like filter of Todorov
//!   (2005)'s reaching example (Neural Computation 17(5):1084-1108; 40 ms
//!   each, with 10 ms steps: quoted from the paper's example as public
//!   reimplementations use it, the paper's text not at hand here). The
//!   command's noise grows with it (SD `c |u|`: Harris & Wolpert 1998,
//!   Nature 394:780-784; Todorov 2005), so a fast shift scatters more
//!   than a slow one, and holding still adds none.
//! - **Load.** Whatever else pushes on the handle (friction, a stuck
//!   slide, a damper) is one unknown force `d` that the participant's
//!   internal model lets drift (SD `load_drift_n` per step, forgotten
//!   over `load_memory_s`: without forgetting, a load that may wander
//!   without bound has no steady state) and estimates from how the handle
//!   moves under its own force: an unknown disturbance as a state of the
//!   estimator, as in models of online adaptation to unexpected forces
//!   (Crevecoeur, Thonnard & Lefèvre 2020, eNeuro 7(3)). Its estimate
//!   enters the command, so a handle held back is pushed harder until it
//!   moves: a person leaning into a stuck handle, from the estimator, not
//!   written in.
//! - **Senses.** Position, velocity and the hand's own force (`F`), each
//!   with its own noise, all `delay_s` old: the state carries the senses'
//!   past readings, one per step (the delay as extra states, as Todorov
//!   2005 models it; here only the sensed values are carried, not the
//!   whole state, which keeps the solve small).
//! - **Cost.** Per step, the squared distance to the target and the
//!   squared command (effort), as the infinite-horizon model of Qian,
//!   Jiang, Jiang & Mazzoni (2013, Neural Computation 25(3):697-724):
//!   there is no movement time in it, and none is set.
//!
//! The continuous plant is discretised exactly over a step (the matrix
//! exponential), with the equilibrium point held over the step as the
//! hand's drive holds it, so a stiff hand stays stable at 10 ms steps and
//! the model moves as the rendered hand does. Positions are measured from the target: the controller
//! drives the state to zero.

use nalgebra::DMatrix;

use super::ofc::{Cost, Plant};

/// The limb's own states: position from the target (m), velocity (m/s),
/// the equilibrium point (m), its filter's first stage (m), the central
/// command (m), the load (N). The senses' past readings follow.
pub const OWN: usize = 6;
/// Index of the position.
pub const POSITION: usize = 0;
/// Index of the velocity.
pub const VELOCITY: usize = 1;
/// Index of the equilibrium point.
pub const EQUILIBRIUM: usize = 2;
/// Index of the equilibrium point's filter's first stage.
pub const STAGE: usize = 3;
/// Index of the central command.
pub const COMMAND: usize = 4;
/// Index of the load.
pub const LOAD: usize = 5;
/// What the senses read: position, velocity, the hand's force.
pub const SENSED: usize = 3;

/// What the plant and cost are made of. SI units.
#[derive(Debug, Clone, PartialEq)]
pub struct Limb {
    /// Hand and handle, kg.
    pub mass_kg: f64,
    /// The limb's stiffness, N/m.
    pub stiffness_n_m: f64,
    /// The limb's damping, N s/m.
    pub damping_n_s_m: f64,
    /// Each stage of the muscle's filter, s.
    pub muscle_tau_s: f64,
    /// The controller's step, s.
    pub step_s: f64,
    /// The senses' delay, s (rounded to whole steps).
    pub delay_s: f64,
    /// The command's own noise: SD per unit of command.
    pub command_noise: f64,
    /// Additive noise of the central command per step, m.
    pub command_sd_m: f64,
    /// The senses' noise: position (m), velocity (m/s), force (N).
    pub sense_sd: [f64; 3],
    /// How far the internal model lets the load drift per step, N.
    pub load_drift_n: f64,
    /// Over how long the internal model forgets a load (its time
    /// constant), s.
    pub load_memory_s: f64,
    /// The cost's weight on the squared distance, 1/m².
    pub distance_weight: f64,
    /// The cost's weight on the squared command, s²/m².
    pub effort_weight: f64,
}

impl Limb {
    /// Whole steps of sensory delay.
    #[must_use]
    pub fn delay_steps(&self) -> usize {
        let steps = (self.delay_s / self.step_s).round();
        #[expect(
            clippy::cast_possible_truncation,
            clippy::cast_sign_loss,
            reason = "clamped to a small non-negative count"
        )]
        let steps = steps.clamp(0.0, 100.0) as usize;
        steps
    }

    /// The size of the state: the limb's own, and the senses' readings
    /// of each step of delay.
    #[must_use]
    pub fn states(&self) -> usize {
        OWN + SENSED * self.delay_steps()
    }

    /// The senses' rows over the limb's own states: position, velocity,
    /// and the hand's force `k (λ - x) - b v`.
    fn senses(&self) -> DMatrix<f64> {
        let mut h = DMatrix::zeros(SENSED, OWN);
        h[(0, POSITION)] = 1.0;
        h[(1, VELOCITY)] = 1.0;
        h[(2, EQUILIBRIUM)] = self.stiffness_n_m;
        h[(2, POSITION)] = -self.stiffness_n_m;
        h[(2, VELOCITY)] = -self.damping_n_s_m;
        h
    }

    /// The limb's own states over one step, `(A, B)`.
    ///
    /// Each part exactly over the step (the matrix exponential), with what
    /// drives it held, as the device renders it: the mechanics with the
    /// equilibrium point and the load held at their values at the step's
    /// start (the hand's drive changes once a step); the muscle's filter
    /// with the command held.
    fn own_step(&self) -> (DMatrix<f64>, DMatrix<f64>) {
        let (m, k, b, tau, dt) = (
            self.mass_kg.max(1e-6),
            self.stiffness_n_m,
            self.damping_n_s_m,
            self.muscle_tau_s.max(1e-6),
            self.step_s,
        );
        // Mechanics over (x, v, λ, d).
        let mut mech = DMatrix::zeros(4, 4);
        mech[(0, 1)] = 1.0;
        mech[(1, 0)] = -k / m;
        mech[(1, 1)] = -b / m;
        mech[(1, 2)] = k / m;
        mech[(1, 3)] = 1.0 / m;
        let mech = (mech * dt).exp();
        // The muscle's filter over (λ, its stage, ν, u).
        let mut filter = DMatrix::zeros(4, 4);
        filter[(0, 0)] = -1.0 / tau;
        filter[(0, 1)] = 1.0 / tau;
        filter[(1, 1)] = -1.0 / tau;
        filter[(1, 2)] = 1.0 / tau;
        filter[(2, 3)] = 1.0;
        let filter = (filter * dt).exp();
        let mut a = DMatrix::zeros(OWN, OWN);
        let mut bu = DMatrix::zeros(OWN, 1);
        let mech_cols = [POSITION, VELOCITY, EQUILIBRIUM, LOAD];
        for (r, &i) in [POSITION, VELOCITY].iter().enumerate() {
            for (c, &j) in mech_cols.iter().enumerate() {
                a[(i, j)] = mech[(r, c)];
            }
        }
        let filter_states = [EQUILIBRIUM, STAGE, COMMAND];
        for (r, &i) in filter_states.iter().enumerate() {
            for (c, &j) in filter_states.iter().enumerate() {
                a[(i, j)] = filter[(r, c)];
            }
            bu[(i, 0)] = filter[(r, 3)];
        }
        a[(LOAD, LOAD)] = (-dt / self.load_memory_s.max(dt)).exp();
        (a, bu)
    }

    /// The plant and the cost (see the module docs).
    #[must_use]
    pub fn plant(&self) -> (Plant, Cost) {
        let n = self.states();
        let delay = self.delay_steps();
        let (own_a, own_b) = self.own_step();
        let senses = self.senses();
        let mut a = DMatrix::zeros(n, n);
        a.view_mut((0, 0), (OWN, OWN)).copy_from(&own_a);
        let mut b = DMatrix::zeros(n, 1);
        b.view_mut((0, 0), (OWN, 1)).copy_from(&own_b);
        // The newest reading is the present's; each older one is the one
        // before it, a step later.
        if delay > 0 {
            a.view_mut((OWN, 0), (SENSED, OWN)).copy_from(&senses);
            for i in OWN + SENSED..n {
                a[(i, i - SENSED)] = 1.0;
            }
        }
        let mut process = DMatrix::zeros(n, n);
        process[(COMMAND, COMMAND)] = self.command_sd_m.powi(2);
        process[(LOAD, LOAD)] = self.load_drift_n.powi(2);
        // The senses read the oldest reading (the present, undelayed).
        let mut h = DMatrix::zeros(SENSED, n);
        if delay > 0 {
            for i in 0..SENSED {
                h[(i, n - SENSED + i)] = 1.0;
            }
        } else {
            h.view_mut((0, 0), (SENSED, OWN)).copy_from(&senses);
        }
        let sensor = DMatrix::from_diagonal(&nalgebra::DVector::from_iterator(
            SENSED,
            self.sense_sd.iter().map(|s| s * s),
        ));
        let mut q = DMatrix::zeros(n, n);
        q[(POSITION, POSITION)] = self.distance_weight;
        let plant = Plant {
            a,
            b,
            control_noise: vec![self.command_noise],
            process,
            h,
            sensor,
            internal: DMatrix::zeros(n, n),
        };
        let cost = Cost {
            q,
            r: DMatrix::from_element(1, 1, self.effort_weight),
        };
        (plant, cost)
    }

    /// What the senses read of the limb's own states `own` now (before
    /// their delay and noise): position, velocity, the hand's force.
    #[must_use]
    pub fn sense(&self, own: &[f64; OWN]) -> [f64; SENSED] {
        let force = self.stiffness_n_m * (own[EQUILIBRIUM] - own[POSITION])
            - self.damping_n_s_m * own[VELOCITY];
        [own[POSITION], own[VELOCITY], force]
    }
}

#[cfg(test)]
mod tests {
    use nalgebra::DVector;

    use super::super::ofc::{Estimate, solve};
    use super::*;

    /// Todorov (2005)'s example's filter and step, a 50 ms delay, a hand
    /// of 500 N/m and 20 N s/m on a 1 kg handle; the noise small, the
    /// weights free (these tests check the plant, not the participant).
    fn limb() -> Limb {
        Limb {
            mass_kg: 1.0,
            stiffness_n_m: 500.0,
            damping_n_s_m: 20.0,
            muscle_tau_s: 0.04,
            step_s: 0.01,
            delay_s: 0.05,
            command_noise: 0.0,
            command_sd_m: 1e-6,
            sense_sd: [1e-5, 1e-4, 1e-3],
            load_drift_n: 0.01,
            load_memory_s: 10.0,
            distance_weight: 1e4,
            effort_weight: 1e-2,
        }
    }

    /// Runs the loop for `seconds` from `start_m` from the target, with a
    /// `load_n` on the handle the estimate does not know of at first:
    /// the true plant is the model's own, noise-free, the load entering
    /// as a force. Returns each step's true state and the last estimate.
    fn run(start_m: f64, load_n: f64, seconds: f64) -> (Vec<DVector<f64>>, Estimate) {
        let l = limb();
        let (plant, cost) = l.plant();
        let gains = solve(&plant, &cost).unwrap();
        let n = l.states();
        // At rest at the start: the equilibrium point, its stage and the
        // command there too, and the senses' past readings of it.
        let mut x = DVector::zeros(n);
        for i in [POSITION, EQUILIBRIUM, STAGE, COMMAND] {
            x[i] = start_m;
        }
        for d in 0..l.delay_steps() {
            x[OWN + SENSED * d] = start_m;
        }
        let mut est = Estimate(x.clone());
        // The load is the world's: the true state's load is held at it.
        x[LOAD] = load_n;
        let zero = DVector::zeros(n);
        let mut states = Vec::new();
        #[expect(
            clippy::cast_possible_truncation,
            clippy::cast_sign_loss,
            reason = "a short run"
        )]
        for _ in 0..(seconds / l.step_s) as usize {
            let u = est.command(&gains);
            let y = &plant.h * &x;
            est.step(&plant, &gains, &u, &y, &zero);
            x = &plant.a * &x + &plant.b * &u;
            x[LOAD] = load_n;
            states.push(x.clone());
        }
        (states, est)
    }

    /// A reach of 24 mm without noise: the handle comes to the target and
    /// stays, with no movement time set anywhere; its primary movement
    /// (until the velocity first changes sign) has one peak of speed, as
    /// reaches have.
    #[test]
    fn a_reach_ends_on_the_target_with_one_peak_of_speed() {
        let (states, _) = run(-0.024, 0.0, 3.0);
        let last = states.last().unwrap();
        assert!(last[POSITION].abs() < 1e-5, "{} m off", last[POSITION]);
        let v: Vec<f64> = states.iter().map(|s| s[VELOCITY]).collect();
        let start = v.iter().position(|&v| v > 0.0).unwrap();
        let end = start
            + v[start..]
                .iter()
                .position(|&v| v <= 0.0)
                .unwrap_or(v.len() - start);
        let primary = &v[start..end];
        let peaks = (1..primary.len() - 1)
            .filter(|&i| primary[i] >= primary[i - 1] && primary[i] > primary[i + 1])
            .count();
        assert_eq!(peaks, 1, "{primary:?}");
        let reached = states[end - 1][POSITION];
        assert!(reached > -0.012, "{reached} m after the primary movement");
    }

    /// A handle held back by a load the participant did not expect (2 N
    /// against the reach): the estimate of the load grows from the handle
    /// lagging, the equilibrium point is pushed that much further, and
    /// the handle comes to rest inside the narrowest target's tolerance
    /// (0.5 mm either way; the model's forgetting leaves a small offset).
    #[test]
    fn a_load_is_estimated_and_pushed_against_until_the_target_is_reached() {
        let load = -2.0;
        let (states, est) = run(-0.024, load, 6.0);
        let last = states.last().unwrap();
        assert!(last[POSITION].abs() < 5e-4, "{} m off", last[POSITION]);
        assert!(last[VELOCITY].abs() < 1e-5, "{} m/s", last[VELOCITY]);
        let force = limb().stiffness_n_m * (last[EQUILIBRIUM] - last[POSITION]);
        assert!((force + load).abs() < 0.01, "force {force}");
        assert!(
            (est.0[LOAD] - load).abs() < 0.1,
            "load estimated {}",
            est.0[LOAD]
        );
    }

    #[test]
    fn the_senses_read_the_reading_a_delay_old() {
        let l = limb();
        let (plant, _) = l.plant();
        assert_eq!(l.delay_steps(), 5);
        assert_eq!(plant.a.nrows(), OWN + 15);
        assert_eq!(plant.h[(0, OWN + 12)], 1.0);
        assert_eq!(plant.h.row(0).sum(), 1.0);
        // The newest reading is the present's force.
        assert_eq!(plant.a[(OWN + 2, EQUILIBRIUM)], 500.0);
    }

    /// The exact discretisation: with no command, the hand alone on the
    /// mass is a damped spring; after a step its position is that of the
    /// closed form (m 1, k 500, b 20: ζ 0.447, ω_d 20 rad/s).
    #[test]
    fn a_step_of_the_plant_is_the_damped_springs_closed_form() {
        let l = limb();
        let (a, _) = l.own_step();
        let mut x = DVector::zeros(OWN);
        x[POSITION] = 0.01;
        let (sigma, wd) = (10.0_f64, 20.0_f64);
        let mut t = 0.0;
        for _ in 0..10 {
            x = &a * x;
            t += l.step_s;
        }
        let want = 0.01 * (-sigma * t).exp() * ((wd * t).cos() + sigma / wd * (wd * t).sin());
        assert!(
            (x[POSITION] - want).abs() < 1e-12,
            "{} vs {want}",
            x[POSITION]
        );
    }
}
