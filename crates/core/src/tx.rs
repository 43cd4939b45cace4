//! A device's transmit queue: whole frames, oldest first, handed to the
//! link as fast as it takes bytes.
//!
//! The loop queues every tick's telemetry; when the link drains more
//! slowly than that (a host that stopped reading, an emulator falling
//! behind), the queue fills and a frame that does not fit is dropped whole
//! (the host sees the gap in the tick numbers). A new host's `Hello` must
//! still be answered: [`TxQueue::new_host`] drops what was queued for the
//! last host, all but the frame the link may be part-way through, so the
//! replies fit and go out next. Without it a full queue dropped the
//! `Capabilities`, the host said `Hello` again into the same full queue,
//! and the link never came back while it stayed slower than the telemetry.

use heapless::Deque;

use crate::wire::{MAX_FRAME, Message, encode};

/// A queue of up to `N` bytes of frames.
#[derive(Debug, Default)]
pub struct TxQueue<const N: usize> {
    bytes: Deque<u8, N>,
}

impl<const N: usize> TxQueue<N> {
    /// An empty queue.
    #[must_use]
    pub const fn new() -> Self {
        TxQueue {
            bytes: Deque::new(),
        }
    }

    /// Queues `message`'s frame whole; false when it does not fit (dropped).
    pub fn push(&mut self, message: &Message) -> bool {
        let mut frame = [0_u8; MAX_FRAME];
        let Ok(len) = encode(message, &mut frame) else {
            return false;
        };
        if N - self.bytes.len() < len {
            return false;
        }
        for byte in &frame[..len] {
            // Room was checked above.
            let _ = self.bytes.push_back(*byte);
        }
        true
    }

    /// A new host: drops every queued frame but the first, which the link
    /// may be part-way through sending (kept up to its 0x00 delimiter, so
    /// no frame on the wire is cut short).
    pub fn new_host(&mut self) {
        let first = self
            .bytes
            .iter()
            .position(|&b| b == 0)
            .map_or(0, |end| end + 1);
        self.bytes.truncate(first);
    }

    /// Copies up to `out.len()` queued bytes into `out`, leaving them
    /// queued; returns how many.
    pub fn peek(&self, out: &mut [u8]) -> usize {
        let mut n = 0;
        for (slot, byte) in out.iter_mut().zip(self.bytes.iter()) {
            *slot = *byte;
            n += 1;
        }
        n
    }

    /// Removes the first `n` queued bytes (sent).
    pub fn pop(&mut self, n: usize) {
        for _ in 0..n {
            self.bytes.pop_front();
        }
    }

    /// Bytes queued.
    #[must_use]
    pub fn len(&self) -> usize {
        self.bytes.len()
    }

    /// Whether nothing is queued.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.bytes.is_empty()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::wire::Decoder;

    fn telemetry(tick: u32) -> Message {
        Message::Telemetry {
            tick,
            x_m: 0.01,
            v_m_s: -0.2,
            force_n: 1.5,
            vibration: 0.25,
            render: 3,
            flags: 0,
        }
    }

    const CAPABILITIES: Message = Message::Capabilities {
        version: 2,
        dof: 1,
        max_force_n: 9.48,
        counts_per_m: 40_000.0,
        force_rate_hz: 5000,
        vibration_rate_hz: 5000,
    };

    /// A queue full of telemetry, the link 5 bytes into its first frame
    /// (those bytes fed to `link`): what the next ticks queue.
    fn full(link: &mut Decoder) -> (TxQueue<1024>, u32) {
        let mut q = TxQueue::<1024>::new();
        let mut tick = 0;
        while q.push(&telemetry(tick)) {
            tick += 1;
        }
        let mut sent = [0_u8; 5];
        assert_eq!(q.peek(&mut sent), 5);
        q.pop(5);
        link.feed(&sent, |_| panic!("no frame is whole yet"));
        (q, tick)
    }

    /// Everything still queued, through `link`.
    fn drain(q: &mut TxQueue<1024>, link: &mut Decoder) -> ([Option<Message>; 4], usize) {
        let mut got = [None, None, None, None];
        let mut n = 0;
        let mut buf = [0_u8; 64];
        while !q.is_empty() {
            let k = q.peek(&mut buf);
            q.pop(k);
            link.feed(&buf[..k], |m| {
                if let Some(slot) = got.get_mut(n) {
                    *slot = Some(m);
                }
                n += 1;
            });
        }
        (got, n)
    }

    #[test]
    fn a_full_queue_drops_a_frame_whole() {
        let mut q = TxQueue::<1024>::new();
        let mut tick = 0;
        while q.push(&telemetry(tick)) {
            tick += 1;
        }
        assert!(tick > 10, "{tick} frames fill 1 KiB");
        let full = q.len();
        assert!(!q.push(&telemetry(tick)));
        assert_eq!(q.len(), full, "nothing of the dropped frame queued");
        let mut link = Decoder::new();
        let (_, frames) = drain(&mut q, &mut link);
        assert_eq!(frames, usize::try_from(tick).unwrap());
        assert_eq!(link.stats().crc_errors + link.stats().malformed, 0);
    }

    #[test]
    fn a_new_host_gets_its_replies_after_the_frame_under_way() {
        let mut link = Decoder::new();
        let (mut q, _) = full(&mut link);
        q.new_host();
        assert!(q.push(&CAPABILITIES));
        assert!(q.push(&telemetry(1000)));
        let (got, frames) = drain(&mut q, &mut link);
        // The frame under way arrives whole, then the reply, then what
        // followed it; nothing corrupt on the wire.
        assert_eq!(frames, 3);
        assert_eq!(got[0], Some(telemetry(0)));
        assert_eq!(got[1], Some(CAPABILITIES));
        assert_eq!(got[2], Some(telemetry(1000)));
        assert_eq!(link.stats().crc_errors + link.stats().malformed, 0);
    }

    #[test]
    fn a_new_host_at_a_frame_boundary_keeps_one_whole_frame() {
        let mut q = TxQueue::<1024>::new();
        assert!(q.push(&telemetry(0)));
        assert!(q.push(&telemetry(1)));
        q.new_host();
        let mut link = Decoder::new();
        let (got, frames) = drain(&mut q, &mut link);
        assert_eq!((frames, got[0]), (1, Some(telemetry(0))));
        let mut empty = TxQueue::<1024>::new();
        empty.new_host();
        assert!(empty.is_empty());
    }
}
