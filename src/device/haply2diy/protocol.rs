//! The 2DIY's host protocol, as the vendor's client `HaplyHAPI.py` 1.0.1
//! speaks it and the board's firmware (`Haply_M3_Firmware_V1_5`) reads it.
//! Pure: bytes in, bytes out.
//!
//! Host to board: `[type u8][device id u8][bytes...][f32 little-endian...]`,
//! no length, no checksum:
//! - type 0, reset: `00 00` (the vendor's client always sends id 0);
//! - type 1, setup: `01 id`, the motor block `[mask][direction per port in
//!   use, ascending]`, the encoder block likewise, `00` (no analog
//!   sensors), `00` (no PWM pins), then per encoder port in use, ascending:
//!   `f32 offset (degrees)`, `f32 resolution (counts per revolution)`.
//!   Mask bit `k` is port `k + 1`. No reply;
//! - type 2, torques: `02 id`, then per motor port in use, ascending, `f32`
//!   torque, N m. Reply: `[id][f32 angle, degrees, per encoder port in use,
//!   ascending]`.

/// Ports on the board.
pub const PORTS: usize = 4;

/// Direction bytes (`CW`, `CCW` in the vendor's code).
pub const CW: u8 = 0;
/// See [`CW`].
pub const CCW: u8 = 1;

/// A motor: its port (1 to 4) and direction byte.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Motor {
    /// Port, 1 to 4.
    pub port: u8,
    /// [`CW`] or [`CCW`].
    pub direction: u8,
}

/// An encoder: its port, direction, the angle it reads at power-up and
/// its counts per revolution.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Encoder {
    /// Port, 1 to 4.
    pub port: u8,
    /// [`CW`] or [`CCW`].
    pub direction: u8,
    /// Angle at the calibration pose, degrees.
    pub offset_deg: f64,
    /// Counts per revolution.
    pub resolution: f64,
}

/// How a 2DIY's two motors and encoders are wired: motor and encoder 1 are
/// the joint at the origin (θ1), 2 the one at `x = d` (θ2).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Wiring {
    /// The board's device id (the vendor's example: 5).
    pub device_id: u8,
    /// Motors 1 and 2.
    pub motors: [Motor; 2],
    /// Encoders 1 and 2.
    pub encoders: [Encoder; 2],
}

impl Wiring {
    /// The vendor's values for hardware `version` (the client's README
    /// example): v3 (plastic) motors and encoders 1 on port 2 and 2 on
    /// port 1, both counter-clockwise, offsets 168° and 12°, 4880 counts;
    /// v2 (metal) offsets 241° and −61°, 10752 counts, joint 2 clockwise.
    #[must_use]
    pub fn vendor(version: u8) -> Self {
        let (dir2, offsets, resolution) = if version == 3 {
            (CCW, [168.0, 12.0], 4880.0)
        } else {
            (CW, [241.0, -61.0], 10752.0)
        };
        Wiring {
            device_id: 5,
            motors: [
                Motor {
                    port: 2,
                    direction: CCW,
                },
                Motor {
                    port: 1,
                    direction: dir2,
                },
            ],
            encoders: [
                Encoder {
                    port: 2,
                    direction: CCW,
                    offset_deg: offsets[0],
                    resolution,
                },
                Encoder {
                    port: 1,
                    direction: dir2,
                    offset_deg: offsets[1],
                    resolution,
                },
            ],
        }
    }

