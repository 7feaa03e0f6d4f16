//! The archive at scale (BENCHMARKS.md, section Archive): generates missions with varied
//! vehicles, crews, drivers and routes over a year, adds them, and times the adds, the
//! fleet page and a per-vehicle query; prints the database's size per mission-hour.
//!
//! The missions' reports come from a pool of [`POOL`] distinct `supine ride` profile rides
//! (30 to 90 s at 200 Hz), each evaluated once as `supine archive add` evaluates it (its
//! time printed apart): this measures the database, and ten thousand evaluations would
//! take the shared machine an hour. A ride is archived once, so each mission's ride hash
//! is the SHA-256 of its pool ride's bytes followed by the mission's number.
//!
//! Run: `cargo bench -p supine-host --profile dev --bench archive_scale -- MISSIONS ARCHIVE [OUT]`
//! (ARCHIVE a SQLite path or a postgres:// URL of an empty database; OUT the folder for
//! `fleet.html`, default `target/archive-bench`).

use std::path::PathBuf;
use std::time::{Duration, Instant};

use rand::{Rng as _, SeedableRng as _};
use rand_chacha::ChaCha8Rng;
use sha2::{Digest as _, Sha256};
use sqlx::Row as _;
use supine_host::archive::db::{Archive, Backend};
use supine_host::archive::fleet::{self, DIMENSIONS};
use supine_host::archive::fleet_html;
use supine_host::archive::location::Location;
use supine_host::archive::meta::MissionMeta;
use supine_host::archive::record::{MissionRecord, RideFile};
use supine_host::archive::store::{self, Filter};
use supine_host::commands::report::{MissionArgs, mission_report};
use supine_host::exposure::ride::{Profile, generate, write_ride};
use supine_host::io::params_file::{ModelSource, PresetArg};
use supine_host::io::ride_input::{RideInputArgs, TrackArgs};
use supine_host::io::subject_args::SubjectArgs;

/// Distinct rides evaluated, per route profile kind.
const POOL: usize = 40;

/// The routes: a name and the profile its roads give.
const ROUTES: [(&str, Profile); 6] = [
    ("city ring", Profile::Ambulance),
    ("coast road", Profile::Ambulance),
    ("motorway", Profile::Ambulance),
    ("forest track", Profile::RoughRoad),
    ("hill villages", Profile::RoughRoad),
    ("air bridge", Profile::Helicopter),
];

