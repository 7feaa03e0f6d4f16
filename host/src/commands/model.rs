//! `supine model`: the model's transmissibility H(f), all 27 components, as CSV.

use std::path::PathBuf;

use anyhow::{Result, anyhow};

use crate::commands::values;
use crate::identify::transmissibility::model_h;
use crate::io::h_csv;
use crate::io::params_file::ModelSource;

/// Arguments of `supine model`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Which parameters.
    #[command(flatten)]
    pub source: ModelSource,
    /// Override the subject's height, m.
    #[arg(long)]
    pub height_m: Option<f64>,
    /// Override the subject's mass, kg.
    #[arg(long)]
    pub mass_kg: Option<f64>,
    /// Lowest frequency, Hz (above 0: H is the static response there, 1 on matching axes).
    #[arg(long = "fmin", value_name = "HZ", default_value_t = 0.5, value_parser = values::positive_hz)]
    pub fmin_hz: f64,
    /// Highest frequency, Hz (above --fmin).
    #[arg(long = "fmax", value_name = "HZ", default_value_t = 16.0, value_parser = values::positive_hz)]
    pub fmax_hz: f64,
    /// Frequency step, Hz (at most 100,000 frequencies).
    #[arg(long = "df", value_name = "HZ", default_value_t = 0.05, value_parser = values::positive_hz)]
    pub df_hz: f64,
    /// Where to write the CSV.
    #[arg(long)]
    pub out: PathBuf,
}

/// Writes H at every grid frequency for the chosen parameters.
pub fn run(args: &Args) -> Result<()> {
    let mut params = args.source.load()?.params;
    if let Some(h) = args.height_m {
        params.subject.height_m = h;
    }
    if let Some(m) = args.mass_kg {
        params.subject.mass_kg = m;
    }
    params.validate().map_err(|e| anyhow!("{e}"))?;
    let freqs = h_csv::frequency_grid(args.fmin_hz, args.fmax_hz, args.df_hz)?;
    let h = model_h(&params, &freqs)?;
    let rows = h_csv::rows(&freqs, &h, None);
    h_csv::write(&args.out, &rows)?;
    eprintln!(
        "wrote {} ({} frequencies x 27 components)",
        args.out.display(),
        freqs.len()
    );
    Ok(())
}
