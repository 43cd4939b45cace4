//! A session on the Lab Streaming Layer (issue 34): the session's events
//! as markers, its device samples as the `Haptics` stream.
//!
//! The session calls in here where each event happens (its driver loop:
//! a trial starts when the engine enters a trial, ends with its record; a
//! stimulus is a render; an answer is an input handed to the engine), so
//! a marker's timestamp is the event's session time on LSL's clock
//! ([`Clock`]): the same number the trial record keeps as `lsl_start_s`
//! and `lsl_end_s`. The shell says how session time maps to LSL's clock:
//! a paced simulated device's virtual time runs at its pace from the
//! session's start ([`Session::lsl_pace`]); the window re-anchors at each
//! frame; a port's loop clock is the system's monotonic clock, which is
//! liblsl's ([`Session::publish`] maps it once).
//!
//! # Streams first (issue 42)
//! Both streams are published before the session starts, and
//! `--lsl-wait` waits for a reader on each before the first marker: with
//! the simulated device at once ([`Session::publish`]); on a port at its
//! first connected tick, which says who renders (before the session's log
//! opens and its first input is handled). The device stream's first
//! sample is at the session's start: the simulated device's state there
//! (at rest), or a port's ticks queued while the session waited.

use serde_json::{Map, Value};

use super::renders::How;
use super::{Responder, Session, SessionError};
use crate::kinds::{Action, Header, PlannedTrial, TrialRecord};
use crate::lsl::{Clock, DeviceStream, Node, Publisher, Streaming};
use crate::protocol::engine::{Answer, Input, RenderMode, Screen};
use crate::time::Time;

/// What a session publishing on LSL keeps.
pub(super) struct Tap {
    publisher: Publisher,
    clock: Clock,
    /// Re-anchored at each frame of the window (the simulated device).
    per_frame: bool,
    stream_name: String,
    source_id: String,
    /// The render on, if any (its number).
    stimulus: Option<u32>,
    last_block: Option<usize>,
    in_trial: bool,
    /// LSL time of the trial under way's start.
    trial_start: Option<f64>,
    /// A `device_lost` was sent, and no `device_back` since.
    lost: bool,
    /// How long to wait for readers when the streams open, s.
    wait_s: f64,
}

/// A marker's fields: `event` first.
fn fields(event: &str) -> Map<String, Value> {
    let mut m = Map::new();
    m.insert("event".into(), event.into());
    m
}

/// A short JSON summary of a planned trial's conditions: its fields with
/// every friction model (an object tagged `model`) given by its tag and
/// every condition (an object with an `id`) by its id. Generic: the
/// session names no kind.
fn conditions<T: serde::Serialize>(spec: &T) -> Value {
    fn short(v: Value) -> Value {
        match v {
            Value::Object(m) => {
                if let Some(id) = m.get("id").filter(|v| v.is_string()) {
                    return id.clone();
                }
                if let Some(model) = m.get("model").filter(|v| v.is_string()) {
                    return model.clone();
                }
                Value::Object(m.into_iter().map(|(k, v)| (k, short(v))).collect())
            }
            Value::Array(a) => Value::Array(a.into_iter().map(short).collect()),
            other => other,
        }
    }
    // A tagged union of kinds serialises as `{kind: {...}}` or flat.
    match serde_json::to_value(spec).map(short) {
        Ok(Value::Object(m)) if m.len() == 1 => {
            m.into_iter().next().map(|(_, v)| v).unwrap_or_default()
        }
        Ok(v) => v,
        Err(_) => Value::Null,
    }
}

impl Tap {
    /// Whether both streams are open (their readers waited for).
    pub(super) fn is_open(&self) -> bool {
        self.publisher.is_open()
    }

    fn mark(&mut self, t: Time, event: &str, extra: impl FnOnce(&mut Map<String, Value>)) {
        let mut m = fields(event);
        extra(&mut m);
        self.publisher.marker(self.clock.at(t), m);
    }

