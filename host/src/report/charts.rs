//! The mission report's charts: time charts on one mission time axis with each leg shaded
//! and named, and a spectrum figure per leg. What goes on each chart is decided here; how
//! it is drawn, in [`crate::plot`].

use anyhow::Result;
use supine_core::alerts::{AlertConfig, Level};
use supine_core::exposure::combined_vdv_m_s175;

use crate::plot::downsample::min_max;
use crate::plot::time_chart::{
    Band, Chart, LEVEL_COLORS, Line, Marker, PLOT_COLUMNS, alert_thresholds, y_range,
};
use crate::plot::{Panel, Rgb, Series, figure_svg};
use crate::report::mission::Leg;
use crate::report::third_octave;

/// Alternating shades of the legs.
const LEG_COLORS: [Rgb; 2] = [Rgb(120, 160, 220), Rgb(180, 180, 180)];
/// The vector sum's colour.
const VECTOR_COLOR: Rgb = Rgb(25, 25, 25);
/// The mission's cumulative VDV.
const MISSION_COLOR: Rgb = Rgb(148, 52, 160);
/// Litter input.
const INPUT_COLOR: &str = "#1f77b4";
/// Predicted head.
const HEAD_COLOR: &str = "#d62728";
/// Predicted head, weighted.
const WEIGHTED_COLOR: &str = "#2ca02c";

fn bands(legs: &[Leg]) -> Vec<Band> {
    legs.iter()
        .enumerate()
        .map(|(i, l)| Band {
            start_s: l.start_s,
            end_s: l.start_s + l.duration_s,
            label: l.label.clone(),
            color: LEG_COLORS[i % 2],
        })
        .collect()
}

fn x_range(legs: &[Leg]) -> (f64, f64) {
    let end = legs
        .iter()
        .map(|l| l.start_s + l.duration_s)
        .fold(0.0, f64::max);
    (0.0, end.max(1e-3))
}

/// Colours of the two compared rides, A and B.
const COMPARE_COLORS: [Rgb; 2] = [Rgb(25, 25, 25), Rgb(255, 127, 14)];

/// How the legs are drawn: one after the other, shaded and named (a mission), or both from
/// time zero in two colours (a comparison).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Layout {
    /// Legs in sequence.
    Mission,
    /// Two rides over each other.
    Compare,
}

fn bands_for(legs: &[Leg], layout: Layout) -> Vec<Band> {
    match layout {
        Layout::Mission => bands(legs),
        Layout::Compare => Vec::new(),
    }
}

/// Each leg's series `y` against mission time, one line per leg (no line across gaps);
/// compared rides each in their own colour and named.
fn per_leg(
    legs: &[Leg],
    layout: Layout,
    y: impl Fn(&Leg) -> Vec<f64>,
    color: Rgb,
    label: &str,
) -> Vec<Line> {
    let span = x_range(legs).1;
    legs.iter()
        .enumerate()
        .map(|(i, l)| {
            if layout == Layout::Compare {
                let t: Vec<f64> = l.series.t_s.to_vec();
                return Line {
                    points: min_max(&t, &y(l), PLOT_COLUMNS),
                    color: if label.starts_with("min") {
                        Rgb(170, 170, 170)
                    } else {
                        COMPARE_COLORS[i % 2]
                    },
                    width: 1,
                    dashed: i == 1,
                    label: format!("{}: {label}", ["A", "B"][i % 2]),
                };
            }
            let t: Vec<f64> = l.series.t_s.iter().map(|t| l.start_s + t).collect();
            let columns = ((PLOT_COLUMNS as f64) * l.duration_s / span)
                .ceil()
                .max(2.0) as usize;
            Line {
                points: min_max(&t, &y(l), columns),
                color,
                width: 2,
                dashed: false,
                label: if i == 0 {
                    label.to_string()
                } else {
                    String::new()
                },
            }
        })
        .collect()
}

/// The buckets of the legs' series as a legend says them: `0.1 s` (a chart step), or a
/// range when a long leg has longer ones.
fn bucket_s(legs: &[Leg]) -> String {
    let (shortest, longest) = legs
        .iter()
        .filter_map(|l| match l.series.t_s.as_slice() {
            [a, b, _, ..] => Some(b - a),
            _ => None,
        })
        .fold((f64::INFINITY, 0.0f64), |(lo, hi), w| {
            (lo.min(w), hi.max(w))
        });
    if shortest >= longest {
        format!("{longest:.1} s")
    } else {
        format!("{shortest:.1}-{longest:.1} s")
    }
}