    /// What is wrong with this wiring, if anything: a port outside 1 to 4,
    /// two on one port, a direction not 0 or 1, a resolution not above 0.
    #[must_use]
    pub fn problem(&self) -> Option<String> {
        let ports = |p: [u8; 2], what: &str| {
            if p.iter().any(|&p| p == 0 || usize::from(p) > PORTS) {
                Some(format!("{what} ports must be 1 to {PORTS}"))
            } else if p[0] == p[1] {
                Some(format!("the two {what}s must be on different ports"))
            } else {
                None
            }
        };
        ports(self.motors.map(|m| m.port), "motor")
            .or_else(|| ports(self.encoders.map(|e| e.port), "encoder"))
            .or_else(|| {
                let dirs = self.motors.iter().map(|m| m.direction);
                let dirs = dirs.chain(self.encoders.iter().map(|e| e.direction));
                dirs.clone()
                    .any(|d| d > 1)
                    .then(|| "directions must be 0 (CW) or 1 (CCW)".to_owned())
            })
            .or_else(|| {
                self.encoders
                    .iter()
                    .any(|e| {
                        !(e.resolution > 0.0
                            && e.resolution.is_finite()
                            && e.offset_deg.is_finite())
                    })
                    .then(|| "encoder resolutions must be above 0, offsets finite".to_owned())
            })
    }

    /// Joint indices (0, 1) in port order (the wire's order).
    fn motor_order(&self) -> [usize; 2] {
        if self.motors[0].port < self.motors[1].port {
            [0, 1]
        } else {
            [1, 0]
        }
    }

    fn encoder_order(&self) -> [usize; 2] {
        if self.encoders[0].port < self.encoders[1].port {
            [0, 1]
        } else {
            [1, 0]
        }
    }

    /// The reset frame.
    #[must_use]
    pub fn reset(&self) -> [u8; 2] {
        [0, 0]
    }

    /// The setup frame.
    #[must_use]
    pub fn setup(&self) -> Vec<u8> {
        let mut out = vec![1, self.device_id];
        let (m, e) = (self.motor_order(), self.encoder_order());
        out.push(
            m.iter()
                .fold(0, |mask, &i| mask | 1 << (self.motors[i].port - 1)),
        );
        out.extend(m.iter().map(|&i| self.motors[i].direction));
        out.push(
            e.iter()
                .fold(0, |mask, &i| mask | 1 << (self.encoders[i].port - 1)),
        );
        out.extend(e.iter().map(|&i| self.encoders[i].direction));
        out.extend([0, 0]);
        for &i in &e {
            push_f32(&mut out, self.encoders[i].offset_deg);
            push_f32(&mut out, self.encoders[i].resolution);
        }
        out
    }

    /// The torque frame for motor torques `tau` (N m, joints 1 and 2).
    #[must_use]
    pub fn torques(&self, tau: [f64; 2]) -> [u8; TORQUE_FRAME] {
        let mut out = [0_u8; TORQUE_FRAME];
        out[0] = 2;
        out[1] = self.device_id;
        for (k, &i) in self.motor_order().iter().enumerate() {
            out[2 + 4 * k..6 + 4 * k].copy_from_slice(&f32_bytes(tau[i]));
        }
        out
    }

    /// The joint angles (degrees, joints 1 and 2) in a reply.
    #[must_use]
    pub fn angles(&self, reply: &[u8; REPLY]) -> [f64; 2] {
        let mut angles = [0.0; 2];
        for (k, &i) in self.encoder_order().iter().enumerate() {
            let b = [
                reply[1 + 4 * k],
                reply[2 + 4 * k],
                reply[3 + 4 * k],
                reply[4 + 4 * k],
            ];
            angles[i] = f64::from(f32::from_le_bytes(b));
        }
        angles
    }
}

/// Bytes of a torque frame with two motors.
pub const TORQUE_FRAME: usize = 10;

/// Bytes of a reply with two encoders.
pub const REPLY: usize = 9;

#[expect(clippy::cast_possible_truncation, reason = "the wire's f32")]
fn f32_bytes(v: f64) -> [u8; 4] {
    (v as f32).to_le_bytes()
}

fn push_f32(out: &mut Vec<u8>, v: f64) {
    out.extend(f32_bytes(v));
}

/// An answer the board gave to a torque frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Answer {
    /// A reply: the joint angles, degrees (joints 1 and 2).
    Angles([f64; 2]),
    /// The board's id alone: a board that is not set up (the firmware
    /// answers a torque frame with its id, then the angle of each encoder
    /// set up: none).
    Bare,
}

