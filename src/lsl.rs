//! Publishing on the Lab Streaming Layer (issue 34): the session's events
//! as a marker stream and the device's samples as a `Haptics` stream.
//!
//! The session (on its own thread: the headless loop, or the window's) hands
//! each marker and sample to a [`Publisher`] already stamped with LSL's
//! clock at the moment it happened ([`Clock`]); a worker thread pushes them
//! into liblsl. Markers are handed over in a queue under a mutex, and
//! never dropped. Device samples go through a wait-free ring with one
//! producer (the session, or a port's haptic loop through its
//! [`SampleTap`]) and one consumer (the worker), bounded at 2 s of them: a
//! sample that finds the ring full is dropped and counted. The haptic loop
//! runs at real-time priority and must never wait on a lock a thread of
//! normal priority holds: under a concurrent build it did, on this queue's
//! mutex, for up to 88 ms, and an on-board board was judged lost (issue
//! 63). So pushing, and whatever liblsl does with no consumer or a slow
//! one, never holds up the session or the loop.
//!
//! # Streams first (issue 42)
//! Both outlets exist before anything is pushed: [`Publisher::start`]
//! makes the marker stream, [`Publisher::device`] the device stream, and
//! [`Publisher::open`] then waits (at most `--lsl-wait`) for a reader on
//! each before the worker starts pushing. So a recorder started before
//! the session sees both streams while the session waits for it, and
//! records both from the session's first marker; what is queued before
//! `open` waits for it.
//!
//! [`Publisher::finish`] pushes what is queued, lets a connected inlet
//! drain the last samples, and returns [`LslStats`]: counts and latencies
//! (event to session, event to push) for the session log.

use std::collections::VecDeque;
use std::path::Path;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Condvar, Mutex, MutexGuard, PoisonError};
use std::thread::JoinHandle;
use std::time::Duration;

use crate::time::Time;

pub use frictionlab_lsl::{Content, Format, LoadError, Lsl, Node, OutletError, StreamSpec};

/// Finds and opens liblsl: `explicit` (`--lsl-lib`), then
/// `FRICTIONLAB_LSL_LIB`, then the usual library names.
///
/// # Errors
/// Not found (every place tried is named), too old, or not liblsl.
pub fn load(explicit: Option<&Path>) -> Result<Arc<Lsl>, LoadError> {
    let env = std::env::var_os("FRICTIONLAB_LSL_LIB").filter(|v| !v.is_empty());
    Lsl::load(&frictionlab_lsl::candidates(
        explicit,
        env.as_deref().map(Path::new),
    ))
}

/// A session's streaming settings: the library, and how long the session
/// may wait for a recorder before it starts.
#[derive(Debug, Clone)]
pub struct Streaming {
    /// liblsl.
    pub lib: Arc<Lsl>,
    /// Hold the session's start, with both streams published, until an
    /// inlet listens to each, at most this long in all, s (0: start at
    /// once; what is pushed before a recorder connects is not recorded).
    pub wait_s: f64,
}

/// Session time to LSL time: `lsl0 + (t - t0) / pace`. The simulated
/// device's virtual time is held to the wall clock by its pacing (`pace`
/// times real time); a port's loop clock is `Instant`, the clock liblsl
/// reads on Linux, mapped once.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Clock {
    /// A session time.
    pub t0: Time,
    /// The LSL time it maps to, s.
    pub lsl0: f64,
    /// Session seconds per LSL second.
    pub pace: f64,
}

impl Clock {
    /// The LSL time of session time `t` (before or after `t0`).
    #[must_use]
    pub fn at(&self, t: Time) -> f64 {
        let since = if t >= self.t0 {
            (t - self.t0).secs()
        } else {
            -(self.t0 - t).secs()
        };
        self.lsl0 + since / self.pace
    }
}

