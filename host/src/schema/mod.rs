//! The output vocabulary: how every CSV column and JSON key of `supine` is named, and the
//! record pieces that more than one output shares, defined once here.
//!
//! The rules, which `host/tests/output_names.rs` checks on every command's JSON and every
//! CSV header the commands write:
//! - names are lower-case ASCII `snake_case`;
//! - a number with a unit carries the unit as the name's suffix, one of
//!   [`UNIT_SUFFIXES`] (`time_s`, `vdv_m_s175`, `neck_x_mm`); a number without one is a
//!   count, an index or a ratio ([`UNITLESS`], [`UNITLESS_SUFFIXES`]), or sits in an object
//!   whose key has the unit (`"rms_m_s2": {"x": ..}`) or that names it in a `unit` field
//!   (a joint output's `rms` in `mm` or `deg`, an events CSV's `value`);
//! - a quantity has one name everywhere: the vector running rms is
//!   `vector_running_rms_m_s2` (wire, telemetry CSV, `--jsonl`), a level is named by
//!   [`Level`](supine_core::alerts::Level)'s own serialization (`normal`, `advisory`,
//!   `warning`, `alarm`), a criterion by [`Criterion`](supine_core::alerts::Criterion)'s
//!   (`running-rms`, `vdv`), an event that raises an alert is `raised`;
//! - values a person typed or reads (a height, a threshold) are written as the shortest
//!   decimal of their f32 ([`shortest`]).

pub mod event;
pub mod names;
pub mod subject;

/// The unit suffixes a numeric name may end with.
pub const UNIT_SUFFIXES: &[&str] = &[
    "_m_s175", "_m_s2", "_hz", "_kg", "_mm", "_deg", "_rad", "_m", "_s", "_h", "_bytes", "_months",
];

/// Numeric names without a unit: counts, indices, seeds and dimensionless ratios. Any
/// other numeric name must end in a unit ([`UNIT_SUFFIXES`]) or in one of
/// [`UNITLESS_SUFFIXES`].
pub const UNITLESS: &[&str] = &[
    "sample",
    "samples",
    "rows",
    "gaps",
    "seed",
    "shocks",
    "subjects",
    "cases",
    "segments",
    "fixes",
    "missions",
    "passes",
    "frequencies",
    "components",
    "residuals",
    "evaluations",
    "iterations",
    "best_start",
    "modal_blocks",
    "frames",
    "fault_flags",
    "sensor_to_litter",
    "magnitude",
    // A sensor axis's reading per true acceleration (its calibration).
    "sensitivity",
    // Flags, written 1 or 0 in a CSV.
    "valid",
    "raised",
    // Settings that count samples, name a flash slot, or number an upload.
    "telemetry_decimation",
    "slot",
    "counter",
    // An archive's mission number, and a road place's cell (row and column of its grid).
    "id",
    "row",
    "column",
    // A two-group test's statistics (the Mann-Whitney U, its normal z, its p-value).
    "u_statistic",
    "z_score",
    "p_value",
    // A prediction's agreement with a recording (`validate`): the paper's R^2 both ways,
    // and errors relative to the measured values.
    "r2_determination",
    "r2_pearson",
    "normalized_rms_error",
    "mean_relative_error",
];

/// Endings of numeric names without a unit: counts of a thing (`dropped_samples`,
/// `lost_frames`), ratios (`vdv_ratio`, `crest_factor`), a fit's cost (a sum of squared
/// log ratios).
pub const UNITLESS_SUFFIXES: &[&str] = &[
    "_samples",
    "_frames",
    "_fixes",
    "_missions",
    "_records",
    "_events",
    "_raised",
    "_per_sample",
    "_ratio",
    "_fraction",
    "_factor",
    "_magnitude",
    "_cost",
    // A grid cell's indices (the archive's `cell_row`, `cell_column` of a road place).
    "_row",
    "_column",
];

/// An f32 as the shortest decimal that reads back as it (`1.82`, not
/// `1.8200000524520874`), as an f64 for serde: for numbers a person typed or reads.
pub fn shortest(x: f32) -> f64 {
    // `Display` of an f32 is its shortest round-trip decimal; NaN and infinities read back.
    format!("{x}").parse().unwrap_or(f64::from(x))
}

/// Whether `name` is a lower-case ASCII `snake_case` name (`head_x_m_s2`).
pub fn is_snake_case(name: &str) -> bool {
    !name.is_empty()
        && !name.starts_with('_')
        && !name.ends_with('_')
        && !name.contains("__")
        && name
            .bytes()
            .all(|b| b.is_ascii_lowercase() || b.is_ascii_digit() || b == b'_')
}

/// Whether a numeric value may be named `name`: with a unit suffix, or a unitless name.
pub fn names_a_number(name: &str) -> bool {
    UNIT_SUFFIXES
        .iter()
        .chain(UNITLESS_SUFFIXES)
        .any(|u| name.ends_with(u))
        || UNITLESS.contains(&name)
}

#[cfg(test)]
mod tests {
    use super::*;
    use supine_core::alerts::{Criterion, Level, SensorFault};

    #[test]
    fn shortest_gives_the_decimal_a_person_typed() {
        assert_eq!(shortest(1.82), 1.82);
        assert_eq!(shortest(52.0), 52.0);
        assert_eq!(shortest(f32::MAX), 3.4028235e38);
        assert!(shortest(f32::NAN).is_nan());
        assert_eq!(shortest(f32::NEG_INFINITY), f64::NEG_INFINITY);
    }

    #[test]
    fn snake_case_names_pass_and_others_do_not() {
        assert!(is_snake_case("head_x_m_s2"));
        assert!(is_snake_case("neck_ry_deg"));
        for bad in [
            "", "Head_x", "head-x", "head x", "_x", "x_", "a__b", "vdv_m/s",
        ] {
            assert!(!is_snake_case(bad), "{bad}");
        }
        assert!(names_a_number("vdv_m_s175"));
        assert!(!names_a_number("head_x"));
    }

    #[test]
    fn the_cores_names_serialize_as_they_print() {
        for level in Level::ALL {
            assert_eq!(serde_json::to_value(level).unwrap(), level.name());
            assert_eq!(Level::from_name(level.name()), Some(level));
        }
        for fault in SensorFault::ALL {
            assert_eq!(serde_json::to_value(fault).unwrap(), fault.name());
        }
        for c in [
            Criterion::RunningRms { value_m_s2: 1.0 },
            Criterion::Vdv { value_m_s175: 1.0 },
        ] {
            let v = serde_json::to_value(c).unwrap();
            let (name, _) = v.as_object().unwrap().iter().next().unwrap();
            assert_eq!(name, c.name());
        }
    }
}
