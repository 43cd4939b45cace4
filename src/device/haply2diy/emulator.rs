//! An emulated 2DIY: the board's firmware (`Haply_M3_Firmware_V1_5`, as
//! read: reset, setup, torque writes answered with the encoder angles; no
//! reply to anything else) on a pantograph with a hand on it.
//!
//! [`BoardCore`] is sans-IO: bytes in, reply bytes out, time as an
//! argument. The shell ([`serve`]) runs it on a port or a new
//! pseudo-terminal, and takes the simulated participant's hand drive from
//! the socket beside the path ([`crate::device::hand_link`]).
//!
//! The physics: the end effector moves along the default track under the
//! simulated apparatus model of [`Rig`] (the hand of the simulated
//! participant follows the session's drive), and across it as a point mass
//! held by the hand's own impedance. The motors' torques act through the
//! pantograph's Jacobian at the true pose; the encoders count whole steps
//! from the pose at setup, as the board's do. It powers up at the vendor's
//! calibration pose (where the experimenter puts the handle before a
//! session); a reset forgets the setup and leaves the handle where it is,
//! as a real board's does.
//!
//! Faults for tests, when asked ([`Faults`]): the board loses its setup
//! mid-session (as a board that browned out and restarted: its port goes
//! away for [`REPLUG_GAP_S`] as the board's USB starts again, and it then
//! answers with its id alone), or its port goes away for [`REPLUG_GAP_S`]
//! and comes back with the board still set up (a USB replug the board
//! rode out). Either way the board's serial input starts empty when the
//! port comes back ([`BoardCore::replugged`]).
//!
//! Free constants of the emulated hand and linkage (not from a source; no
//! result depends on their exact values, the tests ask only that the loop
//! hold the hand on the track):
//! - [`LINKAGE_MASS_KG`], [`LINKAGE_FRICTION_N`]: the linkage's moving mass
//!   and friction at the end effector;
//! - [`HAND_ACROSS_STIFFNESS_N_M`], [`HAND_ACROSS_DAMPING_N_S_M`],
//!   [`HAND_ACROSS_REST_M`]: the hand across the track: a person's hand on
//!   a stylus drifts off a line; it rests 3 mm off the track and pulls
//!   there.

use std::io::{Read, Write};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use super::pantograph::{self, Links, Pose};
use super::protocol::{PORTS, Wiring};
use super::{Config, MAX_TORQUE_N_M};
use crate::device::hand_link;
use crate::device::miswiring::Miswiring;
use crate::device::pty::is_busy;
use crate::device::track::Track;
use frictionlab_core::plant::{Apparatus, Rig};

/// The linkage's moving mass at the end effector, kg (free).
pub const LINKAGE_MASS_KG: f64 = 0.05;
/// The linkage's friction at the end effector, N (free).
pub const LINKAGE_FRICTION_N: f64 = 0.02;
/// The hand's stiffness across the track, N/m (free).
pub const HAND_ACROSS_STIFFNESS_N_M: f64 = 200.0;
/// The hand's damping across the track, N s/m (free).
pub const HAND_ACROSS_DAMPING_N_S_M: f64 = 5.0;
/// Where the hand rests across the track, m off it (free).
pub const HAND_ACROSS_REST_M: f64 = 0.003;
/// The hand's mass, kg (as the simulated participant's on our own device).
pub const HAND_MASS_KG: f64 = 0.4;
/// How far along the track the linkage moves before it meets its stops, m:
/// the travel the driver states for `config` ([`Config::reach`]), so that a
/// bring-up check of the emulator measures what the driver states (issue
/// 63; a real 2DIY has no stops there: the lab marks the ends).
#[must_use]
pub fn track_range_m(config: &Config) -> f64 {
    let ([lo, hi], _) = config.reach();
    2.0 * hi.min(-lo).max(0.0)
}

/// Physics step of the emulator, s.
pub const STEP_S: f64 = 0.0005;
/// Physics steps per host period in lockstep ([`Clock::Lockstep`]): 1 ms,
/// the host loop's period ([`super::RATE_HZ`]).
const LOCKSTEP_STEPS: u32 = 2;

/// What the host set up (the firmware's tables after a type 1 frame).
#[derive(Debug, Clone, Default)]
struct Registered {
    id: u8,
    /// Per port: the direction byte of a motor there.
    motors: [Option<u8>; PORTS],
    /// Per port: direction, count at setup, counts per revolution.
    encoders: [Option<(u8, i64, f64)>; PORTS],
    /// The true joint angles at setup, degrees.
    at_setup: [f64; 2],
}

