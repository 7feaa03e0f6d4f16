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
//! - The project's own ride (`time_s,platform_x_m_s2,platform_y_m_s2,platform_z_m_s2`;
//!   `time_s,platform_x,platform_y,platform_z` before the columns carried their unit), s
//!   and m/s^2.

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
pub const KNOWN_FORMATS: [KnownFormat; 6] = [
    KnownFormat {
        name: "supine ride",
        columns: [
            "time_s",
            "platform_x_m_s2",
            "platform_y_m_s2",
            "platform_z_m_s2",
        ],
        time_unit: TimeUnit::S,
        units: AccelUnit::MS2,
    },
    // The same ride as written before its columns carried their unit.
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

/// Where a position file's (or a ride file's) time and position columns are.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct PositionColumns {
    /// Header name of the time column.
    pub time: String,
    /// Header name of the latitude column, degrees.
    pub lat: String,
    /// Header name of the longitude column, degrees.
    pub lon: String,
    /// Header names the ground speed (m/s) may have, the first found read.
    pub speed: Vec<String>,
    /// Header names the horizontal accuracy (m) may have, the first found read.
    pub accuracy: Vec<String>,
}

/// A recognized location file that phone apps write beside their accelerometer file.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct KnownPositionFormat {
    /// The app, as the account names it.
    pub name: &'static str,
    /// Header names of time, latitude, longitude.
    pub columns: [&'static str; 3],
    /// The time column's unit.
    pub time_unit: TimeUnit,
    /// Header names of the speed (m/s), any one of them.
    pub speed: &'static [&'static str],
    /// Header names of the horizontal accuracy (m), any one of them.
    pub accuracy: &'static [&'static str],
}

/// The location files recognized, from real exports in public repositories:
/// - Sensor Logger's `Location.csv` (`time,seconds_elapsed,bearingAccuracy,
///   speedAccuracy,verticalAccuracy,horizontalAccuracy,speed,bearing,altitude,longitude,
///   latitude`): `seconds_elapsed` is read, the clock its accelerometer file's
///   `seconds_elapsed` shares, so the two files join without an offset;
/// - phyphox's `Location.csv` (`"Time (s)","Latitude (°)","Longitude (°)","Height (m)",
///   "Velocity (m/s)","Direction (°)","Horizontal Accuracy (m)","Vertical Accuracy (m)"`;
///   newer versions write `"Speed (m/s)"`), seconds since the experiment's start, as its
///   acceleration files.
pub const KNOWN_POSITION_FORMATS: [KnownPositionFormat; 2] = [
    KnownPositionFormat {
        name: "Sensor Logger location",
        columns: ["seconds_elapsed", "latitude", "longitude"],
        time_unit: TimeUnit::S,
        speed: &["speed"],
        accuracy: &["horizontalAccuracy"],
    },
    KnownPositionFormat {
        name: "phyphox location",
        columns: ["Time (s)", "Latitude (°)", "Longitude (°)"],
        time_unit: TimeUnit::S,
        speed: &["Velocity (m/s)", "Speed (m/s)"],
        accuracy: &["Horizontal Accuracy (m)"],
    },
];

/// The location format whose time, latitude and longitude are all in `header`.
pub fn recognize_positions(header: &[String]) -> Option<&'static KnownPositionFormat> {
    KNOWN_POSITION_FORMATS
        .iter()
        .find(|f| f.columns.iter().all(|c| header.iter().any(|h| h == c)))
}

impl KnownPositionFormat {
    /// Its columns.
    pub fn columns(&self) -> PositionColumns {
        let owned = |names: &[&str]| names.iter().map(|n| n.to_string()).collect();
        PositionColumns {
            time: self.columns[0].to_string(),
            lat: self.columns[1].to_string(),
            lon: self.columns[2].to_string(),
            speed: owned(self.speed),
            accuracy: owned(self.accuracy),
        }
    }
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
            found("time_s,platform_x_m_s2,platform_y_m_s2,platform_z_m_s2"),
            Some("supine ride")
        );
        assert_eq!(
            found("time_s,platform_x,platform_y,platform_z"),
            Some("supine ride")
        );
        let position = |s: &str| recognize_positions(&names(s)).map(|f| f.name);
        assert_eq!(
            position(
                "time,seconds_elapsed,bearingAccuracy,speedAccuracy,verticalAccuracy,horizontalAccuracy,speed,bearing,altitude,longitude,latitude"
            ),
            Some("Sensor Logger location")
        );
        assert_eq!(
            position(
                "\"Time (s)\",\"Latitude (°)\",\"Longitude (°)\",\"Height (m)\",\"Velocity (m/s)\",\"Direction (°)\",\"Horizontal Accuracy (m)\",\"Vertical Accuracy (m)\""
            ),
            Some("phyphox location")
        );
        assert_eq!(position("time,seconds_elapsed,z,y,x"), None);
    }
}
