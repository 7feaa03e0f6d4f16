//! Modal analysis of the continuous model, one decoupled subsystem at a time.
//!
//! With joints on the x axis and sensors offset from it, the 18 DOFs fall into four
//! subsystems that share no stiffness, damping or mass: longitudinal {x}, lateral {y, th_z},
//! vertical {z, th_y} and roll {th_x}. Each is driven by at most one input axis, and roll by
//! none: its modes (including the free whole-body roll) cannot be reached from the input.
//! Decomposing each subsystem separately keeps the eigenproblems small (at most 12 states)
//! and gives every mode exactly one input axis, which the device realization exploits.

use core::f64::consts::PI;
use core::fmt;

use heapless::Vec;
use nalgebra::allocator::Allocator;
use nalgebra::{Complex, Const, DefaultAllocator, DimDiff, DimMin, DimSub, SMatrix, U1};

use super::ModelError;
use super::assembly::{DOF_COUNT, OUTPUT_COUNT};
use super::geometry::Axis;
use super::joints::JOINT_OUTPUT_COUNT;
use super::response::Transmissibility;
use super::state_space::StateSpace;

/// One of the four decoupled subsystems.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Subsystem {
    /// x of each segment; driven by the x input.
    Longitudinal,
    /// y and th_z of each segment; driven by the y input.
    Lateral,
    /// z and th_y of each segment; driven by the z input.
    Vertical,
    /// th_x of each segment; driven by nothing.
    Roll,
}

impl Subsystem {
    /// All four, in DOF order of their first coordinate.
    pub const ALL: [Subsystem; 4] = [
        Subsystem::Longitudinal,
        Subsystem::Lateral,
        Subsystem::Vertical,
        Subsystem::Roll,
    ];

    /// The generalized coordinates (indices into q) of this subsystem.
    pub const fn dofs(self) -> &'static [usize] {
        match self {
            Subsystem::Longitudinal => &[0, 6, 12],
            Subsystem::Lateral => &[1, 5, 7, 11, 13, 17],
            Subsystem::Vertical => &[2, 4, 8, 10, 14, 16],
            Subsystem::Roll => &[3, 9, 15],
        }
    }

    /// The support axis that drives this subsystem, if any.
    pub const fn input_axis(self) -> Option<Axis> {
        match self {
            Subsystem::Longitudinal => Some(Axis::X),
            Subsystem::Lateral => Some(Axis::Y),
            Subsystem::Vertical => Some(Axis::Z),
            Subsystem::Roll => None,
        }
    }

    /// Lower-case name for tables.
    pub const fn name(self) -> &'static str {
        match self {
            Subsystem::Longitudinal => "longitudinal",
            Subsystem::Lateral => "lateral",
            Subsystem::Vertical => "vertical",
            Subsystem::Roll => "roll",
        }
    }
}

impl fmt::Display for Subsystem {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// One eigenvalue of the continuous model (a complex pair counts once), with how the input
/// reaches it and how it shows in the nine sensor outputs.
///
/// Its contribution to H is c_o g / (j w - lambda), plus the complex conjugate for a pair.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ModalComponent {
    /// The subsystem the mode lives in.
    pub subsystem: Subsystem,
    /// The eigenvalue, 1/s (for a pair, the one with positive imaginary part).
    pub eigenvalue: Complex<f64>,
    /// Whether this stands for a complex-conjugate pair.
    pub is_pair: bool,
    /// Modal input gain g from the subsystem's input axis (zero for roll).
    pub input_gain: Complex<f64>,
    /// Modal output gains c for the nine outputs.
    pub output_gain: [Complex<f64>; OUTPUT_COUNT],
    /// Modal output gains for the ten joint outputs (m or rad per unit modal state).
    pub joint_gain: [Complex<f64>; JOINT_OUTPUT_COUNT],
    /// Whether the input can excite this mode at all.
    pub reachable: bool,
}

impl ModalComponent {
    /// Undamped natural frequency |lambda| / 2 pi, Hz.
    pub fn natural_frequency_hz(&self) -> f64 {
        modulus(self.eigenvalue) / (2.0 * PI)
    }

    /// Damping ratio -Re(lambda) / |lambda| of an oscillatory pair; `None` for a real pole.
    pub fn damping_ratio(&self) -> Option<f64> {
        let norm = modulus(self.eigenvalue);
        (self.is_pair && norm > 0.0).then(|| -self.eigenvalue.re / norm)
    }
}

/// Upper bound on components: 36 eigenvalues if all were real.
pub const MAX_COMPONENTS: usize = 36;

/// The modal decomposition of the whole model.
#[derive(Clone, Debug, PartialEq)]
pub struct ModalAnalysis {
    /// Every mode of every subsystem; roll's carry no gains.
    pub components: Vec<ModalComponent, MAX_COMPONENTS>,
}

impl ModalAnalysis {
    /// Decomposes each subsystem of the relative-coordinate state space.
    pub fn new(ss: &StateSpace) -> Result<Self, ModelError> {
        let mut components = Vec::new();
        for subsystem in Subsystem::ALL {
            match subsystem.dofs().len() {
                3 => decompose::<6>(ss, subsystem, &mut components)?,
                _ => decompose::<12>(ss, subsystem, &mut components)?,
            }
        }
        Ok(Self { components })
    }

