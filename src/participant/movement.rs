//! Aimed movements in the Fitts task: minimum-jerk submovements whose
//! durations are chosen by the stochastic optimized-submovement model.
//!
//! # Mechanism and sources
//! - **Plan.** Each movement is a sequence of submovements (Meyer, Abrams,
//!   Kornblum, Wright & Smith 1988, Psychological Review 95:340-370). A
//!   submovement moves the hand's equilibrium point (Feldman 1986; the
//!   virtual trajectory of Flash & Hogan 1985) along a minimum-jerk path
//!   (Flash & Hogan 1985, J. Neurosci. 5:1688-1703: peak velocity
//!   1.875 D/T) to an aim point; the hand's spring-damper pulls the device
//!   towards it through the device's inertia, friction and viscosity. A
//!   correction shifts the equilibrium point by the perceived error, from
//!   where it was, so a device held back by friction keeps the pull it had.
//! - **Noise.** The aim scatters with signal-dependent noise: SD
//!   `S = K D / T` for amplitude `D` and duration `T` (Meyer et al. 1988,
//!   who derive it from force variability proportional to force; Harris &
//!   Wolpert 1998, Nature 394:780-784, noise proportional to the motor
//!   command). `K` is the participant's [`super::Traits::motor_noise_s`].
//! - **Duration.** The participant does not have a set duration: it
//!   picks the duration `T` that minimises the expected time to land in
//!   the target, `T + P_miss(T) (feedback + expected time of the
//!   correction)`, the optimisation of Meyer et al. 1988. With the noise
//!   law, `P_miss` depends on `T` and `D / W` only, so the chosen duration
//!   depends on the target only through `D / W` ([`Planner`]). Nothing
//!   about `log2(D / W)` is written here: whether movement time grows with
//!   Fitts' index of difficulty is for the replays to show.
//! - **Checking and clicking.** When the device has come to rest (or
//!   0.3 s after the reference ends), the participant perceives the cursor
//!   (Gaussian noise of its [`super::Traits::position_sd_m`]): inside the
//!   target's tolerance, it presses the button; else, after its visual
//!   feedback delay ([`super::Traits::feedback_s`], Keele & Posner 1968;
//!   Carlton 1981), it starts a corrective submovement towards the centre,
//!   planned the same way. After [`MAX_CORRECTIONS`] corrections it clicks
//!   anyway (free constant: people do not correct forever). A miss leaves
//!   the target lit; the participant goes on correcting from where its
//!   equilibrium point is.
//! - **Button.** A click is a press and a release of [`super::Traits::button_s`]
//!   each (the Keystroke-Level Model's `B`, 0.1 s: Card, Moran & Newell
//!   1980, CACM 23(7):396-410): the click registers when the press ends,
//!   and the next movement starts when the release ends.
//!
//! Friction and viscosity change time and errors physically: stiction
//! holds the device until the hand's pull breaks it free, and it then
//! overshoots; viscosity slows the device behind the equilibrium point.

use std::f64::consts::SQRT_2;
use std::sync::Arc;

use statrs::function::erf::erfc;

use super::Traits;
use crate::hand::HandDrive;
use crate::scenario::min_jerk;

/// Corrections after which the participant clicks anyway (free).
pub const MAX_CORRECTIONS: u32 = 3;
/// The device counts as at rest below this speed, m/s.
const AT_REST_M_S: f64 = 0.01;
/// Longest wait for rest after a submovement's reference ends, s.
const SETTLE_S: f64 = 0.3;

/// Submovements the expected time looks ahead: after this many misses in
/// a row the rest is left out of the expectation (it weighs the product of
/// their miss probabilities; a correction from a few half-widths rarely
/// misses).
const LOOKAHEAD: usize = 3;
/// The grid of `D / (W / 2)` the expected times are tabulated on
/// (log-spaced; beyond its ends the nearest end is used).
const R_RANGE: (f64, f64, usize) = (1.0, 1e4, 61);
/// Durations searched, s (log-spaced grid, then refined).
const T_RANGE: (f64, f64, usize) = (0.02, 4.0, 30);

