//! The input stream's frame: the model's input for consecutive samples, packed, and the
//! frame encoded by hand, byte for byte what [`encode_frame`](super::encode_frame)
//! (postcard + COBS) produces for `DeviceFrame { seq, message: DeviceToHost::Input(batch) }`.
//!
//! Packing: per sample and axis (x, y, z), the difference from the sample before (the
//! first sample's from zero, so each frame decodes on its own), wrapping i16 arithmetic,
//! as a zigzag varint (postcard's encoding of a signed integer): a quiet ride's samples
//! take 3-6 bytes. The message carries the packed bytes as a byte string, so the device's
//! generic encoder needs next to no code for it. One frame goes out per block of samples
//! while the stream is on, encoded here without serde (postcard's generic COBS encoder
//! costs about 30 instructions a byte on the device):
//!
//! ```text
//! varint(seq) varint(6 = DeviceToHost::Input) varint(first_sample_index)
//! varint(packed length) packed bytes
//! ```
//!
//! then COBS with the terminating zero. `shared/tests/input_frame.rs` compares it byte for
//! byte with postcard's encoding of [`InputBatch::from_counts`], so a change to
//! `DeviceToHost`'s variant order or to [`InputBatch`] not mirrored here fails on the host.

use serde::Serializer;

use super::{InputBatch, MAX_INPUT_SAMPLES_PER_FRAME};

/// Postcard variant index of `DeviceToHost::Input` (the seventh variant).
const INPUT_VARIANT: u8 = 6;

/// Longest packed batch: 3 bytes (the longest zigzag varint of an i16) per axis and sample.
pub const MAX_PACKED_LEN: usize = MAX_INPUT_SAMPLES_PER_FRAME * 3 * 3;

/// Longest postcard payload: three 5-byte varints, the variant and the packed samples
/// (whose length takes two varint bytes).
const MAX_RAW: usize = 5 + 1 + 5 + 2 + MAX_PACKED_LEN;

/// Longest frame: COBS adds one byte per 254 (one here: the payload is shorter) plus the
/// terminating zero. Also the size of [`encode`]'s buffer.
pub const MAX_FRAME: usize = MAX_RAW + 2;

/// Packs `counts` (at most [`MAX_INPUT_SAMPLES_PER_FRAME`], any more are left out) into
/// `out`; returns the packed length.
pub fn pack(counts: &[[i16; 3]], out: &mut [u8; MAX_PACKED_LEN]) -> usize {
    pack_at(counts, out, 0)
}

/// [`pack`] into `out` from offset `at`; returns the offset after the packed bytes.
fn pack_at(counts: &[[i16; 3]], out: &mut [u8], mut at: usize) -> usize {
    let counts = counts.get(..MAX_INPUT_SAMPLES_PER_FRAME).unwrap_or(counts);
    // One loop over the axes of all samples; each value's predecessor is 3 values back,
    // kept in `before` (x, y, z of the sample before, rotating).
    let mut before = [0i16; 3];
    for &now in counts.as_flattened() {
        let v = zigzag(now.wrapping_sub(before[0]));
        // Most differences take one byte: written here, the rest by the general varint.
        match out.get_mut(at) {
            Some(b) if v < 0x80 => {
                *b = v as u8;
                at += 1;
            }
            _ => at = put_varint(out, at, u32::from(v)),
        }
        before = [before[1], before[2], now];
    }
    at
}

/// Longest header before the packed bytes: the sequence number, the variant, the first
/// index and the packed length.
const MAX_HEADER: usize = MAX_RAW - MAX_PACKED_LEN;

/// Encodes the frame of the samples `counts` (consecutive indices from
/// `first_sample_index`; at most [`MAX_INPUT_SAMPLES_PER_FRAME`], any more are left out)
/// in `buf`; returns where in `buf` the frame is, terminating zero included.
///
/// One buffer, no copy of the samples: they are packed at a fixed offset after room for
/// the longest header, the header (whose last field is their length) goes just before
/// them, and COBS is applied in place (the payload is shorter than 254 bytes, so every
/// code byte replaces a zero of the payload, and the first goes before it).
pub fn encode(
    seq: u32,
    first_sample_index: u32,
    counts: &[[i16; 3]],
    buf: &mut [u8; MAX_FRAME],
) -> core::ops::Range<usize> {
    const PACKED_AT: usize = 1 + MAX_HEADER;
    let end = pack_at(counts, buf, PACKED_AT);
    let mut header = [0u8; MAX_HEADER];
    let mut len = put_varint(&mut header, 0, seq);
    len = put_varint(&mut header, len, INPUT_VARIANT.into());
    len = put_varint(&mut header, len, first_sample_index);
    len = put_varint(&mut header, len, (end - PACKED_AT) as u32);
    let start = PACKED_AT - len - 1;
    if let (Some(dst), Some(src)) = (buf.get_mut(start + 1..PACKED_AT), header.get(..len)) {
        dst.copy_from_slice(src);
    }
    let mut code_at = start;
    for i in start + 1..end {
        if buf.get(i) == Some(&0) {
            if let Some(code) = buf.get_mut(code_at) {
                *code = (i - code_at) as u8;
            }
            code_at = i;
        }
    }
    if let Some(code) = buf.get_mut(code_at) {
        *code = (end - code_at) as u8;
    }
    if let Some(zero) = buf.get_mut(end) {
        *zero = 0;
    }
    start..end + 1
}

