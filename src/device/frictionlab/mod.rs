//! frictionlab's own device: a board speaking our serial wire protocol
//! ([`wire`], `docs/wire-protocol.md`), its host side ([`link`], sans-IO),
//! the serial port that carries it ([`transport`]), the emulator that
//! speaks it ([`emulator`]) and the firmware on QEMU ([`qemu`]).
//!
//! [`Port`] is the backend the haptic loop drives: a one-axis device that
//! takes a force per tick (wire protocol v1 and v2), or renders a model on
//! board and streams its ticks as telemetry (v2).
//!
//! # On board (wire protocol v2)
//! When the device states in its handshake that it renders a model on
//! board at least at the model's rate, the loop does not step that model:
//! [`Port`] uploads it and selects it (`Upload`, `Select`; `Clear` for
//! nothing), resending until the device's telemetry shows it in effect,
//! and after a reconnect. Its ticks to the session are then the device's
//! `Telemetry`, one per device tick, timed by the device's tick count, and
//! it sends only `Heartbeat`s to feed the device's watchdog. A model the
//! device does not render (or a version 1 device) is rendered by the loop,
//! the device told to `Clear` its own.

pub mod emulator;
pub mod link;
pub mod qemu;
pub mod wire;

use std::path::Path;

use self::link::{Incoming, Link, Telemetry};
use self::wire::{MAX_FRAME, Message, encode, status};
use super::backend::{
    Backend, Capabilities, LinkState, LinkStats, Mode, Reading, Tick, UNKNOWN_RENDER, Vector,
};
use crate::device::transport::Transport;
use crate::friction::{Float, ModelParams};
use crate::hand::HandDrive;

/// The device kind, as listed in [`super::KINDS`]: a bare path is one.
pub const KIND: super::Kind = super::Kind {
    name: "frictionlab",
    about: "frictionlab's own board (or `frictionlab device-emulator`) on a serial port",
    target: "PATH",
    bare: true,
    check,
    check_settings: |_| Ok(()),
    open,
    find,
};

fn check(target: &str) -> Result<(), String> {
    super::check_port(Path::new(target))
}

fn open(target: &str, _settings: &super::Settings) -> Result<Box<dyn Backend>, String> {
    check(target)?;
    Ok(Box::new(Port::new(Path::new(target))))
}

fn find() -> Vec<super::Found> {
    super::list_ports()
        .unwrap_or_default()
        .into_iter()
        .map(|p| super::Found {
            address: p.path,
            what: p.kind,
        })
        .collect()
}

/// How long the loop waits for telemetry to show a selected model before it
/// uploads it again, s; each further resend of the same render waits twice
/// as long, up to 8 times this (a slow link is not flooded with copies).
const RESEND_AFTER_S: f64 = 0.050;

/// How far a telemetry's time on the loop's clock (its device tick from an
/// anchor) may be from the time the host read it before the anchor moves,
/// s: ahead, it is anchored afresh; behind, it follows at [`DRIFT_SLEW`].
const ANCHOR_TOLERANCE_S: f64 = 0.1;

/// The most the anchor moves forward per tick when telemetry falls behind
/// the host's clock, as a share of the device's period: 1000 ppm, ten
/// times a crystal's drift, so a slow clock is followed, and a burst of
/// late ticks keeps its spacing.
const DRIFT_SLEW: f64 = 1e-3;

/// How many labels the loop remembers: renders sent while the device has
/// not yet caught up (a lagging link) keep their meaning.
const LABELS: usize = 16;

/// Frames that fail their check, with no handshake, before the port is
/// said to be another device's.
const GARBAGE_FRAMES: u64 = 20;

/// Telemetry kept per loop tick.
const TELEMETRY_PER_TICK: usize = 64;

