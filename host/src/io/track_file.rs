//! Position tracks from files (`docs/exposure.md#positions-and-road-segments`): a GPX
//! 1.1 file (`--gpx`, read by the `gpx` crate), a phone app's location CSV written
//! beside its accelerometer file (`--positions`, recognized by its header:
//! [`crate::ride::formats::KNOWN_POSITION_FORMATS`]), or the latitude and longitude
//! columns of the ride file itself (`--columns ...,lat=NAME,lon=NAME`).
//!
//! Every cell is checked and an error names the file, the line (a GPX file: the track
//! point) and the field; the fixes are then checked as a track ([`Track::new`]). A GPX
//! file is parsed whole, so it is refused above [`MAX_GPX_BYTES`]; a CSV is read a line
//! at a time.

use std::path::Path;

use anyhow::{Result, anyhow, bail};

use crate::io::csv_lines::{CsvLines, MAX_LINE_BYTES};
use crate::io::excerpt::{excerpt, quoted_name};
use crate::io::ride_rows::{read_header, unquoted_cells};
use crate::ride::clock::{Clock, TimeUnit};
use crate::ride::formats::{PositionColumns, recognize_positions};
use crate::ride::position::{Fix, Track, out_of_range};

/// Largest GPX file read, bytes: about 200,000 track points, 5.5 h at 10 Hz (a GPX
/// file is parsed whole).
pub const MAX_GPX_BYTES: u64 = 32 << 20;

/// The track in the GPX file at `path`: every track point of every track and segment,
/// in order, its time relative to the first point's (the ride's clock then starts with
/// the track, unless an offset says otherwise).
pub fn read_gpx(path: &Path) -> Result<Track> {
    let shown = path.display();
    let bytes = crate::io::small_file::read_text(path, "GPX file", MAX_GPX_BYTES)?;
    let gpx = gpx::read(bytes.as_bytes())
        .map_err(|e| anyhow!("{shown}: expected a GPX 1.1 file of track points, found: {e}"))?;
    let mut fixes = Vec::new();
    let mut origin: Option<time::OffsetDateTime> = None;
    let points = gpx
        .tracks
        .iter()
        .flat_map(|t| &t.segments)
        .flat_map(|s| &s.points);
    for (index, point) in points.enumerate() {
        let at = format!("{shown}: track point {}", index + 1);
        let time: time::OffsetDateTime = point
            .time
            .ok_or_else(|| anyhow!("{at}: expected a <time>, found none"))?
            .into();
        let first = *origin.get_or_insert(time);
        let p = point.point();
        let (lat, lon) = (p.y(), p.x());
        if let Some(why) = out_of_range(lat, lon) {
            bail!("{at}: {why}");
        }
        fixes.push(Fix {
            t_s: (time - first).as_seconds_f64(),
            lat_deg: lat,
            lon_deg: lon,
            speed_m_s: point.speed.filter(|s| s.is_finite() && *s >= 0.0),
            accuracy_m: None,
        });
    }
    if fixes.is_empty() {
        bail!("{shown}: expected GPX track points (<trk><trkseg><trkpt>), found none");
    }
    Track::new(fixes, &format!("{shown} (GPX)")).map_err(|e| anyhow!(e))
}

/// Writes `fixes` as a GPX 1.1 track at `path` (whole or not at all), their times from
/// `start` (UTC) on.
pub fn write_gpx(path: &Path, fixes: &[Fix], start: time::OffsetDateTime) -> Result<()> {
    let mut segment = gpx::TrackSegment::new();
    for f in fixes {
        let mut point = gpx::Waypoint::new(geo_types::Point::new(f.lon_deg, f.lat_deg));
        point.time = Some((start + time::Duration::seconds_f64(f.t_s)).into());
        segment.points.push(point);
    }
    let mut track = gpx::Track::new();
    track.segments.push(segment);
    let document = gpx::Gpx {
        version: gpx::GpxVersion::Gpx11,
        creator: Some("supine".to_string()),
        tracks: vec![track],
        ..gpx::Gpx::default()
    };
    crate::io::output::write_atomically(path, |w| {
        gpx::write(&document, w).map_err(|e| anyhow!("{}: cannot write GPX: {e}", path.display()))
    })
}

/// The track of a phone app's location CSV at `path`, recognized by its header.
pub fn read_positions(path: &Path) -> Result<Track> {
    let (_, header) = read_header(path)?;
    let known = recognize_positions(&header).ok_or_else(|| {
        anyhow!(
            "{}: line 1: expected a location file's header (Sensor Logger's Location.csv: \
             seconds_elapsed,...,longitude,latitude; phyphox's: \"Time (s)\",\"Latitude (°)\",...), found {}",
            path.display(),
            excerpt(header.join(","))
        )
    })?;
    read_position_columns(path, &known.columns(), known.time_unit, known.name)
}

