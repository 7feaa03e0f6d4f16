//! The parameter file's `[device.calibration]` table: the sensor's calibration record as
//! a person writes it (a date as `YYYY-MM-DD`, the method and the calibrator by name),
//! and its rendering for `supine calibrate tumble`.
//!
//! The record itself, its rules and its use are the core's
//! ([`supine_core::calibration::SensorCalibration`]); this module only reads and writes
//! its file form. A file without the table runs on the datasheet's nominal values, which
//! every report flags.

use serde::{Deserialize, Deserializer, Serialize, Serializer};
use supine_core::calibration::{
    CALIBRATED_BY_LEN, CalibrationDate, CalibrationMethod, SensorCalibration,
};

use crate::io::excerpt::value;

/// `[device.calibration]`: the core's [`SensorCalibration`], every key optional (each
/// defaults to the datasheet record's).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct CalibrationTable {
    sensitivity: [f32; 3],
    offset_m_s2: [f32; 3],
    #[serde(skip_serializing_if = "DateText::is_undated")]
    date: DateText,
    method: MethodName,
    #[serde(skip_serializing_if = "ByText::is_empty")]
    by: ByText,
    interval_months: u8,
}

impl CalibrationTable {
    /// Whether this is the datasheet record (a file need not spell it out).
    pub fn is_default(&self) -> bool {
        *self == Self::default()
    }
}

impl Default for CalibrationTable {
    fn default() -> Self {
        SensorCalibration::DATASHEET.into()
    }
}

impl From<SensorCalibration> for CalibrationTable {
    fn from(c: SensorCalibration) -> Self {
        Self {
            sensitivity: c.sensitivity,
            offset_m_s2: c.offset_m_s2,
            date: DateText(c.date),
            method: MethodName(c.method),
            by: ByText(c.by),
            interval_months: c.interval_months,
        }
    }
}

impl From<CalibrationTable> for SensorCalibration {
    fn from(t: CalibrationTable) -> Self {
        Self {
            sensitivity: t.sensitivity,
            offset_m_s2: t.offset_m_s2,
            date: t.date.0,
            method: t.method.0,
            by: t.by.0,
            interval_months: t.interval_months,
        }
    }
}

/// `#[serde(with = ...)]` for a [`SensorCalibration`] written as its table
/// ([`CalibrationTable`]).
pub mod as_table {
    use serde::{Deserialize, Deserializer, Serialize, Serializer};
    use supine_core::calibration::SensorCalibration;

    use super::CalibrationTable;

    /// `calibration` as its table.
    pub fn serialize<S: Serializer>(
        calibration: &SensorCalibration,
        s: S,
    ) -> Result<S::Ok, S::Error> {
        CalibrationTable::from(*calibration).serialize(s)
    }

    /// The record a table holds.
    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<SensorCalibration, D::Error> {
        CalibrationTable::deserialize(d).map(SensorCalibration::from)
    }
}

/// Whether `calibration` is the datasheet record (a file need not spell it out).
pub fn is_datasheet(calibration: &SensorCalibration) -> bool {
    CalibrationTable::from(*calibration).is_default()
}

/// Today's date, UTC: the day a session starts or a report is made.
pub fn today() -> time::Date {
    time::OffsetDateTime::now_utc().date()
}

/// `date` as written: `YYYY-MM-DD`.
pub fn date_text(date: CalibrationDate) -> String {
    if date.is_undated() {
        "undated".to_string()
    } else {
        format!("{:04}-{:02}-{:02}", date.year, date.month, date.day)
    }
}

/// The date `text` (`YYYY-MM-DD`, a day that exists), or what was expected.
pub fn parse_date(text: &str) -> Result<CalibrationDate, String> {
    let expected = || format!("expected a date YYYY-MM-DD, found {}", value(text));
    let parts: Vec<&str> = text.trim().split('-').collect();
    let [y, m, d] = parts.as_slice() else {
        return Err(expected());
    };
    if y.len() != 4 || m.len() != 2 || d.len() != 2 {
        return Err(expected());
    }
    let date = CalibrationDate {
        year: y.parse().map_err(|_| expected())?,
        month: m.parse().map_err(|_| expected())?,
        day: d.parse().map_err(|_| expected())?,
    };
    if date.is_undated() || !date.is_valid() {
        return Err(expected());
    }
    Ok(date)
}

/// A date in the file's form.
#[derive(Clone, Copy, Debug, PartialEq)]
struct DateText(CalibrationDate);

impl DateText {
    fn is_undated(&self) -> bool {
        self.0.is_undated()
    }
}

