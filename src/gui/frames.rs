//! Frame-time statistics from egui's own timing: kept for the last
//! [`FRAMES_KEPT`] frames, shown under the experimenter's view and printed
//! when the window closes.

use std::collections::VecDeque;

use crate::live::percentile;

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
