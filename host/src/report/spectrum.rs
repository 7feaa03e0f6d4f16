//! Power spectral densities for the report's frequency charts: per axis, the litter input
//! and the predicted head, and the head weighted as the device weights it, so that narrow
//! lines (a helicopter's blade passage) show where a time chart is only a dense band.
//!
//! Welch's method of [`crate::identify::spectral::psd`] (Hann, 50 % overlap, one-sided
//! density), with the segment chosen here: the resolution [`TARGET_RESOLUTION_HZ`] when
//! the leg holds [`MIN_SEGMENTS`] such segments, coarser for a short leg. A leg's spectra
//! are taken sample by sample ([`LegSpectra`], one [`WelchStream`] per signal), so memory
//! holds a segment per signal whatever the leg's length.

use anyhow::{Result, anyhow};
use supine_core::blob::DeviceParams;
use supine_core::weighting::analog_response;

use crate::identify::spectral::{WelchSettings, WelchStream, psd};

/// The finest resolution asked for, Hz: a quarter hertz separates a rotor's lines.
pub const TARGET_RESOLUTION_HZ: f64 = 0.25;
/// The fewest Welch segments averaged (a smoother estimate than the identification's 4).
pub const MIN_SEGMENTS: usize = 8;
/// Shortest segment, samples.
const MIN_SEGMENT_LEN: usize = 64;
/// Highest frequency charted, Hz: the weightings end at 80 Hz.
pub const MAX_CHART_HZ: f64 = 100.0;

/// The spectra of one axis.
#[derive(Clone, Debug, PartialEq)]
pub struct AxisSpectrum {
    /// Bin frequencies, Hz (0 to the chart's top).
    pub freqs_hz: Vec<f64>,
    /// Litter input, (m/s^2)^2/Hz.
    pub input: Vec<f64>,
    /// Predicted head, (m/s^2)^2/Hz.
    pub head: Vec<f64>,
    /// Predicted head weighted (|W(f)|^2 times `head`), (m/s^2)^2/Hz.
    pub head_weighted: Vec<f64>,
    /// The weighting's name (`wd`, `wj`, `wk`).
    pub weighting: &'static str,
}

/// Welch settings for `samples` at `fs_hz`: the segment for [`TARGET_RESOLUTION_HZ`],
/// halved until [`MIN_SEGMENTS`] fit (never below `MIN_SEGMENT_LEN`).
pub fn settings_for(samples: usize, fs_hz: f64) -> WelchSettings {
    let mut s = WelchSettings::for_resolution(fs_hz, TARGET_RESOLUTION_HZ);
    s.min_segments = MIN_SEGMENTS;
    while s.segment_len > MIN_SEGMENT_LEN && s.segment_count(samples) < MIN_SEGMENTS {
        s.segment_len /= 2;
        s.overlap = s.segment_len / 2;
    }
    s
}

/// One-sided PSD of `x` at `fs_hz` with [`settings_for`], Hz and (unit)^2/Hz.
pub fn density(x: &[f64], fs_hz: f64) -> Result<(Vec<f64>, Vec<f64>)> {
    let mut settings = settings_for(x.len(), fs_hz);
    // A leg too short for eight segments still gets what it holds.
    settings.min_segments = settings.segment_count(x.len()).clamp(1, MIN_SEGMENTS);
    psd(x, fs_hz, &settings).map_err(|e| anyhow!("spectrum: {e}"))
}

/// The spectra of one leg, taken sample by sample: the litter input and the predicted
/// head on each axis.
pub struct LegSpectra {
    input: [WelchStream; 3],
    head: [WelchStream; 3],
}

impl LegSpectra {
    /// The spectra of a leg of `samples` at `fs_hz`, with [`density`]'s settings.
    pub fn new(samples: usize, fs_hz: f64) -> Result<Self> {
        let mut settings = settings_for(samples, fs_hz);
        // A leg too short for eight segments still gets what it holds.
        settings.min_segments = settings.segment_count(samples).clamp(1, MIN_SEGMENTS);
        let stream = || WelchStream::new(&settings, fs_hz).map_err(|e| anyhow!("spectrum: {e}"));
        Ok(Self {
            input: [stream()?, stream()?, stream()?],
            head: [stream()?, stream()?, stream()?],
        })
    }

    /// Takes one sample's input and predicted head (x, y, z, m/s^2).
    pub fn push(&mut self, input_m_s2: [f64; 3], head_m_s2: [f64; 3]) {
        for axis in 0..3 {
            self.input[axis].push(input_m_s2[axis]);
            self.head[axis].push(head_m_s2[axis]);
        }
    }

