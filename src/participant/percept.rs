//! What the simulated participant feels and how it judges it.
//!
//! # Friction strength (magnitude estimation)
//! The participant judges friction from the tangential force at break-away
//! and while sliding, and from the vibration on its skin:
//! `felt = w F_peak + (1 - w) F_mean + g V_rms`. `F_peak` is the mean of
//! the largest |force| of each stroke (a stroke ends where the velocity
//! reverses: break-away comes once per stroke), `F_mean` the mean |force|
//! over the exploration, `V_rms` the RMS vibrotactile drive. Sources and
//! free constants:
//! - that people judge friction from the tangential force at break-away and
//!   during sliding: the seeds (000's static coefficient, 001's claim that
//!   perceived friction follows the static coefficient). No source gives the
//!   weight `w`: it is [`super::Population::breakaway_weight`], free (0.5,
//!   no preference), and swept in `analysis/claims.md`'s robustness table;
//! - no source gives the force a vibrotactile drive feels like (`g`,
//!   [`super::Population::tactile_gain_n`]): free, reported as a function of
//!   it, never tuned;
//! - the felt magnitude carries the participant's Weber noise (log-normal,
//!   SD = its force Weber fraction; 7-15 %, Jones 1989; Pang, Tan & Durlach
//!   1991), then Stevens' power law (Stevens 1957) with the participant's own
//!   exponent, modulus and log-normal answer noise.
//!
//! # Viscosity and stiffness: two cues, each with its own noise
//! A quality other than friction is judged from the cues it is made of
//! (Jones & Hunter's analysis of stiffness and viscosity as force over
//! displacement and force over velocity): the RMS force on the hand and
//! the RMS velocity of the hand (viscosity), or its RMS displacement from
//! where the exploration started (stiffness), over the exploration. Each
//! cue is perceived with its own log-normal noise: the force with the
//! force Weber fraction, the velocity and the displacement with their
//! kinesthetic Weber fractions ([`super::Population::velocity_weber`],
//! [`super::Population::displacement_weber`], with their sources). The
//! percept is the ratio of the perceived cues ([`Cues::percept`]), so its
//! own Weber fraction is what the two noises imply together, and nothing
//! else: `sqrt(sigma_F^2 + sigma_cue^2)` in ln units. Magnitude estimates
//! of each quality follow its own Stevens exponent where the literature
//! measures one (viscosity: Stevens & Guirao 1964; stiffness: Harper &
//! Stevens 1964), the friction exponent being free.
//!
//! # Nearness to a real surface (paired comparison)
//! Each slide (seed 000's: rest, then the hand's reference moves at
//! 0.03 m/s) is summarised by three features of the force the finger felt
//! ([`slide_features`]): the peak |force| (break-away), the mean |force| late
//! in the slide (the sliding level) and the RMS of the force high-passed at
//! 20 Hz late in the slide (the vibration still going; vibration-sensitive
//! receptors hardly respond to slow drift). Each feature is perceived with
//! log-normal noise of SD = the participant's Weber fraction for it (force
//! 7-15 %; vibration amplitude 15-30 %, Gescheider et al. 1990 report about
//! 1.5 dB), the vibration above a floor [`super::Population::vibration_floor_n`]
//! (free). The distance of a stimulus to the remembered desk is the
//! Euclidean norm of the per-feature log differences in units of the Weber
//! fraction (JNDs). The nearer stimulus wins; distances within
//! [`super::Population::no_difference_jnd`] (free, 1 JND) answer "no
//! difference".
//!
//! The desk is a physical contact the participant explores in the reference
//! phase ([`desk_slide`]): the participant's own hand (mass, stiffness,
//! damping) slides a finger on a surface whose friction is seed 002's Dahl
//! model (presliding and hysteresis, no stiction: the model seed 002
//! identified for a real contact) at `mu_desk F_N`. No source gives a
//! finger-on-desk coefficient for seed 000's desk: `mu_desk` is free (0.6,
//! the rendered conditions' dynamic coefficient, so the renderings match the
//! desk's sliding level and differ in what the study varies) and swept.

use crate::friction::{DahlParams, ForceLimit, Friction, Input, ModelParams};
use crate::hand::{Hand, HandDrive};
use crate::protocol::kind::Quality;