/// A frictionlab board on a serial port, reopened when it goes away.
#[expect(
    clippy::struct_excessive_bools,
    reason = "the device's flags and the link's, each its own"
)]
pub struct Port {
    transport: Transport,
    link: Link,
    bytes: [u8; 1024],
    frame: [u8; MAX_FRAME],
    x_m: f64,
    /// The time of the last read, s.
    now_s: f64,
    button: bool,
    watchdog: bool,
    was_connected: bool,
    /// Something was sent this tick (no heartbeat needed).
    sent: bool,
    telemetry: Vec<Telemetry>,
    board: OnBoardState,
}

impl std::fmt::Debug for Port {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Port")
            .field("transport", &self.transport)
            .finish_non_exhaustive()
    }
}

impl Port {
    /// The board at `path` (opened on the first tick, reopened after).
    #[must_use]
    pub fn new(path: &Path) -> Self {
        Port {
            transport: Transport::new(path),
            link: Link::new(),
            bytes: [0; 1024],
            frame: [0; MAX_FRAME],
            x_m: 0.0,
            now_s: 0.0,
            button: false,
            watchdog: false,
            was_connected: false,
            sent: false,
            telemetry: Vec::with_capacity(TELEMETRY_PER_TICK),
            board: OnBoardState::new(),
        }
    }

    fn write(transport: &mut Transport, frame: &mut [u8; MAX_FRAME], m: &Message) {
        if let Ok(len) = encode(m, frame) {
            transport.write(&frame[..len]);
        }
    }

    fn mode(&self) -> Mode {
        let on_board = self.link.on_board();
        Mode::OnBoard {
            rate_hz: on_board.map_or(0, |o| o.loop_rate_hz),
            float: if on_board.is_some_and(|o| o.float_bytes == 4) {
                Float::F32
            } else {
                Float::F64
            },
            #[expect(clippy::cast_possible_truncation, reason = "the wire's f32")]
            limit_n: self
                .link
                .capabilities()
                .map_or(0.0, |c| c.max_force_n as f32),
        }
    }
}

impl Backend for Port {
    fn capabilities(&self) -> Capabilities {
        Capabilities {
            axes: 1,
            vertical_axis: None,
            force_limit_n: self
                .link
                .capabilities()
                .map_or(crate::device::sim::Apparatus::default().max_force_n, |c| {
                    c.max_force_n
                }),
            // The wire states no travel: the board is built as seed 002's
            // apparatus (docs/hardware.md), as its emulator and QEMU's
            // firmware simulate it.
            travel_m: crate::device::sim::Apparatus::default().travel_m(),
            max_rate_hz: f64::INFINITY,
            on_board: self.link.on_board().is_some(),
        }
    }

    fn read(&mut self, now_s: f64) -> Reading {
        self.sent = false;
        self.now_s = now_s;
        let n = self.transport.read(&mut self.bytes);
        self.telemetry.clear();
        let (x, button, watchdog, telemetry) = (
            &mut self.x_m,
            &mut self.button,
            &mut self.watchdog,
            &mut self.telemetry,
        );
        self.link
            .receive(now_s, &self.bytes[..n], |incoming| match incoming {
                Incoming::Sample(s) => {
                    *x = s.x_m;
                    *button = s.button;
                    *watchdog = s.status & status::WATCHDOG != 0;
                }
                Incoming::Telemetry(t) => {
                    *x = t.x_m;
                    *button = t.flags & status::BUTTON != 0;
                    if telemetry.len() < telemetry.capacity() {
                        telemetry.push(t);
                    }
                }
            });
        let link = self.link.state(now_s);
        let connected = link == LinkState::Connected;
        let on_board = self.link.on_board();
        if connected && !self.was_connected {
            // A new connection: the device has nothing of ours.
            self.board.disconnected();
            if on_board.is_some() {
                Self::write(
                    &mut self.transport,
                    &mut self.frame,
                    &Message::SetTelemetry { every: 1 },
                );
                self.board.rendering =
                    OnBoardState::renders(on_board, self.board.wanted.1.as_ref());
                if self.board.rendering {
                    let wanted = self.board.wanted.1.clone();
                    let (t, f) = (&mut self.transport, &mut self.frame);
                    self.board
                        .send(now_s, wanted.as_ref(), |m| Self::write(t, f, &m));
                }
                self.sent = true;
            }
        }
        self.was_connected = connected;
        let stats = self.link.stats();
        Reading {
            link,
            position_m: [self.x_m, 0.0, 0.0],
            button: self.button,
            watchdog: self.watchdog,
            problem: (self.link.capabilities().is_none() && stats.crc_errors + stats.resyncs() > GARBAGE_FRAMES)
                .then_some("answers with bytes that are not frictionlab's wire protocol (another device on this port?)"),
        }
    }

