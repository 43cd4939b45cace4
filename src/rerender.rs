//! Re-rendering a recorded trial stream: the audit of what a participant
//! felt. The stream gives the motion each tick's model saw (`x_m`,
//! `v_m_s`), what was rendered (`force_n`, `vibration`) and which of the
//! trial's renders was in effect (`render`); the trial's record in the log
//! gives each render's model and how it was stepped (who, float, rate,
//! crossfade, force limit). The models are rendered again through the
//! core's [`Renderer`] over the recorded motion, and the largest
//! differences from the recorded force and vibration are reported.
//!
//! # Where the replay starts
//! A stream starts when its trial does; the render in effect at its first
//! row may have begun before (the previous trial's, fading out), in a state
//! the stream does not show. So the replay starts at the first row marked
//! `selected` whose render is a model and whose previous row rendered
//! nothing (the trial's model starting), and the rows before it are
//! counted as `skipped`. A select crossfades from the render in effect,
//! which is then nothing, so the model's state from there on is all in
//! the stream. Every later `selected` row selects its render again, as the
//! device did.
//!
//! A stream that opens rendering nothing, unselected (a trial whose
//! condition renders no model: Fitts' baseline), has rendered nothing
//! since its first row at the latest, and whatever the previous render
//! left has faded out a crossfade (`ramp_s`) later. The replay starts
//! there, rendering nothing (zero force and vibration expected), unless a
//! select of a model comes first.
//!
//! A select in a stream's first row is taken to start from nothing too, as
//! every trial ends by rendering nothing. (On board, over a lagging link,
//! the previous trial's selects can take effect after the next trial's
//! stream has begun: hence the rule. One landing on the first row exactly
//! would show as a difference, never pass unseen.)
//!
//! A select takes effect at its row, the model at rest at that row's
//! position, as the haptic loop and the on-board `BoardLoop` does; on the
//! simulated device, at the previous row's position (where the device was
//! when the model was set).
//!
//! # Lost telemetry
//! An on-board stream's `tick` column numbers the device's loop ticks; a
//! step of more than one is telemetry the link lost. (In streams from
//! before the column, `t_s` stepping by more than the device's loop
//! period says the same; but `t_s` is on the host's clock, which also
//! jumps when a device's clock drifts from it.) The device's model stepped
//! through those ticks, so the replay stops at the first such gap and
//! reports the missing ticks and the rows it did not replay.
//!
//! # A device started afresh
//! An on-board device changes its render only by a select (marked
//! `selected`), except when a new connection's `Hello` starts it afresh
//! (nothing rendered, no select). A row whose render changed unmarked is
//! such a restart, from a state the stream does not show: the replay stops
//! there too (`restarted_row`).
//!
//! # The watchdog
//! Where a row is marked `watchdog` the device rendered nothing (no message
//! from the host for 20 ms) while its model kept stepping, so an on-board
//! row is expected to show force and vibration 0 there. A host-loop row
//! shows what the host sent, which the replay renders as usual.

use std::path::{Path, PathBuf};

use frictionlab_core::render::Renderer;

use crate::friction::{Float, ForceLimit, Input, ModelParams};
use crate::problem::Problem;
use crate::results::{RenderEntry, RenderMode};
use frictionlab_core::Real;

/// One row of a stream.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Row {
    /// Session time, s.
    pub t_s: f64,
    /// Position the model saw, m.
    pub x_m: f64,
    /// Velocity the model saw, m/s.
    pub v_m_s: f64,
    /// Force rendered, N.
    pub force_n: f64,
    /// Vibration drive rendered.
    pub vibration: f64,
    /// Index of the render in effect in the record's `rendering`.
    pub render: usize,
    /// Whether a render took effect at this row.
    pub selected: bool,
    /// Whether the device's watchdog had tripped at this row (column
    /// `watchdog`, absent in streams from before it was recorded: 0).
    pub watchdog: bool,
    /// The device's loop tick number (column `tick`; empty where the
    /// device gave none, absent in older streams).
    pub tick: Option<u32>,
    /// The normal force the model rendered with where it was the hand's
    /// press (column `normal_force_n` of a multi-axis device's stream;
    /// empty otherwise).
    pub normal_n: Option<f64>,
}