/// Seed 000's slide, as the participant performs it: rest, then the hand's
/// reference moves at this speed (seed 000: "about 0.03 m/s").
pub const SLIDE_REST_S: f64 = 1.0;
/// Slide speed, m/s.
pub const SLIDE_SPEED_M_S: f64 = 0.03;
/// Slide duration after the rest, s; the hand lags its reference by about
/// a centimetre, so the device stays inside its 3.2 cm range.
pub const SLIDE_S: f64 = 1.6;
/// The late window, after the rest, over which the sliding level and the
/// remaining vibration are felt, s.
const LATE: (f64, f64) = (0.8, SLIDE_S);

/// A slide's features: peak |force|, late mean |force|, late vibration RMS
/// (N each).
pub type Features = [f64; 3];

/// The features of a slide's force trace, `(time since the slide's start,
/// force)`, rest included (see the module docs).
#[must_use]
pub fn slide_features(trace: &[(f64, f64)]) -> Features {
    // First-order high-pass at 20 Hz.
    let rc = 1.0 / (std::f64::consts::TAU * 20.0);
    let (mut y, mut prev) = (0.0, trace.first().copied().unwrap_or((0.0, 0.0)));
    let (mut peak, mut level, mut vib, mut n) = (0.0_f64, 0.0, 0.0, 0.0);
    for &(t, f) in trace {
        let dt = (t - prev.0).max(0.0);
        y = rc / (rc + dt) * (y + f - prev.1);
        prev = (t, f);
        let s = t - SLIDE_REST_S;
        if s < 0.0 {
            continue;
        }
        peak = peak.max(f.abs());
        if s >= LATE.0 && s <= LATE.1 {
            level += f.abs();
            vib += y * y;
            n += 1.0;
        }
    }
    if n > 0.0 {
        [peak, level / n, (vib / n).sqrt()]
    } else {
        [peak, 0.0, 0.0]
    }
}

/// How far the device travels, from where the slide leaves rest, over
/// which a forced choice's friction is felt, m. The slide's hand runs on
/// for 4.8 cm of reference against the device's 3.2 cm range, so later in
/// the slide the device can meet the end of its range, whose jolt is no
/// friction (free: 15 mm, under half the range).
pub const FORCED_TRAVEL_M: f64 = 0.015;

/// Root-mean-square force, velocity and displacement over an exploration:
/// the cues viscosity and stiffness are judged from.
#[derive(Debug, Clone, Default)]
pub struct Cues {
    x0: Option<f64>,
    f2: f64,
    v2: f64,
    x2: f64,
    n: f64,
}

impl Cues {
    /// One sample: device position, velocity, force on the hand.
    pub fn add(&mut self, x_m: f64, v_m_s: f64, force_n: f64) {
        let x0 = *self.x0.get_or_insert(x_m);
        self.f2 += force_n * force_n;
        self.v2 += v_m_s * v_m_s;
        self.x2 += (x_m - x0) * (x_m - x0);
        self.n += 1.0;
    }

    /// RMS force (N), velocity (m/s) and displacement from the first
    /// sample (m).
    #[must_use]
    pub fn rms(&self) -> [f64; 3] {
        let n = self.n.max(1.0);
        [
            (self.f2 / n).sqrt(),
            (self.v2 / n).sqrt(),
            (self.x2 / n).sqrt(),
        ]
    }

    /// The perceived viscosity (N s/m) or stiffness (N/m): the perceived
    /// RMS force over the perceived RMS velocity or displacement, each
    /// with its own log-normal noise (`normal()` draws N(0, 1)). `None`
    /// for friction, which is judged from other features.
    pub fn percept(
        &self,
        quality: Quality,
        acuity: &Acuity,
        mut normal: impl FnMut() -> f64,
    ) -> Option<f64> {
        let [f, v, x] = self.rms();
        let (cue, weber) = match quality {
            Quality::Friction => return None,
            Quality::Viscosity => (v, acuity.velocity),
            Quality::Stiffness => (x, acuity.displacement),
        };
        let force = f.max(1e-9) * (acuity.force * normal()).exp();
        let cue = cue.max(1e-12) * (weber * normal()).exp();
        Some(force / cue)
    }
}

