//! The accelerometer's calibration record, and the correction it makes to every reading
//! before the mounting rotation.
//!
//! A reading of axis i is taken as `f_i = sensitivity_i * a_i + offset_m_s2_i`: the
//! sensitivity is the indicated per true acceleration (1 for a sensor exactly at its
//! datasheet's scale), the offset what the axis reads with no acceleration along it. The
//! device corrects each reading, `a_i = (f_i - offset_m_s2_i) / sensitivity_i`, then
//! rotates it into litter axes and takes gravity off ([`SensorFrame::to_litter_m_s2`]).
//! The host's reference of a recording makes the same f32 calls in the same order, so the
//! two agree bit for bit.
//!
//! The record also says when, how and by whom the sensor was calibrated, and how often it
//! must be redone: the device sends it in its greeting and status, the monitor's session
//! log keeps it, and every report states its age (docs/exposure.md, "Calibration").

use core::fmt;

use serde::{Deserialize, Serialize};

use crate::mounting::{Mounting, MountingError};

/// Bytes of the calibrator's name or initials (UTF-8, zero-padded).
pub const CALIBRATED_BY_LEN: usize = 16;

/// Accepted sensitivities (indicated per true): a sensor further off its datasheet's scale
/// than a factor of two is broken or misconfigured, not in need of calibration.
pub const SENSITIVITY_RANGE: (f32, f32) = (0.5, 2.0);

/// Largest accepted offset magnitude, m/s^2 (2 g: an LIS3DH's zero-g level is +-40 mg, a
/// cheap sensor's a few tenths of a g).
pub const MAX_OFFSET_M_S2: f32 = 19.6133;

/// Longest accepted recalibration interval, months (ten years).
pub const MAX_INTERVAL_MONTHS: u8 = 120;

/// How the sensitivity and offset were found.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum CalibrationMethod {
    /// The datasheet's nominal values: no measurement of this sensor (reports flag it).
    Datasheet,
    /// A reference shaker at ISO 8041-1's reference point, 15.915 Hz (100 rad/s).
    Shaker,
    /// Six static orientations, each axis at +1 g and -1 g (`supine calibrate tumble`).
    Tumble,
}

impl CalibrationMethod {
    /// Every method, in declaration order.
    pub const ALL: [Self; 3] = [Self::Datasheet, Self::Shaker, Self::Tumble];

    /// The name the parameter file and the reports use.
    pub const fn name(self) -> &'static str {
        match self {
            Self::Datasheet => "datasheet",
            Self::Shaker => "shaker",
            Self::Tumble => "tumble",
        }
    }

    /// The method named `name` ([`name`](Self::name)), in any case.
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL
            .into_iter()
            .find(|m| m.name().eq_ignore_ascii_case(name))
    }
}

/// A calendar date (proleptic Gregorian), or none: `year` 0 means undated (the datasheet
/// default). The device only carries it; the host computes ages from it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct CalibrationDate {
    /// Year (1-9999), 0 for undated.
    pub year: u16,
    /// Month, 1-12 (0 when undated).
    pub month: u8,
    /// Day of the month, 1-31 (0 when undated).
    pub day: u8,
}

impl CalibrationDate {
    /// No date.
    pub const UNDATED: Self = Self {
        year: 0,
        month: 0,
        day: 0,
    };

    /// Whether this is [`UNDATED`](Self::UNDATED).
    pub const fn is_undated(&self) -> bool {
        self.year == 0 && self.month == 0 && self.day == 0
    }

    /// Undated, or a day that exists (29 February in leap years only).
    pub fn is_valid(&self) -> bool {
        if self.is_undated() {
            return true;
        }
        let leap = self.year % 4 == 0 && (self.year % 100 != 0 || self.year % 400 == 0);
        let days = match self.month {
            1 | 3 | 5 | 7 | 8 | 10 | 12 => 31,
            4 | 6 | 9 | 11 => 30,
            2 if leap => 29,
            2 => 28,
            _ => return false,
        };
        (1..=9999).contains(&self.year) && (1..=days).contains(&self.day)
    }
}

