//! The report's data-quality section: per leg, the one-line verdict of its data-quality
//! account ([`crate::ride::quality`]) and the figures behind it, near the top of the page,
//! so that a reader sees how far the values below can be trusted before reading them.

use std::fmt::Write as _;

use crate::report::markup::escape;
use crate::report::mission::Leg;
use crate::ride::quality::DataQuality;

/// The section, or nothing when no leg carries an account (recordings).
pub fn section(h: &mut String, legs: &[Leg]) {
    let accounts: Vec<(usize, &Leg, &DataQuality)> = legs
        .iter()
        .enumerate()
        .filter_map(|(i, l)| l.exposure.data_quality.as_ref().map(|q| (i, l, q)))
        .collect();
    if accounts.is_empty() {
        return;
    }
    h.push_str("<h2>Data quality</h2>\n");
    for (_, leg, q) in &accounts {
        let class = match q.verdict {
            "good" => "normal",
            "usable with caveats" => "advisory",
            _ => "alarm",
        };
        let _ = writeln!(
            h,
            "<p class=\"verdict lvl-{class}\"><b>{}:</b> <span class=\"tag tag-{class}\">{}</span>{}</p>",
            escape(&leg.label),
            q.verdict,
            if q.reasons.is_empty() {
                String::new()
            } else {
                format!(": {}", escape(&q.reasons.join("; ")))
            }
        );
    }
    h.push_str(
        "<table>\n<tr><th>leg</th><th>format</th><th>source rate (median step)</th>\
         <th>step p99</th><th>sensor's own rate</th><th>evaluated at</th><th>band covered</th>\
         <th>gaps (longest, total)</th><th>rows dropped / repeated</th><th>gravity, tilt</th>\
         <th>clipped samples</th></tr>\n",
    );
    for (i, _, q) in &accounts {
        let gravity = match q.levelling {
            Some(l) => format!(
                "{:.3} m/s<sup>2</sup>{}, {:.1}&deg; ({})",
                l.gravity_m_s2,
                if q.gravity_scale_error {
                    " (scale error)"
                } else {
                    ""
                },
                l.tilt_rad.to_degrees(),
                l.method
            ),
            None => "not in the file".to_string(),
        };
        let clipped: u64 = q.clipping.iter().map(|c| c.samples).sum();
        let clipping = if clipped == 0 {
            "0".to_string()
        } else {
            q.clipping
                .iter()
                .map(|c| {
                    format!(
                        "{} at {:.3} ({} from {:.1} s)",
                        c.axis, c.value_m_s2, c.samples, c.first_s
                    )
                })
                .collect::<Vec<_>>()
                .join("; ")
        };
        let _ = writeln!(
            h,
            "<tr><td>{}</td><td class=\"text\">{}</td><td>{:.1} Hz ({:.2} ms)</td><td>{:.2} ms</td>\
             <td>{:.1} Hz</td><td>{} Hz</td><td>0-{:.1} Hz</td><td>{} ({:.2} s, {:.2} s)</td>\
             <td>{} / {}</td><td>{gravity}</td><td>{clipping}</td></tr>",
            i + 1,
            escape(&q.format),
            q.source_rate_hz,
            1e3 * q.step_median_s,
            1e3 * q.step_p99_s,
            q.effective_rate_hz,
            q.resampled_rate_hz,
            q.band_upper_hz,
            q.gaps,
            q.gap_longest_s,
            q.gap_total_s,
            q.dropped_samples,
            q.repeated_samples
        );
    }
    h.push_str("</table>\n");
    let gaps: Vec<String> = accounts
        .iter()
        .flat_map(|(i, _, q)| {
            q.gap_list
                .iter()
                .map(move |g| format!("leg {} at {:.2} s for {:.2} s", i + 1, g.at_s, g.length_s))
        })
        .take(20)
        .collect();
    if !gaps.is_empty() {
        let _ = writeln!(
            h,
            "<p>Gaps longer than the bound are not bridged: the exposure pauses across them ({}).</p>",
            gaps.join("; ")
        );
    }
}
