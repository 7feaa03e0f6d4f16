//! What `supine demo --json` prints (the run's settings, the host's exposure of the
//! predicted head and the device's own account beside it) and `supine ride --json` (the
//! demo's ride written), each field documented once with its unit (the keys follow the
//! naming rules of [`crate::schema`]); the commands only fill these in.

use std::path::Path;

use serde::Serialize;

use crate::demo::demo_ride::{DemoProfile, DemoRide, Segment};
use crate::demo::summary::Summary;
use crate::exposure::reported_values::AxisReport;

/// `supine demo --json`.
#[derive(Clone, Debug, Serialize)]
pub struct DemoRecord<'a> {
    /// The report written (HTML).
    pub report: &'a Path,
    /// The ride's profile.
    pub profile: &'static str,
    /// The ride's length, s.
    pub duration_s: f64,
    /// The ride's seed.
    pub seed: u64,
    /// The host's exposure of the predicted head, as `supine exposure --json` gives it.
    pub exposure: DemoExposure<'a>,
    /// Largest valid vector running rms in the device's telemetry (its MTVV), m/s^2.
    pub device_mtvv_m_s2: f64,
    /// The device's VDV of the vector sum at its last record, m/s^1.75.
    pub device_vdv_m_s175: f64,
    /// Highest level in the device's telemetry.
    pub highest_level: &'static str,
    /// When it was first reached, s (null when never above normal).
    pub highest_at_s: Option<f64>,
    /// The level at the device's last record.
    pub final_level: &'static str,
    /// When the level last went back down to normal, s (null when it did not).
    pub cleared_at_s: Option<f64>,
    /// Level events (raises and clears) the device sent.
    pub level_events: usize,
    /// Sensor faults the device raised, in order.
    pub faults: Vec<FaultRecord<'a>>,
    /// Largest |device head - host head| with the host running the same f32 pipeline, m/s^2.
    pub head_diff_f32_m_s2: f64,
    /// Largest |device head - f64 model head|, m/s^2.
    pub head_diff_f64_m_s2: f64,
    /// Largest |device - host| vector running rms, m/s^2.
    pub running_rms_diff_m_s2: f64,
    /// Telemetry values in which some device record differs from the host's.
    pub differing_values: &'a [&'static str],
    /// The device's and the host's alert events are the same.
    pub events_agree: bool,
    /// The device sent a record for every sample the host computed one for.
    pub records_complete: bool,
}

/// The exposure of [`DemoRecord`], named as in `supine exposure --json`.
#[derive(Clone, Debug, Serialize)]
pub struct DemoExposure<'a> {
    /// Head x, y, z, each with its weighting.
    pub head: [&'a AxisReport; 3],
    /// The vector sum.
    pub vector: &'a AxisReport,
}

/// One sensor fault of [`DemoRecord`].
#[derive(Clone, Debug, Serialize)]
pub struct FaultRecord<'a> {
    /// The fault's name.
    pub fault: &'a str,
    /// When the device raised it, s.
    pub time_s: f64,
}

impl<'a> DemoRecord<'a> {
    /// The record of a run's `summary`, its `report`, and the ride it was asked for.
    pub fn new(
        summary: &'a Summary,
        report: &'a Path,
        profile: DemoProfile,
        duration_s: f64,
        seed: u64,
    ) -> Self {
        let s = &summary.check;
        Self {
            report,
            profile: profile.name(),
            duration_s,
            seed,
            exposure: DemoExposure {
                head: [
                    &summary.exposure[0].1,
                    &summary.exposure[1].1,
                    &summary.exposure[2].1,
                ],
                vector: &summary.exposure[3].1,
            },
            device_mtvv_m_s2: s.device_mtvv_m_s2,
            device_vdv_m_s175: s.device_vdv_m_s175,
            highest_level: s.highest_level.name(),
            highest_at_s: s.highest_at_s,
            final_level: s.final_level.name(),
            cleared_at_s: s.cleared_at_s,
            level_events: s.level_events,
            faults: s
                .faults
                .iter()
                .map(|(fault, t)| FaultRecord { fault, time_s: *t })
                .collect(),
            head_diff_f32_m_s2: s.head_diff_f32_m_s2,
            head_diff_f64_m_s2: s.head_diff_f64_m_s2,
            running_rms_diff_m_s2: s.rms_diff_m_s2,
            differing_values: &s.differing_values,
            events_agree: s.events_agree,
            records_complete: s.records_complete,
        }
    }
}

/// `supine ride --json`: the generated ride written.
#[derive(Clone, Debug, Serialize)]
pub struct RideSummary<'a> {
    /// The ride CSV.
    pub out: &'a Path,
    /// The ride's profile.
    pub profile: &'static str,
    /// Its length, s.
    pub duration_s: f64,
    /// Its sample rate, Hz.
    pub sample_rate_hz: f64,
    /// Its seed.
    pub seed: u64,
    /// Samples written.
    pub samples: usize,
    /// Unweighted rms of the platform acceleration, m/s^2.
    pub rms_m_s2: PlatformAxesRecord,
    /// Peak over rms of the vertical platform acceleration.
    pub vertical_crest_factor: f64,
    /// Shocks (potholes, kerbs) in the ride.
    pub shocks: usize,
    /// The road surfaces in order, with their times.
    pub segments: &'a [Segment],
    /// The GPX track written beside the ride (`--track-out`), if any.
    pub track_out: Option<&'a Path>,
}

/// One value per platform axis, in the unit of the key that holds it.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct PlatformAxesRecord {
    /// Platform x (toward the head).
    pub x: f64,
    /// Platform y.
    pub y: f64,
    /// Platform z (up).
    pub z: f64,
}

impl<'a> RideSummary<'a> {
    /// The record of `made` (the `profile` ride with `seed`) written to `out`, its track
    /// to `track_out`.
    pub fn new(
        made: &'a DemoRide,
        profile: DemoProfile,
        seed: u64,
        out: &'a Path,
        track_out: Option<&'a Path>,
    ) -> Self {
        let ride = &made.ride;
        let [x, y, z] = ride.rms_m_s2();
        Self {
            out,
            profile: profile.name(),
            duration_s: made.duration_s(),
            sample_rate_hz: ride.sample_rate_hz,
            seed,
            samples: ride.len(),
            rms_m_s2: PlatformAxesRecord { x, y, z },
            vertical_crest_factor: ride.vertical_crest_factor(),
            shocks: made.shocks.len(),
            segments: &made.segments,
            track_out,
        }
    }
}