/// What a two-interval forced choice ("which felt like more friction")
/// feels of a slide: over the first [`FORCED_TRAVEL_M`] of travel after
/// the rest, the break-away (peak |force|), the mean |force| and the RMS
/// vibrotactile drive. Its strength is the magnitude estimate's `felt` of
/// the module docs over that stretch: `w F_peak + (1 - w) F_mean + g
/// V_rms`. The participant perceives it with log-normal noise of SD its
/// force Weber fraction, so where the strength scales with a parameter
/// its Weber fraction for that parameter at two-interval criterion `c` is
/// `exp(sqrt(2) sigma Phi^-1(c)) - 1`.
#[derive(Debug, Clone, Default)]
pub struct BreakAway {
    x0: Option<f64>,
    peak: f64,
    sum: f64,
    n: f64,
    vib2: f64,
    done: bool,
    /// The same stretch's cues, for viscosity and stiffness.
    pub cues: Cues,
}

impl BreakAway {
    /// One tick `s` into the slide (rest included): device position, force
    /// on the hand, vibrotactile drive.
    pub fn add(&mut self, s: f64, x_m: f64, v_m_s: f64, force_n: f64, vibration: f64) {
        if s < SLIDE_REST_S || self.done {
            return;
        }
        let x0 = *self.x0.get_or_insert(x_m);
        if (x_m - x0).abs() > FORCED_TRAVEL_M {
            self.done = true;
            return;
        }
        self.cues.add(x_m, v_m_s, force_n);
        self.peak = self.peak.max(force_n.abs());
        self.sum += force_n.abs();
        self.vib2 += vibration * vibration;
        self.n += 1.0;
    }

    /// The felt strength with break-away weight `w` and tactile gain `g`
    /// N per unit drive.
    #[must_use]
    pub fn strength(&self, w: f64, g: f64) -> f64 {
        let n = self.n.max(1.0);
        w * self.peak + (1.0 - w) * self.sum / n + g * (self.vib2 / n).sqrt()
    }
}

/// The hand of a slide: seed 000's reference motion through the hand's own
/// impedance (no integral term: the hand regulates speed, not position).
#[must_use]
pub fn slide_drive(s: f64, start_m: f64, stiffness: f64, damping: f64, segment: u32) -> HandDrive {
    let s = s - SLIDE_REST_S;
    let (x_m, v_m_s) = if s <= 0.0 {
        (start_m, 0.0)
    } else {
        (start_m + SLIDE_SPEED_M_S * s, SLIDE_SPEED_M_S)
    };
    HandDrive {
        x_m,
        v_m_s,
        stiffness_n_m: stiffness,
        damping_n_s_m: damping,
        integral_gain: 0.0,
        segment,
    }
}

/// The desk the participant slides on in the reference phase.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Desk {
    /// Friction coefficient of finger on desk.
    pub mu: f64,
    /// Normal force the finger presses with, N (seed 000's 3 N).
    pub normal_n: f64,
}

/// The force trace of the participant's hand (`mass`, `stiffness`,
/// `damping`) sliding a finger on `desk`, at 1 kHz (seed 000's rate): the
/// friction force on the finger, `(time, force)`.
#[must_use]
pub fn desk_slide(desk: Desk, mass_kg: f64, stiffness: f64, damping: f64) -> Vec<(f64, f64)> {
    const DT: f64 = 1e-3;
    // (SLIDE_REST_S + SLIDE_S) / DT steps.
    const STEPS: u32 = 2600;
    let fc = desk.mu * desk.normal_n;
    // Dahl's rest stiffness: seed 002's value for its real contact (the
    // shipped Fitts protocol's `real` block).
    let params = ModelParams::Dahl(DahlParams {
        sigma_n_m: 1e5,
        fc_pos_n: fc,
        fc_neg_n: fc,
        viscous_n_s_m: 0.0,
        ..DahlParams::default()
    });
    let Ok(mut friction) = Friction::new(&params, ForceLimit::new(1e3).unwrap_or_default(), 0.0)
    else {
        return Vec::new();
    };
    let mut hand = Hand::default();
    let (mut x, mut v) = (0.0_f64, 0.0_f64);
    let mut trace = Vec::with_capacity(STEPS as usize);
    for i in 0..STEPS {
        let t = f64::from(i) * DT;
        let f = friction.step(DT, Input { x_m: x, v_m_s: v }).force_n;
        let h = hand.force(&slide_drive(t, 0.0, stiffness, damping, 1), x, v, DT);
        v += (h + f) / mass_kg.max(1e-3) * DT;
        x += v * DT;
        trace.push((t, f));
    }
    trace
}

