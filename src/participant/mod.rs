//! The simulated participant: a hand that moves the (simulated) device
//! through the rendered friction, and a perceiver that answers from what the
//! hand felt, never from the protocol's labels.
//!
//! # Mechanisms (each with its sources, in its module)
//! - [`movement`]: Fitts movements as minimum-jerk submovements of the
//!   hand's equilibrium point, with signal-dependent noise and durations
//!   chosen by the stochastic optimized-submovement model (Flash & Hogan
//!   1985; Meyer et al. 1988; Harris & Wolpert 1998), and a button press
//!   and release from the Keystroke-Level Model.
//! - [`percept`]: friction strength from the force at break-away and while
//!   sliding; viscosity and stiffness from force over velocity and over
//!   displacement, each cue with its own noise (magnitude estimation and
//!   forced choice, of the quality the protocol asks about); nearness of a
//!   rendering to a desk the participant slid on, in JNDs of its own Weber
//!   fractions (paired comparison).
//! - Magnitude exploration: the hand strokes sinusoidally (its own amplitude
//!   and rate) for its own exploration time (at most the protocol's).
//! - [`feedback`] (with [`Population::feedback`]; issue 65): the other
//!   Fitts hand. [`ofc`]'s stochastic optimal feedback controller (Todorov
//!   2005; Qian et al. 2013) moves the equilibrium point of [`limb`]'s
//!   hand from delayed, noisy senses, correcting during the movement, and
//!   [`click`] clicks from the participant's own estimate. Not the default
//!   until it copes with friction (`docs/guide/validation.md`).
//!
//! # Between-participant variation
//! Every participant draws its hand impedance, motor noise, perceptual noise
//! and answer scale from the ranges of a [`Population`] (defaults below,
//! each with its source or marked free). `frictionlab simulate --population
//! FILE` replaces them; `analysis/claims.md` sweeps the free ones.
//!
//! # Determinism
//! A participant's traits are drawn from (seed, participant id); everything
//! random within a trial from (trial seed, participant id); its memory of
//! the desk from (seed, participant id). Each trial starts with the hand and
//! the device at rest at a home position and the hand's effort at zero, and
//! everything within it runs on the trial's own clock (whole nanoseconds
//! since its start, [`Time`]) with movement segments numbered from the
//! trial's index: what it does depends on the seed, the trial and the tick
//! within the trial, never on where the session clock stood when the trial
//! began (issue 42). So an answer is a pure function of (seed, participant,
//! trial), and a resumed session gets the same answers as an
//! uninterrupted one.

pub mod click;
mod feedback;
pub mod limb;
mod movement;
pub mod ofc;
pub mod percept;
pub mod population;

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

use crate::device::DeviceSample;
use crate::hand::{Hand, HandDrive};
use crate::protocol::engine::{Action, Answer, Choice, Input, Question, Screen};
use crate::protocol::kind::{Kinds, Quality};
use crate::protocol::plan::PlannedTrial;
use crate::time::Time;
pub use feedback::Controller;
pub use movement::{MAX_CORRECTIONS, Planner};
use movement::{Step, Tap};
use percept::{Acuity, Desk, Features, Felt, SLIDE_REST_S, SLIDE_S};
pub use population::{Population, Range};
use std::sync::Arc;

/// What a responder does in response to an action or a sample.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Reaction {
    /// Inputs for the engine, in order.
    pub inputs: Vec<Input>,
    /// Put the device (and hand) at rest here first, m. Only the simulated
    /// device can do this; on a real one the hand moves there itself.
    pub reset_to: Option<f64>,
}

