//! Welch spectral estimates: cross-spectral densities, the H1 MIMO transmissibility
//! estimator with multiple coherence, and power spectral densities.
//!
//! Settings (the defaults of every command that estimates spectra):
//! - periodic Hann window (as `scipy.signal.get_window("hann", n)`);
//! - segment length: the smallest power of two n with fs / n <= the requested resolution
//!   (0.1 Hz by default: 2048 samples, 0.098 Hz, at 200 Hz);
//! - 50 % overlap; the mean of each segment is removed (scipy's `detrend="constant"`);
//! - one-sided density scaling 2 / (fs sum w^2), so a PSD is in (m/s^2)^2/Hz;
//! - at least [`MIN_SEGMENTS`] segments, so that the 3 x 3 input matrix is well averaged.
//!
//! Convention: S_ab(f) = E[conj(A(f)) B(f)] (scipy's `csd(a, b)`). With y = H x,
//! S_xy = S_xx H^T, so H1 = (S_xx^-1 S_xy)^T. Using A conj(B) instead would conjugate H
//! and flip every phase: the test on a known system checks the sign.

use std::f64::consts::PI;
use std::sync::Arc;

use nalgebra::{Complex, Matrix3, SMatrix};
use realfft::{RealFftPlanner, RealToComplex};
use supine_core::model::Transmissibility;

/// The fewest Welch segments an estimate accepts.
pub const MIN_SEGMENTS: usize = 4;
/// The largest condition number (largest over smallest eigenvalue) of the 3 x 3 input
/// matrix S_xx at which H1 is still computed: beyond it an input axis is dead or two axes
/// carry the same signal (an input amplitude ratio of 1e4, 80 dB), and S_xx^-1 S_xy
/// would be dominated by rounding instead of the data.
pub const MAX_INPUT_CONDITION: f64 = 1e8;
/// The default frequency resolution, Hz (the issue asks for at most 0.1 Hz).
pub const DEFAULT_RESOLUTION_HZ: f64 = 0.1;

/// How spectra are averaged: plain data, serializable into a report.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WelchSettings {
    /// Samples per segment (a power of two by default, not required).
    pub segment_len: usize,
    /// Samples shared by consecutive segments.
    pub overlap: usize,
    /// The fewest segments accepted.
    pub min_segments: usize,
}

/// Why spectra could not be estimated.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum SpectralError {
    /// The record is shorter than the settings need.
    #[error(
        "expected at least {needed} samples ({segments} Welch segments of {segment_len} samples with {overlap} overlapping), found {found}"
    )]
    TooShort {
        /// Samples needed.
        needed: usize,
        /// Segments required.
        segments: usize,
        /// Segment length, samples.
        segment_len: usize,
        /// Overlap, samples.
        overlap: usize,
        /// Samples available.
        found: usize,
    },
    /// Channels of different lengths.
    #[error("expected channels of equal length")]
    Lengths,
    /// S_xx is singular or ill-conditioned at some bins: H1 cannot separate the inputs.
    #[error(
        "the inputs' cross-spectral matrix Sxx is singular or ill-conditioned (condition number {condition:.1e}, limit {MAX_INPUT_CONDITION:.0e}) at {bins} of {of} bins in {from_hz:.3}-{to_hz:.3} Hz: an input axis is dead or two axes carry the same signal"
    )]
    IllConditioned {
        /// The lowest bad bin's frequency, Hz.
        from_hz: f64,
        /// The highest bad bin's frequency, Hz.
        to_hz: f64,
        /// How many bins are bad.
        bins: usize,
        /// How many bins were estimated.
        of: usize,
        /// The worst condition number (infinite when singular).
        condition: f64,
    },
    /// Invalid settings (zero length, overlap not below the segment length).
    #[error("invalid Welch settings: segment length {segment_len}, overlap {overlap}")]
    Settings {
        /// Segment length, samples.
        segment_len: usize,
        /// Overlap, samples.
        overlap: usize,
    },
}

impl WelchSettings {
    /// Hann, 50 % overlap, segment length the smallest power of two giving a resolution of
    /// `resolution_hz` or finer at `sample_rate_hz`.
    pub fn for_resolution(sample_rate_hz: f64, resolution_hz: f64) -> Self {
        let wanted = (sample_rate_hz / resolution_hz).ceil().max(8.0) as usize;
        let segment_len = wanted.next_power_of_two();
        Self {
            segment_len,
            overlap: segment_len / 2,
            min_segments: MIN_SEGMENTS,
        }
    }