    fn send_force(&mut self, now_s: f64, force_n: Vector, vibration: f64) {
        if let Some(m) = self.link.transmit(now_s, force_n[0], vibration) {
            Self::write(&mut self.transport, &mut self.frame, &m);
        }
    }

    fn close(&mut self) {
        // Zero the force on the way out.
        if let Some(m) = self.link.transmit(self.now_s, 0.0, 0.0) {
            Self::write(&mut self.transport, &mut self.frame, &m);
        }
    }

    fn drive_hand(&mut self, drive: &HandDrive) {
        Self::write(
            &mut self.transport,
            &mut self.frame,
            &wire::hand_drive(drive),
        );
    }

    fn on_board(&mut self) -> Option<&mut dyn super::backend::OnBoard> {
        Some(self)
    }

    fn stats(&self) -> LinkStats {
        let stats = self.link.stats();
        let board = (self.board.ticks > 0).then_some(());
        LinkStats {
            crc_errors: stats.crc_errors,
            resyncs: stats.resyncs(),
            on_board_ticks: board.map(|()| self.board.ticks),
            telemetry_gaps: board.map(|()| self.board.gaps),
            device_longest_loop_us: board.map(|()| self.link.device_loop().longest_loop_us),
            device_missed_ticks: board.map(|()| self.link.device_loop().missed_ticks),
        }
    }
}

impl super::backend::OnBoard for Port {
    fn select(&mut self, now_s: f64, render: u32, model: Option<&ModelParams>) -> bool {
        let on_board = self.link.on_board();
        self.board.rendering = OnBoardState::renders(on_board, model);
        self.board.wanted = (render, model.cloned());
        if self.link.state(now_s) == LinkState::Connected && on_board.is_some() {
            // On board: this model; host-rendered: nothing of the device's
            // own.
            let rendering = self.board.rendering;
            let (t, f) = (&mut self.transport, &mut self.frame);
            self.board.send(now_s, model.filter(|_| rendering), |m| {
                Self::write(t, f, &m);
            });
            self.sent = true;
        }
        self.board.rendering
    }

    fn ticks(&mut self, now_s: f64, reading: &Reading, emit: &mut dyn FnMut(Tick)) -> bool {
        let on_board = self.link.on_board();
        if !(self.board.rendering && on_board.is_some()) {
            // The loop renders; the telemetry still keeps the device's
            // render and clock known.
            let dt = 1.0 / f64::from(on_board.map_or(1, |o| o.loop_rate_hz.max(1)));
            for t in &self.telemetry {
                self.board.started_afresh(t);
                self.board.observe(t, now_s, dt);
            }
            return false;
        }
        // The device renders: its telemetry are the ticks.
        let mode = self.mode();
        let device_limit_n = Backend::capabilities(self).force_limit_n;
        let connected = reading.link == LinkState::Connected;
        let device_dt = 1.0 / f64::from(on_board.map_or(1, |o| o.loop_rate_hz.max(1)));
        for t in &self.telemetry {
            // A device that started afresh is one lost and back: the
            // session's trial ends before this tick (its stream cannot
            // show the restart).
            let link = if self.board.started_afresh(t) {
                LinkState::Lost
            } else {
                reading.link
            };
            let at = self.board.observe(t, now_s, device_dt);
            emit(Tick {
                button: t.flags & status::BUTTON != 0,
                link,
                render: self.board.device_render,
                selected: t.flags & status::SELECTED != 0,
                watchdog: t.flags & status::WATCHDOG != 0,
                device_tick: Some(t.tick),
                mode,
                device_limit_n,
                ..Tick::on_axis(at, t.x_m, t.v_m_s, t.force_n, t.vibration)
            });
        }
        // Resend only after this tick's telemetry is seen: after a stall it
        // may already show the select in effect.
        if connected
            && self
                .board
                .sent_s
                .is_some_and(|t| now_s - t >= self.board.resend_after())
        {
            let wanted = self.board.wanted.1.clone();
            let (t, f) = (&mut self.transport, &mut self.frame);
            self.board
                .send(now_s, wanted.as_ref(), |m| Self::write(t, f, &m));
            self.sent = true;
        }
        if let Some(m) = self.link.heartbeat(now_s, self.sent) {
            Self::write(&mut self.transport, &mut self.frame, &m);
        }
        if !connected {
            emit(Tick {
                link: reading.link,
                mode,
                device_limit_n,
                ..Tick::on_axis(
                    now_s.max(self.board.last_now),
                    reading.position_m[0],
                    0.0,
                    0.0,
                    0.0,
                )
            });
        }
        true
    }
}

