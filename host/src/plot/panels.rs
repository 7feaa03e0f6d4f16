//! Line-plot figures for the command line's reports (`fit --report`, `validate --report`):
//! a grid of panels, each with linear or logarithmic y, ticks and lines.

use std::ops::Range;

use anyhow::Result;
use plotters::coord::ranged1d::{AsRangedCoord, ValueFormatter};
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use super::{Rgb, plot_error};

/// One line of a panel.
#[derive(Clone, Debug, PartialEq)]
pub struct Series {
    /// (x, y) points; non-finite values (and, on a log axis, non-positive ones) break the line.
    pub points: Vec<(f64, f64)>,
    /// Colour.
    pub color: Rgb,
    /// Stroke width, px.
    pub width: f64,
    /// Dashed stroke.
    pub dashed: bool,
    /// Legend text (series without one are left out of the legend).
    pub label: Option<String>,
}

impl Series {
    /// A solid line in the colour written `#rrggbb` (see [`Rgb::from_hex`]).
    pub fn line(points: Vec<(f64, f64)>, color: &str, width: f64, label: Option<&str>) -> Self {
        Self {
            points,
            color: Rgb::from_hex(color),
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
    /// Logarithmic x axis (non-positive values are dropped): a spectrum over decades.
    pub log_x: bool,
    /// Fixed x range, else the data's; points outside it are dropped.
    pub x_range: Option<(f64, f64)>,
    /// Fixed y range, else from the data; points outside it break the line.
    pub y_range: Option<(f64, f64)>,
    /// The lines, drawn in order.
    pub series: Vec<Series>,
}

/// Size of one panel, px.
const PANEL_PX: (u32, u32) = (340, 240);
/// Height of the figure's title and legend, px.
const TOP_PX: u32 = 56;

impl Panel {
    fn usable(&self, &(x, y): &(f64, f64)) -> bool {
        x.is_finite()
            && y.is_finite()
            && (!self.log_y || y > 0.0)
            && (!self.log_x || x > 0.0)
            && self.x_range.is_none_or(|(a, b)| (a..=b).contains(&x))
    }

    /// The x and y ranges: the data's (y padded by 5 %, of log10 y on a log axis), or the
    /// fixed y range; never empty.
    fn ranges(&self) -> (Range<f64>, Range<f64>) {
        let (mut x0, mut x1) = (f64::INFINITY, f64::NEG_INFINITY);
        let (mut y0, mut y1) = (f64::INFINITY, f64::NEG_INFINITY);
        for p in self
            .series
            .iter()
            .flat_map(|s| &s.points)
            .filter(|p| self.usable(p))
        {
            x0 = x0.min(p.0);
            x1 = x1.max(p.0);
            y0 = y0.min(p.1);
            y1 = y1.max(p.1);
        }
        if !x0.is_finite() {
            (x0, x1) = (0.0, 1.0);
            (y0, y1) = if self.log_y { (0.1, 1.0) } else { (0.0, 1.0) };
        }
        if let Some((a, b)) = self.x_range {
            (x0, x1) = (a, b);
        }
        if x1 <= x0 {
            x1 = x0 + 1.0;
        }
        if let Some((a, b)) = self.y_range {
            return (x0..x1, a..b);
        }
        if self.log_y {
            let (l0, l1) = (y0.log10(), y1.log10());
            let pad = if l1 > l0 { 0.05 * (l1 - l0) } else { 0.5 };
            return (x0..x1, 10f64.powf(l0 - pad)..10f64.powf(l1 + pad));
        }
        if y1 <= y0 {
            let pad = y0.abs().max(1.0) * 0.1;
            return (x0..x1, y0 - pad..y1 + pad);
        }
        let pad = 0.05 * (y1 - y0);
        (x0..x1, y0 - pad..y1 + pad)
    }

    /// The runs of a series' points that can be drawn (split at unusable points and,
    /// with a fixed range, at points outside it).
    fn runs(&self, s: &Series) -> Vec<Vec<(f64, f64)>> {
        let inside = |y: f64| {
            self.y_range
                .is_none_or(|(a, b)| y >= a - 1e-9 * (b - a).abs() && y <= b + 1e-9 * (b - a).abs())
        };
        let mut runs = vec![Vec::new()];
        for p in &s.points {
            if self.usable(p) && inside(p.1) {
                if let Some(run) = runs.last_mut() {
                    run.push(*p);
                }
            } else if runs.last().is_some_and(|r| !r.is_empty()) {
                runs.push(Vec::new());
            }
        }
        runs.retain(|r| r.len() > 1);
        runs
    }
}

fn draw_panel<DB, X, Y>(
    area: &DrawingArea<DB, plotters::coord::Shift>,
    panel: &Panel,
    x: X,
    y: Y,
) -> Result<()>
where
    DB: DrawingBackend,
    X: AsRangedCoord<Value = f64>,
    X::CoordDescType: ValueFormatter<f64>,
    Y: AsRangedCoord<Value = f64>,
    Y::CoordDescType: ValueFormatter<f64>,
{
    let mut chart = ChartBuilder::on(area)
        .caption(
            &panel.title,
            ("sans-serif", 13).into_font().style(FontStyle::Bold),
        )
        .margin(6)
        .x_label_area_size(34)
        .y_label_area_size(52)
        .build_cartesian_2d(x, y)
        .map_err(plot_error)?;
    let mut mesh = chart.configure_mesh();
    mesh.x_desc(panel.x_label.as_str())
        .y_desc(panel.y_label.as_str())
        .x_labels(6)
        .y_labels(6)
        .light_line_style(RGBColor(240, 240, 240))
        .bold_line_style(RGBColor(215, 215, 215))
        .label_style(("sans-serif", 10))
        .axis_desc_style(("sans-serif", 11));
    if panel.log_y {
        mesh.y_label_formatter(&|v| log_tick(*v));
    }
    if panel.log_x {
        mesh.x_label_formatter(&|v| format!("{}", (v * 100.0).round() / 100.0));
    }
    mesh.draw().map_err(plot_error)?;
    for s in &panel.series {
        let style = RGBColor::from(s.color).stroke_width(s.width.round().max(1.0) as u32);
        for run in panel.runs(s) {
            if s.dashed {
                chart
                    .draw_series(DashedLineSeries::new(run, 5, 3, style))
                    .map_err(plot_error)?;
            } else {
                chart
                    .draw_series(LineSeries::new(run, style))
                    .map_err(plot_error)?;
            }
        }
    }
    Ok(())
}

/// A tick of a log axis in short scientific form (`1e-5`, `2.5e-3`): the powers of ten
/// a log axis ticks at come out of `log10` a rounding away, as `9.999999999e-6`.
fn log_tick(v: f64) -> String {
    let short = format!("{v:.1e}");
    short.replace(".0e", "e")
}

/// A figure of `panels` in a grid of `columns`, with a title and a legend of the first
/// panel's labelled series, as an `<svg>` document.
pub fn figure_svg(title: &str, panels: &[Panel], columns: usize) -> Result<String> {
    let columns = columns.max(1);
    let rows = panels.len().div_ceil(columns).max(1);
    let width = PANEL_PX.0 * columns as u32;
    let height = TOP_PX + PANEL_PX.1 * rows as u32;
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (width, height)).into_drawing_area();
        root.fill(&WHITE).map_err(plot_error)?;
        let (top, body) = root.split_vertically(TOP_PX);
        let center = Pos::new(HPos::Center, VPos::Top);
        top.draw(&Text::new(
            title.to_string(),
            (width as i32 / 2, 6),
            TextStyle::from(("sans-serif", 16).into_font().style(FontStyle::Bold)).pos(center),
        ))
        .map_err(plot_error)?;
        if let Some(first) = panels.first() {
            let mut x = 12;
            for s in first.series.iter().filter(|s| s.label.is_some()) {
                let label = s.label.clone().unwrap_or_default();
                let c = RGBColor::from(s.color);
                top.draw(&PathElement::new(
                    vec![(x, 38), (x + 22, 38)],
                    c.stroke_width(2),
                ))
                .map_err(plot_error)?;
                top.draw(&Text::new(
                    label.clone(),
                    (x + 28, 32),
                    ("sans-serif", 12).into_font(),
                ))
                .map_err(plot_error)?;
                x += 48 + 7 * label.chars().count() as i32;
            }
        }
        let areas = body.split_evenly((rows, columns));
        for (panel, area) in panels.iter().zip(&areas) {
            let (x, y) = panel.ranges();
            match (panel.log_x, panel.log_y) {
                (true, true) => draw_panel(area, panel, x.log_scale(), y.log_scale())?,
                (true, false) => draw_panel(area, panel, x.log_scale(), y)?,
                (false, true) => draw_panel(area, panel, x, y.log_scale())?,
                (false, false) => draw_panel(area, panel, x, y)?,
            }
        }
        root.present().map_err(plot_error)?;
    }
    Ok(svg)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn panel(log_y: bool, points: Vec<(f64, f64)>) -> Panel {
        Panel {
            title: "H11 <magnitude>".into(),
            x_label: "frequency (Hz)".into(),
            y_label: "|H|".into(),
            log_y,
            log_x: false,
            x_range: None,
            y_range: None,
            series: vec![Series::line(points, "#d62728", 1.8, Some("fitted model"))],
        }
    }

