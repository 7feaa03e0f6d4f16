//! Assembly of the equations of motion M q'' + C q' + K q = K G u0 + C G u0' in f64, and of
//! the sensor output map R.
//!
//! Every spring-damper element is a rank-one term: its elongation is l = b^T q for a sparse
//! shape vector b, so it adds k b b^T to K and c b b^T to C. The same shape vectors give the
//! fit its exact Jacobian (dA/dp = b b^T or j w b b^T).

use nalgebra::{SMatrix, SVector};

use super::geometry::{Axis, Body, Segment};
use super::joints::{JOINT_OUTPUT_COUNT, JointOutput};
use super::params::{Element, JointMotion, ModelParams, ParamId, Quantity};

/// Degrees of freedom: 6 per segment (x, y, z, th_x, th_y, th_z), head first.
pub const DOF_COUNT: usize = 18;
/// Sensor outputs: head x, y, z, torso x, y, z, pelvis x, y, z.
pub const OUTPUT_COUNT: usize = 9;
/// Support inputs: x, y, z acceleration.
pub const INPUT_COUNT: usize = 3;

/// J: 10 x 18, joint motion from the generalized coordinates.
pub type JointOutputMatrix = SMatrix<f64, JOINT_OUTPUT_COUNT, DOF_COUNT>;
/// An 18 x 18 real matrix over the generalized coordinates.
pub type DofMatrix = SMatrix<f64, DOF_COUNT, DOF_COUNT>;
/// G: 18 x 3, the identity in each segment's translational rows.
pub type InputMatrix = SMatrix<f64, DOF_COUNT, INPUT_COUNT>;
/// R: 9 x 18, sensor-point acceleration from generalized accelerations.
pub type OutputMatrix = SMatrix<f64, OUTPUT_COUNT, DOF_COUNT>;

/// Index of a segment's translational DOF along `axis`.
pub const fn translation_dof(segment: Segment, axis: Axis) -> usize {
    6 * segment.index() + axis.index()
}

/// Index of a segment's rotational DOF about `axis`.
pub const fn rotation_dof(segment: Segment, axis: Axis) -> usize {
    6 * segment.index() + 3 + axis.index()
}

/// The sparse shape vector of one element along one axis: its elongation is sum w_i q_i.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Shape {
    entries: [(usize, f64); 4],
    len: usize,
}

impl Shape {
    fn new() -> Self {
        Self {
            entries: [(0, 0.0); 4],
            len: 0,
        }
    }

    fn push(&mut self, dof: usize, weight: f64) {
        if weight != 0.0 && self.len < self.entries.len() {
            self.entries[self.len] = (dof, weight);
            self.len += 1;
        }
    }

    /// The non-zero (DOF index, weight) pairs.
    pub fn entries(&self) -> &[(usize, f64)] {
        &self.entries[..self.len]
    }

    /// As a dense 18-vector.
    pub fn dense(&self) -> SVector<f64, DOF_COUNT> {
        let mut b = SVector::zeros();
        for &(i, w) in self.entries() {
            b[i] += w;
        }
        b
    }

    /// Adds `value * b b^T` to `matrix`.
    pub fn add_outer(&self, matrix: &mut DofMatrix, value: f64) {
        for &(i, wi) in self.entries() {
            for &(j, wj) in self.entries() {
                matrix[(i, j)] += value * wi * wj;
            }
        }
    }
}

/// The shape vector of `element` along (or about) `axis` for this body.
///
/// Joint o between s (head side) and t: l = (u_t + th_t x La_t) - (u_s + th_s x Lb_s), with
/// La_t = (+La, 0, 0) and Lb_s = (-Lb, 0, 0) since x points toward the head. With
/// th x (r, 0, 0) = (0, th_z r, -th_y r) that is, per axis:
/// l_x = x_t - x_s; l_y = y_t + La th_z,t - y_s + Lb th_z,s; l_z = z_t - La th_y,t - z_s - Lb th_y,s.
pub fn element_shape(element: Element, axis: Axis, body: &Body) -> Shape {
    let mut shape = Shape::new();
    match element {
        Element::Contact { segment } => shape.push(translation_dof(segment, axis), 1.0),
        Element::Joint {
            joint,
            motion: JointMotion::Rotational,
        } => {
            shape.push(rotation_dof(joint.feet_side(), axis), 1.0);
            shape.push(rotation_dof(joint.head_side(), axis), -1.0);
        }
        Element::Joint {
            joint,
            motion: JointMotion::Translational,
        } => {
            let (s, t) = (joint.head_side(), joint.feet_side());
            let la_t = body.segments[t.index()].to_head_joint_m;
            let lb_s = body.segments[s.index()].to_feet_joint_m;
            shape.push(translation_dof(t, axis), 1.0);
            shape.push(translation_dof(s, axis), -1.0);
            match axis {
                Axis::X => {}
                Axis::Y => {
                    shape.push(rotation_dof(t, Axis::Z), la_t);
                    shape.push(rotation_dof(s, Axis::Z), lb_s);
                }
                Axis::Z => {
                    shape.push(rotation_dof(t, Axis::Y), -la_t);
                    shape.push(rotation_dof(s, Axis::Y), -lb_s);
                }
            }
        }
    }
    shape
}