fn main() {
    let args: Vec<String> = std::env::args()
        .skip(1)
        .filter(|a| a != "--bench")
        .collect();
    let missions: usize = args.first().and_then(|a| a.parse().ok()).unwrap_or(10_000);
    let location = Location::resolve(args.get(1).map(String::as_str)).unwrap();
    let out = PathBuf::from(args.get(2).map_or("target/archive-bench", String::as_str));
    std::fs::create_dir_all(&out).unwrap();
    let archive = Archive::open(&location).unwrap();
    let rides_dir = tempfile::tempdir().unwrap();
    let model = ModelSource {
        preset: Some(PresetArg::PaperLitter),
        params: None,
    };
    let mut rng = ChaCha8Rng::seed_from_u64(2631);
    let (mut evaluate, mut add) = (Duration::ZERO, Duration::ZERO);
    // The pool: POOL rides of each profile, evaluated once.
    let profiles = [Profile::Ambulance, Profile::RoughRoad, Profile::Helicopter];
    let mut pool = Vec::new();
    for (k, &profile) in profiles.iter().enumerate() {
        for j in 0..POOL {
            let duration_s = 30.0 + 60.0 * rng.random::<f64>();
            let path = rides_dir.path().join(format!("ride-{k}-{j}.csv"));
            let seed = 10_000 + (k * POOL + j) as u64;
            write_ride(&path, &generate(profile, duration_s, 200.0, seed).unwrap()).unwrap();
            let t = Instant::now();
            let args = MissionArgs {
                input: vec![path.clone()],
                ride: RideInputArgs::default(),
                track: TrackArgs::default(),
                model: model.clone(),
                subject: SubjectArgs::default(),
            };
            let (_, _, report) = mission_report(&args, false).unwrap();
            evaluate += t.elapsed();
            let bytes = std::fs::read(&path).unwrap();
            pool.push((profile, report, path, bytes));
        }
    }
    let evaluated = pool.len();
    let mut ride_s = 0.0;
    let year_start = 1_767_225_600_i64; // 2026-01-01T00:00:00Z
    for i in 0..missions {
        let vehicle = rng.random_range(0..12_usize);
        // Each vehicle has its usual routes: the first half of the fleet the towns, the
        // second half the country.
        let route = (vehicle / 6) * 3 + rng.random_range(0..3_usize);
        let (route_name, mut profile) = ROUTES[route];
        if rng.random_bool(0.1) {
            profile = Profile::RoughRoad;
        }
        let start = year_start
            + (i as i64 * 365 * 86_400) / missions.max(1) as i64
            + rng.random_range(0..3_600);
        let k = profiles.iter().position(|p| *p == profile).unwrap();
        let (_, report, path, bytes) = &pool[k * POOL + rng.random_range(0..POOL)];
        let mut hasher = Sha256::new();
        hasher.update(bytes);
        hasher.update((i as u64).to_le_bytes());
        let ride = RideFile {
            input: path.display().to_string(),
            sha256: hasher
                .finalize()
                .iter()
                .map(|b| format!("{b:02x}"))
                .collect(),
            bytes: bytes.len() as u64,
            content: None,
        };
        let meta = MissionMeta {
            vehicle: Some(format!("V{:02}", vehicle + 1)),
            crew: Some(format!("crew {}", rng.random_range(1..=8))),
            driver: Some(format!("D{:02}", rng.random_range(1..=20))),
            route: Some(route_name.to_string()),
            position: Some("supine".into()),
            start: Some(jiff::Timestamp::from_second(start).unwrap().to_string()),
            ..Default::default()
        };
        let record = MissionRecord::new(report, vec![ride], meta).unwrap();
        let t = Instant::now();
        archive.run(store::add(&archive, &record)).unwrap();
        add += t.elapsed();
        ride_s += report.mission.duration_s;
        if (i + 1) % 500 == 0 {
            eprintln!("{} missions", i + 1);
        }
    }
    let n = archive.run(store::count(&archive)).unwrap();
    let t = Instant::now();
    let rows = archive
        .run(store::fleet_rows(&archive, &Filter::default()))
        .unwrap();
    let places = archive
        .run(store::road_segments(&archive, &Filter::default()))
        .unwrap();
    let view = fleet::build(&rows, places, &DIMENSIONS, None);
    let page = fleet_html::render(&view);
    std::fs::write(out.join("fleet.html"), &page).unwrap();
    let fleet_s = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let filter = Filter {
        vehicle: vec!["V03".into()],
        ..Default::default()
    };
    let one = archive.run(store::fleet_rows(&archive, &filter)).unwrap();
    let vehicle_s = t.elapsed().as_secs_f64();
    let bytes = match archive.backend() {
        Backend::Sqlite => {
            archive
                .run(sqlx::query("PRAGMA wal_checkpoint(TRUNCATE)").execute(archive.pool()))
                .unwrap();
            match &location {
                Location::Sqlite(p) => std::fs::metadata(p).unwrap().len() as f64,
                Location::Postgres(_) => unreachable!(),
            }
        }
        Backend::Postgres => archive
            .run(
                sqlx::query("SELECT pg_database_size(current_database()) AS n")
                    .fetch_one(archive.pool()),
            )
            .unwrap()
            .try_get::<i64, _>("n")
            .unwrap() as f64,
    };
    let hours_added = ride_s / 3600.0;
    println!("archive {}", location.display());
    println!("missions in the archive {n}, added now {missions}, ride {hours_added:.1} h");
    if missions > 0 {
        println!(
            "add: {:.1} missions/s database only ({:.2} ms each); evaluation {:.1} ms a ride \
             ({evaluated} rides)",
            missions as f64 / add.as_secs_f64(),
            1e3 * add.as_secs_f64() / missions as f64,
            1e3 * evaluate.as_secs_f64() / evaluated as f64
        );
    }
    println!(
        "size {:.1} MB, {:.0} kB per mission, {:.0} kB per mission-hour",
        bytes / 1e6,
        bytes / 1e3 / n as f64,
        bytes / 1e3 / (rows.iter().map(|r| r.duration_s).sum::<f64>() / 3600.0)
    );
    println!(
        "fleet page ({} missions, {} groups): {:.2} s, {:.0} kB",
        view.missions,
        view.groups.len(),
        fleet_s,
        page.len() as f64 / 1e3
    );
    println!(
        "per-vehicle query (V03, {} missions): {:.1} ms",
        one.len(),
        1e3 * vehicle_s
    );
}
