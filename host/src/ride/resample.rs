//! Band-limited sample-rate conversion for recordings: a Kaiser-windowed sinc evaluated at
//! every output instant (any ratio, including irrational ones such as 333.3 Hz to 500 Hz).
//!
//! # Method, and why this one
//! The output sample at time `t` is `y(t) = sum_n x[n] h(t - n/fs_in) / fs_in`, with
//! `h(t) = 2 fc sinc(2 fc t) w(t)` a low-pass at `fc` = [`CUTOFF_FRACTION`] of the lower
//! of the two rates, windowed by a Kaiser window of half-width
//! `(A - 7.95) / (2 x 14.36 x df)` s (`A` = [`STOPBAND_ATTENUATION_DB`], `df` the
//! transition width, from [`PASSBAND_FRACTION`] to [`STOPBAND_FRACTION`] of the lower
//! rate: Kaiser's design formula). The kernel is symmetric, so the conversion has no
//! delay and no phase error: what the exposure and the model see is the recording's own
//! timing. Passband ripple is about `10^(-A/20)` = 1e-4; everything above half the lower
//! rate is attenuated by at least `A` dB, so downsampling does not alias.
//!
//! A dedicated crate (e.g. `rubato`) would do the same with a streaming, chunked design
//! built for audio, with a delay; a few dozen lines give a zero-delay, zero-phase
//! converter whose every constant is tested (`exposure_resample`). [`Resampler::stream`]
//! gives [`Resampler::process`]'s output bit for bit from a signal of known length read
//! a sample at a time, holding the kernel's width of it (and its first samples, for the
//! mirror), so a ride of any length converts in bounded memory.
//!
//! The kernel is tabulated at [`TABLE_PHASES`] points per input sample and interpolated
//! linearly (relative error about `(pi / TABLE_PHASES)^2 / 8`, 2e-5). Beyond the ends, the
//! recording is mirrored about its first and last sample (whole-sample symmetric), so a
//! slow signal is carried up to the edges instead of being tapered to zero.

use anyhow::{Result, bail};

/// Stopband attenuation of the anti-alias/anti-image kernel, dB.
pub const STOPBAND_ATTENUATION_DB: f64 = 80.0;
/// Upper edge of the passband (ripple about 1e-4), as a fraction of the lower rate.
pub const PASSBAND_FRACTION: f64 = 0.4;
/// Start of the stopband, as a fraction of the lower rate (its Nyquist frequency).
pub const STOPBAND_FRACTION: f64 = 0.5;
/// The kernel's -6 dB cutoff, as a fraction of the lower rate (middle of the transition).
pub const CUTOFF_FRACTION: f64 = 0.5 * (PASSBAND_FRACTION + STOPBAND_FRACTION);
/// Kernel table points per input sample period (linear interpolation between them).
pub const TABLE_PHASES: usize = 256;

/// A conversion from one sample rate to another, with its tabulated kernel.
#[derive(Clone, Debug)]
pub struct Resampler {
    /// Input rate, Hz.
    pub in_hz: f64,
    /// Output rate, Hz.
    pub out_hz: f64,
    /// Kernel half-width, in input samples.
    half_width_samples: f64,
    /// `h(u / fs_in) / fs_in` at `u = i / TABLE_PHASES` input samples, `i = 0, 1, ...`.
    table: Vec<f64>,
}

/// Zeroth-order modified Bessel function of the first kind (power series; x <= 50 here).
fn bessel_i0(x: f64) -> f64 {
    let q = x * x / 4.0;
    let (mut term, mut sum) = (1.0, 1.0);
    for k in 1..200 {
        term *= q / (k * k) as f64;
        sum += term;
        if term < sum * 1e-17 {
            break;
        }
    }
    sum
}

