//! The demo's findings in numbers, and their one-screen text form.
//!
//! Everything here is derived from [`DemoData`]: the exposure table from the mission
//! report's leg (the host's run of the device code on the same samples); the device-side
//! figures (MTVV, VDV, levels, faults) and the agreement between device and host from the
//! report's device check ([`Check`]).

use std::fmt::Write as _;

use supine_core::alerts::Level;
use supine_core::exposure::AxisValues;

use super::data::DemoData;
use crate::exposure::reported_values::AxisReport;
use crate::report::device_check::{Check, difference};

/// What the demo found.
#[derive(Clone, Debug, PartialEq)]
pub struct Summary {
    /// Overall exposure of the predicted head (the mission report's leg, the host running
    /// the device's code on the same samples): head x, y, z, vector.
    pub exposure: [(String, AxisReport); 4],
    /// The device's own account beside the host's.
    pub check: Check,
}

impl Summary {
    /// Derives the summary of a run.
    pub fn new(data: &DemoData) -> Self {
        // The demo's report has one leg, the ride it streamed.
        let none = AxisReport::new("-", &AxisValues::default());
        let (head, vector) = data
            .report
            .legs
            .first()
            .map_or(([none; 3], none), |leg| (leg.axes, leg.vector));
        let labels = head.map(|a| capitalized(a.weighting));
        Summary {
            exposure: [
                (format!("head x ({})", labels[0]), head[0]),
                (format!("head y ({})", labels[1]), head[1]),
                (format!("head z ({})", labels[2]), head[2]),
                ("vector sum".to_string(), vector),
            ],
            check: data.log.pass.check.clone(),
        }
    }

    /// The highest level in words, with when it was reached and whether it cleared.
    pub fn alert_line(&self) -> String {
        let c = &self.check;
        let mut s = format!("highest alert level: {}", c.highest_level);
        if let Some(t) = c.highest_at_s {
            let _ = write!(s, ", first at {t:.3} s");
        }
        let _ = write!(s, "; at the end: {}", c.final_level);
        if c.final_level == Level::Normal
            && c.highest_level > Level::Normal
            && let Some(t) = c.cleared_at_s
        {
            let _ = write!(s, " (cleared at {t:.3} s)");
        }
        s
    }

    /// The one-screen text summary.
    pub fn to_text(&self, data: &DemoData) -> String {
        let i = &data.info;
        let run = &data.log.run;
        let c = &self.check;
        let warmup_s = data
            .report
            .legs
            .first()
            .map_or(0.0, |leg| leg.exposure.warmup_s);
        let mut s = String::new();
        let _ = writeln!(
            s,
            "summary: {} ride, {:.1} s at {} Hz (seed {}), {} parameters on firmware {}",
            i.profile.name(),
            i.samples as f64 / i.sample_rate_hz,
            i.sample_rate_hz,
            i.seed,
            i.params_name,
            run.firmware_version
        );
        let _ = writeln!(
            s,
            "  predicted head exposure (host, same samples, after the {} s warm-up):",
            warmup_s
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
            c.device_mtvv_m_s2, c.device_vdv_m_s175
        );
        let _ = writeln!(s, "  {}", self.alert_line());
        let faults = if c.faults.is_empty() {
            "none".to_string()
        } else {
            c.faults
                .iter()
                .map(|(n, t)| format!("{n} at {t:.3} s"))
                .collect::<Vec<_>>()
                .join(", ")
        };
        let _ = writeln!(
            s,
            "  alert events: {}; sensor faults: {faults}",
            crate::io::wording::count(c.level_events, "level change")
        );
        let st = run.status.unwrap_or_default();
        let _ = writeln!(
            s,
            "  link: {} frames received, {} lost, {} bad; device: {} samples processed, {} dropped, {} bad frames",
            run.link.frames,
            run.link.lost_frames,
            run.link.bad_frames,
            st.samples_processed,
            st.samples_dropped,
            st.bad_frames
        );
        let _ = writeln!(
            s,
            "  device vs host: head max |diff| {} with the same f32 code, {} vs the f64 model; running rms {}; events {}",
            difference(c.head_diff_f32_m_s2, "m/s^2"),
            difference(c.head_diff_f64_m_s2, "m/s^2"),
            difference(c.rms_diff_m_s2, "m/s^2"),
            if c.events_agree {
                "identical"
            } else {
                "DIFFER"
            }
        );
        s
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