    fn trial_of(m: &mut Map<String, Value>, trial: usize) {
        m.insert("trial".into(), trial.into());
    }
}

/// The device was lost (`true`, once it had answered) or is back: a
/// `device_lost` or `device_back` marker at session time `t`, once each.
pub(super) fn device_lost(tap: Option<&mut Tap>, t: Time, lost: bool) {
    if let Some(tap) = tap
        && tap.lost != lost
    {
        tap.lost = lost;
        tap.mark(t, if lost { "device_lost" } else { "device_back" }, |_| {});
    }
}

/// A device sample as the stream's channels: position, velocity, force,
/// vibration, and the device's tick (on board).
fn sample_values(s: &crate::device::DeviceSample, tick: Option<u32>) -> [f32; 5] {
    #[expect(
        clippy::cast_possible_truncation,
        reason = "the stream is float32, as LSL's float channels are"
    )]
    [
        s.x_m as f32,
        s.v_m_s as f32,
        s.force_n as f32,
        s.vibration as f32,
        tick.map_or(0.0, |t| t as f32),
    ]
}

/// The device stream of a session whose device steps as `how`.
fn device_stream(tap: &Tap, how: How, device: &str) -> DeviceStream {
    let mode = match how.mode {
        RenderMode::Simulated => "simulated",
        RenderMode::HostLoop => "host_loop",
        RenderMode::OnBoard => "on_board",
    };
    let float = match how.float {
        crate::friction::Float::F32 => "f32",
        crate::friction::Float::F64 => "f64",
    };
    DeviceStream {
        name: format!("{} haptics", tap.stream_name),
        source_id: format!("{}/haptics", tap.source_id),
        rate_hz: how.rate_hz,
        tick: how.mode == RenderMode::OnBoard,
        desc: vec![
            Node::parent(
                "acquisition",
                vec![
                    Node::value("manufacturer", "frictionlab"),
                    Node::value("model", device),
                ],
            ),
            Node::parent(
                "rendering",
                vec![
                    Node::value("mode", mode),
                    Node::value("float", float),
                    Node::value("rate_hz", how.rate_hz.to_string()),
                    Node::value("force_limit_n", how.force_limit_n.to_string()),
                ],
            ),
        ],
    }
}

/// The stream name of a session: `frictionlab <protocol id> <participant>`.
#[must_use]
pub fn stream_name(h: &Header) -> String {
    format!("frictionlab {} {}", h.protocol_id, h.participant)
}

/// The marker stream's `source_id`: the same for every run of one session
/// (a resume continues the stream a recorder follows).
#[must_use]
pub fn source_id(h: &Header) -> String {
    format!(
        "frictionlab/{}/{}/session-{}/seed-{}",
        h.protocol_id, h.participant, h.session, h.plan_seed
    )
}