    /// The bin spacing at `sample_rate_hz`, Hz.
    pub fn resolution_hz(&self, sample_rate_hz: f64) -> f64 {
        sample_rate_hz / self.segment_len as f64
    }

    /// How many segments fit in `samples`.
    pub fn segment_count(&self, samples: usize) -> usize {
        if samples < self.segment_len {
            0
        } else {
            (samples - self.segment_len) / self.step() + 1
        }
    }

    /// Samples from one segment's start to the next.
    pub fn step(&self) -> usize {
        self.segment_len - self.overlap
    }

    /// The fewest samples these settings accept.
    pub fn min_samples(&self) -> usize {
        self.segment_len + (self.min_segments.max(1) - 1) * self.step()
    }

    /// Checks the settings against a record length.
    pub fn check(&self, samples: usize) -> Result<(), SpectralError> {
        if self.segment_len < 2 || self.overlap >= self.segment_len {
            return Err(SpectralError::Settings {
                segment_len: self.segment_len,
                overlap: self.overlap,
            });
        }
        if self.segment_count(samples) < self.min_segments {
            return Err(SpectralError::TooShort {
                needed: self.min_samples(),
                segments: self.min_segments,
                segment_len: self.segment_len,
                overlap: self.overlap,
                found: samples,
            });
        }
        Ok(())
    }

    /// The one-sided frequency of bin `k`, Hz.
    pub fn bin_hz(&self, k: usize, sample_rate_hz: f64) -> f64 {
        k as f64 * self.resolution_hz(sample_rate_hz)
    }

    /// The bins whose frequencies lie in `[fmin_hz, fmax_hz]`.
    pub fn bins_in(
        &self,
        sample_rate_hz: f64,
        fmin_hz: f64,
        fmax_hz: f64,
    ) -> std::ops::Range<usize> {
        let df = self.resolution_hz(sample_rate_hz);
        let nyquist_bin = self.segment_len / 2;
        let lo = ((fmin_hz / df) - 1e-9).ceil().max(0.0) as usize;
        let hi = (((fmax_hz / df) + 1e-9).floor() as usize).min(nyquist_bin);
        lo.min(hi + 1)..hi + 1
    }
}

/// The periodic Hann window of length n.
pub fn hann(n: usize) -> Vec<f64> {
    (0..n)
        .map(|i| 0.5 - 0.5 * (2.0 * PI * i as f64 / n as f64).cos())
        .collect()
}

/// Welch-averaged one-sided spectra of every channel over a range of bins: the FFT of each
/// windowed, mean-removed segment, ready for products.
struct SegmentFfts {
    fft: Arc<dyn RealToComplex<f64>>,
    window: Vec<f64>,
    scale: f64,
}

impl SegmentFfts {
    fn new(settings: &WelchSettings, sample_rate_hz: f64) -> Self {
        let window = hann(settings.segment_len);
        let sum_sq: f64 = window.iter().map(|w| w * w).sum();
        let fft = RealFftPlanner::<f64>::new().plan_fft_forward(settings.segment_len);
        Self {
            fft,
            window,
            scale: 2.0 / (sample_rate_hz * sum_sq),
        }
    }

    /// The FFT of one segment of one channel into `out` (len n/2 + 1).
    fn transform(&self, segment: &[f64], scratch: &mut Vec<f64>, out: &mut [Complex<f64>]) {
        let mean = segment.iter().sum::<f64>() / segment.len() as f64;
        scratch.clear();
        scratch.extend(
            segment
                .iter()
                .zip(&self.window)
                .map(|(x, w)| (x - mean) * w),
        );
        // Lengths match by construction; realfft only fails on wrong lengths.
        let _ = self.fft.process(scratch, out);
    }

    /// The density scale of bin k of n (DC and Nyquist are not doubled).
    fn bin_scale(&self, k: usize, n: usize) -> f64 {
        if k == 0 || (n % 2 == 0 && k == n / 2) {
            self.scale / 2.0
        } else {
            self.scale
        }
    }
}

/// One-sided power spectral density of `x` by Welch's method, (unit)^2/Hz.
///
/// Returns the frequencies (Hz) and densities of every bin from 0 to Nyquist.
pub fn psd(
    x: &[f64],
    sample_rate_hz: f64,
    settings: &WelchSettings,
) -> Result<(Vec<f64>, Vec<f64>), SpectralError> {
    settings.check(x.len())?;
    let n = settings.segment_len;
    let ffts = SegmentFfts::new(settings, sample_rate_hz);
    let segments = settings.segment_count(x.len());
    let mut acc = vec![0.0; n / 2 + 1];
    let mut scratch = Vec::with_capacity(n);
    let mut spec = vec![Complex::new(0.0, 0.0); n / 2 + 1];
    for s in 0..segments {
        let start = s * settings.step();
        ffts.transform(&x[start..start + n], &mut scratch, &mut spec);
        for (a, z) in acc.iter_mut().zip(&spec) {
            *a += z.norm_sqr();
        }
    }
    let freqs = (0..=n / 2)
        .map(|k| settings.bin_hz(k, sample_rate_hz))
        .collect();
    let density = acc
        .iter()
        .enumerate()
        .map(|(k, a)| a * ffts.bin_scale(k, n) / segments as f64)
        .collect();
    Ok((freqs, density))
}

