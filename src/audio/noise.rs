//! Masking noise: pink or white, at an RMS level in dBFS, switched on and
//! off with 50 ms ramps. Pure: no clock, no I/O; the randomness is a seeded
//! generator handed in.
//!
//! Pink noise is Paul Kellet's "refined" filter of white noise (Kellet,
//! "Filter to make pink noise from white", music-dsp mailing list, 1999;
//! the musicdsp.org archive's "Pink noise" entry): six one-pole low-passes
//! and a direct path, summed, whose response falls 3 dB per octave within
//! ±0.05 dB from 9.2 Hz to the Nyquist frequency at 44.1 kHz. At 48 kHz the
//! poles sit 9 % higher in frequency, which only moves the band's low edge
//! (to about 10 Hz); masking needs 100 Hz to 8 kHz. The filter's gain for a
//! unit-variance input ([`kellet_rms`]) is computed from its coefficients,
//! so the level is set exactly, not calibrated by a run.
//!
//! White noise is Gaussian (`rand_distr::StandardNormal`). Either is
//! clamped to ±1 (full scale); at the ceiling ([`MAX_LEVEL_DBFS`]) a
//! Gaussian's peaks reach full scale at 4 standard deviations, 6 in 100,000
//! samples.

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;

/// The ramp on and off, s: long enough to make no click, short against a
/// trial.
pub const RAMP_S: f64 = 0.05;

/// The highest masking level a protocol may set, dBFS RMS. The digital
/// ceiling: above it the noise's peaks clip (a Gaussian's crest factor is
/// about 4, 12 dB), which adds distortion the masking does not need. The
/// acoustic level at the ear is the amplifier's and headphones': the guide
/// says how to set it (at most 85 dB(A) at the ear, the level workers may
/// hear for 8 hours, EU directive 2003/10/EC's upper action value).
pub const MAX_LEVEL_DBFS: f64 = -12.0;

/// The lowest level a protocol may set, dBFS RMS: below it the noise is
/// under 16-bit quantisation's floor in a few bits and masks nothing.
pub const MIN_LEVEL_DBFS: f64 = -80.0;

/// Which noise.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Color {
    /// 3 dB per octave down: equal power per octave.
    Pink,
    /// Flat.
    White,
}

/// Kellet's refined pink filter: the six poles and their input gains, then
/// the direct gain and the one-sample-delayed gain (b6).
const KELLET_POLES: [f64; 6] = [0.99886, 0.99332, 0.96900, 0.86650, 0.55000, -0.7616];
const KELLET_GAINS: [f64; 6] = [
    0.055_517_9,
    0.075_075_9,
    0.153_852,
    0.310_485_6,
    0.532_952_2,
    -0.016_898,
];
const KELLET_DIRECT: f64 = 0.5362;
const KELLET_DELAYED: f64 = 0.115_926;

/// The RMS of Kellet's filter's output for unit-variance white input: the
/// square root of the sum of its impulse response's squares, in closed
/// form. `h[0] = sum(g) + direct`; for `n >= 1`, `h[n] = sum(g_i p_i^n)`
/// plus `delayed` at `n = 1`.
#[must_use]
pub fn kellet_rms() -> f64 {
    let h0 = KELLET_GAINS.iter().sum::<f64>() + KELLET_DIRECT;
    let mut tail = 0.0;
    for (gi, pi) in KELLET_GAINS.iter().zip(KELLET_POLES) {
        for (gj, pj) in KELLET_GAINS.iter().zip(KELLET_POLES) {
            tail += gi * gj * pi * pj / (1.0 - pi * pj);
        }
    }
    let cross: f64 = KELLET_GAINS
        .iter()
        .zip(KELLET_POLES)
        .map(|(g, p)| g * p)
        .sum();
    (h0 * h0 + tail + 2.0 * KELLET_DELAYED * cross + KELLET_DELAYED * KELLET_DELAYED).sqrt()
}

/// Masking noise at a level, gated on and off with ramps: see the module
/// docs.
#[derive(Debug, Clone)]
pub struct Masking {
    rng: ChaCha8Rng,
    color: Color,
    /// The filter's states b0..b6.
    state: [f64; 7],
    /// The gain that puts the output at the level (with the filter's RMS
    /// taken out).
    gain: f64,
    /// The ramp's place: 0 off, 1 on.
    envelope: f64,
    /// The ramp's step per sample.
    ramp_step: f64,
    on: bool,
}

impl Masking {
    /// Noise of `color` at `level_dbfs` (RMS, within
    /// [`MIN_LEVEL_DBFS`]..=[`MAX_LEVEL_DBFS`], clamped there), for an
    /// output at `rate_hz`, off until [`Masking::set_on`].
    #[must_use]
    pub fn new(color: Color, level_dbfs: f64, rate_hz: f64, seed: u64) -> Self {
        let level = 10f64.powf(level_dbfs.clamp(MIN_LEVEL_DBFS, MAX_LEVEL_DBFS) / 20.0);
        let gain = match color {
            Color::Pink => level / kellet_rms(),
            Color::White => level,
        };
        Masking {
            rng: ChaCha8Rng::seed_from_u64(seed),
            color,
            state: [0.0; 7],
            gain,
            envelope: 0.0,
            ramp_step: 1.0 / (RAMP_S * rate_hz).max(1.0),
            on: false,
        }
    }