/// The sensor's calibration record: the correction and where it came from.
///
/// In the blob and on the wire it is one byte string of [`ENCODED_LEN`] bytes
/// ([`to_bytes`](Self::to_bytes)), not serde's field-by-field form: serde's code for six
/// f32s, a date and a 16-byte name cost the image about 2.5 KB, the fixed layout a few
/// hundred bytes.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SensorCalibration {
    /// Indicated per true acceleration, per sensor axis (1: the datasheet's scale).
    pub sensitivity: [f32; 3],
    /// What each sensor axis reads with no acceleration along it, m/s^2.
    pub offset_m_s2: [f32; 3],
    /// When it was done ([`CalibrationDate::UNDATED`] for datasheet values).
    pub date: CalibrationDate,
    /// How it was done.
    pub method: CalibrationMethod,
    /// Who did it: a name or initials, UTF-8, zero-padded (empty: not recorded).
    pub by: [u8; CALIBRATED_BY_LEN],
    /// Months after `date` when it is due again; reports flag an older one.
    pub interval_months: u8,
}

/// Why a calibration record was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum CalibrationError {
    /// A sensitivity or offset is NaN or infinite.
    NotFinite,
    /// A sensitivity outside [`SENSITIVITY_RANGE`].
    Sensitivity,
    /// An offset larger than [`MAX_OFFSET_M_S2`].
    Offset,
    /// A date that does not exist, or a measured calibration without a date.
    Date,
    /// The name has a zero before its end (not zero-padded).
    Name,
    /// An interval of 0 or over [`MAX_INTERVAL_MONTHS`].
    Interval,
}

impl fmt::Display for CalibrationError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            CalibrationError::NotFinite => "calibration: a number is not finite",
            CalibrationError::Sensitivity => "calibration: each sensitivity must be 0.5-2",
            CalibrationError::Offset => "calibration: each offset must be within +-19.6133 m/s^2",
            CalibrationError::Date => {
                "calibration: the date must exist (YYYY-MM-DD), and a shaker or tumble \
                 calibration must have one"
            }
            CalibrationError::Name => "calibration: the name must be at most 16 bytes, zero-padded",
            CalibrationError::Interval => "calibration: the interval must be 1-120 months",
        })
    }
}

impl core::error::Error for CalibrationError {}

impl SensorCalibration {
    /// The recalibration interval when none is set, months.
    pub const DEFAULT_INTERVAL_MONTHS: u8 = 12;

    /// The datasheet's nominal scale and no offset, undated: what a sensor without a
    /// calibration runs on, and what reports flag.
    pub const DATASHEET: Self = Self {
        sensitivity: [1.0; 3],
        offset_m_s2: [0.0; 3],
        date: CalibrationDate::UNDATED,
        method: CalibrationMethod::Datasheet,
        by: [0; CALIBRATED_BY_LEN],
        interval_months: Self::DEFAULT_INTERVAL_MONTHS,
    };

    /// Checks a stored record: what the device relies on. The name's bytes are only
    /// carried by the device, so it checks their padding, not their UTF-8 (the host's
    /// [`by_name`](Self::by_name) does, where they are read).
    pub fn validate(&self) -> Result<(), CalibrationError> {
        let numbers = self.sensitivity.iter().chain(&self.offset_m_s2);
        if !numbers.clone().all(|v| v.is_finite()) {
            return Err(CalibrationError::NotFinite);
        }
        let (lo, hi) = SENSITIVITY_RANGE;
        if !self.sensitivity.iter().all(|s| (lo..=hi).contains(s)) {
            return Err(CalibrationError::Sensitivity);
        }
        if !self.offset_m_s2.iter().all(|o| o.abs() <= MAX_OFFSET_M_S2) {
            return Err(CalibrationError::Offset);
        }
        let measured = self.method != CalibrationMethod::Datasheet;
        if !self.date.is_valid() || (measured && self.date.is_undated()) {
            return Err(CalibrationError::Date);
        }
        let len = self.by_len();
        if self.by[len..].iter().any(|&b| b != 0) {
            return Err(CalibrationError::Name);
        }
        if !(1..=MAX_INTERVAL_MONTHS).contains(&self.interval_months) {
            return Err(CalibrationError::Interval);
        }
        Ok(())
    }

    /// Bytes of the name before its padding.
    fn by_len(&self) -> usize {
        self.by
            .iter()
            .position(|&b| b == 0)
            .unwrap_or(CALIBRATED_BY_LEN)
    }

    /// Who calibrated, if the bytes are a name (UTF-8, zero-padded, no zero inside).
    pub fn by_name(&self) -> Option<&str> {
        let len = self.by_len();
        if self.by[len..].iter().any(|&b| b != 0) {
            return None;
        }
        core::str::from_utf8(&self.by[..len]).ok()
    }

