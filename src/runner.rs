//! The headless session runner: a shell that connects the engine, the
//! simulated device, the simulated participant and the results folder.
//!
//! This is one of the places (with the CLI and the GUI) that may read a
//! clock and write files: it paces virtual time against the wall clock
//! (`--pace`) and writes each trial record to the log, fsync'd, before it
//! tells the engine the record is written. The physics runs in virtual
//! time at the current model's loop rate; each trial starts with the device at
//! rest at the participant's home position, so a resumed session replays
//! exactly what an uninterrupted one would.

use std::collections::VecDeque;
use std::fmt::Write as _;
use std::path::PathBuf;
use std::time::{Duration, Instant};

use crate::device::DeviceSample;
use crate::device::sim::{Apparatus, SimDevice};
use crate::participant::SimParticipant;
use crate::protocol::Protocol;
use crate::protocol::engine::{Action, Engine, Input};
use crate::protocol::plan::{Plan, resolve};
use crate::results::{
    Header, LOG_FORMAT, LogLine, ReadLog, ResultsDir, ResultsError, SessionFiles, SessionLog,
    data_csv, kinds_present, read_log, replace_file, sha256_hex, write_dataset_description,
};

/// What to run.
#[derive(Debug, Clone)]
pub struct SessionRequest<'a> {
    /// The checked protocol.
    pub protocol: &'a Protocol,
    /// The protocol file's bytes (hashed into the log header).
    pub protocol_bytes: &'a [u8],
    /// Participant id (already checked).
    pub participant: &'a str,
    /// Counterbalancing index; default: participants already in the folder.
    pub participant_index: Option<u32>,
    /// Plan seed of a new session (a resumed one keeps its own).
    pub seed: u64,
    /// Continue the participant's last unfinished session.
    pub resume: bool,
    /// Virtual time runs this many times faster than real time; `None`: as
    /// fast as possible.
    pub pace: Option<f64>,
    /// The device, as logged: `sim`, or the serial port's path.
    pub device: &'a str,
    /// Record each trial's device stream (`streams/`, see [`StreamRecorder`]).
    pub streams: bool,
}

/// How a session went.
#[derive(Debug, Clone, PartialEq)]
pub struct SessionOutcome {
    /// Session number.
    pub session: u32,
    /// Trials completed in the whole session.
    pub completed: usize,
    /// Trials aborted in the whole session.
    pub aborted: usize,
    /// The trial a resume started at.
    pub resumed_at: Option<usize>,
    /// Bytes of a torn last log line cut off before resuming.
    pub torn_bytes: u64,
    /// Virtual time simulated by this run, s.
    pub simulated_s: f64,
    /// The data CSV.
    pub csv: PathBuf,
    /// The log.
    pub log: PathBuf,
}

/// A session ready to run: its plan, its log, and where it starts.
pub(crate) struct Prepared {
    pub(crate) plan: Plan,
    pub(crate) log: SessionLog,
    pub(crate) read: ReadLog,
    pub(crate) start_at: usize,
    pub(crate) start_time: f64,
    pub(crate) session: u32,
    pub(crate) csv: PathBuf,
    pub(crate) resumed_at: Option<usize>,
    pub(crate) torn_bytes: u64,
    pub(crate) streams: StreamRecorder,
}

/// A session checked and planned, nothing written yet: [`Planned::open`]
/// writes. A device shell connects in between, so a device that never
/// answers leaves no session behind.
pub(crate) struct Planned {
    pub(crate) plan: Plan,
    opening: Opening,
    streams: bool,
}

enum Opening {
    /// The participant's unfinished session, read back.
    Resume {
        read: Box<ReadLog>,
        files: SessionFiles,
    },
    /// A new session with this header.
    New {
        header: Box<Header>,
        files: SessionFiles,
    },
}

