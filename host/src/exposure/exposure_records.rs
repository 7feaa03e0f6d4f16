//! What the exposure commands print with `--json` about the files they wrote (`supine
//! weighting`, `predict` on a ride): one record type per command, each field documented
//! once with its unit. The keys follow the naming rules of [`crate::schema`] (checked by
//! `host/tests/output_names.rs`); the commands only fill these in.

use std::path::PathBuf;

use serde::Serialize;

use crate::exposure::ride_prediction::RidePrediction;
use crate::ride::quality::DataQuality;

/// `supine weighting --json`: the weighting's response written.
#[derive(Clone, Debug, Serialize)]
pub struct WeightingResponseSummary {
    /// The CSV.
    pub out: PathBuf,
    /// Frequencies written (the standard's one-third-octave centres).
    pub frequencies: usize,
    /// The weighting (`wk`, `wd`...).
    pub weighting: String,
    /// The sample rate of the digital filter, Hz.
    pub sample_rate_hz: f32,
}

/// `supine predict --json` on a ride: the telemetry and events CSVs written.
#[derive(Clone, Debug, Serialize)]
pub struct RidePredictionSummary<'a> {
    /// The telemetry CSV.
    pub out: &'a PathBuf,
    /// The alert events CSV beside it.
    pub events_csv: &'a PathBuf,
    /// Samples evaluated.
    pub samples: usize,
    /// Their sample rate, Hz.
    pub sample_rate_hz: f64,
    /// Alert events written.
    pub alert_events: usize,
    /// What the ride's data quality check found (null for a generated ride).
    pub data_quality: Option<&'a DataQuality>,
}

impl<'a> From<&'a RidePrediction> for RidePredictionSummary<'a> {
    fn from(p: &'a RidePrediction) -> Self {
        Self {
            out: &p.telemetry_csv,
            events_csv: &p.events_csv,
            samples: p.exposure.samples,
            sample_rate_hz: p.exposure.sample_rate_hz,
            alert_events: p.events,
            data_quality: p.exposure.data_quality.as_ref(),
        }
    }
}
