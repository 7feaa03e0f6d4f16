//! A prediction band for the head exposure of a recording: parameter sets drawn from a
//! fit's uncertainty ([`StoredUncertainty`]: ln p of the determined parameters from their
//! linearized covariance, every other parameter at its fitted value), each one's predicted
//! head acceleration evaluated like the device does (docs/exposure.md: the recumbent
//! axes' frequency weightings, overall weighted rms after the warm-up), and the band is the
//! 2.5 to 97.5 percentile of each value over the draws. The drawing, the parallel
//! evaluation and the quantiles are shared with `supine report`'s band (`report::prediction_band`),
//! which evaluates each draw through the device's pipeline instead.
//!
//! What it covers and what it does not: docs/model.md#uncertainty-of-a-fit.

use anyhow::{Result, anyhow, bail};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use supine_core::exposure::{ExposureConfig, ExposureSettings, ExposureState};
use supine_core::model::ModelParams;
use supine_core::sample_rate::SampleRate;

use super::uncertainty::{GaussianDraws, StoredUncertainty};
use crate::identify::validate::predict;
use crate::io::recording::Recording;

/// The band's lower and upper quantiles (a central 95 % band).
pub const BAND_QUANTILES: (f64, f64) = (0.025, 0.975);

/// The band's middle: the median over the draws.
pub const BAND_MEDIAN: f64 = 0.5;

/// What a band asks for: how many draws, their seed, and the covariance they come from.
#[derive(Clone, Debug)]
pub struct BandRequest {
    /// Parameter sets drawn.
    pub draws: usize,
    /// Seed of the draws.
    pub seed: u64,
    /// The fit's uncertainty.
    pub uncertainty: StoredUncertainty,
}

/// One value's band over the draws: its [`BAND_QUANTILES`] and its [`BAND_MEDIAN`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Spread {
    /// The lower quantile.
    pub low: f64,
    /// The median.
    pub median: f64,
    /// The upper quantile.
    pub high: f64,
}

impl Spread {
    /// The band of `values` (one per draw).
    pub fn of(values: &[f64]) -> Self {
        Self {
            low: quantile(values, BAND_QUANTILES.0),
            median: quantile(values, BAND_MEDIAN),
            high: quantile(values, BAND_QUANTILES.1),
        }
    }
}

/// The head exposure of one prediction: overall frequency-weighted rms per head axis and
/// of the vector sum, m/s^2.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HeadExposure {
    /// Head x, y, z.
    pub axes_rms_m_s2: [f64; 3],
    /// The vector sum a_v.
    pub vector_rms_m_s2: f64,
}

impl HeadExposure {
    /// The four values: x, y, z, vector.
    pub fn values(&self) -> [f64; 4] {
        let [x, y, z] = self.axes_rms_m_s2;
        [x, y, z, self.vector_rms_m_s2]
    }

    fn from_values(v: [f64; 4]) -> Self {
        Self {
            axes_rms_m_s2: [v[0], v[1], v[2]],
            vector_rms_m_s2: v[3],
        }
    }
}

/// The head exposure `params` predict for the recording's support acceleration (the
/// device's evaluation with its default configuration, at the recording's rate).
pub fn head_exposure(params: &ModelParams, recording: &Recording) -> Result<HeadExposure> {
    let predicted = predict(params, recording)?;
    let fs = recording.sample_rate_hz();
    let sample_rate = SampleRate::from_hz_f64(fs)
        .map_err(|e| anyhow!("{}: {e} (at {fs:.3} Hz)", recording.path.display()))?;
    let settings = ExposureSettings::new(ExposureConfig::DEFAULT, sample_rate)
        .map_err(|e| anyhow!("{}: {e} (at {fs:.3} Hz)", recording.path.display()))?;
    let mut state = ExposureState::new();
    let n = predicted[0].len();
    if n > u32::MAX as usize {
        bail!("{n} samples: more than a 32-bit sample index");
    }
    let [x, y, z] = [&predicted[0], &predicted[1], &predicted[2]];
    for (k, ((&x, &y), &z)) in x.iter().zip(y).zip(z).enumerate() {
        settings.step(&mut state, [x as f32, y as f32, z as f32], k as u32);
    }
    let values = settings.values(sample_rate, &state);
    if !values.valid {
        bail!(
            "{}: {:.2} s: expected more than the {} s warm-up of the weighting filters",
            recording.path.display(),
            recording.duration_s(),
            ExposureConfig::DEFAULT.warmup_s
        );
    }
    Ok(HeadExposure {
        axes_rms_m_s2: values.axes.map(|a| f64::from(a.rms_m_s2)),
        vector_rms_m_s2: f64::from(values.vector.rms_m_s2),
    })
}

