//! The model's parameters: subject, joints, contacts and sensor offsets, with the paper's
//! presets and validation.
//!
//! Fields are named by what they are (`neck.translational.stiffness_n_per_m.z`); the 42
//! identifiable numbers are also addressable one by one through [`ParamId`] for the fit,
//! without exposing a bare array.

use core::fmt;

use serde::{Deserialize, Serialize};

use super::geometry::{Axis, Segment, Subject};

/// One number per Cartesian axis (x longitudinal toward the head, y lateral, z up).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PerAxis {
    /// Value along x (longitudinal).
    pub x: f64,
    /// Value along y (lateral).
    pub y: f64,
    /// Value along z (vertical).
    pub z: f64,
}

impl PerAxis {
    /// Builds from x, y, z.
    pub const fn new(x: f64, y: f64, z: f64) -> Self {
        Self { x, y, z }
    }

    /// The value along `axis`.
    pub const fn get(&self, axis: Axis) -> f64 {
        match axis {
            Axis::X => self.x,
            Axis::Y => self.y,
            Axis::Z => self.z,
        }
    }

    /// Mutable access to the value along `axis`.
    pub fn get_mut(&mut self, axis: Axis) -> &mut f64 {
        match axis {
            Axis::X => &mut self.x,
            Axis::Y => &mut self.y,
            Axis::Z => &mut self.z,
        }
    }
}

/// A translational spring-damper, diagonal in x, y, z.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TranslationalSpringDamper {
    /// Stiffness per axis, N/m.
    pub stiffness_n_per_m: PerAxis,
    /// Damping per axis, N s/m.
    pub damping_n_s_per_m: PerAxis,
}

/// A rotational spring-damper, diagonal about x, y, z.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RotationalSpringDamper {
    /// Stiffness per axis, N m/rad.
    pub stiffness_nm_per_rad: PerAxis,
    /// Damping per axis, N m s/rad.
    pub damping_nm_s_per_rad: PerAxis,
}

/// A joint between two neighbouring segments: 12 numbers.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct JointParams {
    /// Resists the relative displacement of the two joint points.
    pub translational: TranslationalSpringDamper,
    /// Resists the relative rotation of the two segments.
    pub rotational: RotationalSpringDamper,
}

/// The two joints, head side first.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Joints {
    /// J1, between head-neck and torso-arms.
    pub head_torso: JointParams,
    /// J2, between torso-arms and pelvis-legs.
    pub torso_pelvis: JointParams,
}

/// Contacts of each segment with the support (spinal board, litter or platform).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Contacts {
    /// Under the head.
    pub head: TranslationalSpringDamper,
    /// Under the torso.
    pub torso: TranslationalSpringDamper,
    /// Under the pelvis and legs.
    pub pelvis: TranslationalSpringDamper,
}

impl Contacts {
    /// The contact of one segment.
    pub const fn of(&self, segment: Segment) -> &TranslationalSpringDamper {
        match segment {
            Segment::Head => &self.head,
            Segment::Torso => &self.torso,
            Segment::Pelvis => &self.pelvis,
        }
    }

    fn of_mut(&mut self, segment: Segment) -> &mut TranslationalSpringDamper {
        match segment {
            Segment::Head => &mut self.head,
            Segment::Torso => &mut self.torso,
            Segment::Pelvis => &mut self.pelvis,
        }
    }
}

/// Where each segment's accelerometer sits relative to the segment's centre, m.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SensorOffsets {
    /// Forehead sensor E1 from the head-neck centre, m.
    pub head_m: PerAxis,
    /// Sternum sensor E2 from the torso-arms centre, m.
    pub torso_m: PerAxis,
    /// Pelvis sensor E3 from the pelvis-legs centre, m.
    pub pelvis_m: PerAxis,
}

impl SensorOffsets {
    /// The offset of one segment's sensor, m.
    pub const fn of(&self, segment: Segment) -> &PerAxis {
        match segment {
            Segment::Head => &self.head_m,
            Segment::Torso => &self.torso_m,
            Segment::Pelvis => &self.pelvis_m,
        }
    }

    fn of_mut(&mut self, segment: Segment) -> &mut PerAxis {
        match segment {
            Segment::Head => &mut self.head_m,
            Segment::Torso => &mut self.torso_m,
            Segment::Pelvis => &mut self.pelvis_m,
        }
    }

