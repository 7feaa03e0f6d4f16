//! The demo's report: one self-contained HTML file (inline CSS, inline SVG; no script, no
//! external font, style or image), readable by someone who has not seen the code.
//!
//! - [`figures`]: which charts the report has and what goes on each (drawn by
//!   [`crate::plot::time_chart`]).
//! - this module: the page around them (summary, tables, explanations), with every piece
//!   of text that did not come from this file escaped.

pub mod figures;

use std::fmt::Write as _;

use anyhow::Result;
use supine_core::alerts::Level;

use crate::demo::data::DemoData;
use crate::demo::summary::{Summary, difference};
use crate::io::telemetry_csv::level_from_name;

/// Most alert events listed in the report's table (all are in the CSV file).
pub const MAX_EVENT_ROWS: usize = 40;

pub use crate::report::html::escape;

const STYLE: &str = "
body { font-family: system-ui, -apple-system, 'Segoe UI', Helvetica, Arial, sans-serif; color: #222; margin: 0; background: #f6f6f4; }
main { max-width: 1120px; margin: 0 auto; padding: 20px 24px 48px; background: #fff; }
h1 { font-size: 26px; margin: 4px 0 2px; }
h2 { font-size: 19px; margin: 30px 0 6px; border-bottom: 1px solid #ddd; padding-bottom: 4px; }
p, li, td, th, dd, dt { font-size: 14.5px; line-height: 1.45; }
.sub { color: #555; margin-top: 0; }
.verdict { border-left: 8px solid #888; padding: 10px 16px; margin: 16px 0; background: #fafafa; }
.verdict .big { font-size: 20px; font-weight: 600; }
.lvl-normal { border-color: #2e8b57; } .lvl-advisory { border-color: #cc9900; }
.lvl-warning { border-color: #e65a00; } .lvl-alarm { border-color: #c80000; }
.tag { display: inline-block; padding: 1px 8px; border-radius: 10px; color: #fff; font-weight: 600; font-size: 13px; }
.tag-normal { background: #2e8b57; } .tag-advisory { background: #cc9900; }
.tag-warning { background: #e65a00; } .tag-alarm { background: #c80000; }
.ok { color: #2e7d32; font-weight: 600; } .bad { color: #c62828; font-weight: 600; }
table { border-collapse: collapse; margin: 8px 0; }
th, td { border: 1px solid #ddd; padding: 4px 10px; text-align: right; }
th { background: #f0f0ee; } td:first-child, th:first-child { text-align: left; }
td.text, th.text { text-align: left; }
.grid { display: flex; gap: 28px; flex-wrap: wrap; align-items: flex-start; }
figure { margin: 14px 0 4px; } figcaption { font-size: 13.5px; color: #444; max-width: 1060px; margin-top: 2px; }
svg { display: block; max-width: 100%; height: auto; }
.caveat { background: #fff7e0; border: 1px solid #e8d28a; padding: 8px 14px; }
dl { display: grid; grid-template-columns: max-content auto; gap: 3px 16px; } dt { font-weight: 600; } dd { margin: 0; }
code { background: #f2f2f2; padding: 0 4px; border-radius: 3px; font-size: 13.5px; }
";

fn level_tag(level: Level) -> String {
    format!("<span class=\"tag tag-{0}\">{0}</span>", level.name())
}

fn num(v: f64, digits: usize) -> String {
    format!("{v:.digits$}")
}

/// The whole report page, section by section.
pub fn render(data: &DemoData, summary: &Summary) -> Result<String> {
    let mut h = String::with_capacity(1 << 20);
    head(&mut h, data);
    verdict(&mut h, data, summary);
    h.push_str("<div class=\"grid\">");
    exposure_table(&mut h, data, summary);
    events_table(&mut h, data);
    h.push_str("</div>\n");
    charts(&mut h, data)?;
    level_meanings(&mut h, data);
    how_made(&mut h, data);
    h.push_str("</main>\n</body>\n</html>\n");
    Ok(h)
}

/// The page's head and the title with the one-paragraph account of what was done.
fn head(h: &mut String, data: &DemoData) {
    let i = &data.info;
    let duration_s = data.ride.duration_s();
    let _ = write!(
        h,
        "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n\
         <title>supine demo report: {} ride</title>\n<style>{STYLE}</style>\n</head>\n<body>\n<main>\n",
        escape(i.profile.name())
    );
    let _ = write!(
        h,
        "<h1>supine demo: head vibration of a supine patient on a litter</h1>\n\
         <p class=\"sub\">A {:.0} s <b>{}</b> ride at {} Hz, streamed into the supine firmware running in QEMU \
         with the parameters {}. The device predicted the patient's head acceleration \
         sample by sample, weighted it as ISO 2631-1 prescribes, and raised alerts; the host computed the same \
         things on its own as a check.</p>\n",
        duration_s,
        escape(i.profile.name()),
        i.sample_rate_hz,
        escape(&i.params_name)
    );
}

/// The verdict: the highest alert level, and whether the device and the host agree.
fn verdict(h: &mut String, data: &DemoData, summary: &Summary) {
    let i = &data.info;
    let lvl = summary.highest_level;
    let _ = write!(
        h,
        "<div class=\"verdict lvl-{}\"><div class=\"big\">Highest alert level: {}",
        lvl.name(),
        level_tag(lvl)
    );
    if let Some(t) = summary.highest_at_s {
        let _ = write!(h, " first reached at {t:.1} s");
    }
    let _ = write!(
        h,
        "; at the end of the ride: {}",
        level_tag(summary.final_level)
    );
    if summary.final_level == Level::Normal
        && lvl > Level::Normal
        && let Some(t) = summary.cleared_at_s
    {
        let _ = write!(h, " (cleared at {t:.1} s)");
    }
    h.push_str("</div>\n");
    let agree =
        summary.events_agree && summary.head_diff_f32_m_s2 == 0.0 && summary.records_complete;
    let _ = writeln!(
        h,
        "<p>Check against the host: {} Head acceleration: largest |device &minus; host| {} \
         with the host running the same f32 code, {} against the f64 model; running rms {}; \
         alert events {}. Link: {} frames, {} lost, {} bad. Sensor faults: {}.</p></div>",
        if agree {
            "<span class=\"ok\">the device and the host agree.</span>"
        } else {
            "<span class=\"bad\">the device and the host DIFFER (see below).</span>"
        },
        difference(summary.head_diff_f32_m_s2, "m/s&sup2;"),
        difference(summary.head_diff_f64_m_s2, "m/s&sup2;"),
        difference(summary.rms_diff_m_s2, "m/s&sup2;"),
        if summary.events_agree {
            "identical"
        } else {
            "<span class=\"bad\">different</span>"
        },
        i.link.frames,
        i.link.lost_frames,
        i.link.bad_frames,
        if summary.faults.is_empty() {
            "none".to_string()
        } else {
            escape(
                &summary
                    .faults
                    .iter()
                    .map(|(n, t)| format!("{n} at {t:.2} s"))
                    .collect::<Vec<_>>()
                    .join(", "),
            )
        }
    );
}

/// The exposure of the predicted head (the host's run of the device code), and what the
/// device itself reported.
fn exposure_table(h: &mut String, data: &DemoData, summary: &Summary) {
    let i = &data.info;
    h.push_str("<div>\n<h2>Exposure of the predicted head</h2>\n<table>\n\
        <tr><th></th><th>overall rms<br>m/s&sup2;</th><th>MTVV<br>m/s&sup2;</th><th>VDV<br>m/s<sup>1.75</sup></th>\
        <th>peak<br>m/s&sup2;</th><th>crest<br>factor</th></tr>\n");
    for (label, a) in &summary.exposure {
        let _ = writeln!(
            h,
            "<tr><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td></tr>",
            escape(label),
            num(a.rms_m_s2, 4),
            num(a.mtvv_m_s2, 4),
            num(a.vdv_m_s175, 4),
            num(a.peak_m_s2, 3),
            num(a.crest_factor, 2)
        );
    }
    let _ = write!(
        h,
        "<tr><td>device, vector sum</td><td class=\"text\">(not sent)</td><td>{}</td><td>{}</td><td></td><td></td></tr>\n</table>\n\
         <p>Frequency-weighted (Wd on x and y, Wj on z, k = 1), evaluated after the {} s warm-up by the host \
         running the device's own code on the same samples. The last row is what the device itself reported: \
         its largest running rms (MTVV) and its final VDV.</p>\n</div>\n",
        num(summary.device_mtvv_m_s2, 4),
        num(summary.device_vdv_m_s175, 4),
        i.warmup_s
    );
}

/// The device's alert events, at most [`MAX_EVENT_ROWS`].
fn events_table(h: &mut String, data: &DemoData) {
    h.push_str(
        "<div>\n<h2>Alert events (device)</h2>\n<table>\n<tr><th>time, s</th><th>event</th></tr>\n",
    );
    if data.device_events.is_empty() {
        h.push_str(
            "<tr><td colspan=\"2\" class=\"text\">no alert: the exposure stayed normal</td></tr>\n",
        );
    }
    for e in data.device_events.iter().take(MAX_EVENT_ROWS) {
        let cell = match (e.kind.as_str(), level_from_name(&e.name)) {
            ("level", Some(l)) => format!(
                "{} {}",
                if e.raised { "raised to" } else { "lowered to" },
                level_tag(l)
            ),
            _ => escape(&e.text()),
        };
        let _ = writeln!(
            h,
            "<tr><td>{:.3}</td><td class=\"text\">{cell}</td></tr>",
            e.time_s
        );
    }
    if data.device_events.len() > MAX_EVENT_ROWS {
        let _ = writeln!(
            h,
            "<tr><td colspan=\"2\" class=\"text\">... {} more in device.events.csv</td></tr>",
            data.device_events.len() - MAX_EVENT_ROWS
        );
    }
    h.push_str("</table>\n</div>");
}

/// The charts of [`figures`], with their captions.
fn charts(h: &mut String, data: &DemoData) -> Result<()> {
    let i = &data.info;
    h.push_str("<h2>What the device saw and predicted</h2>\n");
    figure(
        h,
        &figures::input(data),
        "The litter frame's acceleration that was streamed to the device, per axis (x along the patient's body, \
         y lateral, z vertical). Shaded: the rough stretch of road; dotted lines: shocks (potholes, speed bumps). \
         Long series are drawn as the minimum and maximum of each pixel column, so every peak is shown.",
    )?;
    for axis in 0..3 {
        figure(
            h,
            &figures::head(data, axis),
            if axis == 0 {
                "The head acceleration the device predicted (solid), with the host's f64 model on the same input \
                 (orange dashes). They coincide: the largest difference is given in the check at the top."
            } else {
                ""
            },
        )?;
    }
    h.push_str("<h2>Exposure and alerts</h2>\n");
    let rms = i.alerts.running_rms_m_s2;
    figure(
        h,
        &figures::vector_rms(data),
        &format!(
            "The 1 s running rms of the weighted head acceleration (vector sum): what the alert levels follow. \
             Dashed horizontal lines: advisory {} / warning {} / alarm {} m/s&sup2;. A level is raised after {} s \
             above its line (up triangle) and lowered after {} s below {}&nbsp;% of it (down triangle). Device \
             solid, host dashed orange. Grey: the first {} s, before the values are valid (the weighting filters settle); no alert is raised then.",
            rms[0],
            rms[1],
            rms[2],
            i.alerts.raise_dwell_s,
            i.alerts.clear_dwell_s,
            (100.0 * (1.0 - i.alerts.hysteresis)).round(),
            i.warmup_s
        ),
    )?;
    figure(
        h,
        &figures::axis_rms(data),
        "The same running rms for each head axis (device solid, host dashed).",
    )?;
    let vdv = i.alerts.vdv_m_s175;
    figure(
        h,
        &figures::vdv(data),
        &format!(
            "The vibration dose value grows with every jolt and never falls (fourth power: shocks weigh heavily). \
             Thresholds advisory {} / warning {} / alarm {} m/s<sup>1.75</sup>; those above the plotted range are \
             not drawn.",
            vdv[0], vdv[1], vdv[2]
        ),
    )?;
    figure(
        h,
        &figures::levels(data),
        "The alert level the device reported with each telemetry record (solid), and the host's (dashed).",
    )?;
    Ok(())
}

/// What the alert levels mean, where their thresholds come from, and the caveat.
fn level_meanings(h: &mut String, data: &DemoData) {
    let i = &data.info;
    let rms = i.alerts.running_rms_m_s2;
    let vdv = i.alerts.vdv_m_s175;
    let _ = write!(
        h,
        "<h2>What the alert levels mean</h2>\n<table>\n\
         <tr><th>level</th><th>running rms<br>(1 s, vector sum)</th><th>VDV<br>(vector sum)</th><th class=\"text\">borrowed from</th></tr>\n\
         <tr><td>{}</td><td>below {} m/s&sup2;</td><td>below {} m/s<sup>1.75</sup></td><td class=\"text\">nothing to do</td></tr>\n\
         <tr><td>{}</td><td>from {} m/s&sup2;</td><td>from {} m/s<sup>1.75</sup></td><td class=\"text\">&ldquo;fairly uncomfortable&rdquo; (ISO 2631-1 Annex C); VDV entering the health guidance caution zone (Annex B)</td></tr>\n\
         <tr><td>{}</td><td>from {} m/s&sup2;</td><td>from {} m/s<sup>1.75</sup></td><td class=\"text\">&ldquo;uncomfortable&rdquo;; VDV leaving the caution zone: health risks likely</td></tr>\n\
         <tr><td>{}</td><td>from {} m/s&sup2;</td><td>from {} m/s<sup>1.75</sup></td><td class=\"text\">&ldquo;very uncomfortable&rdquo;; VDV at the EU daily exposure limit for the crew (2002/44/EC)</td></tr>\n\
         </table>\n\
         <p>The level is the higher of the two criteria. A running-rms level clears once the running rms has stayed below \
         {}&nbsp;% of its threshold for {} s; the VDV only grows, so a VDV level lasts to the end of the evaluation. \
         Sensor faults (non-finite samples, saturation, a stuck axis, gaps in the sample indices) are reported separately.</p>\n\
         <p class=\"caveat\"><b>Caveat.</b> ISO 2631-1 gives no comfort or health method for recumbent persons. These thresholds \
         are the seated scales applied to the predicted head acceleration of a supine patient: an extrapolation and a starting \
         point to be set per mission in the parameter file, not limits established for patients. Use the alerts to compare \
         rides and to slow down, not as a diagnosis.</p>\n",
        level_tag(Level::Normal),
        rms[0],
        vdv[0],
        level_tag(Level::Advisory),
        rms[0],
        vdv[0],
        level_tag(Level::Warning),
        rms[1],
        vdv[1],
        level_tag(Level::Alarm),
        rms[2],
        vdv[2],
        (100.0 * (1.0 - i.alerts.hysteresis)).round(),
        i.alerts.clear_dwell_s
    );
}

/// How this run was made: device, firmware, parameters, ride, counters, files.
fn how_made(h: &mut String, data: &DemoData) {
    let i = &data.info;
    let duration_s = data.ride.duration_s();
    let st = i.status.unwrap_or_default();
    let steps = i
        .step_times
        .iter()
        .map(|(name, d)| format!("{} {:.1} s", escape(name), d.as_secs_f64()))
        .collect::<Vec<_>>()
        .join(", ");
    let _ = write!(
        h,
        "<h2>How this run was made</h2>\n<dl>\n\
         <dt>device</dt><dd>{}</dd>\n\
         <dt>firmware</dt><dd>{} (from the device's greeting), in QEMU mps2-an386 (Cortex-M4F)</dd>\n\
         <dt>parameters</dt><dd>{} preset (Wang &amp; Rahmatalla 2013, litter-board case), identity <code>{}</code>, \
         placed in the PARAMS region's slot A as <code>supine flash</code> would (file: <code>params.toml</code>)</dd>\n\
         <dt>ride</dt><dd>{}, {:.1} s, {} samples at {} Hz, seed {}; streamed {}</dd>\n\
         <dt>device counters</dt><dd>{} samples processed, {} dropped, {} frames received, {} bad frames, {} telemetry frames sent, \
         deepest stack {} bytes</dd>\n\
         <dt>host link</dt><dd>{} frames decoded, {} lost, {} bad, {} reordered</dd>\n\
         <dt>instructions per sample</dt><dd>not measured in this run (QEMU ran without <code>-icount</code>); \
         <code>supine replay --qemu --icount</code> measures it, see BENCHMARKS.md</dd>\n\
         <dt>wall time</dt><dd>{}</dd>\n\
         <dt>files</dt><dd><a href=\"ride.csv\">ride.csv</a> (input), <a href=\"device.csv\">device.csv</a> and \
         <a href=\"device.events.csv\">device.events.csv</a> (what the device sent), <a href=\"host.csv\">host.csv</a> and \
         <a href=\"host.events.csv\">host.events.csv</a> (the host's reference), <a href=\"params.toml\">params.toml</a></dd>\n\
         <dt>again</dt><dd><code>supine demo --profile {} --duration-s {} --seed {}</code> gives the same ride and the same numbers</dd>\n\
         </dl>\n",
        escape(&i.device_line),
        escape(&i.firmware_version),
        escape(&i.params_name),
        escape(&i.identity),
        escape(i.profile.name()),
        duration_s,
        i.samples,
        i.sample_rate_hz,
        i.seed,
        if i.realtime {
            "in real time"
        } else {
            "as fast as the device took them"
        },
        st.samples_processed,
        st.samples_dropped,
        st.frames_received,
        st.bad_frames,
        st.telemetry_sent,
        st.stack_used_bytes,
        i.link.frames,
        i.link.lost_frames,
        i.link.bad_frames,
        i.link.reordered_frames,
        steps,
        escape(i.profile.name()),
        duration_s,
        i.seed
    );
}

fn figure(h: &mut String, chart: &crate::plot::time_chart::Chart, caption: &str) -> Result<()> {
    let svg = chart.to_svg()?;
    let _ = write!(h, "<figure>\n{svg}\n");
    if !caption.is_empty() {
        let _ = writeln!(h, "<figcaption>{caption}</figcaption>");
    }
    h.push_str("</figure>\n");
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::demo::data::{HostExposure, RunInfo};
    use crate::demo::ride::{DemoProfile, make};
    use crate::demo::trace::Trace;
    use crate::exposure::report::AxisReport;
    use crate::io::telemetry_csv::EventRow;
    use supine_core::alerts::{AlertConfig, AlertEvent, Criterion, FaultFlags};
    use supine_core::exposure::AxisValues;
    use supine_core::protocol::Telemetry;

    /// A small run: 12 s at 100 Hz, the vector running rms ramping through every
    /// threshold and back, one level raised and cleared; the device's version string
    /// carries markup (it comes from the device, so it must be escaped).
    fn data() -> DemoData {
        let fs = 100.0;
        let ride = make(DemoProfile::Lab, 12.0, fs, 1).expect("ride");
        let n = ride.ride.len();
        let telemetry: Vec<Telemetry> = (0..n as u32)
            .map(|k| {
                let t = f64::from(k) / fs;
                let v = (1.5 * (std::f64::consts::PI * t / 12.0).sin()) as f32;
                Telemetry {
                    sample_index: k,
                    head_acc_m_s2: [0.1, -0.2, v],
                    running_rms_m_s2: [0.0, 0.0, v],
                    vector_running_rms_m_s2: v,
                    vdv_m_s175: (t / 4.0) as f32,
                    alert_level: if (300..900).contains(&k) {
                        Level::Warning
                    } else {
                        Level::Normal
                    },
                    fault_flags: FaultFlags::empty(),
                    valid: k >= 500,
                }
            })
            .collect();
        let events: Vec<EventRow> = [
            AlertEvent::Level {
                from: Level::Normal,
                to: Level::Warning,
                criterion: Criterion::RunningRms { value_m_s2: 0.6 },
                at_sample: 300,
            },
            AlertEvent::Level {
                from: Level::Warning,
                to: Level::Normal,
                criterion: Criterion::RunningRms { value_m_s2: 0.6 },
                at_sample: 900,
            },
        ]
        .iter()
        .map(|e| EventRow::from_event(e, fs))
        .collect();
        let trace = Trace::from_telemetry(&telemetry, fs);
        let axis = AxisReport::new("wd", &AxisValues::default());
        DemoData {
            info: RunInfo {
                profile: DemoProfile::Lab,
                seed: 1,
                sample_rate_hz: fs,
                samples: n,
                params_name: "paper-litter".into(),
                identity: "00ff".into(),
                firmware_version: "0.1.0<b>+test".into(),
                device_line: "firmware 0.1.0<b>+test".into(),
                warmup_s: 5.0,
                alerts: AlertConfig::DEFAULT,
                status: None,
                link: Default::default(),
                step_times: vec![("device".into(), std::time::Duration::from_millis(1500))],
                realtime: false,
            },
            host_head_f64_m_s2: trace.head_m_s2.clone(),
            host: trace.clone(),
            device: trace,
            host_events: events.clone(),
            device_events: events,
            ride,
            exposure: HostExposure {
                head: [axis; 3],
                vector: axis,
            },
        }
    }

    #[test]
    fn the_report_is_self_contained_escaped_and_draws_the_thresholds() {
        let data = data();
        let summary = Summary::new(&data);
        assert_eq!(summary.highest_level, Level::Warning);
        assert_eq!(summary.highest_at_s, Some(3.0));
        assert_eq!(summary.cleared_at_s, Some(9.0));
        assert_eq!(summary.final_level, Level::Normal);
        // MTVV from the valid records only: the peak 1.5 at t = 6 s is inside them.
        assert!(
            (summary.device_mtvv_m_s2 - 1.5).abs() < 1e-6,
            "{}",
            summary.device_mtvv_m_s2
        );
        assert!(summary.events_agree && summary.records_complete);
        assert_eq!(summary.head_diff_f32_m_s2, 0.0);

        let html = render(&data, &summary).expect("report");
        assert!(!html.to_lowercase().contains("<script"));
        for (at, _) in html.match_indices("href=\"") {
            assert!(!html[at + 6..].starts_with("http"), "external link");
        }
        // The only URL is SVG's namespace name, which nothing fetches.
        for (at, _) in html.match_indices("http") {
            assert!(
                html[at..].starts_with("http://www.w3.org/2000/svg"),
                "a URL in the report"
            );
        }
        // The device's text is escaped, not interpreted.
        assert!(html.contains("0.1.0&lt;b&gt;+test"));
        assert!(!html.contains("0.1.0<b>"));
        // Every running-rms threshold is drawn (the data reach 1.5 > 1.25), the VDV's
        // advisory too; the caption names all three VDV thresholds.
        for label in [
            "advisory 0.5 m/s^2",
            "warning 0.8 m/s^2",
            "alarm 1.25 m/s^2",
            "advisory 8.5 m/s^1.75",
        ] {
            assert!(html.contains(label), "{label} not drawn");
        }
        assert!(html.contains("advisory 8.5 / warning 17 / alarm 21"));
        assert!(html.matches("<svg").count() == 8, "eight charts");
        assert!(html.contains("recumbent"), "the standard's caveat");
        assert!(html.contains("first reached at 3.0 s"));
        assert!(html.contains("cleared at 9.0 s"));
    }

    #[test]
    fn escaping_covers_markup_and_quotes() {
        assert_eq!(
            escape("<script>alert(\"x\") & 'y'</script>"),
            "&lt;script&gt;alert(&quot;x&quot;) &amp; &#39;y&#39;&lt;/script&gt;"
        );
        assert_eq!(escape("0.1.0+qemu"), "0.1.0+qemu");
    }
}
