//! The device's input resolution: the litter-frame input reaches the model as a whole
//! number of [`INPUT_STEP_M_S2`] steps, an `i16` count per axis.
//!
//! Why quantize at all: the device streams the input it used (`DeviceToHost::Input`) so a
//! session can be re-analysed on the host bit for bit. A compact stream cannot carry
//! arbitrary f32s, so the pipeline computes on exactly what it can stream: a power-of-two
//! step, which an `i16` count times the step gives back exactly in f32. The step,
//! 2^-9 m/s^2 (about 0.002 m/s^2), is ten times finer than an LIS3DH's least
//! significant bit at +-4 g, so the sensor's own resolution is kept; the `i16` range is
//! +-64 m/s^2 (6.5 g). See docs/exposure.md#input-resolution.

/// Counts per m/s^2 (a power of two, so counts and m/s^2 convert exactly).
pub const INPUT_COUNTS_PER_M_S2: f32 = 512.0;

/// One count, m/s^2 (2^-9).
pub const INPUT_STEP_M_S2: f32 = 1.0 / INPUT_COUNTS_PER_M_S2;

/// Largest count magnitude: symmetric, so that clipping never depends on the sign.
pub const INPUT_MAX_COUNTS: i16 = i16::MAX;

/// Largest input magnitude the counts hold, m/s^2 (just under 64). The sensor checks
/// treat anything at or above it as saturated, as for the sensor's own full scale.
pub const INPUT_RANGE_M_S2: f32 = INPUT_MAX_COUNTS as f32 * INPUT_STEP_M_S2;

/// The count nearest `v_m_s2` (ties to even) after clipping to +-`full_scale_m_s2` and to
/// +-[`INPUT_MAX_COUNTS`]. `v_m_s2` should be finite (the pipeline holds the last finite
/// sample instead); NaN gives 0 rather than a panic.
#[inline(always)]
pub fn to_counts(v_m_s2: f32, full_scale_m_s2: f32) -> i16 {
    // Through i32, which the FPU converts in one instruction; the clip keeps the value
    // inside i16.
    counts_f32(v_m_s2, full_scale_m_s2) as i32 as i16
}

/// [`to_counts`] as a whole-valued f32 (exact: below 2^15), so that the device can take
/// both the count it streams and the m/s^2 its model gets (`counts * INPUT_STEP_M_S2`,
/// exact) from one rounding.
#[inline(always)]
pub fn counts_f32(v_m_s2: f32, full_scale_m_s2: f32) -> f32 {
    // Clipped in counts (scaling by a power of two is exact), with plain comparisons:
    // f32::clamp would add NaN handling and a panic path.
    let max = f32::from(INPUT_MAX_COUNTS);
    let full_scale = full_scale_m_s2 * INPUT_COUNTS_PER_M_S2;
    let limit = if full_scale < max { full_scale } else { max };
    let scaled = v_m_s2 * INPUT_COUNTS_PER_M_S2;
    let scaled = if scaled > limit {
        limit
    } else if scaled < -limit {
        -limit
    } else {
        scaled
    };
    // Adding and taking away 1.5 * 2^23 leaves no fraction bits for |scaled| < 2^22: f32's
    // own rounding (to nearest, ties to even) rounds to a whole count, in two additions.
    (scaled + ROUNDER) - ROUNDER
}

/// 1.5 * 2^23: see [`to_counts`].
const ROUNDER: f32 = 12_582_912.0;

/// The acceleration `counts` stands for, m/s^2 (exact).
#[inline(always)]
pub fn to_m_s2(counts: i16) -> f32 {
    f32::from(counts) * INPUT_STEP_M_S2
}

/// A sample (three axes) as the model gets it: clipped to +-`full_scale_m_s2` and to the
/// counts' range, rounded to the step. The host's references use this to feed their
/// models exactly what the device's does.
pub fn quantize_m_s2(sample_m_s2: [f32; 3], full_scale_m_s2: f32) -> [f32; 3] {
    sample_m_s2.map(|v| to_m_s2(to_counts(v, full_scale_m_s2)))
}

#[cfg(test)]
mod tests {
    use super::*;

    const NO_LIMIT: f32 = f32::INFINITY;

    #[test]
    fn the_step_is_a_power_of_two_and_counts_convert_back_exactly() {
        assert_eq!(INPUT_STEP_M_S2, 2f32.powi(-9));
        for c in [-32767i16, -1000, -1, 0, 1, 513, 32767] {
            assert_eq!(to_m_s2(c), f64::from(c) as f32 / 512.0);
            assert_eq!(to_counts(to_m_s2(c), NO_LIMIT), c, "round trip of {c}");
        }
    }

    #[test]
    fn values_round_to_the_nearest_step_ties_to_even() {
        let step = f64::from(INPUT_STEP_M_S2);
        // Exactly representable ties and near-ties, checked against f64 arithmetic.
        for (v, expect) in [
            (0.5 * step, 0),
            (-0.5 * step, 0),
            (1.5 * step, 2),
            (0.499_999 * step, 0),
            (0.500_001 * step, 1),
            (-2.5 * step, -2),
            (-3.5 * step, -4),
            (9.81, (9.81f32 as f64 * 512.0).round_ties_even() as i16),
            (-3.3, (-3.3f32 as f64 * 512.0).round_ties_even() as i16),
        ] {
            assert_eq!(to_counts(v as f32, NO_LIMIT), expect, "{v}");
        }
        // The largest f32 below one half step must round down (adding 0.5 would not).
        let below_half = f32::from_bits((0.5f32).to_bits() - 1) * INPUT_STEP_M_S2;
        assert_eq!(to_counts(below_half, NO_LIMIT), 0);
        // Every count's neighbourhood, against f64 rounding.
        for c in (-32767i32..=32767).step_by(97) {
            for frac in [-0.49f64, -0.25, 0.0, 0.3, 0.49] {
                let v = ((f64::from(c) + frac) / 512.0) as f32;
                let expect = (f64::from(v) * 512.0).round_ties_even() as i16;
                assert_eq!(to_counts(v, NO_LIMIT), expect, "{v}");
            }
        }
    }

    #[test]
    fn inputs_beyond_the_full_scale_or_the_range_are_clipped() {
        assert_eq!(to_counts(1e30, NO_LIMIT), INPUT_MAX_COUNTS);
        assert_eq!(to_counts(-1e30, NO_LIMIT), -INPUT_MAX_COUNTS);
        assert_eq!(to_counts(100.0, NO_LIMIT), INPUT_MAX_COUNTS);
        assert_eq!(to_counts(50.0, 20.0), 20 * 512);
        assert_eq!(to_counts(-50.0, 20.0), -20 * 512);
        assert_eq!(to_counts(f32::NAN, NO_LIMIT), 0);
        assert_eq!(INPUT_RANGE_M_S2, 64.0 - 1.0 / 512.0);
    }

    #[test]
    fn quantizing_twice_changes_nothing() {
        for v in [0.0f32, 1e-4, 0.123_456, -7.77, 39.2, 63.999, 1e6] {
            let once = quantize_m_s2([v, -v, v * 0.5], 40.0);
            assert_eq!(quantize_m_s2(once, 40.0), once, "{v}");
        }
    }
}
