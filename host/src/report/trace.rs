//! Telemetry as columns: what a device sent (read back from the CSV files its monitor
//! wrote with [`crate::io::telemetry_csv`], so the report shows exactly what a user can
//! open) and what the host computed on the same samples.
//!
//! Reading the files back rather than keeping the messages makes the CSVs the report's
//! single source: a number in the report can always be found in a file beside it.

use supine_core::alerts::{FaultFlags, Level};
use supine_core::protocol::Telemetry;

/// Telemetry records as columns, in sample order.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Trace {
    /// Sample index of each record.
    pub sample: Vec<u32>,
    /// Time of each record from sample 0, s.
    pub time_s: Vec<f64>,
    /// Predicted head acceleration x, y, z, m/s^2.
    pub head_m_s2: [Vec<f64>; 3],
    /// Weighted running rms per axis, m/s^2.
    pub running_rms_m_s2: [Vec<f64>; 3],
    /// Vector sum of the weighted running rms, m/s^2.
    pub vector_rms_m_s2: Vec<f64>,
    /// VDV of the vector sum so far, m/s^1.75.
    pub vdv_m_s175: Vec<f64>,
    /// Exposure alert level.
    pub level: Vec<Level>,
    /// Active sensor faults.
    pub fault_flags: Vec<FaultFlags>,
    /// Exposure values are valid (warm-up over).
    pub valid: Vec<bool>,
}

impl Trace {
    /// Number of records.
    pub fn len(&self) -> usize {
        self.sample.len()
    }

    /// Whether there are no records.
    pub fn is_empty(&self) -> bool {
        self.sample.is_empty()
    }

    fn push(&mut self, t: &Telemetry, sample_rate_hz: f64) {
        self.sample.push(t.sample_index);
        self.time_s.push(f64::from(t.sample_index) / sample_rate_hz);
        for axis in 0..3 {
            self.head_m_s2[axis].push(f64::from(t.head_acc_m_s2[axis]));
            self.running_rms_m_s2[axis].push(f64::from(t.running_rms_m_s2[axis]));
        }
        self.vector_rms_m_s2
            .push(f64::from(t.vector_running_rms_m_s2));
        self.vdv_m_s175.push(f64::from(t.vdv_m_s175));
        self.level.push(t.alert_level);
        self.fault_flags.push(t.fault_flags);
        self.valid.push(t.valid);
    }

    /// Columns of `telemetry` (records at `sample_rate_hz`).
    pub fn from_telemetry(telemetry: &[Telemetry], sample_rate_hz: f64) -> Self {
        let mut trace = Self::default();
        for t in telemetry {
            trace.push(t, sample_rate_hz);
        }
        trace
    }
}