/// Checks the request against the results folder and plans the session:
/// a new one, or the participant's unfinished one when resuming. Reads
/// only. `responder` is logged in a new header.
///
/// # Errors
/// `--resume` without an unfinished session; an unreadable log.
pub(crate) fn plan_session(
    dir: &ResultsDir,
    req: &SessionRequest<'_>,
    responder: &str,
) -> Result<Planned, ResultsError> {
    let id = &req.protocol.id;
    let sessions = dir.sessions(id, req.participant)?;
    if req.resume {
        let Some(last) = sessions.into_iter().next_back() else {
            return Err(ResultsError::input(
                "--resume",
                format!(
                    "participant '{}' has no session of '{id}' in {}",
                    req.participant,
                    dir.root().display()
                ),
            ));
        };
        let read = read_log(&last.log)?;
        if read.ended {
            return Err(ResultsError::input(
                "--resume",
                format!(
                    "session {} of participant '{}' has ended: nothing to resume",
                    last.session, req.participant
                ),
            ));
        }
        let h = &read.header;
        return Ok(Planned {
            plan: resolve(&h.protocol, h.plan_seed, h.participant_index),
            opening: Opening::Resume {
                read: Box::new(read),
                files: last,
            },
            streams: req.streams,
        });
    }
    let session = sessions.last().map_or(1, |s| s.session + 1);
    let files = dir.files(id, req.participant, session);
    let participant_index = req
        .participant_index
        .unwrap_or_else(|| dir.other_participants(id, req.participant));
    let plan = resolve(req.protocol, req.seed, participant_index);
    let header = Header {
        format: LOG_FORMAT.into(),
        software_version: env!("CARGO_PKG_VERSION").into(),
        protocol_id: id.clone(),
        protocol_sha256: sha256_hex(req.protocol_bytes),
        protocol: req.protocol.clone(),
        plan_seed: req.seed,
        participant: req.participant.to_owned(),
        participant_index,
        session,
        device: req.device.to_owned(),
        responder: responder.into(),
        planned_trials: plan.trials.len(),
    };
    Ok(Planned {
        plan,
        opening: Opening::New {
            header: Box::new(header),
            files,
        },
        streams: req.streams,
    })
}

impl Planned {
    /// The session's header (a new one's, or the resumed one's).
    pub(crate) fn header(&self) -> &Header {
        match &self.opening {
            Opening::Resume { read, .. } => &read.header,
            Opening::New { header, .. } => header,
        }
    }

    /// The session's number and files.
    pub(crate) fn files(&self) -> &SessionFiles {
        match &self.opening {
            Opening::Resume { files, .. } | Opening::New { files, .. } => files,
        }
    }

    /// Session time where this run starts, s (a resumed session's last
    /// trial's end).
    pub(crate) fn start_time(&self) -> f64 {
        match &self.opening {
            Opening::Resume { read, .. } => read.trials.last().map_or(0.0, |r| r.ended_s),
            Opening::New { .. } => 0.0,
        }
    }

    /// The first trial this run presents.
    pub(crate) fn start_at(&self) -> usize {
        match &self.opening {
            Opening::Resume { read, .. } => read.next_trial(),
            Opening::New { .. } => 0,
        }
    }

