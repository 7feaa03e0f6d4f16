//! Time charts (the demo's report): lines over time, with alert thresholds, shaded
//! stretches, event markers and vertical instants.
//!
//! A [`Chart`] is data only (lines, threshold lines, shaded stretches, event markers), so
//! what the report draws is testable without parsing SVG; [`Chart::to_svg`] draws it.

use anyhow::Result;
use plotters::prelude::*;
use supine_core::alerts::Level;

use super::{Rgb, plot_error, report_frame};

/// Width of every chart, px (the report's column).
pub const WIDTH_PX: u32 = 1100;
/// Pixel columns of the plotting area, for downsampling.
pub const PLOT_COLUMNS: usize = 1000;

/// One data line.
#[derive(Clone, Debug, PartialEq)]
pub struct Line {
    /// Points (time s, value).
    pub points: Vec<(f64, f64)>,
    /// Colour.
    pub color: Rgb,
    /// Stroke width, px.
    pub width: u32,
    /// Dashed (the host's overlays).
    pub dashed: bool,
    /// Legend entry.
    pub label: String,
}

/// A horizontal reference line (an alert threshold).
#[derive(Clone, Debug, PartialEq)]
pub struct Threshold {
    /// Its value.
    pub y: f64,
    /// Colour.
    pub color: Rgb,
    /// Text drawn at its right end.
    pub label: String,
}

/// Alert level colours: normal, advisory, warning, alarm (the live panel's, in the reports).
pub const LEVEL_COLORS: [Rgb; 4] = [
    Rgb(46, 139, 87),
    Rgb(204, 153, 0),
    Rgb(230, 90, 0),
    Rgb(200, 0, 0),
];

/// Threshold lines for the advisory, warning and alarm `values`, each labelled with its
/// level's name and value (the unit is the y axis's: a label must fit the right margin).
pub fn alert_thresholds(values: [f32; 3]) -> Vec<Threshold> {
    Level::RAISED
        .iter()
        .zip(values)
        .map(|(level, v)| Threshold {
            y: f64::from(v),
            color: LEVEL_COLORS[*level as usize],
            label: format!("{} {v}", level.name()),
        })
        .collect()
}

/// Vertical spacing of threshold labels, px: a 13 px line and a gap.
const THRESHOLD_LABEL_GAP_PX: i32 = 15;

/// Label positions for lines at pixel rows `ys` (any order), each as near its line as
/// possible, at least `gap` apart, and all within `top..=bottom` (when they fit):
/// labels are pushed down past their upper neighbour, then back up from the bottom.
pub fn spread_labels(ys: &[i32], gap: i32, top: i32, bottom: i32) -> Vec<i32> {
    let mut order: Vec<usize> = (0..ys.len()).collect();
    order.sort_by_key(|&i| ys[i]);
    let mut placed = vec![0; ys.len()];
    let mut next = top;
    for &i in &order {
        placed[i] = ys[i].max(next);
        next = placed[i] + gap;
    }
    let mut limit = bottom;
    for &i in order.iter().rev() {
        placed[i] = placed[i].min(limit);
        limit = placed[i] - gap;
    }
    placed
}

/// A shaded stretch of time (a road surface), labelled at its top.
#[derive(Clone, Debug, PartialEq)]
pub struct Band {
    /// Start, s.
    pub start_s: f64,
    /// End, s.
    pub end_s: f64,
    /// Label.
    pub label: String,
    /// Fill colour (drawn at 18 % opacity).
    pub color: Rgb,
}

/// A marker at a point: an up triangle (raised) or a down triangle (cleared).
#[derive(Clone, Debug, PartialEq)]
pub struct Marker {
    /// Time, s.
    pub t_s: f64,
    /// Value.
    pub y: f64,
    /// Pointing up (raise) or down (clear).
    pub up: bool,
    /// Colour.
    pub color: Rgb,
}

/// A vertical line at an instant (a shock), labelled at its top.
#[derive(Clone, Debug, PartialEq)]
pub struct Moment {
    /// Time, s.
    pub t_s: f64,
    /// Label.
    pub label: String,
}

