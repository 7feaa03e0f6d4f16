//! `supine ride`: a realistic litter-frame acceleration recording (platform columns only)
//! for one of the ride profiles (the demo's road trip, or one of
//! [`crate::exposure::ride`]'s surfaces throughout), deterministic for a seed.

use std::path::PathBuf;

use anyhow::Result;

use crate::commands::json_output::{self, JsonFlag};
use crate::commands::values;
use crate::demo::demo_record::RideSummary;
use crate::demo::demo_ride::{DemoProfile, make};
use crate::exposure::ride::write_ride;

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
    /// Where to write the recording (`time_s,platform_x,platform_y,platform_z`).
    #[arg(long, value_name = "RIDE.csv")]
    pub out: PathBuf,
    /// Print the ride's summary as JSON.
    #[command(flatten)]
    pub json: JsonFlag,
}

/// Generates and writes the ride, with a one-line summary on standard error (or JSON on
/// standard output).
pub fn run(args: &Args) -> Result<()> {
    let made = make(args.profile, args.duration_s, args.fs_hz, args.seed)?;
    let ride = &made.ride;
    write_ride(&args.out, ride)?;
    let rms = ride.rms_m_s2();
    if args.json.json {
        return json_output::print(&RideSummary::new(&made, args.profile, args.seed, &args.out));
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