impl Resampler {
    /// Designs the kernel for `in_hz` to `out_hz` (both finite and positive).
    pub fn new(in_hz: f64, out_hz: f64) -> Result<Self> {
        if !(in_hz.is_finite() && in_hz > 0.0 && out_hz.is_finite() && out_hz > 0.0) {
            bail!("resampling needs finite positive rates, got {in_hz} Hz to {out_hz} Hz");
        }
        let low_hz = in_hz.min(out_hz);
        let cutoff_hz = CUTOFF_FRACTION * low_hz;
        let transition_hz = (STOPBAND_FRACTION - PASSBAND_FRACTION) * low_hz;
        let a = STOPBAND_ATTENUATION_DB;
        let beta = 0.1102 * (a - 8.7);
        let half_width_s = (a - 7.95) / (2.0 * 14.36 * transition_hz);
        let half_width_samples = half_width_s * in_hz;
        let points = (half_width_samples * TABLE_PHASES as f64).ceil() as usize + 2;
        let i0_beta = bessel_i0(beta);
        let table = (0..points)
            .map(|i| {
                let u = i as f64 / TABLE_PHASES as f64;
                let t_s = u / in_hz;
                let r = t_s / half_width_s;
                if r >= 1.0 {
                    return 0.0;
                }
                let x = 2.0 * cutoff_hz * t_s;
                let sinc = if x == 0.0 {
                    1.0
                } else {
                    (std::f64::consts::PI * x).sin() / (std::f64::consts::PI * x)
                };
                let window = bessel_i0(beta * (1.0 - r * r).sqrt()) / i0_beta;
                2.0 * cutoff_hz * sinc * window / in_hz
            })
            .collect();
        Ok(Self {
            in_hz,
            out_hz,
            half_width_samples,
            table,
        })
    }

    /// Output samples for `n_in` input samples: the same time span, first sample at the
    /// same instant, `floor((n_in - 1) out/in) + 1` samples.
    pub fn output_len(&self, n_in: usize) -> usize {
        if n_in == 0 {
            return 0;
        }
        ((n_in - 1) as f64 * self.out_hz / self.in_hz + 1e-9).floor() as usize + 1
    }

    /// The kernel at `u` input samples from its centre (interpolated from the table).
    fn kernel(&self, u: f64) -> f64 {
        let p = u.abs() * TABLE_PHASES as f64;
        let i = p.floor() as usize;
        let frac = p - i as f64;
        match (self.table.get(i), self.table.get(i + 1)) {
            (Some(a), Some(b)) => a + frac * (b - a),
            _ => 0.0,
        }
    }

    /// Converts one channel sampled at `in_hz` into one at `out_hz`.
    pub fn process(&self, x: &[f64]) -> Vec<f64> {
        let n = x.len();
        if n <= 1 {
            return x.to_vec();
        }
        let period = 2 * (n - 1);
        // Whole-sample symmetric extension: ... x2 x1 | x0 x1 ... x(n-1) | x(n-2) ...
        let mirror = |k: i64| -> f64 {
            let m = k.rem_euclid(period as i64) as usize;
            x[if m < n { m } else { period - m }]
        };
        let ratio = self.in_hz / self.out_hz;
        let hw = self.half_width_samples;
        (0..self.output_len(n))
            .map(|m| {
                let centre = m as f64 * ratio;
                let first = (centre - hw).ceil() as i64;
                let last = (centre + hw).floor() as i64;
                (first..=last)
                    .map(|k| mirror(k) * self.kernel(centre - k as f64))
                    .sum()
            })
            .collect()
    }
}

/// [`Resampler::process`] of `K` signals of one known length, taken a sample (`K`
/// values) at a time.
pub struct ResampledStream<'a, I, const K: usize> {
    resampler: &'a Resampler,
    input: I,
    n: usize,
    taken: usize,
    /// The signal's first samples, for the mirror about the first one.
    head: Vec<[f64; K]>,
    head_len: usize,
    /// Samples from `window_start` to `taken`.
    window: std::collections::VecDeque<[f64; K]>,
    window_start: usize,
    weights: Vec<f64>,
    next_out: usize,
    out_len: usize,
}

impl Resampler {
    /// The conversion of the `n` samples `input` gives, each of `K` signals, in the order
    /// of [`process`](Self::process)'s sums, so bit for bit its output. `n` must be at
    /// least four kernel widths (a shorter signal fits in memory anyway).
    pub fn stream<I: Iterator<Item = Result<[f64; K]>>, const K: usize>(
        &self,
        n: usize,
        input: I,
    ) -> Result<ResampledStream<'_, I, K>> {
        let head_len = self.half_width_samples.ceil() as usize + 3;
        if n < 4 * head_len {
            bail!(
                "{n} samples: too short to resample as a stream (expected at least {})",
                4 * head_len
            );
        }
        Ok(ResampledStream {
            resampler: self,
            input,
            n,
            taken: 0,
            head: Vec::with_capacity(head_len),
            head_len,
            window: std::collections::VecDeque::new(),
            window_start: 0,
            weights: Vec::new(),
            next_out: 0,
            out_len: self.output_len(n),
        })
    }
}