/// Weber fractions (SD of ln) and floor with which forces, vibrations and
/// the hand's own motion are perceived.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Acuity {
    /// Force Weber fraction.
    pub force: f64,
    /// Vibration amplitude Weber fraction.
    pub vibration: f64,
    /// Vibration floor, N.
    pub floor_n: f64,
    /// The hand's displacement, Weber fraction.
    pub displacement: f64,
    /// The hand's velocity, Weber fraction.
    pub velocity: f64,
}

impl Acuity {
    /// Features perceived with log-normal noise; `normal()` draws N(0, 1).
    pub fn perceive(&self, f: Features, mut normal: impl FnMut() -> f64) -> Features {
        [
            f[0].max(1e-6) * (self.force * normal()).exp(),
            f[1].max(1e-6) * (self.force * normal()).exp(),
            (f[2] + self.floor_n) * (self.vibration * normal()).exp(),
        ]
    }

    /// Distance between two perceived slides, in JNDs.
    #[must_use]
    pub fn distance(&self, a: Features, b: Features) -> f64 {
        let d = |x: f64, y: f64, w: f64| (x.ln() - y.ln()) / w.max(1e-9);
        (d(a[0], b[0], self.force).powi(2)
            + d(a[1], b[1], self.force).powi(2)
            + d(a[2], b[2], self.vibration).powi(2))
        .sqrt()
    }
}

/// What the hand felt while exploring a magnitude-estimation stimulus.
#[derive(Debug, Clone, Default)]
pub struct Felt {
    /// The exploration's cues, for viscosity and stiffness.
    pub cues: Cues,
    sum_abs_f: f64,
    sum_vib2: f64,
    n: f64,
    stroke_peak: f64,
    peaks: f64,
    strokes: f64,
    direction: f64,
}

impl Felt {
    /// Adds one sample: force on the hand, vibration drive, device
    /// velocity. (The cues of viscosity and stiffness are added to
    /// [`Felt::cues`] separately, only when one of them is judged: a
    /// friction study's replay does not pay for them.)
    pub fn add(&mut self, force_n: f64, vibration: f64, v_m_s: f64) {
        self.sum_abs_f += force_n.abs();
        self.sum_vib2 += vibration * vibration;
        self.n += 1.0;
        let direction = if v_m_s.abs() > 1e-3 {
            v_m_s.signum()
        } else {
            self.direction
        };
        if direction != self.direction && self.direction != 0.0 {
            self.peaks += self.stroke_peak;
            self.strokes += 1.0;
            self.stroke_peak = 0.0;
        }
        self.direction = direction;
        self.stroke_peak = self.stroke_peak.max(force_n.abs());
    }