/// The device stream: what it holds and how its samples come.
#[derive(Debug, Clone, PartialEq)]
pub struct DeviceStream {
    /// The stream's name.
    pub name: String,
    /// Its `source_id`.
    pub source_id: String,
    /// Rate the samples arrive at, Hz.
    pub rate_hz: f64,
    /// Whether samples carry the device's loop tick (on-board rendering).
    pub tick: bool,
    /// `desc/acquisition` and `desc/rendering`, after the channels.
    pub desc: Vec<Node>,
}

/// Channels of the device stream: label, unit, LSL content type.
pub const DEVICE_CHANNELS: [(&str, &str, &str); 5] = [
    ("position_m", "m", "Position"),
    ("velocity_m_s", "m/s", "Velocity"),
    ("force_n", "N", "Force"),
    ("vibration", "normalized", "Vibration"),
    ("tick", "count", "Tick"),
];

/// Device samples held for a lagging worker: this many seconds of them.
const SAMPLE_QUEUE_S: f64 = 2.0;

/// How often the worker takes the queued device samples: each is pushed
/// within about this of being queued, for one wake-up per period instead
/// of one per sample.
const SAMPLE_PERIOD: Duration = Duration::from_micros(500);

/// How long [`Publisher::finish`] lets a connected inlet take the last
/// samples before the outlets close, s.
const LINGER_S: f64 = 0.5;

/// A latency's median and 99th percentile, microseconds.
#[derive(
    Debug,
    Clone,
    Copy,
    PartialEq,
    Default,
    serde::Serialize,
    serde::Deserialize,
    schemars::JsonSchema,
)]
pub struct Quantiles {
    /// Median, us.
    pub p50_us: f64,
    /// 99th percentile, us.
    pub p99_us: f64,
    /// Largest, us.
    pub max_us: f64,
}

/// What a session published, for its log.
#[derive(
    Debug, Clone, PartialEq, Default, serde::Serialize, serde::Deserialize, schemars::JsonSchema,
)]
pub struct LslStats {
    /// The library and its version (`1.18`).
    pub library: String,
    /// Its version.
    pub version: String,
    /// The marker stream's `source_id`.
    pub source_id: String,
    /// Markers pushed.
    pub markers: u64,
    /// Whether the device stream was published (liblsl made its outlet).
    pub device_stream: bool,
    /// Device samples pushed.
    pub samples: u64,
    /// Device samples dropped because the worker lagged.
    pub dropped_samples: u64,
    /// A marker's timestamp to the moment the session handled its event
    /// (negative: a simulated device's virtual time ran ahead of the clock).
    pub marker_event: Quantiles,
    /// A marker's timestamp to its push into liblsl.
    pub marker_push: Quantiles,
    /// A device sample's timestamp to the session reading it.
    pub sample_event: Quantiles,
    /// A device sample's timestamp to its push into liblsl.
    pub sample_push: Quantiles,
}

/// A histogram of latencies, 1 us bins from -10 ms to +100 ms (beyond:
/// the end bins; the largest is kept exactly).
#[derive(Debug, Clone)]
struct Latencies {
    bins: Vec<u32>,
    n: u64,
    max_us: f64,
}

const LATENCY_MIN_US: f64 = -10_000.0;
const LATENCY_BINS: usize = 110_000;

impl Latencies {
    fn new() -> Self {
        Latencies {
            bins: vec![0; LATENCY_BINS],
            n: 0,
            max_us: f64::NEG_INFINITY,
        }
    }

