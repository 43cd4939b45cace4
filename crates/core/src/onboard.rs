//! A device that renders friction itself (wire protocol v2): what firmware
//! and the emulator's on-board mode run each loop tick.
//!
//! [`BoardLoop`] is sans-IO. The shell hands it each valid message from the
//! host ([`BoardLoop::receive`]) and, each loop tick, what the device sensed
//! ([`BoardLoop::tick`]); it returns the force and vibration to output and the
//! `Telemetry` to send. It keeps:
//! - the staged upload, checked against the `Select`'s CRC before a model
//!   is built (a lost or corrupted part is refused, never rendered);
//! - the [`Renderer`] (50 ms crossfade, force clamp), a new model starting
//!   at the tick after its `Select`, at that tick's position;
//! - selects in the order they came, one a tick (each tick's telemetry
//!   shows the render it put in effect), up to [`PENDING_SELECTS`] waiting;
//! - resends taken for what they are: a `Select` of the model in effect
//!   under its label (or a `Clear` of the nothing in effect) changes
//!   nothing, so a host resending over a slow link restarts no model;
//! - the force-only path: with no on-board model, the last `Command`'s
//!   force (v1 behaviour);
//! - the 20 ms watchdog, in both modes: no valid frame from the host for
//!   [`WATCHDOG_S`] zeroes the force;
//! - telemetry decimation, and the loop statistics the shell measures.

use crate::friction::{ForceLimit, Input, ModelParams, Phase};
use crate::real::Real;
use crate::render::{Flat, MAX_VALUES, RAMP_S, Renderer};
use crate::wire::{Message, UPLOAD_VALUES, status, values_check};

/// No valid frame from the host for this long zeroes the force, s.
pub const WATCHDOG_S: f64 = 0.020;

/// Every model kind (bits 0..8 of `OnBoard.models`).
pub const ALL_MODELS: u16 = 0xff;

/// What to output this tick.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Drive<T> {
    /// Force on the hand, N.
    pub force_n: T,
    /// Vibrotactile drive.
    pub vibration: T,
    /// Telemetry to send, if due.
    pub telemetry: Option<Message>,
}

/// Selects that can wait for their tick; a further one drops the oldest
/// (the host resends what it does not see in effect).
pub const PENDING_SELECTS: usize = 4;

/// A select waiting for its tick.
#[derive(Debug, Clone, Copy)]
enum Pending {
    Model { render: u8, flat: Flat },
    Clear { render: u8 },
    Refused,
}

/// The on-board renderer of a device: see the module docs.
#[derive(Debug, Clone)]
#[expect(
    clippy::struct_excessive_bools,
    reason = "independent flags of the device's state"
)]
pub struct BoardLoop<T: Real> {
    renderer: Renderer<T>,
    has_model: bool,
    staged_kind: u8,
    staged: [f64; MAX_VALUES],
    staged_mask: u32,
    /// Selects waiting: a ring of `pending_len` from `pending_head`.
    pending: [Pending; PENDING_SELECTS],
    pending_head: usize,
    pending_len: usize,
    /// The model in effect (None: nothing, or a refused select).
    in_effect: Option<Flat>,
    render: u8,
    refused: bool,
    command: T,
    clamped: bool,
    /// Telemetry goes out once per this many ticks (0: none).
    telemetry_period_ticks: u16,
    countdown: u16,
    tick: u32,
    rate_hz: u16,
    dt: T,
    quiet_ticks: u32,
    watchdog_ticks: u32,
    /// A message from the host has arrived since start.
    host_heard: bool,
    longest_loop_us: u32,
    missed_ticks: u32,
}