    #[test]
    fn a_figure_has_its_title_legend_panels_and_escaped_text() {
        let p = panel(false, vec![(0.5, 1.0), (8.0, 2.5), (16.0, 0.2)]);
        let svg = figure_svg("fit & check", &[p.clone(), p], 2).expect("svg");
        assert!(svg.starts_with("<svg"));
        assert!(svg.contains("fit &amp; check"));
        assert!(svg.contains("H11 &lt;magnitude&gt;"));
        assert!(svg.contains("fitted model"));
        assert!(
            svg.contains("#D62728") || svg.contains("#d62728"),
            "the series' colour"
        );
        assert!(!svg.contains("<script"));
    }

    #[test]
    fn log_ticks_are_short() {
        assert_eq!(log_tick(9.999_999_999_999_9e-6), "1e-5");
        assert_eq!(log_tick(0.001_000_000_000_000_2), "1e-3");
        assert_eq!(log_tick(2.5e-3), "2.5e-3");
        assert_eq!(log_tick(1.0), "1e0");
    }

    #[test]
    fn ranges_pad_the_data_and_log_axes_drop_non_positive_values() {
        let p = panel(false, vec![(0.0, 0.0), (10.0, 2.0)]);
        let (x, y) = p.ranges();
        assert_eq!(x, 0.0..10.0);
        assert!((y.start + 0.1).abs() < 1e-12 && (y.end - 2.1).abs() < 1e-12);
        let p = panel(
            true,
            vec![(1.0, 1e-4), (2.0, -1.0), (3.0, 1e-2), (4.0, f64::NAN)],
        );
        let (_, y) = p.ranges();
        assert!(y.start > 0.0 && y.start < 1e-4 && y.end > 1e-2, "{y:?}");
        // The non-positive and NaN points break the line: two runs would need two points
        // each, so only what is drawable remains.
        assert!(p.runs(&p.series[0]).is_empty());
        let q = panel(
            true,
            vec![(1.0, 1.0), (2.0, 2.0), (3.0, 0.0), (4.0, 1.0), (5.0, 3.0)],
        );
        assert_eq!(q.runs(&q.series[0]).len(), 2);
    }
}