    /// Opens the session's log: a new session (header, empty CSV, dataset
    /// description) or the unfinished one (torn last line cut, a `resumed`
    /// line appended).
    ///
    /// # Errors
    /// The log exists (a new session never overwrites), or any I/O error.
    pub(crate) fn open(&self, dir: &ResultsDir) -> Result<Prepared, ResultsError> {
        let (start_at, start_time) = (self.start_at(), self.start_time());
        let (plan, streams) = (self.plan.clone(), self.streams);
        match &self.opening {
            Opening::Resume { read, files } => {
                let (mut log, torn) = SessionLog::reopen(&files.log, read.valid_len)?;
                log.append(&LogLine::Resumed {
                    at_trial: start_at,
                    torn_bytes: torn,
                })?;
                Ok(Prepared {
                    plan,
                    log,
                    start_at,
                    start_time,
                    session: files.session,
                    csv: files.csv.clone(),
                    resumed_at: Some(start_at),
                    torn_bytes: torn,
                    streams: StreamRecorder::new(dir, &read.header, streams),
                    read: (**read).clone(),
                })
            }
            Opening::New { header, files } => {
                let log = SessionLog::create(&files.log, (**header).clone())?;
                let read = ReadLog {
                    header: (**header).clone(),
                    trials: Vec::new(),
                    ended: false,
                    valid_len: 0,
                    torn_bytes: 0,
                };
                replace_file(&files.csv, data_csv(&read).as_bytes(), false)?;
                write_dataset_description(dir, &kinds_present(dir))?;
                Ok(Prepared {
                    plan,
                    log,
                    streams: StreamRecorder::new(dir, &read.header, streams),
                    read,
                    start_at,
                    start_time,
                    session: files.session,
                    csv: files.csv.clone(),
                    resumed_at: None,
                    torn_bytes: 0,
                })
            }
        }
    }
}

/// [`plan_session`], then [`Planned::open`].
///
/// # Errors
/// As those.
pub(crate) fn prepare(
    dir: &ResultsDir,
    req: &SessionRequest<'_>,
    responder: &str,
) -> Result<Prepared, ResultsError> {
    plan_session(dir, req, responder)?.open(dir)
}

/// Records each trial's device stream at the loop rate and writes it, when
/// the trial ends, to
/// `streams/study-<P>_subject-<S>_session-<n>_trial-<k>_run-<r>_stream.csv`
/// (`k` the planned trial index, `r` its presentation: 1, or more for a
/// re-queued trial). Columns `t_s,x_m,v_m_s,force_n,vibration`: session
/// time, device position and velocity, rendered force on the hand, and
/// vibrotactile drive (SI units), readable by `frictionlab identify`.
#[derive(Debug, Clone, Default)]
pub struct StreamRecorder {
    stem: Option<PathBuf>,
    rows: Vec<[f64; 5]>,
}

impl StreamRecorder {
    /// A recorder for the session of `header` (`on`: record at all).
    #[must_use]
    pub fn new(dir: &ResultsDir, header: &crate::results::Header, on: bool) -> Self {
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
        }
    }

    /// Adds a sample of the trial under way.
    pub fn push(&mut self, t_s: f64, s: &DeviceSample) {
        if self.stem.is_some() {
            self.rows
                .push([t_s, s.x_m, s.v_m_s, s.force_n, s.vibration]);
        }
    }

    /// Writes the trial's stream (whole, fsync'd) and starts afresh.
    fn write(&mut self, trial: usize, run: usize) -> Result<(), ResultsError> {
        let rows = std::mem::take(&mut self.rows);
        let Some(stem) = &self.stem else {
            return Ok(());
        };
        let mut text = String::with_capacity(rows.len() * 64 + 40);
        text.push_str("t_s,x_m,v_m_s,force_n,vibration\n");
        for r in &rows {
            let _ = writeln!(text, "{},{},{},{},{}", r[0], r[1], r[2], r[3], r[4]);
        }
        let path = PathBuf::from(format!(
            "{}_trial-{trial}_run-{run}_stream.csv",
            stem.display()
        ));
        replace_file(&path, text.as_bytes(), true)
    }
}

/// Puts a trial record on disk: its device stream (if recorded), then the
/// record appended to the log and fsync'd, then the CSV rewritten from the
/// log. Only after this may the next trial start.
pub(crate) fn write_record(
    log: &mut SessionLog,
    read: &mut ReadLog,
    csv: &std::path::Path,
    streams: &mut StreamRecorder,
    record: &crate::protocol::engine::TrialRecord,
) -> Result<(), ResultsError> {
    let run = 1 + read
        .trials
        .iter()
        .filter(|r| r.trial == record.trial)
        .count();
    streams.write(record.trial, run)?;
    log.append(&LogLine::Trial(record.clone()))?;
    read.trials.push(record.clone());
    replace_file(csv, data_csv(read).as_bytes(), false)
}