/// A participant's traits, drawn from its [`Population`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Traits {
    /// Stevens exponent of friction.
    pub exponent: f64,
    /// Stevens exponent of viscosity.
    pub viscosity_exponent: f64,
    /// Stevens exponent of stiffness.
    pub stiffness_exponent: f64,
    /// Stevens modulus (the participant's own scale): 10 e^U(-1, 1) (free).
    pub modulus: f64,
    /// Log-normal answer noise (SD of ln).
    pub answer_noise: f64,
    /// Exploration stroke amplitude, m: U(8, 12) mm (free).
    pub stroke_m: f64,
    /// Exploration stroke rate, Hz: U(1, 2) (free).
    pub stroke_hz: f64,
    /// How long the participant explores before answering, s: U(2.5, 5)
    /// (free).
    pub explore_s: f64,
    /// Hand mass on the device, kg.
    pub hand_mass_kg: f64,
    /// Hand stiffness, N/m.
    pub hand_stiffness_n_m: f64,
    /// Hand damping, N s/m.
    pub hand_damping_n_s_m: f64,
    /// Hand integral gain (effort builds while off the plan), N/(m s):
    /// 3000, free (see [`crate::hand`]).
    pub hand_integral: f64,
    /// Motor noise `K` of the aim's SD `K D / T`, s.
    pub motor_noise_s: f64,
    /// Whether its Fitts hand is the feedback controller
    /// ([`Population::feedback`]) rather than optimised submovements.
    pub feedback: bool,
    /// The noise of the feedback controller's command, SD per unit of
    /// command.
    pub command_noise: f64,
    /// The controller's weight on its squared command, s².
    pub effort_weight: f64,
    /// The probability of being inside at which it clicks.
    pub click_criterion: f64,
    /// Time to press, and to release, the button, s.
    pub button_s: f64,
    /// Visual feedback delay, s.
    pub feedback_s: f64,
    /// Position perception noise, m (SD).
    pub position_sd_m: f64,
    /// How finely forces and vibrations are told apart.
    pub acuity: Acuity,
    /// Break-away weight, tactile gain and "no difference" band (from the
    /// population).
    pub breakaway_weight: f64,
    /// N per unit vibrotactile drive.
    pub tactile_gain_n: f64,
    /// JND.
    pub no_difference_jnd: f64,
    /// The desk of the reference phase.
    pub desk: Desk,
}

impl Traits {
    /// Draws the traits of participant `id` in study seed `seed`.
    #[must_use]
    pub fn draw(seed: u64, id: &str, p: &Population) -> Self {
        let mut r = ChaCha8Rng::seed_from_u64(seed ^ id_hash(id));
        // A range pinned to one value still takes its draw, so pinning one
        // trait (the validation sweep, the claims' hand grid) leaves every
        // other trait of the participant as drawn (common random numbers).
        let mut u = |[lo, hi]: Range| {
            if hi > lo {
                r.random_range(lo..hi)
            } else {
                let _: f64 = r.random_range(0.0..1.0);
                lo
            }
        };
        // In the order the traits were drawn before issue 44, so the
        // traits it kept stay as they were drawn; the new ones come last.
        let exponent = u(p.stevens_exponent);
        let modulus = 10.0 * u([-1.0, 1.0]).exp();
        let answer_noise = u(p.answer_noise);
        let stroke_m = u([0.008, 0.012]);
        let stroke_hz = u([1.0, 2.0]);
        let explore_s = u([2.5, 5.0]);
        let hand_mass_kg = u(p.hand_mass_kg);
        let hand_stiffness_n_m = u(p.hand_stiffness_n_m);
        let hand_damping_n_s_m = u(p.hand_damping_n_s_m);
        let motor_noise_s = u(p.motor_noise_s);
        // The retired submovement duration's draw.
        let _ = u([0.0, 1.0]);
        let feedback_s = u(p.feedback_s);
        let position_sd_m = u(p.position_sd_m);
        let force = u(p.force_weber);
        let vibration = u(p.vibration_weber);
        let displacement = u(p.displacement_weber);
        let velocity = u(p.velocity_weber);
        let viscosity_exponent = u(p.viscosity_exponent);
        let stiffness_exponent = u(p.stiffness_exponent);
        // The feedback hand's, drawn whether it is used or not.
        let f = p.feedback.clone().unwrap_or_default();
        let command_noise = u(f.command_noise);
        let effort_weight = u(f.effort_weight);
        let click_criterion = u(f.click_criterion);
        Traits {
            exponent,
            viscosity_exponent,
            stiffness_exponent,
            modulus,
            answer_noise,
            stroke_m,
            stroke_hz,
            explore_s,
            hand_mass_kg,
            hand_stiffness_n_m,
            hand_damping_n_s_m,
            hand_integral: 3000.0,
            motor_noise_s,
            feedback: p.feedback.is_some(),
            command_noise,
            effort_weight,
            click_criterion,
            button_s: p.button_s,
            feedback_s,
            position_sd_m,
            acuity: Acuity {
                force,
                vibration,
                floor_n: p.vibration_floor_n,
                displacement,
                velocity,
            },
            breakaway_weight: p.breakaway_weight,
            tactile_gain_n: p.tactile_gain_n,
            no_difference_jnd: p.no_difference_jnd,
            desk: Desk {
                mu: p.desk_mu,
                normal_n: p.desk_normal_n,
            },
        }
    }