/// The optimised-submovement planner of one participant: its noise
/// constant `K`, its feedback delay, its limb's settling time, and the
/// expected time to hit a target from distance `r` half-widths,
/// tabulated.
///
/// A submovement's duration `T` is that of the equilibrium point's
/// minimum-jerk path, and `S = K D / T` is its spread. The planner never
/// picks a `T` shorter than the limb's own settling time ([`settling_s`]):
/// the limb cannot follow a faster path, so its movement would last about
/// as long anyway while the faster command's noise grows; such a `T` is
/// dominated.
#[derive(Debug, Clone, PartialEq)]
pub struct Planner {
    k_s: f64,
    feedback_s: f64,
    settling_s: f64,
    /// `J(r)` with [`LOOKAHEAD`] - 1 submovements ahead, on [`R_RANGE`].
    ahead: Vec<f64>,
}

/// The 2 % settling time of the hand's own impedance, a second-order
/// system of mass `m`, stiffness `k` and damping `b`, s: `8 m / b` when
/// underdamped (`4 / (zeta omega_n)`), `4 / p` with `p` the slow pole
/// when overdamped (Ogata, Modern Control Engineering, the transient
/// response of second-order systems). The earliest a submovement of the
/// limb can be over.
#[must_use]
pub fn settling_s(m: f64, k: f64, b: f64) -> f64 {
    let (m, k, b) = (m.max(1e-6), k.max(1e-6), b.max(1e-6));
    let wn = (k / m).sqrt();
    let zeta = b / (2.0 * (k * m).sqrt());
    if zeta < 1.0 {
        8.0 * m / b
    } else {
        4.0 / (wn * (zeta - (zeta * zeta - 1.0).sqrt()))
    }
}

/// `ln r` of grid point `i`.
fn grid(range: (f64, f64, usize), i: usize) -> f64 {
    let (lo, hi, n) = range;
    #[expect(clippy::cast_precision_loss, reason = "small grids")]
    let f = i as f64 / (n - 1) as f64;
    lo.ln() + f * (hi.ln() - lo.ln())
}

/// What a submovement of duration `t` from `r` half-widths away does, for
/// noise constant `k_s`: the probability of landing outside the target,
/// and the expected distance left (in half-widths) when it does.
fn outcome(k_s: f64, r: f64, t: f64) -> (f64, f64) {
    // a = half-width over the endpoint SD = (W/2) / (K D / T).
    let a = t / (k_s * r).max(1e-300);
    let miss = erfc(a / SQRT_2);
    if miss < 1e-300 {
        return (0.0, 1.0);
    }
    // E[|e| | |e| > W/2] / (W/2) = (phi(a) / Q(a)) / a, the inverse Mills
    // ratio of the folded normal over a.
    let phi = (-0.5 * a * a).exp() / (2.0 * std::f64::consts::PI).sqrt();
    (miss, (phi / (miss / 2.0)) / a)
}

impl Planner {
    /// The planner for noise constant `k_s` (s), feedback delay
    /// `feedback_s` (s) and the limb's settling time `settling_s` (s).
    #[must_use]
    pub fn new(k_s: f64, feedback_s: f64, settling_s: f64) -> Self {
        let mut p = Planner {
            k_s: k_s.max(1e-6),
            feedback_s,
            settling_s: settling_s.clamp(0.0, T_RANGE.1 / 2.0),
            ahead: Vec::new(),
        };
        // J_0 = 0 beyond the look-ahead; J_d(r) = min_T T + P_miss (fb + J_{d-1}(r')).
        let mut table = vec![0.0; R_RANGE.2];
        for _ in 1..LOOKAHEAD {
            p.ahead = table;
            table = (0..R_RANGE.2)
                .map(|i| p.best(grid(R_RANGE, i).exp()).1)
                .collect();
        }
        p.ahead = table;
        p
    }

