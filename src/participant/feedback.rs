//! Aimed movements in the Fitts task (issue 65): the limb of
//! [`super::limb`] under the stochastic optimal feedback controller of
//! [`super::ofc`], clicking from its own estimate ([`super::click`]).
//!
//! # Mechanism and sources
//! - **Why this model.** Of the two candidates the issue names, the
//!   stochastic optimal feedback controller (Todorov & Jordan 2002, Nature
//!   Neuroscience 5:1226-1235; Todorov 2005) corrects continuously, from
//!   delayed and noisy senses, through a noisy command: the mechanisms
//!   whose absence issue 44's model showed (corrections only from rest, a
//!   click without estimation error). Elliott et al.'s two-component model
//!   describes the same online control in words and phases, not as a
//!   mechanism one can simulate without choosing its phases' durations.
//! - **The loop.** Every 10 ms step the participant reads its senses (the
//!   handle's position and velocity and its own force, a delay old, each
//!   with its noise), updates its estimate, and sets its command; its
//!   equilibrium point follows the command through the muscle's filter and
//!   the limb's impedance pulls the handle towards it
//!   ([`crate::hand::HandDrive`]). The controller aims at the lit target's
//!   centre; nothing sets a movement's duration, peak speed or path.
//! - **Targets.** The controller's states are measured from the lit
//!   target. A hit lights the other target: once the button is released,
//!   the participant's estimate is shifted to the new target's frame and
//!   the same controller takes the handle there.
//! - **Clicks.** At every step, the participant predicts where the cursor
//!   will be when a press started now registers (its estimate of position
//!   and velocity, one button press ahead) and the SD of that prediction
//!   (its estimator's error covariance); it presses once the probability
//!   that the cursor is inside the target reaches its criterion
//!   ([`super::click`]). After a miss it sees the target still lit, a
//!   visual feedback delay later ([`super::Traits::feedback_s`]; Keele &
//!   Posner 1968; Carlton 1981), before it may press again.
//! - **Button.** A click is a press and a release of
//!   [`super::Traits::button_s`] each (the Keystroke-Level Model's `B`,
//!   0.1 s: Card, Moran & Newell 1980, CACM 23(7):396-410): the click
//!   registers when the press ends.
//!
//! Friction and viscosity change time and errors physically: the handle's
//! load is whatever the device renders, which the estimator learns as it
//! goes (a stuck handle is pushed harder until it breaks away; a damper
//! slows the handle behind the equilibrium point).

use std::collections::VecDeque;
use std::sync::Arc;

use nalgebra::{DMatrix, DVector};

use super::Traits;
use super::click;
use super::limb::{COMMAND, EQUILIBRIUM, LOAD, Limb, OWN, POSITION, SENSED, STAGE, VELOCITY};
use super::movement::Step;
use super::ofc::{Estimate, Gains, OfcError, Plant, solve};
use crate::hand::HandDrive;

/// The controller's step, s: Todorov (2005)'s example's.
pub const STEP_S: f64 = 0.01;
/// Each stage of the muscle's filter, s: Todorov (2005)'s example's.
pub const MUSCLE_TAU_S: f64 = 0.04;

/// Above this estimated speed the participant holds the handle as moving,
/// m/s (free: the speed below which the submovement hand counts the
/// handle at rest, `movement.rs`).
pub const MOVING_M_S: f64 = 0.01;

/// How many past commands the participant's uncertainty counts: 1 s of
/// steps, by which a command's noise has long been taken in by the
/// estimate (the error's dynamics `A - K H` decay within a few hundred
/// milliseconds).
pub const MEMORY_STEPS: usize = 100;

