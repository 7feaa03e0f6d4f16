//! `supine report`: the mission report of one or more rides (each `--input` one leg, in
//! order) for a given patient: `DIR/report.html`, and with `--json` one JSON object on
//! standard output (see [`crate::report`]). `--compare` puts two rides side by side.

use std::io::Write;
use std::path::PathBuf;

use anyhow::{Context as _, Result, anyhow, bail};
use clap::ValueEnum as _;
use supine_core::model::params::{HEIGHT_RANGE_M, MASS_RANGE_KG};

use crate::io::output::write_atomically;
use crate::io::params_file::{ModelSource, ParamFile};
use crate::io::ride_input::RideInputArgs;
use crate::report::{self, html};

/// Arguments of `supine report`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// A ride (one leg of the mission); give one per leg, in order.
    #[arg(long, value_name = "RIDE.csv", required = true)]
    pub input: Vec<PathBuf>,
    /// How to read the rides (another logger's columns and units, gravity).
    #[command(flatten)]
    pub ride: RideInputArgs,
    /// The model parameters (and optional `[device]` table).
    #[command(flatten)]
    pub model: ModelSource,
    /// The patient's height, m (the model's anthropometric scaling).
    #[arg(long, value_name = "M")]
    pub height_m: Option<f64>,
    /// The patient's mass, kg (the model's anthropometric scaling).
    #[arg(long, value_name = "KG")]
    pub mass_kg: Option<f64>,
    /// Output folder for report.html (created if missing).
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
    /// Also print the report as one JSON object on standard output.
    #[arg(long)]
    pub json: bool,
    /// Two rides side by side (routes, vehicles, litters), with their differences,
    /// instead of the legs of one mission.
    #[arg(long)]
    pub compare: bool,
}

/// The parameters of `source` for the patient: height and mass replaced where given, and
/// refused with the model's range when outside it.
pub fn for_subject(
    source: &ModelSource,
    height_m: Option<f64>,
    mass_kg: Option<f64>,
) -> Result<ParamFile> {
    let mut file = source.load()?;
    for (flag, value, (lo, hi), unit) in [
        ("--height-m", height_m, HEIGHT_RANGE_M, "m"),
        ("--mass-kg", mass_kg, MASS_RANGE_KG, "kg"),
    ] {
        if let Some(v) = value.filter(|v| !(lo..=hi).contains(v)) {
            bail!("{flag} {v}: expected {lo} to {hi} {unit}, the model's range");
        }
    }
    if let Some(h) = height_m {
        file.params.subject.height_m = h;
    }
    if let Some(m) = mass_kg {
        file.params.subject.mass_kg = m;
    }
    file.params
        .validate()
        .map_err(|e| anyhow!("--height-m/--mass-kg: {e}"))?;
    Ok(file)
}

/// The name the model is reported by.
pub fn model_name(source: &ModelSource) -> String {
    match (&source.params, source.preset) {
        (Some(p), _) => p.display().to_string(),
        (None, Some(p)) => p
            .to_possible_value()
            .map_or_else(|| format!("{p:?}"), |v| v.get_name().to_string()),
        (None, None) => "?".to_string(),
    }
}

/// Builds the report, writes `report.html`, and the JSON to `out` with `--json`.
pub fn run_to(args: &Args, out: &mut impl Write) -> Result<()> {
    let file = for_subject(&args.model, args.height_m, args.mass_kg)?;
    let mounting = file.device.unwrap_or_default().mounting;
    let rides = args
        .input
        .iter()
        .map(|path| args.ride.read(path, &mounting))
        .collect::<Result<Vec<_>>>()?;
    let report = report::build(&rides, &file, &model_name(&args.model), args.compare)?;
    let page = html::render(&report)?;
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("{}: cannot create the folder", args.out.display()))?;
    let path = args.out.join("report.html");
    write_atomically(&path, |w| Ok(w.write_all(page.as_bytes())?))?;
    if args.json {
        let text = serde_json::to_string(&report)? + "\n";
        out.write_all(text.as_bytes())
            .map_err(|e| anyhow!("writing the JSON: {e}"))?;
    }
    eprintln!(
        "wrote {}: {} {}, {:.1} s, mission VDV {:.3} m/s^1.75, highest level {}",
        path.display(),
        report.legs.len(),
        if args.compare {
            "rides compared"
        } else {
            "legs"
        },
        report.mission.duration_s,
        report.mission.vector.vdv_m_s175,
        report.mission.max_level
    );
    Ok(())
}

/// Builds and writes the report; the JSON goes to standard output.
pub fn run(args: &Args) -> Result<()> {
    run_to(args, &mut std::io::stdout().lock())
}