    /// Expected time to hit from `r` half-widths with the tabulated
    /// look-ahead: 0 inside the target.
    fn expected(&self, r: f64) -> f64 {
        if r <= 1.0 || self.ahead.is_empty() {
            return 0.0;
        }
        let (lo, hi, n) = R_RANGE;
        #[expect(clippy::cast_precision_loss, reason = "small grid")]
        let pos =
            ((r.ln() - lo.ln()) / (hi.ln() - lo.ln()) * (n - 1) as f64).clamp(0.0, (n - 1) as f64);
        #[expect(
            clippy::cast_possible_truncation,
            clippy::cast_sign_loss,
            reason = "clamped to the grid"
        )]
        let i = (pos.floor() as usize).min(n - 2);
        #[expect(clippy::cast_precision_loss, reason = "small grid")]
        let f = pos - i as f64;
        self.ahead[i] * (1.0 - f) + self.ahead[i + 1] * f
    }

    /// The expected time of a submovement of duration `t` from `r`
    /// half-widths, the later ones included.
    fn cost(&self, r: f64, t: f64) -> f64 {
        let (miss, left) = outcome(self.k_s, r, t);
        t + miss * (self.feedback_s + self.expected(left))
    }

    /// The duration with the least expected time from `r` half-widths,
    /// and that time: the grid's best, refined by golden-section search
    /// between its neighbours.
    fn best(&self, r: f64) -> (f64, f64) {
        let range = (self.settling_s.max(T_RANGE.0), T_RANGE.1, T_RANGE.2);
        let n = range.2;
        let (mut bi, mut bc) = (0, f64::INFINITY);
        for i in 0..n {
            let c = self.cost(r, grid(range, i).exp());
            if c < bc {
                (bi, bc) = (i, c);
            }
        }
        let (mut lo, mut hi) = (
            grid(range, bi.saturating_sub(1)).exp(),
            grid(range, (bi + 1).min(n - 1)).exp(),
        );
        let g = (5.0_f64.sqrt() - 1.0) / 2.0;
        // 24 steps shrink the bracket (two grid steps, 44 %) to 1e-5 of
        // itself.
        for _ in 0..24 {
            let (a, b) = (hi - g * (hi - lo), lo + g * (hi - lo));
            if self.cost(r, a) < self.cost(r, b) {
                hi = b;
            } else {
                lo = a;
            }
        }
        let t = 0.5 * (lo + hi);
        let c = self.cost(r, t);
        if c < bc {
            (t, c)
        } else {
            (grid(range, bi).exp(), bc)
        }
    }

    /// The duration the participant gives a submovement of `distance` to a
    /// target `width` wide (m), s: the least expected time to land in it.
    #[must_use]
    pub fn duration(&self, distance: f64, width: f64) -> f64 {
        let r = distance.abs() / (width / 2.0).max(1e-9);
        self.best(r.max(1.0)).0
    }

    /// The SD of the aim of a submovement of `distance` in `duration`, m
    /// (`K D / T`).
    #[must_use]
    pub fn aim_sd(&self, distance: f64, duration: f64) -> f64 {
        self.k_s * distance.abs() / duration.max(1e-9)
    }
}

/// One Fitts test in progress.
#[derive(Debug, Clone)]
pub struct Tap {
    planner: Arc<Planner>,
    centres: [f64; 2],
    lit: usize,
    width: f64,
    from: f64,
    to: f64,
    t0: f64,
    duration: f64,
    settling_since: Option<f64>,
    /// The button is being pressed; the click registers at this time.
    pressing: Option<f64>,
    waiting: bool,
    corrections: u32,
    /// Where the participant saw the cursor when it last judged it.
    perceived: f64,
}

/// What the participant does after a tick.
#[derive(Debug, Clone, Copy)]
pub enum Step {
    /// Keep moving or waiting.
    Wait,
    /// Click at this position.
    Click(f64),
}

