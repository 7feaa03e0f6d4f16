//! `supine report` and `supine exposure` read a ride row by row: their numbers against a
//! whole-ride reference computed here from the ride held in memory (the device pipeline
//! over every sample at once, Welch over whole arrays, the projection from a per-sample
//! VDV trace), and the lists that could grow with a ride bounded.

use std::path::{Path, PathBuf};

use supine_core::alerts::Level;
use supine_core::calibration::SensorFrame;
use supine_core::model::Preset;
use supine_core::pipeline::{PipelineOutput, PipelineState};

use supine_host::device::device_params;
use supine_host::exposure::model_exposure::evaluate_model;
use supine_host::exposure::model_run::MAX_LISTED_EVENTS;
use supine_host::exposure::ride::{Profile, generate, write_ride};
use supine_host::io::params_file::ParamFile;
use supine_host::io::recording::{PLATFORM_HEADER_LINE, read_input};
use supine_host::io::ride_input::RideInputArgs;
use supine_host::report::build;
use supine_host::report::mission::{CHART_RATE_HZ, PROJECTION_WINDOW_S};
use supine_host::report::spectrum::density;
use supine_host::schema::event::EventCriterion;

const FS_HZ: f64 = 500.0;

fn ride(dir: &Path, profile: Profile, duration_s: f64, seed: u64) -> PathBuf {
    let path = dir.join(format!("{}-{seed}.csv", profile.name()));
    write_ride(&path, &generate(profile, duration_s, FS_HZ, seed).unwrap()).unwrap();
    path
}

/// The whole ride through the device pipeline in one call: every sample's telemetry and
/// every event.
struct Whole {
    input: [Vec<f64>; 3],
    head: [Vec<f64>; 3],
    vector_rms: Vec<f64>,
    vdv: Vec<f64>,
    level: Vec<u8>,
    events: Vec<supine_core::alerts::AlertEvent>,
}

fn whole(path: &Path, file: &ParamFile) -> Whole {
    let (recording, _) = read_input(path).unwrap();
    let params = device_params::build(file, FS_HZ)
        .unwrap()
        .with_telemetry(supine_core::blob::TelemetryConfig::EVERY_SAMPLE)
        .unwrap();
    let samples = recording.platform_samples();
    let indices: Vec<u32> = (0..samples.len() as u32).collect();
    let mut state = PipelineState::new();
    let mut w = Whole {
        input: recording.platform_m_s2.clone(),
        head: Default::default(),
        vector_rms: Vec::new(),
        vdv: Vec::new(),
        level: Vec::new(),
        events: Vec::new(),
    };
    params.process(&mut state, &indices, &samples, |out| match out {
        PipelineOutput::Alert(e) => w.events.push(e),
        PipelineOutput::Telemetry(t) => {
            for (axis, v) in w.head.iter_mut().zip(t.head_acc_m_s2) {
                axis.push(f64::from(v));
            }
            w.vector_rms.push(f64::from(t.vector_running_rms_m_s2));
            w.vdv.push(f64::from(t.vdv_m_s175));
            w.level.push(t.alert_level as u8);
        }
    });
    w
}

