//! Aimed movements in the Fitts task: stochastic optimized submovements.
//!
//! # Mechanism and sources
//! - Each movement is a sequence of submovements (Meyer, Abrams, Kornblum,
//!   Wright & Smith 1988). A submovement moves the hand's equilibrium point
//!   (Feldman 1986; the virtual trajectory of Flash & Hogan 1985) along a
//!   minimum-jerk path to an aim point; the hand's spring-damper pulls the
//!   device towards it through the device's inertia and friction. A
//!   correction shifts the equilibrium point by the perceived error, from
//!   where it was, so a device held back by friction keeps the pull it had.
//!   There is no integral term: the pull on a device stuck by stiction grows
//!   only as the participant sees the error and corrects again, one
//!   feedback delay at a time.
//! - Its endpoint scatters with signal-dependent noise: SD proportional to
//!   the amplitude (Meyer et al. 1988, `S = K D / T`; Harris & Wolpert 1998,
//!   noise proportional to the motor command). The proportion is the
//!   participant's [`super::Traits::motor_noise`].
//! - Every submovement lasts the participant's
//!   [`super::Traits::submovement_s`], whatever its amplitude or the target
//!   (Crossman & Goodeve 1963/1983: corrections of constant duration). There
//!   is no duration law and nothing here depends on the target's width
//!   except the participant's judgement of whether it is inside.
//! - When the device has come to rest (or 0.3 s after the reference ends),
//!   the participant perceives the cursor (Gaussian noise of its
//!   [`super::Traits::position_sd_m`]): inside the target's tolerance, it
//!   clicks; else, after its visual feedback delay
//!   ([`super::Traits::feedback_s`], Keele & Posner 1968; Carlton 1981), it
//!   starts a corrective submovement towards the centre. After
//!   [`MAX_CORRECTIONS`] corrections it clicks anyway (free constant: people
//!   do not correct forever). A miss leaves the target lit; the participant
//!   goes on correcting from where its equilibrium point is.
//!
//! So the number of submovements, and with it the movement time, grows with
//! distance over width because the noise does: Fitts' law is not written
//! here. Friction changes time and errors physically: stiction holds the
//! device until the hand's force (with the effort that builds while it is
//! stuck, [`crate::hand`]) breaks it free, and it then overshoots.

use super::Traits;
use crate::hand::HandDrive;
use crate::scenario::min_jerk;

/// Corrections after which the participant clicks anyway (free).
pub const MAX_CORRECTIONS: u32 = 3;
/// Delay from a click to the next primary submovement, s (free: in the
/// reciprocal task the next target is known in advance).
const CLICK_TO_MOVE_S: f64 = 0.05;
/// The device counts as at rest below this speed, m/s.
const AT_REST_M_S: f64 = 0.01;
/// Longest wait for rest after a submovement's reference ends, s.
const SETTLE_S: f64 = 0.3;

/// One Fitts test in progress.
#[derive(Debug, Clone)]
pub struct Tap {
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
    /// Where the participant saw the cursor when it last judged it.
    perceived: f64,
}

/// What the participant does after a tick.
pub enum Step {
    /// Keep moving or waiting.
    Wait,
    /// Click at this position.
    Click(f64),
}

impl Tap {
    /// A new test: the hand at rest on the first lit target.
    #[must_use]
    pub fn start(centres: [f64; 2], width: f64, now: f64) -> Self {
        Tap {
            centres,
            lit: 0,
            width,
            from: centres[0],
            to: centres[0],
            t0: now,
            duration: 0.0,
            settling_since: None,
            waiting: false,
            corrections: 0,
            perceived: centres[0],
        }
    }

    /// A new screen after a click: `lit` now shows, `width` counts; the next
    /// submovement goes from where the last one aimed. After a hit it aims at
    /// the new target's centre; after a miss (the same target still lit) it
    /// is one more correction by the error the participant saw when it
    /// clicked, so the pull built against friction is kept rather than
    /// dropped back to the centre. Returns whether the target changed (a
    /// hit), which starts a new movement segment.
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
        self.submovement(traits, from, shift, now + CLICK_TO_MOVE_S, normal);
        changed
    }

    /// A submovement of the equilibrium point from `from` by `shift` (plus
    /// the motor noise of that amplitude), starting at `t0`.
    fn submovement(
        &mut self,
        traits: &Traits,
        from: f64,
        shift: f64,
        t0: f64,
        normal: impl FnOnce(f64) -> f64,
    ) {
        self.from = from;
        self.to = from + shift + normal(traits.motor_noise * shift.abs());
        self.t0 = t0;
        self.duration = traits.submovement_s;
        self.settling_since = None;
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
            self.waiting = true;
            return Step::Click(x_m);
        }
        self.corrections += 1;
        let from = self.to;
        self.submovement(
            traits,
            from,
            centre - perceived,
            now + traits.feedback_s,
            normal,
        );
        Step::Wait
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::participant::population::Population;

    /// Runs `decide` on a device held at `x_m` until the participant clicks.
    fn click_when_held(tap: &mut Tap, traits: &Traits, x_m: f64, mut now: f64) -> f64 {
        loop {
            now += 0.001;
            if let Step::Click(at) = tap.decide(traits, now, x_m, 0.0, |_| 0.0) {
                assert!((at - x_m).abs() < 1e-12);
                return now;
            }
            assert!(now < 100.0, "never clicked");
        }
    }

    #[test]
    fn a_miss_keeps_the_pull_built_against_a_stuck_device() {
        let traits = Traits::draw(1, "p", &Population::default());
        let (centre, width, held) = (0.1, 0.002, 0.095);
        let mut tap = Tap::start([0.0, centre], width, 0.0);
        assert!(tap.next_target(&traits, centre, width, 0.0, |_| 0.0));
        // Stuck 5 mm short: each correction adds the seen error to the aim.
        let now = click_when_held(&mut tap, &traits, held, 0.0);
        let aim = |tap: &Tap| tap.drive(&traits, 1e3, 0).x_m;
        let before = aim(&tap);
        let expected = centre + f64::from(MAX_CORRECTIONS) * (centre - held);
        assert!((before - expected).abs() < 1e-12, "{before} vs {expected}");
        // The miss leaves the target lit: one more correction, not a reset.
        assert!(!tap.next_target(&traits, centre, width, now, |_| 0.0));
        let after = aim(&tap);
        assert!((after - (before + centre - held)).abs() < 1e-12, "{after}");
        // A hit on the other target aims at its centre.
        let now = click_when_held(&mut tap, &traits, centre, now);
        assert!(tap.next_target(&traits, 0.0, width, now, |_| 0.0));
        assert!(aim(&tap).abs() < 1e-12);
    }
}