impl Tap {
    /// A new test: the hand at rest on the first lit target.
    #[must_use]
    pub fn start(planner: Arc<Planner>, centres: [f64; 2], width: f64, now: f64) -> Self {
        Tap {
            planner,
            centres,
            lit: 0,
            width,
            from: centres[0],
            to: centres[0],
            t0: now,
            duration: 0.0,
            settling_since: None,
            pressing: None,
            waiting: false,
            corrections: 0,
            perceived: centres[0],
        }
    }

    /// A new screen after a click: `lit` now shows, `width` counts; the next
    /// submovement goes from where the last one aimed, once the button is
    /// released. After a hit it aims at the new target's centre; after a
    /// miss (the same target still lit) it is one more correction by the
    /// error the participant saw when it clicked, so the pull built against
    /// friction is kept rather than dropped back to the centre. Returns
    /// whether the target changed (a hit), which starts a new movement
    /// segment.
    pub fn next_target(
        &mut self,
        traits: &Traits,
        lit_m: f64,
        width: f64,
        now: f64,
        normal: impl FnOnce(f64) -> f64,
    ) -> bool {
        let lit = usize::from((lit_m - self.centres[0]).abs() >= 1e-12);
        let changed = lit != self.lit;
        let from = self.to;
        self.lit = lit;
        self.width = width;
        self.corrections = 0;
        let shift = if changed {
            self.centres[lit] - from
        } else {
            self.centres[lit] - self.perceived
        };
        self.submovement(from, shift, now + traits.button_s, normal);
        changed
    }

    /// A submovement of the equilibrium point from `from` by `shift`, in
    /// the duration the planner picks for it, its aim scattered by the
    /// noise of that amplitude and duration, starting at `t0`.
    fn submovement(&mut self, from: f64, shift: f64, t0: f64, normal: impl FnOnce(f64) -> f64) {
        let duration = self.planner.duration(shift, self.width);
        self.from = from;
        self.to = from + shift + normal(self.planner.aim_sd(shift, duration));
        self.t0 = t0;
        self.duration = duration;
        self.settling_since = None;
        self.pressing = None;
        self.waiting = false;
    }

    /// The hand's reference at `now` (impedance from `traits`).
    #[must_use]
    pub fn drive(&self, traits: &Traits, now: f64, segment: u32) -> HandDrive {
        let (x_m, v_m_s) = min_jerk(self.from, self.to, self.duration, now - self.t0);
        HandDrive {
            x_m,
            v_m_s,
            stiffness_n_m: traits.hand_stiffness_n_m,
            damping_n_s_m: traits.hand_damping_n_s_m,
            // Equilibrium-point control: the shifted reference is the
            // effort; no integral term on top.
            integral_gain: 0.0,
            segment,
        }
    }

    /// After a tick with the device at `x_m`, `v_m_s`: click, correct or
    /// keep going. `normal(sd)` draws N(0, sd).
    pub fn decide(
        &mut self,
        traits: &Traits,
        now: f64,
        x_m: f64,
        v_m_s: f64,
        mut normal: impl FnMut(f64) -> f64,
    ) -> Step {
        if let Some(at) = self.pressing {
            if now >= at {
                self.pressing = None;
                self.waiting = true;
                return Step::Click(x_m);
            }
            return Step::Wait;
        }
        if self.waiting || now < self.t0 + self.duration {
            return Step::Wait;
        }
        let since = *self.settling_since.get_or_insert(now);
        if v_m_s.abs() > AT_REST_M_S && now - since < SETTLE_S {
            return Step::Wait;
        }
        let centre = self.centres[self.lit];
        let perceived = x_m + normal(traits.position_sd_m);
        self.perceived = perceived;
        if (perceived - centre).abs() <= self.width / 2.0 || self.corrections >= MAX_CORRECTIONS {
            self.pressing = Some(now + traits.button_s);
            return Step::Wait;
        }
        self.corrections += 1;
        let from = self.to;
        self.submovement(from, centre - perceived, now + traits.feedback_s, normal);
        Step::Wait
    }
}

#[cfg(test)]
mod tests {
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;
    use rand_distr::{Distribution, Normal};

    use super::*;
    use crate::participant::population::Population;