/// What the loop knows of the device's on-board rendering.
struct OnBoardState {
    /// The session's render to render, and whether the device renders it.
    wanted: (u32, Option<ModelParams>),
    rendering: bool,
    /// Labels sent lately and the renders they stand for, newest first
    /// (a resend is not a new label).
    labels: [(u8, u32); LABELS],
    /// Resends of the wanted render so far.
    resends: u32,
    /// The render whose telemetry shows in effect on the device.
    device_render: u32,
    /// When the wanted render was last sent, if not yet in effect.
    sent_s: Option<f64>,
    /// Device tick and loop time of the first telemetry since connecting,
    /// and the last tick seen.
    anchor: Option<(u32, f64)>,
    last_tick: Option<u32>,
    /// The tick and label of the last telemetry since connecting.
    last_label: Option<(u32, u8)>,
    last_now: f64,
    ticks: u64,
    gaps: u64,
}

impl OnBoardState {
    fn new() -> Self {
        OnBoardState {
            wanted: (0, None),
            rendering: false,
            labels: [(0, UNKNOWN_RENDER); LABELS],
            resends: 0,
            device_render: UNKNOWN_RENDER,
            sent_s: None,
            anchor: None,
            last_tick: None,
            last_label: None,
            last_now: 0.0,
            ticks: 0,
            gaps: 0,
        }
    }

    /// Whether the device renders `model` on board.
    fn renders(on_board: Option<link::OnBoard>, model: Option<&ModelParams>) -> bool {
        on_board.is_some_and(|o| {
            model.is_none_or(|m| {
                let kind = m.kind();
                kind > 0
                    && o.models & (1 << (kind - 1)) != 0
                    && f64::from(o.loop_rate_hz) >= m.loop_rate_hz()
            })
        })
    }

    /// Sends the wanted render to the device (upload and select, or clear)
    /// through `send`.
    #[expect(clippy::cast_possible_truncation, reason = "labels wrap by design")]
    fn send(&mut self, now_s: f64, model: Option<&ModelParams>, mut send: impl FnMut(Message)) {
        let render = self.wanted.0;
        let label = render as u8;
        if self.labels[0] == (label, render) {
            self.resends += 1;
        } else {
            self.labels.rotate_right(1);
            self.labels[0] = (label, render);
            self.resends = 0;
        }
        match model {
            Some(m) => frictionlab_core::onboard::upload(m, label, &mut send),
            None => send(Message::Clear { render: label }),
        }
        self.sent_s = Some(now_s);
    }

    /// Whether `t` shows the device started afresh since the telemetry
    /// of the tick before it: its render changed without a select. Only a
    /// `Hello` does that, and one comes after the link is up when the link
    /// lags by more than [`link::HELLO_EVERY_S`]: the host connects on the
    /// answer to an earlier `Hello` while later ones are still on their
    /// way. Across lost telemetry it cannot tell (the lost frame may have
    /// been the select's), and a stream is not replayed past a gap anyway.
    fn started_afresh(&mut self, t: &Telemetry) -> bool {
        let last = self.last_label.replace((t.tick, t.render));
        last.is_some_and(|(tick, label)| {
            t.tick == tick.wrapping_add(1) && label != t.render && t.flags & status::SELECTED == 0
        })
    }

