//! `supine predict` of a ride (issue 26): a phone's file, read with the options every
//! command that takes a ride shares, gives per sample the head, its exposure and the
//! joints that `supine report` computes of the same file. Each check is against the
//! report's own summary of the ride: its VDV, its MTVV, the time it spent at each
//! level, its alert times and the joints' largest excursions.

use std::path::Path;
use std::process::Command;

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde_json::Value;
use supine_core::mounting::STANDARD_GRAVITY_M_S2;
use supine_host::exposure::ride::{Profile, generate};

/// A rough road as a phone upright in a holder logs it (Sensor Logger's accelerometer
/// CSV: nanoseconds since the epoch, seconds elapsed, then z, y, x): gravity on the
/// phone's y axis, tilted 20 degrees towards z, and a 200 Hz clock that jitters by up to
/// +-1 ms with a burst of rows 1 ms apart every 5 s.
fn phone_ride(path: &Path) {
    let fs = 200.0;
    let ride = generate(Profile::RoughRoad, 40.0, fs, 7).unwrap();
    let g = STANDARD_GRAVITY_M_S2;
    let tilt = 20f64.to_radians();
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    let mut text = String::from("time,seconds_elapsed,z,y,x\n");
    let mut last_ns = 0u64;
    for k in 0..ride.len() {
        let [lx, ly, lz] = [0, 1, 2].map(|a| ride.platform_m_s2[a][k]);
        // Litter vertical (+ gravity) along the phone's y tilted towards z; litter x
        // along the phone's x; litter y the rest of the right-handed frame.
        let vertical = lz + g;
        let (s, c) = tilt.sin_cos();
        let phone = [lx, c * vertical - s * ly, s * vertical + c * ly];
        let nominal_s = k as f64 / fs;
        let stamp_s = if k % 1000 < 5 && k > 5 {
            nominal_s - 0.004 + 0.001 * (k % 1000) as f64
        } else {
            nominal_s + rng.random_range(-0.001..0.001)
        };
        let ns = (1_718_030_736_872_695_300u64 + (stamp_s * 1e9).round() as u64).max(last_ns + 1);
        last_ns = ns;
        text += &format!(
            "{ns},{:.9},{},{},{}\n",
            (ns - 1_718_030_736_872_695_300u64) as f64 * 1e-9,
            phone[2],
            phone[1],
            phone[0]
        );
    }
    std::fs::write(path, text).unwrap();
}

fn supine(args: &[&str]) -> String {
    let output = Command::new(env!("CARGO_BIN_EXE_supine"))
        .args(args)
        .output()
        .expect("supine runs");
    assert!(
        output.status.success(),
        "supine {args:?}: {}",
        String::from_utf8_lossy(&output.stderr)
    );
    String::from_utf8(output.stdout).unwrap()
}

/// The telemetry CSV as columns by name.
struct Table {
    header: Vec<String>,
    rows: Vec<Vec<String>>,
}

impl Table {
    fn read(path: &Path) -> Self {
        let text = std::fs::read_to_string(path).unwrap();
        let mut lines = text.lines();
        let header = lines.next().unwrap().split(',').map(String::from).collect();
        let rows = lines
            .map(|l| l.split(',').map(String::from).collect())
            .collect();
        Self { header, rows }
    }

    fn column(&self, name: &str) -> usize {
        self.header
            .iter()
            .position(|h| h == name)
            .unwrap_or_else(|| panic!("no column {name} in {:?}", self.header))
    }

    fn numbers(&self, name: &str) -> Vec<f64> {
        let c = self.column(name);
        self.rows.iter().map(|r| r[c].parse().unwrap()).collect()
    }
}

fn relative(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs().max(1e-12)
}