/// The emulated board and pantograph.
#[derive(Debug, Clone)]
pub struct BoardCore {
    /// How the board is really wired (which joint on which port, which
    /// way) and its links.
    truth: Wiring,
    links: Links,
    track: Track,
    registered: Option<Registered>,
    input: Vec<u8>,
    /// Joint torques applied now, N m.
    torque: [f64; 2],
    rig: Rig,
    /// Across the track: offset, m, and velocity, m/s.
    across: (f64, f64),
    /// The last pose inside the workspace.
    angles: [f64; 2],
    /// The encoders count this many times the steps per turn the host
    /// sets up ([`Miswiring::encoder_scale`]; 1: right).
    encoder_scale: f64,
}

impl BoardCore {
    /// A board wired as `config` says a vendor 2DIY is, powered up at its
    /// calibration pose.
    #[must_use]
    pub fn new(config: &Config) -> Self {
        let truth = config.wiring;
        let apparatus = Apparatus {
            mass_kg: LINKAGE_MASS_KG,
            static_friction_n: LINKAGE_FRICTION_N,
            max_force_n: 1e3,
            range_m: track_range_m(config),
            encoder_m: 1e-9,
            ..Apparatus::default()
        };
        let mut core = BoardCore {
            truth,
            links: config.links,
            track: config.track,
            registered: None,
            input: Vec::new(),
            torque: [0.0; 2],
            rig: Rig::new(apparatus, HAND_MASS_KG),
            across: (0.0, 0.0),
            angles: [0.0; 2],
            encoder_scale: 1.0,
        };
        core.park();
        core
    }

    /// This board wired wrong as `miswiring` says: both encoders counting
    /// the other way than the setup says (`flip_encoder`), both motors
    /// turning the other way (`flip_motor`), the encoders counting
    /// `encoder_scale` times the steps per turn the setup states.
    #[must_use]
    pub fn miswired(mut self, miswiring: &Miswiring) -> Self {
        for e in &mut self.truth.encoders {
            e.direction ^= u8::from(miswiring.flip_encoder);
        }
        for m in &mut self.truth.motors {
            m.direction ^= u8::from(miswiring.flip_motor);
        }
        self.encoder_scale = miswiring.encoder_scale;
        self
    }

    /// Puts the linkage at its calibration pose, at rest, where the
    /// experimenter puts a 2DIY's handle before a host sets it up (its
    /// encoders count from where it is then): where it powers up.
    pub fn park(&mut self) {
        let calibration = [
            self.truth.encoders[0].offset_deg,
            self.truth.encoders[1].offset_deg,
        ];
        let rest = pantograph::forward(&self.links, calibration);
        let (along, across) = self.track.split([rest.x_m, rest.y_m, 0.0]);
        self.rig.place(along);
        self.across = (signed_across(&self.track, across), 0.0);
        self.angles = calibration;
    }

    /// The hand follows `drive` from now on.
    pub fn drive(&mut self, drive: crate::hand::HandDrive) {
        self.rig.drive(drive);
    }

    /// The true joint angles, degrees.
    #[must_use]
    pub fn angles(&self) -> [f64; 2] {
        self.angles
    }

    /// The end effector's true position, m.
    #[must_use]
    pub fn position(&self) -> [f64; 2] {
        let p = pantograph::forward(&self.links, self.angles);
        [p.x_m, p.y_m]
    }

    /// Takes bytes from the host; each whole frame is handled as the
    /// firmware does, and a torque frame's reply appended to `reply`.
    /// Each frame (and reply) is also handed to `log` (`true`: from the
    /// host).
    pub fn receive(&mut self, bytes: &[u8], reply: &mut Vec<u8>, log: &mut dyn FnMut(bool, &[u8])) {
        self.input.extend_from_slice(bytes);
        while let Some(len) = self.frame_len() {
            let frame: Vec<u8> = self.input.drain(..len).collect();
            log(true, &frame);
            let start = reply.len();
            self.handle(&frame, reply);
            if reply.len() > start {
                log(false, &reply[start..]);
            }
        }
    }