    /// The paper's sensor points: 0.10, 0.12 and 0.10 m above the centres.
    pub const PAPER: Self = Self {
        head_m: PerAxis::new(0.0, 0.0, 0.10),
        torso_m: PerAxis::new(0.0, 0.0, 0.12),
        pelvis_m: PerAxis::new(0.0, 0.0, 0.10),
    };
}

/// Everything that defines one supine human on one support: the model's full input.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ModelParams {
    /// Height and mass, from which segment masses, lengths and inertias follow.
    pub subject: Subject,
    /// The head-torso and torso-pelvis joints.
    pub joints: Joints,
    /// The segments' contacts with the support.
    pub contacts: Contacts,
    /// Sensor points relative to the segment centres.
    pub sensors: SensorOffsets,
}

/// The paper's parameter sets (Wang & Rahmatalla 2013, Tables 3 and 4).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Preset {
    /// Subjects lying directly on the rigid platform.
    PaperRigid,
    /// Subjects strapped to a spinal board on a litter.
    PaperLitter,
}

impl Preset {
    /// Every preset, in a stable order.
    pub const ALL: [Preset; 2] = [Preset::PaperRigid, Preset::PaperLitter];

    /// The command-line name.
    pub const fn name(self) -> &'static str {
        match self {
            Preset::PaperRigid => "paper-rigid",
            Preset::PaperLitter => "paper-litter",
        }
    }

    /// Looks a preset up by its command-line name.
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|p| p.name() == name)
    }
}

const fn tsd(k: [f64; 3], c: [f64; 3]) -> TranslationalSpringDamper {
    TranslationalSpringDamper {
        stiffness_n_per_m: PerAxis::new(k[0], k[1], k[2]),
        damping_n_s_per_m: PerAxis::new(c[0], c[1], c[2]),
    }
}

const fn rsd(k: [f64; 3], c: [f64; 3]) -> RotationalSpringDamper {
    RotationalSpringDamper {
        stiffness_nm_per_rad: PerAxis::new(k[0], k[1], k[2]),
        damping_nm_s_per_rad: PerAxis::new(c[0], c[1], c[2]),
    }
}

/// Table 3: the joints of the rigid-case fit, shared by both presets.
const PAPER_JOINTS: Joints = Joints {
    head_torso: JointParams {
        translational: tsd([31967.2, 14553.6, 122987.8], [14335.5, 591.9, 8.1]),
        rotational: rsd([50005.3, 772.9, 48964.0], [1.0, 11.0, 2140.5]),
    },
    torso_pelvis: JointParams {
        translational: tsd([38485.4, 22719.8, 68341.0], [273.8, 66.5, 46061.6]),
        rotational: rsd([50005.6, 18832.4, 49596.6], [1.0, 278.9, 4992.1]),
    },
};

/// Table 4, rigid platform.
const PAPER_RIGID_CONTACTS: Contacts = Contacts {
    head: tsd([21042.5, 24968.7, 109881.9], [6.2, 1.9, 118.4]),
    torso: tsd([13626.3, 8756.4, 83841.3], [230.8, 425.7, 3574.1]),
    pelvis: tsd([9147.7, 6042.0, 107865.1], [487.4, 319.3, 0.156]),
};

/// Table 4, spinal board on a litter.
const PAPER_LITTER_CONTACTS: Contacts = Contacts {
    head: tsd([21042.5, 21382.4, 43148.0], [0.004, 0.9, 117.1]),
    torso: tsd([13626.3, 7337.7, 0.8], [160.1, 337.3, 488.8]),
    pelvis: tsd([4859.3, 6041.9, 66421.1], [458.3, 166.4, 0.023]),
};

impl ModelParams {
    /// The paper's parameters for the mean subject (1.82 m, 81 kg).
    pub const fn preset(preset: Preset) -> Self {
        Self {
            subject: Subject::PAPER_MEAN,
            joints: PAPER_JOINTS,
            contacts: match preset {
                Preset::PaperRigid => PAPER_RIGID_CONTACTS,
                Preset::PaperLitter => PAPER_LITTER_CONTACTS,
            },
            sensors: SensorOffsets::PAPER,
        }
    }

