//! Synthetic datasets from the model, for tests and benchmarks: subjects with their own
//! anthropometry and parameters, random tri-axial band-limited support acceleration, the
//! simulated sensor accelerations, and white measurement noise on every channel.
//!
//! Accuracy: the input is a sum of sinusoids on the record's own frequency grid (1/T),
//! flat between 0.5 and 16 Hz, made periodic over the record. It is generated directly at
//! the simulation rate (the largest multiple of the dataset rate up to 2 kHz) by an inverse
//! FFT, so the dataset's samples are exact samples of the same continuous signal. The
//! model runs at that rate with the core's first-order-hold realization, whose error
//! against the continuous response is (2 pi f / fs)^2 / 12: 0.02 % at 16 Hz and 2 kHz. It
//! runs over two periods of the input and keeps the second, which is the periodic steady
//! state (no start-up transient), and keeps every D-th sample (the response of a
//! band-limited input is band-limited, so no anti-alias filter is needed).

use std::path::{Path, PathBuf};

use anyhow::{Result, anyhow, bail};
use nalgebra::Complex;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use realfft::RealFftPlanner;
use supine_core::model::{ModalState, Model, ModelParams, Output, ParamId, Preset, Subject};
use supine_core::sample_rate::SampleRate;

use crate::io::dataset::{Dataset, SubjectEntry};
use crate::io::params_file::{self, ParamFile};
use crate::io::recording::Recording;

/// What to generate: plain data with the defaults.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SynthSettings {
    /// How many subjects.
    pub subjects: usize,
    /// Seed of every random draw (ChaCha8).
    pub seed: u64,
    /// Length of each recording, s.
    pub duration_s: f64,
    /// The dataset's sample rate, Hz.
    pub sample_rate_hz: f64,
    /// Standard deviation of the white noise added to every channel, m/s^2.
    pub noise_m_s2: f64,
    /// Band of the support acceleration, Hz.
    pub band_hz: (f64, f64),
    /// Rms of the support acceleration's vector magnitude, m/s^2 (split equally over axes).
    pub input_rms_m_s2: f64,
    /// Mean and standard deviation of height, m (the paper's subjects: 1.82 +- 0.084).
    pub height_m: (f64, f64),
    /// Mean and standard deviation of mass, kg (the paper's subjects: 81 +- 15).
    pub mass_kg: (f64, f64),
    /// Standard deviation of ln(parameter / paper value) per subject.
    pub param_log_sd: f64,
    /// Correlation of any two of a subject's ln(parameter / paper value), in [0, 1): a
    /// subject stiff (or damped) in one element tends to be in every other.
    pub param_correlation: f64,
}

impl Default for SynthSettings {
    fn default() -> Self {
        Self {
            subjects: 8,
            seed: 1,
            duration_s: 60.0,
            sample_rate_hz: 200.0,
            noise_m_s2: 0.01,
            band_hz: (0.5, 16.0),
            input_rms_m_s2: 0.5,
            height_m: (1.82, 0.084),
            mass_kg: (81.0, 15.0),
            param_log_sd: 0.15,
            param_correlation: 0.0,
        }
    }
}

/// One synthetic subject's truth.
#[derive(Clone, Debug, PartialEq)]
pub struct SynthSubject {
    /// `s1`, `s2`, ...
    pub id: String,
    /// Parameters on the rigid platform (this subject's anthropometry).
    pub rigid: ModelParams,
    /// Parameters on the litter board: the same joints, their own contacts.
    pub litter: ModelParams,
}

