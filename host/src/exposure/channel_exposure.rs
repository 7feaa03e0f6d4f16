//! `supine exposure`'s channel form: one recorded channel (a head accelerometer, a test
//! signal), weighted with Wk, Wd or Wj, no model: an `ExposureSettings` whose x axis
//! carries the channel and whose other axes carry zeros, so the x axis' values are the
//! channel's. Its text form is in [`crate::exposure::exposure_text`].

use std::path::Path;

use anyhow::{Result, anyhow, bail};
use serde::Serialize;
use supine_core::exposure::{
    AxisMapping, AxisWeighting, ExposureConfig, ExposureSample, ExposureSettings, ExposureState,
};
use supine_core::sample_rate::SampleRate;
use supine_core::weighting::WeightingKind;

use crate::exposure::evaluation_input::{EvaluationInput, check_warmup};
use crate::exposure::reported_values::{AxisReport, tidy};
use crate::io::recording::{COLUMNS, Layout, column_index};
use crate::io::ride_rows::RideSource;
use crate::parallel::read_ahead;
use crate::ride::quality::DataQuality;

/// Samples stepped together through the weighting (the core's `step_block`).
const STEP_BLOCK: usize = 32;

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
    // Blocks of samples, stepped together: the same values as one at a time, bit for
    // bit (the core's `step_block`), in a fraction of the time.
    let mut block = [[0.0f32; 3]; STEP_BLOCK];
    let mut out = [ExposureSample::default(); STEP_BLOCK];
    let mut filled = 0;
    // The ride is read on a thread of its own while the weighting runs on this one.
    read_ahead(
        || input.columns([index]),
        |[x]| {
            if n >= u32::MAX as usize {
                bail!(
                    "more than {} samples: more than a 32-bit sample index",
                    u32::MAX
                );
            }
            block[filled] = [x as f32, 0.0, 0.0];
            filled += 1;
            sum2 += x * x;
            n += 1;
            if filled == STEP_BLOCK {
                let first = (n - STEP_BLOCK) as u32;
                settings.step_block(&mut state, &block, first, &mut out);
                filled = 0;
            }
            Ok(())
        },
    )?;
    for (k, sample) in block[..filled].iter().enumerate() {
        settings.step(&mut state, *sample, (n - filled + k) as u32);
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

/// The column index (0-based, in [`COLUMNS`]) of an acceleration column, named in either
/// naming ([`column_index`]); an error that lists the columns `layout` holds otherwise.
pub fn channel_index(name: &str, layout: Layout, path: &Path) -> Result<usize> {
    let available = &COLUMNS[1..layout.columns().min(COLUMNS.len())];
    match column_index(name).filter(|i| (1..=available.len()).contains(i)) {
        Some(i) => Ok(i),
        None => bail!(
            "{}: line 1: --channel {name}: expected one of the acceleration columns {}",
            path.display(),
            available.join(", ")
        ),
    }
}
