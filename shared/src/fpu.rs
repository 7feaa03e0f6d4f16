//! Square root on the FPU where there is one, bit-identical to the host.
//!
//! `libm::sqrtf` is software on `thumbv7em` (about 59 instructions; libm has no ARM path),
//! while the Cortex-M4F's `vsqrt.f32` takes one. Both are correctly rounded as IEEE 754
//! requires, so the device and the host compute the same bits; the self-test image checks
//! that on the device (`firmware/src/bin/selftest.rs`) and the host tests check the
//! fallback against `f64` rounding.
//!
//! Rust exposes no stable `f32::sqrt` in `core` and no `sreg` asm operands on this target
//! without an unstable target feature, so the value crosses in a core register and `s0`
//! is declared clobbered: three instructions plus the compiler's moves.
#![allow(unsafe_code)]

/// Correctly rounded single-precision square root (NaN for negative input, as IEEE 754).
#[inline(always)]
pub fn sqrt_f32(x: f32) -> f32 {
    #[cfg(all(target_arch = "arm", target_abi = "eabihf"))]
    {
        let bits: u32;
        // SAFETY: pure register arithmetic: reads `x` from a core register, computes in
        // `s0` (declared clobbered, so the compiler keeps nothing there) and returns the
        // result in a core register. No memory, no stack. Not `preserves_flags`: Rust's
        // asm rules count FPSCR's exception flags as flags, and `vsqrt` sets its inexact
        // flag (IXC) for most inputs and its invalid flag (IOC) for negative ones, as
        // Rust's own float arithmetic does (nothing in this crate reads them).
        unsafe {
            core::arch::asm!(
                "vmov s0, {x}",
                "vsqrt.f32 s0, s0",
                "vmov {y}, s0",
                x = in(reg) x.to_bits(),
                y = lateout(reg) bits,
                out("s0") _,
                options(pure, nomem, nostack),
            );
        }
        f32::from_bits(bits)
    }
    #[cfg(not(all(target_arch = "arm", target_abi = "eabihf")))]
    {
        libm::sqrtf(x)
    }
}

#[cfg(test)]
mod tests {
    use super::sqrt_f32;

    /// The f64 square root of an f32 rounded to f32 is the correctly rounded f32 result
    /// (53 >= 2 x 24 + 2 bits), an independent reference for the fallback.
    #[test]
    fn matches_correct_rounding_over_a_sweep_of_bit_patterns() {
        let mut bits: u32 = 0;
        let mut checked = 0;
        while bits < 0x7f80_0000 {
            let x = f32::from_bits(bits);
            let expected = (f64::from(x)).sqrt() as f32;
            assert_eq!(sqrt_f32(x).to_bits(), expected.to_bits(), "sqrt({x:e})");
            bits += 0x0000_1fff;
            checked += 1;
        }
        assert!(checked > 250_000);
    }

    #[test]
    fn special_values_follow_ieee_754() {
        assert_eq!(sqrt_f32(0.0).to_bits(), 0.0f32.to_bits());
        assert_eq!(sqrt_f32(-0.0).to_bits(), (-0.0f32).to_bits());
        assert_eq!(sqrt_f32(f32::INFINITY), f32::INFINITY);
        assert!(sqrt_f32(-1.0).is_nan());
        assert!(sqrt_f32(f32::NAN).is_nan());
    }
}