#[test]
fn predict_of_a_phone_ride_gives_per_sample_what_the_report_computes_of_it() {
    let dir = tempfile::tempdir().unwrap();
    let phone = dir.path().join("phone.csv");
    phone_ride(&phone);
    let phone = phone.to_str().unwrap();
    let predicted = dir.path().join("predicted.csv");
    let report_dir = dir.path().join("report");
    let ride_options = ["--input", phone, "--remove-gravity", "--fs", "500"];
    let said: Value = serde_json::from_str(&supine(
        &[
            &["predict", "--json", "--out", predicted.to_str().unwrap()][..],
            &ride_options,
        ]
        .concat(),
    ))
    .unwrap();
    let report: Value = serde_json::from_str(&supine(
        &[
            &["report", "--json", "--out", report_dir.to_str().unwrap()][..],
            &ride_options,
        ]
        .concat(),
    ))
    .unwrap();
    let leg = &report["legs"][0];
    let table = Table::read(&predicted);

    // Every evaluated sample, at the evaluation's rate, after the reader's conditioning.
    let fs = said["sample_rate_hz"].as_f64().unwrap();
    assert_eq!(fs, 500.0);
    assert_eq!(said["data_quality"]["format"], "Sensor Logger");
    assert_eq!(leg["data_quality"], said["data_quality"]);
    let duration_s = leg["duration_s"].as_f64().unwrap();
    assert_eq!(table.rows.len() as f64, (duration_s * fs).round(), "{said}");

    // The head: the last sample's VDV is the leg's; the largest running rms after the
    // warm-up is its MTVV (the same f32 values, printed in shortest form by both).
    let vdv = table.numbers("vdv_m_s175");
    let running = table.numbers("vector_running_rms_m_s2");
    let valid = table.numbers("valid");
    assert_eq!(
        *vdv.last().unwrap(),
        leg["vector"]["vdv_m_s175"].as_f64().unwrap()
    );
    let mtvv = running
        .iter()
        .zip(&valid)
        .filter(|(_, v)| **v == 1.0)
        .map(|(r, _)| *r)
        .fold(0.0, f64::max);
    assert_eq!(mtvv, leg["vector"]["mtvv_m_s2"].as_f64().unwrap());

    // The level, sample by sample, adds up to the report's time at each level.
    let level = table.column("alert_level");
    for (name, seconds) in leg["time_at_level_s"].as_object().unwrap() {
        let at = table.rows.iter().filter(|r| r[level] == *name).count() as f64 / fs;
        assert!(
            (at - seconds.as_f64().unwrap()).abs() <= 1.0 / fs,
            "{name}: {at} s predicted, {seconds} s in the report"
        );
    }
    // And the events CSV holds the report's level changes, at the same times.
    let events = Table::read(&dir.path().join("predicted.events.csv"));
    let event_times = events.numbers("time_s");
    let report_times: Vec<f64> = leg["alerts"]
        .as_array()
        .unwrap()
        .iter()
        .map(|a| a["leg_time_s"].as_f64().unwrap())
        .collect();
    assert!(
        !report_times.is_empty(),
        "the rough stretch raises an alert"
    );
    assert_eq!(event_times.len(), report_times.len());
    for (p, r) in event_times.iter().zip(&report_times) {
        assert!(
            (p - r).abs() < 1e-9,
            "{event_times:?} against {report_times:?}"
        );
    }

    // The joints: the device's f32 outputs per sample against the report's f64 statistics
    // after the warm-up (its largest excursion, in mm or degrees), within f32's precision
    // of the two realizations.
    let first_valid = valid.iter().position(|v| *v == 1.0).unwrap();
    for joint in leg["joints"].as_array().unwrap() {
        let output = joint["output"].as_str().unwrap();
        let (suffix, scale) = match joint["unit"].as_str().unwrap() {
            "mm" => ("m", 1e3),
            "deg" => ("rad", 180.0 / std::f64::consts::PI),
            other => panic!("unit {other}"),
        };
        let values = table.numbers(&format!("{output}_{suffix}"));
        let largest = values[first_valid..]
            .iter()
            .map(|v| v.abs() * scale)
            .fold(0.0, f64::max);
        let reported = joint["largest_excursion"].as_f64().unwrap();
        assert!(
            relative(largest, reported) < 1e-3,
            "{output}: largest {largest} predicted, {reported} reported"
        );
        // The report's time of it is when the prediction reaches it too (the sample
        // index counts from the leg's start).
        let at = (joint["largest_excursion_at_s"].as_f64().unwrap() * fs).round() as usize;
        assert!(
            relative(values[at].abs() * scale, reported) < 1e-3,
            "{output}: {} predicted at the report's time of its largest, {reported} reported",
            values[at].abs() * scale
        );
    }
}

#[test]
fn predict_of_a_ride_refuses_a_band_and_names_the_ride() {
    let dir = tempfile::tempdir().unwrap();
    let phone = dir.path().join("phone.csv");
    phone_ride(&phone);
    let output = Command::new(env!("CARGO_BIN_EXE_supine"))
        .args(["predict", "--band", "10", "--remove-gravity", "--input"])
        .arg(&phone)
        .arg("--out")
        .arg(dir.path().join("p.csv"))
        .output()
        .unwrap();
    assert!(!output.status.success());
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(
        stderr.contains("phone.csv is a ride") && stderr.lines().count() == 1,
        "{stderr}"
    );
    assert!(!dir.path().join("p.csv").exists());
}
