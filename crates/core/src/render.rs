//! What a device needs to run a trial's model: the model's parameters as a
//! flat list of numbers (how they travel over the wire), and the
//! [`Renderer`], which crossfades between models and clamps the force.
//!
//! The host's haptic loop, the emulator's on-board mode, the firmware and
//! `frictionlab rerender` all render through [`Renderer`], so a re-render
//! of a recorded stream follows the same crossfade, clamp and float as the
//! device did.

use crate::friction::{
    ConstantStatic, DahlParams, ForceLimit, Friction, GodObjectParams, Input, KarnoppParams,
    ModelParams, NakanoParams, Output, Phase, TimeVaryingStatic, ViscousParams,
};
use crate::real::Real;

/// Crossfade time between models, s (the 50 ms of the wire protocol's
/// `Select`).
pub const RAMP_S: f64 = 0.050;

/// The most numbers any model's parameters flatten to.
pub const MAX_VALUES: usize = 16;

/// A model's parameters as numbers: its kind (1 + its index in
/// [`ModelParams::NAMES`]) and its fields in declaration order (a god
/// object's static law last).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Flat {
    /// 1 + the index of the model's name in [`ModelParams::NAMES`].
    pub kind: u8,
    /// How many of `values` are used.
    pub len: usize,
    /// The parameters, in declaration order.
    pub values: [f64; MAX_VALUES],
}

impl Flat {
    /// The used values.
    #[must_use]
    pub fn used(&self) -> &[f64] {
        self.values.get(..self.len).unwrap_or(&[])
    }
}

/// Parameters that flatten to numbers.
trait Fields: Sized {
    /// Writes the fields from `out[0]` on; returns how many.
    fn put(&self, out: &mut [f64]) -> usize;
    /// Reads them back from `v` (None if too few).
    fn take(v: &[f64]) -> Option<(Self, usize)>;
}

macro_rules! fields {
    ($t:ty { $($f:ident),* $(,)? }) => {
        impl Fields for $t {
            fn put(&self, out: &mut [f64]) -> usize {
                let mut n = 0;
                $(
                    if let Some(slot) = out.get_mut(n) {
                        *slot = self.$f;
                    }
                    n += 1;
                )*
                n
            }
            fn take(v: &[f64]) -> Option<(Self, usize)> {
                let mut n = 0;
                Some((
                    Self {
                        $($f: {
                            n += 1;
                            *v.get(n - 1)?
                        },)*
                    },
                    n,
                ))
            }
        }
    };
}

fields!(ConstantStatic { mu_s, mu_d });
fields!(TimeVaryingStatic { mu_d, b, c_per_s });
fields!(NakanoParams {
    mass_kg,
    stiffness_n_m,
    damping_n_s_m,
    normal_load_n,
    mu_s,
    mu_k,
    alpha_per_n,
    carrier_hz,
    envelope_time_constant_s,
    force_scale,
    max_substep_s,
});
fields!(KarnoppParams {
    block_mass_kg,
    coupling_stiffness_n_m,
    coupling_damping_n_s_m,
    f_static_n,
    f_dynamic_n,
    viscous_n_s_m,
    presliding_stiffness_n_m,
    zero_velocity_band_m_s,
});
fields!(DahlParams {
    sigma_n_m,
    fc_pos_n,
    fc_neg_n,
    exponent,
    viscous_n_s_m,
    slip_fraction,
});
fields!(ViscousParams { damping_n_s_m });

impl<L: Fields> Fields for GodObjectParams<L> {
    fn put(&self, out: &mut [f64]) -> usize {
        let own = [
            self.proxy_mass_kg,
            self.coupling_stiffness_n_m,
            self.coupling_damping_n_s_m,
            self.normal_force_n,
            self.restick_speed_m_s,
            self.vibration_amplitude_m_s,
            self.vibration_decay_per_s,
            self.vibration_wavenumber_rad_m,
            self.vibration_min_speed_m_s,
        ];
        for (slot, v) in out.iter_mut().zip(own) {
            *slot = v;
        }
        own.len()
            + self
                .static_friction
                .put(out.get_mut(own.len()..).unwrap_or(&mut []))
    }