impl<T: Real> BoardLoop<T> {
    /// A board looping at `rate_hz`, its force limited to `limit`,
    /// rendering nothing, sending telemetry every tick.
    #[must_use]
    pub fn new(rate_hz: u16, limit: ForceLimit<T>) -> Self {
        let rate = f64::from(rate_hz.max(1));
        BoardLoop {
            renderer: Renderer::new(limit, T::of(RAMP_S)),
            has_model: false,
            staged_kind: 0,
            staged: [0.0; MAX_VALUES],
            staged_mask: 0,
            pending: [Pending::Refused; PENDING_SELECTS],
            pending_head: 0,
            pending_len: 0,
            in_effect: None,
            render: 0,
            refused: false,
            command: T::ZERO,
            clamped: false,
            telemetry_period_ticks: 1,
            countdown: 0,
            tick: 0,
            rate_hz,
            dt: T::of(1.0 / rate),
            quiet_ticks: u32::MAX,
            #[expect(
                clippy::cast_possible_truncation,
                clippy::cast_sign_loss,
                reason = "a few hundred ticks"
            )]
            watchdog_ticks: libm::ceil(WATCHDOG_S * rate) as u32,
            host_heard: false,
            longest_loop_us: 0,
            missed_ticks: 0,
        }
    }

    /// The `OnBoard` message this board states.
    #[must_use]
    pub fn on_board(&self) -> Message {
        Message::OnBoard {
            models: ALL_MODELS,
            loop_rate_hz: self.rate_hz,
            float_bytes: u8::try_from(core::mem::size_of::<T>()).unwrap_or(0),
        }
    }

    /// The loop step, s.
    #[must_use]
    pub fn dt(&self) -> T {
        self.dt
    }

    /// Starts afresh for a new host (its `Hello`): nothing rendered,
    /// nothing staged, force zero until it commands.
    pub fn reset(&mut self) {
        let limit = self.renderer.limit();
        *self = BoardLoop {
            tick: self.tick,
            ..BoardLoop::new(self.rate_hz, limit)
        };
    }

    /// Handles one valid message from the host (any message feeds the
    /// watchdog).
    pub fn receive(&mut self, message: &Message) {
        self.quiet_ticks = 0;
        self.host_heard = true;
        match *message {
            Message::Command { force_n, .. } => {
                let f = T::of(f64::from(force_n));
                let limit = self.renderer.limit();
                self.clamped = f.abs() > limit.newtons() || !f.is_finite();
                self.command = limit.clamp(f);
            }
            Message::Upload {
                kind,
                first,
                values,
            } => {
                if kind != self.staged_kind {
                    self.staged_kind = kind;
                    self.staged_mask = 0;
                }
                for (i, v) in values.iter().enumerate() {
                    let at = usize::from(first) + i;
                    if let Some(slot) = self.staged.get_mut(at) {
                        *slot = *v;
                        self.staged_mask |= 1 << at;
                    }
                }
            }
            Message::Select {
                render,
                kind,
                count,
                check,
            } => {
                let n = usize::from(count);
                let complete = n <= MAX_VALUES && self.staged_mask & ((1 << n) - 1) == (1 << n) - 1;
                let values = self.staged.get(..n).unwrap_or(&[]);
                // A model of no numbers (`none`) is sent with no upload.
                self.queue(
                    if (kind == self.staged_kind || n == 0)
                        && complete
                        && values_check(values) == check
                    {
                        let mut flat = Flat {
                            kind,
                            len: n,
                            values: [0.0; MAX_VALUES],
                        };
                        flat.values[..n].copy_from_slice(values);
                        Pending::Model { render, flat }
                    } else {
                        Pending::Refused
                    },
                );
            }
            Message::Clear { render } => self.queue(Pending::Clear { render }),
            Message::SetTelemetry { every } => {
                self.telemetry_period_ticks = every;
                self.countdown = 0;
            }
            _ => {}
        }
    }

    /// Queues a select for its tick, dropping the oldest if full.
    fn queue(&mut self, pending: Pending) {
        if self.pending_len == PENDING_SELECTS {
            self.pending_head = (self.pending_head + 1) % PENDING_SELECTS;
            self.pending_len -= 1;
        }
        self.pending[(self.pending_head + self.pending_len) % PENDING_SELECTS] = pending;
        self.pending_len += 1;
    }

    /// The next select waiting, if any.
    fn next_pending(&mut self) -> Option<Pending> {
        if self.pending_len == 0 {
            return None;
        }
        let next = self.pending[self.pending_head];
        self.pending_head = (self.pending_head + 1) % PENDING_SELECTS;
        self.pending_len -= 1;
        Some(next)
    }

    /// Notes how long this tick's loop body took and whether its deadline
    /// had passed (measured by the shell).
    pub fn note_loop(&mut self, loop_us: u32, missed: bool) {
        self.longest_loop_us = self.longest_loop_us.max(loop_us);
        self.missed_ticks += u32::from(missed);
    }

    /// The `LoopReport` of the loop so far.
    #[must_use]
    pub fn loop_report(&self) -> Message {
        Message::LoopReport {
            ticks: self.tick,
            longest_loop_us: self.longest_loop_us,
            missed_ticks: self.missed_ticks,
        }
    }

    /// One loop tick at the sensed `input`: applies the next pending select,
    /// steps the renderer, applies the watchdog, and returns the output.
    pub fn tick(&mut self, input: Input<T>, button: bool, end_stop: bool) -> Drive<T> {
        // Only a select that changes what the device renders is marked
        // selected (a re-render restarts the model there): not a refused
        // one, nor a resend of what is in effect.
        let mut selected = false;
        match self.next_pending() {
            Some(Pending::Model { render, flat })
                if !(render == self.render && self.in_effect == Some(flat)) =>
            {
                let params = ModelParams::unflatten(flat.kind, flat.used());
                self.refused =
                    !(params.is_some() && self.renderer.select(params.as_ref(), input.x_m));
                if self.refused {
                    self.renderer.select(None, input.x_m);
                }
                self.has_model = !self.refused;
                self.in_effect = self.has_model.then_some(flat);
                self.render = render;
                selected = true;
            }
            Some(Pending::Clear { render })
                if !(render == self.render && !self.has_model && !self.refused) =>
            {
                self.renderer.select(None, input.x_m);
                self.has_model = false;
                self.in_effect = None;
                self.refused = false;
                self.render = render;
                selected = true;
            }
            Some(Pending::Refused) => self.refused = true,
            Some(Pending::Model { .. } | Pending::Clear { .. }) | None => {}
        }
        let out = self.renderer.step(self.dt, input);
        let watchdog = self.quiet_ticks > self.watchdog_ticks;
        self.quiet_ticks = self.quiet_ticks.saturating_add(1);
        let commanded = if self.has_model {
            T::ZERO
        } else {
            self.command
        };
        let force = if watchdog {
            T::ZERO
        } else {
            self.renderer.limit().clamp(out.force_n + commanded)
        };
        let vibration = if watchdog { T::ZERO } else { out.vibration };
        self.tick = self.tick.wrapping_add(1);
        let telemetry = if self.telemetry_period_ticks > 0 && self.countdown == 0 {
            let mut flags = 0;
            if watchdog && self.host_heard {
                flags |= status::WATCHDOG;
            }
            if self.clamped && !self.has_model {
                flags |= status::CLAMPED;
            }
            if end_stop {
                flags |= status::END_STOP;
            }
            if out.phase == Phase::Slip {
                flags |= status::SLIP;
            }
            if button {
                flags |= status::BUTTON;
            }
            if self.refused {
                flags |= status::REFUSED;
            }
            if selected {
                flags |= status::SELECTED;
            }
            Some(Message::Telemetry {
                tick: self.tick,
                x_m: input.x_m.to_f32(),
                v_m_s: input.v_m_s.to_f32(),
                force_n: force.to_f32(),
                vibration: vibration.to_f32(),
                render: self.render,
                flags,
            })
        } else {
            None
        };
        if self.telemetry_period_ticks > 0 {
            self.countdown = (self.countdown + 1) % self.telemetry_period_ticks;
        }
        Drive {
            force_n: force,
            vibration,
            telemetry,
        }
    }
}

