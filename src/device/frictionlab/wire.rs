//! The device wire protocol (specified in `docs/wire-protocol.md`). The
//! messages, the frame encoding and the sans-IO decoder live in the
//! `no_std` core (`frictionlab_core::wire`), shared with device firmware;
//! this module re-exports them and adds what needs the host (a frame as a
//! `Vec`, the simulated hand's message).

pub use frictionlab_core::wire::*;

/// Encodes `message` as a new frame.
#[must_use]
pub fn frame(message: &Message) -> Vec<u8> {
    let mut out = [0_u8; MAX_FRAME];
    let n = encode(message, &mut out).unwrap_or(0);
    out[..n].to_vec()
}

/// The `HandDrive` message for a hand drive (the emulator's hand; see
/// [`crate::hand`]).
#[must_use]
#[expect(clippy::cast_possible_truncation, reason = "f32 is the wire's type")]
pub fn hand_drive(d: &crate::hand::HandDrive) -> Message {
    Message::HandDrive {
        x_m: d.x_m as f32,
        v_m_s: d.v_m_s as f32,
        stiffness_n_m: d.stiffness_n_m as f32,
        damping_n_s_m: d.damping_n_s_m as f32,
        integral: d.integral_gain as f32,
        click: false,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn byte_layouts_are_as_documented() {
        // docs/wire-protocol.md: Command = 0x01, seq u32 LE, force f32 LE,
        // vibration f32 LE.
        let m = Message::Command {
            seq: 0x0403_0201,
            force_n: 1.5,
            vibration: 0.0,
        };
        let payload = postcard::to_allocvec(&m).unwrap();
        let mut expected = vec![0x01, 0x01, 0x02, 0x03, 0x04];
        expected.extend(1.5_f32.to_le_bytes());
        expected.extend(0.0_f32.to_le_bytes());
        assert_eq!(payload, expected);
        let s = Message::Sample {
            ack_seq: 7,
            time_us: 1000,
            position_counts: -2,
            button: true,
            status: status::CLAMPED,
        };
        let payload = postcard::to_allocvec(&s).unwrap();
        assert_eq!(
            payload,
            [
                5, 7, 0, 0, 0, 0xe8, 0x03, 0, 0, 0xfe, 0xff, 0xff, 0xff, 1, 2
            ]
        );
        // CRC-16/IBM-3740 check value.
        assert_eq!(CRC.checksum(b"123456789"), 0x29b1);
    }
}
