//! A deterministic, band-limited tri-axial test input, bit-identical on host and device.
//!
//! Pure f32 arithmetic on integer noise (no libm, no platform rounding differences), so
//! the same sample index gives the same bits everywhere: the firmware's self-test and the
//! host's check of it feed the realization exactly the same numbers.

/// Input accelerations (m/s^2, x, y, z) of roughly 0.3 m/s^2 rms per axis, low-passed
/// white noise with most energy below about 20 Hz at 500 Hz.
#[derive(Clone, Debug)]
pub struct TestVector {
    rng: [u32; 3],
    stage1: [f32; 3],
    stage2: [f32; 3],
}

/// Pole of each of the two cascaded one-pole low-passes.
const POLE: f32 = 0.85;
/// Scales uniform noise in [-1, 1) to about 0.3 m/s^2 rms after the filters.
const GAIN_M_S2: f32 = 0.12;

impl TestVector {
    /// A sequence for a seed; different axes get decorrelated streams.
    pub fn new(seed: u32) -> Self {
        let mix = |k: u32| {
            let s = seed
                .wrapping_mul(0x9E37_79B9)
                .wrapping_add(k.wrapping_mul(0x85EB_CA6B));
            if s == 0 { 0x1234_5678 } else { s }
        };
        Self {
            rng: [mix(1), mix(2), mix(3)],
            stage1: [0.0; 3],
            stage2: [0.0; 3],
        }
    }
}

fn xorshift32(state: &mut u32) -> u32 {
    let mut x = *state;
    x ^= x << 13;
    x ^= x >> 17;
    x ^= x << 5;
    *state = x;
    x
}

impl Iterator for TestVector {
    type Item = [f32; 3];

    fn next(&mut self) -> Option<[f32; 3]> {
        let mut out = [0.0; 3];
        let filters = self
            .rng
            .iter_mut()
            .zip(self.stage1.iter_mut().zip(self.stage2.iter_mut()));
        for (value, (rng, (stage1, stage2))) in out.iter_mut().zip(filters) {
            // Top 24 bits to [-1, 1): exact in f32.
            let noise = (xorshift32(rng) >> 8) as i32 - (1 << 23);
            let white = noise as f32 * (1.0 / (1 << 23) as f32);
            *stage1 = POLE * *stage1 + (1.0 - POLE) * white;
            *stage2 = POLE * *stage2 + (1.0 - POLE) * *stage1;
            *value = GAIN_M_S2 * 10.0 * *stage2;
        }
        Some(out)
    }
}
