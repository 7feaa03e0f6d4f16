//! Bounds on how far a stable two-state linear recursion can amplify a bounded input.
//!
//! The blob validator needs them (docs/protocol.md, "Validation", step 7): a
//! realization or filter whose poles are inside the unit circle can still carry a gain so
//! large (a coefficient of 1e30, a pole 1e-12 inside the circle) that input within the
//! sensor's full scale overflows f32.
//!
//! For x[k+1] = A x\[k\] + b u\[k\] with |u| <= U and x\[0\] = 0, write A = T M T^-1 with M
//! diagonal (real poles) or a scaled rotation (a complex pair), whose powers have norm
//! |pole|^k. In z = T^-1 x each mode is a geometric series: |z_i| <= |(T^-1 b)_i| U /
//! (1 - |pole_i|); then ||x|| <= sum ||t_i|| |z_i| and an output c x + d u is at most
//! (sum |(c T)_i| |z_i| + |d|) U. The bound is the l1 norm of the impulse response for a
//! diagonal or rotation form (the realization's blocks) and stays within a small factor of
//! it for a filter's companion form unless its two poles nearly coincide (T close to
//! singular), where it grows and the recursion is refused.
//!
//! In f32, on the FPU: the device validates every blob it loads, and f64 in software would
//! cost 6 KiB of flash. A is given as D = A - I, so each pole's distance from the unit
//! circle comes from D's small eigenvalues without cancellation, and the result carries a
//! margin ([`ROUNDING_MARGIN`]) for the rounding of the few operations that make it.
//!
//! Written here because no no_std crate bounds the l1 norm of a recursion's impulse
//! response without a heap; tested against closed forms and brute-force sums.

use crate::fpu::sqrt_f32;

/// Largest 1 / (1 - |pole|) accepted: a pole this close to the unit circle is no body's
/// or weighting's (the slowest the product builds, at 2 kHz, is about 3,000), and beyond
/// it the f32 rounding of each step, amplified that many times, would no longer be small
/// against the signal (it times the f32 epsilon stays under 0.01).
pub const MAX_POLE_SUM: f32 = 1.0e5;

/// Factor every bound is multiplied by: the relative rounding error of its own f32
/// arithmetic (a few dozen operations, each within 6e-8, on a pole margin of at least
/// 1e-5 known to about 1e-7) is under 1 %.
pub const ROUNDING_MARGIN: f32 = 1.05;

/// The Euclidean norm of a 2-vector.
pub fn vector_norm(v: [f32; 2]) -> f32 {
    sqrt_f32(v[0] * v[0] + v[1] * v[1])
}

/// How much a recursion amplifies a bounded input: the bounds on its state's norm and on
/// its output, per unit of input bound.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Amplification {
    /// Bound on ||x|| per unit input bound.
    pub state: f32,
    /// Bound on |y| per unit input bound.
    pub output: f32,
}

/// A recursion x[k+1] = A x\[k\] + b u\[k\] in modal coordinates z = T^-1 x, with the bound on
/// each |z_i| per unit input bound (module doc).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ModalBound {
    /// T's columns: the real (and imaginary) parts of A's eigenvectors.
    t: [[f32; 2]; 2],
    /// Bound on |z_i| per unit input bound; for a complex pair, both entries bound ||z||.
    z: [f32; 2],
    /// Whether ||z|| decays as a whole (a complex pair, or a symmetric A with T = I)
    /// rather than entry by entry.
    pair: bool,
}

