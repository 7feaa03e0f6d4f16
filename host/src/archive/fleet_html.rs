//! The fleet view as one self-contained HTML page (`DIR/fleet.html`): inline CSS and SVG,
//! no script, nothing fetched. What it shows is [`FleetView`]'s; this module only draws.

use std::fmt::Write as _;

use jiff::Timestamp;

use crate::archive::fleet::{DIMENSIONS, FleetView, Group, SIGNIFICANCE};
use crate::archive::stats::Distribution;
use crate::io::wording::count;
use crate::report::markup::{escape, tag as level_tag};
use crate::report::page::STYLE;
use supine_core::alerts::Level;

const LEVEL_COLOURS: [(&str, &str); 4] = [
    ("normal", "#2e8b57"),
    ("advisory", "#cc9900"),
    ("warning", "#e65a00"),
    ("alarm", "#c80000"),
];

/// A level's name as the page's coloured tag.
fn tag(level: &str) -> String {
    Level::from_name(level).map_or_else(|| escape(level), level_tag)
}

fn level_colour(level: &str) -> &'static str {
    LEVEL_COLOURS
        .iter()
        .find(|(l, _)| *l == level)
        .map_or("#555", |(_, c)| c)
}

/// Tick values for `[lo, hi]`: about five, at 1, 2 or 5 times a power of ten.
fn ticks(lo: f64, hi: f64) -> Vec<f64> {
    let span = (hi - lo).max(1e-9);
    let raw = span / 5.0;
    let p = 10f64.powf(raw.log10().floor());
    let step = [1.0, 2.0, 5.0, 10.0]
        .into_iter()
        .map(|m| m * p)
        .find(|s| *s >= raw)
        .unwrap_or(10.0 * p);
    let first = (lo / step).ceil() as i64;
    let last = (hi / step + 1e-9).floor() as i64;
    (first..=last).map(|k| k as f64 * step).collect()
}

fn date(epoch_s: f64) -> String {
    utc(epoch_s, "%Y-%m-%d")
}

fn utc(epoch_s: f64, format: &str) -> String {
    Timestamp::from_second(epoch_s as i64)
        .map(|t| t.strftime(format).to_string())
        .unwrap_or_default()
}

/// Ticks for a time axis over `[lo, hi]` (Unix seconds), with their labels: at most about
/// six, at whole multiples of a calendar step (hours, days, weeks) counted from the epoch,
/// so every label is a distinct round time (a step of 1, 2 or 5 times a power of ten
/// seconds put several ticks in one day, each labelled with the same date).
fn time_ticks(lo: f64, hi: f64) -> Vec<(f64, String)> {
    const HOUR_S: f64 = 3_600.0;
    const DAY_S: f64 = 86_400.0;
    let mut steps_s = [1.0, 3.0, 6.0, 12.0]
        .map(|h| h * HOUR_S)
        .into_iter()
        .chain([1.0, 2.0, 7.0, 14.0, 28.0, 91.0, 182.0, 364.0].map(|d| d * DAY_S));
    let span = hi - lo;
    let step = steps_s
        .find(|step| span / step <= 6.0)
        .unwrap_or_else(|| (span / 6.0 / (364.0 * DAY_S)).ceil() * 364.0 * DAY_S);
    let format = if step < DAY_S {
        "%Y-%m-%d %H:%M"
    } else {
        "%Y-%m-%d"
    };
    let first = (lo / step).ceil() as i64;
    let last = (hi / step).floor() as i64;
    (first..=last)
        .map(|k| k as f64 * step)
        .map(|t| (t, utc(t, format)))
        .collect()
}