    /// The length of the whole frame at the start of the input, if it is
    /// all there.
    fn frame_len(&self) -> Option<usize> {
        let b = &self.input;
        let need = |n: usize| (b.len() >= n).then_some(n);
        match *b.first()? {
            0 => need(2),
            1 => {
                let mut at = 2;
                for _ in 0..2 {
                    let mask = *b.get(at)?;
                    at += 1 + mask.count_ones() as usize;
                }
                let encoders = b.get(2 + 1 + b[2].count_ones() as usize)?.count_ones() as usize;
                let sensors = usize::from(*b.get(at)?);
                at += 1 + sensors;
                let pwms = usize::from(*b.get(at)?);
                at += 1 + pwms;
                need(at + 8 * encoders)
            }
            2 => {
                b.get(1)?;
                let motors = self.motors_of(b[1]);
                need(2 + 4 * motors)
            }
            _ => need(1),
        }
    }

    fn motors_of(&self, id: u8) -> usize {
        self.registered
            .as_ref()
            .filter(|r| r.id == id)
            .map_or(0, |r| r.motors.iter().flatten().count())
    }

    fn handle(&mut self, frame: &[u8], reply: &mut Vec<u8>) {
        match frame[0] {
            0 => self.lose_setup(),
            1 => self.setup(frame),
            2 => {
                self.torques(frame);
                reply.push(frame[1]);
                if let Some(r) = self.registered.as_ref().filter(|r| r.id == frame[1]) {
                    for (port, e) in r.encoders.iter().enumerate() {
                        if let Some(&(direction, count0, resolution)) = e.as_ref() {
                            let angle = self.encoder_angle(port, direction, count0, resolution, r);
                            reply.extend(angle.to_le_bytes());
                        }
                    }
                }
            }
            _ => {}
        }
    }

    /// Forgets the setup and stops the motors, the handle left where it
    /// is (a reset, or a board that restarted): torque frames are answered
    /// with the id alone until a host sets it up again.
    pub fn lose_setup(&mut self) {
        self.registered = None;
        self.torque = [0.0; 2];
    }

    /// The board's port came back (a replug, or a restart): what was left
    /// of a frame read before it went is gone with the USB link, and the
    /// next byte read starts a frame. (Kept, it would take the new bytes
    /// as that frame's rest and read every frame after it from the wrong
    /// byte: a torque's zero bytes as resets.)
    pub fn replugged(&mut self) {
        self.input.clear();
    }

    /// Whether a host has set the board up.
    #[must_use]
    pub fn is_set_up(&self) -> bool {
        self.registered.is_some()
    }

    fn setup(&mut self, frame: &[u8]) {
        let mut r = Registered {
            id: frame[1],
            at_setup: self.angles,
            ..Registered::default()
        };
        // Each block: a mask (bit k: port k + 1), then a direction per
        // port in use, in port order.
        let mut at = 2;
        for block in 0..2 {
            let mask = frame[at];
            at += 1;
            for p in 0..PORTS {
                if mask & (1 << p) != 0 {
                    if block == 0 {
                        r.motors[p] = Some(frame[at]);
                    } else {
                        r.encoders[p] = Some((frame[at], 0, 1.0));
                    }
                    at += 1;
                }
            }
        }
        at += 1 + usize::from(frame[at]);
        at += 1 + usize::from(frame[at]);
        for p in 0..PORTS {
            if let Some((direction, _, _)) = r.encoders[p] {
                let f = |k: usize| {
                    f64::from(f32::from_le_bytes([
                        frame[k],
                        frame[k + 1],
                        frame[k + 2],
                        frame[k + 3],
                    ]))
                };
                let (offset, resolution) = (f(at), f(at + 4));
                at += 8;
                // `Encoder::write(offset * resolution / 360)`: a float
                // converted to a whole count.
                #[expect(clippy::cast_possible_truncation, reason = "the firmware's int")]
                let count0 = (offset * resolution / 360.0) as i64;
                r.encoders[p] = Some((direction, count0, resolution));
            }
        }
        self.registered = Some(r);
    }

    /// Which joint is on `port`, and whether `direction` is the way it is
    /// really wired.
    fn joint(&self, port: usize, motor: bool, direction: u8) -> Option<(usize, f64)> {
        (0..2).find_map(|j| {
            let (p, d) = if motor {
                (self.truth.motors[j].port, self.truth.motors[j].direction)
            } else {
                (
                    self.truth.encoders[j].port,
                    self.truth.encoders[j].direction,
                )
            };
            (usize::from(p) == port + 1).then_some((j, if d == direction { 1.0 } else { -1.0 }))
        })
    }