/// [`psd`] of one channel taken a sample at a time, for records of any length (the
/// report's spectra): each segment is transformed as soon as it is complete, so memory
/// holds one segment, and the result is [`psd`]'s bit for bit.
pub struct WelchStream {
    settings: WelchSettings,
    sample_rate_hz: f64,
    ffts: SegmentFfts,
    buffer: Vec<f64>,
    taken: usize,
    segments: usize,
    acc: Vec<f64>,
    scratch: Vec<f64>,
    spec: Vec<Complex<f64>>,
}

impl WelchStream {
    /// An empty estimate with `settings` at `sample_rate_hz`.
    pub fn new(settings: &WelchSettings, sample_rate_hz: f64) -> Result<Self, SpectralError> {
        if settings.segment_len < 2 || settings.overlap >= settings.segment_len {
            return Err(SpectralError::Settings {
                segment_len: settings.segment_len,
                overlap: settings.overlap,
            });
        }
        let n = settings.segment_len;
        Ok(Self {
            settings: *settings,
            sample_rate_hz,
            ffts: SegmentFfts::new(settings, sample_rate_hz),
            buffer: Vec::with_capacity(n),
            taken: 0,
            segments: 0,
            acc: vec![0.0; n / 2 + 1],
            scratch: Vec::with_capacity(n),
            spec: vec![Complex::new(0.0, 0.0); n / 2 + 1],
        })
    }

    /// Takes the next sample.
    pub fn push(&mut self, x: f64) {
        self.buffer.push(x);
        self.taken += 1;
        if self.buffer.len() == self.settings.segment_len {
            self.ffts
                .transform(&self.buffer, &mut self.scratch, &mut self.spec);
            for (a, z) in self.acc.iter_mut().zip(&self.spec) {
                *a += z.norm_sqr();
            }
            self.segments += 1;
            self.buffer.drain(..self.settings.step());
        }
    }

    /// The frequencies (Hz) and densities of every bin from 0 to Nyquist, as [`psd`]
    /// gives them for the samples taken.
    pub fn finish(&self) -> Result<(Vec<f64>, Vec<f64>), SpectralError> {
        self.settings.check(self.taken)?;
        let n = self.settings.segment_len;
        let freqs = (0..=n / 2)
            .map(|k| self.settings.bin_hz(k, self.sample_rate_hz))
            .collect();
        let density = self
            .acc
            .iter()
            .enumerate()
            .map(|(k, a)| a * self.ffts.bin_scale(k, n) / self.segments as f64)
            .collect();
        Ok((freqs, density))
    }
}

/// The H1 estimate of a 3-input, 9-output system at each bin of a frequency band.
#[derive(Clone, Debug, PartialEq)]
pub struct H1Estimate {
    /// Bin frequencies, Hz.
    pub freqs_hz: Vec<f64>,
    /// H at each frequency: rows outputs (H's order), columns inputs x, y, z.
    pub h: Vec<Transmissibility>,
    /// Multiple coherence of each output with the three inputs, 0..=1.
    pub coherence: Vec<[f64; 9]>,
    /// How many segments were averaged.
    pub segments: usize,
}