/// The page.
pub fn render(view: &FleetView) -> String {
    let mut h = String::new();
    let _ = write!(
        h,
        "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n\
         <meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n\
         <title>supine fleet view</title>\n<style>{STYLE}\n.ci {{ color: #555; }}</style>\n\
         </head>\n<body>\n<main>\n<h1>Fleet view</h1>\n"
    );
    let span = match (view.timeline.first(), view.timeline.last()) {
        (Some(a), Some(b)) => format!(", {} to {}", date(a.start_epoch_s), date(b.start_epoch_s)),
        _ => String::new(),
    };
    let _ = write!(
        h,
        "<p class=\"sub\">{}, {:.1} hours of ride{span}{}.</p>\n\
         <p>Missions are compared by the head's <b>VDV per hour of ride</b>: the vibration \
         dose value (ISO 2631-1, m/s<sup>1.75</sup>) one hour at the mission's own dose rate \
         would give, VDV&nbsp;(3600&nbsp;s&nbsp;/&nbsp;T)<sup>1/4</sup>. Groups are described \
         by their median, quartiles and 10th and 90th percentiles; the median's 95&nbsp;% \
         interval comes from order statistics (none below 6 missions).</p>\n",
        count(view.missions, "mission"),
        view.duration_h,
        if view.undated_missions > 0 {
            format!(
                "; {} without a start time are left off the time axis",
                view.undated_missions
            )
        } else {
            String::new()
        }
    );
    timeline(&mut h, view);
    for by in DIMENSIONS {
        let groups: Vec<&Group> = view.groups.iter().filter(|g| g.by == by).collect();
        if !groups.is_empty() {
            dimension(&mut h, by, &groups);
        }
    }
    compare(&mut h, view);
    worst(&mut h, view);
    road(&mut h, view);
    h.push_str("</main>\n</body>\n</html>\n");
    h
}

fn timeline(h: &mut String, view: &FleetView) {
    h.push_str("<h2>Missions over time</h2>\n");
    let points = &view.timeline;
    let (Some(first), Some(last)) = (points.first(), points.last()) else {
        h.push_str("<p>No mission has a start time.</p>\n");
        return;
    };
    let (w, ht, left, right, top, bottom) = (1060.0, 300.0, 60.0, 20.0, 14.0, 40.0);
    let x0 = first.start_epoch_s;
    let x1 = last.start_epoch_s.max(x0 + 86_400.0);
    let y1 = points
        .iter()
        .map(|p| p.vdv_per_hour_m_s175)
        .fold(0.0, f64::max)
        .max(1e-6)
        * 1.05;
    let sx = |x: f64| left + (x - x0) / (x1 - x0) * (w - left - right);
    let sy = |y: f64| top + (1.0 - y / y1) * (ht - top - bottom);
    let _ = write!(
        h,
        "<figure><svg viewBox=\"0 0 {w} {ht}\" width=\"{w}\" height=\"{ht}\" \
         xmlns=\"http://www.w3.org/2000/svg\" font-size=\"11\">"
    );
    for t in ticks(0.0, y1) {
        let y = sy(t);
        let _ = write!(
            h,
            "<line x1=\"{left}\" x2=\"{}\" y1=\"{y:.1}\" y2=\"{y:.1}\" stroke=\"#e4e4e4\"/>\
             <text x=\"{}\" y=\"{:.1}\" text-anchor=\"end\">{t:.3}</text>",
            w - right,
            left - 4.0,
            y + 4.0
        );
    }
    for (t, label) in time_ticks(x0, x1) {
        let x = sx(t);
        let _ = write!(
            h,
            "<line x1=\"{x:.1}\" x2=\"{x:.1}\" y1=\"{top}\" y2=\"{}\" stroke=\"#eee\"/>\
             <text x=\"{x:.1}\" y=\"{}\" text-anchor=\"middle\">{}</text>",
            ht - bottom,
            ht - bottom + 14.0,
            label
        );
    }
    for p in points {
        let _ = write!(
            h,
            "<circle cx=\"{:.1}\" cy=\"{:.1}\" r=\"2.5\" fill=\"{}\" fill-opacity=\"0.7\"/>",
            sx(p.start_epoch_s),
            sy(p.vdv_per_hour_m_s175),
            level_colour(&p.max_level)
        );
    }
    // The weekly medians.
    let path: Vec<String> = view
        .weeks
        .iter()
        .filter_map(|wk| {
            let t: Timestamp = format!("{}T00:00:00Z", wk.week_of).parse().ok()?;
            let mid = t.as_second() as f64 + 3.5 * 86_400.0;
            Some(format!(
                "{:.1},{:.1}",
                sx(mid.clamp(x0, x1)),
                sy(wk.vdv_per_hour_m_s175.median)
            ))
        })
        .collect();
    if path.len() > 1 {
        let _ = write!(
            h,
            "<polyline points=\"{}\" fill=\"none\" stroke=\"#222\" stroke-width=\"1.5\"/>",
            path.join(" ")
        );
    }
    let _ = write!(
        h,
        "<text x=\"12\" y=\"{:.1}\" transform=\"rotate(-90 12 {:.1})\" text-anchor=\"middle\">\
         VDV per hour, m/s^1.75</text></svg>\n<figcaption>Each mission at its start, \
         coloured by its highest alert level ",
        ht / 2.0,
        ht / 2.0
    );
    for (level, _) in LEVEL_COLOURS {
        h.push_str(&tag(level));
        h.push(' ');
    }
    h.push_str("; the line is each week's median.</figcaption></figure>\n");
    let _ = writeln!(
        h,
        "<p>{}; busiest: {}.</p>",
        count(view.weeks.len(), "week"),
        view.weeks
            .iter()
            .max_by_key(|w| w.missions)
            .map_or(String::new(), |w| format!(
                "week of {} with {}",
                w.week_of,
                count(w.missions, "mission")
            ))
    );
}

