//! The mission report's device section, present when a device log is given: whether the
//! device and the host agree ([`Check`]), the device's own alert events, its telemetry
//! charted over the host's ([`crate::report::device_charts`]), and how the run was made.
//! Every piece of text that did not come from this file is escaped.

use std::fmt::Write as _;

use anyhow::Result;
use supine_core::alerts::{AlertConfig, Level};

use crate::report::device_charts;
use crate::report::device_check::{Check, DeviceLog, difference, differing_text};
use crate::report::markup::{escape, figure, tag};

/// Most device alert events listed (all are in the events CSV).
pub const MAX_DEVICE_EVENT_ROWS: usize = 40;

/// The check at the top of the report: the device's levels and whether it agrees with the
/// host, and the device's alert events.
pub fn check(h: &mut String, log: &DeviceLog, check: &Check) {
    let lvl = check.highest_level;
    let _ = write!(
        h,
        "<h2>The device versus the host</h2>\n<p>{}</p>\n\
         <div class=\"verdict lvl-{}\"><div class=\"big\">The device's highest alert level: {}",
        escape(&log.run.account),
        lvl.name(),
        tag(lvl)
    );
    if let Some(t) = check.highest_at_s {
        let _ = write!(h, " first reached at {t:.1} s");
    }
    let _ = write!(h, "; at the end of the ride: {}", tag(check.final_level));
    if check.final_level == Level::Normal
        && lvl > Level::Normal
        && let Some(t) = check.cleared_at_s
    {
        let _ = write!(h, " (cleared at {t:.1} s)");
    }
    h.push_str("</div>\n");
    let link = &log.run.link;
    let _ = writeln!(
        h,
        "<p>Check against the host: {} Head acceleration: largest |device &minus; host| {} \
         with the host running the same f32 code, {} against the f64 model; running rms {}; \
         the other values the device reports {}; alert events {}. Link: {} frames, {} lost, {} bad. Sensor faults: {}.</p>\n\
         <p>The device's own exposure values (vector sum): largest running rms (MTVV) {:.4} m/s&sup2;, \
         final VDV {:.4} m/s<sup>1.75</sup>; the leg's table below gives the host's.</p></div>",
        if check.agree() {
            "<span class=\"ok\">the device and the host agree.</span>"
        } else {
            "<span class=\"bad\">the device and the host DIFFER (see below).</span>"
        },
        difference(check.head_diff_f32_m_s2, "m/s&sup2;"),
        difference(check.head_diff_f64_m_s2, "m/s&sup2;"),
        difference(check.rms_diff_m_s2, "m/s&sup2;"),
        if check.differing_values.is_empty() {
            differing_text(&check.differing_values)
        } else {
            format!(
                "<span class=\"bad\">{}</span>",
                differing_text(&check.differing_values)
            )
        },
        match (check.events_agree, check.first_event_difference) {
            (true, _) => "identical".to_string(),
            (false, Some(i)) => format!(
                "<span class=\"bad\">different from the {} event on</span>",
                ordinal(i + 1)
            ),
            (false, None) => "<span class=\"bad\">different</span>".to_string(),
        },
        link.frames,
        link.lost_frames,
        link.bad_frames,
        if check.faults.is_empty() {
            "none".to_string()
        } else {
            escape(
                &check
                    .faults
                    .iter()
                    .map(|(n, t)| format!("{n} at {t:.2} s"))
                    .collect::<Vec<_>>()
                    .join(", "),
            )
        },
        check.device_mtvv_m_s2,
        check.device_vdv_m_s175
    );
    events_table(h, log);
}

/// `1st`, `2nd`, `3rd`, `4th`, ... `11th`, `21st`.
fn ordinal(n: usize) -> String {
    let suffix = match (n % 10, n % 100) {
        (_, 11..=13) => "th",
        (1, _) => "st",
        (2, _) => "nd",
        (3, _) => "rd",
        _ => "th",
    };
    format!("{n}{suffix}")
}

/// The device's alert events, at most [`MAX_DEVICE_EVENT_ROWS`].
fn events_table(h: &mut String, log: &DeviceLog) {
    h.push_str(
        "<h3>Alert events (device)</h3>\n<table>\n<tr><th>time, s</th><th class=\"text\">event</th></tr>\n",
    );
    if log.pass.device_events.is_empty() {
        h.push_str(
            "<tr><td colspan=\"2\" class=\"text\">no alert: the exposure stayed normal</td></tr>\n",
        );
    }
    for e in log.pass.device_events.iter().take(MAX_DEVICE_EVENT_ROWS) {
        let cell = match (e.kind.as_str(), Level::from_name(&e.name)) {
            ("level", Some(l)) => format!(
                "{} {}",
                if e.raised { "raised to" } else { "lowered to" },
                tag(l)
            ),
            _ => escape(&e.text()),
        };
        let _ = writeln!(
            h,
            "<tr><td>{:.3}</td><td class=\"text\">{cell}</td></tr>",
            e.time_s
        );
    }
    if log.pass.device_event_count > MAX_DEVICE_EVENT_ROWS {
        let _ = writeln!(
            h,
            "<tr><td colspan=\"2\" class=\"text\">... {} more in the events file</td></tr>",
            log.pass.device_event_count - MAX_DEVICE_EVENT_ROWS
        );
    }
    h.push_str("</table>\n");
}