/// The senses' delay, s: Todorov (2005)'s example's 50 ms, for all three
/// senses (proprioception's; vision's longer delay is not modelled
/// separately: a simplification, stated).
pub const SENSE_DELAY_S: f64 = 0.05;
/// The velocity sense's noise, m/s (SD). No source at hand: free, a tenth
/// of a typical 0.05 m/s hand speed on this slide.
pub const VELOCITY_SD_M_S: f64 = 0.005;
/// The force sense's noise, N (SD). Free: the force Weber fraction's 7 %
/// (Jones 1989) of a 1.5 N force.
pub const FORCE_SD_N: f64 = 0.1;
/// How far the internal model lets the load drift per step, N. Free: 0.05
/// N per 10 ms lets it learn a few newtons within a few hundred
/// milliseconds.
pub const LOAD_DRIFT_N: f64 = 0.05;
/// Over how long the internal model forgets a load, s. Free: 10 s, the
/// limb's own tests' (`limb.rs`). At 1 s the forgetting left the estimate
/// of a 3.7 N friction 0.4 N short, and the hand stuck 1.2 mm short of a
/// target whose tolerance is 0.5 mm, for ever (every 1 mm tolerance test
/// under friction timed out): a mechanism's failure, not a row's number.
pub const LOAD_MEMORY_S: f64 = 10.0;
/// Additive noise of the central command per step, m. Free, small beside
/// the command's own noise.
pub const COMMAND_SD_M: f64 = 1e-5;

impl Traits {
    /// The participant's limb on a handle of `handle_kg`
    /// ([`super::limb`]): its traits, and the constants above.
    #[must_use]
    pub fn limb(&self, handle_kg: f64) -> Limb {
        Limb {
            mass_kg: self.hand_mass_kg + handle_kg,
            stiffness_n_m: self.hand_stiffness_n_m,
            damping_n_s_m: self.hand_damping_n_s_m,
            muscle_tau_s: MUSCLE_TAU_S,
            step_s: STEP_S,
            delay_s: SENSE_DELAY_S,
            command_noise: self.command_noise,
            command_sd_m: COMMAND_SD_M,
            sense_sd: [self.position_sd_m, VELOCITY_SD_M_S, FORCE_SD_N],
            load_drift_n: LOAD_DRIFT_N,
            load_memory_s: LOAD_MEMORY_S,
            distance_weight: 1.0,
            effort_weight: self.effort_weight,
        }
    }
}

/// The participant's prediction of its position `steps` ahead under its
/// own control ([`Controller::predict`]).
///
/// - **Mean:** the position's row of `(A - B L)^steps` over the estimate.
/// - **Spread:** the loop's own. The true state and the estimate evolve
///   together, `x' = A x - B L x̂ + ξ + B ε` and `x̂' = (A - B L) x̂ +
///   K (H x + ω - H x̂)`, from the estimation error `E` now (the estimate
///   itself known), with the plant's and the senses' noise added each
///   step: the corrections made during the press are in it. The
///   command's own noise `ε` (SD `c |u|`) depends on the commands to come,
///   `u_k = -L (A - B L)^k x̂`: its variance at the end is
///   `Σ_k c² u_k² r_k²`, with `r_k` the end position's response to a unit
///   of command noise at step `k`.
/// - **The commands already sent.** The noise of the commands of the last
///   [`MEMORY_STEPS`] has moved the handle, and the estimator has only in
///   part caught up with it (the senses report it a delay late, and the
///   filter's steady-state gain takes it in gradually); the steady-state
///   error `E` (the loop near rest) does not hold it. The participant
///   knows what it sent (an efference copy), not the noise: a command
///   `u_j` sent `d` steps ago adds `c² u_j² s_d²`, with `s_d` the end
///   position's response to a unit of command noise `d` steps ago, carried
///   until now by the estimation error's own dynamics `A - K H`, then by
///   the loop.
#[derive(Debug, Clone)]
struct Prediction {
    /// The mean's row over the estimate.
    mean: DVector<f64>,
    /// The variance from the estimation error and the additive noise, m².
    fixed_var: f64,
    /// Per step `k`: the command's row over the estimate (`-L (A - B
    /// L)^k`), and `c r_k` (m per unit of command).
    commands: Vec<(DVector<f64>, f64)>,
    /// Per command sent `d` steps ago (`d` from 1 to [`MEMORY_STEPS`]):
    /// `c s_d`.
    unsensed: Vec<f64>,
}

