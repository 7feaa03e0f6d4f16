//! `supine report` with positions (issue 27): the route's distances and segments against
//! the closed form of a known path, events drawn where their sample was, a track joined
//! by time with a known offset, the segments' contributions combined against the leg's
//! own values, and bad tracks refused or flagged.

use std::f64::consts::PI;
use std::path::{Path, PathBuf};

use supine_core::model::Preset;
use supine_host::commands::band_args::BandArgs;
use supine_host::commands::report::{self, MissionArgs};
use supine_host::io::params_file::{ModelSource, ParamFile, PresetArg};
use supine_host::io::ride_input::{RideInputArgs, TrackArgs};
use supine_host::io::ride_rows::ColumnNames;
use supine_host::io::subject_args::SubjectArgs;
use supine_host::report::build;
use supine_host::report::mission::Leg;
use supine_host::ride::position::EARTH_RADIUS_M;

const FS_HZ: f64 = 200.0;
/// Metres per degree of latitude on the mean sphere.
const M_PER_DEG: f64 = EARTH_RADIUS_M * PI / 180.0;

/// The platform's vertical acceleration at `t_s`: 4 Hz, rough in the middle third.
fn vertical_m_s2(t_s: f64, seconds: f64) -> f64 {
    let gain = if t_s > seconds / 3.0 && t_s < 2.0 * seconds / 3.0 {
        4.0
    } else {
        0.6
    };
    gain * (2.0 * PI * 4.0 * t_s).sin() + 0.2 * (2.0 * PI * 11.0 * t_s).sin()
}

/// Position along a straight road from (lat0, lon0) at `bearing_rad` after `d_m`.
fn along(lat0: f64, lon0: f64, bearing_rad: f64, d_m: f64) -> (f64, f64) {
    (
        lat0 + d_m * bearing_rad.cos() / M_PER_DEG,
        lon0 + d_m * bearing_rad.sin() / (M_PER_DEG * lat0.to_radians().cos()),
    )
}

/// A logger's CSV with time, acceleration and (on every 20th row, 10 Hz, and the last)
/// position columns: a straight road from 52 N, 4 E at `bearing_deg`, `speed_m_s`.
fn ride_with_positions(dir: &Path, seconds: f64, speed_m_s: f64, bearing_deg: f64) -> PathBuf {
    let path = dir.join("logger.csv");
    let mut text = String::from("t,ax,ay,az,lat,lon\n");
    let n = (seconds * FS_HZ) as usize;
    for k in 0..n {
        let t = k as f64 / FS_HZ;
        let z = vertical_m_s2(t, seconds);
        let x = 0.3 * (2.0 * PI * 1.3 * t).sin();
        if k % 20 == 0 || k + 1 == n {
            let (lat, lon) = along(52.0, 4.0, bearing_deg.to_radians(), speed_m_s * t);
            text.push_str(&format!("{t},{x},0.05,{z},{lat:.9},{lon:.9}\n"));
        } else {
            text.push_str(&format!("{t},{x},0.05,{z},,\n"));
        }
    }
    std::fs::write(&path, text).unwrap();
    path
}

fn columns_args() -> RideInputArgs {
    RideInputArgs {
        columns: Some(ColumnNames::parse("time=t,x=ax,y=ay,z=az,lat=lat,lon=lon").unwrap()),
        ..RideInputArgs::default()
    }
}

fn legs(inputs: &[PathBuf], args: &RideInputArgs, tracks: &TrackArgs) -> anyhow::Result<Vec<Leg>> {
    let file = ParamFile::preset(Preset::PaperLitter);
    let opener =
        args.opener_with_tracks(supine_core::calibration::SensorFrame::LEVEL, tracks, inputs)?;
    Ok(build(inputs, opener, &file, "paper-litter", false)?.legs)
}

/// `supine report --json` of `input` with the preset, into `out`.
fn report_args(
    input: Vec<PathBuf>,
    ride: RideInputArgs,
    track: TrackArgs,
    out: &Path,
) -> report::Args {
    report::Args {
        mission: MissionArgs {
            input,
            ride,
            track,
            model: ModelSource {
                preset: Some(PresetArg::PaperLitter),
                params: None,
            },
            subject: SubjectArgs::default(),
        },
        out: out.to_path_buf(),
        json: true,
        compare: false,
        band: BandArgs::default(),
    }
}