    fn add(&mut self, seconds: f64) {
        let us = seconds * 1e6;
        if !us.is_finite() {
            return;
        }
        #[expect(
            clippy::cast_possible_truncation,
            clippy::cast_sign_loss,
            reason = "clamped to the bins first"
        )]
        let bin = (us - LATENCY_MIN_US).clamp(0.0, (LATENCY_BINS - 1) as f64) as usize;
        self.bins[bin] += 1;
        self.n += 1;
        self.max_us = self.max_us.max(us);
    }

    fn quantile(&self, q: f64) -> f64 {
        if self.n == 0 {
            return 0.0;
        }
        #[expect(
            clippy::cast_possible_truncation,
            clippy::cast_sign_loss,
            reason = "a rank within 1..=n"
        )]
        let rank = ((q * self.n as f64).ceil() as u64).clamp(1, self.n);
        let mut seen = 0_u64;
        for (i, &c) in self.bins.iter().enumerate() {
            seen += u64::from(c);
            if seen >= rank {
                return (LATENCY_MIN_US + i as f64 + 0.5).min(self.max_us);
            }
        }
        self.max_us
    }

    fn summary(&self) -> Quantiles {
        Quantiles {
            p50_us: self.quantile(0.5),
            p99_us: self.quantile(0.99),
            max_us: if self.n == 0 { 0.0 } else { self.max_us },
        }
    }
}

/// One queued sample: the values, its LSL time, when the session read it.
type Sample = ([f32; 5], f64, f64);

/// The device stream as the worker gets it: its outlet, its channels, and
/// the consumer end of its samples' ring.
type DeviceOutlet = (frictionlab_lsl::Outlet, usize, rtrb::Consumer<Sample>);

struct Queue {
    markers: VecDeque<(String, f64, f64)>,
    device: Option<DeviceOutlet>,
    closing: bool,
}

struct Shared {
    queue: Mutex<Queue>,
    ready: Condvar,
    /// Device samples that found the ring full.
    dropped: AtomicU64,
}

impl Shared {
    fn lock(&self) -> MutexGuard<'_, Queue> {
        self.queue.lock().unwrap_or_else(PoisonError::into_inner)
    }

    /// Queues a sample on `ring` (dropped, and counted, when it is full):
    /// wait-free, no lock, no system call. The worker is not woken: it
    /// takes the samples every [`SAMPLE_PERIOD`].
    fn sample(&self, ring: &mut rtrb::Producer<Sample>, sample: Sample) {
        if ring.push(sample).is_err() {
            self.dropped.fetch_add(1, Ordering::Relaxed);
        }
    }
}

/// Queues device samples into a [`Publisher`] from another thread (the
/// ring's one producer, moved there from the publisher).
pub struct SampleTap {
    lsl: Arc<Lsl>,
    shared: Arc<Shared>,
    /// Only the thread that pushes locks it: never contended.
    ring: Mutex<rtrb::Producer<Sample>>,
    lsl0: f64,
}

impl std::fmt::Debug for SampleTap {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SampleTap")
            .field("lsl0", &self.lsl0)
            .finish_non_exhaustive()
    }
}

impl SampleTap {
    /// Queues the sample of the tick at loop time `now_s`.
    pub fn push(&self, now_s: f64, values: [f32; 5]) {
        let mut ring = self.ring.lock().unwrap_or_else(PoisonError::into_inner);
        self.shared.sample(
            &mut ring,
            (values, self.lsl0 + now_s, self.lsl.local_clock()),
        );
    }
}

/// What the worker measured.
struct Pushed {
    markers: u64,
    samples: u64,
    marker_event: Latencies,
    marker_push: Latencies,
    sample_event: Latencies,
    sample_push: Latencies,
}

/// A session's two streams: see the module docs.
pub struct Publisher {
    lsl: Arc<Lsl>,
    shared: Arc<Shared>,
    /// The device samples' ring, until [`Publisher::sample_tap`] hands it
    /// to a port's haptic loop.
    samples: Option<rtrb::Producer<Sample>>,
    /// The marker outlet until [`Publisher::open`] hands it to the worker.
    markers: Option<frictionlab_lsl::Outlet>,
    worker: Option<JoinHandle<Pushed>>,
    source_id: String,
    seq: u64,
    device_open: bool,
    device_failed: bool,
}

impl std::fmt::Debug for Publisher {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Publisher")
            .field("source_id", &self.source_id)
            .finish_non_exhaustive()
    }
}

