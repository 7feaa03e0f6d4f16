//! The per-second series kept for each leg: what the fleet view and later analyses
//! (road segments, time of day) need of a leg's course, at one row a second: the head's
//! vector running rms, its VDV, the alert level and the joint outputs' running rms.
//!
//! Taken from the report's chart series (`report::mission::LegSeries`, ten points a second
//! or, for legs over 27 minutes, fewer), not recomputed: a second's row holds the largest
//! value of the chart points in it (the VDV only grows, so its largest is its last). A
//! second with no chart point (a leg so long that its chart buckets exceed a second)
//! repeats the row before it. Stored as one blob per leg, little-endian `f32`, row after
//! row, since nothing queries single seconds by value; `columns` names them.

use anyhow::{Result, bail};

use crate::report::mission::Leg;

/// A leg's seconds: `rows` rows of `columns.len()` values.
#[derive(Clone, Debug, PartialEq)]
pub struct SecondSeries {
    /// The column names, with their units.
    pub columns: Vec<String>,
    /// Row-major values.
    pub values: Vec<f32>,
}

impl SecondSeries {
    /// The series of `leg`.
    pub fn of_leg(leg: &Leg) -> Self {
        let mut columns = vec![
            "head_running_rms_m_s2".to_string(),
            "vdv_m_s175".to_string(),
            "level".to_string(),
        ];
        columns.extend(
            leg.joints
                .iter()
                .map(|j| format!("{}_running_rms_{}", j.output, j.unit)),
        );
        let width = columns.len();
        let seconds = leg.duration_s.ceil().max(0.0) as usize;
        let s = &leg.series;
        let mut values = vec![0.0_f32; seconds * width];
        let mut filled = vec![false; seconds];
        for (i, &t) in s.t_s.iter().enumerate() {
            // The leg's end point belongs to its last second.
            let second = (t.floor() as usize).min(seconds.saturating_sub(1));
            if seconds == 0 {
                break;
            }
            let row = &mut values[second * width..(second + 1) * width];
            let joints = s.joint_running_rms.get(i);
            let point = [s.vector_rms_m_s2[i], s.vdv_m_s175[i], f64::from(s.level[i])]
                .into_iter()
                .chain(
                    joints
                        .into_iter()
                        .flat_map(|j| j.iter().copied())
                        .take(width - 3),
                );
            for (cell, v) in row.iter_mut().zip(point) {
                let v = v as f32;
                *cell = if filled[second] { cell.max(v) } else { v };
            }
            filled[second] = true;
        }
        for second in 1..seconds {
            if !filled[second] {
                let (before, after) = values.split_at_mut(second * width);
                after[..width].copy_from_slice(&before[(second - 1) * width..]);
            }
        }
        Self { columns, values }
    }

    /// Rows (seconds).
    pub fn rows(&self) -> usize {
        self.values.len() / self.columns.len().max(1)
    }

    /// The blob: the values as little-endian `f32`.
    pub fn to_blob(&self) -> Vec<u8> {
        self.values.iter().flat_map(|v| v.to_le_bytes()).collect()
    }

    /// Reads a blob stored with `columns` (comma-separated) and `rows`.
    pub fn from_blob(columns: &str, rows: usize, blob: &[u8]) -> Result<Self> {
        let columns: Vec<String> = columns.split(',').map(str::to_string).collect();
        if blob.len() != rows * columns.len() * 4 {
            bail!(
                "a leg's series has {} bytes, expected {} ({rows} seconds of {} columns)",
                blob.len(),
                rows * columns.len() * 4,
                columns.len()
            );
        }
        let values = blob
            .chunks_exact(4)
            .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
            .collect();
        Ok(Self { columns, values })
    }

    /// Column `name`'s values, one a second.
    pub fn column(&self, name: &str) -> Option<Vec<f32>> {
        let k = self.columns.iter().position(|c| c == name)?;
        let width = self.columns.len();
        Some(self.values.iter().skip(k).step_by(width).copied().collect())
    }
}
