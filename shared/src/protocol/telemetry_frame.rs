//! A telemetry frame encoded by hand, byte for byte what [`encode_frame`](super::encode_frame)
//! (postcard + COBS) produces for `DeviceFrame { seq, message: DeviceToHost::Telemetry(t) }`.
//!
//! Telemetry goes out once per sample, so its encoding is on the hot path: serde's generic
//! serializer with postcard's COBS flavour cost about 1,350 instructions per frame on the
//! Cortex-M4F, more than the model. Written out here, in one pass straight into the transmit
//! ring, a float's four bytes moved as one word when none is zero, it is about 150. The
//! layout is postcard's wire format (stable since 1.0):
//!
//! ```text
//! varint(seq) varint(1 = DeviceToHost::Telemetry) varint(sample_index)
//! f32le x3 (head) f32le x3 (running rms) f32le (vector rms) f32le (vdv)
//! varint(alert level variant) u8 (fault flags) u8 (valid: 0 or 1)
//! varint(joint value count, 0 to 10) f32le x count (joint values)
//! ```
//!
//! then COBS with the terminating zero. `shared/tests/telemetry_frame.rs` compares it byte for
//! byte with postcard's encoding over many random records (NaN, subnormals, infinities,
//! zero bytes, every fault set and level, sequence numbers across the varint lengths), so
//! a protocol change to `DeviceToHost`'s variant order (`TELEMETRY_VARIANT`) or to
//! `Telemetry`'s fields that is not mirrored here fails on the host.

use crate::pipeline::Telemetry;

/// Postcard variant index of `DeviceToHost::Telemetry` (the second variant).
const TELEMETRY_VARIANT: u8 = 1;

/// Longest postcard payload: two 5-byte varints, the variant, 8 f32s, 3 small fields, the
/// joint values' count and ten joint values.
const MAX_RAW: usize = 5 + 1 + 5 + 8 * 4 + 1 + 1 + 1 + 1 + 10 * 4;

/// Longest frame: COBS adds one byte per 254 (one here) plus the terminating zero.
pub const MAX_FRAME: usize = MAX_RAW + 2;

/// COBS encoder writing straight into the frame's bytes as the payload is produced, one
/// pass: each nonzero byte goes to its place at once; each zero closes a run by writing
/// the run's length as the code byte where the run started. Runs stay below 254 bytes:
/// the whole payload is shorter than that.
struct Cobs<'a> {
    frame: &'a mut [u8; MAX_FRAME],
    code_at: usize,
    out: usize,
}

impl Cobs<'_> {
    #[inline(always)]
    fn put(&mut self, at: usize, b: u8) {
        if let Some(slot) = self.frame.get_mut(at) {
            *slot = b;
        }
    }

    #[inline(always)]
    fn byte(&mut self, b: u8) {
        if b == 0 {
            self.put(self.code_at, (self.out - self.code_at) as u8);
            self.code_at = self.out;
        } else {
            self.put(self.out, b);
        }
        self.out += 1;
    }

    #[inline(always)]
    fn varint(&mut self, mut v: u32) {
        while v >= 0x80 {
            self.byte((v as u8) | 0x80);
            v >>= 7;
        }
        self.byte(v as u8);
    }

    /// Four payload bytes: copied as one word when none is zero (the usual case for a
    /// float), else byte by byte.
    #[inline(always)]
    fn float(&mut self, v: f32) {
        let bytes = v.to_le_bytes();
        let w = u32::from_le_bytes(bytes);
        // Nonzero iff some byte of w is zero (the classic bit trick).
        let has_zero_byte = w.wrapping_sub(0x0101_0101) & !w & 0x8080_8080;
        match self.frame.get_mut(self.out..self.out + 4) {
            Some(dst) if has_zero_byte == 0 => {
                dst.copy_from_slice(&bytes);
                self.out += 4;
            }
            _ => self.float_bytes(bytes),
        }
    }

    /// A float with a zero byte (or, never, past the frame's end), byte by byte. Out of
    /// line: it is rare, and inlined at each of the straight-line floats it costs flash.
    #[inline(never)]
    fn float_bytes(&mut self, bytes: [u8; 4]) {
        bytes.into_iter().for_each(|b| self.byte(b));
    }

    /// Closes the last run and writes the terminating zero; returns the frame length.
    #[inline(always)]
    fn finish(mut self) -> usize {
        self.put(self.code_at, (self.out - self.code_at) as u8);
        self.put(self.out, 0);
        self.out + 1
    }
}

/// Encodes the frame into `frame` (offsets `0..len`); returns its length, terminating zero
/// included (at most [`MAX_FRAME`]). Out of line, so compiled in this crate (built for
/// speed on the device) and once.
#[inline(never)]
pub fn encode(seq: u32, t: &Telemetry, frame: &mut [u8; MAX_FRAME]) -> usize {
    let mut c = Cobs {
        frame,
        code_at: 0,
        out: 1,
    };
    c.varint(seq);
    c.byte(TELEMETRY_VARIANT);
    c.varint(t.sample_index);
    // Straight-line, not a loop over an array of them: each value is loaded once, as a
    // word, and no counter runs.
    let [hx, hy, hz] = t.head_acc_m_s2;
    let [rx, ry, rz] = t.running_rms_m_s2;
    c.float(hx);
    c.float(hy);
    c.float(hz);
    c.float(rx);
    c.float(ry);
    c.float(rz);
    c.float(t.vector_running_rms_m_s2);
    c.float(t.vdv_m_s175);
    // The level's variant index (< 128: one varint byte); postcard writes a u8 and a
    // bool as one raw byte each.
    c.byte(t.alert_level as u8);
    c.byte(t.fault_flags.as_repr());
    c.byte(u8::from(t.valid));
    let joints = t.joints.as_slice();
    // At most ten: one varint byte.
    c.byte(joints.len() as u8);
    for &v in joints {
        c.float(v);
    }
    c.finish()
}