/// Ends the log after the last trial: the `end` line with the counts of
/// completed and aborted trials, which it returns.
pub(crate) fn write_end(
    log: &mut SessionLog,
    read: &ReadLog,
) -> Result<(usize, usize), ResultsError> {
    let completed = read.completed();
    let aborted = read.trials.len() - completed;
    log.append(&LogLine::End { completed, aborted })?;
    Ok((completed, aborted))
}

/// Carries out a simulated participant's reaction on the simulated device:
/// the hand (and device) move to rest at a home position if asked, and the
/// inputs queue for the engine.
fn apply(
    reaction: crate::participant::Reaction,
    device: &mut SimDevice,
    sample: &mut DeviceSample,
    pending: &mut VecDeque<Input>,
) {
    if let Some(x) = reaction.reset_to {
        device.reset(x);
        *sample = DeviceSample {
            x_m: x,
            ..DeviceSample::default()
        };
    }
    pending.extend(reaction.inputs);
}

/// Keeps virtual time from running ahead of `pace` x the wall clock.
struct Pacer {
    pace: Option<f64>,
    wall: Instant,
    virtual_start: f64,
}

impl Pacer {
    fn wait(&self, t: f64) {
        let Some(pace) = self.pace.filter(|p| p.is_finite() && *p > 0.0) else {
            return;
        };
        let due = Duration::from_secs_f64(((t - self.virtual_start) / pace).max(0.0));
        let elapsed = self.wall.elapsed();
        if let Some(rest) = due.checked_sub(elapsed) {
            std::thread::sleep(rest);
        }
    }
}

/// Runs (or resumes) one session with the simulated device and participant.
///
/// The loop drains the engine's actions, feeds the engine the participant's
/// inputs one at a time, and otherwise advances the physics by one tick.
/// `progress(done, total)` is called after each trial is on disk.
///
/// # Errors
/// Bad input (resume without a session, a colliding id) or I/O.
pub fn run_simulated(
    dir: &ResultsDir,
    req: &SessionRequest<'_>,
    progress: &mut dyn FnMut(usize, usize),
) -> Result<SessionOutcome, ResultsError> {
    let Prepared {
        plan,
        mut log,
        mut read,
        start_at,
        start_time,
        session,
        csv,
        resumed_at,
        torn_bytes,
        mut streams,
    } = prepare(dir, req, "sim")?;
    let total = plan.trials.len();
    let seed = read.header.plan_seed;
    let mut participant = SimParticipant::new(seed, &read.header.participant);
    let mut device = SimDevice::new(Apparatus::default(), participant.traits().hand_mass_kg);
    let mut engine = Engine::new(plan, start_at);
    let pacer = Pacer {
        pace: req.pace,
        wall: Instant::now(),
        virtual_start: start_time,
    };

    let mut t = start_time;
    let mut dt = 1e-3;
    let mut sample = DeviceSample::default();
    let mut pending: VecDeque<Input> = VecDeque::from([Input::Start]);
    let mut timers: Vec<f64> = Vec::new();
    let mut ticks: u64 = 0;
    loop {
        while let Some(action) = engine.poll() {
            match &action {
                Action::Render(model) => {
                    device.set_model(model.as_ref());
                    if let Some(m) = model {
                        dt = 1.0 / m.loop_rate_hz();
                    }
                }
                Action::Physical(model) => device.set_physical(model.as_ref()),
                Action::WakeAt(at) => timers.push(*at),
                Action::Record(record) => {
                    write_record(&mut log, &mut read, &csv, &mut streams, record)?;
                    pending.push_back(Input::Recorded);
                    progress(record.trial + 1, total);
                }
                Action::Finished => {
                    let (completed, aborted) = write_end(&mut log, &read)?;
                    return Ok(SessionOutcome {
                        session,
                        completed,
                        aborted,
                        resumed_at,
                        torn_bytes,
                        simulated_s: t - start_time,
                        csv,
                        log: log.path().to_owned(),
                    });
                }
                _ => {}
            }
            let reaction = participant.on_action(t, &action, engine.trial());
            apply(reaction, &mut device, &mut sample, &mut pending);
        }
        if let Some(input) = pending.pop_front() {
            engine.handle(t, input);
            continue;
        }
        let force = participant.hand_force(t, dt, &sample);
        sample = device.step(dt, force);
        t += dt;
        if engine.in_trial() {
            streams.push(t, &sample);
        }
        ticks += 1;
        let reaction = participant.decide(t, &sample);
        apply(reaction, &mut device, &mut sample, &mut pending);
        if timers.iter().any(|&w| w <= t) {
            timers.retain(|&w| w > t);
            pending.push_back(Input::Timer);
        }
        if ticks.is_multiple_of(64) {
            pacer.wait(t);
        }
    }
}