fn ci(d: &Distribution) -> String {
    match d.median_ci95 {
        Some([lo, hi]) => format!("<span class=\"ci\">[{lo:.3}, {hi:.3}]</span>"),
        None => "<span class=\"ci\">(too few)</span>".into(),
    }
}

fn dimension(h: &mut String, by: &str, groups: &[&Group]) {
    let _ = writeln!(h, "<h2>By {by}</h2>");
    // Box plots: whiskers 10th-90th percentile, box the quartiles, the median's interval
    // as a band, the median as a line.
    let (w, label_w, right, row_h, top) = (1060.0, 170.0, 20.0, 22.0, 8.0);
    let ht = top + row_h * groups.len() as f64 + 28.0;
    let x1 = groups
        .iter()
        .map(|g| g.vdv_per_hour_m_s175.p90)
        .fold(0.0, f64::max)
        .max(1e-6)
        * 1.05;
    let sx = |x: f64| label_w + x / x1 * (w - label_w - right);
    let _ = write!(
        h,
        "<figure><svg viewBox=\"0 0 {w} {ht}\" width=\"{w}\" height=\"{ht}\" \
         xmlns=\"http://www.w3.org/2000/svg\" font-size=\"11\">"
    );
    let axis_y = ht - 28.0;
    for t in ticks(0.0, x1) {
        let x = sx(t);
        let _ = write!(
            h,
            "<line x1=\"{x:.1}\" x2=\"{x:.1}\" y1=\"{top}\" y2=\"{axis_y}\" stroke=\"#eee\"/>\
             <text x=\"{x:.1}\" y=\"{:.1}\" text-anchor=\"middle\">{t:.3}</text>",
            axis_y + 13.0
        );
    }
    for (i, g) in groups.iter().enumerate() {
        let d = &g.vdv_per_hour_m_s175;
        let y = top + row_h * i as f64 + row_h / 2.0;
        let _ = write!(
            h,
            "<text x=\"{:.1}\" y=\"{:.1}\" text-anchor=\"end\">{} ({})</text>\
             <line x1=\"{:.1}\" x2=\"{:.1}\" y1=\"{y:.1}\" y2=\"{y:.1}\" stroke=\"#666\"/>\
             <rect x=\"{:.1}\" y=\"{:.1}\" width=\"{:.1}\" height=\"12\" fill=\"#cfe0f3\" stroke=\"#4a78a8\"/>",
            label_w - 6.0,
            y + 4.0,
            escape(&g.key),
            g.missions,
            sx(d.p10),
            sx(d.p90),
            sx(d.p25),
            y - 6.0,
            (sx(d.p75) - sx(d.p25)).max(1.0)
        );
        if let Some([lo, hi]) = d.median_ci95 {
            let _ = write!(
                h,
                "<rect x=\"{:.1}\" y=\"{:.1}\" width=\"{:.1}\" height=\"6\" fill=\"#e65a00\" fill-opacity=\"0.55\"/>",
                sx(lo),
                y - 3.0,
                (sx(hi) - sx(lo)).max(1.0)
            );
        }
        let _ = write!(
            h,
            "<line x1=\"{m:.1}\" x2=\"{m:.1}\" y1=\"{:.1}\" y2=\"{:.1}\" stroke=\"#111\" stroke-width=\"2\"/>",
            y - 7.0,
            y + 7.0,
            m = sx(d.median)
        );
    }
    let _ = write!(
        h,
        "<text x=\"{:.1}\" y=\"{:.1}\" text-anchor=\"middle\">VDV per hour of ride, m/s^1.75</text>\
         </svg>\n<figcaption>Per {by} (missions): whiskers from the 10th to the 90th \
         percentile, the box the quartiles, the black line the median and the orange band \
         its 95&nbsp;% interval.</figcaption></figure>\n",
        (label_w + w - right) / 2.0,
        ht - 4.0
    );
    let _ = writeln!(
        h,
        "<table><tr><th class=\"text\">{by}</th><th>missions</th><th>hours</th>\
         <th>VDV/h median [95&nbsp;%]</th><th>quartiles</th><th>at warning, s</th>\
         <th>at alarm, s</th><th>share at warning or alarm</th><th>missions reaching \
         warning / alarm</th></tr>"
    );
    for g in groups {
        let d = &g.vdv_per_hour_m_s175;
        let _ = writeln!(
            h,
            "<tr><td>{}</td><td>{}</td><td>{:.1}</td><td>{:.3} {}</td><td>{:.3} to {:.3}</td>\
             <td>{:.0}</td><td>{:.0}</td><td>{:.1} %</td><td>{} / {}</td></tr>",
            escape(&g.key),
            g.missions,
            g.duration_h,
            d.median,
            ci(d),
            d.p25,
            d.p75,
            g.warning_s,
            g.alarm_s,
            100.0 * g.warning_or_alarm_fraction,
            g.warning_or_alarm_missions,
            g.alarm_missions
        );
    }
    h.push_str("</table>\n");
    let outputs: Vec<(String, String)> = groups
        .iter()
        .flat_map(|g| g.joints.iter().map(|j| (j.output.clone(), j.unit.clone())))
        .fold(Vec::new(), |mut acc, o| {
            if !acc.contains(&o) {
                acc.push(o);
            }
            acc
        });
    if outputs.is_empty() {
        return;
    }
    let _ = write!(
        h,
        "<h3>Joints' largest excursions per mission, median (largest), by {by}</h3>\n\
         <table><tr><th class=\"text\">{by}</th>"
    );
    for (o, u) in &outputs {
        let _ = write!(h, "<th>{}, {}</th>", escape(o), escape(u));
    }
    h.push_str("</tr>\n");
    for g in groups {
        let _ = write!(h, "<tr><td>{}</td>", escape(&g.key));
        for (o, _) in &outputs {
            match g.joints.iter().find(|j| &j.output == o) {
                Some(j) => {
                    let _ = write!(
                        h,
                        "<td>{:.2} ({:.2})</td>",
                        j.largest_excursion.median, j.largest_excursion.max
                    );
                }
                None => h.push_str("<td></td>"),
            }
        }
        h.push_str("</tr>\n");
    }
    h.push_str("</table>\n");
}