    fn take(v: &[f64]) -> Option<(Self, usize)> {
        let own = v.get(..9)?;
        let (static_friction, n) = L::take(v.get(9..)?)?;
        Some((
            GodObjectParams {
                proxy_mass_kg: own[0],
                coupling_stiffness_n_m: own[1],
                coupling_damping_n_s_m: own[2],
                normal_force_n: own[3],
                press_stiffness_n_m: None,
                static_friction,
                restick_speed_m_s: own[4],
                vibration_amplitude_m_s: own[5],
                vibration_decay_per_s: own[6],
                vibration_wavenumber_rad_m: own[7],
                vibration_min_speed_m_s: own[8],
            },
            9 + n,
        ))
    }
}

impl ModelParams {
    /// The parameters as numbers (how the wire protocol uploads them).
    #[must_use]
    pub fn flatten(&self) -> Flat {
        let mut values = [0.0; MAX_VALUES];
        let len = match self {
            Self::GodObjectConstant(p) => p.put(&mut values),
            Self::GodObjectTimeVarying(p) => p.put(&mut values),
            Self::StickSlipTactile(p) | Self::StickSlipForce(p) => p.put(&mut values),
            Self::Karnopp(p) => p.put(&mut values),
            Self::Dahl(p) => p.put(&mut values),
            Self::Viscous(p) => p.put(&mut values),
            Self::None => 0,
        };
        Flat {
            kind: self.kind(),
            len,
            values,
        }
    }

    /// The model's kind on the wire: 1 + the index of its name in
    /// [`ModelParams::NAMES`].
    #[must_use]
    pub fn kind(&self) -> u8 {
        let index = Self::NAMES
            .iter()
            .position(|n| *n == self.name())
            .unwrap_or(0);
        u8::try_from(index + 1).unwrap_or(0)
    }

    /// The parameters of model `kind` from exactly its numbers; None for an
    /// unknown kind or the wrong count.
    #[must_use]
    pub fn unflatten(kind: u8, values: &[f64]) -> Option<Self> {
        fn exact<P: Fields>(v: &[f64]) -> Option<P> {
            P::take(v).filter(|(_, n)| *n == v.len()).map(|(p, _)| p)
        }
        Some(match kind {
            1 => Self::GodObjectConstant(exact(values)?),
            2 => Self::GodObjectTimeVarying(exact(values)?),
            3 => Self::StickSlipTactile(exact(values)?),
            4 => Self::StickSlipForce(exact(values)?),
            5 => Self::Karnopp(exact(values)?),
            6 => Self::Dahl(exact(values)?),
            7 => Self::Viscous(exact(values)?),
            8 if values.is_empty() => Self::None,
            _ => return None,
        })
    }
}

/// The model a device renders, with the crossfade between models and the
/// force clamp.
///
/// After [`Renderer::select`] the force fades from the previous model's to
/// the new model's over the ramp (the previous model keeps stepping until
/// the fade ends); the vibration fades in with the new model. Each step's
/// force is clamped to the limit.
#[derive(Debug, Clone)]
pub struct Renderer<T: Real> {
    current: Option<Friction<T>>,
    previous: Option<Friction<T>>,
    ramp: T,
    ramp_s: T,
    limit: ForceLimit<T>,
}

impl<T: Real> Renderer<T> {
    /// Rendering nothing, with force limit `limit` and crossfades of
    /// `ramp_s` (0: switch at once).
    #[must_use]
    pub fn new(limit: ForceLimit<T>, ramp_s: T) -> Self {
        Renderer {
            current: None,
            previous: None,
            ramp: T::ONE,
            ramp_s,
            limit,
        }
    }

    /// The force limit.
    #[must_use]
    pub fn limit(&self) -> ForceLimit<T> {
        self.limit
    }

    /// Limits the models selected from now on to `limit`, and every
    /// step's force from now on (a device that states its own limit once
    /// connected).
    pub fn set_limit(&mut self, limit: ForceLimit<T>) {
        self.limit = limit;
    }

    /// Renders `params` from the next step on (`None`: nothing), the model
    /// at rest at `x_m`, crossfading from what was rendered. An invalid
    /// model renders nothing; returns false then.
    pub fn select(&mut self, params: Option<&ModelParams>, x_m: T) -> bool {
        let next = params.map(|p| Friction::new(p, self.limit, x_m));
        let ok = !matches!(next, Some(Err(_)));
        self.previous = self.current.take();
        self.current = next.and_then(Result::ok);
        self.ramp = T::ZERO;
        ok
    }

