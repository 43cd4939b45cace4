//! The simulated participant: a hand that moves the (simulated) device
//! through the rendered friction, and a perceiver that answers from what the
//! hand felt, never from the protocol's labels.
//!
//! # Determinism
//! A participant's traits are drawn from (seed, participant id); everything
//! random within a trial from (trial seed, participant id). Each trial starts
//! with the hand and the device at rest at a home position, so an answer is a
//! pure function of (seed, participant, trial), and a resumed session gets
//! the same answers as an uninterrupted one.
//!
//! # What the participant feels and answers (choices documented here)
//! - Magnitude estimation: the hand strokes sinusoidally (its own amplitude
//!   and rate) for its own exploration time (at most the protocol's). The felt
//!   magnitude is the RMS of the rendered tangential force plus the RMS of the
//!   vibrotactile drive times a force-equivalent gain. The gain is calibrated
//!   so that tactile answers are about one seventh of force answers, the
//!   seed's finding. The answer follows Stevens' power law,
//!   `modulus * felt^exponent * exp(N(0, noise))`, with a per-participant
//!   exponent and modulus.
//! - Paired comparison: for each stimulus the hand performs seed 000's slide
//!   (rest, then a slide at about 0.03 m/s, the hand regulating its speed
//!   through its own compliance: 300 N/m, 20 N s/m; a stiffer hand hides the
//!   effect). The felt waveform is summarised by how much the stick-slip
//!   vibration decays: the RMS of the force high-passed at 20 Hz late in the
//!   slide (0.45-0.65 s after break-away; the apparatus's 3.2 cm range ends
//!   the slide soon after) over early (0.1-0.3 s) ([`decay_ratio`]). The
//!   real-slide reference is [`REFERENCE_RATIO`]. Each stimulus's perceived
//!   distance to the reference is `|r - r_ref| + N(0, noise)`. The nearer
//!   wins, or `no_difference` when the distances differ by less than a
//!   threshold.
//! - Fitts: aimed minimum-jerk movements (duration from the participant's own
//!   Fitts law, aim point scattered around the target centre), tracked by the
//!   hand's impedance with an integral term (people push harder when stuck);
//!   the participant clicks once slow, if it perceives (with noise) the
//!   cursor within 80% of the half-width from the centre, else it corrects
//!   (at most 3 times, then clicks anyway). The integral term restarts with
//!   each new target, keeps building through corrections of the same one
//!   (a person pushes harder while stuck), and is limited to 12 N. Friction changes time and errors physically: stiction
//!   holds the device until the hand's force breaks it free, and it then
//!   overshoots.

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

use crate::device::DeviceSample;
use crate::hand::{Hand, HandDrive};
use crate::protocol::engine::{Action, Answer, Choice, Input, Question, Screen};
use crate::protocol::plan::PlannedTrial;
use crate::scenario::min_jerk;
use crate::session::Reaction;

/// Force-equivalent newtons per unit RMS vibrotactile drive (see module
/// docs; calibrated to the seed's tactile/force ratio of about 1/7).
pub const TACTILE_GAIN_N: f64 = 0.15;

/// Reference decay ratio of the real slide: seed 000's Fig. 3 oscillation
/// decays from 0.2 s to 0.7 s after slip onset and stops. Taken as a linear
/// decay of amplitude from 1 at 0.2 s to 0 at 0.7 s, the mean amplitude over
/// the late window (0.45-0.65 s) is 0.30 of that over the early one
/// (0.1-0.3 s).
pub const REFERENCE_RATIO: f64 = 0.3;

