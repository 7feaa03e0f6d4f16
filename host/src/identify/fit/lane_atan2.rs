//! atan2 of every lane, for the phase residuals of the objective's evaluation.
//!
//! Why not libm's: one call a phase residual was a tenth of a rigid fit's instructions,
//! and a scalar call per lane keeps the evaluation's lanes apart. No crate serves: `libm`
//! is scalar, and the SIMD ones (sleef) need nightly Rust or use fused multiply-adds,
//! which would give the AVX2 build other bits than the baseline build
//! ([`super::kernels`]). This is plain f64 arithmetic with selects, the same bits in both
//! builds, within 3 ulp of libm's atan2 (the test below).
//!
//! Method (Cephes, Moshier 1989): with t = min(|x|, |y|) / max(|x|, |y|) in [0, 1],
//! atan(t) is a rational function u + u z P(z) / Q(z), z = u^2, of u = t below tan(pi/8)
//! and u = (t - 1) / (t + 1) (plus pi/4) above it; the octant and the quadrant then follow
//! from which of |x|, |y| is larger and from the signs. Each constant pi/4, pi/2, pi adds
//! back the part of pi its double cannot hold.

use std::f64::consts::{FRAC_PI_2, FRAC_PI_4, PI};

use super::block_solve::Lane;

/// Above tan(pi/8) the argument is reduced by pi/4.
const TAN_PI_8: f64 = 0.414_213_562_373_095_05;
/// pi/2 less the double nearest it (pi/4's and pi's are a half and twice it).
const PI_2_REST: f64 = 6.123_233_995_736_766e-17;
/// The numerator's coefficients, highest power first.
const P: [f64; 5] = [
    -8.750_608_600_031_904e-1,
    -1.615_753_718_733_365e1,
    -7.500_855_792_314_705e1,
    -1.228_866_684_490_136_2e2,
    -6.485_021_904_942_025e1,
];
/// The monic denominator's coefficients below its leading 1, highest power first.
const Q: [f64; 5] = [
    2.485_846_490_142_306_3e1,
    1.650_270_098_316_988e2,
    4.328_810_604_912_903e2,
    4.853_903_996_359_137e2,
    1.945_506_571_482_614e2,
];

/// atan(t) for t in [0, 1].
#[inline(always)]
fn atan_unit(t: f64) -> f64 {
    let reduced = t > TAN_PI_8;
    let u = if reduced { (t - 1.0) / (t + 1.0) } else { t };
    let z = u * u;
    let p = (((P[0] * z + P[1]) * z + P[2]) * z + P[3]) * z + P[4];
    let q = ((((z + Q[0]) * z + Q[1]) * z + Q[2]) * z + Q[3]) * z + Q[4];
    let a = u + u * z * p / q;
    if reduced {
        FRAC_PI_4 + (a + 0.5 * PI_2_REST)
    } else {
        a
    }
}

/// atan2(y, x) in [-pi, pi], as libm's up to 3 ulp, signed zeros and all.
#[inline(always)]
pub fn atan2(y: f64, x: f64) -> f64 {
    let (ax, ay) = (x.abs(), y.abs());
    let steep = ay > ax;
    let (most, least) = if steep { (ay, ax) } else { (ax, ay) };
    let t = if most > 0.0 { least / most } else { 0.0 };
    let mut a = atan_unit(t);
    if steep {
        a = (FRAC_PI_2 - a) + PI_2_REST;
    }
    if x.is_sign_negative() {
        a = (PI - a) + 2.0 * PI_2_REST;
    }
    if y.is_sign_negative() { -a } else { a }
}

/// atan2 of every lane.
#[inline(always)]
pub fn lane_atan2(y: &Lane, x: &Lane) -> Lane {
    std::array::from_fn(|l| atan2(y[l], x[l]))
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    fn ulps(got: f64, want: f64) -> f64 {
        (got - want).abs()
            / if want == 0.0 {
                f64::MIN_POSITIVE
            } else {
                f64_ulp(want)
            }
    }

    fn f64_ulp(v: f64) -> f64 {
        let bits = v.abs().to_bits();
        f64::from_bits(bits + 1) - v.abs()
    }

    /// Against libm's atan2 over every quadrant and twelve decades of |x| and |y|.
    #[test]
    fn within_3_ulp_of_libm_everywhere() {
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let mut worst: f64 = 0.0;
        for _ in 0..400_000 {
            let mut draw = || rng.random_range(-1.0..1.0) * 10f64.powf(rng.random_range(-6.0..6.0));
            let (y, x) = (draw(), draw());
            worst = worst.max(ulps(atan2(y, x), y.atan2(x)));
        }
        assert!(worst <= 3.0, "{worst} ulp");
    }

    /// The axes, the diagonals and the signed zeros, exactly as libm.
    #[test]
    fn the_special_points_are_libms() {
        for (y, x) in [
            (0.0, 0.0),
            (-0.0, 0.0),
            (0.0, -0.0),
            (-0.0, -0.0),
            (1.0, 0.0),
            (-1.0, 0.0),
            (0.0, -1.0),
            (-0.0, -1.0),
            (1.0, 1.0),
            (-1.0, -1.0),
            (1e-300, -1.0),
        ] {
            assert_eq!(
                atan2(y, x).to_bits(),
                y.atan2(x).to_bits(),
                "atan2({y}, {x})"
            );
        }
        let lanes = lane_atan2(&[1.0; 8], &[-1.0; 8]);
        assert!(lanes.iter().all(|&v| v == (1.0f64).atan2(-1.0)));
    }
}
