//! A device's own account of a ride beside the host's: what the device sent (its
//! telemetry and alert events, as its monitor logged them) and what the host computed on
//! the same samples with the same f32 code and with the f64 model. [`Check`] is how far
//! apart they are; the report shows it as a section of its own when a device log is given
//! ([`crate::report::device_section`]).

use std::time::Duration;

use serde::Serialize;
use supine_core::alerts::Level;
use supine_core::protocol::Status;

use crate::device::link::LinkStats;
use crate::io::telemetry_csv::EventRow;
use crate::plot::time_chart::{Band, Moment};
use crate::report::device_series::DeviceSeries;
use supine_core::protocol::Telemetry;

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

/// What the device sent for one ride and what the host computed on the same samples, as
/// the report keeps it: the check's figures, the first events, and chart series of a
/// bounded size ([`crate::report::device_pass`] builds it in one pass over the files).
#[derive(Clone, Debug, PartialEq)]
pub struct DeviceLog {
    /// How the run was made.
    pub run: DeviceRun,
    /// Sample rate, Hz.
    pub sample_rate_hz: f64,
    /// Samples streamed to the device.
    pub samples: usize,
    /// Stretches of the ride worth marking on the charts (road surfaces).
    pub bands: Vec<Band>,
    /// Instants worth marking (shocks).
    pub moments: Vec<Moment>,
    /// What the pass over the device's and the host's records found.
    pub pass: PassResult,
}

/// What one pass over a run's records found ([`crate::report::device_pass`]): the check,
/// the device's first events, counts, chart series.
#[derive(Clone, Debug, PartialEq)]
pub struct PassResult {
    /// How the device's account compares with the host's.
    pub check: Check,
    /// The device's first [`MAX_LISTED_EVENTS`] alert events (all are in its events CSV).
    pub device_events: Vec<EventRow>,
    /// The device's alert events, all of them.
    pub device_event_count: usize,
    /// The host pipeline's alert events.
    pub host_event_count: usize,
    /// Telemetry records the device sent.
    pub device_records: usize,
    /// Telemetry records the host's run made.
    pub host_records: usize,
    /// What the charts draw.
    pub series: DeviceSeries,
}

/// Most device alert events kept for the report (the rest are counted).
pub const MAX_LISTED_EVENTS: usize = 1000;

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
    /// Sensor faults the device raised, in order (name and time, s); the first
    /// [`MAX_LISTED_EVENTS`].
    pub faults: Vec<(String, f64)>,
    /// Largest |device head - host head| with the host running the same f32 pipeline,
    /// m/s^2 (0 expected: the same code on the same inputs).
    pub head_diff_f32_m_s2: f64,
    /// Largest |device head - f64 model head|, m/s^2 (the device's numerical accuracy).
    pub head_diff_f64_m_s2: f64,
    /// Largest |device - host| vector running rms, m/s^2.
    pub rms_diff_m_s2: f64,
    /// The values of the telemetry, other than the head acceleration, in which some
    /// device record differs from the host's in the same position, by their names in the
    /// telemetry CSV (in [`COMPARED_VALUES`] order); empty when all are the same.
    pub differing_values: Vec<&'static str>,
    /// The device's and the host's alert events are the same (sample, kind, name).
    pub events_agree: bool,
    /// Position (from 0) of the first event where the device and the host differ, one
    /// missing on either side included.
    pub first_event_difference: Option<usize>,
    /// The device sent a record for every sample the host computed one for (every
    /// `decimation`-th), and the host's run covers every sample.
    pub records_complete: bool,
}

/// Every value of a telemetry record the check compares besides the head acceleration
/// and the sample index, by its column in the telemetry CSV (`joints`: any joint column).
pub const COMPARED_VALUES: [&str; 9] = [
    "running_rms_x_m_s2",
    "running_rms_y_m_s2",
    "running_rms_z_m_s2",
    "vector_running_rms_m_s2",
    "vdv_m_s175",
    "alert_level",
    "fault_flags",
    "valid",
    "joints",
];

impl Check {
    /// The device and the host agree: the same head bit for bit, every other value the
    /// device reports the same, the same events, every record there.
    pub fn agree(&self) -> bool {
        self.events_agree
            && self.head_diff_f32_m_s2 == 0.0
            && self.differing_values.is_empty()
            && self.records_complete
    }
}

/// Which of [`COMPARED_VALUES`] differ between the device's record `d` and the host's
/// `h` (bit for bit: the device runs the host's f32 code), as flags in that order.
pub fn differing(d: &Telemetry, h: &Telemetry) -> [bool; COMPARED_VALUES.len()] {
    let same = |a: f32, b: f32| a.to_bits() == b.to_bits();
    let joints_differ = d.joints.as_slice().len() != h.joints.as_slice().len()
        || d.joints
            .as_slice()
            .iter()
            .zip(h.joints.as_slice())
            .any(|(a, b)| !same(*a, *b));
    [
        !same(d.running_rms_m_s2[0], h.running_rms_m_s2[0]),
        !same(d.running_rms_m_s2[1], h.running_rms_m_s2[1]),
        !same(d.running_rms_m_s2[2], h.running_rms_m_s2[2]),
        !same(d.vector_running_rms_m_s2, h.vector_running_rms_m_s2),
        !same(d.vdv_m_s175, h.vdv_m_s175),
        d.alert_level != h.alert_level,
        d.fault_flags != h.fault_flags,
        d.valid != h.valid,
        joints_differ,
    ]
}

