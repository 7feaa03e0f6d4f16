//! The fit's residuals and their exact Jacobian.
//!
//! Residuals (docs/model.md#objective, the paper's Eq. 8): for each frequency f and each of the 12 fitted
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

use nalgebra::{DMatrix, SMatrix};
use supine_core::model::assembly::{DOF_COUNT, Shape, param_shape};
use supine_core::model::geometry::Body;
use supine_core::model::modal::Subsystem;
use supine_core::model::response::COUPLED_COMPONENTS;
use supine_core::model::{ModelParams, ParamId, SystemMatrices, Transmissibility};

use super::block_solve::{
    Cplx, LANES, Lane, LaneCplx, LaneSystem, MAX_BLOCK, MAX_OUTPUTS, MAX_RHS, lane_sqrt,
    solve_lanes, solve_small,
};
#[cfg(target_arch = "x86_64")]
use super::kernels;
use super::lane_atan2::lane_atan2;
use crate::identify::geomean::wrap_pi;

/// Number of fitted components.
pub const COMPONENTS: usize = COUPLED_COMPONENTS.len();

/// A component's derivative factors projected on one shape: (magnitude, phase), per lane.
type Projected = [(LaneCplx, LaneCplx); COMPONENTS];

/// An evaluation's largest working arrays, kept per thread between evaluations: every
/// entry is written before it is read, so zeroing them for each block of each evaluation
/// (about 4 % of a rigid fit's instructions, most of it in `memset`) bought nothing.
struct Scratch {
    /// The block's systems, lane by lane.
    lanes: LaneSystem,
    /// Per shape of the block: [`Projected`].
    projected: Vec<Projected>,
}

impl Scratch {
    fn new() -> Self {
        Self {
            lanes: LaneSystem::new(),
            projected: Vec::new(),
        }
    }
}

thread_local! {
    /// This thread's [`Scratch`], taken for an evaluation and put back after it.
    static SCRATCH: std::cell::Cell<Option<Box<Scratch>>> = const { std::cell::Cell::new(None) };
}

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
    /// The distinct shape vectors of the free parameters (a stiffness and the damping of
    /// the same element and axis share one), with the block each lies in.
    shapes: Vec<LocalShape>,
    /// Per free parameter: its index in `shapes`.
    param_shape: Vec<usize>,
    blocks: Vec<Block>,
    /// Per free parameter: the block its shape vector lies in.
    param_block: Vec<usize>,
}

/// One uncoupled block of A and what it touches.
#[derive(Clone, Debug)]
struct Block {
    /// Its DOFs, ascending.
    dofs: Vec<usize>,
    /// Input axes whose forcing (K + j w C) G reaches it.
    inputs: Vec<usize>,
    /// The fitted components (indices into `COUPLED_COMPONENTS`) it contributes to.
    components: Vec<usize>,
    /// The outputs its fitted components read, ascending: the only rows of R A^-1 the
    /// Jacobian needs (the other outputs that see the block are not fitted).
    read_outputs: Vec<usize>,
    /// Per read output: the non-zero (local DOF, weight) entries of its row of R within
    /// the block, in DOF order (R's entries on other blocks meet a zero column of X).
    read_rows: Vec<Vec<(usize, f64)>>,
    /// Per fitted component: (its index into `inputs`, its index into `read_outputs`).
    component_at: Vec<(usize, usize)>,
}

/// A distinct shape vector of the free parameters, in its block's local DOFs.
#[derive(Clone, Debug)]
struct LocalShape {
    /// The shape as the model gives it (over all DOFs).
    shape: Shape,
    /// The block it lies in.
    block: usize,
    /// Its (local DOF, global DOF, weight) entries, in the shape's order.
    entries: Vec<(usize, usize, f64)>,
}