    /// `name` as the zero-padded field [`by`](Self::by), if it fits.
    pub fn by_field(name: &str) -> Option<[u8; CALIBRATED_BY_LEN]> {
        let bytes = name.as_bytes();
        if bytes.len() > CALIBRATED_BY_LEN || bytes.contains(&0) {
            return None;
        }
        let mut field = [0; CALIBRATED_BY_LEN];
        field[..bytes.len()].copy_from_slice(bytes);
        Some(field)
    }

    /// One reading, sensor axes, m/s^2, corrected for sensitivity and offset.
    #[inline]
    pub fn correct_m_s2(&self, reading_m_s2: [f32; 3]) -> [f32; 3] {
        let (s, o) = (&self.sensitivity, &self.offset_m_s2);
        [
            (reading_m_s2[0] - o[0]) / s[0],
            (reading_m_s2[1] - o[1]) / s[1],
            (reading_m_s2[2] - o[2]) / s[2],
        ]
    }
}

/// Bytes of a calibration record's encoding: sensitivity and offset (6 f32, little-endian),
/// year (u16 LE), month, day, method, interval (u8 each), then the name.
pub const ENCODED_LEN: usize = 6 * 4 + 2 + 4 + CALIBRATED_BY_LEN;

impl SensorCalibration {
    /// The record's fixed layout ([`ENCODED_LEN`] bytes).
    pub fn to_bytes(&self) -> [u8; ENCODED_LEN] {
        let mut out = [0; ENCODED_LEN];
        let numbers = self.sensitivity.iter().chain(&self.offset_m_s2);
        for (chunk, v) in out.chunks_exact_mut(4).zip(numbers) {
            chunk.copy_from_slice(&v.to_le_bytes());
        }
        out[24..26].copy_from_slice(&self.date.year.to_le_bytes());
        out[26] = self.date.month;
        out[27] = self.date.day;
        out[28] = self.method as u8;
        out[29] = self.interval_months;
        out[30..].copy_from_slice(&self.by);
        out
    }

    /// The record in `bytes` ([`to_bytes`](Self::to_bytes)'s layout), if its length is
    /// right and its method one of [`CalibrationMethod::ALL`]; its values are checked by
    /// [`validate`](Self::validate).
    pub fn from_bytes(bytes: &[u8]) -> Option<Self> {
        let bytes: &[u8; ENCODED_LEN] = bytes.try_into().ok()?;
        let f32_at = |k: usize| {
            let mut word = [0; 4];
            word.copy_from_slice(&bytes[4 * k..4 * k + 4]);
            f32::from_le_bytes(word)
        };
        let mut by = [0; CALIBRATED_BY_LEN];
        by.copy_from_slice(&bytes[30..]);
        Some(Self {
            sensitivity: [f32_at(0), f32_at(1), f32_at(2)],
            offset_m_s2: [f32_at(3), f32_at(4), f32_at(5)],
            date: CalibrationDate {
                year: u16::from_le_bytes([bytes[24], bytes[25]]),
                month: bytes[26],
                day: bytes[27],
            },
            method: *CalibrationMethod::ALL.get(usize::from(bytes[28]))?,
            interval_months: bytes[29],
            by,
        })
    }
}

impl Serialize for SensorCalibration {
    /// One byte string (postcard: its length, then the bytes).
    fn serialize<S: serde::Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        serializer.serialize_bytes(&self.to_bytes())
    }
}

impl<'de> Deserialize<'de> for SensorCalibration {
    fn deserialize<D: serde::Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        struct Record;
        impl<'de> serde::de::Visitor<'de> for Record {
            type Value = SensorCalibration;
            fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                f.write_str("a calibration record of 46 bytes")
            }
            fn visit_bytes<E: serde::de::Error>(self, bytes: &[u8]) -> Result<Self::Value, E> {
                SensorCalibration::from_bytes(bytes)
                    .ok_or_else(|| E::invalid_value(serde::de::Unexpected::Bytes(bytes), &self))
            }
            /// Formats without a byte string (JSON: a monitor session's file) write the
            /// record as a list of its bytes.
            fn visit_seq<A: serde::de::SeqAccess<'de>>(
                self,
                mut seq: A,
            ) -> Result<Self::Value, A::Error> {
                let mut bytes = [0u8; ENCODED_LEN];
                let mut n = 0;
                while let Some(byte) = seq.next_element::<u8>()? {
                    if n == ENCODED_LEN {
                        return Err(serde::de::Error::invalid_length(n + 1, &self));
                    }
                    bytes[n] = byte;
                    n += 1;
                }
                self.visit_bytes(&bytes[..n])
            }
        }
        deserializer.deserialize_bytes(Record)
    }
}

