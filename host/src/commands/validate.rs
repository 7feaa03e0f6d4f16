//! `supine validate`: measured against predicted sensor accelerations of one recording,
//! per channel and as the paper's R^2 (see `validate`).

use std::path::PathBuf;

use anyhow::Result;

use crate::identify::validate::{predict, table, validate, write_report};
use crate::io::params_file;
use crate::io::recording::Recording;

/// Arguments of `supine validate`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// The parameter file (as `supine fit` writes).
    #[arg(long, value_name = "FILE")]
    pub params: PathBuf,
    /// The recording to compare with.
    #[arg(long, value_name = "REC.csv")]
    pub recording: PathBuf,
    /// Print JSON instead of a table.
    #[arg(long)]
    pub json: bool,
    /// A folder for the PSD plots (psd.svg) and the JSON (validation.json).
    #[arg(long)]
    pub report: Option<PathBuf>,
    /// Override the subject's height, m.
    #[arg(long)]
    pub height_m: Option<f64>,
    /// Override the subject's mass, kg.
    #[arg(long)]
    pub mass_kg: Option<f64>,
}

/// Predicts, compares, prints.
pub fn run(args: &Args) -> Result<()> {
    let params = params_file::load_for_subject(&args.params, args.height_m, args.mass_kg)?;
    let recording = Recording::read(&args.recording)?;
    let predicted = predict(&params, &recording)?;
    let result = validate(&recording, &predicted);
    let json = serde_json::to_string_pretty(&result)?;
    if let Some(dir) = &args.report {
        write_report(dir, &recording, &predicted, &json)?;
    }
    if args.json {
        println!("{json}");
    } else {
        print!("{}", table(&result));
    }
    Ok(())
}
