//! A route map as SVG: lines in a local metric frame (east, north in metres) drawn at
//! one scale on both axes, with a scale bar, a north arrow, markers and a legend. No
//! tiles and no network: the page that holds it opens offline.
//!
//! A [`Map`] is data only (pieces of line, markers, legend), so what the report draws
//! is testable without parsing SVG; [`Map::to_svg`] draws it.

use anyhow::Result;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use super::{Rgb, plot_error};

/// Size of the map, px.
pub const MAP_PX: (u32, u32) = (1100, 700);
/// Margin around the drawn extent, px (room for the legend and the scale bar).
const MARGIN_PX: f64 = 60.0;

/// A piece of line of one colour and width.
#[derive(Clone, Debug, PartialEq)]
pub struct Piece {
    /// Points, m east and north.
    pub points: Vec<[f64; 2]>,
    /// Colour.
    pub color: Rgb,
    /// Stroke width, px.
    pub width: u32,
}

/// A marker's shape.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Shape {
    /// A filled circle (a start).
    Circle,
    /// A filled square (an end).
    Square,
    /// A filled triangle (an event).
    Triangle,
}

/// A marker with a short label beside it.
#[derive(Clone, Debug, PartialEq)]
pub struct Marker {
    /// Where, m east and north.
    pub at: [f64; 2],
    /// Fill colour.
    pub color: Rgb,
    /// Shape.
    pub shape: Shape,
    /// Text drawn beside it (empty: none).
    pub label: String,
}

/// A map: pieces drawn in order (later over earlier), then the markers.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct Map {
    /// Title above the map.
    pub title: String,
    /// The lines.
    pub pieces: Vec<Piece>,
    /// The markers.
    pub markers: Vec<Marker>,
    /// Legend rows: a colour swatch and its text.
    pub legend: Vec<(Rgb, String)>,
}

/// The frame from metres to pixels: one scale on both axes, the extent centred.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Frame {
    /// Pixels per metre.
    pub px_per_m: f64,
    centre_m: [f64; 2],
}

impl Frame {
    /// The frame that fits every point of `map` into [`MAP_PX`] less the margins.
    pub fn fitting(map: &Map) -> Self {
        let all = map
            .pieces
            .iter()
            .flat_map(|p| p.points.iter())
            .chain(map.markers.iter().map(|m| &m.at));
        let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
        for p in all {
            for i in 0..2 {
                lo[i] = lo[i].min(p[i]);
                hi[i] = hi[i].max(p[i]);
            }
        }
        if !lo[0].is_finite() {
            (lo, hi) = ([-1.0; 2], [1.0; 2]);
        }
        // At least 100 m across, so a short track is not drawn at a silly scale.
        let span = [(hi[0] - lo[0]).max(100.0), (hi[1] - lo[1]).max(100.0)];
        let usable = [
            f64::from(MAP_PX.0) - 2.0 * MARGIN_PX,
            f64::from(MAP_PX.1) - 2.0 * MARGIN_PX - 40.0,
        ];
        Self {
            px_per_m: (usable[0] / span[0]).min(usable[1] / span[1]),
            centre_m: [(lo[0] + hi[0]) / 2.0, (lo[1] + hi[1]) / 2.0],
        }
    }

    /// The pixel of a point (x right, y down).
    pub fn pixel(&self, [x, y]: [f64; 2]) -> (i32, i32) {
        let cx = f64::from(MAP_PX.0) / 2.0;
        let cy = f64::from(MAP_PX.1) / 2.0 + 20.0;
        (
            (cx + (x - self.centre_m[0]) * self.px_per_m).round() as i32,
            (cy - (y - self.centre_m[1]) * self.px_per_m).round() as i32,
        )
    }
}

/// The scale bar's length: 1, 2 or 5 times a power of ten metres, the longest within
/// `max_m`.
pub fn scale_bar_m(max_m: f64) -> f64 {
    let decade = 10f64.powf(max_m.log10().floor());
    [5.0, 2.0, 1.0]
        .into_iter()
        .map(|f| f * decade)
        .find(|l| *l <= max_m)
        .unwrap_or(decade)
}

