//! Exposure reports for recordings, computed by the same `supine-core` code the device runs.
//!
//! Two evaluations, both on `supine_core::exposure::ExposureSettings`:
//! - [`model_exposure`]: the device's whole chain ([`DeviceParams::process`]: sensor checks,
//!   model, weighting and exposure, alerts) over a recording's platform columns, then
//!   `ExposureSettings::values` of the final state, and the alert timeline.
//! - [`channel_exposure`]: one recorded channel (a head accelerometer, a test signal),
//!   weighted with Wk, Wd or Wj, no model: an `ExposureSettings` whose x axis carries the
//!   channel and whose other axes carry zeros, so the x axis' values are the channel's.
//!
//! Both need a sample rate the device supports ([`SampleRate`]); a recording at another
//! rate is converted first by the band-limited [`crate::exposure::resample`] (zero phase), at the
//! user's request only.
//!
//! Recordings are read by [`crate::io::recording::read_input`], which also accepts a file
//! with only the platform columns (what `supine ride` writes), its sensor columns filled
//! with zeros that no evaluation here reads.

use crate::exposure::joints::{JointReport, joint_motion, joints_text};
use std::fmt::Write as _;
use std::path::Path;

use anyhow::{Result, anyhow, bail};
use serde::Serialize;
use supine_core::alerts::{AlertConfig, AlertEvent, Criterion, Level};
use supine_core::blob::DeviceParams;
use supine_core::exposure::{
    AxisMapping, AxisValues, AxisWeighting, ExposureConfig, ExposureSettings, ExposureState,
};
use supine_core::pipeline::{PipelineOutput, PipelineState};
use supine_core::sample_rate::{SampleRate, SampleRateError};
use supine_core::weighting::WeightingKind;

use crate::device::device_params;
use crate::exposure::resample::Resampler;
use crate::io::params_file::ParamFile;
use crate::io::recording::{COLUMNS, Layout, Recording};

/// Samples handed to the device pipeline per call (bounds the index buffer, not the result).
const CHUNK_SAMPLES: usize = 4096;

/// Signals at the rate they will be evaluated at.
#[derive(Clone, Debug, PartialEq)]
pub struct Prepared {
    /// The evaluation's sample rate, Hz.
    pub sample_rate_hz: f64,
    /// The recording's own rate when it was converted, Hz.
    pub resampled_from_hz: Option<f64>,
    /// Time of the first sample, s (the recording's).
    pub start_s: f64,
    /// The channels, each at `sample_rate_hz`.
    pub channels: Vec<Vec<f64>>,
}

/// Brings `channels` of `recording` to `fs_hz` if given (band-limited, see
/// [`crate::exposure::resample`]), else checks that the recording's own rate is one the device supports.
pub fn prepare(recording: &Recording, channels: &[&[f64]], fs_hz: Option<f64>) -> Result<Prepared> {
    let own_hz = recording.sample_rate_hz();
    let path = recording.path.display();
    let start_s = recording.time_s.first().copied().unwrap_or(0.0);
    if let Some(target_hz) = fs_hz.filter(|f| !SampleRate::supports_hz(*f)) {
        bail!("--fs {target_hz}: {SampleRateError}");
    }
    // `--fs` at the recording's own rate (to 1 ppm) changes nothing: no conversion.
    let fs_hz = fs_hz.filter(|f| (f - own_hz).abs() > 1e-6 * own_hz);
    let Some(target_hz) = fs_hz else {
        if !SampleRate::supports_hz(own_hz) {
            bail!(
                "{path}: sample rate {own_hz:.6} Hz (from column time_s) is outside \
                 {}..={} Hz, the device's range; give --fs HZ to resample",
                SampleRate::MIN_HZ,
                SampleRate::MAX_HZ
            );
        }
        return Ok(Prepared {
            sample_rate_hz: own_hz,
            resampled_from_hz: None,
            start_s,
            channels: channels.iter().map(|c| c.to_vec()).collect(),
        });
    };
    let resampler = Resampler::new(own_hz, target_hz)?;
    Ok(Prepared {
        sample_rate_hz: target_hz,
        resampled_from_hz: Some(own_hz),
        start_s,
        channels: channels.iter().map(|c| resampler.process(c)).collect(),
    })
}

