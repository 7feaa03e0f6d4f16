//! `supine ride`: a realistic litter-frame acceleration recording (platform columns only)
//! for one of the profiles of [`crate::exposure::ride`], deterministic for a seed.

use std::path::PathBuf;

use anyhow::Result;

use crate::commands::values;
use crate::exposure::ride::{Profile, generate, write_ride};

/// Arguments of `supine ride`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// The kind of ride.
    #[arg(long, value_enum)]
    pub profile: Profile,
    /// Length of the ride, s.
    #[arg(long, default_value_t = 600.0)]
    pub duration_s: f64,
    /// Sample rate, Hz (a rate the device supports).
    #[arg(
        long = "fs",
        value_name = "HZ",
        default_value_t = 500.0,
        help = values::sample_rate_help("Sample rate")
    )]
    pub fs_hz: f64,
    /// Seed of every random draw (ChaCha8): the same seed gives the same file.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Where to write the recording (`time_s,platform_x,platform_y,platform_z`).
    #[arg(long, value_name = "RIDE.csv")]
    pub out: PathBuf,
}

/// Generates and writes the ride, with a one-line summary on standard error.
pub fn run(args: &Args) -> Result<()> {
    let ride = generate(args.profile, args.duration_s, args.fs_hz, args.seed)?;
    write_ride(&args.out, &ride)?;
    let rms = ride.rms_m_s2();
    eprintln!(
        "wrote {}: {} {} s at {} Hz, seed {}; rms x {:.3}, y {:.3}, z {:.3} m/s^2, crest factor z {:.1}, {} shocks",
        args.out.display(),
        ride.profile.name(),
        ride.len() as f64 / ride.sample_rate_hz,
        ride.sample_rate_hz,
        ride.seed,
        rms[0],
        rms[1],
        rms[2],
        ride.vertical_crest_factor(),
        ride.shocks.len()
    );
    Ok(())
}
