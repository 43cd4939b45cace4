//! Publishing a session on the Lab Streaming Layer: the session's events
//! as markers, its device samples as the `Haptics` stream. A shell's part
//! ([`super::run::Run`]): the session publishes nothing itself.
//!
//! [`Publishing::on`] turns each [`Event`] the session reports into its
//! marker, stamped with the event's session time on LSL's clock
//! ([`Clock`]): the same number the trial record keeps as `lsl_start_s`
//! and `lsl_end_s` (added where the record is written,
//! [`Session::annotate_records`]). How session time maps to LSL's clock:
//! a paced simulated device's virtual time runs at its pace from the
//! session's start ([`Publishing::pace`]); the window re-anchors at each
//! frame ([`Event::Frame`]); a port's loop clock is the system's monotonic
//! clock, which is liblsl's ([`Publishing::start`] maps it once).
//!
//! # Streams first
//! Both streams are published before the session starts, and
//! `--lsl-wait` waits for a reader on each before the first marker: with
//! the simulated device at once ([`Publishing::start`]); on a port at
//! [`Event::Ready`], its first connected tick, which says who renders
//! (before the session's log opens and its first input is handled). The
//! device stream's first sample is at the session's start: the simulated
//! device's state there (at rest), or a port's ticks queued while the
//! session waited (its haptic loop offers them to the stream,
//! [`Session::offer_samples`]).

use std::sync::{Arc, Mutex, PoisonError};

use serde_json::{Map, Value};

use super::renders::How;
use super::{Event, Feed, Responder, Session, SessionError};
use crate::device::haptic::{Offer, SampleSink, Tick};
use crate::kinds::{Action, Header, LogLine, LoggedTrial};
use crate::lsl::{Clock, DeviceStream, Node, Publisher, SampleTap, Streaming};
use crate::protocol::engine::{Answer, Input, Screen};
use crate::results::RenderMode;
use crate::time::Time;

/// What the record annotation shares with the publisher: LSL's clock and
/// the trial under way's start on it.
struct Stamps {
    clock: Clock,
    trial_start: Option<f64>,
}

/// A session published on LSL: see the module docs.
pub struct Publishing {
    publisher: Publisher,
    stamps: Arc<Mutex<Stamps>>,
    /// Re-anchored at each frame of the window (the simulated device).
    per_frame: bool,
    stream_name: String,
    source_id: String,
    /// The render on, if any (its number).
    stimulus: Option<u32>,
    last_block: Option<usize>,
    /// A `device_lost` was sent, and no `device_back` since.
    lost: bool,
    /// How long to wait for readers when the streams open, s.
    wait_s: f64,
}

/// A port's ticks, offered by its haptic loop, into the device stream.
struct LoopSamples(SampleTap);

impl SampleSink for LoopSamples {
    fn offer(&self, tick: &Tick) {
        self.0
            .push(tick.now_s, sample_values(&tick.sample(), tick.device_tick));
    }
}
/// A marker's fields: `event` first.
fn fields(event: &str) -> Map<String, Value> {
    let mut m = Map::new();
    m.insert("event".into(), event.into());
    m
}

