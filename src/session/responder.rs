//! Who answers: the [`Responder`] a session drives. A simulated participant
//! answers from what its hand felt; a [`Person`] answers through the window
//! (the session hears the answers as inputs) and, on the simulated device,
//! moves the hand with the mouse.

use crate::device::DeviceSample;
use crate::hand::HandDrive;
use crate::kinds::{Action, PlannedTrial};
pub use crate::participant::Reaction;
use crate::participant::SimParticipant;
use crate::time::Time;

use super::Session;

/// Who answers the session's questions and moves the hand.
pub trait Responder {
    /// As logged in the session header (`sim`, `gui`).
    const LABEL: &'static str;
    /// Mass of the hand on the device, kg.
    fn hand_mass_kg(&self) -> f64;
    /// Reacts to an engine action at session time `now`; `trial` is the
    /// engine's current trial.
    fn on_action(&mut self, now: Time, action: &Action, trial: Option<&PlannedTrial>) -> Reaction;
    /// Reacts to a device sample (after each tick).
    fn decide(&mut self, now: Time, sample: &DeviceSample) -> Reaction;
    /// The hand's reference and impedance now (`None`: no hand on the
    /// device).
    fn drive(&self, now: Time, sample: &DeviceSample) -> Option<HandDrive>;
    /// The force the hand applies to the simulated device over the next
    /// `dt`, N.
    fn hand_force(&mut self, now: Time, dt: f64, sample: &DeviceSample) -> f64;
}

impl Responder for SimParticipant {
    const LABEL: &'static str = "sim";

    fn hand_mass_kg(&self) -> f64 {
        self.traits().hand_mass_kg
    }

    fn on_action(&mut self, now: Time, action: &Action, trial: Option<&PlannedTrial>) -> Reaction {
        SimParticipant::on_action(self, now, action, trial)
    }

    fn decide(&mut self, now: Time, sample: &DeviceSample) -> Reaction {
        SimParticipant::decide(self, now, sample)
    }

    fn drive(&self, now: Time, sample: &DeviceSample) -> Option<HandDrive> {
        Some(SimParticipant::drive(self, now, sample))
    }

    fn hand_force(&mut self, now: Time, dt: f64, sample: &DeviceSample) -> f64 {
        SimParticipant::hand_force(self, now, dt, sample)
    }
}

/// The hand a mouse drives on the simulated device: a spring-damper pulling
/// the device towards the pointer; with the pointer away, the hand only
/// damps. The mass is the STUDIES 1a hand's (1 kg). Its 300 N/m would leave
/// the device stuck 23 mm short of the pointer under the Fitts
/// `high_stiction` condition (7 N), farther than the 32 mm workspace allows,
/// so the mouse hand is stiffer: 2000 N/m breaks 7 N of stiction 3.5 mm
/// from the pointer, and 80 N s/m damps the 1.7 kg of hand and slide at
/// about 0.7 of critical.
pub const MOUSE_HAND_MASS_KG: f64 = 1.0;
/// See [`MOUSE_HAND_MASS_KG`]. N/m.
pub const MOUSE_HAND_STIFFNESS_N_M: f64 = 2000.0;
/// See [`MOUSE_HAND_MASS_KG`]. N s/m.
pub const MOUSE_HAND_DAMPING_N_S_M: f64 = 80.0;

/// A person at the window: answers arrive as inputs from the window, and
/// the mouse holds the hand (on the simulated device, or the emulator's).
#[derive(Debug, Clone, Default)]
pub struct Person {
    hand_target: Option<f64>,
    hand: crate::hand::Hand,
}

impl Person {
    /// Where the mouse holds the hand, m (`None`: the pointer is away).
    pub fn set_hand_target(&mut self, x_m: Option<f64>) {
        self.hand_target = x_m.filter(|x| x.is_finite());
    }
}

impl Responder for Person {
    const LABEL: &'static str = "gui";

    fn hand_mass_kg(&self) -> f64 {
        MOUSE_HAND_MASS_KG
    }

    fn on_action(&mut self, _: Time, _: &Action, _: Option<&PlannedTrial>) -> Reaction {
        Reaction::default()
    }

    fn decide(&mut self, _: Time, _: &DeviceSample) -> Reaction {
        Reaction::default()
    }

    fn drive(&self, _: Time, sample: &DeviceSample) -> Option<HandDrive> {
        Some(match self.hand_target {
            Some(x_m) => HandDrive {
                x_m,
                stiffness_n_m: MOUSE_HAND_STIFFNESS_N_M,
                damping_n_s_m: MOUSE_HAND_DAMPING_N_S_M,
                ..HandDrive::default()
            },
            None => HandDrive::relaxed(sample.x_m, MOUSE_HAND_DAMPING_N_S_M),
        })
    }

    fn hand_force(&mut self, now: Time, dt: f64, sample: &DeviceSample) -> f64 {
        let d = self.drive(now, sample).unwrap_or_default();
        self.hand.force(&d, sample.x_m, sample.v_m_s, dt)
    }
}

impl Session<Person> {
    /// Where the mouse holds the hand, m (`None`: the pointer is away).
    pub fn set_hand_target(&mut self, x_m: Option<f64>) {
        self.responder.set_hand_target(x_m);
    }
}
