//! The Haply 2DIY: a 2-DOF pantograph on a board that speaks the vendor's
//! open host protocol ([`protocol`]) over USB serial. Its kinematics are
//! the vendor's ([`pantograph`]); [`emulator`] is a board we ship for tests
//! and for trying without hardware.
//!
//! [`Haply2Diy`] is the backend: it resets and sets the board up when the
//! port first opens, sends one torque frame per loop tick and reads the
//! angles each one is answered with. Forces become torques through the
//! Jacobian at the last angles read (`τ = Jᵀ f`), scaled down as a whole
//! when either is beyond the firmware's limit ([`MAX_TORQUE_N_M`]), so no
//! torque the board would clamp is ever sent; until angles have come back,
//! the torques are zero.
//!
//! # The board's setup
//! The board counts its encoders from where the handle is when it is set
//! up, so the driver sets it up only where the pose it counts from is
//! known:
//! - at first contact (no angles read yet), at once: the experimenter put
//!   the handle at its calibration pose before starting, as with the
//!   vendor's software (docs/guide/devices.md). A board that answers with
//!   its id alone there did not take the setup (it was still starting): it
//!   is set up again every [`SETUP_RETRY_S`], and after [`SETUP_TRIES`]
//!   the port is reported as a 2DIY that does not take its setup;
//! - after the port reopens (a hiccup, a replug), not at all: a board that
//!   kept its setup answers with angles and goes on from its count;
//! - a board that answers with its id alone once angles have been read
//!   ([`BARE_ANSWERS`] in a row: it lost its setup, powered down or reset)
//!   is asked for ([`Request::CalibrationPose`]): its link is lost, and it
//!   is set up again only when the experimenter confirms the handle is at
//!   its calibration pose ([`Backend::confirm`]).
//!
//! # Which answers are a 2DIY's
//! A reply is taken only where the board can have sent it
//! ([`Haply2Diy::plausible`]): each joint within half a turn of its
//! calibration angle with the linkage closed (a pose it reaches), and each
//! joint no further from the last reply
//! taken than [`MAX_JOINT_RATE_DEG_S`] turns it in the time between the
//! frames they answer. Whatever is not taken is dropped, and a port whose
//! bytes are mostly dropped over a recent window
//! ([`protocol::Replies::mostly_dropped`]) is not a 2DIY, at any time
//! ([`Reading::problem`]).
//!
//! Never run on a 2DIY here: it is written from the vendor's client and
//! firmware and tested against the vendor's client on the emulator.

pub mod emulator;
pub mod pantograph;
pub mod protocol;

use std::collections::VecDeque;
use std::path::Path;

use self::pantograph::{Links, Pose};
use self::protocol::{Answer, Replies, Wiring};
use super::backend::{Backend, Capabilities, LinkState, LinkStats, Reading, Request, Vector};
use super::track::Track;
use super::transport::Transport;
use crate::hand::HandDrive;

/// The firmware's torque limit, N m (`MAX_TORQUE 0.123 //Nm`).
pub const MAX_TORQUE_N_M: f64 = 0.123;

/// No reply for this long: the link is lost, s (as for our own board).
pub const LOST_AFTER_S: f64 = 0.100;

/// After the port (re)opens and the board is set up, replies are ignored
/// for this long, s: bytes a board sent an earlier host may still be on
/// their way (the board answers each torque frame, and says nothing else).
pub const SETTLE_S: f64 = 0.020;

/// Bare answers (the board's id alone) in a row that say the board is not
/// set up: a reply's bytes are never the id nine times over, so even a few
/// are no accident; 8 is 8 ms at 1 kHz.
pub const BARE_ANSWERS: u32 = 8;

/// At first contact, a board that answers with its id alone is set up
/// again this often, s (a board still starting when the first setup came).
pub const SETUP_RETRY_S: f64 = 0.5;

