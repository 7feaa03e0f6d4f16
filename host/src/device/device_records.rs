//! What the device commands print with `--json` (`supine calibrate`, `flash`, `replay`):
//! one record type per command, each field documented once with its unit. The keys follow
//! the naming rules of [`crate::schema`] (checked by `host/tests/output_names.rs`); the
//! commands only fill these in.

use std::path::PathBuf;

use serde::Serialize;
use supine_core::calibration::SensorCalibration;
use supine_core::mounting::Mounting;

use crate::io::calibration_section::date_text;
use crate::schema::subject::SubjectRecord;

/// `supine calibrate --at-rest-m-s2 X,Y,Z --json`.
#[derive(Clone, Debug, Serialize)]
pub struct MountingSummary {
    /// The reading at rest, sensor axes x, y, z, m/s^2.
    pub at_rest_m_s2: [f64; 3],
    /// The `[device.mounting]` table it gives (`sensor_to_litter` rows: the litter's x, y,
    /// z in sensor axes; `gravity_m_s2`: gravity as the sensor measured it).
    pub mounting: Mounting,
}

/// `supine calibrate --tumble FILE.csv --json`.
#[derive(Clone, Debug, Serialize)]
pub struct TumbleCalibrationSummary {
    /// The tumble test's CSV.
    pub tumble: String,
    /// Readings per orientation (+x, -x, +y, -y, +z, -z up).
    pub rows: [usize; 6],
    /// Each axis's sensitivity (reading per true acceleration).
    pub sensitivity: [f32; 3],
    /// Each axis's offset, m/s^2.
    pub offset_m_s2: [f32; 3],
    /// The day of the test, YYYY-MM-DD.
    pub date: String,
    /// How the calibration was found (`tumble`).
    pub method: &'static str,
    /// Who did the test (null when not given).
    pub by: Option<String>,
    /// Months until the sensor is due again.
    pub interval_months: u8,
}

impl TumbleCalibrationSummary {
    /// The record of `calibration`, found from the `rows` readings of the file `tumble`.
    pub fn new(tumble: String, rows: [usize; 6], calibration: &SensorCalibration) -> Self {
        Self {
            tumble,
            rows,
            sensitivity: calibration.sensitivity,
            offset_m_s2: calibration.offset_m_s2,
            date: date_text(calibration.date),
            method: calibration.method.name(),
            by: calibration.by_name().map(str::to_string),
            interval_months: calibration.interval_months,
        }
    }
}

/// `supine replay --qemu --json`: the device's run of a ride.
#[derive(Clone, Debug, Serialize)]
pub struct ReplaySummary {
    /// Samples streamed to the device.
    pub samples: usize,
    /// Their sample rate, Hz.
    pub sample_rate_hz: f64,
    /// The ride's length, s.
    pub ride_duration_s: f64,
    /// Wall-clock time of the replay, s.
    pub elapsed_s: f64,
    /// `ride_duration_s / elapsed_s`.
    pub real_time_factor: f64,
    /// Telemetry records the device sent.
    pub telemetry_records: usize,
    /// The device sent one record per this many samples.
    pub telemetry_decimation: u16,
    /// Frames the link lost.
    pub lost_frames: u64,
    /// Frames that arrived damaged.
    pub bad_frames: u64,
    /// Alert events that raised an alert.
    pub alerts_raised: usize,
    /// The patient as the device itself reports it (its status).
    pub subject: SubjectRecord,
    /// The device's stack high-water mark, bytes.
    pub stack_used_bytes: u32,
    /// The telemetry CSV written.
    pub telemetry_csv: PathBuf,
    /// The alert events CSV written.
    pub events_csv: PathBuf,
    /// Instructions the device ran per sample (only with `--icount`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub instructions_per_sample: Option<f64>,
}

/// `supine flash --json`: where the parameters went, by target (its `target` key).
#[derive(Clone, Debug, Serialize)]
#[serde(tag = "target")]
pub enum FlashSummary {
    /// `--qemu-image`: a parameter region image written for QEMU's loader.
    #[serde(rename = "qemu-image")]
    QemuImage {
        /// The image file.
        path: PathBuf,
        /// Its size, bytes.
        size_bytes: usize,
        /// The parameters' identity (hex).
        params_identity: String,
        /// The sample rate the parameters are built for, Hz.
        sample_rate_hz: f64,
        /// The patient they are scaled to.
        subject: SubjectRecord,
        /// Where QEMU must load it (hex).
        load_address: String,
    },
    /// `--probe`: written to a board's flash through a debug probe.
    #[serde(rename = "probe")]
    Probe {
        /// The probe's chip name.
        chip: String,
        /// The flash address written (hex).
        base_address: String,
        /// The parameters' identity (hex).
        params_identity: String,
        /// The sample rate the parameters are built for, Hz.
        sample_rate_hz: f64,
        /// The patient they are scaled to.
        subject: SubjectRecord,
    },
    /// `--qemu`: uploaded to the device in QEMU.
    #[serde(rename = "qemu")]
    Qemu(UploadSummary),
    /// `--serial`: uploaded to a device on a serial port.
    #[serde(rename = "serial")]
    Serial(UploadSummary),
}

/// An upload the device committed and restarted on (`--qemu`, `--serial`).
#[derive(Clone, Debug, Serialize)]
pub struct UploadSummary {
    /// The device (`QEMU` or the port).
    pub device: String,
    /// The parameters' identity (hex).
    pub params_identity: String,
    /// The flash slot they were committed to.
    pub slot: u8,
    /// The upload's counter.
    pub counter: u32,
    /// The sample rate in the device's greeting after the restart, Hz.
    pub greeting_sample_rate_hz: f32,
    /// The patient in that greeting.
    pub greeting_subject: SubjectRecord,
    /// The device's firmware version.
    pub firmware_version: String,
    /// Whether the upload was signed with the public development key.
    pub development_key: bool,
}
