//! `supine report`: the mission report's numbers against independent ones: `supine exposure` on each leg's
//! file, the ISO combination by hand, and the model's transmissibility for the patient.

use std::f64::consts::PI;
use std::path::{Path, PathBuf};

use serde_json::Value;
use supine_core::alerts::{AlertEvent, Criterion, FaultFlags, Level};
use supine_core::model::{ModelParams, Preset};
use supine_core::protocol::Telemetry;

use supine_host::commands::band_args::BandArgs;
use supine_host::commands::report::MissionArgs;
use supine_host::commands::{exposure, report};
use supine_host::exposure::ride::Profile;
use supine_host::identify::transmissibility::model_h;
use supine_host::io::params_file::{ParamFile, PresetArg};
use supine_host::io::recording::read_input;
use supine_host::io::ride_input::RideInputArgs;
use supine_host::io::subject_args::SubjectArgs;
use supine_host::io::telemetry_csv::EventRow;
use supine_host::report::build;
use supine_host::report::device_check::CheckBuilder;
use supine_host::report::device_check::{DeviceLog, DeviceRun, PassResult};
use supine_host::report::device_series::{DeviceSeries, TraceSeriesBuilder};
use supine_host::report::page::render;

use crate::common::{paper_litter as preset, ride};

fn report_json(inputs: &[PathBuf], out: &Path, height_mass: Option<(f64, f64)>) -> Value {
    let mission = MissionArgs {
        input: inputs.to_vec(),
        ride: RideInputArgs::default(),
        track: Default::default(),
        model: preset(),
        subject: SubjectArgs {
            height_m: height_mass.map(|h| h.0),
            mass_kg: height_mass.map(|h| h.1),
        },
    };
    crate::common::report_json(mission, out)
}

fn exposure_json(input: &Path) -> Value {
    let args = exposure::Args {
        preset: Some(PresetArg::PaperLitter),
        params: None,
        input: input.to_path_buf(),
        ride: RideInputArgs::default(),
        subject: SubjectArgs::default(),
        channel: None,
        weighting: None,
        json: true,
    };
    let mut text = Vec::new();
    exposure::run_to(&args, &mut text).unwrap();
    serde_json::from_slice(&text).unwrap()
}

fn f(v: &Value) -> f64 {
    v.as_f64().unwrap_or_else(|| panic!("not a number: {v}"))
}