    /// The Stevens exponent of magnitude estimates of `quality`.
    #[must_use]
    pub fn exponent_of(&self, quality: Quality) -> f64 {
        match quality {
            Quality::Friction => self.exponent,
            Quality::Viscosity => self.viscosity_exponent,
            Quality::Stiffness => self.stiffness_exponent,
        }
    }
}

/// A stable 64-bit hash of a participant id (FNV-1a: the same on every run and
/// platform, unlike `std`'s hashers).
#[must_use]
pub fn id_hash(id: &str) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for b in id.bytes() {
        h ^= u64::from(b);
        h = h.wrapping_mul(0x0100_0000_01b3);
    }
    h
}

/// The simulated participant.
#[derive(Debug, Clone)]
pub struct SimParticipant {
    id: String,
    seed: u64,
    traits: Traits,
    behaviour: Behaviour,
    hand: Hand,
    /// The hand's movement segment (see [`crate::hand`]): a new trial
    /// starts the first of its own ([`segment_of`]), a new Fitts target the
    /// next.
    segment: u32,
    /// When the trial under way started: its clock's origin.
    trial_start: Time,
    rng: ChaCha8Rng,
    /// What it remembers of the desk (perceived features), once it slid.
    desk: Option<Features>,
    /// A set paired-comparison preference (an assumed effect, see
    /// [`Population::paired_preference`]), not a percept.
    preference: Option<population::PairedPreference>,
    /// Its movement planner, made at its first Fitts test (a function of
    /// its traits only).
    planner: Option<Arc<Planner>>,
    /// Its feedback controller (with [`Traits::feedback`]), solved at its
    /// first Fitts test (a function of its traits only); `Err` when none
    /// exists for its traits.
    controller: Option<Result<Arc<Controller>, ofc::OfcError>>,
}

#[derive(Debug, Clone)]
/// The large states are boxed: `decide` moves the behaviour out and back
/// every tick, a pointer's copy rather than the state's (a memcpy was 10%
/// of a discrimination replay's instructions).
enum Behaviour {
    Idle,
    Explore(Explore),
    Slide(Box<Slide>),
    Tap(Box<Tap>),
    /// A Fitts test under the feedback controller.
    Reach(Box<feedback::Tap>),
}

#[derive(Debug, Clone)]
struct Explore {
    start: Time,
    stop: Time,
    /// The quality asked about.
    judged: Quality,
    felt: Felt,
    answered: bool,
    /// The stroke's phase as the simulated device steps it.
    phase: Phasor,
}

/// `(sin, cos)` of a phase `w s` that advances in equal steps: turned by a
/// per-step rotation (the core's carrier does the same) instead of a
/// `sin`/`cos` call per tick, which cost a fifth of a simulated session.
/// A step of another length (the first two, or a device's irregular ticks)
/// is computed directly. Over the 50,000 ticks of a 10 s exploration at
/// 5 kHz, `sin` and `cos` stay within 2.1e-12 of the direct values (test
/// below).
#[derive(Debug, Clone, Copy)]
struct Phasor {
    s: f64,
    sin: f64,
    cos: f64,
    /// The step the rotation turns by, and its `(sin, cos)`.
    step: f64,
    rotation: (f64, f64),
}

/// Steps whose lengths differ by at most this much are equal, s: two
/// trial-local times, each a whole number of nanoseconds rounded once to
/// seconds, differ from their tick by a few units in the last place
/// (under 1e-12 s in the first hour of a trial; later steps are computed
/// directly).
const SAME_STEP_S: f64 = 1e-12;

impl Phasor {
    fn new() -> Self {
        Phasor {
            s: f64::NAN,
            sin: 0.0,
            cos: 1.0,
            step: f64::NAN,
            rotation: (0.0, 1.0),
        }
    }

