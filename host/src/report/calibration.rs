//! The sensor's calibration as every report states it: what it is, how old it was on the
//! day the data were taken (or the report made), and whether it is flagged: older than
//! its interval, or the datasheet's nominal values only (docs/exposure.md, "Calibration").

use serde::Serialize;
use supine_core::calibration::{CalibrationDate, CalibrationMethod, SensorCalibration};
use time::{Date, Month};

use crate::io::calibration_section::date_text;
pub use crate::io::calibration_section::today;

/// The calibration record with its age and verdict.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct CalibrationReport {
    /// `datasheet`, `shaker` or `tumble`.
    pub method: String,
    /// When it was done (`YYYY-MM-DD`), if dated.
    pub date: Option<String>,
    /// Who did it, if recorded.
    pub by: Option<String>,
    /// Indicated per true acceleration, per sensor axis.
    pub sensitivity: [f32; 3],
    /// Zero-acceleration reading per sensor axis, m/s^2.
    pub offset_m_s2: [f32; 3],
    /// The day the age is counted to (`YYYY-MM-DD`).
    pub as_of: String,
    /// What that day is: the session's, or the report's.
    pub as_of_what: String,
    /// Whole months from the calibration to `as_of`, if dated.
    pub age_months: Option<i32>,
    /// Months after which it is due again.
    pub interval_months: u8,
    /// Older than `interval_months` on `as_of`.
    pub overdue: bool,
    /// The datasheet's nominal values, no measurement of this sensor.
    pub datasheet_only: bool,
    /// Overdue or datasheet-only: the report flags it.
    pub flagged: bool,
    /// One sentence saying all this.
    pub statement: String,
}

/// A record's date as a calendar date, if dated and real.
pub fn calendar(date: CalibrationDate) -> Option<Date> {
    let month = Month::try_from(date.month).ok()?;
    Date::from_calendar_date(i32::from(date.year), month, date.day).ok()
}

/// `date` plus `months`, the day kept or, past the month's end, its last day.
fn add_months(date: Date, months: u32) -> Date {
    let index = date.year() * 12 + i32::from(u8::from(date.month())) - 1 + months as i32;
    let (year, month0) = (index.div_euclid(12), index.rem_euclid(12));
    let month = Month::try_from(month0 as u8 + 1).unwrap_or(Month::December);
    let day = date.day().min(month.length(year));
    Date::from_calendar_date(year, month, day).unwrap_or(date)
}

/// Whole months from `from` to `to` (negative if `to` is earlier).
fn whole_months(from: Date, to: Date) -> i32 {
    let months = |d: Date| d.year() * 12 + i32::from(u8::from(d.month()));
    let mut n = months(to) - months(from);
    if n > 0 && to.day() < from.day() {
        n -= 1;
    }
    n
}

impl CalibrationReport {
    /// `calibration`'s report as of `as_of`, which is `as_of_what` ("the session's start",
    /// "the report's date").
    pub fn new(calibration: &SensorCalibration, as_of: Date, as_of_what: &str) -> Self {
        let dated = calendar(calibration.date);
        let interval = calibration.interval_months;
        let age_months = dated.map(|d| whole_months(d, as_of));
        let overdue = dated.is_some_and(|d| as_of > add_months(d, u32::from(interval)));
        let datasheet_only = calibration.method == CalibrationMethod::Datasheet;
        let by = calibration
            .by_name()
            .filter(|n| !n.is_empty())
            .map(str::to_string);
        let as_of_text = as_of.to_string();
        let method = calibration.method.name().to_string();
        let statement = match (dated, age_months) {
            (Some(_), Some(age)) => {
                let how = match calibration.method {
                    CalibrationMethod::Shaker => "reference shaker at 15.915 Hz",
                    CalibrationMethod::Tumble => "static tumble test at +-1 g",
                    CalibrationMethod::Datasheet => "datasheet nominal values",
                };
                let who = by
                    .as_deref()
                    .map(|b| format!(" by {b}"))
                    .unwrap_or_default();
                let verdict = if overdue {
                    format!(
                        "OVERDUE: older than its {interval}-month interval; recalibrate the sensor"
                    )
                } else {
                    format!("within its {interval}-month interval")
                };
                format!(
                    "Sensor calibrated {} ({how}){who}: {age} month{} old on {as_of_text} \
                     ({as_of_what}), {verdict}.",
                    date_text(calibration.date),
                    if age == 1 { "" } else { "s" },
                )
            }
            _ => "NOT CALIBRATED: the sensor runs on its datasheet's nominal sensitivity and \
                  offset, undated; calibrate it (supine calibrate --tumble) before relying on \
                  absolute values."
                .to_string(),
        };
        let statement = if datasheet_only && dated.is_some() {
            format!("{statement} Datasheet values only: this sensor was not measured.")
        } else {
            statement
        };
        Self {
            method,
            date: dated.map(|_| date_text(calibration.date)),
            by,
            sensitivity: calibration.sensitivity,
            offset_m_s2: calibration.offset_m_s2,
            as_of: as_of_text,
            as_of_what: as_of_what.to_string(),
            age_months,
            interval_months: interval,
            overdue,
            datasheet_only,
            flagged: overdue || datasheet_only,
            statement,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tumble(year: u16, month: u8, day: u8) -> SensorCalibration {
        SensorCalibration {
            method: CalibrationMethod::Tumble,
            date: CalibrationDate { year, month, day },
            by: SensorCalibration::by_field("A. Tech").unwrap(),
            ..SensorCalibration::DATASHEET
        }
    }

    fn day(y: i32, m: u8, d: u8) -> Date {
        Date::from_calendar_date(y, Month::try_from(m).unwrap(), d).unwrap()
    }

    #[test]
    fn a_calibration_13_months_old_is_flagged_overdue() {
        let r = CalibrationReport::new(
            &tumble(2025, 10, 1),
            day(2026, 11, 2),
            "the session's start",
        );
        assert_eq!(r.age_months, Some(13));
        assert!(r.overdue && r.flagged && !r.datasheet_only);
        assert!(r.statement.contains("13 months old"), "{}", r.statement);
        assert!(r.statement.contains("OVERDUE"), "{}", r.statement);
    }

    #[test]
    fn one_within_its_interval_is_not_flagged_and_the_edges_count_by_calendar() {
        let cal = tumble(2025, 11, 30);
        let r = CalibrationReport::new(&cal, day(2026, 11, 30), "the report's date");
        assert_eq!(r.age_months, Some(12));
        assert!(!r.flagged, "due on the day itself: {}", r.statement);
        let r = CalibrationReport::new(&cal, day(2026, 12, 1), "the report's date");
        assert!(r.overdue);
        // 31 January plus one month ends on February's last day.
        assert_eq!(add_months(day(2024, 1, 31), 1), day(2024, 2, 29));
        assert_eq!(whole_months(day(2024, 1, 31), day(2024, 2, 29)), 0);
        assert_eq!(whole_months(day(2024, 1, 15), day(2025, 1, 15)), 12);
    }

    #[test]
    fn datasheet_values_are_flagged_whatever_their_age() {
        let r = CalibrationReport::new(
            &SensorCalibration::DATASHEET,
            day(2026, 1, 1),
            "the report's date",
        );
        assert!(r.datasheet_only && r.flagged && !r.overdue);
        assert_eq!(r.age_months, None);
        assert!(r.statement.starts_with("NOT CALIBRATED"), "{}", r.statement);
    }
}
