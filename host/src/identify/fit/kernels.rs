//! The fit's two hot loops, the part evaluation (`Objective::evaluate_scope`, with the
//! block solve inlined into it) and J^T J (`part::gram_dense`), are each compiled twice:
//! for the x86-64 baseline (SSE2) and with AVX2, and the AVX2 build runs where the CPU
//! has it. A [`super::block_solve::Lane`] of eight f64 is then two registers instead of
//! four, and `round` one instruction instead of a software routine.
//!
//! Both builds give the same bits: the same operations in the same order, only wider. No
//! FMA is enabled, and Rust never fuses a multiply and an add on its own. The tests of
//! `objective` and `part` compare the two builds bit for bit.

/// Whether this CPU runs the AVX2 builds (detected once, then a cached flag).
#[cfg(target_arch = "x86_64")]
pub fn avx2() -> bool {
    std::arch::is_x86_feature_detected!("avx2")
}

use nalgebra::{DMatrix, DVector};

/// J^T v, bit for bit nalgebra's `J.tr_mul(&v)` (one dot product per column of J, eight
/// running sums over the rows in chunks of eight, joined as `((0 + (s0 + s4)) + (s1 +
/// s5)) + ...`, then the remaining rows one by one), with AVX2 where the CPU has it: the
/// sums s0..s3 and s4..s7 are then one register each. The solver forms it once per
/// accepted step (the gradient) and once per geodesic acceleration.
pub fn tr_mul_vec(jacobian: &DMatrix<f64>, v: &[f64]) -> DVector<f64> {
    assert_eq!(
        jacobian.nrows(),
        v.len(),
        "J^T v: J has {} rows",
        jacobian.nrows()
    );
    #[cfg(target_arch = "x86_64")]
    if avx2() {
        // SAFETY: the CPU has AVX2 (checked just above).
        return unsafe { tr_mul_vec_avx2(jacobian, v) };
    }
    tr_mul_vec_portable(jacobian, v)
}

/// [`tr_mul_vec_portable`] compiled with AVX2.
///
/// # Safety
/// The CPU must have AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn tr_mul_vec_avx2(jacobian: &DMatrix<f64>, v: &[f64]) -> DVector<f64> {
    tr_mul_vec_portable(jacobian, v)
}

/// J^T v in nalgebra's order, inlined into both callers above.
#[inline(always)]
fn tr_mul_vec_portable(jacobian: &DMatrix<f64>, v: &[f64]) -> DVector<f64> {
    let m = jacobian.nrows();
    let data = jacobian.as_slice();
    let full = m / 8 * 8;
    DVector::from_iterator(
        jacobian.ncols(),
        data.chunks_exact(m.max(1))
            .take(jacobian.ncols())
            .map(|column| {
                let (mut low, mut high) = ([0.0f64; 4], [0.0f64; 4]);
                for (x, y) in column[..full]
                    .chunks_exact(8)
                    .zip(v[..full].chunks_exact(8))
                {
                    for k in 0..4 {
                        low[k] += x[k] * y[k];
                        high[k] += x[k + 4] * y[k + 4];
                    }
                }
                let mut sum = 0.0;
                for k in 0..4 {
                    sum += low[k] + high[k];
                }
                for (x, y) in column[full..].iter().zip(&v[full..]) {
                    sum += x * y;
                }
                sum
            }),
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    #[test]
    fn j_transpose_v_gives_nalgebras_bits() {
        let mut rng = ChaCha8Rng::seed_from_u64(30);
        // Row counts that leave every remainder of the chunks of eight; a part's and the
        // whole problem's.
        for rows in [1, 7, 8, 9, 15, 948, 1263, 1896, 3792] {
            let jacobian = DMatrix::from_fn(rows, 14, |_, _| rng.random_range(-1e3..1e3));
            let v: Vec<f64> = (0..rows).map(|_| rng.random_range(-1.0..1.0)).collect();
            let expected = jacobian.tr_mul(&DVector::from_column_slice(&v));
            let bits = |x: &DVector<f64>| x.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
            assert_eq!(
                bits(&tr_mul_vec(&jacobian, &v)),
                bits(&expected),
                "{rows} rows"
            );
            assert_eq!(
                bits(&tr_mul_vec_portable(&jacobian, &v)),
                bits(&expected),
                "{rows} rows, portable"
            );
        }
    }
}