    /// One identifiable parameter.
    pub fn get(&self, id: ParamId) -> f64 {
        match id.element {
            Element::Joint { joint, motion } => {
                let j = joint.of(&self.joints);
                match (motion, id.quantity) {
                    (JointMotion::Translational, Quantity::Stiffness) => {
                        j.translational.stiffness_n_per_m.get(id.axis)
                    }
                    (JointMotion::Translational, Quantity::Damping) => {
                        j.translational.damping_n_s_per_m.get(id.axis)
                    }
                    (JointMotion::Rotational, Quantity::Stiffness) => {
                        j.rotational.stiffness_nm_per_rad.get(id.axis)
                    }
                    (JointMotion::Rotational, Quantity::Damping) => {
                        j.rotational.damping_nm_s_per_rad.get(id.axis)
                    }
                }
            }
            Element::Contact { segment } => {
                let c = self.contacts.of(segment);
                match id.quantity {
                    Quantity::Stiffness => c.stiffness_n_per_m.get(id.axis),
                    Quantity::Damping => c.damping_n_s_per_m.get(id.axis),
                }
            }
        }
    }

    /// Sets one identifiable parameter.
    pub fn set(&mut self, id: ParamId, value: f64) {
        let slot = match id.element {
            Element::Joint { joint, motion } => {
                let j = joint.of_mut(&mut self.joints);
                match (motion, id.quantity) {
                    (JointMotion::Translational, Quantity::Stiffness) => {
                        &mut j.translational.stiffness_n_per_m
                    }
                    (JointMotion::Translational, Quantity::Damping) => {
                        &mut j.translational.damping_n_s_per_m
                    }
                    (JointMotion::Rotational, Quantity::Stiffness) => {
                        &mut j.rotational.stiffness_nm_per_rad
                    }
                    (JointMotion::Rotational, Quantity::Damping) => {
                        &mut j.rotational.damping_nm_s_per_rad
                    }
                }
            }
            Element::Contact { segment } => {
                let c = self.contacts.of_mut(segment);
                match id.quantity {
                    Quantity::Stiffness => &mut c.stiffness_n_per_m,
                    Quantity::Damping => &mut c.damping_n_s_per_m,
                }
            }
        };
        *slot.get_mut(id.axis) = value;
    }

    /// Checks every number once, at the boundary, so the model code can assume sane input.
    ///
    /// Stiffness, damping, height and mass must be finite, strictly positive and within
    /// their plausible range ([`ParamField::plausible_range`]); sensor offsets finite and
    /// within [`MAX_SENSOR_OFFSET_M`] of the segment centre.
    pub fn validate(&self) -> Result<(), ParamError> {
        plausible(self.subject.height_m, ParamField::HeightM)?;
        plausible(self.subject.mass_kg, ParamField::MassKg)?;
        for id in ParamId::ALL {
            plausible(self.get(id), ParamField::Param(id))?;
        }
        for segment in Segment::ALL {
            let offset = self.sensors.of(segment);
            for axis in Axis::ALL {
                let v = offset.get(axis);
                let field = ParamField::SensorOffsetM { segment, axis };
                if !v.is_finite() {
                    return Err(ParamError {
                        field,
                        problem: Problem::NotFinite,
                    });
                }
                if v.abs() > MAX_SENSOR_OFFSET_M {
                    return Err(ParamError {
                        field,
                        problem: Problem::OutOfRange,
                    });
                }
            }
        }
        Ok(())
    }

    /// Sets a sensor offset component (m); for tests and tools that move a sensor.
    pub fn set_sensor_offset_m(&mut self, segment: Segment, axis: Axis, value_m: f64) {
        *self.sensors.of_mut(segment).get_mut(axis) = value_m;
    }
}

/// A sensor further than this from its segment's centre (m) is surely a unit mistake.
pub const MAX_SENSOR_OFFSET_M: f64 = 0.5;

/// Subject height, m: from a small child to the tallest adults.
pub const HEIGHT_RANGE_M: (f64, f64) = (0.5, 2.5);
/// Subject mass, kg.
pub const MASS_RANGE_KG: (f64, f64) = (2.0, 300.0);
/// Any stiffness (N/m, N m/rad) or damping (N s/m, N m s/rad): six decades around the
/// fit's bounds (1e-3 to 1e6). Far outside, a number is a unit mistake, and the modal
/// analysis of e.g. a 1e308 stiffness or a subnormal mass need not converge.
pub const COEFFICIENT_RANGE: (f64, f64) = (1e-6, 1e9);

fn plausible(value: f64, field: ParamField) -> Result<(), ParamError> {
    let problem = if !value.is_finite() {
        Problem::NotFinite
    } else if value <= 0.0 {
        Problem::NotPositive
    } else {
        let (lo, hi) = field.plausible_range();
        if (lo..=hi).contains(&value) {
            return Ok(());
        }
        Problem::OutOfRange
    };
    Err(ParamError { field, problem })
}

