//! Every name a user's script reads follows the output vocabulary (`supine_host::schema`):
//! each command's `--json` object and the header of every CSV file the commands write,
//! run as a user runs them. Names are lower-case `snake_case`; a number carries its unit
//! as the name's suffix, or is a count or ratio the schema names unitless, or sits in an
//! object whose key carries the unit (`"rms_m_s2": {"x": ..}`) or that states it in a
//! `unit` field (a joint output's `rms` in `mm` or `deg`). As `cli_conventions.rs` does
//! for flags. (The device's outputs, `replay`, `monitor` and `demo`, need QEMU: their
//! JSON and CSV go through the same records, checked in `tests/tests`.)

use std::path::{Path, PathBuf};
use std::process::Command;

use serde_json::Value;
use supine_core::alerts::{AlertEvent, Criterion, FaultFlags, JointCriterion, Level, SensorFault};
use supine_core::joint_exposure::JointValues;
use supine_core::pipeline::Telemetry;
use supine_host::io::telemetry_csv::{write_events, write_telemetry};
use supine_host::monitor::json::{event_json, telemetry_json};
use supine_host::schema::names;

fn supine(args: &[&str]) -> String {
    let out = Command::new(env!("CARGO_BIN_EXE_supine"))
        .args(args)
        .output()
        .expect("supine runs");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{args:?}: {stderr}");
    String::from_utf8(out.stdout).expect("utf-8")
}

fn json(args: &[&str]) -> Value {
    serde_json::from_str(&supine(args)).unwrap_or_else(|e| panic!("{args:?}: {e}"))
}

fn s(p: &Path) -> &str {
    p.to_str().expect("utf-8 path")
}

/// The names in `value` that break the rules, each with where it is.
fn json_problems(value: &Value, path: &str, _unit_given: bool, out: &mut Vec<String>) {
    out.extend(names::json_problems(value, path));
}

/// The header names of `csv` that break the rules.
fn csv_problems(csv: &Path, out: &mut Vec<String>) {
    let text = std::fs::read_to_string(csv).expect("a CSV written");
    let name = csv.file_name().unwrap().to_string_lossy();
    out.extend(names::csv_problems(&text, &name));
}

fn csv_files(dir: &Path) -> Vec<PathBuf> {
    let mut files = Vec::new();
    let mut dirs = vec![dir.to_path_buf()];
    while let Some(d) = dirs.pop() {
        for entry in std::fs::read_dir(&d).unwrap() {
            let p = entry.unwrap().path();
            if p.is_dir() {
                dirs.push(p);
            } else if p.extension().is_some_and(|e| e == "csv") {
                files.push(p);
            }
        }
    }
    files.sort();
    files
}