/// ... and after this many setups without angles, the port is reported as
/// a 2DIY that does not take its setup.
pub const SETUP_TRIES: u32 = 3;

/// The fastest a 2DIY's joint turns, degrees per second: 200 rad/s. A hand
/// at 3 m/s (faster than people move a stylus, 1-2 m/s at their fastest)
/// turns the joint with the least leverage in the vendor v3's workspace 35
/// rad per metre (at (0.07, 0.14) m; 15 rad per metre at the track's
/// centre): about 105 rad/s, doubled.
pub const MAX_JOINT_RATE_DEG_S: f64 = 200.0 * 180.0 / std::f64::consts::PI;

/// What a joint's reading may differ by beyond [`MAX_JOINT_RATE_DEG_S`],
/// degrees: far more than an encoder count (0.074° at 4880 counts per
/// turn) and the wire's float.
pub const ANGLE_TOLERANCE_DEG: f64 = 1.0;

/// How far a joint turns from its calibration angle at most, degrees: half
/// a turn (a proximal link further round would pass through the base or
/// the other link).
pub const MAX_TURN_DEG: f64 = 180.0;

/// Torque frames whose send times are kept until their answers come.
const SENT_KEPT: usize = 64;

/// The loop rate the vendor's examples run the board at, Hz.
pub const RATE_HZ: f64 = 1000.0;

/// The device kind, as listed in [`super::KINDS`].
pub const KIND: super::Kind = super::Kind {
    name: "haply2diy",
    about: "Haply 2DIY (2-DOF pantograph) on a serial port, or `frictionlab device-emulator haply2diy:PATH`",
    target: "PATH",
    bare: false,
    check,
    check_settings: |set| Config::with(set).map(|_| ()),
    open,
    find,
};

fn check(target: &str) -> Result<(), String> {
    if target.is_empty() {
        return Err("needs the board's serial port: haply2diy:PATH".into());
    }
    super::check_port(Path::new(target))
}

fn open(target: &str, settings: &super::Settings) -> Result<Box<dyn Backend>, String> {
    check(target)?;
    let config = Config::with(&settings.set)?;
    Ok(Box::new(Haply2Diy::new(Path::new(target), config)))
}

/// Serial ports that may be a 2DIY: Arduino Due-class boards (the M3
/// board's SAM3X, USB vendor 2341) and every port whose kind is not known.
fn find() -> Vec<super::Found> {
    super::list_ports()
        .unwrap_or_default()
        .into_iter()
        .filter(|p| p.kind.starts_with("usb 2341:") || p.kind == "unknown")
        .map(|p| super::Found {
            address: p.path,
            what: p.kind,
        })
        .collect()
}

/// A 2DIY's settings: the vendor's values by default, each overridable
/// with `--device-set NAME=VALUE`.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Config {
    /// Hardware version: 3 (the plastic 2DIY) or 2 (the metal one); picks
    /// the vendor's wiring and link lengths, which the other settings then
    /// override.
    pub version: u8,
    /// Ports, directions and encoder calibration.
    pub wiring: Wiring,
    /// Link lengths.
    pub links: Links,
    /// The track friction is rendered along, and the wall that holds the
    /// hand on it. Default: along x through (d/2, 0.10) m, the middle of
    /// the workspace 10 cm out from the motors; the wall 1000 N/m and
    /// 2 N s/m (our choice: about the stiffness the vendor's wall examples
    /// use, and stable at 1 kHz with the linkage and a hand).
    pub track: Track,
}

impl Config {
    /// The vendor's values for hardware `version`.
    #[must_use]
    pub fn vendor(version: u8) -> Self {
        let links = Links::vendor(version);
        Config {
            version,
            wiring: Wiring::vendor(version),
            links,
            track: Track {
                origin_m: [links.d / 2.0, 0.10, 0.0],
                direction: [1.0, 0.0, 0.0],
                wall_stiffness_n_m: 2000.0,
                wall_damping_n_s_m: 5.0,
            },
        }
    }