/// Rounds an f32 to the shortest decimal that reads back as the same f32, as f64
/// (so 0.3f32 reports as 0.3, not 0.30000001192092896).
fn tidy(x: f32) -> f64 {
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
    /// Level changes and sensor faults, in sample order.
    pub alerts: Vec<TimedEvent>,
    /// Highest exposure level reached.
    pub max_level: &'static str,
    /// Exposure level after the last sample.
    pub final_level: &'static str,
    /// The predicted neck and lower-back motion over the whole ride (from the start, warm-up
    /// included: the joints need no settling filter); empty when the model is not known.
    pub joints: Vec<JointReport>,
}

/// Runs the device pipeline over `platform_m_s2` (m/s^2, x, y, z at the params' rate,
/// sample 0 at `start_s`) and reports the exposure of the predicted head acceleration.
///
/// Exactly what the device computes: [`DeviceParams::process`] in f32, sample indices
/// `0, 1, ...`, and `exposure.values` of the final state.
pub fn run_pipeline(
    params: &DeviceParams,
    platform_m_s2: &[[f32; 3]],
    start_s: f64,
) -> Result<(
    supine_core::exposure::ExposureValues,
    Vec<TimedEvent>,
    Level,
)> {
    if platform_m_s2.len() > u32::MAX as usize {
        bail!(
            "{} samples: more than the device's 32-bit sample index",
            platform_m_s2.len()
        );
    }
    let fs = params.sample_rate_hz() as f64;
    let mut state = PipelineState::new();
    let mut events = Vec::new();
    let mut indices = Vec::with_capacity(CHUNK_SAMPLES);
    for (c, chunk) in platform_m_s2.chunks(CHUNK_SAMPLES).enumerate() {
        let first = (c * CHUNK_SAMPLES) as u32;
        indices.clear();
        indices.extend((0..chunk.len() as u32).map(|k| first + k));
        params.process(&mut state, &indices, chunk, |out| {
            if let PipelineOutput::Alert(e) = out {
                events.push(TimedEvent::new(&e, start_s, fs));
            }
        });
    }
    let values = params.exposure.values(params.sample_rate, state.exposure());
    Ok((values, events, state.level()))
}

