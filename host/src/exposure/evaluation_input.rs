//! A ride at the rate it is evaluated at. Every evaluation needs a sample rate the device
//! supports ([`SampleRate`]); a ride at another rate is converted first by the
//! band-limited [`crate::exposure::resample`] (zero phase), at the user's request only,
//! as it is read ([`Resampler::stream`]).
//!
//! Rides come from [`RideSource`] (opened by [`crate::io::ride_input`]), which also
//! accepts a file with only the platform columns (what `supine ride` writes), its sensor
//! columns zeros that no evaluation reads.

use anyhow::{Result, bail};
use supine_core::sample_rate::{SampleRate, SampleRateError};

use crate::exposure::resample::Resampler;
use crate::io::ride_rows::RideSource;

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
            resampled_from_hz: None,
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

    /// The values of `columns` (indices in [`COLUMNS`](crate::io::recording::COLUMNS)) of each sample at the evaluation's
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

/// Refuses a ride no longer than the weighting filters' warm-up: nothing would be evaluated.
pub fn check_warmup(path: &str, samples: usize, fs: f64, warmup_s: f64) -> Result<()> {
    let duration_s = samples as f64 / fs;
    if samples as f64 <= (warmup_s * fs).round() {
        bail!(
            "{path}: {duration_s:.3} s of samples at {fs} Hz: expected more than the \
             {warmup_s} s warm-up of the weighting filters"
        );
    }
    Ok(())
}
