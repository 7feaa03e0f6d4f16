//! The fit's residuals and their exact Jacobian.
//!
//! Residuals (model.md, the paper's Eq. 8): for each frequency f and each of the 12 fitted
//! components h = H_jk (`COUPLED_COMPONENTS`), against the subjects' geometric mean g:
//! r_mag = (|h| - |g|) / |g| and r_phase = wrap(arg h - arg g) / pi. The cost is
//! 0.5 sum r^2 (scipy's `least_squares` convention).
//!
//! Unknowns are theta_i = ln p_i (so the box bounds stay boxes and stiffness of 1e5 and
//! damping of 1 are on one scale). Every parameter p multiplies a rank-one term b b^T of
//! K (stiffness) or C (damping), so with A = K - w^2 M + j w C, F = (K + j w C) G,
//! X = A^-1 F and H = R X:
//!
//! dH/dp = s (R A^-1 b) (b^T (G - X)), s = 1 for a stiffness, j w for a damping,
//!
//! and dH/dtheta = p dH/dp. A is complex symmetric, so R A^-1 = (A^-1 R^T)^T: one LU of A
//! per frequency solves for X (3 columns) and A^-1 R^T (9 columns), and every Jacobian
//! column is then an outer product of two short sparse sums. Then
//! d r_mag = Re(conj(h) dh) / (|h| |g|) and d r_phase = Im(dh / h) / pi.

use std::f64::consts::PI;

use nalgebra::{Complex, DMatrix, SMatrix};
use supine_core::model::assembly::{DOF_COUNT, Shape, param_shape};
use supine_core::model::geometry::Body;
use supine_core::model::response::{COUPLED_COMPONENTS, dynamic_stiffness};
use supine_core::model::{ModelParams, ParamId, SystemMatrices, Transmissibility};

use crate::geomean::wrap_pi;

/// Number of fitted components.
pub const COMPONENTS: usize = COUPLED_COMPONENTS.len();

/// The measured (geometric-mean) transmissibility the model is fitted to.
#[derive(Clone, Debug, PartialEq)]
pub struct Target {
    /// Frequencies, Hz (0.5..=16 Hz on the Welch grid).
    pub freqs_hz: Vec<f64>,
    /// H at each frequency.
    pub h: Vec<Transmissibility>,
}

/// The fit's least-squares problem: which parameters are free, around which base set.
#[derive(Clone, Debug)]
pub struct Objective {
    /// The parameters the free ones are substituted into (subject, fixed values, sensors).
    pub base: ModelParams,
    /// The free parameters, in the order of theta.
    pub free: Vec<ParamId>,
    /// What to fit.
    pub target: Target,
    shapes: Vec<Shape>,
}

type Cplx = Complex<f64>;

impl Objective {
    /// Sets up the problem. Shapes depend on the subject only, so they are computed once.
    pub fn new(base: ModelParams, free: Vec<ParamId>, target: Target) -> Self {
        let body = Body::dempster(&base.subject);
        let shapes = free.iter().map(|&id| param_shape(id, &body)).collect();
        Self {
            base,
            free,
            target,
            shapes,
        }
    }

    /// Residuals: 2 per component and frequency.
    pub fn residual_count(&self) -> usize {
        2 * COMPONENTS * self.target.freqs_hz.len()
    }

    /// Free parameters.
    pub fn param_count(&self) -> usize {
        self.free.len()
    }

    /// The full parameter set for log-parameters `theta`.
    pub fn params(&self, theta: &[f64]) -> ModelParams {
        let mut p = self.base;
        for (&id, &t) in self.free.iter().zip(theta) {
            p.set(id, t.exp());
        }
        p
    }

    /// Log-parameters of a full parameter set.
    pub fn theta(&self, params: &ModelParams) -> Vec<f64> {
        self.free.iter().map(|&id| params.get(id).ln()).collect()
    }

    /// Residual index of component `c`'s magnitude at frequency index `f` (phase is +1).
    pub fn residual_index(f: usize, c: usize) -> usize {
        2 * (COMPONENTS * f + c)
    }

