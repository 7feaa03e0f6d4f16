//! The continuous model in relative coordinates, the form the device discretizes.
//!
//! With y = q - G u0 the support acceleration a0 drives the model directly:
//! M y'' + C y' + K y = -M G a0, and the absolute sensor acceleration is
//! a_E = R (y'' + G a0) = R M^-1 (-C y' - K y), with no feedthrough.
//! State x = [y; y'], so x' = A x + B a0 and a_E = C x. The joint motion is J y (J q and
//! J y agree: a rigid translation moves both joint points alike), so its output map is
//! [J, 0].

use core::f64::consts::PI;

use nalgebra::{Complex, SMatrix};

use super::ModelError;
use super::assembly::{DOF_COUNT, INPUT_COUNT, OUTPUT_COUNT, SystemMatrices};
use super::joints::JOINT_OUTPUT_COUNT;
use super::response::Transmissibility;

/// Number of continuous states: displacement and velocity of each DOF.
pub const STATE_COUNT: usize = 2 * DOF_COUNT;

/// x' = A x + B a0, a_E = C x, in SI units (m, m/s, rad, rad/s; input and output m/s^2).
#[derive(Clone, Debug, PartialEq)]
pub struct StateSpace {
    /// A = [[0, I], [-M^-1 K, -M^-1 C]].
    pub a: SMatrix<f64, STATE_COUNT, STATE_COUNT>,
    /// B = [0; -G].
    pub b: SMatrix<f64, STATE_COUNT, INPUT_COUNT>,
    /// C = R M^-1 [-K, -C].
    pub c: SMatrix<f64, OUTPUT_COUNT, STATE_COUNT>,
    /// [J, 0]: joint motion (m, rad) from the state.
    pub c_joint: SMatrix<f64, JOINT_OUTPUT_COUNT, STATE_COUNT>,
}

impl StateSpace {
    /// Builds the relative-coordinate state space (M is diagonal and positive).
    pub fn new(m: &SystemMatrices) -> Self {
        let n = DOF_COUNT;
        let inv_mass = |i: usize| 1.0 / m.mass[(i, i)];
        let mut a = SMatrix::<f64, STATE_COUNT, STATE_COUNT>::zeros();
        for i in 0..n {
            a[(i, n + i)] = 1.0;
            for j in 0..n {
                a[(n + i, j)] = -inv_mass(i) * m.stiffness[(i, j)];
                a[(n + i, n + j)] = -inv_mass(i) * m.damping[(i, j)];
            }
        }
        let mut b = SMatrix::<f64, STATE_COUNT, INPUT_COUNT>::zeros();
        for i in 0..n {
            for k in 0..INPUT_COUNT {
                b[(n + i, k)] = -m.input[(i, k)];
            }
        }
        let mut c = SMatrix::<f64, OUTPUT_COUNT, STATE_COUNT>::zeros();
        for o in 0..OUTPUT_COUNT {
            for j in 0..n {
                let mut ck = 0.0;
                let mut cc = 0.0;
                for i in 0..n {
                    let w = m.output[(o, i)] * inv_mass(i);
                    ck -= w * m.stiffness[(i, j)];
                    cc -= w * m.damping[(i, j)];
                }
                c[(o, j)] = ck;
                c[(o, n + j)] = cc;
            }
        }
        let c_joint = SMatrix::<f64, JOINT_OUTPUT_COUNT, STATE_COUNT>::from_fn(|o, j| {
            if j < n { m.joint_output[(o, j)] } else { 0.0 }
        });
        Self { a, b, c, c_joint }
    }

    /// C (j w I - A)^-1 B at `freq_hz`: must equal the transmissibility.
    pub fn frequency_response(&self, freq_hz: f64) -> Result<Transmissibility, ModelError> {
        let omega = 2.0 * PI * freq_hz;
        let sys: SMatrix<Complex<f64>, STATE_COUNT, STATE_COUNT> = SMatrix::from_fn(|i, j| {
            let diag = if i == j { omega } else { 0.0 };
            Complex::new(-self.a[(i, j)], diag)
        });
        let rhs = self.b.map(|v| Complex::new(v, 0.0));
        let x = sys.lu().solve(&rhs).ok_or(ModelError::Singular)?;
        Ok(self.c.map(|v| Complex::new(v, 0.0)) * x)
    }
}
