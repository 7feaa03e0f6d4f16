//! The mission report as one self-contained HTML page: inline CSS and SVG, no script, no
//! external font, style or image, and print rules so that the browser's Print gives A4
//! pages with no chart or table cut across a page. Every piece of text that did not come
//! from this file is escaped.

use std::fmt::Write as _;

use anyhow::Result;
use supine_core::alerts::{AlertConfig, Criterion, Level};

use crate::exposure::reported_values::AxisReport;
use crate::report::device_check::DeviceLog;
use crate::report::markup::{escape, tag};
use crate::report::mission::Leg;
use crate::report::{Comparison, MissionReport};
use crate::report::{
    band_section, calibration_section, charts, device_section, joints_section, quality_section,
    route_section,
};
use crate::schema::event::EventCriterion;

/// Most alert events listed per leg (the JSON has them all).
pub const MAX_EVENT_ROWS: usize = 60;

/// The pages' style sheet (the mission report and the fleet view share it).
pub const STYLE: &str = "
body { font-family: system-ui, -apple-system, 'Segoe UI', Helvetica, Arial, sans-serif; color: #222; margin: 0; background: #f6f6f4; }
main { max-width: 1120px; margin: 0 auto; padding: 20px 24px 48px; background: #fff; }
h1 { font-size: 26px; margin: 4px 0 2px; }
h2 { font-size: 19px; margin: 28px 0 6px; border-bottom: 1px solid #ddd; padding-bottom: 4px; }
h3 { font-size: 16px; margin: 18px 0 4px; }
p, li, td, th { font-size: 14px; line-height: 1.45; }
.sub { color: #555; margin-top: 0; }
.warn { color: #8a1c00; background: #fff3e6; border-left: 6px solid #e65a00; padding: 6px 12px; }
.verdict { border-left: 8px solid #888; padding: 10px 16px; margin: 16px 0; background: #fafafa; }
.verdict .big { font-size: 20px; font-weight: 600; }
.lvl-normal { border-color: #2e8b57; } .lvl-advisory { border-color: #cc9900; }
.lvl-warning { border-color: #e65a00; } .lvl-alarm { border-color: #c80000; }
.tag { display: inline-block; padding: 1px 8px; border-radius: 10px; color: #fff; font-weight: 600; font-size: 13px; }
.tag-normal { background: #2e8b57; } .tag-advisory { background: #cc9900; }
.tag-warning { background: #e65a00; } .tag-alarm { background: #c80000; }
table { border-collapse: collapse; margin: 8px 0; }
th, td { border: 1px solid #ddd; padding: 3px 9px; text-align: right; }
th { background: #f0f0ee; } td:first-child, th:first-child { text-align: left; }
td.text, th.text { text-align: left; }
figure { margin: 14px 0 4px; } figcaption { font-size: 13px; color: #444; margin-top: 2px; }
svg { display: block; max-width: 100%; height: auto; }
.caveat { background: #fff7e0; border: 1px solid #e8d28a; padding: 8px 14px; }
.worse { color: #c62828; } .better { color: #2e7d32; }
.ok { color: #2e7d32; font-weight: 600; } .bad { color: #c62828; font-weight: 600; }
dl { display: grid; grid-template-columns: max-content auto; gap: 3px 16px; } dt { font-weight: 600; } dd { margin: 0; }
dt, dd { font-size: 14px; line-height: 1.45; }
code { background: #f2f2f2; padding: 0 4px; border-radius: 3px; font-size: 13px; }
@page { size: A4; margin: 12mm; }
@media print {
  body { background: #fff; }
  main { max-width: none; padding: 0; }
  figure, table, .verdict, .caveat { break-inside: avoid; page-break-inside: avoid; }
  h2, h3 { break-after: avoid; page-break-after: avoid; }
  .leg { break-before: page; page-break-before: always; }
}
";

/// A duration in words, with no-break spaces so that a table cell never splits it.
fn duration(s: f64) -> String {
    let total = s.round() as u64;
    let (h, m, sec) = (total / 3600, (total / 60) % 60, total % 60);
    if h > 0 {
        format!("{h}\u{a0}h\u{a0}{m:02}\u{a0}min")
    } else if m > 0 {
        format!("{m}\u{a0}min\u{a0}{sec:02}\u{a0}s")
    } else {
        format!("{s:.1}\u{a0}s")
    }
}

/// A sample rate as a person writes it: a rate estimated from time stamps (499.99999999999994)
/// shown to the millihertz, and whole rates without decimals.
fn rate_hz(hz: f64) -> String {
    let rounded = (hz * 1000.0).round() / 1000.0;
    format!("{rounded}")
}

/// The page for a mission report (or a comparison of two rides); with `device`, the
/// device's own account of the ride beside the host's (a one-leg report of the ride the
/// device was given).
pub fn render(report: &MissionReport, device: Option<&DeviceLog>) -> Result<String> {
    let mut h = String::with_capacity(1 << 20);
    let title = if report.comparison.is_some() {
        "supine ride comparison"
    } else {
        "supine mission report"
    };
    let _ = write!(
        h,
        "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n\
         <title>{title}</title>\n<style>{STYLE}</style>\n</head>\n<body>\n<main>\n\
         <h1>{title}: predicted head vibration of a supine patient</h1>\n"
    );
    let legs = &report.legs;
    let _ = writeln!(
        h,
        "<p class=\"sub\">{} {} ({}); patient {:.2} m, {:.0} kg; model {} (identity <code>{}</code>). \
         Each ride went through the device's own pipeline (model, ISO 2631-1 weighting, exposure, alerts) \
         on this computer.</p>",
        legs.len(),
        if report.comparison.is_some() {
            "rides"
        } else if legs.len() == 1 {
            "leg"
        } else {
            "legs"
        },
        duration(report.mission.duration_s),
        report.subject.height_m,
        report.subject.mass_kg,
        escape(&report.model.name),
        escape(&report.model.identity)
    );
    quality_section::section(&mut h, legs);
    calibration_section::section(&mut h, &report.calibration);
    match &report.comparison {
        Some(c) => comparison(&mut h, legs, c),
        None => mission(&mut h, report),
    }
    if let Some(b) = &report.band {
        let total = if report.comparison.is_some() {
            "both rides"
        } else {
            "mission"
        };
        h.push_str(&band_section::html(b, legs, total));
    }
    if let Some(log) = device {
        device_section::check(&mut h, log, &log.pass.check);
    }
    h.push_str("<h2>Charts</h2>\n");
    let config = &report.thresholds;
    let layout = if report.comparison.is_some() {
        charts::Layout::Compare
    } else {
        charts::Layout::Mission
    };
    for chart in [
        charts::input(legs, layout),
        charts::running_rms(legs, config, layout),
        charts::vdv(legs, config, layout),
        charts::levels(legs, layout),
    ] {
        let _ = writeln!(h, "<figure>{}</figure>", chart.to_svg()?);
    }
    // Every leg runs with the same parameter file, so the same warm-up.
    let warmup_s = legs.first().map_or(0.0, |leg| leg.exposure.warmup_s);
    let _ = writeln!(
        h,
        "{}",
        if report.comparison.is_some() {
            format!(
                "<p>Both rides are drawn from their own start, ride A solid, ride B dashed. \
                 Each starts from a fresh device state, with its own {warmup_s} s warm-up of \
                 the weighting filters.</p>"
            )
        } else {
            format!(
                "<p>The legs are shaded and named along one time axis. Each leg starts from a \
                 fresh device state, so every leg has its own {warmup_s} s warm-up of the \
                 weighting filters; the mission's VDV adds the legs' fourth powers.</p>"
            )
        }
    );
    route_section::section(&mut h, legs, config)?;
    joints_section::section(&mut h, legs, &report.mission.joints, layout)?;
    for leg in legs {
        leg_section(&mut h, leg, report.comparison.is_some())?;
    }
    if let (Some(log), Some(leg)) = (device, legs.first()) {
        device_section::charts(&mut h, log, config, leg.exposure.warmup_s)?;
    }
    level_meanings(&mut h, config);
    h.push_str("</main>\n</body>\n</html>\n");
    Ok(h)
}

/// What the alert levels mean, where their thresholds come from, and the caveat.
fn level_meanings(h: &mut String, config: &AlertConfig) {
    let rms = config.running_rms_m_s2;
    let vdv = config.vdv_m_s175;
    let _ = write!(
        h,
        "<section><h2>What the alert levels mean</h2>\n<table>\n\
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
         point to be set per mission in the parameter file, not limits established for patients; and the head acceleration is \
         a model's prediction from the litter's, not a measurement. Use the alerts to compare rides and to slow down, not as \
         a diagnosis.</p></section>\n",
        tag(Level::Normal),
        rms[0],
        vdv[0],
        tag(Level::Advisory),
        rms[0],
        vdv[0],
        tag(Level::Warning),
        rms[1],
        vdv[1],
        tag(Level::Alarm),
        rms[2],
        vdv[2],
        (100.0 * (1.0 - config.hysteresis)).round(),
        config.clear_dwell_s
    );
}

fn mission(h: &mut String, report: &MissionReport) {
    let m = &report.mission;
    let _ = writeln!(
        h,
        "<div class=\"verdict lvl-{0}\"><div class=\"big\">Highest alert level: {1}</div>\
         <p>Mission VDV {2:.3} m/s<sup>1.75</sup> (the legs combined as (&Sigma; VDV<sub>i</sub><sup>4</sup>)<sup>1/4</sup>); \
         rms {3:.3} m/s<sup>2</sup> (energy-equivalent over the evaluated time); largest MTVV {4:.3} m/s<sup>2</sup>.</p></div>",
        m.max_level.name(),
        tag(m.max_level),
        m.vector.vdv_m_s175,
        m.vector.rms_m_s2,
        m.vector.mtvv_m_s2
    );
    h.push_str("<h2>Mission</h2>\n<table><tr><th>leg</th><th>duration</th><th>rms, m/s<sup>2</sup></th><th>MTVV, m/s<sup>2</sup></th><th>VDV, m/s<sup>1.75</sup></th><th>peak, m/s<sup>2</sup></th><th>crest</th>");
    for level in Level::ALL {
        let _ = write!(h, "<th>at {level}</th>");
    }
    h.push_str("<th>highest</th></tr>\n");
    for leg in &report.legs {
        let v = &leg.vector;
        let _ = write!(
            h,
            "<tr><td>{}</td><td>{}</td><td>{:.3}</td><td>{:.3}</td><td>{:.3}</td><td>{:.3}</td><td>{:.2}</td>",
            escape(&leg.label),
            duration(leg.duration_s),
            v.rms_m_s2,
            v.mtvv_m_s2,
            v.vdv_m_s175,
            v.peak_m_s2,
            v.crest_factor
        );
        for t in leg.time_at_level_s.as_array() {
            let _ = write!(h, "<td>{}</td>", duration(t));
        }
        let _ = writeln!(h, "<td>{}</td></tr>", tag(leg.max_level));
    }
    let _ = write!(
        h,
        "<tr><th>mission</th><th>{}</th><th>{:.3}</th><th>{:.3}</th><th>{:.3}</th><th></th><th></th>",
        duration(m.duration_s),
        m.vector.rms_m_s2,
        m.vector.mtvv_m_s2,
        m.vector.vdv_m_s175
    );
    for t in m.time_at_level_s.as_array() {
        let _ = write!(h, "<th>{}</th>", duration(t));
    }
    let _ = writeln!(h, "<th>{}</th></tr></table>", tag(m.max_level));
    let p = &m.projection;
    let _ = write!(
        h,
        "<h3>Projection</h3><p>At the dose rate of the last {} of the mission (VDV<sup>4</sup> growing by {:.4} m<sup>4</sup>s<sup>-7</sup> a second), the mission's VDV would reach:</p><table><tr><th>level</th><th>VDV threshold, m/s<sup>1.75</sup></th><th class=\"text\">reached</th></tr>",
        duration(p.window_s),
        p.vdv4_rate_per_s
    );
    for t in &p.thresholds {
        let when = match t.reached_after_s {
            Some(s) if s <= 0.0 => "already reached".to_string(),
            Some(s) => format!("after {} more at this rate", duration(s)),
            None => "never at this rate".to_string(),
        };
        let _ = write!(
            h,
            "<tr><td>{}</td><td>{:.2}</td><td class=\"text\">{when}</td></tr>",
            tag(t.level),
            t.vdv_m_s175
        );
    }
    h.push_str("</table>\n");
}

fn comparison(h: &mut String, legs: &[Leg], c: &Comparison) {
    let [a, b] = [&legs[0], &legs[1]];
    let _ = write!(
        h,
        "<h2>Comparison of two rides</h2><p>Ride A is {}, ride B is {}: two rides of the same \
         patient side by side, not one journey. Differences are B &minus; A; red is worse for \
         the patient in B (more vibration, more time at a raised level), green better (less \
         vibration, more time at normal).</p>\n<table><tr><th>predicted head</th><th>A</th><th>B</th><th>B &minus; A</th><th>change</th></tr>\n",
        escape(&a.input),
        escape(&b.input)
    );
    for row in &c.rows {
        let class = match (row.more_is_worse, row.difference) {
            (Some(worse), d) if d > 0.0 => ["better", "worse"][usize::from(worse)],
            (Some(worse), d) if d < 0.0 => ["worse", "better"][usize::from(worse)],
            _ => "",
        };
        let _ = writeln!(
            h,
            "<tr><td>{}</td><td>{:.3}</td><td>{:.3}</td><td class=\"{class}\">{:+.3}</td><td class=\"{class}\">{}</td></tr>",
            escape(&row.quantity),
            row.a,
            row.b,
            row.difference,
            row.change_percent
                .map_or_else(|| "-".to_string(), |p| format!("{p:+.1} %"))
        );
    }
    h.push_str("</table>\n");
}

fn axis_row(h: &mut String, label: &str, a: &AxisReport) {
    let m = a.additional_methods;
    let flags: Vec<&str> = [
        (m.crest_factor, "crest factor &gt; 9"),
        (m.mtvv_ratio, "MTVV/rms &gt; 1.5"),
        (m.vdv_ratio, "VDV ratio &gt; 1.75"),
    ]
    .iter()
    .filter(|(on, _)| *on)
    .map(|(_, n)| *n)
    .collect();
    let _ = writeln!(
        h,
        "<tr><td>{label}</td><td class=\"text\">{}</td><td>{:.4}</td><td>{:.4}</td><td>{:.4}</td><td>{:.4}</td><td>{:.2}</td><td class=\"text\">{}</td></tr>",
        a.weighting,
        a.rms_m_s2,
        a.mtvv_m_s2,
        a.vdv_m_s175,
        a.peak_m_s2,
        a.crest_factor,
        if flags.is_empty() {
            "-".to_string()
        } else {
            flags.join(", ")
        }
    );
}

fn leg_section(h: &mut String, leg: &Leg, compared: bool) -> Result<()> {
    let e = &leg.exposure;
    let when = if compared {
        duration(leg.duration_s)
    } else {
        format!(
            "{} from {} into the mission",
            duration(leg.duration_s),
            duration(leg.start_s)
        )
    };
    let _ = writeln!(
        h,
        "<section class=\"leg\"><h2>{}</h2><p>{when}; {} samples at {} Hz; \
         evaluated {:.1} s after the {} s warm-up{}. Litter input rms (unweighted) x {:.3}, y {:.3}, z {:.3} m/s<sup>2</sup>.</p>",
        escape(&leg.label),
        e.samples,
        rate_hz(e.sample_rate_hz),
        e.evaluated_s,
        e.warmup_s,
        if e.valid {
            ""
        } else {
            " (too short: NOT VALID)"
        },
        e.platform_rms_m_s2[0],
        e.platform_rms_m_s2[1],
        e.platform_rms_m_s2[2]
    );
    h.push_str("<table><tr><th>predicted head</th><th class=\"text\">weighting</th><th>rms, m/s<sup>2</sup></th><th>MTVV, m/s<sup>2</sup></th><th>VDV, m/s<sup>1.75</sup></th><th>peak, m/s<sup>2</sup></th><th>crest</th><th class=\"text\">additional methods (ISO 2631-1 6.3)</th></tr>\n");
    for (label, axis) in ["x", "y", "z"].iter().zip(&leg.axes) {
        axis_row(h, label, axis);
    }
    axis_row(h, "vector", &leg.vector);
    h.push_str("</table>\n");
    if leg.alerts.is_empty() {
        h.push_str(if compared {
            "<p>No alert in this ride.</p>\n"
        } else {
            "<p>No alert in this leg.</p>\n"
        });
    } else {
        let _ = writeln!(
            h,
            "<table><tr>{}<th class=\"text\">event</th><th class=\"text\">criterion</th><th>value</th><th>running rms, m/s<sup>2</sup></th><th>VDV, m/s<sup>1.75</sup></th></tr>",
            if compared {
                "<th>time</th>"
            } else {
                "<th>mission time</th><th>leg time</th>"
            }
        );
        for a in leg.alerts.iter().take(MAX_EVENT_ROWS) {
            let when = if compared {
                format!("<td>{:.1} s</td>", a.leg_time_s)
            } else {
                format!(
                    "<td>{:.1} s</td><td>{:.1} s</td>",
                    a.mission_time_s, a.leg_time_s
                )
            };
            let _ = writeln!(
                h,
                "<tr>{when}<td class=\"text\">{} {}</td><td class=\"text\">{}</td><td>{:.3}</td><td>{:.3}</td><td>{:.3}</td></tr>",
                a.kind,
                escape(&a.event),
                criterion_words(a.criterion),
                // A fault has no criterion: its row shows the running rms then.
                a.criterion.map_or(a.running_rms_m_s2, |c| c.value().1),
                a.running_rms_m_s2,
                a.vdv_m_s175
            );
        }
        h.push_str("</table>\n");
        if leg.alerts.len() > MAX_EVENT_ROWS {
            let _ = writeln!(
                h,
                "<p>{} more events are in the JSON output (--json).</p>",
                leg.alerts.len() - MAX_EVENT_ROWS
            );
        }
    }
    let _ = writeln!(
        h,
        "<figure>{}<figcaption>Power spectral density (Welch, Hann, 50 % overlap, {:.2} Hz bins) of the litter input, \
         the predicted head, and the head weighted as the device weights it, on a logarithmic frequency axis over \
         0.5-80 Hz, the range ISO 2631-1 weights: the weighted curve is what the exposure values integrate.</figcaption></figure>",
        charts::spectra_svg(leg)?,
        leg.spectra
            .first()
            .and_then(|s| s.freqs_hz.get(1))
            .copied()
            .unwrap_or(0.0)
    );
    third_octave_table(h, leg);
    h.push_str("</section>\n");
    Ok(())
}

/// The weighted head's one-third-octave band values, as a meter lists them.
fn third_octave_table(h: &mut String, leg: &Leg) {
    h.push_str(
        "<h3>One-third-octave bands of the weighted head</h3>\n<p>The rms of the predicted head, \
         weighted, in each one-third-octave band (ISO 8041-1 band centres; the band's share of the \
         spectrum above; below about 2 Hz a band is narrower than the spectrum's bins and is \
         interpolated). The JSON gives the same values (<code>third_octave_bands</code>).</p>\n\
         <table class=\"bands\"><tr><th>centre, Hz</th><th>x, m/s<sup>2</sup></th><th>y, m/s<sup>2</sup></th><th>z, m/s<sup>2</sup></th></tr>\n",
    );
    for b in &leg.third_octave_bands {
        let [x, y, z] = b.head_weighted_m_s2;
        let _ = writeln!(
            h,
            "<tr><td>{}</td><td>{x:.4}</td><td>{y:.4}</td><td>{z:.4}</td></tr>",
            b.centre_hz
        );
    }
    h.push_str("</table>\n");
}

/// What changed an alert, in the alert table's words.
fn criterion_words(c: Option<EventCriterion>) -> &'static str {
    match c {
        Some(EventCriterion::Exposure(Criterion::RunningRms { .. })) => "running rms",
        Some(EventCriterion::Exposure(Criterion::Vdv { .. })) => "VDV",
        Some(EventCriterion::Joint(..)) => "joint motion",
        None => "sensor fault",
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn durations_hold_together_and_rates_read_as_written() {
        assert_eq!(duration(4.04), "4.0\u{a0}s");
        assert_eq!(duration(600.0), "10\u{a0}min\u{a0}00\u{a0}s");
        assert_eq!(duration(5400.0), "1\u{a0}h\u{a0}30\u{a0}min");
        assert_eq!(rate_hz(499.999_999_999_999_94), "500");
        assert_eq!(rate_hz(1000.0 / 3.0), "333.333");
    }
}