fn same_event(x: &EventRow, y: &EventRow) -> bool {
    x.sample == y.sample && x.kind == y.kind && x.name == y.name && x.raised == y.raised
}

/// A [`Check`] built as the records and events go by, in order: memory holds the
/// figures, not the series.
#[derive(Clone, Debug)]
pub struct CheckBuilder {
    device_mtvv_m_s2: f64,
    device_last: Option<(f64, Level)>,
    highest_level: Level,
    first_raise_s: [Option<f64>; 4],
    cleared_at_s: Option<f64>,
    level_events: usize,
    faults: Vec<(String, f64)>,
    head_diff_f32_m_s2: f64,
    head_diff_f64_m_s2: f64,
    rms_diff_m_s2: f64,
    differing: [bool; COMPARED_VALUES.len()],
    first_event_difference: Option<usize>,
    records_complete: bool,
    device_records: usize,
    host_records: usize,
    device_events: usize,
    host_events: usize,
}

impl Default for CheckBuilder {
    fn default() -> Self {
        Self {
            device_mtvv_m_s2: 0.0,
            device_last: None,
            highest_level: Level::Normal,
            first_raise_s: [None; 4],
            cleared_at_s: None,
            level_events: 0,
            faults: Vec::new(),
            head_diff_f32_m_s2: 0.0,
            head_diff_f64_m_s2: 0.0,
            rms_diff_m_s2: 0.0,
            differing: [false; COMPARED_VALUES.len()],
            first_event_difference: None,
            records_complete: true,
            device_records: 0,
            host_records: 0,
            device_events: 0,
            host_events: 0,
        }
    }
}

impl CheckBuilder {
    /// The next device record; `f64_head` is the f64 model's head at its sample, `None`
    /// when the host has no sample there.
    pub fn device_record(&mut self, d: &Telemetry, f64_head: Option<[f64; 3]>) {
        self.device_records += 1;
        if d.valid {
            self.device_mtvv_m_s2 = self
                .device_mtvv_m_s2
                .max(f64::from(d.vector_running_rms_m_s2));
        }
        self.highest_level = self.highest_level.max(d.alert_level);
        self.device_last = Some((f64::from(d.vdv_m_s175), d.alert_level));
        let diff = match f64_head {
            Some(h) => (0..3)
                .map(|a| (f64::from(d.head_acc_m_s2[a]) - h[a]).abs())
                .fold(0.0, f64::max),
            None => f64::INFINITY,
        };
        self.head_diff_f64_m_s2 = self.head_diff_f64_m_s2.max(diff);
    }

    /// The next host record, and the device's in the same position.
    pub fn host_record(&mut self, h: &Telemetry, d: Option<&Telemetry>) {
        self.host_records += 1;
        let Some(d) = d else {
            self.records_complete = false;
            return;
        };
        if d.sample_index != h.sample_index {
            self.records_complete = false;
        }
        let head = (0..3)
            .map(|a| (f64::from(d.head_acc_m_s2[a]) - f64::from(h.head_acc_m_s2[a])).abs())
            .fold(0.0, f64::max);
        self.head_diff_f32_m_s2 = self.head_diff_f32_m_s2.max(head);
        let rms =
            (f64::from(d.vector_running_rms_m_s2) - f64::from(h.vector_running_rms_m_s2)).abs();
        self.rms_diff_m_s2 = self.rms_diff_m_s2.max(rms);
        for (seen, now) in self.differing.iter_mut().zip(differing(d, h)) {
            *seen |= now;
        }
    }

    /// The next device event and the host's in the same position (either may be missing).
    pub fn events(&mut self, d: Option<&EventRow>, h: Option<&EventRow>) {
        let position = self.device_events.max(self.host_events);
        if h.is_some() {
            self.host_events += 1;
        }
        if let Some(e) = d {
            self.device_events += 1;
            if e.kind == "level" {
                self.level_events += 1;
                match Level::from_name(&e.name) {
                    Some(level) if e.raised => {
                        self.first_raise_s[level as usize].get_or_insert(e.time_s);
                    }
                    _ => {}
                }
                if Level::from_name(&e.name) == Some(Level::Normal) {
                    self.cleared_at_s = Some(e.time_s);
                }
            }
            if e.kind == "fault" && e.raised && self.faults.len() < MAX_LISTED_EVENTS {
                self.faults.push((e.name.clone(), e.time_s));
            }
        }
        let same = matches!((d, h), (Some(x), Some(y)) if same_event(x, y));
        if !same && self.first_event_difference.is_none() {
            self.first_event_difference = Some(position);
        }
    }

    /// Records seen: the device's and the host's.
    pub fn records(&self) -> (usize, usize) {
        (self.device_records, self.host_records)
    }