    /// `(sin, cos)` of `w s`, `w` the same at every call.
    fn at(&mut self, s: f64, w: f64) -> (f64, f64) {
        let d = s - self.s;
        if (d - self.step).abs() <= SAME_STEP_S {
            let (rs, rc) = self.rotation;
            (self.sin, self.cos) = (self.sin * rc + self.cos * rs, self.cos * rc - self.sin * rs);
        } else {
            (self.sin, self.cos) = (w * s).sin_cos();
            if d.is_finite() {
                self.step = d;
                self.rotation = (w * d).sin_cos();
            }
        }
        self.s = s;
        (self.sin, self.cos)
    }
}

#[derive(Debug, Clone)]
struct Slide {
    stimulus: usize,
    start: Time,
    trace: Vec<(f64, f64)>,
    /// Forced choice: what the slide felt like.
    felt: percept::BreakAway,
    /// Paired comparison: each stimulus's distance to the desk, JNDs.
    distances: [f64; 2],
    /// Forced choice: each stimulus's perceived friction strength, N.
    strengths: [f64; 2],
    /// A forced choice (which had more of `judged`), not nearness.
    forced: bool,
    /// The quality a forced choice asks about.
    judged: Quality,
    /// With a set preference: which stimulus (0 first, 1 second presented)
    /// is the preferred condition, if either is.
    preferred: Option<usize>,
    answered: bool,
}

/// Where seed 000's slide starts on the device, m: the hand lags its
/// reference by about 1 cm, so the slide stays inside the 3.2 cm range.
const SLIDE_START_M: f64 = -0.0158;

/// The first movement segment of trial `index` (its later ones follow):
/// numbered from the trial's index, so the hand's segments do not depend
/// on how many trials came before in this run (a resume runs fewer).
fn segment_of(index: usize) -> u32 {
    #[expect(
        clippy::cast_possible_truncation,
        reason = "segments only need to differ from the last one"
    )]
    let index = index as u32;
    index.wrapping_mul(1 << 12).wrapping_add(1)
}

impl SimParticipant {
    /// Participant `id` of a study with seed `seed`, drawn from `population`.
    #[must_use]
    pub fn new(seed: u64, id: &str, population: &Population) -> Self {
        SimParticipant {
            id: id.to_owned(),
            seed,
            traits: Traits::draw(seed, id, population),
            behaviour: Behaviour::Idle,
            hand: Hand::default(),
            segment: 0,
            trial_start: Time::ZERO,
            rng: ChaCha8Rng::seed_from_u64(seed),
            desk: None,
            preference: population.paired_preference.clone(),
            planner: None,
            controller: None,
        }
    }

    /// The participant's traits.
    #[must_use]
    pub fn traits(&self) -> &Traits {
        &self.traits
    }

    fn normal(&mut self, sd: f64) -> f64 {
        Normal::new(0.0, sd.max(0.0)).map_or(0.0, |n| n.sample(&mut self.rng))
    }

    /// What the participant remembers of the desk: it slides on it (in the
    /// reference phase, or, resumed after it, as it did then: the memory is
    /// drawn from (seed, participant) only).
    fn desk_memory(&mut self) -> Features {
        if let Some(d) = self.desk {
            return d;
        }
        let t = self.traits;
        let felt = percept::slide_features(&percept::desk_slide(
            t.desk,
            t.hand_mass_kg,
            t.hand_stiffness_n_m,
            t.hand_damping_n_s_m,
        ));
        let mut rng = ChaCha8Rng::seed_from_u64(self.seed ^ id_hash(&self.id) ^ 0xde5c);
        let unit = Normal::new(0.0, 1.0).ok();
        let memory = t
            .acuity
            .perceive(felt, || unit.map_or(0.0, |n| n.sample(&mut rng)));
        self.desk = Some(memory);
        memory
    }

