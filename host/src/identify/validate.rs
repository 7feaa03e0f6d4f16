//! Prediction of the sensor accelerations from a recording's support acceleration, and
//! validation against the measured ones (the paper's Table 5 and its R^2).
//!
//! Prediction is faithful to the continuous model: the core's first-order-hold realization
//! has a relative error of (2 pi f / fs)^2 / 12 for a band-limited input, 2 % at 16 Hz and
//! 200 Hz. So a recording slower than 1 kHz is first upsampled by an integer factor L to at
//! least 1 kHz (error at 16 Hz under 0.09 %) by band-limited (FFT) interpolation of its
//! even extension (which avoids the wrap-around jump), the model runs at fs L from rest,
//! and every L-th output is kept. The start-up transient from rest decays within a few
//! seconds; it is part of the prediction, as it would be on the device.

use std::io::Write as _;
use std::path::Path;

use anyhow::{Result, anyhow, bail};
use nalgebra::Complex;
use realfft::RealFftPlanner;
use serde::Serialize;
use supine_core::model::{
    JointOutput, JointUnit, ModalOutput, ModalState, Model, ModelParams, Output,
};
use supine_core::sample_rate::SampleRate;

use crate::identify::spectral::{DEFAULT_RESOLUTION_HZ, WelchSettings, psd};
use crate::io::output::write_atomically;
use crate::io::recording::{HEADER_LINE, PREDICTED_JOINT_COLUMNS, Recording};
use crate::plot::{Panel, Series, figure_svg};

/// The model runs at no less than this rate, Hz (upsampling slower recordings).
pub const MIN_SIMULATION_RATE_HZ: f64 = 1000.0;

/// Band-limited interpolation of `x` by an integer factor: the even extension [x, x
/// reversed] is periodic without a jump, its spectrum is zero-padded, and the first
/// len * factor samples of the inverse are kept.
pub fn upsample(x: &[f64], factor: usize) -> Result<Vec<f64>> {
    if factor <= 1 {
        return Ok(x.to_vec());
    }
    let n = x.len();
    let m = 2 * n;
    let mut ext: Vec<f64> = x.iter().chain(x.iter().rev()).copied().collect();
    let mut planner = RealFftPlanner::<f64>::new();
    let forward = planner.plan_fft_forward(m);
    let mut spectrum = forward.make_output_vec();
    forward
        .process(&mut ext, &mut spectrum)
        .map_err(|e| anyhow!("FFT: {e}"))?;
    let big = m * factor;
    let inverse = planner.plan_fft_inverse(big);
    let mut padded = inverse.make_input_vec();
    // Bins below the original Nyquist carry over; the Nyquist bin itself is dropped.
    for (k, c) in spectrum.iter().enumerate().take(n) {
        padded[k] = *c;
    }
    padded[0] = Complex::new(padded[0].re, 0.0);
    let mut out = inverse.make_output_vec();
    inverse
        .process(&mut padded, &mut out)
        .map_err(|e| anyhow!("inverse FFT: {e}"))?;
    let scale = 1.0 / m as f64;
    out.truncate(n * factor);
    for v in &mut out {
        *v *= scale;
    }
    Ok(out)
}

/// The nine sensor accelerations (m/s^2, H's output order) the model predicts for the
/// recording's support acceleration, one per input sample, starting from rest.
pub fn predict(params: &ModelParams, recording: &Recording) -> Result<[Vec<f64>; 9]> {
    simulate(params, recording, &Output::ALL)
}

/// The ten joint outputs (m or rad, `JointOutput::ALL` order) the model predicts for the
/// recording's support acceleration, as [`predict`] does the sensors.
pub fn predict_joints(params: &ModelParams, recording: &Recording) -> Result<[Vec<f64>; 10]> {
    simulate(params, recording, &JointOutput::ALL)
}