/// Writes `v` as a varint (7 bits a byte, low first) into `out` at `at`; returns the
/// offset after it. Bytes past the end of `out` are dropped (never: callers size `out`).
#[inline(never)]
fn put_varint(out: &mut [u8], mut at: usize, mut v: u32) -> usize {
    loop {
        let low = (v & 0x7F) as u8;
        v >>= 7;
        if let Some(b) = out.get_mut(at) {
            *b = if v == 0 { low } else { low | 0x80 };
        }
        at += 1;
        if v == 0 {
            return at;
        }
    }
}

/// postcard's signed-integer mapping: 0, -1, 1, -2, ... to 0, 1, 2, 3, ...
#[inline(always)]
fn zigzag(v: i16) -> u16 {
    ((v << 1) ^ (v >> 15)) as u16
}

/// The inverse of [`zigzag`].
fn unzigzag(v: u16) -> i16 {
    ((v >> 1) as i16) ^ -((v & 1) as i16)
}

/// Why the packed bytes of an [`InputBatch`] do not decode.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PackError {
    /// A varint is cut off, longer than an i16's, or the bytes end inside a sample.
    Malformed,
    /// More samples than a frame carries.
    TooLong,
}

impl core::fmt::Display for PackError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            PackError::Malformed => "input batch: malformed packed samples",
            PackError::TooLong => "input batch: more samples than a frame carries",
        })
    }
}

impl core::error::Error for PackError {}

impl InputBatch {
    /// The batch of `counts` (consecutive indices from `first_sample_index`; at most
    /// [`MAX_INPUT_SAMPLES_PER_FRAME`], any more are left out).
    pub fn from_counts(first_sample_index: u32, counts: &[[i16; 3]]) -> Self {
        let mut buf = [0u8; MAX_PACKED_LEN];
        let len = pack(counts, &mut buf);
        let mut packed = heapless::Vec::new();
        let _ = packed.extend_from_slice(buf.get(..len).unwrap_or(&[]));
        Self {
            first_sample_index,
            packed,
        }
    }

    /// The samples: (sample index, x, y, z counts), the differences added back up.
    pub fn samples(
        &self,
    ) -> Result<heapless::Vec<(u32, [i16; 3]), MAX_INPUT_SAMPLES_PER_FRAME>, PackError> {
        let mut out = heapless::Vec::new();
        let mut previous = [0i16; 3];
        let mut bytes = self.packed.iter();
        let mut index = self.first_sample_index;
        while bytes.len() > 0 {
            let mut sample = [0i16; 3];
            for (s, p) in sample.iter_mut().zip(&mut previous) {
                let mut v: u32 = 0;
                let mut shift = 0;
                loop {
                    let &b = bytes.next().ok_or(PackError::Malformed)?;
                    v |= u32::from(b & 0x7F) << shift;
                    shift += 7;
                    if b & 0x80 == 0 {
                        break;
                    }
                    if shift > 14 {
                        return Err(PackError::Malformed);
                    }
                }
                let v = u16::try_from(v).map_err(|_| PackError::Malformed)?;
                *p = p.wrapping_add(unzigzag(v));
                *s = *p;
            }
            out.push((index, sample)).map_err(|_| PackError::TooLong)?;
            index = index.wrapping_add(1);
        }
        Ok(out)
    }
}

/// The packed bytes go out as a byte string (postcard: length, then the bytes), the wire
/// form a derived `Vec<u8>` would also give, through the serializer's one bytes call.
pub(super) fn serialize_packed<S: Serializer>(
    packed: &heapless::Vec<u8, MAX_PACKED_LEN>,
    serializer: S,
) -> Result<S::Ok, S::Error> {
    serializer.serialize_bytes(packed)
}
