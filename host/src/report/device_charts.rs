//! The device section's charts: the device's telemetry over the host's on the same
//! samples. What each shows is decided here, how it is drawn in [`crate::plot::time_chart`].

use supine_core::alerts::{AlertConfig, Level};

use crate::io::telemetry_csv::level_from_name;
use crate::plot::Rgb;
use crate::plot::downsample::min_max;
use crate::plot::time_chart::{
    Band, Chart, LEVEL_COLORS, Line, Marker, PLOT_COLUMNS, alert_thresholds, y_range,
};
use crate::report::device_check::DeviceLog;
use crate::report::trace::Trace;

/// Axis colours: x, y, z.
pub const AXIS_COLORS: [Rgb; 3] = [Rgb(31, 119, 180), Rgb(44, 160, 44), Rgb(214, 39, 40)];
/// The vector sum's colour.
pub const VECTOR_COLOR: Rgb = Rgb(25, 25, 25);
/// The host's overlays.
pub const HOST_COLOR: Rgb = Rgb(255, 127, 14);
/// Shading of the exposure's warm-up.
pub const WARMUP_COLOR: Rgb = Rgb(120, 120, 120);

const AXES: [&str; 3] = ["x (along the body)", "y (lateral)", "z (vertical)"];

fn series(t: &[f64], y: &[f64]) -> Vec<(f64, f64)> {
    min_max(t, y, PLOT_COLUMNS)
}

fn line(points: Vec<(f64, f64)>, color: Rgb, width: u32, dashed: bool, label: &str) -> Line {
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
    let fs = log.sample_rate_hz;
    let t: Vec<f64> = (0..log.input_m_s2[0].len())
        .map(|k| k as f64 / fs)
        .collect();
    let lines: Vec<Line> = [2, 0, 1]
        .into_iter()
        .map(|a| {
            line(
                series(&t, &log.input_m_s2[a]),
                AXIS_COLORS[a],
                1,
                false,
                &format!("litter {}", AXES[a]),
            )
        })
        .collect();
    let y = y_range(log.input_m_s2.iter().flatten(), &[], false);
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
    let d = &log.device;
    let host_t: Vec<f64> = (0..log.host_head_f64_m_s2[axis].len())
        .map(|k| k as f64 / log.sample_rate_hz)
        .collect();
    let y = y_range(
        d.head_m_s2[axis]
            .iter()
            .chain(&log.host_head_f64_m_s2[axis]),
        &[],
        false,
    );
    Chart {
        title: format!("Predicted head acceleration, {} (unweighted)", AXES[axis]),
        y_label: "m/s^2".into(),
        x_range_s: x_range(log),
        y_range: y,
        height_px: 230,
        bands: log.bands.clone(),
        lines: vec![
            line(
                series(&d.time_s, &d.head_m_s2[axis]),
                AXIS_COLORS[axis],
                2,
                false,
                "device",
            ),
            line(
                series(&host_t, &log.host_head_f64_m_s2[axis]),
                HOST_COLOR,
                1,
                true,
                "host, f64 model",
            ),
        ],
        ..Chart::default()
    }
}

/// Where the vector running rms was when each level event happened, for markers.
fn level_markers(log: &DeviceLog, trace: &Trace, y_of: impl Fn(usize) -> f64) -> Vec<Marker> {
    log.device_events
        .iter()
        .filter(|e| e.kind == "level")
        .filter_map(|e| {
            let k = trace.sample.binary_search(&e.sample).ok()?;
            let level = level_from_name(&e.name)?;
            Some(Marker {
                t_s: e.time_s,
                y: y_of(k),
                up: e.raised,
                color: LEVEL_COLORS[level as usize],
            })
        })
        .collect()
}

/// The vector sum's running rms against the running-rms thresholds, with level events.
pub fn vector_rms(log: &DeviceLog, alerts: &AlertConfig, warmup_s: f64) -> Chart {
    let d = &log.device;
    let h = &log.host;
    let th = alerts.running_rms_m_s2;
    let y = y_range(
        d.vector_rms_m_s2.iter(),
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
        thresholds: alert_thresholds(th, "m/s^2"),
        lines: vec![
            line(
                series(&d.time_s, &d.vector_rms_m_s2),
                VECTOR_COLOR,
                2,
                false,
                "device, vector sum",
            ),
            line(
                series(&h.time_s, &h.vector_rms_m_s2),
                HOST_COLOR,
                1,
                true,
                "host, vector sum",
            ),
        ],
        markers: level_markers(log, d, |k| d.vector_rms_m_s2[k]),
        ..Chart::default()
    }
}