/// The litter's vertical acceleration (the input), min and max per bucket of the series.
pub fn input(legs: &[Leg], layout: Layout) -> Chart {
    let bucket_s = bucket_s(legs);
    let mut lines = per_leg(
        legs,
        layout,
        |l| l.series.platform_z_m_s2.iter().map(|p| p.1).collect(),
        Rgb(214, 39, 40),
        &format!("litter z (vertical), max per {bucket_s}"),
    );
    lines.extend(per_leg(
        legs,
        layout,
        |l| l.series.platform_z_m_s2.iter().map(|p| p.0).collect(),
        Rgb(240, 140, 140),
        &format!("min per {bucket_s}"),
    ));
    let all = legs
        .iter()
        .flat_map(|l| l.series.platform_z_m_s2.iter().flat_map(|p| [p.0, p.1]))
        .collect::<Vec<_>>();
    Chart {
        title: "Litter-frame vertical acceleration (the input)".into(),
        y_label: "acceleration, m/s^2".into(),
        x_range_s: x_range(legs),
        y_range: y_range(&all, &[], false),
        height_px: 260,
        bands: bands_for(legs, layout),
        lines,
        ..Chart::default()
    }
}

/// The vector running rms with its thresholds and the alert raises marked.
pub fn running_rms(legs: &[Leg], config: &AlertConfig, layout: Layout) -> Chart {
    let lines = per_leg(
        legs,
        layout,
        |l| l.series.vector_rms_m_s2.clone(),
        VECTOR_COLOR,
        "vector running rms (predicted head)",
    );
    let th = config.running_rms_m_s2.map(f64::from);
    let all: Vec<f64> = legs
        .iter()
        .flat_map(|l| l.series.vector_rms_m_s2.iter().copied())
        .collect();
    let markers = legs
        .iter()
        .flat_map(|l| l.alerts.iter())
        .filter(|a| a.kind == "level")
        .map(|a| Marker {
            t_s: a.mission_time_s,
            y: a.running_rms_m_s2,
            up: a.raised,
            color: LEVEL_COLORS[a.level.unwrap_or_default() as usize],
        })
        .collect();
    Chart {
        title: "Weighted running rms of the predicted head (vector sum, 1 s)".into(),
        y_label: "running rms, m/s^2".into(),
        x_range_s: x_range(legs),
        y_range: y_range(&all, &th[..1], true),
        height_px: 300,
        bands: bands_for(legs, layout),
        thresholds: alert_thresholds(config.running_rms_m_s2),
        lines,
        markers,
        ..Chart::default()
    }
}

/// Each leg's VDV, and the mission's: earlier legs' doses plus this one's so far.
pub fn vdv(legs: &[Leg], config: &AlertConfig, layout: Layout) -> Chart {
    let mut lines = per_leg(
        legs,
        layout,
        |l| l.series.vdv_m_s175.clone(),
        VECTOR_COLOR,
        match layout {
            Layout::Mission => "the leg's VDV",
            Layout::Compare => "the ride's VDV",
        },
    );
    let mut before = Vec::new();
    let mission: Vec<Line> = legs
        .iter()
        .enumerate()
        .map(|(i, l)| {
            let t: Vec<f64> = l.series.t_s.iter().map(|t| l.start_s + t).collect();
            let y: Vec<f64> = l
                .series
                .vdv_m_s175
                .iter()
                .map(|v| {
                    let mut all = before.clone();
                    all.push(*v);
                    combined_vdv_m_s175(&all)
                })
                .collect();
            before.push(l.vector.vdv_m_s175);
            Line {
                points: min_max(&t, &y, PLOT_COLUMNS),
                color: MISSION_COLOR,
                width: 2,
                dashed: true,
                label: if i == 0 {
                    "mission VDV, (sum VDV_i^4)^(1/4)".into()
                } else {
                    String::new()
                },
            }
        })
        .collect();
    if layout == Layout::Mission {
        lines.extend(mission);
    }
    let all: Vec<f64> = lines
        .iter()
        .flat_map(|l| l.points.iter().map(|p| p.1))
        .collect();
    let th = config.vdv_m_s175.map(f64::from);
    Chart {
        title: "Vibration dose value (vector sum of the predicted head)".into(),
        y_label: "VDV, m/s^1.75".into(),
        x_range_s: x_range(legs),
        y_range: y_range(&all, &th[..1], true),
        height_px: 300,
        bands: bands_for(legs, layout),
        thresholds: alert_thresholds(config.vdv_m_s175),
        lines,
        ..Chart::default()
    }
}

