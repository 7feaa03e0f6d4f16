//! `supine weighting`: the frequency response of the ISO 2631-1 weighting filter the
//! device runs, as CSV (see [`crate::exposure::weighting_response`]).

use std::path::PathBuf;

use anyhow::{Result, anyhow};
use supine_core::sample_rate::SampleRate;
use supine_core::weighting::{WeightingKind, WeightingSettings};

use crate::commands::json_output::{self, JsonFlag};
use crate::commands::values;
use crate::exposure::exposure_records::WeightingResponseSummary;
use crate::exposure::weighting_response::{centre_frequencies, write_response};

/// The weighting to describe.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Kind {
    /// Wk: vertical (recumbent: under the pelvis).
    Wk,
    /// Wd: horizontal (recumbent: both horizontal axes).
    Wd,
    /// Wj: recumbent, vertical under the head.
    Wj,
}

impl From<Kind> for WeightingKind {
    fn from(k: Kind) -> Self {
        match k {
            Kind::Wk => WeightingKind::Wk,
            Kind::Wd => WeightingKind::Wd,
            Kind::Wj => WeightingKind::Wj,
        }
    }
}

/// Arguments of `supine weighting`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Which weighting (`--kind` is an older spelling).
    #[arg(long, value_enum, alias = "kind")]
    pub weighting: Kind,
    /// Sample rate the filter is designed for, Hz (a rate the device supports).
    #[arg(
        long = "fs",
        value_name = "HZ",
        default_value_t = values::DEFAULT_SAMPLE_RATE_HZ as f32,
        help = values::sample_rate_help("Sample rate the filter is designed for")
    )]
    pub fs_hz: f32,
    /// Lowest frequency, Hz.
    #[arg(long = "fmin", value_name = "HZ", default_value_t = 0.1, value_parser = values::positive_hz)]
    pub fmin_hz: f64,
    /// Highest frequency, Hz (the grid also stops below fs/2).
    #[arg(long = "fmax", value_name = "HZ", default_value_t = 400.0, value_parser = values::positive_hz)]
    pub fmax_hz: f64,
    /// Frequencies per decade, at the exact centres 10^(n/N) Hz (10: one-third octaves).
    #[arg(long, default_value_t = 10)]
    pub per_decade: u32,
    /// Where to write the CSV (`freq_hz,magnitude,phase_rad,analog_magnitude`).
    #[arg(long)]
    pub out: PathBuf,
    /// Print what was written as JSON.
    #[command(flatten)]
    pub json: JsonFlag,
}

/// Writes the response of the device's filter and of the analog weighting on the grid.
pub fn run(args: &Args) -> Result<()> {
    let kind = WeightingKind::from(args.weighting);
    let sample_rate =
        SampleRate::new(args.fs_hz).map_err(|e| anyhow!("--fs {}: {e}", args.fs_hz))?;
    let filter = WeightingSettings::new(kind, sample_rate)
        .map_err(|e| anyhow!("--fs {}: {e}", args.fs_hz))?;
    let freqs = centre_frequencies(
        args.fmin_hz,
        args.fmax_hz,
        args.per_decade,
        args.fs_hz as f64,
    )?;
    write_response(&args.out, kind, &filter, sample_rate, &freqs)?;
    if args.json.json {
        return json_output::print(&WeightingResponseSummary {
            out: args.out.clone(),
            frequencies: freqs.len(),
            weighting: kind.to_string(),
            sample_rate_hz: args.fs_hz,
        });
    }
    eprintln!(
        "wrote {} ({} frequencies, {kind} at {} Hz)",
        args.out.display(),
        freqs.len(),
        args.fs_hz
    );
    Ok(())
}