/// What a re-render found.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Rerendered {
    /// The stream file.
    pub stream: String,
    /// The trial and its presentation.
    pub trial: usize,
    /// 1 for the first presentation, more for a re-queued trial.
    pub run: usize,
    /// Rows in the stream.
    pub rows: usize,
    /// Rows before the replay starts (see the module docs).
    pub skipped: usize,
    /// Rows re-rendered and compared with what was recorded (the rows
    /// less those skipped and those not replayed). None compared shows
    /// nothing: `bit_exact` is then false, and `frictionlab rerender`
    /// exits 2 (issue 63: a stream that had lost its start was skipped
    /// whole and still said `bit_exact`).
    pub compared: usize,
    /// The record's status (`completed` or `aborted`): an aborted
    /// presentation may end before its model took effect, with nothing
    /// to compare.
    pub status: crate::protocol::engine::Status,
    /// Who rendered the replayed rows (each mode once, in order).
    pub modes: Vec<RenderMode>,
    /// The floats they were stepped in.
    pub floats: Vec<Float>,
    /// Largest |recorded - re-rendered| force over the replayed rows, N.
    pub max_force_diff_n: f64,
    /// Largest |recorded - re-rendered| vibration drive.
    pub max_vibration_diff: f64,
    /// The row (0-based, after the header) of the largest force
    /// difference, if any differs.
    pub worst_row: Option<usize>,
    /// The row of the largest vibration difference, if any differs.
    pub worst_vibration_row: Option<usize>,
    /// Replayed rows where the device reported its watchdog tripped. On
    /// board it rendered nothing there (the model kept stepping), so the
    /// replay expects force and vibration 0 at those rows.
    pub watchdog_rows: usize,
    /// Whether every replayed row matches exactly (the same number; 0 and
    /// -0 alike), and at least one was compared.
    pub bit_exact: bool,
    /// Time the replayed rows span, s.
    pub replayed_s: f64,
    /// Device ticks missing from the stream (telemetry the link lost), from
    /// the gaps in an on-board stream's `t_s`. The device's model stepped
    /// through ticks the stream does not show, so the replay stops at the
    /// first gap.
    pub missing_ticks: usize,
    /// Rows after the first gap or restart, not replayed.
    pub unreplayed_rows: usize,
    /// The first replayed on-board row whose render changed without a
    /// select: the device started afresh there (a new connection's
    /// `Hello`), in a state the stream does not show, so the replay stops
    /// at it. A session ends a trial's stream where its device is lost, so
    /// its streams have none.
    pub restarted_row: Option<usize>,
    /// Stick-to-slip transitions of the replayed models (Nakano's stick-slip
    /// and the god object; the other models have none).
    pub slip_onsets: usize,
    /// Those of them that started a vibrotactile burst (in a model that
    /// drives the actuator).
    pub bursts: usize,
}

/// Re-renders the stream at `path`, with its models from the session log
/// beside it (`<results>/logs/`, found from the stream's name).
///
/// # Errors
/// An unreadable or malformed stream (with `line:col`), no log or no
/// record for the trial, a render index the record lacks.
pub fn rerender_file(path: &Path) -> Result<Rerendered, Problem> {
    let file = path.display().to_string();
    let (log_path, trial, run) = log_of(path).ok_or_else(|| {
        Problem::new(
            &file,
            "not a session stream: expected <results>/streams/study-<P>_subject-<S>_session-<n>_trial-<k>_run-<r>_stream.csv",
        )
    })?;
    let text = std::fs::read_to_string(path)
        .map_err(|e| Problem::new(&file, format!("cannot read: {e}")))?;
    let rows = parse_stream(&file, &text)?;
    let log = crate::results::read_log::<crate::kinds::Registry>(&log_path)
        .map_err(|e| Problem::new(log_path.display().to_string(), e.to_string()))?;
    let record = log
        .trials
        .iter()
        .filter(|r| r.trial == trial)
        .nth(run - 1)
        .ok_or_else(|| {
            Problem::new(
                log_path.display().to_string(),
                format!("no record of trial {trial}, presentation {run}"),
            )
        })?;
    // A trial aborted before the device's first tick has neither rows
    // nor renders: nothing to replay.
    if record.rendering.is_empty() && !rows.is_empty() {
        return Err(Problem::new(
            log_path.display().to_string(),
            format!(
                "trial {trial}: the record has no 'rendering' (a log from before frictionlab recorded it)"
            ),
        ));
    }
    if let Some(i) = rows.iter().position(|r| r.render >= record.rendering.len()) {
        return Err(Problem::new(
            format!("{file}: {}:6", i + 2),
            format!(
                "render {} is not in the record's rendering (it has {})",
                rows[i].render,
                record.rendering.len()
            ),
        ));
    }
    let mut out = rerender(&rows, &record.rendering);
    out.stream = file;
    out.trial = trial;
    out.run = run;
    out.status = record.status;
    Ok(out)
}