/// Plan seed of simulated participant `i` of a study seeded with `seed`
/// (`SplitMix64` of the pair, so seeds of neighbouring participants differ).
#[must_use]
pub fn participant_seed(seed: u64, i: u32) -> u64 {
    let mut z = seed.wrapping_add(
        u64::from(i)
            .wrapping_add(1)
            .wrapping_mul(0x9e37_79b9_7f4a_7c15),
    );
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// A simulated study: `participants` whole sessions of `protocol` with
/// simulated participants `sim-001`, `sim-002`, ... (participant index i,
/// plan seed [`participant_seed`]).
#[derive(Debug, Clone, Copy)]
pub struct Simulation<'a> {
    /// The protocol, as parsed.
    pub protocol: &'a Protocol,
    /// Its file's bytes (hashed into each log header).
    pub protocol_bytes: &'a [u8],
    /// How many participants.
    pub participants: u32,
    /// The study seed.
    pub seed: u64,
    /// Simulated time runs `pace` x faster than real time; `None`: as fast
    /// as possible.
    pub pace: Option<f64>,
    /// Record each trial's device stream.
    pub streams: bool,
    /// Sessions run at once, on as many threads (at least 1). Each session
    /// depends only on its participant's seed, so the files are the same
    /// byte for byte whatever the number.
    pub jobs: usize,
}

/// Runs a [`Simulation`]; the outcomes come in participant order.
/// `progress(trials done in all sessions)` is called after each trial (from
/// the worker threads). After a session fails, no new one starts; the first
/// failure (in participant order) is returned.
///
/// # Errors
/// As [`run_simulated`].
pub fn simulate_participants(
    dir: &ResultsDir,
    sim: &Simulation<'_>,
    progress: &(dyn Fn(usize) + Sync),
) -> Result<Vec<SessionOutcome>, ResultsError> {
    use std::sync::Mutex;
    use std::sync::atomic::{AtomicBool, AtomicU32, AtomicUsize, Ordering};
    let (next, done, failed) = (
        AtomicU32::new(0),
        AtomicUsize::new(0),
        AtomicBool::new(false),
    );
    let outcomes: Mutex<Vec<(u32, Result<SessionOutcome, ResultsError>)>> = Mutex::default();
    let work = || {
        while !failed.load(Ordering::Relaxed) {
            let i = next.fetch_add(1, Ordering::Relaxed);
            if i >= sim.participants {
                break;
            }
            let id = format!("sim-{:03}", i + 1);
            let req = SessionRequest {
                protocol: sim.protocol,
                protocol_bytes: sim.protocol_bytes,
                participant: &id,
                participant_index: Some(i),
                seed: participant_seed(sim.seed, i),
                resume: false,
                pace: sim.pace,
                device: "sim",
                streams: sim.streams,
            };
            let mut reported = 0;
            let outcome = run_simulated(dir, &req, &mut |trial, _| {
                let new = trial.saturating_sub(reported);
                reported = reported.max(trial);
                progress(done.fetch_add(new, Ordering::Relaxed) + new);
            });
            failed.fetch_or(outcome.is_err(), Ordering::Relaxed);
            if let Ok(mut list) = outcomes.lock() {
                list.push((i, outcome));
            }
        }
    };
    std::thread::scope(|scope| {
        for _ in 1..sim.jobs.min(sim.participants as usize) {
            scope.spawn(work);
        }
        work();
    });
    let mut list = outcomes
        .into_inner()
        .unwrap_or_else(std::sync::PoisonError::into_inner);
    list.sort_by_key(|(i, _)| *i);
    list.into_iter().map(|(_, outcome)| outcome).collect()
}

