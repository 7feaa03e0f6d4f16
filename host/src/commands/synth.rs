//! `supine synth`: a synthetic dataset from the model (see `synth` for how it is made).

use std::path::PathBuf;

use anyhow::{Result, bail};

use crate::commands::json_output::{self, JsonFlag};
use crate::commands::values;
use crate::identify::identify_records::SynthSummary;
use crate::identify::synth::{SynthSettings, write_dataset};
use crate::io::output_folder;

/// Arguments of `supine synth`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// The dataset folder to write (created if missing; a folder holding files supine did
    /// not write is refused, see --force).
    #[arg(long)]
    pub out: PathBuf,
    /// Write into the folder even if it holds files supine did not write there (those
    /// are kept).
    #[arg(long)]
    pub force: bool,
    /// Number of subjects.
    #[arg(long, default_value_t = 8)]
    pub subjects: usize,
    /// Seed of every random draw.
    #[arg(long, default_value_t = values::DEFAULT_SEED)]
    pub seed: u64,
    /// Length of each recording, s.
    #[arg(long, default_value_t = values::DEFAULT_DURATION_S)]
    pub duration_s: f64,
    /// Sample rate of the recordings, Hz (200: the laboratory's, as in the paper).
    #[arg(long = "fs", value_name = "HZ", default_value_t = SynthSettings::default().sample_rate_hz)]
    pub fs_hz: f64,
    /// Standard deviation of the white noise on every channel, m/s^2.
    #[arg(long, default_value_t = 0.01)]
    pub noise_m_s2: f64,
    /// Spread of the subjects' parameters: each is the paper's value times e^N(0, this).
    #[arg(long, default_value_t = SynthSettings::default().param_log_sd)]
    pub param_log_sd: f64,
    /// Correlation of any two of a subject's ln-parameters, 0 (independent) to below 1.
    #[arg(long, default_value_t = SynthSettings::default().param_correlation)]
    pub param_correlation: f64,
    /// Print what was written as JSON.
    #[command(flatten)]
    pub json: JsonFlag,
}

/// Writes the dataset.
pub fn run(args: &Args) -> Result<()> {
    let rho = args.param_correlation;
    if !(0.0..1.0).contains(&rho) {
        bail!("--param-correlation: expected a number in [0, 1), found {rho}");
    }
    let settings = SynthSettings {
        subjects: args.subjects,
        seed: args.seed,
        duration_s: args.duration_s,
        sample_rate_hz: args.fs_hz,
        noise_m_s2: args.noise_m_s2,
        param_log_sd: args.param_log_sd,
        param_correlation: rho,
        ..SynthSettings::default()
    };
    let folder = output_folder::claim(&args.out, "supine synth", "--out", args.force)?;
    let bar = indicatif::ProgressBar::new((2 * args.subjects) as u64);
    bar.set_style(
        indicatif::ProgressStyle::with_template("synth {bar:30} {pos}/{len} recordings")
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    let subjects = folder.write_or_undo(|folder| {
        let subjects = write_dataset(&args.out, &settings, |done, _| {
            bar.set_position(done as u64)
        })?;
        folder.record_new_entries()?;
        Ok(subjects)
    });
    bar.finish_and_clear();
    let subjects = subjects?;
    if args.json.json {
        return json_output::print(&SynthSummary {
            out: args.out.clone(),
            subjects: subjects.len(),
            cases: 2,
            duration_s: args.duration_s,
            sample_rate_hz: args.fs_hz,
            seed: args.seed,
            truth: args.out.join("truth"),
        });
    }
    eprintln!(
        "wrote {} subjects x 2 cases ({} s at {} Hz) to {}, true parameters in {}/truth",
        subjects.len(),
        args.duration_s,
        args.fs_hz,
        args.out.display(),
        args.out.display()
    );
    Ok(())
}