/// The log, trial and run of a stream at `<root>/streams/<stem>_trial-<k>_run-<r>_stream.csv`.
fn log_of(path: &Path) -> Option<(PathBuf, usize, usize)> {
    let name = path.file_name()?.to_str()?;
    let rest = name.strip_suffix("_stream.csv")?;
    let (rest, run) = rest.rsplit_once("_run-")?;
    let (stem, trial) = rest.rsplit_once("_trial-")?;
    let run: usize = run.parse().ok().filter(|r| *r >= 1)?;
    let root = path.parent()?.parent()?;
    Some((
        root.join("logs").join(format!("{stem}_log.jsonl")),
        trial.parse().ok()?,
        run,
    ))
}

/// Parses a stream's text.
///
/// # Errors
/// A missing column, or a value that is not a number, at `line:col`.
pub fn parse_stream(file: &str, text: &str) -> Result<Vec<Row>, Problem> {
    const COLUMNS: [&str; 7] = [
        "t_s",
        "x_m",
        "v_m_s",
        "force_n",
        "vibration",
        "render",
        "selected",
    ];
    const OPTIONAL: &str = "watchdog";
    const TICK: &str = "tick";
    const NORMAL: &str = "normal_force_n";
    let mut lines = text.lines();
    let header = lines.next().unwrap_or_default();
    let names: Vec<&str> = header.split(',').map(str::trim).collect();
    let at: Vec<usize> = COLUMNS
        .iter()
        .map(|c| {
            names.iter().position(|n| n == c).ok_or_else(|| {
                Problem::new(
                    format!("{file}: 1:1"),
                    format!("column '{c}': missing (a stream has {})", COLUMNS.join(",")),
                )
            })
        })
        .collect::<Result<_, _>>()?;
    let optional = names.iter().position(|n| *n == OPTIONAL);
    let tick_at = names.iter().position(|n| *n == TICK);
    let normal_at = names.iter().position(|n| *n == NORMAL);
    let mut rows = Vec::new();
    for (i, line) in lines.enumerate() {
        if line.trim().is_empty() {
            continue;
        }
        let cells: Vec<&str> = line.split(',').collect();
        let number = |c: usize, name: &str| {
            let cell = cells.get(c).map(|s| s.trim()).unwrap_or_default();
            cell.parse::<f64>()
                .ok()
                .filter(|x| x.is_finite())
                .ok_or_else(|| {
                    Problem::new(
                        format!("{file}: {}:{}", i + 2, c + 1),
                        format!("column '{name}': '{cell}' is not a finite number"),
                    )
                })
        };
        let mut v = [0.0; 7];
        for (k, &c) in at.iter().enumerate() {
            v[k] = number(c, COLUMNS[k])?;
        }
        let watchdog = match optional {
            Some(c) => number(c, OPTIONAL)? != 0.0,
            None => false,
        };
        let tick = match tick_at.map(|c| (c, cells.get(c).map_or("", |s| s.trim()))) {
            None | Some((_, "")) => None,
            Some((c, cell)) => Some(cell.parse::<u32>().map_err(|_| {
                Problem::new(
                    format!("{file}: {}:{}", i + 2, c + 1),
                    format!("column 'tick': '{cell}' is not a device tick number"),
                )
            })?),
        };
        let normal_n = match normal_at.map(|c| (c, cells.get(c).map_or("", |s| s.trim()))) {
            None | Some((_, "")) => None,
            Some((c, _)) => Some(number(c, NORMAL)?),
        };
        #[expect(
            clippy::cast_possible_truncation,
            clippy::cast_sign_loss,
            reason = "checked to be a small whole number"
        )]
        let render = if v[5] >= 0.0 && v[5].fract() == 0.0 && v[5] < 1e6 {
            v[5] as usize
        } else {
            return Err(Problem::new(
                format!("{file}: {}:{}", i + 2, at[5] + 1),
                format!("column 'render': '{}' is not a render index", v[5]),
            ));
        };
        rows.push(Row {
            t_s: v[0],
            x_m: v[1],
            v_m_s: v[2],
            force_n: v[3],
            vibration: v[4],
            render,
            selected: v[6] != 0.0,
            watchdog,
            tick,
            normal_n,
        });
    }
    Ok(rows)
}