/// Why a device session stopped early.
#[derive(Debug, thiserror::Error)]
pub enum DeviceRunError {
    /// Bad input or I/O on the results folder.
    #[error(transparent)]
    Results(#[from] ResultsError),
    /// The device gave no valid frame for the timeout (exit 3). Completed
    /// trials are in the log.
    #[error(
        "no answer from the device for {timeout_s} s ({completed} trials completed are in the log)"
    )]
    Lost {
        /// The timeout, s.
        timeout_s: f64,
        /// Trials completed before.
        completed: usize,
    },
    /// The device never answered within the timeout; no session was
    /// started or resumed (exit 3, nothing written).
    #[error("no answer from the device for {timeout_s} s; no session was started")]
    NeverConnected {
        /// The timeout, s.
        timeout_s: f64,
    },
    /// The loop thread could not start.
    #[error("cannot start the haptic loop: {0}")]
    Loop(std::io::Error),
}

/// The haptic loop rate a plan needs: the highest loop rate of any model it
/// renders (5 kHz for seed 001's stick-slip models, else 1 kHz).
pub(crate) fn loop_rate_hz(plan: &Plan) -> f64 {
    use crate::protocol::plan::TrialSpec;
    plan.trials
        .iter()
        .map(|t| match &t.spec {
            TrialSpec::MagnitudeEstimation { model, .. } | TrialSpec::Fitts { model, .. } => {
                model.loop_rate_hz()
            }
            TrialSpec::PairedComparison { first, second, .. } => {
                first.model.loop_rate_hz().max(second.model.loop_rate_hz())
            }
        })
        .fold(1000.0, f64::max)
}

/// How often the participant's hand drive is sent to the emulator, s.
pub(crate) const HAND_EVERY_S: f64 = 0.005;

