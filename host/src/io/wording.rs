//! Counts with their noun in what the tools print (`1 shock`, `3 shocks`), and joint
//! motion in the units people read (mm, degrees), for commands, the monitor, the report
//! and the demo alike.

use supine_core::alerts::JointCriterion;
use supine_core::model::JointOutput;

/// Display unit of a joint output and the factor from its SI value (m, rad) to it
/// ([`JointUnit::display`](supine_core::model::JointUnit::display)).
pub fn display_unit(output: JointOutput) -> (&'static str, f64) {
    output.unit().display()
}

/// A joint alert in words: `neck_x running-rms 3.100 mm raised`.
pub fn joint_alert_text(output: JointOutput, criterion: &JointCriterion, raised: bool) -> String {
    let (unit, scale) = display_unit(output);
    format!(
        "{output} {} {:.3} {unit} {}",
        criterion.name(),
        scale * f64::from(criterion.value_m_or_rad()),
        if raised { "raised" } else { "cleared" }
    )
}

/// `n` and the noun, plural unless `n` is 1: `1 shock`, `3 shocks`, `0 shocks`, `2
/// passes`. Any integer type: lengths are `usize`, an archive's counts `i64`.
pub fn count(n: impl std::fmt::Display, noun: &str) -> String {
    let n = n.to_string();
    match (n.as_str(), noun.ends_with('s')) {
        ("1", _) => format!("1 {noun}"),
        (_, true) => format!("{n} {noun}es"),
        (_, false) => format!("{n} {noun}s"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn joint_alerts_read_in_mm_and_degrees() {
        let neck_x = JointOutput::from_name("neck_x").unwrap();
        let c = JointCriterion::RunningRms {
            value_m_or_rad: 0.0031,
        };
        assert_eq!(
            joint_alert_text(neck_x, &c, true),
            "neck_x running-rms 3.100 mm raised"
        );
        let ry = JointOutput::from_name("low_back_ry").unwrap();
        let c = JointCriterion::Excursion {
            value_m_or_rad: core::f32::consts::PI / 180.0,
        };
        assert_eq!(
            joint_alert_text(ry, &c, false),
            "low_back_ry excursion 1.000 deg cleared"
        );
    }

    #[test]
    fn counts_are_singular_for_one_only() {
        assert_eq!(count(0, "shock"), "0 shocks");
        assert_eq!(count(1, "shock"), "1 shock");
        assert_eq!(count(2, "level change"), "2 level changes");
        assert_eq!(count(1i64, "pass"), "1 pass");
        assert_eq!(count(3i64, "pass"), "3 passes");
    }
}
