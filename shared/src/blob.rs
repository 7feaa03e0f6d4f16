//! The parameter blob: everything the device needs to run, as it sits in flash or travels
//! in an upload, and its validation.
//!
//! Layout (little-endian): magic `SUPB` (4 bytes), format version (u16), reserved (u16,
//! zero), payload length (u32), CRC-32/ISO-HDLC of the payload (u32), then the payload:
//! [`DeviceParams`] in postcard. A blob is validated once, when it loads or arrives;
//! after that the hot path cannot fail.
//!
//! Versioning: any change to the header or to the payload's encoding bumps
//! [`BLOB_FORMAT_VERSION`]; the device refuses versions it does not know and falls back
//! to its built-in parameters, so an old device never misreads a new blob.

use core::fmt;

use crc::{CRC_32_ISO_HDLC, Crc, NoTable};
use serde::{Deserialize, Serialize};

use crate::alerts::{
    AlertConfig, AlertSettings, JointAlertConfig, JointAlertSettings, SensorCheckConfig,
    SensorCheckSettings,
};
use crate::calibration::{CalibrationError, SensorCalibration, SensorFrame};
use crate::exposure::{ExposureConfig, ExposureError, ExposureSettings};
use crate::model::params::{HEIGHT_RANGE_M, MASS_RANGE_KG};
use crate::model::{DeviceRealization, JointReadout, RealizationError, Subject};
use crate::mounting::Mounting;
use crate::sample_rate::SampleRate;
use crate::weighting::WeightingError;

/// First four bytes of every blob.
pub const BLOB_MAGIC: [u8; 4] = *b"SUPB";
/// Version of the header and payload encoding (6: the sensor's calibration record).
pub const BLOB_FORMAT_VERSION: u16 = 6;
/// Header length, bytes.
pub const BLOB_HEADER_LEN: usize = 16;
/// Largest blob the device accepts (header and payload), bytes. The device receives an
/// upload whole into a buffer this long, in RAM, before it touches flash: every blob the
/// product builds is about 1.7 KB (all ten joint outputs), and the RAM budget has no room
/// for the 4 KiB this was (BENCHMARKS.md).
pub const MAX_BLOB_LEN: usize = 2048;

/// Bytes of the parameter identity (the start of the SHA-256 of the parameter file).
pub const IDENTITY_LEN: usize = 16;

/// Largest predicted or weighted acceleration, m/s^2, that input within the sensor's full
/// scale may drive a blob's realization and weighting to (ten million g): four times the
/// bound of any blob the product builds (400 g full scale, any rate and weighting, every
/// subject parameter within e^(+-0.9) of the litter-board preset's: at most 0.26 of it,
/// `shared/tests/blob_gain_bound.rs`), and low enough that a block's sum of the vector's
/// fourth powers (256 samples of at most 9e32) stays 700 times inside f32 (the exposure
/// caps its f64 dose total where it narrows it to f32). A million g, the bound before,
/// refused some of those subjects: the bound multiplies the model's and the weighting's
/// l1 gains, each summed mode by mode, so it runs well above what a real input reaches.
pub const MAX_SIGNAL_M_S2: f32 = 1.0e8;

/// Largest norm a realization's or filter's internal state may reach under input within
/// the full scale: f32 overflows at 3.4e38, and a few such terms are added per step.
pub const MAX_STATE: f32 = 1.0e30;

/// Identity of a parameter set: the first 16 bytes of the SHA-256 of its parameter file.
pub type ParamsIdentity = [u8; IDENTITY_LEN];

/// The CRC-32/ISO-HDLC engine used for blobs and commit records.
pub(crate) const CRC32: Crc<u32, NoTable> = Crc::<u32, NoTable>::new(&CRC_32_ISO_HDLC);

/// CRC-32/ISO-HDLC (the zlib/Ethernet CRC) of `bytes`.
pub fn crc32(bytes: &[u8]) -> u32 {
    CRC32.checksum(bytes)
}

