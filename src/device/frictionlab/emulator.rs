//! The device emulator: firmware for the simulated apparatus, speaking the
//! wire protocol (`docs/wire-protocol.md`).
//!
//! [`EmulatorCore`] is sans-IO: messages in, samples out, time as an
//! argument. It answers `Hello` with its capabilities and applies each
//! `Command`'s force, clamped to the device maximum. A watchdog zeroes the
//! force when no valid command has arrived for 20 ms. Each tick it steps the
//! simulated apparatus, with the hand `HandDrive` describes, and reports a
//! `Sample` while a host is there: from the host's `Hello` until nothing
//! has come from it for [`HOST_GONE_S`]. Before the first `Hello` and after
//! a host has gone it sends nothing.
//!
//! With `--on-board` ([`EmulatorCore::on_board`]) it is a wire protocol v2
//! device: to a host that says `Hello` in version 2 it states its on-board
//! models (all of them, in `f32`, at [`ON_BOARD_RATE_HZ`]) and renders the
//! models the host uploads itself, through the core's
//! [`BoardLoop`](frictionlab_core::onboard::BoardLoop), streaming `Telemetry`. A
//! host speaking version 1 gets the version 1 device.
//!
//! The shell: [`open`] finds the port for a path (an existing port, or a new
//! pseudo-terminal linked there) and [`Emulator::serve`] (or [`serve`] on
//! any port) runs the core at the force loop rate, dropping any frame the
//! port cannot take at once.

use std::collections::VecDeque;
use std::io::{Read, Write};
use std::time::{Duration, Instant};

use super::wire::{Decoder, MAX_FRAME, Message, encode, status};
use crate::device::miswiring::Miswiring;
use crate::device::sim::Apparatus;
use crate::friction::ForceLimit;
use frictionlab_core::onboard::{self, Firmware};
use frictionlab_core::plant::Rig;

/// Force loop rate of the emulated firmware, Hz (seed 002's 1 kHz servo).
pub const FORCE_RATE_HZ: u16 = 1000;

/// Loop rate of the on-board mode, Hz: seed 001's stick-slip rate, which
/// every model runs at on board.
pub const ON_BOARD_RATE_HZ: u16 = 5000;

/// Watchdog: no valid command for this long zeroes the force, s.
pub const WATCHDOG_S: f64 = frictionlab_core::onboard::WATCHDOG_S;

/// A host that has sent nothing for this long is gone: the emulator stops
/// streaming until the next `Hello`, s.
pub const HOST_GONE_S: f64 = onboard::HOST_GONE_S;

/// Hand mass on the emulated device, kg (as the simulated participant's).
const HAND_MASS_KG: f64 = 0.4;

/// The emulated firmware.
#[derive(Debug, Clone)]
pub struct EmulatorCore {
    p: Apparatus,
    /// The apparatus with the hand `HandDrive` describes on it.
    rig: Rig,
    now_s: f64,
    force_n: f64,
    clamped: bool,
    ack_seq: u32,
    last_command_s: Option<f64>,
    /// When the host last sent a valid frame, since its `Hello`; `None`
    /// while no host is there.
    host_heard_s: Option<f64>,
    /// The on-board firmware (`--on-board`), and whether the host speaks
    /// version 2 (so it is used).
    firmware: Option<Firmware<f32>>,
    v2: bool,
    /// Replies beyond the first to a message (`OnBoard` after
    /// `Capabilities`) and loop reports, sent with the next tick.
    outbox: Vec<Message>,
    /// How the board is wired wrong, if it is (tests of the bring-up
    /// check).
    miswiring: Miswiring,
}

impl Default for EmulatorCore {
    fn default() -> Self {
        Self::new()
    }
}

impl EmulatorCore {
    /// Firmware for seed 002's apparatus, at rest at the centre.
    #[must_use]
    pub fn new() -> Self {
        let p = Apparatus::default();
        EmulatorCore {
            p,
            rig: Rig::new(p, HAND_MASS_KG),
            now_s: 0.0,
            force_n: 0.0,
            clamped: false,
            ack_seq: 0,
            last_command_s: None,
            host_heard_s: None,
            firmware: None,
            v2: false,
            outbox: Vec::new(),
            miswiring: Miswiring::default(),
        }
    }

