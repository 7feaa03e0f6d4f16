//! Exposure reports for rides, computed by the same `supine-core` code the device runs,
//! reading the ride row by row: memory holds the evaluation's state and a chunk of
//! samples, whatever the ride's length (`docs/architecture.md`, "Reading rides").
//!
//! Two evaluations, both on `supine_core::exposure::ExposureSettings`:
//! - [`evaluate_model`]: the device's whole chain ([`DeviceParams::process`]: sensor checks,
//!   model, weighting and exposure, alerts) over a ride's platform columns ([`ModelRun`]),
//!   then `ExposureSettings::values` of the final state, and the alert timeline.
//! - [`evaluate_channel`]: one recorded channel (a head accelerometer, a test signal),
//!   weighted with Wk, Wd or Wj, no model: an `ExposureSettings` whose x axis carries the
//!   channel and whose other axes carry zeros, so the x axis' values are the channel's.
//!
//! Both need a sample rate the device supports ([`SampleRate`]); a ride at another
//! rate is converted first by the band-limited [`crate::exposure::resample`] (zero phase),
//! at the user's request only, as it is read ([`Resampler::stream`]).
//!
//! Rides come from [`RideSource`] (opened by [`crate::io::ride_input`]), which also
//! accepts a file with only the platform columns (what `supine ride` writes), its sensor
//! columns zeros that no evaluation here reads.

use crate::exposure::joints::{JointReport, JointTracker, joints_text};
use std::fmt::Write as _;
use std::path::Path;

use anyhow::{Result, anyhow, bail};
use serde::Serialize;
use supine_core::alerts::{AlertConfig, AlertEvent, Criterion, Level};
use supine_core::blob::{DeviceParams, TelemetryConfig};
use supine_core::exposure::{
    AxisMapping, AxisValues, AxisWeighting, ExposureConfig, ExposureSettings, ExposureState,
    ExposureValues,
};
use supine_core::pipeline::{PipelineOutput, PipelineState, Telemetry};
use supine_core::sample_rate::{SampleRate, SampleRateError};
use supine_core::weighting::WeightingKind;

use crate::device::device_params;
use crate::exposure::resample::Resampler;
use crate::io::params_file::ParamFile;
use crate::io::recording::{COLUMNS, Layout};
use crate::io::ride_rows::RideSource;
use crate::io::wording::joint_alert_text;
use crate::ride::quality::DataQuality;

/// Samples handed to the device pipeline per call (bounds the chunk buffer).
const CHUNK_SAMPLES: usize = 4096;
/// Most alert events a report lists: a sensor fault that comes and goes on every sample
/// would otherwise grow the list with the ride; the rest are counted, not kept.
pub const MAX_LISTED_EVENTS: usize = 1000;

/// A ride at the rate it is evaluated at, read sample by sample.
pub struct EvaluationInput<'a> {
    source: &'a RideSource,
    /// The evaluation's sample rate, Hz.
    pub sample_rate_hz: f64,
    /// The ride's own rate when it is converted, Hz.
    pub resampled_from_hz: Option<f64>,
    /// Time of the first sample, s (the ride's).
    pub start_s: f64,
    /// Samples at the evaluation's rate.
    pub samples: usize,
    resampler: Option<Resampler>,
}

impl<'a> EvaluationInput<'a> {
    /// `source` at `fs_hz` if given (band-limited, see [`crate::exposure::resample`]),
    /// else at its own rate, which must be one the device supports.
    pub fn new(source: &'a RideSource, fs_hz: Option<f64>) -> Result<Self> {
        let own_hz = source.sample_rate_hz();
        let path = source.path().display();
        if let Some(target_hz) = fs_hz.filter(|f| !SampleRate::supports_hz(*f)) {
            bail!("--fs {target_hz}: {SampleRateError}");
        }
        // `--fs` at the ride's own rate (to 1 ppm) changes nothing: no conversion.
        let fs_hz = fs_hz.filter(|f| (f - own_hz).abs() > 1e-6 * own_hz);
        let mut input = Self {
            source,
            sample_rate_hz: own_hz,
            resampled_from_hz: source.converted_from_hz(),
            start_s: source.start_s(),
            samples: source.len(),
            resampler: None,
        };
        match fs_hz {
            None if !SampleRate::supports_hz(own_hz) => bail!(
                "{path}: sample rate {own_hz:.6} Hz (from column time_s) is outside \
                 {}..={} Hz, the device's range; give --fs HZ to resample",
                SampleRate::MIN_HZ,
                SampleRate::MAX_HZ
            ),
            None => {}
            Some(target_hz) => {
                let resampler = Resampler::new(own_hz, target_hz)?;
                input.sample_rate_hz = target_hz;
                input.resampled_from_hz = Some(own_hz);
                input.samples = resampler.output_len(source.len());
                input.resampler = Some(resampler);
            }
        }
        Ok(input)
    }

