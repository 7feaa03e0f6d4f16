//! A scatter chart as SVG: points of one or more groups, each its own colour, with axes,
//! horizontal reference lines and a legend (the report's running rms against speed).

use anyhow::Result;
use plotters::prelude::*;

use super::time_chart::{Threshold, WIDTH_PX};
use super::{Rgb, plot_error, report_frame};

/// Height of a scatter chart, px.
const HEIGHT_PX: u32 = 380;

/// One group of points.
#[derive(Clone, Debug, PartialEq)]
pub struct Group {
    /// (x, y) points; non-finite ones are left out.
    pub points: Vec<(f64, f64)>,
    /// Colour.
    pub color: Rgb,
    /// Legend text.
    pub label: String,
}

/// A scatter chart.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct Scatter {
    /// Title.
    pub title: String,
    /// X axis label.
    pub x_label: String,
    /// Y axis label.
    pub y_label: String,
    /// The groups, drawn in order.
    pub groups: Vec<Group>,
    /// Horizontal reference lines.
    pub thresholds: Vec<Threshold>,
}

impl Scatter {
    /// The x and y ranges: from zero to the largest value (and threshold), padded.
    fn ranges(&self) -> ((f64, f64), (f64, f64)) {
        let finite = self
            .groups
            .iter()
            .flat_map(|g| g.points.iter())
            .filter(|(x, y)| x.is_finite() && y.is_finite());
        let (mut x1, mut y1) = (0.0f64, 0.0f64);
        for (x, y) in finite {
            x1 = x1.max(*x);
            y1 = y1.max(*y);
        }
        for t in &self.thresholds {
            y1 = y1.max(t.y);
        }
        ((0.0, (x1 * 1.05).max(1.0)), (0.0, (y1 * 1.08).max(0.1)))
    }

    /// The chart as an `<svg>` element.
    pub fn to_svg(&self) -> Result<String> {
        let ((x0, x1), (y0, y1)) = self.ranges();
        let mut svg = String::new();
        {
            let root = SVGBackend::with_string(&mut svg, (WIDTH_PX, HEIGHT_PX)).into_drawing_area();
            root.fill(&WHITE).map_err(plot_error)?;
            let mut chart = report_frame(&root, &self.title, (x0, x1), (y0, y1))?;
            chart
                .configure_mesh()
                .x_desc(self.x_label.as_str())
                .y_desc(self.y_label.as_str())
                .light_line_style(RGBColor(238, 238, 238))
                .bold_line_style(RGBColor(215, 215, 215))
                .axis_desc_style(("sans-serif", 14))
                .label_style(("sans-serif", 13))
                .draw()
                .map_err(plot_error)?;
            for t in &self.thresholds {
                let color: RGBColor = t.color.into();
                chart
                    .draw_series(LineSeries::new(
                        [(x0, t.y), (x1, t.y)],
                        color.stroke_width(1),
                    ))
                    .map_err(plot_error)?
                    .label(t.label.clone())
                    .legend(move |(x, y)| PathElement::new([(x, y), (x + 16, y)], color));
            }
            for g in &self.groups {
                let color: RGBColor = g.color.into();
                chart
                    .draw_series(
                        g.points
                            .iter()
                            .filter(|(x, y)| x.is_finite() && y.is_finite())
                            .map(|p| Circle::new(*p, 3, color.mix(0.7).filled())),
                    )
                    .map_err(plot_error)?
                    .label(g.label.clone())
                    .legend(move |(x, y)| Circle::new((x + 8, y), 4, color.filled()));
            }
            chart
                .configure_series_labels()
                .background_style(WHITE.mix(0.85))
                .border_style(RGBColor(200, 200, 200))
                .label_font(("sans-serif", 13))
                .position(SeriesLabelPosition::UpperLeft)
                .draw()
                .map_err(plot_error)?;
            root.present().map_err(plot_error)?;
        }
        Ok(svg)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ranges_hold_every_point_and_threshold() {
        let chart = Scatter {
            groups: vec![Group {
                points: vec![(10.0, 0.5), (25.0, 1.2), (f64::NAN, 9.0)],
                color: Rgb::BLACK,
                label: "leg 1".into(),
            }],
            thresholds: vec![Threshold {
                y: 2.0,
                color: Rgb::BLACK,
                label: "alarm".into(),
            }],
            ..Scatter::default()
        };
        let ((_, x1), (_, y1)) = chart.ranges();
        assert!((25.0..27.0).contains(&x1) && (2.0..2.2).contains(&y1));
        assert!(chart.to_svg().unwrap().contains("<circle"));
    }
}
