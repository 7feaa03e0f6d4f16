//! `supine ride`: a realistic litter-frame acceleration recording (platform columns only)
//! for one of the ride profiles (the demo's road trip, or one of
//! [`crate::exposure::ride`]'s surfaces throughout), deterministic for a seed.

use std::path::PathBuf;

use anyhow::{Result, bail};

use crate::commands::json_output::{self, JsonFlag};
use crate::commands::values;
use crate::demo::demo_record::RideSummary;
use crate::demo::demo_ride::{DemoProfile, make};
use crate::demo::demo_track::{START_DEG, track_from};
use crate::exposure::ride::write_ride;
use crate::io::track_file::write_gpx;
use crate::ride::position::out_of_range;

/// The time of a written track's first point (a GPX point needs a date; the report
/// joins the track by time from its first point).
const TRACK_START: time::OffsetDateTime = time::macros::datetime!(2026-01-01 08:00 UTC);

/// Arguments of `supine ride`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// The kind of ride (road-trip: paved road, rough road with shocks, paved road again).
    #[arg(long, value_enum)]
    pub profile: DemoProfile,
    /// Length of the ride, s.
    #[arg(long, default_value_t = values::DEFAULT_DURATION_S)]
    pub duration_s: f64,
    /// Sample rate, Hz (a rate the device supports).
    #[arg(
        long = "fs",
        value_name = "HZ",
        default_value_t = values::DEFAULT_SAMPLE_RATE_HZ,
        help = values::sample_rate_help("Sample rate")
    )]
    pub fs_hz: f64,
    /// Seed of every random draw (ChaCha8): the same seed gives the same file.
    #[arg(long, default_value_t = values::DEFAULT_SEED)]
    pub seed: u64,
    /// Where to write the recording (`time_s,platform_x_m_s2,platform_y_m_s2,platform_z_m_s2`).
    #[arg(long, value_name = "RIDE.csv")]
    pub out: PathBuf,
    /// Also write where the ride happened, as a GPX 1.1 track (a fix a second on a
    /// plausible road, slower on the rough stretch), for `supine report --track`.
    #[arg(long, value_name = "TRACK.gpx")]
    pub track_out: Option<PathBuf>,
    /// Where the written track starts, latitude and longitude in degrees (a mission's
    /// next leg starts where the last ended).
    #[arg(long, value_name = "LAT,LON", requires = "track_out", value_parser = parse_lat_lon, allow_hyphen_values = true)]
    pub track_from: Option<(f64, f64)>,
    /// Print the ride's summary as JSON.
    #[command(flatten)]
    pub json: JsonFlag,
}

/// `LAT,LON` in degrees, each within its range.
fn parse_lat_lon(text: &str) -> Result<(f64, f64), String> {
    let parsed = text
        .split_once(',')
        .and_then(|(a, b)| Some((a.trim().parse::<f64>().ok()?, b.trim().parse::<f64>().ok()?)));
    let Some((lat, lon)) = parsed else {
        return Err(format!(
            "expected LAT,LON in degrees (47.95,11.30), found {}",
            crate::io::excerpt::excerpt(text)
        ));
    };
    match out_of_range(lat, lon) {
        Some(why) => Err(why),
        None => Ok((lat, lon)),
    }
}

/// Generates and writes the ride, with a one-line summary on standard error (or JSON on
/// standard output).
pub fn run(args: &Args) -> Result<()> {
    let made = make(args.profile, args.duration_s, args.fs_hz, args.seed)?;
    let ride = &made.ride;
    let fixes = track_from(&made, args.track_from.unwrap_or(START_DEG));
    if args.track_out.is_some() && fixes.is_empty() {
        bail!(
            "--track-out: the {} profile goes nowhere: expected a ride on a road or in the air",
            args.profile.name()
        );
    }
    write_ride(&args.out, ride)?;
    if let Some(path) = &args.track_out {
        write_gpx(path, &fixes, TRACK_START)?;
    }
    let rms = ride.rms_m_s2();
    if args.json.json {
        return json_output::print(&RideSummary::new(
            &made,
            args.profile,
            args.seed,
            &args.out,
            args.track_out.as_deref(),
        ));
    }
    eprintln!(
        "wrote {}: {} {} s at {} Hz, seed {}; rms x {:.3}, y {:.3}, z {:.3} m/s^2, crest factor z {:.1}, {}",
        args.out.display(),
        args.profile.name(),
        made.duration_s(),
        ride.sample_rate_hz,
        args.seed,
        rms[0],
        rms[1],
        rms[2],
        ride.vertical_crest_factor(),
        crate::io::wording::count(made.shocks.len(), "shock")
    );
    Ok(())
}
