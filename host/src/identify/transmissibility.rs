//! The measured transmissibility of a dataset's case: per subject by H1 with Welch
//! averaging (see [`super::spectral`] for the settings) and across subjects by the
//! geometric mean (see [`super::geomean`]); and the model's own H on a frequency grid, so
//! that measured and modelled H come from one place.

use anyhow::{Result, anyhow, bail};
use supine_core::model::{ModelParams, Subject, SystemMatrices, Transmissibility};

use super::geomean::geometric_mean_h;
use super::spectral::{self, H1Estimate, SpectralError, WelchSettings};
use crate::io::dataset::{Case, Dataset};

/// One subject's estimate.
#[derive(Clone, Debug, PartialEq)]
pub struct SubjectEstimate {
    /// The subject's id.
    pub id: String,
    /// Height and mass.
    pub subject: Subject,
    /// H1 and coherence.
    pub estimate: H1Estimate,
}

/// The measured transmissibility of one case of a dataset.
#[derive(Clone, Debug, PartialEq)]
pub struct CaseEstimate {
    /// The recordings' sample rate, Hz.
    pub sample_rate_hz: f64,
    /// The Welch settings used.
    pub settings: WelchSettings,
    /// Frequencies, Hz.
    pub freqs_hz: Vec<f64>,
    /// Each subject's estimate.
    pub subjects: Vec<SubjectEstimate>,
    /// The geometric mean across subjects.
    pub geomean: Vec<Transmissibility>,
}

impl CaseEstimate {
    /// The subjects' mean height and mass (the fitted model's subject).
    pub fn mean_subject(&self) -> Subject {
        let n = self.subjects.len().max(1) as f64;
        Subject {
            height_m: self
                .subjects
                .iter()
                .map(|s| s.subject.height_m)
                .sum::<f64>()
                / n,
            mass_kg: self.subjects.iter().map(|s| s.subject.mass_kg).sum::<f64>() / n,
        }
    }
}

/// Reads the selected recordings and estimates H per subject and the geometric mean.
pub fn estimate(
    dataset: &Dataset,
    case: Case,
    only: Option<&str>,
    exclude: &[String],
    resolution_hz: f64,
    fmin_hz: f64,
    fmax_hz: f64,
) -> Result<CaseEstimate> {
    if !(resolution_hz.is_finite() && resolution_hz > 0.0) {
        bail!("--resolution-hz: expected a positive number, found {resolution_hz}");
    }
    if !(fmin_hz.is_finite() && fmax_hz.is_finite() && 0.0 <= fmin_hz && fmin_hz < fmax_hz) {
        bail!("--fmin/--fmax: expected 0 <= fmin < fmax, found {fmin_hz} and {fmax_hz}");
    }
    let selected = dataset.select(case, only, exclude)?;
    let recordings = dataset.read_case(case, &selected)?;
    let sample_rate_hz = recordings[0].recording.sample_rate_hz();
    let settings = WelchSettings::for_resolution(sample_rate_hz, resolution_hz);
    // One subject's spectra per job, on every core; errors in the subjects' order.
    let estimates = crate::parallel::in_parallel(recordings.len(), 0, |k| {
        let rec = &recordings[k].recording;
        let inputs = [0, 1, 2].map(|a| rec.platform_m_s2[a].as_slice());
        let outputs = core::array::from_fn(|j| rec.sensors_m_s2[j].as_slice());
        spectral::h1(inputs, outputs, sample_rate_hz, &settings, fmin_hz, fmax_hz)
    });
    let mut subjects = Vec::with_capacity(recordings.len());
    for (r, estimate) in recordings.iter().zip(estimates) {
        let rec = &r.recording;
        let estimate = estimate.map_err(|e| match e {
            SpectralError::TooShort { .. } => anyhow!(
                "{}: {e} (at {sample_rate_hz:.3} Hz for {resolution_hz} Hz resolution: record {:.2} s)",
                rec.path.display(),
                rec.duration_s()
            ),
            _ => anyhow!(
                "{}: columns platform_x_m_s2, platform_y_m_s2, platform_z_m_s2: {e}",
                rec.path.display()
            ),
        })?;
        if estimate.freqs_hz.is_empty() {
            bail!(
                "no Welch bin between {fmin_hz} and {fmax_hz} Hz at {:.4} Hz resolution",
                settings.resolution_hz(sample_rate_hz)
            );
        }
        subjects.push(SubjectEstimate {
            id: r.entry.id.clone(),
            subject: r.entry.subject,
            estimate,
        });
    }
    let freqs_hz = subjects[0].estimate.freqs_hz.clone();
    let all: Vec<Vec<Transmissibility>> = subjects.iter().map(|s| s.estimate.h.clone()).collect();
    Ok(CaseEstimate {
        sample_rate_hz,
        settings,
        freqs_hz,
        geomean: geometric_mean_h(&all),
        subjects,
    })
}

/// The model's H at each of `freqs_hz` (`params` must be valid).
pub fn model_h(params: &ModelParams, freqs_hz: &[f64]) -> Result<Vec<Transmissibility>> {
    let matrices = SystemMatrices::assemble(params);
    freqs_hz
        .iter()
        .map(|&f| matrices.transmissibility(f).map_err(|e| anyhow!("{e}")))
        .collect()
}