impl Default for DateText {
    fn default() -> Self {
        Self(CalibrationDate::UNDATED)
    }
}

impl Serialize for DateText {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(&date_text(self.0))
    }
}

impl<'de> Deserialize<'de> for DateText {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let text = String::deserialize(d)?;
        parse_date(&text)
            .map(Self)
            .map_err(serde::de::Error::custom)
    }
}

/// A method by name (`datasheet`, `shaker`, `tumble`).
#[derive(Clone, Copy, Debug, PartialEq)]
struct MethodName(CalibrationMethod);

impl Default for MethodName {
    fn default() -> Self {
        Self(CalibrationMethod::Datasheet)
    }
}

impl Serialize for MethodName {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(self.0.name())
    }
}

impl<'de> Deserialize<'de> for MethodName {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let text = String::deserialize(d)?;
        CalibrationMethod::from_name(text.trim())
            .map(Self)
            .ok_or_else(|| {
                serde::de::Error::custom(format!(
                    "expected one of datasheet, shaker, tumble, found {}",
                    value(&text)
                ))
            })
    }
}

/// Who calibrated, as text.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct ByText([u8; CALIBRATED_BY_LEN]);

impl ByText {
    fn is_empty(&self) -> bool {
        self.0 == [0; CALIBRATED_BY_LEN]
    }
}

impl Serialize for ByText {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let len = self.0.iter().position(|&b| b == 0).unwrap_or(self.0.len());
        s.serialize_str(&String::from_utf8_lossy(&self.0[..len]))
    }
}

impl<'de> Deserialize<'de> for ByText {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let text = String::deserialize(d)?;
        SensorCalibration::by_field(text.trim())
            .map(Self)
            .ok_or_else(|| {
                serde::de::Error::custom(format!(
                    "expected a name of at most {CALIBRATED_BY_LEN} bytes, found {}",
                    value(&text)
                ))
            })
    }
}

/// `calibration` as the `[device.calibration]` table of a parameter file.
pub fn calibration_toml(calibration: SensorCalibration) -> Result<String, toml::ser::Error> {
    #[derive(Serialize)]
    struct Device {
        calibration: CalibrationTable,
    }
    #[derive(Serialize)]
    struct Wrapper {
        device: Device,
    }
    toml::to_string(&Wrapper {
        device: Device {
            calibration: calibration.into(),
        },
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn read(text: &str) -> Result<SensorCalibration, String> {
        toml::from_str::<CalibrationTable>(text)
            .map(SensorCalibration::from)
            .map_err(|e| e.to_string())
    }

    #[test]
    fn an_empty_table_is_the_datasheet_record() {
        assert_eq!(read(""), Ok(SensorCalibration::DATASHEET));
        assert!(CalibrationTable::default().is_default());
    }

    #[test]
    fn a_written_table_reads_back_and_names_each_part() {
        let cal = read(
            "sensitivity = [1.01, 0.99, 1.0]\noffset_m_s2 = [0.1, -0.2, 0.0]\n\
             date = \"2025-10-28\"\nmethod = \"Tumble\"\nby = \"J. Doe\"\ninterval_months = 6\n",
        )
        .unwrap();
        assert_eq!(cal.method, CalibrationMethod::Tumble);
        assert_eq!(cal.by_name(), Some("J. Doe"));
        assert_eq!(date_text(cal.date), "2025-10-28");
        assert_eq!(cal.interval_months, 6);
        let text = calibration_toml(cal).unwrap();
        assert!(text.starts_with("[device.calibration]\n"), "{text}");
        let body = text.trim_start_matches("[device.calibration]\n");
        assert_eq!(read(body), Ok(cal));
    }

    #[test]
    fn bad_values_say_what_was_expected() {
        let err = read("date = \"2025-02-30\"").unwrap_err();
        assert!(
            err.contains("expected a date YYYY-MM-DD, found 2025-02-30"),
            "{err}"
        );
        let err = read("date = \"28/10/2025\"").unwrap_err();
        assert!(err.contains("expected a date YYYY-MM-DD"), "{err}");
        let err = read("method = \"guess\"").unwrap_err();
        assert!(
            err.contains("expected one of datasheet, shaker, tumble, found guess"),
            "{err}"
        );
        let err = read("by = \"a name much longer than sixteen\"").unwrap_err();
        assert!(err.contains("at most 16 bytes"), "{err}");
        let err = read("sensitivty = [1.0, 1.0, 1.0]").unwrap_err();
        assert!(err.contains("unknown field `sensitivty`"), "{err}");
    }
}
