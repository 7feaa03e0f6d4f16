//! `supine predict`: the sensor accelerations and the neck and lower-back motion the model
//! predicts for a recording's support acceleration (see `validate::predict` for how it stays faithful to the continuous model),
//! and with `--band N` the head exposure's prediction band from the fit's uncertainty (see
//! `fit::band`).

use std::path::PathBuf;

use anyhow::{Result, anyhow};

use crate::identify::fit::band::{BAND_QUANTILES, ExposureBand, head_exposure_band};
use crate::identify::fit::uncertainty::StoredUncertainty;
use crate::identify::validate::{predict, predict_joints, write_prediction};
use crate::io::params_file;
use crate::io::recording::Recording;

/// Arguments of `supine predict`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// The parameter file (as `supine fit` writes).
    #[arg(long, value_name = "FILE")]
    pub params: PathBuf,
    /// The recording whose platform columns drive the model.
    #[arg(long, value_name = "REC.csv")]
    pub input: PathBuf,
    /// Where to write the prediction (a recording's columns, then the joint motion).
    #[arg(long, value_name = "PRED.csv")]
    pub out: PathBuf,
    /// Override the subject's height, m.
    #[arg(long)]
    pub height_m: Option<f64>,
    /// Override the subject's mass, kg.
    #[arg(long)]
    pub mass_kg: Option<f64>,
    /// Also print the head exposure's 95 % prediction band from this many parameter sets
    /// drawn from the fit's uncertainty (the file's [fit.uncertainty]).
    #[arg(long, value_name = "DRAWS")]
    pub band: Option<usize>,
    /// Seed of the band's draws.
    #[arg(long, default_value_t = 1)]
    pub band_seed: u64,
}

/// The band as a table.
fn band_table(band: &ExposureBand) -> String {
    let mut s = format!(
        "head exposure (frequency-weighted rms, m/s^2), {:.1} to {:.1} % of {} parameter sets drawn from the fit's uncertainty:\n| axis | fitted | low | high |\n|---|---|---|---|\n",
        100.0 * BAND_QUANTILES.0,
        100.0 * BAND_QUANTILES.1,
        band.draws.len()
    );
    for (i, axis) in ["x", "y", "z", "vector"].iter().enumerate() {
        s += &format!(
            "| {axis} | {:.5} | {:.5} | {:.5} |\n",
            band.fitted.values()[i],
            band.low.values()[i],
            band.high.values()[i]
        );
    }
    s
}

/// Predicts and writes the CSV.
pub fn run(args: &Args) -> Result<()> {
    let params = params_file::load_for_subject(&args.params, args.height_m, args.mass_kg)?;
    let recording = Recording::read(&args.input)?;
    let band = match args.band {
        Some(draws) => {
            let file = params_file::load(&args.params)?;
            let uncertainty = StoredUncertainty::from_fit_table(file.fit.as_ref())
                .map_err(|e| anyhow!("{}: {e}", args.params.display()))?
                .ok_or_else(|| {
                    anyhow!(
                        "{}: --band: expected a [fit.uncertainty] table (written by supine fit)",
                        args.params.display()
                    )
                })?;
            let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
            Some(head_exposure_band(
                &params,
                &uncertainty,
                &recording,
                draws,
                args.band_seed,
                threads,
            )?)
        }
        None => None,
    };
    let predicted = predict(&params, &recording)?;
    let joints = predict_joints(&params, &recording)?;
    write_prediction(&recording, predicted, &joints, &args.out)?;
    eprintln!("wrote {} ({} samples)", args.out.display(), recording.len());
    if let Some(band) = &band {
        print!("{}", band_table(band));
    }
    Ok(())
}
