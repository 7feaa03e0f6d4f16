//! `--json` as a script reads it: one object on standard output whose numbers agree with
//! the files the command wrote and with the text form; and a parameter file written by
//! hand (a partial `[device]` table, weightings in either case) as `exposure` uses it.

use std::path::Path;
use std::process::Command;

use serde_json::Value;

fn supine(args: &[&str]) -> (bool, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_supine"))
        .args(args)
        .output()
        .expect("supine runs");
    (
        out.status.success(),
        String::from_utf8(out.stdout).expect("utf-8"),
        String::from_utf8(out.stderr).expect("utf-8"),
    )
}

fn json(args: &[&str]) -> Value {
    let (ok, stdout, stderr) = supine(args);
    assert!(ok, "{args:?}: {stderr}");
    assert_eq!(stdout.lines().count(), 1, "one line: {stdout}");
    serde_json::from_str(&stdout).expect("one JSON object")
}

fn s(p: &Path) -> &str {
    p.to_str().expect("utf-8 path")
}

/// The rms of a column of a CSV file, computed here from the file itself.
fn column_rms(path: &Path, column: &str) -> f64 {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let k = header.iter().position(|h| *h == column).expect(column);
    let values: Vec<f64> = lines
        .map(|l| l.split(',').nth(k).unwrap().parse().unwrap())
        .collect();
    (values.iter().map(|v| v * v).sum::<f64>() / values.len() as f64).sqrt()
}

#[test]
fn ride_json_describes_the_file_it_wrote() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("ride.csv");
    let j = json(&[
        "ride",
        "--profile",
        "road-trip",
        "--duration-s",
        "20",
        "--out",
        s(&out),
        "--json",
    ]);
    assert_eq!(j["profile"], "road-trip");
    assert_eq!(j["seed"], 1);
    assert_eq!(j["samples"], 10_000);
    assert_eq!(j["segments"].as_array().unwrap().len(), 3);
    // The rms in the JSON is the file's (written to 1e-6 m/s^2).
    let rms_z = j["rms_m_s2"]["z"].as_f64().unwrap();
    assert!(
        (rms_z - column_rms(&out, "platform_z_m_s2")).abs() < 1e-5,
        "{rms_z}"
    );
}

#[test]
fn modes_json_lists_the_same_modes_as_the_table() {
    let j = json(&["modes", "--preset", "paper-litter", "--json"]);
    let (ok, table, _) = supine(&["modes", "--preset", "paper-litter"]);
    assert!(ok);
    let modes = j["modes"].as_array().unwrap();
    // The table: a header, a row per mode, the realization line.
    assert_eq!(modes.len(), table.lines().count() - 2);
    for (m, row) in modes.iter().zip(table.lines().skip(1)) {
        let f: f64 = row.split_whitespace().nth(1).unwrap().parse().unwrap();
        assert!(
            (m["frequency_hz"].as_f64().unwrap() - f).abs() < 1e-4,
            "{row}"
        );
    }
    assert_eq!(j["device_realization"]["sample_rate_hz"], 500.0);
}

#[test]
fn a_hand_written_partial_device_table_sets_only_what_it_names() {
    let dir = tempfile::tempdir().unwrap();
    let ride = dir.path().join("ride.csv");
    let (ok, _, stderr) = supine(&[
        "ride",
        "--profile",
        "road-trip",
        "--duration-s",
        "20",
        "--out",
        s(&ride),
    ]);
    assert!(ok, "{stderr}");
    let (ok, printed, _) = supine(&["params", "--preset", "paper-litter"]);
    assert!(ok);
    assert!(printed.contains("# [device.alerts]"), "{printed}");
    // Thresholds far below the ride's running rms, and a weighting in the CLI's spelling.
    let file = dir.path().join("low.toml");
    std::fs::write(
        &file,
        format!(
            "{printed}\n[device.alerts]\nrunning_rms_m_s2 = [0.01, 0.02, 0.03]\n\
             [device.exposure.axes.z]\nkind = \"WJ\"\n"
        ),
    )
    .unwrap();
    let preset = json(&[
        "exposure",
        "--preset",
        "paper-litter",
        "--input",
        s(&ride),
        "--json",
    ]);
    let low = json(&[
        "exposure",
        "--params",
        s(&file),
        "--input",
        s(&ride),
        "--json",
    ]);
    assert_ne!(preset["max_level"], "alarm", "{preset}");
    assert_eq!(low["max_level"], "alarm", "{low}");
    // The same weighting (wj is the default on z): the same head exposure.
    assert_eq!(low["vector"], preset["vector"]);
}

#[test]
fn demo_refuses_a_folder_with_a_users_file() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("ride.csv"), "my own ride").unwrap();
    let (ok, _, stderr) = supine(&["demo", "--out", s(dir.path())]);
    assert!(!ok);
    assert_eq!(stderr.lines().count(), 1, "{stderr}");
    assert!(
        stderr.contains("holds ride.csv, which supine did not write"),
        "{stderr}"
    );
    assert!(stderr.contains("--force"), "{stderr}");
    assert_eq!(
        std::fs::read_to_string(dir.path().join("ride.csv")).unwrap(),
        "my own ride"
    );
}

/// `model --json` counts what it wrote: frequencies times components is the CSV's rows,
/// 27 sensor components (9 x 3) or 30 joint ones (10 x 3).
#[test]
fn model_json_counts_the_components_of_the_file_it_wrote() {
    let dir = tempfile::tempdir().unwrap();
    for (quantity, components) in [("sensors", 27), ("joints", 30)] {
        let out = dir.path().join(format!("{quantity}.csv"));
        let j = json(&[
            "model",
            "--preset",
            "paper-litter",
            "--quantity",
            quantity,
            "--out",
            s(&out),
            "--json",
        ]);
        assert_eq!(j["components"], components, "{quantity}: {j}");
        let rows = std::fs::read_to_string(&out).unwrap().lines().count() - 1;
        let frequencies = j["frequencies"].as_u64().unwrap() as usize;
        assert_eq!(rows, frequencies * components, "{quantity}");
    }
}