#[test]
fn a_two_leg_missions_vdv_and_times_combine_the_legs_own_values() {
    let dir = tempfile::tempdir().unwrap();
    let legs = [
        ride(dir.path(), Profile::Ambulance, 40.0, 1),
        ride(dir.path(), Profile::RoughRoad, 60.0, 2),
    ];
    let r = report_json(&legs, &dir.path().join("out"), None);
    assert!(dir.path().join("out/report.html").is_file());
    let mut fourth = 0.0;
    let mut weighted_ms = 0.0;
    let mut evaluated = 0.0;
    let mut duration = 0.0;
    let mut evaluated_by_leg = Vec::new();
    for (i, path) in legs.iter().enumerate() {
        let leg = &r["legs"][i];
        let own = exposure_json(path);
        // A leg's values are those `supine exposure` gives for the same file.
        assert_eq!(leg["input"], own["input"]);
        assert_eq!(leg["vector"], own["vector"]);
        assert_eq!(leg["axes"], own["head"]);
        assert_eq!(leg["joints"], own["joints"]);
        assert_eq!(leg["joints"].as_array().map(Vec::len), Some(10));
        assert_eq!(f(&leg["duration_s"]), f(&own["duration_s"]));
        let at: f64 = ["normal", "advisory", "warning", "alarm"]
            .iter()
            .map(|l| f(&leg["time_at_level_s"][l]))
            .sum();
        assert!((at - f(&leg["duration_s"])).abs() < 1e-9, "{at}");
        let v = f(&own["vector"]["vdv_m_s175"]);
        fourth += v * v * v * v;
        let a = f(&own["vector"]["rms_m_s2"]);
        let t = f(&own["evaluated_s"]);
        evaluated_by_leg.push(t);
        weighted_ms += a * a * t;
        evaluated += t;
        duration += f(&own["duration_s"]);
    }
    let m = &r["mission"];
    // The neck and lower back over the mission: the legs' largest values, and their mean
    // squares weighted by evaluated time (each leg's after its warm-up).
    for (o, joint) in m["joints"].as_array().unwrap().iter().enumerate() {
        let leg_joint = |i: usize| &r["legs"][i]["joints"][o];
        let (a, b) = (leg_joint(0), leg_joint(1));
        assert_eq!(joint["output"], a["output"]);
        let peak = f(&a["largest_excursion"]).max(f(&b["largest_excursion"]));
        assert_eq!(f(&joint["largest_excursion"]), peak);
        let leg = if f(&b["largest_excursion"]) > f(&a["largest_excursion"]) {
            1
        } else {
            0
        };
        let at = f(&r["legs"][leg]["start_s"]) + f(&leg_joint(leg)["largest_excursion_at_s"]);
        assert!((f(&joint["largest_excursion_at_mission_s"]) - at).abs() < 1e-9);
        assert_eq!(
            joint["largest_excursion_leg"].as_u64(),
            Some(leg as u64 + 1)
        );
        let max_rr = f(&a["max_running_rms"]).max(f(&b["max_running_rms"]));
        assert_eq!(f(&joint["max_running_rms"]), max_rr);
        let (ta, tb) = (evaluated_by_leg[0], evaluated_by_leg[1]);
        let (ra, rb) = (f(&a["rms"]), f(&b["rms"]));
        let rms = ((ra * ra * ta + rb * rb * tb) / (ta + tb)).sqrt();
        assert!(
            (f(&joint["rms"]) - rms).abs() <= 1e-12 * rms.max(1e-12),
            "{joint}"
        );
        assert!(f(&joint["largest_excursion"]) > 0.0, "{joint}");
    }
    let html = std::fs::read_to_string(dir.path().join("out/report.html")).unwrap();
    assert!(html.contains("<h2>Neck and lower back</h2>"));
    assert!(html.contains("No standard sets limits"));
    assert!((f(&m["vector"]["vdv_m_s175"]) - fourth.powf(0.25)).abs() < 1e-12);
    assert!((f(&m["vector"]["rms_m_s2"]) - (weighted_ms / evaluated).sqrt()).abs() < 1e-12);
    assert_eq!(f(&m["duration_s"]), duration);
    for level in ["normal", "advisory", "warning", "alarm"] {
        let sum: f64 = (0..2)
            .map(|i| f(&r["legs"][i]["time_at_level_s"][level]))
            .sum();
        assert!((f(&m["time_at_level_s"][level]) - sum).abs() < 1e-9);
    }
    // The rough road's shocks raise alerts, each with its criterion and value.
    let alerts = r["legs"][1]["alerts"].as_array().unwrap();
    let raise = alerts
        .iter()
        .find(|a| a["raised"] == true)
        .expect("an alert");
    let criterion = raise["criterion"].as_str().unwrap();
    // The core's names, the value under a key that carries its unit.
    let (value_key, key) = match criterion {
        "vdv" => ("value_m_s175", "vdv_m_s175"),
        "running-rms" => ("value_m_s2", "running_rms_m_s2"),
        other => panic!("{other}"),
    };
    let value = f(&raise[value_key]);
    let thresholds = &r["model"]["thresholds"];
    assert!(value >= f(&thresholds[key][0]), "{raise}");
}