impl Publisher {
    /// Publishes the marker stream `name` (type `Markers`, one string
    /// channel, irregular rate, `source_id`, `desc` its description). The
    /// device stream is published by [`Publisher::device`]; nothing is
    /// pushed until [`Publisher::open`] (markers and samples queue).
    ///
    /// # Errors
    /// liblsl made no outlet.
    pub fn start(
        lsl: &Arc<Lsl>,
        name: &str,
        source_id: &str,
        desc: &[Node],
    ) -> Result<Self, OutletError> {
        let markers = lsl.outlet(
            &StreamSpec {
                name,
                kind: "Markers",
                channels: 1,
                rate_hz: 0.0,
                format: Format::String,
                source_id,
            },
            desc,
        )?;
        let shared = Arc::new(Shared {
            queue: Mutex::new(Queue {
                markers: VecDeque::new(),
                device: None,
                closing: false,
            }),
            ready: Condvar::new(),
            dropped: AtomicU64::new(0),
        });
        Ok(Publisher {
            lsl: lsl.clone(),
            shared,
            samples: None,
            markers: Some(markers),
            worker: None,
            source_id: source_id.to_owned(),
            seq: 0,
            device_open: false,
            device_failed: false,
        })
    }

    /// Waits, at most `wait_s` in all, for an inlet on the marker stream
    /// and then on the device stream (if published), and starts pushing
    /// (the worker): what was queued goes first. Whether each stream had a
    /// reader. Once open, a second call does nothing.
    ///
    /// # Errors
    /// The worker thread could not start.
    pub fn open(&mut self, wait_s: f64) -> Result<(bool, bool), OutletError> {
        let Some(markers) = self.markers.take() else {
            return Ok((true, true));
        };
        let start = self.lsl.local_clock();
        let left = |lsl: &Lsl| (wait_s - (lsl.local_clock() - start)).max(0.0);
        let marker_reader = wait_s > 0.0 && markers.wait_for_consumers(wait_s);
        // Out of the queue while waited on: a port's haptic loop queues
        // its samples meanwhile, and must not wait for the lock.
        let device = self.shared.lock().device.take();
        let device_reader = device
            .as_ref()
            .is_some_and(|(o, ..)| left(&self.lsl) > 0.0 && o.wait_for_consumers(left(&self.lsl)));
        if device.is_some() {
            self.shared.lock().device = device;
        }
        let worker = {
            let (lsl, shared) = (self.lsl.clone(), self.shared.clone());
            std::thread::Builder::new()
                .name("lsl-outlets".into())
                .spawn(move || work(&lsl, &shared, &markers))
                .map_err(|_| OutletError::Create("worker".into()))?
        };
        self.worker = Some(worker);
        self.shared.ready.notify_one();
        Ok((marker_reader, device_reader))
    }

    /// Whether [`Publisher::open`] has started pushing.
    #[must_use]
    pub fn is_open(&self) -> bool {
        self.markers.is_none()
    }

    /// LSL's clock now, s.
    #[must_use]
    pub fn now(&self) -> f64 {
        self.lsl.local_clock()
    }

    /// Queues a marker stamped `at` (LSL time): `fields` with `seq` (0, 1,
    /// ... in this run) added first.
    pub fn marker(&mut self, at: f64, fields: serde_json::Map<String, serde_json::Value>) {
        let mut object = serde_json::Map::with_capacity(fields.len() + 1);
        object.insert("seq".into(), self.seq.into());
        object.extend(fields);
        self.seq += 1;
        let text = serde_json::Value::Object(object).to_string();
        let handled = self.now();
        let mut q = self.shared.lock();
        let idle = q.markers.is_empty();
        q.markers.push_back((text, at, handled));
        drop(q);
        self.wake(idle);
        // The worker, just woken, is often queued on this thread's CPU,
        // where it would wait out whatever the session does next (a
        // trial's files written and synced: milliseconds). Let it push.
        std::thread::yield_now();
    }