    /// This firmware on a board wired wrong as `miswiring` says: its
    /// encoder's count and its motor's force, on board too.
    #[must_use]
    pub fn miswired(mut self, miswiring: Miswiring) -> Self {
        self.miswiring = miswiring;
        self
    }

    /// Firmware that also renders models on board (wire protocol v2), in
    /// `f32` at [`ON_BOARD_RATE_HZ`], within the apparatus's maximum force.
    #[must_use]
    pub fn on_board() -> Self {
        let mut core = Self::new();
        let stated = core.p.stated();
        let limit = ForceLimit::new(stated.max_force_n).unwrap_or_default();
        core.firmware = Some(Firmware::new(ON_BOARD_RATE_HZ, limit, stated));
        core
    }

    /// The loop rate in the mode the current host speaks, Hz.
    #[must_use]
    pub fn rate_hz(&self) -> u16 {
        if self.firmware.is_some() {
            ON_BOARD_RATE_HZ
        } else {
            FORCE_RATE_HZ
        }
    }

    /// Messages to send besides [`EmulatorCore::receive`]'s reply and
    /// [`EmulatorCore::tick`]'s sample.
    pub fn take_outbox(&mut self) -> Vec<Message> {
        std::mem::take(&mut self.outbox)
    }

    /// The capabilities this firmware states.
    #[must_use]
    pub fn capabilities(&self) -> Message {
        if let Some(firmware) = self.firmware.as_ref().filter(|_| self.v2) {
            return firmware.capabilities();
        }
        let stated = self.p.stated();
        Message::Capabilities {
            version: 1,
            dof: 1,
            max_force_n: stated.max_force_n,
            counts_per_m: stated.counts_per_m,
            force_rate_hz: FORCE_RATE_HZ,
            vibration_rate_hz: 0,
        }
    }

    /// Whether a host is there: it said `Hello` and has sent something
    /// within [`HOST_GONE_S`]. Samples go out only then.
    #[must_use]
    pub fn has_host(&self) -> bool {
        self.host_heard_s
            .is_some_and(|t| self.now_s - t <= HOST_GONE_S)
    }

    /// Handles one message from the host; returns the reply, if any.
    pub fn receive(&mut self, message: Message) -> Option<Message> {
        if matches!(message, Message::Hello { .. }) || self.host_heard_s.is_some() {
            self.host_heard_s = Some(self.now_s);
        }
        if let Message::Hello { version } = message {
            self.v2 = version >= 2 && self.firmware.is_some();
        }
        let mut reply = None;
        if let Some(firmware) = self.firmware.as_mut().filter(|_| self.v2) {
            // The first reply (`Capabilities` to a `Hello`) now, the rest
            // (`OnBoard`) with the next tick.
            firmware.receive(&message, |m| match reply {
                None => reply = Some(m),
                Some(_) => self.outbox.push(m),
            });
        }
        match message {
            Message::Hello { .. } => {
                self.force_n = 0.0;
                self.last_command_s = None;
                reply.or_else(|| Some(self.capabilities()))
            }
            Message::Command { seq, force_n, .. } => {
                let f = if force_n.is_finite() {
                    f64::from(force_n)
                } else {
                    0.0
                };
                let max = self.p.max_force_n;
                self.clamped = f.abs() > max;
                self.force_n = f.clamp(-max, max);
                self.ack_seq = seq;
                self.last_command_s = Some(self.now_s);
                None
            }
            Message::HandDrive { .. } => {
                self.rig.follow(&message);
                None
            }
            _ => None,
        }
    }

    /// The hand's integral effort now, N (see [`crate::hand`]).
    #[must_use]
    pub fn hand_integral_n(&self) -> f64 {
        self.rig.hand_integral_n()
    }

