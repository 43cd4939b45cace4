//! Feeling one friction model before it is in a protocol (the builder's
//! "Feel a condition"): the simulated apparatus with the mouse's hand on
//! it, stepped in real time, or the device on a port rendering the model
//! while the experimenter's own hand explores it. Nothing is logged.

use crate::device::DeviceSample;
use crate::device::LinkState;
use crate::friction::ModelParams;
use crate::time::Time;

use super::device::Device;
use super::responder::{Person, Responder};
use super::{DeviceChoice, SessionError};

/// The most simulated time one call catches up, s: a window that stalled
/// (dragged, minimised) resumes from where it stopped, not with seconds
/// of physics in one frame.
const MOST_BEHIND_S: f64 = 0.1;

/// The render number a feel renders its model as.
const FEEL_RENDER: u32 = 1;

/// A model rendered on a device for the experimenter to explore.
pub struct Feel {
    device: Device,
    person: Person,
    sample: DeviceSample,
    /// Device time (the simulated device's, or the port's loop clock).
    t: Time,
    model: ModelParams,
}

impl std::fmt::Debug for Feel {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Feel")
            .field("model", &self.model.name())
            .field("t", &self.t)
            .finish_non_exhaustive()
    }
}

impl Feel {
    /// Renders `model` on the device `choice` names, from time `now_s`.
    ///
    /// # Errors
    /// The port cannot be opened.
    pub fn start(
        choice: &DeviceChoice,
        model: &ModelParams,
        now_s: f64,
    ) -> Result<Self, SessionError> {
        let person = Person::default();
        let mut device = Device::open(choice, model.loop_rate_hz(), person.hand_mass_kg())?;
        let t = Time::from_secs_saturating(now_s);
        device.render(t, FEEL_RENDER, Some(model));
        Ok(Feel {
            device,
            person,
            sample: DeviceSample::default(),
            t,
            model: model.clone(),
        })
    }

    /// The model rendered.
    #[must_use]
    pub fn model(&self) -> &ModelParams {
        &self.model
    }

    /// Whether the device answers (always, for the simulated one).
    #[must_use]
    pub fn connected(&self) -> bool {
        self.device.connected()
    }

    /// The device's latest sample.
    #[must_use]
    pub fn sample(&self) -> &DeviceSample {
        &self.sample
    }

    /// Runs the device up to `now_s` with the mouse holding the hand at
    /// `target` (m; `None`: let go): the simulated device steps its
    /// model's loop period at a time; a port's ticks are read.
    pub fn advance(&mut self, now_s: f64, target: Option<f64>) {
        self.person.set_hand_target(target);
        match &mut self.device {
            Device::Stepped { dt, .. } => {
                let dt = *dt;
                let now = Time::from_secs_saturating(now_s);
                self.t = self.t.max(now - Time::from_secs_saturating(MOST_BEHIND_S));
                while self.t + dt <= now {
                    let force = self.person.hand_force(self.t, dt.secs(), &self.sample);
                    let Some(tick) = self.device.step(self.t, force) else {
                        break;
                    };
                    self.sample = tick.sample();
                    self.t += dt;
                }
            }
            Device::Port(port) => {
                while let Some((tick, _)) = port.recv() {
                    if tick.link != LinkState::Connected {
                        continue;
                    }
                    self.t = Time::from_secs_saturating(tick.now_s);
                    self.sample = tick.sample();
                    if let Some(drive) = self.person.drive(self.t, &self.sample) {
                        port.drive_hand(tick.now_s, &drive);
                    }
                }
            }
            Device::Stopped { .. } => {}
        }
    }
}

impl Drop for Feel {
    fn drop(&mut self) {
        self.device.render(self.t, FEEL_RENDER + 1, None);
        let _ = self.device.stop();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_mouse_drags_the_hand_and_the_model_resists_on_the_simulated_device() {
        let viscous = ModelParams::default_for("viscous").unwrap();
        let none = ModelParams::None;
        let mut travel = Vec::new();
        for model in [&none, &viscous] {
            let mut feel = Feel::start(&DeviceChoice::Simulated, model, 0.0).unwrap();
            let mut t = 0.0;
            let mut peak_force: f64 = 0.0;
            // The mouse sweeps from 0 to 10 mm in 0.1 s, frame by frame.
            for frame in 1..=6 {
                t = f64::from(frame) / 60.0;
                feel.advance(t, Some(0.01 * (t / 0.1).min(1.0)));
                peak_force = peak_force.max(feel.sample().force_n.abs());
            }
            assert!(t > 0.09);
            travel.push((feel.sample().x_m, peak_force));
        }
        let (free, damped) = (travel[0], travel[1]);
        assert!(free.0 > 0.002, "the hand follows the mouse: {free:?}");
        assert_eq!(free.1, 0.0, "no model, no force");
        assert!(damped.1 > 0.1, "the damper resists: {damped:?}");
        assert!(damped.0 < free.0, "{damped:?} vs {free:?}");
    }

    #[test]
    fn a_stalled_window_catches_up_at_most_a_tenth_of_a_second() {
        let model = ModelParams::default_for("karnopp").unwrap();
        let mut feel = Feel::start(&DeviceChoice::Simulated, &model, 0.0).unwrap();
        feel.advance(100.0, Some(0.0));
        let t = feel.t.secs();
        assert!((100.0 - 1e-3..=100.0).contains(&t), "{t}");
    }
}
