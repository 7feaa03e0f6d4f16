//! `supine archive`: keep every mission in one database and look across them
//! (`docs/archive.md`): `add`, `list`, `show`, `remove`, `fleet`, `export`.

use std::io::Write;
use std::path::PathBuf;

use anyhow::{Context as _, Result, anyhow, bail};

use crate::archive::db::Archive;
use crate::archive::fleet::{self, DIMENSIONS, Side};
use crate::archive::location::Location;
use crate::archive::meta::{MissionMeta, parse_bound};
use crate::archive::record::{AddedMission, MissionRecord, RideFile};
use crate::archive::store::{self, Filter};
use crate::archive::{fhir, fleet_html};
use crate::commands::report::{MissionArgs, mission_report};
use crate::io::output::{write_all_atomically, write_atomically};
use crate::io::wording::count;

/// Arguments of `supine archive`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// The archive: a SQLite file, or a PostgreSQL URL (postgres://user@host/db).
    /// Default: $XDG_DATA_HOME/supine/archive.sqlite.
    #[arg(long, value_name = "PATH|URL", global = true)]
    pub archive: Option<String>,
    /// What to do.
    #[command(subcommand)]
    pub command: Command,
}

/// The subcommands of `supine archive`.
#[derive(Debug, clap::Subcommand)]
pub enum Command {
    /// Evaluate rides as `supine report` does and store the mission; print its id.
    Add(Box<AddArgs>),
    /// List the missions (with --json: their metadata and report values).
    List(ListArgs),
    /// Show one mission.
    Show(ShowArgs),
    /// Remove one mission and everything stored with it.
    Remove(RemoveArgs),
    /// Write the fleet view: DIR/fleet.html (and --json).
    #[command(
        after_help = "Example:\n  supine archive fleet --out fleet --compare vehicle=A1 --compare vehicle=A2"
    )]
    Fleet(FleetArgs),
    /// Export one mission for the patient's record.
    Export(ExportArgs),
}

/// The metadata flags of `add` (each overrides the same key of `--meta`).
#[derive(Debug, Default, clap::Args)]
pub struct MetaArgs {
    /// The metadata given as flags.
    #[command(flatten)]
    pub flags: MissionMeta,
    /// The metadata as a TOML file (the keys above; tags = [...]).
    #[arg(long, value_name = "FILE.toml")]
    pub meta: Option<PathBuf>,
}

impl MetaArgs {
    /// The metadata: `--meta`'s file overlaid with the flags.
    pub fn resolve(&self) -> Result<MissionMeta> {
        let file = match &self.meta {
            Some(path) => MissionMeta::load(path)?,
            None => MissionMeta::default(),
        };
        let meta = file.overlaid(self.flags.clone());
        // A bad start is refused before the rides are evaluated.
        meta.start_time()?;
        Ok(meta)
    }
}

/// Arguments of `supine archive add`.
#[derive(Debug, clap::Args)]
pub struct AddArgs {
    /// The rides and how to evaluate them, as for `supine report`.
    #[command(flatten)]
    pub mission: MissionArgs,
    /// The mission's metadata.
    #[command(flatten)]
    pub meta: MetaArgs,
    /// Also keep a copy of each ride file in the archive (by default only its SHA-256).
    #[arg(long)]
    pub copy_rides: bool,
    /// Print {"id": ..., "rides": [...], "mission": {...}} instead of the id alone.
    #[arg(long)]
    pub json: bool,
}

/// Which missions `list` and `fleet` take.
#[derive(Debug, Default, clap::Args)]
pub struct FilterArgs {
    /// Missions that started on or after this date (2026-11-01) or instant.
    #[arg(long, value_name = "DATE")]
    pub since: Option<String>,
    /// Missions that started before this date or instant.
    #[arg(long, value_name = "DATE")]
    pub until: Option<String>,
    /// Only this vehicle (repeat for more).
    #[arg(long = "vehicle", value_name = "ID")]
    pub vehicle: Vec<String>,
    /// Only this crew (repeat for more).
    #[arg(long = "crew", value_name = "ID")]
    pub crew: Vec<String>,
    /// Only this driver (repeat for more).
    #[arg(long = "driver", value_name = "ID")]
    pub driver: Vec<String>,
    /// Only this route (repeat for more).
    #[arg(long = "route", value_name = "NAME")]
    pub route: Vec<String>,
}

impl FilterArgs {
    /// The filter.
    pub fn filter(&self) -> Result<Filter> {
        Ok(Filter {
            since: self.since.as_deref().map(parse_bound).transpose()?,
            until: self.until.as_deref().map(parse_bound).transpose()?,
            vehicle: self.vehicle.clone(),
            crew: self.crew.clone(),
            driver: self.driver.clone(),
            route: self.route.clone(),
        })
    }
}