    fn traits() -> Traits {
        Traits::draw(1, "p", &Population::default())
    }

    fn planner(t: &Traits) -> Arc<Planner> {
        Arc::new(Planner::new(
            t.motor_noise_s,
            t.feedback_s,
            settling_s(t.hand_mass_kg, t.hand_stiffness_n_m, t.hand_damping_n_s_m),
        ))
    }

    /// Runs `decide` on a device held at `x_m` until the participant
    /// clicks; returns when it decided (pressed) and when the click came.
    fn click_when_held(tap: &mut Tap, traits: &Traits, x_m: f64, mut now: f64) -> (f64, f64) {
        let mut pressed = None;
        loop {
            now += 0.001;
            let step = tap.decide(traits, now, x_m, 0.0, |_| 0.0);
            if pressed.is_none() && tap.pressing.is_some() {
                pressed = Some(now);
            }
            if let Step::Click(at) = step {
                assert!((at - x_m).abs() < 1e-12);
                return (pressed.unwrap_or(now), now);
            }
            assert!(now < 100.0, "never clicked");
        }
    }

    #[test]
    fn a_minimum_jerk_reference_peaks_at_1_875_d_over_t_halfway() {
        let (d, t) = (0.024, 0.4);
        let (x, v) = min_jerk(0.0, d, t, t / 2.0);
        assert!((v - 1.875 * d / t).abs() < 1e-12, "{v}");
        assert!((x - d / 2.0).abs() < 1e-12);
        let peak = (1..1000)
            .map(|i| min_jerk(0.0, d, t, t * f64::from(i) / 1000.0).1)
            .fold(0.0, f64::max);
        assert!((peak - 1.875 * d / t).abs() < 1e-12, "{peak}");
    }

    /// The aim's spread is K D / T: measured over 4000 submovements of
    /// two limbs, one settling in 0.2 s, one in 0.4 s (each planner's
    /// movement lasts its limb's settling time or longer): the faster
    /// movement scatters more, in proportion.
    #[test]
    fn the_aim_spreads_as_k_d_over_t_so_faster_is_wider() {
        let t = traits();
        let d = 0.02;
        let width = 0.004;
        let normal = Normal::new(0.0, 1.0).expect("unit normal");
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        let mut spreads = Vec::new();
        for settling in [0.2, 0.4] {
            let p = Arc::new(Planner::new(t.motor_noise_s, t.feedback_s, settling));
            let mut tap = Tap::start(p.clone(), [0.0, d], width, 0.0);
            let n = 4000;
            let aims: Vec<f64> = (0..n)
                .map(|_| {
                    tap.submovement(0.0, d, 0.0, |sd| sd * normal.sample(&mut rng));
                    tap.to
                })
                .collect();
            let mean = aims.iter().sum::<f64>() / f64::from(n);
            let sd =
                (aims.iter().map(|a| (a - mean).powi(2)).sum::<f64>() / f64::from(n - 1)).sqrt();
            let duration = p.duration(d, width);
            assert!(duration >= settling, "{duration} s, limb {settling} s");
            let law = t.motor_noise_s * d / duration;
            // SE of an SD over 4000 draws: 1.1 %.
            assert!(
                (sd / law - 1.0).abs() < 0.05,
                "limb {settling}: sd {sd} vs K D/T {law}"
            );
            spreads.push((duration, sd));
        }
        assert!(spreads[0].0 < spreads[1].0, "{spreads:?}");
        let ratio = (spreads[0].1 / spreads[1].1) / (spreads[1].0 / spreads[0].0);
        assert!(
            (ratio - 1.0).abs() < 0.07,
            "spread ratio over speed ratio {ratio}"
        );
    }

