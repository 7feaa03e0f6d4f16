//! The files `supine monitor --log FILE.csv` writes beside the telemetry and events logs
//! so that the session can be re-analysed (`supine report --input FILE.csv`):
//!
//! - `<stem>.input.csv`: the input the device's model got (its input stream), as a
//!   `supine ride` file ([`PLATFORM_HEADER_LINE`]), one row per sample, time from the
//!   sample index. The values are whole input-resolution steps written exactly, so they
//!   read back to the f32 values the device computed on.
//! - `<stem>.session.json` ([`SessionInfo`]): what a re-analysis needs and the CSVs
//!   cannot hold: the device's parameters identity, sample rate, patient and sensor
//!   calibration from its greeting, the day it started, and how complete the input stream
//!   is.

use std::path::{Path, PathBuf};

use anyhow::{Result, anyhow};
use serde::{Deserialize, Serialize};
use supine_core::protocol::Status;

use super::calibration_section::CalibrationTable;
use super::output::write_atomically;
pub use super::recording::PLATFORM_HEADER_LINE;
use super::small_file::read_text;

/// Largest session file read, bytes (a few hundred are written).
const MAX_SESSION_BYTES: u64 = 64 * 1024;

/// `<stem>.input.csv` next to the telemetry log `log`.
pub fn input_path(log: &Path) -> PathBuf {
    sibling(log, "input.csv")
}

/// `<stem>.session.json` next to the telemetry log `log`.
pub fn session_path(log: &Path) -> PathBuf {
    sibling(log, "session.json")
}

fn sibling(log: &Path, suffix: &str) -> PathBuf {
    let stem = log
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    log.with_file_name(format!("{stem}.{suffix}"))
}

/// One row of the input file: the sample's time from its index, and the three axes.
/// Both are written exactly (a whole number of 2^-9 m/s^2 steps below 64 m/s^2 has at
/// most 11 significant digits, which f64's shortest form keeps).
pub fn input_row(sample_index: u32, counts: [i16; 3], sample_rate_hz: f64) -> String {
    let [x, y, z] = counts.map(|c| f64::from(supine_core::input_resolution::to_m_s2(c)));
    format!("{},{x},{y},{z}\n", f64::from(sample_index) / sample_rate_hz)
}

/// What `<stem>.session.json` holds. Its default is a session that has received
/// nothing yet (every counter zero), of a device still to be named.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct SessionInfo {
    /// The device's protocol version.
    pub protocol_version: u16,
    /// The device's firmware version.
    pub firmware_version: String,
    /// The identity of the parameters the device ran (hex), from its greeting.
    pub params_identity: String,
    /// The device's sample rate, Hz.
    pub sample_rate_hz: f64,
    /// The patient the parameters were scaled to: height, m.
    pub height_m: f64,
    /// The patient: mass, kg.
    pub mass_kg: f64,
    /// Whether the device greeted again with other parameters during the session (the
    /// input stream then stopped: the log covers two parameter sets).
    pub params_changed: bool,
    /// Input frames received.
    pub input_frames: u64,
    /// Samples in the input file.
    pub input_samples: u64,
    /// Samples missing from the input file: index gaps in the stream (lost frames, or
    /// samples the device never got), or input frames that did not decode.
    pub input_samples_lost: u64,
    /// Input frames whose samples did not decode (counted, not written).
    pub input_frames_bad: u64,
    /// Index of the first sample in the input file, if any.
    pub first_input_sample: Option<u32>,
    /// The device's last status (its counters), if it sent one.
    pub status: Option<Status>,
    /// The host's link counters at the end: frames decoded, lost (gaps in the device's
    /// sequence numbers), bad and reordered.
    pub link_frames: u64,
    /// See `link_frames`.
    pub link_lost_frames: u64,
    /// See `link_frames`.
    pub link_bad_frames: u64,
    /// See `link_frames`.
    pub link_reordered_frames: u64,
    /// The day the session started (UTC, `YYYY-MM-DD`): what a report counts the sensor
    /// calibration's age to. Absent in logs written before it was recorded.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub started_utc: Option<String>,
    /// The sensor's calibration record from the device's greeting, as the parameter file
    /// writes it. Absent in logs written before it was recorded.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub calibration: Option<CalibrationTable>,
}

impl SessionInfo {
    /// Writes the file whole (or not at all).
    pub fn write(&self, path: &Path) -> Result<()> {
        let text = serde_json::to_string_pretty(self)? + "\n";
        write_atomically(path, |w| {
            use std::io::Write as _;
            Ok(w.write_all(text.as_bytes())?)
        })
    }

    /// Reads the file; an error names the file and what is wrong.
    pub fn read(path: &Path) -> Result<Self> {
        let text = read_text(path, "session file", MAX_SESSION_BYTES)?;
        serde_json::from_str(&text).map_err(|e| {
            anyhow!(
                "{}: line {}, column {}: not a session file of supine monitor: {e}",
                path.display(),
                e.line(),
                e.column()
            )
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rows_read_back_to_the_exact_steps() {
        let row = input_row(1001, [1, -32767, 12345], 500.0);
        assert_eq!(row, "2.002,0.001953125,-63.998046875,24.111328125\n");
        let cells: Vec<f64> = row.trim().split(',').map(|c| c.parse().unwrap()).collect();
        assert_eq!(cells[1] as f32, 1.0 / 512.0);
        assert_eq!(cells[3] as f32 * 512.0, 12345.0);
    }

    #[test]
    fn paths_sit_beside_the_log() {
        let log = Path::new("/tmp/run/session1.csv");
        assert_eq!(input_path(log), Path::new("/tmp/run/session1.input.csv"));
        assert_eq!(
            session_path(log),
            Path::new("/tmp/run/session1.session.json")
        );
    }

    /// The device's status carries its calibration record, a byte string that JSON
    /// writes as a list of numbers: the session file must read it back.
    #[test]
    fn a_calibration_record_written_as_json_reads_back() {
        use supine_core::calibration::SensorCalibration;
        let mut record = SensorCalibration::DATASHEET;
        record.interval_months = 6;
        let text = serde_json::to_string(&record).unwrap();
        assert!(text.starts_with('['), "{text}");
        let back: SensorCalibration = serde_json::from_str(&text).unwrap();
        assert_eq!(back, record);
        let long = text.replacen('[', "[0,", 1);
        assert!(serde_json::from_str::<SensorCalibration>(&long).is_err());
    }
}