/// The running rms of each weighted head axis, device and host.
pub fn axis_rms(log: &DeviceLog, warmup_s: f64) -> Chart {
    let d = &log.device;
    let h = &log.host;
    let mut lines = Vec::new();
    for a in 0..3 {
        lines.push(line(
            series(&d.time_s, &d.running_rms_m_s2[a]),
            AXIS_COLORS[a],
            2,
            false,
            &format!("device, head {}", AXES[a]),
        ));
    }
    for a in 0..3 {
        lines.push(line(
            series(&h.time_s, &h.running_rms_m_s2[a]),
            HOST_COLOR,
            1,
            true,
            if a == 0 { "host (each axis)" } else { "" },
        ));
    }
    let y = y_range(d.running_rms_m_s2.iter().flatten(), &[], true);
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
    let d = &log.device;
    let h = &log.host;
    let th = alerts.vdv_m_s175;
    // Keep the first threshold in view; higher ones far above the data would flatten the
    // curve, and the caption lists them.
    let y = y_range(d.vdv_m_s175.iter(), &[f64::from(th[0]) * 1.05], true);
    Chart {
        title: "Vibration dose value (VDV) of the vector sum, since the start".into(),
        y_label: "m/s^1.75".into(),
        x_range_s: x_range(log),
        y_range: y,
        height_px: 280,
        bands: bands_with_warmup(log, warmup_s),
        thresholds: alert_thresholds(th, "m/s^1.75"),
        lines: vec![
            line(
                series(&d.time_s, &d.vdv_m_s175),
                VECTOR_COLOR,
                2,
                false,
                "device",
            ),
            line(
                series(&h.time_s, &h.vdv_m_s175),
                HOST_COLOR,
                1,
                true,
                "host",
            ),
        ],
        ..Chart::default()
    }
}

/// Steps of a level trace: a point at the start, then two at every change.
fn level_steps(trace: &Trace, end_s: f64) -> Vec<(f64, f64)> {
    let mut points = Vec::new();
    let mut last: Option<Level> = None;
    for (k, &level) in trace.level.iter().enumerate() {
        let t = trace.time_s[k];
        match last {
            None => points.push((t, level as u8 as f64)),
            Some(prev) if prev != level => {
                points.push((t, prev as u8 as f64));
                points.push((t, level as u8 as f64));
            }
            _ => {}
        }
        last = Some(level);
    }
    if let Some(l) = last {
        points.push((end_s, l as u8 as f64));
    }
    points
}

/// The alert level over time, with a marker at each raise and clear.
pub fn levels(log: &DeviceLog, warmup_s: f64) -> Chart {
    let end = log.duration_s();
    Chart {
        title: "Alert level (raised: up triangle, lowered: down triangle)".into(),
        y_label: "level".into(),
        x_range_s: x_range(log),
        y_range: (-0.3, 3.4),
        height_px: 240,
        bands: bands_with_warmup(log, warmup_s),
        lines: vec![
            line(
                level_steps(&log.device, end),
                VECTOR_COLOR,
                2,
                false,
                "device",
            ),
            line(level_steps(&log.host, end), HOST_COLOR, 1, true, "host"),
        ],
        markers: level_markers(log, &log.device, |k| log.device.level[k] as u8 as f64),
        y_tick_names: Some(
            ["normal", "advisory", "warning", "alarm"]
                .iter()
                .map(|s| s.to_string())
                .collect(),
        ),
        ..Chart::default()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn level_steps_change_where_the_level_does() {
        let trace = Trace {
            sample: vec![0, 1, 2, 3],
            time_s: vec![0.0, 1.0, 2.0, 3.0],
            level: vec![Level::Normal, Level::Normal, Level::Warning, Level::Normal],
            ..Trace::default()
        };
        assert_eq!(
            level_steps(&trace, 4.0),
            vec![
                (0.0, 0.0),
                (2.0, 0.0),
                (2.0, 2.0),
                (3.0, 2.0),
                (3.0, 0.0),
                (4.0, 0.0)
            ]
        );
    }
}