#[test]
fn the_json_keys_are_the_contract() {
    let dir = tempfile::tempdir().unwrap();
    let legs = [ride(dir.path(), Profile::Helicopter, 20.0, 3)];
    let r = report_json(&legs, &dir.path().join("out"), Some((1.6, 52.0)));
    assert_eq!(f(&r["subject"]["height_m"]), 1.6);
    assert_eq!(f(&r["subject"]["mass_kg"]), 52.0);
    assert!(r["model"].is_object());
    let leg = &r["legs"][0];
    for key in ["input", "duration_s", "axes", "vector", "alerts"] {
        assert!(!leg[key].is_null(), "legs[0].{key}");
    }
    for key in [
        "rms_m_s2",
        "mtvv_m_s2",
        "vdv_m_s175",
        "peak_m_s2",
        "crest_factor",
    ] {
        assert!(leg["vector"][key].is_number(), "legs[0].vector.{key}");
    }
    let m = &r["mission"];
    for key in ["rms_m_s2", "mtvv_m_s2", "vdv_m_s175"] {
        assert!(m["vector"][key].is_number(), "mission.vector.{key}");
    }
    assert!(m["duration_s"].is_number() && m["projection"].is_object());
    for key in ["normal", "advisory", "warning", "alarm"] {
        assert!(m["time_at_level_s"][key].is_number(), "{key}");
    }
}

/// A vertical sine at `freq_hz` on the litter, 60 s at 500 Hz.
fn sine_ride(path: &Path, freq_hz: f64, amplitude_m_s2: f64) {
    let mut text = String::from("time_s,platform_x_m_s2,platform_y_m_s2,platform_z_m_s2\n");
    for k in 0..30_000 {
        let t = k as f64 / 500.0;
        text.push_str(&format!(
            "{t},0,0,{}\n",
            amplitude_m_s2 * (2.0 * PI * freq_hz * t).sin()
        ));
    }
    std::fs::write(path, text).unwrap();
}

#[test]
fn a_small_patients_head_differs_from_the_mean_subjects_as_the_transmissibility_says() {
    let dir = tempfile::tempdir().unwrap();
    // A frequency on a Welch bin (500 Hz / 2048 * 20), in the body's 4-8 Hz band.
    let freq_hz = 500.0 / 2048.0 * 20.0;
    let input = dir.path().join("sine.csv");
    sine_ride(&input, freq_hz, 0.5);
    let head_psd_at = |height_mass| {
        let r = report_json(
            std::slice::from_ref(&input),
            &dir.path().join("out"),
            height_mass,
        );
        assert!(r["legs"][0]["vector"]["rms_m_s2"].as_f64().unwrap() > 0.0);
        r
    };
    // The report's numbers for each patient, and the model's H for each.
    let mean = head_psd_at(None);
    let small = head_psd_at(Some((1.6, 52.0)));
    let mut params = ModelParams::preset(Preset::PaperLitter);
    let h_mean = model_h(&params, &[freq_hz]).unwrap()[0][(2, 2)].norm();
    params.subject.height_m = 1.6;
    params.subject.mass_kg = 52.0;
    let h_small = model_h(&params, &[freq_hz]).unwrap()[0][(2, 2)].norm();
    assert!(
        (h_small / h_mean - 1.0).abs() > 0.01,
        "the patients must differ"
    );
    // Head z's weighted rms over the evaluated time: a steady sine's, so in the ratio of
    // the two patients the weighting (the same for both) cancels and |H| remains.
    let rms = |r: &Value| f(&r["legs"][0]["axes"][2]["rms_m_s2"]);
    let ratio = rms(&small) / rms(&mean);
    assert!(
        (ratio - h_small / h_mean).abs() < 2e-3 * (h_small / h_mean),
        "report {ratio}, model {}",
        h_small / h_mean
    );
}