impl Prediction {
    fn new(plant: &Plant, gains: &Gains, steps: usize) -> Self {
        let n = plant.a.nrows();
        let bl = &plant.b * &gains.control;
        let kh = &gains.filter * &plant.h;
        let mut joint = DMatrix::zeros(2 * n, 2 * n);
        joint.view_mut((0, 0), (n, n)).copy_from(&plant.a);
        joint.view_mut((0, n), (n, n)).copy_from(&(-&bl));
        joint.view_mut((n, 0), (n, n)).copy_from(&kh);
        joint
            .view_mut((n, n), (n, n))
            .copy_from(&(&plant.a - &bl - &kh));
        let mut added = DMatrix::zeros(2 * n, 2 * n);
        added.view_mut((0, 0), (n, n)).copy_from(&plant.process);
        added
            .view_mut((n, n), (n, n))
            .copy_from(&(&gains.filter * &plant.sensor * gains.filter.transpose()));
        let mut cov = DMatrix::zeros(2 * n, 2 * n);
        cov.view_mut((0, 0), (n, n)).copy_from(&gains.error);
        let closed = &plant.a - &bl;
        let mut mean = DVector::zeros(n);
        mean[POSITION] = 1.0;
        // The end position's row over the joint state, `steps - 1 - k`
        // steps before the end, for the command noise's response.
        let mut end = DVector::zeros(2 * n);
        end[POSITION] = 1.0;
        let mut responses = Vec::with_capacity(steps);
        let mut b_joint = DVector::zeros(2 * n);
        b_joint.rows_mut(0, n).copy_from(&plant.b.column(0));
        for _ in 0..steps {
            cov = &joint * cov * joint.transpose() + &added;
            mean = closed.tr_mul(&mean);
            responses.push(end.dot(&b_joint));
            end = joint.tr_mul(&end);
        }
        responses.reverse();
        let c = plant.control_noise.first().copied().unwrap_or(0.0);
        // `end` is now the end position's row over the joint state now;
        // an error `e` in the estimate is the joint state `(x̂ + e, x̂)`.
        let error = &plant.a - &kh;
        let mut carried = plant.b.column(0).into_owned();
        let mut unsensed = Vec::with_capacity(MEMORY_STEPS);
        for _ in 0..MEMORY_STEPS {
            unsensed.push(c * end.rows(0, n).dot(&carried));
            carried = &error * carried;
        }
        let mut command = -gains.control.row(0).transpose();
        let commands = responses
            .into_iter()
            .map(|r| {
                let row = command.clone();
                command = closed.tr_mul(&command);
                (row, c * r)
            })
            .collect();
        Prediction {
            mean,
            fixed_var: cov[(POSITION, POSITION)].max(0.0),
            commands,
            unsensed,
        }
    }

    /// The SD of the prediction at rest (no command sent or to come), m.
    fn rest_sd(&self) -> f64 {
        self.fixed_var.sqrt()
    }

    /// The predicted position (m from the target) and its SD (m), for the
    /// estimate and the commands sent (most recent first).
    fn at(&self, estimate: &DVector<f64>, sent: &VecDeque<f64>) -> (f64, f64) {
        let ahead: f64 = self
            .commands
            .iter()
            .map(|(row, cr)| (row.dot(estimate) * cr).powi(2))
            .sum();
        let past: f64 = self
            .unsensed
            .iter()
            .zip(sent)
            .map(|(cs, u)| (cs * u).powi(2))
            .sum();
        (
            self.mean.dot(estimate),
            (self.fixed_var + ahead + past).sqrt(),
        )
    }
}

/// One participant's controller: its limb, the plant its internal model
/// is, and the steady-state gains (a function of its traits only, solved
/// once and shared by its tests: 6.2 ms, `cargo bench --bench ofc`).
#[derive(Debug, Clone)]
pub struct Controller {
    limb: Limb,
    plant: Plant,
    gains: Gains,
    /// The position a press ahead, as the participant predicts it.
    prediction: Prediction,
    /// The position now, as the participant estimates it (a prediction of
    /// no steps).
    present: Prediction,
}