/// Which of the two joints.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum JointId {
    /// J1, head-neck to torso-arms.
    HeadTorso,
    /// J2, torso-arms to pelvis-legs.
    TorsoPelvis,
}

impl JointId {
    /// Both joints, head side first.
    pub const ALL: [JointId; 2] = [JointId::HeadTorso, JointId::TorsoPelvis];

    /// The segment on the head side of the joint.
    pub const fn head_side(self) -> Segment {
        match self {
            JointId::HeadTorso => Segment::Head,
            JointId::TorsoPelvis => Segment::Torso,
        }
    }

    /// The segment on the feet side of the joint.
    pub const fn feet_side(self) -> Segment {
        match self {
            JointId::HeadTorso => Segment::Torso,
            JointId::TorsoPelvis => Segment::Pelvis,
        }
    }

    /// The name used in parameter files.
    pub const fn name(self) -> &'static str {
        match self {
            JointId::HeadTorso => "head_torso",
            JointId::TorsoPelvis => "torso_pelvis",
        }
    }

    const fn of(self, joints: &Joints) -> &JointParams {
        match self {
            JointId::HeadTorso => &joints.head_torso,
            JointId::TorsoPelvis => &joints.torso_pelvis,
        }
    }

    fn of_mut(self, joints: &mut Joints) -> &mut JointParams {
        match self {
            JointId::HeadTorso => &mut joints.head_torso,
            JointId::TorsoPelvis => &mut joints.torso_pelvis,
        }
    }
}

/// Whether a joint element resists relative translation or relative rotation.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum JointMotion {
    /// Relative displacement of the joint points.
    Translational,
    /// Relative rotation of the segments.
    Rotational,
}

/// A spring-damper element of the model: 21 in all (12 in joints, 9 in contacts).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Element {
    /// One direction of one joint.
    Joint {
        /// Which joint.
        joint: JointId,
        /// Translation or rotation.
        motion: JointMotion,
    },
    /// One direction of one segment's contact with the support.
    Contact {
        /// Which segment.
        segment: Segment,
    },
}

/// Spring or damper of an element.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Quantity {
    /// Force (moment) per displacement (rotation).
    Stiffness,
    /// Force (moment) per velocity (angular velocity).
    Damping,
}

/// One of the 42 identifiable numbers: an element, spring or damper, and an axis.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct ParamId {
    /// The spring-damper element.
    pub element: Element,
    /// Its stiffness or its damping.
    pub quantity: Quantity,
    /// The axis it acts along (or about).
    pub axis: Axis,
}

impl ParamId {
    /// Number of identifiable parameters: 24 joint and 18 contact.
    pub const COUNT: usize = 42;

    /// Every parameter: joints first (J1 translational, J1 rotational, J2 ...), then
    /// contacts (head, torso, pelvis); within each, stiffness x, y, z then damping x, y, z.
    pub const ALL: [ParamId; Self::COUNT] = {
        let mut all = [ParamId {
            element: Element::Contact {
                segment: Segment::Head,
            },
            quantity: Quantity::Stiffness,
            axis: Axis::X,
        }; Self::COUNT];
        let mut n = 0;
        let mut e = 0;
        while e < 7 {
            let element = match e {
                0 => Element::Joint {
                    joint: JointId::HeadTorso,
                    motion: JointMotion::Translational,
                },
                1 => Element::Joint {
                    joint: JointId::HeadTorso,
                    motion: JointMotion::Rotational,
                },
                2 => Element::Joint {
                    joint: JointId::TorsoPelvis,
                    motion: JointMotion::Translational,
                },
                3 => Element::Joint {
                    joint: JointId::TorsoPelvis,
                    motion: JointMotion::Rotational,
                },
                4 => Element::Contact {
                    segment: Segment::Head,
                },
                5 => Element::Contact {
                    segment: Segment::Torso,
                },
                _ => Element::Contact {
                    segment: Segment::Pelvis,
                },
            };
            let mut q = 0;
            while q < 2 {
                let quantity = if q == 0 {
                    Quantity::Stiffness
                } else {
                    Quantity::Damping
                };
                let mut a = 0;
                while a < 3 {
                    all[n] = ParamId {
                        element,
                        quantity,
                        axis: Axis::ALL[a],
                    };
                    n += 1;
                    a += 1;
                }
                q += 1;
            }
            e += 1;
        }
        all
    };