impl<R: Responder> Session<R> {
    /// Publishes this session on LSL with `lsl`. Call before the session
    /// is first fed. With the simulated device both streams open now
    /// ([`Session::lsl_open`]); on a port at its first connected tick.
    ///
    /// # Errors
    /// liblsl made no outlet, or its worker could not start.
    pub fn publish(&mut self, streaming: &Streaming) -> Result<(), SessionError> {
        let lsl = &streaming.lib;
        let header = self.log.header().clone();
        let (name, source) = (stream_name(&header), source_id(&header));
        let desc = vec![
            Node::value("protocol", header.protocol_id.as_str()),
            Node::value("participant", header.participant.as_str()),
            Node::value("session", header.session.to_string()),
            Node::value("kind", header.protocol.kind()),
            Node::parent(
                "acquisition",
                vec![
                    Node::value("manufacturer", "frictionlab"),
                    Node::value("model", env!("CARGO_PKG_VERSION")),
                ],
            ),
        ];
        let publisher = Publisher::start(lsl, &name, &format!("{source}/markers"), &desc)
            .map_err(|e| SessionError::Lsl(e.to_string()))?;
        let now = lsl.local_clock();
        // A port's ticks count from the loop's origin (session time
        // `start_t`); the simulated device's time is anchored when its
        // streams open.
        let (clock, per_frame) = match self.device.origin() {
            Some(origin) => (
                Clock {
                    t0: self.start_t,
                    lsl0: now - origin.elapsed().as_secs_f64(),
                    pace: 1.0,
                },
                false,
            ),
            None => (
                Clock {
                    t0: self.t,
                    lsl0: now,
                    pace: 1.0,
                },
                true,
            ),
        };
        self.lsl = Some(Box::new(Tap {
            publisher,
            clock,
            per_frame,
            stream_name: name,
            source_id: source,
            stimulus: None,
            last_block: None,
            in_trial: false,
            trial_start: None,
            lost: false,
            wait_s: streaming.wait_s,
        }));
        if self.device.is_sim() {
            // It ticks at the rate of the model it renders: the plan's
            // (its fastest model's) is the stream's nominal rate.
            let how = How {
                rate_hz: self.loop_rate_hz,
                ..self.row_render.1
            };
            self.lsl_open(how)?;
        }
        Ok(())
    }

    /// Opens both streams (module docs): publishes the device stream of a
    /// device stepping as `how`, waits for a reader on each (at most
    /// `--lsl-wait` in all), then sends `session_start` (or
    /// `session_resume`). The simulated device's clock is anchored there,
    /// and its state at that moment is the device stream's first sample;
    /// a port's loop queues its ticks' samples from before the wait.
    pub(super) fn lsl_open(&mut self, how: How) -> Result<(), SessionError> {
        let header = self.log.header().clone();
        let label = self.device_label.clone();
        let Some(tap) = self.lsl.as_deref_mut() else {
            return Ok(());
        };
        if tap.publisher.is_open() {
            return Ok(());
        }
        let stream = device_stream(tap, how, &label);
        let published = tap.publisher.device(&stream);
        if published && let super::device::Device::Port(port) = &mut self.device {
            port.publish(tap.publisher.sample_tap(tap.clock.lsl0));
        }
        tap.publisher
            .open(tap.wait_s)
            .map_err(|e| SessionError::Lsl(e.to_string()))?;
        let now = tap.publisher.now();
        if self.device.is_sim() {
            tap.clock = Clock {
                t0: self.t,
                lsl0: now,
                pace: tap.clock.pace,
            };
            tap.publisher.sample(now, sample_values(&self.sample, None));
        }
        let mut m = fields(match self.resumed_at {
            Some(_) => "session_resume",
            None => "session_start",
        });
        m.insert("session".into(), header.session.into());
        m.insert("protocol".into(), header.protocol_id.clone().into());
        m.insert("participant".into(), header.participant.clone().into());
        m.insert("planned_trials".into(), header.planned_trials.into());
        if let Some(at) = self.resumed_at {
            m.insert("at_trial".into(), at.into());
        }
        tap.publisher.marker(now, m);
        Ok(())
    }

    /// A headless shell paces the simulated device: session time runs
    /// `pace` times real time from the session's start on LSL's clock
    /// (where its streams opened).
    pub fn lsl_pace(&mut self, pace: f64) {
        if let Some(tap) = &mut self.lsl {
            tap.clock.pace = pace;
            tap.per_frame = false;
        }
    }

    /// Holds a paced simulated session (after [`Session::lsl_pace`]) until
    /// LSL's clock reaches its next tick, so each tick's sample (and the
    /// events settled right after it) are handled at, or just after,
    /// their timestamps. Returns at once when not so paced.
    pub(super) fn lsl_hold(&self) {
        let (Some(tap), super::device::Device::Sim { dt, .. }) = (&self.lsl, &self.device) else {
            return;
        };
        if tap.per_frame {
            return;
        }
        let due = tap.clock.at(self.t + *dt);
        let rest = due - tap.publisher.now();
        if rest > 0.0 {
            std::thread::sleep(std::time::Duration::from_secs_f64(rest));
        }
    }

