//! `supine predict`: the sensor accelerations the model predicts for a recording's support
//! acceleration (see `validate::predict` for how it stays faithful to the continuous model).

use std::path::PathBuf;

use anyhow::Result;

use crate::identify::validate::{predict, write_prediction};
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
    /// Where to write the prediction (same columns as a recording).
    #[arg(long, value_name = "PRED.csv")]
    pub out: PathBuf,
    /// Override the subject's height, m.
    #[arg(long)]
    pub height_m: Option<f64>,
    /// Override the subject's mass, kg.
    #[arg(long)]
    pub mass_kg: Option<f64>,
}

/// Predicts and writes the CSV.
pub fn run(args: &Args) -> Result<()> {
    let params = params_file::load_for_subject(&args.params, args.height_m, args.mass_kg)?;
    let recording = Recording::read(&args.input)?;
    let predicted = predict(&params, &recording)?;
    write_prediction(&recording, predicted, &args.out)?;
    eprintln!("wrote {} ({} samples)", args.out.display(), recording.len());
    Ok(())
}