/// A participant's traits.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Traits {
    /// Stevens exponent.
    pub exponent: f64,
    /// Stevens modulus (the participant's own scale).
    pub modulus: f64,
    /// Log-normal answer noise (SD of ln).
    pub answer_noise: f64,
    /// Personal scaling of the tactile gain.
    pub tactile_sensitivity: f64,
    /// Exploration stroke amplitude, m.
    pub stroke_m: f64,
    /// Exploration stroke rate, Hz.
    pub stroke_hz: f64,
    /// How long the participant explores before answering, s.
    pub explore_s: f64,
    /// Noise on perceived distances in paired comparison.
    pub compare_noise: f64,
    /// Distance difference below which the answer is "no difference".
    pub no_difference: f64,
    /// Hand mass on the device, kg.
    pub hand_mass_kg: f64,
    /// Hand stiffness for aimed movements, N/m.
    pub hand_stiffness_n_m: f64,
    /// Hand damping for aimed movements, N s/m.
    pub hand_damping_n_s_m: f64,
    /// Hand integral gain (effort builds while off the plan), N/(m s).
    pub hand_integral: f64,
    /// Fitts intercept, s.
    pub fitts_a_s: f64,
    /// Fitts slope, s/bit.
    pub fitts_b_s: f64,
    /// Aim scatter, as a fraction of the effective width (SD).
    pub aim_sd: f64,
    /// Position perception noise, m (SD).
    pub perception_sd_m: f64,
}

