//! The input stream's frame encoded by hand, byte for byte what
//! [`encode_frame`](super::encode_frame) (postcard + COBS) produces for
//! `DeviceFrame { seq, message: DeviceToHost::Input(batch) }`.
//!
//! One goes out per block of samples while the stream is on, so, like telemetry, it is
//! written in one pass straight from the pipeline's counts (the differences taken here),
//! through the same COBS writer (`telemetry_frame`). postcard's layout:
//!
//! ```text
//! varint(seq) varint(6 = DeviceToHost::Input) varint(first_sample_index)
//! varint(sample count) then per sample and axis zigzag-varint(i16 difference)
//! ```
//!
//! then COBS with the terminating zero. `shared/tests/input_frame.rs` compares it byte for
//! byte with postcard's encoding of [`InputBatch::from_counts`], so a change to
//! `DeviceToHost`'s variant order or to [`InputBatch`] not mirrored here fails on the host.

use super::InputBatch;
use super::MAX_INPUT_SAMPLES_PER_FRAME;
use super::telemetry_frame::Cobs;

/// Postcard variant index of `DeviceToHost::Input` (the seventh variant).
const INPUT_VARIANT: u8 = 6;

/// Longest postcard payload: three 5-byte varints, the variant, and 3 bytes (the longest
/// zigzag varint of an i16) per axis and sample.
const MAX_RAW: usize = 5 + 1 + 5 + 1 + MAX_INPUT_SAMPLES_PER_FRAME * 3 * 3;

/// Longest frame: COBS adds one byte per 254 (one here: the payload is shorter) plus the
/// terminating zero.
pub const MAX_FRAME: usize = MAX_RAW + 2;

/// Encodes the frame of the samples `counts` (consecutive indices from
/// `first_sample_index`; at most [`MAX_INPUT_SAMPLES_PER_FRAME`], any more are left out)
/// into `frame`; returns its length, terminating zero included.
pub fn encode(
    seq: u32,
    first_sample_index: u32,
    counts: &[[i16; 3]],
    frame: &mut [u8; MAX_FRAME],
) -> usize {
    let counts = counts.get(..MAX_INPUT_SAMPLES_PER_FRAME).unwrap_or(counts);
    let mut c = Cobs::new(frame);
    c.varint(seq);
    c.byte(INPUT_VARIANT);
    c.varint(first_sample_index);
    c.byte(counts.len() as u8);
    let mut previous = [0i16; 3];
    for sample in counts {
        for (&now, before) in sample.iter().zip(&mut previous) {
            c.varint(zigzag(now.wrapping_sub(*before)));
            *before = now;
        }
    }
    c.finish()
}

/// postcard's signed-integer mapping: 0, -1, 1, -2, ... to 0, 1, 2, 3, ...
#[inline(always)]
fn zigzag(v: i16) -> u32 {
    u32::from(((v << 1) ^ (v >> 15)) as u16)
}

impl InputBatch {
    /// The batch of `counts` (consecutive indices from `first_sample_index`; at most
    /// [`MAX_INPUT_SAMPLES_PER_FRAME`], any more are left out): each sample as its
    /// difference from the one before, the first from zero.
    pub fn from_counts(first_sample_index: u32, counts: &[[i16; 3]]) -> Self {
        let mut delta_counts = heapless::Vec::new();
        let mut previous = [0i16; 3];
        for sample in counts.iter().take(MAX_INPUT_SAMPLES_PER_FRAME) {
            let mut d = [0i16; 3];
            for ((d, &now), before) in d.iter_mut().zip(sample).zip(&mut previous) {
                *d = now.wrapping_sub(*before);
                *before = now;
            }
            let _ = delta_counts.push(d);
        }
        Self {
            first_sample_index,
            delta_counts,
        }
    }

    /// The samples: (sample index, x, y, z counts), the differences added back up.
    pub fn samples(&self) -> impl Iterator<Item = (u32, [i16; 3])> + '_ {
        let mut previous = [0i16; 3];
        self.delta_counts.iter().zip(0u32..).map(move |(d, n)| {
            for (p, &d) in previous.iter_mut().zip(d) {
                *p = p.wrapping_add(d);
            }
            (self.first_sample_index.wrapping_add(n), previous)
        })
    }
}