    /// Advances the firmware by `dt`; returns this tick's sample, or `None`
    /// while no host is there ([`EmulatorCore::has_host`]).
    pub fn tick(&mut self, dt: f64) -> Option<Message> {
        if self.v2 && self.firmware.is_some() {
            return self.tick_on_board(dt);
        }
        self.now_s += dt;
        let watchdog = self
            .last_command_s
            .is_none_or(|t| self.now_s - t > WATCHDOG_S);
        let force = if watchdog {
            0.0
        } else {
            self.miswiring.motor(self.force_n)
        };
        let mut button = false;
        let sample = self.rig.step(dt, |sensed| {
            button = sensed.button;
            force
        });
        if !self.has_host() {
            self.host_heard_s = None;
            return None;
        }
        let mut flags = 0;
        if watchdog && self.last_command_s.is_some() {
            flags |= status::WATCHDOG;
        }
        if self.clamped {
            flags |= status::CLAMPED;
        }
        if self.rig.at_end_stop() {
            flags |= status::END_STOP;
        }
        #[expect(
            clippy::cast_possible_truncation,
            reason = "counts fit i32 over the 3.2 cm range; time wraps by design"
        )]
        #[expect(clippy::cast_sign_loss, reason = "time is non-negative")]
        Some(Message::Sample {
            ack_seq: self.ack_seq,
            time_us: ((self.now_s * 1e6) as u64 & 0xffff_ffff) as u32,
            position_counts: (self.miswiring.encoder(sample.x_m) / self.p.encoder_m).round() as i32,
            button,
            status: flags,
        })
    }

    /// One tick rendering on board: the firmware computes the force from
    /// what the apparatus sensed; its telemetry is the tick's message (a
    /// loop report goes with the next tick).
    fn tick_on_board(&mut self, dt: f64) -> Option<Message> {
        let firmware = self.firmware.as_mut()?;
        self.now_s += dt;
        let mut telemetry = None;
        let outbox = &mut self.outbox;
        let miswiring = self.miswiring;
        let sample = self.rig.step(dt, |sensed| {
            let sensed = frictionlab_core::plant::Sensed {
                input: crate::friction::Input {
                    x_m: miswiring.encoder(sensed.input.x_m),
                    v_m_s: miswiring.encoder(sensed.input.v_m_s),
                },
                ..sensed
            };
            let input = sensed.input_f32();
            let (force_n, _) =
                firmware.tick(input, sensed.button, sensed.end_stop, |m| match telemetry {
                    None => telemetry = Some(m),
                    Some(_) => outbox.push(m),
                });
            miswiring.motor(f64::from(force_n))
        });
        self.force_n = sample.force_n;
        if !firmware.has_host() {
            self.host_heard_s = None;
            self.v2 = false;
            self.outbox.clear();
            return None;
        }
        telemetry
    }

    /// Notes the loop's timing for the on-board `LoopReport`.
    pub fn note_loop(&mut self, loop_us: u32, missed: bool) {
        if let Some(firmware) = &mut self.firmware {
            firmware.note_loop(loop_us, missed);
        }
    }

    /// The force being rendered now (after the watchdog), N.
    #[must_use]
    pub fn rendered_force_n(&self) -> f64 {
        if self.v2 {
            return self.force_n;
        }
        if self
            .last_command_s
            .is_none_or(|t| self.now_s - t > WATCHDOG_S)
        {
            0.0
        } else {
            self.force_n
        }
    }
}