#[test]
fn every_commands_json_and_every_csv_header_follow_the_naming_rules() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let ride = d.join("ride.csv");
    let data = d.join("data");
    let rigid = d.join("rigid.toml");
    let runs: Vec<(&str, Value)> = vec![
        (
            "ride",
            json(&[
                "ride",
                "--profile",
                "rough-road",
                "--duration-s",
                "20",
                "--out",
                s(&ride),
                "--json",
            ]),
        ),
        (
            "exposure",
            json(&[
                "exposure",
                "--preset",
                "paper-litter",
                "--input",
                s(&ride),
                "--json",
            ]),
        ),
        (
            "report",
            json(&[
                "report",
                "--preset",
                "paper-litter",
                "--input",
                s(&ride),
                "--out",
                s(&d.join("report")),
                "--json",
            ]),
        ),
        (
            "modes",
            json(&["modes", "--preset", "paper-litter", "--json"]),
        ),
        (
            "model",
            json(&[
                "model",
                "--preset",
                "paper-litter",
                "--out",
                s(&d.join("model.csv")),
                "--json",
            ]),
        ),
        (
            "weighting",
            json(&[
                "weighting",
                "--weighting",
                "wk",
                "--out",
                s(&d.join("wk.csv")),
                "--json",
            ]),
        ),
        (
            "calibrate",
            json(&["calibrate", "--at-rest-m-s2", "0.1,0.2,9.8", "--json"]),
        ),
        (
            "synth",
            json(&[
                "synth",
                "--out",
                s(&data),
                "--subjects",
                "3",
                "--duration-s",
                "30",
                "--json",
            ]),
        ),
        (
            "transmissibility",
            json(&[
                "transmissibility",
                "--dataset",
                s(&data),
                "--case",
                "rigid",
                "--out",
                s(&d.join("h.csv")),
                "--json",
            ]),
        ),
        (
            "fit",
            json(&[
                "fit",
                "--dataset",
                s(&data),
                "--case",
                "rigid",
                "--starts",
                "1",
                "--out",
                s(&rigid),
                "--json",
            ]),
        ),
    ];
    let recording = csv_files(&data)
        .into_iter()
        .find(|p| p.to_string_lossy().contains("rigid"))
        .expect("a rigid recording");
    let predicted = (
        "predict",
        json(&[
            "predict",
            "--params",
            s(&rigid),
            "--input",
            s(&recording),
            "--out",
            s(&d.join("pred.csv")),
            "--json",
        ]),
    );
    let mut problems = Vec::new();
    for (command, value) in runs.iter().chain([&predicted]) {
        json_problems(value, command, false, &mut problems);
    }
    let csvs = csv_files(d);
    assert!(csvs.len() >= 8, "{csvs:?}");
    for csv in &csvs {
        csv_problems(csv, &mut problems);
    }
    problems.sort();
    problems.dedup();
    assert!(
        problems.is_empty(),
        "{} names break the rules:\n{}",
        problems.len(),
        problems.join("\n")
    );
}

/// The device's records as the host writes them (`replay`, `monitor --log`, `--jsonl`,
/// `demo`: they need QEMU to run, so their records are built here): the telemetry and
/// events CSV headers and the monitor's JSON lines.
#[test]
fn the_device_records_follow_the_naming_rules() {
    let mut problems = Vec::new();
    let all_joints: u16 = (1 << supine_core::model::JOINT_OUTPUT_COUNT) - 1;
    let dir = tempfile::tempdir().unwrap();
    let t = Telemetry {
        sample_index: 1234,
        head_acc_m_s2: [0.1, -0.2, 0.3],
        running_rms_m_s2: [0.1, 0.2, 0.3],
        vector_running_rms_m_s2: 0.4,
        vdv_m_s175: 2.25,
        alert_level: Level::Warning,
        fault_flags: FaultFlags::empty(),
        valid: true,
        joints: JointValues::from_slice(&[1e-3; 10]).unwrap(),
    };
    let telemetry = dir.path().join("device.csv");
    write_telemetry(&telemetry, &[t], 500.0, all_joints).unwrap();
    csv_problems(&telemetry, &mut problems);
    json_problems(
        &telemetry_json(&t, 500.0, all_joints),
        "jsonl telemetry",
        false,
        &mut problems,
    );
    let neck_ry = supine_core::model::JointOutput::ALL[3];
    for e in [
        AlertEvent::Level {
            at_sample: 7,
            from: Level::Normal,
            to: Level::Warning,
            criterion: Criterion::Vdv { value_m_s175: 9.0 },
        },
        AlertEvent::Fault {
            at_sample: 7,
            fault: SensorFault::Stuck,
            active: true,
        },
        AlertEvent::Joint {
            at_sample: 7,
            output: neck_ry.index() as u8,
            criterion: JointCriterion::Excursion {
                value_m_or_rad: 0.1,
            },
            raised: true,
        },
    ] {
        json_problems(&event_json(&e, 500.0), "jsonl event", false, &mut problems);
        let events = dir.path().join("device.events.csv");
        write_events(&events, &[e], 500.0).unwrap();
        csv_problems(&events, &mut problems);
    }
    assert!(problems.is_empty(), "{}", problems.join("\n"));
}