/// How often the device reports, in samples.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct TelemetryConfig {
    /// Send telemetry every this many samples (1 = every sample).
    pub decimation: u16,
}

impl TelemetryConfig {
    /// Every sample: what replay and the tests want, to compare each sample with the host.
    pub const EVERY_SAMPLE: Self = Self { decimation: 1 };

    /// The telemetry rate of a device in service, Hz. Exposure values move with a 1 s time
    /// constant, so 100 Hz is plenty for a display or a log; it fits a 115,200-baud UART
    /// (a frame per sample at 500 Hz would not), and it keeps the pipeline within its
    /// instruction budget (BENCHMARKS.md).
    pub const DEFAULT_RATE_HZ: f32 = 100.0;

    /// Telemetry at the nearest whole fraction of `sample_rate_hz` to `rate_hz`, at most
    /// every sample.
    pub fn at_rate(sample_rate_hz: f32, rate_hz: f32) -> Self {
        // `as` saturates and maps NaN to 0; `max(1)` keeps at least every sample.
        let decimation = (sample_rate_hz / rate_hz + 0.5) as u16;
        Self {
            decimation: decimation.max(1),
        }
    }

    /// [`DEFAULT_RATE_HZ`](Self::DEFAULT_RATE_HZ) at `sample_rate_hz`: every 5th sample at
    /// 500 Hz, every sample at 100 Hz, every 20th at 2 kHz.
    pub fn default_for(sample_rate_hz: f32) -> Self {
        Self::at_rate(sample_rate_hz, Self::DEFAULT_RATE_HZ)
    }
}

/// The patient the realization was scaled to: carried so that the device can say whom it
/// predicts for (greeting, status), since the realization's numbers cannot.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Patient {
    /// Standing height, m.
    pub height_m: f32,
    /// Body mass, kg.
    pub mass_kg: f32,
}

impl Patient {
    /// The model's subject, rounded to f32.
    pub fn of(subject: &Subject) -> Self {
        Self {
            height_m: subject.height_m as f32,
            mass_kg: subject.mass_kg as f32,
        }
    }

    /// Within the model's range ([`HEIGHT_RANGE_M`], [`MASS_RANGE_KG`]), the range the
    /// host's parameter checks use too: `NonFinite` for NaN or infinity, else `BadConfig`.
    pub fn validate(&self) -> Result<(), BlobError> {
        let within = |v: f32, (lo, hi): (f64, f64)| (lo..=hi).contains(&f64::from(v));
        if !(self.height_m.is_finite() && self.mass_kg.is_finite()) {
            Err(BlobError::NonFinite)
        } else if within(self.height_m, HEIGHT_RANGE_M) && within(self.mass_kg, MASS_RANGE_KG) {
            Ok(())
        } else {
            Err(BlobError::BadConfig)
        }
    }
}

/// Everything the device runs, for one sample rate.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct DeviceParams {
    /// Identity of the parameter file these came from (start of its SHA-256).
    pub identity: ParamsIdentity,
    /// The patient `realization` was scaled to.
    pub patient: Patient,
    /// The sample rate every stage below was built for: stored here once, and given to
    /// the stages that need it rather than kept by each.
    pub sample_rate: SampleRate,
    /// The model's discretized head-output realization.
    pub realization: DeviceRealization,
    /// The joint outputs read from `realization`'s states (none, some or all ten), on the
    /// samples telemetry reports.
    pub joints: JointReadout,
    /// Weighting and exposure evaluation, with the axis mapping.
    pub exposure: ExposureSettings,
    /// Exposure alert thresholds, hysteresis and dwell.
    pub alerts: AlertSettings,
    /// Joint-motion alert thresholds (none by default), hysteresis and dwell, for the
    /// outputs `joints` reads.
    pub joint_alerts: JointAlertSettings,
    /// Sensor fault checks.
    pub sensor_checks: SensorCheckSettings,
    /// Sensor-to-litter rotation and gravity.
    pub mounting: Mounting,
    /// The sensor's sensitivity and offset (applied before `mounting`), and when, how and
    /// by whom they were found.
    pub calibration: SensorCalibration,
    /// Reporting rate (the payload's last field: its varint ends the blob in a byte that
    /// is neither 0 nor 0xFF, which tells a cut write from a bad CRC, [`blob_payload`]).
    pub telemetry: TelemetryConfig,
}

