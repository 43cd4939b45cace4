//! The hand on a device: one model for the simulated participant, the
//! device emulator, the window's mouse hand and the scripted scenarios.
//!
//! # Model (SI units; positive x = device positive direction)
//! The hand pulls the device towards a reference position and velocity
//! through a spring-damper, plus an integral term for effort that builds
//! while the device lags (people push harder when stuck):
//!
//! `F = k (x_ref - x) + b (v_ref - v) + I`, with
//! `I <- clamp(I + k_i (x_ref - x) dt, -I_max, I_max)`.
//!
//! # The one reset rule
//! The integral restarts at zero when the drive's `segment` changes (a new
//! trial, a new Fitts target: the movement the effort built up for is
//! over), and is zero whenever the integral gain is not positive (a relaxed
//! hand). Nothing else resets it: corrections towards the same target keep
//! the effort already built.

/// Largest integral effort, N.
pub const INTEGRAL_LIMIT_N: f64 = 12.0;

/// What the hand aims for and how stiffly: the reference and the impedance.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct HandDrive {
    /// Reference position, m.
    pub x_m: f64,
    /// Reference velocity, m/s.
    pub v_m_s: f64,
    /// Stiffness k, N/m.
    pub stiffness_n_m: f64,
    /// Damping b, N s/m.
    pub damping_n_s_m: f64,
    /// Integral gain k_i, N/(m s); 0: no integral term.
    pub integral_gain: f64,
    /// Movement segment; a change restarts the integral.
    pub segment: u32,
}

impl HandDrive {
    /// A hand that only damps (the reference follows the device).
    #[must_use]
    pub fn relaxed(x_m: f64, damping_n_s_m: f64) -> Self {
        HandDrive {
            x_m,
            damping_n_s_m,
            ..HandDrive::default()
        }
    }
}

/// The hand's state: its integral effort.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Hand {
    integral_n: f64,
    segment: u32,
}

impl Hand {
    /// The force the hand applies to a device at `x_m`, `v_m_s` over the
    /// next `dt`, N.
    pub fn force(&mut self, d: &HandDrive, x_m: f64, v_m_s: f64, dt: f64) -> f64 {
        if d.segment != self.segment {
            self.segment = d.segment;
            self.integral_n = 0.0;
        }
        let e = d.x_m - x_m;
        self.integral_n = if d.integral_gain > 0.0 {
            (self.integral_n + d.integral_gain * e * dt).clamp(-INTEGRAL_LIMIT_N, INTEGRAL_LIMIT_N)
        } else {
            0.0
        };
        d.stiffness_n_m * e + d.damping_n_s_m * (d.v_m_s - v_m_s) + self.integral_n
    }

    /// The integral effort now, N.
    #[must_use]
    pub fn integral_n(&self) -> f64 {
        self.integral_n
    }
}