    /// Fills `residuals` (and the Jacobian d r / d theta, residuals x params, if asked).
    ///
    /// Fails only if A is singular at some frequency (not for positive parameters).
    pub fn evaluate(
        &self,
        theta: &[f64],
        residuals: &mut [f64],
        mut jacobian: Option<&mut DMatrix<f64>>,
    ) -> Result<(), String> {
        let params = self.params(theta);
        let values: Vec<f64> = self.free.iter().map(|&id| params.get(id)).collect();
        let matrices = SystemMatrices::assemble(&params);
        let g_real = matrices.input;
        let rt: SMatrix<Cplx, DOF_COUNT, 9> =
            matrices.output.transpose().map(|v| Cplx::new(v, 0.0));
        for (f, &freq_hz) in self.target.freqs_hz.iter().enumerate() {
            let omega = 2.0 * PI * freq_hz;
            let a = dynamic_stiffness(&matrices, omega);
            let forcing: SMatrix<Cplx, DOF_COUNT, 3> = SMatrix::from_fn(|i, k| {
                let mut acc = Cplx::new(0.0, 0.0);
                for j in 0..DOF_COUNT {
                    if g_real[(j, k)] != 0.0 {
                        acc +=
                            Cplx::new(matrices.stiffness[(i, j)], omega * matrices.damping[(i, j)]);
                    }
                }
                acc
            });
            let lu = a.lu();
            let x = lu
                .solve(&forcing)
                .ok_or_else(|| format!("the model is singular at {freq_hz} Hz"))?;
            let h = matrices.output.map(|v| Cplx::new(v, 0.0)) * x;
            let measured = &self.target.h[f];
            for (c, (output, input)) in COUPLED_COMPONENTS.iter().enumerate() {
                let (j, k) = (output.index(), input.index());
                let (hv, gv) = (h[(j, k)], measured[(j, k)]);
                let r = Self::residual_index(f, c);
                residuals[r] = (hv.norm() - gv.norm()) / gv.norm();
                residuals[r + 1] = wrap_pi(hv.arg() - gv.arg()) / PI;
            }
            let Some(jac) = jacobian.as_deref_mut() else {
                continue;
            };
            // W = A^-1 R^T, so (R A^-1)_(j, d) = W_(d, j) by symmetry of A.
            let w = lu
                .solve(&rt)
                .ok_or_else(|| format!("the model is singular at {freq_hz} Hz"))?;
            for (p, (shape, &id)) in self.shapes.iter().zip(&self.free).enumerate() {
                // u = R A^-1 b (9), v = b^T (G - X) (3).
                let mut u = [Cplx::new(0.0, 0.0); 9];
                let mut v = [Cplx::new(0.0, 0.0); 3];
                for &(d, wt) in shape.entries() {
                    for (j, uj) in u.iter_mut().enumerate() {
                        *uj += w[(d, j)] * wt;
                    }
                    for (k, vk) in v.iter_mut().enumerate() {
                        *vk += (Cplx::new(g_real[(d, k)], 0.0) - x[(d, k)]) * wt;
                    }
                }
                let s = if id.is_stiffness() {
                    Cplx::new(values[p], 0.0)
                } else {
                    Cplx::new(0.0, omega * values[p])
                };
                for (c, (output, input)) in COUPLED_COMPONENTS.iter().enumerate() {
                    let (j, k) = (output.index(), input.index());
                    let (hv, gv) = (h[(j, k)], measured[(j, k)]);
                    let dh = s * u[j] * v[k];
                    let r = Self::residual_index(f, c);
                    jac[(r, p)] = (hv.conj() * dh).re / (hv.norm() * gv.norm());
                    jac[(r + 1, p)] = (dh / hv).im / PI;
                }
            }
        }
        Ok(())
    }

    /// The cost 0.5 sum r^2 at `theta`.
    pub fn cost(&self, theta: &[f64]) -> Result<f64, String> {
        let mut r = vec![0.0; self.residual_count()];
        self.evaluate(theta, &mut r, None)?;
        Ok(0.5 * r.iter().map(|v| v * v).sum::<f64>())
    }

    /// The model's H at the target frequencies for `theta`.
    pub fn model_h(&self, theta: &[f64]) -> Result<Vec<Transmissibility>, String> {
        let matrices = SystemMatrices::assemble(&self.params(theta));
        self.target
            .freqs_hz
            .iter()
            .map(|&f| matrices.transmissibility(f).map_err(|e| e.to_string()))
            .collect()
    }
}