    fn torques(&mut self, frame: &[u8]) {
        let Some(r) = self.registered.clone().filter(|r| r.id == frame[1]) else {
            return;
        };
        let mut at = 2;
        for (port, m) in r.motors.iter().enumerate() {
            if let Some(direction) = *m {
                let tau =
                    f32::from_le_bytes([frame[at], frame[at + 1], frame[at + 2], frame[at + 3]]);
                at += 4;
                if let Some((joint, sign)) = self.joint(port, true, direction) {
                    self.torque[joint] = sign * applied(f64::from(tau));
                }
            }
        }
    }

    fn encoder_angle(
        &self,
        port: usize,
        direction: u8,
        count0: i64,
        resolution: f64,
        r: &Registered,
    ) -> f32 {
        let turned = self
            .joint(port, false, direction)
            .map_or(0.0, |(j, sign)| sign * (self.angles[j] - r.at_setup[j]));
        #[expect(clippy::cast_possible_truncation, reason = "whole encoder steps")]
        let count = count0 + (turned * self.encoder_scale * resolution / 360.0).floor() as i64;
        #[expect(
            clippy::cast_possible_truncation,
            clippy::cast_precision_loss,
            reason = "the firmware's float"
        )]
        let angle = (360.0 * count as f64 / resolution) as f32;
        angle
    }

    /// Advances the pantograph and hand by `dt`.
    pub fn step(&mut self, dt: f64) {
        let pose: Pose = pantograph::forward(&self.links, self.angles);
        let f = pose.force(self.torque);
        let (u, v) = axes(&self.track);
        let along = f[0] * u[0] + f[1] * u[1];
        let across_force = f[0] * v[0] + f[1] * v[1];
        let sample = self.rig.step(dt, |_| along);
        let (y, vy) = self.across;
        let a = (across_force
            - HAND_ACROSS_STIFFNESS_N_M * (y - HAND_ACROSS_REST_M)
            - HAND_ACROSS_DAMPING_N_S_M * vy)
            / (LINKAGE_MASS_KG + HAND_MASS_KG);
        let vy = vy + a * dt;
        let y = y + vy * dt;
        let o = self.track.origin_m;
        let (px, py) = (
            o[0] + sample.x_m * u[0] + y * v[0],
            o[1] + sample.x_m * u[1] + y * v[1],
        );
        if let Some(angles) = pantograph::inverse(&self.links, px, py) {
            self.angles = angles;
            self.across = (y, vy);
        } else {
            self.across = (self.across.0, 0.0);
        }
    }
}

/// The firmware's torque: |τ| clamped to [`MAX_TORQUE_N_M`] and set as a
/// 12-bit duty (`duty = 4095 τ / MAX`, an int).
fn applied(tau: f64) -> f64 {
    if !tau.is_finite() {
        return 0.0;
    }
    let magnitude = tau.abs().min(MAX_TORQUE_N_M);
    let duty = (4095.0 * magnitude / MAX_TORQUE_N_M).floor();
    tau.signum() * duty * MAX_TORQUE_N_M / 4095.0
}

/// The track's direction and the direction across it (in the plane, a
/// quarter turn counter-clockwise).
fn axes(track: &Track) -> ([f64; 2], [f64; 2]) {
    let d = track.direction;
    let n = d[0].hypot(d[1]).max(1e-12);
    let u = [d[0] / n, d[1] / n];
    (u, [-u[1], u[0]])
}

/// An offset across the track as a signed distance along [`axes`]' second.
fn signed_across(track: &Track, offset: [f64; 3]) -> f64 {
    let (_, v) = axes(track);
    offset[0] * v[0] + offset[1] * v[1]
}

/// How the emulator advances time.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Clock {
    /// In real time, in steps of [`STEP_S`].
    Real,
    /// One millisecond per batch of torque frames read together (one
    /// frame, for a host that waits for each reply), whatever the time:
    /// two hosts that send the same bytes read the same angles back, and
    /// a host that sends on at its rate while the emulator is not
    /// scheduled has the physics wait for it, as it waits while the host
    /// stalls.
    Lockstep,
}

/// How long the port stays away in a replug ([`Faults::replug`]), s:
/// longer than the host's lost-link time (0.1 s), so the trial under way
/// is lost, as with a cable pulled and put back.
pub const REPLUG_GAP_S: f64 = 0.5;

