//! A telemetry frame encoded by hand, byte for byte what `encode_frame` (postcard + COBS)
//! produces for `DeviceFrame { seq, message: DeviceToHost::Telemetry(t) }`.
//!
//! Telemetry goes out once per sample, so its encoding is on the hot path: serde's generic
//! serializer with postcard's COBS flavour cost about 2,000 instructions per frame on the
//! Cortex-M4F, more than the model. Written out here it is a few hundred. The layout is
//! postcard's wire format (stable since 1.0):
//!
//! ```text
//! varint(seq) varint(1 = DeviceToHost::Telemetry) varint(sample_index)
//! f32le x3 (head) f32le x3 (running rms) f32le (vector rms) f32le (vdv)
//! varint(alert level variant) u8 (fault flags) u8 (valid: 0 or 1)
//! ```
//!
//! then COBS with the terminating zero. The QEMU tests decode every frame with postcard
//! on the host and compare the values bit for bit with the host's pipeline, so a
//! divergence from postcard fails them; `encode` also falls back to postcard if a new
//! protocol version changes `DeviceToHost`'s variant order (see `TELEMETRY_VARIANT`).

use supine_core::protocol::Telemetry;

/// Postcard variant index of `DeviceToHost::Telemetry` (the second variant).
const TELEMETRY_VARIANT: u8 = 1;

/// Longest postcard payload: two 5-byte varints, the variant, 8 f32s and 3 small fields.
const MAX_RAW: usize = 5 + 1 + 5 + 8 * 4 + 1 + 1 + 1;

/// Longest frame: COBS adds one byte per 254 (one here) plus the terminating zero.
pub const MAX_FRAME: usize = MAX_RAW + 2;

fn varint(out: &mut [u8; MAX_RAW], at: &mut usize, mut v: u32) {
    loop {
        let byte = (v & 0x7F) as u8;
        v >>= 7;
        if let Some(slot) = out.get_mut(*at) {
            *slot = if v == 0 { byte } else { byte | 0x80 };
        }
        *at += 1;
        if v == 0 {
            return;
        }
    }
}

fn float(out: &mut [u8; MAX_RAW], at: &mut usize, v: f32) {
    if let Some(slot) = out.get_mut(*at..*at + 4) {
        slot.copy_from_slice(&v.to_le_bytes());
    }
    *at += 4;
}

/// Encodes the frame into `frame`; returns its length (terminating zero included).
pub fn encode(seq: u32, t: &Telemetry, frame: &mut [u8; MAX_FRAME]) -> usize {
    let mut raw = [0u8; MAX_RAW];
    let mut n = 0;
    varint(&mut raw, &mut n, seq);
    varint(&mut raw, &mut n, u32::from(TELEMETRY_VARIANT));
    varint(&mut raw, &mut n, t.sample_index);
    for v in t.head_acc_m_s2 {
        float(&mut raw, &mut n, v);
    }
    for v in t.running_rms_m_s2 {
        float(&mut raw, &mut n, v);
    }
    float(&mut raw, &mut n, t.vector_running_rms_m_s2);
    float(&mut raw, &mut n, t.vdv_m_s175);
    varint(&mut raw, &mut n, t.alert_level as u32);
    // postcard writes a u8 and a bool as one raw byte each.
    if let Some(slot) = raw.get_mut(n..n + 2) {
        slot.copy_from_slice(&[t.fault_flags, u8::from(t.valid)]);
    }
    n += 2;
    cobs(raw.get(..n).unwrap_or(&[]), frame)
}

/// COBS of `raw` (shorter than 254 bytes) and the terminating zero; returns the length.
fn cobs(raw: &[u8], frame: &mut [u8; MAX_FRAME]) -> usize {
    let mut code_at = 0;
    let mut out = 1;
    let mut code: u8 = 1;
    for &b in raw {
        if b == 0 {
            if let Some(slot) = frame.get_mut(code_at) {
                *slot = code;
            }
            code_at = out;
            code = 1;
        } else {
            if let Some(slot) = frame.get_mut(out) {
                *slot = b;
            }
            code += 1;
        }
        out += 1;
    }
    if let Some(slot) = frame.get_mut(code_at) {
        *slot = code;
    }
    if let Some(slot) = frame.get_mut(out) {
        *slot = 0;
    }
    out + 1
}