fn rms(x: &[f64]) -> f64 {
    if x.is_empty() {
        return 0.0;
    }
    (x.iter().map(|v| v * v).sum::<f64>() / x.len() as f64).sqrt()
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

/// The model form of `supine exposure`: `params` must be built at `prepared`'s rate, and
/// `prepared.channels` must be the platform x, y, z columns.
pub fn model_exposure(
    params: &DeviceParams,
    prepared: &Prepared,
    input: &str,
    layout: Layout,
    model: String,
    identity: String,
) -> Result<ModelExposure> {
    let [x, y, z] = match prepared.channels.as_slice() {
        [x, y, z] => [x, y, z],
        _ => bail!("the model form needs the three platform columns"),
    };
    let n = x.len();
    let fs = prepared.sample_rate_hz;
    let warmup_s = params.exposure.config.warmup_s as f64;
    check_warmup(input, n, fs, warmup_s)?;
    let platform: Vec<[f32; 3]> = (0..n)
        .map(|k| [x[k] as f32, y[k] as f32, z[k] as f32])
        .collect();
    let (values, alerts, final_level) = run_pipeline(params, &platform, prepared.start_s)?;
    let max_level = alerts
        .iter()
        .filter_map(|e| e.level)
        .fold(Level::Normal, |m, name| {
            let l = Level::RAISED
                .into_iter()
                .find(|l| l.name() == name)
                .unwrap_or(Level::Normal);
            m.max(l)
        });
    let kinds = params.exposure.config.axes.axes().map(|a| a.kind.name());
    Ok(ModelExposure {
        form: "model",
        input: input.to_string(),
        layout,
        model,
        identity,
        sample_rate_hz: fs,
        resampled_from_hz: prepared.resampled_from_hz,
        samples: n,
        duration_s: n as f64 / fs,
        warmup_s,
        evaluated_s: tidy(values.duration_s),
        valid: values.valid,
        platform_rms_m_s2: [rms(x), rms(y), rms(z)],
        head: [0, 1, 2].map(|i| AxisReport::new(kinds[i], &values.axes[i])),
        vector: AxisReport::new("vector", &values.vector),
        thresholds: (&params.alerts.config).into(),
        alerts,
        max_level: max_level.name(),
        final_level: final_level.name(),
        joints: Vec::new(),
    })
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
}

/// Evaluates one channel `x_m_s2` at `sample_rate_hz` with weighting `kind`, through the
/// core's [`ExposureSettings`] (default running-rms time constant and warm-up, `k = 1`).
pub fn channel_values(
    kind: WeightingKind,
    sample_rate_hz: f64,
    x_m_s2: &[f64],
) -> Result<supine_core::exposure::ExposureValues> {
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
    let mut state = ExposureState::new();
    if x_m_s2.len() > u32::MAX as usize {
        bail!("{} samples: more than a 32-bit sample index", x_m_s2.len());
    }
    for (k, &x) in x_m_s2.iter().enumerate() {
        settings.step(&mut state, [x as f32, 0.0, 0.0], k as u32);
    }
    Ok(settings.values(sample_rate, &state))
}

/// The channel form of `supine exposure`: `prepared.channels` holds the one channel.
pub fn channel_exposure(
    kind: WeightingKind,
    prepared: &Prepared,
    input: &str,
    channel: &str,
) -> Result<ChannelExposure> {
    let x = prepared
        .channels
        .first()
        .ok_or_else(|| anyhow!("no channel to evaluate"))?;
    let fs = prepared.sample_rate_hz;
    let warmup_s = ExposureConfig::DEFAULT.warmup_s as f64;
    check_warmup(input, x.len(), fs, warmup_s)?;
    let values = channel_values(kind, fs, x)?;
    Ok(ChannelExposure {
        form: "channel",
        input: input.to_string(),
        channel: channel.to_string(),
        sample_rate_hz: fs,
        resampled_from_hz: prepared.resampled_from_hz,
        samples: x.len(),
        duration_s: x.len() as f64 / fs,
        warmup_s,
        evaluated_s: tidy(values.duration_s),
        valid: values.valid,
        unweighted_rms_m_s2: rms(x),
        values: AxisReport::new(kind.name(), &values.axes[0]),
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

/// `supine exposure`'s model form on `recording` (with the columns of `layout`): its
/// platform columns at `fs_hz` (else its own rate) through the device parameters of
/// `file`, built at that rate; `model` names the parameters in the report.
pub fn evaluate_model(
    recording: &Recording,
    layout: Layout,
    file: &ParamFile,
    model: String,
    fs_hz: Option<f64>,
) -> Result<ModelExposure> {
    let [x, y, z] = &recording.platform_m_s2;
    let prepared = prepare(recording, &[x, y, z], fs_hz)?;
    let params = device_params::build(file, prepared.sample_rate_hz)?;
    let identity = device_params::identity_hex(&params.identity);
    let input = recording.path.display().to_string();
    let mut report = model_exposure(&params, &prepared, &input, layout, model, identity)?;
    let platform: Vec<[f64; 3]> = match prepared.channels.as_slice() {
        [x, y, z] => (0..x.len()).map(|k| [x[k], y[k], z[k]]).collect(),
        _ => Vec::new(),
    };
    report.joints = joint_motion(&file.params, prepared.sample_rate_hz, &platform)?;
    Ok(report)
}

/// `supine exposure`'s channel form on `recording` (with the columns of `layout`): the
/// column named `channel`, at `fs_hz` (else its own rate), weighted with `kind`.
pub fn evaluate_channel(
    recording: &Recording,
    layout: Layout,
    channel: &str,
    kind: WeightingKind,
    fs_hz: Option<f64>,
) -> Result<ChannelExposure> {
    let index = channel_index(channel, layout, &recording.path)?;
    let prepared = prepare(recording, &[column(recording, index)], fs_hz)?;
    let input = recording.path.display().to_string();
    channel_exposure(kind, &prepared, &input, channel)
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

/// The channel at `index` in [`COLUMNS`] (1..=12) of `recording`.
pub fn column(recording: &Recording, index: usize) -> &[f64] {
    match index {
        1..=3 => &recording.platform_m_s2[index - 1],
        4..=12 => &recording.sensors_m_s2[index - 4],
        _ => &recording.time_s,
    }
}
