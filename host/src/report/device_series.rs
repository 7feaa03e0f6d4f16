//! The device section's chart data, built as the session goes by: every series drawn in
//! a bounded number of points (the minimum and maximum of each pixel column,
//! [`crate::plot::downsample::MinMax`]), so a ten-hour session costs the same memory as a
//! minute's, and every peak keeps its height.

use supine_core::alerts::Level;
use supine_core::protocol::Telemetry;

use crate::plot::downsample::MinMax;
use crate::plot::time_chart::PLOT_COLUMNS;

/// A chart line's points, `(t_s, y)`.
pub type Points = Vec<(f64, f64)>;

/// One side's telemetry (the device's or the host's), ready to draw.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TraceSeries {
    /// Predicted head acceleration x, y, z, m/s^2.
    pub head_m_s2: [Points; 3],
    /// Weighted running rms per axis, m/s^2.
    pub running_rms_m_s2: [Points; 3],
    /// Vector sum of the weighted running rms, m/s^2.
    pub vector_rms_m_s2: Points,
    /// VDV of the vector sum so far, m/s^1.75.
    pub vdv_m_s175: Points,
    /// The alert level (0-3) of every record and held to the end, per column its lowest
    /// and highest: a change is a vertical step within its pixel column.
    pub level_steps: Points,
}

/// Builds a [`TraceSeries`] record by record.
#[derive(Clone, Debug)]
pub struct TraceSeriesBuilder {
    head_m_s2: [MinMax; 3],
    running_rms_m_s2: [MinMax; 3],
    vector_rms_m_s2: MinMax,
    vdv_m_s175: MinMax,
    level_steps: MinMax,
    last_level: Option<Level>,
}

impl TraceSeriesBuilder {
    /// For about `records` records (the columns are cut by that count).
    pub fn new(records: usize) -> Self {
        let column = || MinMax::new(records, PLOT_COLUMNS);
        Self {
            head_m_s2: [column(), column(), column()],
            running_rms_m_s2: [column(), column(), column()],
            vector_rms_m_s2: column(),
            vdv_m_s175: column(),
            // One more point: the level held to the end.
            level_steps: MinMax::new(records + 1, PLOT_COLUMNS),
            last_level: None,
        }
    }

    /// The next record, at `sample_rate_hz`.
    pub fn push(&mut self, t: &Telemetry, sample_rate_hz: f64) {
        let time_s = f64::from(t.sample_index) / sample_rate_hz;
        for axis in 0..3 {
            self.head_m_s2[axis].push(time_s, f64::from(t.head_acc_m_s2[axis]));
            self.running_rms_m_s2[axis].push(time_s, f64::from(t.running_rms_m_s2[axis]));
        }
        self.vector_rms_m_s2
            .push(time_s, f64::from(t.vector_running_rms_m_s2));
        self.vdv_m_s175.push(time_s, f64::from(t.vdv_m_s175));
        self.level_steps
            .push(time_s, f64::from(t.alert_level as u8));
        self.last_level = Some(t.alert_level);
    }

    /// The series, the level held to `end_s`.
    pub fn finish(self, end_s: f64) -> TraceSeries {
        let mut level_steps = self.level_steps;
        if let Some(l) = self.last_level {
            level_steps.push(end_s, f64::from(l as u8));
        }
        TraceSeries {
            head_m_s2: self.head_m_s2.map(MinMax::finish),
            running_rms_m_s2: self.running_rms_m_s2.map(MinMax::finish),
            vector_rms_m_s2: self.vector_rms_m_s2.finish(),
            vdv_m_s175: self.vdv_m_s175.finish(),
            level_steps: level_steps.finish(),
        }
    }
}

/// A device level event where the charts mark it: the device's vector running rms and
/// level in its record at the event's sample.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LevelMark {
    /// When, s.
    pub t_s: f64,
    /// The device's vector running rms then, m/s^2.
    pub vector_rms_m_s2: f64,
    /// The level the event went to.
    pub level: Level,
    /// Raised (else lowered).
    pub raised: bool,
}

/// Everything the device section draws.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct DeviceSeries {
    /// The litter-frame input streamed, x, y, z, m/s^2 (time from the first sample).
    pub input_m_s2: [Points; 3],
    /// The f64 model's head for every sample, x, y, z, m/s^2 (time from the first sample).
    pub head_f64_m_s2: [Points; 3],
    /// What the device sent.
    pub device: TraceSeries,
    /// The host's run of the same f32 pipeline.
    pub host: TraceSeries,
    /// The device's level events that have a record at their sample.
    pub level_marks: Vec<LevelMark>,
}

#[cfg(test)]
mod tests {
    use super::*;
    use supine_core::alerts::FaultFlags;

    #[test]
    fn levels_are_drawn_record_by_record_and_held_to_the_end() {
        let levels = [Level::Normal, Level::Normal, Level::Warning, Level::Normal];
        let mut b = TraceSeriesBuilder::new(levels.len());
        for (k, level) in levels.into_iter().enumerate() {
            let t = Telemetry {
                sample_index: k as u32,
                head_acc_m_s2: [0.0; 3],
                running_rms_m_s2: [0.0; 3],
                vector_running_rms_m_s2: 0.0,
                vdv_m_s175: 0.0,
                alert_level: level,
                fault_flags: FaultFlags::empty(),
                valid: true,
                joints: supine_core::joint_exposure::JointValues::EMPTY,
            };
            b.push(&t, 1.0);
        }
        assert_eq!(
            b.finish(4.0).level_steps,
            vec![(0.0, 0.0), (1.0, 0.0), (2.0, 2.0), (3.0, 0.0), (4.0, 0.0)]
        );
    }

    #[test]
    fn a_level_that_changes_all_session_long_stays_bounded() {
        let n = 200_000;
        let mut b = TraceSeriesBuilder::new(n);
        for k in 0..n {
            let level = if (k / 50) % 2 == 0 {
                Level::Normal
            } else {
                Level::Alarm
            };
            let t = Telemetry {
                sample_index: k as u32,
                head_acc_m_s2: [0.0; 3],
                running_rms_m_s2: [0.0; 3],
                vector_running_rms_m_s2: 0.0,
                vdv_m_s175: 0.0,
                alert_level: level,
                fault_flags: FaultFlags::empty(),
                valid: true,
                joints: supine_core::joint_exposure::JointValues::EMPTY,
            };
            b.push(&t, 100.0);
        }
        let steps = b.finish(n as f64 / 100.0).level_steps;
        assert!(steps.len() <= 2 * PLOT_COLUMNS, "{} points", steps.len());
        assert!(steps.iter().any(|p| p.1 == 3.0) && steps.iter().any(|p| p.1 == 0.0));
    }
}