    /// H(f) as the sum of modal contributions: equals the direct solution.
    pub fn frequency_response(&self, freq_hz: f64) -> Transmissibility {
        let jw = Complex::new(0.0, 2.0 * PI * freq_hz);
        let mut h = Transmissibility::zeros();
        for m in self.components.iter().filter(|m| m.reachable) {
            let Some(axis) = m.subsystem.input_axis() else {
                continue;
            };
            for (o, c) in m.output_gain.iter().enumerate() {
                let mut term = c * m.input_gain / (jw - m.eigenvalue);
                if m.is_pair {
                    term += c.conj() * m.input_gain.conj() / (jw - m.eigenvalue.conj());
                }
                h[(o, axis.index())] += term;
            }
        }
        h
    }
}

/// Relative tolerance on the eigen-decomposition residual and on V V^-1 = I.
const DECOMPOSITION_TOLERANCE: f64 = 1e-8;
/// Imaginary part (relative to |lambda|) below which an eigenvalue is taken as real.
const REAL_EIGENVALUE_TOLERANCE: f64 = 1e-9;

type Cplx = Complex<f64>;

/// |z|, without relying on a float extension trait.
pub fn modulus(z: Complex<f64>) -> f64 {
    libm::hypot(z.re, z.im)
}

/// arg z in (-pi, pi], without relying on a float extension trait.
pub fn argument(z: Complex<f64>) -> f64 {
    libm::atan2(z.im, z.re)
}

fn decompose<const S: usize>(
    ss: &StateSpace,
    subsystem: Subsystem,
    out: &mut Vec<ModalComponent, MAX_COMPONENTS>,
) -> Result<(), ModelError>
where
    Const<S>: DimMin<Const<S>, Output = Const<S>> + DimSub<U1>,
    DefaultAllocator: Allocator<DimDiff<Const<S>, U1>> + Allocator<Const<S>, DimDiff<Const<S>, U1>>,
{
    let dofs = subsystem.dofs();
    let n = dofs.len();
    debug_assert_eq!(2 * n, S);
    // Subsystem state k < n is y_{dofs[k]}, k >= n is y'_{dofs[k - n]}.
    let full = |k: usize| {
        if k < n {
            dofs[k]
        } else {
            DOF_COUNT + dofs[k - n]
        }
    };
    let a = SMatrix::<f64, S, S>::from_fn(|i, j| ss.a[(full(i), full(j))]);
    let eigenvalues = eigenvalues_of(&a);

    let Some(axis) = subsystem.input_axis() else {
        for lambda in pairs_and_reals(&eigenvalues) {
            push(
                out,
                ModalComponent {
                    subsystem,
                    eigenvalue: lambda.0,
                    is_pair: lambda.1,
                    input_gain: Cplx::new(0.0, 0.0),
                    output_gain: [Cplx::new(0.0, 0.0); OUTPUT_COUNT],
                    joint_gain: [Cplx::new(0.0, 0.0); JOINT_OUTPUT_COUNT],
                    reachable: false,
                },
            )?;
        }
        return Ok(());
    };

    let ac = a.map(|v| Cplx::new(v, 0.0));
    let b = SMatrix::<f64, S, 1>::from_fn(|i, _| ss.b[(full(i), axis.index())]);
    // Columns of V: one eigenvector per eigenvalue, a pair's conjugate next to it.
    let mut v = SMatrix::<Cplx, S, S>::zeros();
    let mut lambdas = [Cplx::new(0.0, 0.0); S];
    let mut is_pair = [false; S];
    let mut col = 0;
    for (lambda, pair) in pairs_and_reals(&eigenvalues) {
        let vec = eigenvector(&ac, lambda, !pair)?;
        if col + usize::from(pair) >= S {
            return Err(ModelError::DefectiveModes(subsystem));
        }
        v.set_column(col, &vec);
        lambdas[col] = lambda;
        is_pair[col] = pair;
        col += 1;
        if pair {
            v.set_column(col, &vec.map(|z| z.conj()));
            lambdas[col] = lambda.conj();
            col += 1;
        }
    }
    if col != S {
        return Err(ModelError::DefectiveModes(subsystem));
    }
    let w = v
        .lu()
        .try_inverse()
        .ok_or(ModelError::DefectiveModes(subsystem))?;
    check_decomposition(&ac, &v, &w, &lambdas, subsystem)?;

    let g = w * b.map(|x| Cplx::new(x, 0.0));
    let c_full =
        SMatrix::<Cplx, OUTPUT_COUNT, S>::from_fn(|o, j| Cplx::new(ss.c[(o, full(j))], 0.0));
    let c = c_full * v;
    let c_joint = SMatrix::<Cplx, JOINT_OUTPUT_COUNT, S>::from_fn(|o, j| {
        Cplx::new(ss.c_joint[(o, full(j))], 0.0)
    }) * v;
    let g_max = g.iter().map(|z| modulus(*z)).fold(0.0, f64::max);
    let mut k = 0;
    while k < S {
        let pair = is_pair[k];
        push(
            out,
            ModalComponent {
                subsystem,
                eigenvalue: lambdas[k],
                is_pair: pair,
                input_gain: g[k],
                output_gain: core::array::from_fn(|o| c[(o, k)]),
                joint_gain: core::array::from_fn(|o| c_joint[(o, k)]),
                reachable: modulus(g[k]) > 1e-10 * g_max,
            },
        )?;
        k += if pair { 2 } else { 1 };
    }
    Ok(())
}

