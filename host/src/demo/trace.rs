//! Telemetry as columns: what the device sent (read back from the CSV files the demo
//! wrote, so the report shows exactly what a user can open) and what the host computed.
//!
//! Reading the files back rather than keeping the messages makes the CSVs the report's
//! single source: a number in the report can always be found in a file beside it.

use std::path::Path;

use anyhow::{Result, anyhow, bail};
use supine_core::alerts::{AlertEvent, FaultFlags, Level};
use supine_core::protocol::Telemetry;

use crate::replay::{EVENTS_HEADER, TELEMETRY_HEADER};

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

    /// Reads a telemetry CSV ([`TELEMETRY_HEADER`]) written at `sample_rate_hz`. Values
    /// were written in f32's shortest round-trip form, so they read back exactly.
    pub fn read_csv(path: &Path, sample_rate_hz: f64) -> Result<Self> {
        let text = std::fs::read_to_string(path)
            .map_err(|e| anyhow!("{}: cannot read: {e}", path.display()))?;
        let mut lines = text.lines();
        match lines.next() {
            Some(TELEMETRY_HEADER) => {}
            other => bail!(
                "{}: line 1: expected the header \"{TELEMETRY_HEADER}\", found \"{}\"",
                path.display(),
                other.unwrap_or("")
            ),
        }
        let mut trace = Self::default();
        for (k, line) in lines.enumerate() {
            let at = || format!("{}: line {}", path.display(), k + 2);
            let cells: Vec<&str> = line.split(',').collect();
            if cells.len() != 13 {
                bail!("{}: expected 13 cells, found {}", at(), cells.len());
            }
            let num = |i: usize| -> Result<f32> {
                cells[i].parse::<f32>().map_err(|_| {
                    anyhow!(
                        "{}, cell {}: expected a number, found \"{}\"",
                        at(),
                        i + 1,
                        cells[i]
                    )
                })
            };
            let sample: u32 = cells[0].parse().map_err(|_| {
                anyhow!(
                    "{}, column sample: expected an index, found \"{}\"",
                    at(),
                    cells[0]
                )
            })?;
            let level = level_from_name(cells[10])
                .ok_or_else(|| anyhow!("{}, column alert_level: expected normal, advisory, warning or alarm, found \"{}\"", at(), cells[10]))?;
            let fault_flags = cells[11]
                .parse()
                .ok()
                .and_then(FaultFlags::try_from_repr)
                .ok_or_else(|| {
                    anyhow!(
                        "{}, column fault_flags: expected 0..={}, found \"{}\"",
                        at(),
                        FaultFlags::all().as_repr(),
                        cells[11]
                    )
                })?;
            let valid = match cells[12] {
                "0" => false,
                "1" => true,
                other => bail!("{}, column valid: expected 0 or 1, found \"{other}\"", at()),
            };
            let t = Telemetry {
                sample_index: sample,
                head_acc_m_s2: [num(2)?, num(3)?, num(4)?],
                running_rms_m_s2: [num(5)?, num(6)?, num(7)?],
                vector_running_rms_m_s2: num(8)?,
                vdv_m_s175: num(9)?,
                alert_level: level,
                fault_flags,
                valid,
            };
            trace.push(&t, sample_rate_hz);
        }
        Ok(trace)
    }
}

/// The level named `name` (`normal`, `advisory`, `warning`, `alarm`).
pub fn level_from_name(name: &str) -> Option<Level> {
    [Level::Normal, Level::Advisory, Level::Warning, Level::Alarm]
        .into_iter()
        .find(|l| l.name() == name)
}

/// One row of an events CSV ([`EVENTS_HEADER`]).
#[derive(Clone, Debug, PartialEq)]
pub struct EventRow {
    /// Sample index the event is stamped with.
    pub sample: u32,
    /// Its time from sample 0, s.
    pub time_s: f64,
    /// `level` or `fault`.
    pub kind: String,
    /// The level reached (`kind` level) or the fault's name.
    pub name: String,
    /// Raised (rather than cleared).
    pub raised: bool,
}

impl EventRow {
    /// The row [`crate::replay::event_row`] writes for `e`, at `sample_rate_hz`.
    pub fn from_event(e: &AlertEvent, sample_rate_hz: f64) -> Self {
        let (kind, name) = match *e {
            AlertEvent::Level { to, .. } => ("level", to.name()),
            AlertEvent::Fault { fault, .. } => ("fault", fault.name()),
        };
        Self {
            sample: e.at_sample(),
            time_s: f64::from(e.at_sample()) / sample_rate_hz,
            kind: kind.to_string(),
            name: name.to_string(),
            raised: e.is_raise(),
        }
    }