impl Controller {
    /// The controller of a participant with `traits` on a handle of
    /// `handle_kg`.
    ///
    /// # Errors
    /// When no steady-state controller exists for these traits.
    pub fn new(traits: &Traits, handle_kg: f64) -> Result<Self, OfcError> {
        let limb = traits.limb(handle_kg);
        let (plant, cost) = limb.plant();
        let gains = solve(&plant, &cost)?;
        #[expect(
            clippy::cast_possible_truncation,
            clippy::cast_sign_loss,
            reason = "a press of at most seconds, in 10 ms steps"
        )]
        let steps = (traits.button_s / limb.step_s).round().clamp(0.0, 1000.0) as usize;
        let prediction = Prediction::new(&plant, &gains, steps);
        let present = Prediction::new(&plant, &gains, 0);
        Ok(Controller {
            limb,
            plant,
            gains,
            prediction,
            present,
        })
    }

    /// The limb it controls.
    #[must_use]
    pub fn limb(&self) -> &Limb {
        &self.limb
    }

    /// Where the participant predicts the cursor a press ahead of
    /// `estimate`, m from the target, and the SD of that prediction, with
    /// the commands `sent` in the last steps (most recent first).
    #[must_use]
    pub fn predict(&self, estimate: &Estimate, sent: &VecDeque<f64>) -> (f64, f64) {
        self.prediction.at(&estimate.0, sent)
    }

    /// Where the participant estimates the cursor now, m from the target,
    /// and the SD of that estimate (as [`Controller::predict`]).
    #[must_use]
    pub fn locate(&self, estimate: &Estimate, sent: &VecDeque<f64>) -> (f64, f64) {
        self.present.at(&estimate.0, sent)
    }
}

/// One Fitts test in progress.
#[derive(Debug, Clone)]
pub struct Tap {
    ctl: Arc<Controller>,
    centres: [f64; 2],
    /// The target the controller aims at.
    lit: usize,
    width: f64,
    /// The true equilibrium point, its first stage and the central
    /// command, absolute, m: at the next step's start.
    limb: [f64; 3],
    /// The equilibrium point the hand holds over this step, m.
    held: f64,
    /// The estimate, in the lit target's frame.
    estimate: Estimate,
    /// The senses' true readings of the last steps (position absolute),
    /// oldest first: what arrives a delay later.
    readings: VecDeque<[f64; SENSED]>,
    /// The commands sent in the last [`MEMORY_STEPS`], most recent first.
    sent: VecDeque<f64>,
    /// The next control step, s on the trial's clock.
    next_step: f64,
    /// The button is being pressed; the click registers at this time.
    pressing: Option<f64>,
    /// No press before this time (the release, or a miss seen).
    blocked_until: f64,
    /// A target to take up once the button is released: its index, and
    /// when.
    pending: Option<(usize, f64)>,
}

impl Tap {
    /// A new test: the hand at rest on the first lit target, its estimate
    /// right.
    #[must_use]
    pub fn start(ctl: Arc<Controller>, centres: [f64; 2], width: f64, now: f64) -> Self {
        let n = ctl.plant.a.nrows();
        let delay = ctl.limb.delay_steps();
        let at = centres[0];
        Tap {
            ctl,
            centres,
            lit: 0,
            width,
            limb: [at; 3],
            held: at,
            estimate: Estimate(DVector::zeros(n)),
            readings: std::iter::repeat_n([at, 0.0, 0.0], delay).collect(),
            sent: std::iter::repeat_n(0.0, MEMORY_STEPS).collect(),
            next_step: now,
            pressing: None,
            blocked_until: now,
            pending: None,
        }
    }

    /// A new screen after a click: `lit_m` now shows, `width` counts. After
    /// a hit (the other target lit) the controller takes it up when the
    /// button is released; after a miss the participant may press again
    /// once it has seen the miss. Returns whether the target changed.
    pub fn next_target(&mut self, traits: &Traits, lit_m: f64, width: f64, now: f64) -> bool {
        let lit = usize::from((lit_m - self.centres[0]).abs() >= 1e-12);
        let changed = lit != self.lit;
        self.width = width;
        if changed {
            self.pending = Some((lit, now + traits.button_s));
            self.blocked_until = now + traits.button_s;
        } else {
            self.blocked_until = now + traits.button_s.max(traits.feedback_s);
        }
        changed
    }

    /// Moves the estimate to the other target's frame, `lit`.
    fn take_up(&mut self, lit: usize) {
        let shift = self.centres[self.lit] - self.centres[lit];
        self.lit = lit;
        let x = &mut self.estimate.0;
        for i in [POSITION, EQUILIBRIUM, STAGE, COMMAND] {
            x[i] += shift;
        }

        let mut i = OWN;
        while i < x.len() {
            x[i] += shift;
            i += SENSED;
        }
    }

