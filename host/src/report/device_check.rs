//! A device's own account of a ride beside the host's: what the device sent (its
//! telemetry and alert events, as its monitor logged them) and what the host computed on
//! the same samples with the same f32 code and with the f64 model. [`Check`] is how far
//! apart they are; the report shows it as a section of its own when a device log is given
//! ([`crate::report::device_section`]).

use std::time::Duration;

use supine_core::alerts::Level;
use supine_core::protocol::Status;

use crate::device::link::LinkStats;
use crate::io::telemetry_csv::{EventRow, level_from_name};
use crate::plot::time_chart::{Band, Moment};
use crate::report::trace::Trace;

/// How the device run was made, in the device's own words and the host's counters.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct DeviceRun {
    /// One sentence on what was done (which ride went to which device, how).
    pub account: String,
    /// The device in one line (firmware, protocol, parameters and their source, rate).
    pub device_line: String,
    /// The firmware's version from its greeting.
    pub firmware_version: String,
    /// The device's last status.
    pub status: Option<Status>,
    /// Frames the host decoded, lost, bad and reordered.
    pub link: LinkStats,
    /// Wall time of each step of the run.
    pub step_times: Vec<(String, Duration)>,
    /// Further facts of the run (what, plain text), listed as they are.
    pub notes: Vec<(String, String)>,
    /// The files beside the report (file name, what it holds).
    pub files: Vec<(String, String)>,
}

/// What the device sent for one ride and what the host computed on the same samples.
#[derive(Clone, Debug, PartialEq)]
pub struct DeviceLog {
    /// How the run was made.
    pub run: DeviceRun,
    /// Sample rate, Hz.
    pub sample_rate_hz: f64,
    /// Samples streamed to the device.
    pub samples: usize,
    /// The litter-frame input streamed, x, y, z, m/s^2.
    pub input_m_s2: [Vec<f64>; 3],
    /// Stretches of the ride worth marking on the charts (road surfaces).
    pub bands: Vec<Band>,
    /// Instants worth marking (shocks).
    pub moments: Vec<Moment>,
    /// What the device sent (read back from its telemetry CSV).
    pub device: Trace,
    /// The device's alert events (read back from its events CSV).
    pub device_events: Vec<EventRow>,
    /// The host's run of the device pipeline (f32, the same code) on the same samples,
    /// with the device's telemetry decimation.
    pub host: Trace,
    /// The host pipeline's alert events.
    pub host_events: Vec<EventRow>,
    /// The f64 model's head acceleration for every sample, m/s^2 (the first is the
    /// sample the host's run starts at, `host.sample[0]`).
    pub host_head_f64_m_s2: [Vec<f64>; 3],
}

impl DeviceLog {
    /// Duration of the ride streamed, s.
    pub fn duration_s(&self) -> f64 {
        self.samples as f64 / self.sample_rate_hz
    }
}

/// How the device's account compares with the host's, and what the device reported.
#[derive(Clone, Debug, PartialEq)]
pub struct Check {
    /// Largest valid vector running rms in the device's telemetry (its MTVV), m/s^2.
    pub device_mtvv_m_s2: f64,
    /// The device's VDV of the vector sum at its last record, m/s^1.75.
    pub device_vdv_m_s175: f64,
    /// Highest level in the device's telemetry.
    pub highest_level: Level,
    /// When it was first reached (from the device's events), s.
    pub highest_at_s: Option<f64>,
    /// The level at the device's last record.
    pub final_level: Level,
    /// When the level last went back down to normal, s.
    pub cleared_at_s: Option<f64>,
    /// Level events (raises and clears) the device sent.
    pub level_events: usize,
    /// Sensor faults the device raised, in order (name and time, s).
    pub faults: Vec<(String, f64)>,
    /// Largest |device head - host head| with the host running the same f32 pipeline,
    /// m/s^2 (0 expected: the same code on the same inputs).
    pub head_diff_f32_m_s2: f64,
    /// Largest |device head - f64 model head|, m/s^2 (the device's numerical accuracy).
    pub head_diff_f64_m_s2: f64,
    /// Largest |device - host| vector running rms, m/s^2.
    pub rms_diff_m_s2: f64,
    /// The device's and the host's alert events are the same (sample, kind, name).
    pub events_agree: bool,
    /// The device sent a record for every sample the host computed one for (every
    /// `decimation`-th), and the host's run covers every sample.
    pub records_complete: bool,
}