/// H1 = (S_xx^-1 S_xy)^T per bin with f in `[fmin_hz, fmax_hz]`, and the multiple coherence
/// gamma_j^2 = S_xy,j^H S_xx^-1 S_xy,j / S_yy,j of each output.
///
/// `inputs` are the three support accelerations, `outputs` the nine sensor accelerations,
/// all of one length and sampled at `sample_rate_hz`.
pub fn h1(
    inputs: [&[f64]; 3],
    outputs: [&[f64]; 9],
    sample_rate_hz: f64,
    settings: &WelchSettings,
    fmin_hz: f64,
    fmax_hz: f64,
) -> Result<H1Estimate, SpectralError> {
    let len = inputs[0].len();
    if inputs.iter().chain(outputs.iter()).any(|c| c.len() != len) {
        return Err(SpectralError::Lengths);
    }
    settings.check(len)?;
    let n = settings.segment_len;
    let bins = settings.bins_in(sample_rate_hz, fmin_hz, fmax_hz);
    let nb = bins.len();
    let ffts = SegmentFfts::new(settings, sample_rate_hz);
    let segments = settings.segment_count(len);
    let zero = Complex::new(0.0, 0.0);
    let mut sxx = vec![Matrix3::<Complex<f64>>::zeros(); nb];
    let mut sxy = vec![SMatrix::<Complex<f64>, 3, 9>::zeros(); nb];
    let mut syy = vec![[0.0f64; 9]; nb];
    let mut scratch = Vec::with_capacity(n);
    let mut x_spec = vec![vec![zero; n / 2 + 1]; 3];
    let mut y_spec = vec![vec![zero; n / 2 + 1]; 9];
    for s in 0..segments {
        let start = s * settings.step();
        for (c, spec) in x_spec.iter_mut().enumerate() {
            ffts.transform(&inputs[c][start..start + n], &mut scratch, spec);
        }
        for (c, spec) in y_spec.iter_mut().enumerate() {
            ffts.transform(&outputs[c][start..start + n], &mut scratch, spec);
        }
        for (b, k) in bins.clone().enumerate() {
            let x = [x_spec[0][k], x_spec[1][k], x_spec[2][k]];
            for i in 0..3 {
                let xi = x[i].conj();
                for l in 0..3 {
                    sxx[b][(i, l)] += xi * x[l];
                }
                for (j, y) in y_spec.iter().enumerate() {
                    sxy[b][(i, j)] += xi * y[k];
                }
            }
            for (j, y) in y_spec.iter().enumerate() {
                syy[b][j] += y[k].norm_sqr();
            }
        }
    }
    let mut estimate = H1Estimate {
        freqs_hz: Vec::with_capacity(nb),
        h: Vec::with_capacity(nb),
        coherence: Vec::with_capacity(nb),
        segments,
    };
    check_conditioning(&sxx, |b| settings.bin_hz(bins.start + b, sample_rate_hz))?;
    for (b, k) in bins.enumerate() {
        // The common scale factor cancels in H and in the coherence.
        let Some(ht) = sxx[b].lu().solve(&sxy[b]) else {
            let f = settings.bin_hz(k, sample_rate_hz);
            return Err(SpectralError::IllConditioned {
                from_hz: f,
                to_hz: f,
                bins: 1,
                of: nb,
                condition: f64::INFINITY,
            });
        };
        let mut coherence = [0.0; 9];
        for (j, c) in coherence.iter_mut().enumerate() {
            let mut num = 0.0;
            for i in 0..3 {
                num += (sxy[b][(i, j)].conj() * ht[(i, j)]).re;
            }
            *c = if syy[b][j] > 0.0 {
                num / syy[b][j]
            } else {
                0.0
            };
        }
        estimate.freqs_hz.push(settings.bin_hz(k, sample_rate_hz));
        estimate.h.push(ht.transpose());
        estimate.coherence.push(coherence);
    }
    Ok(estimate)
}

/// The condition number of a Hermitian positive semi-definite S_xx: largest over smallest
/// eigenvalue (infinite when singular, NaN-free).
pub fn input_condition(sxx: &Matrix3<Complex<f64>>) -> f64 {
    let eigen = sxx.symmetric_eigenvalues();
    let max = eigen.iter().copied().fold(0.0, f64::max);
    let min = eigen.iter().copied().fold(f64::INFINITY, f64::min);
    if min > 0.0 && max.is_finite() && !eigen.iter().any(|v| v.is_nan()) {
        max / min
    } else {
        f64::INFINITY
    }
}

/// Fails when S_xx is worse conditioned than [`MAX_INPUT_CONDITION`] at any bin, naming
/// the band of the bad bins.
fn check_conditioning(
    sxx: &[Matrix3<Complex<f64>>],
    bin_hz: impl Fn(usize) -> f64,
) -> Result<(), SpectralError> {
    let conditions: Vec<f64> = sxx.iter().map(input_condition).collect();
    let bad: Vec<usize> = (0..conditions.len())
        .filter(|&b| conditions[b] > MAX_INPUT_CONDITION)
        .collect();
    match (bad.first(), bad.last()) {
        (Some(&first), Some(&last)) => Err(SpectralError::IllConditioned {
            from_hz: bin_hz(first),
            to_hz: bin_hz(last),
            bins: bad.len(),
            of: sxx.len(),
            condition: bad.iter().map(|&b| conditions[b]).fold(0.0, f64::max),
        }),
        _ => Ok(()),
    }
}
