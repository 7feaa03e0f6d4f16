//! `supine exposure`'s readable text: the table of ISO 2631-1 values and the alert
//! timeline (the data is [`ModelExposure`] and [`ChannelExposure`]; `--json` serializes
//! it).

use std::fmt::Write as _;

use crate::exposure::channel_exposure::ChannelExposure;
use crate::exposure::joints::joints_text;
use crate::exposure::model_exposure::ModelExposure;
use crate::exposure::model_run::MAX_LISTED_EVENTS;
use crate::exposure::reported_values::AxisReport;
use crate::io::recording::Layout;

const TABLE_HEADER: &str = "           weighting  rms       MTVV      VDV        peak      crest    additional methods\n                      m/s^2     m/s^2     m/s^1.75   m/s^2";

/// One axis as a row of [`TABLE_HEADER`].
fn axis_row(axis: &AxisReport, label: &str) -> String {
    let a = axis.additional_methods;
    let flags: Vec<&str> = [
        (a.crest_factor, "crest>9"),
        (a.mtvv_ratio, "MTVV/rms>1.5"),
        (a.vdv_ratio, "VDV-ratio>1.75"),
    ]
    .iter()
    .filter(|(on, _)| *on)
    .map(|(_, name)| *name)
    .collect();
    format!(
        "{label:<10} {:<8} {:>9.4} {:>9.4} {:>10.4} {:>9.4} {:>7.2}  {}",
        axis.weighting,
        axis.rms_m_s2,
        axis.mtvv_m_s2,
        axis.vdv_m_s175,
        axis.peak_m_s2,
        axis.crest_factor,
        if flags.is_empty() {
            "-".to_string()
        } else {
            flags.join(", ")
        }
    )
}

fn rate_line(fs: f64, from: Option<f64>) -> String {
    match from {
        Some(own) => {
            format!("{fs} Hz (resampled from {own:.3} Hz, Kaiser-windowed sinc, zero phase)")
        }
        None => format!("{fs:.3} Hz"),
    }
}

impl ModelExposure {
    /// The readable table and alert timeline.
    pub fn to_text(&self) -> String {
        let mut s = String::new();
        let _ = writeln!(
            s,
            "predicted head exposure: {} ({}), model {} (identity {})",
            self.input,
            match self.layout {
                Layout::Full => "recording",
                Layout::PlatformOnly => "platform columns only",
                Layout::Prediction => "prediction",
            },
            self.model,
            self.identity
        );
        let _ = writeln!(
            s,
            "{} samples at {} = {:.3} s; evaluated {:.3} s after the {} s warm-up{}",
            self.samples,
            rate_line(self.sample_rate_hz, self.resampled_from_hz),
            self.duration_s,
            self.evaluated_s,
            self.warmup_s,
            if self.valid { "" } else { " (NOT VALID)" }
        );
        let [px, py, pz] = self.platform_rms_m_s2;
        let _ = writeln!(
            s,
            "platform input rms (unweighted): x {px:.4}, y {py:.4}, z {pz:.4} m/s^2\n"
        );
        let _ = writeln!(s, "{TABLE_HEADER}");
        for (label, axis) in ["head x", "head y", "head z"].iter().zip(&self.head) {
            let _ = writeln!(s, "{}", axis_row(axis, label));
        }
        let _ = writeln!(s, "{}", axis_row(&self.vector, "vector"));
        let t = &self.thresholds;
        let _ = writeln!(
            s,
            "\nalert timeline (vector sum; running rms {} / {} / {} m/s^2, VDV {} / {} / {} m/s^1.75 for advisory / warning / alarm):",
            t.running_rms_m_s2[0],
            t.running_rms_m_s2[1],
            t.running_rms_m_s2[2],
            t.vdv_m_s175[0],
            t.vdv_m_s175[1],
            t.vdv_m_s175[2]
        );
        if self.alerts.is_empty() {
            let _ = writeln!(s, "  (no alert)");
        } else {
            let _ = writeln!(s, "  {:>10}  event", "time_s");
            for e in &self.alerts {
                let _ = writeln!(s, "  {:>10.3}  {} {}", e.time_s, e.kind, e.event);
            }
            if self.alerts_omitted > 0 {
                let _ = writeln!(
                    s,
                    "  ... and {} more events (the first {MAX_LISTED_EVENTS} are listed)",
                    self.alerts_omitted
                );
            }
        }
        let _ = writeln!(
            s,
            "highest level: {}; at the end: {}",
            self.max_level, self.final_level
        );
        let _ = writeln!(
            s,
            "note: ISO 2631-1 gives no health method for recumbent persons; these thresholds are extrapolations."
        );
        if !self.joints.is_empty() {
            s += &joints_text(&self.joints);
        }
        s
    }
}

impl ChannelExposure {
    /// The readable table.
    pub fn to_text(&self) -> String {
        let mut s = String::new();
        let _ = writeln!(
            s,
            "exposure of column {} of {} (no model)",
            self.channel, self.input
        );
        let _ = writeln!(
            s,
            "{} samples at {} = {:.3} s; evaluated {:.3} s after the {} s warm-up{}",
            self.samples,
            rate_line(self.sample_rate_hz, self.resampled_from_hz),
            self.duration_s,
            self.evaluated_s,
            self.warmup_s,
            if self.valid { "" } else { " (NOT VALID)" }
        );
        let _ = writeln!(s, "unweighted rms: {:.4} m/s^2\n", self.unweighted_rms_m_s2);
        let _ = writeln!(s, "{TABLE_HEADER}");
        let _ = writeln!(s, "{}", axis_row(&self.values, &self.channel));
        s
    }
}