    /// Position in [`ParamId::ALL`].
    pub fn index(self) -> usize {
        // ALL is small and fixed; a linear search keeps one source of truth for the order.
        Self::ALL.iter().position(|p| *p == self).unwrap_or(0)
    }

    /// Whether this parameter belongs to a contact (the litter-board fit's unknowns).
    pub const fn is_contact(self) -> bool {
        matches!(self.element, Element::Contact { .. })
    }

    /// Whether this parameter is a stiffness.
    pub const fn is_stiffness(self) -> bool {
        matches!(self.quantity, Quantity::Stiffness)
    }

    /// The unit of the value.
    pub const fn unit(self) -> &'static str {
        match (self.element, self.quantity) {
            (
                Element::Joint {
                    motion: JointMotion::Rotational,
                    ..
                },
                Quantity::Stiffness,
            ) => "N m/rad",
            (
                Element::Joint {
                    motion: JointMotion::Rotational,
                    ..
                },
                Quantity::Damping,
            ) => "N m s/rad",
            (_, Quantity::Stiffness) => "N/m",
            (_, Quantity::Damping) => "N s/m",
        }
    }
}

impl fmt::Display for ParamId {
    /// The parameter file's key path, e.g. `joints.head_torso.rotational.stiffness_nm_per_rad.y`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let key = match (self.element, self.quantity) {
            (
                Element::Joint {
                    motion: JointMotion::Rotational,
                    ..
                },
                Quantity::Stiffness,
            ) => "stiffness_nm_per_rad",
            (
                Element::Joint {
                    motion: JointMotion::Rotational,
                    ..
                },
                Quantity::Damping,
            ) => "damping_nm_s_per_rad",
            (_, Quantity::Stiffness) => "stiffness_n_per_m",
            (_, Quantity::Damping) => "damping_n_s_per_m",
        };
        match self.element {
            Element::Joint { joint, motion } => {
                let motion = match motion {
                    JointMotion::Translational => "translational",
                    JointMotion::Rotational => "rotational",
                };
                write!(
                    f,
                    "joints.{}.{motion}.{key}.{}",
                    joint.name(),
                    self.axis.name()
                )
            }
            Element::Contact { segment } => {
                write!(f, "contacts.{}.{key}.{}", segment.name(), self.axis.name())
            }
        }
    }
}

/// Which field of the parameters a validation error is about.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ParamField {
    /// `subject.height_m`.
    HeightM,
    /// `subject.mass_kg`.
    MassKg,
    /// One of the 42 spring-damper numbers.
    Param(ParamId),
    /// One component of a sensor offset.
    SensorOffsetM {
        /// Whose sensor.
        segment: Segment,
        /// Which component.
        axis: Axis,
    },
}

impl fmt::Display for ParamField {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ParamField::HeightM => f.write_str("subject.height_m"),
            ParamField::MassKg => f.write_str("subject.mass_kg"),
            ParamField::Param(id) => id.fmt(f),
            ParamField::SensorOffsetM { segment, axis } => {
                write!(f, "sensors.{}_m.{}", segment.name(), axis.name())
            }
        }
    }
}

/// What is wrong with a field.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Problem {
    /// NaN or infinite.
    NotFinite,
    /// Zero or negative where only a positive value is physical.
    NotPositive,
    /// Outside the documented plausible range.
    OutOfRange,
}

/// A parameter set failed validation: which field, and why.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ParamError {
    /// The offending field.
    pub field: ParamField,
    /// What is wrong with it.
    pub problem: Problem,
}

impl ParamField {
    /// The plausible values of this field, `(min, max)` inclusive, in its unit.
    pub fn plausible_range(&self) -> (f64, f64) {
        match self {
            ParamField::HeightM => HEIGHT_RANGE_M,
            ParamField::MassKg => MASS_RANGE_KG,
            ParamField::Param(_) => COEFFICIENT_RANGE,
            ParamField::SensorOffsetM { .. } => (-MAX_SENSOR_OFFSET_M, MAX_SENSOR_OFFSET_M),
        }
    }
}

impl fmt::Display for ParamError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.problem {
            Problem::NotFinite => write!(f, "{}: must be a finite number", self.field),
            Problem::NotPositive => write!(f, "{}: must be greater than zero", self.field),
            Problem::OutOfRange => {
                let (lo, hi) = self.field.plausible_range();
                write!(f, "{}: must be within {lo} to {hi}", self.field)
            }
        }
    }
}

impl core::error::Error for ParamError {}