    /// The ride.
    pub fn source(&self) -> &RideSource {
        self.source
    }

    /// The values of `columns` (indices in [`COLUMNS`]) of each sample at the evaluation's
    /// rate, read as they are taken (a resampled ride too: [`Resampler::stream`]; one too
    /// short for it is converted whole).
    pub fn columns<const K: usize>(
        &self,
        columns: [usize; K],
    ) -> Result<Box<dyn Iterator<Item = Result<[f64; K]>> + '_>> {
        let rows = self
            .source
            .rows()?
            .map(move |r| r.map(|row| columns.map(|c| row[c])));
        let Some(resampler) = &self.resampler else {
            return Ok(Box::new(rows));
        };
        if let Ok(stream) = resampler.stream(self.source.len(), rows) {
            return Ok(Box::new(stream));
        }
        let mut whole: [Vec<f64>; K] = std::array::from_fn(|_| Vec::new());
        for row in self.source.rows()? {
            let row = row?;
            for (column, c) in whole.iter_mut().zip(columns) {
                column.push(row[c]);
            }
        }
        let converted = whole.map(|c| resampler.process(&c));
        let n = converted.iter().map(Vec::len).min().unwrap_or(0);
        Ok(Box::new((0..n).map(move |k| {
            Ok(std::array::from_fn(|i| converted[i][k]))
        })))
    }

    /// The platform x, y, z of each sample at the evaluation's rate.
    pub fn platform(&self) -> Result<Box<dyn Iterator<Item = Result<[f64; 3]>> + '_>> {
        self.columns([1, 2, 3])
    }
}

/// Rounds an f32 to the shortest decimal that reads back as the same f32, as f64
/// (so 0.3f32 reports as 0.3, not 0.30000001192092896).
pub fn tidy(x: f32) -> f64 {
    format!("{x}").parse().unwrap_or(x as f64)
}

/// Which ISO 2631-1 criteria call for methods beyond the basic rms.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub struct AdditionalMethodsReport {
    /// Crest factor above 9.
    pub crest_factor: bool,
    /// `MTVV / a_w` above 1.5.
    pub mtvv_ratio: bool,
    /// `VDV / (a_w T^(1/4))` above 1.75.
    pub vdv_ratio: bool,
}

/// The evaluation of one weighted signal (an axis or the vector sum), SI units.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct AxisReport {
    /// The weighting applied (`wk`, `wd`, `wj`), or `vector` for the vector sum.
    pub weighting: &'static str,
    /// Overall weighted rms after the warm-up, m/s^2.
    pub rms_m_s2: f64,
    /// Maximum transient vibration value (largest 1 s running rms), m/s^2.
    pub mtvv_m_s2: f64,
    /// Vibration dose value `(integral a_w^4 dt)^(1/4)`, m/s^1.75.
    pub vdv_m_s175: f64,
    /// Largest |weighted acceleration| after the warm-up, m/s^2.
    pub peak_m_s2: f64,
    /// `peak / rms`.
    pub crest_factor: f64,
    /// Running rms at the last sample, m/s^2.
    pub running_rms_m_s2: f64,
    /// `MTVV / rms`.
    pub mtvv_ratio: f64,
    /// `VDV / (rms T^(1/4))`.
    pub vdv_ratio: f64,
    /// Which criteria call for the additional methods.
    pub additional_methods: AdditionalMethodsReport,
}