#[test]
fn the_page_is_self_contained_prints_on_a4_and_names_every_leg() {
    let dir = tempfile::tempdir().unwrap();
    let legs = [
        ride(dir.path(), Profile::Ambulance, 20.0, 4),
        ride(dir.path(), Profile::Helicopter, 20.0, 5),
        ride(dir.path(), Profile::Ambulance, 20.0, 6),
    ];
    let out = dir.path().join("out");
    report_json(&legs, &out, None);
    let page = std::fs::read_to_string(out.join("report.html")).unwrap();
    for outside in ["<script", "src=", "href=", "@import", "url("] {
        assert!(!page.contains(outside), "{outside}");
    }
    assert!(page.contains("@page { size: A4"));
    assert!(page.contains("break-inside: avoid"));
    for name in [
        "leg 1: ambulance-4.csv",
        "leg 2: helicopter-5.csv",
        "leg 3: ambulance-6.csv",
    ] {
        assert!(page.contains(name), "{name}");
    }
    // Four time charts, the neck's and the lower back's, and one spectrum figure per leg.
    assert_eq!(page.matches("<svg").count(), 4 + 2 + legs.len());
}

#[test]
fn a_ride_with_gravity_is_refused_by_the_report_too() {
    let dir = tempfile::tempdir().unwrap();
    let raw = dir.path().join("raw.csv");
    let mut text = String::from("time_s,platform_x_m_s2,platform_y_m_s2,platform_z_m_s2\n");
    for k in 0..5000 {
        text.push_str(&format!(
            "{},0,0,{}\n",
            k as f64 / 500.0,
            9.81 + 0.01 * (k % 7) as f64
        ));
    }
    std::fs::write(&raw, text).unwrap();
    let args = report::Args {
        mission: MissionArgs {
            input: vec![raw],
            ride: RideInputArgs::default(),
            track: Default::default(),
            model: preset(),
            subject: SubjectArgs::default(),
        },
        out: dir.path().join("out"),
        json: false,
        compare: false,
        band: BandArgs::default(),
    };
    let err = report::run_to(&args, &mut Vec::new())
        .unwrap_err()
        .to_string();
    assert!(err.contains("gravity left in a raw accelerometer"), "{err}");
    assert!(!dir.path().join("out/report.html").exists());
}

/// A device log of `n` records at `fs` Hz: the vector running rms ramps through every
/// running-rms threshold and back, one warning raised at 3 s and cleared at 9 s; the
/// firmware's version carries markup (it comes from the device, so it must be escaped).
fn device_log(n: u32, fs: f64) -> DeviceLog {
    let (telemetry, events) = device_records(n, fs);
    log_of(&telemetry, &telemetry, &events, fs)
}

/// The records and events of [`device_log`].
fn device_records(n: u32, fs: f64) -> (Vec<Telemetry>, Vec<EventRow>) {
    let telemetry: Vec<Telemetry> = (0..n)
        .map(|k| {
            let t = f64::from(k) / fs;
            let v = (1.5 * (PI * t / 12.0).sin()) as f32;
            Telemetry {
                sample_index: k,
                head_acc_m_s2: [0.1, -0.2, v],
                running_rms_m_s2: [0.0, 0.0, v],
                vector_running_rms_m_s2: v,
                vdv_m_s175: (t / 4.0) as f32,
                alert_level: if (300..900).contains(&k) {
                    Level::Warning
                } else {
                    Level::Normal
                },
                fault_flags: FaultFlags::empty(),
                valid: k >= 500,
                joints: supine_core::joint_exposure::JointValues::EMPTY,
            }
        })
        .collect();
    let events: Vec<EventRow> = [
        (Level::Normal, Level::Warning, 300),
        (Level::Warning, Level::Normal, 900),
    ]
    .iter()
    .map(|&(from, to, at_sample)| {
        EventRow::from_event(
            &AlertEvent::Level {
                from,
                to,
                criterion: Criterion::RunningRms { value_m_s2: 0.6 },
                at_sample,
            },
            fs,
        )
    })
    .collect();
    (telemetry, events)
}

