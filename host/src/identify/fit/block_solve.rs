//! Solves of one small complex block of A (at most [`MAX_BLOCK`] DOFs), one frequency at a
//! time or [`LANES`] frequencies at once.
//!
//! The fit solves the same block at 158 frequencies per evaluation; the systems differ
//! only in their numbers, so [`solve_lanes`] keeps one frequency per lane of `[f64; LANES]`
//! arrays (real and imaginary parts apart) and the compiler turns each lane-wise operation
//! into SIMD instructions of the x86-64 baseline (SSE2), with no target-specific flags.
//! Every lane does exactly the operations [`solve_small`] does on its own frequency, in
//! the same order (num-complex's product, quotient and norm written out), so the results
//! are bit for bit the same: each lane picks its own pivot (near a frequency where the
//! pivot changes, the lanes swap different rows) and skips the rows whose elimination
//! factor is zero in it. Only when a lane is singular does [`solve_lanes`] refuse, and the
//! caller solves those frequencies one at a time (to report the singular one).

use nalgebra::Complex;

/// A complex number of the fit's arithmetic.
pub type Cplx = Complex<f64>;

/// The largest uncoupled block of A this solver handles (the geometry gives 3, 6, 6, 3).
pub const MAX_BLOCK: usize = 6;

/// Outputs (rows of R): the most a block's components can read.
pub const MAX_OUTPUTS: usize = 9;

/// Right-hand sides of one block's solve: X's input columns and W's output columns.
pub const MAX_RHS: usize = 3 + MAX_OUTPUTS;

/// Frequencies solved at once: two AVX2 registers of four f64 per operation (four SSE2
/// ones in the baseline build). Eight rather than four: each operation's two registers are
/// independent, so a complex product no longer waits on the one before it (the rigid
/// fit's solver 8 % faster, BENCHMARKS.md); 158 frequencies leave 2 spare lanes either way.
pub const LANES: usize = 8;

/// One value per lane.
pub type Lane = [f64; LANES];

/// Solves A X = B in place for a small complex system (n <= 6) by Gaussian elimination
/// with partial pivoting; `rhs` holds B's first `nrhs` columns and receives X. Returns
/// false if A is singular.
// Row operations read one row and write another: index loops say that most plainly.
#[allow(clippy::needless_range_loop)]
pub fn solve_small(
    n: usize,
    a: &mut [[Cplx; MAX_BLOCK]; MAX_BLOCK],
    rhs: &mut [[Cplx; MAX_RHS]; MAX_BLOCK],
    nrhs: usize,
) -> bool {
    // 1 / the pivot of each column, used again by the back substitution (row `col` of A
    // no longer changes once its column is eliminated).
    let mut inverse = [Cplx::new(0.0, 0.0); MAX_BLOCK];
    for col in 0..n {
        // The largest |a|^2 in the column, the last one on a tie.
        let (mut pivot, mut largest) = (col, a[col][col].norm_sqr());
        for i in col + 1..n {
            let v = a[i][col].norm_sqr();
            if v.total_cmp(&largest).is_ge() {
                (pivot, largest) = (i, v);
            }
        }
        if largest == 0.0 {
            return false;
        }
        if pivot != col {
            // Only what is read later: A's columns from `col` on, B's first `nrhs`.
            for k in col..n {
                (a[col][k], a[pivot][k]) = (a[pivot][k], a[col][k]);
            }
            for k in 0..nrhs {
                (rhs[col][k], rhs[pivot][k]) = (rhs[pivot][k], rhs[col][k]);
            }
        }
        let inv = Cplx::new(1.0, 0.0) / a[col][col];
        inverse[col] = inv;
        for row in col + 1..n {
            let factor = a[row][col] * inv;
            if factor == Cplx::new(0.0, 0.0) {
                continue;
            }
            for k in col..n {
                let v = a[col][k];
                a[row][k] -= factor * v;
            }
            for k in 0..nrhs {
                let v = rhs[col][k];
                rhs[row][k] -= factor * v;
            }
        }
    }
    for col in (0..n).rev() {
        let inv = inverse[col];
        for k in 0..nrhs {
            let mut acc = rhs[col][k];
            for j in col + 1..n {
                acc -= a[col][j] * rhs[j][k];
            }
            rhs[col][k] = acc * inv;
        }
    }
    true
}