impl<I, const K: usize> ResampledStream<'_, I, K> {
    /// Sample `k` of the signal mirrored about its ends, as [`Resampler::process`] takes it.
    fn value(&self, k: i64) -> [f64; K] {
        let period = 2 * (self.n - 1);
        let m = k.rem_euclid(period as i64) as usize;
        let i = if m < self.n { m } else { period - m };
        match i.checked_sub(self.window_start) {
            Some(w) => self.window[w],
            None => self.head[i],
        }
    }
}

impl<I: Iterator<Item = Result<[f64; K]>>, const K: usize> Iterator for ResampledStream<'_, I, K> {
    type Item = Result<[f64; K]>;

    fn next(&mut self) -> Option<Result<[f64; K]>> {
        if self.next_out >= self.out_len {
            return None;
        }
        let r = self.resampler;
        let centre = self.next_out as f64 * (r.in_hz / r.out_hz);
        let hw = r.half_width_samples;
        let first = (centre - hw).ceil() as i64;
        let last = (centre + hw).floor() as i64;
        // Every sample up to the last one the kernel reaches (all of them near the end,
        // where the mirror reaches back).
        let needed = if last >= self.n as i64 - 1 {
            self.n
        } else {
            last as usize + 1
        };
        while self.taken < needed {
            let x = match self.input.next() {
                Some(Ok(x)) => x,
                Some(Err(e)) => return Some(Err(e)),
                None => {
                    return Some(Err(anyhow::anyhow!(
                        "the signal ended after {} of {} samples",
                        self.taken,
                        self.n
                    )));
                }
            };
            if self.head.len() < self.head_len {
                self.head.push(x);
            }
            self.window.push_back(x);
            self.taken += 1;
        }
        // Samples before the kernel's reach (less a margin for the mirror at the end,
        // where the output's centre may pass the last sample by rounding) are done with.
        let keep_from = first.max(0) as usize;
        while self.window_start + 2 < keep_from && !self.window.is_empty() {
            self.window.pop_front();
            self.window_start += 1;
        }
        self.weights.clear();
        self.weights
            .extend((first..=last).map(|k| r.kernel(centre - k as f64)));
        let y = std::array::from_fn(|c| {
            (first..=last)
                .zip(&self.weights)
                .map(|(k, w)| self.value(k)[c] * w)
                .sum()
        });
        self.next_out += 1;
        Some(Ok(y))
    }
}

/// Converts `x` from `in_hz` to `out_hz` (see [`Resampler`]).
pub fn resample(x: &[f64], in_hz: f64, out_hz: f64) -> Result<Vec<f64>> {
    Ok(Resampler::new(in_hz, out_hz)?.process(x))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_stream_converts_bit_for_bit_as_the_whole_signal() {
        let n = 6_007;
        let x: Vec<f64> = (0..n)
            .map(|k| ((k * 7919 % 1013) as f64 / 1013.0 - 0.5) + (0.01 * k as f64).sin())
            .collect();
        let y: Vec<f64> = x.iter().map(|v| 0.5 * v * v - 1.0).collect();
        for (from, to) in [
            (500.0, 333.3),
            (300.0, 500.0),
            (1000.0, 200.0),
            (200.0, 2000.0),
        ] {
            let r = Resampler::new(from, to).unwrap();
            let whole = [r.process(&x), r.process(&y)];
            let rows = (0..n).map(|k| Ok([x[k], y[k]]));
            let streamed: Vec<[f64; 2]> = r.stream(n, rows).unwrap().map(Result::unwrap).collect();
            assert_eq!(streamed.len(), whole[0].len(), "{from} -> {to}");
            for (k, s) in streamed.iter().enumerate() {
                assert_eq!(s[0].to_bits(), whole[0][k].to_bits(), "{from} -> {to}, {k}");
                assert_eq!(s[1].to_bits(), whole[1][k].to_bits(), "{from} -> {to}, {k}");
            }
        }
        // A signal too short for the stream is refused (and converted whole by callers).
        let r = Resampler::new(500.0, 200.0).unwrap();
        assert!(r.stream(10, (0..10).map(|_| Ok([0.0]))).is_err());
    }
}
