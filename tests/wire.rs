//! The wire protocol's frame decoder on split, merged, truncated and
//! corrupted input (no hardware: bytes only).
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    reason = "a failed unwrap is a failed test"
)]
#![allow(
    clippy::cast_possible_truncation,
    clippy::cast_sign_loss,
    reason = "positions in a test stream from fractions in [0, 1)"
)]

use frictionlab::device::wire::{Decoder, MAX_FRAME, Message, frame};
use proptest::prelude::*;

fn message() -> impl Strategy<Value = Message> {
    let f = -1e4_f32..1e4;
    prop_oneof![
        any::<u16>().prop_map(|version| Message::Hello { version }),
        (any::<u32>(), f.clone(), -1.0_f32..1.0).prop_map(|(seq, force_n, vibration)| {
            Message::Command {
                seq,
                force_n,
                vibration,
            }
        }),
        any::<u32>().prop_map(|seq| Message::Heartbeat { seq }),
        (
            f.clone(),
            f.clone(),
            f.clone(),
            f.clone(),
            f.clone(),
            any::<bool>()
        )
            .prop_map(|(a, b, c, d, e, click)| Message::HandDrive {
                x_m: a,
                v_m_s: b,
                stiffness_n_m: c,
                damping_n_s_m: d,
                integral: e,
                click
            }),
        (
            any::<u16>(),
            any::<u8>(),
            f.clone(),
            f.clone(),
            any::<u16>(),
            any::<u16>()
        )
            .prop_map(|(version, dof, m, c, fr, vr)| {
                Message::Capabilities {
                    version,
                    dof,
                    max_force_n: m,
                    counts_per_m: c,
                    force_rate_hz: fr,
                    vibration_rate_hz: vr,
                }
            }),
        (
            any::<u32>(),
            any::<u32>(),
            any::<i32>(),
            any::<bool>(),
            any::<u8>()
        )
            .prop_map(|(a, t, p, b, s)| Message::Sample {
                ack_seq: a,
                time_us: t,
                position_counts: p,
                button: b,
                status: s
            }),
    ]
}

fn decode_all(decoder: &mut Decoder, chunks: &[&[u8]]) -> Vec<Message> {
    let mut out = Vec::new();
    for c in chunks {
        decoder.feed(c, |m| out.push(m));
    }
    out
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 300, ..ProptestConfig::default() })]

    #[test]
    fn frames_split_and_merged_anyhow_decode_exactly(
        messages in proptest::collection::vec(message(), 1..20),
        cuts in proptest::collection::vec(0.0_f64..1.0, 0..30),
    ) {
        let stream: Vec<u8> = messages.iter().flat_map(frame).collect();
        prop_assert!(messages.iter().all(|m| frame(m).len() <= MAX_FRAME));
        let mut points: Vec<usize> = cuts.iter().map(|c| (c * stream.len() as f64) as usize).collect();
        points.sort_unstable();
        let mut chunks = Vec::new();
        let mut from = 0;
        for p in points.into_iter().chain([stream.len()]) {
            chunks.push(&stream[from..p.max(from)]);
            from = p.max(from);
        }
        let mut d = Decoder::new();
        prop_assert_eq!(decode_all(&mut d, &chunks), messages.clone());
        prop_assert_eq!(d.stats().frames, messages.len() as u64);
        prop_assert_eq!(d.stats().resyncs(), 0);
    }

    #[test]
    fn a_truncated_frame_is_dropped_and_the_next_frames_survive(
        messages in proptest::collection::vec(message(), 3..12),
        which in 0_usize..100,
        keep in 0.0_f64..1.0,
    ) {
        let frames: Vec<Vec<u8>> = messages.iter().map(frame).collect();
        let i = which % (frames.len() - 1);
        let mut stream = Vec::new();
        for (j, f) in frames.iter().enumerate() {
            if j == i {
                // Lose the end of frame i, delimiter included.
                let n = ((f.len() - 1) as f64 * keep) as usize;
                stream.extend_from_slice(&f[..n]);
            } else {
                stream.extend_from_slice(f);
            }
        }
        let mut d = Decoder::new();
        let got = decode_all(&mut d, &[&stream]);
        // Frame i merges with frame i+1 (both lost, unless i was cut to
        // nothing); every other frame is intact.
        let mut expected: Vec<Message> = messages.clone();
        if ((frames[i].len() - 1) as f64 * keep) as usize > 0 {
            expected.remove(i + 1);
        }
        expected.remove(i);
        for m in &expected {
            prop_assert!(got.contains(m), "{m:?} lost");
        }
        prop_assert!(got.len() <= expected.len() + 1);
    }

    #[test]
    fn corrupted_bytes_cost_only_the_frames_they_touch(
        messages in proptest::collection::vec(message(), 2..15),
        flips in proptest::collection::vec((0.0_f64..1.0, 1_u8..=255), 1..6),
    ) {
        let frames: Vec<Vec<u8>> = messages.iter().map(frame).collect();
        let mut stream: Vec<u8> = frames.concat();
        let mut touched = vec![false; frames.len()];
        let starts: Vec<usize> = frames.iter().scan(0, |s, f| { let at = *s; *s += f.len(); Some(at) }).collect();
        for (at, mask) in flips {
            let pos = (at * stream.len() as f64) as usize % stream.len();
            stream[pos] ^= mask;
            let k = starts.iter().rposition(|&s| s <= pos).unwrap();
            touched[k] = true;
            // A damaged delimiter also merges the frame with the next one.
            if pos == starts[k] + frames[k].len() - 1 && k + 1 < frames.len() {
                touched[k + 1] = true;
            }
        }
        let mut d = Decoder::new();
        let got = decode_all(&mut d, &[&stream]);
        for (k, m) in messages.iter().enumerate() {
            // Untouched frames after an intact delimiter decode exactly.
            let prev_ok = k == 0 || !touched[k - 1];
            if !touched[k] && prev_ok {
                prop_assert!(got.contains(m), "frame {k} lost");
            }
        }
    }

    #[test]
    fn garbage_never_panics(bytes in proptest::collection::vec(any::<u8>(), 0..600)) {
        let mut d = Decoder::new();
        d.feed(&bytes, |_| {});
        let s = d.stats();
        prop_assert!(s.frames + s.resyncs() <= bytes.len() as u64);
    }
}

#[test]
fn an_overlong_frame_is_skipped_and_counted() {
    let mut d = Decoder::new();
    let mut stream = vec![0x55; MAX_FRAME * 3];
    stream.push(0);
    let m = Message::Heartbeat { seq: 9 };
    stream.extend(frame(&m));
    let got = decode_all(&mut d, &[&stream]);
    assert_eq!(got, [m]);
    assert_eq!(d.stats().overflows, 1);
}