#[test]
fn a_leg_read_row_by_row_gives_the_whole_rides_spectra_levels_alerts_and_projection() {
    let dir = tempfile::tempdir().unwrap();
    // Longer than the projection's window, so that the window starts inside the leg.
    let path = ride(dir.path(), Profile::RoughRoad, 400.0, 11);
    let file = ParamFile::preset(Preset::PaperLitter);
    let opener = RideInputArgs::default();
    let report = build(
        std::slice::from_ref(&path),
        opener.opener(SensorFrame::LEVEL),
        &file,
        "paper-litter",
        false,
    )
    .unwrap();
    let leg = &report.legs[0];
    let w = whole(&path, &file);
    let n = w.level.len();

    // Spectra: Welch over the whole arrays, bit for bit.
    for axis in 0..3 {
        let s = &leg.spectra[axis];
        let top = s.freqs_hz.len();
        let (f, input) = density(&w.input[axis], FS_HZ).unwrap();
        let (_, head) = density(&w.head[axis], FS_HZ).unwrap();
        assert_eq!(s.freqs_hz, f[..top]);
        assert_eq!(s.input, input[..top]);
        assert_eq!(s.head, head[..top]);
    }

    // Time at each level: the per-sample trace counted.
    let at = leg.time_at_level_s.as_array();
    for (l, seconds) in at.iter().enumerate() {
        let count = w.level.iter().filter(|&&v| usize::from(v) == l).count();
        assert_eq!(*seconds, count as f64 / FS_HZ, "level {l}");
    }

    // Alerts: each with its criterion's value and the vector values at its sample.
    assert!(!w.events.is_empty(), "a rough road raises alerts");
    assert_eq!(leg.alerts.len(), w.events.len());
    for (row, e) in leg.alerts.iter().zip(&w.events) {
        let k = e.at_sample() as usize;
        assert_eq!(row.leg_time_s, k as f64 / FS_HZ);
        assert_eq!(row.running_rms_m_s2, w.vector_rms[k]);
        assert_eq!(row.vdv_m_s175, w.vdv[k]);
        match (e.criterion(), row.criterion) {
            (Some(c), Some(EventCriterion::Exposure(r))) => {
                assert_eq!(r, c);
                assert_eq!(row.criterion.unwrap().value().1, f64::from(c.value()));
            }
            (None, None) => assert_eq!(row.kind, "fault"),
            (c, r) => panic!("{c:?} against {r:?}"),
        }
    }

    // The projection: the VDV at the first 10 Hz step at or after the window's start
    // (the last 300 s) and at the last sample.
    let step = (FS_HZ / CHART_RATE_HZ).round() as usize;
    let end_s = n as f64 / FS_HZ;
    let from_s = end_s - PROJECTION_WINDOW_S;
    let k_from = (0..n)
        .step_by(step)
        .find(|&k| k as f64 / FS_HZ >= from_s)
        .unwrap();
    let rate = (w.vdv[n - 1].powi(4) - w.vdv[k_from].powi(4)).max(0.0) / PROJECTION_WINDOW_S;
    let p = &report.mission.projection;
    assert_eq!(p.window_s, PROJECTION_WINDOW_S);
    assert_eq!(p.vdv4_rate_per_s, rate);
    assert!(rate > 0.0);

    // The chart series: one point per 0.1 s and the end; its largest running rms and its
    // extreme inputs are the ride's.
    let series = &leg.series;
    assert_eq!(series.t_s.len(), n.div_ceil(step) + 1);
    let max_rms = w.vector_rms.iter().copied().fold(0.0, f64::max);
    let series_max = series.vector_rms_m_s2.iter().copied().fold(0.0, f64::max);
    assert_eq!(series_max, max_rms);
    let z_max = w.input[2].iter().copied().fold(f64::MIN, f64::max);
    let z_min = w.input[2].iter().copied().fold(f64::MAX, f64::min);
    assert_eq!(
        series
            .platform_z_m_s2
            .iter()
            .map(|p| p.1)
            .fold(f64::MIN, f64::max),
        z_max
    );
    assert_eq!(
        series
            .platform_z_m_s2
            .iter()
            .map(|p| p.0)
            .fold(f64::MAX, f64::min),
        z_min
    );
    let page = supine_host::report::page::render(&report, None).unwrap();
    assert!(page.contains("litter z (vertical), max per 0.1 s"));
}

#[test]
fn events_beyond_the_listed_ones_are_counted_not_kept() {
    // A sensor that saturates for one sample in every ten, and a fault that clears after
    // 4 ms without it: raised and cleared 3000 times in a minute.
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("flicker.csv");
    let mut text = format!("{PLATFORM_HEADER_LINE}\n");
    for k in 0..30_000 {
        let z = if k % 10 == 5 {
            1e30
        } else {
            0.01 * (k % 7) as f64
        };
        text.push_str(&format!("{},0,0,{z}\n", k as f64 / FS_HZ));
    }
    std::fs::write(&path, text).unwrap();
    let mut file = ParamFile::preset(Preset::PaperLitter);
    let mut device = file.device.unwrap_or_default();
    device.sensor_checks.clear_after_s = 0.004;
    file.device = Some(device);
    let w = whole(&path, &file);
    assert!(w.events.len() > MAX_LISTED_EVENTS, "{}", w.events.len());
    let ride = RideInputArgs::default()
        .open(&path, &SensorFrame::LEVEL)
        .unwrap();
    let e = evaluate_model(&ride, &file, "paper-litter".into(), None).unwrap();
    assert_eq!(e.alerts.len(), MAX_LISTED_EVENTS);
    assert_eq!(e.alerts_omitted, w.events.len() - MAX_LISTED_EVENTS);
    for (listed, event) in e.alerts.iter().zip(&w.events) {
        assert_eq!(listed.sample, event.at_sample());
    }
    let highest = w
        .events
        .iter()
        .filter_map(|e| match e {
            supine_core::alerts::AlertEvent::Level { to, .. } => Some(*to),
            _ => None,
        })
        .fold(Level::Normal, Level::max);
    assert_eq!(e.max_level, highest);
    assert!(e.to_text().contains(&format!(
        "... and {} more events",
        w.events.len() - MAX_LISTED_EVENTS
    )));
    let report = build(
        std::slice::from_ref(&path),
        RideInputArgs::default().opener(SensorFrame::LEVEL),
        &file,
        "paper-litter",
        false,
    )
    .unwrap();
    assert_eq!(report.legs[0].alerts.len(), MAX_LISTED_EVENTS);
    let json = serde_json::to_value(&report).unwrap();
    assert_eq!(
        json["legs"][0]["alerts_omitted"].as_u64(),
        Some((w.events.len() - MAX_LISTED_EVENTS) as u64)
    );
}