impl DeviceParams {
    /// Builds the settings of every stage at `sample_rate`, the rate `realization` was
    /// discretized at.
    // One argument per stage: a builder would only rename them.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        identity: ParamsIdentity,
        patient: Patient,
        sample_rate: SampleRate,
        realization: DeviceRealization,
        exposure: ExposureConfig,
        alerts: AlertConfig,
        sensor_checks: SensorCheckConfig,
        mounting: Mounting,
        telemetry: TelemetryConfig,
        joints: JointReadout,
    ) -> Result<Self, BlobError> {
        let params = Self {
            identity,
            patient,
            sample_rate,
            realization,
            joints,
            exposure: ExposureSettings::new(exposure, sample_rate)
                .map_err(BlobError::from_exposure)?,
            alerts: AlertSettings::new(alerts, sample_rate).map_err(|_| BlobError::BadConfig)?,
            joint_alerts: JointAlertSettings::new(
                JointAlertConfig::NONE,
                sample_rate,
                telemetry.decimation,
                joints.output_count(),
            )
            .map_err(|_| BlobError::BadConfig)?,
            sensor_checks: SensorCheckSettings::new(sensor_checks, sample_rate)
                .map_err(|_| BlobError::BadConfig)?,
            mounting,
            calibration: SensorCalibration::DATASHEET,
            telemetry,
        };
        params.validate()?;
        Ok(params)
    }

    /// A realization (of `patient`, discretized at `sample_rate`) with the documented
    /// default configuration: weighting and axes ([`ExposureConfig::DEFAULT`]), alert thresholds,
    /// sensor checks, a level mounting, and telemetry at
    /// [`TelemetryConfig::DEFAULT_RATE_HZ`], reading the joint outputs of `joints`.
    pub fn with_defaults(
        identity: ParamsIdentity,
        patient: Patient,
        sample_rate: SampleRate,
        realization: DeviceRealization,
        joints: JointReadout,
    ) -> Result<Self, BlobError> {
        Self::new(
            identity,
            patient,
            sample_rate,
            realization,
            ExposureConfig::DEFAULT,
            AlertConfig::DEFAULT,
            SensorCheckConfig::DEFAULT,
            Mounting::LEVEL,
            TelemetryConfig::default_for(sample_rate.hz()),
            joints,
        )
    }

    /// These parameters with the joint-motion alerts of `config` (thresholds in the order
    /// of the outputs `joints` reads), validated as the device will.
    pub fn with_joint_alerts(self, config: JointAlertConfig) -> Result<Self, BlobError> {
        let params = Self {
            joint_alerts: JointAlertSettings::new(
                config,
                self.sample_rate,
                self.telemetry.decimation,
                self.joints.output_count(),
            )
            .map_err(|_| BlobError::BadConfig)?,
            ..self
        };
        params.validate()?;
        Ok(params)
    }

    /// These parameters with the sensor calibration `calibration`, validated as the device
    /// will.
    pub fn with_calibration(self, calibration: SensorCalibration) -> Result<Self, BlobError> {
        let params = Self {
            calibration,
            ..self
        };
        params.validate()?;
        Ok(params)
    }

    /// What turns a sensor reading into the model's input: the calibration, then the
    /// mounting.
    pub fn sensor_frame(&self) -> SensorFrame {
        SensorFrame {
            calibration: self.calibration,
            mounting: self.mounting,
        }
    }

    /// These parameters reporting at `telemetry`'s rate: the joint outputs are read on the
    /// samples telemetry reports, so the joint alerts' dwells (in readings) are rebuilt
    /// for it; setting the field alone leaves a blob the device refuses.
    pub fn with_telemetry(self, telemetry: TelemetryConfig) -> Result<Self, BlobError> {
        Self { telemetry, ..self }.with_joint_alerts(self.joint_alerts.config)
    }

    /// The sample rate every stage was built for, Hz.
    pub fn sample_rate_hz(&self) -> f32 {
        self.sample_rate.hz()
    }

    /// Checks what must hold before the device runs these parameters.
    #[inline(never)]
    pub fn validate(&self) -> Result<(), BlobError> {
        self.patient.validate()?;
        let fs = self
            .sample_rate
            .check()
            .map_err(|_| BlobError::SampleRate)?;
        self.realization.check().map_err(|e| match e {
            RealizationError::NotFinite => BlobError::NonFinite,
            RealizationError::Unstable => BlobError::Unstable,
            RealizationError::TooManyBlocks | RealizationError::Layout => BlobError::Malformed,
        })?;
        self.joints.check().map_err(|e| match e {
            RealizationError::NotFinite => BlobError::NonFinite,
            _ => BlobError::Malformed,
        })?;
        if !self.config_numbers().all(f32::is_finite) {
            return Err(BlobError::NonFinite);
        }
        self.exposure
            .validate(fs)
            .map_err(BlobError::from_exposure)?;
        self.alerts.validate(fs).map_err(|_| BlobError::BadConfig)?;
        self.joint_alerts
            .validate(fs, self.telemetry.decimation, self.joints.output_count())
            .map_err(|_| BlobError::BadConfig)?;
        self.sensor_checks
            .validate(fs)
            .map_err(|_| BlobError::BadConfig)?;
        self.mounting.validate().map_err(|e| match e {
            crate::mounting::MountingError::NotFinite => BlobError::NonFinite,
            _ => BlobError::BadConfig,
        })?;
        self.calibration.validate().map_err(|e| match e {
            CalibrationError::NotFinite => BlobError::NonFinite,
            _ => BlobError::BadConfig,
        })?;
        if self.telemetry.decimation == 0 {
            return Err(BlobError::BadConfig);
        }
        self.check_bounded()
    }

    /// That no input within the sensor's full scale can drive the realization, a joint
    /// output (m or rad: the same bound keeps its square finite) or a weighting past
    /// [`MAX_SIGNAL_M_S2`] or a state past [`MAX_STATE`]: stable poles are
    /// not enough, a coefficient of 1e30 or a pole 1e-12 inside the unit circle passes the
    /// checks above and still overflows f32 (docs/protocol.md, "Validation", step 7).
    /// Such a blob is refused as `Unstable`: not bounded-input bounded-output in f32.
    fn check_bounded(&self) -> Result<(), BlobError> {
        let full_scale = self.sensor_checks.config.full_scale_m_s2;
        let model = self
            .realization
            .amplification()
            .ok_or(BlobError::Unstable)?;
        let within = |state: f32, output: f32| state <= MAX_STATE && output <= MAX_SIGNAL_M_S2;
        let head_m_s2 = model.outputs.map(|gain| gain * full_scale);
        let state = model.state * full_scale;
        let joints = self.joints.amplification(state, full_scale);
        let mut bounded = within(state, head_m_s2.iter().fold(joints, |m, &v| v.max(m)));
        for (weighting, head) in self.exposure.weighting.iter().zip(head_m_s2) {
            let filter = weighting.amplification().ok_or(BlobError::Unstable)?;
            bounded &= within(filter.state * head, filter.output * head);
        }
        if bounded {
            Ok(())
        } else {
            Err(BlobError::Unstable)
        }
    }

    /// Every number of the exposure, alert and sensor-check configurations and the tables
    /// derived from them: a NaN anywhere is `NonFinite`, whichever stage would trip on it.
    fn config_numbers(&self) -> impl Iterator<Item = f32> + '_ {
        let (e, a, c) = (
            &self.exposure.config,
            &self.alerts.config,
            &self.sensor_checks.config,
        );
        let axes = e.axes.axes().into_iter().map(|axis| axis.k);
        let exposure = [e.running_tau_s, e.warmup_s];
        let alerts = [a.hysteresis, a.raise_dwell_s, a.clear_dwell_s];
        let checks = [c.full_scale_m_s2, c.stuck_after_s, c.clear_after_s];
        axes.chain(exposure)
            .chain(a.running_rms_m_s2)
            .chain(a.vdv_m_s175)
            .chain(alerts)
            .chain(checks)
            .chain(self.alerts.raise_ms_m2_s4)
            .chain(self.alerts.clear_ms_m2_s4)
            .chain(self.alerts.vdv4_m4_s7)
            .chain(self.joint_alerts.scalars())
    }

    /// Writes header and payload into `buf`; returns the blob's length.
    pub fn encode(&self, buf: &mut [u8]) -> Result<usize, BlobError> {
        if buf.len() < BLOB_HEADER_LEN {
            return Err(BlobError::TooLong);
        }
        let (header, rest) = buf.split_at_mut(BLOB_HEADER_LEN);
        let payload_len = postcard::to_slice(self, rest)
            .map_err(|_| BlobError::TooLong)?
            .len();
        let total = BLOB_HEADER_LEN + payload_len;
        if total > MAX_BLOB_LEN {
            return Err(BlobError::TooLong);
        }
        let crc = crc32(&rest[..payload_len]);
        header[0..4].copy_from_slice(&BLOB_MAGIC);
        header[4..6].copy_from_slice(&BLOB_FORMAT_VERSION.to_le_bytes());
        header[6..8].copy_from_slice(&0u16.to_le_bytes());
        header[8..12].copy_from_slice(&(payload_len as u32).to_le_bytes());
        header[12..16].copy_from_slice(&crc.to_le_bytes());
        Ok(total)
    }

    /// Reads and validates a blob; `bytes` may extend past its end (a flash slot).
    pub fn decode(bytes: &[u8]) -> Result<Self, BlobError> {
        let mut decoded = Err(BlobError::Empty);
        Self::decode_to(bytes, &mut decoded);
        decoded
    }

    /// [`decode`](Self::decode), with the outcome written into `out`: the parameters are
    /// decoded straight into the caller's variable and checked there, so the device's
    /// stack holds no second copy of them (an upload's, BENCHMARKS.md).
    #[inline(never)]
    pub fn decode_to(bytes: &[u8], out: &mut Result<Self, BlobError>) {
        match blob_payload(bytes) {
            Ok(payload) => Self::from_payload(payload, out),
            Err(e) => *out = Err(e),
        }
        if let Ok(params) = out
            && let Err(e) = params.validate()
        {
            *out = Err(e);
        }
    }

    /// The payload decoded, not yet validated. Out of line, as is
    /// [`validate`](Self::validate): serde's temporaries and the checks' then take turns
    /// on the device's stack instead of adding up in one frame.
    #[inline(never)]
    fn from_payload(payload: &[u8], out: &mut Result<Self, BlobError>) {
        let mut deserializer = postcard::Deserializer::from_bytes(payload);
        match Self::deserialize(&mut deserializer) {
            Ok(params) => *out = Ok(params),
            Err(_) => *out = Err(BlobError::Malformed),
        }
        if !matches!(deserializer.finalize(), Ok([])) {
            *out = Err(BlobError::Malformed);
        }
    }
}