impl AxisReport {
    /// The core's values, labelled with their weighting.
    pub fn new(weighting: &'static str, v: &AxisValues) -> Self {
        Self {
            weighting,
            rms_m_s2: tidy(v.rms_m_s2),
            mtvv_m_s2: tidy(v.mtvv_m_s2),
            vdv_m_s175: tidy(v.vdv_m_s175),
            peak_m_s2: tidy(v.peak_m_s2),
            crest_factor: tidy(v.crest_factor),
            running_rms_m_s2: tidy(v.running_rms_m_s2),
            mtvv_ratio: tidy(v.mtvv_ratio),
            vdv_ratio: tidy(v.vdv_ratio),
            additional_methods: AdditionalMethodsReport {
                crest_factor: v.additional.crest_factor,
                mtvv_ratio: v.additional.mtvv_ratio,
                vdv_ratio: v.additional.vdv_ratio,
            },
        }
    }

    fn row(&self, label: &str) -> String {
        let a = self.additional_methods;
        let flags: Vec<&str> = [
            (a.crest_factor, "crest>9"),
            (a.mtvv_ratio, "MTVV/rms>1.5"),
            (a.vdv_ratio, "VDV-ratio>1.75"),
        ]
        .iter()
        .filter(|(on, _)| *on)
        .map(|(_, name)| *name)
        .collect();
        format!(
            "{label:<10} {:<8} {:>9.4} {:>9.4} {:>10.4} {:>9.4} {:>7.2}  {}",
            self.weighting,
            self.rms_m_s2,
            self.mtvv_m_s2,
            self.vdv_m_s175,
            self.peak_m_s2,
            self.crest_factor,
            if flags.is_empty() {
                "-".to_string()
            } else {
                flags.join(", ")
            }
        )
    }
}

const TABLE_HEADER: &str = "           weighting  rms       MTVV      VDV        peak      crest    additional methods\n                      m/s^2     m/s^2     m/s^1.75   m/s^2";

/// One entry of the alert timeline.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct TimedEvent {
    /// Time of the event in the recording's time base, s.
    pub time_s: f64,
    /// Sample index from the first evaluated sample (0-based, at the evaluation's rate).
    pub sample: u32,
    /// `level` (exposure level change) or `fault` (sensor fault raised or cleared).
    pub kind: &'static str,
    /// What happened, e.g. `normal -> warning` or `saturated raised`.
    pub event: String,
    /// The level after a level change (absent for faults).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub level: Option<&'static str>,
    /// The event raises (rather than clears) an alert.
    pub raise: bool,
    /// What changed the level, with its value then (absent for faults): serialized as
    /// `criterion` (`running-rms` or `vdv`) and `value_m_s2` or `value_m_s175`.
    #[serde(flatten, serialize_with = "criterion_fields")]
    pub criterion: Option<Criterion>,
}

/// [`TimedEvent::criterion`] as flat keys with the unit in the value's name.
fn criterion_fields<S: serde::Serializer>(
    c: &Option<Criterion>,
    serializer: S,
) -> Result<S::Ok, S::Error> {
    use serde::ser::SerializeMap;
    let mut map = serializer.serialize_map(None)?;
    if let Some(c) = c {
        map.serialize_entry("criterion", c.name())?;
        let key = match c {
            Criterion::RunningRms { .. } => "value_m_s2",
            Criterion::Vdv { .. } => "value_m_s175",
        };
        map.serialize_entry(key, &f64::from(c.value()))?;
    }
    map.end()
}

impl TimedEvent {
    /// Stamps a core event with the time of its sample.
    pub fn new(e: &AlertEvent, start_s: f64, sample_rate_hz: f64) -> Self {
        let sample = e.at_sample();
        let time_s = start_s + sample as f64 / sample_rate_hz;
        match *e {
            AlertEvent::Level { from, to, .. } => Self {
                time_s,
                sample,
                kind: "level",
                event: format!("{from} -> {to}"),
                level: Some(to.name()),
                raise: e.is_raise(),
                criterion: e.criterion(),
            },
            AlertEvent::Fault { fault, active, .. } => Self {
                time_s,
                sample,
                kind: "fault",
                event: format!("{fault} {}", if active { "raised" } else { "cleared" }),
                level: None,
                raise: active,
                criterion: None,
            },
            AlertEvent::Joint { raised, .. } => Self {
                time_s,
                sample,
                kind: "joint",
                event: e
                    .joint_criterion()
                    .map_or_else(String::new, |(o, c)| joint_alert_text(o, &c, raised)),
                level: None,
                raise: raised,
                criterion: None,
            },
        }
    }
}

