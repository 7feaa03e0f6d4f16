//! `supine exposure`'s model form: a ride's platform columns through the device's whole
//! chain ([`DeviceParams::process`]: sensor checks, model, weighting and exposure, alerts;
//! run by [`ModelRun`]), then `ExposureSettings::values` of the final state, the alert
//! timeline and the joints. The ride is read row by row: memory holds the evaluation's
//! state and a chunk of samples, whatever the ride's length (`docs/architecture.md`,
//! "Reading rides"). Its text form is in [`crate::exposure::exposure_text`].

use anyhow::Result;
use serde::Serialize;
use supine_core::alerts::Level;
use supine_core::blob::DeviceParams;

use crate::device::device_params;
use crate::exposure::evaluation_input::{EvaluationInput, check_warmup};
use crate::exposure::joints::{JointReport, JointTracker};
use crate::exposure::model_run::{ModelRun, Step};
use crate::exposure::reported_values::{AxisReport, ThresholdsReport, tidy};
use crate::exposure::timed_event::TimedEvent;
use crate::io::params_file::ParamFile;
use crate::io::recording::Layout;
use crate::io::ride_rows::RideSource;
use crate::parallel::read_ahead;
use crate::ride::quality::DataQuality;

/// Predicted head exposure of a ride: the device pipeline over the platform columns.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ModelExposure {
    /// Always `model`.
    pub form: &'static str,
    /// The recording.
    pub input: String,
    /// Which columns the file held.
    pub layout: Layout,
    /// The model: a preset's name or the parameter file.
    pub model: String,
    /// The parameter set's identity (hex), as the device reports it.
    pub identity: String,
    /// Evaluation sample rate, Hz.
    pub sample_rate_hz: f64,
    /// The recording's own rate, when it was resampled to `sample_rate_hz`, Hz.
    pub resampled_from_hz: Option<f64>,
    /// Samples evaluated.
    pub samples: usize,
    /// Samples over the rate, s.
    pub duration_s: f64,
    /// Warm-up excluded from rms, MTVV, VDV, peak and crest factor, s.
    pub warmup_s: f64,
    /// Evaluated time after the warm-up, s.
    pub evaluated_s: f64,
    /// The warm-up is over: the values mean what they say.
    pub valid: bool,
    /// Unweighted rms of the (resampled) platform input per axis x, y, z, m/s^2.
    pub platform_rms_m_s2: [f64; 3],
    /// Predicted head x (longitudinal), y (lateral), z (vertical), weighted.
    pub head: [AxisReport; 3],
    /// The vector sum of the three weighted head axes (k per the parameter file).
    pub vector: AxisReport,
    /// Thresholds of the alert stage.
    pub thresholds: ThresholdsReport,
    /// Level changes and sensor faults, in sample order (the first
    /// [`MAX_LISTED_EVENTS`](crate::exposure::model_run::MAX_LISTED_EVENTS)).
    pub alerts: Vec<TimedEvent>,
    /// Events after the listed ones, counted only (absent when none).
    #[serde(skip_serializing_if = "none_omitted")]
    pub alerts_omitted: usize,
    /// Highest exposure level reached.
    pub max_level: Level,
    /// Exposure level after the last sample.
    pub final_level: Level,
    /// The predicted neck and lower-back motion over the ride after the warm-up (as the
    /// head's and the device's: the model's start-up transient is not motion of the ride);
    /// empty when the model is not known.
    pub joints: Vec<JointReport>,
    /// The ride's data-quality account (a logger's file; null for a recording).
    pub data_quality: Option<DataQuality>,
}

/// No event was left out of a list (serde's test for leaving the count out).
pub fn none_omitted(n: &usize) -> bool {
    *n == 0
}

/// The model form of `supine exposure` on `input` with the parameters of `file` (built at
/// its rate; `model` names them), in one pass; `observe` sees every pipeline output
/// (the report's charts and spectra). Also gives the device parameters it ran.
pub fn evaluate_model_with(
    input: &EvaluationInput<'_>,
    file: &ParamFile,
    model: String,
    mut observe: impl FnMut(Step<'_>),
) -> Result<(ModelExposure, DeviceParams)> {
    let fs = input.sample_rate_hz;
    let params = device_params::build(file, fs)?;
    let identity = device_params::identity_hex(&params.identity);
    let name = input.source().path().display().to_string();
    let warmup_s = params.exposure.config.warmup_s as f64;
    check_warmup(&name, input.samples, fs, warmup_s)?;
    let joints = JointTracker::new(&file.params, fs, &params.exposure)?;
    let mut run = ModelRun::new(&params, Some(joints), input.start_s);
    // The ride is read on a thread of its own while the pipeline runs on this one.
    read_ahead(|| input.platform(), |sample| run.push(sample, &mut observe))?;
    let outcome = run.finish(&mut observe);
    let n = outcome.samples;
    let values = &outcome.values;
    let kinds = params.exposure.config.axes.axes().map(|a| a.kind.name());
    let report = ModelExposure {
        form: "model",
        input: name,
        layout: input.source().layout(),
        model,
        identity,
        sample_rate_hz: fs,
        resampled_from_hz: input.resampled_from_hz,
        samples: n,
        duration_s: n as f64 / fs,
        warmup_s,
        evaluated_s: tidy(values.duration_s),
        valid: values.valid,
        platform_rms_m_s2: outcome.platform_rms_m_s2,
        head: [0, 1, 2].map(|i| AxisReport::new(kinds[i], &values.axes[i])),
        vector: AxisReport::new("vector", &values.vector),
        thresholds: (&params.alerts.config).into(),
        alerts: outcome.events,
        alerts_omitted: outcome.events_omitted,
        max_level: outcome.max_level,
        final_level: outcome.final_level,
        joints: outcome.joints,
        data_quality: input.source().quality().cloned(),
    };
    Ok((report, params))
}

/// `supine exposure`'s model form on `source`: its platform columns at `fs_hz` (else its
/// own rate) through the device parameters of `file`, built at that rate; `model` names
/// the parameters in the report.
pub fn evaluate_model(
    source: &RideSource,
    file: &ParamFile,
    model: String,
    fs_hz: Option<f64>,
) -> Result<ModelExposure> {
    let input = EvaluationInput::new(source, fs_hz)?;
    Ok(evaluate_model_with(&input, file, model, |_| {})?.0)
}
