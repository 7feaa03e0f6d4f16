//! Road segments across missions: each leg's `"route"` segments (`report --json`, one per
//! 50 m of its track, with the head's exposure there) stored as passes over places, so
//! that passes of different missions over the same stretch of road meet.
//!
//! A leg's segments start wherever its track starts, so two missions' segments never share
//! ends; the archive keys a place instead by the square cell of about [`CELL_M`] that a
//! segment's midpoint falls in (rows of latitude [`CELL_M`] tall, each cut into cells
//! [`CELL_M`] wide at the row's middle latitude). A stretch of road driven by many
//! missions is then a handful of cells each with many passes.

use serde::Serialize;

use crate::report::route::{SEGMENT_LENGTH_M, Segment};
use crate::ride::position::EARTH_RADIUS_M;

/// Side of a place's cell, m: the report's segment length, so a pass lands in one or two.
pub const CELL_M: f64 = SEGMENT_LENGTH_M;

/// Metres per degree of latitude on the mean Earth sphere.
const M_PER_DEG: f64 = EARTH_RADIUS_M * std::f64::consts::PI / 180.0;

/// A place: its cell's row and column (the road segments table's key, `cell_row` and
/// `cell_column`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize)]
pub struct Cell {
    /// Row: `floor(lat_deg * M_PER_DEG / CELL_M)`.
    pub row: i64,
    /// Column: `floor(lon_deg * M_PER_DEG * cos(row's middle latitude) / CELL_M)`.
    pub column: i64,
}

impl Cell {
    /// The cell `lat_deg`, `lon_deg` falls in.
    pub fn of(lat_deg: f64, lon_deg: f64) -> Self {
        let row = (lat_deg * M_PER_DEG / CELL_M).floor();
        let middle_deg = (row + 0.5) * CELL_M / M_PER_DEG;
        // Near a pole a row's width shrinks to nothing: one cell per row there.
        let width_m = M_PER_DEG * middle_deg.to_radians().cos().max(1e-9);
        let column = (lon_deg * width_m / CELL_M).floor();
        Self {
            row: row as i64,
            column: column as i64,
        }
    }
}

/// One pass of a leg over a road segment: the report's segment and the place it is in.
#[derive(Clone, Debug, PartialEq)]
pub struct Pass {
    /// The place its midpoint falls in.
    pub cell: Cell,
    /// The segment, as `report --json`'s `"route"` gives it.
    pub segment: Segment,
}

/// The passes of a leg whose route has `segments` (none without positions).
pub fn passes(segments: &[Segment]) -> Vec<Pass> {
    segments
        .iter()
        .map(|segment| Pass {
            cell: Cell::of(segment.lat_deg, segment.lon_deg),
            segment: segment.clone(),
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
        assert!((b.row - a.row).abs() <= 1);
        // 100 m north is two rows; 100 m east (0.001344 deg at 48.137 N) two columns.
        assert_eq!(
            Cell::of(48.137_00 + 100.0 / M_PER_DEG, 11.575).row - a.row,
            2
        );
        let east = 100.0 / (M_PER_DEG * 48.137_f64.to_radians().cos());
        let c = Cell::of(48.137_00, 11.575_00 + east);
        assert!((1..=3).contains(&(c.column - a.column)), "{a:?} {c:?}");
        // The same point gives the same cell; the southern and western hemispheres too.
        assert_eq!(Cell::of(-33.86, -151.2), Cell::of(-33.86, -151.2));
        assert!(Cell::of(-33.86, -151.2).row < 0 && Cell::of(-33.86, -151.2).column < 0);
        // At a pole, one finite cell.
        let pole = Cell::of(90.0, 45.0);
        assert!(pole.column.abs() < i64::MAX);
    }

    #[test]
    fn a_pass_is_its_segment_in_the_cell_of_its_midpoint() {
        let segment = |lat_deg, lon_deg| Segment {
            start_s: 0.0,
            end_s: 4.0,
            lat_deg,
            lon_deg,
            length_m: 50.2,
            speed_m_s: 12.5,
            rms_m_s2: 0.4,
            vdv_m_s175: 0.6,
            max_running_rms_m_s2: 0.5,
            time_at_level_s: Default::default(),
            largest_joint_excursions: None,
            evaluated_s: 4.0,
        };
        assert!(passes(&[]).is_empty());
        let segments = [segment(48.1, 11.5), segment(-33.86, -151.2)];
        let p = passes(&segments);
        assert_eq!(p.len(), 2);
        assert_eq!(p[0].cell, Cell::of(48.1, 11.5));
        assert_eq!(p[1].cell, Cell::of(-33.86, -151.2));
        assert_eq!(p[1].segment, segments[1]);
    }

    #[test]
    fn a_places_rms_is_the_time_weighted_energy_mean() {
        // 1 s at 1 m/s^2 and 3 s at 2 m/s^2: sqrt((1 + 12) / 4).
        let s = RoadSegment::from_sums(
            Cell { row: 0, column: 0 },
            (0.0, 0.0),
            (2, 2),
            13.0,
            4.0,
            2.0,
        );
        assert!((s.rms_m_s2 - (13.0_f64 / 4.0).sqrt()).abs() < 1e-15);
    }
}