/// A distance as the scale bar names it.
fn distance_text(m: f64) -> String {
    if m >= 1000.0 {
        format!("{} km", m / 1000.0)
    } else {
        format!("{m} m")
    }
}

/// The labels drawn so far, so that a label is never drawn over another: each goes to
/// the first free place beside its marker, or is left out (the table lists them all).
#[derive(Default)]
struct Labels {
    boxes: Vec<[i32; 4]>,
}

impl Labels {
    /// Approximate size of a label at the map's 12 px font, px.
    fn size(text: &str) -> (i32, i32) {
        (7 * text.chars().count() as i32, 15)
    }

    /// Where `text` goes beside a marker at `(x, y)`: right above, right below, left above
    /// or left below; `None` when it is empty or every place is taken.
    fn place(&mut self, text: &str, (x, y): (i32, i32)) -> Option<(i32, i32)> {
        if text.is_empty() {
            return None;
        }
        let (w, h) = Self::size(text);
        let candidates = [
            (x + 10, y - 18),
            (x + 10, y + 6),
            (x - 10 - w, y - 18),
            (x - 10 - w, y + 6),
        ];
        let free = |b: &[i32; 4]| {
            self.boxes
                .iter()
                .all(|o| b[2] <= o[0] || b[0] >= o[2] || b[3] <= o[1] || b[1] >= o[3])
        };
        let at = candidates
            .into_iter()
            .map(|(cx, cy)| [cx, cy, cx + w, cy + h])
            .find(|b| free(b))?;
        self.boxes.push(at);
        Some((at[0], at[1]))
    }
}