    /// Reacts to an engine action; `trial` is the engine's current trial.
    pub fn on_action<K: Kinds>(
        &mut self,
        now: Time,
        action: &Action<K>,
        trial: Option<&PlannedTrial<K>>,
    ) -> Reaction {
        let idle = Reaction {
            inputs: vec![Input::Continue],
            reset_to: None,
        };
        match action {
            // A kind's own screen: its task, as any kind's.
            Action::ShowOwn(own) => self.on_action(now, &Action::<K>::Show(own.task()), trial),
            Action::Show(Screen::Reference { .. }) => {
                self.desk_memory();
                idle
            }
            Action::Show(Screen::Instructions(_) | Screen::Break { .. }) | Action::Prompt(_) => {
                idle
            }
            Action::Show(Screen::Explore { until }) => {
                self.start_trial(trial, now);
                let explore = Time::from_secs_saturating(self.traits.explore_s);
                self.behaviour = Behaviour::Explore(Explore {
                    start: now,
                    stop: now + explore.min(*until - now),
                    judged: trial.map_or(Quality::Friction, |t| K::judged(&t.spec)),
                    felt: Felt::default(),
                    answered: false,
                    phase: Phasor::new(),
                });
                Reaction {
                    inputs: vec![],
                    reset_to: Some(0.0),
                }
            }
            Action::Show(Screen::Paired {
                active: 0, forced, ..
            }) if !matches!(self.behaviour, Behaviour::Slide(_)) => {
                self.start_trial(trial, now);
                let preferred = self.preferred_stimulus(trial);
                self.behaviour = Behaviour::Slide(Box::new(Slide {
                    stimulus: 0,
                    start: now,
                    trace: Vec::new(),
                    felt: percept::BreakAway::default(),
                    distances: [0.0; 2],
                    strengths: [0.0; 2],
                    forced: forced.is_some(),
                    judged: trial.map_or(Quality::Friction, |t| K::judged(&t.spec)),
                    preferred,
                    answered: false,
                }));
                Reaction {
                    inputs: vec![],
                    reset_to: Some(SLIDE_START_M),
                }
            }
            Action::Show(Screen::Targets {
                lit_m,
                other_m,
                effective_width_m,
                ..
            }) => self.fitts_screen(now, trial, [*lit_m, *other_m], *effective_width_m),
            Action::Ask(Question::Magnitude) => {
                let answer = self.magnitude_answer();
                Reaction {
                    inputs: vec![Input::Answer(Answer::Magnitude(answer))],
                    reset_to: None,
                }
            }
            Action::Ask(Question::PairedChoice | Question::ForcedChoice) => Reaction {
                inputs: vec![Input::Answer(Answer::Paired(self.paired_choice()))],
                reset_to: None,
            },
            Action::Record(_) => {
                self.behaviour = Behaviour::Idle;
                Reaction::default()
            }
            _ => Reaction::default(),
        }
    }

    /// A trial starts at `now`: its clock starts, its randomness is
    /// reseeded from (trial seed, participant), the hand's effort is let
    /// go, and its first movement segment is the trial's own.
    fn start_trial<K: Kinds>(&mut self, trial: Option<&PlannedTrial<K>>, now: Time) {
        let seed = trial.map_or(0, |t| t.seed);
        self.rng = ChaCha8Rng::seed_from_u64(seed ^ id_hash(&self.id));
        self.trial_start = now;
        self.hand = Hand::default();
        self.segment = segment_of(trial.map_or(0, |t| t.index));
    }

    /// Seconds since the trial under way started (exact: a whole number
    /// of nanoseconds, divided once).
    fn local(&self, now: Time) -> f64 {
        (now - self.trial_start).secs()
    }