/// Re-renders `rows` with the renders `entries` (see the module docs).
#[must_use]
pub fn rerender(rows: &[Row], entries: &[RenderEntry]) -> Rerendered {
    let mut out = Rerendered {
        stream: String::new(),
        trial: 0,
        run: 1,
        rows: rows.len(),
        skipped: 0,
        compared: 0,
        status: crate::protocol::engine::Status::Completed,
        modes: Vec::new(),
        floats: Vec::new(),
        max_force_diff_n: 0.0,
        max_vibration_diff: 0.0,
        worst_row: None,
        worst_vibration_row: None,
        watchdog_rows: 0,
        bit_exact: true,
        replayed_s: 0.0,
        missing_ticks: 0,
        unreplayed_rows: 0,
        restarted_row: None,
        slip_onsets: 0,
        bursts: 0,
    };
    let Some(first) = rows.first().and_then(|r| entries.get(r.render)) else {
        out.bit_exact = false;
        return out;
    };
    let renders_nothing = |r: &Row| entries.get(r.render).is_some_and(|e| e.model.is_none());
    let selected = (0..rows.len())
        .find(|&i| {
            let r = &rows[i];
            let after_nothing = i.checked_sub(1).is_none_or(|p| renders_nothing(&rows[p]));
            r.selected && entries.get(r.render).is_some_and(|e| e.model.is_some()) && after_nothing
        })
        .unwrap_or(rows.len());
    // A stream that opens rendering nothing has rendered nothing since a
    // crossfade's length before its first row at the latest: from there
    // on, nothing is what the replay renders too (module docs).
    let settled = renders_nothing(&rows[0])
        .then(|| {
            (0..rows.len()).find(|&i| {
                rows[i].render != rows[0].render || rows[i].t_s - rows[0].t_s >= first.ramp_s
            })
        })
        .flatten()
        .filter(|&i| rows[i].render == rows[0].render);
    let start = settled.map_or(selected, |i| i.min(selected));
    out.skipped = start;
    match first.float {
        Float::F64 => replay::<f64>(rows, entries, start, &mut out),
        Float::F32 => replay::<f32>(rows, entries, start, &mut out),
    }
    out.compared = rows.len().saturating_sub(out.skipped + out.unreplayed_rows);
    out.bit_exact &= out.compared > 0;
    out
}

/// Device ticks missing between two rows of an on-board stream: from
/// their tick numbers, or, without them, from `t_s` (which steps by the
/// device's loop period).
fn missing_ticks(a: &Row, b: &Row, entries: &[RenderEntry]) -> usize {
    let Some(e) = entries
        .get(b.render)
        .filter(|e| e.mode == RenderMode::OnBoard)
    else {
        return 0;
    };
    if let (Some(ta), Some(tb)) = (a.tick, b.tick) {
        return usize::try_from(tb.wrapping_sub(ta).saturating_sub(1)).unwrap_or(usize::MAX);
    }
    let periods = (b.t_s - a.t_s) * e.rate_hz;
    if periods > 1.5 {
        #[expect(
            clippy::cast_possible_truncation,
            clippy::cast_sign_loss,
            reason = "a positive count of ticks"
        )]
        let missing = periods.round() as usize - 1;
        missing
    } else {
        0
    }
}