    /// Notes one telemetry: the render in effect, gaps, and its time on the
    /// loop's clock (device ticks from an anchor, never going back).
    fn observe(&mut self, t: &Telemetry, now_s: f64, dt: f64) -> f64 {
        if let Some(&(_, render)) = self.labels.iter().find(|(l, _)| *l == t.render) {
            self.device_render = render;
            if render == self.wanted.0 {
                self.sent_s = None;
            }
        } else {
            self.device_render = UNKNOWN_RENDER;
        }
        if self.rendering && self.device_render != self.wanted.0 && self.sent_s.is_none() {
            // The device no longer renders what it had in effect (it
            // restarted, a late Hello over a lagging link): send it again.
            self.sent_s = Some(now_s);
        }
        if let Some(last) = self.last_tick {
            self.gaps += u64::from(t.tick.wrapping_sub(last).saturating_sub(1));
        }
        self.last_tick = Some(t.tick);
        self.ticks += 1;
        let (tick0, t0) = *self.anchor.get_or_insert((t.tick, now_s));
        let mut at = t0 + f64::from(t.tick.wrapping_sub(tick0)) * dt;
        if at > now_s + ANCHOR_TOLERANCE_S {
            // Ahead of the clock that read it: the device restarted (its
            // count went back), or the anchor was a tick that came late.
            // Anchor afresh.
            self.anchor = Some((t.tick, now_s));
            at = now_s;
        } else if at < now_s - ANCHOR_TOLERANCE_S {
            // Behind: the telemetry was held up on its way (a loaded
            // host's tty work), or the device's clock is slower than the
            // host's. A tick happened when its count says: the anchor
            // follows the host's clock by at most DRIFT_SLEW of a period
            // per tick, so ticks read in a burst keep their own times, one
            // period apart. (Anchored afresh on the host's clock, a burst
            // ran ahead of it and was anchored back: 419 ticks of one
            // stream had one time, issue 63.)
            let slew = (now_s - ANCHOR_TOLERANCE_S - at).min(DRIFT_SLEW * dt);
            self.anchor = Some((tick0, t0 + slew));
            at += slew;
        }
        at = at.max(self.last_now);
        self.last_now = at;
        at
    }

    /// How long after the last send of the wanted render to resend it, s.
    fn resend_after(&self) -> f64 {
        RESEND_AFTER_S * f64::from(1_u32 << self.resends.min(3))
    }

