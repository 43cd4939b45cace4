//! The write rule: a trial's stream, then its record (fsync'd), then the CSV
//! made from the log, all before the next trial starts.

use std::fmt::Write as _;
use std::path::PathBuf;

use super::open::OpenLog;
use crate::device::DeviceSample;
use crate::kinds::{Header, LogLine, LoggedTrial};
use crate::results::csv::Num;
use crate::results::{ResultsDir, ResultsError, data_csv, replace_file};

/// Records each trial's device stream at the loop rate and writes it, when
/// the trial ends, to
/// `streams/study-<P>_subject-<S>_session-<n>_trial-<k>_run-<r>_stream.csv`
/// (`k` the planned trial index, `r` its presentation: 1, or more for a
/// re-queued trial). Columns
/// `t_s,x_m,v_m_s,force_n,vibration,render,selected,watchdog,tick`:
/// session time, device position and velocity (what the model saw),
/// rendered force on the hand, vibrotactile drive (SI units), and the
/// index of the render in effect in the trial record's `rendering` list,
/// and the row's [`RowMarks`]. On a device with more than one axis, where
/// `x_m` is the place along the track the model was rendered on, seven more
/// columns `device_x_m,device_y_m,device_z_m,device_fx_n,device_fy_n,device_fz_n`
/// give the hand's position and the force sent on each of the device's
/// axes, in its own frame (the friction and the wall that holds the hand on
/// the track), and `normal_force_n` the normal force the model rendered
/// with where it is the hand's press (empty otherwise).
/// Readable by `frictionlab identify`; `frictionlab rerender` renders it
/// again.
#[derive(Debug, Clone, Default)]
pub struct StreamRecorder {
    stem: Option<PathBuf>,
    rows: Vec<([f64; 5], usize, RowMarks)>,
    /// The device has more than one axis: every stream has the axis
    /// columns, a trial with no rows too.
    axes: bool,
}

/// What a stream row marks besides its values (columns `selected` and
/// `watchdog`, 0 or 1, and `tick`, empty where the device gave none).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct RowMarks {
    /// A render took effect at this row (its model started at rest here).
    pub selected: bool,
    /// The device reported its watchdog tripped (no message from the host
    /// for 20 ms): it rendered nothing at this tick. On board the row's
    /// `force_n` and `vibration` are then 0, what the hand got; in the host
    /// loop they are what the host sent.
    pub watchdog: bool,
    /// The device's loop tick number, where its telemetry gave one (on
    /// board).
    pub device_tick: Option<u32>,
    /// On a device with more than one axis: the hand's position, m, and
    /// the force sent, N, on each axis of the device's frame, and the
    /// normal force the model rendered with where it is the press, N.
    pub axes: Option<([f64; 3], [f64; 3], Option<f64>)>,
}

impl StreamRecorder {
    /// A recorder for the session of `header` (`on`: record at all).
    #[must_use]
    pub fn new(dir: &ResultsDir, header: &Header, on: bool) -> Self {
        let files = dir.files(&header.protocol_id, &header.participant, header.session);
        let stem = files
            .csv
            .file_name()
            .map(|n| n.to_string_lossy().trim_end_matches("_data.csv").to_owned());
        StreamRecorder {
            stem: stem
                .filter(|_| on)
                .map(|s| dir.root().join("streams").join(s)),
            rows: Vec::new(),
            axes: false,
        }
    }

    /// Removes the temporaries of the streams of the session of `header`
    /// that a killed writer left (`results::remove_partials`).
    ///
    /// # Errors
    /// A temporary that cannot be removed.
    pub fn remove_partials(dir: &ResultsDir, header: &Header) -> Result<usize, ResultsError> {
        match Self::new(dir, header, true).stem {
            Some(stem) => crate::results::remove_partials(
                &dir.root().join("streams"),
                &format!(
                    "{}_",
                    stem.file_name()
                        .map(|n| n.to_string_lossy())
                        .unwrap_or_default()
                ),
            ),
            None => Ok(0),
        }
    }

    /// From now on every stream has the columns of a device with more than
    /// one axis.
    pub fn multi_axis(&mut self) {
        self.axes = true;
    }

    /// Adds a sample of the trial under way, rendered by the trial's
    /// render number `render`.
    pub fn push(&mut self, t_s: f64, s: &DeviceSample, render: usize, marks: RowMarks) {
        if self.stem.is_some() {
            self.rows
                .push(([t_s, s.x_m, s.v_m_s, s.force_n, s.vibration], render, marks));
        }
    }

    /// Writes the trial's stream (whole, fsync'd) and starts afresh.
    fn write(&mut self, trial: usize, run: usize) -> Result<(), ResultsError> {
        let rows = std::mem::take(&mut self.rows);
        let Some(stem) = &self.stem else {
            return Ok(());
        };
        let mut text = String::with_capacity(rows.len() * 64 + 40);
        let axes = self.axes || rows.iter().any(|(_, _, m)| m.axes.is_some());
        text.push_str("t_s,x_m,v_m_s,force_n,vibration,render,selected,watchdog,tick");
        text.push_str(if axes {
            ",device_x_m,device_y_m,device_z_m,device_fx_n,device_fy_n,device_fz_n,normal_force_n\n"
        } else {
            "\n"
        });
        for (r, render, marks) in &rows {
            let _ = write!(
                text,
                "{},{},{},{},{},{render},{},{},",
                Num(r[0]),
                Num(r[1]),
                Num(r[2]),
                Num(r[3]),
                Num(r[4]),
                u8::from(marks.selected),
                u8::from(marks.watchdog)
            );
            if let Some(tick) = marks.device_tick {
                let _ = write!(text, "{tick}");
            }
            if axes {
                let (p, f, normal) = marks.axes.unwrap_or_default();
                for v in p.iter().chain(&f) {
                    let _ = write!(text, ",{}", Num(*v));
                }
                text.push(',');
                if let Some(n) = normal {
                    let _ = write!(text, "{}", Num(n));
                }
            }
            text.push('\n');
        }
        let path = PathBuf::from(format!(
            "{}_trial-{trial}_run-{run}_stream.csv",
            stem.display()
        ));
        replace_file(&path, text.as_bytes(), true)
    }
}

impl OpenLog {
    /// Puts a trial record on disk: its device stream (if recorded), then
    /// the record appended to the log and fsync'd, then the CSV rewritten
    /// from the log. Only after this may the next trial start.
    ///
    /// # Errors
    /// I/O.
    pub fn write_record(&mut self, record: &LoggedTrial) -> Result<(), ResultsError> {
        let run = 1 + self
            .read
            .trials
            .iter()
            .filter(|r| r.trial == record.trial)
            .count();
        self.streams.write(record.trial, run)?;
        self.log.append(&LogLine::Trial(record.clone()))?;
        self.read.trials.push(record.clone());
        replace_file(&self.csv, data_csv(&self.read).as_bytes(), false)
    }

    /// Ends the log after the last trial: the `end` line with the counts of
    /// completed and aborted trials, which it returns.
    ///
    /// # Errors
    /// I/O.
    pub fn write_end(&mut self) -> Result<(usize, usize), ResultsError> {
        let completed = self.read.completed();
        let aborted = self.read.trials.len() - completed;
        self.log.append(&LogLine::End { completed, aborted })?;
        Ok((completed, aborted))
    }
}