    /// After a record was written (flushed and synced, the write rule): a
    /// paced simulated session's time stood still meanwhile, so its clock
    /// goes on from now: the next trial starts when it really does, and
    /// the device stream has a gap as long as the write.
    pub(super) fn lsl_written(&mut self) {
        if let (Some(tap), true) = (&mut self.lsl, self.device.is_sim())
            && !tap.per_frame
        {
            tap.clock = Clock {
                t0: self.t,
                lsl0: tap.publisher.now(),
                pace: tap.clock.pace,
            };
        }
    }

    /// LSL's clock now, when publishing.
    #[must_use]
    pub fn lsl_now(&self) -> Option<f64> {
        self.lsl.as_ref().map(|tap| tap.publisher.now())
    }

    /// The window's frame reaches session time `end` now: the simulated
    /// device's samples of the frame are stamped back from now.
    pub(super) fn lsl_frame(&mut self, end: Time) {
        if let Some(tap) = &mut self.lsl
            && tap.per_frame
        {
            tap.clock = Clock {
                t0: end,
                lsl0: tap.publisher.now(),
                pace: 1.0,
            };
        }
    }

    /// A simulated device's sample (after `observe` set it): queued for
    /// the device stream (a port's loop queues its own).
    pub(super) fn lsl_sample(&mut self) {
        let Some(tap) = &mut self.lsl else { return };
        if !self.device.is_sim() {
            return;
        }
        let at = tap.clock.at(self.t);
        tap.publisher
            .sample(at, sample_values(&self.sample, self.marks.device_tick));
    }

    /// An input about to reach the engine.
    pub(super) fn lsl_input(&mut self, input: &Input) {
        let t = self.t;
        let trial = self.engine.in_trial().then(|| self.engine.trial_index());
        let Some(tap) = &mut self.lsl else { return };
        let (event, extra): (&str, Option<(&str, Value)>) = match input {
            Input::Answer(Answer::Magnitude(text)) => {
                ("answer", Some(("answer", text.clone().into())))
            }
            Input::Answer(Answer::Paired(choice)) => (
                "answer",
                Some(("answer", serde_json::to_value(choice).unwrap_or_default())),
            ),
            Input::Switch(i) => ("switch", Some(("stimulus", (*i).into()))),
            Input::Click { x_m } => ("click", Some(("x_m", (*x_m).into()))),
            Input::Continue => ("continue", None),
            Input::Start | Input::Recorded | Input::Abort { .. } => return,
        };
        tap.mark(t, event, |m| {
            if let Some(trial) = trial {
                Tap::trial_of(m, trial);
            }
            if let Some((k, v)) = extra {
                m.insert(k.into(), v);
            }
        });
    }

    /// After the engine took an input or a timeout: a trial that started
    /// (and the block it starts, if new).
    pub(super) fn lsl_after_engine(&mut self) {
        let now_in = self.engine.in_trial();
        let t = self.t;
        let kind = self.engine.protocol().kind();
        let trial: Option<&PlannedTrial> = self.engine.trial();
        let Some(tap) = &mut self.lsl else { return };
        let started = now_in && !tap.in_trial;
        tap.in_trial = now_in;
        let Some(trial) = trial.filter(|_| started) else {
            return;
        };
        if tap.last_block != Some(trial.block_index) {
            tap.last_block = Some(trial.block_index);
            tap.mark(t, "block_start", |m| {
                m.insert("block".into(), trial.block.clone().into());
                m.insert("block_index".into(), trial.block_index.into());
            });
        }
        tap.trial_start = Some(tap.clock.at(t));
        let conditions = conditions(&trial.spec);
        tap.mark(t, "trial_start", |m| {
            Tap::trial_of(m, trial.index);
            m.insert("kind".into(), kind.into());
            m.insert("block".into(), trial.block.clone().into());
            m.insert("practice".into(), trial.practice.into());
            m.insert("repetition".into(), trial.repetition.into());
            m.insert("conditions".into(), conditions);
        });
    }

