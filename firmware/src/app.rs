//! What every board runs: the core's on-board [`Firmware`] in the loop
//! interrupt, frames in and out through a byte queue.
//!
//! - The loop interrupt ([`Shared::tick`]) senses, steps the firmware (the
//!   model, crossfade, force clamp and 20 ms watchdog are all in this path)
//!   and outputs; the telemetry it sends is encoded into the transmit queue
//!   (a frame that does not fit is dropped whole, and the host sees the gap
//!   in the tick numbers).
//! - The main loop reads the link, decodes frames and hands each valid
//!   message to [`Shared::receive`] in a critical section, and drains the
//!   transmit queue into the link. A host's `Hello` first clears the
//!   queue but the frame under way ([`TxQueue::new_host`]), so the replies
//!   always fit.
//!
//! Nothing allocates: the queue and the decoder are fixed-size.

use frictionlab_core::friction::ForceLimit;
use frictionlab_core::onboard::Firmware;
use frictionlab_core::tx::TxQueue;
use frictionlab_core::wire::Message;

use crate::board::Board;

/// Transmit queue, bytes: 50 ms of telemetry at every tick at 10 kHz.
pub const TX_BYTES: usize = 16 * 1024;

/// The state the loop interrupt and the main loop share.
pub struct Shared<B: Board> {
    /// The protocol and on-board rendering.
    pub firmware: Firmware<f32>,
    /// The board.
    pub board: B,
    tx: TxQueue<TX_BYTES>,
}

impl<B: Board> Shared<B> {
    /// Firmware at the board's loop rate on `board`, its force clamped to the
    /// board's limit.
    pub fn new(board: B) -> Self {
        let limit = ForceLimit::new(board.force_limit_n()).unwrap_or_default();
        Shared {
            firmware: Firmware::new(B::LOOP_RATE_HZ, limit, board.apparatus()),
            board,
            tx: TxQueue::new(),
        }
    }

    /// A valid message from the host.
    pub fn receive(&mut self, message: &Message) {
        if matches!(message, Message::Hello { .. }) {
            // Room for the replies, whatever the last host left queued.
            self.tx.new_host();
        }
        let tx = &mut self.tx;
        self.firmware.receive(message, |reply| {
            tx.push(&reply);
        });
        self.board.host_message(message);
    }

    /// One loop tick.
    pub fn tick(&mut self) {
        let Shared {
            firmware,
            board,
            tx,
        } = self;
        board.tick(
            1.0 / f64::from(B::LOOP_RATE_HZ),
            |input, button, end_stop| {
                firmware.tick(input, button, end_stop, |m| {
                    tx.push(&m);
                })
            },
        );
    }

    /// Copies up to `out.len()` queued bytes into `out`, leaving them
    /// queued; returns how many.
    pub fn peek_tx(&self, out: &mut [u8]) -> usize {
        self.tx.peek(out)
    }

    /// Removes the first `n` queued bytes (sent).
    pub fn pop_tx(&mut self, n: usize) {
        self.tx.pop(n);
    }
}