fn compare(h: &mut String, view: &FleetView) {
    h.push_str("<h2>Compare</h2>\n");
    let Some(c) = &view.compare else {
        h.push_str(
            "<p>Nothing to compare: give <code>--compare FIELD=VALUE</code> twice, or \
                    archive missions of two groups.</p>\n",
        );
        return;
    };
    h.push_str("<table><tr><th class=\"text\">group</th><th>missions</th><th>VDV/h median [95&nbsp;%]</th><th>quartiles</th></tr>\n");
    for side in [&c.a, &c.b] {
        match &side.vdv_per_hour_m_s175 {
            Some(d) => {
                let _ = writeln!(
                    h,
                    "<tr><td>{}</td><td>{}</td><td>{:.3} {}</td><td>{:.3} to {:.3}</td></tr>",
                    escape(&side.label),
                    d.missions,
                    d.median,
                    ci(d),
                    d.p25,
                    d.p75
                );
            }
            None => {
                let _ = writeln!(
                    h,
                    "<tr><td>{}</td><td>0</td><td></td><td></td></tr>",
                    escape(&side.label)
                );
            }
        }
    }
    h.push_str("</table>\n");
    match (&c.mann_whitney, c.median_difference_m_s175) {
        (Some(t), Some(diff)) => {
            let _ = writeln!(
                h,
                "<p>The median VDV per hour of <b>{}</b> is {:+.3} m/s<sup>1.75</sup> from \
                 that of <b>{}</b>. {} (U = {:.1}, z = {:.2}, p = {:.4}; {}; a difference is \
                 called more than chance when p &lt; {SIGNIFICANCE}).</p>",
                escape(&c.b.label),
                diff,
                escape(&c.a.label),
                if c.more_than_chance {
                    "<span class=\"bad\">The difference is more than chance</span>"
                } else {
                    "<span class=\"ok\">The difference could be chance</span>"
                },
                t.u_statistic,
                t.z_score,
                t.p_value,
                c.test
            );
        }
        _ => h.push_str("<p>A group has no missions (or every value is tied): no test.</p>\n"),
    }
}