    /// A targets screen (a Fitts test): `w_eff` is the width that counts for a hit.
    fn fitts_screen<K: Kinds>(
        &mut self,
        now: Time,
        trial: Option<&PlannedTrial<K>>,
        lit_other: [f64; 2],
        w_eff: f64,
    ) -> Reaction {
        let mut behaviour = std::mem::replace(&mut self.behaviour, Behaviour::Idle);
        let (traits, s) = (self.traits, self.local(now));
        let changed = match &mut behaviour {
            Behaviour::Tap(tap) => {
                Some(tap.next_target(&traits, lit_other[0], w_eff, s, |sd| self.normal(sd)))
            }
            Behaviour::Reach(reach) => Some(reach.next_target(&traits, lit_other[0], w_eff, s)),
            _ => None,
        };
        self.behaviour = behaviour;
        if let Some(changed) = changed {
            if changed {
                self.segment = self.segment.wrapping_add(1);
            }
            return Reaction::default();
        }
        // A new test: the hand starts at rest on the first lit target.
        self.start_trial(trial, now);
        let t = self.traits;
        self.behaviour = if t.feedback {
            let controller = self
                .controller
                .get_or_insert_with(|| {
                    Controller::new(&t, crate::device::sim::Apparatus::default().mass_kg)
                        .map(Arc::new)
                })
                .clone();
            match controller {
                Ok(c) => Behaviour::Reach(Box::new(feedback::Tap::start(c, lit_other, w_eff, 0.0))),
                // No controller for these traits (a population far outside
                // the defaults): the hand stays relaxed and the test runs
                // to its timeout, which the log records.
                Err(_) => Behaviour::Idle,
            }
        } else {
            let planner = self
                .planner
                .get_or_insert_with(|| {
                    let limb = movement::settling_s(
                        t.hand_mass_kg,
                        t.hand_stiffness_n_m,
                        t.hand_damping_n_s_m,
                    );
                    Arc::new(Planner::new(t.motor_noise_s, t.feedback_s, limb))
                })
                .clone();
            Behaviour::Tap(Box::new(Tap::start(planner, lit_other, w_eff, 0.0)))
        };
        Reaction {
            inputs: vec![],
            reset_to: Some(lit_other[0]),
        }
    }

    /// The hand's reference and impedance at `now`.
    #[must_use]
    pub fn drive(&self, now: Time, sample: &DeviceSample) -> HandDrive {
        let t = &self.traits;
        match &self.behaviour {
            Behaviour::Idle => HandDrive {
                segment: self.segment,
                ..HandDrive::relaxed(sample.x_m, t.hand_damping_n_s_m)
            },
            Behaviour::Explore(e) => {
                let s = (now - e.start).secs();
                let phase = (self.stroke_w() * s).sin_cos();
                self.stroke(s, phase)
            }
            Behaviour::Slide(sl) => percept::slide_drive(
                (now - sl.start).secs(),
                SLIDE_START_M,
                t.hand_stiffness_n_m,
                t.hand_damping_n_s_m,
                self.segment,
            ),
            Behaviour::Tap(tap) => tap.drive(t, self.local(now), self.segment),
            Behaviour::Reach(reach) => reach.drive(self.segment),
        }
    }

    /// The exploring stroke's angular frequency, rad/s.
    fn stroke_w(&self) -> f64 {
        std::f64::consts::TAU * self.traits.stroke_hz
    }

    /// The exploring hand's drive `s` into the exploration, the stroke at
    /// phase `(sin, cos)`: a sinusoid ramped in over 0.25 s.
    fn stroke(&self, s: f64, (sin, cos): (f64, f64)) -> HandDrive {
        let t = &self.traits;
        let ramp = (s / 0.25).min(1.0);
        HandDrive {
            x_m: t.stroke_m * ramp * sin,
            v_m_s: t.stroke_m * ramp * self.stroke_w() * cos,
            stiffness_n_m: t.hand_stiffness_n_m,
            damping_n_s_m: t.hand_damping_n_s_m,
            integral_gain: t.hand_integral,
            segment: self.segment,
        }
    }

    /// The force the hand applies to the device this tick, N. The
    /// exploring stroke's phase is stepped ([`Phasor`]), as the simulated
    /// device calls this once per tick.
    pub fn hand_force(&mut self, now: Time, dt: f64, sample: &DeviceSample) -> f64 {
        let w = self.stroke_w();
        let d = if let Behaviour::Explore(e) = &mut self.behaviour {
            let s = (now - e.start).secs();
            let phase = e.phase.at(s, w);
            self.stroke(s, phase)
        } else {
            self.drive(now, sample)
        };
        self.hand.force(&d, sample.x_m, sample.v_m_s, dt)
    }