/// Checks the header and CRC; returns the payload.
pub fn blob_payload(bytes: &[u8]) -> Result<&[u8], BlobError> {
    let Some(header) = bytes.get(..BLOB_HEADER_LEN) else {
        return Err(BlobError::Truncated);
    };
    if header.iter().all(|b| *b == 0xFF) || header.iter().all(|b| *b == 0) {
        return Err(BlobError::Empty);
    }
    if header[0..4] != BLOB_MAGIC {
        return Err(BlobError::BadMagic);
    }
    let word16 = |i: usize| u16::from_le_bytes([header[i], header[i + 1]]);
    let word32 =
        |i: usize| u32::from_le_bytes([header[i], header[i + 1], header[i + 2], header[i + 3]]);
    if word16(4) != BLOB_FORMAT_VERSION || word16(6) != 0 {
        return Err(BlobError::UnsupportedVersion);
    }
    let payload_len = word32(8) as usize;
    if payload_len == 0 || payload_len > MAX_BLOB_LEN - BLOB_HEADER_LEN {
        return Err(BlobError::BadLength);
    }
    let Some(payload) = bytes.get(BLOB_HEADER_LEN..BLOB_HEADER_LEN + payload_len) else {
        return Err(BlobError::Truncated);
    };
    if crc32(payload) != word32(12) {
        // A write that stopped early leaves the payload's end blank (0xFF in erased flash,
        // 0 in QEMU's zeroed memory). A complete payload ends in neither: its last field is
        // the telemetry decimation (at least 1) as a varint, whose last byte is 0x01-0x7F.
        let tail = &payload[payload.len().saturating_sub(BLANK_TAIL_LEN)..];
        if tail.len() == BLANK_TAIL_LEN
            && (tail.iter().all(|b| *b == 0xFF) || tail.iter().all(|b| *b == 0))
        {
            return Err(BlobError::Truncated);
        }
        return Err(BlobError::BadCrc);
    }
    Ok(payload)
}