/// Bytes in each half of the window [`Replies::mostly_dropped`] judges
/// (about 57 replies, 57 ms at 1 kHz): the window holds the last one to two
/// halves, so a judgement rests on at least this many bytes.
pub const JUDGE_BYTES: u64 = 512;

/// Finds answers in what the board sent: `[id][f32][f32]`, nothing to frame
/// them. At each byte:
/// - nine id bytes in a row are a bare answer, one byte (a real reply's
///   angles are never four bytes of the id each: that would be a whole
///   count at which the encoder's float is the id repeated);
/// - the id and two finite angles within ±3600° is a reply if the caller
///   takes it (it judges whether the board can have sent it);
/// - otherwise one byte is dropped (counted) and the search goes on.
///
/// It keeps the count of bytes dropped over a recent window against the
/// bytes it went through ([`Replies::mostly_dropped`]).
#[derive(Debug, Clone, Default)]
pub struct Replies {
    buffer: Vec<u8>,
    /// Bytes dropped to find a reply again.
    pub dropped: u64,
    /// Bytes gone through and dropped: the window's current half, then
    /// the one before.
    window: [(u64, u64); 2],
}

impl Replies {
    /// Forgets the bytes of a reply begun (the counts of bytes dropped
    /// stay).
    pub fn clear(&mut self) {
        self.buffer.clear();
    }

    /// Whether most of the bytes gone through over the recent window (at
    /// least [`JUDGE_BYTES`] of them) were dropped: a 2DIY drops bytes
    /// only where a reply was cut (a few bytes when its port opens), so a
    /// stream that is mostly resyncs is no 2DIY's.
    #[must_use]
    pub fn mostly_dropped(&self) -> bool {
        let [(read0, dropped0), (read1, dropped1)] = self.window;
        let (read, dropped) = (read0 + read1, dropped0 + dropped1);
        read >= JUDGE_BYTES && 2 * dropped > read
    }

    fn went_through(&mut self, bytes: u64, dropped: u64) {
        self.dropped += dropped;
        let current = &mut self.window[0];
        current.0 += bytes;
        current.1 += dropped;
        if current.0 >= JUDGE_BYTES {
            self.window = [(0, 0), self.window[0]];
        }
    }

