//! The report's calibration paragraph: the sensor's calibration statement, marked when
//! flagged (overdue, or the datasheet's values only), and its numbers.

use std::fmt::Write as _;

use crate::report::calibration::CalibrationReport;
use crate::report::markup::escape;

/// Appends the paragraph to `h`.
pub fn section(h: &mut String, calibration: &CalibrationReport) {
    let class = if calibration.flagged { "warn" } else { "sub" };
    let axes = |v: [f32; 3]| {
        v.iter()
            .map(|x| format!("{x}"))
            .collect::<Vec<_>>()
            .join(", ")
    };
    let _ = writeln!(
        h,
        "<p class=\"{class}\"><strong>Calibration.</strong> {} Sensitivity (x, y, z) {}; \
         offset {} m/s<sup>2</sup>.</p>",
        escape(&calibration.statement),
        axes(calibration.sensitivity),
        axes(calibration.offset_m_s2)
    );
}

#[cfg(test)]
mod tests {
    use supine_core::calibration::{CalibrationDate, CalibrationMethod, SensorCalibration};
    use time::{Date, Month};

    use super::*;

    #[test]
    fn an_overdue_calibration_is_marked_and_a_current_one_is_not() {
        let cal = SensorCalibration {
            method: CalibrationMethod::Tumble,
            date: CalibrationDate {
                year: 2025,
                month: 10,
                day: 1,
            },
            by: SensorCalibration::by_field("A. Tech & Co").unwrap(),
            ..SensorCalibration::DATASHEET
        };
        let day = |m| Date::from_calendar_date(2026, m, 2).unwrap();
        let mut h = String::new();
        section(
            &mut h,
            &CalibrationReport::new(&cal, day(Month::November), "the session's start"),
        );
        assert!(
            h.contains("class=\"warn\"") && h.contains("13 months old"),
            "{h}"
        );
        assert!(h.contains("A. Tech &amp; Co"), "{h}");
        let mut h = String::new();
        section(
            &mut h,
            &CalibrationReport::new(&cal, day(Month::March), "the report's date"),
        );
        assert!(
            h.contains("class=\"sub\"") && h.contains("5 months old"),
            "{h}"
        );
    }
}