/// Whether `b` shows an on-board device that changed its render since `a`
/// without a select (started afresh).
fn restarted(a: &Row, b: &Row, entries: &[RenderEntry]) -> bool {
    let on_board = |r: &Row| {
        entries
            .get(r.render)
            .is_some_and(|e| e.mode == RenderMode::OnBoard)
    };
    b.render != a.render && !b.selected && (on_board(a) || on_board(b))
}

fn replay<T: Real>(rows: &[Row], entries: &[RenderEntry], start: usize, out: &mut Rerendered) {
    let Some(entry) = rows.get(start).and_then(|r| entries.get(r.render)) else {
        return;
    };
    let limit = ForceLimit::new(T::of(entry.force_limit_n)).unwrap_or_default();
    let mut renderer = Renderer::<T>::new(limit, T::of(entry.ramp_s));
    let dt = T::of(1.0 / entry.rate_hz);
    let mut current = None;
    let mut vibrates = false;
    // One pass over the gaps: their total, and the first gap or restart
    // after the start (where the replay ends).
    let mut end = rows.len();
    for (i, w) in rows.windows(2).enumerate() {
        let missing = missing_ticks(&w[0], &w[1], entries);
        out.missing_ticks += missing;
        if i < start || end < rows.len() {
            continue;
        }
        if missing > 0 {
            end = i + 1;
        } else if restarted(&w[0], &w[1], entries) {
            end = i + 1;
            out.restarted_row = Some(end);
        }
    }
    out.unreplayed_rows = rows.len() - end;
    out.replayed_s = rows[end - 1].t_s - rows[start].t_s;
    for (i, row) in rows.iter().enumerate().take(end).skip(start) {
        if row.selected || current != Some(row.render) {
            let Some(e) = entries.get(row.render) else {
                return;
            };
            if !out.modes.contains(&e.mode) {
                out.modes.push(e.mode);
            }
            if !out.floats.contains(&e.float) {
                out.floats.push(e.float);
            }
            let x = if e.mode == RenderMode::Simulated && i > 0 {
                rows[i - 1].x_m
            } else {
                row.x_m
            };
            // Renders skipped between two rows (two selects in one tick)
            // are selected in turn.
            let from = match current {
                Some(c) if c < row.render => c + 1,
                _ => row.render,
            };
            for k in from..=row.render {
                renderer.select(entries.get(k).and_then(|e| e.model.as_ref()), T::of(x));
            }
            current = Some(row.render);
            vibrates = e.model.as_ref().is_some_and(ModelParams::has_vibration);
        }
        if let Some(n) = row.normal_n {
            renderer.set_pressed_normal(T::of(n));
        }
        let o = renderer.step(
            dt,
            Input {
                x_m: T::of(row.x_m),
                v_m_s: T::of(row.v_m_s),
            },
        );
        if o.slip_onset {
            out.slip_onsets += 1;
            out.bursts += usize::from(vibrates);
        }
        // On board a tripped watchdog zeroes what the device renders.
        let zeroed = row.watchdog
            && entries
                .get(row.render)
                .is_some_and(|e| e.mode == RenderMode::OnBoard);
        out.watchdog_rows += usize::from(row.watchdog);
        let (f, v) = if zeroed {
            (0.0, 0.0)
        } else {
            (o.force_n.to_f64(), o.vibration.to_f64())
        };
        let df = (f - row.force_n).abs();
        let dv = (v - row.vibration).abs();
        if df != 0.0 || dv != 0.0 {
            out.bit_exact = false;
        }
        if df > out.max_force_diff_n {
            out.max_force_diff_n = df;
            out.worst_row = Some(i);
        }
        if dv > out.max_vibration_diff {
            out.max_vibration_diff = dv;
            out.worst_vibration_row = Some(i);
        }
    }
}
