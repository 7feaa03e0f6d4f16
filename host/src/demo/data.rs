//! What the demo's report and summary are made from: how the run was made, what the
//! device sent and what the host computed on the same samples.

use std::time::Duration;

use supine_core::alerts::AlertConfig;
use supine_core::protocol::Status;

use super::ride::{DemoProfile, DemoRide};
use super::trace::Trace;
use crate::device::link::LinkStats;
use crate::exposure::report::AxisReport;
use crate::io::telemetry_csv::EventRow;

/// How the run was made (for the report's last section and the summary's first line).
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
    /// The parameters' name (the preset).
    pub params_name: String,
    /// Their identity, hex.
    pub identity: String,
    /// The firmware's version from its greeting.
    pub firmware_version: String,
    /// The device in one line (firmware, protocol, parameters and their source, rate).
    pub device_line: String,
    /// Exposure warm-up, s.
    pub warmup_s: f64,
    /// The alert configuration flashed.
    pub alerts: AlertConfig,
    /// The device's last status.
    pub status: Option<Status>,
    /// Frames the host decoded, lost and bad.
    pub link: LinkStats,
    /// Wall time of each step.
    pub step_times: Vec<(String, Duration)>,
    /// Samples streamed in real time.
    pub realtime: bool,
}

/// The host's exposure evaluation of the predicted head (supine-core on the same samples).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HostExposure {
    /// Head x, y, z.
    pub head: [AxisReport; 3],
    /// Vector sum.
    pub vector: AxisReport,
}

/// Everything the report and the summary are made from.
#[derive(Clone, Debug)]
pub struct DemoData {
    /// How the run was made.
    pub info: RunInfo,
    /// The ride.
    pub ride: DemoRide,
    /// What the device sent (read back from `device.csv`).
    pub device: Trace,
    /// The device's alert events (read back from `device.events.csv`).
    pub device_events: Vec<EventRow>,
    /// The host's run of the device pipeline (f32, the same code) on the same samples.
    pub host: Trace,
    /// The host pipeline's alert events.
    pub host_events: Vec<EventRow>,
    /// The f64 model's head acceleration for the same samples, m/s^2.
    pub host_head_f64_m_s2: [Vec<f64>; 3],
    /// The exposure of the host's run.
    pub exposure: HostExposure,
}
