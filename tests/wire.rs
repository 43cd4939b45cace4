//! The wire protocol's frame decoder on split, merged, truncated and
//! corrupted input, over every message of versions 1 and 2, and the
//! on-board device fed a corrupted upload (no hardware: bytes only).
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    reason = "a failed unwrap is a failed test"
)]
#![allow(
    clippy::cast_possible_truncation,
    clippy::cast_sign_loss,
    reason = "positions in a test stream from fractions in [0, 1); the device's f32"
)]

use frictionlab::device::frictionlab::wire::{Decoder, MAX_FRAME, Message, frame, status};
use frictionlab::friction::{ForceLimit, Input, ModelParams};
use frictionlab_core::onboard::{BoardLoop, upload};
use frictionlab_core::render::{RAMP_S, Renderer};
use proptest::prelude::*;

fn message() -> impl Strategy<Value = Message> {
    prop_oneof![v1_message(), v2_message()]
}

/// The messages wire protocol version 2 added.
fn v2_message() -> impl Strategy<Value = Message> {
    let f = -1e4_f32..1e4;
    prop_oneof![
        (any::<u16>(), any::<u16>(), any::<u8>()).prop_map(
            |(models, loop_rate_hz, float_bytes)| {
                Message::OnBoard {
                    models,
                    loop_rate_hz,
                    float_bytes,
                }
            }
        ),
        (
            any::<u8>(),
            any::<u8>(),
            proptest::array::uniform5(-1e6_f64..1e6)
        )
            .prop_map(|(kind, first, values)| {
                Message::Upload {
                    kind,
                    first,
                    values,
                }
            }),
        (any::<u8>(), any::<u8>(), any::<u8>(), any::<u16>()).prop_map(
            |(render, kind, count, check)| Message::Select {
                render,
                kind,
                count,
                check,
            }
        ),
        any::<u8>().prop_map(|render| Message::Clear { render }),
        any::<u16>().prop_map(|every| Message::SetTelemetry { every }),
        (
            any::<u32>(),
            [f.clone(), f.clone(), f.clone(), -1.0_f32..1.0],
            any::<u8>(),
            any::<u8>()
        )
            .prop_map(|(tick, [x_m, v_m_s, force_n, vibration], render, flags)| {
                Message::Telemetry {
                    tick,
                    x_m,
                    v_m_s,
                    force_n,
                    vibration,
                    render,
                    flags,
                }
            }),
        (any::<u32>(), any::<u32>(), any::<u32>()).prop_map(
            |(ticks, longest_loop_us, missed_ticks)| Message::LoopReport {
                ticks,
                longest_loop_us,
                missed_ticks,
            }
        ),
    ]
}

fn v1_message() -> impl Strategy<Value = Message> {
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

/// Flips bytes of `stream` at the fractions `flips` of its length.
fn corrupt(stream: &mut [u8], flips: &[(f64, u8)]) {
    for &(at, mask) in flips {
        let pos = (at * stream.len() as f64) as usize % stream.len();
        stream[pos] ^= mask;
    }
}

/// The position and velocity a board senses at tick `k`: a 2 Hz stroke of
/// 1 cm, at 5 kHz.
fn stroke(k: u32) -> Input<f32> {
    let t = f64::from(k) / 5000.0;
    let w = std::f64::consts::TAU * 2.0;
    Input {
        x_m: (0.01 * (w * t).sin()) as f32,
        v_m_s: (0.01 * w * (w * t).cos()) as f32,
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 200, ..ProptestConfig::default() })]

    /// Issue 15: a board rendering model B is sent model A of the same kind
    /// over a link that corrupts bytes. It renders A exactly when every
    /// part of A arrived, and otherwise keeps rendering B: never a model
    /// made of parts of both, never one with a part missing.
    #[test]
    fn a_corrupted_upload_renders_the_model_sent_or_keeps_the_last_never_a_wrong_one(
        which in 0_usize..64,
        scale in 1.05_f64..1.5,
        flips in proptest::collection::vec((0.0_f64..1.0, 1_u8..=255), 0..4),
    ) {
        // Every model a board renders ("none" is a `Clear`, not an upload).
        let names: Vec<&str> = ModelParams::NAMES.into_iter().filter(|&n| n != "none").collect();
        let name = names[which % names.len()];
        let b = ModelParams::default_for(name).unwrap();
        let mut flat = b.flatten();
        let n = flat.len;
        // A differs from B in every value.
        for v in &mut flat.values[..n] {
            *v *= scale;
        }
        let a = ModelParams::unflatten(flat.kind, flat.used()).unwrap();
        let limit = ForceLimit::new(9.48_f32).unwrap();
        let mut board = BoardLoop::<f32>::new(5000, limit);
        let mut reference = Renderer::<f32>::new(limit, RAMP_S as f32);
        prop_assume!(reference.clone().select(Some(&a), 0.0), "A is a valid {}", name);

        let mut b_messages = Vec::new();
        upload(&b, 1, |m| b_messages.push(m));
        let mut a_messages = Vec::new();
        upload(&a, 2, |m| a_messages.push(m));
        let mut stream: Vec<u8> = a_messages.iter().flat_map(frame).collect();
        corrupt(&mut stream, &flips);
        let arrived = decode_all(&mut Decoder::new(), &[&stream]);
        let all_of_a = a_messages.iter().all(|m| arrived.contains(m));

        // One message per tick, then 40 quiet ticks (8 ms: within the
        // watchdog); the reference selects what the board's telemetry says
        // it selected.
        let mut selected_a = false;
        let messages = b_messages.iter().chain(&arrived).map(Some).chain(std::iter::repeat_n(None, 40));
        for (k, m) in (0_u32..).zip(messages) {
            if let Some(m) = m {
                board.receive(m);
            }
            let input = stroke(k);
            let drive = board.tick(input, false, false);
            let Some(Message::Telemetry { render, flags, .. }) = drive.telemetry else {
                panic!("telemetry every tick");
            };
            if flags & status::SELECTED != 0 && flags & status::REFUSED == 0 {
                let model = match render {
                    1 => &b,
                    2 => &a,
                    other => panic!("render {other} was never sent"),
                };
                selected_a |= render == 2;
                reference.select(Some(model), input.x_m);
            }
            let expected = reference.step(board.dt(), input);
            prop_assert_eq!(drive.force_n.to_bits(), expected.force_n.to_bits(), "tick {}", k);
            prop_assert_eq!(drive.vibration.to_bits(), expected.vibration.to_bits(), "tick {}", k);
        }
        prop_assert_eq!(selected_a, all_of_a, "A rendered exactly when all of it arrived");
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