#[test]
fn a_straight_road_gives_its_length_its_segments_and_the_legs_values() {
    let dir = tempfile::tempdir().unwrap();
    let (seconds, speed) = (60.0, 14.0);
    let input = ride_with_positions(dir.path(), seconds, speed, 30.0);
    let legs = legs(&[input], &columns_args(), &TrackArgs::default()).unwrap();
    let leg = &legs[0];
    let route = leg.route.as_ref().expect("a route");
    // 14 m/s from the first sample to the last: 839.93 m, to 0.2 %.
    let closed_form = speed * (seconds - 1.0 / FS_HZ);
    assert!(
        (route.length_m / closed_form - 1.0).abs() < 2e-3,
        "{} against {closed_form}",
        route.length_m
    );
    let full = &route.segments[..route.segments.len() - 1];
    assert_eq!(full.len(), (closed_form / 50.0) as usize);
    for s in full {
        // 50 m and at most one sample's travel (7 cm) more.
        assert!(
            s.length_m >= 50.0 && s.length_m <= 50.0 + speed / FS_HZ + 1e-6,
            "{}",
            s.length_m
        );
        assert!((s.speed_m_s - speed).abs() < 0.05, "{}", s.speed_m_s);
        // The midpoint is where the closed form puts half the segment.
        let d = speed * (s.start_s + s.end_s) / 2.0;
        let (lat, lon) = along(52.0, 4.0, 30f64.to_radians(), d);
        let off_m = ((s.lat_deg - lat) * M_PER_DEG)
            .hypot((s.lon_deg - lon) * M_PER_DEG * 52f64.to_radians().cos());
        assert!(off_m < 0.5, "{off_m} m off");
    }
    // Energy-equivalent: the segments' rms over their evaluated time is the leg's rms
    // (the device's f32 sums against the segments' f64 ones), their VDV^4 sum its VDV.
    let weights: f64 = route.segments.iter().map(|s| s.evaluated_s).sum();
    assert!((weights - leg.exposure.evaluated_s).abs() < 1e-6);
    let rms = (route
        .segments
        .iter()
        .map(|s| s.rms_m_s2 * s.rms_m_s2 * s.evaluated_s)
        .sum::<f64>()
        / weights)
        .sqrt();
    let vdv = route
        .segments
        .iter()
        .map(|s| s.vdv_m_s175.powi(4))
        .sum::<f64>()
        .powf(0.25);
    assert!(
        (rms / leg.vector.rms_m_s2 - 1.0).abs() < 1e-5,
        "{rms} against {}",
        leg.vector.rms_m_s2
    );
    assert!(
        (vdv / leg.vector.vdv_m_s175 - 1.0).abs() < 1e-5,
        "{vdv} against {}",
        leg.vector.vdv_m_s175
    );
    // The rough middle third is where the worst segments are.
    let worst = &route.worst_segments[0];
    assert!(worst.start_s > 20.0 && worst.end_s < 40.5, "{worst:?}");
    let levels: f64 = route
        .segments
        .iter()
        .map(|s| s.time_at_level_s.as_array().iter().sum::<f64>())
        .sum();
    assert!((levels - leg.duration_s).abs() < 1e-6);
    // The joints: the largest excursion over the segments is the leg's (every evaluated
    // sample has a position), output by output, in the same display units.
    for joint in &leg.joints {
        let key = format!("{}_{}", joint.output, joint.unit);
        let peak = route
            .segments
            .iter()
            // A segment within the warm-up has none.
            .filter_map(|s| s.largest_joint_excursions)
            .map(|peaks| serde_json::to_value(peaks).unwrap()[&key].as_f64().unwrap())
            .fold(0.0, f64::max);
        assert!(
            (peak - joint.largest_excursion).abs() <= 1e-12 * joint.largest_excursion.max(1e-300),
            "{key}: {peak} over the segments, {} for the leg",
            joint.largest_excursion
        );
    }
}

#[test]
fn an_event_is_drawn_where_its_sample_was() {
    let dir = tempfile::tempdir().unwrap();
    let (seconds, speed) = (60.0, 14.0);
    let input = ride_with_positions(dir.path(), seconds, speed, 120.0);
    let legs = legs(&[input], &columns_args(), &TrackArgs::default()).unwrap();
    let leg = &legs[0];
    let route = leg.route.as_ref().unwrap();
    assert!(!leg.alerts.is_empty(), "the rough stretch raises an alert");
    assert_eq!(route.events.len(), leg.alerts.len());
    for (placed, alert) in route.events.iter().zip(&leg.alerts) {
        assert_eq!(placed.leg_time_s, alert.leg_time_s);
        let (lat, lon) = along(52.0, 4.0, 120f64.to_radians(), speed * alert.leg_time_s);
        let off_m = ((placed.lat_deg - lat) * M_PER_DEG)
            .hypot((placed.lon_deg - lon) * M_PER_DEG * 52f64.to_radians().cos());
        assert!(off_m < 0.5, "{} at {off_m} m from its sample", placed.event);
    }
}

