//! The transmit ring: frames wait here while the pipeline runs, and go to the link from
//! the main loop, so the pipeline never waits on the link.

use supine_core::protocol::Telemetry;

use crate::link::{self, Link};
use supine_core::protocol::telemetry_frame;

/// Bytes of the transmit ring: more than one block's worst-case output (the monitor's
/// `TX_HEADROOM`), and no more: it is an eighth of the device's 16 KiB RAM budget. A
/// power of two, so `i & TX_MASK` indexes it without a bounds check.
const TX_RING_LEN: usize = 2048;
const TX_MASK: usize = TX_RING_LEN - 1;

/// A byte ring for outgoing frames.
pub(crate) struct TxRing {
    buf: [u8; TX_RING_LEN],
    head: usize,
    len: usize,
}

impl TxRing {
    pub(crate) const fn new() -> Self {
        Self {
            buf: [0; TX_RING_LEN],
            head: 0,
            len: 0,
        }
    }

    pub(crate) fn free(&self) -> usize {
        TX_RING_LEN - self.len
    }

    /// Appends `bytes`, first writing the oldest bytes to `link` (waiting) if room lacks.
    // Out of line: the generic messages, the input stream and the telemetry frames that
    // wrap around the ring's end share one copy (about 250 B of flash each).
    #[inline(never)]
    pub(crate) fn push(&mut self, bytes: &[u8], link: &mut impl Link) {
        while self.free() < bytes.len() && self.len > 0 {
            self.drain_blocking_one(link);
        }
        if bytes.len() > self.free() {
            // Only if a frame were longer than the ring: send it straight through.
            bytes.iter().for_each(|&b| link::write_byte(link, b));
            return;
        }
        let tail = (self.head + self.len) % TX_RING_LEN;
        // At most two contiguous pieces: up to the end of the buffer, then from its start.
        let first = bytes.len().min(TX_RING_LEN - tail);
        let (a, b) = bytes.split_at(first);
        if let Some(dst) = self.buf.get_mut(tail..tail + a.len()) {
            dst.copy_from_slice(a);
        }
        if let Some(dst) = self.buf.get_mut(..b.len()) {
            dst.copy_from_slice(b);
        }
        self.len += bytes.len();
    }

    /// Encodes a telemetry frame straight into the ring (the hot path: no copy), or,
    /// where the free space wraps around the ring's end (one frame in about 80), into a
    /// scratch frame copied in two pieces. Kept out of line: the pipeline's per-sample
    /// loop stays smaller.
    #[inline(never)]
    pub(crate) fn push_telemetry(&mut self, seq: u32, t: &Telemetry, link: &mut impl Link) {
        while self.free() < telemetry_frame::MAX_FRAME && self.len > 0 {
            self.drain_blocking_one(link);
        }
        let tail = (self.head + self.len) & TX_MASK;
        let contiguous = self
            .buf
            .get_mut(tail..tail + telemetry_frame::MAX_FRAME)
            .and_then(|s| <&mut [u8; telemetry_frame::MAX_FRAME]>::try_from(s).ok());
        if let Some(frame) = contiguous {
            self.len += telemetry_frame::encode(seq, t, frame);
        } else {
            let mut frame = [0u8; telemetry_frame::MAX_FRAME];
            let len = telemetry_frame::encode(seq, t, &mut frame);
            self.push(frame.get(..len).unwrap_or(&[]), link);
        }
    }

    /// Writes the oldest byte to `link`, waiting for room.
    pub(crate) fn drain_blocking_one(&mut self, link: &mut impl Link) {
        if let Some(&b) = self.buf.get(self.head) {
            link::write_byte(link, b);
        }
        self.head = (self.head + 1) % TX_RING_LEN;
        self.len -= 1;
    }

    /// Writes to `link` while it takes bytes without waiting.
    pub(crate) fn drain(&mut self, link: &mut impl Link) {
        while self.len > 0 {
            let Some(&b) = self.buf.get(self.head) else {
                return;
            };
            if !link::try_write_byte(link, b) {
                return;
            }
            self.head = (self.head + 1) % TX_RING_LEN;
            self.len -= 1;
        }
    }
}