    /// `felt` of the module docs, with break-away weight `w` and tactile
    /// gain `g` N per unit drive.
    #[must_use]
    pub fn magnitude(&self, w: f64, g: f64) -> f64 {
        let n = self.n.max(1.0);
        let peak = if self.strokes > 0.0 {
            self.peaks / self.strokes
        } else {
            self.stroke_peak
        };
        w * peak + (1.0 - w) * self.sum_abs_f / n + g * (self.sum_vib2 / n).sqrt()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_smooth_desk_feels_like_its_coulomb_level_with_no_late_vibration() {
        let desk = Desk {
            mu: 0.6,
            normal_n: 3.0,
        };
        let f = slide_features(&desk_slide(desk, 1.0, 300.0, 20.0));
        assert!((f[1] - 1.8).abs() < 0.1, "sliding level {} N", f[1]);
        assert!(f[0] < 2.0, "peak {} N", f[0]);
        assert!(f[2] < 0.01, "late vibration {} N", f[2]);
    }

    #[test]
    fn distance_counts_jnds_and_is_zero_for_equal_percepts() {
        let a = Acuity {
            force: 0.1,
            vibration: 0.2,
            floor_n: 0.05,
            displacement: 0.14,
            velocity: 0.18,
        };
        let x = [2.0, 1.0, 0.1];
        assert!(a.distance(x, x).abs() < 1e-12);
        let y = [2.0 * 0.1_f64.exp(), 1.0, 0.1];
        assert!((a.distance(x, y) - 1.0).abs() < 1e-9);
    }

    #[test]
    fn breakaway_peaks_are_averaged_per_stroke() {
        let mut felt = Felt::default();
        for (f, v) in [
            (1.0, 0.1),
            (3.0, 0.1),
            (1.0, 0.1),
            (1.0, -0.1),
            (5.0, -0.1),
            (1.0, 0.1),
        ] {
            felt.add(f, 0.0, v);
        }
        // Strokes peak at 3 and 5; mean |F| = 12/6.
        assert!((felt.magnitude(1.0, 0.0) - 4.0).abs() < 1e-12);
        assert!((felt.magnitude(0.0, 0.0) - 2.0).abs() < 1e-12);
    }

    /// The viscosity percept of a damper explored at a steady stroke: its
    /// 75 %-correct two-interval Weber fraction is what the force and
    /// velocity noises imply together, `exp(sqrt(2) sqrt(sF^2 + sv^2)
    /// Phi^-1(0.75)) - 1`; the stiffness percept's likewise with the
    /// displacement noise.
    #[test]
    fn a_ratio_percepts_weber_fraction_is_what_its_two_cues_noises_imply() {
        use rand::SeedableRng;
        use rand_distr::{Distribution, Normal};
        let acuity = Acuity {
            force: 0.1,
            vibration: 0.2,
            floor_n: 0.05,
            displacement: 0.14,
            velocity: 0.18,
        };
        let unit = Normal::new(0.0, 1.0).expect("unit normal");
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(44);
        // A stroke of 1 cm at 1.5 Hz on a damper `b` or a spring `k`.
        let explore = |quality: Quality, level: f64| {
            let mut cues = Cues::default();
            for i in 0..3000 {
                let t = f64::from(i) * 1e-3;
                let w = std::f64::consts::TAU * 1.5;
                let (x, v) = (0.01 * (w * t).sin(), 0.01 * w * (w * t).cos());
                let f = match quality {
                    Quality::Stiffness => -level * x,
                    _ => -level * v,
                };
                cues.add(x, v, f);
            }
            cues
        };
        let z75 = 0.674_489_750_196_081_7;
        for (quality, cue) in [
            (Quality::Viscosity, acuity.velocity),
            (Quality::Stiffness, acuity.displacement),
        ] {
            let sigma = (acuity.force.powi(2) + cue.powi(2)).sqrt();
            let weber = (std::f64::consts::SQRT_2 * sigma * z75).exp() - 1.0;
            let (a, b) = (
                explore(quality, 10.0),
                explore(quality, 10.0 * (1.0 + weber)),
            );
            let [ra, rb] = [&a, &b].map(Cues::rms);
            // The cue ratio of the stimulus is its level.
            assert!(
                (ra[0]
                    / if quality == Quality::Stiffness {
                        ra[2]
                    } else {
                        ra[1]
                    }
                    - 10.0)
                    .abs()
                    < 1e-6
            );
            assert!(rb[0] > ra[0]);
            let n = 40_000;
            let mut draw = || unit.sample(&mut rng);
            let correct = (0..n)
                .filter(|_| {
                    let pa = a.percept(quality, &acuity, &mut draw).expect("a ratio");
                    let pb = b.percept(quality, &acuity, &mut draw).expect("a ratio");
                    pb > pa
                })
                .count();
            #[expect(clippy::cast_precision_loss, reason = "small counts")]
            let p = correct as f64 / f64::from(n);
            // SE of a proportion over 40,000 pairs: 0.0022.
            assert!(
                (p - 0.75).abs() < 0.01,
                "{quality:?}: {p} correct at the predicted {weber}"
            );
        }
        assert!(
            explore(Quality::Friction, 1.0)
                .percept(Quality::Friction, &acuity, || 0.0)
                .is_none()
        );
    }
}
