//! `supine model`: the model's transmissibility H(f), all 27 components, as CSV.

use std::path::PathBuf;

use anyhow::{Result, anyhow};
use supine_core::model::{Axis, Output, SystemMatrices};

use crate::h_csv::{self, HRow};
use crate::params_file::ModelSource;

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
    /// Lowest frequency, Hz.
    #[arg(long, default_value_t = 0.5)]
    pub fmin: f64,
    /// Highest frequency, Hz.
    #[arg(long, default_value_t = 16.0)]
    pub fmax: f64,
    /// Frequency step, Hz.
    #[arg(long, default_value_t = 0.05)]
    pub df: f64,
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
    let freqs = h_csv::frequency_grid(args.fmin, args.fmax, args.df)?;
    let matrices = SystemMatrices::assemble(&params);
    let mut rows = Vec::with_capacity(freqs.len() * 27);
    for &freq_hz in &freqs {
        let h = matrices
            .transmissibility(freq_hz)
            .map_err(|e| anyhow!("{e}"))?;
        for output in Output::ALL {
            for input in Axis::ALL {
                let value = h[(output.index(), input.index())];
                rows.push(HRow {
                    freq_hz,
                    output,
                    input,
                    value,
                    coherence: None,
                });
            }
        }
    }
    h_csv::write(&args.out, &rows)?;
    eprintln!(
        "wrote {} ({} frequencies x 27 components)",
        args.out.display(),
        freqs.len()
    );
    Ok(())
}
