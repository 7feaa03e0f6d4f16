//! `supine model`: the model's transmissibility H(f), all 27 components, or with
//! `--quantity joints` its joint response (ten joint outputs by three inputs), as CSV.

use std::path::PathBuf;

use anyhow::{Result, anyhow};
use supine_core::model::SystemMatrices;

use crate::commands::json_output::{self, JsonFlag};
use crate::commands::values;
use crate::identify::identify_records::ModelResponseSummary;
use crate::identify::transmissibility::model_h;
use crate::io::h_csv;
use crate::io::params_file::ModelSource;
use crate::io::subject_args::SubjectArgs;

/// What `supine model` writes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Quantity {
    /// Sensor acceleration per support acceleration (m/s^2 per m/s^2), 9 x 3.
    Sensors,
    /// Joint motion per support acceleration (m or rad per m/s^2), 10 x 3.
    Joints,
}

/// Arguments of `supine model`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Which parameters.
    #[command(flatten)]
    pub source: ModelSource,
    /// The subject, if not the parameters' own.
    #[command(flatten)]
    pub subject: SubjectArgs,
    /// Lowest frequency, Hz (above 0: H is the static response there, 1 on matching axes).
    #[arg(long = "fmin", value_name = "HZ", default_value_t = 0.5, value_parser = values::positive_hz)]
    pub fmin_hz: f64,
    /// Highest frequency, Hz (above --fmin).
    #[arg(long = "fmax", value_name = "HZ", default_value_t = 16.0, value_parser = values::positive_hz)]
    pub fmax_hz: f64,
    /// Frequency step, Hz (at most 100,000 frequencies).
    #[arg(long = "df", value_name = "HZ", default_value_t = 0.05, value_parser = values::positive_hz)]
    pub df_hz: f64,
    /// Sensor accelerations (the paper's H) or the neck and lower-back motion.
    #[arg(long, value_enum, default_value_t = Quantity::Sensors)]
    pub quantity: Quantity,
    /// Where to write the CSV.
    #[arg(long)]
    pub out: PathBuf,
    /// Print what was written as JSON.
    #[command(flatten)]
    pub json: JsonFlag,
}

/// Writes H at every grid frequency for the chosen parameters.
pub fn run(args: &Args) -> Result<()> {
    let params = args.subject.load_from(&args.source)?;
    let freqs = h_csv::frequency_grid(args.fmin_hz, args.fmax_hz, args.df_hz)?;
    let rows = match args.quantity {
        Quantity::Sensors => h_csv::rows(&freqs, &model_h(&params, &freqs)?, None),
        Quantity::Joints => {
            let matrices = SystemMatrices::assemble(&params);
            let h = freqs
                .iter()
                .map(|&f| matrices.joint_response(f))
                .collect::<Result<Vec<_>, _>>()
                .map_err(|e| anyhow!("{e}"))?;
            h_csv::joint_rows(&freqs, &h)
        }
    };
    h_csv::write(&args.out, &rows)?;
    if args.json.json {
        return json_output::print(&ModelResponseSummary {
            out: args.out.clone(),
            frequencies: freqs.len(),
            components: rows.len() / freqs.len().max(1),
            fmin_hz: freqs.first().copied(),
            fmax_hz: freqs.last().copied(),
            df_hz: args.df_hz,
        });
    }
    eprintln!(
        "wrote {} ({} frequencies x {} components)",
        args.out.display(),
        freqs.len(),
        rows.len() / freqs.len().max(1)
    );
    Ok(())
}