/// Draws the subjects' anthropometry and parameters: each of the 42 parameters is the
/// paper's value times e^(sd (sqrt(rho) z_s + sqrt(1 - rho) z)), with z_s one N(0, 1) draw
/// per subject shared by all its parameters (drawn only when rho > 0, so rho = 0 keeps
/// the stream of independent draws) and z one per parameter; the litter case keeps the
/// subject's joints and draws its contacts around the paper's litter-board values the
/// same way. Height and mass are normal, clipped to 1.5..2.1 m and 50..130 kg.
pub fn draw_subjects(settings: &SynthSettings, rng: &mut ChaCha8Rng) -> Result<Vec<SynthSubject>> {
    let unit = Normal::new(0.0, 1.0).map_err(|e| anyhow!("{e}"))?;
    let rigid_paper = ModelParams::preset(Preset::PaperRigid);
    let litter_paper = ModelParams::preset(Preset::PaperLitter);
    let mut out = Vec::with_capacity(settings.subjects);
    for s in 0..settings.subjects {
        let subject = Subject {
            height_m: (settings.height_m.0 + settings.height_m.1 * unit.sample(rng))
                .clamp(1.5, 2.1),
            mass_kg: (settings.mass_kg.0 + settings.mass_kg.1 * unit.sample(rng))
                .clamp(50.0, 130.0),
        };
        let rho = settings.param_correlation;
        let shared = if rho > 0.0 {
            rho.sqrt() * unit.sample(rng)
        } else {
            0.0
        };
        let own = (1.0 - rho).sqrt();
        let mut factor = || (settings.param_log_sd * (shared + own * unit.sample(rng))).exp();
        let mut rigid = rigid_paper;
        rigid.subject = subject;
        for id in ParamId::ALL {
            rigid.set(id, rigid_paper.get(id) * factor());
        }
        let mut litter = rigid;
        for id in ParamId::ALL.into_iter().filter(|id| id.is_contact()) {
            litter.set(id, litter_paper.get(id) * factor());
        }
        out.push(SynthSubject {
            id: format!("s{}", s + 1),
            rigid,
            litter,
        });
    }
    Ok(out)
}

/// A periodic, band-limited random signal per axis at `rate_hz` with `n` samples: complex
/// Gaussian coefficients on the bins inside `band_hz`, zero elsewhere, scaled so the vector
/// magnitude's rms is `rms_m_s2` (each axis rms_m_s2 / sqrt 3).
pub fn band_limited_input(
    rng: &mut ChaCha8Rng,
    n: usize,
    rate_hz: f64,
    band_hz: (f64, f64),
    rms_m_s2: f64,
) -> Result<[Vec<f64>; 3]> {
    let unit = Normal::new(0.0, 1.0).map_err(|e| anyhow!("{e}"))?;
    let inverse = RealFftPlanner::<f64>::new().plan_fft_inverse(n);
    let df_hz = rate_hz / n as f64;
    let axis_rms = rms_m_s2 / 3f64.sqrt();
    let mut axes: [Vec<f64>; 3] = Default::default();
    for axis in &mut axes {
        let mut spectrum = vec![Complex::new(0.0, 0.0); n / 2 + 1];
        let mut any = false;
        for (k, c) in spectrum.iter_mut().enumerate() {
            let f = k as f64 * df_hz;
            // Exclude the Nyquist bin, which must be real.
            if f >= band_hz.0 && f <= band_hz.1 && (k > 0) && (2 * k != n) {
                *c = Complex::new(unit.sample(rng), unit.sample(rng));
                any = true;
            }
        }
        if !any {
            bail!(
                "the record is too short for any frequency in {:?} Hz",
                band_hz
            );
        }
        let mut signal = vec![0.0; n];
        inverse
            .process(&mut spectrum, &mut signal)
            .map_err(|e| anyhow!("inverse FFT: {e}"))?;
        let rms = (signal.iter().map(|x| x * x).sum::<f64>() / n as f64).sqrt();
        for x in &mut signal {
            *x *= axis_rms / rms;
        }
        *axis = signal;
    }
    Ok(axes)
}

/// The sensor accelerations (m/s^2, H's output order) of `params` driven by the periodic
/// `input_m_s2` sampled at `rate_hz`, in periodic steady state, keeping every
/// `decimation`-th sample.
pub fn simulate_periodic(
    params: &ModelParams,
    input_m_s2: &[Vec<f64>; 3],
    rate_hz: f64,
    decimation: usize,
) -> Result<[Vec<f64>; 9]> {
    let model = Model::new(params).map_err(|e| anyhow!("{e}"))?;
    let realization = model
        .realization(rate_hz, &Output::ALL)
        .map_err(|e| anyhow!("{e}"))?;
    let n = input_m_s2[0].len();
    let mut state = ModalState::<f64>::default();
    let at = |k: usize| [input_m_s2[0][k], input_m_s2[1][k], input_m_s2[2][k]];
    for k in 0..n {
        realization.step(&mut state, at(k));
    }
    let mut out: [Vec<f64>; 9] = Default::default();
    for k in 0..n {
        let y = realization.step(&mut state, at(k));
        if k % decimation == 0 {
            for (column, value) in out.iter_mut().zip(y) {
                column.push(value);
            }
        }
    }
    Ok(out)
}