/// The marker of a screen shown at `t` during trial `trial`, if it has
/// one; `own`: the name of the kind's own screen whose task it is, which
/// is marked as its task is, with its name (`screen`), or as `screen` if
/// its task has no marker.
fn screen_marker(
    t: Time,
    trial: Option<usize>,
    screen: &Screen,
    own: Option<&str>,
) -> Option<Map<String, Value>> {
    let (event, duration_s, active) = match screen {
        Screen::Paired { active, .. } => ("interval", None, Some(*active)),
        Screen::Break { until } => ("break", Some((*until - t).secs()), None),
        Screen::Instructions(_) => ("instructions", None, None),
        Screen::Reference { .. } => ("reference", None, None),
        Screen::Explore { .. } | Screen::Targets { .. } => {
            own?;
            ("screen", None, None)
        }
    };
    let mut m = fields(event);
    // A trial's screens (an interval, a kind's own) name their trial.
    if let Some(trial) = trial.filter(|_| active.is_some() || own.is_some()) {
        m.insert("trial".into(), trial.into());
    }
    if let Some(active) = active {
        m.insert("active".into(), active.into());
    }
    if let Some(d) = duration_s {
        m.insert("duration_s".into(), d.into());
    }
    if let Some(name) = own {
        m.insert("screen".into(), name.into());
    }
    Some(m)
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
fn device_stream(tap: &Publishing, how: How, device: &str) -> DeviceStream {
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

impl Publishing {
    /// Publishes `session` on LSL with `streaming`, before it is first
    /// fed: the session waits for this shell from now on
    /// ([`Session::wait_for_shell`]). With the simulated device both
    /// streams open now ([`Publishing::open`]); on a port at
    /// [`Event::Ready`].
    ///
    /// # Errors
    /// liblsl made no outlet, or its worker could not start.
    pub fn start<R: Responder>(
        streaming: &Streaming,
        session: &mut Session<R>,
    ) -> Result<Self, SessionError> {
        let lsl = &streaming.lib;
        let header = session.header().clone();
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
        // A port's ticks count from the loop's origin (session time at the
        // start); the simulated device's time is anchored when its
        // streams open.
        let (clock, per_frame) = match session.loop_origin() {
            Some(origin) => (
                Clock {
                    t0: session.now(),
                    lsl0: now - origin.elapsed().as_secs_f64(),
                    pace: 1.0,
                },
                false,
            ),
            None => (
                Clock {
                    t0: session.now(),
                    lsl0: now,
                    pace: 1.0,
                },
                true,
            ),
        };
        let stamps = Arc::new(Mutex::new(Stamps {
            clock,
            trial_start: None,
        }));
        let mut publishing = Publishing {
            publisher,
            stamps: Arc::clone(&stamps),
            per_frame,
            stream_name: name,
            source_id: source,
            stimulus: None,
            last_block: None,
            lost: false,
            wait_s: streaming.wait_s,
        };
        session.wait_for_shell();
        session.annotate_records(Box::new(move |record: &mut LoggedTrial| {
            let mut stamps = stamps.lock().unwrap_or_else(PoisonError::into_inner);
            let end = stamps.clock.at(record.ended_s);
            let start = stamps
                .trial_start
                .take()
                .unwrap_or_else(|| stamps.clock.at(record.started_s));
            record.lsl_start_s = Some(start);
            record.lsl_end_s = Some(end);
        }));
        if let Some(how) = session.sim_stepping() {
            publishing.open(session, how)?;
        }
        Ok(publishing)
    }

    fn clock(&self) -> Clock {
        self.stamps
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .clock
    }

    fn set_clock(&self, clock: Clock) {
        self.stamps
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .clock = clock;
    }

    /// Opens both streams (module docs): publishes the device stream of a
    /// device stepping as `how`, waits for a reader on each (at most
    /// `--lsl-wait` in all), then sends `session_start` (or
    /// `session_resume`). The simulated device's clock is anchored there,
    /// and its state at that moment is the device stream's first sample;
    /// a port's loop offers its ticks' samples from before the wait.
    fn open<R: Responder>(
        &mut self,
        session: &mut Session<R>,
        how: How,
    ) -> Result<(), SessionError> {
        if self.publisher.is_open() {
            return Ok(());
        }
        let stream = device_stream(self, how, session.device_label());
        if self.publisher.device(&stream)
            && !session.is_sim()
            && let Some(tap) = self.publisher.sample_tap(self.clock().lsl0)
        {
            session.offer_samples(Offer(Arc::new(LoopSamples(tap))));
        }
        self.publisher
            .open(self.wait_s)
            .map_err(|e| SessionError::Lsl(e.to_string()))?;
        let now = self.publisher.now();
        if session.is_sim() {
            let pace = self.clock().pace;
            self.set_clock(Clock {
                t0: session.now(),
                lsl0: now,
                pace,
            });
            self.publisher
                .sample(now, sample_values(&session.sample(), None));
        }
        let header = session.header();
        let mut m = fields(match session.resumed_at() {
            Some(_) => "session_resume",
            None => "session_start",
        });
        m.insert("session".into(), header.session.into());
        m.insert("protocol".into(), header.protocol_id.clone().into());
        m.insert("participant".into(), header.participant.clone().into());
        m.insert("planned_trials".into(), header.planned_trials.into());
        if let Some(at) = session.resumed_at() {
            m.insert("at_trial".into(), at.into());
        }
        self.publisher.marker(now, m);
        Ok(())
    }

    /// A headless shell paces the simulated device: session time runs
    /// `pace` times real time from the session's start on LSL's clock
    /// (where its streams opened).
    pub fn pace(&mut self, pace: f64) {
        let clock = self.clock();
        self.set_clock(Clock { pace, ..clock });
        self.per_frame = false;
    }

    /// Holds a paced simulated session (after [`Publishing::pace`]) until
    /// LSL's clock reaches its next tick ([`Session::poll_timeout`]).
    /// Returns at once when not so paced.
    pub fn hold<R: Responder>(&self, session: &Session<R>) {
        if self.per_frame || !session.is_sim() {
            return;
        }
        let Some(next) = session.poll_timeout() else {
            return;
        };
        let rest = self.clock().at(next) - self.publisher.now();
        if rest > 0.0 {
            std::thread::sleep(std::time::Duration::from_secs_f64(rest));
        }
    }

    /// LSL's clock now.
    #[must_use]
    pub fn now(&self) -> f64 {
        self.publisher.now()
    }

    fn mark(&mut self, t: Time, event: &str, extra: impl FnOnce(&mut Map<String, Value>)) {
        let mut m = fields(event);
        extra(&mut m);
        self.marker_at(t, m);
    }

    /// Pushes the marker `m` stamped at session time `t`.
    fn marker_at(&mut self, t: Time, m: Map<String, Value>) {
        let at = self.clock().at(t);
        self.publisher.marker(at, m);
    }

    /// Publishes what `event` says (a marker, a sample, a clock anchor),
    /// and answers the session's waits: [`Event::Ready`] opens the streams
    /// and says [`Feed::Go`].
    ///
    /// # Errors
    /// The streams could not open.
    pub fn on<R: Responder>(
        &mut self,
        event: Event,
        session: &mut Session<R>,
    ) -> Result<(), SessionError> {
        match event {
            Event::Ready { how } => {
                self.open(session, how)?;
                session.handle(Feed::Go)?;
            }
            Event::Frame { end } => {
                if self.per_frame {
                    self.set_clock(Clock {
                        t0: end,
                        lsl0: self.publisher.now(),
                        pace: 1.0,
                    });
                }
            }
            Event::Sample { t, sample } => {
                let at = self.clock().at(t);
                self.publisher.sample(at, sample_values(&sample, None));
            }
            Event::Input { t, trial, input } => self.input(t, trial, &input),
            Event::TrialStarted { t, trial } => {
                if self.last_block != Some(trial.block_index) {
                    self.last_block = Some(trial.block_index);
                    self.mark(t, "block_start", |m| {
                        m.insert("block".into(), trial.block.clone().into());
                        m.insert("block_index".into(), trial.block_index.into());
                    });
                }
                let start = self.clock().at(t);
                self.stamps
                    .lock()
                    .unwrap_or_else(PoisonError::into_inner)
                    .trial_start = Some(start);
                let kind = session.header().protocol.kind();
                self.mark(t, "trial_start", |m| {
                    m.insert("trial".into(), trial.index.into());
                    m.insert("kind".into(), kind.into());
                    m.insert("block".into(), trial.block.clone().into());
                    m.insert("practice".into(), trial.practice.into());
                    m.insert("repetition".into(), trial.repetition.into());
                    m.insert("conditions".into(), conditions(&trial.spec));
                });
            }
            Event::Action {
                t,
                trial,
                action,
                render,
            } => self.action(t, trial, &action, render),
            Event::Written { t, record } => self.written(t, &record, session),
            Event::DeviceLost { t } | Event::DeviceBack { t } => {
                let lost = matches!(event, Event::DeviceLost { .. });
                if self.lost != lost {
                    self.lost = lost;
                    self.mark(t, if lost { "device_lost" } else { "device_back" }, |_| {});
                }
            }
            Event::DeviceRequest { t, request } => self.mark(t, "device_request", |m| {
                m.insert("request".into(), request.ask().into());
            }),
            Event::Paused { t } => self.mark(t, "pause", |_| {}),
            Event::Resumed { t } => self.mark(t, "resume", |_| {}),
            Event::Note { t, text } => self.mark(t, "note", |m| {
                m.insert("text".into(), text.into());
            }),
            Event::Finished {
                t,
                completed,
                aborted,
            } => self.mark(t, "session_end", |m| {
                m.insert("completed".into(), completed.into());
                m.insert("aborted".into(), aborted.into());
            }),
            Event::Stopped { t, reason, signal } => self.mark(t, "session_stop", |m| {
                m.insert("reason".into(), reason.into());
                if let Some(signal) = signal {
                    m.insert("signal".into(), signal.into());
                }
            }),
        }
        Ok(())
    }

    /// Ends publishing: pushes what is queued; the log line that records
    /// what was published.
    #[must_use]
    pub fn finish(self) -> Vec<LogLine> {
        vec![LogLine::Lsl(self.publisher.finish())]
    }

    /// An input about to reach the engine.
    fn input(&mut self, t: Time, trial: Option<usize>, input: &Input) {
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
        self.mark(t, event, |m| {
            if let Some(trial) = trial {
                m.insert("trial".into(), trial.into());
            }
            if let Some((k, v)) = extra {
                m.insert(k.into(), v);
            }
        });
    }

    /// An action the session carried out (`render`: the render number a
    /// `Render` was given).
    fn action(&mut self, t: Time, trial: Option<usize>, action: &Action, render: Option<u32>) {
        let with_trial = |m: &mut Map<String, Value>| {
            if let Some(trial) = trial {
                m.insert("trial".into(), trial.into());
            }
        };
        match action {
            Action::Render(model) => {
                if let Some(off) = self.stimulus.take() {
                    self.mark(t, "stimulus_off", |m| {
                        with_trial(m);
                        m.insert("render".into(), off.into());
                    });
                }
                if let (Some(model), Some(render)) = (model, render) {
                    self.stimulus = Some(render);
                    self.mark(t, "stimulus_on", |m| {
                        with_trial(m);
                        m.insert("render".into(), render.into());
                        m.insert("model".into(), model.name().into());
                    });
                }
            }
            Action::Show(screen) => self.shown(t, trial, screen, None),
            // A kind's own screen: marked as its task is, with its name
            // (`screen`), and marked `screen` if its task has no marker.
            Action::ShowOwn(own) => self.shown(t, trial, &own.task(), Some(own.name())),
            Action::Prompt(text) => self.mark(t, "prompt", |m| {
                with_trial(m);
                m.insert("text".into(), text.clone().into());
            }),
            Action::Refused(why) => self.mark(t, "refused", |m| {
                with_trial(m);
                m.insert("why".into(), why.clone().into());
            }),
            _ => {}
        }
    }

    /// A screen shown at `t` (`own`: the name of the kind's own screen
    /// whose task it is): its marker, if it has one.
    fn shown(&mut self, t: Time, trial: Option<usize>, screen: &Screen, own: Option<&str>) {
        if let Some(m) = screen_marker(t, trial, screen, own) {
            self.marker_at(t, m);
        }
    }

    /// A trial's record was written at session time `t`: its `trial_end`
    /// marker at its LSL end. A paced simulated session's time stood still
    /// during the write (flushed and synced, the write rule), so its clock
    /// goes on from now: the next trial starts when it really does, and
    /// the device stream has a gap as long as the write.
    fn written<R: Responder>(&mut self, t: Time, record: &LoggedTrial, session: &Session<R>) {
        let end = record
            .lsl_end_s
            .unwrap_or_else(|| self.clock().at(record.ended_s));
        let mut m = fields("trial_end");
        m.insert("trial".into(), record.trial.into());
        m.insert("status".into(), record.status.as_str().into());
        if let Some(reason) = &record.abort_reason {
            m.insert("reason".into(), reason.clone().into());
        }
        if record.requeued {
            m.insert("requeued".into(), true.into());
        }
        self.publisher.marker(end, m);
        if session.is_sim() && !self.per_frame {
            let pace = self.clock().pace;
            self.set_clock(Clock {
                t0: t,
                lsl0: self.publisher.now(),
                pace,
            });
        }
    }
}

#[cfg(test)]
mod tests {
    use serde_json::json;

    use super::*;

    fn marker(screen: &Screen, own: Option<&str>) -> Option<Value> {
        screen_marker(Time::from_whole_secs(2), Some(3), screen, own).map(Value::Object)
    }

    #[test]
    fn a_kinds_own_screen_is_marked_as_its_task_with_its_name() {
        let until = Time::from_whole_secs(5);
        let pair = Screen::Paired {
            active: 1,
            until,
            forced: None,
        };
        let explore = Screen::Explore { until };
        // The shared screens, as they always were.
        assert_eq!(
            marker(&pair, None),
            Some(json!({"event": "interval", "trial": 3, "active": 1}))
        );
        assert_eq!(
            marker(&Screen::Break { until }, None),
            Some(json!({"event": "break", "duration_s": 3.0}))
        );
        assert_eq!(marker(&explore, None), None);
        // A kind's own: its task's marker with its name, or `screen`.
        assert_eq!(
            marker(&pair, Some("staircase_pair")),
            Some(json!({"event": "interval", "trial": 3, "active": 1, "screen": "staircase_pair"}))
        );
        assert_eq!(
            marker(&explore, Some("dial")),
            Some(json!({"event": "screen", "trial": 3, "screen": "dial"}))
        );
    }
}