/// One chart with time on the x axis.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct Chart {
    /// Title, drawn above.
    pub title: String,
    /// Y axis description (with units).
    pub y_label: String,
    /// Time range, s.
    pub x_range_s: (f64, f64),
    /// Value range.
    pub y_range: (f64, f64),
    /// Height, px.
    pub height_px: u32,
    /// Shaded stretches, drawn first.
    pub bands: Vec<Band>,
    /// Threshold lines.
    pub thresholds: Vec<Threshold>,
    /// Data lines, in drawing order.
    pub lines: Vec<Line>,
    /// Markers, drawn last.
    pub markers: Vec<Marker>,
    /// Instants (vertical dotted lines).
    pub instants: Vec<Moment>,
    /// Names for integer y ticks (the alert levels), instead of numbers.
    pub y_tick_names: Option<Vec<String>>,
}

/// The y range covering `values` and `also` (threshold values to keep in view), with a
/// margin of 8 % of the span; never empty.
pub fn y_range<'a>(
    values: impl IntoIterator<Item = &'a f64>,
    also: &'a [f64],
    from_zero: bool,
) -> (f64, f64) {
    let mut lo = if from_zero { 0.0 } else { f64::INFINITY };
    let mut hi = f64::NEG_INFINITY;
    for &v in values.into_iter().chain(also) {
        if v.is_finite() {
            lo = lo.min(v);
            hi = hi.max(v);
        }
    }
    if !(lo.is_finite() && hi.is_finite()) {
        return (0.0, 1.0);
    }
    if hi - lo < 1e-12 {
        return (lo - 0.5, hi + 0.5);
    }
    let pad = 0.08 * (hi - lo);
    (if from_zero { lo } else { lo - pad }, hi + pad)
}

/// Height of one legend row, px (13 px text and spacing), and the legend box's margin and
/// padding together.
const LEGEND_ROW_PX: f64 = 19.0;
const LEGEND_FRAME_PX: f64 = 24.0;
/// Room for the bands' names between the data and the legend, px.
const BAND_LABEL_PX: f64 = 16.0;
/// Caption, axis labels and margins: what the plot area is not, px.
const NON_PLOT_PX: f64 = 70.0;

/// Where the data, the bands' names and the legend go, top to bottom: the legend in the
/// upper right above everything, the bands' names under it, the data below them.
#[derive(Clone, Copy, Debug, PartialEq)]
struct YLayout {
    /// The y range drawn.
    range: (f64, f64),
    /// Top of the bands' names, in y units.
    band_label_y: f64,
}

impl Chart {
    /// The y range, raised so that the legend and the bands' names sit above the data
    /// rather than over it (a chart named by levels keeps its range: its ticks are the
    /// names).
    fn y_layout(&self) -> YLayout {
        let (y0, data_y1) = self.y_range;
        let rows = self.lines.iter().filter(|l| !l.label.is_empty()).count();
        let legend_px = if rows == 0 || self.y_tick_names.is_some() {
            0.0
        } else {
            rows as f64 * LEGEND_ROW_PX + LEGEND_FRAME_PX
        };
        let label_px = if legend_px > 0.0 && !self.bands.is_empty() {
            BAND_LABEL_PX
        } else {
            0.0
        };
        let plot_px = (f64::from(self.height_px) - NON_PLOT_PX).max(1.0);
        // At most half the plot for the legend: a chart with many series stays readable.
        let share = ((legend_px + label_px) / plot_px).min(0.5);
        let y1 = data_y1 + (data_y1 - y0) * share / (1.0 - share);
        let band_label_y = if label_px > 0.0 {
            data_y1 + label_px * (y1 - y0) / plot_px
        } else {
            y1 - 0.04 * (y1 - y0)
        };
        YLayout {
            range: (y0, y1),
            band_label_y,
        }
    }