    /// The chosen duration depends on the target through D / W only (the
    /// noise law makes the miss probability a function of K D / (T W)),
    /// and is never shorter than the limb's settling time.
    #[test]
    fn the_planned_duration_depends_on_distance_over_width_only() {
        let t = traits();
        let limb = settling_s(t.hand_mass_kg, t.hand_stiffness_n_m, t.hand_damping_n_s_m);
        for p in [
            Planner::new(t.motor_noise_s, t.feedback_s, limb),
            Planner::new(0.05, 0.15, 0.0),
        ] {
            for (d, w) in [(0.01, 0.002), (0.024, 0.006), (0.016, 0.004), (0.3, 0.001)] {
                let (a, b) = (p.duration(d, w), p.duration(2.0 * d, 2.0 * w));
                assert!((a - b).abs() < 1e-9, "{d}/{w}: {a} vs {b}");
                assert!(
                    a >= p.settling_s - 1e-12,
                    "{a} under the limb's {}",
                    p.settling_s
                );
            }
        }
    }

    /// The limb's settling time: `8 m / b` underdamped, the slow pole's
    /// `4 / p` overdamped (here m 1 kg, k 100 N/m, b 40 N s/m: poles 2.68
    /// and 37.3 rad/s).
    #[test]
    fn the_limbs_settling_time_is_the_second_order_systems() {
        assert!((settling_s(0.5, 400.0, 20.0) - 0.2).abs() < 1e-12);
        let slow = 20.0 - 300.0_f64.sqrt();
        assert!((settling_s(1.0, 100.0, 40.0) - 4.0 / slow).abs() < 1e-12);
    }

    /// Meyer et al.'s optimum: the chosen duration's expected time is no
    /// larger than that of any other duration the limb allows.
    #[test]
    fn the_planned_duration_minimises_the_expected_time() {
        for p in [
            Planner::new(0.015, 0.15, 0.2),
            Planner::new(0.05, 0.15, 0.0),
        ] {
            for r in [2.0, 8.0, 30.0] {
                let (t, best) = p.best(r);
                for i in 0..200 {
                    let other = p.settling_s.max(0.02) + f64::from(i) * 0.01;
                    assert!(
                        p.cost(r, other) >= best - 1e-9,
                        "r {r}: {other} s beats {t} s"
                    );
                }
            }
        }
    }

    #[test]
    fn a_click_registers_one_button_press_after_the_decision() {
        let t = traits();
        let mut tap = Tap::start(planner(&t), [0.0, 0.1], 0.002, 0.0);
        assert!(tap.next_target(&t, 0.1, 0.002, 0.0, |_| 0.0));
        assert!(
            (tap.t0 - t.button_s).abs() < 1e-12,
            "the release comes first"
        );
        let (pressed, clicked) = click_when_held(&mut tap, &t, 0.1, 0.0);
        assert!(
            (clicked - pressed - t.button_s).abs() < 1.5e-3,
            "{pressed} {clicked}"
        );
    }

    #[test]
    fn a_miss_keeps_the_pull_built_against_a_stuck_device() {
        let traits = traits();
        let (centre, width, held) = (0.1, 0.002, 0.095);
        let mut tap = Tap::start(planner(&traits), [0.0, centre], width, 0.0);
        assert!(tap.next_target(&traits, centre, width, 0.0, |_| 0.0));
        // Stuck 5 mm short: each correction adds the seen error to the aim.
        let (_, now) = click_when_held(&mut tap, &traits, held, 0.0);
        let aim = |tap: &Tap| tap.drive(&traits, 1e3, 0).x_m;
        let before = aim(&tap);
        let expected = centre + f64::from(MAX_CORRECTIONS) * (centre - held);
        assert!((before - expected).abs() < 1e-12, "{before} vs {expected}");
        // The miss leaves the target lit: one more correction, not a reset.
        assert!(!tap.next_target(&traits, centre, width, now, |_| 0.0));
        let after = aim(&tap);
        assert!((after - (before + centre - held)).abs() < 1e-12, "{after}");
        // A hit on the other target aims at its centre.
        let (_, now) = click_when_held(&mut tap, &traits, centre, now);
        assert!(tap.next_target(&traits, 0.0, width, now, |_| 0.0));
        assert!(aim(&tap).abs() < 1e-12);
    }
}
