//! The frequency response of the ISO 2631-1 weighting filter the device runs (its f32
//! coefficients), beside the analog definition, on a grid of exact band centres, as CSV
//! (`supine weighting`).

use std::io::Write as _;
use std::path::Path;

use anyhow::{Result, bail};
use supine_core::sample_rate::SampleRate;
use supine_core::weighting::{WeightingKind, WeightingSettings, analog_response};

use crate::io::output::write_atomically;

/// Header of the response CSV.
pub const HEADER: &str = "freq_hz,magnitude,phase_rad,analog_magnitude";

/// The exact band centres `10^(n/per_decade)` Hz within `fmin..=fmax` and below `fs/2`.
pub fn centre_frequencies(fmin: f64, fmax: f64, per_decade: u32, fs: f64) -> Result<Vec<f64>> {
    if !(fmin.is_finite() && fmax.is_finite() && fmin > 0.0 && fmin <= fmax) {
        bail!("need 0 < --fmin <= --fmax, got {fmin} and {fmax}");
    }
    if per_decade == 0 || per_decade > 1000 {
        bail!("--per-decade must be within 1..=1000, got {per_decade}");
    }
    let n_per = per_decade as f64;
    // A little slack so that 0.1 Hz (n = -10) counts as inside 0.1..
    let lo = (n_per * fmin.log10() - 1e-9).ceil() as i64;
    let hi = (n_per * fmax.log10() + 1e-9).floor() as i64;
    let freqs: Vec<f64> = (lo..=hi)
        .map(|n| 10f64.powf(n as f64 / n_per))
        .filter(|&f| f < fs / 2.0)
        .collect();
    if freqs.is_empty() {
        bail!(
            "no band centre between {fmin} Hz and min({fmax}, fs/2 = {}) Hz",
            fs / 2.0
        );
    }
    Ok(freqs)
}

/// Writes the response of `filter` (a `kind` weighting) and of the analog weighting at
/// each of `freqs_hz` ([`HEADER`]), whole or not at all.
pub fn write_response(
    path: &Path,
    kind: WeightingKind,
    filter: &WeightingSettings,
    sample_rate: SampleRate,
    freqs_hz: &[f64],
) -> Result<()> {
    write_atomically(path, |w| {
        writeln!(w, "{HEADER}")?;
        for &f in freqs_hz {
            let h = filter.response(sample_rate, f);
            let a = analog_response(kind, f);
            writeln!(w, "{f},{},{},{}", h.abs(), h.arg(), a.abs())?;
        }
        Ok(())
    })
}