/// One recording of `params`: fresh input from `rng`, simulated, with noise.
pub fn synth_recording(
    params: &ModelParams,
    settings: &SynthSettings,
    rng: &mut ChaCha8Rng,
    path: PathBuf,
) -> Result<Recording> {
    let fs = settings.sample_rate_hz;
    let max_hz = f64::from(SampleRate::MAX_HZ);
    if !(fs.is_finite() && fs > 0.0 && fs <= max_hz) {
        bail!("--fs: expected a sample rate in (0, {max_hz}] Hz, found {fs}");
    }
    if fs < 2.0 * settings.band_hz.1 {
        bail!("--fs: expected at least twice the 16 Hz band edge, found {fs} Hz");
    }
    let decimation = (max_hz / fs).floor().max(1.0) as usize;
    let sim_rate_hz = fs * decimation as f64;
    let n = (settings.duration_s * fs).round() as usize;
    if n < 16 {
        bail!("--duration-s: expected at least 16 samples, found {n}");
    }
    let input_hi = band_limited_input(
        rng,
        n * decimation,
        sim_rate_hz,
        settings.band_hz,
        settings.input_rms_m_s2,
    )?;
    let mut sensors = simulate_periodic(params, &input_hi, sim_rate_hz, decimation)?;
    let mut platform: [Vec<f64>; 3] =
        core::array::from_fn(|a| input_hi[a].iter().step_by(decimation).copied().collect());
    if settings.noise_m_s2 > 0.0 {
        let noise = Normal::new(0.0, settings.noise_m_s2).map_err(|e| anyhow!("{e}"))?;
        for column in platform.iter_mut().chain(sensors.iter_mut()) {
            for x in column.iter_mut() {
                *x += noise.sample(rng);
            }
        }
    }
    Ok(Recording::from_columns(path, fs, platform, sensors))
}

/// Writes a whole dataset into `dir`: `sN_rigid.csv`, `sN_litter.csv`, the true parameters
/// `truth/sN_rigid.toml` and `truth/sN_litter.toml`, and `dataset.toml` last (a dataset
/// interrupted part-way has no `dataset.toml` and is not mistaken for a complete one).
pub fn write_dataset(
    dir: &Path,
    settings: &SynthSettings,
    mut progress: impl FnMut(usize, usize),
) -> Result<Vec<SynthSubject>> {
    if settings.subjects == 0 {
        bail!("--subjects: expected at least 1");
    }
    if !(settings.noise_m_s2 >= 0.0 && settings.noise_m_s2.is_finite()) {
        bail!(
            "--noise-m-s2: expected a finite number >= 0, found {}",
            settings.noise_m_s2
        );
    }
    if !(settings.param_log_sd >= 0.0 && settings.param_log_sd.is_finite()) {
        bail!(
            "--param-log-sd: expected a finite number >= 0, found {}",
            settings.param_log_sd
        );
    }
    std::fs::create_dir_all(dir.join("truth"))
        .map_err(|e| anyhow!("{}: cannot create: {e}", dir.display()))?;
    let _ = std::fs::remove_file(dir.join(crate::io::dataset::DATASET_FILE));
    let mut rng = ChaCha8Rng::seed_from_u64(settings.seed);
    let subjects = draw_subjects(settings, &mut rng)?;
    let mut entries = Vec::with_capacity(subjects.len());
    let total = 2 * subjects.len();
    for (i, s) in subjects.iter().enumerate() {
        let mut files = [PathBuf::new(), PathBuf::new()];
        for (c, (case, params)) in [("rigid", &s.rigid), ("litter", &s.litter)]
            .into_iter()
            .enumerate()
        {
            // One child generator per recording keeps each recording's draws independent.
            let mut child = ChaCha8Rng::seed_from_u64(rng.random());
            let file = dir.join(format!("{}_{case}.csv", s.id));
            let recording = synth_recording(params, settings, &mut child, file.clone())?;
            recording.write(&file)?;
            let mut fit = toml::Table::new();
            fit.insert("synthetic_truth".into(), true.into());
            fit.insert("case".into(), case.into());
            fit.insert("subject".into(), s.id.clone().into());
            fit.insert("seed".into(), (settings.seed as i64).into());
            params_file::save(
                &dir.join("truth").join(format!("{}_{case}.toml", s.id)),
                &ParamFile {
                    params: *params,
                    fit: Some(fit),
                    device: None,
                },
            )?;
            files[c] = file;
            progress(2 * i + c + 1, total);
        }
        let [rigid, litter] = files;
        entries.push(SubjectEntry {
            id: s.id.clone(),
            subject: s.rigid.subject,
            rigid: Some(rigid),
            litter: Some(litter),
            line: 0,
            column: 0,
        });
    }
    Dataset {
        dir: dir.to_path_buf(),
        subjects: entries,
    }
    .write_description()?;
    Ok(subjects)
}