impl ModalBound {
    /// The bound for A = I + `a_minus_identity` and b, or `None` when a pole lies on or
    /// outside the unit circle or closer to it than [`MAX_POLE_SUM`] allows, the two
    /// poles coincide in a non-diagonal A, or a value is not finite.
    #[inline(never)]
    pub fn new(a_minus_identity: [[f32; 2]; 2], b: [f32; 2]) -> Option<Self> {
        let d = a_minus_identity;
        // D's eigenvalues mu are A's poles minus one; T is the same for both.
        let half_trace = 0.5 * (d[0][0] + d[1][1]);
        let det = d[0][0] * d[1][1] - d[0][1] * d[1][0];
        let discriminant = half_trace * half_trace - det;
        let symmetric = d[0][1] == d[1][0] && d[0][1] != 0.0;
        let pair = discriminant < 0.0 || symmetric;
        let (t, margins) = if symmetric {
            // Normal, so ||A^k|| = max |pole|^k: no eigenvectors needed (T = I), which keeps
            // a near-double pole (a block of two real poles, a dead-beat block) exact.
            let root = sqrt_f32(discriminant.max(0.0));
            let mu = [half_trace + root, half_trace - root];
            let margin = mu.map(pole_margin);
            let slowest = if margin[0] < margin[1] {
                margin[0]
            } else {
                margin[1]
            };
            ([[1.0, 0.0], [0.0, 1.0]], [slowest; 2])
        } else if pair {
            // mu = h +- j omega: T = [Re v, Im v] for the eigenvector v = (d01, mu - d00)
            // makes M a rotation scaled by r, with 1 - r^2 = -(2 h + |mu|^2) exactly.
            // (d01 = 0 would make D triangular, with real eigenvalues.)
            let omega = sqrt_f32(-discriminant);
            let r_sq = 1.0 + 2.0 * half_trace + det;
            let margin = -(2.0 * half_trace + det) / (1.0 + sqrt_f32(r_sq));
            ([[d[0][1], 0.0], [half_trace - d[0][0], omega]], [margin; 2])
        } else {
            let root = sqrt_f32(discriminant);
            let mu = [half_trace + root, half_trace - root];
            let t = if d[0][1] == 0.0 && d[1][0] == 0.0 {
                [[1.0, 0.0], [0.0, 1.0]]
            } else {
                let v = mu.map(|m| {
                    if d[0][1] != 0.0 {
                        [d[0][1], m - d[0][0]]
                    } else {
                        [m - d[1][1], d[1][0]]
                    }
                });
                [[v[0][0], v[1][0]], [v[0][1], v[1][1]]]
            };
            let diagonal_mu = if d[0][1] == 0.0 && d[1][0] == 0.0 {
                [d[0][0], d[1][1]]
            } else {
                mu
            };
            (t, diagonal_mu.map(pole_margin))
        };
        let t_det = t[0][0] * t[1][1] - t[0][1] * t[1][0];
        let z = [
            (t[1][1] * b[0] - t[0][1] * b[1]) / t_det,
            (t[0][0] * b[1] - t[1][0] * b[0]) / t_det,
        ];
        let mut z_bound = [0.0; 2];
        for i in 0..2 {
            // False for NaN too.
            let far_enough = margins[i] * MAX_POLE_SUM >= 1.0;
            if !far_enough {
                return None;
            }
            // A pair's z turns as a whole: its norm, not each entry, decays as r^k.
            let size = if pair { vector_norm(z) } else { z[i].abs() };
            z_bound[i] = ROUNDING_MARGIN * size / margins[i];
        }
        let all_finite = t.iter().flatten().chain(&z_bound).all(|v| v.is_finite());
        all_finite.then_some(Self {
            t,
            z: z_bound,
            pair,
        })
    }

    /// Bound on ||x|| per unit input bound.
    pub fn state(&self) -> f32 {
        let columns = [
            vector_norm([self.t[0][0], self.t[1][0]]),
            vector_norm([self.t[0][1], self.t[1][1]]),
        ];
        if self.pair {
            // ||T z|| <= ||T||_F ||z||.
            vector_norm(columns) * self.z[0]
        } else {
            columns[0] * self.z[0] + columns[1] * self.z[1]
        }
    }

    /// Bound on |c x| per unit input bound.
    pub fn output(&self, c: [f32; 2]) -> f32 {
        let w = [
            c[0] * self.t[0][0] + c[1] * self.t[1][0],
            c[0] * self.t[0][1] + c[1] * self.t[1][1],
        ];
        if self.pair {
            vector_norm(w) * self.z[0]
        } else {
            w[0].abs() * self.z[0] + w[1].abs() * self.z[1]
        }
    }
}

/// 1 - |1 + mu|, the distance of the pole 1 + mu from the unit circle (negative outside):
/// -mu for a pole in [0, 1), 2 + mu for one in (-1, 0). Comparisons, not `f32::min`, which
/// is a library call on the device.
fn pole_margin(mu: f32) -> f32 {
    if mu > -1.0 { -mu } else { 2.0 + mu }
}

/// One 2-state recursion with a single input and a single output:
/// x[k+1] = (I + D) x\[k\] + b u\[k\], y\[k\] = c x\[k\] + d u\[k\].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Recursion2 {
    /// D = A - I, the transition matrix minus the identity.
    pub a_minus_identity: [[f32; 2]; 2],
    /// Input vector b.
    pub b: [f32; 2],
    /// Output row c.
    pub c: [f32; 2],
    /// Direct term d.
    pub d: f32,
}

impl Recursion2 {
    /// Its amplification, or `None` when [`ModalBound::new`] finds none.
    pub fn amplification(&self) -> Option<Amplification> {
        let modes = ModalBound::new(self.a_minus_identity, self.b)?;
        let total = Amplification {
            state: modes.state(),
            output: modes.output(self.c) + self.d.abs(),
        };
        (total.state.is_finite() && total.output.is_finite()).then_some(total)
    }
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;

