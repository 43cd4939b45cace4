//! The haptic loop stepped in a session's own time: the same
//! [`LoopCore`] as the loop's thread ([`super::haptic`]) runs, tick by
//! tick, on a [`Virtual`] device (the simulated apparatus), each tick as
//! long as the session says. No clock: a replay is exact, and as fast as
//! the machine can step it.
//!
//! Two choices differ from the loop's thread, both the simulated
//! apparatus's since its first session (so every simulated replay, the
//! committed analyses among them, stays what it was):
//! - a new model starts at once, with no crossfade (ramp 0 s): the
//!   crossfade keeps a real motor from a jump; a simulated participant's
//!   trial begins with the hand at rest;
//! - each tick is as long as the session says (its model's own loop
//!   period, whole nanoseconds), not the loop's one fixed rate.

use super::backend::{Capabilities, Tick, Virtual};
use super::haptic::{LoopCore, ToLoop};
use crate::friction::{ModelParams, StepParams};

/// The crossfade of a stepped loop, s: none (module docs).
pub const STEPPED_RAMP_S: f64 = 0.0;

/// A [`Virtual`] device and the loop core that renders on it, stepped by
/// its owner (the device's type known, so a tick's calls inline: a
/// simulated session is mostly ticks).
pub struct Stepped<V: Virtual> {
    device: V,
    core: LoopCore,
}

impl<V: Virtual> std::fmt::Debug for Stepped<V> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Stepped").finish_non_exhaustive()
    }
}

impl<V: Virtual> Stepped<V> {
    /// Rendering nothing on `device`, within `step`'s force limit and
    /// velocity filter (its rate is each tick's `dt`).
    #[must_use]
    pub fn new(device: V, step: StepParams) -> Self {
        let core = LoopCore::new(&device, step, STEPPED_RAMP_S);
        Stepped { device, core }
    }

    /// What the device can do.
    #[must_use]
    pub fn capabilities(&self) -> Capabilities {
        self.device.capabilities()
    }

    /// The force limit its models render within, N: the smaller of the
    /// step's and the device's.
    #[must_use]
    pub fn limit_n(&self) -> f64 {
        self.core.limit_n()
    }

    /// Renders `model` (or nothing) from the next tick on, as the
    /// session's render `render`, starting at rest where the device read
    /// last.
    pub fn select(&mut self, now_s: f64, render: u32, model: Option<&ModelParams>) {
        self.core.handle(
            &mut self.device,
            now_s,
            ToLoop::Model {
                render,
                model: model.cloned(),
            },
        );
    }

    /// Puts the device at rest at `x_m`, the model selected last restarted
    /// there as render `render`.
    pub fn place(&mut self, now_s: f64, x_m: f64, render: u32) {
        self.device.place(x_m);
        self.core.place(&mut self.device, now_s, render);
    }

    /// The physical friction of a condition from now on.
    pub fn set_physical(&mut self, model: Option<&ModelParams>) {
        self.device.set_physical(model);
    }

    /// One tick at `now_s` lasting `dt` s, the hand pushing with
    /// `hand_force_n` N over it: the device read, the force rendered and
    /// sent, then the time passed.
    pub fn tick(&mut self, now_s: f64, dt: f64, hand_force_n: f64) -> Tick {
        let device = &mut self.device;
        let reading = self.core.read(device, now_s, dt);
        // A device in this process: its models are the loop's to render.
        let tick = self.core.host_tick(device, now_s, dt, &reading);
        device.elapse(dt, hand_force_n);
        tick
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::device::sim::{Apparatus, Simulated};
    use crate::friction::ForceLimit;

    /// The simulated apparatus with a 0.4 kg hand, stepped within a force
    /// limit of `limit_n`.
    fn apparatus(limit_n: f64) -> Stepped<Simulated> {
        let step = StepParams {
            force_limit: ForceLimit::new(limit_n).unwrap(),
            ..StepParams::default()
        };
        Stepped::new(Simulated::new(Apparatus::default(), 0.4), step)
    }

    /// `ms` ticks of 1 ms from `t0`, the hand pushing `push_n`.
    fn run(loop_: &mut Stepped<Simulated>, t0: f64, ms: u32, push_n: f64) -> Vec<Tick> {
        (0..ms)
            .map(|i| loop_.tick(t0 + f64::from(i) * 1e-3, 1e-3, push_n))
            .collect()
    }

    #[test]
    fn the_limit_in_force_is_the_smaller_of_the_steps_and_the_apparatuss() {
        let max = Apparatus::default().max_force_n;
        assert_eq!(apparatus(5.0).limit_n(), 5.0);
        assert_eq!(apparatus(20.0).limit_n(), max);
        assert_eq!(apparatus(20.0).capabilities().force_limit_n, max);
    }

    #[test]
    fn a_selected_model_is_rendered_on_the_apparatus_by_the_loop_core() {
        let viscous = ModelParams::default_for("viscous").unwrap();
        let mut free = apparatus(9.48);
        let mut damped = apparatus(9.48);
        damped.select(0.0, 7, Some(&viscous));
        // The hand pushes 3 N, four times the apparatus's own stiction.
        let free = run(&mut free, 0.0, 200, 3.0);
        let damped = run(&mut damped, 0.0, 200, 3.0);
        assert!(
            damped[0].selected,
            "the render took effect at the first tick"
        );
        assert!(damped[1..].iter().all(|t| !t.selected && t.render == 7));
        // Each tick's force is the model's on the loop's own velocity
        // estimate: -35 N s/m times it.
        for t in &damped {
            assert_eq!(t.force_n, -35.0 * t.v_m_s, "{t:?}");
            assert_eq!(t.force_vector_n, [t.force_n, 0.0, 0.0]);
        }
        let (x_free, x_damped) = (free.last().unwrap().x_m, damped.last().unwrap().x_m);
        assert!(free.iter().all(|t| t.force_n == 0.0), "nothing rendered");
        assert!(
            x_damped > 0.0 && x_damped < 0.8 * x_free,
            "{x_damped} vs {x_free}"
        );
    }

    #[test]
    fn a_placed_apparatus_is_at_rest_there_its_model_restarted_there() {
        let god = ModelParams::default_for("god-object-constant").unwrap();
        let mut loop_ = apparatus(9.48);
        loop_.select(0.0, 1, Some(&god));
        run(&mut loop_, 0.0, 100, 4.0);
        loop_.place(0.1, -0.005, 2);
        let first = loop_.tick(0.1, 1e-3, 0.0);
        let encoder = Apparatus::default().encoder_m;
        assert!((first.x_m + 0.005).abs() <= encoder, "{first:?}");
        assert_eq!(first.v_m_s, 0.0);
        assert!(first.selected && first.render == 2);
        // The god object starts where the device is: no pull back to
        // where it was anchored before.
        assert_eq!(first.force_n, 0.0, "{first:?}");
    }

    #[test]
    fn the_physical_friction_acts_on_the_apparatus_without_being_rendered() {
        let block = ModelParams::default_for("viscous").unwrap();
        let mut bare = apparatus(9.48);
        let mut on_block = apparatus(9.48);
        on_block.set_physical(Some(&block));
        let bare = run(&mut bare, 0.0, 200, 3.0);
        let on_block = run(&mut on_block, 0.0, 200, 3.0);
        assert!(on_block.iter().all(|t| t.force_n == 0.0), "not rendered");
        let (x_bare, x_block) = (bare.last().unwrap().x_m, on_block.last().unwrap().x_m);
        assert!(x_block < 0.8 * x_bare, "{x_block} vs {x_bare}");
    }
}
