//! `supine model`: the model's transmissibility H(f), all 27 components, as CSV.

use std::path::PathBuf;

use anyhow::Result;

use crate::commands::json_output::{self, JsonFlag};
use crate::commands::values;
use crate::identify::transmissibility::model_h;
use crate::io::h_csv;
use crate::io::params_file::{ModelSource, SubjectOverride};

/// Arguments of `supine model`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Which parameters.
    #[command(flatten)]
    pub source: ModelSource,
    /// The subject, if not the parameters' own.
    #[command(flatten)]
    pub subject: SubjectOverride,
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
    /// Print what was written as JSON.
    #[command(flatten)]
    pub json: JsonFlag,
}

/// Writes H at every grid frequency for the chosen parameters.
pub fn run(args: &Args) -> Result<()> {
    let params = args.source.load_for_subject(&args.subject)?;
    let freqs = h_csv::frequency_grid(args.fmin_hz, args.fmax_hz, args.df_hz)?;
    let h = model_h(&params, &freqs)?;
    let rows = h_csv::rows(&freqs, &h, None);
    h_csv::write(&args.out, &rows)?;
    if args.json.json {
        return json_output::print(&serde_json::json!({
            "out": args.out,
            "frequencies": freqs.len(),
            "components": 27,
            "fmin_hz": freqs.first(),
            "fmax_hz": freqs.last(),
            "df_hz": args.df_hz,
        }));
    }
    eprintln!(
        "wrote {} ({} frequencies x 27 components)",
        args.out.display(),
        freqs.len()
    );
    Ok(())
}