/// Runs the emulator on an open port until the port fails (or forever).
///
/// Reads and writes never wait long: a read or write that times out or
/// would block counts as nothing read, or as a frame dropped (a frame cut
/// short by a full buffer is dropped by the host's decoder too). Only other
/// errors end it.
///
/// With a `link_delay`, what the host sends reaches the device that much
/// later, in order: a backed-up link, as QEMU's UART on a loaded machine
/// (a way to test how a host copes).
///
/// # Errors
/// An I/O error on the port.
pub fn serve(
    port: &mut (impl Read + Write),
    core: EmulatorCore,
    link_delay: Duration,
    mut on_tick: impl FnMut(&EmulatorCore),
) -> std::io::Result<()> {
    // A device keeps its own time: at real-time priority where allowed
    // (crate::device::realtime; issue 63).
    let _ = crate::device::realtime::ask_fifo(); // granted or not, it serves
    let mut core = core;
    let mut decoder = Decoder::new();
    let mut input = [0_u8; 512];
    let mut out = [0_u8; MAX_FRAME];
    let mut in_flight: VecDeque<(Instant, Vec<u8>)> = VecDeque::new();
    let start = Instant::now();
    let mut ticks = 0_u64;
    loop {
        let n = match port.read(&mut input) {
            Ok(n) => n,
            Err(e) if is_busy(&e) => 0,
            Err(e) => return Err(e),
        };
        let mut replies = Vec::new();
        if link_delay.is_zero() {
            decoder.feed(&input[..n], |m| replies.extend(core.receive(m)));
        } else {
            let now = Instant::now();
            if n > 0 {
                in_flight.push_back((now + link_delay, input[..n].to_vec()));
            }
            while let Some((_, bytes)) = in_flight.pop_front_if(|(due, _)| *due <= now) {
                decoder.feed(&bytes, |m| replies.extend(core.receive(m)));
            }
        }
        // Every tick due by now (one a wake-up at 1 kHz, five on board).
        let dt = 1.0 / f64::from(core.rate_hz());
        let elapsed = start.elapsed().as_secs_f64();
        #[expect(
            clippy::cast_possible_truncation,
            clippy::cast_sign_loss,
            reason = "non-negative tick counts"
        )]
        let due = (elapsed / dt) as u64;
        if due > ticks + 100 {
            ticks = due - 1; // Fell far behind (machine stalled): do not burst.
        }
        while ticks < due.max(1) {
            let began = Instant::now();
            replies.extend(core.take_outbox());
            replies.extend(core.tick(dt));
            let late = began.duration_since(start).as_secs_f64() - ticks as f64 * dt;
            ticks += 1;
            #[expect(clippy::cast_possible_truncation, reason = "microseconds of one tick")]
            core.note_loop(began.elapsed().as_micros() as u32, late > MISSED_AFTER_S);
            for m in replies.drain(..) {
                if let Ok(len) = encode(&m, &mut out) {
                    match port.write_all(&out[..len]) {
                        Err(e) if !is_busy(&e) => return Err(e),
                        _ => {} // Sent, or dropped: nobody is reading.
                    }
                }
            }
            on_tick(&core);
        }
        let next = start + Duration::from_secs_f64((ticks + 1) as f64 * dt);
        let now = Instant::now();
        let wake = next.max(now + Duration::from_micros(WAKE_US));
        std::thread::sleep(wake - now);
    }
}

/// The emulator wakes at most this often, microseconds: on board it runs
/// the ticks due since its last wake-up in a batch (a real device's timer
/// interrupt runs each on time).
const WAKE_US: u64 = 1000;

/// A tick that runs this long after its deadline counts as missed, s: more
/// than a batch late.
const MISSED_AFTER_S: f64 = 0.002;

use crate::device::pty::is_busy;
pub use crate::device::pty::{Endpoint, OpenError, link_pty, open};

/// An emulator on its port, ready to [`serve`](Emulator::serve).
pub type Emulator = crate::device::pty::Emulated;