    /// The vendor's values for the `version` the settings name (default 3),
    /// with the settings applied.
    ///
    /// # Errors
    /// One line naming each setting that is wrong.
    pub fn with(set: &[String]) -> Result<Self, String> {
        let mut pairs = Vec::new();
        for s in set {
            let (name, value) = crate::settings::split_setting(s).map_err(|p| p.to_string())?;
            pairs.push((name, value));
        }
        let version = match pairs.iter().find(|(n, _)| *n == "version") {
            Some((_, v)) => match *v {
                "2" => 2,
                "3" => 3,
                _ => return Err(format!("version: expected 2 or 3, got '{v}'")),
            },
            None => 3,
        };
        let config: Config =
            crate::settings::apply(&Config::vendor(version), "", "haply2diy", &pairs).map_err(
                |problems| {
                    problems
                        .iter()
                        .map(ToString::to_string)
                        .collect::<Vec<_>>()
                        .join("; ")
                },
            )?;
        if let Some(p) = config.wiring.problem().or_else(|| config.track.problem()) {
            return Err(p);
        }
        if config.track.direction[2] != 0.0 || config.track.origin_m[2] != 0.0 {
            return Err("the 2DIY is planar: the track's z must be 0".into());
        }
        Ok(config)
    }

    /// The pose at the track's origin, if the linkage reaches it.
    #[must_use]
    pub fn origin_pose(&self) -> Option<Pose> {
        let o = self.track.origin_m;
        pantograph::inverse(&self.links, o[0], o[1]).map(|a| pantograph::forward(&self.links, a))
    }

    /// The largest force that needs no torque beyond the firmware's limit,
    /// whatever its direction, at the point `along_m` from the track's
    /// origin, N; None where the linkage does not reach.
    #[must_use]
    pub fn force_limit_at(&self, along_m: f64) -> Option<f64> {
        let (o, d) = (self.track.origin_m, self.track.direction);
        let n = d[0].hypot(d[1]);
        let (x, y) = (o[0] + along_m * d[0] / n, o[1] + along_m * d[1] / n);
        pantograph::inverse(&self.links, x, y).map(|a| {
            let [j11, j12, j21, j22] = pantograph::forward(&self.links, a).j;
            MAX_TORQUE_N_M / j11.hypot(j12).max(j21.hypot(j22))
        })
    }

    /// The stretch of the track the 2DIY is stated to reach, m from its
    /// origin (lowest, highest), and the force limit over it, N: from the
    /// origin outwards in steps of [`TRAVEL_STEP_M`], as far as the
    /// linkage reaches with a force limit (in every direction, within
    /// the firmware's torque) of at least [`TRAVEL_FORCE_SHARE`] of the
    /// origin's; the limit is the smallest over that stretch, so it holds
    /// everywhere on it. Our choice: the vendor states no workspace for
    /// the 2DIY in the documents read, and the force limit falls towards
    /// the linkage's singular edges. The vendor's v3 on the default track:
    /// about ±76 mm, 1.717 N. Zero travel and 0 N where the linkage does
    /// not reach the origin.
    #[must_use]
    pub fn reach(&self) -> ([f64; 2], f64) {
        let Some(at_origin) = self.force_limit_at(0.0) else {
            return ([0.0; 2], 0.0);
        };
        let mut limit = at_origin;
        let mut travel = [0.0; 2];
        for (side, sign) in [(0, -1.0), (1, 1.0)] {
            for k in 1..=MAX_TRAVEL_STEPS {
                let along = sign * f64::from(k) * TRAVEL_STEP_M;
                match self.force_limit_at(along) {
                    Some(l) if l >= TRAVEL_FORCE_SHARE * at_origin => {
                        limit = limit.min(l);
                        travel[side] = along;
                    }
                    _ => break,
                }
            }
        }
        (travel, limit)
    }