/// Blank bytes at the payload's end that mark an unfinished write (one would do; four
/// keep a flipped bit of a final 0x7F or 0x01 from reading as a truncation).
const BLANK_TAIL_LEN: usize = 4;

/// Total length (header and payload) the header announces, if the header is sane.
pub fn announced_len(bytes: &[u8]) -> Option<usize> {
    let header = bytes.get(..BLOB_HEADER_LEN)?;
    let len = u32::from_le_bytes([header[8], header[9], header[10], header[11]]) as usize;
    (len <= MAX_BLOB_LEN - BLOB_HEADER_LEN).then_some(BLOB_HEADER_LEN + len)
}

/// Why a blob was refused; each has its own code.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum BlobError {
    /// The slot is erased (all 0xFF) or blank.
    Empty,
    /// The first four bytes are not `SUPB`.
    BadMagic,
    /// A format version this firmware does not know.
    UnsupportedVersion,
    /// The announced payload length is zero or larger than a blob can be.
    BadLength,
    /// Fewer bytes than the header announces, or the payload's end still erased (a write
    /// that stopped early).
    Truncated,
    /// The payload's CRC-32 does not match.
    BadCrc,
    /// The payload does not decode exactly (postcard error or trailing bytes).
    Malformed,
    /// A number in the payload is NaN or infinite.
    NonFinite,
    /// The model realization or a weighting filter has a pole on or outside |z| = 1, or a
    /// gain that lets input within the full scale overflow f32
    /// ([`MAX_SIGNAL_M_S2`], [`MAX_STATE`]).
    Unstable,
    /// The sample rate is outside the supported range ([`SampleRate`]).
    SampleRate,
    /// A configuration value is out of its range (patient, thresholds, times, mounting,
    /// calibration, decimation).
    BadConfig,
    /// The blob does not fit the buffer or the device's limit.
    TooLong,
}