/// A GPX track of a straight road northwards, a fix a second for `seconds`.
fn gpx(dir: &Path, seconds: usize, speed_m_s: f64) -> PathBuf {
    let path = dir.join("track.gpx");
    let mut text = String::from(
        "<?xml version=\"1.0\"?>\n<gpx version=\"1.1\" creator=\"test\" xmlns=\"http://www.topografix.com/GPX/1/1\"><trk><trkseg>\n",
    );
    for k in 0..=seconds {
        let (lat, lon) = along(-33.9, 18.4, 0.0, speed_m_s * k as f64);
        text.push_str(&format!(
            "<trkpt lat=\"{lat:.9}\" lon=\"{lon:.9}\"><time>2026-03-01T10:{:02}:{:02}Z</time></trkpt>\n",
            k / 60,
            k % 60
        ));
    }
    text.push_str("</trkseg></trk></gpx>\n");
    std::fs::write(&path, text).unwrap();
    path
}

/// The project's own ride file (no positions), `seconds` long at [`FS_HZ`].
fn plain_ride(dir: &Path, name: &str, seconds: f64) -> PathBuf {
    let path = dir.join(name);
    let mut text = String::from("time_s,platform_x_m_s2,platform_y_m_s2,platform_z_m_s2\n");
    for k in 0..(seconds * FS_HZ) as usize {
        let t = k as f64 / FS_HZ;
        text.push_str(&format!("{t},0.1,0.05,{}\n", vertical_m_s2(t, seconds)));
    }
    std::fs::write(&path, text).unwrap();
    path
}

#[test]
fn a_track_joined_with_an_offset_lands_where_the_offset_says() {
    let dir = tempfile::tempdir().unwrap();
    let ride = plain_ride(dir.path(), "ride.csv", 60.0);
    let track = gpx(dir.path(), 40, 10.0);
    let tracks = TrackArgs {
        tracks: vec![track],
        track_offset_s: 12.0,
    };
    let legs = legs(&[ride], &RideInputArgs::default(), &tracks).unwrap();
    let route = legs[0].route.as_ref().unwrap();
    // The track's zero is the ride's 12 s: nothing placed before it, nor after 52 s.
    assert!(
        (route.unplaced_s - 20.0).abs() < 0.01,
        "{}",
        route.unplaced_s
    );
    assert!((route.segments[0].start_s - 12.0).abs() < 1e-9);
    // The ride's 32 s is the track's 20 s: 200 m north of its start.
    let at_32 = route
        .segments
        .iter()
        .find(|s| s.start_s <= 32.0 && s.end_s > 32.0)
        .unwrap();
    assert!((at_32.start_s - 32.0).abs() <= 5.0);
    let first = &route.map[0];
    let (lat0, lon0) = along(-33.9, 18.4, 0.0, 0.0);
    assert!(
        ((first.lat_deg - lat0) * M_PER_DEG).abs() < 0.01 && (first.lon_deg - lon0).abs() < 1e-9
    );
    let (mid_lat, _) = along(
        -33.9,
        18.4,
        0.0,
        10.0 * (at_32.start_s + at_32.end_s) / 2.0 - 120.0,
    );
    assert!(((at_32.lat_deg - mid_lat) * M_PER_DEG).abs() < 0.5);
    assert!((route.length_m - 400.0).abs() < 0.5, "{}", route.length_m);
}