    /// The force limit over the stated travel ([`Config::reach`]), N.
    #[must_use]
    pub fn force_limit_n(&self) -> f64 {
        self.reach().1
    }
}

/// The step of the search for a 2DIY's travel ([`Config::reach`]), m.
pub const TRAVEL_STEP_M: f64 = 0.0005;

/// How far that search goes each way, in steps (0.2 m, beyond any 2DIY's
/// reach).
const MAX_TRAVEL_STEPS: u32 = 400;

/// Along its stated travel a 2DIY renders at least this share of the force
/// it can render at the track's origin ([`Config::reach`]; our choice).
pub const TRAVEL_FORCE_SHARE: f64 = 0.99;

/// A 2DIY on a serial port.
pub struct Haply2Diy {
    config: Config,
    force_limit_n: f64,
    travel_m: [f64; 2],
    transport: Transport,
    opens: u64,
    replies: Replies,
    pose: Option<Pose>,
    /// The last angles read, degrees, and how many replies so far.
    angles: Option<[f64; 2]>,
    replies_read: u64,
    last_reply_s: Option<f64>,
    /// Replies are ignored until then (bytes in flight when the port
    /// opened or the board was set up).
    settle_until_s: f64,
    /// When the board was last set up, and setup frames sent.
    setup_s: f64,
    setups: u32,
    /// The angles the next reply is judged against, and the time the
    /// frame they answered was sent (the calibration angles at setup).
    reference: Option<([f64; 2], f64)>,
    /// When each torque frame not yet answered was sent, oldest first.
    sent: VecDeque<f64>,
    /// Bare answers in a row, and whether there were [`BARE_ANSWERS`]
    /// since the last reply.
    bare: u32,
    not_set_up: bool,
    /// The board lost its setup: the experimenter is asked to put the
    /// handle at its calibration pose.
    awaiting_pose: bool,
    link: LinkState,
    hand: super::hand_link::Sender,
    bytes: [u8; 256],
}

impl std::fmt::Debug for Haply2Diy {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Haply2Diy")
            .field("transport", &self.transport)
            .finish_non_exhaustive()
    }
}

impl Haply2Diy {
    /// The board at `path` (opened on the first tick, reopened after).
    #[must_use]
    pub fn new(path: &Path, config: Config) -> Self {
        let (travel_m, force_limit_n) = config.reach();
        Haply2Diy {
            force_limit_n,
            travel_m,
            config,
            transport: Transport::new(path),
            opens: 0,
            replies: Replies::default(),
            pose: None,
            angles: None,
            replies_read: 0,
            last_reply_s: None,
            settle_until_s: 0.0,
            setup_s: f64::NEG_INFINITY,
            setups: 0,
            reference: None,
            sent: VecDeque::with_capacity(SENT_KEPT),
            bare: 0,
            not_set_up: false,
            awaiting_pose: false,
            link: LinkState::Connecting,
            hand: super::hand_link::Sender::new(path),
            bytes: [0; 256],
        }
    }