    /// Forgets the device's state (a new connection).
    fn disconnected(&mut self) {
        self.labels = [(0, UNKNOWN_RENDER); LABELS];
        self.device_render = UNKNOWN_RENDER;
        self.anchor = None;
        self.last_tick = None;
        self.last_label = None;
        self.sent_s = None;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn telemetry(tick: u32, render: u8) -> Telemetry {
        Telemetry {
            tick,
            x_m: 0.0,
            v_m_s: 0.0,
            force_n: 0.0,
            vibration: 0.0,
            render,
            flags: 0,
        }
    }

    /// Over a link that lags (QEMU's UART on a loaded machine lagged
    /// 200 ms), the loop resends a render the device has not yet shown in
    /// effect: ever less often, and without forgetting what the labels
    /// sent before it stand for.
    #[test]
    fn resends_back_off_and_keep_the_labels_sent_before() {
        let mut board = OnBoardState::new();
        let model = ModelParams::default_for("karnopp").unwrap();
        let mut sent = 0;
        board.wanted = (18, Some(model.clone()));
        board.send(0.0, Some(&model), |_| sent += 1);
        board.wanted = (19, None);
        board.send(0.01, None, |_| sent += 1);
        let mut waits = Vec::new();
        for k in 0..6 {
            waits.push(board.resend_after());
            board.send(0.1 * f64::from(k), None, |_| sent += 1);
        }
        assert_eq!(waits, [0.05, 0.1, 0.2, 0.4, 0.4, 0.4]);
        assert!(sent > 7);
        // The device still shows label 18, then takes 19.
        board.observe(&telemetry(1, 18), 0.6, 0.0002);
        assert_eq!(board.device_render, 18, "label 18 still means render 18");
        assert!(board.sent_s.is_some(), "19 not in effect yet");
        board.observe(&telemetry(2, 19), 0.6, 0.0002);
        assert_eq!((board.device_render, board.sent_s), (19, None));
        // A device that restarts (its telemetry shows none of ours) gets
        // the render in effect sent again.
        board.rendering = true;
        board.observe(&telemetry(3, 0), 0.65, 0.0002);
        assert_eq!(board.device_render, UNKNOWN_RENDER);
        assert_eq!(board.sent_s, Some(0.65), "19 is due again");
        // A new render starts the backoff afresh.
        board.wanted = (20, None);
        board.send(0.7, None, |_| {});
        assert_eq!(board.resend_after(), 0.05);
    }

    /// Ticks read at once after their telemetry was held up keep their own
    /// times, one period apart; a slow device clock is followed within
    /// the tolerance; a device whose count went back is anchored afresh.
    #[test]
    fn ticks_read_late_keep_their_own_times_in_order() {
        let mut board = OnBoardState::new();
        let dt = 0.0002;
        let mut times = Vec::new();
        for k in 0..1000_u32 {
            times.push(board.observe(&telemetry(k, 0), f64::from(k) * dt, dt));
        }
        // 0.5 s held up, then the 2500 ticks made meanwhile read at once.
        let read_at = 0.2 + 0.5;
        for k in 1000..3500_u32 {
            times.push(board.observe(&telemetry(k, 0), read_at, dt));
        }
        assert!(
            times.windows(2).all(|w| w[1] > w[0]),
            "times increase with every tick"
        );
        let spacing = times[3499] - times[1000];
        assert!(
            (spacing - 2499.0 * dt).abs() <= 2499.0 * DRIFT_SLEW * dt + 1e-12,
            "{spacing}"
        );
        assert!(times[1000] < 0.2 + 0.01, "tick 1000 at {}", times[1000]);
        // A device clock 500 ppm slow is followed: never more than the
        // tolerance behind.
        let mut board = OnBoardState::new();
        let mut last = 0.0;
        for k in 0..200_000_u32 {
            let now = f64::from(k) * dt * 1.0005;
            last = board.observe(&telemetry(k, 0), now, dt);
            assert!(
                last >= now - ANCHOR_TOLERANCE_S - 1e-9,
                "tick {k}: {last} at {now}"
            );
        }
        // Restarted: its count went back; anchored on the host's clock,
        // never before the last time.
        let now = f64::from(200_000_u32) * dt * 1.0005;
        let at = board.observe(&telemetry(3, 0), now, dt);
        assert!(at >= last && at <= now, "{at}");
    }

    /// A render that changed without a select from one tick to the next
    /// is the device started afresh (a `Hello` that arrived late), told
    /// once; a select's change, a change across lost telemetry, and the
    /// first telemetry of a connection are not.
    #[test]
    fn a_render_changed_without_a_select_is_the_device_started_afresh() {
        let mut board = OnBoardState::new();
        let selected = |tick, render| Telemetry {
            flags: status::SELECTED,
            ..telemetry(tick, render)
        };
        assert!(!board.started_afresh(&telemetry(1, 0)), "the first");
        assert!(!board.started_afresh(&selected(2, 5)));
        assert!(!board.started_afresh(&telemetry(3, 5)));
        assert!(board.started_afresh(&telemetry(4, 0)), "5 to 0 unselected");
        assert!(!board.started_afresh(&telemetry(5, 0)));
        assert!(!board.started_afresh(&selected(6, 6)));
        assert!(!board.started_afresh(&telemetry(8, 0)), "across a gap");
        board.disconnected();
        assert!(!board.started_afresh(&telemetry(9, 7)), "a new connection");
    }
}