impl Traits {
    /// Draws the traits of participant `id` in study seed `seed`.
    #[must_use]
    pub fn draw(seed: u64, id: &str) -> Self {
        let mut r = ChaCha8Rng::seed_from_u64(seed ^ id_hash(id));
        Traits {
            exponent: r.random_range(0.6..1.1),
            modulus: 10.0 * (r.random_range(-1.0..1.0_f64)).exp(),
            answer_noise: r.random_range(0.1..0.25),
            tactile_sensitivity: (r.random_range(-0.2..0.2_f64)).exp(),
            stroke_m: r.random_range(0.008..0.012),
            stroke_hz: r.random_range(1.0..2.0),
            explore_s: r.random_range(2.5..5.0),
            compare_noise: r.random_range(0.05..0.2),
            no_difference: 0.2,
            hand_mass_kg: 0.4,
            hand_stiffness_n_m: r.random_range(400.0..800.0),
            hand_damping_n_s_m: 30.0,
            hand_integral: 3000.0,
            fitts_a_s: r.random_range(0.05..0.15),
            fitts_b_s: r.random_range(0.08..0.15),
            aim_sd: r.random_range(0.1..0.25),
            perception_sd_m: 0.0002,
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
    traits: Traits,
    behaviour: Behaviour,
    hand: Hand,
    /// The hand's movement segment (see [`crate::hand`]): a new trial or a
    /// new Fitts target starts the next.
    segment: u32,
    rng: ChaCha8Rng,
}

#[derive(Debug, Clone)]
enum Behaviour {
    Idle,
    Explore(Explore),
    Slide(Slide),
    Tap(Tap),
}

#[derive(Debug, Clone)]
struct Explore {
    start: f64,
    stop: f64,
    sum_f2: f64,
    sum_vib2: f64,
    n: f64,
    answered: bool,
}

#[derive(Debug, Clone)]
struct Slide {
    stimulus: usize,
    start: f64,
    trace: Vec<(f64, f64)>,
    distances: [f64; 2],
    answered: bool,
}

/// The participant clicks when it perceives the cursor within this fraction
/// of the half-width from the target centre (people keep a margin).
const CLICK_CRITERION: f64 = 0.8;

/// Seed 000's slide on the device: rest, then the reference moves at this
/// speed; the hand tracks it through 300 N/m and 20 N s/m (STUDIES 1a).
const SLIDE_REST_S: f64 = 1.0;
const SLIDE_SPEED_M_S: f64 = 0.03;
const SLIDE_START_M: f64 = -0.0158;
/// Slide duration after the rest: break-away comes within about 0.6 s, the
/// late window ends 0.85 s after it; the hand lags its reference by about
/// 1 cm, so the device stays inside its 3.2 cm range.
const SLIDE_S: f64 = 1.6;

#[derive(Debug, Clone)]
struct Tap {
    centres: [f64; 2],
    lit: usize,
    width: f64,
    from: f64,
    to: f64,
    t0: f64,
    duration: f64,
    settling_since: Option<f64>,
    waiting: bool,
    corrections: u32,
}

impl SimParticipant {
    /// Participant `id` of a study with seed `seed`.
    #[must_use]
    pub fn new(seed: u64, id: &str) -> Self {
        SimParticipant {
            id: id.to_owned(),
            traits: Traits::draw(seed, id),
            behaviour: Behaviour::Idle,
            hand: Hand::default(),
            segment: 0,
            rng: ChaCha8Rng::seed_from_u64(seed),
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

    /// Reacts to an engine action; `trial` is the engine's current trial.
    pub fn on_action(
        &mut self,
        now: f64,
        action: &Action,
        trial: Option<&PlannedTrial>,
    ) -> Reaction {
        match action {
            Action::Show(
                Screen::Instructions(_) | Screen::Reference { .. } | Screen::Break { .. },
            )
            | Action::Prompt(_) => Reaction {
                inputs: vec![Input::Continue],
                reset_to: None,
            },
            Action::Show(Screen::Explore { until_s }) => {
                self.start_trial(trial);
                self.behaviour = Behaviour::Explore(Explore {
                    start: now,
                    stop: now + self.traits.explore_s.min(until_s - now).max(0.0),
                    sum_f2: 0.0,
                    sum_vib2: 0.0,
                    n: 0.0,
                    answered: false,
                });
                Reaction {
                    inputs: vec![],
                    reset_to: Some(0.0),
                }
            }
            Action::Show(Screen::Paired { active: 0, .. })
                if !matches!(self.behaviour, Behaviour::Slide(_)) =>
            {
                self.start_trial(trial);
                self.behaviour = Behaviour::Slide(Slide {
                    stimulus: 0,
                    start: now,
                    trace: Vec::new(),
                    distances: [0.0; 2],
                    answered: false,
                });
                Reaction {
                    inputs: vec![],
                    reset_to: Some(SLIDE_START_M),
                }
            }
            Action::Show(Screen::Fitts {
                lit_m,
                other_m,
                effective_width_m,
                missed,
                ..
            }) => self.fitts_screen(now, trial, [*lit_m, *other_m], *effective_width_m, *missed),
            Action::Ask(Question::Magnitude) => {
                let answer = self.magnitude_answer();
                Reaction {
                    inputs: vec![Input::Answer(Answer::Magnitude(answer))],
                    reset_to: None,
                }
            }
            Action::Ask(Question::PairedChoice) => Reaction {
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

    /// Reseeds the trial's randomness from (trial seed, participant).
    fn start_trial(&mut self, trial: Option<&PlannedTrial>) {
        let seed = trial.map_or(0, |t| t.seed);
        self.rng = ChaCha8Rng::seed_from_u64(seed ^ id_hash(&self.id));
        self.segment = self.segment.wrapping_add(1);
    }

    /// A Fitts screen: `w_eff` is the width that counts for a hit.
    fn fitts_screen(
        &mut self,
        now: f64,
        trial: Option<&PlannedTrial>,
        lit_other: [f64; 2],
        w_eff: f64,
        missed: bool,
    ) -> Reaction {
        if let Behaviour::Tap(t) = &mut self.behaviour {
            // After a click: a new target, or a correction after a miss.
            let lit = usize::from((lit_other[0] - t.centres[0]).abs() >= 1e-12);
            let from = t.to;
            // After a miss the participant starts a fresh correction attempt.
            let (centres, corrections) = (t.centres, 0);
            let aim_sd = self.traits.aim_sd * w_eff * if missed { 0.5 } else { 1.0 };
            let to = centres[lit] + self.normal(aim_sd);
            let duration = self.movement_time(from, to, w_eff);
            if !missed {
                self.segment = self.segment.wrapping_add(1);
            }
            self.behaviour = Behaviour::Tap(Tap {
                centres,
                lit,
                width: w_eff,
                from,
                to,
                t0: now + 0.05,
                duration,
                settling_since: None,
                waiting: false,
                corrections,
            });
            return Reaction::default();
        }
        // A new test: the hand starts at rest on the first lit target.
        self.start_trial(trial);
        let centres = lit_other;
        self.behaviour = Behaviour::Tap(Tap {
            centres,
            lit: 0,
            width: w_eff,
            from: centres[0],
            to: centres[0],
            t0: now,
            duration: 0.0,
            settling_since: None,
            waiting: false,
            corrections: 0,
        });
        Reaction {
            inputs: vec![],
            reset_to: Some(centres[0]),
        }
    }

    fn movement_time(&self, from: f64, to: f64, w: f64) -> f64 {
        self.traits.fitts_a_s + self.traits.fitts_b_s * ((to - from).abs() / w + 1.0).log2()
    }

    /// The hand's reference and impedance at `now`.
    #[must_use]
    pub fn drive(&self, now: f64, sample: &DeviceSample) -> HandDrive {
        let t = &self.traits;
        let aimed = |x_m: f64, v_m_s: f64| HandDrive {
            x_m,
            v_m_s,
            stiffness_n_m: t.hand_stiffness_n_m,
            damping_n_s_m: t.hand_damping_n_s_m,
            integral_gain: t.hand_integral,
            segment: self.segment,
        };
        match &self.behaviour {
            Behaviour::Idle => HandDrive {
                segment: self.segment,
                ..HandDrive::relaxed(sample.x_m, t.hand_damping_n_s_m)
            },
            Behaviour::Explore(e) => {
                let w = std::f64::consts::TAU * t.stroke_hz;
                let s = now - e.start;
                let ramp = (s / 0.25).min(1.0);
                aimed(
                    t.stroke_m * ramp * (w * s).sin(),
                    t.stroke_m * ramp * w * (w * s).cos(),
                )
            }
            Behaviour::Slide(sl) => {
                let s = now - sl.start - SLIDE_REST_S;
                let (x_m, v_m_s) = if s <= 0.0 {
                    (SLIDE_START_M, 0.0)
                } else {
                    (SLIDE_START_M + SLIDE_SPEED_M_S * s, SLIDE_SPEED_M_S)
                };
                HandDrive {
                    x_m,
                    v_m_s,
                    stiffness_n_m: 300.0,
                    damping_n_s_m: 20.0,
                    integral_gain: 0.0,
                    segment: self.segment,
                }
            }
            Behaviour::Tap(tap) => {
                let (x, v) = min_jerk(tap.from, tap.to, tap.duration, now - tap.t0);
                aimed(x, v)
            }
        }
    }

    /// The force the hand applies to the device this tick, N.
    pub fn hand_force(&mut self, now: f64, dt: f64, sample: &DeviceSample) -> f64 {
        let d = self.drive(now, sample);
        self.hand.force(&d, sample.x_m, sample.v_m_s, dt)
    }

    /// What the participant decides after this tick, if anything.
    pub fn decide(&mut self, now: f64, sample: &DeviceSample) -> Reaction {
        match &mut self.behaviour {
            Behaviour::Idle => Reaction::default(),
            Behaviour::Explore(e) => {
                e.sum_f2 += sample.force_n * sample.force_n;
                e.sum_vib2 += sample.vibration * sample.vibration;
                e.n += 1.0;
                if now >= e.stop && !e.answered {
                    e.answered = true;
                    let answer = self.magnitude_answer();
                    return Reaction {
                        inputs: vec![Input::Answer(Answer::Magnitude(answer))],
                        reset_to: None,
                    };
                }
                Reaction::default()
            }
            Behaviour::Slide(sl) => {
                sl.trace.push((now - sl.start, sample.force_n));
                let done = now - sl.start > SLIDE_REST_S + SLIDE_S;
                if !done || sl.answered {
                    return Reaction::default();
                }
                let ratio = decay_ratio(&sl.trace);
                let stimulus = sl.stimulus;
                let noise = self.normal(self.traits.compare_noise);
                let distance = (ratio - REFERENCE_RATIO).abs() + noise;
                let Behaviour::Slide(sl) = &mut self.behaviour else {
                    return Reaction::default();
                };
                sl.distances[stimulus] = distance;
                if stimulus == 0 {
                    sl.stimulus = 1;
                    sl.start = now;
                    sl.trace.clear();
                    Reaction {
                        inputs: vec![Input::Switch(1)],
                        reset_to: Some(SLIDE_START_M),
                    }
                } else {
                    sl.answered = true;
                    Reaction {
                        inputs: vec![Input::Answer(Answer::Paired(self.paired_choice()))],
                        reset_to: None,
                    }
                }
            }
            Behaviour::Tap(tap) => {
                if tap.waiting || now < tap.t0 + tap.duration {
                    return Reaction::default();
                }
                let since = *tap.settling_since.get_or_insert(now);
                if sample.v_m_s.abs() > 0.01 && now - since < 0.3 {
                    return Reaction::default();
                }
                let (centre, width, corrections, x) =
                    (tap.centres[tap.lit], tap.width, tap.corrections, sample.x_m);
                let perceived = x + self.normal(self.traits.perception_sd_m);
                let Behaviour::Tap(tap) = &mut self.behaviour else {
                    return Reaction::default();
                };
                if (perceived - centre).abs() <= CLICK_CRITERION * width / 2.0 || corrections >= 3 {
                    tap.waiting = true;
                    tap.to = x;
                    return Reaction {
                        inputs: vec![Input::Click { x_m: x }],
                        reset_to: None,
                    };
                }
                tap.corrections += 1;
                let aim = self.traits.aim_sd * width * 0.5;
                let to = centre + self.normal(aim);
                let duration = self.movement_time(x, to, width);
                let Behaviour::Tap(tap) = &mut self.behaviour else {
                    return Reaction::default();
                };
                *tap = Tap {
                    from: x,
                    to,
                    t0: now + 0.05,
                    duration,
                    settling_since: None,
                    ..tap.clone()
                };
                Reaction::default()
            }
        }
    }

    fn magnitude_answer(&mut self) -> String {
        let (f2, v2, n) = match &self.behaviour {
            Behaviour::Explore(e) => (e.sum_f2, e.sum_vib2, e.n.max(1.0)),
            _ => (0.0, 0.0, 1.0),
        };
        let t = self.traits;
        let felt = (f2 / n).sqrt() + TACTILE_GAIN_N * t.tactile_sensitivity * (v2 / n).sqrt();
        let noise = self.normal(t.answer_noise);
        let value = t.modulus * felt.max(1e-6).powf(t.exponent) * noise.exp();
        format!("{value:.4}")
    }

    fn paired_choice(&mut self) -> Choice {
        let [a, b] = match &self.behaviour {
            Behaviour::Slide(sl) => sl.distances,
            _ => [0.0, 0.0],
        };
        if (a - b).abs() < self.traits.no_difference {
            Choice::NoDifference
        } else if a < b {
            Choice::First
        } else {
            Choice::Second
        }
    }
}

/// How much a slide's stick-slip vibration decays: the RMS of the force,
/// high-passed at 20 Hz (what vibration-sensitive receptors feel; a slow
/// drift or a single step hardly counts), over 0.45-0.65 s after break-away,
/// divided by that over 0.1-0.3 s. `trace` holds (time since the slide's
/// start, force). Break-away is the first time after the rest that |force|
/// falls below 80% of its running peak (the first slip releases the holding
/// force).
#[must_use]
pub fn decay_ratio(trace: &[(f64, f64)]) -> f64 {
    let mut peak: f64 = 0.0;
    let mut breakaway = None;
    for &(t, f) in trace.iter().filter(|(t, _)| *t >= SLIDE_REST_S) {
        peak = peak.max(f.abs());
        if peak > 0.5 && f.abs() < 0.8 * peak {
            breakaway = Some(t);
            break;
        }
    }
    let Some(onset) = breakaway else {
        return 0.0;
    };
    // First-order high-pass at 20 Hz.
    let rc = 1.0 / (std::f64::consts::TAU * 20.0);
    let mut high = Vec::with_capacity(trace.len());
    let (mut y, mut prev) = (0.0, trace.first().map_or((0.0, 0.0), |p| *p));
    for &(t, f) in trace {
        let dt = (t - prev.0).max(0.0);
        let a = rc / (rc + dt);
        y = a * (y + f - prev.1);
        prev = (t, f);
        high.push((t, y));
    }
    let rms = |a: f64, b: f64| {
        let (sum, n) = high
            .iter()
            .filter(|(t, _)| *t >= onset + a && *t <= onset + b)
            .fold((0.0, 0.0), |(s, n), (_, y)| (s + y * y, n + 1.0));
        if n > 0.0 { (sum / n).sqrt() } else { 0.0 }
    };
    let early = rms(0.1, 0.3);
    if early <= 0.0 {
        0.0
    } else {
        rms(0.45, 0.65) / early
    }
}
