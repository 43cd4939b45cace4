//! The test tone of the window's Setup (issue 64): seed 001's burst
//! frequency, 600 Hz, for 0.5 s on one output (one channel, or all), so
//! the experimenter hears or feels that the wiring and the amplifier are
//! right before a participant sits down; its level shows on the meter.

use std::sync::atomic::Ordering;

use super::{AudioError, Server, Source, backend};

/// The tone's frequency, Hz: seed 001's vibrotactile burst.
pub const TONE_HZ: f64 = 600.0;

/// How long it plays, s.
pub const TONE_S: f64 = 0.5;

/// Its RMS level, dBFS: the masking noise's default level, 8 dB under
/// its ceiling (docs/guide/sound.md), so that a test on the headphones is
/// never louder than a session.
pub const TONE_DBFS: f64 = -20.0;

/// Its raised-cosine ramps on and off, s: no click at either end.
pub const TONE_RAMP_S: f64 = 0.01;

/// The tone's samples.
struct Tone {
    /// Frames played so far.
    frame: u64,
    rate_hz: f64,
    /// The channel it plays on (0-based), or every channel.
    channel: Option<usize>,
}

impl Tone {
    /// Its sample at frame `n`.
    fn sample(&self, n: u64) -> f32 {
        #[allow(clippy::cast_precision_loss)]
        let t = n as f64 / self.rate_hz;
        if t >= TONE_S {
            return 0.0;
        }
        let edge = t.min(TONE_S - t) / TONE_RAMP_S;
        let ramp = if edge >= 1.0 {
            1.0
        } else {
            0.5 - 0.5 * (std::f64::consts::PI * edge).cos()
        };
        let amplitude = std::f64::consts::SQRT_2 * 10f64.powf(TONE_DBFS / 20.0);
        #[allow(clippy::cast_possible_truncation)]
        let s = (amplitude * ramp * (std::f64::consts::TAU * TONE_HZ * t).sin()) as f32;
        s
    }
}

impl Source for Tone {
    fn fill(&mut self, out: &mut [f32], channels: usize, _ending: bool) {
        for frame in out.chunks_exact_mut(channels) {
            let s = self.sample(self.frame);
            self.frame += 1;
            for (c, x) in frame.iter_mut().enumerate() {
                *x = if self.channel.is_none_or(|k| k == c) {
                    s
                } else {
                    0.0
                };
            }
        }
    }

    fn finished(&self) -> bool {
        #[allow(clippy::cast_precision_loss)]
        let played_s = self.frame as f64 / self.rate_hz;
        played_s >= TONE_S
    }

    fn ends(&self) -> bool {
        true
    }
}

/// The test tone playing on an output; dropped, it stops.
pub struct TestTone {
    player: backend::Player,
}

impl TestTone {
    /// Plays the tone on `output` of `server`: on channel `channel`
    /// (0-based) only, or on every channel.
    ///
    /// # Errors
    /// No sound server, no such output or channel, or the stream refused.
    pub fn play(
        server: &Server,
        output: &str,
        channel: Option<usize>,
    ) -> Result<TestTone, AudioError> {
        let tone = Tone {
            frame: 0,
            rate_hz: f64::from(backend::RATE_HZ),
            channel,
        };
        // Latency does not matter here, an underrun would: the masking
        // noise's buffer.
        let player =
            backend::Player::open(server, output, super::BUFFER_FRAMES * 8, Box::new(tone))?;
        let channels = player.info.channels;
        if let Some(c) = channel.filter(|c| *c >= channels) {
            return Err(AudioError::Server(format!(
                "output '{output}' has {channels} channels; channel {} was asked for",
                c + 1
            )));
        }
        Ok(TestTone { player })
    }

    /// The largest |sample| of the buffer it played last, full scale 1.
    #[must_use]
    pub fn peak(&self) -> f32 {
        f32::from_bits(self.player.shared.peak.load(Ordering::SeqCst))
    }

    /// Whether it has played out (or its output was lost).
    #[must_use]
    pub fn done(&self) -> bool {
        self.player.done()
    }
}

impl std::fmt::Debug for TestTone {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("TestTone")
            .field("output", &self.player.info.output)
            .finish_non_exhaustive()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tone(channel: Option<usize>) -> Tone {
        Tone {
            frame: 0,
            rate_hz: 48_000.0,
            channel,
        }
    }

    #[test]
    fn the_tone_is_600_hz_for_half_a_second_at_its_level_on_its_channel_only() {
        let mut t = tone(Some(1));
        let mut out = vec![0.0f32; 2 * 48_000];
        t.fill(&mut out, 2, false);
        let left: Vec<f64> = out.iter().step_by(2).map(|x| f64::from(*x)).collect();
        let right: Vec<f64> = out
            .iter()
            .skip(1)
            .step_by(2)
            .map(|x| f64::from(*x))
            .collect();
        assert!(left.iter().all(|x| *x == 0.0), "channel 1 is silent");
        // Sounding for 0.5 s: from the first to the last sample not zero.
        let first = right.iter().position(|x| x.abs() > 0.0).unwrap_or(0);
        let last = right.iter().rposition(|x| x.abs() > 0.0).unwrap_or(0);
        #[allow(clippy::cast_precision_loss)]
        let span_s = (last - first) as f64 / 48_000.0;
        assert!((span_s - TONE_S).abs() < 1e-3, "sounds for {span_s} s");
        // 600 Hz for 0.5 s: 300 rising zero crossings.
        let rising = right
            .windows(2)
            .filter(|w| w[0] <= 0.0 && w[1] > 0.0)
            .count();
        assert!(rising.abs_diff(300) <= 1, "{rising} rising crossings");
        // Its level between the ramps: -20 dBFS RMS.
        let steady = &right[4_800..19_200];
        #[allow(clippy::cast_precision_loss)]
        let rms = (steady.iter().map(|x| x * x).sum::<f64>() / steady.len() as f64).sqrt();
        assert!((20.0 * rms.log10() - TONE_DBFS).abs() < 0.01);
        assert!(t.finished() && t.ends());
    }

    #[test]
    fn the_tone_ramps_on_and_off_without_a_click() {
        let t = tone(None);
        let amplitude = std::f64::consts::SQRT_2 * 10f64.powf(TONE_DBFS / 20.0);
        let peak = |from: u64, to: u64| {
            (from..to)
                .map(|n| f64::from(t.sample(n).abs()))
                .fold(0.0, f64::max)
        };
        // A raised cosine over 10 ms: under 2.5 % of the amplitude in the
        // first and the last millisecond (a cut-on tone reaches all of it
        // within 0.42 ms), half of it at 5 ms (0.37 to 0.63 over the
        // period around it), all of it from 10 ms.
        assert!(peak(0, 48) < 0.025 * amplitude, "{}", peak(0, 48));
        assert!(peak(23_952, 24_000) < 0.025 * amplitude);
        let mid = peak(200, 280) / amplitude;
        assert!((0.37..0.64).contains(&mid), "{mid}");
        assert!((peak(480, 2_000) / amplitude - 1.0).abs() < 1e-3);
        assert!(t.sample(24_000).abs() < 1e-9, "silent once played");
    }
}