    /// The load as a resistance: the participant's internal model holds
    /// the handle's load as friction, opposing the handle's motion when it
    /// moves (its estimated speed over [`MOVING_M_S`]), and opposing the
    /// way to the target when it is still and outside it; still inside the
    /// target, the load keeps its sign. Friction compensation by the sign
    /// of the velocity, the usual form of a friction model in control
    /// (Armstrong-Hélouvry, Dupont & Canudas de Wit 1994, Automatica
    /// 30(7):1083-1138); that a person's internal model takes this form
    /// is our choice, stated.
    fn resist(&mut self) {
        let x = &mut self.estimate.0;
        let (p, v) = (x[POSITION], x[VELOCITY]);
        let opposing = if v.abs() > MOVING_M_S {
            -v.signum()
        } else if p.abs() > self.width / 2.0 {
            p.signum()
        } else {
            return;
        };
        x[LOAD] = x[LOAD].abs() * opposing;
    }

    /// The hand's drive: the limb's impedance about its true equilibrium
    /// point.
    #[must_use]
    pub fn drive(&self, segment: u32) -> HandDrive {
        let l = &self.ctl.limb;
        HandDrive {
            x_m: self.held,
            v_m_s: 0.0,
            stiffness_n_m: l.stiffness_n_m,
            damping_n_s_m: l.damping_n_s_m,
            integral_gain: 0.0,
            segment,
        }
    }

    /// One control step with the handle at `x_m`, `v_m_s`: sense, estimate,
    /// command. `normal(sd)` draws N(0, sd).
    fn control(&mut self, x_m: f64, v_m_s: f64, normal: &mut impl FnMut(f64) -> f64) {
        let ctl = Arc::clone(&self.ctl);
        let l = &ctl.limb;
        let centre = self.centres[self.lit];
        let own = [x_m, v_m_s, self.limb[0], self.limb[1], self.limb[2], 0.0];
        let now = l.sense(&own);
        // What arrives now is a delay old (or the present, with no delay).
        let sensed = match self.readings.pop_front() {
            Some(old) => {
                self.readings.push_back(now);
                old
            }
            None => now,
        };
        let y = DVector::from_iterator(
            SENSED,
            [sensed[0] - centre, sensed[1], sensed[2]]
                .iter()
                .zip(l.sense_sd)
                .map(|(v, sd)| v + normal(sd)),
        );
        self.resist();
        let u = self.estimate.command(&ctl.gains);
        if self.sent.pop_back().is_some() {
            self.sent.push_front(u[0]);
        }
        let eta = DVector::zeros(self.estimate.0.len());
        self.estimate.step(&ctl.plant, &ctl.gains, &u, &y, &eta);
        // The true limb: the command with its own noise, through the
        // muscle's filter.
        let command =
            u[0] + normal(l.command_noise * u[0].abs()) + normal(l.command_sd_m) / l.step_s;
        // The filter's own rows and columns of the plant's `A` and `B`.
        let filter = [EQUILIBRIUM, STAGE, COMMAND];
        let old = self.limb;
        self.held = old[0];
        for (next, &i) in self.limb.iter_mut().zip(&filter) {
            *next = filter
                .iter()
                .zip(old)
                .map(|(&j, x)| ctl.plant.a[(i, j)] * x)
                .sum::<f64>()
                + ctl.plant.b[(i, 0)] * command;
        }
    }

    /// After a tick with the device at `x_m`, `v_m_s`: a control step when
    /// one is due, then click, press or keep going.
    pub fn decide(
        &mut self,
        traits: &Traits,
        now: f64,
        x_m: f64,
        v_m_s: f64,
        mut normal: impl FnMut(f64) -> f64,
    ) -> Step {
        if let Some(at) = self.pressing
            && now >= at
        {
            self.pressing = None;
            // Nothing more until the engine shows the next screen.
            self.blocked_until = f64::INFINITY;
            return Step::Click(x_m);
        }
        if now + 1e-9 < self.next_step {
            return Step::Wait;
        }
        self.next_step += STEP_S;
        if let Some((lit, at)) = self.pending
            && now >= at
        {
            self.pending = None;
            self.take_up(lit);
        }
        self.control(x_m, v_m_s, &mut normal);
        if self.pressing.is_none() && self.pending.is_none() && now >= self.blocked_until {
            let half = self.width / 2.0;
            // The criterion is a share of the most the participant can be
            // sure of here: the probability inside with its estimate at
            // rest on the centre (a narrow target may allow less than the
            // criterion itself, and waiting would not make it surer).
            let sure = |(at, sd): (f64, f64), rest_sd: f64| {
                let best = click::inside(0.0, rest_sd, 0.0, half);
                click::clicks(at, sd, 0.0, half, traits.click_criterion * best)
            };
            if sure(
                self.ctl.locate(&self.estimate, &self.sent),
                self.ctl.present.rest_sd(),
            ) && sure(
                self.ctl.predict(&self.estimate, &self.sent),
                self.ctl.prediction.rest_sd(),
            ) {
                self.pressing = Some(now + traits.button_s);
            }
        }
        Step::Wait
    }
}

