//! `supine exposure`: ISO 2631-1 exposure of a recording, in two forms.
//! - Model form (`--preset NAME | --params FILE`): the predicted head exposure of a ride,
//!   the device's own pipeline over the recording's platform columns, with the alert
//!   timeline (see [`crate::exposure::model_exposure::evaluate_model`]).
//! - Channel form (`--channel COLUMN --weighting wk|wd|wj`): one recorded channel,
//!   weighted and evaluated without a model.
//!
//! The recording's own sample rate is used; `--fs HZ` converts it first with the
//! band-limited, zero-phase resampler of [`crate::ride::resample`]. The ride is read
//! row by row ([`crate::io::ride_rows`]): memory does not grow with its length, with
//! `--fs` too.

use std::io::Write;
use std::path::PathBuf;

use anyhow::Result;
use clap::ArgGroup;
use supine_core::calibration::SensorFrame;

use crate::commands::weighting::Kind;
use crate::exposure::channel_exposure::evaluate_channel;
use crate::exposure::model_exposure::evaluate_model;
use crate::io::params_file::{ModelSource, PresetArg};
use crate::io::ride_input::RideInputArgs;
use crate::io::stdout::stdout_error;
use crate::io::subject_args::SubjectArgs;

/// Arguments of `supine exposure`.
#[derive(Debug, clap::Args)]
#[command(group(
    ArgGroup::new("form").args(["preset", "params", "channel"])
))]
pub struct Args {
    /// Model form: one of the paper's parameter sets.
    #[arg(long, value_enum, conflicts_with_all = ["params", "channel", "weighting"])]
    pub preset: Option<PresetArg>,
    /// Model form: a parameter file (TOML; its optional `[device]` table sets the
    /// weighting per axis, the alert thresholds and the sensor checks).
    #[arg(long, value_name = "FILE", conflicts_with_all = ["channel", "weighting"])]
    pub params: Option<PathBuf>,
    /// The recording (CSV in the recording format, its platform columns only, or another
    /// logger's file with --columns).
    #[arg(long, value_name = "REC.csv")]
    pub input: PathBuf,
    /// How to read the ride (another logger's columns and units, gravity).
    #[command(flatten)]
    pub ride: RideInputArgs,
    /// Model form: the patient (else the parameters' subject).
    #[command(flatten)]
    pub subject: SubjectArgs,
    /// Channel form: the column to evaluate (e.g. head_z, platform_z).
    #[arg(long, value_name = "COLUMN", requires = "weighting")]
    pub channel: Option<String>,
    /// Channel form: the weighting to apply to the channel.
    #[arg(long, value_enum, requires = "channel")]
    pub weighting: Option<Kind>,
    /// Print one JSON object instead of the table.
    #[arg(long)]
    pub json: bool,
}

/// Evaluates and writes the report (table or JSON) to `out`.
pub fn run_to(args: &Args, out: &mut impl Write) -> Result<()> {
    let text = match (&args.channel, args.weighting) {
        (Some(channel), Some(kind)) => {
            // No parameters: a raw reading is taken as level-mounted.
            let ride = args.ride.open(&args.input, &SensorFrame::LEVEL)?;
            let report = evaluate_channel(&ride, channel, kind.into(), args.ride.fs_hz)?;
            if args.json {
                serde_json::to_string(&report)? + "\n"
            } else {
                report.to_text()
            }
        }
        _ => {
            let source = ModelSource {
                preset: args.preset,
                params: args.params.clone(),
            };
            let model = source.model_name();
            let mut file = source.load_for_ride()?;
            args.subject.apply(&mut file)?;
            let frame = file.device.unwrap_or_default().sensor_frame();
            let ride = args.ride.open(&args.input, &frame)?;
            let report = evaluate_model(&ride, &file, model, args.ride.fs_hz)?;
            if args.json {
                serde_json::to_string(&report)? + "\n"
            } else {
                report.to_text()
            }
        }
    };
    out.write_all(text.as_bytes())
        .and_then(|()| out.flush())
        .map_err(stdout_error)
}

/// Evaluates and prints the report on standard output.
pub fn run(args: &Args) -> Result<()> {
    run_to(args, &mut std::io::stdout().lock())
}
