//! The accelerometer exports people have, recognized by their headers so that no
//! `--columns` is needed. Each entry's header names, units and time base are taken from
//! real files in public repositories:
//! - phyphox (its CSV export of "Acceleration with g" and "Acceleration without g"):
//!   `"Time (s)","Acceleration x (m/s^2)",...` or `"Linear Acceleration x (m/s^2)"`,
//!   quoted, seconds since the start, m/s^2.
//! - Sensor Logger (`Accelerometer.csv`, `TotalAcceleration.csv`):
//!   `time,seconds_elapsed,z,y,x`, `time` in ns since the epoch and `seconds_elapsed`
//!   in s; m/s^2. The nanosecond column is read (exact, relative to the first row).
//! - Physics Toolbox Sensor Suite (g-force meter): `time,gFx,gFy,gFz,...` in g, the time
//!   as date-time text (`2018-10-03 17:23:55.4640`, iOS) or a clock time.
//! - The project's own ride (`time_s,platform_x,platform_y,platform_z`), s and m/s^2.

use crate::ride::clock::TimeUnit;
use crate::ride::units::AccelUnit;

/// A recognized export: its name and where its time and x, y, z are.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct KnownFormat {
    /// The app or logger, as the data-quality account names it.
    pub name: &'static str,
    /// Header names of time, x, y, z.
    pub columns: [&'static str; 4],
    /// The time column's unit.
    pub time_unit: TimeUnit,
    /// The acceleration columns' unit.
    pub units: AccelUnit,
}

/// The formats recognized, in the order they are tried.
pub const KNOWN_FORMATS: [KnownFormat; 5] = [
    KnownFormat {
        name: "supine ride",
        columns: ["time_s", "platform_x", "platform_y", "platform_z"],
        time_unit: TimeUnit::S,
        units: AccelUnit::MS2,
    },
    KnownFormat {
        name: "phyphox (acceleration with g)",
        columns: [
            "Time (s)",
            "Acceleration x (m/s^2)",
            "Acceleration y (m/s^2)",
            "Acceleration z (m/s^2)",
        ],
        time_unit: TimeUnit::S,
        units: AccelUnit::MS2,
    },
    KnownFormat {
        name: "phyphox (linear acceleration)",
        columns: [
            "Time (s)",
            "Linear Acceleration x (m/s^2)",
            "Linear Acceleration y (m/s^2)",
            "Linear Acceleration z (m/s^2)",
        ],
        time_unit: TimeUnit::S,
        units: AccelUnit::MS2,
    },
    KnownFormat {
        name: "Sensor Logger",
        columns: ["time", "x", "y", "z"],
        time_unit: TimeUnit::Ns,
        units: AccelUnit::MS2,
    },
    KnownFormat {
        name: "Physics Toolbox Sensor Suite",
        columns: ["time", "gFx", "gFy", "gFz"],
        time_unit: TimeUnit::Text,
        units: AccelUnit::G,
    },
];

/// The format whose four columns are all in `header` (Sensor Logger also needs its
/// `seconds_elapsed`, so that another file's `time,x,y,z` is not taken for it).
pub fn recognize(header: &[String]) -> Option<&'static KnownFormat> {
    let has = |name: &str| header.iter().any(|h| h == name);
    KNOWN_FORMATS.iter().find(|f| {
        f.columns.iter().all(|c| has(c)) && (f.name != "Sensor Logger" || has("seconds_elapsed"))
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn headers_of_real_exports_are_recognized_and_others_are_not() {
        let names = |s: &str| {
            s.split(',')
                .map(|c| c.trim_matches('"').to_string())
                .collect::<Vec<_>>()
        };
        let found = |s: &str| recognize(&names(s)).map(|f| f.name);
        assert_eq!(found("time,seconds_elapsed,z,y,x"), Some("Sensor Logger"));
        assert_eq!(found("time,x,y,z"), None);
        assert_eq!(
            found(
                "\"Time (s)\",\"Acceleration x (m/s^2)\",\"Acceleration y (m/s^2)\",\"Acceleration z (m/s^2)\""
            ),
            Some("phyphox (acceleration with g)")
        );
        assert_eq!(
            found("time,gFx,gFy,gFz,TgF"),
            Some("Physics Toolbox Sensor Suite")
        );
        assert_eq!(
            found("time_s,platform_x,platform_y,platform_z"),
            Some("supine ride")
        );
    }
}