/// One independent part of the fit ([`Objective::subsystems`]).
#[derive(Clone, Debug, PartialEq)]
pub struct FitSubsystem {
    /// The model's name for it (e.g. `lateral`).
    pub name: String,
    /// Its block of A.
    block: usize,
    /// Its free parameters: indices into theta, in theta's order.
    pub params: Vec<usize>,
    /// Its residuals: indices into the full residual vector, in the part's own order.
    pub rows: Vec<usize>,
}

/// What one evaluation covers.
#[derive(Clone, Copy)]
enum Scope<'a> {
    /// Every block: the full residual vector, a Jacobian column per free parameter.
    All,
    /// One part: its rows and its parameters' columns, in its order.
    Part(&'a FitSubsystem),
}

/// What one evaluation's scope covers.
struct Layout {
    /// Its blocks of A.
    blocks: Vec<usize>,
    /// (component, the offset of its magnitude residual within a frequency's rows).
    comps: Vec<(usize, usize)>,
    /// (free parameter, its Jacobian column).
    cols: Vec<(usize, usize)>,
    /// Residuals per frequency.
    per_freq: usize,
}

/// One block's part of the system's matrices in its local DOFs, for one evaluation.
struct LocalMatrices {
    stiffness: [[f64; MAX_BLOCK]; MAX_BLOCK],
    mass: [[f64; MAX_BLOCK]; MAX_BLOCK],
    damping: [[f64; MAX_BLOCK]; MAX_BLOCK],
    /// K G and C G, per local DOF and input of the block.
    kg: [[f64; 3]; MAX_BLOCK],
    cg: [[f64; 3]; MAX_BLOCK],
    /// The read outputs' rows of R, per read output and local DOF.
    output: [[f64; MAX_BLOCK]; MAX_OUTPUTS],
}

impl LocalMatrices {
    fn of_block(
        block: &Block,
        matrices: &SystemMatrices,
        kg: &SMatrix<f64, DOF_COUNT, 3>,
        cg: &SMatrix<f64, DOF_COUNT, 3>,
        r_out: &SMatrix<f64, 9, DOF_COUNT>,
    ) -> Self {
        let mut out = Self {
            stiffness: [[0.0; MAX_BLOCK]; MAX_BLOCK],
            mass: [[0.0; MAX_BLOCK]; MAX_BLOCK],
            damping: [[0.0; MAX_BLOCK]; MAX_BLOCK],
            kg: [[0.0; 3]; MAX_BLOCK],
            cg: [[0.0; 3]; MAX_BLOCK],
            output: [[0.0; MAX_BLOCK]; MAX_OUTPUTS],
        };
        for (i, &di) in block.dofs.iter().enumerate() {
            for (j, &dj) in block.dofs.iter().enumerate() {
                out.stiffness[i][j] = matrices.stiffness[(di, dj)];
                out.mass[i][j] = matrices.mass[(di, dj)];
                out.damping[i][j] = matrices.damping[(di, dj)];
            }
            for (col, &k) in block.inputs.iter().enumerate() {
                out.kg[i][col] = kg[(di, k)];
                out.cg[i][col] = cg[(di, k)];
            }
            for (o, &j) in block.read_outputs.iter().enumerate() {
                out.output[o][i] = r_out[(j, di)];
            }
        }
        out
    }
}

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

