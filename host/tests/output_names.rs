//! Every name a user's script reads follows the output vocabulary (`supine_host::schema`):
//! each command's `--json` object, the JSON and the header of every CSV file the commands
//! write, run as a user runs them, and the archive's JSON and its database columns. Names are lower-case `snake_case`; a number carries its unit
//! as the name's suffix, or is a count or ratio the schema names unitless, or sits in an
//! object whose key carries the unit (`"rms_m_s2": {"x": ..}`) or that states it in a
//! `unit` field (a joint output's `rms` in `mm` or `deg`). As `cli_conventions.rs` does
//! for flags. (The device's outputs, `replay`, `monitor` and `demo`, need QEMU: their
//! records are built here, and `demo --json` with its files is walked in `tests/tests/demo.rs`.)

use std::path::{Path, PathBuf};
use std::process::Command;

use serde_json::Value;
use sqlx::Row as _;
use supine_core::alerts::{AlertEvent, Criterion, FaultFlags, JointCriterion, Level, SensorFault};
use supine_core::joint_exposure::JointValues;
use supine_core::pipeline::Telemetry;
use supine_host::archive::db::Archive;
use supine_host::archive::location::Location;
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
    files_named(dir, "csv")
}

/// The files under `dir` whose extension is `extension`, sorted.
fn files_named(dir: &Path, extension: &str) -> Vec<PathBuf> {
    let mut files = Vec::new();
    let mut dirs = vec![dir.to_path_buf()];
    while let Some(d) = dirs.pop() {
        for entry in std::fs::read_dir(&d).unwrap() {
            let p = entry.unwrap().path();
            if p.is_dir() {
                dirs.push(p);
            } else if p.extension().is_some_and(|e| e == extension) {
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
            "model --quantity joints",
            json(&[
                "model",
                "--preset",
                "paper-litter",
                "--quantity",
                "joints",
                "--out",
                s(&d.join("joints.csv")),
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
    let validated = (
        "validate",
        json(&[
            "validate",
            "--params",
            s(&rigid),
            "--input",
            s(&recording),
            "--report",
            s(&d.join("validation")),
            "--json",
        ]),
    );
    // A tumble test's readings: each orientation 1 g along its axis, a little offset.
    let tumble = d.join("tumble.in");
    let rows: String = ["+x", "-x", "+y", "-y", "+z", "-z"]
        .iter()
        .enumerate()
        .map(|(k, o)| {
            let mut g = [0.02, -0.01, 0.03];
            g[k / 2] += if k % 2 == 0 { 9.81 } else { -9.81 };
            format!("{o},{},{},{}\n", g[0], g[1], g[2])
        })
        .collect();
    std::fs::write(&tumble, format!("orientation,x_m_s2,y_m_s2,z_m_s2\n{rows}")).unwrap();
    let tumbled = (
        "calibrate --tumble",
        json(&["calibrate", "--tumble", s(&tumble), "--json"]),
    );
    let flashed = (
        "flash --qemu-image",
        json(&[
            "flash",
            "--preset",
            "paper-litter",
            "--qemu-image",
            s(&d.join("params.bin")),
            "--json",
        ]),
    );
    let mut problems = Vec::new();
    for (command, value) in runs
        .iter()
        .chain([&predicted, &validated, &tumbled, &flashed])
    {
        json_problems(value, command, false, &mut problems);
    }
    // The JSON files the commands write (validate's validation.json, ...).
    for file in files_named(d, "json") {
        let text = std::fs::read_to_string(&file).unwrap();
        let value: Value = serde_json::from_str(&text).unwrap_or_else(|e| panic!("{file:?}: {e}"));
        let name = file.file_name().unwrap().to_string_lossy().to_string();
        json_problems(&value, &name, false, &mut problems);
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

/// `supine archive`'s JSON, on a temporary SQLite archive of two missions (one ride with
/// a track, so that the road segments are there): `add --json`, `list --json`,
/// `show --json` and `fleet --json`. (`export --fhir` writes FHIR R4's own names,
/// `resourceType`, `valueQuantity`, ...: the standard's, which a receiver's parser
/// expects, so it is left out; `the_fhir_bundle_validates_against_the_r4_schema` holds
/// it to the standard instead.)
#[test]
fn every_archive_subcommands_json_follows_the_naming_rules() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let db = d.join("archive.sqlite");
    let db = s(&db);
    // A straight road north at 15 m/s, a fix a second.
    let fixes: String = (0..=20)
        .map(|k| {
            let lat = 48.1 + 15.0 * f64::from(k) / 111_195.0;
            format!(
                "<trkpt lat=\"{lat:.7}\" lon=\"11.5\"><time>2026-03-01T10:00:{k:02}Z</time></trkpt>"
            )
        })
        .collect();
    let track = d.join("track.gpx");
    std::fs::write(
        &track,
        format!(
            "<gpx version=\"1.1\" creator=\"test\" xmlns=\"http://www.topografix.com/GPX/1/1\">\
             <trk><trkseg>{fixes}</trkseg></trk></gpx>\n"
        ),
    )
    .unwrap();
    // `supine archive --archive DB ARGS...`'s JSON.
    let archive = |args: &[&str]| json(&[&["archive", "--archive", db][..], args].concat());
    let mut runs = Vec::new();
    for (k, (profile, vehicle)) in [("rough-road", "A1"), ("ambulance", "A2")]
        .iter()
        .enumerate()
    {
        let ride = d.join(format!("{profile}.csv"));
        supine(&[
            "ride",
            "--profile",
            profile,
            "--duration-s",
            "20",
            "--out",
            s(&ride),
        ]);
        let start = format!("2026-03-0{}T10:00:00Z", k + 1);
        let mut add = vec![
            "add",
            "--preset",
            "paper-litter",
            "--input",
            s(&ride),
            "--vehicle",
            vehicle,
            "--start",
            start.as_str(),
            "--patient",
            "P1",
            "--json",
        ];
        if k == 0 {
            add.extend(["--track", s(&track)]);
        }
        runs.push(("archive add", archive(&add)));
    }
    let fleet = d.join("fleet");
    runs.extend([
        ("archive list", archive(&["list", "--json"])),
        ("archive show", archive(&["show", "1", "--json"])),
        (
            "archive fleet",
            archive(&["fleet", "--out", s(&fleet), "--json"]),
        ),
    ]);
    let view = &runs.last().unwrap().1;
    assert!(
        !view["road_segments"].as_array().unwrap().is_empty() && view["compare"].is_object(),
        "the view has places and a compare: {view}"
    );
    let mut problems = Vec::new();
    for (command, value) in &runs {
        json_problems(value, command, false, &mut problems);
    }
    problems.extend(column_problems(db));
    assert!(problems.is_empty(), "{}", problems.join("\n"));
}

/// The archive's numeric columns that break the rules: `docs/archive.md` gives the tables
/// for queries, which name the columns as a script names JSON keys. A number beside a
/// `unit` column (a joint's `rms`), or a `NAME_unit` one (an alert's `value`), is in that
/// unit; the keys that tie rows together are indices.
fn column_problems(db: &str) -> Vec<String> {
    const KEYS: [&str; 4] = ["mission_id", "leg", "seq", "version"];
    let archive = Archive::open(&Location::resolve(Some(db)).unwrap()).unwrap();
    let rows = archive
        .run(
            sqlx::query(
                "SELECT m.name AS table_name, p.name AS column_name, p.type AS column_type \
                 FROM sqlite_master m, pragma_table_info(m.name) p \
                 WHERE m.type = 'table' AND m.name NOT LIKE 'sqlite_%' ORDER BY m.name, p.cid",
            )
            .fetch_all(archive.pool()),
        )
        .unwrap();
    let column = |r: &sqlx::any::AnyRow, k: &str| r.try_get::<String, _>(k).unwrap();
    let columns: Vec<(String, String, String)> = rows
        .iter()
        .map(|r| {
            (
                column(r, "table_name"),
                column(r, "column_name"),
                column(r, "column_type"),
            )
        })
        .collect();
    assert!(columns.len() > 50, "the archive's columns: {columns:?}");
    let has = |table: &str, name: &str| columns.iter().any(|(t, c, _)| t == table && c == name);
    columns
        .iter()
        .filter(|(table, name, kind)| {
            let numeric = ["BIGINT", "INTEGER", "DOUBLE PRECISION"].contains(&kind.as_str());
            // The series' count of rows, one a second.
            let series_rows = table == "leg_seconds" && name == "seconds";
            let named = supine_host::schema::names_a_number(name)
                || KEYS.contains(&name.as_str())
                || has(table, "unit")
                || has(table, &format!("{name}_unit"))
                || series_rows;
            numeric && !named
        })
        .map(|(table, name, _)| format!("archive column {table}.{name}: a number without a unit"))
        .collect()
}