#[test]
fn bad_tracks_are_refused_in_one_line_or_flagged() {
    let dir = tempfile::tempdir().unwrap();
    let ride = plain_ride(dir.path(), "ride.csv", 20.0);
    // Not overlapping in time.
    let tracks = TrackArgs {
        tracks: vec![gpx(dir.path(), 10, 10.0)],
        track_offset_s: 500.0,
    };
    let e = legs(
        std::slice::from_ref(&ride),
        &RideInputArgs::default(),
        &tracks,
    )
    .unwrap_err()
    .to_string();
    assert!(
        e.contains("ride.csv: the track") && e.contains("expected them to overlap"),
        "{e}"
    );
    assert_eq!(e.lines().count(), 1);
    // A latitude out of range in the ride's own columns: file, line, column.
    let input = ride_with_positions(dir.path(), 10.0, 10.0, 0.0);
    let text = std::fs::read_to_string(&input).unwrap();
    let broken = text.replacen(",52.000000000,", ",152.000000000,", 1);
    assert_ne!(text, broken);
    std::fs::write(&input, broken).unwrap();
    let e = legs(
        std::slice::from_ref(&input),
        &columns_args(),
        &TrackArgs::default(),
    )
    .unwrap_err()
    .to_string();
    assert!(
        e.contains("logger.csv: line 2, column \"lat\": expected a latitude within -90..90"),
        "{e}"
    );
    // A jump of 300 km in a second: excluded, counted, the road's length kept.
    let jumpy = dir.path().join("jumpy.gpx");
    let good = std::fs::read_to_string(gpx(dir.path(), 10, 10.0)).unwrap();
    let bad = good.replacen("lat=\"-33.899910", "lat=\"-31.199910", 1);
    assert_ne!(good, bad);
    std::fs::write(&jumpy, bad).unwrap();
    let tracks = TrackArgs {
        tracks: vec![jumpy],
        track_offset_s: 0.0,
    };
    let legs = legs(&[ride], &RideInputArgs::default(), &tracks).unwrap();
    let route = legs[0].route.as_ref().unwrap();
    assert_eq!(route.track.jumps_excluded, 1);
    // The data-quality account flags it too.
    let quality = legs[0].data_quality.as_ref().expect("a ride's account");
    assert_eq!(quality.positions.as_ref().unwrap().jumps_excluded, 1);
    assert!((route.length_m - 100.0).abs() < 0.5, "{}", route.length_m);
    // --track given for one of two rides.
    let args = report_args(
        vec![dir.path().join("ride.csv"), dir.path().join("ride.csv")],
        RideInputArgs::default(),
        TrackArgs {
            tracks: vec![gpx(dir.path(), 10, 10.0)],
            track_offset_s: 0.0,
        },
        &dir.path().join("out"),
    );
    let e = report::run_to(&args, &mut Vec::new())
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("--track: expected one per --input (2), found 1"),
        "{e}"
    );
}

#[test]
fn the_json_has_route_per_leg_and_null_without_positions() {
    let dir = tempfile::tempdir().unwrap();
    let with = ride_with_positions(dir.path(), 20.0, 12.0, 45.0);
    let args = report_args(
        vec![with],
        columns_args(),
        TrackArgs::default(),
        &dir.path().join("out"),
    );
    let mut text = Vec::new();
    report::run_to(&args, &mut text).unwrap();
    let json: serde_json::Value = serde_json::from_slice(&text).unwrap();
    let route = &json["legs"][0]["route"];
    assert_eq!(route["fixes"], 20 * 10 + 1);
    let segment = &route["segments"][0];
    for key in [
        "start_s",
        "end_s",
        "lat_deg",
        "lon_deg",
        "length_m",
        "speed_m_s",
        "rms_m_s2",
        "vdv_m_s175",
        "max_running_rms_m_s2",
    ] {
        assert!(segment[key].is_number(), "{key}: {segment}");
    }
    assert!(segment["time_at_level_s"]["normal"].is_number());
    // After the warm-up (the first 60 m), each segment has the joints' largest excursions.
    let later = &route["segments"][2]["largest_joint_excursions"];
    assert!(
        later["neck_x_mm"].is_number() && later["low_back_rz_deg"].is_number(),
        "{later}"
    );
    assert!(
        segment.get("largest_joint_excursions").is_none(),
        "{segment}"
    );
    assert!(!route["worst_segments"].as_array().unwrap().is_empty());
    let page = std::fs::read_to_string(dir.path().join("out/report.html")).unwrap();
    assert!(page.contains("Where it happened") && page.contains("start 1"));

    let plain = plain_ride(dir.path(), "plain.csv", 10.0);
    let args = report::Args {
        mission: MissionArgs {
            input: vec![plain],
            ride: RideInputArgs::default(),
            ..args.mission
        },
        ..args
    };
    let mut text = Vec::new();
    report::run_to(&args, &mut text).unwrap();
    let json: serde_json::Value = serde_json::from_slice(&text).unwrap();
    assert!(json["legs"][0]["route"].is_null());
    let page = std::fs::read_to_string(dir.path().join("out/report.html")).unwrap();
    assert!(page.contains("No positions: these rides have no position track"));
}
