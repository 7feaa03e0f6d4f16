//! The transmissibility CSV: `freq_hz,output,input,magnitude,phase_rad[,coherence]`, one row
//! per frequency, output and input, frequency-major. Shared by `supine model` and
//! `supine transmissibility` so that measured and modelled files line up; `supine model
//! --quantity joints` writes the joint response in the same form.

use std::path::Path;

use anyhow::Result;
use nalgebra::Complex;
use supine_core::model::{Axis, Channel, JointOutput, JointResponse, Output, Transmissibility};

use crate::io::output::write_atomically;

/// One component of H at one frequency.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HRow {
    /// Frequency, Hz.
    pub freq_hz: f64,
    /// The sensor channel or joint output.
    pub output: Channel,
    /// The support axis.
    pub input: Axis,
    /// H (m/s^2 per m/s^2 for a sensor; m or rad per m/s^2 for a joint).
    pub value: Complex<f64>,
    /// Multiple coherence of the output, for a single subject's estimate.
    pub coherence: Option<f64>,
}

/// All 27 components per frequency, frequency-major, with coherence if given.
pub fn rows(freqs_hz: &[f64], h: &[Transmissibility], coherence: Option<&[[f64; 9]]>) -> Vec<HRow> {
    let mut rows = Vec::with_capacity(freqs_hz.len() * 27);
    for (f, &freq_hz) in freqs_hz.iter().enumerate() {
        for output in Output::ALL {
            for input in Axis::ALL {
                rows.push(HRow {
                    freq_hz,
                    output: Channel::Sensor(output),
                    input,
                    value: h[f][(output.index(), input.index())],
                    coherence: coherence.map(|c| c[f][output.index()]),
                });
            }
        }
    }
    rows
}

/// The ten joint outputs' response to the three inputs per frequency, frequency-major.
pub fn joint_rows(freqs_hz: &[f64], h: &[JointResponse]) -> Vec<HRow> {
    let mut rows = Vec::with_capacity(freqs_hz.len() * 30);
    for (&freq_hz, h) in freqs_hz.iter().zip(h) {
        for output in JointOutput::ALL {
            for input in Axis::ALL {
                rows.push(HRow {
                    freq_hz,
                    output: Channel::Joint(output),
                    input,
                    value: h[(output.index(), input.index())],
                    coherence: None,
                });
            }
        }
    }
    rows
}

/// The header without the coherence column.
pub const HEADER: &str = "freq_hz,output,input,magnitude,phase_rad";

/// Writes the rows; adds the `coherence` column when every row has one.
pub fn write(path: &Path, rows: &[HRow]) -> Result<()> {
    let with_coherence = !rows.is_empty() && rows.iter().all(|r| r.coherence.is_some());
    write_atomically(path, |w| {
        let mut csv = csv::Writer::from_writer(w);
        let mut header: Vec<&str> = HEADER.split(',').collect();
        if with_coherence {
            header.push("coherence");
        }
        csv.write_record(&header)?;
        for row in rows {
            let mut record = vec![
                format!("{}", row.freq_hz),
                row.output.name().to_string(),
                row.input.name().to_string(),
                format!("{}", row.value.norm()),
                format!("{}", row.value.arg()),
            ];
            if with_coherence {
                record.push(format!("{}", row.coherence.unwrap_or(f64::NAN)));
            }
            csv.write_record(&record)?;
        }
        csv.flush()?;
        Ok(())
    })
}

/// Most frequencies a grid may hold: 100,000 (27 CSV rows each).
pub const MAX_GRID_POINTS: usize = 100_000;

/// The frequencies from `fmin_hz` in steps of `df_hz` up to `fmax_hz` (inclusive within
/// a millionth of a step). Needs 0 < fmin < fmax, df > 0 and at most
/// [`MAX_GRID_POINTS`]; the errors name the flags of `supine model`.
pub fn frequency_grid(fmin_hz: f64, fmax_hz: f64, df_hz: f64) -> Result<Vec<f64>> {
    for (flag, value) in [("--fmin", fmin_hz), ("--fmax", fmax_hz), ("--df", df_hz)] {
        if !(value.is_finite() && value > 0.0) {
            anyhow::bail!("{flag} {value}: expected a frequency above 0 Hz");
        }
    }
    if fmax_hz <= fmin_hz {
        anyhow::bail!("--fmax {fmax_hz}: expected a frequency above --fmin {fmin_hz} Hz");
    }
    let steps = ((fmax_hz - fmin_hz) / df_hz + 1e-6).floor();
    if steps + 1.0 > MAX_GRID_POINTS as f64 {
        anyhow::bail!(
            "--df {df_hz}: {fmin_hz}..{fmax_hz} Hz would need {} frequencies, expected at most {MAX_GRID_POINTS}: raise --df",
            steps + 1.0
        );
    }
    Ok((0..=steps as usize)
        .map(|i| fmin_hz + i as f64 * df_hz)
        .collect())
}