    /// What the participant decides after this tick, if anything.
    pub fn decide(&mut self, now: Time, sample: &DeviceSample) -> Reaction {
        // The exploring hand, every tick of a magnitude trial: in place.
        if let Behaviour::Explore(e) = &mut self.behaviour {
            e.felt.add(sample.force_n, sample.vibration, sample.v_m_s);
            if e.judged != Quality::Friction {
                e.felt.cues.add(sample.x_m, sample.v_m_s, sample.force_n);
            }
            if now < e.stop || e.answered {
                return Reaction::default();
            }
        }
        let mut behaviour = std::mem::replace(&mut self.behaviour, Behaviour::Idle);
        let reaction = match &mut behaviour {
            Behaviour::Idle => Reaction::default(),
            Behaviour::Explore(e) => {
                // Felt this tick already (above); time to answer.
                e.answered = true;
                let answer = self.answer(&e.felt, e.judged);
                Reaction {
                    inputs: vec![Input::Answer(Answer::Magnitude(answer))],
                    reset_to: None,
                }
            }
            Behaviour::Slide(sl) => self.slide_tick(sl, now, sample),
            Behaviour::Tap(tap) => {
                let (traits, s) = (self.traits, self.local(now));
                Self::click(tap.decide(&traits, s, sample.x_m, sample.v_m_s, |sd| self.normal(sd)))
            }
            Behaviour::Reach(reach) => {
                let (traits, s) = (self.traits, self.local(now));
                Self::click(
                    reach.decide(&traits, s, sample.x_m, sample.v_m_s, |sd| self.normal(sd)),
                )
            }
        };
        self.behaviour = behaviour;
        reaction
    }

    /// The reaction to a Fitts hand's step.
    fn click(step: Step) -> Reaction {
        match step {
            Step::Wait => Reaction::default(),
            Step::Click(x_m) => Reaction {
                inputs: vec![Input::Click { x_m }],
                reset_to: None,
            },
        }
    }

    fn slide_tick(&mut self, sl: &mut Slide, now: Time, sample: &DeviceSample) -> Reaction {
        let s = (now - sl.start).secs();
        if sl.forced {
            sl.felt.add(
                s,
                sample.x_m,
                sample.v_m_s,
                sample.force_n,
                sample.vibration,
            );
        } else {
            sl.trace.push((s, sample.force_n));
        }
        if now - sl.start <= Time::from_secs_saturating(SLIDE_REST_S + SLIDE_S) || sl.answered {
            return Reaction::default();
        }
        if sl.forced {
            sl.strengths[sl.stimulus] = self.perceive(&sl.felt.cues, sl.judged, |t| {
                sl.felt.strength(t.breakaway_weight, t.tactile_gain_n)
            });
        } else {
            let felt = percept::slide_features(&sl.trace);
            let desk = self.desk_memory();
            let acuity = self.traits.acuity;
            let perceived = acuity.perceive(felt, || self.normal(1.0));
            sl.distances[sl.stimulus] = acuity.distance(perceived, desk);
        }
        if sl.stimulus == 0 {
            sl.stimulus = 1;
            sl.start = now;
            sl.trace.clear();
            sl.felt = percept::BreakAway::default();
            return Reaction {
                inputs: vec![Input::Switch(1)],
                reset_to: Some(SLIDE_START_M),
            };
        }
        sl.answered = true;
        let choice = self.slide_choice(sl);
        Reaction {
            inputs: vec![Input::Answer(Answer::Paired(choice))],
            reset_to: None,
        }
    }

    /// The perceived amount of `quality`: viscosity and stiffness from
    /// their two cues ([`percept::Cues::percept`]); friction as
    /// `friction(traits)` (its felt strength, N) with the force's
    /// log-normal noise.
    fn perceive(
        &mut self,
        cues: &percept::Cues,
        quality: Quality,
        friction: impl FnOnce(&Traits) -> f64,
    ) -> f64 {
        let t = self.traits;
        match cues.percept(quality, &t.acuity, || self.normal(1.0)) {
            Some(p) => p,
            None => friction(&t).max(1e-6) * self.normal(t.acuity.force).exp(),
        }
    }

    fn answer(&mut self, felt: &Felt, quality: Quality) -> String {
        let perceived = self.perceive(&felt.cues, quality, |t| {
            felt.magnitude(t.breakaway_weight, t.tactile_gain_n)
        });
        let t = self.traits;
        let noise = self.normal(t.answer_noise);
        let value = t.modulus * perceived.max(1e-12).powf(t.exponent_of(quality)) * noise.exp();
        let text = format!("{value:.4}");
        // A value that rounds to 0.0000 keeps its digits: the engine
        // refuses an answer of zero and asks again, and the same answer
        // again looped inside one settle for ever (issue 63: a session on
        // a device that had given it nothing to feel spun at full CPU).
        if text.parse::<f64>().is_ok_and(|x| x > 0.0) {
            text
        } else {
            format!("{value:.4e}")
        }
    }