/// A complex value per lane, real and imaginary parts apart (so each is one SIMD vector).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct LaneCplx {
    /// Real parts.
    pub re: Lane,
    /// Imaginary parts.
    pub im: Lane,
}

impl LaneCplx {
    /// Zero in every lane.
    pub const ZERO: Self = Self {
        re: [0.0; LANES],
        im: [0.0; LANES],
    };

    /// Lane `l`'s value.
    pub fn get(&self, l: usize) -> Cplx {
        Cplx::new(self.re[l], self.im[l])
    }

    /// Sets lane `l`.
    pub fn set(&mut self, l: usize, value: Cplx) {
        self.re[l] = value.re;
        self.im[l] = value.im;
    }

    /// self += v * weight (a real weight), lane by lane, as num-complex computes it.
    #[inline(always)]
    pub fn add_scaled(&mut self, v: &Self, weight: f64) {
        for l in 0..LANES {
            self.re[l] += v.re[l] * weight;
            self.im[l] += v.im[l] * weight;
        }
    }

    /// self += (real - v) * weight, lane by lane, as num-complex computes
    /// `(Complex::new(real, 0.0) - v) * weight`.
    #[inline(always)]
    pub fn add_real_minus_scaled(&mut self, real: f64, v: &Self, weight: f64) {
        for l in 0..LANES {
            self.re[l] += (real - v.re[l]) * weight;
            self.im[l] += (0.0 - v.im[l]) * weight;
        }
    }

    /// self * other, lane by lane, as num-complex computes it.
    #[inline(always)]
    pub fn mul(&self, other: &Self) -> Self {
        let mut out = Self::ZERO;
        for l in 0..LANES {
            out.re[l] = self.re[l] * other.re[l] - self.im[l] * other.im[l];
            out.im[l] = self.re[l] * other.im[l] + self.im[l] * other.re[l];
        }
        out
    }

    /// self -= factor * v, lane by lane, as num-complex computes it.
    #[inline(always)]
    fn sub_mul(&mut self, factor: &Self, v: &Self) {
        let product = factor.mul(v);
        for l in 0..LANES {
            self.re[l] -= product.re[l];
            self.im[l] -= product.im[l];
        }
    }

    /// |self|^2, lane by lane, as num-complex's `norm_sqr`.
    #[inline(always)]
    pub fn norm_sqr(&self) -> Lane {
        std::array::from_fn(|l| self.re[l] * self.re[l] + self.im[l] * self.im[l])
    }

    /// The complex conjugate, lane by lane.
    #[inline(always)]
    pub fn conj(&self) -> Self {
        Self {
            re: self.re,
            im: self.im.map(|v| -v),
        }
    }

    /// self * factor (a real factor), lane by lane, as num-complex's `self * factor`.
    #[inline(always)]
    pub fn scale(&self, factor: f64) -> Self {
        Self {
            re: self.re.map(|v| v * factor),
            im: self.im.map(|v| v * factor),
        }
    }

    /// self / divisor (a real divisor per lane), as num-complex's `self / divisor`.
    #[inline(always)]
    pub fn div_real(&self, divisor: &Lane) -> Self {
        Self {
            re: std::array::from_fn(|l| self.re[l] / divisor[l]),
            im: std::array::from_fn(|l| self.im[l] / divisor[l]),
        }
    }

    /// 1 / self, lane by lane, as num-complex's `Complex::new(1.0, 0.0) / self`.
    #[inline(always)]
    pub fn recip(&self) -> Self {
        let mut out = Self::ZERO;
        for l in 0..LANES {
            let (re, im) = (self.re[l], self.im[l]);
            let norm_sqr = re * re + im * im;
            out.re[l] = (1.0 * re + 0.0 * im) / norm_sqr;
            out.im[l] = (0.0 * re - 1.0 * im) / norm_sqr;
        }
        out
    }
}

/// The square root of every lane (exact, as the scalar's).
#[inline(always)]
pub fn lane_sqrt(v: Lane) -> Lane {
    v.map(f64::sqrt)
}