/// The band of a fit's head exposure for one recording.
#[derive(Clone, Debug, PartialEq)]
pub struct ExposureBand {
    /// The fitted parameters' prediction.
    pub fitted: HeadExposure,
    /// The lower quantile over the draws.
    pub low: HeadExposure,
    /// The upper quantile over the draws.
    pub high: HeadExposure,
    /// Every draw's exposure, in draw order.
    pub draws: Vec<HeadExposure>,
}

/// The `q` quantile of `values` (linear between order statistics).
pub fn quantile(values: &[f64], q: f64) -> f64 {
    let mut sorted = values.to_vec();
    sorted.sort_by(f64::total_cmp);
    if sorted.is_empty() {
        return f64::NAN;
    }
    let position = q.clamp(0.0, 1.0) * (sorted.len() - 1) as f64;
    let (below, frac) = (position.floor() as usize, position.fract());
    let above = (below + 1).min(sorted.len() - 1);
    sorted[below] + frac * (sorted[above] - sorted[below])
}

/// `draws` parameter sets from `uncertainty` around `params` (deterministic for `seed`).
pub fn draw_params(
    params: &ModelParams,
    uncertainty: &StoredUncertainty,
    draws: usize,
    seed: u64,
) -> Result<Vec<ModelParams>> {
    let mean: Vec<f64> = uncertainty
        .parameters
        .iter()
        .map(|&id| params.get(id).ln())
        .collect();
    let gaussian = GaussianDraws::new(&mean, &uncertainty.covariance_ln_p)
        .ok_or_else(|| anyhow!("[fit.uncertainty]: the covariance is not a finite square"))?;
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    Ok((0..draws)
        .map(|_| {
            let mut p = *params;
            for (&id, theta) in uncertainty.parameters.iter().zip(gaussian.sample(&mut rng)) {
                p.set(id, theta.exp());
            }
            p
        })
        .collect())
}

/// `evaluate` of every parameter set in `sets`, spread over `threads` threads; the
/// results in the sets' order (they do not depend on `threads`).
pub fn evaluate_draws<T: Send>(
    sets: &[ModelParams],
    threads: usize,
    evaluate: impl Fn(&ModelParams) -> Result<T> + Sync,
) -> Result<Vec<T>> {
    crate::parallel::in_parallel(sets.len(), threads, |k| evaluate(&sets[k]))
        .into_iter()
        .collect()
}

/// Refuses a band of fewer than 2 draws (no spread to take quantiles of).
pub fn check_draws(draws: usize) -> Result<()> {
    if draws < 2 {
        bail!("--band: expected at least 2 draws, found {draws}");
    }
    Ok(())
}

/// The head exposure band of `params` for `recording` from `draws` parameter sets, spread
/// over `threads` threads (the result does not depend on it).
pub fn head_exposure_band(
    params: &ModelParams,
    uncertainty: &StoredUncertainty,
    recording: &Recording,
    draws: usize,
    seed: u64,
    threads: usize,
) -> Result<ExposureBand> {
    check_draws(draws)?;
    let fitted = head_exposure(params, recording)?;
    let sets = draw_params(params, uncertainty, draws, seed)?;
    let exposures = evaluate_draws(&sets, threads, |p| head_exposure(p, recording))?;
    let bound = |q: f64| {
        HeadExposure::from_values(core::array::from_fn(|i| {
            let column: Vec<f64> = exposures.iter().map(|e| e.values()[i]).collect();
            quantile(&column, q)
        }))
    };
    Ok(ExposureBand {
        fitted,
        low: bound(BAND_QUANTILES.0),
        high: bound(BAND_QUANTILES.1),
        draws: exposures,
    })
}
