//! Body geometry: segments, axes, and the anthropometry that turns a subject's height and
//! mass into segment masses, inertias and joint positions (paper Table 2, after Dempster).

use core::fmt;

use serde::{Deserialize, Serialize};

/// A Cartesian axis of the global frame: x longitudinal (toward the head), y lateral, z up.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[repr(u8)]
pub enum Axis {
    /// Longitudinal, positive toward the head.
    X = 0,
    /// Lateral.
    Y = 1,
    /// Vertical, positive up.
    Z = 2,
}

impl Axis {
    /// x, y, z.
    pub const ALL: [Axis; 3] = [Axis::X, Axis::Y, Axis::Z];

    /// `x`, `y` or `z`.
    pub const fn name(self) -> &'static str {
        match self {
            Axis::X => "x",
            Axis::Y => "y",
            Axis::Z => "z",
        }
    }

    /// 0, 1 or 2.
    pub const fn index(self) -> usize {
        self as usize
    }
}

impl fmt::Display for Axis {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// One of the model's three rigid segments.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum Segment {
    /// Head and neck (m = 1).
    Head,
    /// Torso and arms (m = 2).
    Torso,
    /// Pelvis and legs (m = 3).
    Pelvis,
}

impl Segment {
    /// Head first, as the DOFs and outputs are ordered.
    pub const ALL: [Segment; 3] = [Segment::Head, Segment::Torso, Segment::Pelvis];

    /// 0, 1 or 2.
    pub const fn index(self) -> usize {
        match self {
            Segment::Head => 0,
            Segment::Torso => 1,
            Segment::Pelvis => 2,
        }
    }

    /// `head`, `torso` or `pelvis`.
    pub const fn name(self) -> &'static str {
        match self {
            Segment::Head => "head",
            Segment::Torso => "torso",
            Segment::Pelvis => "pelvis",
        }
    }
}

/// The person on the litter: the two numbers anthropometry scales from.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Subject {
    /// Standing height, m.
    pub height_m: f64,
    /// Body mass, kg.
    pub mass_kg: f64,
}

impl Subject {
    /// The paper's mean subject: 1.82 m, 81 kg.
    pub const PAPER_MEAN: Subject = Subject {
        height_m: 1.82,
        mass_kg: 81.0,
    };
}

/// Per-segment anthropometric ratios (head-neck, torso-arms, pelvis-legs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SegmentRatios {
    /// Segment mass over body mass.
    pub mass: [f64; 3],
    /// Segment length over body height.
    pub length: [f64; 3],
    /// Distance from the centre to the head-side joint over segment length.
    pub to_head_joint: [f64; 3],
    /// Distance from the centre to the feet-side joint over segment length.
    pub to_feet_joint: [f64; 3],
    /// Radius of gyration over segment length (isotropic inertia by convention).
    pub gyration: [f64; 3],
}

impl SegmentRatios {
    /// Paper Table 2 (after Dempster). The head has no head-side joint and the pelvis-legs
    /// no feet-side one in the model; their ratios are kept for completeness where given.
    pub const DEMPSTER: SegmentRatios = SegmentRatios {
        mass: [0.081, 0.455, 0.464],
        length: [0.182, 0.288, 0.530],
        to_head_joint: [0.0, 0.630, 0.10],
        to_feet_joint: [0.118, 0.370, 0.895],
        gyration: [0.495, 0.496, 0.326],
    };
}

/// One segment's inertial properties and joint positions, SI units.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SegmentBody {
    /// Mass, kg.
    pub mass_kg: f64,
    /// Moment of inertia about each axis through the centre, kg m^2.
    pub inertia_kg_m2: f64,
    /// Distance from the centre to the head-side joint (La), m.
    pub to_head_joint_m: f64,
    /// Distance from the centre to the feet-side joint (Lb), m.
    pub to_feet_joint_m: f64,
}

/// The three segments of one subject.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Body {
    /// Head-neck, torso-arms, pelvis-legs.
    pub segments: [SegmentBody; 3],
}

impl Body {
    /// Scales the ratios by the subject: m = r_m W, L = r_L H, I = m (rho L)^2.
    pub fn new(subject: &Subject, ratios: &SegmentRatios) -> Self {
        let segments = core::array::from_fn(|i| {
            let mass_kg = ratios.mass[i] * subject.mass_kg;
            let length_m = ratios.length[i] * subject.height_m;
            let gyration_m = ratios.gyration[i] * length_m;
            SegmentBody {
                mass_kg,
                inertia_kg_m2: mass_kg * gyration_m * gyration_m,
                to_head_joint_m: ratios.to_head_joint[i] * length_m,
                to_feet_joint_m: ratios.to_feet_joint[i] * length_m,
            }
        });
        Self { segments }
    }

    /// The body of a subject with the paper's (Dempster) ratios.
    pub fn dempster(subject: &Subject) -> Self {
        Self::new(subject, &SegmentRatios::DEMPSTER)
    }
}