impl Map {
    /// The map as an `<svg>` element.
    pub fn to_svg(&self) -> Result<String> {
        let frame = Frame::fitting(self);
        let mut svg = String::new();
        {
            let root = SVGBackend::with_string(&mut svg, MAP_PX).into_drawing_area();
            root.fill(&RGBColor(250, 250, 246)).map_err(plot_error)?;
            let font = |size: i32| ("sans-serif", size).into_font();
            root.draw(&Text::new(
                self.title.clone(),
                (16, 12),
                font(17).color(&BLACK),
            ))
            .map_err(plot_error)?;
            for piece in &self.pieces {
                let color: RGBColor = piece.color.into();
                root.draw(&PathElement::new(
                    piece
                        .points
                        .iter()
                        .map(|p| frame.pixel(*p))
                        .collect::<Vec<_>>(),
                    color.stroke_width(piece.width),
                ))
                .map_err(plot_error)?;
            }
            let mut labels = Labels::default();
            for m in &self.markers {
                let color: RGBColor = m.color.into();
                let (x, y) = frame.pixel(m.at);
                let outline = BLACK.stroke_width(1);
                match m.shape {
                    Shape::Circle => {
                        root.draw(&Circle::new((x, y), 7, color.filled()))
                            .map_err(plot_error)?;
                        root.draw(&Circle::new((x, y), 7, outline))
                            .map_err(plot_error)?;
                    }
                    Shape::Square => {
                        let corners = [(x - 6, y - 6), (x + 6, y + 6)];
                        root.draw(&Rectangle::new(corners, color.filled()))
                            .map_err(plot_error)?;
                        root.draw(&Rectangle::new(corners, outline))
                            .map_err(plot_error)?;
                    }
                    Shape::Triangle => {
                        let corners = vec![(x, y - 8), (x - 7, y + 5), (x + 7, y + 5)];
                        root.draw(&Polygon::new(corners.clone(), color.filled()))
                            .map_err(plot_error)?;
                        let mut closed = corners.clone();
                        closed.push(corners[0]);
                        root.draw(&PathElement::new(closed, outline))
                            .map_err(plot_error)?;
                    }
                }
                if let Some(at) = labels.place(&m.label, (x, y)) {
                    root.draw(&Text::new(m.label.clone(), at, font(12).color(&BLACK)))
                        .map_err(plot_error)?;
                }
            }
            // The legend, top left under the title.
            for (i, (color, text)) in self.legend.iter().enumerate() {
                let y = 40 + 18 * i as i32;
                let c: RGBColor = (*color).into();
                root.draw(&Rectangle::new([(16, y), (36, y + 10)], c.filled()))
                    .map_err(plot_error)?;
                root.draw(&Text::new(
                    text.clone(),
                    (42, y - 1),
                    font(12).color(&BLACK),
                ))
                .map_err(plot_error)?;
            }
            // The scale bar, bottom left: at most a quarter of the map's width.
            let (w, h) = (MAP_PX.0 as i32, MAP_PX.1 as i32);
            let bar_m = scale_bar_m(f64::from(MAP_PX.0) / 4.0 / frame.px_per_m);
            let bar_px = (bar_m * frame.px_per_m).round() as i32;
            let (bx, by) = (20, h - 28);
            root.draw(&Rectangle::new(
                [(bx, by), (bx + bar_px, by + 6)],
                BLACK.filled(),
            ))
            .map_err(plot_error)?;
            root.draw(&Rectangle::new(
                [(bx + bar_px / 2, by + 1), (bx + bar_px - 1, by + 5)],
                WHITE.filled(),
            ))
            .map_err(plot_error)?;
            root.draw(&Text::new(
                distance_text(bar_m),
                (bx + bar_px + 8, by - 4),
                font(13).color(&BLACK),
            ))
            .map_err(plot_error)?;
            // The north arrow, top right (the frame's y is north).
            let (nx, ny) = (w - 40, 30);
            root.draw(&Polygon::new(
                vec![
                    (nx, ny),
                    (nx - 9, ny + 30),
                    (nx, ny + 22),
                    (nx + 9, ny + 30),
                ],
                BLACK.filled(),
            ))
            .map_err(plot_error)?;
            root.draw(&Text::new(
                "N",
                (nx, ny + 34),
                font(15)
                    .color(&BLACK)
                    .pos(Pos::new(HPos::Center, VPos::Top)),
            ))
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
    fn one_scale_on_both_axes_and_a_round_scale_bar() {
        let map = Map {
            pieces: vec![Piece {
                points: vec![[0.0, 0.0], [2000.0, 0.0], [2000.0, 500.0]],
                color: Rgb::BLACK,
                width: 3,
            }],
            ..Map::default()
        };
        let frame = Frame::fitting(&map);
        let (x0, y0) = frame.pixel([0.0, 0.0]);
        let (x1, _) = frame.pixel([2000.0, 0.0]);
        let (_, y2) = frame.pixel([2000.0, 500.0]);
        // 2000 m east and 500 m north in the ratio 4:1, north up.
        assert!(((x1 - x0) as f64 / (y0 - y2) as f64 - 4.0).abs() < 0.02);
        assert!(y2 < y0);
        assert_eq!(scale_bar_m(730.0), 500.0);
        assert_eq!(scale_bar_m(3100.0), 2000.0);
        assert_eq!(scale_bar_m(99.0), 50.0);
        assert_eq!(distance_text(2000.0), "2 km");
        // Labels never overlap: a second at the same marker goes below, a fifth nowhere.
        let mut labels = Labels::default();
        let places: Vec<_> = (0..5)
            .map(|_| labels.place("247 s alarm", (500, 300)))
            .collect();
        assert_eq!(places[0], Some((510, 282)));
        assert_eq!(places[1], Some((510, 306)));
        assert!(places[2].is_some() && places[3].is_some() && places[4].is_none());
        let svg = map.to_svg().unwrap();
        assert!(svg.starts_with("<svg"), "{}", &svg[..200]);
        assert!(svg.contains("500 m"), "{svg}");
        assert!(svg.contains("\nN\n</text>"), "{svg}");
    }
}