#[cfg(test)]
mod tests {
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;
    use rand_distr::{Distribution, Normal};

    use super::*;
    use crate::hand::Hand;
    use crate::participant::population::Population;

    fn traits() -> Traits {
        Traits::draw(1, "p", &Population::default())
    }

    /// The controller of [`traits`] on seed 002's handle, solved once for
    /// all the tests (a solve takes seconds in a debug build).
    fn controller() -> Arc<Controller> {
        static ONE: std::sync::OnceLock<Arc<Controller>> = std::sync::OnceLock::new();
        Arc::clone(ONE.get_or_init(|| Arc::new(Controller::new(&traits(), 0.692).unwrap())))
    }

    /// A frictionless handle of the controller's own mass under the hand,
    /// at 1 kHz, with a `load_n` on it; runs one reach from the first
    /// target until the participant clicks on the second, noise-free.
    /// Returns the click's position and time, and the largest speed.
    fn reach(load_n: f64, noise: bool) -> (f64, f64, f64) {
        let t = traits();
        let ctl = controller();
        let mass = ctl.limb().mass_kg;
        let (c, w) = ([0.0, 0.016], 0.002);
        let mut tap = Tap::start(ctl, c, w, 0.0);
        assert!(tap.next_target(&t, c[1], w, 0.0));
        let mut hand = Hand::default();
        let (mut x, mut v, dt) = (0.0, 0.0, 0.001);
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let unit = Normal::new(0.0, 1.0).unwrap();
        let mut top: f64 = 0.0;
        for i in 1..20_000 {
            let now = f64::from(i) * dt;
            let f = hand.force(&tap.drive(1), x, v, dt) + load_n;
            v += f / mass * dt;
            x += v * dt;
            top = top.max(v.abs());
            let draw = |sd: f64| {
                if noise {
                    sd * unit.sample(&mut rng)
                } else {
                    0.0
                }
            };
            if let Step::Click(at) = tap.decide(&t, now, x, v, draw) {
                return (at, now, top);
            }
        }
        panic!("never clicked: x {x}");
    }

    /// A stuck handle: the slide of seed 002's apparatus with 3 N of
    /// friction on it (the "real" condition's Dahl model), more than the
    /// participant expects (nothing). Noise-free, it learns the load,
    /// pushes harder until the handle breaks away, and clicks inside a
    /// 1 mm tolerance: the hand leans on the friction instead of stopping
    /// short of the target for ever.
    #[test]
    fn a_handle_held_by_friction_is_pushed_until_the_click_lands_inside() {
        let t = traits();
        let ctl = controller();
        let (c, w) = ([-0.008, 0.008], 0.001);
        let mut dev = frictionlab_core::plant::SimDevice::new(
            frictionlab_core::plant::Apparatus::default(),
            t.hand_mass_kg,
            frictionlab_core::friction::StepParams::default(),
        );
        let model: frictionlab_core::friction::ModelParams = serde_json::from_str(
            r#"{"model": "dahl", "sigma_n_m": 100000.0, "fc_pos_n": 3.0, "fc_neg_n": 3.0, "viscous_n_s_m": 0.0}"#,
        )
        .unwrap();
        dev.set_physical(Some(&model));
        dev.reset(c[0]);
        let mut tap = Tap::start(ctl, c, w, 0.0);
        assert!(tap.next_target(&t, c[1], w, 0.0));
        let mut hand = Hand::default();
        let dt = 0.0002;
        let mut sample = frictionlab_core::plant::DeviceSample {
            x_m: c[0],
            ..Default::default()
        };
        let mut most: f64 = 0.0;
        for i in 1..100_000 {
            let now = f64::from(i) * dt;
            let f = hand.force(&tap.drive(1), sample.x_m, sample.v_m_s, dt);
            most = most.max(f);
            sample = dev.step_with(dt, f, |_| 0.0);
            if let Step::Click(at) = tap.decide(&t, now, sample.x_m, sample.v_m_s, |_| 0.0) {
                assert!((at - c[1]).abs() <= w / 2.0, "clicked {at} m after {now} s");
                // It pushed past the friction (3 N and the slide's 0.75 N).
                assert!(most > 3.75, "pushed at most {most} N");
                return;
            }
        }
        panic!("never clicked: x {}", sample.x_m);
    }