/// Arguments of `supine archive list`.
#[derive(Debug, clap::Args)]
pub struct ListArgs {
    /// Which missions.
    #[command(flatten)]
    pub filter: FilterArgs,
    /// One JSON array of missions instead of a table.
    #[arg(long)]
    pub json: bool,
}

/// Arguments of `supine archive show`.
#[derive(Debug, clap::Args)]
pub struct ShowArgs {
    /// The mission's id.
    pub id: i64,
    /// The mission as JSON: metadata, "mission" and "legs" as `report --json` has them,
    /// and each leg's per-second series.
    #[arg(long)]
    pub json: bool,
}

/// Arguments of `supine archive remove`.
#[derive(Debug, clap::Args)]
pub struct RemoveArgs {
    /// The mission's id.
    pub id: i64,
}

/// Arguments of `supine archive fleet`.
#[derive(Debug, clap::Args)]
pub struct FleetArgs {
    /// Output folder for fleet.html (created if missing).
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
    /// Also print the view as one JSON object.
    #[arg(long)]
    pub json: bool,
    /// Group by this (repeat for more; default: vehicle, crew, driver, route).
    #[arg(long, value_name = "vehicle|crew|driver|route")]
    pub by: Vec<String>,
    /// Which missions.
    #[command(flatten)]
    pub filter: FilterArgs,
    /// A group to compare, `FIELD=VALUE[,since=DATE][,until=DATE]`; give two (default: the
    /// two largest groups of the first --by).
    #[arg(long, value_name = "FIELD=VALUE")]
    pub compare: Vec<String>,
}

/// Arguments of `supine archive export`.
#[derive(Debug, clap::Args)]
pub struct ExportArgs {
    /// The mission's id.
    pub id: i64,
    /// Write a FHIR R4 Bundle of Observations (JSON) here.
    #[arg(long, value_name = "FILE", required = true)]
    pub fhir: PathBuf,
}

/// Runs `supine archive`, printing to standard output.
pub fn run(args: &Args) -> Result<()> {
    run_to(args, &mut std::io::stdout().lock())
}

/// Runs `supine archive`, printing to `out`.
pub fn run_to(args: &Args, out: &mut impl Write) -> Result<()> {
    let location = Location::resolve(args.archive.as_deref())?;
    let print = |out: &mut dyn Write, text: String| {
        out.write_all(text.as_bytes())
            .map_err(|e| anyhow!("writing the output: {e}"))
    };
    match &args.command {
        Command::Add(a) => {
            let meta = a.meta.resolve()?;
            // A monitor log is one leg (its input stream), hashed as the log file itself.
            let (_, _, report) = mission_report(&a.mission, false)?;
            let rides = a
                .mission
                .input
                .iter()
                .map(|p| RideFile::read(p, a.copy_rides))
                .collect::<Result<Vec<_>>>()?;
            let record = MissionRecord::new(&report, rides, meta)?;
            let archive = Archive::open(&location)?;
            let id = archive.run(store::add(&archive, &record))?;
            if a.json {
                let added = AddedMission::new(id, location.display().to_string(), &record);
                print(out, serde_json::to_value(&added)?.to_string() + "\n")?;
            } else {
                print(out, format!("{id}\n"))?;
            }
            eprintln!(
                "archived mission {id} in {}: {}, {:.1} s, VDV {:.3} m/s^1.75",
                location.display(),
                count(report.legs.len(), "leg"),
                report.mission.duration_s,
                report.mission.vector.vdv_m_s175
            );
        }
        Command::List(a) => {
            let archive = Archive::open(&location)?;
            let missions = archive.run(store::list(&archive, &a.filter.filter()?))?;
            if a.json {
                print(out, serde_json::to_string(&missions)? + "\n")?;
            } else {
                let mut text = format!(
                    "{:>6}  {:<20}  {:<10}  {:<10}  {:<12}  {:>8}  {:>10}  {}\n",
                    "id", "start", "vehicle", "crew", "route", "min", "VDV", "level"
                );
                for m in &missions {
                    let f = |k: &str| m.mission[k].clone();
                    text += &format!(
                        "{:>6}  {:<20}  {:<10}  {:<10}  {:<12}  {:>8.1}  {:>10.3}  {}\n",
                        m.id,
                        m.meta.start.as_deref().unwrap_or("-"),
                        m.meta.vehicle.as_deref().unwrap_or("-"),
                        m.meta.crew.as_deref().unwrap_or("-"),
                        m.meta.route.as_deref().unwrap_or("-"),
                        f("duration_s").as_f64().unwrap_or(0.0) / 60.0,
                        m.mission["vector"]["vdv_m_s175"].as_f64().unwrap_or(0.0),
                        f("max_level").as_str().unwrap_or("?")
                    );
                }
                print(out, text)?;
            }
        }
        Command::Show(a) => {
            let archive = Archive::open(&location)?;
            let m = archive.run(store::show(&archive, a.id))?;
            if a.json {
                print(out, serde_json::to_string(&m)? + "\n")?;
            } else {
                print(out, show_text(&m))?;
            }
        }
        Command::Remove(a) => {
            let archive = Archive::open(&location)?;
            archive.run(store::remove(&archive, a.id))?;
            eprintln!("removed mission {} from {}", a.id, location.display());
        }
        Command::Fleet(a) => {
            let dims = dimensions(&a.by)?;
            let compare = match a.compare.as_slice() {
                [] => None,
                [x, y] => Some([Side::parse(x)?, Side::parse(y)?]),
                other => bail!("--compare: give two groups, found {}", other.len()),
            };
            let archive = Archive::open(&location)?;
            let filter = a.filter.filter()?;
            let rows = archive.run(store::fleet_rows(&archive, &filter))?;
            let places = archive.run(store::road_segments(&archive, &filter))?;
            let view = fleet::build(&rows, places, &dims, compare);
            std::fs::create_dir_all(&a.out)
                .with_context(|| format!("{}: cannot create the folder", a.out.display()))?;
            let page = a.out.join("fleet.html");
            write_all_atomically(&[(page.clone(), fleet_html::render(&view).into_bytes())])?;
            if a.json {
                print(out, serde_json::to_string(&view)? + "\n")?;
            }
            eprintln!(
                "wrote {}: {} missions, {} groups",
                page.display(),
                view.missions,
                view.groups.len()
            );
        }
        Command::Export(a) => {
            let archive = Archive::open(&location)?;
            let m = archive.run(store::show(&archive, a.id))?;
            let bundle = fhir::bundle(&m.summary)?;
            let text = serde_json::to_string_pretty(&bundle)? + "\n";
            write_atomically(&a.fhir, |w| Ok(w.write_all(text.as_bytes())?))?;
            eprintln!(
                "wrote {}: mission {} as a FHIR R4 Bundle",
                a.fhir.display(),
                a.id
            );
        }
    }
    Ok(())
}

