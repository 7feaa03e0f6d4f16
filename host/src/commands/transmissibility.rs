//! `supine transmissibility`: the measured H of a dataset's case, per subject by H1 with
//! Welch averaging (see `spectral` for the settings) and across subjects by the geometric
//! mean (see `geomean`). Written in `supine model`'s CSV format; one subject's file adds the
//! multiple coherence of each output.

use std::path::PathBuf;

use anyhow::{Result, anyhow, bail};
use supine_core::model::{Axis, Output, Subject, Transmissibility};

use crate::identify::geomean::geometric_mean_h;
use crate::identify::spectral::{
    self, DEFAULT_RESOLUTION_HZ, H1Estimate, SpectralError, WelchSettings,
};
use crate::io::dataset::{Case, Dataset};
use crate::io::h_csv::{self, HRow};

/// Arguments of `supine transmissibility`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// The dataset folder (with dataset.toml).
    #[arg(long)]
    pub dataset: PathBuf,
    /// Which case's recordings.
    #[arg(long, value_enum)]
    pub case: Case,
    /// One subject only (the file then adds a coherence column).
    #[arg(long, conflicts_with = "exclude")]
    pub subject: Option<String>,
    /// Subjects to leave out of the mean, comma-separated (e.g. s8).
    #[arg(long, value_delimiter = ',')]
    pub exclude: Vec<String>,
    /// Frequency resolution, Hz: the Welch segment is the smallest power of two giving it.
    #[arg(long, default_value_t = DEFAULT_RESOLUTION_HZ)]
    pub resolution_hz: f64,
    /// Lowest frequency written, Hz.
    #[arg(long, default_value_t = 0.5)]
    pub fmin: f64,
    /// Highest frequency written, Hz.
    #[arg(long, default_value_t = 16.0)]
    pub fmax: f64,
    /// Where to write the CSV.
    #[arg(long)]
    pub out: PathBuf,
}

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
    let mut subjects = Vec::with_capacity(recordings.len());
    for r in &recordings {
        let rec = &r.recording;
        let inputs = [0, 1, 2].map(|a| rec.platform_m_s2[a].as_slice());
        let outputs = core::array::from_fn(|j| rec.sensors_m_s2[j].as_slice());
        let estimate = spectral::h1(inputs, outputs, sample_rate_hz, &settings, fmin_hz, fmax_hz)
            .map_err(|e| match e {
                SpectralError::TooShort { .. } => anyhow!(
                    "{}: {e} (at {sample_rate_hz:.3} Hz for {resolution_hz} Hz resolution: record {:.2} s)",
                    rec.path.display(),
                    rec.duration_s()
                ),
                _ => anyhow!("{}: columns platform_x,y,z: {e}", rec.path.display()),
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

/// All 27 components per frequency, frequency-major, with coherence if given.
pub fn rows(freqs_hz: &[f64], h: &[Transmissibility], coherence: Option<&[[f64; 9]]>) -> Vec<HRow> {
    let mut rows = Vec::with_capacity(freqs_hz.len() * 27);
    for (f, &freq_hz) in freqs_hz.iter().enumerate() {
        for output in Output::ALL {
            for input in Axis::ALL {
                rows.push(HRow {
                    freq_hz,
                    output,
                    input,
                    value: h[f][(output.index(), input.index())],
                    coherence: coherence.map(|c| c[f][output.index()]),
                });
            }
        }
    }
    rows
}

/// Estimates and writes the CSV.
pub fn run(args: &Args) -> Result<()> {
    let dataset = Dataset::load(&args.dataset)?;
    let est = estimate(
        &dataset,
        args.case,
        args.subject.as_deref(),
        &args.exclude,
        args.resolution_hz,
        args.fmin,
        args.fmax,
    )?;
    let rows = match &args.subject {
        Some(_) => {
            let s = &est.subjects[0].estimate;
            rows(&s.freqs_hz, &s.h, Some(&s.coherence))
        }
        None => rows(&est.freqs_hz, &est.geomean, None),
    };
    h_csv::write(&args.out, &rows)?;
    eprintln!(
        "wrote {} ({} subject(s), {} frequencies at {:.4} Hz: Hann, {} samples, {} overlap, {} segments)",
        args.out.display(),
        est.subjects.len(),
        est.freqs_hz.len(),
        est.settings.resolution_hz(est.sample_rate_hz),
        est.settings.segment_len,
        est.settings.overlap,
        est.subjects[0].estimate.segments
    );
    Ok(())
}