    /// Whether the device stream is open.
    #[must_use]
    pub fn has_device(&self) -> bool {
        self.device_open
    }

    /// Publishes the device stream (on this thread: creating an outlet
    /// takes liblsl some milliseconds, which the worker must not spend
    /// while markers wait), then hands it to the worker. Whether it could.
    pub fn device(&mut self, stream: &DeviceStream) -> bool {
        self.device_open = true;
        let Some(outlet) = open_device(&self.lsl, stream) else {
            self.device_failed = true;
            return false;
        };
        #[expect(
            clippy::cast_possible_truncation,
            clippy::cast_sign_loss,
            reason = "a positive, modest count"
        )]
        let capacity = (stream.rate_hz * SAMPLE_QUEUE_S).clamp(64.0, 1e6) as usize;
        let (producer, consumer) = rtrb::RingBuffer::new(capacity);
        self.samples = Some(producer);
        self.shared.lock().device = Some((outlet.0, outlet.1, consumer));
        self.shared.ready.notify_one();
        true
    }

    /// A handle that queues device samples from another thread (a port's
    /// haptic loop, which stamps each tick where it reads it): a tick at
    /// loop time `now_s` is LSL time `lsl0 + now_s`. The samples' ring
    /// moves to it: [`Publisher::sample`] queues nothing after this. None
    /// without a device stream (or when a tap has it already).
    #[must_use]
    pub fn sample_tap(&mut self, lsl0: f64) -> Option<SampleTap> {
        Some(SampleTap {
            lsl: self.lsl.clone(),
            shared: self.shared.clone(),
            ring: Mutex::new(self.samples.take()?),
            lsl0,
        })
    }

    /// Queues a device sample stamped `at` (LSL time): position m, velocity
    /// m/s, force N, vibration, and the device's tick (on board). When the
    /// ring is full the sample is dropped (counted).
    pub fn sample(&mut self, at: f64, values: [f32; 5]) {
        let handled = self.now();
        if let Some(ring) = &mut self.samples {
            self.shared.sample(ring, (values, at, handled));
        }
    }

    /// Wakes the worker if the queue was empty (see [`Shared::sample`]).
    fn wake(&self, idle: bool) {
        if idle {
            self.shared.ready.notify_one();
        }
    }

    /// Pushes everything queued (opening without a wait if not yet
    /// open), gives a connected inlet [`LINGER_S`] to take it, closes both
    /// streams and says what was published.
    #[must_use]
    pub fn finish(mut self) -> LslStats {
        let _ = self.open(0.0);
        self.shared.lock().closing = true;
        self.shared.ready.notify_one();
        let pushed = self.worker.take().and_then(|w| w.join().ok());
        let dropped = self.shared.dropped.load(Ordering::Relaxed);
        let version = self.lsl.version();
        let Some(p) = pushed else {
            return LslStats::default();
        };
        LslStats {
            library: self.lsl.path().to_owned(),
            version: format!("{}.{}", version / 100, version % 100),
            source_id: self.source_id.clone(),
            markers: p.markers,
            device_stream: self.device_open && !self.device_failed,
            samples: p.samples,
            dropped_samples: dropped,
            marker_event: p.marker_event.summary(),
            marker_push: p.marker_push.summary(),
            sample_event: p.sample_event.summary(),
            sample_push: p.sample_push.summary(),
        }
    }
}

impl Drop for Publisher {
    fn drop(&mut self) {
        if let Some(worker) = self.worker.take() {
            self.shared.lock().closing = true;
            self.shared.ready.notify_one();
            let _ = worker.join();
        }
    }
}