/// Largest |a - b|; infinite when the series differ in length (a record is missing).
fn max_abs_diff(a: &[f64], b: &[f64]) -> f64 {
    if a.len() != b.len() {
        return f64::INFINITY;
    }
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max)
}

fn same_events(a: &[EventRow], b: &[EventRow]) -> bool {
    a.len() == b.len()
        && a.iter().zip(b).all(|(x, y)| {
            x.sample == y.sample && x.kind == y.kind && x.name == y.name && x.raised == y.raised
        })
}

impl Check {
    /// Compares the device's account in `log` with the host's.
    pub fn new(log: &DeviceLog) -> Self {
        let d = &log.device;
        let device_mtvv_m_s2 = d
            .vector_rms_m_s2
            .iter()
            .zip(&d.valid)
            .filter(|(_, v)| **v)
            .map(|(x, _)| *x)
            .fold(0.0, f64::max);
        let highest_level = d.level.iter().copied().max().unwrap_or(Level::Normal);
        let highest_at_s = log
            .device_events
            .iter()
            .find(|e| {
                e.kind == "level" && e.raised && level_from_name(&e.name) == Some(highest_level)
            })
            .map(|e| e.time_s);
        let cleared_at_s = log
            .device_events
            .iter()
            .rev()
            .find(|e| e.kind == "level" && e.name == "normal")
            .map(|e| e.time_s);
        let head_diff = |host: &[Vec<f64>; 3]| {
            (0..3)
                .map(|a| max_abs_diff(&d.head_m_s2[a], &host[a]))
                .fold(0.0, f64::max)
        };
        // The f64 model has a value for every sample: the device's records pick theirs.
        let first = log.host.sample.first().copied().unwrap_or(0);
        let f64_at_records: [Vec<f64>; 3] = log.host_head_f64_m_s2.each_ref().map(|axis| {
            d.sample
                .iter()
                .map(|&k| {
                    k.checked_sub(first)
                        .and_then(|i| axis.get(i as usize))
                        .copied()
                        .unwrap_or(f64::INFINITY)
                })
                .collect()
        });
        Self {
            device_mtvv_m_s2,
            device_vdv_m_s175: d.vdv_m_s175.last().copied().unwrap_or(0.0),
            highest_level,
            highest_at_s,
            final_level: d.level.last().copied().unwrap_or(Level::Normal),
            cleared_at_s,
            level_events: log
                .device_events
                .iter()
                .filter(|e| e.kind == "level")
                .count(),
            faults: log
                .device_events
                .iter()
                .filter(|e| e.kind == "fault" && e.raised)
                .map(|e| (e.name.clone(), e.time_s))
                .collect(),
            head_diff_f32_m_s2: head_diff(&log.host.head_m_s2),
            head_diff_f64_m_s2: head_diff(&f64_at_records),
            rms_diff_m_s2: max_abs_diff(&d.vector_rms_m_s2, &log.host.vector_rms_m_s2),
            events_agree: same_events(&log.device_events, &log.host_events),
            records_complete: d.sample == log.host.sample
                && log
                    .host_head_f64_m_s2
                    .iter()
                    .all(|a| a.len() == log.samples),
        }
    }

    /// The device and the host agree: the same head bit for bit, the same events, every
    /// record there.
    pub fn agree(&self) -> bool {
        self.events_agree && self.head_diff_f32_m_s2 == 0.0 && self.records_complete
    }
}