/// The alert thresholds in force (the parameter file's, or the documented defaults).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct ThresholdsReport {
    /// Running-rms thresholds of the vector sum: advisory, warning, alarm, m/s^2.
    pub running_rms_m_s2: [f64; 3],
    /// VDV thresholds of the vector sum: advisory, warning, alarm, m/s^1.75.
    pub vdv_m_s175: [f64; 3],
}

impl From<&AlertConfig> for ThresholdsReport {
    fn from(c: &AlertConfig) -> Self {
        Self {
            running_rms_m_s2: c.running_rms_m_s2.map(tidy),
            vdv_m_s175: c.vdv_m_s175.map(tidy),
        }
    }
}

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
    /// [`MAX_LISTED_EVENTS`]).
    pub alerts: Vec<TimedEvent>,
    /// Events after the listed ones, counted only (absent when none).
    #[serde(skip_serializing_if = "none_omitted")]
    pub alerts_omitted: usize,
    /// Highest exposure level reached.
    pub max_level: &'static str,
    /// Exposure level after the last sample.
    pub final_level: &'static str,
    /// The predicted neck and lower-back motion over the whole ride (from the start, warm-up
    /// included: the joints need no settling filter); empty when the model is not known.
    pub joints: Vec<JointReport>,
    /// The ride's data-quality account (a logger's file; null for a recording).
    pub data_quality: Option<DataQuality>,
}

/// No event was left out of a list (serde's test for leaving the count out).
pub fn none_omitted(n: &usize) -> bool {
    *n == 0
}

/// What [`ModelRun`] shows its observer, in the pipeline's order: an alert event, then
/// each sample.
pub enum Step<'a> {
    /// An alert event (before the telemetry of its sample).
    Alert(&'a AlertEvent),
    /// A sample's telemetry, its input (x, y, z at the evaluation's rate) and the joint
    /// tracker after it.
    Sample {
        /// The pipeline's telemetry of the sample.
        telemetry: &'a Telemetry,
        /// The sample's platform input, m/s^2.
        input_m_s2: [f64; 3],
        /// The joints after the sample, when tracked.
        joints: Option<&'a JointTracker>,
    },
}

/// The device pipeline over a ride, one sample at a time: [`DeviceParams::process`] in
/// f32 on chunks of [`CHUNK_SAMPLES`] with sample indices `0, 1, ...`, exactly what the
/// device computes, and beside it what `supine exposure` reports: the alert timeline (its
/// first [`MAX_LISTED_EVENTS`] events), the platform's unweighted mean squares, and the
/// joints when tracked. Memory: the pipeline state and one chunk.
pub struct ModelRun {
    params: DeviceParams,
    state: PipelineState,
    start_s: f64,
    chunk: Vec<[f64; 3]>,
    indices: Vec<u32>,
    samples_f32: Vec<[f32; 3]>,
    taken: usize,
    events: Vec<TimedEvent>,
    events_omitted: usize,
    max_level: Level,
    platform_sum2: [f64; 3],
    joints: Option<JointTracker>,
}

/// What a [`ModelRun`] found over the whole ride.
pub struct RunOutcome {
    /// The exposure values of the final state.
    pub values: ExposureValues,
    /// The listed events.
    pub events: Vec<TimedEvent>,
    /// Events not listed.
    pub events_omitted: usize,
    /// Highest level reached.
    pub max_level: Level,
    /// The level after the last sample.
    pub final_level: Level,
    /// Samples taken.
    pub samples: usize,
    /// Unweighted rms of the platform x, y, z, m/s^2.
    pub platform_rms_m_s2: [f64; 3],
    /// The joints' statistics, when tracked.
    pub joints: Vec<JointReport>,
}

impl ModelRun {
    /// A run of `params` from a fresh state (the first sample at `start_s` in the ride's
    /// time), with `joints` tracked beside it if given.
    pub fn new(params: &DeviceParams, joints: Option<JointTracker>, start_s: f64) -> Self {
        // Every sample's telemetry for the observer. The head's values and events do not
        // depend on it; the joint outputs are then read on every sample, their alerts'
        // dwells rebuilt for that (the same parameters with every sample are valid).
        let params = params
            .with_telemetry(TelemetryConfig::EVERY_SAMPLE)
            .unwrap_or(*params);
        Self {
            params,
            state: PipelineState::new(),
            start_s,
            chunk: Vec::with_capacity(CHUNK_SAMPLES),
            indices: Vec::with_capacity(CHUNK_SAMPLES),
            samples_f32: Vec::with_capacity(CHUNK_SAMPLES),
            taken: 0,
            events: Vec::new(),
            events_omitted: 0,
            max_level: Level::Normal,
            platform_sum2: [0.0; 3],
            joints,
        }
    }

