//! One-third-octave band values of a spectrum, as vibration meters give them: the rms in
//! each band of ISO 8041-1 (base-10 bands, IEC 61260-1), from 0.5 Hz to 80 Hz, the
//! frequency range of ISO 2631-1's weightings.
//!
//! Band `n` has the exact centre `10^(n/10)` Hz and edges a twentieth of a decade either
//! side; it is named by its nominal centre (0.5, 0.63, 0.8, 1, 1.25 ... 80 Hz). A band's
//! mean square is the one-sided PSD integrated over the band, the PSD taken as linear
//! between its bins (so a band narrower than the resolution, below about 2 Hz at 0.25 Hz,
//! gets the interpolated density times its width). Written here because it is a dozen
//! lines over the report's own Welch PSD; no crate computes bands from a given PSD.

use serde::Serialize;

use crate::report::spectrum::AxisSpectrum;

/// The nominal centres of the one-third-octave bands from 0.5 Hz to 80 Hz, Hz (ISO 8041-1,
/// IEC 61260-1 Annex E), in order: band `k` is number `k - 3` (1 Hz is band 0).
pub const NOMINAL_CENTRES_HZ: [f64; 23] = [
    0.5, 0.63, 0.8, 1.0, 1.25, 1.6, 2.0, 2.5, 3.15, 4.0, 5.0, 6.3, 8.0, 10.0, 12.5, 16.0, 20.0,
    25.0, 31.5, 40.0, 50.0, 63.0, 80.0,
];

/// The band number of the first centre (0.5 Hz): 1 Hz is band 0.
const FIRST_BAND: i32 = -3;

/// One band's value.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct BandValue {
    /// Nominal centre, Hz.
    pub centre_hz: f64,
    /// The rms in the band (square root of the integrated PSD), in the signal's unit.
    pub rms: f64,
}

/// One band of a leg's predicted head, weighted as the device weights each axis.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct HeadBand {
    /// Nominal centre, Hz.
    pub centre_hz: f64,
    /// The weighted head's rms in the band on x, y, z, m/s^2.
    pub head_weighted_m_s2: [f64; 3],
}

/// The weighted head's band values of a leg's three axis spectra (x, y, z).
pub fn head_weighted_bands(spectra: &[AxisSpectrum]) -> Vec<HeadBand> {
    let per_axis: Vec<Vec<BandValue>> = spectra
        .iter()
        .map(|s| band_values(&s.freqs_hz, &s.head_weighted))
        .collect();
    NOMINAL_CENTRES_HZ
        .iter()
        .enumerate()
        .map(|(k, &centre_hz)| HeadBand {
            centre_hz,
            head_weighted_m_s2: std::array::from_fn(|a| {
                per_axis
                    .get(a)
                    .and_then(|b| b.get(k))
                    .map_or(0.0, |b| b.rms)
            }),
        })
        .collect()
}

/// The exact centre and edges of band `k` of [`NOMINAL_CENTRES_HZ`], Hz.
pub fn band_edges_hz(k: usize) -> (f64, f64, f64) {
    let n = f64::from(FIRST_BAND + k as i32);
    let centre = 10f64.powf(n / 10.0);
    let half = 10f64.powf(1.0 / 20.0);
    (centre / half, centre, centre * half)
}

/// The lowest and highest edge of the bands, Hz: where a spectrum matters here.
pub fn span_hz() -> (f64, f64) {
    (
        band_edges_hz(0).0,
        band_edges_hz(NOMINAL_CENTRES_HZ.len() - 1).2,
    )
}

/// The band values of the one-sided PSD `psd` at bin frequencies `freqs_hz` (ascending,
/// evenly spaced); a band beyond the spectrum's top gets what part of it is covered.
pub fn band_values(freqs_hz: &[f64], psd: &[f64]) -> Vec<BandValue> {
    NOMINAL_CENTRES_HZ
        .iter()
        .enumerate()
        .map(|(k, &centre_hz)| {
            let (lo, _, hi) = band_edges_hz(k);
            BandValue {
                centre_hz,
                rms: integral(freqs_hz, psd, lo, hi).max(0.0).sqrt(),
            }
        })
        .collect()
}

/// The integral of the piecewise-linear `y(f)` through the points over `lo..hi`.
fn integral(f: &[f64], y: &[f64], lo: f64, hi: f64) -> f64 {
    let mut total = 0.0;
    for (fs, ys) in f.windows(2).zip(y.windows(2)) {
        let (a, b) = (fs[0].max(lo), fs[1].min(hi));
        if b <= a {
            continue;
        }
        let at = |x: f64| ys[0] + (ys[1] - ys[0]) * (x - fs[0]) / (fs[1] - fs[0]);
        total += 0.5 * (at(a) + at(b)) * (b - a);
    }
    total
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::report::spectrum::density;

    #[test]
    fn the_exact_centres_round_to_the_nominal_ones_and_the_bands_tile() {
        for (k, &nominal) in NOMINAL_CENTRES_HZ.iter().enumerate() {
            let (lo, centre, hi) = band_edges_hz(k);
            // IEC 61260-1: nominal centres are the exact ones to about 3 significant digits.
            assert!((centre / nominal - 1.0).abs() < 0.03, "{nominal}: {centre}");
            assert!(((hi / lo).log10() - 0.1).abs() < 1e-12);
            if k > 0 {
                assert!((band_edges_hz(k - 1).2 - lo).abs() < 1e-12);
            }
        }
        let (lo, hi) = span_hz();
        assert!(
            (lo - 0.4467).abs() < 1e-4 && (hi - 89.125).abs() < 1e-3,
            "{lo} {hi}"
        );
    }

    #[test]
    fn a_sine_lands_in_its_band_with_its_rms_and_the_bands_sum_to_the_total() {
        let fs = 500.0;
        let n = 120_000;
        let (amp, f0) = (0.8, 4.0);
        let noise_amp = 0.05;
        let mut seed = 7u64;
        let x: Vec<f64> = (0..n)
            .map(|i| {
                seed = seed
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                let noise = ((seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5) * 2.0 * noise_amp;
                amp * (2.0 * std::f64::consts::PI * f0 * i as f64 / fs).sin() + noise
            })
            .collect();
        let (freqs, psd) = density(&x, fs).unwrap();
        let bands = band_values(&freqs, &psd);
        let four = bands.iter().find(|b| b.centre_hz == 4.0).unwrap();
        // The sine's rms, plus the noise's share of the band (white: its width / fs/2).
        let (lo, _, hi) = band_edges_hz(9);
        let noise_ms = noise_amp * noise_amp / 3.0 * (hi - lo) / (fs / 2.0);
        let want = (amp * amp / 2.0 + noise_ms).sqrt();
        assert!(
            (four.rms / want - 1.0).abs() < 0.02,
            "{} vs {want}",
            four.rms
        );
        // Far from the sine, only the noise.
        let forty = bands.iter().find(|b| b.centre_hz == 40.0).unwrap();
        let (lo, _, hi) = band_edges_hz(19);
        let noise_only = (noise_amp * noise_amp / 3.0 * (hi - lo) / (fs / 2.0)).sqrt();
        assert!(
            (forty.rms / noise_only - 1.0).abs() < 0.15,
            "{} vs {noise_only}",
            forty.rms
        );
        // Parseval over the bands' span: the bands' mean squares add up to the PSD's.
        let (lo, hi) = span_hz();
        let total: f64 = bands.iter().map(|b| b.rms * b.rms).sum();
        assert!((total / integral(&freqs, &psd, lo, hi) - 1.0).abs() < 1e-9);
    }
}
