//! Transmissibility H(f): sensor-point acceleration over support acceleration, 9 x 3; and
//! the joint response: joint motion over support acceleration, 10 x 3.

use core::f64::consts::PI;
use core::fmt;

use nalgebra::{Complex, SMatrix};

use super::ModelError;
use super::assembly::{DOF_COUNT, INPUT_COUNT, OUTPUT_COUNT, SystemMatrices, rotation_dof};
use super::geometry::{Axis, Segment};
use super::joints::JOINT_OUTPUT_COUNT;

/// H at one frequency: rows head x,y,z, torso x,y,z, pelvis x,y,z; columns input x,y,z.
pub type Transmissibility = SMatrix<Complex<f64>, OUTPUT_COUNT, INPUT_COUNT>;

/// Joint motion per unit support acceleration at one frequency (m or rad per m/s^2):
/// rows in [`JointOutput::ALL`](super::joints::JointOutput::ALL) order, columns input x,
/// y, z.
pub type JointResponse = SMatrix<Complex<f64>, JOINT_OUTPUT_COUNT, INPUT_COUNT>;

/// The coordinates the support drives: all but the roll angles, which no joint output
/// involves and whose free whole-body mode would make the static problem singular.
const DRIVEN_DOF_COUNT: usize = 15;

fn driven_dofs() -> [usize; DRIVEN_DOF_COUNT] {
    let mut dofs = [0; DRIVEN_DOF_COUNT];
    let roll = Segment::ALL.map(|s| rotation_dof(s, Axis::X));
    let driven = (0..DOF_COUNT).filter(|d| !roll.contains(d));
    for (slot, dof) in dofs.iter_mut().zip(driven) {
        *slot = dof;
    }
    dofs
}

/// One sensor channel: a segment's sensor point along one axis.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Output {
    /// Whose sensor.
    pub segment: Segment,
    /// Which axis.
    pub axis: Axis,
}

impl Output {
    /// The nine outputs in H's row order.
    pub const ALL: [Output; OUTPUT_COUNT] = [
        Output::new(Segment::Head, Axis::X),
        Output::new(Segment::Head, Axis::Y),
        Output::new(Segment::Head, Axis::Z),
        Output::new(Segment::Torso, Axis::X),
        Output::new(Segment::Torso, Axis::Y),
        Output::new(Segment::Torso, Axis::Z),
        Output::new(Segment::Pelvis, Axis::X),
        Output::new(Segment::Pelvis, Axis::Y),
        Output::new(Segment::Pelvis, Axis::Z),
    ];

    /// The three head outputs, the ones the device predicts.
    pub const HEAD: [Output; 3] = [Self::ALL[0], Self::ALL[1], Self::ALL[2]];

    /// Builds an output.
    pub const fn new(segment: Segment, axis: Axis) -> Self {
        Self { segment, axis }
    }

    /// Row of H (0..9): the paper's output index minus one.
    pub const fn index(self) -> usize {
        3 * self.segment.index() + self.axis.index()
    }

    /// The recording column name, e.g. `head_x`.
    pub const fn name(self) -> &'static str {
        const NAMES: [&str; OUTPUT_COUNT] = [
            "head_x", "head_y", "head_z", "torso_x", "torso_y", "torso_z", "pelvis_x", "pelvis_y",
            "pelvis_z",
        ];
        NAMES[self.index()]
    }

    /// Looks an output up by its column name.
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|o| o.name() == name)
    }
}

impl fmt::Display for Output {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// The 12 components this geometry couples (the ones the paper fits), as (output, input).
///
/// H11, H22, H33, H41, H52, H63, H71, H82, H93, H13, H43, H73 in the paper's numbering.
pub const COUPLED_COMPONENTS: [(Output, Axis); 12] = [
    (Output::ALL[0], Axis::X),
    (Output::ALL[1], Axis::Y),
    (Output::ALL[2], Axis::Z),
    (Output::ALL[3], Axis::X),
    (Output::ALL[4], Axis::Y),
    (Output::ALL[5], Axis::Z),
    (Output::ALL[6], Axis::X),
    (Output::ALL[7], Axis::Y),
    (Output::ALL[8], Axis::Z),
    (Output::ALL[0], Axis::Z),
    (Output::ALL[3], Axis::Z),
    (Output::ALL[6], Axis::Z),
];

/// The dynamic stiffness A(w) = K - w^2 M + j w C, complex symmetric.
pub fn dynamic_stiffness(
    matrices: &SystemMatrices,
    omega_rad_s: f64,
) -> SMatrix<Complex<f64>, DOF_COUNT, DOF_COUNT> {
    SMatrix::from_fn(|i, j| {
        Complex::new(
            matrices.stiffness[(i, j)] - omega_rad_s * omega_rad_s * matrices.mass[(i, j)],
            omega_rad_s * matrices.damping[(i, j)],
        )
    })
}

impl SystemMatrices {
    /// H(f) = R (K - w^2 M + j w C)^-1 (K + j w C) G at `freq_hz` (>= 0).
    pub fn transmissibility(&self, freq_hz: f64) -> Result<Transmissibility, ModelError> {
        let omega = 2.0 * PI * freq_hz;
        let a = dynamic_stiffness(self, omega);
        let forcing: SMatrix<Complex<f64>, DOF_COUNT, INPUT_COUNT> = SMatrix::from_fn(|i, k| {
            let mut acc = Complex::new(0.0, 0.0);
            for j in 0..DOF_COUNT {
                let g = self.input[(j, k)];
                if g != 0.0 {
                    acc += Complex::new(self.stiffness[(i, j)], omega * self.damping[(i, j)]) * g;
                }
            }
            acc
        });
        let x = a.lu().solve(&forcing).ok_or(ModelError::Singular)?;
        let r = self.output.map(|v| Complex::new(v, 0.0));
        Ok(r * x)
    }
}

impl SystemMatrices {
    /// The joint response J (K - w^2 M + j w C)^-1 (-M G) at `freq_hz` (>= 0): the
    /// relative-coordinate equation solved directly, on the coordinates the support drives
    /// (so that it holds at 0 Hz too, the static deflection).
    pub fn joint_response(&self, freq_hz: f64) -> Result<JointResponse, ModelError> {
        let omega = 2.0 * PI * freq_hz;
        let dofs = driven_dofs();
        let full = dynamic_stiffness(self, omega);
        let a = SMatrix::<Complex<f64>, DRIVEN_DOF_COUNT, DRIVEN_DOF_COUNT>::from_fn(|i, j| {
            full[(dofs[i], dofs[j])]
        });
        let forcing = SMatrix::<Complex<f64>, DRIVEN_DOF_COUNT, INPUT_COUNT>::from_fn(|i, k| {
            let d = dofs[i];
            Complex::new(-self.mass[(d, d)] * self.input[(d, k)], 0.0)
        });
        let y = a.lu().solve(&forcing).ok_or(ModelError::Singular)?;
        let j = SMatrix::<Complex<f64>, JOINT_OUTPUT_COUNT, DRIVEN_DOF_COUNT>::from_fn(|o, i| {
            Complex::new(self.joint_output[(o, dofs[i])], 0.0)
        });
        Ok(j * y)
    }
}