    /// What is wrong with what the port sends: mostly bytes that are no
    /// 2DIY's (at any time), or, before any angles, the id alone after
    /// every setup.
    fn problem(&self) -> Option<&'static str> {
        if self.replies.mostly_dropped() {
            Some("answers with bytes that are not a 2DIY's replies (another device on this port?)")
        } else if self.replies_read == 0 && self.not_set_up && self.setups >= SETUP_TRIES {
            Some("answers each torque frame with its id alone: a 2DIY that does not take its setup")
        } else {
            None
        }
    }

    /// Resets and sets the board up: it counts its encoders from here, and
    /// replies are judged from its calibration angles.
    fn set_up(&mut self, now_s: f64) {
        self.transport.write(&self.config.wiring.reset());
        self.transport.write(&self.config.wiring.setup());
        self.setup_s = now_s;
        self.setups += 1;
        self.settle_until_s = now_s + SETTLE_S;
        self.bare = 0;
        self.pose = None;
        self.last_reply_s = None;
        self.sent.clear();
        let e = self.config.wiring.encoders;
        self.reference = Some(([e[0].offset_deg, e[1].offset_deg], now_s));
    }

    /// Whether the board can have sent `angles` in answer to a frame sent
    /// after the reference's, as read at `now_s`: each joint within
    /// [`MAX_TURN_DEG`] of its calibration angle, the linkage closed there
    /// (a finite end effector), and each joint within
    /// [`MAX_JOINT_RATE_DEG_S`] of the reference over the time since its
    /// frame was sent (plus [`ANGLE_TOLERANCE_DEG`]). A reply read at `now_s` was sent before
    /// then, and the reference's after its frame: so the time between
    /// them is at most `now_s` less that frame's send time, however the
    /// link and the loop were delayed.
    #[must_use]
    pub fn plausible(&self, angles: [f64; 2], now_s: f64) -> bool {
        let e = self.config.wiring.encoders;
        let reach = (0..2).all(|i| (angles[i] - e[i].offset_deg).abs() <= MAX_TURN_DEG);
        let pose = pantograph::forward(&self.config.links, angles);
        let closed = pose.x_m.is_finite() && pose.y_m.is_finite();
        let moved = self.reference.is_none_or(|(before, sent_s)| {
            let most = MAX_JOINT_RATE_DEG_S * (now_s - sent_s).max(0.0) + ANGLE_TOLERANCE_DEG;
            (0..2).all(|i| (angles[i] - before[i]).abs() <= most)
        });
        reach && closed && moved
    }

    /// The last joint angles read, degrees (joints 1 and 2), and how many
    /// replies have been read.
    #[must_use]
    pub fn angles(&self) -> (Option<[f64; 2]>, u64) {
        (self.angles, self.replies_read)
    }

    /// The joint torques for force `f` at the last angles read: zero before
    /// any, scaled down as a whole to the firmware's limit, zero if not
    /// finite.
    #[must_use]
    pub fn torques_for(&self, f: Vector) -> [f64; 2] {
        let Some(pose) = self.pose else {
            return [0.0; 2];
        };
        let tau = pose.torques(f[0], f[1]);
        if !tau.iter().all(|t| t.is_finite()) {
            return [0.0; 2];
        }
        let largest = tau[0].abs().max(tau[1].abs());
        if largest > MAX_TORQUE_N_M {
            tau.map(|t| t * MAX_TORQUE_N_M / largest)
        } else {
            tau
        }
    }
}

impl Backend for Haply2Diy {
    fn capabilities(&self) -> Capabilities {
        Capabilities {
            axes: 2,
            vertical_axis: None,
            force_limit_n: self.force_limit_n,
            travel_m: self.travel_m,
            max_rate_hz: RATE_HZ,
            on_board: false,
        }
    }