/// A largest difference: `0 (bit for bit)` when exact, else two digits and the unit.
pub fn difference(v: f64, unit: &str) -> String {
    if v == 0.0 {
        "0 (bit for bit)".to_string()
    } else {
        format!("{v:.1e} {unit}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use supine_core::alerts::{AlertEvent, Criterion, FaultFlags};
    use supine_core::protocol::Telemetry;

    fn record(k: u32, head_z: f32, level: Level) -> Telemetry {
        Telemetry {
            sample_index: k,
            head_acc_m_s2: [0.0, 0.0, head_z],
            running_rms_m_s2: [0.0, 0.0, 0.5],
            vector_running_rms_m_s2: 0.5 + k as f32 * 0.01,
            vdv_m_s175: k as f32,
            alert_level: level,
            fault_flags: FaultFlags::empty(),
            valid: k >= 2,
            joints: supine_core::joint_exposure::JointValues::EMPTY,
        }
    }

    fn log(device: &[Telemetry], host: &[Telemetry], events: &[AlertEvent]) -> DeviceLog {
        let rows: Vec<EventRow> = events
            .iter()
            .map(|e| EventRow::from_event(e, 10.0))
            .collect();
        let host = Trace::from_telemetry(host, 10.0);
        DeviceLog {
            run: DeviceRun::default(),
            sample_rate_hz: 10.0,
            samples: 5,
            input_m_s2: Default::default(),
            bands: Vec::new(),
            moments: Vec::new(),
            device: Trace::from_telemetry(device, 10.0),
            device_events: rows.clone(),
            host_head_f64_m_s2: host.head_m_s2.clone(),
            host,
            host_events: rows,
        }
    }

    #[test]
    fn a_device_head_that_differs_by_one_f32_step_is_reported_and_levels_are_timed() {
        let levels = [
            Level::Normal,
            Level::Warning,
            Level::Warning,
            Level::Normal,
            Level::Normal,
        ];
        let host: Vec<Telemetry> = (0..5).map(|k| record(k, 1.0, levels[k as usize])).collect();
        let mut device = host.clone();
        device[3].head_acc_m_s2[2] = f32::from_bits(1.0f32.to_bits() + 1);
        let events = [
            AlertEvent::Level {
                from: Level::Normal,
                to: Level::Warning,
                criterion: Criterion::RunningRms { value_m_s2: 1.0 },
                at_sample: 1,
            },
            AlertEvent::Level {
                from: Level::Warning,
                to: Level::Normal,
                criterion: Criterion::RunningRms { value_m_s2: 1.0 },
                at_sample: 3,
            },
        ];
        let check = Check::new(&log(&device, &host, &events));
        assert_eq!(
            check.head_diff_f32_m_s2,
            f64::from(f32::EPSILON),
            "one ulp at 1.0"
        );
        assert!(!check.agree());
        assert_eq!(check.highest_level, Level::Warning);
        assert_eq!(check.highest_at_s, Some(0.1));
        assert_eq!(check.cleared_at_s, Some(0.3));
        assert_eq!(check.final_level, Level::Normal);
        assert_eq!(check.level_events, 2);
        // MTVV from the valid records (2..5) only: 0.5 + 4 * 0.01.
        assert!((check.device_mtvv_m_s2 - 0.54).abs() < 1e-6);
        assert_eq!(check.device_vdv_m_s175, 4.0);
        let same = Check::new(&log(&host, &host, &events));
        assert!(same.agree(), "{same:?}");
        let missing = Check::new(&log(&host[..4], &host, &events));
        assert!(!missing.records_complete && missing.head_diff_f32_m_s2.is_infinite());
    }

    #[test]
    fn differences_say_bit_for_bit_only_when_exact() {
        assert_eq!(difference(0.0, "m/s^2"), "0 (bit for bit)");
        assert_eq!(difference(1.2e-7, "m/s^2"), "1.2e-7 m/s^2");
    }
}
