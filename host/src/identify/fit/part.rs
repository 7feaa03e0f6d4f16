//! One independent part of the fit ([`FitSubsystem`]) as a least-squares problem of its
//! own: its parameters, its residuals, and a dense Jacobian. The fit solves the parts
//! apart because the cost is their sum and no parameter moves two of them: each part gets
//! its own damping and stops when it has converged, and a cheaper evaluation (one block
//! of A instead of all) per iteration.

use nalgebra::DMatrix;

use super::objective::{FitSubsystem, Objective};
use super::solver::Problem;

/// A part of `objective`, the other parts' parameters held at `theta`'s values (they do
/// not change its residuals; they only fill the full vector the model is assembled from).
pub struct PartProblem<'a> {
    objective: &'a Objective,
    part: &'a FitSubsystem,
    theta: Vec<f64>,
}

impl<'a> PartProblem<'a> {
    /// The part `part` of `objective` around the full log-parameter vector `theta`.
    pub fn new(objective: &'a Objective, part: &'a FitSubsystem, theta: &[f64]) -> Self {
        Self {
            objective,
            part,
            theta: theta.to_vec(),
        }
    }

    /// The part's entries of a full vector.
    pub fn restrict(&self, full: &[f64]) -> Vec<f64> {
        self.part.params.iter().map(|&p| full[p]).collect()
    }

    /// The position of unknown `unknown` among the part's parameters, if it is one of them.
    pub fn position(&self, unknown: usize) -> Option<usize> {
        self.part.params.iter().position(|&p| p == unknown)
    }

    /// Writes the part's entries `x` into the full vector `full`.
    pub fn scatter(&self, x: &[f64], full: &mut [f64]) {
        for (&p, &v) in self.part.params.iter().zip(x) {
            full[p] = v;
        }
    }
}

impl Problem for PartProblem<'_> {
    fn residual_count(&self) -> usize {
        self.part.rows.len()
    }
    fn param_count(&self) -> usize {
        self.part.params.len()
    }
    fn evaluate(
        &self,
        x: &[f64],
        residuals: &mut [f64],
        jacobian: Option<&mut DMatrix<f64>>,
    ) -> Result<(), String> {
        let mut theta = self.theta.clone();
        self.scatter(x, &mut theta);
        self.objective
            .evaluate_subsystem(self.part, &theta, residuals, jacobian)
    }
    fn gram(&self, jacobian: &DMatrix<f64>) -> DMatrix<f64> {
        gram_dense(jacobian)
    }
}

/// J^T J of a dense Jacobian: one dot product of two contiguous columns per entry of the
/// lower triangle (J is column-major), mirrored. With AVX2 where the CPU has it
/// ([`super::kernels`]): the same bits either way.
pub fn gram_dense(jacobian: &DMatrix<f64>) -> DMatrix<f64> {
    #[cfg(target_arch = "x86_64")]
    if super::kernels::avx2() {
        // SAFETY: the CPU has AVX2 (checked just above).
        return unsafe { gram_dense_avx2(jacobian) };
    }
    gram_dense_portable(jacobian)
}