    /// Takes the next platform sample (x, y, z, m/s^2); `observe` sees the pipeline's
    /// outputs as each chunk is run.
    pub fn push(&mut self, input_m_s2: [f64; 3], observe: &mut impl FnMut(Step<'_>)) -> Result<()> {
        if self.taken >= u32::MAX as usize {
            bail!(
                "more than {} samples: more than the device's 32-bit sample index",
                u32::MAX
            );
        }
        for (sum, v) in self.platform_sum2.iter_mut().zip(input_m_s2) {
            *sum += v * v;
        }
        self.chunk.push(input_m_s2);
        self.taken += 1;
        if self.chunk.len() == CHUNK_SAMPLES {
            self.flush(observe);
        }
        Ok(())
    }

    fn flush(&mut self, observe: &mut impl FnMut(Step<'_>)) {
        if self.chunk.is_empty() {
            return;
        }
        let first = (self.taken - self.chunk.len()) as u32;
        self.indices.clear();
        self.indices
            .extend((0..self.chunk.len() as u32).map(|k| first + k));
        self.samples_f32.clear();
        self.samples_f32
            .extend(self.chunk.iter().map(|u| u.map(|v| v as f32)));
        let fs = self.params.sample_rate_hz() as f64;
        let Self {
            params,
            state,
            start_s,
            chunk,
            indices,
            samples_f32,
            events,
            events_omitted,
            max_level,
            joints,
            ..
        } = self;
        params.process(state, indices, samples_f32, |out| match out {
            PipelineOutput::Alert(e) => {
                if let AlertEvent::Level { to, .. } = e {
                    *max_level = (*max_level).max(to);
                }
                if events.len() < MAX_LISTED_EVENTS {
                    events.push(TimedEvent::new(&e, *start_s, fs));
                } else {
                    *events_omitted += 1;
                }
                observe(Step::Alert(&e));
            }
            PipelineOutput::Telemetry(t) => {
                let input_m_s2 = chunk[(t.sample_index - first) as usize];
                if let Some(j) = joints.as_mut() {
                    j.step(input_m_s2);
                }
                observe(Step::Sample {
                    telemetry: &t,
                    input_m_s2,
                    joints: joints.as_ref(),
                });
            }
        });
        self.chunk.clear();
    }

    /// Runs what is left and gives the values of the final state.
    pub fn finish(mut self, observe: &mut impl FnMut(Step<'_>)) -> RunOutcome {
        self.flush(observe);
        let n = self.taken;
        let values = self
            .params
            .exposure
            .values(self.params.sample_rate, self.state.exposure());
        RunOutcome {
            values,
            events: self.events,
            events_omitted: self.events_omitted,
            max_level: self.max_level,
            final_level: self.state.level(),
            samples: n,
            platform_rms_m_s2: self
                .platform_sum2
                .map(|s| if n == 0 { 0.0 } else { (s / n as f64).sqrt() }),
            joints: self.joints.map(|j| j.report()).unwrap_or_default(),
        }
    }
}

fn check_warmup(path: &str, samples: usize, fs: f64, warmup_s: f64) -> Result<()> {
    let duration_s = samples as f64 / fs;
    if samples as f64 <= (warmup_s * fs).round() {
        bail!(
            "{path}: {duration_s:.3} s of samples at {fs} Hz: expected more than the \
             {warmup_s} s warm-up of the weighting filters"
        );
    }
    Ok(())
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
    let joints = JointTracker::new(&file.params, fs)?;
    let mut run = ModelRun::new(&params, Some(joints), input.start_s);
    for sample in input.platform()? {
        run.push(sample?, &mut observe)?;
    }
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
        max_level: outcome.max_level.name(),
        final_level: outcome.final_level.name(),
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

fn rate_line(fs: f64, from: Option<f64>) -> String {
    match from {
        Some(own) => {
            format!("{fs} Hz (resampled from {own:.3} Hz, Kaiser-windowed sinc, zero phase)")
        }
        None => format!("{fs:.3} Hz"),
    }
}

impl ModelExposure {
    /// The readable table and alert timeline.
    pub fn to_text(&self) -> String {
        let mut s = String::new();
        let _ = writeln!(
            s,
            "predicted head exposure: {} ({}), model {} (identity {})",
            self.input,
            match self.layout {
                Layout::Full => "recording",
                Layout::PlatformOnly => "platform columns only",
                Layout::Prediction => "prediction",
            },
            self.model,
            self.identity
        );
        let _ = writeln!(
            s,
            "{} samples at {} = {:.3} s; evaluated {:.3} s after the {} s warm-up{}",
            self.samples,
            rate_line(self.sample_rate_hz, self.resampled_from_hz),
            self.duration_s,
            self.evaluated_s,
            self.warmup_s,
            if self.valid { "" } else { " (NOT VALID)" }
        );
        let [px, py, pz] = self.platform_rms_m_s2;
        let _ = writeln!(
            s,
            "platform input rms (unweighted): x {px:.4}, y {py:.4}, z {pz:.4} m/s^2\n"
        );
        let _ = writeln!(s, "{TABLE_HEADER}");
        for (label, axis) in ["head x", "head y", "head z"].iter().zip(&self.head) {
            let _ = writeln!(s, "{}", axis.row(label));
        }
        let _ = writeln!(s, "{}", self.vector.row("vector"));
        let t = &self.thresholds;
        let _ = writeln!(
            s,
            "\nalert timeline (vector sum; running rms {} / {} / {} m/s^2, VDV {} / {} / {} m/s^1.75 for advisory / warning / alarm):",
            t.running_rms_m_s2[0],
            t.running_rms_m_s2[1],
            t.running_rms_m_s2[2],
            t.vdv_m_s175[0],
            t.vdv_m_s175[1],
            t.vdv_m_s175[2]
        );
        if self.alerts.is_empty() {
            let _ = writeln!(s, "  (no alert)");
        } else {
            let _ = writeln!(s, "  {:>10}  event", "time_s");
            for e in &self.alerts {
                let _ = writeln!(s, "  {:>10.3}  {} {}", e.time_s, e.kind, e.event);
            }
            if self.alerts_omitted > 0 {
                let _ = writeln!(
                    s,
                    "  ... and {} more events (the first {MAX_LISTED_EVENTS} are listed)",
                    self.alerts_omitted
                );
            }
        }
        let _ = writeln!(
            s,
            "highest level: {}; at the end: {}",
            self.max_level, self.final_level
        );
        let _ = writeln!(
            s,
            "note: ISO 2631-1 gives no health method for recumbent persons; these thresholds are extrapolations."
        );
        if !self.joints.is_empty() {
            s += &joints_text(&self.joints);
        }
        s
    }
}

/// The VDV of exposures in sequence (the legs of a mission), m/s^1.75: ISO 2631-1 adds
/// the fourth powers, `(sum VDV_i^4)^(1/4)`, because the VDV is the fourth root of an
/// integral over time.
pub fn combined_vdv_m_s175(vdv_m_s175: &[f64]) -> f64 {
    vdv_m_s175.iter().map(|v| v.powi(4)).sum::<f64>().powf(0.25)
}

/// The rms of exposures in sequence, m/s^2: energy-equivalent, as ISO 2631-1 combines
/// periods of different magnitude, `sqrt(sum a_i^2 T_i / sum T_i)` over `(a_i, T_i)`
/// pairs of rms (m/s^2) and evaluated duration (s). Zero when no time was evaluated.
pub fn combined_rms_m_s2(rms_and_duration: &[(f64, f64)]) -> f64 {
    let total_s: f64 = rms_and_duration.iter().map(|(_, t)| t).sum();
    if total_s <= 0.0 {
        return 0.0;
    }
    (rms_and_duration.iter().map(|(a, t)| a * a * t).sum::<f64>() / total_s).sqrt()
}

/// A single recorded channel, weighted and evaluated without a model.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ChannelExposure {
    /// Always `channel`.
    pub form: &'static str,
    /// The recording.
    pub input: String,
    /// The column evaluated.
    pub channel: String,
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
    /// Unweighted rms of the channel (all samples), m/s^2.
    pub unweighted_rms_m_s2: f64,
    /// The weighted evaluation.
    #[serde(flatten)]
    pub values: AxisReport,
    /// The ride's data-quality account (a logger's file; null for a recording).
    pub data_quality: Option<DataQuality>,
}

/// The channel form's settings: `kind` on every axis at `sample_rate_hz`, the core's
/// default running-rms time constant and warm-up, `k = 1`.
fn channel_settings(
    kind: WeightingKind,
    sample_rate_hz: f64,
) -> Result<(ExposureSettings, SampleRate)> {
    let axis = AxisWeighting { kind, k: 1.0 };
    let config = ExposureConfig {
        axes: AxisMapping {
            x: axis,
            y: axis,
            z: axis,
        },
        ..ExposureConfig::DEFAULT
    };
    let sample_rate = SampleRate::from_hz_f64(sample_rate_hz)
        .map_err(|e| anyhow!("{e}, found {sample_rate_hz} Hz"))?;
    let settings = ExposureSettings::new(config, sample_rate)
        .map_err(|e| anyhow!("{e} (at {sample_rate_hz} Hz)"))?;
    Ok((settings, sample_rate))
}

/// `supine exposure`'s channel form on `source`: the column named `channel`, at `fs_hz`
/// (else its own rate), weighted with `kind`, through the core's [`ExposureSettings`]
/// with the channel on x and zeros on y and z, in one pass.
pub fn evaluate_channel(
    source: &RideSource,
    channel: &str,
    kind: WeightingKind,
    fs_hz: Option<f64>,
) -> Result<ChannelExposure> {
    let index = channel_index(channel, source.layout(), source.path())?;
    let input = EvaluationInput::new(source, fs_hz)?;
    let name = source.path().display().to_string();
    let fs = input.sample_rate_hz;
    let warmup_s = ExposureConfig::DEFAULT.warmup_s as f64;
    check_warmup(&name, input.samples, fs, warmup_s)?;
    let (settings, sample_rate) = channel_settings(kind, fs)?;
    let mut state = ExposureState::new();
    let (mut n, mut sum2) = (0usize, 0.0f64);
    for x in input.columns([index])? {
        let [x] = x?;
        if n >= u32::MAX as usize {
            bail!(
                "more than {} samples: more than a 32-bit sample index",
                u32::MAX
            );
        }
        settings.step(&mut state, [x as f32, 0.0, 0.0], n as u32);
        sum2 += x * x;
        n += 1;
    }
    let values = settings.values(sample_rate, &state);
    Ok(ChannelExposure {
        form: "channel",
        input: name,
        channel: channel.to_string(),
        sample_rate_hz: fs,
        resampled_from_hz: input.resampled_from_hz,
        samples: n,
        duration_s: n as f64 / fs,
        warmup_s,
        evaluated_s: tidy(values.duration_s),
        valid: values.valid,
        unweighted_rms_m_s2: if n == 0 {
            0.0
        } else {
            (sum2 / n as f64).sqrt()
        },
        values: AxisReport::new(kind.name(), &values.axes[0]),
        data_quality: source.quality().cloned(),
    })
}

impl ChannelExposure {
    /// The readable table.
    pub fn to_text(&self) -> String {
        let mut s = String::new();
        let _ = writeln!(
            s,
            "exposure of column {} of {} (no model)",
            self.channel, self.input
        );
        let _ = writeln!(
            s,
            "{} samples at {} = {:.3} s; evaluated {:.3} s after the {} s warm-up{}",
            self.samples,
            rate_line(self.sample_rate_hz, self.resampled_from_hz),
            self.duration_s,
            self.evaluated_s,
            self.warmup_s,
            if self.valid { "" } else { " (NOT VALID)" }
        );
        let _ = writeln!(s, "unweighted rms: {:.4} m/s^2\n", self.unweighted_rms_m_s2);
        let _ = writeln!(s, "{TABLE_HEADER}");
        let _ = writeln!(s, "{}", self.values.row(&self.channel));
        s
    }
}

/// The column index (0-based, in [`COLUMNS`]) of an acceleration column; an error that
/// lists the columns `layout` holds otherwise.
pub fn channel_index(name: &str, layout: Layout, path: &Path) -> Result<usize> {
    let available: &[&str] = match layout {
        Layout::Full | Layout::Prediction => &COLUMNS[1..],
        Layout::PlatformOnly => &COLUMNS[1..4],
    };
    match available.iter().position(|c| *c == name) {
        Some(i) => Ok(i + 1),
        None => bail!(
            "{}: line 1: --channel {name}: expected one of the acceleration columns {}",
            path.display(),
            available.join(", ")
        ),
    }
}
