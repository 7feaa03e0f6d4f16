//! What the identification commands print with `--json` (`supine synth`,
//! `transmissibility`, `fit`, `predict` on a lab recording, `model`, `modes`): one record
//! type per command, each field documented once with its unit. The keys follow the naming
//! rules of [`crate::schema`] (checked by `host/tests/output_names.rs`); the commands only
//! fill these in.

use std::path::PathBuf;

use serde::Serialize;
use supine_core::model::{DeviceRealization, Model};

use crate::identify::fit::band::{BAND_QUANTILES, ExposureBand, HeadExposure};
use crate::identify::fit::workflow::DatasetFit;
use crate::identify::fit::{Determination, ParamSummary};
use crate::identify::transmissibility::CaseEstimate;

/// `supine synth --json`: the synthetic dataset written.
#[derive(Clone, Debug, Serialize)]
pub struct SynthSummary {
    /// The dataset folder.
    pub out: PathBuf,
    /// Subjects written.
    pub subjects: usize,
    /// Cases per subject (rigid and litter board).
    pub cases: usize,
    /// Each recording's length, s.
    pub duration_s: f64,
    /// The recordings' sample rate, Hz.
    pub sample_rate_hz: f64,
    /// The seed of the synthetic noise and subjects.
    pub seed: u64,
    /// The folder of the true parameters.
    pub truth: PathBuf,
}

/// `supine transmissibility --json`: the measured H written, and how it was estimated.
#[derive(Clone, Debug, Serialize)]
pub struct TransmissibilitySummary {
    /// The H CSV.
    pub out: PathBuf,
    /// The subjects' ids, in the CSV's order.
    pub subjects: Vec<String>,
    /// Frequencies per subject.
    pub frequencies: usize,
    /// The frequency resolution, Hz.
    pub resolution_hz: f64,
    /// The recordings' sample rate, Hz.
    pub sample_rate_hz: f64,
    /// The spectral window (`hann`).
    pub window: &'static str,
    /// Samples per Welch segment.
    pub segment_samples: usize,
    /// Samples shared by consecutive segments.
    pub overlap_samples: usize,
    /// Segments averaged (the first subject's).
    pub segments: usize,
}

impl TransmissibilitySummary {
    /// The record of `estimate` written to `out`.
    pub fn new(estimate: &CaseEstimate, out: PathBuf) -> Self {
        Self {
            out,
            subjects: estimate.subjects.iter().map(|s| s.id.clone()).collect(),
            frequencies: estimate.freqs_hz.len(),
            resolution_hz: estimate.settings.resolution_hz(estimate.sample_rate_hz),
            sample_rate_hz: estimate.sample_rate_hz,
            window: "hann",
            segment_samples: estimate.settings.segment_len,
            overlap_samples: estimate.settings.overlap,
            segments: estimate.subjects.first().map_or(0, |s| s.estimate.segments),
        }
    }
}

/// `supine model --json`: the model response written.
#[derive(Clone, Debug, Serialize)]
pub struct ModelResponseSummary {
    /// The CSV.
    pub out: PathBuf,
    /// Grid frequencies.
    pub frequencies: usize,
    /// Response components per frequency (27 sensor ones, or 30 joint ones).
    pub components: usize,
    /// The grid's first frequency, Hz (null on an empty grid).
    pub fmin_hz: Option<f64>,
    /// The grid's last frequency, Hz (null on an empty grid).
    pub fmax_hz: Option<f64>,
    /// The grid's step, Hz.
    pub df_hz: f64,
}

/// `supine modes --json`: the model's modes and the device realization that keeps them.
#[derive(Clone, Debug, Serialize)]
pub struct ModesSummary {
    /// One entry per mode (a complex pair once), slowest first within each subsystem.
    pub modes: Vec<ModeRecord>,
    /// The device's discrete realization.
    pub device_realization: DeviceRealizationRecord,
}

/// One mode of [`ModesSummary`].
#[derive(Clone, Debug, Serialize)]
pub struct ModeRecord {
    /// The subsystem it belongs to (`longitudinal`, `lateral`, `vertical`...).
    pub subsystem: &'static str,
    /// Its natural frequency, Hz.
    pub frequency_hz: f64,
    /// Its damping ratio (null for a real pole).
    pub damping_ratio: Option<f64>,
    /// `oscillatory` or `real pole`.
    pub kind: &'static str,
    /// Whether the support acceleration excites it.
    pub reachable: bool,
}

/// The device realization of [`ModesSummary`].
#[derive(Clone, Debug, Serialize)]
pub struct DeviceRealizationRecord {
    /// Its sample rate, Hz.
    pub sample_rate_hz: f64,
    /// Modal blocks (two states each).
    pub modal_blocks: u8,
    /// Multiply-adds per sample for head x, y, z.
    pub multiply_adds_per_sample: usize,
}

impl ModesSummary {
    /// The modes of `model` and its realization `device` at `sample_rate_hz`.
    pub fn new(model: &Model, device: &DeviceRealization, sample_rate_hz: f64) -> Self {
        Self {
            modes: model
                .modes
                .components
                .iter()
                .map(|m| ModeRecord {
                    subsystem: m.subsystem.name(),
                    frequency_hz: m.natural_frequency_hz(),
                    damping_ratio: m.damping_ratio(),
                    kind: if m.damping_ratio().is_some() {
                        "oscillatory"
                    } else {
                        "real pole"
                    },
                    reachable: m.reachable,
                })
                .collect(),
            device_realization: DeviceRealizationRecord {
                sample_rate_hz,
                modal_blocks: device.block_count,
                multiply_adds_per_sample: device.multiply_adds_per_sample(),
            },
        }
    }
}

