//! `supine predict` of a ride: the report's pipeline, sample by sample, written out.
//!
//! A ride (any logger's file, or the project's recording read as a ride) goes through
//! [`evaluate_model_with`], the very pass `supine report` and `supine exposure` make: the
//! same conditioning, resampling, levelling and device chain ([`ModelRun`], f32, what
//! the device computes). Every sample's telemetry is written to the telemetry CSV that
//! `supine replay --qemu` writes of the device itself (so the two files can be compared
//! row for row), and every alert event to its events CSV; nothing is held in memory
//! but the pipeline's state, whatever the ride's length.
//!
//! [`ModelRun`]: crate::exposure::model_run::ModelRun

use std::io::Write as _;
use std::path::{Path, PathBuf};

use anyhow::{Result, anyhow};
use supine_core::alerts::AlertEvent;

use crate::exposure::evaluation_input::EvaluationInput;
use crate::exposure::model_exposure::{ModelExposure, evaluate_model_with};
use crate::exposure::model_run::Step;
use crate::io::output::write_atomically;
use crate::io::params_file::ParamFile;
use crate::io::ride_rows::RideSource;
use crate::io::telemetry_csv::{EVENTS_HEADER, event_row, events_path, write_telemetry_streamed};

/// What a ride's prediction wrote, and the exposure the same pass computed.
pub struct RidePrediction {
    /// The telemetry CSV, one row per evaluated sample.
    pub telemetry_csv: PathBuf,
    /// The alert events CSV beside it.
    pub events_csv: PathBuf,
    /// Alert events written (all of them: the events CSV is not capped as the report's
    /// list is).
    pub events: usize,
    /// The exposure of the same pass (what `supine exposure --json` prints).
    pub exposure: ModelExposure,
}

/// Predicts the head, its exposure and the joints for every sample of `source` at
/// `fs_hz` (else its own rate) with the parameters of `file`, writing the telemetry CSV
/// to `out` and the events CSV beside it, each whole or not at all.
pub fn predict_ride(
    source: &RideSource,
    file: &ParamFile,
    model: String,
    fs_hz: Option<f64>,
    out: &Path,
) -> Result<RidePrediction> {
    let input = EvaluationInput::new(source, fs_hz)?;
    let fs = input.sample_rate_hz;
    let joint_mask = file.device.unwrap_or_default().joint_outputs.mask;
    let events_csv = events_path(out);
    let mut events = 0usize;
    let mut exposure = None;
    write_atomically(&events_csv, |event_writer| {
        writeln!(event_writer, "{EVENTS_HEADER}")?;
        exposure = Some(write_telemetry_streamed(out, fs, joint_mask, |emit| {
            // The observer cannot return an error: the first one stops the writing and
            // is returned once the pass is over.
            let mut failed: Option<anyhow::Error> = None;
            let (report, _) = evaluate_model_with(&input, file, model, |step| {
                if failed.is_some() {
                    return;
                }
                let written = match step {
                    Step::Sample { telemetry, .. } => emit(telemetry),
                    Step::Alert(event) => {
                        events += 1;
                        write_event(event_writer, event, fs)
                    }
                };
                if let Err(e) = written {
                    failed = Some(e);
                }
            })?;
            match failed {
                Some(e) => Err(e),
                None => Ok(report),
            }
        })?);
        Ok(())
    })?;
    Ok(RidePrediction {
        telemetry_csv: out.to_path_buf(),
        events_csv,
        events,
        exposure: exposure.ok_or_else(|| anyhow!("{}: nothing was written", out.display()))?,
    })
}

fn write_event(w: &mut impl std::io::Write, event: &AlertEvent, fs: f64) -> Result<()> {
    Ok(w.write_all(event_row(event, fs).as_bytes())?)
}