/// A host that has sent nothing for this long is gone: the device stops
/// streaming until the next `Hello`, s.
pub const HOST_GONE_S: f64 = 1.0;

/// How often a device sends its `LoopReport`, s.
pub const REPORT_EVERY_S: f64 = 0.1;

/// What a device states in its `Capabilities` besides its loop rate.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Apparatus {
    /// Maximum continuous force, N.
    pub max_force_n: f32,
    /// Encoder counts per metre.
    pub counts_per_m: f32,
}

/// The wire protocol v2 side of firmware that renders on board, sans-IO:
/// what the device emulator's `--on-board` mode and the microcontroller
/// firmware run. It answers `Hello` with `Capabilities` and `OnBoard`
/// (and starts the [`BoardLoop`] afresh), hands every other message to the
/// board, and streams the board's `Telemetry` and a `LoopReport` every
/// [`REPORT_EVERY_S`] while a host is there: from its `Hello` until it has
/// sent nothing for [`HOST_GONE_S`]. Before the first `Hello` and after a
/// host has gone it sends nothing (a device on a port nobody reads must
/// not fill it).
#[derive(Debug, Clone)]
pub struct Firmware<T: Real> {
    board: BoardLoop<T>,
    apparatus: Apparatus,
    /// Ticks since the host's last frame; `None`: no host.
    host_quiet: Option<u32>,
    gone_ticks: u32,
    report_every: u32,
}