/// `supine fit --json`: the cost, every start, and every free parameter's verdict.
#[derive(Clone, Debug, Serialize)]
pub struct FitSummary {
    /// The parameter file written.
    pub out: PathBuf,
    /// The case fitted (`rigid` or `litter`).
    pub case: &'static str,
    /// The best start's final cost (half the sum of squared residuals).
    pub final_cost: f64,
    /// Residuals in the cost.
    pub residuals: usize,
    /// The index of the best start in `starts`.
    pub best_start: usize,
    /// Every start of the multistart.
    pub starts: Vec<FitStartRecord>,
    /// Every free parameter's value and verdict.
    pub parameters: Vec<FitParameterRecord>,
    /// Names of the parameters without effect on the cost.
    pub parameters_without_effect: Vec<String>,
    /// Time spent estimating the measured spectra, s.
    pub spectra_s: f64,
    /// Time spent in the solver, all starts, s.
    pub solver_s: f64,
}

/// One start of [`FitSummary`].
#[derive(Clone, Debug, Serialize)]
pub struct FitStartRecord {
    /// Where it started (`paper`, `random 1`...).
    pub label: String,
    /// Its cost at the start.
    pub initial_cost: f64,
    /// Its cost at the end.
    pub final_cost: f64,
    /// Solver iterations.
    pub iterations: usize,
    /// Cost evaluations.
    pub evaluations: usize,
    /// Its time in the solver, s.
    pub solver_s: f64,
}

/// One free parameter of [`FitSummary`].
#[derive(Clone, Debug, Serialize)]
pub struct FitParameterRecord {
    /// Its name in the parameter file.
    pub name: String,
    /// Its fitted value, in `unit`.
    pub value: f64,
    /// The unit of `value` and `interval_95`.
    pub unit: &'static str,
    /// `determined`, `weakly determined`, ... (the identifiability verdict).
    pub determination: &'static str,
    /// Standard error of its logarithm (null when undetermined).
    pub standard_error_ln: Option<f64>,
    /// Its 95 % confidence interval, in `unit` (null when undetermined).
    pub interval_95: Option<[f64; 2]>,
}

impl FitParameterRecord {
    fn new(p: &ParamSummary) -> Self {
        Self {
            name: p.id.to_string(),
            value: p.value,
            unit: p.id.unit(),
            determination: p.determination.name(),
            standard_error_ln: p.standard_error,
            interval_95: p.interval_95().map(|(lo, hi)| [lo, hi]),
        }
    }
}

impl FitSummary {
    /// The record of `fitted`, the `case` fit written to `out`.
    pub fn new(fitted: &DatasetFit, case: &'static str, out: PathBuf) -> Self {
        let result = &fitted.result;
        Self {
            out,
            case,
            final_cost: result.solution.cost,
            residuals: result.solution.residuals.len(),
            best_start: result.best,
            starts: result
                .starts
                .iter()
                .map(|s| FitStartRecord {
                    label: s.label.clone(),
                    initial_cost: s.initial_cost,
                    final_cost: s.final_cost,
                    iterations: s.iterations,
                    evaluations: s.evaluations,
                    solver_s: s.seconds,
                })
                .collect(),
            parameters: fitted
                .identifiability
                .params
                .iter()
                .map(FitParameterRecord::new)
                .collect(),
            parameters_without_effect: fitted.params_with(Determination::NoEffect),
            spectra_s: fitted.spectra_s,
            solver_s: fitted.solver_s,
        }
    }
}

/// `supine predict --json` on a lab recording: the prediction written, and with `--band`
/// the head exposure's prediction band.
#[derive(Clone, Debug, Serialize)]
pub struct LabPredictionSummary {
    /// The prediction CSV.
    pub out: PathBuf,
    /// Samples predicted.
    pub samples: usize,
    /// The band (null without `--band`).
    pub head_exposure_band: Option<HeadExposureBandRecord>,
}

/// The head exposure's prediction band of [`LabPredictionSummary`].
#[derive(Clone, Debug, Serialize)]
pub struct HeadExposureBandRecord {
    /// Parameter sets drawn.
    pub draws: usize,
    /// The band's lower and upper quantiles.
    pub quantiles: [f64; 2],
    /// The fitted parameters' exposure, m/s^2.
    pub fitted_m_s2: HeadAxesRecord,
    /// The lower quantile over the draws, m/s^2.
    pub low_m_s2: HeadAxesRecord,
    /// The upper quantile over the draws, m/s^2.
    pub high_m_s2: HeadAxesRecord,
}

/// Overall frequency-weighted rms per head axis and of the vector sum, in the unit of the
/// key that holds it.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct HeadAxesRecord {
    /// Head x.
    pub x: f64,
    /// Head y.
    pub y: f64,
    /// Head z.
    pub z: f64,
    /// The vector sum a_v.
    pub vector: f64,
}

impl From<&HeadExposure> for HeadAxesRecord {
    fn from(e: &HeadExposure) -> Self {
        let [x, y, z, vector] = e.values();
        Self { x, y, z, vector }
    }
}

impl From<&ExposureBand> for HeadExposureBandRecord {
    fn from(b: &ExposureBand) -> Self {
        Self {
            draws: b.draws.len(),
            quantiles: [BAND_QUANTILES.0, BAND_QUANTILES.1],
            fitted_m_s2: (&b.fitted).into(),
            low_m_s2: (&b.low).into(),
            high_m_s2: (&b.high).into(),
        }
    }
}