/// A position file's track, or the GPX file's when `path` ends in `.gpx`.
pub fn read_track(path: &Path) -> Result<Track> {
    if path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("gpx"))
    {
        read_gpx(path)
    } else {
        read_positions(path)
    }
}

/// The fixes in `columns` of the CSV at `path`, time in `time_unit`; `name` says where
/// they came from. A row whose latitude or longitude cell is empty (a logger that writes
/// positions on some rows only) has no fix; a negative speed or accuracy is "not known"
/// (iOS writes -1).
pub fn read_position_columns(
    path: &Path,
    columns: &PositionColumns,
    time_unit: TimeUnit,
    name: &str,
) -> Result<Track> {
    let shown = path.display();
    let (delimiter, header) = read_header(path)?;
    let find = |wanted: &str| header.iter().position(|h| h == wanted);
    let need = |key: &str, wanted: &str| {
        find(wanted).ok_or_else(|| {
            anyhow!(
                "{shown}: line 1: {key}: expected a field {}, found {}",
                quoted_name(wanted),
                excerpt(header.join(","))
            )
        })
    };
    let time = need("time", &columns.time)?;
    let lat = need("lat", &columns.lat)?;
    let lon = need("lon", &columns.lon)?;
    let speed = columns.speed.iter().find_map(|n| find(n));
    let accuracy = columns.accuracy.iter().find_map(|n| find(n));
    let file = std::fs::File::open(path)
        .map_err(|e| anyhow!("{shown}: cannot read the positions: {e}"))?;
    let mut lines = CsvLines::with_delimiter(file, MAX_LINE_BYTES, delimiter);
    lines.next_line().map_err(|e| anyhow!("{shown}: {e}"))?;
    let mut clock = Clock::new(time_unit);
    let mut fixes = Vec::new();
    while let Some(line) = lines.next_line().map_err(|e| anyhow!("{shown}: {e}"))? {
        let number = line.line;
        let cells: Vec<Vec<u8>> = if memchr::memchr(b'"', line.text()).is_some() {
            unquoted_cells(line.text(), delimiter).ok_or_else(|| {
                anyhow!(
                    "{shown}: line {number}: expected RFC 4180 quoting, found an unclosed quote"
                )
            })?
        } else {
            line.split().cells().map(<[u8]>::to_vec).collect()
        };
        let cell = |k: usize| -> &[u8] {
            let c = cells.get(k).map_or(&[][..], Vec::as_slice);
            c.strip_suffix(b"\r").unwrap_or(c)
        };
        let text = |k: usize| std::str::from_utf8(cell(k)).unwrap_or("").trim();
        let number_in = |k: usize, field: &str, what: &str| -> Result<f64> {
            fast_float2::parse::<f64, _>(text(k))
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(|| {
                    anyhow!(
                        "{shown}: line {number}, column {}: expected {what}, found {}",
                        quoted_name(field),
                        excerpt(cell(k))
                    )
                })
        };
        let t_s = clock.seconds(text(time)).ok_or_else(|| {
            anyhow!(
                "{shown}: line {number}, column {}: expected {}, found {}",
                quoted_name(&columns.time),
                time_unit.expected(),
                excerpt(cell(time))
            )
        })?;
        // After the time, so a relative clock's origin is the file's first row.
        if text(lat).is_empty() && text(lon).is_empty() {
            continue;
        }
        let lat_deg = number_in(lat, &columns.lat, "a latitude in degrees")?;
        let lon_deg = number_in(lon, &columns.lon, "a longitude in degrees")?;
        if let Some(why) = out_of_range(lat_deg, lon_deg) {
            let field = if why.contains("latitude") {
                &columns.lat
            } else {
                &columns.lon
            };
            bail!(
                "{shown}: line {number}, column {}: {why}",
                quoted_name(field)
            );
        }
        let optional = |k: Option<usize>| {
            k.and_then(|k| fast_float2::parse::<f64, _>(text(k)).ok())
                .filter(|v| v.is_finite() && *v >= 0.0)
        };
        fixes.push(Fix {
            t_s,
            lat_deg,
            lon_deg,
            speed_m_s: optional(speed),
            accuracy_m: optional(accuracy),
        });
    }
    Track::new(fixes, &format!("{shown} ({name})")).map_err(|e| anyhow!(e))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn write(dir: &Path, name: &str, text: &str) -> std::path::PathBuf {
        let path = dir.join(name);
        std::fs::write(&path, text).unwrap();
        path
    }

    #[test]
    fn gpx_points_are_read_relative_to_the_first_and_bad_files_refused() {
        let dir = tempfile::tempdir().unwrap();
        let gpx = write(
            dir.path(),
            "t.gpx",
            r#"<?xml version="1.0"?>
<gpx version="1.1" creator="test" xmlns="http://www.topografix.com/GPX/1/1">
<trk><trkseg>
<trkpt lat="48.0" lon="11.0"><time>2024-06-10T14:45:36Z</time></trkpt>
<trkpt lat="48.0001" lon="11.0"><time>2024-06-10T14:45:37Z</time></trkpt>
<trkpt lat="48.0002" lon="11.0"><time>2024-06-10T14:45:38.5Z</time></trkpt>
</trkseg></trk></gpx>"#,
        );
        let track = read_gpx(&gpx).unwrap();
        let t: Vec<f64> = track.fixes().iter().map(|f| f.t_s).collect();
        assert_eq!(t, vec![0.0, 1.0, 2.5]);
        assert!(
            (track.length_m() - 22.24).abs() < 0.05,
            "{}",
            track.length_m()
        );

        let not_gpx = write(dir.path(), "n.gpx", "time,lat\n1,2\n");
        let e = read_gpx(&not_gpx).unwrap_err().to_string();
        assert!(e.contains("n.gpx: expected a GPX 1.1 file"), "{e}");
        let bad = write(
            dir.path(),
            "b.gpx",
            r#"<gpx version="1.1" creator="t"><trk><trkseg>
<trkpt lat="95.0" lon="11.0"><time>2024-06-10T14:45:36Z</time></trkpt>
</trkseg></trk></gpx>"#,
        );
        let e = read_gpx(&bad).unwrap_err().to_string();
        assert!(
            e.contains("b.gpx: expected a GPX 1.1 file") && e.contains("latitude"),
            "{e}"
        );
        assert_eq!(e.lines().count(), 1);
    }

    #[test]
    fn a_written_gpx_reads_back() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("w.gpx");
        let fixes: Vec<Fix> = (0..5)
            .map(|k| Fix {
                t_s: k as f64 * 0.5,
                lat_deg: 47.0 + k as f64 * 1e-4,
                lon_deg: -3.0,
                speed_m_s: None,
                accuracy_m: None,
            })
            .collect();
        write_gpx(&path, &fixes, time::macros::datetime!(2026-01-01 0:00 UTC)).unwrap();
        let back = read_gpx(&path).unwrap();
        assert_eq!(back.fixes(), &fixes[..]);
    }

    #[test]
    fn location_files_are_recognized_and_bad_cells_named() {
        let dir = tempfile::tempdir().unwrap();
        let sensor_logger = write(
            dir.path(),
            "Location.csv",
            "time,seconds_elapsed,bearingAccuracy,speedAccuracy,verticalAccuracy,horizontalAccuracy,speed,bearing,altitude,longitude,latitude\n\
             1718030736000000000,0.5,1,1,3,4.5,12.0,90,500,11.0,48.0\n\
             1718030737000000000,1.5,1,1,3,45.0,-1,90,500,11.0002,48.0\n",
        );
        let track = read_positions(&sensor_logger).unwrap();
        let f = track.fixes();
        assert_eq!((f[0].t_s, f[1].t_s), (0.5, 1.5));
        assert_eq!((f[0].speed_m_s, f[1].speed_m_s), (Some(12.0), None));
        assert_eq!(track.account().poor_accuracy, 1);

        let phyphox = write(
            dir.path(),
            "phyphox.csv",
            "\"Time (s)\",\"Latitude (°)\",\"Longitude (°)\",\"Height (m)\",\"Velocity (m/s)\",\"Direction (°)\",\"Horizontal Accuracy (m)\",\"Vertical Accuracy (m)\"\n\
             0.0,48.0,11.0,500,10,0,5,5\n\
             1.0,48.0,abc,500,10,0,5,5\n",
        );
        let e = read_positions(&phyphox).unwrap_err().to_string();
        assert!(
            e.contains("phyphox.csv: line 3, column ") && e.contains(": expected a longitude"),
            "{e}"
        );
        let other = write(dir.path(), "o.csv", "a,b\n1,2\n");
        let e = read_positions(&other).unwrap_err().to_string();
        assert!(
            e.contains("o.csv: line 1: expected a location file's header"),
            "{e}"
        );
    }
}
