//! Plots as SVG text, drawn by `plotters` (its SVG backend into a `String`: plain `<svg>`
//! elements with system sans-serif text, no script, no font file). One layer for every
//! figure the host draws: one colour type, one error, one backend.
//!
//! - [`panels`]: a grid of line-plot panels (`fit --report`, `validate --report`).
//! - [`time_chart`]: a time chart with thresholds, bands and markers (the demo's report).
//! - [`downsample`]: min/max per pixel column, so long series stay small and peaks stay.
//! - [`map`]: a route map in a local metric frame, with scale bar and north arrow.
//! - [`scatter`]: points against two axes (the report's running rms against speed).

pub mod downsample;
pub mod map;
pub mod panels;
pub mod scatter;
pub mod time_chart;

use plotters::coord::Shift;
use plotters::coord::types::RangedCoordf64;
use plotters::prelude::{Cartesian2d, ChartBuilder, ChartContext, DrawingArea, SVGBackend};
use plotters::style::RGBColor;

pub use panels::{Panel, Series, figure_svg};

/// A colour as red, green, blue.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Rgb(pub u8, pub u8, pub u8);

impl Rgb {
    /// Black.
    pub const BLACK: Rgb = Rgb(0, 0, 0);

    /// The colour written `#rrggbb` (case-insensitive), black if `text` is not one: a
    /// mistyped colour shows as a black line rather than failing a whole report.
    pub fn from_hex(text: &str) -> Rgb {
        let hex = text.strip_prefix('#').unwrap_or(text);
        let byte = |i: usize| {
            hex.get(i..i + 2)
                .and_then(|h| u8::from_str_radix(h, 16).ok())
        };
        match (hex.len(), byte(0), byte(2), byte(4)) {
            (6, Some(r), Some(g), Some(b)) => Rgb(r, g, b),
            _ => Rgb::BLACK,
        }
    }
}

impl From<Rgb> for RGBColor {
    fn from(c: Rgb) -> Self {
        RGBColor(c.0, c.1, c.2)
    }
}

/// The frame of the report's charts on `root`: the title above, the margins and label
/// areas every report chart has (so their plotting areas line up on the page), over
/// `x` and `y`.
fn report_frame<'a, 'b>(
    root: &'a DrawingArea<SVGBackend<'b>, Shift>,
    title: &str,
    (x0, x1): (f64, f64),
    (y0, y1): (f64, f64),
) -> anyhow::Result<ChartContext<'a, SVGBackend<'b>, Cartesian2d<RangedCoordf64, RangedCoordf64>>> {
    ChartBuilder::on(root)
        .caption(title, ("sans-serif", 17))
        .margin_left(10)
        .margin_right(110)
        .margin_top(6)
        .margin_bottom(6)
        .x_label_area_size(36)
        .y_label_area_size(70)
        .build_cartesian_2d(x0..x1, y0..y1)
        .map_err(plot_error)
}

/// A `plotters` drawing error as an error of ours.
fn plot_error<E: std::fmt::Debug>(e: E) -> anyhow::Error {
    anyhow::anyhow!("drawing a plot: {e:?}")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn colours_parse_and_bad_ones_fall_back_to_black() {
        assert_eq!(Rgb::from_hex("#c8c8c8"), Rgb(200, 200, 200));
        assert_eq!(Rgb::from_hex("#D62728"), Rgb(214, 39, 40));
        assert_eq!(Rgb::from_hex("red"), Rgb::BLACK);
        assert_eq!(Rgb::from_hex("#c8c8c"), Rgb::BLACK);
        assert_eq!(RGBColor::from(Rgb(1, 2, 3)), RGBColor(1, 2, 3));
    }
}