/// `outputs` of the model driven by the recording's support acceleration (see the module's
/// doc for the upsampling), one per input sample, from rest.
fn simulate<C: ModalOutput, const N: usize>(
    params: &ModelParams,
    recording: &Recording,
    outputs: &[C; N],
) -> Result<[Vec<f64>; N]> {
    let fs = recording.sample_rate_hz();
    // Slower recordings than the device's are upsampled for the simulation, down to a tenth.
    let (lowest_hz, highest_hz) = (
        f64::from(SampleRate::MIN_HZ) / 10.0,
        f64::from(SampleRate::MAX_HZ),
    );
    if !(lowest_hz..=highest_hz).contains(&fs) {
        bail!(
            "{}: column time_s: expected a sample rate of {lowest_hz}..={highest_hz} Hz, found {fs:.3} Hz",
            recording.path.display()
        );
    }
    let factor = (MIN_SIMULATION_RATE_HZ / fs).ceil().max(1.0) as usize;
    let rate_hz = fs * factor as f64;
    let model = Model::new(params).map_err(|e| anyhow!("{e}"))?;
    let realization = model
        .realization(rate_hz, outputs)
        .map_err(|e| anyhow!("{e}"))?;
    let inputs: Vec<Vec<f64>> = recording
        .platform_m_s2
        .iter()
        .map(|x| upsample(x, factor))
        .collect::<Result<_>>()?;
    let mut state = ModalState::<f64>::default();
    let mut out: [Vec<f64>; N] = core::array::from_fn(|_| Vec::with_capacity(recording.len()));
    let samples = inputs[0].iter().zip(&inputs[1]).zip(&inputs[2]);
    for (k, ((&x, &y), &z)) in samples.enumerate() {
        let y = realization.step(&mut state, [x, y, z]);
        if k % factor == 0 {
            for (column, v) in out.iter_mut().zip(y) {
                column.push(v);
            }
        }
    }
    Ok(out)
}

/// One channel's comparison.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ChannelValidation {
    /// The channel, e.g. `head_z`.
    pub channel: &'static str,
    /// Rms of the measured acceleration (mean removed), m/s^2.
    pub measured_rms_m_s2: f64,
    /// Rms of the predicted acceleration (mean removed), m/s^2.
    pub predicted_rms_m_s2: f64,
    /// rms(predicted - measured) / rms(measured), time domain.
    pub normalized_rms_error: f64,
}

/// The validation of a prediction against a recording.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Validation {
    /// The recording.
    pub recording: String,
    /// Per channel, in H's output order.
    pub channels: Vec<ChannelValidation>,
    /// The paper's R^2: the squared Pearson correlation of the nine rms pairs.
    pub r2_pearson: f64,
    /// 1 - SS_res / SS_tot of the nine rms values (predicted against measured).
    pub r2_determination: f64,
    /// Mean of |predicted - measured| / measured over the nine rms values.
    pub mean_relative_error: f64,
}

fn rms_mean_removed(x: &[f64]) -> f64 {
    let n = x.len().max(1) as f64;
    let mean = x.iter().sum::<f64>() / n;
    (x.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / n).sqrt()
}

/// Compares `predicted` with the recording's sensor channels.
pub fn validate(recording: &Recording, predicted: &[Vec<f64>; 9]) -> Validation {
    let channels: Vec<ChannelValidation> = Output::ALL
        .iter()
        .map(|o| {
            let measured = &recording.sensors_m_s2[o.index()];
            let pred = &predicted[o.index()];
            let measured_rms = rms_mean_removed(measured);
            let diff: Vec<f64> = pred.iter().zip(measured).map(|(p, m)| p - m).collect();
            ChannelValidation {
                channel: o.name(),
                measured_rms_m_s2: measured_rms,
                predicted_rms_m_s2: rms_mean_removed(pred),
                normalized_rms_error: rms_mean_removed(&diff) / measured_rms,
            }
        })
        .collect();
    let m: Vec<f64> = channels.iter().map(|c| c.measured_rms_m_s2).collect();
    let p: Vec<f64> = channels.iter().map(|c| c.predicted_rms_m_s2).collect();
    let n = m.len() as f64;
    let (mm, pm) = (m.iter().sum::<f64>() / n, p.iter().sum::<f64>() / n);
    let sxy: f64 = m.iter().zip(&p).map(|(a, b)| (a - mm) * (b - pm)).sum();
    let sxx: f64 = m.iter().map(|a| (a - mm).powi(2)).sum();
    let syy: f64 = p.iter().map(|b| (b - pm).powi(2)).sum();
    let ss_res: f64 = m.iter().zip(&p).map(|(a, b)| (b - a).powi(2)).sum();
    Validation {
        recording: recording.path.display().to_string(),
        r2_pearson: sxy * sxy / (sxx * syy),
        r2_determination: 1.0 - ss_res / sxx,
        mean_relative_error: m
            .iter()
            .zip(&p)
            .map(|(a, b)| (b - a).abs() / a)
            .sum::<f64>()
            / n,
        channels,
    }
}