    /// The chart as an `<svg>` element.
    pub fn to_svg(&self) -> Result<String> {
        let mut svg = String::new();
        {
            let root =
                SVGBackend::with_string(&mut svg, (WIDTH_PX, self.height_px)).into_drawing_area();
            root.fill(&WHITE).map_err(plot_error)?;
            let (x0, x1) = self.x_range_s;
            let layout = self.y_layout();
            let (y0, y1) = layout.range;
            let mut chart = report_frame(&root, &self.title, (x0, x1), (y0, y1))?;
            let names = self.y_tick_names.clone();
            let mut mesh = chart.configure_mesh();
            mesh.x_desc("time, s")
                .y_desc(self.y_label.as_str())
                .light_line_style(RGBColor(238, 238, 238))
                .bold_line_style(RGBColor(215, 215, 215))
                .axis_desc_style(("sans-serif", 14))
                .label_style(("sans-serif", 13));
            let formatter = move |v: &f64| match &names {
                Some(n) => {
                    let i = v.round();
                    if (v - i).abs() < 1e-6 && i >= 0.0 && (i as usize) < n.len() {
                        n[i as usize].clone()
                    } else {
                        String::new()
                    }
                }
                None => format_tick(*v),
            };
            if let Some(n) = &self.y_tick_names {
                mesh.y_labels(n.len() * 2 - 1);
            }
            mesh.y_label_formatter(&formatter)
                .draw()
                .map_err(plot_error)?;

            for band in &self.bands {
                chart
                    .draw_series(std::iter::once(Rectangle::new(
                        [(band.start_s, y0), (band.end_s, y1)],
                        RGBColor::from(band.color).mix(0.18).filled(),
                    )))
                    .map_err(plot_error)?;
                chart
                    .draw_series(std::iter::once(Text::new(
                        band.label.clone(),
                        (band.start_s + 0.01 * (x1 - x0), layout.band_label_y),
                        ("sans-serif", 13).into_font().color(&RGBColor(110, 80, 40)),
                    )))
                    .map_err(plot_error)?;
            }
            let rows = label_rows(&self.instants, (x0, x1));
            for (instant, row) in self.instants.iter().zip(rows) {
                chart
                    .draw_series(DashedLineSeries::new(
                        [(instant.t_s, y0), (instant.t_s, y1)],
                        3,
                        4,
                        RGBColor(120, 120, 120).stroke_width(1),
                    ))
                    .map_err(plot_error)?;
                chart
                    .draw_series(std::iter::once(Text::new(
                        instant.label.clone(),
                        (
                            instant.t_s + 0.005 * (x1 - x0),
                            y1 - (0.12 + 0.07 * row as f64) * (y1 - y0),
                        ),
                        ("sans-serif", 12).into_font().color(&RGBColor(90, 90, 90)),
                    )))
                    .map_err(plot_error)?;
            }
            let shown: Vec<&Threshold> = self
                .thresholds
                .iter()
                .filter(|th| (y0..=y1).contains(&th.y))
                .collect();
            let rows: Vec<i32> = shown
                .iter()
                .map(|th| chart.backend_coord(&(x1, th.y)).1)
                .collect();
            let (top, bottom) = (
                chart.backend_coord(&(x1, y1)).1,
                chart.backend_coord(&(x1, y0)).1,
            );
            // Text is drawn from its top: 7 px above the line centres it on it.
            let label_rows = spread_labels(&rows, THRESHOLD_LABEL_GAP_PX, top + 7, bottom - 7);
            for (th, label_y) in shown.into_iter().zip(label_rows) {
                let color = RGBColor::from(th.color);
                chart
                    .draw_series(DashedLineSeries::new(
                        [(x0, th.y), (x1, th.y)],
                        8,
                        5,
                        color.stroke_width(2),
                    ))
                    .map_err(plot_error)?;
                // The label sits in the right margin, beside the line's end.
                let (px, _) = chart.backend_coord(&(x1, th.y));
                root.draw(&Text::new(
                    th.label.clone(),
                    (px + 6, label_y - 7),
                    ("sans-serif", 13).into_font().color(&color),
                ))
                .map_err(plot_error)?;
            }
            for line in &self.lines {
                let color = RGBColor::from(line.color);
                let style = color.stroke_width(line.width);
                let legend = move |(x, y): (i32, i32)| {
                    PathElement::new(vec![(x, y), (x + 22, y)], color.stroke_width(3))
                };
                let drawn = if line.dashed {
                    chart
                        .draw_series(DashedLineSeries::new(
                            line.points.iter().copied(),
                            6,
                            4,
                            style,
                        ))
                        .map_err(plot_error)?
                } else {
                    chart
                        .draw_series(LineSeries::new(line.points.iter().copied(), style))
                        .map_err(plot_error)?
                };
                // Lines without a label share the legend entry of one that has it.
                if !line.label.is_empty() {
                    drawn.label(line.label.as_str()).legend(legend);
                }
            }
            for m in &self.markers {
                let color = RGBColor::from(m.color);
                let shape = if m.up {
                    vec![(0, -11), (-8, 4), (8, 4)]
                } else {
                    vec![(0, 11), (-8, -4), (8, -4)]
                };
                chart
                    .draw_series(std::iter::once(
                        EmptyElement::at((m.t_s, m.y)) + Polygon::new(shape, color.filled()),
                    ))
                    .map_err(plot_error)?;
            }
            if !self.lines.is_empty() {
                chart
                    .configure_series_labels()
                    .position(SeriesLabelPosition::UpperRight)
                    .margin(8)
                    .label_font(("sans-serif", 13))
                    .background_style(WHITE.mix(0.85))
                    .border_style(RGBColor(190, 190, 190))
                    .draw()
                    .map_err(plot_error)?;
            }
            root.present().map_err(plot_error)?;
        }
        Ok(svg)
    }
}