/// Shape vector of the element a parameter belongs to.
pub fn param_shape(id: ParamId, body: &Body) -> Shape {
    element_shape(id.element, id.axis, body)
}

/// M, C, K, G, R and J of one parameter set.
#[derive(Clone, Debug, PartialEq)]
pub struct SystemMatrices {
    /// Segment masses and inertias (diagonal), kg and kg m^2.
    pub mass: DofMatrix,
    /// Joint and contact damping.
    pub damping: DofMatrix,
    /// Joint and contact stiffness.
    pub stiffness: DofMatrix,
    /// G: support translation to each segment's translational DOFs.
    pub input: InputMatrix,
    /// R: generalized accelerations to sensor-point accelerations, a_E = u'' + th'' x p.
    pub output: OutputMatrix,
    /// J: generalized coordinates to joint motion (`super::joints`).
    pub joint_output: JointOutputMatrix,
}

impl SystemMatrices {
    /// Assembles the matrices for already validated parameters.
    pub fn assemble(params: &ModelParams) -> Self {
        let body = Body::dempster(&params.subject);
        let mut mass = DofMatrix::zeros();
        for segment in Segment::ALL {
            let seg = &body.segments[segment.index()];
            for axis in Axis::ALL {
                mass[(
                    translation_dof(segment, axis),
                    translation_dof(segment, axis),
                )] = seg.mass_kg;
                mass[(rotation_dof(segment, axis), rotation_dof(segment, axis))] =
                    seg.inertia_kg_m2;
            }
        }
        let mut damping = DofMatrix::zeros();
        let mut stiffness = DofMatrix::zeros();
        for id in ParamId::ALL {
            let target = match id.quantity {
                Quantity::Stiffness => &mut stiffness,
                Quantity::Damping => &mut damping,
            };
            param_shape(id, &body).add_outer(target, params.get(id));
        }
        Self {
            mass,
            damping,
            stiffness,
            input: input_matrix(),
            output: output_matrix(params),
            joint_output: joint_output_matrix(&body),
        }
    }
}

/// G (18 x 3): a rigid translation of the support moves every segment centre with it.
pub fn input_matrix() -> InputMatrix {
    let mut g = InputMatrix::zeros();
    for segment in Segment::ALL {
        for axis in Axis::ALL {
            g[(translation_dof(segment, axis), axis.index())] = 1.0;
        }
    }
    g
}

/// R (9 x 18): R_m = \[I3, -\[p_m\]x\], so that a_E = u'' + th'' x p_m.
pub fn output_matrix(params: &ModelParams) -> OutputMatrix {
    let mut r = OutputMatrix::zeros();
    for segment in Segment::ALL {
        let p = params.sensors.of(segment);
        let row = 3 * segment.index();
        for axis in Axis::ALL {
            r[(row + axis.index(), translation_dof(segment, axis))] = 1.0;
        }
        // th x p = -[p]x th, with [p]x = [[0, -pz, py], [pz, 0, -px], [-py, px, 0]].
        let cross = [[0.0, -p.z, p.y], [p.z, 0.0, -p.x], [-p.y, p.x, 0.0]];
        for (i, cross_row) in cross.iter().enumerate() {
            for axis in Axis::ALL {
                r[(row + i, rotation_dof(segment, axis))] = -cross_row[axis.index()];
            }
        }
    }
    r
}

/// J (10 x 18) for this body: each row is minus the shape vector of the joint element
/// that resists the motion, which measures the lower segment against the upper one
/// (`super::joints` defines the outputs).
pub fn joint_output_matrix(body: &Body) -> JointOutputMatrix {
    let mut j = JointOutputMatrix::zeros();
    for output in JointOutput::ALL {
        let motion = if output.component.is_rotation() {
            JointMotion::Rotational
        } else {
            JointMotion::Translational
        };
        let axis = output.component.axis();
        let element = Element::Joint {
            joint: output.joint,
            motion,
        };
        for &(dof, weight) in element_shape(element, axis, body).entries() {
            j[(output.index(), dof)] -= weight;
        }
    }
    j
}
