//! What the demo's summary and report are made from: how the run was made, the mission
//! report of the ride it streamed, and the device's log of that ride beside the host's.

use super::demo_ride::DemoProfile;
use crate::report::MissionReport;
use crate::report::device_check::DeviceLog;

/// The demo's own facts of the run (the device's are in [`DeviceLog::run`]).
#[derive(Clone, Debug, PartialEq)]
pub struct RunInfo {
    /// The ride.
    pub profile: DemoProfile,
    /// Its seed.
    pub seed: u64,
    /// Sample rate, Hz.
    pub sample_rate_hz: f64,
    /// Samples streamed.
    pub samples: usize,
    /// The parameters' name (the preset or file, and the patient when one was given).
    pub params_name: String,
}

/// Everything the summary and the report are made from.
#[derive(Clone, Debug)]
pub struct DemoData {
    /// How the run was made.
    pub info: RunInfo,
    /// The mission report of the ride (one leg: `ride.csv`), as `supine report` makes it.
    pub report: MissionReport,
    /// What the device sent for the ride, and the host's run of the same samples.
    pub log: DeviceLog,
}