    /// Feeds bytes; hands each answer to `take`, which says whether it
    /// takes a reply's angles (a bare answer is taken whatever it says).
    pub fn feed(&mut self, wiring: &Wiring, bytes: &[u8], mut take: impl FnMut(Answer) -> bool) {
        self.buffer.extend_from_slice(bytes);
        let id = wiring.device_id;
        let mut start = 0;
        while self.buffer.len() - start >= REPLY {
            let mut reply = [0_u8; REPLY];
            reply.copy_from_slice(&self.buffer[start..start + REPLY]);
            if reply.iter().all(|&b| b == id) {
                take(Answer::Bare);
                self.went_through(1, 0);
                start += 1;
                continue;
            }
            let angles = wiring.angles(&reply);
            if reply[0] == id
                && angles.iter().all(|a| a.is_finite() && a.abs() <= 3600.0)
                && take(Answer::Angles(angles))
            {
                self.went_through(REPLY as u64, 0);
                start += REPLY;
            } else {
                self.went_through(1, 1);
                start += 1;
            }
        }
        self.buffer.drain(..start);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The bytes the vendor's client sends for the v3 setup with device id
    /// 5 (captured from `HaplyHAPI.py` 1.0.1 writing to a recording port).
    #[test]
    fn the_v3_setup_frame_is_the_vendors_byte_for_byte() {
        let setup = Wiring::vendor(3).setup();
        let want = [
            0x01, 0x05, 0x03, 0x01, 0x01, 0x03, 0x01, 0x01, 0x00, 0x00, 0x00, 0x00, 0x40, 0x41,
            0x00, 0x80, 0x98, 0x45, 0x00, 0x00, 0x28, 0x43, 0x00, 0x80, 0x98, 0x45,
        ];
        assert_eq!(setup, want);
    }

    #[test]
    fn torques_go_in_port_order_and_replies_come_back_in_joint_order() {
        let w = Wiring::vendor(3);
        let frame = w.torques([0.5, -0.25]);
        assert_eq!(&frame[..2], &[2, 5]);
        assert_eq!(
            f32::from_le_bytes(frame[2..6].try_into().unwrap()),
            -0.25,
            "port 1 is motor 2"
        );
        let mut reply = [5_u8; REPLY];
        reply[1..5].copy_from_slice(&12.5_f32.to_le_bytes());
        reply[5..9].copy_from_slice(&170.0_f32.to_le_bytes());
        assert_eq!(w.angles(&reply), [170.0, 12.5]);
    }

    #[test]
    fn replies_are_found_again_after_a_lost_byte() {
        let w = Wiring::vendor(3);
        let mut reply = [5_u8; REPLY];
        reply[1..5].copy_from_slice(&12.0_f32.to_le_bytes());
        reply[5..9].copy_from_slice(&168.0_f32.to_le_bytes());
        let mut bytes = reply[3..].to_vec(); // the end of a reply, its start lost
        bytes.extend(reply);
        bytes.extend(&reply[..4]); // half of the next
        let mut replies = Replies::default();
        let mut got = Vec::new();
        let mut take = |a| {
            got.push(a);
            true
        };
        replies.feed(&w, &bytes, &mut take);
        replies.feed(&w, &reply[4..], &mut take);
        assert_eq!(
            got,
            [Answer::Angles([168.0, 12.0]); 2],
            "the rest of the half reply completes it"
        );
        assert_eq!(replies.dropped, 6);
    }

    /// Issue 63: a board that answers with its id alone (not set up) is
    /// read as bare answers, never as angles; a reply the caller does not
    /// take is dropped a byte at a time.
    #[test]
    fn bare_answers_are_no_angles_and_untaken_replies_are_dropped() {
        let w = Wiring::vendor(3);
        let mut replies = Replies::default();
        let mut got = Vec::new();
        replies.feed(&w, &[5; 30], |a| {
            got.push(a);
            true
        });
        assert_eq!(got, [Answer::Bare; 22], "the last 8 wait for what follows");
        assert_eq!(replies.dropped, 0);
        let mut reply = [5_u8; REPLY];
        reply[1..5].copy_from_slice(&12.0_f32.to_le_bytes());
        reply[5..9].copy_from_slice(&168.0_f32.to_le_bytes());
        let mut replies = Replies::default();
        let mut offered = 0;
        replies.feed(&w, &reply, |_| {
            offered += 1;
            false
        });
        assert_eq!((offered, replies.dropped), (1, 1));
    }

    /// Over a window of at least `JUDGE_BYTES`, a stream mostly dropped is
    /// judged so, and one of replies is not.
    #[test]
    fn a_stream_mostly_dropped_is_judged_over_a_recent_window() {
        let w = Wiring::vendor(3);
        let mut reply = [5_u8; REPLY];
        reply[1..5].copy_from_slice(&12.0_f32.to_le_bytes());
        reply[5..9].copy_from_slice(&168.0_f32.to_le_bytes());
        let mut replies = Replies::default();
        let garbage = [0x80_u8; 600];
        replies.feed(&w, &garbage, |_| true);
        assert!(replies.mostly_dropped(), "600 bytes dropped of 600");
        for _ in 0..200 {
            replies.feed(&w, &reply, |_| true);
        }
        assert!(!replies.mostly_dropped(), "the garbage has left the window");
        let mut few = Replies::default();
        few.feed(&w, &garbage[..300], |_| true);
        assert!(!few.mostly_dropped(), "too few bytes to judge");
    }

    #[test]
    fn a_wiring_with_a_bad_port_or_direction_is_refused() {
        let mut w = Wiring::vendor(3);
        w.motors[1].port = 2;
        assert!(w.problem().unwrap().contains("different ports"));
        let mut w = Wiring::vendor(3);
        w.encoders[0].direction = 7;
        assert!(w.problem().unwrap().contains("directions"));
        assert_eq!(Wiring::vendor(2).problem(), None);
    }
}