fn worst(h: &mut String, view: &FleetView) {
    h.push_str("<h2>Worst missions</h2>\n<p>By VDV per hour of ride; \
                <code>supine archive show ID</code> shows a mission in full.</p>\n\
                <table><tr><th>id</th><th class=\"text\">start</th><th class=\"text\">vehicle</th>\
                <th class=\"text\">crew</th><th class=\"text\">driver</th><th class=\"text\">route</th>\
                <th>duration, min</th><th>VDV, m/s^1.75</th><th>VDV/h</th><th class=\"text\">highest level</th></tr>\n");
    let text = |v: &Option<String>| escape(v.as_deref().unwrap_or(""));
    for m in &view.worst {
        let _ = writeln!(
            h,
            "<tr id=\"mission-{id}\"><td>{id}</td><td class=\"text\">{}</td><td class=\"text\">{}</td>\
             <td class=\"text\">{}</td><td class=\"text\">{}</td><td class=\"text\">{}</td>\
             <td>{:.1}</td><td>{:.3}</td><td>{:.3}</td><td class=\"text\">{}</td></tr>",
            text(&m.start),
            text(&m.vehicle),
            text(&m.crew),
            text(&m.driver),
            text(&m.route),
            m.duration_s / 60.0,
            m.vdv_m_s175,
            m.vdv_per_hour_m_s175,
            tag(&m.max_level),
            id = m.id
        );
    }
    h.push_str("</table>\n");
}

/// Most places drawn on the map (the worst); the table lists [`ROAD_LISTED`].
const ROAD_DRAWN: usize = 5000;
/// Places in the table of the worst.
const ROAD_LISTED: usize = 10;

/// A place's colour: green to red over the drawn places' rms, lowest to highest.
fn rms_colour(rms: f64, low: f64, high: f64) -> String {
    let t = if high > low {
        ((rms - low) / (high - low)).clamp(0.0, 1.0)
    } else {
        1.0
    };
    format!("hsl({:.0},80%,40%)", 120.0 * (1.0 - t))
}

