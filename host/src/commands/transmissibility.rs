//! `supine transmissibility`: the measured H of a dataset's case (see
//! [`crate::identify::transmissibility`]), written in `supine model`'s CSV format; one
//! subject's file adds the multiple coherence of each output.

use std::path::PathBuf;

use anyhow::Result;

use crate::commands::json_output::{self, JsonFlag};
use crate::commands::values;
use crate::identify::identify_records::TransmissibilitySummary;
use crate::identify::spectral::DEFAULT_RESOLUTION_HZ;
use crate::identify::transmissibility::estimate;
use crate::io::dataset::{Case, Dataset};
use crate::io::h_csv::{self, rows};
use crate::io::wording::count;

/// Arguments of `supine transmissibility`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// The dataset folder (with dataset.toml).
    #[arg(long)]
    pub dataset: PathBuf,
    /// Which case's recordings.
    #[arg(long, value_enum)]
    pub case: Case,
    /// One subject only (the file then adds a coherence column).
    #[arg(long, conflicts_with = "exclude")]
    pub subject: Option<String>,
    /// Subjects to leave out of the mean, comma-separated (e.g. s8 or "s1, s2").
    #[arg(long, value_name = "S1,S2")]
    pub exclude: Vec<String>,
    /// Frequency resolution, Hz: the Welch segment is the smallest power of two giving it.
    #[arg(long, default_value_t = DEFAULT_RESOLUTION_HZ)]
    pub resolution_hz: f64,
    /// Lowest frequency written, Hz.
    #[arg(long = "fmin", value_name = "HZ", default_value_t = 0.5, value_parser = values::positive_hz)]
    pub fmin_hz: f64,
    /// Highest frequency written, Hz.
    #[arg(long = "fmax", value_name = "HZ", default_value_t = 16.0, value_parser = values::positive_hz)]
    pub fmax_hz: f64,
    /// Where to write the CSV.
    #[arg(long)]
    pub out: PathBuf,
    /// Print a summary of the estimate as JSON.
    #[command(flatten)]
    pub json: JsonFlag,
}

/// Estimates and writes the CSV.
pub fn run(args: &Args) -> Result<()> {
    let exclude = values::comma_list("--exclude", &args.exclude)?;
    let dataset = Dataset::load(&args.dataset)?;
    let est = estimate(
        &dataset,
        args.case,
        args.subject.as_deref(),
        &exclude,
        args.resolution_hz,
        args.fmin_hz,
        args.fmax_hz,
    )?;
    let rows = match &args.subject {
        Some(_) => {
            let s = &est.subjects[0].estimate;
            rows(&s.freqs_hz, &s.h, Some(&s.coherence))
        }
        None => rows(&est.freqs_hz, &est.geomean, None),
    };
    h_csv::write(&args.out, &rows)?;
    if args.json.json {
        return json_output::print(&TransmissibilitySummary::new(&est, args.out.clone()));
    }
    eprintln!(
        "wrote {} ({}, {} frequencies at {:.4} Hz: Hann, {} samples, {} overlap, {} segments)",
        args.out.display(),
        count(est.subjects.len(), "subject"),
        est.freqs_hz.len(),
        est.settings.resolution_hz(est.sample_rate_hz),
        est.settings.segment_len,
        est.settings.overlap,
        est.subjects[0].estimate.segments
    );
    Ok(())
}