impl BlobError {
    /// A stable numeric code, distinct per error.
    pub const fn code(self) -> u8 {
        match self {
            BlobError::Empty => 1,
            BlobError::BadMagic => 2,
            BlobError::UnsupportedVersion => 3,
            BlobError::BadLength => 4,
            BlobError::Truncated => 5,
            BlobError::BadCrc => 6,
            BlobError::Malformed => 7,
            BlobError::NonFinite => 8,
            BlobError::Unstable => 9,
            BlobError::SampleRate => 10,
            BlobError::BadConfig => 11,
            BlobError::TooLong => 12,
        }
    }

    fn from_exposure(e: ExposureError) -> Self {
        match e {
            ExposureError::Weighting(WeightingError::NonFiniteCoefficient) => BlobError::NonFinite,
            ExposureError::Weighting(WeightingError::Unstable) => BlobError::Unstable,
            _ => BlobError::BadConfig,
        }
    }
}

/// [`BlobError`]'s variant names, in declaration order (index = code - 1).
const BLOB_ERROR_NAMES: [&str; 12] = [
    "Empty",
    "BadMagic",
    "UnsupportedVersion",
    "BadLength",
    "Truncated",
    "BadCrc",
    "Malformed",
    "NonFinite",
    "Unstable",
    "SampleRate",
    "BadConfig",
    "TooLong",
];