    /// Switches the noise on (ramping up) or off (ramping down).
    pub fn set_on(&mut self, on: bool) {
        self.on = on;
    }

    /// Whether the noise is off and its ramp down is over: it plays
    /// silence.
    #[must_use]
    pub fn silent(&self) -> bool {
        !self.on && self.envelope == 0.0
    }

    /// The next sample, full scale ±1.
    pub fn next_sample(&mut self) -> f32 {
        let white: f64 = self.rng.sample(StandardNormal);
        let raw = match self.color {
            Color::White => white,
            Color::Pink => {
                let s = &mut self.state;
                for i in 0..6 {
                    s[i] = KELLET_POLES[i] * s[i] + KELLET_GAINS[i] * white;
                }
                let pink = s[..6].iter().sum::<f64>() + s[6] + KELLET_DIRECT * white;
                s[6] = KELLET_DELAYED * white;
                pink
            }
        };
        self.envelope = if self.on {
            (self.envelope + self.ramp_step).min(1.0)
        } else {
            (self.envelope - self.ramp_step).max(0.0)
        };
        // A raised-cosine ramp: no corner at either end.
        let shape = 0.5 - 0.5 * (std::f64::consts::PI * self.envelope).cos();
        #[allow(clippy::cast_possible_truncation)]
        let out = (raw * self.gain * shape).clamp(-1.0, 1.0) as f32;
        out
    }

    /// Fills `out` (`channels` interleaved) with the same noise on every
    /// channel. Never blocks, never allocates.
    pub fn fill(&mut self, out: &mut [f32], channels: usize) {
        for frame in out.chunks_mut(channels.max(1)) {
            let s = self.next_sample();
            frame.fill(s);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rms(x: &[f32]) -> f64 {
        (x.iter().map(|&v| f64::from(v) * f64::from(v)).sum::<f64>() / x.len() as f64).sqrt()
    }

    fn dbfs(x: f64) -> f64 {
        20.0 * x.log10()
    }

    #[test]
    fn kellet_rms_matches_the_filters_impulse_response_summed() {
        // The closed form against the impulse response summed directly.
        let mut s = [0.0f64; 7];
        let mut sum = 0.0;
        for n in 0..200_000 {
            let w = if n == 0 { 1.0 } else { 0.0 };
            for i in 0..6 {
                s[i] = KELLET_POLES[i] * s[i] + KELLET_GAINS[i] * w;
            }
            let h = s[..6].iter().sum::<f64>() + s[6] + KELLET_DIRECT * w;
            s[6] = KELLET_DELAYED * w;
            sum += h * h;
        }
        assert!(
            (sum.sqrt() - kellet_rms()).abs() < 1e-9,
            "{} vs {}",
            sum.sqrt(),
            kellet_rms()
        );
    }

    #[test]
    fn noise_plays_at_its_rms_level_once_ramped_up() {
        for color in [Color::Pink, Color::White] {
            let mut m = Masking::new(color, -20.0, 48_000.0, 7);
            m.set_on(true);
            let mut out = vec![0.0f32; 48_000 * 20];
            m.fill(&mut out, 1);
            // Past the ramp (and the pink filter's slowest pole settling).
            let level = dbfs(rms(&out[48_000..]));
            assert!((level + 20.0).abs() < 0.2, "{color:?}: {level} dBFS");
        }
    }

    #[test]
    fn the_ramps_take_50_ms_and_end_in_silence() {
        let rate = 48_000.0;
        let mut m = Masking::new(Color::Pink, -20.0, rate, 1);
        assert!(m.silent());
        m.set_on(true);
        let ramp = 2400; // RAMP_S at 48 kHz
        assert!((RAMP_S * rate - 2400.0).abs() < 1e-9);
        let mut up = vec![0.0f32; ramp];
        m.fill(&mut up, 1);
        assert!(m.envelope >= 1.0 - 1e-9, "on after 50 ms: {}", m.envelope);
        // The first millisecond is far below the level: no step on.
        assert!(rms(&up[..48]) < 0.01 * 0.1, "{}", rms(&up[..48]));
        m.set_on(false);
        let mut down = vec![0.0f32; ramp];
        m.fill(&mut down, 1);
        assert!(m.silent(), "silent after 50 ms");
        let mut after = vec![1.0f32; 480];
        m.fill(&mut after, 1);
        assert!(after.iter().all(|&v| v == 0.0));
    }

    #[test]
    fn levels_are_clamped_to_the_ceiling() {
        let mut m = Masking::new(Color::White, 0.0, 48_000.0, 3);
        m.set_on(true);
        let mut out = vec![0.0f32; 48_000 * 4];
        m.fill(&mut out, 2);
        let level = dbfs(rms(&out[48_000..]));
        assert!((level - MAX_LEVEL_DBFS).abs() < 0.2, "{level}");
    }
}
