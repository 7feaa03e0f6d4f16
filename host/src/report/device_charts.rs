//! The device section's charts: the device's telemetry over the host's on the same
//! samples. What each shows is decided here, how it is drawn in [`crate::plot::time_chart`].

use supine_core::alerts::{AlertConfig, Level};

use crate::plot::Rgb;
use crate::plot::time_chart::{Band, Chart, LEVEL_COLORS, Line, Marker, alert_thresholds, y_range};
use crate::report::device_check::DeviceLog;
use crate::report::device_series::{LevelMark, Points};

/// Axis colours: x, y, z.
pub const AXIS_COLORS: [Rgb; 3] = [Rgb(31, 119, 180), Rgb(44, 160, 44), Rgb(214, 39, 40)];
/// The vector sum's colour.
pub const VECTOR_COLOR: Rgb = Rgb(25, 25, 25);
/// The host's overlays.
pub const HOST_COLOR: Rgb = Rgb(255, 127, 14);
/// Shading of the exposure's warm-up.
pub const WARMUP_COLOR: Rgb = Rgb(120, 120, 120);

const AXES: [&str; 3] = ["x (along the body)", "y (lateral)", "z (vertical)"];

/// The y values of lines' points: each column's minimum and maximum are kept, so the
/// range is the whole series'.
fn ys<'a>(lines: impl IntoIterator<Item = &'a Points>) -> impl Iterator<Item = &'a f64> {
    lines.into_iter().flatten().map(|(_, y)| y)
}

fn line(points: Points, color: Rgb, width: u32, dashed: bool, label: &str) -> Line {
    Line {
        points,
        color,
        width,
        dashed,
        label: label.to_string(),
    }
}

/// The ride's marked stretches and the warm-up, for charts of exposure values.
fn bands_with_warmup(log: &DeviceLog, warmup_s: f64) -> Vec<Band> {
    let mut b = vec![Band {
        start_s: 0.0,
        end_s: warmup_s,
        label: "warm-up".into(),
        color: WARMUP_COLOR,
    }];
    b.extend(log.bands.iter().cloned());
    b
}

fn x_range(log: &DeviceLog) -> (f64, f64) {
    (0.0, log.duration_s())
}

/// The litter frame's acceleration on every axis: the ride the device was given.
pub fn input(log: &DeviceLog) -> Chart {
    let input = &log.pass.series.input_m_s2;
    let lines: Vec<Line> = [2, 0, 1]
        .into_iter()
        .map(|a| {
            line(
                input[a].clone(),
                AXIS_COLORS[a],
                1,
                false,
                &format!("litter {}", AXES[a]),
            )
        })
        .collect();
    let y = y_range(ys(input), &[], false);
    Chart {
        title: "Litter-frame acceleration (the device's input)".into(),
        y_label: "acceleration, m/s^2".into(),
        x_range_s: x_range(log),
        y_range: y,
        height_px: 320,
        bands: log.bands.clone(),
        lines,
        instants: log.moments.clone(),
        ..Chart::default()
    }
}

/// Predicted head acceleration on one axis: the device, and the f64 model over it.
pub fn head(log: &DeviceLog, axis: usize) -> Chart {
    let d = &log.pass.series.device;
    let f64_head = &log.pass.series.head_f64_m_s2[axis];
    let y = y_range(ys([&d.head_m_s2[axis], f64_head]), &[], false);
    Chart {
        title: format!("Predicted head acceleration, {} (unweighted)", AXES[axis]),
        y_label: "m/s^2".into(),
        x_range_s: x_range(log),
        y_range: y,
        height_px: 230,
        bands: log.bands.clone(),
        lines: vec![
            line(
                d.head_m_s2[axis].clone(),
                AXIS_COLORS[axis],
                2,
                false,
                "device",
            ),
            line(f64_head.clone(), HOST_COLOR, 1, true, "host, f64 model"),
        ],
        ..Chart::default()
    }
}

/// A marker at each device level event, at height `y_of` it.
fn level_markers(log: &DeviceLog, y_of: impl Fn(&LevelMark) -> f64) -> Vec<Marker> {
    log.pass
        .series
        .level_marks
        .iter()
        .map(|m| Marker {
            t_s: m.t_s,
            y: y_of(m),
            up: m.raised,
            color: LEVEL_COLORS[m.level as usize],
        })
        .collect()
}