/// By hand, with exactly the derived encoding (the variant's index, its code less one, and
/// its name): one call instead of one per variant saves the device about 1 KiB of flash.
impl Serialize for BlobError {
    fn serialize<S: serde::Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        let index = self.code() - 1;
        let name = BLOB_ERROR_NAMES
            .get(usize::from(index))
            .copied()
            .unwrap_or("");
        serializer.serialize_unit_variant("BlobError", u32::from(index), name)
    }
}

impl fmt::Display for BlobError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let what = match self {
            BlobError::Empty => "no parameter blob (erased slot)",
            BlobError::BadMagic => "not a parameter blob (bad magic)",
            BlobError::UnsupportedVersion => "unsupported blob format version",
            BlobError::BadLength => "bad payload length",
            BlobError::Truncated => "blob truncated",
            BlobError::BadCrc => "CRC-32 mismatch",
            BlobError::Malformed => "payload does not decode",
            BlobError::NonFinite => "a number is not finite",
            BlobError::Unstable => {
                "unstable filter or model realization, or a gain that can overflow"
            }
            BlobError::SampleRate => "sample rate out of range",
            BlobError::BadConfig => "a configuration value is out of range",
            BlobError::TooLong => "blob too long",
        };
        write!(f, "{what} (blob error {})", self.code())
    }
}

impl core::error::Error for BlobError {}

#[cfg(test)]
mod serialize_tests {
    extern crate std;
    use super::*;

    /// The hand-written encoding against serde's derive on a twin enum, for every variant.
    #[test]
    fn blob_errors_encode_as_the_derive_would() {
        #[derive(Serialize)]
        enum Derived {
            Empty,
            BadMagic,
            UnsupportedVersion,
            BadLength,
            Truncated,
            BadCrc,
            Malformed,
            NonFinite,
            Unstable,
            SampleRate,
            BadConfig,
            TooLong,
        }
        let pairs = [
            (BlobError::Empty, Derived::Empty),
            (BlobError::BadMagic, Derived::BadMagic),
            (BlobError::UnsupportedVersion, Derived::UnsupportedVersion),
            (BlobError::BadLength, Derived::BadLength),
            (BlobError::Truncated, Derived::Truncated),
            (BlobError::BadCrc, Derived::BadCrc),
            (BlobError::Malformed, Derived::Malformed),
            (BlobError::NonFinite, Derived::NonFinite),
            (BlobError::Unstable, Derived::Unstable),
            (BlobError::SampleRate, Derived::SampleRate),
            (BlobError::BadConfig, Derived::BadConfig),
            (BlobError::TooLong, Derived::TooLong),
        ];
        for (ours, derived) in pairs {
            let (mut a, mut b) = ([0u8; 8], [0u8; 8]);
            let a = postcard::to_slice(&ours, &mut a).expect("fits");
            let b = postcard::to_slice(&derived, &mut b).expect("fits");
            assert_eq!(a, b, "{ours:?}");
            let back: BlobError = postcard::from_bytes(a).expect("decodes");
            assert_eq!(back, ours);
        }
    }
}