    /// The load held as a resistance: moving, it opposes the motion; still
    /// and outside the target, it opposes the way to the target; still
    /// inside, it keeps its sign.
    #[test]
    fn the_load_is_held_as_a_resistance_to_the_motion() {
        let ctl = controller();
        let mut tap = Tap::start(ctl, [0.0, 0.016], 0.002, 0.0);
        let mut held = |p: f64, v: f64, load: f64| {
            tap.estimate.0[POSITION] = p;
            tap.estimate.0[VELOCITY] = v;
            tap.estimate.0[LOAD] = load;
            tap.resist();
            tap.estimate.0[LOAD]
        };
        assert_eq!(held(-0.01, 0.05, 2.0), -2.0);
        assert_eq!(held(0.01, -0.05, -2.0), 2.0);
        assert_eq!(held(-0.01, 0.0, 2.0), -2.0);
        assert_eq!(held(0.01, 0.0, -2.0), 2.0);
        assert_eq!(held(0.0005, 0.0, -2.0), -2.0);
        assert_eq!(held(-0.0005, 0.0, 2.0), 2.0);
    }

    /// Without noise the handle goes to the target and the participant
    /// clicks inside it, with no duration set anywhere.
    #[test]
    fn a_noise_free_reach_clicks_inside_the_target() {
        let (at, when, top) = reach(0.0, false);
        assert!((at - 0.016).abs() <= 0.001, "clicked at {at}");
        assert!(when > 0.1 && when < 2.0, "clicked after {when} s");
        assert!(top > 0.02, "peak speed {top}");
    }

    /// A load the participant did not expect (1.5 N against the reach) is
    /// learnt and pushed against: it still clicks inside.
    #[test]
    fn a_reach_against_an_unexpected_load_still_ends_inside() {
        let (at, _, _) = reach(-1.5, false);
        assert!((at - 0.016).abs() <= 0.001, "clicked at {at}");
    }

    #[test]
    fn a_click_registers_one_button_press_after_the_decision() {
        let t = traits();
        let ctl = controller();
        let mut tap = Tap::start(ctl, [0.0, 0.016], 0.002, 0.0);
        // At rest on the lit target, sure of it: it presses at the first
        // step and the click comes one press later.
        let mut now = 0.0;
        let mut pressed = None;
        loop {
            if let Step::Click(at) = tap.decide(&t, now, 0.0, 0.0, |_| 0.0) {
                assert_eq!(at, 0.0);
                break;
            }
            if pressed.is_none() && tap.pressing.is_some() {
                pressed = Some(now);
            }
            now += 0.001;
            assert!(now < 5.0, "never clicked");
        }
        let pressed = pressed.unwrap();
        assert!(
            (now - pressed - t.button_s).abs() < 1.5e-3,
            "{pressed} {now}"
        );
    }

    /// A miss: the same target stays lit and the participant does not
    /// press again before it has seen the miss.
    #[test]
    fn after_a_miss_no_press_until_the_miss_is_seen() {
        let t = traits();
        let ctl = controller();
        let mut tap = Tap::start(ctl, [0.0, 0.016], 0.002, 0.0);
        assert!(!tap.next_target(&t, 0.0, 0.002, 1.0));
        tap.next_step = 1.0;
        let mut now = 1.0;
        while tap.pressing.is_none() {
            let _ = tap.decide(&t, now, 0.0, 0.0, |_| 0.0);
            now += 0.001;
        }
        let gap = now - 0.001 - 1.0;
        let want = t.button_s.max(t.feedback_s);
        assert!(gap >= want - 1e-9 && gap < want + STEP_S + 1e-9, "{gap}");
    }
}