impl Default for SensorCalibration {
    /// [`DATASHEET`](Self::DATASHEET).
    fn default() -> Self {
        Self::DATASHEET
    }
}

/// Everything between the sensor's reading and the model's input: the calibration, then
/// the mounting. What the device's sensor source and the host's reading of a recording
/// both use, so that their inputs are the same f32s.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SensorFrame {
    /// The sensor's sensitivity and offset.
    pub calibration: SensorCalibration,
    /// Sensor-to-litter rotation and gravity.
    pub mounting: Mounting,
}

impl SensorFrame {
    /// A sensor at its datasheet's scale, mounted level.
    pub const LEVEL: Self = Self {
        calibration: SensorCalibration::DATASHEET,
        mounting: Mounting::LEVEL,
    };

    /// One reading (sensor axes, m/s^2) to the model's input (litter axes, gravity
    /// removed): corrected, then rotated.
    #[inline]
    pub fn to_litter_m_s2(&self, reading_m_s2: [f32; 3]) -> [f32; 3] {
        self.mounting
            .to_litter_m_s2(self.calibration.correct_m_s2(reading_m_s2))
    }

    /// Checks both parts.
    pub fn validate(&self) -> Result<(), SensorFrameError> {
        self.calibration
            .validate()
            .map_err(SensorFrameError::Calibration)?;
        self.mounting.validate().map_err(SensorFrameError::Mounting)
    }
}

impl From<Mounting> for SensorFrame {
    /// `mounting` with the datasheet's calibration.
    fn from(mounting: Mounting) -> Self {
        Self {
            mounting,
            ..Self::LEVEL
        }
    }
}

/// Why a sensor frame was refused: its calibration's or its mounting's reason.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SensorFrameError {
    /// The calibration record.
    Calibration(CalibrationError),
    /// The mounting.
    Mounting(MountingError),
}

impl fmt::Display for SensorFrameError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            SensorFrameError::Calibration(e) => e.fmt(f),
            SensorFrameError::Mounting(e) => e.fmt(f),
        }
    }
}

impl core::error::Error for SensorFrameError {}