    fn magnitude_answer(&mut self) -> String {
        let (felt, quality) = match &self.behaviour {
            Behaviour::Explore(e) => (e.felt.clone(), e.judged),
            _ => (Felt::default(), Quality::Friction),
        };
        self.answer(&felt, quality)
    }

    fn paired_choice(&mut self) -> Choice {
        match std::mem::replace(&mut self.behaviour, Behaviour::Idle) {
            Behaviour::Slide(sl) => {
                let choice = self.slide_choice(&sl);
                self.behaviour = Behaviour::Slide(sl);
                choice
            }
            other => {
                self.behaviour = other;
                self.choose([0.0, 0.0])
            }
        }
    }

    /// The answer to a slide: the stronger stimulus (forced choice), the
    /// set preference if the population has one for this pair, else the
    /// one nearer the desk.
    fn slide_choice(&mut self, sl: &Slide) -> Choice {
        match (sl.forced, sl.preferred) {
            (true, _) => Self::stronger(sl.strengths),
            (false, Some(i)) => {
                let p = self.preference.as_ref().map_or(0.5, |pref| pref.p);
                let pick = if self.rng.random::<f64>() < p {
                    i
                } else {
                    1 - i
                };
                if pick == 0 {
                    Choice::First
                } else {
                    Choice::Second
                }
            }
            (false, None) => self.choose(sl.distances),
        }
    }

    /// With a set preference, which of the trial's two presented
    /// conditions (0 or 1) it names; `None` without one, or when the pair
    /// lacks it.
    fn preferred_stimulus<K: Kinds>(&self, trial: Option<&PlannedTrial<K>>) -> Option<usize> {
        let pref = self.preference.as_ref()?;
        K::preferable_stimuli(&trial?.spec)
            .iter()
            .position(|id| *id == pref.condition)
    }

    /// A forced choice: the stimulus perceived as more friction (the first
    /// on a tie, which two noisy percepts practically never are).
    fn stronger([a, b]: [f64; 2]) -> Choice {
        if b > a { Choice::Second } else { Choice::First }
    }

    fn choose(&self, [a, b]: [f64; 2]) -> Choice {
        if (a - b).abs() < self.traits.no_difference_jnd {
            Choice::NoDifference
        } else if a < b {
            Choice::First
        } else {
            Choice::Second
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Issue 63: a magnitude answered with nothing felt is still a number
    /// greater than zero, as the engine asks: once it rounded to "0.0000",
    /// which the engine refuses and asks again, for ever.
    #[test]
    fn a_magnitude_answered_with_nothing_felt_is_one_the_engine_takes() {
        for seed in 0..200 {
            let mut p = SimParticipant::new(seed, "p", &crate::participant::Population::default());
            let text = p.magnitude_answer();
            // The engine's rule for a typed magnitude (kinds::magnitude's
            // parse_magnitude, a layer above): a finite number above zero.
            let taken = text
                .trim()
                .parse::<f64>()
                .is_ok_and(|x| x.is_finite() && x > 0.0);
            assert!(taken, "seed {seed}: {text}");
        }
    }

    /// The stepped stroke stays on the exact sinusoid over a 10 s
    /// exploration at 5 kHz (a clock summed tick by tick, as the session's),
    /// and an irregular step is computed directly.
    #[test]
    fn the_stepped_stroke_phase_matches_sin_and_cos() {
        let w = std::f64::consts::TAU * 2.5;
        let (start, dt) = (123.456, 1.0 / 5000.0);
        let mut phasor = Phasor::new();
        let mut now = start;
        let mut worst = 0.0_f64;
        for _ in 0..50_000 {
            let s = now - start;
            let (sin, cos) = phasor.at(s, w);
            let (es, ec) = (w * s).sin_cos();
            worst = worst.max((sin - es).abs()).max((cos - ec).abs());
            now += dt;
        }
        assert!(worst < 1e-9, "largest error {worst}");
        let s = now - start + 0.0037;
        assert_eq!(phasor.at(s, w), (w * s).sin_cos(), "an irregular step");
    }
}