/// [`LANES`] systems of one block, lane `l` holding one frequency's.
pub struct LaneSystem {
    /// A, per row and column.
    pub a: [[LaneCplx; MAX_BLOCK]; MAX_BLOCK],
    /// B's columns, per row; receives X.
    pub rhs: [[LaneCplx; MAX_RHS]; MAX_BLOCK],
}

impl LaneSystem {
    /// All zeros (every solve overwrites the entries it reads).
    pub fn new() -> Self {
        Self {
            a: [[LaneCplx::ZERO; MAX_BLOCK]; MAX_BLOCK],
            rhs: [[LaneCplx::ZERO; MAX_RHS]; MAX_BLOCK],
        }
    }
}

impl Default for LaneSystem {
    fn default() -> Self {
        Self::new()
    }
}

/// [`solve_small`] on every lane of `system` at once, bit for bit what it gives each lane.
/// Returns false, leaving `system` spoiled, when some lane is singular.
// Row operations read one row and write another: index loops say that most plainly.
#[allow(clippy::needless_range_loop)]
// Inlined into the evaluation, so that its AVX2 build (`kernels`) covers the solve too.
#[inline(always)]
pub fn solve_lanes(n: usize, system: &mut LaneSystem, nrhs: usize) -> bool {
    let LaneSystem { a, rhs } = system;
    let mut inverse = [LaneCplx::ZERO; MAX_BLOCK];
    for col in 0..n {
        let norm_sqr = |v: &LaneCplx, l: usize| v.re[l] * v.re[l] + v.im[l] * v.im[l];
        let mut pivot = [col; LANES];
        let mut largest = [0.0; LANES];
        for l in 0..LANES {
            largest[l] = norm_sqr(&a[col][col], l);
            for i in col + 1..n {
                let v = norm_sqr(&a[i][col], l);
                if v.total_cmp(&largest[l]).is_ge() {
                    (pivot[l], largest[l]) = (i, v);
                }
            }
        }
        if largest.contains(&0.0) {
            return false;
        }
        if pivot.iter().all(|&p| p == pivot[0]) {
            let pivot = pivot[0];
            if pivot != col {
                for k in col..n {
                    (a[col][k], a[pivot][k]) = (a[pivot][k], a[col][k]);
                }
                for k in 0..nrhs {
                    (rhs[col][k], rhs[pivot][k]) = (rhs[pivot][k], rhs[col][k]);
                }
            }
        } else {
            // Near a frequency where the pivot changes: each lane swaps its own rows.
            for (l, &p) in pivot.iter().enumerate() {
                if p != col {
                    swap_lane(&mut a[..], col, p, col..n, l);
                    swap_lane(&mut rhs[..], col, p, 0..nrhs, l);
                }
            }
        }
        let inv = a[col][col].recip();
        inverse[col] = inv;
        for row in col + 1..n {
            let factor = a[row][col].mul(&inv);
            // solve_small skips a row whose factor is zero: so do the lanes where it is.
            let skip: [bool; LANES] =
                std::array::from_fn(|l| factor.re[l] == 0.0 && factor.im[l] == 0.0);
            if skip == [true; LANES] {
                continue;
            }
            // (Rare: near a pivot change the lanes' zeros can sit in different rows.)
            let kept = skip.contains(&true).then(|| (a[row], rhs[row]));
            let (above, below) = a.split_at_mut(row);
            for k in col..n {
                below[0][k].sub_mul(&factor, &above[col][k]);
            }
            let (above, below) = rhs.split_at_mut(row);
            for k in 0..nrhs {
                below[0][k].sub_mul(&factor, &above[col][k]);
            }
            if let Some((kept_a, kept_rhs)) = kept {
                for (l, _) in skip.iter().enumerate().filter(|(_, skipped)| **skipped) {
                    restore_lane(&mut a[row], &kept_a, l);
                    restore_lane(&mut rhs[row], &kept_rhs, l);
                }
            }
        }
    }
    for col in (0..n).rev() {
        let inv = inverse[col];
        for k in 0..nrhs {
            let mut acc = rhs[col][k];
            for j in col + 1..n {
                acc.sub_mul(&a[col][j], &rhs[j][k]);
            }
            rhs[col][k] = acc.mul(&inv);
        }
    }
    true
}