/// The device's telemetry charted over the host's, and how the run was made.
pub fn charts(h: &mut String, log: &DeviceLog, alerts: &AlertConfig, warmup_s: f64) -> Result<()> {
    h.push_str("<section class=\"leg\"><h2>What the device saw and predicted</h2>\n");
    figure(
        h,
        &device_charts::input(log),
        "The litter frame's acceleration that was streamed to the device, per axis (x along the patient's body, \
         y lateral, z vertical). Shaded: the rough stretches of the ride; dotted lines: shocks (potholes, speed bumps). \
         Long series are drawn as the minimum and maximum of each pixel column, so every peak is shown.",
    )?;
    for axis in 0..3 {
        figure(
            h,
            &device_charts::head(log, axis),
            if axis == 0 {
                "The head acceleration the device predicted (solid), with the host's f64 model on the same input \
                 (orange dashes). They coincide: the largest difference is given in the check above."
            } else {
                ""
            },
        )?;
    }
    h.push_str("<h3>The device's exposure and alerts</h3>\n");
    let rms = alerts.running_rms_m_s2;
    figure(
        h,
        &device_charts::vector_rms(log, alerts, warmup_s),
        &format!(
            "The 1 s running rms of the weighted head acceleration (vector sum): what the alert levels follow. \
             Dashed horizontal lines: advisory {} / warning {} / alarm {} m/s&sup2;. A level is raised after {} s \
             above its line (up triangle) and lowered after {} s below {}&nbsp;% of it (down triangle). Device \
             solid, host dashed orange. Grey: the first {} s, before the values are valid (the weighting filters settle); no alert is raised then.",
            rms[0],
            rms[1],
            rms[2],
            alerts.raise_dwell_s,
            alerts.clear_dwell_s,
            (100.0 * (1.0 - alerts.hysteresis)).round(),
            warmup_s
        ),
    )?;
    figure(
        h,
        &device_charts::axis_rms(log, warmup_s),
        "The same running rms for each head axis (device solid, host dashed).",
    )?;
    let vdv = alerts.vdv_m_s175;
    figure(
        h,
        &device_charts::vdv(log, alerts, warmup_s),
        &format!(
            "The vibration dose value grows with every jolt and never falls (fourth power: shocks weigh heavily). \
             Thresholds advisory {} / warning {} / alarm {} m/s<sup>1.75</sup>; those above the plotted range are \
             not drawn.",
            vdv[0], vdv[1], vdv[2]
        ),
    )?;
    figure(
        h,
        &device_charts::levels(log, warmup_s),
        "The alert level the device reported with each telemetry record (solid), and the host's (dashed).",
    )?;
    how_made(h, log);
    h.push_str("</section>\n");
    Ok(())
}

/// How the run was made: device, firmware, counters, wall time, notes, files.
fn how_made(h: &mut String, log: &DeviceLog) {
    let run = &log.run;
    let st = run.status.unwrap_or_default();
    let steps = run
        .step_times
        .iter()
        .map(|(name, d)| format!("{} {:.1} s", escape(name), d.as_secs_f64()))
        .collect::<Vec<_>>()
        .join(", ");
    let _ = write!(
        h,
        "<h3>How this run was made</h3>\n<dl>\n\
         <dt>device</dt><dd>{}</dd>\n\
         <dt>firmware</dt><dd>{} (from the device's greeting)</dd>\n\
         <dt>samples streamed</dt><dd>{:.1} s, {} samples at {} Hz</dd>\n\
         <dt>device counters</dt><dd>{} samples processed, {} dropped, {} frames received, {} bad frames, {} telemetry frames sent, \
         deepest stack {} bytes</dd>\n\
         <dt>host link</dt><dd>{} frames decoded, {} lost, {} bad, {} reordered</dd>\n",
        escape(&run.device_line),
        escape(&run.firmware_version),
        log.duration_s(),
        log.samples,
        log.sample_rate_hz,
        st.samples_processed,
        st.samples_dropped,
        st.frames_received,
        st.bad_frames,
        st.telemetry_sent,
        st.stack_used_bytes,
        run.link.frames,
        run.link.lost_frames,
        run.link.bad_frames,
        run.link.reordered_frames,
    );
    if !steps.is_empty() {
        let _ = writeln!(h, "<dt>wall time</dt><dd>{steps}</dd>");
    }
    for (what, text) in &run.notes {
        let _ = writeln!(h, "<dt>{}</dt><dd>{}</dd>", escape(what), escape(text));
    }
    if !run.files.is_empty() {
        let files = run
            .files
            .iter()
            .map(|(name, what)| {
                format!("<a href=\"{0}\">{0}</a> ({1})", escape(name), escape(what))
            })
            .collect::<Vec<_>>()
            .join(", ");
        let _ = writeln!(h, "<dt>files</dt><dd>{files}</dd>");
    }
    h.push_str("</dl>\n");
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ordinals_read_as_words_do() {
        let got: Vec<String> = [1, 2, 3, 4, 11, 12, 13, 21, 102].map(ordinal).to_vec();
        assert_eq!(
            got,
            [
                "1st", "2nd", "3rd", "4th", "11th", "12th", "13th", "21st", "102nd"
            ]
        );
    }
}