    /// sum over k of |c A^k b| + |d| and the norm of (sum over k of |A^k b|, entrywise), by
    /// brute force over `n` steps: what an input of the worst signs reaches.
    fn brute_gains(rec: &Recursion2, n: usize) -> (f64, f64) {
        let d = rec.a_minus_identity.map(|r| r.map(f64::from));
        let a = [[1.0 + d[0][0], d[0][1]], [d[1][0], 1.0 + d[1][1]]];
        let (b, c) = (rec.b.map(f64::from), rec.c.map(f64::from));
        let (mut x, mut output, mut state_abs) = (b, f64::from(rec.d.abs()), [0.0f64; 2]);
        for _ in 0..n {
            output += (c[0] * x[0] + c[1] * x[1]).abs();
            state_abs = [state_abs[0] + x[0].abs(), state_abs[1] + x[1].abs()];
            x = [
                a[0][0] * x[0] + a[0][1] * x[1],
                a[1][0] * x[0] + a[1][1] * x[1],
            ];
        }
        (output, state_abs[0].hypot(state_abs[1]))
    }

    /// The recursion with transition matrix `a` (given near the identity in f64).
    fn recursion(a: [[f64; 2]; 2], b: [f32; 2], c: [f32; 2], d: f32) -> Recursion2 {
        Recursion2 {
            a_minus_identity: [
                [(a[0][0] - 1.0) as f32, a[0][1] as f32],
                [a[1][0] as f32, (a[1][1] - 1.0) as f32],
            ],
            b,
            c,
            d,
        }
    }

    fn assert_tight(rec: Recursion2, factor: f64) {
        let gain = rec.amplification().expect("stable");
        let (bound_output, bound_state) = (f64::from(gain.output), f64::from(gain.state));
        let (output, state) = brute_gains(&rec, 100_000);
        assert!(bound_output >= output, "{gain:?} < {output}");
        assert!(
            bound_output <= factor * output,
            "{gain:?} loose against {output}"
        );
        // ||x|| for the worst signs of each entry is at most the norm of the entrywise sums.
        assert!(bound_state * 2f64.sqrt() >= state, "{gain:?} < {state}");
    }

    #[test]
    fn a_scaled_rotation_gives_the_l1_gain_of_its_state() {
        let (r, t) = (0.999f64, 0.01f64);
        let a = [[r * t.cos(), -r * t.sin()], [r * t.sin(), r * t.cos()]];
        let rec = recursion(a, [1.0, 0.0], [1.0, 0.0], 0.0);
        let gain = f64::from(rec.amplification().expect("stable").state);
        // The exact sum of ||A^k b|| is 1 / (1 - r); the Frobenius norm of T costs sqrt 2,
        // the rounding margin 5 %.
        let exact = 1.0 / (1.0 - r);
        assert!(
            gain >= exact && gain <= exact * 2f64.sqrt() * 1.06,
            "{gain} against {exact}"
        );
        assert_tight(rec, 1.8);
    }

    #[test]
    fn diagonal_symmetric_and_non_normal_forms_are_bounded_tightly() {
        let (b, c) = ([1.0, 2.0], [0.5, -1.0]);
        // Exact per mode (and 5 % for rounding); the modes' sum can cancel a little.
        assert_tight(recursion([[0.99, 0.0], [0.0, -0.5]], b, c, 0.1), 1.2);
        // Symmetric: bounded as normal, with the slower pole's decay for both modes.
        assert_tight(recursion([[0.98, 0.01], [0.01, 0.5]], b, c, 0.1), 6.0);
        // Two close real poles with a large coupling: transient growth, then decay.
        let non_normal = [[0.99, 0.5], [0.0, 0.98]];
        assert_tight(recursion(non_normal, [0.3, 1.0], [1.0, -0.2], 0.0), 3.5);
        // A filter's companion form with a resonant pair near z = 1.
        let (r, theta) = (0.995f64, 0.05f64);
        let companion = [[2.0 * r * theta.cos(), 1.0], [-r * r, 0.0]];
        assert_tight(recursion(companion, [1.0, -0.5], [1.0, 0.0], 0.2), 3.0);
    }

    #[test]
    fn unstable_marginal_too_slow_and_defective_recursions_are_refused() {
        let refused = |d: [[f32; 2]; 2]| ModalBound::new(d, [1.0, 1.0]).is_none();
        assert!(refused([[0.0, 0.0], [0.0, -0.5]]));
        assert!(refused([[1e-4, 0.0], [0.0, -0.5]]));
        assert!(refused([[-1e-9, 0.0], [0.0, -0.5]]));
        assert!(refused([[f32::NAN, 0.0], [0.0, -0.5]]));
        // A pole at -1, and a pair on the circle.
        assert!(refused([[-2.0, 0.0], [0.0, -0.5]]));
        assert!(refused([[0.0, -0.1], [0.1, 0.0]]));
        // A double pole with a coupling (a Jordan block): no modal basis.
        assert!(refused([[-0.5, 1.0], [0.0, -0.5]]));
        assert!(!refused([[-1e-4, 0.0], [0.0, -0.5]]));
        assert!(!refused([[-0.5, 0.0], [0.0, -0.5]]));
    }
}