/// The worker: takes what is queued, pushes it, until closed and empty.
fn work(lsl: &Arc<Lsl>, shared: &Shared, markers: &frictionlab_lsl::Outlet) -> Pushed {
    let mut out = Pushed {
        markers: 0,
        samples: 0,
        marker_event: Latencies::new(),
        marker_push: Latencies::new(),
        sample_event: Latencies::new(),
        sample_push: Latencies::new(),
    };
    let mut device: Option<DeviceOutlet> = None;
    let mut marks = VecDeque::new();
    loop {
        let (open, closing) = {
            let mut q = shared.lock();
            // Markers, a new stream and the end wake the worker; samples
            // are taken every period while the device stream is open.
            while q.markers.is_empty() && q.device.is_none() && !q.closing {
                let Some((.., ring)) = &device else {
                    q = shared.ready.wait(q).unwrap_or_else(PoisonError::into_inner);
                    continue;
                };
                if !ring.is_empty() {
                    break;
                }
                q = shared
                    .ready
                    .wait_timeout(q, SAMPLE_PERIOD)
                    .unwrap_or_else(PoisonError::into_inner)
                    .0;
            }
            std::mem::swap(&mut marks, &mut q.markers);
            (q.device.take(), q.closing)
        };
        if open.is_some() {
            device = open;
        }
        for (text, at, handled) in marks.drain(..) {
            if markers.push_str(&text, at) {
                out.markers += 1;
            }
            out.marker_event.add(handled - at);
            out.marker_push.add(lsl.local_clock() - at);
        }
        if let Some((outlet, channels, ring)) = &mut device {
            while let Ok((values, at, handled)) = ring.pop() {
                if outlet.push_f32(&values[..*channels], at) {
                    out.samples += 1;
                }
                out.sample_event.add(handled - at);
                out.sample_push.add(lsl.local_clock() - at);
            }
        }
        if closing {
            break;
        }
    }
    let listened =
        markers.has_consumers() || device.as_ref().is_some_and(|(o, ..)| o.has_consumers());
    if listened {
        std::thread::sleep(Duration::from_secs_f64(LINGER_S));
    }
    out
}

/// Publishes the device stream: its channels described as LSL's meta-data
/// conventions say (`desc/channels/channel/{label,unit,type}`).
fn open_device(lsl: &Arc<Lsl>, stream: &DeviceStream) -> Option<(frictionlab_lsl::Outlet, usize)> {
    let channels = if stream.tick { 5 } else { 4 };
    let described: Vec<Node> = DEVICE_CHANNELS[..channels]
        .iter()
        .map(|(label, unit, kind)| {
            Node::parent(
                "channel",
                vec![
                    Node::value("label", *label),
                    Node::value("unit", *unit),
                    Node::value("type", *kind),
                ],
            )
        })
        .collect();
    let mut desc = vec![Node::parent("channels", described)];
    desc.extend(stream.desc.iter().cloned());
    let outlet = lsl
        .outlet(
            &StreamSpec {
                name: &stream.name,
                kind: "Haptics",
                channels,
                rate_hz: stream.rate_hz,
                format: Format::Float32,
                source_id: &stream.source_id,
            },
            &desc,
        )
        .ok()?;
    Some((outlet, channels))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn latency_quantiles_come_from_the_histogram_within_a_microsecond() {
        let mut l = Latencies::new();
        for i in 0..1000 {
            l.add(f64::from(i) * 1e-6);
        }
        let q = l.summary();
        assert!((q.p50_us - 499.5).abs() <= 1.0, "{q:?}");
        assert!((q.p99_us - 989.5).abs() <= 1.0, "{q:?}");
        assert!((q.max_us - 999.0).abs() < 1e-6, "{q:?}");
        l.add(-0.02);
        assert!(l.quantile(0.0).is_finite());
    }

    #[test]
    fn a_clock_maps_session_time_at_its_pace() {
        let c = Clock {
            t0: Time::from_whole_secs(10),
            lsl0: 1000.0,
            pace: 2.0,
        };
        assert_eq!(c.at(Time::from_whole_secs(10)), 1000.0);
        assert_eq!(c.at(Time::from_whole_secs(12)), 1001.0);
        assert_eq!(c.at(Time::from_whole_secs(8)), 999.0);
    }
}
