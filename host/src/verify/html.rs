//! The conformance report: one self-contained, printable HTML page (inline CSS, no script
//! or external resource), like the mission report. Every piece of text that did not come
//! from this file is escaped.

use std::fmt::Write as _;

use super::{Conformance, TestResult};
use crate::report::markup::escape;

const STYLE: &str = "
body { font-family: system-ui, sans-serif; color: #222; margin: 0; }
main { max-width: 1100px; margin: 0 auto; padding: 20px 28px; }
h1 { font-size: 24px; margin: 4px 0; } h2 { font-size: 18px; margin: 24px 0 6px; border-bottom: 1px solid #ddd; }
p, td, th, li { font-size: 13px; line-height: 1.4; }
table { border-collapse: collapse; width: 100%; }
td, th { border-bottom: 1px solid #eee; padding: 2px 6px; text-align: right; }
td.l, th.l { text-align: left; }
.pass { color: #1d6b3a; font-weight: 600; } .fail { color: #b00000; font-weight: 700; }
.verdict { border-left: 8px solid #2e8b57; padding: 8px 14px; background: #f6fbf7; font-size: 18px; }
.verdict.bad { border-color: #c80000; background: #fff4f4; }
.note { border: 1px solid #ccc; padding: 8px 14px; background: #fafafa; }
code { font-size: 12px; }
@media print { main { max-width: none; padding: 0; } tr, .note { break-inside: avoid; } h2 { break-after: avoid; } }
";

fn number(v: f64) -> String {
    if !v.is_finite() {
        return "n/a".to_string();
    }
    if v == 0.0 {
        return "0".to_string();
    }
    let digits = (4 - v.abs().log10().floor() as i32).clamp(0, 8) as usize;
    format!("{v:.digits$}")
}

fn row(h: &mut String, t: &TestResult) {
    let deviation = t
        .deviation_percent()
        .map_or_else(|| "n/a".to_string(), |d| format!("{d:+.2} %"));
    let _ = writeln!(
        h,
        "<tr><td class=\"l\">{}</td><td class=\"l\">{}</td><td>{}</td><td>{}</td><td>{}</td>\
         <td>{}</td><td>{} to {}</td><td class=\"l\">{}</td><td class=\"{}\">{}</td></tr>",
        escape(&t.name),
        escape(&t.weighting),
        t.frequency_hz.map_or_else(|| "-".to_string(), number),
        number(t.expected),
        number(t.measured),
        deviation,
        number(t.lower_limit),
        number(t.upper_limit),
        escape(&t.unit),
        if t.pass { "pass" } else { "fail" },
        if t.pass { "pass" } else { "FAIL" },
    );
}

/// The page for `c`.
pub fn render(c: &Conformance) -> String {
    let mut h = String::with_capacity(1 << 18);
    let _ = write!(
        h,
        "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n\
         <title>supine ISO 8041-1 self-verification</title>\n<style>{STYLE}</style>\n</head>\n\
         <body>\n<main>\n<h1>ISO 8041-1 self-verification of the supine device</h1>\n"
    );
    let failed = c.tests.iter().filter(|t| !t.pass).count();
    let mut rates: Vec<f64> = c.tests.iter().map(|t| t.fs_hz).collect();
    rates.dedup();
    let _ = writeln!(
        h,
        "<p class=\"verdict{}\">{}: {} tests at {} Hz, {} failed.</p>",
        if c.pass { "" } else { " bad" },
        if c.pass { "PASS" } else { "FAIL" },
        c.tests.len(),
        rates
            .iter()
            .map(|r| r.to_string())
            .collect::<Vec<_>>()
            .join(", "),
        failed
    );
    let _ = writeln!(
        h,
        "<table><tr><th class=\"l\">firmware image (SHA-256)</th><td class=\"l\"><code>{}</code></td></tr>\
         <tr><th class=\"l\">firmware version</th><td class=\"l\">{}</td></tr>\
         <tr><th class=\"l\">verification parameter set (identity)</th><td class=\"l\"><code>{}</code></td></tr>\
         <tr><th class=\"l\">date (UTC)</th><td class=\"l\">{}</td></tr></table>",
        escape(&c.firmware_sha256),
        escape(&c.version),
        escape(&c.params_identity),
        escape(&c.date)
    );
    h.push_str(
        "<div class=\"note\"><p><strong>What this is.</strong> A self-verification of the \
         device's electrical and computational chain against ISO 8041-1's electrical tests \
         for a whole-body instrument with the Wk, Wd and Wj weightings: the firmware image \
         above, the one that ships, ran in QEMU (mps2-an386) with a verification parameter \
         set whose model passes the input straight to the weighting; the weighting, running \
         rms, MTVV, VDV and fault logic are the shipping ones. Expected values come from the \
         standard's definitions (the analog weighting, the exponential running rms, the VDV), \
         tolerances from its tables (docs/exposure.md).</p>\
         <p><strong>What this is not.</strong> Not a type approval or a pattern evaluation by \
         an accredited laboratory. The accelerometer and its mounting are not covered: they \
         are calibrated separately (the calibration record every report states), and a \
         real board's timing, anti-alias filter and supply are not emulated. Linear \
         integration is not tested: the product implements exponential averaging only.</p></div>\n",
    );
    for rate in &rates {
        let _ = writeln!(h, "<h2>{rate} Hz</h2>");
        h.push_str(
            "<table><tr><th class=\"l\">test</th><th class=\"l\">weighting</th><th>f, Hz</th>\
             <th>expected</th><th>measured</th><th>deviation</th><th>limits</th>\
             <th class=\"l\">unit</th><th>result</th></tr>\n",
        );
        let mut clause = String::new();
        for t in c.tests.iter().filter(|t| t.fs_hz == *rate) {
            if t.clause != clause {
                clause = t.clause.clone();
                let _ = writeln!(
                    h,
                    "<tr><th class=\"l\" colspan=\"9\">{}</th></tr>",
                    escape(&clause)
                );
            }
            row(&mut h, t);
        }
        h.push_str("</table>\n");
    }
    h.push_str("</main>\n</body>\n</html>\n");
    h
}