/// Approximate width of one character of a 12 px sans-serif label, px.
const LABEL_CHAR_PX: f64 = 6.5;

/// The text row (0 = top) of each instant's label: the first row whose previous label
/// ends (with a 6 px gap) before this one starts, so that labels of close shocks do not
/// overprint each other. `instants` are in time order.
pub fn label_rows(instants: &[Moment], (x0, x1): (f64, f64)) -> Vec<usize> {
    let px_per_s = PLOT_COLUMNS as f64 / (x1 - x0).max(f64::MIN_POSITIVE);
    let mut row_ends_px: Vec<f64> = Vec::new();
    instants
        .iter()
        .map(|m| {
            let start = (m.t_s - x0) * px_per_s;
            let end = start + 4.0 + LABEL_CHAR_PX * m.label.chars().count() as f64;
            let row = row_ends_px
                .iter()
                .position(|&e| e + 6.0 <= start)
                .unwrap_or(row_ends_px.len());
            if row == row_ends_px.len() {
                row_ends_px.push(end);
            } else {
                row_ends_px[row] = end;
            }
            row
        })
        .collect()
}

/// A tick label: short, no trailing zeros.
fn format_tick(v: f64) -> String {
    let s = format!("{v:.3}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    if s == "-0" {
        "0".to_string()
    } else {
        s.to_string()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_svg_has_the_title_thresholds_and_lines() {
        let chart = Chart {
            title: "running rms".into(),
            y_label: "m/s^2".into(),
            x_range_s: (0.0, 10.0),
            y_range: (0.0, 2.0),
            height_px: 300,
            thresholds: vec![
                Threshold {
                    y: 0.5,
                    color: Rgb(200, 150, 0),
                    label: "advisory 0.5".into(),
                },
                Threshold {
                    y: 5.0,
                    color: Rgb(200, 0, 0),
                    label: "alarm 5 (off scale)".into(),
                },
            ],
            lines: vec![Line {
                points: vec![(0.0, 0.1), (5.0, 1.5), (10.0, 0.2)],
                color: Rgb(0, 0, 200),
                width: 2,
                dashed: false,
                label: "device <vector>".into(),
            }],
            ..Chart::default()
        };
        let svg = chart.to_svg().expect("svg");
        assert!(svg.starts_with("<svg"), "{}", &svg[..80]);
        assert!(svg.contains("running rms"));
        assert!(svg.contains("advisory 0.5"));
        // A threshold outside the range is not drawn (the caption lists it instead).
        assert!(!svg.contains("alarm 5"));
        // Text is escaped by the backend.
        assert!(svg.contains("device &lt;vector&gt;"));
        assert!(!svg.contains("<script"));
    }

    #[test]
    fn labels_of_close_instants_go_to_separate_rows() {
        let at = |t_s: f64, label: &str| Moment {
            t_s,
            label: label.into(),
        };
        // 60 s over 1000 px: "speed bump" is about 69 px (4.1 s) wide.
        let instants = [
            at(20.5, "speed bump"),
            at(23.0, "pothole"),
            at(26.0, "pothole"),
            at(26.5, "pothole"),
            at(26.7, "speed bump"),
            at(40.0, "pothole"),
        ];
        assert_eq!(label_rows(&instants, (0.0, 60.0)), [0, 1, 0, 1, 2, 0]);
        // Zoomed in to 20-30 s (100 px/s), the first three have room on one row.
        assert_eq!(label_rows(&instants[..3], (20.0, 30.0)), [0, 0, 0]);
    }

    #[test]
    fn the_legend_and_the_bands_names_get_room_above_the_data() {
        let line = |label: &str| Line {
            points: vec![(0.0, 0.0), (1.0, 1.0)],
            color: Rgb(0, 0, 0),
            width: 1,
            dashed: false,
            label: label.into(),
        };
        let mut chart = Chart {
            y_range: (0.0, 1.0),
            height_px: 300,
            lines: vec![line("a"), line(""), line("b"), line("c")],
            ..Chart::default()
        };
        // Three labelled rows: 3 x 19 + 24 = 81 px of a 230 px plot. The data keep the
        // lower 1 - 81/230 of the height, so the top of the range is 1 / (1 - 81/230).
        let layout = chart.y_layout();
        assert_eq!(layout.range.0, 0.0);
        let top = 1.0 / (1.0 - 81.0 / 230.0);
        assert!((layout.range.1 - top).abs() < 1e-12, "{layout:?}");
        // With bands, 16 px more, and their names' top 16 px above the data's.
        chart.bands.push(Band {
            start_s: 0.0,
            end_s: 1.0,
            label: "leg 1".into(),
            color: Rgb(0, 0, 0),
        });
        let layout = chart.y_layout();
        let top = 1.0 / (1.0 - 97.0 / 230.0);
        assert!((layout.range.1 - top).abs() < 1e-12, "{layout:?}");
        assert!((layout.band_label_y - (1.0 + 16.0 * top / 230.0)).abs() < 1e-12);
        // Named ticks (the levels) keep their range; no legend, no room.
        chart.y_tick_names = Some(vec!["normal".into()]);
        assert_eq!(chart.y_layout().range, (0.0, 1.0));
        chart.y_tick_names = None;
        chart.lines.clear();
        assert_eq!(chart.y_layout().range, (0.0, 1.0));
    }

    #[test]
    fn ranges_include_thresholds_and_pad() {
        let (lo, hi) = y_range(&[0.2, 0.9], &[1.25], true);
        assert_eq!(lo, 0.0);
        assert!(hi > 1.25 && hi < 1.4, "{hi}");
        assert_eq!(y_range(&[], &[], false), (0.0, 1.0));
        assert_eq!(format_tick(0.5), "0.5");
        assert_eq!(format_tick(2.0), "2");
    }

    #[test]
    fn thresholds_carry_their_values_and_level_colours() {
        let t = alert_thresholds([0.5, 0.8, 1.25]);
        assert_eq!(t[2].label, "alarm 1.25");
        assert_eq!(t[2].y, 1.25);
        assert_eq!(t[0].color, LEVEL_COLORS[1]);
    }

    #[test]
    fn threshold_labels_never_overlap_and_stay_in_the_plot() {
        let gap = THRESHOLD_LABEL_GAP_PX;
        let cases: [(&[i32], i32, i32); 5] = [
            // Far apart: each at its line.
            (&[100, 200, 300], 10, 400),
            // Two lines 4 px apart (0.5 and 0.8 on a tall range): pushed apart.
            (&[250, 246, 120], 10, 400),
            // All three on one row.
            (&[50, 50, 50], 10, 400),
            // At the bottom edge: pushed back up inside.
            (&[398, 399, 400], 10, 400),
            // At the top edge.
            (&[10, 11, 12], 10, 400),
        ];
        for (ys, top, bottom) in cases {
            let placed = spread_labels(ys, gap, top, bottom);
            let mut sorted = placed.clone();
            sorted.sort();
            assert!(
                sorted.windows(2).all(|w| w[1] - w[0] >= gap),
                "{ys:?} -> {placed:?}"
            );
            assert!(
                placed.iter().all(|&y| (top..=bottom).contains(&y)),
                "{ys:?} -> {placed:?}"
            );
            // The order of the lines is kept, and a label far from others is on its line.
            for (i, j) in [(0, 1), (1, 2), (0, 2)] {
                if ys[i] != ys[j] {
                    assert_eq!(ys[i] < ys[j], placed[i] < placed[j], "{ys:?}");
                }
            }
        }
        assert_eq!(
            spread_labels(&[100, 200, 300], gap, 10, 400),
            [100, 200, 300]
        );
    }
}
