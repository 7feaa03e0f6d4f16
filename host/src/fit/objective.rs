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
use supine_core::model::response::COUPLED_COMPONENTS;
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
    blocks: Vec<Vec<usize>>,
}

/// The largest uncoupled block of A this solver handles (the geometry gives 3, 6, 6, 3).
const MAX_BLOCK: usize = 6;

/// The DOFs of each uncoupled block of A = K - w^2 M + j w C: the connected components of
/// the graph in which every element's shape vector links its DOFs (M is diagonal).
fn uncoupled_blocks(body: &Body) -> Vec<Vec<usize>> {
    let mut parent: Vec<usize> = (0..DOF_COUNT).collect();
    fn root(parent: &mut [usize], mut i: usize) -> usize {
        while parent[i] != i {
            parent[i] = parent[parent[i]];
            i = parent[i];
        }
        i
    }
    for id in ParamId::ALL {
        let shape = param_shape(id, body);
        let entries = shape.entries();
        for pair in entries.windows(2) {
            let (a, b) = (root(&mut parent, pair[0].0), root(&mut parent, pair[1].0));
            parent[a] = b;
        }
    }
    let mut blocks: Vec<Vec<usize>> = Vec::new();
    let mut roots: Vec<usize> = Vec::new();
    for d in 0..DOF_COUNT {
        let r = root(&mut parent, d);
        match roots.iter().position(|&x| x == r) {
            Some(i) => blocks[i].push(d),
            None => {
                roots.push(r);
                blocks.push(vec![d]);
            }
        }
    }
    blocks
}

type Cplx = Complex<f64>;

impl Objective {
    /// Sets up the problem. Shapes depend on the subject only, so they are computed once.
    pub fn new(base: ModelParams, free: Vec<ParamId>, target: Target) -> Self {
        let body = Body::dempster(&base.subject);
        let shapes = free.iter().map(|&id| param_shape(id, &body)).collect();
        let blocks = uncoupled_blocks(&body);
        assert!(
            blocks.iter().all(|b| b.len() <= MAX_BLOCK),
            "the model's geometry couples more than {MAX_BLOCK} DOFs"
        );
        Self {
            base,
            free,
            target,
            shapes,
            blocks,
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
        let (kg, cg) = (matrices.stiffness * g_real, matrices.damping * g_real);
        let r_out = &matrices.output;
        let mut x = SMatrix::<Cplx, DOF_COUNT, 3>::zeros();
        let mut w = SMatrix::<Cplx, DOF_COUNT, 9>::zeros();
        for (f, &freq_hz) in self.target.freqs_hz.iter().enumerate() {
            let omega = 2.0 * PI * freq_hz;
            let want_w = jacobian.is_some();
            // A is block diagonal over the uncoupled subsystems: solve each block alone
            // for X = A^-1 F (F = (K + j w C) G) and W = A^-1 R^T.
            for block in &self.blocks {
                let mut a = SMatrix::<Cplx, MAX_BLOCK, MAX_BLOCK>::identity();
                let mut rhs = SMatrix::<Cplx, MAX_BLOCK, 12>::zeros();
                for (i, &di) in block.iter().enumerate() {
                    for (j, &dj) in block.iter().enumerate() {
                        a[(i, j)] = Cplx::new(
                            matrices.stiffness[(di, dj)] - omega * omega * matrices.mass[(di, dj)],
                            omega * matrices.damping[(di, dj)],
                        );
                    }
                    for k in 0..3 {
                        rhs[(i, k)] = Cplx::new(kg[(di, k)], omega * cg[(di, k)]);
                    }
                    if want_w {
                        for j in 0..9 {
                            rhs[(i, 3 + j)] = Cplx::new(r_out[(j, di)], 0.0);
                        }
                    }
                }
                let sol = a
                    .lu()
                    .solve(&rhs)
                    .ok_or_else(|| format!("the model is singular at {freq_hz} Hz"))?;
                for (i, &di) in block.iter().enumerate() {
                    for k in 0..3 {
                        x[(di, k)] = sol[(i, k)];
                    }
                    for j in 0..9 {
                        w[(di, j)] = sol[(i, 3 + j)];
                    }
                }
            }
            // Only the fitted components of H = R X.
            let mut h = [Cplx::new(0.0, 0.0); COMPONENTS];
            for (c, (output, input)) in COUPLED_COMPONENTS.iter().enumerate() {
                let (j, k) = (output.index(), input.index());
                h[c] = (0..DOF_COUNT)
                    .filter(|&d| r_out[(j, d)] != 0.0)
                    .map(|d| x[(d, k)] * r_out[(j, d)])
                    .sum();
            }
            let measured = &self.target.h[f];
            for (c, (output, input)) in COUPLED_COMPONENTS.iter().enumerate() {
                let (j, k) = (output.index(), input.index());
                let (hv, gv) = (h[c], measured[(j, k)]);
                let r = Self::residual_index(f, c);
                residuals[r] = (hv.norm() - gv.norm()) / gv.norm();
                residuals[r + 1] = wrap_pi(hv.arg() - gv.arg()) / PI;
            }
            let Some(jac) = jacobian.as_deref_mut() else {
                continue;
            };
            // d r_mag = Re(dh conj(h) / (|h| |g|)), d r_phase = Im(dh / (pi h)): the factors
            // once per component, so the inner loop only multiplies.
            let mut mag_factor = [Cplx::new(0.0, 0.0); COMPONENTS];
            let mut phase_factor = [Cplx::new(0.0, 0.0); COMPONENTS];
            for (c, (output, input)) in COUPLED_COMPONENTS.iter().enumerate() {
                let (hv, gv) = (h[c], measured[(output.index(), input.index())]);
                mag_factor[c] = hv.conj() / (hv.norm() * gv.norm());
                phase_factor[c] = Cplx::new(1.0, 0.0) / (hv * PI);
            }
            // W = A^-1 R^T, so (R A^-1)_(j, d) = W_(d, j) by symmetry of A.
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
                let column = &mut jac.column_mut(p);
                for (c, (output, input)) in COUPLED_COMPONENTS.iter().enumerate() {
                    let dh = s * u[output.index()] * v[input.index()];
                    let r = Self::residual_index(f, c);
                    column[r] = (dh * mag_factor[c]).re;
                    column[r + 1] = (dh * phase_factor[c]).im;
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
