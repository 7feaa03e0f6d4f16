//! `supine predict`, in two forms by what it is given:
//! - a lab recording (the project's 13 columns, with the measured sensors): the sensor
//!   accelerations and the neck and lower-back motion the model predicts for its support
//!   acceleration (see `validate::predict` for how it stays faithful to the continuous
//!   model), and with `--band N` the head exposure's prediction band from the fit's
//!   uncertainty (see `fit::band`);
//! - a ride (any logger's file, or any ride option given): every sample's predicted head,
//!   its weighted running rms, VDV and level, and the joint outputs, as the report's
//!   pipeline computes them ([`crate::exposure::ride_prediction`]), in the telemetry CSV
//!   `supine replay --qemu` writes of the device.

use std::path::PathBuf;

use anyhow::{Result, bail};

use crate::commands::band_args::{BandArgs, band_threads};
use crate::commands::json_output::{self, JsonFlag};
use crate::exposure::exposure_records::RidePredictionSummary;
use crate::exposure::ride_prediction::predict_ride;
use crate::identify::fit::band::{BAND_QUANTILES, ExposureBand, head_exposure_band};
use crate::identify::identify_records::LabPredictionSummary;
use crate::identify::validate::{predict, predict_joints, write_prediction};
use crate::io::params_file::ModelSource;
use crate::io::recording::Recording;
use crate::io::ride_input::RideInputArgs;
use crate::io::stdout::print_text;
use crate::io::subject_args::SubjectArgs;

/// Arguments of `supine predict`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Which parameters (`supine fit` writes a file for --params; --band needs one).
    #[command(flatten)]
    pub source: ModelSource,
    /// The lab recording, or the ride, whose platform acceleration drives the model.
    #[arg(long, value_name = "REC.csv")]
    pub input: PathBuf,
    /// How to read a ride (another logger's columns and units, gravity, a window).
    #[command(flatten)]
    pub ride: RideInputArgs,
    /// Where to write the prediction (a lab recording: its columns, then the joint
    /// motion; a ride: the telemetry CSV, and its alert events beside it).
    #[arg(long, value_name = "PRED.csv")]
    pub out: PathBuf,
    /// The subject, if not the parameters' own.
    #[command(flatten)]
    pub subject: SubjectArgs,
    /// The head exposure's prediction band (printed with the table, or in the JSON).
    #[command(flatten)]
    pub band: BandArgs,
    /// Print what was written, and the band, as JSON.
    #[command(flatten)]
    pub json: JsonFlag,
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
    if !args.ride.reads_lab_recording(&args.input)? {
        return run_ride(args);
    }
    let mut file = args.source.load()?;
    args.subject.apply(&mut file)?;
    let params = file.params;
    let recording = Recording::read(&args.input)?;
    let band = match args.band.request(&args.source, &file)? {
        Some(request) => Some(head_exposure_band(
            &params,
            &request.uncertainty,
            &recording,
            request.draws,
            request.seed,
            band_threads(),
        )?),
        None => None,
    };
    let predicted = predict(&params, &recording)?;
    let joints = predict_joints(&params, &recording)?;
    write_prediction(&recording, predicted, &joints, &args.out)?;
    if args.json.json {
        return json_output::print(&LabPredictionSummary {
            out: args.out.clone(),
            samples: recording.len(),
            head_exposure_band: band.as_ref().map(Into::into),
        });
    }
    eprintln!("wrote {} ({} samples)", args.out.display(), recording.len());
    match &band {
        Some(band) => print_text(&band_table(band)),
        None => Ok(()),
    }
}

/// A ride's prediction: the report's pipeline, every sample written.
fn run_ride(args: &Args) -> Result<()> {
    if args.band.band.is_some() {
        bail!(
            "--band: {} is a ride; the prediction band needs a lab recording (the project's 13 columns)",
            args.input.display()
        );
    }
    let mut file = args.source.load_for_ride()?;
    args.subject.apply(&mut file)?;
    let frame = file.device.unwrap_or_default().sensor_frame();
    let source = args.ride.open(&args.input, &frame)?;
    let prediction = predict_ride(
        &source,
        &file,
        args.source.model_name(),
        args.ride.fs_hz,
        &args.out,
    )?;
    let exposure = &prediction.exposure;
    if args.json.json {
        return json_output::print(&RidePredictionSummary::from(&prediction));
    }
    eprintln!(
        "wrote {} ({} samples at {} Hz) and {} ({} alert events)",
        prediction.telemetry_csv.display(),
        exposure.samples,
        exposure.sample_rate_hz,
        prediction.events_csv.display(),
        prediction.events
    );
    Ok(())
}