    /// The hand presses `y_m` into the surface: each model whose normal
    /// force is the press takes `k y` (seed 000's `F_N = k y`). Returns the
    /// normal force of the model selected, or else of the one fading out.
    pub fn press(&mut self, y_m: T) -> Option<T> {
        let old = self.previous.as_mut().and_then(|m| m.press(y_m));
        self.current.as_mut().and_then(|m| m.press(y_m)).or(old)
    }

    /// Sets the pressed normal force of the models whose normal force is
    /// the press (a replay of a logged one), N.
    pub fn set_pressed_normal(&mut self, normal_n: T) {
        for m in [self.previous.as_mut(), self.current.as_mut()]
            .into_iter()
            .flatten()
        {
            m.set_pressed_normal(normal_n);
        }
    }

    /// Advances by `dt` to `input`: the crossfaded, clamped force and the
    /// new model's vibration (faded in).
    pub fn step(&mut self, dt: T, input: Input<T>) -> Output<T> {
        let new = self.current.as_mut().map(|f| f.step(dt, input));
        let old = if self.ramp < T::ONE {
            self.previous.as_mut().map(|f| f.step(dt, input))
        } else {
            None
        };
        self.ramp = if self.ramp_s > T::ZERO {
            (self.ramp + dt / self.ramp_s).min(T::ONE)
        } else {
            T::ONE
        };
        let force = |o: Option<Output<T>>| o.map_or(T::ZERO, |o| o.force_n);
        let ramp = self.ramp;
        Output {
            force_n: self
                .limit
                .clamp(ramp * force(new) + (T::ONE - ramp) * force(old)),
            vibration: new.map_or(T::ZERO, |o| o.vibration) * ramp,
            vibration_q: new.map_or(T::ZERO, |o| o.vibration_q) * ramp,
            phase: new.map_or(Phase::Stick, |o| o.phase),
            slip_onset: new.is_some_and(|o| o.slip_onset),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_model_flattens_and_comes_back_the_same() {
        for name in ModelParams::NAMES {
            let mut p = ModelParams::default_for(name).unwrap();
            // Make each field distinct so an order mix-up shows.
            let mut flat = p.flatten();
            for (i, v) in flat.values.iter_mut().take(flat.len).enumerate() {
                *v += 0.001 * (i as f64 + 1.0);
            }
            p = ModelParams::unflatten(flat.kind, flat.used()).unwrap();
            assert_eq!(p.flatten(), flat, "{name}");
            assert!(flat.len <= MAX_VALUES);
            assert_eq!(
                ModelParams::unflatten(flat.kind, &flat.values[..=flat.len]),
                None
            );
        }
        assert_eq!(ModelParams::unflatten(0, &[]), None);
        assert_eq!(ModelParams::unflatten(9, &[]), None);
    }

    #[test]
    fn the_renderer_crossfades_over_the_ramp_and_clamps() {
        let viscous = ModelParams::Viscous(ViscousParams {
            damping_n_s_m: 10.0,
        });
        let mut r = Renderer::<f64>::new(ForceLimit::new(5.0).unwrap(), 0.05);
        r.select(Some(&viscous), 0.0);
        let input = Input {
            x_m: 0.0,
            v_m_s: 0.1,
        };
        let forces: [f64; 60] = core::array::from_fn(|_| r.step(0.001, input).force_n);
        assert!(
            (forces[0] + 1.0 * 0.001 / 0.05).abs() < 1e-12,
            "{}",
            forces[0]
        );
        assert!((forces[24] + 0.5).abs() < 1e-12, "half way: {}", forces[24]);
        assert_eq!(forces[49], -1.0);
        assert_eq!(forces[59], -1.0);
        let fast = Input {
            x_m: 0.0,
            v_m_s: 10.0,
        };
        assert_eq!(r.step(0.001, fast).force_n, -5.0, "clamped");
        // Nothing: fades out.
        r.select(None, 0.0);
        let f = r.step(0.001, input).force_n;
        assert!((f + 0.98).abs() < 1e-12, "{f}");
        // Ramp 0 switches at once.
        let mut r = Renderer::<f32>::new(ForceLimit::new(5.0).unwrap(), 0.0);
        r.select(Some(&viscous), 0.0);
        let input = Input {
            x_m: 0.0,
            v_m_s: 0.1,
        };
        assert_eq!(r.step(0.001, input).force_n, -1.0);
    }
}
