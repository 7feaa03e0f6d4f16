//! Minimal SVG line plots for reports, written as SVG text (no plotting crate: plotters'
//! build cost is not worth a few line charts). A figure is a grid of panels; each panel
//! has linear or log axes, ticks, and polylines.

use std::fmt::Write as _;

/// One line of a panel.
#[derive(Clone, Debug, PartialEq)]
pub struct Series {
    /// (x, y) points; non-finite values break the line.
    pub points: Vec<(f64, f64)>,
    /// An SVG colour, e.g. `#bbbbbb`.
    pub color: String,
    /// Stroke width, px.
    pub width: f64,
    /// Dashed stroke.
    pub dashed: bool,
    /// Legend text (series without one are left out of the legend).
    pub label: Option<String>,
}

impl Series {
    /// A solid line.
    pub fn line(points: Vec<(f64, f64)>, color: &str, width: f64, label: Option<&str>) -> Self {
        Self {
            points,
            color: color.to_string(),
            width,
            dashed: false,
            label: label.map(str::to_string),
        }
    }
}

/// One chart.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct Panel {
    /// Title above the chart.
    pub title: String,
    /// X axis label.
    pub x_label: String,
    /// Y axis label.
    pub y_label: String,
    /// Logarithmic y axis (non-positive values are dropped).
    pub log_y: bool,
    /// Fixed y range, else from the data.
    pub y_range: Option<(f64, f64)>,
    /// The lines, drawn in order.
    pub series: Vec<Series>,
}

const PANEL_W: f64 = 300.0;
const PANEL_H: f64 = 200.0;
const MARGIN_L: f64 = 55.0;
const MARGIN_R: f64 = 12.0;
const MARGIN_T: f64 = 24.0;
const MARGIN_B: f64 = 36.0;

fn nice_ticks(lo: f64, hi: f64) -> Vec<f64> {
    let span = (hi - lo).max(1e-300);
    let raw = span / 5.0;
    let mag = 10f64.powf(raw.log10().floor());
    let step = [1.0, 2.0, 5.0, 10.0]
        .iter()
        .map(|m| m * mag)
        .find(|s| span / s <= 6.0)
        .unwrap_or(10.0 * mag);
    let mut ticks = Vec::new();
    let mut t = (lo / step).ceil() * step;
    while t <= hi + step * 1e-9 {
        ticks.push(if t.abs() < step * 1e-9 { 0.0 } else { t });
        t += step;
    }
    ticks
}

fn fmt_tick(v: f64) -> String {
    if v != 0.0 && (v.abs() >= 1e4 || v.abs() < 1e-2) {
        format!("{v:.0e}")
    } else {
        let s = format!("{v:.3}");
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    }
}

fn escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}