impl<T: Real> Firmware<T> {
    /// Firmware looping at `rate_hz` with its force limited to `limit`.
    #[must_use]
    pub fn new(rate_hz: u16, limit: ForceLimit<T>, apparatus: Apparatus) -> Self {
        let rate = f64::from(rate_hz.max(1));
        #[expect(
            clippy::cast_possible_truncation,
            clippy::cast_sign_loss,
            reason = "ticks of a second at most"
        )]
        let ticks = |s: f64| libm::ceil(s * rate) as u32;
        Firmware {
            board: BoardLoop::new(rate_hz, limit),
            apparatus,
            host_quiet: None,
            gone_ticks: ticks(HOST_GONE_S),
            report_every: ticks(REPORT_EVERY_S).max(1),
        }
    }

    /// The `Capabilities` this firmware states (version 2).
    #[must_use]
    pub fn capabilities(&self) -> Message {
        let rate = self.board.rate_hz;
        Message::Capabilities {
            version: crate::wire::PROTOCOL_VERSION,
            dof: 1,
            max_force_n: self.apparatus.max_force_n,
            counts_per_m: self.apparatus.counts_per_m,
            force_rate_hz: rate,
            vibration_rate_hz: rate,
        }
    }

    /// Whether a host is there (see the type's docs).
    #[must_use]
    pub fn has_host(&self) -> bool {
        self.host_quiet.is_some()
    }

    /// Handles one valid message from the host; `send` gets the replies.
    pub fn receive(&mut self, message: &Message, mut send: impl FnMut(Message)) {
        if matches!(message, Message::Hello { .. }) {
            self.host_quiet = Some(0);
            self.board.reset();
            send(self.capabilities());
            send(self.board.on_board());
            return;
        }
        if let Some(quiet) = &mut self.host_quiet {
            *quiet = 0;
        }
        self.board.receive(message);
    }

    /// Notes how long this tick's loop body took and whether its deadline
    /// had passed (measured by the shell).
    pub fn note_loop(&mut self, loop_us: u32, missed: bool) {
        self.board.note_loop(loop_us, missed);
    }

    /// One loop tick at the sensed `input` ([`BoardLoop::tick`]); `send` gets
    /// the telemetry and loop reports due. Returns the force and vibration
    /// to output.
    pub fn tick(
        &mut self,
        input: Input<T>,
        button: bool,
        end_stop: bool,
        mut send: impl FnMut(Message),
    ) -> (T, T) {
        let drive = self.board.tick(input, button, end_stop);
        if let Some(quiet) = self.host_quiet {
            self.host_quiet = (quiet < self.gone_ticks).then_some(quiet + 1);
        }
        if self.has_host() {
            if let Some(telemetry) = drive.telemetry {
                send(telemetry);
            }
            if self.board.tick.is_multiple_of(self.report_every) {
                send(self.board.loop_report());
            }
        }
        (drive.force_n, drive.vibration)
    }
}