fn road(h: &mut String, view: &FleetView) {
    h.push_str("<h2>Road segments</h2>\n");
    let places = &view.road_segments[..view.road_segments.len().min(ROAD_DRAWN)];
    if places.is_empty() {
        h.push_str(
            "<p>No mission in this view has positions, so there is no map of road segments. \
             It appears once rides carry GPS positions.</p>\n",
        );
        return;
    }
    // An equirectangular map around the places' middle latitude: one scale both ways.
    let (mut lat0, mut lat1, mut lon0, mut lon1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    for p in places {
        lat0 = lat0.min(p.lat_deg);
        lat1 = lat1.max(p.lat_deg);
        lon0 = lon0.min(p.lon_deg);
        lon1 = lon1.max(p.lon_deg);
    }
    let k = ((lat0 + lat1) / 2.0).to_radians().cos();
    let (w, pad) = (1060.0, 12.0);
    let span_x = ((lon1 - lon0) * k).max(1e-6);
    let span_y = (lat1 - lat0).max(1e-6);
    let scale = ((w - 2.0 * pad) / span_x).min(600.0 / span_y);
    let ht = span_y * scale + 2.0 * pad;
    let rms = places.iter().map(|p| p.rms_m_s2);
    let low = rms.clone().fold(f64::MAX, f64::min);
    let high = rms.fold(f64::MIN, f64::max);
    let _ = writeln!(
        h,
        "<figure><svg viewBox=\"0 0 {w} {ht:.0}\" width=\"{w}\" height=\"{ht:.0}\" \
         role=\"img\" aria-label=\"Map of road segments\">"
    );
    // The worst last, so they are drawn on top.
    for p in places.iter().rev() {
        let x = pad + (p.lon_deg - lon0) * k * scale;
        let y = pad + (lat1 - p.lat_deg) * scale;
        let r = 2.0 + (p.passes as f64).log2().min(4.0);
        let _ = writeln!(
            h,
            "<circle cx=\"{x:.1}\" cy=\"{y:.1}\" r=\"{r:.1}\" fill=\"{}\"><title>{:.5}, \
             {:.5}: rms {:.3} m/s^2 over {} ({})</title></circle>",
            rms_colour(p.rms_m_s2, low, high),
            p.lat_deg,
            p.lon_deg,
            p.rms_m_s2,
            count(p.passes, "pass"),
            count(p.missions, "mission")
        );
    }
    let _ = writeln!(
        h,
        "</svg><figcaption>{} places of about 50&nbsp;m passed{}; each coloured by the \
         head's weighted rms over all its passes, from green ({low:.3} m/s^2) to red \
         ({high:.3} m/s^2), larger with more passes.</figcaption></figure>",
        view.road_segments.len(),
        if view.road_segments.len() > ROAD_DRAWN {
            format!(" (the {ROAD_DRAWN} worst drawn)")
        } else {
            String::new()
        }
    );
    h.push_str(
        "<table><tr><th>latitude</th><th>longitude</th><th>passes</th><th>missions</th>\
         <th>rms, m/s^2</th><th>largest pass rms, m/s^2</th></tr>\n",
    );
    for p in places.iter().take(ROAD_LISTED) {
        let _ = writeln!(
            h,
            "<tr><td>{:.5}</td><td>{:.5}</td><td>{}</td><td>{}</td><td>{:.3}</td>\
             <td>{:.3}</td></tr>",
            p.lat_deg, p.lon_deg, p.passes, p.missions, p.rms_m_s2, p.max_rms_m_s2
        );
    }
    h.push_str("</table>\n");
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ticks_are_round_and_cover_the_range() {
        let t = ticks(0.0, 1.0);
        assert_eq!(t.len(), 6);
        assert!(
            t.iter()
                .zip([0.0, 0.2, 0.4, 0.6, 0.8, 1.0])
                .all(|(a, b)| (a - b).abs() < 1e-12)
        );
        let t = ticks(3.0, 47.0);
        assert_eq!(t.first().copied(), Some(10.0));
        assert_eq!(t.last().copied(), Some(40.0));
    }

    #[test]
    fn time_ticks_are_distinct_round_times_within_the_range() {
        // 2026-03-02 09:30 UTC, then spans of a day, a month and three years.
        let start = 1_772_443_800.0;
        for (span_s, label_len) in [
            (86_400.0, 16),
            (30.0 * 86_400.0, 10),
            (3.0e3 * 86_400.0, 10),
        ] {
            let ticks = time_ticks(start, start + span_s);
            assert!((2..=7).contains(&ticks.len()), "{ticks:?}");
            let labels: std::collections::BTreeSet<&String> =
                ticks.iter().map(|(_, l)| l).collect();
            assert_eq!(labels.len(), ticks.len(), "{ticks:?}");
            for (t, label) in &ticks {
                assert!((start..=start + span_s).contains(t), "{ticks:?}");
                assert_eq!(label.len(), label_len, "{label}");
            }
        }
        // Days fall on midnight UTC.
        assert!(
            time_ticks(start, start + 30.0 * 86_400.0)
                .iter()
                .all(|(t, _)| t % 86_400.0 == 0.0)
        );
        assert_eq!(time_ticks(start, start + 86_400.0)[0].1, "2026-03-02 12:00");
    }
}