fn render_panel(out: &mut String, panel: &Panel, ox: f64, oy: f64) {
    let ty = |y: f64| if panel.log_y { y.log10() } else { y };
    let valid = |&(x, y): &(f64, f64)| x.is_finite() && y.is_finite() && (!panel.log_y || y > 0.0);
    let pts = || {
        panel
            .series
            .iter()
            .flat_map(|s| s.points.iter())
            .filter(|p| valid(p))
    };
    let (mut x0, mut x1) = (f64::INFINITY, f64::NEG_INFINITY);
    let (mut y0, mut y1) = (f64::INFINITY, f64::NEG_INFINITY);
    for &(x, y) in pts() {
        x0 = x0.min(x);
        x1 = x1.max(x);
        y0 = y0.min(ty(y));
        y1 = y1.max(ty(y));
    }
    if let Some((a, b)) = panel.y_range {
        (y0, y1) = (ty(a), ty(b));
    }
    if !x0.is_finite() {
        (x0, x1, y0, y1) = (0.0, 1.0, 0.0, 1.0);
    }
    if x1 <= x0 {
        x1 = x0 + 1.0;
    }
    if y1 <= y0 {
        let pad = y0.abs().max(1.0) * 0.1;
        (y0, y1) = (y0 - pad, y1 + pad);
    } else if panel.y_range.is_none() {
        let pad = 0.05 * (y1 - y0);
        (y0, y1) = (y0 - pad, y1 + pad);
    }
    let (pw, ph) = (PANEL_W - MARGIN_L - MARGIN_R, PANEL_H - MARGIN_T - MARGIN_B);
    let (px, py) = (ox + MARGIN_L, oy + MARGIN_T);
    let sx = |x: f64| px + (x - x0) / (x1 - x0) * pw;
    let sy = |y: f64| py + ph - (ty(y) - y0) / (y1 - y0) * ph;
    let _ = writeln!(
        out,
        r##"<rect x="{px:.1}" y="{py:.1}" width="{pw:.1}" height="{ph:.1}" fill="white" stroke="#444"/>"##
    );
    let _ = writeln!(
        out,
        r#"<text x="{:.1}" y="{:.1}" text-anchor="middle" font-size="12" font-weight="bold">{}</text>"#,
        px + pw / 2.0,
        oy + 16.0,
        escape(&panel.title)
    );
    for t in nice_ticks(x0, x1) {
        let x = sx(t);
        let _ = writeln!(
            out,
            r##"<line x1="{x:.1}" y1="{:.1}" x2="{x:.1}" y2="{:.1}" stroke="#ddd"/><text x="{x:.1}" y="{:.1}" text-anchor="middle" font-size="9">{}</text>"##,
            py,
            py + ph,
            py + ph + 11.0,
            fmt_tick(t)
        );
    }
    for t in nice_ticks(y0, y1) {
        let y = py + ph - (t - y0) / (y1 - y0) * ph;
        let label = if panel.log_y {
            fmt_tick(10f64.powf(t))
        } else {
            fmt_tick(t)
        };
        let _ = writeln!(
            out,
            r##"<line x1="{px:.1}" y1="{y:.1}" x2="{:.1}" y2="{y:.1}" stroke="#ddd"/><text x="{:.1}" y="{:.1}" text-anchor="end" font-size="9">{label}</text>"##,
            px + pw,
            px - 3.0,
            y + 3.0
        );
    }
    let _ = writeln!(
        out,
        r#"<text x="{:.1}" y="{:.1}" text-anchor="middle" font-size="10">{}</text>"#,
        px + pw / 2.0,
        py + ph + 26.0,
        escape(&panel.x_label)
    );
    let _ = writeln!(
        out,
        r#"<text x="{:.1}" y="{:.1}" text-anchor="middle" font-size="10" transform="rotate(-90 {:.1} {:.1})">{}</text>"#,
        ox + 14.0,
        py + ph / 2.0,
        ox + 14.0,
        py + ph / 2.0,
        escape(&panel.y_label)
    );
    for s in &panel.series {
        let dash = if s.dashed {
            r#" stroke-dasharray="5,3""#
        } else {
            ""
        };
        let mut run: Vec<String> = Vec::new();
        let flush = |run: &mut Vec<String>, out: &mut String| {
            if run.len() > 1 {
                let _ = writeln!(
                    out,
                    r#"<polyline fill="none" stroke="{}" stroke-width="{}"{dash} points="{}"/>"#,
                    s.color,
                    s.width,
                    run.join(" ")
                );
            }
            run.clear();
        };
        for p in &s.points {
            let inside = valid(p)
                && (ty(p.1) >= y0 - 1e-9 && ty(p.1) <= y1 + 1e-9 || panel.y_range.is_none());
            if inside {
                run.push(format!("{:.1},{:.1}", sx(p.0), sy(p.1)));
            } else {
                flush(&mut run, out);
            }
        }
        flush(&mut run, out);
    }
}

/// A figure of `panels` in a grid of `columns`, with a title and a legend of the first
/// panel's labelled series.
pub fn figure_svg(title: &str, panels: &[Panel], columns: usize) -> String {
    let columns = columns.max(1);
    let rows = panels.len().div_ceil(columns);
    let top = 48.0;
    let width = PANEL_W * columns as f64;
    let height = top + PANEL_H * rows as f64;
    let mut out = String::new();
    let _ = writeln!(
        out,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{width}" height="{height}" viewBox="0 0 {width} {height}" font-family="sans-serif">"#
    );
    let _ = writeln!(out, r#"<rect width="100%" height="100%" fill="white"/>"#);
    let _ = writeln!(
        out,
        r#"<text x="{:.1}" y="20" text-anchor="middle" font-size="15" font-weight="bold">{}</text>"#,
        width / 2.0,
        escape(title)
    );
    if let Some(first) = panels.first() {
        let mut x = 10.0;
        for s in first.series.iter().filter(|s| s.label.is_some()) {
            let label = escape(s.label.as_deref().unwrap_or(""));
            let _ = writeln!(
                out,
                r#"<line x1="{x:.1}" y1="36" x2="{:.1}" y2="36" stroke="{}" stroke-width="{}"/><text x="{:.1}" y="40" font-size="11">{label}</text>"#,
                x + 20.0,
                s.color,
                s.width.max(1.5),
                x + 24.0
            );
            x += 40.0 + 6.5 * label.len() as f64;
        }
    }
    for (i, panel) in panels.iter().enumerate() {
        let (c, r) = (i % columns, i / columns);
        render_panel(
            &mut out,
            panel,
            c as f64 * PANEL_W,
            top + r as f64 * PANEL_H,
        );
    }
    out.push_str("</svg>\n");
    out
}
