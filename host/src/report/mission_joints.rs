//! The predicted joint motion of a mission: each joint output of the legs combined (the
//! numbers of the report's "Neck and lower back" section and of its `--json`).
//!
//! No standard sets limits for a supine patient's spinal motion, so these are values, not
//! judgements: no thresholds, no levels.

use serde::Serialize;
use supine_core::exposure::combined_rms_m_s2;

use crate::exposure::joints::JointReport;

/// What the combination needs of a leg: when it starts in the mission, how long it is, and
/// its joint outputs.
#[derive(Clone, Copy, Debug)]
pub struct LegJoints<'a> {
    /// The leg's start in the mission, s.
    pub start_s: f64,
    /// The leg's duration, s.
    pub duration_s: f64,
    /// The leg's joint outputs, in the model's order.
    pub joints: &'a [JointReport],
}

/// One joint output over the whole mission.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct MissionJoint {
    /// The output, e.g. `neck_z`.
    pub output: &'static str,
    /// `mm` or `deg`.
    pub unit: &'static str,
    /// Rms over the legs' whole time, combined energy-equivalently (each leg's mean square
    /// weighted by its duration).
    pub rms: f64,
    /// The largest 1 s running rms of any leg.
    pub max_running_rms: f64,
    /// The largest |value| of any leg.
    pub largest_excursion: f64,
    /// When, s from the mission's start.
    pub largest_excursion_at_mission_s: f64,
    /// In which leg (1-based).
    pub largest_excursion_leg: usize,
}

/// The legs' joint motion combined. Empty when there are no legs.
pub fn mission_joints(legs: &[LegJoints<'_>]) -> Vec<MissionJoint> {
    let Some(first) = legs.first() else {
        return Vec::new();
    };
    (0..first.joints.len())
        .map(|o| {
            let mut rms_and_duration = Vec::with_capacity(legs.len());
            let mut max_running_rms = 0.0_f64;
            let mut peak = (0.0_f64, 0.0, 1);
            for (i, leg) in legs.iter().enumerate() {
                let Some(j) = leg.joints.get(o) else { continue };
                rms_and_duration.push((j.rms, leg.duration_s));
                max_running_rms = max_running_rms.max(j.max_running_rms);
                if j.largest_excursion > peak.0 {
                    peak = (
                        j.largest_excursion,
                        leg.start_s + j.largest_excursion_at_s,
                        i + 1,
                    );
                }
            }
            MissionJoint {
                output: first.joints[o].output,
                unit: first.joints[o].unit,
                // The head's energy-equivalent combination; the formula holds for any unit.
                rms: combined_rms_m_s2(&rms_and_duration),
                max_running_rms,
                largest_excursion: peak.0,
                largest_excursion_at_mission_s: peak.1,
                largest_excursion_leg: peak.2,
            }
        })
        .collect()
}