/// Runs (or resumes) one session on the device at `path` (a serial port; the
/// emulator's pseudo-terminal for a simulated participant), in real time,
/// with the simulated participant driving the emulated hand. A device lost
/// mid-trial aborts and re-queues the trial and pauses the session until it
/// answers again; after `timeout_s` without an answer the run gives up.
///
/// # Errors
/// Bad input, I/O on the results, or a device lost for longer than the timeout.
#[expect(
    clippy::too_many_lines,
    reason = "the real-time session loop reads best in one place"
)]
pub fn run_device(
    dir: &ResultsDir,
    req: &SessionRequest<'_>,
    path: &std::path::Path,
    timeout_s: f64,
    progress: &mut dyn FnMut(usize, usize),
) -> Result<SessionOutcome, DeviceRunError> {
    use crate::device::haptic::{HapticLoop, ToLoop};
    use crate::device::link::LinkState;
    use crate::friction::ForceLimit;

    // Checked and planned first (bad input fails at once), then the device
    // must answer before anything is written.
    let planned = plan_session(dir, req, "sim")?;
    let rate_hz = loop_rate_hz(&planned.plan);
    let mut haptic = HapticLoop::start(path.to_owned(), rate_hz, true, ForceLimit::default())
        .map_err(DeviceRunError::Loop)?;
    let wall = Instant::now();
    'connect: loop {
        while let Some(tick) = haptic.recv() {
            if tick.link == LinkState::Connected {
                break 'connect;
            }
        }
        if wall.elapsed().as_secs_f64() > timeout_s {
            // No log to put the loop's statistics in.
            let _ = haptic.stop();
            return Err(DeviceRunError::NeverConnected { timeout_s });
        }
        std::thread::sleep(Duration::from_millis(1));
    }
    let Prepared {
        plan,
        mut log,
        mut read,
        start_at,
        session,
        csv,
        resumed_at,
        torn_bytes,
        mut streams,
        ..
    } = match planned.open(dir) {
        Ok(prepared) => prepared,
        Err(e) => {
            let _ = haptic.stop();
            return Err(e.into());
        }
    };
    let total = plan.trials.len();
    let mut participant = SimParticipant::new(read.header.plan_seed, &read.header.participant);
    let mut engine = Engine::new(plan, start_at);
    let mut pending: VecDeque<Input> = VecDeque::from([Input::Start]);
    let mut timers: Vec<f64> = Vec::new();
    let (mut t, mut last_hand) = (0.0_f64, f64::NEG_INFINITY);
    let mut lost_since: Option<f64> = Some(0.0);
    let mut trial_live = false;
    loop {
        while let Some(tick) = haptic.recv() {
            t = tick.now_s;
            if tick.link != LinkState::Connected {
                let since = *lost_since.get_or_insert(t);
                if trial_live {
                    trial_live = false;
                    engine.handle(
                        t,
                        Input::Abort {
                            reason: "device lost".into(),
                            requeue: true,
                        },
                    );
                }
                if t - since > timeout_s {
                    let stats = haptic.stop();
                    log.append(&LogLine::Loop(stats))?;
                    return Err(DeviceRunError::Lost {
                        timeout_s,
                        completed: read.completed(),
                    });
                }
                continue;
            }
            lost_since = None;
            let sample = DeviceSample {
                x_m: tick.x_m,
                v_m_s: tick.v_m_s,
                force_n: tick.force_n,
                vibration: tick.vibration,
            };
            if engine.in_trial() {
                streams.push(t, &sample);
            }
            let reaction = participant.decide(t, &sample);
            pending.extend(reaction.inputs);
            if t - last_hand >= HAND_EVERY_S {
                last_hand = t;
                haptic.send(ToLoop::Device(participant.drive_message(t, &sample)));
            }
            if timers.iter().any(|&w| w <= t) {
                timers.retain(|&w| w > t);
                pending.push_back(Input::Timer);
            }
        }
        // Paused while the device is lost: inputs wait.
        if lost_since.is_none() {
            while let Some(input) = pending.pop_front() {
                engine.handle(t, input);
                while let Some(action) = engine.poll() {
                    match &action {
                        Action::Render(model) => {
                            trial_live = model.is_some();
                            haptic.send(ToLoop::Model(model.clone()));
                        }
                        Action::WakeAt(at) => timers.push(*at),
                        Action::Record(record) => {
                            trial_live = false;
                            write_record(&mut log, &mut read, &csv, &mut streams, record)?;
                            pending.push_back(Input::Recorded);
                            progress(record.trial + 1, total);
                        }
                        Action::Finished => {
                            let stats = haptic.stop();
                            log.append(&LogLine::Loop(stats))?;
                            let (completed, aborted) = write_end(&mut log, &read)?;
                            return Ok(SessionOutcome {
                                session,
                                completed,
                                aborted,
                                resumed_at,
                                torn_bytes,
                                simulated_s: t,
                                csv,
                                log: log.path().to_owned(),
                            });
                        }
                        _ => {}
                    }
                    // On a device the hand cannot jump: it moves to its home position itself.
                    pending.extend(participant.on_action(t, &action, engine.trial()).inputs);
                }
            }
        }
        std::thread::sleep(std::time::Duration::from_millis(1));
    }
}
