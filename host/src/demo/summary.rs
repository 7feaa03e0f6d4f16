//! The demo's findings in numbers, and their one-screen text form.
//!
//! Everything here is derived from [`DemoData`]: the exposure table from the host's run
//! of the device code on the same samples; the device-side figures (MTVV, VDV, levels,
//! faults) from the device's own telemetry and events as written to the CSV files; and the
//! agreement between the two.

use std::fmt::Write as _;

use supine_core::alerts::Level;

use super::data::DemoData;
use crate::exposure::report::AxisReport;
use crate::io::telemetry_csv::{EventRow, level_from_name};

/// What the demo found.
#[derive(Clone, Debug, PartialEq)]
pub struct Summary {
    /// Overall exposure (host, supine-core on the same samples): head x, y, z, vector.
    pub exposure: [(String, AxisReport); 4],
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
    /// The device sent a record for every sample, and the host computed as many.
    pub records_complete: bool,
}

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

impl Summary {
    /// Derives the summary of a run.
    pub fn new(data: &DemoData) -> Self {
        let d = &data.device;
        let device_mtvv_m_s2 = d
            .vector_rms_m_s2
            .iter()
            .zip(&d.valid)
            .filter(|(_, v)| **v)
            .map(|(x, _)| *x)
            .fold(0.0, f64::max);
        let highest_level = d.level.iter().copied().max().unwrap_or(Level::Normal);
        let highest_at_s = data
            .device_events
            .iter()
            .find(|e| {
                e.kind == "level" && e.raised && level_from_name(&e.name) == Some(highest_level)
            })
            .map(|e| e.time_s);
        let cleared_at_s = data
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
        let labels = data.exposure.head.map(|a| capitalized(a.weighting));
        Summary {
            exposure: [
                (format!("head x ({})", labels[0]), data.exposure.head[0]),
                (format!("head y ({})", labels[1]), data.exposure.head[1]),
                (format!("head z ({})", labels[2]), data.exposure.head[2]),
                ("vector sum".to_string(), data.exposure.vector),
            ],
            device_mtvv_m_s2,
            device_vdv_m_s175: d.vdv_m_s175.last().copied().unwrap_or(0.0),
            highest_level,
            highest_at_s,
            final_level: d.level.last().copied().unwrap_or(Level::Normal),
            cleared_at_s,
            level_events: data
                .device_events
                .iter()
                .filter(|e| e.kind == "level")
                .count(),
            faults: data
                .device_events
                .iter()
                .filter(|e| e.kind == "fault" && e.raised)
                .map(|e| (e.name.clone(), e.time_s))
                .collect(),
            head_diff_f32_m_s2: head_diff(&data.host.head_m_s2),
            head_diff_f64_m_s2: head_diff(&data.host_head_f64_m_s2),
            rms_diff_m_s2: max_abs_diff(&d.vector_rms_m_s2, &data.host.vector_rms_m_s2),
            events_agree: same_events(&data.device_events, &data.host_events),
            records_complete: d.len() == data.info.samples && data.host.len() == data.info.samples,
        }
    }

    /// The highest level in words, with when it was reached and whether it cleared.
    pub fn alert_line(&self) -> String {
        let mut s = format!("highest alert level: {}", self.highest_level);
        if let Some(t) = self.highest_at_s {
            let _ = write!(s, ", first at {t:.3} s");
        }
        let _ = write!(s, "; at the end: {}", self.final_level);
        if self.final_level == Level::Normal
            && self.highest_level > Level::Normal
            && let Some(t) = self.cleared_at_s
        {
            let _ = write!(s, " (cleared at {t:.3} s)");
        }
        s
    }

    /// The one-screen text summary.
    pub fn to_text(&self, data: &DemoData) -> String {
        let i = &data.info;
        let mut s = String::new();
        let _ = writeln!(
            s,
            "summary: {} ride, {:.1} s at {} Hz (seed {}), {} parameters on firmware {}",
            i.profile.name(),
            i.samples as f64 / i.sample_rate_hz,
            i.sample_rate_hz,
            i.seed,
            i.params_name,
            i.firmware_version
        );
        let _ = writeln!(
            s,
            "  predicted head exposure (host, same samples, after the {} s warm-up):",
            i.warmup_s
        );
        let _ = writeln!(
            s,
            "    {:<14} {:>11} {:>9} {:>10}",
            "", "overall rms", "MTVV", "VDV"
        );
        let _ = writeln!(
            s,
            "    {:<14} {:>11} {:>9} {:>10}",
            "", "m/s^2", "m/s^2", "m/s^1.75"
        );
        for (label, a) in &self.exposure {
            let _ = writeln!(
                s,
                "    {label:<14} {:>11.4} {:>9.4} {:>10.4}",
                a.rms_m_s2, a.mtvv_m_s2, a.vdv_m_s175
            );
        }
        let _ = writeln!(
            s,
            "  device, from its telemetry: MTVV {:.4} m/s^2, VDV {:.4} m/s^1.75 (vector sum)",
            self.device_mtvv_m_s2, self.device_vdv_m_s175
        );
        let _ = writeln!(s, "  {}", self.alert_line());
        let faults = if self.faults.is_empty() {
            "none".to_string()
        } else {
            self.faults
                .iter()
                .map(|(n, t)| format!("{n} at {t:.3} s"))
                .collect::<Vec<_>>()
                .join(", ")
        };
        let _ = writeln!(
            s,
            "  alert events: {}; sensor faults: {faults}",
            crate::io::wording::count(self.level_events, "level change")
        );
        let st = i.status.unwrap_or_default();
        let _ = writeln!(
            s,
            "  link: {} frames received, {} lost, {} bad; device: {} samples processed, {} dropped, {} bad frames",
            i.link.frames,
            i.link.lost_frames,
            i.link.bad_frames,
            st.samples_processed,
            st.samples_dropped,
            st.bad_frames
        );
        let _ = writeln!(
            s,
            "  device vs host: head max |diff| {} with the same f32 code, {} vs the f64 model; running rms {}; events {}",
            difference(self.head_diff_f32_m_s2, "m/s^2"),
            difference(self.head_diff_f64_m_s2, "m/s^2"),
            difference(self.rms_diff_m_s2, "m/s^2"),
            if self.events_agree {
                "identical"
            } else {
                "DIFFER"
            }
        );
        s
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

/// `wd` -> `Wd`: ISO 2631-1's spelling of the weightings.
fn capitalized(name: &str) -> String {
    let mut c = name.chars();
    match c.next() {
        Some(f) => f.to_uppercase().chain(c).collect(),
        None => String::new(),
    }
}