    /// Each axis' spectra, the head weighted with the weighting `params` maps to it.
    pub fn finish(&self, params: &DeviceParams) -> Result<Vec<AxisSpectrum>> {
        let kinds = params.exposure.config.axes.axes().map(|a| a.kind);
        (0..3)
            .map(|axis| {
                let spectrum = |s: &WelchStream| s.finish().map_err(|e| anyhow!("spectrum: {e}"));
                let (freqs, input_psd) = spectrum(&self.input[axis])?;
                let (_, head_psd) = spectrum(&self.head[axis])?;
                let top = freqs.partition_point(|&f| f <= MAX_CHART_HZ);
                let kind = kinds[axis];
                let head_weighted = freqs[..top]
                    .iter()
                    .zip(&head_psd)
                    .map(|(&f, p)| analog_response(kind, f).abs().powi(2) * p)
                    .collect();
                Ok(AxisSpectrum {
                    freqs_hz: freqs[..top].to_vec(),
                    input: input_psd[..top].to_vec(),
                    head: head_psd[..top].to_vec(),
                    head_weighted,
                    weighting: kind.name(),
                })
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    #[test]
    fn a_sine_shows_at_its_frequency_with_its_power() {
        // 17.25 Hz, amplitude 0.8: mean square 0.32, all of it within a few bins.
        let fs = 500.0;
        let x: Vec<f64> = (0..60_000)
            .map(|k| 0.8 * (2.0 * PI * 17.25 * k as f64 / fs).sin())
            .collect();
        let (f, p) = density(&x, fs).unwrap();
        let df = f[1] - f[0];
        assert!(df <= TARGET_RESOLUTION_HZ + 1e-12, "{df}");
        let peak = (0..p.len()).max_by(|&a, &b| p[a].total_cmp(&p[b])).unwrap();
        assert!((f[peak] - 17.25).abs() <= df, "{}", f[peak]);
        let near: f64 = (0..p.len())
            .filter(|&k| (f[k] - 17.25).abs() <= 3.0 * df)
            .map(|k| p[k] * df)
            .sum();
        assert!((near - 0.32).abs() < 0.32 * 0.01, "{near}");
    }

    #[test]
    fn parseval_the_density_integrates_to_the_mean_square() {
        // Deterministic broadband noise (a sum of incommensurate sines), mean removed.
        let fs = 200.0;
        let n = 20_000;
        let x: Vec<f64> = (0..n)
            .map(|k| {
                let t = k as f64 / fs;
                (1..40)
                    .map(|m| (2.0 * PI * (0.37 + 2.3 * m as f64) * t + m as f64).sin() / m as f64)
                    .sum::<f64>()
            })
            .collect();
        let mean = x.iter().sum::<f64>() / n as f64;
        let ms = x.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / n as f64;
        let (f, p) = density(&x, fs).unwrap();
        let df = f[1] - f[0];
        let integral: f64 = p.iter().sum::<f64>() * df;
        assert!((integral - ms).abs() < 0.02 * ms, "{integral} vs {ms}");
    }

    #[test]
    fn a_short_leg_gets_a_coarser_resolution_and_eight_segments() {
        let s = settings_for(5_000, 500.0);
        assert!(s.segment_count(5_000) >= MIN_SEGMENTS);
        assert_eq!(s.segment_len, 1024);
        assert_eq!(settings_for(1_000_000, 500.0).segment_len, 2048);
    }

    #[test]
    fn a_spectrum_taken_sample_by_sample_is_the_whole_records_bit_for_bit() {
        // Deterministic noise, a length that leaves a partial segment at the end.
        let fs = 500.0;
        let n = 37_777;
        let x: Vec<f64> = (0..n)
            .map(|k| ((k * 7919 % 1013) as f64 / 1013.0 - 0.5) + (0.03 * k as f64).sin())
            .collect();
        for samples in [n, 5_000, 700] {
            let whole = density(&x[..samples], fs).unwrap();
            let mut settings = settings_for(samples, fs);
            settings.min_segments = settings.segment_count(samples).clamp(1, MIN_SEGMENTS);
            let mut stream = WelchStream::new(&settings, fs).unwrap();
            for &v in &x[..samples] {
                stream.push(v);
            }
            assert_eq!(stream.finish().unwrap(), whole, "{samples} samples");
        }
    }
}
