//! Road segments across missions: each leg's `"route"` segments (`report --json`, one per
//! 50 m of its track, with the head's exposure there) stored as passes over places, so
//! that passes of different missions over the same stretch of road meet.
//!
//! A leg's segments start wherever its track starts, so two missions' segments never share
//! ends; the archive keys a place instead by the square cell of about [`CELL_M`] that a
//! segment's midpoint falls in (rows of latitude [`CELL_M`] tall, each cut into cells
//! [`CELL_M`] wide at the row's middle latitude). A stretch of road driven by many
//! missions is then a handful of cells each with many passes.

use anyhow::{Result, anyhow};
use serde::Serialize;
use serde_json::Value;

/// Side of a place's cell, m: the report's segment length, so a pass lands in one or two.
pub const CELL_M: f64 = 50.0;

/// Metres per degree of latitude on the mean Earth sphere (radius 6,371,008.8 m).
const M_PER_DEG: f64 = 6_371_008.8 * std::f64::consts::PI / 180.0;

/// A place: its cell's row and column (the road segments table's key).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize)]
pub struct Cell {
    /// Row: `floor(lat_deg * M_PER_DEG / CELL_M)`.
    pub lat: i64,
    /// Column: `floor(lon_deg * M_PER_DEG * cos(row's middle latitude) / CELL_M)`.
    pub lon: i64,
}

impl Cell {
    /// The cell `lat_deg`, `lon_deg` falls in.
    pub fn of(lat_deg: f64, lon_deg: f64) -> Self {
        let lat = (lat_deg * M_PER_DEG / CELL_M).floor();
        let middle_deg = (lat + 0.5) * CELL_M / M_PER_DEG;
        // Near a pole a row's width shrinks to nothing: one cell per row there.
        let width_m = M_PER_DEG * middle_deg.to_radians().cos().max(1e-9);
        let lon = (lon_deg * width_m / CELL_M).floor();
        Self {
            lat: lat as i64,
            lon: lon as i64,
        }
    }
}

/// One pass of a leg over a road segment, as `report --json` gives it.
#[derive(Clone, Debug, PartialEq)]
pub struct Pass {
    /// The place.
    pub cell: Cell,
    /// Leg time at its start and end, s.
    pub start_s: f64,
    /// Leg time at its end, s.
    pub end_s: f64,
    /// Its midpoint, degrees.
    pub lat_deg: f64,
    /// Its midpoint, degrees.
    pub lon_deg: f64,
    /// Distance along the track, m.
    pub length_m: f64,
    /// Mean ground speed, m/s.
    pub speed_m_s: f64,
    /// The head's weighted vector rms there, m/s^2.
    pub rms_m_s2: f64,
    /// The head's VDV contribution there, m/s^1.75.
    pub vdv_m_s175: f64,
    /// The largest running rms there, m/s^2.
    pub max_running_rms_m_s2: f64,
}

/// The passes of a leg (`report --json`'s object for it): its `"route"`'s `"segments"`,
/// none when it has no route (no positions).
pub fn passes(leg: &Value) -> Result<Vec<Pass>> {
    let segments = match leg.get("route") {
        None | Some(Value::Null) => return Ok(Vec::new()),
        Some(route) => route
            .get("segments")
            .and_then(Value::as_array)
            .ok_or_else(|| anyhow!("the leg's route has no \"segments\" list"))?,
    };
    segments
        .iter()
        .enumerate()
        .map(|(i, s)| {
            let number = |key: &str| {
                s.get(key).and_then(Value::as_f64).ok_or_else(|| {
                    anyhow!(
                        "the leg's route segment {}: expected a number \"{key}\"",
                        i + 1
                    )
                })
            };
            let (lat_deg, lon_deg) = (number("lat_deg")?, number("lon_deg")?);
            Ok(Pass {
                cell: Cell::of(lat_deg, lon_deg),
                start_s: number("start_s")?,
                end_s: number("end_s")?,
                lat_deg,
                lon_deg,
                length_m: number("length_m")?,
                speed_m_s: number("speed_m_s")?,
                rms_m_s2: number("rms_m_s2")?,
                vdv_m_s175: number("vdv_m_s175")?,
                max_running_rms_m_s2: number("max_running_rms_m_s2")?,
            })
        })
        .collect()
}

