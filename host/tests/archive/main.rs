//! `supine archive` on SQLite and on a real PostgreSQL (a private server, `postgres.rs`):
//! every test runs the same steps on both.
//!
//! - what a mission stores equals `supine report --json` of the same rides;
//! - the fleet view's group statistics equal an independent computation from
//!   `archive list --json`;
//! - two concurrent adds both land, and a killed add leaves no half mission;
//! - the FHIR export validates against HL7's R4 JSON schema;
//! - an archive of the previous schema is migrated with every mission kept, and one of a
//!   newer schema is refused.

mod postgres;

use std::io::{BufRead as _, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

use serde_json::Value;
use sqlx::Row as _;
use supine_host::archive::db::Archive;
use supine_host::archive::location::Location;
use supine_host::archive::meta::MissionMeta;
use supine_host::archive::road::Cell;
use supine_host::archive::schema;
use supine_host::archive::store::STALL_ENV;
use supine_host::commands::archive::{self, AddArgs, Command as Sub, MetaArgs};
use supine_host::commands::report::MissionArgs;
use supine_host::exposure::ride::Profile;
use supine_host::io::ride_input::{RideInputArgs, TrackArgs};
use supine_host::io::subject_args::SubjectArgs;

use crate::common::{paper_litter as preset, ride};

/// The two databases: a fresh SQLite file under `dir` and a fresh PostgreSQL database.
fn archives(dir: &Path) -> Vec<String> {
    vec![
        dir.join("archive.sqlite").display().to_string(),
        postgres::database(),
    ]
}

fn run(archive: &str, command: Sub) -> anyhow::Result<String> {
    let args = archive::Args {
        archive: Some(archive.to_string()),
        command,
    };
    let mut out = Vec::new();
    archive::run_to(&args, &mut out)?;
    Ok(String::from_utf8(out).unwrap())
}

/// The rides `inputs` with the preset for a patient of 1.80 m and 82 kg.
fn mission(inputs: &[PathBuf]) -> MissionArgs {
    MissionArgs {
        input: inputs.to_vec(),
        ride: RideInputArgs::default(),
        track: TrackArgs::default(),
        model: preset(),
        subject: SubjectArgs {
            height_m: Some(1.80),
            mass_kg: Some(82.0),
        },
    }
}

fn add_args(inputs: &[PathBuf], meta: MetaArgs) -> AddArgs {
    AddArgs {
        mission: mission(inputs),
        meta,
        copy_rides: false,
        json: true,
    }
}

fn add(archive: &str, inputs: &[PathBuf], meta: MetaArgs) -> anyhow::Result<i64> {
    let out = run(archive, Sub::Add(Box::new(add_args(inputs, meta))))?;
    let json: Value = serde_json::from_str(&out).unwrap();
    Ok(json["id"].as_i64().unwrap())
}

fn list(archive: &str) -> Vec<Value> {
    let out = run(
        archive,
        Sub::List(archive::ListArgs {
            filter: Default::default(),
            json: true,
        }),
    )
    .unwrap();
    serde_json::from_str::<Value>(&out)
        .unwrap()
        .as_array()
        .unwrap()
        .clone()
}

fn show(archive: &str, id: i64) -> Value {
    serde_json::from_str(&run(archive, Sub::Show(archive::ShowArgs { id, json: true })).unwrap())
        .unwrap()
}

fn report_json(inputs: &[PathBuf], out: &Path) -> Value {
    crate::common::report_json(mission(inputs), out)
}

fn open(archive: &str) -> Archive {
    Archive::open(&Location::resolve(Some(archive)).unwrap()).unwrap()
}

fn count(archive: &Archive, table: &str) -> i64 {
    archive
        .run(sqlx::query(&format!("SELECT COUNT(*) AS n FROM {table}")).fetch_one(archive.pool()))
        .unwrap()
        .try_get("n")
        .unwrap()
}

#[test]
fn stored_values_equal_report_json_on_both_databases() {
    let dir = tempfile::tempdir().unwrap();
    let legs = [
        ride(dir.path(), Profile::Ambulance, 40.0, 1),
        ride(dir.path(), Profile::RoughRoad, 30.0, 2),
    ];
    let expected = report_json(&legs, &dir.path().join("report"));
    for db in archives(dir.path()) {
        let meta = flags(MissionMeta {
            vehicle: Some("A1".into()),
            crew: Some("red".into()),
            route: Some("A9 north".into()),
            start: Some("2026-11-28T06:00:00+01:00".into()),
            tags: vec!["night".into(), "rain".into()],
            ..Default::default()
        });
        let id = add(&db, &legs, meta).unwrap();
        let shown = show(&db, id);
        assert_eq!(shown["mission"], expected["mission"], "{db}");
        assert_eq!(shown["legs"], expected["legs"], "{db}");
        assert_eq!(shown["subject"], expected["subject"], "{db}");
        assert_eq!(shown["model"]["name"], expected["model"]["name"]);
        assert_eq!(shown["model"]["identity"], expected["model"]["identity"]);
        assert_eq!(shown["start"], "2026-11-28T05:00:00Z");
        assert_eq!(shown["tags"], serde_json::json!(["night", "rain"]));
        // Each leg's data-quality account, kept in its own column too.
        let a = open(&db);
        for (i, leg) in expected["legs"].as_array().unwrap().iter().enumerate() {
            let stored: Option<String> = a
                .run(
                    sqlx::query(
                        "SELECT data_quality_json FROM legs WHERE mission_id = $1 AND leg = $2",
                    )
                    .bind(id)
                    .bind(i as i64 + 1)
                    .fetch_one(a.pool()),
                )
                .unwrap()
                .try_get("data_quality_json")
                .unwrap();
            let stored: Value = stored.map_or(Value::Null, |t| serde_json::from_str(&t).unwrap());
            assert_eq!(stored, leg["data_quality"], "{db} leg {}", i + 1);
        }
        drop(a);
        let listed = list(&db);
        assert_eq!(listed.len(), 1);
        assert_eq!(listed[0]["mission"], expected["mission"]);
        assert_eq!(listed[0]["vehicle"], "A1");
        // The per-second series: one row a second, ending at the leg's VDV (stored as f32).
        for (leg, seconds) in expected["legs"]
            .as_array()
            .unwrap()
            .iter()
            .zip(shown["seconds"].as_array().unwrap())
        {
            let rows = seconds["rows"].as_array().unwrap();
            assert_eq!(
                rows.len() as f64,
                leg["duration_s"].as_f64().unwrap().ceil()
            );
            assert_eq!(seconds["columns"][1], "vdv_m_s175");
            let last_vdv = rows.last().unwrap()[1].as_f64().unwrap();
            let vdv = leg["vector"]["vdv_m_s175"].as_f64().unwrap();
            assert!((last_vdv - vdv).abs() <= 1e-5 * vdv, "{last_vdv} {vdv}");
        }
        // The same ride again: refused, naming the mission that has it; nothing added.
        let again = add(&db, &legs[1..], MetaArgs::default())
            .unwrap_err()
            .to_string();
        assert!(
            again.contains(&format!("already archived as leg 2 of mission {id}")),
            "{again}"
        );
        assert_eq!(list(&db).len(), 1);
        // Removed, it can be added again.
        run(&db, Sub::Remove(archive::RemoveArgs { id })).unwrap();
        assert!(list(&db).is_empty());
        let a = open(&db);
        for table in ["legs", "alerts", "joints", "leg_seconds", "mission_tags"] {
            assert_eq!(count(&a, table), 0, "{table} after remove on {db}");
        }
        drop(a);
        let err = run(&db, Sub::Remove(archive::RemoveArgs { id })).unwrap_err();
        assert!(err.to_string().contains("not in the archive"), "{err}");
        add(&db, &legs[1..], MetaArgs::default()).unwrap();
    }
}

/// The fleet view's numbers, computed here from `archive list --json` alone.
mod independent {
    use serde_json::Value;

    pub fn rate(m: &Value) -> f64 {
        let vdv = m["mission"]["vector"]["vdv_m_s175"].as_f64().unwrap();
        let t = m["mission"]["duration_s"].as_f64().unwrap();
        (vdv.powi(4) * 3600.0 / t).powf(0.25)
    }

    /// Type-7 quantile of sorted values.
    pub fn quantile(s: &[f64], q: f64) -> f64 {
        let h = q * (s.len() - 1) as f64;
        let (lo, frac) = (h.floor() as usize, h.fract());
        if lo + 1 < s.len() {
            s[lo] * (1.0 - frac) + s[lo + 1] * frac
        } else {
            s[lo]
        }
    }

    fn choose(n: u64, k: u64) -> f64 {
        (0..k).fold(1.0, |acc, i| acc * (n - i) as f64 / (i + 1) as f64)
    }

    /// The largest k with P(k <= Bin(n, 1/2) <= n - k) >= 0.95, by direct summation.
    pub fn ci_rank(n: usize) -> Option<usize> {
        let n64 = n as u64;
        let mut best = None;
        for k in 1..=n / 2 {
            let p: f64 = (k..=n - k)
                .map(|i| choose(n64, i as u64) / 2f64.powi(n as i32))
                .sum();
            if p >= 0.95 {
                best = Some(k);
            }
        }
        best
    }
}

/// `add`'s metadata given as flags, without a `--meta` file.
fn flags(meta: MissionMeta) -> MetaArgs {
    MetaArgs {
        flags: meta,
        meta: None,
    }
}

fn meta(vehicle: &str, route: &str, day: usize) -> MetaArgs {
    flags(MissionMeta {
        vehicle: Some(vehicle.into()),
        crew: Some(format!("crew-{}", day % 3)),
        driver: Some(format!("driver-{}", day % 2)),
        route: Some(route.into()),
        start: Some(format!("2026-10-{:02}T08:30:00Z", day + 1)),
        ..Default::default()
    })
}

/// `archive fleet --out OUT --json` with these groupings, filter and compare: its JSON.
fn fleet(
    db: &str,
    out: &Path,
    by: Vec<String>,
    filter: archive::FilterArgs,
    compare: Vec<String>,
) -> Value {
    let text = run(
        db,
        Sub::Fleet(archive::FleetArgs {
            out: out.to_path_buf(),
            json: true,
            by,
            filter,
            compare,
        }),
    )
    .unwrap();
    serde_json::from_str(&text).unwrap()
}

#[test]
fn fleet_statistics_equal_an_independent_computation_from_list_json() {
    let dir = tempfile::tempdir().unwrap();
    // Two vehicles, two routes: vehicle B rides rougher roads.
    let plan: Vec<(PathBuf, &str, &str)> = (0..14)
        .map(|i| {
            let (profile, vehicle) = if i % 2 == 0 {
                (Profile::Ambulance, "A")
            } else {
                (Profile::RoughRoad, "B")
            };
            let route = if i % 3 == 0 { "coast" } else { "hills" };
            let path = ride(dir.path(), profile, 15.0 + i as f64, 100 + i as u64);
            (path, vehicle, route)
        })
        .collect();
    for db in archives(dir.path()) {
        for (day, (path, vehicle, route)) in plan.iter().enumerate() {
            add(&db, std::slice::from_ref(path), meta(vehicle, route, day)).unwrap();
        }
        let out = dir.path().join(format!("fleet-{}", db.len()));
        let view = fleet(&db, &out, vec![], Default::default(), vec![]);
        let missions = list(&db);
        assert_eq!(view["missions"], missions.len());
        let page = std::fs::read_to_string(out.join("fleet.html")).unwrap();
        assert!(page.contains("<h2>By vehicle</h2>") && page.contains("Compare"));
        let mut checked = 0;
        for g in view["groups"].as_array().unwrap() {
            let by = g["by"].as_str().unwrap();
            let key = g["key"].as_str().unwrap();
            let members: Vec<&Value> = missions.iter().filter(|m| m[by] == key).collect();
            assert_eq!(g["missions"], members.len(), "{by} {key}");
            let mut rates: Vec<f64> = members.iter().map(|m| independent::rate(m)).collect();
            rates.sort_by(f64::total_cmp);
            let d = &g["vdv_per_hour_m_s175"];
            for (name, q) in [
                ("p10", 0.1),
                ("p25", 0.25),
                ("median", 0.5),
                ("p75", 0.75),
                ("p90", 0.9),
            ] {
                let want = independent::quantile(&rates, q);
                let got = d[name].as_f64().unwrap();
                assert!(
                    (got - want).abs() <= 1e-12 * want.abs().max(1.0),
                    "{by} {key} {name}: {got} {want}"
                );
            }
            match independent::ci_rank(rates.len()) {
                Some(k) => {
                    let ci = d["median_ci95"].as_array().unwrap();
                    assert!((ci[0].as_f64().unwrap() - rates[k - 1]).abs() < 1e-12);
                    assert!((ci[1].as_f64().unwrap() - rates[rates.len() - k]).abs() < 1e-12);
                }
                None => assert!(d["median_ci95"].is_null()),
            }
            let sum = |level: &str| -> f64 {
                members
                    .iter()
                    .map(|m| m["mission"]["time_at_level_s"][level].as_f64().unwrap())
                    .sum()
            };
            assert!((g["warning_s"].as_f64().unwrap() - sum("warning")).abs() < 1e-9);
            assert!((g["alarm_s"].as_f64().unwrap() - sum("alarm")).abs() < 1e-9);
            let hours: f64 = members
                .iter()
                .map(|m| m["mission"]["duration_s"].as_f64().unwrap())
                .sum::<f64>()
                / 3600.0;
            assert!((g["duration_h"].as_f64().unwrap() - hours).abs() < 1e-12);
            let reaching = members
                .iter()
                .filter(|m| {
                    ["warning", "alarm"].contains(&m["mission"]["max_level"].as_str().unwrap())
                })
                .count();
            assert_eq!(g["warning_or_alarm_missions"], reaching);
            for j in g["joints"].as_array().unwrap() {
                let output = j["output"].as_str().unwrap();
                let mut v: Vec<f64> = members
                    .iter()
                    .map(|m| {
                        m["mission"]["joints"]
                            .as_array()
                            .unwrap()
                            .iter()
                            .find(|x| x["output"] == output)
                            .unwrap()["largest_excursion"]
                            .as_f64()
                            .unwrap()
                    })
                    .collect();
                v.sort_by(f64::total_cmp);
                assert_eq!(
                    j["largest_excursion"]["max"].as_f64().unwrap(),
                    *v.last().unwrap()
                );
                let median = independent::quantile(&v, 0.5);
                assert!(
                    (j["largest_excursion"]["median"].as_f64().unwrap() - median).abs()
                        <= 1e-12 * median.max(1.0)
                );
            }
            checked += 1;
        }
        // 2 vehicles, 3 crews, 2 drivers, 2 routes.
        assert_eq!(checked, 9);
        // The default compare: the two vehicles; B's rough roads give more than chance.
        let c = &view["compare"];
        assert_eq!(c["a"]["side"]["key"], "A");
        assert_eq!(c["b"]["side"]["key"], "B");
        let p = c["mann_whitney"]["p_value"].as_f64().unwrap();
        assert_eq!(c["more_than_chance"], p < 0.05);
        assert!(c["median_difference_m_s175"].as_f64().unwrap() > 0.0);
        // Road segments: passes of three missions over two places (as a ride with
        // positions leaves them), gathered per place, the worst first.
        let ids: Vec<i64> = missions.iter().map(|m| m["id"].as_i64().unwrap()).collect();
        let a = open(&db);
        let places = [(48.137_1, 11.575_2), (48.140_3, 11.580_9)];
        // (mission, place, seconds, rms)
        let passes = [
            (ids[0], 0, 4.0, 0.5),
            (ids[1], 0, 2.0, 2.0),
            (ids[1], 1, 3.0, 0.2),
            (ids[2], 1, 5.0, 0.4),
            (ids[2], 0, 6.0, 0.1),
        ];
        for (seq, &(mission, place, seconds, rms)) in passes.iter().enumerate() {
            let (lat, lon) = places[place];
            let cell = Cell::of(lat, lon);
            a.run(
                sqlx::query(
                    "INSERT INTO road_segments (cell_row, cell_column, lat_deg, lon_deg) VALUES \
                     ($1, $2, $3, $4) ON CONFLICT (cell_row, cell_column) DO NOTHING",
                )
                .bind(cell.row)
                .bind(cell.column)
                .bind(lat)
                .bind(lon)
                .execute(a.pool()),
            )
            .unwrap();
            a.run(
                sqlx::query(
                    "INSERT INTO segment_passes (mission_id, leg, seq, cell_row, cell_column, \
                     start_s, end_s, lat_deg, lon_deg, length_m, speed_m_s, rms_m_s2, \
                     vdv_m_s175, max_running_rms_m_s2) VALUES ($1, 1, $2, $3, $4, 1.0, $5, \
                     $6, $7, 50.0, 12.0, $8, 0.1, $8)",
                )
                .bind(mission)
                .bind(seq as i64)
                .bind(cell.row)
                .bind(cell.column)
                .bind(1.0 + seconds)
                .bind(lat)
                .bind(lon)
                .bind(rms)
                .execute(a.pool()),
            )
            .unwrap();
        }
        drop(a);
        let view = fleet(&db, &out, vec![], Default::default(), vec![]);
        let segments = view["road_segments"].as_array().unwrap();
        assert_eq!(segments.len(), 2, "{db}");
        // Place 0: sqrt((0.25*4 + 4*2 + 0.01*6) / 12); place 1: sqrt((0.04*3 + 0.16*5) / 8).
        let rms0 = ((0.25 * 4.0 + 4.0 * 2.0 + 0.01 * 6.0) / 12.0_f64).sqrt();
        let rms1 = ((0.04 * 3.0 + 0.16 * 5.0) / 8.0_f64).sqrt();
        assert!(rms0 > rms1);
        let worst = &segments[0];
        assert_eq!(worst["passes"], 3);
        assert_eq!(worst["missions"], 3);
        assert!((worst["rms_m_s2"].as_f64().unwrap() - rms0).abs() < 1e-12);
        assert_eq!(worst["max_rms_m_s2"], 2.0);
        assert_eq!(worst["lat_deg"], places[0].0);
        assert_eq!(segments[1]["passes"], 2);
        assert_eq!(segments[1]["missions"], 2);
        assert!((segments[1]["rms_m_s2"].as_f64().unwrap() - rms1).abs() < 1e-12);
        let page = std::fs::read_to_string(out.join("fleet.html")).unwrap();
        assert!(page.contains("2 places of about 50&nbsp;m passed"));
        // Only vehicle B's missions: the passes of its missions alone.
        let b_ids: Vec<i64> = missions
            .iter()
            .filter(|m| m["vehicle"] == "B")
            .map(|m| m["id"].as_i64().unwrap())
            .collect();
        let view_b = fleet(
            &db,
            &out,
            vec![],
            archive::FilterArgs {
                vehicle: vec!["B".into()],
                ..Default::default()
            },
            vec![],
        );
        let passes_b: i64 = passes.iter().filter(|p| b_ids.contains(&p.0)).count() as i64;
        let counted: i64 = view_b["road_segments"]
            .as_array()
            .unwrap()
            .iter()
            .map(|s| s["passes"].as_i64().unwrap())
            .sum();
        assert_eq!(counted, passes_b, "{db}");
        // The worst mission is the one with the largest rate.
        let worst = missions
            .iter()
            .max_by(|a, b| independent::rate(a).total_cmp(&independent::rate(b)))
            .unwrap();
        assert_eq!(view["worst"][0]["id"], worst["id"]);
        // A filter: one vehicle, from a date on.
        let view = fleet(
            &db,
            &out,
            vec!["route".into()],
            archive::FilterArgs {
                since: Some("2026-10-05".into()),
                vehicle: vec!["B".into()],
                ..Default::default()
            },
            vec!["route=hills".into(), "route=coast".into()],
        );
        let expect = missions
            .iter()
            .filter(|m| m["vehicle"] == "B" && m["start"].as_str().unwrap() >= "2026-10-05")
            .count();
        assert_eq!(view["missions"], expect);
        assert!(
            view["groups"]
                .as_array()
                .unwrap()
                .iter()
                .all(|g| g["by"] == "route")
        );
        assert_eq!(view["compare"]["a"]["side"]["key"], "hills");
    }
}

fn supine() -> Command {
    Command::new(env!("CARGO_BIN_EXE_supine"))
}

fn add_command(db: &str, input: &Path, stall_ms: u64) -> Command {
    let mut c = supine();
    c.args([
        "archive",
        "--archive",
        db,
        "add",
        "--preset",
        "paper-litter",
        "--input",
    ])
    .arg(input)
    .args(["--vehicle", "A1"])
    .env(STALL_ENV, stall_ms.to_string());
    c
}

#[test]
fn two_concurrent_adds_both_land_and_a_killed_add_leaves_no_half_mission() {
    let dir = tempfile::tempdir().unwrap();
    let a = ride(dir.path(), Profile::Ambulance, 20.0, 7);
    let b = ride(dir.path(), Profile::Helicopter, 20.0, 8);
    let c = ride(dir.path(), Profile::RoughRoad, 20.0, 9);
    for db in archives(dir.path()) {
        // Each holds its transaction open for 1.5 s, so the two overlap.
        let first = add_command(&db, &a, 1500)
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        let second = add_command(&db, &b, 1500)
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        for child in [first, second] {
            let out = child.wait_with_output().unwrap();
            assert!(
                out.status.success(),
                "{db}: {}",
                String::from_utf8_lossy(&out.stderr)
            );
        }
        assert_eq!(list(&db).len(), 2, "{db}");
        // An add killed inside its transaction.
        let mut child = add_command(&db, &c, 120_000)
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        let mut lines = BufReader::new(child.stderr.take().unwrap()).lines();
        let held = lines.find(|l| l.as_ref().is_ok_and(|l| l.contains("holding mission")));
        assert!(
            held.is_some(),
            "{db}: the add never reached its transaction"
        );
        child.kill().unwrap();
        child.wait().unwrap();
        let archive = open(&db);
        assert_eq!(count(&archive, "missions"), 2, "{db}");
        assert_eq!(count(&archive, "legs"), 2, "{db}");
        assert_eq!(count(&archive, "leg_seconds"), 2, "{db}");
        drop(archive);
        // Nothing of it is left in the way: the same ride adds now.
        let out = add_command(&db, &c, 0).output().unwrap();
        assert!(
            out.status.success(),
            "{db}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        assert_eq!(list(&db).len(), 3, "{db}");
    }
}

/// The errors HL7's FHIR R4 JSON schema finds in `bundle`, by the Python `jsonschema`
/// validator (jsonschema for the python3 on the PATH, installed by .ci/setup): an implementation
/// independent of this project's.
fn fhir_errors(bundle: &Value) -> Vec<String> {
    let schema = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/fhir-r4.schema.json");
    let file = tempfile::NamedTempFile::new().unwrap();
    std::fs::write(file.path(), bundle.to_string()).unwrap();
    let script = "import json, sys, jsonschema\n\
        schema = json.load(open(sys.argv[1]))\n\
        jsonschema.Draft6Validator.check_schema(schema)\n\
        for e in jsonschema.Draft6Validator(schema).iter_errors(json.load(open(sys.argv[2]))):\n\
        \x20   print(e.message[:300].replace('\\n', ' '))\n";
    let out = Command::new("python3")
        .args(["-c", script])
        .arg(&schema)
        .arg(file.path())
        .output()
        .expect("python3 with jsonschema (run .ci/setup)");
    assert!(
        out.status.success(),
        "the validator failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout)
        .unwrap()
        .lines()
        .map(str::to_string)
        .collect()
}

#[test]
fn the_fhir_bundle_validates_against_the_r4_schema() {
    let dir = tempfile::tempdir().unwrap();
    let legs = [ride(dir.path(), Profile::Ambulance, 30.0, 21)];
    for db in archives(dir.path()) {
        let id = add(
            &db,
            &legs,
            flags(MissionMeta {
                start: Some("2026-11-28T05:00:00Z".into()),
                patient: Some("MRN-0042".into()),
                encounter: Some("ENC-7".into()),
                ..Default::default()
            }),
        )
        .unwrap();
        let file = dir.path().join("bundle.json");
        run(
            &db,
            Sub::Export(archive::ExportArgs {
                id,
                fhir: file.clone(),
            }),
        )
        .unwrap();
        let bundle: Value = serde_json::from_slice(&std::fs::read(&file).unwrap()).unwrap();
        let errors = fhir_errors(&bundle);
        assert!(errors.is_empty(), "{db}: {errors:?}");
        let entries = bundle["entry"].as_array().unwrap();
        assert_eq!(entries.len(), 5);
        let mission = &show(&db, id)["mission"];
        let find = |code: &str| {
            entries
                .iter()
                .map(|e| &e["resource"])
                .find(|r| r["code"]["coding"][0]["code"] == code)
                .unwrap()
                .clone()
        };
        let vdv = find("head-vdv");
        assert_eq!(
            vdv["valueQuantity"]["value"],
            mission["vector"]["vdv_m_s175"]
        );
        assert_eq!(vdv["valueQuantity"]["unit"], "m/s^1.75");
        assert!(
            vdv["valueQuantity"].get("code").is_none()
                && vdv["valueQuantity"].get("system").is_none()
        );
        let rms = find("head-weighted-rms");
        assert_eq!(rms["valueQuantity"]["code"], "m/s2");
        assert_eq!(rms["valueQuantity"]["system"], "http://unitsofmeasure.org");
        assert_eq!(rms["subject"]["identifier"]["value"], "MRN-0042");
        assert_eq!(rms["encounter"]["identifier"]["value"], "ENC-7");
        assert_eq!(rms["effectivePeriod"]["start"], "2026-11-28T05:00:00Z");
        assert_eq!(rms["effectivePeriod"]["end"], "2026-11-28T05:00:30Z");
        let joints = find("joint-largest-excursion");
        assert_eq!(
            joints["component"].as_array().unwrap().len(),
            mission["joints"].as_array().unwrap().len()
        );
        // The validator is not vacuous: a bad status, a text value and a missing status fail.
        let mut bad = bundle.clone();
        bad["entry"][0]["resource"]["status"] = "done".into();
        assert!(!fhir_errors(&bad).is_empty());
        let mut bad = bundle.clone();
        bad["entry"][1]["resource"]["valueQuantity"]["value"] = "high".into();
        assert!(!fhir_errors(&bad).is_empty());
        let mut bad = bundle.clone();
        bad["type"] = "pile".into();
        assert!(!fhir_errors(&bad).is_empty());
        // Without an identifier there is nothing to refer to: refused.
        let other = add(
            &db,
            &[ride(dir.path(), Profile::Lab, 20.0, 22)],
            MetaArgs::default(),
        )
        .unwrap();
        let err = run(
            &db,
            Sub::Export(archive::ExportArgs {
                id: other,
                fhir: file.clone(),
            }),
        )
        .unwrap_err()
        .to_string();
        assert!(err.contains("no patient or encounter identifier"), "{err}");
        let _ = std::fs::remove_file(&file);
    }
}

#[test]
fn an_archive_of_the_previous_schema_is_migrated_and_a_newer_one_refused() {
    let dir = tempfile::tempdir().unwrap();
    let legs = [ride(dir.path(), Profile::Ambulance, 20.0, 31)];
    let report = report_json(&legs, &dir.path().join("report"));
    for db in archives(dir.path()) {
        let location = Location::resolve(Some(&db)).unwrap();
        {
            // What a supine of schema version 1 left: three missions, written with
            // version 1's columns.
            let old = Archive::open_at_version(&location, 1).unwrap();
            assert_eq!(old.run(schema::version(&old)).unwrap(), 1);
            for i in 0..3_i64 {
                let m = &report["mission"];
                let id: i64 = old
                    .run(
                        sqlx::query(
                            "INSERT INTO missions (added_at, vehicle, model_name, params_identity, \
                             height_m, mass_kg, duration_s, rms_m_s2, mtvv_m_s2, vdv_m_s175, \
                             normal_s, advisory_s, warning_s, alarm_s, max_level, mission_json) \
                             VALUES ('2026-01-01T00:00:00Z', $1, 'paper-litter', 'abc', 1.8, 82.0, \
                             $2, $3, $4, $5, 0, 0, 0, 0, 'normal', $6) RETURNING id",
                        )
                        .bind(format!("V{i}"))
                        .bind(m["duration_s"].as_f64().unwrap())
                        .bind(m["vector"]["rms_m_s2"].as_f64().unwrap())
                        .bind(m["vector"]["mtvv_m_s2"].as_f64().unwrap())
                        .bind(m["vector"]["vdv_m_s175"].as_f64().unwrap())
                        .bind(m.to_string())
                        .fetch_one(old.pool()),
                    )
                    .unwrap()
                    .try_get("id")
                    .unwrap();
                old.run(
                    sqlx::query(
                        "INSERT INTO legs (mission_id, leg, input, ride_sha256, ride_bytes, \
                         duration_s, start_s, rms_m_s2, mtvv_m_s2, vdv_m_s175, peak_m_s2, \
                         normal_s, advisory_s, warning_s, alarm_s, max_level, leg_json) VALUES \
                         ($1, 1, 'ride.csv', $2, 10, 1, 0, 0, 0, 0, 0, 0, 0, 0, 0, 'normal', $3)",
                    )
                    .bind(id)
                    .bind(format!("{i:064}"))
                    .bind(report["legs"][0].to_string())
                    .execute(old.pool()),
                )
                .unwrap();
                old.run(
                    sqlx::query(
                        "INSERT INTO leg_seconds (mission_id, leg, seconds, columns, series) \
                         VALUES ($1, 1, 0, 'head_running_rms_m_s2', $2)",
                    )
                    .bind(id)
                    .bind(Vec::<u8>::new())
                    .execute(old.pool()),
                )
                .unwrap();
                // An alert that raised, in version 1's column `raise`.
                old.run(
                    sqlx::query(
                        "INSERT INTO alerts (mission_id, leg, seq, mission_time_s, kind, event, \
                         raise, running_rms_m_s2, vdv_m_s175) VALUES ($1, 1, 0, 2.5, 'level', \
                         'normal -> warning', 1, 0.9, 0.4)",
                    )
                    .bind(id)
                    .execute(old.pool()),
                )
                .unwrap();
            }
        }
        {
            // Version 2 added the places, keyed by `cell_lat`, `cell_lon`: one pass over one.
            let old = Archive::open_at_version(&location, 2).unwrap();
            let first: i64 = old
                .run(sqlx::query("SELECT MIN(id) AS id FROM missions").fetch_one(old.pool()))
                .unwrap()
                .try_get("id")
                .unwrap();
            for statement in [
                "INSERT INTO road_segments (cell_lat, cell_lon, lat_deg, lon_deg) \
                 VALUES (7, -3, 48.1, 11.5)",
                "INSERT INTO segment_passes (mission_id, leg, seq, cell_lat, cell_lon, start_s, \
                 end_s, lat_deg, lon_deg, length_m, speed_m_s, rms_m_s2, vdv_m_s175, \
                 max_running_rms_m_s2) VALUES ($1, 1, 0, 7, -3, 0, 4, 48.1, 11.5, 50, 12.5, \
                 0.4, 0.6, 0.5)",
            ] {
                let query = sqlx::query(statement);
                let query = if statement.contains("$1") {
                    query.bind(first)
                } else {
                    query
                };
                old.run(query.execute(old.pool())).unwrap();
            }
        }
        // Opened by this supine: migrated, every mission kept with its values.
        let listed = list(&db);
        assert_eq!(listed.len(), 3, "{db}");
        for (i, m) in listed.iter().enumerate() {
            assert_eq!(m["vehicle"], format!("V{i}"));
            assert_eq!(m["mission"], report["mission"]);
            assert_eq!(
                show(&db, m["id"].as_i64().unwrap())["legs"][0],
                report["legs"][0]
            );
        }
        let archive = open(&db);
        assert_eq!(
            archive.run(schema::version(&archive)).unwrap(),
            schema::CURRENT_VERSION
        );
        // Version 3's names: the alerts raised and the pass's place, kept.
        let raised: i64 = archive
            .run(
                sqlx::query("SELECT COUNT(*) AS n FROM alerts WHERE raised = 1")
                    .fetch_one(archive.pool()),
            )
            .unwrap()
            .try_get("n")
            .unwrap();
        assert_eq!(raised, 3, "{db}");
        let pass = archive
            .run(
                sqlx::query(
                    "SELECT p.cell_row, p.cell_column, s.lat_deg FROM segment_passes p \
                     JOIN road_segments s ON s.cell_row = p.cell_row \
                     AND s.cell_column = p.cell_column",
                )
                .fetch_one(archive.pool()),
            )
            .unwrap();
        assert_eq!(pass.try_get::<i64, _>("cell_row").unwrap(), 7);
        assert_eq!(pass.try_get::<i64, _>("cell_column").unwrap(), -3);
        let places = fleet(
            &db,
            &dir.path().join("fleet-migrated"),
            vec![],
            Default::default(),
            vec![],
        );
        assert_eq!(places["road_segments"][0]["cell"]["row"], 7, "{db}");
        assert_eq!(places["road_segments"][0]["passes"], 1);
        archive
            .run(sqlx::query("UPDATE archive_schema SET version = 99").execute(archive.pool()))
            .unwrap();
        drop(archive);
        let err = Archive::open(&location).err().unwrap().to_string();
        assert!(
            err.contains(&format!(
                "schema version 99, newer than this supine's ({})",
                schema::CURRENT_VERSION
            )),
            "{err}"
        );
        // Refused, not changed.
        let raw = Archive::open_at_version(&location, 0);
        assert!(raw.is_err());
    }
}