impl Objective {
    /// Sets up the problem. Shapes depend on the subject only, so they are computed once.
    pub fn new(base: ModelParams, free: Vec<ParamId>, target: Target) -> Self {
        let body = Body::dempster(&base.subject);
        let param_shapes: Vec<Shape> = free.iter().map(|&id| param_shape(id, &body)).collect();
        let matrices = SystemMatrices::assemble(&base);
        let blocks: Vec<Block> = uncoupled_blocks(&body)
            .into_iter()
            .map(|dofs| {
                let inputs: Vec<usize> = (0..3)
                    .filter(|&k| dofs.iter().any(|&d| matrices.input[(d, k)] != 0.0))
                    .collect();
                let components: Vec<usize> = (0..COMPONENTS)
                    .filter(|&c| {
                        let (o, i) = COUPLED_COMPONENTS[c];
                        inputs.contains(&i.index())
                            && dofs.iter().any(|&d| matrices.output[(o.index(), d)] != 0.0)
                    })
                    .collect();
                let mut read_outputs: Vec<usize> = components
                    .iter()
                    .map(|&c| COUPLED_COMPONENTS[c].0.index())
                    .collect();
                read_outputs.sort_unstable();
                read_outputs.dedup();
                let read_rows = read_outputs
                    .iter()
                    .map(|&j| {
                        dofs.iter()
                            .enumerate()
                            .filter(|&(_, &d)| matrices.output[(j, d)] != 0.0)
                            .map(|(i, &d)| (i, matrices.output[(j, d)]))
                            .collect()
                    })
                    .collect();
                let component_at = components
                    .iter()
                    .map(|&c| {
                        let (o, i) = COUPLED_COMPONENTS[c];
                        let at = |list: &[usize], x: usize| list.iter().position(|&v| v == x);
                        (
                            at(&inputs, i.index()).unwrap_or(0),
                            at(&read_outputs, o.index()).unwrap_or(0),
                        )
                    })
                    .collect();
                Block {
                    dofs,
                    inputs,
                    components,
                    read_outputs,
                    read_rows,
                    component_at,
                }
            })
            .collect();
        assert!(
            blocks.iter().all(|b| b.dofs.len() <= MAX_BLOCK),
            "the model's geometry couples more than {MAX_BLOCK} DOFs"
        );
        // A component's H sums R X over its input's block only: X is zero elsewhere.
        assert!(
            (0..3).all(|k| blocks.iter().filter(|b| b.inputs.contains(&k)).count() <= 1),
            "the model's geometry drives two blocks from one input axis"
        );
        let param_block: Vec<usize> = param_shapes
            .iter()
            .map(|shape: &Shape| {
                let first = shape.entries().first().map_or(0, |e| e.0);
                blocks
                    .iter()
                    .position(|b| b.dofs.contains(&first))
                    .unwrap_or(0)
            })
            .collect();
        let mut shapes: Vec<LocalShape> = Vec::new();
        let param_shape = param_shapes
            .iter()
            .zip(&param_block)
            .map(|(shape, &block)| {
                let known = shapes
                    .iter()
                    .position(|s| s.shape.entries() == shape.entries());
                known.unwrap_or_else(|| {
                    let dofs = &blocks[block].dofs;
                    let entries = shape
                        .entries()
                        .iter()
                        .map(|&(d, weight)| {
                            (dofs.iter().position(|&x| x == d).unwrap_or(0), d, weight)
                        })
                        .collect();
                    shapes.push(LocalShape {
                        shape: *shape,
                        block,
                        entries,
                    });
                    shapes.len() - 1
                })
            })
            .collect();
        Self {
            base,
            free,
            target,
            shapes,
            param_shape,
            blocks,
            param_block,
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
    /// Only the structurally non-zero entries of the Jacobian are written (a parameter
    /// moves only the components of its own block): pass a matrix that starts zeroed and
    /// is only ever filled by this method, as the solver does.
    ///
    /// Fails only if A is singular at some frequency (not for positive parameters).
    pub fn evaluate(
        &self,
        theta: &[f64],
        residuals: &mut [f64],
        jacobian: Option<&mut DMatrix<f64>>,
    ) -> Result<(), String> {
        self.evaluate_scope(theta, Scope::All, residuals, jacobian)
    }

    /// The independent parts of the problem: per block of A that a fitted component
    /// sees, its free parameters and its residuals. Every component is driven by one
    /// input axis, so it sees one block only: the cost is the sum of the parts' costs, and
    /// each part's cost depends on its own parameters only. The free parameters of blocks
    /// no component sees (roll) have no effect and belong to no part.
    pub fn subsystems(&self) -> Vec<FitSubsystem> {
        let nf = self.target.freqs_hz.len();
        self.blocks
            .iter()
            .enumerate()
            .filter(|(_, block)| !block.components.is_empty())
            .filter_map(|(b, block)| {
                let params: Vec<usize> = (0..self.free.len())
                    .filter(|&p| self.param_block[p] == b)
                    .collect();
                if params.is_empty() {
                    return None;
                }
                let rows = (0..nf)
                    .flat_map(|f| {
                        block.components.iter().flat_map(move |&c| {
                            let r = Self::residual_index(f, c);
                            [r, r + 1]
                        })
                    })
                    .collect();
                let name = Subsystem::ALL
                    .into_iter()
                    .find(|s| s.dofs() == block.dofs.as_slice())
                    .map_or_else(|| format!("block {b}"), |s| s.to_string());
                Some(FitSubsystem {
                    name,
                    block: b,
                    params,
                    rows,
                })
            })
            .collect()
    }

    /// Like [`Objective::evaluate`], for one part: `theta` is the full vector (the other
    /// parts' entries are not read), `residuals` holds the part's rows in the order of
    /// `part.rows`, and the Jacobian (rows x the part's parameters) is dense.
    pub fn evaluate_subsystem(
        &self,
        part: &FitSubsystem,
        theta: &[f64],
        residuals: &mut [f64],
        jacobian: Option<&mut DMatrix<f64>>,
    ) -> Result<(), String> {
        self.evaluate_scope(theta, Scope::Part(part), residuals, jacobian)
    }

    /// What `scope` covers.
    fn layout(&self, scope: Scope) -> Layout {
        match scope {
            Scope::All => Layout {
                blocks: (0..self.blocks.len()).collect(),
                comps: (0..COMPONENTS).map(|c| (c, 2 * c)).collect(),
                cols: (0..self.free.len()).map(|p| (p, p)).collect(),
                per_freq: 2 * COMPONENTS,
            },
            Scope::Part(part) => {
                let block = &self.blocks[part.block];
                Layout {
                    blocks: vec![part.block],
                    comps: block
                        .components
                        .iter()
                        .enumerate()
                        .map(|(i, &c)| (c, 2 * i))
                        .collect(),
                    cols: part
                        .params
                        .iter()
                        .enumerate()
                        .map(|(a, &p)| (p, a))
                        .collect(),
                    per_freq: 2 * block.components.len(),
                }
            }
        }
    }

    /// [`Objective::evaluate_scope_portable`] with AVX2 where the CPU has it (see
    /// [`kernels`]): the same bits either way. The evaluation works in this thread's
    /// [`Scratch`], taken here and put back after it.
    fn evaluate_scope(
        &self,
        theta: &[f64],
        scope: Scope,
        residuals: &mut [f64],
        jacobian: Option<&mut DMatrix<f64>>,
    ) -> Result<(), String> {
        let mut scratch = SCRATCH.take().unwrap_or_else(|| Box::new(Scratch::new()));
        #[cfg(target_arch = "x86_64")]
        let evaluated = if kernels::avx2() {
            // SAFETY: the CPU has AVX2 (checked just above).
            unsafe { self.evaluate_scope_avx2(theta, scope, residuals, jacobian, &mut scratch) }
        } else {
            self.evaluate_scope_portable(theta, scope, residuals, jacobian, &mut scratch)
        };
        #[cfg(not(target_arch = "x86_64"))]
        let evaluated =
            self.evaluate_scope_portable(theta, scope, residuals, jacobian, &mut scratch);
        SCRATCH.set(Some(scratch));
        evaluated
    }

    /// [`Objective::evaluate_scope_portable`] compiled with AVX2.
    ///
    /// # Safety
    /// The CPU must have AVX2.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    unsafe fn evaluate_scope_avx2(
        &self,
        theta: &[f64],
        scope: Scope,
        residuals: &mut [f64],
        jacobian: Option<&mut DMatrix<f64>>,
        scratch: &mut Scratch,
    ) -> Result<(), String> {
        self.evaluate_scope_portable(theta, scope, residuals, jacobian, scratch)
    }

    /// The evaluation itself, in `scratch`'s arrays, inlined into both callers above so
    /// that each compiles it (and the block solve it inlines) for its own instruction set.
    // The block's system is filled entry by entry from several arrays at once: index
    // loops say that most plainly.
    #[allow(clippy::needless_range_loop)]
    #[inline(always)]
    fn evaluate_scope_portable(
        &self,
        theta: &[f64],
        scope: Scope,
        residuals: &mut [f64],
        mut jacobian: Option<&mut DMatrix<f64>>,
        scratch: &mut Scratch,
    ) -> Result<(), String> {
        let params = self.params(theta);
        let values: Vec<f64> = self.free.iter().map(|&id| params.get(id)).collect();
        let matrices = SystemMatrices::assemble(&params);
        let g_real = matrices.input;
        let (kg, cg) = (matrices.stiffness * g_real, matrices.damping * g_real);
        let r_out = &matrices.output;
        let Layout {
            blocks,
            comps,
            cols,
            per_freq,
        } = self.layout(scope);
        let mut slot_of = [usize::MAX; COMPONENTS];
        for &(c, slot) in &comps {
            slot_of[c] = slot;
        }
        let zero = Cplx::new(0.0, 0.0);
        let want_w = jacobian.is_some();
        // Block by block (they are uncoupled), each with its matrices copied to local DOFs
        // once per evaluation, so the frequency loop reads small arrays only.
        for b in blocks {
            let block = &self.blocks[b];
            let (n, nk) = (block.dofs.len(), block.inputs.len());
            let no = if want_w { block.read_outputs.len() } else { 0 };
            let local = LocalMatrices::of_block(block, &matrices, &kg, &cg, r_out);
            let shape_ids: Vec<usize> = (0..self.shapes.len())
                .filter(|&i| self.shapes[i].block == b)
                .collect();
            // (free parameter, its Jacobian column, its shape's index in `shape_ids`).
            let block_cols: Vec<(usize, usize, usize)> = cols
                .iter()
                .filter(|&&(p, _)| self.param_block[p] == b)
                .map(|&(p, col)| {
                    let s = shape_ids.iter().position(|&i| i == self.param_shape[p]);
                    (p, col, s.unwrap_or(0))
                })
                .collect();
            if scratch.projected.len() < shape_ids.len() {
                scratch.projected.resize(
                    shape_ids.len(),
                    [(LaneCplx::ZERO, LaneCplx::ZERO); COMPONENTS],
                );
            }
            let projected = &mut scratch.projected[..shape_ids.len()];
            // X = A^-1 F (F = (K + j w C) G) in the first nk columns, W = A^-1 R^T (the
            // read outputs' rows of R) in the next no. Every frequency overwrites the n x n
            // and n x (nk + no) entries the solve reads.
            let a_at = |omega: f64, i: usize, j: usize| {
                Cplx::new(
                    local.stiffness[i][j] - omega * omega * local.mass[i][j],
                    omega * local.damping[i][j],
                )
            };
            let rhs_at = |omega: f64, i: usize, col: usize| {
                if col < nk {
                    Cplx::new(local.kg[i][col], omega * local.cg[i][col])
                } else {
                    Cplx::new(local.output[col - nk][i], 0.0)
                }
            };
            let nf = self.target.freqs_hz.len();
            let omega_at = |f: usize| 2.0 * PI * self.target.freqs_hz[f];
            let lanes = &mut scratch.lanes;
            // Per component of the block, every group overwrites them (so zeroed once).
            let mut mag_factor = [LaneCplx::ZERO; COMPONENTS];
            let mut phase_factor = [LaneCplx::ZERO; COMPONENTS];
            let (mut u, mut v) = ([LaneCplx::ZERO; MAX_OUTPUTS], [LaneCplx::ZERO; 3]);
            let mut a = [[zero; MAX_BLOCK]; MAX_BLOCK];
            let mut rhs = [[zero; MAX_RHS]; MAX_BLOCK];
            // LANES frequencies solved at once (the last group's spare lanes repeat its
            // last frequency); one at a time only where a lane is singular (to name it).
            for first in (0..nf).step_by(LANES) {
                let count = (first + LANES).min(nf) - first;
                let omega: Lane = std::array::from_fn(|l| omega_at((first + l).min(nf - 1)));
                // a_at and rhs_at in every lane at once.
                for i in 0..n {
                    for j in 0..n {
                        let (k, m, c) =
                            (local.stiffness[i][j], local.mass[i][j], local.damping[i][j]);
                        let entry = &mut lanes.a[i][j];
                        for l in 0..LANES {
                            entry.re[l] = k - omega[l] * omega[l] * m;
                            entry.im[l] = omega[l] * c;
                        }
                    }
                    for col in 0..nk {
                        let (kg, cg) = (local.kg[i][col], local.cg[i][col]);
                        let entry = &mut lanes.rhs[i][col];
                        for l in 0..LANES {
                            entry.re[l] = kg;
                            entry.im[l] = omega[l] * cg;
                        }
                    }
                    for col in 0..no {
                        lanes.rhs[i][nk + col] = LaneCplx {
                            re: [local.output[col][i]; LANES],
                            im: [0.0; LANES],
                        };
                    }
                }
                if !solve_lanes(n, lanes, nk + no) {
                    for l in 0..count {
                        for i in 0..n {
                            for j in 0..n {
                                a[i][j] = a_at(omega[l], i, j);
                            }
                            for col in 0..nk + no {
                                rhs[i][col] = rhs_at(omega[l], i, col);
                            }
                        }
                        if !solve_small(n, &mut a, &mut rhs, nk + no) {
                            let freq_hz = self.target.freqs_hz[first + l];
                            return Err(format!("the model is singular at {freq_hz} Hz"));
                        }
                        for i in 0..n {
                            for col in 0..nk + no {
                                lanes.rhs[i][col].set(l, rhs[i][col]);
                            }
                        }
                    }
                }
                // From here on every lane goes through the same arithmetic the scalar
                // evaluation did, one lane per frequency (spare lanes computed, not written).
                let x = |i: usize, col: usize| &lanes.rhs[i][col];
                let w = |i: usize, o: usize| &lanes.rhs[i][nk + o];
                // Only the fitted components of H = R X, per component of the block.
                for (at, (&c, &(kl, ol))) in
                    block.components.iter().zip(&block.component_at).enumerate()
                {
                    let (output, input) = COUPLED_COMPONENTS[c];
                    let mut sum = LaneCplx::ZERO;
                    for &(i, weight) in &block.read_rows[ol] {
                        sum.add_scaled(x(i, kl), weight);
                    }
                    // g of each lane's frequency (spare lanes repeat the last).
                    let mut g = LaneCplx::ZERO;
                    for l in 0..LANES {
                        let f = (first + l).min(nf - 1);
                        g.set(l, self.target.h[f][(output.index(), input.index())]);
                    }
                    // num-complex's arithmetic of the scalar definitions, lane by lane:
                    // r_mag = (|h| - |g|) / |g|, r_phase = wrap(arg(h conj(g))) / pi.
                    let (h_norm_sqr, g_norm_sqr) = (sum.norm_sqr(), g.norm_sqr());
                    let g_abs = lane_sqrt(g_norm_sqr);
                    let h_abs = lane_sqrt(h_norm_sqr);
                    let h_conj_g = sum.mul(&g.conj());
                    let phase = lane_atan2(&h_conj_g.im, &h_conj_g.re);
                    for l in 0..count {
                        let r = (first + l) * per_freq + slot_of[c];
                        residuals[r] = (h_abs[l] - g_abs[l]) / g_abs[l];
                        // wrap(arg h - arg g) = arg(h conj(g)), in (-pi, pi].
                        residuals[r + 1] = wrap_pi(phase[l]) / PI;
                    }
                    if want_w {
                        // d r_mag = Re(dh conj(h) / (|h| |g|)), d r_phase = Im(dh / (pi h)):
                        // the factors once per component, so the inner loop only multiplies.
                        let norm =
                            lane_sqrt(std::array::from_fn(|l| h_norm_sqr[l] * g_norm_sqr[l]));
                        mag_factor[at] = sum.conj().div_real(&norm);
                        phase_factor[at] = sum.scale(PI).recip();
                    }
                }
                let Some(jac) = jacobian.as_deref_mut() else {
                    continue;
                };
                // W = A^-1 R^T, so (R A^-1)_(j, d) = W_(d, j) by symmetry of A. Per distinct
                // shape b: u = R A^-1 b (the read outputs) and v = b^T (G - X) (the
                // inputs), shared by the stiffness and the damping of its element and axis.
                // Then per component, dh/dp / s projected on both residuals: t = u_o v_i,
                // (t m_c, t p_c) with the factors above. A stiffness (s = p) gives
                // (p Re(t m), p Im(t p)); a damping (s = j w p) gives (-w p Im(t m),
                // w p Re(t p)): one complex product per shape, not per parameter.
                for (s, &i) in shape_ids.iter().enumerate() {
                    u[..no].fill(LaneCplx::ZERO);
                    v[..nk].fill(LaneCplx::ZERO);
                    for &(d, global, wt) in &self.shapes[i].entries {
                        for (o, u) in u.iter_mut().enumerate().take(no) {
                            u.add_scaled(w(d, o), wt);
                        }
                        for (kl, &k) in block.inputs.iter().enumerate() {
                            v[kl].add_real_minus_scaled(g_real[(global, k)], x(d, kl), wt);
                        }
                    }
                    for (at, &(kl, ol)) in block.component_at.iter().enumerate() {
                        let t = u[ol].mul(&v[kl]);
                        projected[s][at] = (t.mul(&mag_factor[at]), t.mul(&phase_factor[at]));
                    }
                }
                let rows = jac.nrows();
                let entries = jac.as_mut_slice();
                let row_of: [usize; LANES] = std::array::from_fn(|l| (first + l) * per_freq);
                for &(p, col, s) in &block_cols {
                    let projected = &projected[s];
                    let column = &mut entries[col * rows..(col + 1) * rows];
                    // Lane l's rows of component c: row_of[l] + slot_of[c] and the next.
                    if self.free[p].is_stiffness() {
                        let value = values[p];
                        for (at, &c) in block.components.iter().enumerate() {
                            let (tm, tp) = &projected[at];
                            for l in 0..count {
                                let r = row_of[l] + slot_of[c];
                                column[r] = value * tm.re[l];
                                column[r + 1] = value * tp.im[l];
                            }
                        }
                    } else {
                        let value: Lane = std::array::from_fn(|l| omega[l] * values[p]);
                        for (at, &c) in block.components.iter().enumerate() {
                            let (tm, tp) = &projected[at];
                            for l in 0..count {
                                let r = row_of[l] + slot_of[c];
                                column[r] = -value[l] * tm.im[l];
                                column[r + 1] = value[l] * tp.re[l];
                            }
                        }
                    }
                }
            }
        }
        Ok(())
    }

    /// J^T J exploiting the Jacobian's structure: a parameter only moves the components of
    /// its own block, so J^T J is block diagonal over the blocks' parameter groups.
    pub fn gram(&self, jacobian: &DMatrix<f64>) -> DMatrix<f64> {
        let n = self.free.len();
        let nf = self.target.freqs_hz.len();
        let mut out = DMatrix::zeros(n, n);
        for (b, block) in self.blocks.iter().enumerate() {
            let params: Vec<usize> = (0..n).filter(|&p| self.param_block[p] == b).collect();
            if params.is_empty() || block.components.is_empty() {
                continue;
            }
            let rows: Vec<usize> = (0..nf)
                .flat_map(|f| {
                    block.components.iter().flat_map(move |&c| {
                        let r = Self::residual_index(f, c);
                        [r, r + 1]
                    })
                })
                .collect();
            let sub = DMatrix::from_fn(rows.len(), params.len(), |i, j| {
                jacobian[(rows[i], params[j])]
            });
            let g = sub.transpose() * &sub;
            for (i, &p) in params.iter().enumerate() {
                for (j, &q) in params.iter().enumerate() {
                    out[(p, q)] = g[(i, j)];
                }
            }
        }
        out
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

/// The H of the paper's rigid model with every parameter scaled by 0.7 to 1.3 (so the
/// fit's residuals are not zero) at `freqs_hz`: a target for tests.
#[cfg(test)]
pub(crate) fn perturbed_target(freqs_hz: Vec<f64>) -> Target {
    let mut other = ModelParams::preset(supine_core::model::Preset::PaperRigid);
    for (i, id) in ParamId::ALL.into_iter().enumerate() {
        other.set(id, other.get(id) * (0.7 + 0.06 * (i % 11) as f64));
    }
    let m = SystemMatrices::assemble(&other);
    let h = freqs_hz
        .iter()
        .map(|&f| m.transmissibility(f).unwrap())
        .collect();
    Target { freqs_hz, h }
}

#[cfg(all(test, target_arch = "x86_64"))]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;
    use supine_core::model::Preset;

    /// The rigid problem against a perturbed target on the fit's 0.5-16 Hz band, at a
    /// resolution that leaves a partial last group of lanes.
    fn objective() -> Objective {
        let freqs_hz: Vec<f64> = (0..155).map(|k| 0.5 + 0.1 * k as f64).collect();
        let base = ModelParams::preset(Preset::PaperRigid);
        Objective::new(base, ParamId::ALL.to_vec(), perturbed_target(freqs_hz))
    }

    fn bits(values: &[f64]) -> Vec<u64> {
        values.iter().map(|v| v.to_bits()).collect()
    }

    #[test]
    fn the_avx2_build_gives_the_portable_builds_bits() {
        if !kernels::avx2() {
            eprintln!("no AVX2 on this CPU: only the portable build runs, nothing to compare");
            return;
        }
        let objective = objective();
        let (m, n) = (objective.residual_count(), objective.param_count());
        let parts = objective.subsystems();
        let mut rng = ChaCha8Rng::seed_from_u64(18);
        for trial in 0..40 {
            // The paper's values times e^(N(0, 1)-ish): as far from them as the random starts.
            let theta: Vec<f64> = objective
                .theta(&objective.base)
                .iter()
                .map(|t| t + rng.random_range(-2.0..2.0))
                .collect();
            let scopes = std::iter::once(Scope::All).chain(parts.iter().map(Scope::Part));
            for scope in scopes {
                let (rows, cols) = match scope {
                    Scope::All => (m, n),
                    Scope::Part(part) => (part.rows.len(), part.params.len()),
                };
                let (mut r_portable, mut r_avx2) = (vec![0.0; rows], vec![0.0; rows]);
                let mut j_portable = DMatrix::zeros(rows, cols);
                let mut j_avx2 = DMatrix::zeros(rows, cols);
                objective
                    .evaluate_scope_portable(
                        &theta,
                        scope,
                        &mut r_portable,
                        Some(&mut j_portable),
                        &mut Scratch::new(),
                    )
                    .unwrap();
                // SAFETY: the CPU has AVX2 (checked above).
                unsafe {
                    objective.evaluate_scope_avx2(
                        &theta,
                        scope,
                        &mut r_avx2,
                        Some(&mut j_avx2),
                        &mut Scratch::new(),
                    )
                }
                .unwrap();
                assert_eq!(bits(&r_portable), bits(&r_avx2), "trial {trial}: residuals");
                assert_eq!(
                    bits(j_portable.as_slice()),
                    bits(j_avx2.as_slice()),
                    "trial {trial}: Jacobian"
                );
                assert!(j_portable.iter().any(|v| *v != 0.0), "trial {trial}");
            }
        }
    }
}