    /// What happened, in words (`warning raised`, `stuck cleared`, `back to normal`).
    pub fn text(&self) -> String {
        match (self.kind.as_str(), self.raised) {
            ("level", true) => format!("level raised to {}", self.name),
            ("level", false) => format!("level lowered to {}", self.name),
            (_, true) => format!("sensor fault {} raised", self.name),
            (_, false) => format!("sensor fault {} cleared", self.name),
        }
    }
}

/// Reads an events CSV ([`EVENTS_HEADER`]) written at `sample_rate_hz`.
pub fn read_events(path: &Path, sample_rate_hz: f64) -> Result<Vec<EventRow>> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| anyhow!("{}: cannot read: {e}", path.display()))?;
    let mut lines = text.lines();
    match lines.next() {
        Some(EVENTS_HEADER) => {}
        other => bail!(
            "{}: line 1: expected the header \"{EVENTS_HEADER}\", found \"{}\"",
            path.display(),
            other.unwrap_or("")
        ),
    }
    lines
        .enumerate()
        .map(|(k, line)| {
            let at = format!("{}: line {}", path.display(), k + 2);
            let cells: Vec<&str> = line.split(',').collect();
            let [sample, _time, kind, name, raised] = cells[..] else {
                bail!("{at}: expected 5 cells, found {}", cells.len());
            };
            let sample: u32 = sample.parse().map_err(|_| {
                anyhow!("{at}, column sample: expected an index, found \"{sample}\"")
            })?;
            if kind != "level" && kind != "fault" {
                bail!("{at}, column kind: expected level or fault, found \"{kind}\"");
            }
            let raised = match raised {
                "0" => false,
                "1" => true,
                other => bail!("{at}, column raised: expected 0 or 1, found \"{other}\""),
            };
            Ok(EventRow {
                sample,
                time_s: f64::from(sample) / sample_rate_hz,
                kind: kind.to_string(),
                name: name.to_string(),
                raised,
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::replay::{event_row, telemetry_row};
    use supine_core::alerts::SensorFault;

    #[test]
    fn telemetry_and_events_read_back_exactly_what_was_written() {
        let t = Telemetry {
            sample_index: 1234,
            head_acc_m_s2: [0.1, -2.5e-7, 3.3333333],
            running_rms_m_s2: [0.123_456_7, 1e-9, 7.0],
            vector_running_rms_m_s2: 7.001,
            vdv_m_s175: 2.25,
            alert_level: Level::Warning,
            fault_flags: SensorFault::Stuck.into(),
            valid: true,
        };
        let dir = tempfile::tempdir().expect("temp dir");
        let path = dir.path().join("device.csv");
        let text = format!("{TELEMETRY_HEADER}\n{}", telemetry_row(&t, 500.0));
        std::fs::write(&path, text).expect("write");
        let trace = Trace::read_csv(&path, 500.0).expect("read");
        assert_eq!(trace, Trace::from_telemetry(&[t], 500.0));

        let e = AlertEvent::Fault {
            fault: SensorFault::Stuck,
            active: false,
            at_sample: 900,
        };
        let path = dir.path().join("device.events.csv");
        std::fs::write(&path, format!("{EVENTS_HEADER}\n{}", event_row(&e, 500.0))).expect("write");
        let events = read_events(&path, 500.0).expect("read");
        assert_eq!(events.len(), 1);
        assert_eq!(events[0].sample, 900);
        assert!((events[0].time_s - 1.8).abs() < 1e-12);
        assert_eq!(events[0].text(), "sensor fault stuck cleared");
        assert_eq!(events[0], EventRow::from_event(&e, 500.0));
    }

    #[test]
    fn a_bad_cell_names_the_file_line_and_column() {
        let dir = tempfile::tempdir().expect("temp dir");
        let path = dir.path().join("device.csv");
        std::fs::write(
            &path,
            format!("{TELEMETRY_HEADER}\n1,0.002,0,0,0,0,0,0,0,0,loud,0,1\n"),
        )
        .expect("write");
        let err = Trace::read_csv(&path, 500.0)
            .expect_err("bad level")
            .to_string();
        assert!(err.contains("line 2, column alert_level"), "{err}");
    }
}