/// The `Upload` messages and `Select` that put `params` on a board as
/// render `render`: calls `send` for each, in order.
pub fn upload(params: &ModelParams, render: u8, mut send: impl FnMut(Message)) {
    let flat = params.flatten();
    let used = flat.used();
    for (i, chunk) in used.chunks(UPLOAD_VALUES).enumerate() {
        let mut values = [0.0; UPLOAD_VALUES];
        values[..chunk.len()].copy_from_slice(chunk);
        send(Message::Upload {
            kind: flat.kind,
            first: u8::try_from(i * UPLOAD_VALUES).unwrap_or(u8::MAX),
            values,
        });
    }
    send(Message::Select {
        render,
        kind: flat.kind,
        count: u8::try_from(flat.len).unwrap_or(u8::MAX),
        check: values_check(used),
    });
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::friction::ViscousParams;

    fn input(x_m: f32, v_m_s: f32) -> Input<f32> {
        Input { x_m, v_m_s }
    }

    fn force(m: Option<Message>) -> f32 {
        match m {
            Some(Message::Telemetry { force_n, .. }) => force_n,
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn an_uploaded_model_renders_as_the_core_does_from_the_next_tick() {
        let params = ModelParams::default_for("stick-slip-tactile").unwrap();
        let mut board = BoardLoop::<f32>::new(5000, ForceLimit::default());
        let mut messages = heapless_vec();
        upload(&params, 7, |m| messages.push(m));
        assert_eq!(messages.len(), 4, "11 values: 3 uploads and a select");
        for m in messages.iter() {
            board.receive(m);
        }
        let mut renderer = Renderer::<f32>::new(ForceLimit::default(), 0.05);
        renderer.select(Some(&params), 0.001);
        for k in 0..2000 {
            board.receive(&Message::Heartbeat { seq: k });
            let i = input(0.001 + 0.00001 * k as f32, 0.05);
            let d = board.tick(i, false, false);
            let r = renderer.step(board.dt(), i);
            assert_eq!(d.force_n.to_bits(), r.force_n.to_bits(), "tick {k}");
            assert_eq!(d.vibration.to_bits(), r.vibration.to_bits());
            let Some(Message::Telemetry { render, .. }) = d.telemetry else {
                panic!()
            };
            assert_eq!(render, 7);
        }
    }

    /// The render label and whether a select took effect, of a tick.
    fn shown(d: &Drive<f32>) -> (u8, bool) {
        match d.telemetry {
            Some(Message::Telemetry { render, flags, .. }) => {
                (render, flags & status::SELECTED != 0)
            }
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn a_resend_of_the_model_in_effect_restarts_nothing() {
        let params = ModelParams::default_for("stick-slip-tactile").unwrap();
        let mut resent = BoardLoop::<f32>::new(5000, ForceLimit::default());
        let mut once = BoardLoop::<f32>::new(5000, ForceLimit::default());
        upload(&params, 3, |m| resent.receive(&m));
        upload(&params, 3, |m| once.receive(&m));
        for k in 0..3000_u16 {
            // Resent (a slow link) 100 and 200 ms in.
            if k == 500 || k == 1000 {
                upload(&params, 3, |m| resent.receive(&m));
            }
            let i = input(0.0001 * f32::from(k % 400), 0.05);
            let (a, b) = (resent.tick(i, false, false), once.tick(i, false, false));
            assert_eq!(a.force_n.to_bits(), b.force_n.to_bits(), "tick {k}");
            assert_eq!(shown(&a), (3, k == 0), "tick {k}");
        }
        // The same model under a new label is a new render: selected.
        upload(&params, 4, |m| resent.receive(&m));
        assert_eq!(
            shown(&resent.tick(input(0.0, 0.0), false, false)),
            (4, true)
        );
        // A clear of the nothing in effect changes nothing either.
        resent.receive(&Message::Clear { render: 5 });
        assert_eq!(
            shown(&resent.tick(input(0.0, 0.0), false, false)),
            (5, true)
        );
        resent.receive(&Message::Clear { render: 5 });
        assert_eq!(
            shown(&resent.tick(input(0.0, 0.0), false, false)),
            (5, false)
        );
    }

    #[test]
    fn selects_arriving_together_take_effect_one_a_tick_in_order() {
        let params = ModelParams::default_for("karnopp").unwrap();
        let mut board = BoardLoop::<f32>::new(5000, ForceLimit::default());
        upload(&params, 1, |m| board.receive(&m));
        for _ in 0..300 {
            board.tick(input(0.01, 0.1), false, false);
        }
        // A clear and a new model in one read of the link.
        board.receive(&Message::Clear { render: 2 });
        upload(&params, 3, |m| board.receive(&m));
        let mut renderer = Renderer::<f32>::new(ForceLimit::default(), f32::of(RAMP_S));
        let a = board.tick(input(0.01, 0.1), false, false);
        assert_eq!(shown(&a), (2, true));
        renderer.select(Some(&params), 0.01);
        for k in 0..400 {
            board.receive(&Message::Heartbeat { seq: k });
            let d = board.tick(input(0.01, 0.1), false, false);
            assert_eq!(shown(&d), (3, k == 0), "tick {k}");
            let r = renderer.step(board.dt(), input(0.01, 0.1));
            // The model starts from the nothing the clear left, not from
            // the model before it.
            assert_eq!(d.force_n.to_bits(), r.force_n.to_bits(), "tick {k}");
        }
        // Six selects, four can wait: the oldest two are dropped.
        for render in 10..=15 {
            board.receive(&Message::Clear { render });
        }
        let labels: [(u8, bool); PENDING_SELECTS + 1] =
            core::array::from_fn(|_| shown(&board.tick(input(0.0, 0.0), false, false)));
        assert_eq!(
            labels,
            [(12, true), (13, true), (14, true), (15, true), (15, false)]
        );
    }

    /// Issue 63: the `none` model (a Fitts baseline's) has no numbers, so
    /// no upload goes before its select, whatever kind was staged last: it
    /// takes effect (it was refused, and the device went on showing the
    /// render before it).
    #[test]
    fn the_none_model_needs_no_upload() {
        let mut board = BoardLoop::<f32>::new(5000, ForceLimit::default());
        upload(&ModelParams::default_for("karnopp").unwrap(), 1, |m| {
            board.receive(&m);
        });
        assert_eq!(
            shown(&board.tick(input(0.01, 0.1), false, false)),
            (1, true)
        );
        let mut sent = 0;
        upload(&ModelParams::None, 2, |m| {
            sent += 1;
            board.receive(&m);
        });
        assert_eq!(sent, 1, "the select alone");
        let d = board.tick(input(0.01, 0.1), false, false);
        assert_eq!(shown(&d), (2, true));
    }

    #[test]
    fn a_select_with_a_part_missing_or_a_bad_check_is_refused() {
        let params = ModelParams::default_for("karnopp").unwrap();
        let mut messages = heapless_vec();
        upload(&params, 1, |m| messages.push(m));
        let mut board = BoardLoop::<f32>::new(1000, ForceLimit::default());
        // The first part lost.
        for m in &messages[1..] {
            board.receive(m);
        }
        let Some(Message::Telemetry { flags, render, .. }) =
            board.tick(input(0.0, 0.1), false, false).telemetry
        else {
            panic!()
        };
        assert_ne!(flags & status::REFUSED, 0);
        assert_eq!(flags & status::SELECTED, 0, "nothing took effect");
        assert_eq!(render, 0);
        // A value changed in transit (the frame CRC would catch it; the
        // select's check does too).
        let mut board = BoardLoop::<f32>::new(1000, ForceLimit::default());
        for m in messages.iter() {
            let mut m = *m;
            if let Message::Upload { values, .. } = &mut m {
                values[0] *= 2.0;
            }
            board.receive(&m);
        }
        let d = board.tick(input(0.0, 0.1), false, false);
        assert_eq!(d.force_n, 0.0);
    }

    #[test]
    fn the_watchdog_zeroes_the_force_after_20_ms_of_host_silence_in_both_modes() {
        let viscous = ModelParams::Viscous(ViscousParams {
            damping_n_s_m: 20.0,
        });
        let mut board = BoardLoop::<f32>::new(1000, ForceLimit::default());
        upload(&viscous, 1, |m| board.receive(&m));
        let forces: [f32; 40] =
            core::array::from_fn(|_| force(board.tick(input(0.0, 0.1), false, false).telemetry));
        assert!(forces[20] < -0.5, "rendering: {}", forces[20]);
        assert_eq!(forces[21..], [0.0; 19], "{forces:?}");
        // Force-only: a command above the limit is clamped, then silence.
        let mut board = BoardLoop::<f32>::new(1000, ForceLimit::new(5.0).unwrap());
        board.receive(&Message::Command {
            seq: 1,
            force_n: 50.0,
            vibration: 0.0,
        });
        let d = board.tick(input(0.0, 0.0), false, false);
        assert_eq!(d.force_n, 5.0);
        let Some(Message::Telemetry { flags, .. }) = d.telemetry else {
            panic!()
        };
        assert_eq!(flags & status::CLAMPED, status::CLAMPED);
        let last = (0..25)
            .map(|_| board.tick(input(0.0, 0.0), false, false).force_n)
            .last();
        assert_eq!(last, Some(0.0));
    }

    #[test]
    fn telemetry_comes_every_nth_tick() {
        let mut board = BoardLoop::<f32>::new(1000, ForceLimit::default());
        board.receive(&Message::SetTelemetry { every: 4 });
        let sent = (0..100)
            .filter(|_| {
                board
                    .tick(input(0.0, 0.0), false, false)
                    .telemetry
                    .is_some()
            })
            .count();
        assert_eq!(sent, 25);
    }

    /// A small fixed-capacity list (no allocator in the core).
    fn heapless_vec() -> Messages {
        Messages {
            items: [Message::Heartbeat { seq: 0 }; 8],
            len: 0,
        }
    }

    struct Messages {
        items: [Message; 8],
        len: usize,
    }

    impl Messages {
        fn push(&mut self, m: Message) {
            self.items[self.len] = m;
            self.len += 1;
        }
        fn len(&self) -> usize {
            self.len
        }
    }

    impl core::ops::Deref for Messages {
        type Target = [Message];
        fn deref(&self) -> &[Message] {
            &self.items[..self.len]
        }
    }
}
