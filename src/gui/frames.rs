//! Frame-time statistics from egui's own timing: kept for the last
//! [`FRAMES_KEPT`] frames, shown under the experimenter's view and printed
//! when the window closes.

use std::collections::VecDeque;

use crate::session::percentile;

/// Frames kept for the frame-time statistics.
const FRAMES_KEPT: usize = 100_000;

/// Frame-time statistics from egui's own timing.
#[derive(Debug, Clone, Default)]
pub struct FrameStats {
    /// CPU time of each frame (eframe's `cpu_usage`: UI and painting, not
    /// vsync), s.
    pub cpu_s: VecDeque<f64>,
    /// Time between frames (egui's `unstable_dt`), s.
    pub interval_s: VecDeque<f64>,
}

impl FrameStats {
    /// Records one frame: its CPU time and the time since the previous
    /// frame, s. The oldest frame is dropped past [`FRAMES_KEPT`].
    pub(super) fn record(&mut self, cpu_s: f64, interval_s: f64) {
        push(&mut self.cpu_s, cpu_s);
        push(&mut self.interval_s, interval_s);
    }

    /// `median / p99 over n frames` of CPU time and interval, in ms.
    #[must_use]
    pub fn summary(&self) -> String {
        let ms = |v: Option<f64>| v.map_or("-".into(), |s| format!("{:.2}", s * 1e3));
        format!(
            "frame time: cpu median {} ms, p99 {} ms; interval median {} ms, p99 {} ms ({} frames)",
            ms(percentile(&self.cpu_s, 0.5)),
            ms(percentile(&self.cpu_s, 0.99)),
            ms(percentile(&self.interval_s, 0.5)),
            ms(percentile(&self.interval_s, 0.99)),
            self.cpu_s.len()
        )
    }
}

fn push(list: &mut VecDeque<f64>, value: f64) {
    if list.len() == FRAMES_KEPT {
        list.pop_front();
    }
    list.push_back(value);
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Issue 13: the statistics moved out of the app keep the last
    /// `FRAMES_KEPT` frames, dropping the oldest.
    #[test]
    fn record_keeps_the_last_frames_kept_frames() {
        let mut stats = FrameStats::default();
        for i in 0..=FRAMES_KEPT {
            #[expect(clippy::cast_precision_loss, reason = "small counts")]
            let i = i as f64;
            stats.record(i, 2.0 * i);
        }
        assert_eq!(stats.cpu_s.len(), FRAMES_KEPT);
        assert_eq!(stats.interval_s.len(), FRAMES_KEPT);
        assert_eq!(stats.cpu_s.front(), Some(&1.0));
        assert_eq!(stats.interval_s.back(), Some(&(2.0 * 100_000.0)));
        assert!(stats.summary().ends_with("(100000 frames)"));
    }
}
