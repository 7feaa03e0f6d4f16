//! The report's "Where it happened" section: the route map, what each leg's track was
//! worth, the worst road segments and the running rms against speed; or, for rides with
//! no positions, a plain statement that the report cannot say where
//! (`docs/exposure.md#positions-and-road-segments`).

use std::fmt::Write as _;

use anyhow::Result;
use supine_core::alerts::{AlertConfig, Level};

use crate::report::markup::escape;
use crate::report::mission::Leg;
use crate::report::route::{SEGMENT_LENGTH_M, Segment};
use crate::report::route_charts::{rms_against_speed, route_map};
use crate::ride::position::{MAX_FIX_AGE_S, MAX_PLAUSIBLE_SPEED_M_S, POOR_ACCURACY_M};

/// The section.
pub fn section(h: &mut String, legs: &[Leg], config: &AlertConfig) -> Result<()> {
    h.push_str("<section><h2>Where it happened</h2>\n");
    let Some(map) = route_map(legs, config) else {
        let any = legs.iter().any(|l| l.route.is_some());
        let _ = writeln!(
            h,
            "<p class=\"caveat\">{} the report cannot say where the patient was shaken. \
             Give each ride its track: <code>--track FILE</code> (a GPX file, or the location \
             file a phone app writes beside its accelerometer file), or the ride's own \
             latitude and longitude columns with <code>--columns ...,lat=NAME,lon=NAME</code>.</p>\n</section>",
            if any {
                "The tracks given are too sparse to draw (fewer than two placed points):"
            } else {
                "No positions: these rides have no position track, so"
            }
        );
        return Ok(());
    };
    let _ = writeln!(
        h,
        "<figure>\n{}\n<figcaption>The track in a local metric frame (north up), coloured by \
         the head's 1 s weighted running rms (vector sum) against the running-rms thresholds; \
         each leg cased in its own colour, its start a circle and its end a square; each alert \
         event a triangle in its level's colour where it happened (raised levels named, with \
         mission time). No map tiles: the page opens offline.</figcaption>\n</figure>",
        map.to_svg()?
    );
    h.push_str("<ul>\n");
    for leg in legs {
        let name = escape(&leg.label);
        let Some(route) = &leg.route else {
            let _ = writeln!(h, "<li>{name}: no positions.</li>");
            continue;
        };
        let a = &route.track;
        let mut flags = Vec::new();
        if a.jumps_excluded > 0 {
            flags.push(format!(
                "{} excluded as jumps faster than {MAX_PLAUSIBLE_SPEED_M_S} m/s",
                a.jumps_excluded
            ));
        }
        if a.out_of_order > 0 {
            flags.push(format!("{} excluded as out of time order", a.out_of_order));
        }
        if a.poor_accuracy > 0 {
            flags.push(format!(
                "<strong>{} with an accuracy worse than {POOR_ACCURACY_M} m</strong>",
                a.poor_accuracy
            ));
        }
        let _ = write!(
            h,
            "<li>{name}: {:.2} km in {} segments; {} fixes from {}{}",
            route.length_m / 1000.0,
            route.segments.len(),
            a.fixes,
            escape(&a.source),
            if flags.is_empty() {
                String::new()
            } else {
                format!(" ({})", flags.join(", "))
            }
        );
        if route.unplaced_s > 0.0 {
            let _ = write!(
                h,
                "; <strong>{:.1} s without a position</strong> (outside the track, or between \
                 fixes more than {MAX_FIX_AGE_S} s away), left out of the segments",
                route.unplaced_s
            );
        }
        if route.map.len() < 2 {
            h.push_str("; too sparse to draw");
        }
        h.push_str(".</li>\n");
    }
    h.push_str("</ul>\n");
    worst_table(h, legs);
    if let Some(chart) = rms_against_speed(legs, config) {
        let _ = writeln!(
            h,
            "<figure>\n{}\n<figcaption>The head's running rms (the largest since the map's \
             previous point) against the ground speed there, a colour per leg.</figcaption>\n</figure>",
            chart.to_svg()?
        );
    }
    h.push_str("</section>\n");
    Ok(())
}

/// The worst segments of every leg, by their rms.
fn worst_table(h: &mut String, legs: &[Leg]) {
    let mut rows: Vec<(&Leg, &Segment)> = legs
        .iter()
        .filter_map(|l| l.route.as_ref().map(|r| (l, r)))
        .flat_map(|(l, r)| r.worst_segments.iter().map(move |s| (l, s)))
        .collect();
    if rows.is_empty() {
        return;
    }
    rows.sort_by(|a, b| b.1.rms_m_s2.total_cmp(&a.1.rms_m_s2));
    let _ = writeln!(
        h,
        "<h3>The worst road segments</h3>\n<p>Segments of {SEGMENT_LENGTH_M} m along the track, \
         by the head's weighted rms over the segment (the VDV is the segment's contribution: \
         the leg's VDV<sup>4</sup> is their sum).</p>\n<table>\n<tr><th class=\"text\">leg</th>\
         <th>mission time, s</th><th>latitude, longitude</th><th>speed, m/s</th><th>rms, m/s&sup2;</th>\
         <th>VDV, m/s<sup>1.75</sup></th><th>largest running rms, m/s&sup2;</th><th class=\"text\">highest level</th></tr>"
    );
    for (leg, s) in rows.iter().take(10) {
        let highest = s
            .time_at_level_s
            .as_array()
            .iter()
            .rposition(|t| *t > 0.0)
            .unwrap_or(0);
        let _ = writeln!(
            h,
            "<tr><td class=\"text\">{}</td><td>{:.1}&ndash;{:.1}</td><td>{:.5}, {:.5}</td><td>{:.1}</td>\
             <td>{:.3}</td><td>{:.3}</td><td>{:.3}</td><td class=\"text\">{}</td></tr>",
            escape(&leg.label),
            leg.start_s + s.start_s,
            leg.start_s + s.end_s,
            s.lat_deg,
            s.lon_deg,
            s.speed_m_s,
            s.rms_m_s2,
            s.vdv_m_s175,
            s.max_running_rms_m_s2,
            Level::ALL[highest].name()
        );
    }
    h.push_str("</table>\n");
}