/// The vector sum's running rms against the running-rms thresholds, with level events.
pub fn vector_rms(log: &DeviceLog, alerts: &AlertConfig, warmup_s: f64) -> Chart {
    let d = &log.pass.series.device;
    let h = &log.pass.series.host;
    let th = alerts.running_rms_m_s2;
    let y = y_range(
        ys([&d.vector_rms_m_s2]),
        &th.map(|v| f64::from(v) * 1.05),
        true,
    );
    Chart {
        title: "Weighted running rms (1 s), vector sum, against the alert thresholds".into(),
        y_label: "m/s^2".into(),
        x_range_s: x_range(log),
        y_range: y,
        height_px: 340,
        bands: bands_with_warmup(log, warmup_s),
        thresholds: alert_thresholds(th),
        lines: vec![
            line(
                d.vector_rms_m_s2.clone(),
                VECTOR_COLOR,
                2,
                false,
                "device, vector sum",
            ),
            line(
                h.vector_rms_m_s2.clone(),
                HOST_COLOR,
                1,
                true,
                "host, vector sum",
            ),
        ],
        markers: level_markers(log, |m| m.vector_rms_m_s2),
        ..Chart::default()
    }
}

/// The running rms of each weighted head axis, device and host.
pub fn axis_rms(log: &DeviceLog, warmup_s: f64) -> Chart {
    let d = &log.pass.series.device;
    let h = &log.pass.series.host;
    let mut lines = Vec::new();
    for a in 0..3 {
        lines.push(line(
            d.running_rms_m_s2[a].clone(),
            AXIS_COLORS[a],
            2,
            false,
            &format!("device, head {}", AXES[a]),
        ));
    }
    for a in 0..3 {
        lines.push(line(
            h.running_rms_m_s2[a].clone(),
            HOST_COLOR,
            1,
            true,
            if a == 0 { "host (each axis)" } else { "" },
        ));
    }
    let y = y_range(ys(&d.running_rms_m_s2), &[], true);
    Chart {
        title: "Weighted running rms (1 s) per head axis".into(),
        y_label: "m/s^2".into(),
        x_range_s: x_range(log),
        y_range: y,
        height_px: 280,
        bands: bands_with_warmup(log, warmup_s),
        lines,
        ..Chart::default()
    }
}

/// The vibration dose value against its thresholds (those in view).
pub fn vdv(log: &DeviceLog, alerts: &AlertConfig, warmup_s: f64) -> Chart {
    let d = &log.pass.series.device;
    let h = &log.pass.series.host;
    let th = alerts.vdv_m_s175;
    // Keep the first threshold in view; higher ones far above the data would flatten the
    // curve, and the caption lists them.
    let y = y_range(ys([&d.vdv_m_s175]), &[f64::from(th[0]) * 1.05], true);
    Chart {
        title: "Vibration dose value (VDV) of the vector sum, since the start".into(),
        y_label: "m/s^1.75".into(),
        x_range_s: x_range(log),
        y_range: y,
        height_px: 280,
        bands: bands_with_warmup(log, warmup_s),
        thresholds: alert_thresholds(th),
        lines: vec![
            line(d.vdv_m_s175.clone(), VECTOR_COLOR, 2, false, "device"),
            line(h.vdv_m_s175.clone(), HOST_COLOR, 1, true, "host"),
        ],
        ..Chart::default()
    }
}

/// The alert level over time, with a marker at each raise and clear.
pub fn levels(log: &DeviceLog, warmup_s: f64) -> Chart {
    Chart {
        title: "Alert level (raised: up triangle, lowered: down triangle)".into(),
        y_label: "level".into(),
        x_range_s: x_range(log),
        y_range: (-0.3, 3.4),
        height_px: 240,
        bands: bands_with_warmup(log, warmup_s),
        lines: vec![
            line(
                log.pass.series.device.level_steps.clone(),
                VECTOR_COLOR,
                2,
                false,
                "device",
            ),
            line(
                log.pass.series.host.level_steps.clone(),
                HOST_COLOR,
                1,
                true,
                "host",
            ),
        ],
        markers: level_markers(log, |m| m.level as u8 as f64),
        y_tick_names: Some(Level::ALL.iter().map(|l| l.to_string()).collect()),
        ..Chart::default()
    }
}
