//! The motion inside the spine's two modelled joints, neck (J1) and lower back (J2): what
//! a spinal-injury patient's board is meant to limit and no sensor on the litter can see.
//!
//! Each output is a linear combination of the generalized coordinates, so the model needs
//! no new states (`docs/model.md`, "Joint motion"). At a joint between an upper segment
//! (toward the head) and a lower one, with r the vector from a segment's centre to the
//! joint:
//! - translation d = (u_upper + th_upper x r_upper) - (u_lower + th_lower x r_lower): the
//!   upper segment's joint point relative to the lower one's, m;
//! - rotation th_upper - th_lower about y (flexion-extension) and z (lateral bending), rad.
//!
//! That is the joint element's elongation with the opposite sign (the element measures the
//! lower segment against the upper), so both come from the one shape vector in
//! [`element_shape`](super::assembly::element_shape) ([`joint_output_matrix`](super::assembly::joint_output_matrix)). Roll about x is left out: no translation of the support excites it.
//! Joint motion is relative, so it is the same in absolute and in support-relative
//! coordinates (a rigid translation moves both joint points alike).

use core::fmt;

use super::geometry::Axis;
use super::params::JointId;

/// Joint outputs: five per joint (three translations, two rotations).
pub const JOINT_OUTPUT_COUNT: usize = 10;

/// One component of a joint's motion (roll about x is not one: nothing excites it).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum JointComponent {
    /// Relative translation along x: compression and distraction of the spine.
    X,
    /// Relative translation along y: lateral shear.
    Y,
    /// Relative translation along z: anteroposterior shear.
    Z,
    /// Relative rotation about y: flexion and extension.
    Ry,
    /// Relative rotation about z: lateral bending.
    Rz,
}

impl JointComponent {
    /// x, y, z, ry, rz.
    pub const ALL: [JointComponent; 5] = [
        JointComponent::X,
        JointComponent::Y,
        JointComponent::Z,
        JointComponent::Ry,
        JointComponent::Rz,
    ];

    /// The axis along or about which it moves.
    pub const fn axis(self) -> Axis {
        match self {
            JointComponent::X => Axis::X,
            JointComponent::Y | JointComponent::Ry => Axis::Y,
            JointComponent::Z | JointComponent::Rz => Axis::Z,
        }
    }

    /// Whether it is a rotation (rad) rather than a translation (m).
    pub const fn is_rotation(self) -> bool {
        matches!(self, JointComponent::Ry | JointComponent::Rz)
    }
}

/// What a joint output is measured in.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum JointUnit {
    /// Metres (translations).
    Metre,
    /// Radians (rotations).
    Radian,
}

impl JointUnit {
    /// The SI unit as a column or key suffix names it: `m` or `rad` (the telemetry CSV's
    /// `neck_x_m`, the wire's values).
    pub const fn si_suffix(self) -> &'static str {
        match self {
            JointUnit::Metre => "m",
            JointUnit::Radian => "rad",
        }
    }

    /// The unit a person reads, as a suffix names it, and the factor from the SI value to
    /// it: `mm` (1e3) or `deg` (180 / pi).
    pub const fn display(self) -> (&'static str, f64) {
        match self {
            JointUnit::Metre => ("mm", 1e3),
            JointUnit::Radian => ("deg", 180.0 / core::f64::consts::PI),
        }
    }
}

/// One joint output: a joint and a component of its motion.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct JointOutput {
    /// Neck (head-torso) or lower back (torso-pelvis).
    pub joint: JointId,
    /// Which motion.
    pub component: JointComponent,
}

impl JointOutput {
    /// The ten outputs in their fixed order: per joint (neck first) x, y, z, ry, rz.
    pub const ALL: [JointOutput; JOINT_OUTPUT_COUNT] = {
        let mut all = [JointOutput::new(JointId::HeadTorso, JointComponent::X); JOINT_OUTPUT_COUNT];
        let mut k = 0;
        while k < JOINT_OUTPUT_COUNT {
            let joint = if k < 5 {
                JointId::HeadTorso
            } else {
                JointId::TorsoPelvis
            };
            all[k] = JointOutput::new(joint, JointComponent::ALL[k % 5]);
            k += 1;
        }
        all
    };

    /// Builds an output.
    pub const fn new(joint: JointId, component: JointComponent) -> Self {
        Self { joint, component }
    }

    /// Position in [`ALL`](Self::ALL) (0..10).
    pub const fn index(self) -> usize {
        let joint = match self.joint {
            JointId::HeadTorso => 0,
            JointId::TorsoPelvis => 5,
        };
        joint + self.component as usize
    }

    /// The column name, e.g. `neck_x`, `low_back_ry`.
    pub const fn name(self) -> &'static str {
        const NAMES: [&str; JOINT_OUTPUT_COUNT] = [
            "neck_x",
            "neck_y",
            "neck_z",
            "neck_ry",
            "neck_rz",
            "low_back_x",
            "low_back_y",
            "low_back_z",
            "low_back_ry",
            "low_back_rz",
        ];
        NAMES[self.index()]
    }

    /// Looks an output up by its name.
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|o| o.name() == name)
    }

    /// Metres or radians.
    pub const fn unit(self) -> JointUnit {
        if self.component.is_rotation() {
            JointUnit::Radian
        } else {
            JointUnit::Metre
        }
    }

    /// The support axis that excites this output (each is reached by exactly one: x the
    /// longitudinal translations, y the lateral ones and bending about z, z the vertical
    /// ones and flexion about y).
    pub const fn input_axis(self) -> Axis {
        match self.component {
            JointComponent::X => Axis::X,
            JointComponent::Y | JointComponent::Rz => Axis::Y,
            JointComponent::Z | JointComponent::Ry => Axis::Z,
        }
    }
}

impl fmt::Display for JointOutput {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}