/// [`gram_dense_portable`] with AVX2, four entries of a row of J^T J at a time: column `a`
/// against columns `b..b + 4` in one pass, each product's four running sums one register
/// (lane k holds the sum of the entries k mod 4), so four additions are in flight where
/// one product alone waits on its own (the compiler, left to itself, spreads a group over
/// the products instead). Each entry is [`dot`]'s arithmetic in [`dot`]'s order: the same
/// bits (tested).
///
/// # Safety
/// The CPU must have AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn gram_dense_avx2(jacobian: &DMatrix<f64>) -> DMatrix<f64> {
    use std::arch::x86_64::{
        _mm256_add_pd, _mm256_loadu_pd, _mm256_mul_pd, _mm256_setzero_pd, _mm256_storeu_pd,
    };
    const GROUP: usize = 4;
    let (m, n) = jacobian.shape();
    let data = jacobian.as_slice();
    let column = |a: usize| &data[a * m..(a + 1) * m];
    let full = m / 4 * 4;
    let mut out = DMatrix::zeros(n, n);
    for a in 0..n {
        let x = column(a);
        let mut b = 0;
        while b + GROUP <= a + 1 {
            let ys: [&[f64]; GROUP] = std::array::from_fn(|g| column(b + g));
            let mut sums = [_mm256_setzero_pd(); GROUP];
            for c in (0..full).step_by(4) {
                // SAFETY: c + 4 <= full <= m, the length of every column.
                let xv = unsafe { _mm256_loadu_pd(x.as_ptr().add(c)) };
                for (sum, y) in sums.iter_mut().zip(&ys) {
                    // SAFETY: as above.
                    let yv = unsafe { _mm256_loadu_pd(y.as_ptr().add(c)) };
                    *sum = _mm256_add_pd(*sum, _mm256_mul_pd(xv, yv));
                }
            }
            for (g, (sum, y)) in sums.iter().zip(&ys).enumerate() {
                let mut lanes = [0.0; 4];
                // SAFETY: `lanes` holds four f64.
                unsafe { _mm256_storeu_pd(lanes.as_mut_ptr(), *sum) };
                let v = dot_total(lanes, &x[full..], &y[full..]);
                out[(a, b + g)] = v;
                out[(b + g, a)] = v;
            }
            b += GROUP;
        }
        for b in b..=a {
            let v = dot(x, column(b));
            out[(a, b)] = v;
            out[(b, a)] = v;
        }
    }
    out
}

/// J^T J itself, inlined into both callers above.
#[inline(always)]
fn gram_dense_portable(jacobian: &DMatrix<f64>) -> DMatrix<f64> {
    let (m, n) = jacobian.shape();
    let data = jacobian.as_slice();
    let column = |a: usize| &data[a * m..(a + 1) * m];
    let mut out = DMatrix::zeros(n, n);
    for a in 0..n {
        for b in 0..=a {
            let v = dot(column(a), column(b));
            out[(a, b)] = v;
            out[(b, a)] = v;
        }
    }
    out
}

/// A dot product with four running sums (the compiler vectorizes it; one sum could not
/// be reordered).
#[inline(always)]
fn dot(x: &[f64], y: &[f64]) -> f64 {
    let mut sums = [0.0; 4];
    let (xc, yc) = (x.chunks_exact(4), y.chunks_exact(4));
    let (x_tail, y_tail) = (xc.remainder(), yc.remainder());
    for (a, b) in xc.zip(yc) {
        for k in 0..4 {
            sums[k] += a[k] * b[k];
        }
    }
    dot_total(sums, x_tail, y_tail)
}

/// A dot product's total from its four running sums over the chunks of four and the
/// remainder `x_tail . y_tail`: the order both J^T J builds share, so they agree in bits.
#[inline(always)]
fn dot_total(sums: [f64; 4], x_tail: &[f64], y_tail: &[f64]) -> f64 {
    let tail: f64 = x_tail.iter().zip(y_tail).map(|(a, b)| a * b).sum();
    (sums[0] + sums[1]) + (sums[2] + sums[3]) + tail
}

#[cfg(all(test, target_arch = "x86_64"))]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    #[test]
    fn the_avx2_gram_gives_the_portable_gram_bits_and_the_product() {
        let mut rng = ChaCha8Rng::seed_from_u64(18);
        // Row counts that leave every remainder of the four running sums.
        for rows in [948, 949, 950, 951, 1896] {
            let jacobian = DMatrix::from_fn(rows, 14, |_, _| rng.random_range(-1e3..1e3));
            let portable = gram_dense_portable(&jacobian);
            let product = jacobian.transpose() * &jacobian;
            assert!(
                (&portable - &product).amax() <= 1e-9 * product.amax(),
                "{rows} rows"
            );
            if !super::super::kernels::avx2() {
                continue;
            }
            // SAFETY: the CPU has AVX2 (checked above).
            let avx2 = unsafe { gram_dense_avx2(&jacobian) };
            let bits = |m: &DMatrix<f64>| m.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(&portable), bits(&avx2), "{rows} rows");
        }
    }
}