    fn read(&mut self, now_s: f64) -> Reading {
        let n = self.transport.read(&mut self.bytes);
        if self.transport.opens() != self.opens {
            // A port (re)opened. Before any angles the board is set up (the
            // handle is where the experimenter put it); after, it is left
            // as it is: its answers say whether it kept its setup.
            self.opens = self.transport.opens();
            self.settle_until_s = now_s + SETTLE_S;
            self.pose = None;
            self.last_reply_s = None;
            self.sent.clear();
            if self.replies_read == 0 {
                self.set_up(now_s);
            }
        }
        if now_s < self.settle_until_s {
            self.replies.clear();
            return Reading {
                link: LinkState::Connecting,
                position_m: [0.0; 3],
                button: false,
                watchdog: false,
                problem: self.problem(),
            };
        }
        let (mut replies, wiring, bytes) = (
            std::mem::take(&mut self.replies),
            self.config.wiring,
            self.bytes,
        );
        replies.feed(&wiring, &bytes[..n], |answer| {
            // The send time of the frame this answers. With none kept (more
            // answers than frames noted: frames sent before a setup or a
            // reopen), the reference's: a time no later than the truth, so
            // a reply is never judged over less time than it had.
            let sent_s = self
                .sent
                .front()
                .copied()
                .or(self.reference.map(|(_, t)| t))
                .unwrap_or(now_s);
            match answer {
                Answer::Bare => {
                    // Not set up: no torque from now on (an unset board
                    // reads a torque frame's floats as frames of their
                    // own, a setup among them).
                    self.sent.pop_front();
                    self.bare = self.bare.saturating_add(1);
                    self.pose = None;
                    true
                }
                // A board that lost its setup is set up again only on the
                // experimenter's word: what it says until then is not
                // counted from a known pose.
                Answer::Angles(_) if self.awaiting_pose => {
                    self.sent.pop_front();
                    true
                }
                Answer::Angles(angles) if self.plausible(angles, now_s) => {
                    self.sent.pop_front();
                    self.pose = Some(pantograph::forward(&self.config.links, angles));
                    self.reference = Some((angles, sent_s));
                    self.last_reply_s = Some(now_s);
                    self.angles = Some(angles);
                    self.replies_read += 1;
                    self.bare = 0;
                    self.not_set_up = false;
                    true
                }
                Answer::Angles(_) => false,
            }
        });
        self.replies = replies;
        if self.bare >= BARE_ANSWERS && !self.awaiting_pose {
            self.not_set_up = true;
            if self.replies_read == 0 {
                if now_s - self.setup_s >= SETUP_RETRY_S {
                    self.set_up(now_s);
                }
            } else {
                self.awaiting_pose = true;
                self.pose = None;
            }
        }
        self.link = match self.last_reply_s {
            _ if self.awaiting_pose => LinkState::Lost,
            None => LinkState::Connecting,
            Some(t) if now_s - t <= LOST_AFTER_S => LinkState::Connected,
            Some(_) => LinkState::Lost,
        };
        let p = self.pose.map_or([0.0; 3], |p| [p.x_m, p.y_m, 0.0]);
        Reading {
            link: self.link,
            position_m: p,
            button: false,
            watchdog: false,
            problem: self.problem(),
        }
    }

    fn send_force(&mut self, now_s: f64, force_n: Vector, _vibration: f64) {
        let tau = if self.link == LinkState::Lost {
            [0.0; 2]
        } else {
            self.torques_for(force_n)
        };
        self.transport.write(&self.config.wiring.torques(tau));
        if self.sent.len() < SENT_KEPT {
            // Full: the oldest are kept, so a reply is judged over at
            // least the time since its frame was sent.
            self.sent.push_back(now_s);
        }
    }

    fn close(&mut self) {
        self.transport.write(&self.config.wiring.torques([0.0; 2]));
    }

    fn drive_hand(&mut self, drive: &HandDrive) {
        self.hand.send(drive);
    }

    fn track(&self) -> Track {
        self.config.track
    }

    fn settings(&self) -> Option<serde_json::Value> {
        serde_json::to_value(self.config).ok()
    }

    fn stats(&self) -> LinkStats {
        LinkStats {
            resyncs: self.replies.dropped,
            ..LinkStats::default()
        }
    }

    fn request(&self) -> Option<Request> {
        self.awaiting_pose.then_some(Request::CalibrationPose)
    }