    /// Events seen: the device's and the host's.
    pub fn event_counts(&self) -> (usize, usize) {
        (self.device_events, self.host_events)
    }

    /// The check; `samples_covered` is whether the host's run covered every sample.
    pub fn finish(self, samples_covered: bool) -> Check {
        let counts_differ = self.device_records != self.host_records;
        let (vdv, final_level) = self.device_last.unwrap_or((0.0, Level::Normal));
        let when_differ = |v: f64| if counts_differ { f64::INFINITY } else { v };
        Check {
            device_mtvv_m_s2: self.device_mtvv_m_s2,
            device_vdv_m_s175: vdv,
            highest_level: self.highest_level,
            highest_at_s: self.first_raise_s[self.highest_level as usize],
            final_level,
            cleared_at_s: self.cleared_at_s,
            level_events: self.level_events,
            faults: self.faults,
            head_diff_f32_m_s2: when_differ(self.head_diff_f32_m_s2),
            head_diff_f64_m_s2: self.head_diff_f64_m_s2,
            rms_diff_m_s2: when_differ(self.rms_diff_m_s2),
            differing_values: COMPARED_VALUES
                .iter()
                .zip(self.differing)
                .filter(|(_, differ)| *differ)
                .map(|(name, _)| *name)
                .collect(),
            events_agree: self.first_event_difference.is_none(),
            first_event_difference: self.first_event_difference,
            records_complete: self.records_complete && !counts_differ && samples_covered,
        }
    }
}

/// The values that differ, for a sentence: `identical`, or `DIFFER: vdv_m_s175, alert_level`.
pub fn differing_text(names: &[&str]) -> String {
    if names.is_empty() {
        "identical".to_string()
    } else {
        format!("DIFFER: {}", names.join(", "))
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

/// `supine report --json`'s `device_check` (with a device log): the device's account
/// against the host's, largest differences (0 when bit for bit; null when a series is
/// missing a record) and whether the events agree.
#[derive(Clone, Debug, Serialize)]
pub struct DeviceCheckRecord<'a> {
    /// The device and the host agree ([`Check::agree`]).
    pub agree: bool,
    /// Largest |device head - host head|, the host running the same f32 pipeline, m/s^2.
    pub head_diff_f32_m_s2: Option<f64>,
    /// Largest |device head - f64 model head|, m/s^2.
    pub head_diff_f64_m_s2: Option<f64>,
    /// Largest |device - host| vector running rms, m/s^2.
    pub rms_diff_m_s2: Option<f64>,
    /// Telemetry values in which some device record differs from the host's.
    pub differing_values: &'a [&'static str],
    /// The device's and the host's alert events are the same.
    pub events_agree: bool,
    /// The device sent a record for every sample the host computed one for.
    pub records_complete: bool,
    /// Telemetry records the device sent.
    pub device_records: usize,
    /// Telemetry records the host computed.
    pub host_records: usize,
    /// Alert events the device sent.
    pub device_events: usize,
    /// Alert events of the host pipeline.
    pub host_events: usize,
    /// Samples streamed to the device.
    pub samples: usize,
    /// Largest valid vector running rms in the device's telemetry (its MTVV), m/s^2.
    pub device_mtvv_m_s2: f64,
    /// The device's VDV of the vector sum at its last record, m/s^1.75.
    pub device_vdv_m_s175: f64,
    /// Highest level in the device's telemetry.
    pub highest_level: &'static str,
}

impl<'a> DeviceCheckRecord<'a> {
    /// The record of `log`'s check.
    pub fn new(log: &'a DeviceLog) -> Self {
        let c = &log.pass.check;
        let finite = |v: f64| v.is_finite().then_some(v);
        Self {
            agree: c.agree(),
            head_diff_f32_m_s2: finite(c.head_diff_f32_m_s2),
            head_diff_f64_m_s2: finite(c.head_diff_f64_m_s2),
            rms_diff_m_s2: finite(c.rms_diff_m_s2),
            differing_values: &c.differing_values,
            events_agree: c.events_agree,
            records_complete: c.records_complete,
            device_records: log.pass.device_records,
            host_records: log.pass.host_records,
            device_events: log.pass.device_event_count,
            host_events: log.pass.host_event_count,
            samples: log.samples,
            device_mtvv_m_s2: c.device_mtvv_m_s2,
            device_vdv_m_s175: c.device_vdv_m_s175,
            highest_level: c.highest_level.name(),
        }
    }
}

/// `supine report --json`: the mission report, and with a device log its check beside it.
#[derive(Clone, Debug, Serialize)]
pub struct CheckedReport<'a> {
    /// The report's numbers.
    #[serde(flatten)]
    pub report: &'a crate::report::MissionReport,
    /// The device's account against the host's (left out without a device log).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub device_check: Option<DeviceCheckRecord<'a>>,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn differences_say_bit_for_bit_only_when_exact() {
        assert_eq!(difference(0.0, "m/s^2"), "0 (bit for bit)");
        assert_eq!(difference(1.2e-7, "m/s^2"), "1.2e-7 m/s^2");
    }
}