fn push(
    out: &mut Vec<ModalComponent, MAX_COMPONENTS>,
    m: ModalComponent,
) -> Result<(), ModelError> {
    out.push(m)
        .map_err(|_| ModelError::DefectiveModes(m.subsystem))
}

fn eigenvalues_of<const S: usize>(a: &SMatrix<f64, S, S>) -> [Cplx; S]
where
    Const<S>: DimMin<Const<S>, Output = Const<S>> + DimSub<U1>,
    DefaultAllocator: Allocator<DimDiff<Const<S>, U1>> + Allocator<Const<S>, DimDiff<Const<S>, U1>>,
{
    let mut lambdas = [Cplx::new(0.0, 0.0); S];
    let computed = a.complex_eigenvalues();
    for (slot, value) in lambdas.iter_mut().zip(computed.iter()) {
        *slot = *value;
    }
    lambdas
}

/// The distinct modes: each complex pair once (positive imaginary part), each real root.
fn pairs_and_reals<const S: usize>(eigenvalues: &[Cplx; S]) -> Vec<(Cplx, bool), S> {
    let mut modes: Vec<(Cplx, bool), S> = Vec::new();
    for lambda in eigenvalues {
        let scale = modulus(*lambda).max(f64::MIN_POSITIVE);
        let is_real = lambda.im.abs() <= REAL_EIGENVALUE_TOLERANCE * scale;
        let entry = if is_real {
            (Cplx::new(lambda.re, 0.0), false)
        } else if lambda.im > 0.0 {
            (*lambda, true)
        } else {
            continue;
        };
        // Capacity is S and there are at most S roots.
        let _ = modes.push(entry);
    }
    // Slow modes first: a stable, readable order.
    modes.sort_unstable_by(|a, b| modulus(a.0).total_cmp(&modulus(b.0)));
    modes
}

/// Eigenvector by inverse iteration from a shift just off the eigenvalue.
fn eigenvector<const S: usize>(
    a: &SMatrix<Cplx, S, S>,
    lambda: Cplx,
    real: bool,
) -> Result<SMatrix<Cplx, S, 1>, ModelError>
where
    Const<S>: DimMin<Const<S>, Output = Const<S>> + DimSub<U1>,
    DefaultAllocator: Allocator<DimDiff<Const<S>, U1>> + Allocator<Const<S>, DimDiff<Const<S>, U1>>,
{
    let scale = modulus(lambda).max(1.0);
    let shift = lambda + Cplx::new(1e-10 * scale, 1e-10 * scale);
    let shifted = a - SMatrix::<Cplx, S, S>::identity() * shift;
    let lu = shifted.lu();
    let mut x =
        SMatrix::<Cplx, S, 1>::from_fn(|i, _| Cplx::new(1.0 + 0.1 * i as f64, 0.05 * i as f64));
    for _ in 0..3 {
        x = lu.solve(&x).ok_or(ModelError::Singular)?;
        let pivot = largest(&x);
        if modulus(pivot) == 0.0 || !pivot.re.is_finite() || !pivot.im.is_finite() {
            return Err(ModelError::Singular);
        }
        x /= pivot;
    }
    if real {
        x = x.map(|z| Cplx::new(z.re, 0.0));
    }
    Ok(x)
}

fn largest<const S: usize>(x: &SMatrix<Cplx, S, 1>) -> Cplx {
    x.iter()
        .copied()
        .max_by(|a, b| modulus(*a).total_cmp(&modulus(*b)))
        .unwrap_or(Cplx::new(0.0, 0.0))
}

fn check_decomposition<const S: usize>(
    a: &SMatrix<Cplx, S, S>,
    v: &SMatrix<Cplx, S, S>,
    w: &SMatrix<Cplx, S, S>,
    lambdas: &[Cplx; S],
    subsystem: Subsystem,
) -> Result<(), ModelError> {
    let a_norm = a.iter().map(|z| modulus(*z)).fold(0.0, f64::max);
    let av = a * v;
    for j in 0..S {
        for i in 0..S {
            if modulus(av[(i, j)] - v[(i, j)] * lambdas[j]) > DECOMPOSITION_TOLERANCE * a_norm {
                return Err(ModelError::DefectiveModes(subsystem));
            }
        }
    }
    let identity = v * w;
    for j in 0..S {
        for i in 0..S {
            let expected = if i == j { 1.0 } else { 0.0 };
            if modulus(identity[(i, j)] - expected) > DECOMPOSITION_TOLERANCE * 1e3 {
                return Err(ModelError::DefectiveModes(subsystem));
            }
        }
    }
    Ok(())
}