/// The device log of `device` against `host` (the f64 head taken as the host's), with
/// `events` on both sides, built record by record as the report's pass builds it.
fn log_of(device: &[Telemetry], host: &[Telemetry], events: &[EventRow], fs: f64) -> DeviceLog {
    let mut check = CheckBuilder::default();
    let mut device_series = TraceSeriesBuilder::new(device.len());
    let mut host_series = TraceSeriesBuilder::new(host.len());
    for (d, h) in device.iter().zip(host) {
        check.host_record(h, Some(d));
        check.device_record(d, Some(h.head_acc_m_s2.map(f64::from)));
        device_series.push(d, fs);
        host_series.push(h, fs);
    }
    for e in events {
        check.events(Some(e), Some(e));
    }
    let n = host.len();
    let end_s = n as f64 / fs;
    DeviceLog {
        run: DeviceRun {
            account: "A lab ride <i>streamed</i>.".into(),
            device_line: "firmware 0.1.0<b>+test".into(),
            firmware_version: "0.1.0<b>+test".into(),
            files: vec![("device.csv".into(), "the device's telemetry".into())],
            ..DeviceRun::default()
        },
        sample_rate_hz: fs,
        samples: n,
        bands: Vec::new(),
        moments: Vec::new(),
        pass: PassResult {
            check: check.finish(true),
            device_events: events.to_vec(),
            device_event_count: events.len(),
            host_event_count: events.len(),
            device_records: device.len(),
            host_records: n,
            series: DeviceSeries {
                device: device_series.finish(end_s),
                host: host_series.finish(end_s),
                ..DeviceSeries::default()
            },
        },
    }
}

#[test]
fn a_device_log_adds_the_devices_check_and_charts_to_the_one_leg_report() {
    let dir = tempfile::tempdir().unwrap();
    let leg = ride(dir.path(), Profile::Lab, 12.0, 1);
    let file = ParamFile::preset(Preset::PaperLitter);
    let report = build(
        std::slice::from_ref(&leg),
        read_input,
        &file,
        "paper-litter",
        false,
    )
    .unwrap();
    let log = device_log(6000, 500.0);
    let page = render(&report, Some(&log)).unwrap();
    assert!(!page.to_lowercase().contains("<script"));
    for (at, _) in page.match_indices("href=\"") {
        assert!(!page[at + 6..].starts_with("http"), "external link");
    }
    // The device's text is escaped, not interpreted.
    assert!(page.contains("0.1.0&lt;b&gt;+test") && !page.contains("0.1.0<b>"));
    assert!(page.contains("&lt;i&gt;streamed"));
    // The device's levels and the check, as the device's telemetry and events say.
    assert!(page.contains("first reached at 0.6 s"), "300 / 500 Hz");
    assert!(page.contains("cleared at 1.8 s"));
    assert!(page.contains("the device and the host agree"));
    assert!(page.contains("largest |device &minus; host| 0 (bit for bit)"));
    assert!(page.contains("<a href=\"device.csv\">device.csv</a>"));
    // Every running-rms threshold is drawn on the device's chart (the data reach 1.5 >
    // 1.25), and the caption names the VDV's.
    for label in ["advisory 0.5", "warning 0.8", "alarm 1.25"] {
        assert!(page.contains(label), "{label} not drawn");
    }
    assert!(page.contains("advisory 8.5 / warning 17 / alarm 21"));
    // The mission's four time charts, the two joints', one spectrum figure, and the
    // device's eight.
    assert_eq!(page.matches("<svg").count(), 4 + 2 + 1 + 8);
    assert!(page.contains("recumbent"), "the standard's caveat");
    // Without the log: no device section.
    let plain = render(&report, None).unwrap();
    assert_eq!(plain.matches("<svg").count(), 4 + 2 + 1);
    assert!(!plain.contains("The device versus the host"));

    // One f32 step of difference in one record is reported, with its size.
    let (host, events) = device_records(6000, 500.0);
    let mut device = host.clone();
    let z = &mut device[700].head_acc_m_s2[2];
    *z = f32::from_bits(z.to_bits() + 1);
    let log = log_of(&device, &host, &events, 500.0);
    let page = render(&report, Some(&log)).unwrap();
    assert!(page.contains("the device and the host DIFFER"));
    assert!(!page.contains("largest |device &minus; host| 0 (bit for bit)"));
}