/// The validation as a plain-text table.
pub fn table(v: &Validation) -> String {
    let mut s = format!("validation of {}\n", v.recording);
    s.push_str("channel     measured rms   predicted rms   nrmse (time domain)\n");
    for c in &v.channels {
        s.push_str(&format!(
            "{:<10} {:>12.5} {:>15.5} {:>12.4}\n",
            c.channel, c.measured_rms_m_s2, c.predicted_rms_m_s2, c.normalized_rms_error
        ));
    }
    s.push_str(&format!(
        "R^2 (Pearson r^2 of the 9 rms values, the paper's) = {:.4}\nR^2 (1 - SSres/SStot) = {:.4}\nmean relative rms error = {:.4}\n",
        v.r2_pearson, v.r2_determination, v.mean_relative_error
    ));
    s
}

/// The report's PSD figure: measured (black) and predicted (red) per channel, 0.5-16 Hz.
pub fn psd_svg(recording: &Recording, predicted: &[Vec<f64>; 9]) -> Result<String> {
    let fs = recording.sample_rate_hz();
    let mut settings = WelchSettings::for_resolution(fs, DEFAULT_RESOLUTION_HZ);
    while settings.segment_count(recording.len()) < settings.min_segments
        && settings.segment_len > 64
    {
        settings.segment_len /= 2;
        settings.overlap = settings.segment_len / 2;
    }
    let mut panels = Vec::with_capacity(9);
    for o in Output::ALL {
        let (f, measured) = psd(&recording.sensors_m_s2[o.index()], fs, &settings)
            .map_err(|e| anyhow!("{}: {e}", recording.path.display()))?;
        let (_, pred) = psd(&predicted[o.index()], fs, &settings)
            .map_err(|e| anyhow!("{}: {e}", recording.path.display()))?;
        let band = |v: &[f64]| -> Vec<(f64, f64)> {
            f.iter()
                .zip(v)
                .filter(|(fr, _)| (0.5..=16.0).contains(*fr))
                .map(|(fr, p)| (*fr, *p))
                .collect()
        };
        panels.push(Panel {
            title: o.name().to_string(),
            x_label: "frequency (Hz)".into(),
            y_label: "PSD ((m/s^2)^2/Hz)".into(),
            log_y: true,
            log_x: false,
            x_range: None,
            y_range: None,
            series: vec![
                Series::line(band(&measured), "#000000", 1.4, Some("measured")),
                Series::line(band(&pred), "#d62728", 1.4, Some("predicted")),
            ],
        });
    }
    figure_svg(
        &format!(
            "supine validate: {} (Welch, Hann, {} samples)",
            recording
                .path
                .file_name()
                .map_or_else(String::new, |n| n.to_string_lossy().into_owned()),
            settings.segment_len
        ),
        &panels,
        3,
    )
}

/// Writes `--report DIR`: `psd.svg` (measured and predicted PSD of every channel) and
/// `validation.json` (`json`, the result as printed with `--json`). Creates `dir`.
pub fn write_report(
    dir: &Path,
    recording: &Recording,
    predicted: &[Vec<f64>; 9],
    json: &str,
) -> Result<()> {
    std::fs::create_dir_all(dir).map_err(|e| anyhow!("{}: cannot create: {e}", dir.display()))?;
    let svg = psd_svg(recording, predicted)?;
    write_atomically(&dir.join("psd.svg"), |w| Ok(w.write_all(svg.as_bytes())?))?;
    write_atomically(&dir.join("validation.json"), |w| {
        Ok(w.write_all(json.as_bytes())?)
    })
}

/// Writes a recording with the input's time and platform columns and predicted sensors,
/// followed by the predicted joint motion ([`PREDICTED_JOINT_COLUMNS`]: mm and degrees).
pub fn write_prediction(
    recording: &Recording,
    predicted: [Vec<f64>; 9],
    joints: &[Vec<f64>; 10],
    out: &Path,
) -> Result<()> {
    let scale = JointOutput::ALL.map(|o| match o.unit() {
        JointUnit::Metre => 1e3,
        JointUnit::Radian => 180.0 / core::f64::consts::PI,
    });
    write_atomically(out, |w| {
        write!(w, "{HEADER_LINE}")?;
        for name in PREDICTED_JOINT_COLUMNS {
            write!(w, ",{name}")?;
        }
        writeln!(w)?;
        let mut line = String::with_capacity(512);
        for k in 0..recording.len() {
            line.clear();
            line.push_str(&format!("{}", recording.time_s[k]));
            for column in recording.platform_m_s2.iter().chain(predicted.iter()) {
                line.push_str(&format!(",{}", column[k]));
            }
            for (column, scale) in joints.iter().zip(scale) {
                line.push_str(&format!(",{}", column[k] * scale));
            }
            writeln!(w, "{line}")?;
        }
        Ok(())
    })
}