/// A place over the missions of a view: its passes and the head's exposure there.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct RoadSegment {
    /// The place.
    pub cell: Cell,
    /// Where it is drawn: the first pass's midpoint, degrees.
    pub lat_deg: f64,
    /// Where it is drawn, degrees.
    pub lon_deg: f64,
    /// Passes over it.
    pub passes: i64,
    /// Missions that passed.
    pub missions: i64,
    /// The head's rms over every pass, each weighted by its time:
    /// `sqrt(sum rms_i^2 T_i / sum T_i)`, m/s^2.
    pub rms_m_s2: f64,
    /// The largest pass's rms, m/s^2.
    pub max_rms_m_s2: f64,
}

impl RoadSegment {
    /// From a place's sums: `energy` is `sum rms_i^2 T_i`, `seconds` `sum T_i`.
    pub fn from_sums(
        cell: Cell,
        (lat_deg, lon_deg): (f64, f64),
        (passes, missions): (i64, i64),
        energy: f64,
        seconds: f64,
        max_rms_m_s2: f64,
    ) -> Self {
        let rms_m_s2 = if seconds > 0.0 {
            (energy / seconds).sqrt()
        } else {
            max_rms_m_s2
        };
        Self {
            cell,
            lat_deg,
            lon_deg,
            passes,
            missions,
            rms_m_s2,
            max_rms_m_s2,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cells_are_about_fifty_metres_square() {
        // 0.0004 degrees of latitude is 44.5 m: the same row or the next, never further.
        let a = Cell::of(48.137_00, 11.575_00);
        let b = Cell::of(48.137_40, 11.575_00);
        assert!((b.lat - a.lat).abs() <= 1);
        // 100 m north is two rows; 100 m east (0.001344 deg at 48.137 N) two columns.
        assert_eq!(
            Cell::of(48.137_00 + 100.0 / M_PER_DEG, 11.575).lat - a.lat,
            2
        );
        let east = 100.0 / (M_PER_DEG * 48.137_f64.to_radians().cos());
        let c = Cell::of(48.137_00, 11.575_00 + east);
        assert!((1..=3).contains(&(c.lon - a.lon)), "{a:?} {c:?}");
        // The same point gives the same cell; the southern and western hemispheres too.
        assert_eq!(Cell::of(-33.86, -151.2), Cell::of(-33.86, -151.2));
        assert!(Cell::of(-33.86, -151.2).lat < 0 && Cell::of(-33.86, -151.2).lon < 0);
        // At a pole, one finite cell.
        let pole = Cell::of(90.0, 45.0);
        assert!(pole.lon.abs() < i64::MAX);
    }

    #[test]
    fn passes_come_from_the_route_segments_and_none_without_a_route() {
        assert!(
            passes(&serde_json::json!({"label": "leg 1"}))
                .unwrap()
                .is_empty()
        );
        assert!(
            passes(&serde_json::json!({"route": null}))
                .unwrap()
                .is_empty()
        );
        let leg = serde_json::json!({"route": {"segments": [
            {"start_s": 0.0, "end_s": 4.0, "lat_deg": 48.1, "lon_deg": 11.5, "length_m": 50.2,
             "speed_m_s": 12.5, "rms_m_s2": 0.4, "vdv_m_s175": 0.6,
             "max_running_rms_m_s2": 0.5, "time_at_level_s": {}}
        ]}});
        let p = passes(&leg).unwrap();
        assert_eq!(p.len(), 1);
        assert_eq!(p[0].cell, Cell::of(48.1, 11.5));
        assert_eq!((p[0].end_s, p[0].rms_m_s2), (4.0, 0.4));
        let bad = serde_json::json!({"route": {"segments": [{"start_s": 0.0}]}});
        let err = passes(&bad).unwrap_err().to_string();
        assert!(
            err.contains("segment 1: expected a number \"lat_deg\""),
            "{err}"
        );
    }

    #[test]
    fn a_places_rms_is_the_time_weighted_energy_mean() {
        // 1 s at 1 m/s^2 and 3 s at 2 m/s^2: sqrt((1 + 12) / 4).
        let s = RoadSegment::from_sums(Cell { lat: 0, lon: 0 }, (0.0, 0.0), (2, 2), 13.0, 4.0, 2.0);
        assert!((s.rms_m_s2 - (13.0_f64 / 4.0).sqrt()).abs() < 1e-15);
    }
}