    /// An action the session carries out (`render`: the render number a
    /// `Render` was given).
    pub(super) fn lsl_action(&mut self, action: &Action, render: Option<u32>) {
        let t = self.t;
        let trial = self.engine.trial().map(|p| p.index);
        let Some(tap) = &mut self.lsl else { return };
        let with_trial = |m: &mut Map<String, Value>| {
            if let Some(trial) = trial {
                Tap::trial_of(m, trial);
            }
        };
        match action {
            Action::Render(model) => {
                if let Some(off) = tap.stimulus.take() {
                    tap.mark(t, "stimulus_off", |m| {
                        with_trial(m);
                        m.insert("render".into(), off.into());
                    });
                }
                if let (Some(model), Some(render)) = (model, render) {
                    tap.stimulus = Some(render);
                    tap.mark(t, "stimulus_on", |m| {
                        with_trial(m);
                        m.insert("render".into(), render.into());
                        m.insert("model".into(), model.name().into());
                    });
                }
            }
            Action::Show(Screen::Paired { active, .. }) => tap.mark(t, "interval", |m| {
                with_trial(m);
                m.insert("active".into(), (*active).into());
            }),
            Action::Show(Screen::Break { until }) => tap.mark(t, "break", |m| {
                m.insert("duration_s".into(), (*until - t).secs().into());
            }),
            Action::Show(Screen::Instructions(_)) => tap.mark(t, "instructions", |_| {}),
            Action::Show(Screen::Reference { .. }) => tap.mark(t, "reference", |_| {}),
            Action::Prompt(text) => tap.mark(t, "prompt", |m| {
                with_trial(m);
                m.insert("text".into(), text.clone().into());
            }),
            Action::Refused(why) => tap.mark(t, "refused", |m| {
                with_trial(m);
                m.insert("why".into(), why.clone().into());
            }),
            _ => {}
        }
    }

    /// A trial's record: its `trial_end` marker, and its LSL times.
    pub(super) fn lsl_record(&mut self, record: &mut TrialRecord) {
        let Some(tap) = &mut self.lsl else { return };
        let end = tap.clock.at(record.ended_s);
        let start = tap
            .trial_start
            .take()
            .unwrap_or_else(|| tap.clock.at(record.started_s));
        record.lsl_start_s = Some(start);
        record.lsl_end_s = Some(end);
        tap.in_trial = false;
        let mut m = fields("trial_end");
        Tap::trial_of(&mut m, record.trial);
        m.insert("status".into(), record.status.as_str().into());
        if let Some(reason) = &record.abort_reason {
            m.insert("reason".into(), reason.clone().into());
        }
        if record.requeued {
            m.insert("requeued".into(), true.into());
        }
        tap.publisher.marker(end, m);
    }

    /// A marker for something the session does outside the engine
    /// (pause, device lost, a note, the end).
    pub(super) fn lsl_event(&mut self, event: &str, extra: impl FnOnce(&mut Map<String, Value>)) {
        let t = self.t;
        if let Some(tap) = &mut self.lsl {
            tap.mark(t, event, extra);
        }
    }

    /// Ends publishing: pushes what is queued and, if the log is open,
    /// records what was published.
    pub(super) fn lsl_close(&mut self) -> Result<(), crate::results::ResultsError> {
        let Some(tap) = self.lsl.take() else {
            return Ok(());
        };
        let stats = tap.publisher.finish();
        if let Some(open) = self.log.opened() {
            open.log.append(&crate::kinds::LogLine::Lsl(stats))?;
        }
        Ok(())
    }
}