impl Emulator {
    /// Runs the emulator until its port fails (see [`serve`]).
    ///
    /// # Errors
    /// An I/O error on the port.
    pub fn serve(
        &mut self,
        core: EmulatorCore,
        link_delay: Duration,
        on_tick: impl FnMut(&EmulatorCore),
    ) -> std::io::Result<()> {
        serve(self.port(), core, link_delay, on_tick)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::device::frictionlab::wire::frame;

    const HELLO: Message = Message::Hello { version: 1 };

    fn ticks(core: &mut EmulatorCore, n: usize) -> usize {
        (0..n).filter_map(|_| core.tick(0.001)).count()
    }

    /// Issue 13: an emulator nobody listens to sends nothing, so the line's
    /// buffer cannot fill before a host comes.
    #[test]
    fn the_core_is_silent_until_a_host_says_hello_issue_13() {
        let mut core = EmulatorCore::new();
        assert_eq!(ticks(&mut core, 5000), 0, "nothing before a Hello");
        assert!(!core.has_host());
        // Commands and hand drives without a Hello start nothing either.
        core.receive(Message::Heartbeat { seq: 1 });
        assert_eq!(ticks(&mut core, 10), 0);
        assert_eq!(core.receive(HELLO), Some(core.capabilities()));
        assert!(core.has_host());
        assert_eq!(ticks(&mut core, 10), 10, "one sample per tick");
    }

    /// Issue 13: the emulator's hand is `hand.rs`'s, with its one reset
    /// rule: a target that moves keeps the effort built (it used to restart
    /// whenever the target moved 1 mm); a relaxed drive ends the segment.
    #[test]
    fn the_emulated_hand_restarts_its_effort_only_at_a_new_segment_issue_13() {
        let mut core = EmulatorCore::new();
        core.receive(HELLO);
        let drive = |x_m: f32, integral: f32| Message::HandDrive {
            x_m,
            v_m_s: 0.0,
            stiffness_n_m: 0.0,
            damping_n_s_m: 0.0,
            integral,
            click: false,
        };
        core.receive(drive(0.010, 3000.0));
        ticks(&mut core, 50);
        let built = core.hand_integral_n();
        assert!(built > 1.0, "{built}");
        core.receive(drive(0.015, 3000.0));
        ticks(&mut core, 1);
        assert!(core.hand_integral_n() > built, "moving the target keeps it");
        core.receive(drive(0.015, 0.0));
        core.receive(drive(0.015, 3000.0));
        ticks(&mut core, 1);
        assert!(
            core.hand_integral_n() < 0.1,
            "a new segment restarts it: {}",
            core.hand_integral_n()
        );
    }

    /// Issue 13: host after host is served; a host that has gone quiet for
    /// HOST_GONE_S is gone, and the next one is served after its Hello.
    #[test]
    fn the_core_goes_quiet_when_its_host_does_and_serves_the_next_issue_13() {
        let mut core = EmulatorCore::new();
        core.receive(HELLO);
        // A host that keeps commanding stays served well past HOST_GONE_S.
        for seq in 0..3000 {
            core.receive(Message::Command {
                seq,
                force_n: 0.0,
                vibration: 0.0,
            });
            assert!(core.tick(0.001).is_some(), "tick {seq}");
        }
        // It goes away: samples for HOST_GONE_S, then silence.
        let sent = ticks(&mut core, 3000) as f64;
        assert!((sent - HOST_GONE_S * 1000.0).abs() <= 1.0, "{sent} samples");
        assert!(!core.has_host());
        // Stray frames do not bring it back; the next Hello does.
        core.receive(Message::Heartbeat { seq: 9 });
        assert_eq!(ticks(&mut core, 10), 0);
        core.receive(HELLO);
        assert_eq!(ticks(&mut core, 10), 10);
    }

    /// A port whose reads give `reads` in turn, then fail for good, and whose
    /// writes never find room.
    struct FullPort {
        reads: Vec<std::io::Result<Vec<u8>>>,
        writes: usize,
    }

    impl Read for FullPort {
        fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
            if self.reads.is_empty() {
                return Err(std::io::Error::other("unplugged"));
            }
            let bytes = self.reads.remove(0)?;
            buf[..bytes.len()].copy_from_slice(&bytes);
            Ok(bytes.len())
        }
    }

    impl Write for FullPort {
        fn write(&mut self, _: &[u8]) -> std::io::Result<usize> {
            self.writes += 1;
            Err(std::io::ErrorKind::TimedOut.into())
        }
        fn flush(&mut self) -> std::io::Result<()> {
            Ok(())
        }
    }

    /// Issue 13: a full line costs frames, not the emulator; only a real
    /// port error ends `serve`.
    #[test]
    fn serve_drops_what_a_full_port_cannot_take_and_ends_only_on_a_port_error_issue_13() {
        let mut reads = vec![Ok(frame(&HELLO))];
        reads.extend((0..20).map(|_| Err(std::io::ErrorKind::TimedOut.into())));
        let mut port = FullPort { reads, writes: 0 };
        let mut served = 0;
        let e = serve(&mut port, EmulatorCore::new(), Duration::ZERO, |core| {
            served += usize::from(core.has_host());
        })
        .unwrap_err();
        assert_eq!(e.to_string(), "unplugged");
        assert!(served >= 21, "every tick ran with the host: {served}");
        // Capabilities and a sample per tick were tried, and dropped.
        assert_eq!(port.writes, served + 1);
    }
}