/// Puts lane `l` of `kept` back into `row`.
fn restore_lane<const C: usize>(row: &mut [LaneCplx; C], kept: &[LaneCplx; C], l: usize) {
    for (v, k) in row.iter_mut().zip(kept) {
        (v.re[l], v.im[l]) = (k.re[l], k.im[l]);
    }
}

/// Swaps lane `l` of rows `i` and `j` (`i < j`) over `columns`.
fn swap_lane<const C: usize>(
    rows: &mut [[LaneCplx; C]],
    i: usize,
    j: usize,
    columns: std::ops::Range<usize>,
    l: usize,
) {
    let (upper, lower) = rows.split_at_mut(j);
    let (first, second) = (&mut upper[i], &mut lower[0]);
    for k in columns {
        std::mem::swap(&mut first[k].re[l], &mut second[k].re[l]);
        std::mem::swap(&mut first[k].im[l], &mut second[k].im[l]);
    }
}

#[cfg(test)]
// Systems are built and compared entry by entry across several arrays.
#[allow(clippy::needless_range_loop)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    fn random_system(
        rng: &mut ChaCha8Rng,
        n: usize,
        nrhs: usize,
    ) -> ([[Cplx; MAX_BLOCK]; MAX_BLOCK], [[Cplx; MAX_RHS]; MAX_BLOCK]) {
        let mut a = [[Cplx::new(0.0, 0.0); MAX_BLOCK]; MAX_BLOCK];
        let mut b = [[Cplx::new(0.0, 0.0); MAX_RHS]; MAX_BLOCK];
        for i in 0..n {
            for j in 0..n {
                // A sparse symmetric pattern like the model's, some zeros off the diagonal.
                if i == j || (i + j) % 3 != 0 {
                    a[i][j] = Cplx::new(rng.random_range(-1e4..1e4), rng.random_range(-50.0..50.0));
                }
            }
            for k in 0..nrhs {
                b[i][k] = Cplx::new(rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0));
            }
        }
        (a, b)
    }

    fn bits(v: Cplx) -> (u64, u64) {
        (v.re.to_bits(), v.im.to_bits())
    }

    #[test]
    fn lanes_give_the_single_solves_bits_whatever_their_pivots() {
        let mut rng = ChaCha8Rng::seed_from_u64(18);
        for trial in 0..400 {
            let n = [3, 6][trial % 2];
            let nrhs = 1 + trial % MAX_RHS;
            let mut system = LaneSystem::new();
            let mut singles = Vec::new();
            // Half the trials: the lanes are one system scaled slightly (the same pivots,
            // as neighbouring frequencies mostly are); the others: unrelated systems (each
            // lane its own pivots, its own rows skipped).
            let (a0, b0) = random_system(&mut rng, n, nrhs);
            for l in 0..LANES {
                let (mut a, b) = if trial % 4 < 2 {
                    random_system(&mut rng, n, nrhs)
                } else {
                    (a0, b0)
                };
                if trial % 4 >= 2 {
                    let scale = 1.0 + 1e-3 * l as f64;
                    for row in a.iter_mut().take(n) {
                        for v in row.iter_mut().take(n) {
                            *v *= scale;
                        }
                    }
                }
                for i in 0..n {
                    for j in 0..n {
                        system.a[i][j].set(l, a[i][j]);
                    }
                    for k in 0..nrhs {
                        system.rhs[i][k].set(l, b[i][k]);
                    }
                }
                singles.push((a, b));
            }
            assert!(solve_lanes(n, &mut system, nrhs), "trial {trial}");
            for (l, (mut a, mut b)) in singles.into_iter().enumerate() {
                assert!(solve_small(n, &mut a, &mut b, nrhs));
                for i in 0..n {
                    for k in 0..nrhs {
                        assert_eq!(
                            bits(system.rhs[i][k].get(l)),
                            bits(b[i][k]),
                            "trial {trial}"
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn a_singular_lane_is_refused() {
        let mut system = LaneSystem::new();
        for l in 0..LANES {
            for i in 0..3 {
                let v = if l == 2 && i == 1 {
                    0.0
                } else {
                    1.0 + i as f64
                };
                system.a[i][i].set(l, Cplx::new(v, 0.0));
                system.rhs[i][0].set(l, Cplx::new(1.0, 0.0));
            }
        }
        assert!(!solve_lanes(3, &mut system, 1));
    }
}