/// The alert level over mission time.
pub fn levels(legs: &[Leg], layout: Layout) -> Chart {
    let lines = legs
        .iter()
        .enumerate()
        .map(|(i, l)| {
            let mut points = Vec::new();
            let mut last = None;
            for (t, &level) in l.series.t_s.iter().zip(&l.series.level) {
                let t = l.start_s + t;
                match last {
                    Some(prev) if prev != level => {
                        points.push((t, f64::from(prev)));
                        points.push((t, f64::from(level)));
                    }
                    None => points.push((t, f64::from(level))),
                    _ => {}
                }
                last = Some(level);
            }
            if let Some(level) = last {
                points.push((l.start_s + l.duration_s, f64::from(level)));
            }
            match layout {
                Layout::Mission => Line {
                    points,
                    color: VECTOR_COLOR,
                    width: 2,
                    dashed: false,
                    label: if i == 0 {
                        "alert level".into()
                    } else {
                        String::new()
                    },
                },
                Layout::Compare => Line {
                    points,
                    color: COMPARE_COLORS[i % 2],
                    width: 2,
                    dashed: i == 1,
                    label: format!("{}: alert level", ["A", "B"][i % 2]),
                },
            }
        })
        .collect();
    Chart {
        title: "Alert level".into(),
        y_label: "level".into(),
        x_range_s: x_range(legs),
        y_range: (-0.3, 3.4),
        height_px: 220,
        bands: bands_for(legs, layout),
        lines,
        y_tick_names: Some(Level::ALL.iter().map(|l| l.to_string()).collect()),
        ..Chart::default()
    }
}

/// A leg's spectra: one panel per axis, input, head and weighted head, log density over
/// log frequency.
pub fn spectra_svg(leg: &Leg) -> Result<String> {
    let axes = ["x (along the body)", "y (lateral)", "z (vertical)"];
    let panels: Vec<Panel> = leg
        .spectra
        .iter()
        .zip(axes)
        .map(|(s, name)| {
            let pts = |y: &[f64]| -> Vec<(f64, f64)> {
                s.freqs_hz
                    .iter()
                    .zip(y)
                    .skip(1)
                    .map(|(&f, &p)| (f, p))
                    .collect()
            };
            Panel {
                title: format!("{name}, head weighted {}", s.weighting),
                x_label: "frequency, Hz".into(),
                y_label: "PSD, (m/s^2)^2/Hz".into(),
                log_y: true,
                // Over the one-third-octave bands ISO 2631-1 weights (0.5-80 Hz), in
                // decades: the model's 0.5-20 Hz is most of the width, not its left fifth.
                log_x: true,
                x_range: Some(third_octave::span_hz()),
                y_range: None,
                series: vec![
                    Series::line(pts(&s.input), INPUT_COLOR, 1.0, Some("litter input")),
                    Series::line(pts(&s.head), HEAD_COLOR, 1.0, Some("predicted head")),
                    Series::line(
                        pts(&s.head_weighted),
                        WEIGHTED_COLOR,
                        1.5,
                        Some("head, weighted |W(f)|^2"),
                    ),
                ],
            }
        })
        .collect();
    figure_svg(&format!("Spectra of {}", leg.label), &panels, 3)
}

/// Colours of a joint's x (along the spine), y (lateral) and z (anteroposterior) motion.
const JOINT_COLORS: [Rgb; 3] = [Rgb(214, 39, 40), Rgb(44, 160, 44), Rgb(31, 119, 180)];

/// The 1 s running rms of the three translations of the joint whose x output is
/// `first_output` (an index in `JointOutput::ALL`: 0 the neck, 5 the lower back), in mm.
pub fn joint_translations(legs: &[Leg], layout: Layout, first_output: usize, title: &str) -> Chart {
    let mut lines = Vec::new();
    for (axis, color) in JOINT_COLORS.iter().enumerate() {
        let o = first_output + axis;
        let name = supine_core::model::JointOutput::ALL
            .get(o)
            .map_or("", |output| output.name());
        lines.extend(per_leg(
            legs,
            layout,
            |l| l.series.joint_running_rms.iter().map(|r| r[o]).collect(),
            *color,
            &format!("{name}, running rms (1 s)"),
        ));
    }
    let all: Vec<f64> = legs
        .iter()
        .flat_map(|l| {
            l.series
                .joint_running_rms
                .iter()
                .flat_map(move |r| r[first_output..first_output + 3].to_vec())
        })
        .collect();
    Chart {
        title: title.into(),
        y_label: "running rms, mm".into(),
        x_range_s: x_range(legs),
        y_range: y_range(&all, &[], true),
        height_px: 260,
        bands: bands_for(legs, layout),
        lines,
        ..Chart::default()
    }
}