/// The dimensions `--by` names (all four when none).
fn dimensions(by: &[String]) -> Result<Vec<&'static str>> {
    if by.is_empty() {
        return Ok(DIMENSIONS.to_vec());
    }
    by.iter()
        .map(|b| {
            DIMENSIONS
                .into_iter()
                .find(|d| *d == b.as_str())
                .ok_or_else(|| anyhow!("--by {b}: expected vehicle, crew, driver or route"))
        })
        .collect()
}

fn show_text(m: &store::MissionDetail) -> String {
    let s = &m.summary;
    let meta = &s.meta;
    let opt = |v: &Option<String>| v.clone().unwrap_or_else(|| "-".into());
    let mut t = format!(
        "mission {}\n  start        {}\n  vehicle      {}\n  crew         {}\n  driver       {}\n  \
         route        {}\n  position     {}\n  from / to    {} / {}\n  patient      {}\n  \
         encounter    {}\n  tags         {}\n  model        {} ({})\n  patient size {} m, {} kg\n",
        s.id,
        opt(&meta.start),
        opt(&meta.vehicle),
        opt(&meta.crew),
        opt(&meta.driver),
        opt(&meta.route),
        opt(&meta.position),
        opt(&meta.origin),
        opt(&meta.destination),
        opt(&meta.patient),
        opt(&meta.encounter),
        meta.tags.join(", "),
        s.model.name,
        s.model.identity,
        s.subject.height_m,
        s.subject.mass_kg
    );
    let v = &s.mission["vector"];
    t += &format!(
        "  duration     {:.1} s\n  head vector  rms {:.4} m/s^2, MTVV {:.4} m/s^2, VDV {:.4} m/s^1.75\n  \
         highest level {}\n",
        s.mission["duration_s"].as_f64().unwrap_or(0.0),
        v["rms_m_s2"].as_f64().unwrap_or(0.0),
        v["mtvv_m_s2"].as_f64().unwrap_or(0.0),
        v["vdv_m_s175"].as_f64().unwrap_or(0.0),
        s.mission["max_level"].as_str().unwrap_or("?")
    );
    for (i, (leg, ride)) in m.legs.iter().zip(&s.rides).enumerate() {
        t += &format!(
            "  leg {}       {} ({:.1} s, VDV {:.4} m/s^1.75, sha256 {}{})\n",
            i + 1,
            ride.input,
            leg["duration_s"].as_f64().unwrap_or(0.0),
            leg["vector"]["vdv_m_s175"].as_f64().unwrap_or(0.0),
            &ride.sha256[..12.min(ride.sha256.len())],
            if ride.copied { ", copy kept" } else { "" }
        );
    }
    t
}
