//! Plots as SVG text, drawn by `plotters`.
//!
//! - [`panels`]: a grid of line-plot panels (`fit --report`, `validate --report`).
//! - [`time_chart`]: a time chart with thresholds, bands and markers (the demo's report).
//! - [`downsample`]: min/max per pixel column, so long series stay small and peaks stay.

pub mod downsample;
pub mod panels;
pub mod time_chart;

pub use panels::{Panel, Series, figure_svg};
