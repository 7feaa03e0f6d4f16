//! `supine weighting`: the frequency response of the ISO 2631-1 weighting filter the
//! device runs (its f32 coefficients), beside the analog definition, as CSV.

use std::io::Write;
use std::path::PathBuf;

use anyhow::{Result, anyhow, bail};
use supine_core::sample_rate::SampleRate;
use supine_core::weighting::{WeightingKind, WeightingSettings, analog_response};

use crate::commands::values;
use crate::output::write_atomically;

/// The weighting to describe.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Kind {
    /// Wk: vertical (recumbent: under the pelvis).
    Wk,
    /// Wd: horizontal (recumbent: both horizontal axes).
    Wd,
    /// Wj: recumbent, vertical under the head.
    Wj,
}

impl From<Kind> for WeightingKind {
    fn from(k: Kind) -> Self {
        match k {
            Kind::Wk => WeightingKind::Wk,
            Kind::Wd => WeightingKind::Wd,
            Kind::Wj => WeightingKind::Wj,
        }
    }
}

/// Arguments of `supine weighting`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Which weighting.
    #[arg(long, value_enum)]
    pub kind: Kind,
    /// Sample rate the filter is designed for, Hz (a rate the device supports).
    #[arg(
        long = "fs",
        value_name = "HZ",
        default_value_t = 500.0,
        help = values::sample_rate_help("Sample rate the filter is designed for")
    )]
    pub fs_hz: f32,
    /// Lowest frequency, Hz.
    #[arg(long = "fmin", value_name = "HZ", default_value_t = 0.1, value_parser = values::positive_hz)]
    pub fmin_hz: f64,
    /// Highest frequency, Hz (the grid also stops below fs/2).
    #[arg(long = "fmax", value_name = "HZ", default_value_t = 400.0, value_parser = values::positive_hz)]
    pub fmax_hz: f64,
    /// Frequencies per decade, at the exact centres 10^(n/N) Hz (10: one-third octaves).
    #[arg(long, default_value_t = 10)]
    pub per_decade: u32,
    /// Where to write the CSV (`freq_hz,magnitude,phase_rad,analog_magnitude`).
    #[arg(long)]
    pub out: PathBuf,
}

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

/// Writes the response of the device's filter and of the analog weighting on the grid.
pub fn run(args: &Args) -> Result<()> {
    let kind = WeightingKind::from(args.kind);
    let sample_rate =
        SampleRate::new(args.fs_hz).map_err(|e| anyhow!("--fs {}: {e}", args.fs_hz))?;
    let filter = WeightingSettings::new(kind, sample_rate)
        .map_err(|e| anyhow!("--fs {}: {e}", args.fs_hz))?;
    let freqs = centre_frequencies(
        args.fmin_hz,
        args.fmax_hz,
        args.per_decade,
        args.fs_hz as f64,
    )?;
    write_atomically(&args.out, |w| {
        writeln!(w, "freq_hz,magnitude,phase_rad,analog_magnitude")?;
        for &f in &freqs {
            let h = filter.response(sample_rate, f);
            let a = analog_response(kind, f);
            writeln!(w, "{f},{},{},{}", h.abs(), h.arg(), a.abs())?;
        }
        Ok(())
    })?;
    eprintln!(
        "wrote {} ({} frequencies, {kind} at {} Hz)",
        args.out.display(),
        freqs.len(),
        args.fs_hz
    );
    Ok(())
}