/// Faults the emulated board shows when asked, for tests (the shell sets
/// them on SIGUSR1 and SIGUSR2); each is cleared as it is shown.
#[derive(Debug, Clone, Default)]
pub struct Faults {
    /// The board loses its setup (it restarted: its port goes away for
    /// [`REPLUG_GAP_S`], the handle stays where it is, and torque frames
    /// are answered with the id alone); or, while it is
    /// not set up, the handle is put at its calibration pose (as the
    /// experimenter is asked to).
    pub lose_setup: Arc<AtomicBool>,
    /// The port goes away for [`REPLUG_GAP_S`] and comes back with the
    /// board still set up.
    pub replug: Arc<AtomicBool>,
}

/// Why [`serve`] returned without an error: a fault to show.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Served {
    /// The board is to restart, losing its setup ([`BoardCore::lose_setup`];
    /// its port goes away for [`REPLUG_GAP_S`]), or, not set up, its
    /// handle is to be put at its calibration pose ([`BoardCore::park`],
    /// on the same port); then it is served again.
    LoseSetup,
    /// The port is to go away for [`REPLUG_GAP_S`] and be served again,
    /// the board as it is.
    Replug,
}

/// Runs `core` on `port` until the port fails or `faults` asks for one:
/// each frame answered at once, the physics advanced by `clock`, the hand
/// following the newest drive on `hand`. Each frame and reply is handed to
/// `log`.
///
/// # Errors
/// An I/O error on the port.
pub fn serve(
    port: &mut (impl Read + Write),
    core: &mut BoardCore,
    clock: Clock,
    hand: Option<&hand_link::Receiver>,
    faults: &Faults,
    mut log: impl FnMut(bool, &[u8]),
) -> std::io::Result<Served> {
    // A device keeps its own time: at real-time priority where allowed
    // (crate::device::realtime; issue 63).
    let _ = crate::device::realtime::ask_fifo(); // granted or not, it serves
    let mut input = [0_u8; 512];
    let mut reply = Vec::with_capacity(512);
    let start = Instant::now();
    let mut steps = 0_u64;
    // Whether the bytes read since time last moved on brought a torque
    // frame.
    let mut torque_frames = false;
    loop {
        if faults.replug.swap(false, Ordering::Relaxed) {
            return Ok(Served::Replug);
        }
        if faults.lose_setup.swap(false, Ordering::Relaxed) {
            return Ok(Served::LoseSetup);
        }
        let n = match port.read(&mut input) {
            Ok(n) => n,
            Err(e) if is_busy(&e) => 0,
            Err(e) => return Err(e),
        };
        if let Some(d) = hand.and_then(hand_link::Receiver::latest) {
            core.drive(d);
        }
        reply.clear();
        core.receive(&input[..n], &mut reply, &mut |from_host, bytes| {
            if from_host && bytes.first() == Some(&2) {
                torque_frames = true;
            }
            log(from_host, bytes);
        });
        if !reply.is_empty() {
            match port.write_all(&reply) {
                Ok(()) => {}
                Err(e) if is_busy(&e) => {}
                Err(e) => return Err(e),
            }
        }
        if n == input.len() {
            continue; // more waiting: read it before time moves on
        }
        match clock {
            // One host period per batch of reads that brought torque
            // frames, however many: frames that arrived together were sent
            // without news of the board between them (the emulator was not
            // running), so physics waits for the emulator as it waits for
            // the host, and the loop's delay in physics time is at most two
            // periods whatever the scheduling.
            Clock::Lockstep if torque_frames => {
                for _ in 0..LOCKSTEP_STEPS {
                    core.step(STEP_S);
                }
            }
            Clock::Lockstep => {}
            Clock::Real => {
                #[expect(
                    clippy::cast_possible_truncation,
                    clippy::cast_sign_loss,
                    reason = "elapsed steps"
                )]
                let due = (start.elapsed().as_secs_f64() / STEP_S) as u64;
                // After a stall, no burst of catch-up: at most 0.1 s.
                steps = steps.max(due.saturating_sub(200));
                while steps < due {
                    core.step(STEP_S);
                    steps += 1;
                }
                if n == 0 {
                    std::thread::sleep(Duration::from_micros(100));
                }
            }
        }
        torque_frames = false;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn setup_core() -> (BoardCore, Wiring) {
        let config = Config::vendor(3);
        let mut core = BoardCore::new(&config);
        let w = config.wiring;
        let mut out = Vec::new();
        core.receive(&w.reset(), &mut out, &mut |_, _| {});
        core.receive(&w.setup(), &mut out, &mut |_, _| {});
        assert!(out.is_empty(), "reset and setup are not answered");
        (core, w)
    }

    /// At power-up the board reads the calibration angles the firmware
    /// preloads: 168° and 12° as whole counts of 4880 per turn.
    #[test]
    fn the_board_reads_its_calibration_pose_as_the_firmware_counts_it() {
        let (mut core, w) = setup_core();
        let mut out = Vec::new();
        core.receive(&w.torques([0.0, 0.0]), &mut out, &mut |_, _| {});
        assert_eq!(out.len(), 9, "{out:?}");
        let a = w.angles(&out.try_into().unwrap());
        #[expect(clippy::cast_possible_truncation, reason = "the firmware's float")]
        let whole =
            |deg: f64| f64::from((360.0 * (deg * 4880.0_f64 / 360.0).trunc() / 4880.0) as f32);
        assert_eq!(a, [whole(168.0), whole(12.0)]);
    }

    /// A frame split anywhere is handled once it is whole; a torque frame
    /// before setup is answered with the id alone, as the firmware does.
    #[test]
    fn frames_are_taken_whole_however_they_arrive() {
        let config = Config::vendor(3);
        let mut core = BoardCore::new(&config);
        let mut out = Vec::new();
        core.receive(&[2, 5], &mut out, &mut |_, _| {});
        assert_eq!(out, [5]);
        let (mut core, w) = setup_core();
        let frame = w.torques([0.01, 0.02]);
        out.clear();
        core.receive(&frame[..3], &mut out, &mut |_, _| {});
        assert!(out.is_empty());
        core.receive(&frame[3..], &mut out, &mut |_, _| {});
        assert_eq!(out.len(), 9);
    }

    /// Torques beyond the firmware's 0.123 N m are applied at 0.123.
    #[test]
    fn the_firmware_clamps_torque_and_sets_it_in_twelve_bits() {
        assert_eq!(applied(0.5), MAX_TORQUE_N_M);
        assert_eq!(applied(-0.5), -MAX_TORQUE_N_M);
        assert!((applied(0.05) - 0.05).abs() <= MAX_TORQUE_N_M / 4095.0);
        assert_eq!(applied(f64::NAN), 0.0);
    }

    /// Issue 63: a reset (or a board that lost its setup) leaves the handle
    /// where it is, as a real board does: set up again there, the board
    /// counts from that pose, reading its calibration angles; not set up,
    /// it answers a torque frame with its id alone.
    #[test]
    fn a_reset_leaves_the_handle_where_it_is() {
        let (mut core, w) = setup_core();
        let calibration = core.position();
        for _ in 0..4000 {
            core.step(STEP_S); // the hand carries it off, towards the track
        }
        let moved = core.position();
        assert!((moved[1] - calibration[1]).abs() > 0.01, "{moved:?}");
        let mut out = Vec::new();
        core.receive(&w.reset(), &mut out, &mut |_, _| {});
        assert_eq!(core.position(), moved, "the reset moved nothing");
        core.receive(&w.torques([0.0; 2]), &mut out, &mut |_, _| {});
        assert_eq!(out, [5], "not set up: the id alone");
        core.receive(&w.setup(), &mut out, &mut |_, _| {});
        out.clear();
        core.receive(&w.torques([0.0; 2]), &mut out, &mut |_, _| {});
        let read = w.angles(&out.clone().try_into().unwrap());
        let (mut first, _) = setup_core();
        let mut at_calibration = Vec::new();
        first.receive(&w.torques([0.0; 2]), &mut at_calibration, &mut |_, _| {});
        assert_eq!(
            read,
            w.angles(&at_calibration.try_into().unwrap()),
            "counted from where the handle was at setup, as if it were the calibration pose"
        );
        core.lose_setup();
        out.clear();
        core.receive(&w.torques([0.0; 2]), &mut out, &mut |_, _| {});
        assert_eq!(
            (out.as_slice(), core.position()),
            ([5_u8].as_slice(), moved)
        );
    }

    /// With no torque, the hand carries the end effector from the
    /// calibration pose to where it rests across the track.
    #[test]
    fn the_hand_brings_the_end_effector_to_its_rest_by_the_track() {
        let (mut core, _) = setup_core();
        for _ in 0..4000 {
            core.step(STEP_S);
        }
        let track = Config::vendor(3).track;
        let p = core.position();
        let (_, off) = track.split([p[0], p[1], 0.0]);
        assert!((off[1] - HAND_ACROSS_REST_M).abs() < 1e-4, "{p:?} {off:?}");
    }
}