    fn confirm(&mut self, now_s: f64) {
        if self.awaiting_pose {
            self.awaiting_pose = false;
            self.not_set_up = false;
            self.set_up(now_s);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The force limit holds along the whole stated travel: at every
    /// point of it a force of the limit in any direction needs no torque
    /// beyond the firmware's (issue 63: the records state this limit).
    #[test]
    fn the_default_track_is_in_reach_and_its_force_limit_keeps_torques_within_the_firmwares() {
        let c = Config::vendor(3);
        let ([lo, hi], limit) = c.reach();
        assert!(limit > 0.5 && limit < 5.0, "{limit}");
        assert!(lo < -0.05 && hi > 0.05, "{lo} .. {hi}");
        let mut along = lo;
        while along <= hi {
            let o = c.track.origin_m;
            let a = pantograph::inverse(&c.links, o[0] + along, o[1]).unwrap();
            let pose = pantograph::forward(&c.links, a);
            for k in 0..36 {
                let a = f64::from(k) * 10_f64.to_radians();
                let t = pose.torques(limit * a.cos(), limit * a.sin());
                assert!(
                    t[0].abs().max(t[1].abs()) <= MAX_TORQUE_N_M * (1.0 + 1e-12),
                    "at {along} m"
                );
            }
            along += TRAVEL_STEP_M;
        }
        // One step further the linkage renders less.
        assert!(
            c.force_limit_at(hi + TRAVEL_STEP_M)
                .is_none_or(|l| l < limit / TRAVEL_FORCE_SHARE)
        );
    }

    #[test]
    fn settings_override_the_vendors_values_and_bad_ones_are_named() {
        let c = Config::with(&["version=2".into(), "wall_stiffness_n_m=500".into()]).unwrap();
        assert_eq!(c.wiring.encoders[0].offset_deg, 241.0);
        assert_eq!(c.track.wall_stiffness_n_m, 500.0);
        let c = Config::with(&["track.origin_m=[0.0, 0.12, 0]".into()]).unwrap();
        assert_eq!(c.track.origin_m, [0.0, 0.12, 0.0]);
        assert!(
            Config::with(&["version=4".into()])
                .unwrap_err()
                .contains("version")
        );
        assert!(
            Config::with(&["nonsense=1".into()])
                .unwrap_err()
                .contains("nonsense")
        );
        assert!(
            Config::with(&["wall_damping_n_s_m=-1".into()])
                .unwrap_err()
                .contains("at least 0")
        );
    }

    /// Issue 63: a reply is taken only where the board can have sent it:
    /// joints that turned no faster than a hand turns them since the frame
    /// before, within half a turn of the calibration angles.
    #[test]
    fn replies_the_board_cannot_have_sent_are_not_taken() {
        let mut b = Haply2Diy::new(Path::new("/nonexistent"), Config::vendor(3));
        b.reference = Some(([168.0, 12.0], 0.0));
        assert!(b.plausible([168.05, 11.98], 0.001), "an encoder count on");
        // The track's centre is (139°, 41°) from the calibration pose:
        // 29° is 2.5 ms at the fastest a hand turns a joint.
        assert!(!b.plausible([139.1, 40.9], 0.001));
        assert!(b.plausible([139.1, 40.9], 0.003));
        assert!(!b.plausible([0.0, 0.0], 0.001), "a bare id read as angles");
        b.reference = None;
        assert!(b.plausible([139.1, 40.9], 0.0));
        assert!(
            !b.plausible([168.0 + 190.0, 12.0], 0.0),
            "beyond half a turn"
        );
        assert!(
            !b.plausible([168.0, 12.0 - 181.0], 0.0),
            "beyond half a turn"
        );
    }

    #[test]
    fn torques_are_zero_before_angles_and_scaled_to_the_limit_after() {
        let mut b = Haply2Diy::new(Path::new("/nonexistent"), Config::vendor(3));
        assert_eq!(b.torques_for([1.0, 1.0, 0.0]), [0.0; 2]);
        b.pose = b.config.origin_pose();
        let t = b.torques_for([50.0, 0.0, 0.0]);
        assert!((t[0].abs().max(t[1].abs()) - MAX_TORQUE_N_M).abs() < 1e-15);
        let want = b.pose.unwrap().torques(50.0, 0.0);
        assert!(
            (t[0] / t[1] - want[0] / want[1]).abs() < 1e-12,
            "direction kept"
        );
        assert_eq!(b.torques_for([f64::NAN, 0.0, 0.0]), [0.0; 2]);
    }
}
