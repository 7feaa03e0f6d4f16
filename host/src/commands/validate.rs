//! `supine validate`: measured against predicted sensor accelerations of one recording,
//! per channel and as the paper's R^2 (see `validate`).

use std::path::PathBuf;

use anyhow::Result;

use crate::commands::json_output::JsonFlag;
use crate::identify::validate::{predict, table, validate, write_report};
use crate::io::output_folder;
use crate::io::params_file::ModelSource;
use crate::io::recording::Recording;
use crate::io::subject_args::SubjectArgs;

/// Arguments of `supine validate`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Which parameters (`supine fit` writes a file for --params).
    #[command(flatten)]
    pub source: ModelSource,
    /// The recording to compare with (`--recording` is an older spelling).
    #[arg(long, value_name = "REC.csv", alias = "recording")]
    pub input: PathBuf,
    /// Print the comparison as JSON instead of a table.
    #[command(flatten)]
    pub json: JsonFlag,
    /// A folder for the PSD plots (psd.svg) and the JSON (validation.json); a folder
    /// holding files supine did not write is refused, see --force.
    #[arg(long)]
    pub report: Option<PathBuf>,
    /// Write into the folder even if it holds files supine did not write there (those
    /// are kept).
    #[arg(long)]
    pub force: bool,
    /// The subject, if not the parameters' own.
    #[command(flatten)]
    pub subject: SubjectArgs,
}

/// Predicts, compares, prints.
pub fn run(args: &Args) -> Result<()> {
    let params = args.subject.load_from(&args.source)?;
    let recording = Recording::read(&args.input)?;
    let predicted = predict(&params, &recording)?;
    let result = validate(&recording, &predicted);
    let json = serde_json::to_string_pretty(&result)?;
    if let Some(dir) = &args.report {
        let folder = output_folder::claim(dir, "supine validate", "--report", args.force)?;
        write_report(dir, &recording, &predicted, &json)?;
        folder.record_new_entries()?;
    }
    if args.json.json {
        println!("{}", serde_json::to_string(&result)?);
    } else {
        print!("{}", table(&result));
    }
    Ok(())
}