/// Sensitivity and offset of one axis from a static tumble test: the axis's mean reading
/// pointing up (+1 g along it), pointing down (-1 g), and in the four orientations where
/// it is horizontal (0 g).
///
/// Least squares of `reading = sensitivity * true + offset` over the six orientations
/// (true accelerations g, -g and four zeros, which sum to zero): the sensitivity is
/// `(up - down) / 2g`, the offset the mean of all six readings. The four horizontal
/// readings make the offset less sensitive to one orientation's noise than `(up + down)/2`.
pub fn tumble_axis(up_m_s2: f64, down_m_s2: f64, level_m_s2: [f64; 4], g_m_s2: f64) -> (f64, f64) {
    let sensitivity = (up_m_s2 - down_m_s2) / (2.0 * g_m_s2);
    let offset = (up_m_s2 + down_m_s2 + level_m_s2.iter().sum::<f64>()) / 6.0;
    (sensitivity, offset)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_datasheet_record_is_valid_and_changes_nothing() {
        assert_eq!(SensorCalibration::DATASHEET.validate(), Ok(()));
        let reading = [0.123f32, -9.81, 3.5];
        assert_eq!(SensorCalibration::DATASHEET.correct_m_s2(reading), reading);
        assert_eq!(
            SensorFrame::LEVEL.to_litter_m_s2(reading),
            Mounting::LEVEL.to_litter_m_s2(reading)
        );
    }

    #[test]
    fn a_reading_is_corrected_back_to_the_true_acceleration() {
        let cal = SensorCalibration {
            sensitivity: [1.02, 0.97, 1.0],
            offset_m_s2: [0.3, -0.2, 0.05],
            ..SensorCalibration::DATASHEET
        };
        let truth = [1.5f64, -2.0, 9.80665];
        let reading = [0, 1, 2].map(|i| {
            (f64::from(cal.sensitivity[i]) * truth[i] + f64::from(cal.offset_m_s2[i])) as f32
        });
        let corrected = cal.correct_m_s2(reading);
        for i in 0..3 {
            assert!((f64::from(corrected[i]) - truth[i]).abs() < 1e-5, "{i}");
        }
    }

    #[test]
    fn the_fixed_layout_round_trips_and_refuses_a_wrong_length_or_method() {
        let cal = SensorCalibration {
            sensitivity: [1.02, 0.97, 1.5],
            offset_m_s2: [0.3, -0.2, 0.05],
            date: CalibrationDate {
                year: 2026,
                month: 3,
                day: 31,
            },
            method: CalibrationMethod::Shaker,
            by: SensorCalibration::by_field("Lab 3").unwrap(),
            interval_months: 6,
        };
        let bytes = cal.to_bytes();
        assert_eq!(SensorCalibration::from_bytes(&bytes), Some(cal));
        assert_eq!(bytes[24..30], [0xEA, 0x07, 3, 31, 1, 6]);
        assert_eq!(&bytes[30..35], b"Lab 3");
        assert_eq!(SensorCalibration::from_bytes(&bytes[1..]), None);
        let mut bad = bytes;
        bad[28] = 3;
        assert_eq!(SensorCalibration::from_bytes(&bad), None);
        let mut buf = [0u8; 64];
        let wire = postcard::to_slice(&cal, &mut buf).unwrap();
        assert_eq!(wire[0] as usize, ENCODED_LEN);
        assert_eq!(postcard::from_bytes::<SensorCalibration>(wire), Ok(cal));
    }

    #[test]
    fn bad_records_are_refused_each_for_its_reason() {
        let base = SensorCalibration {
            method: CalibrationMethod::Tumble,
            date: CalibrationDate {
                year: 2024,
                month: 2,
                day: 29,
            },
            by: SensorCalibration::by_field("A. Tech").unwrap(),
            ..SensorCalibration::DATASHEET
        };
        assert_eq!(base.validate(), Ok(()));
        assert_eq!(base.by_name(), Some("A. Tech"));
        let refused = |f: &dyn Fn(&mut SensorCalibration)| {
            let mut c = base;
            f(&mut c);
            c.validate().unwrap_err()
        };
        use CalibrationError as E;
        assert_eq!(refused(&|c| c.sensitivity[1] = f32::NAN), E::NotFinite);
        assert_eq!(refused(&|c| c.sensitivity[2] = 0.0), E::Sensitivity);
        assert_eq!(refused(&|c| c.offset_m_s2[0] = -25.0), E::Offset);
        assert_eq!(refused(&|c| c.date.year = 2023), E::Date);
        assert_eq!(refused(&|c| c.date.month = 13), E::Date);
        assert_eq!(refused(&|c| c.date = CalibrationDate::UNDATED), E::Date);
        assert_eq!(refused(&|c| c.by[3] = 0), E::Name);
        // Not UTF-8: carried by the device, refused where the host reads it as a name.
        let mut not_utf8 = base;
        not_utf8.by = [0xFF; CALIBRATED_BY_LEN];
        assert_eq!(not_utf8.validate(), Ok(()));
        assert_eq!(not_utf8.by_name(), None);
        assert_eq!(refused(&|c| c.interval_months = 0), E::Interval);
        assert_eq!(refused(&|c| c.interval_months = 121), E::Interval);
        assert!(SensorCalibration::by_field("a name far too long for it").is_none());
    }

    /// Synthetic readings of known sensitivity and offset, with noise of 1 mg, give them
    /// back within 0.2 % and 0.02 m/s^2.
    #[test]
    fn a_tumble_test_recovers_known_sensitivity_and_offset() {
        let g = 9.80665;
        for (sensitivity, offset, noise) in [
            (1.0, 0.0, [0.0; 6]),
            (1.031, -0.42, [0.01, -0.008, 0.004, 0.0, -0.01, 0.006]),
            (0.962, 0.77, [-0.009, 0.01, 0.0, 0.003, 0.007, -0.01]),
        ] {
            let read = |true_m_s2: f64, k: usize| sensitivity * true_m_s2 + offset + noise[k];
            let (s, o) = tumble_axis(
                read(g, 0),
                read(-g, 1),
                [read(0.0, 2), read(0.0, 3), read(0.0, 4), read(0.0, 5)],
                g,
            );
            assert!((s / sensitivity - 1.0).abs() < 2e-3, "{s} vs {sensitivity}");
            assert!((o - offset).abs() < 0.02, "{o} vs {offset}");
        }
    }
}
