//! The predicted neck and lower-back motion of a ride (`docs/exposure.md`, "Neck and lower
//! back"): per joint output its overall rms, the largest 1 s running rms and the largest
//! excursion, with when it happened.
//!
//! No standard sets limits for a supine patient's spinal motion, so these are reported,
//! not judged. The model runs in f64 at the evaluation rate from rest, as the head's does,
//! and the statistics count from the end of the head's warm-up, as the device's do
//! (`supine_core::joint_exposure`): the model's start-up transient on a ride that starts
//! in motion is not motion of the ride. The running rms is primed during the warm-up.

use anyhow::{Result, anyhow};
use serde::Serialize;
use supine_core::exposure::{ExposureSettings, running_rms_gain};
use supine_core::model::{
    DiscreteModal, JOINT_OUTPUT_COUNT, JointOutput, ModalState, Model, ModelParams,
};

/// One joint output over a ride, in display units (mm or degrees).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct JointReport {
    /// The output, e.g. `neck_z`.
    pub output: &'static str,
    /// `mm` or `deg`.
    pub unit: &'static str,
    /// Rms over the ride after the warm-up (mean included: a steady deflection is motion
    /// too).
    pub rms: f64,
    /// Largest running rms (exponential, the head's time constant) after the warm-up.
    pub max_running_rms: f64,
    /// Largest |value| after the warm-up.
    pub largest_excursion: f64,
    /// When the largest excursion happened, s from the ride's start.
    pub largest_excursion_at_s: f64,
}

pub use crate::io::wording::display_unit;

/// The joint outputs after one sample, in display units (mm or degrees), in
/// [`JointOutput::ALL`]'s order: what a report charts of each sample.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct JointSample {
    /// Each output's value.
    pub outputs: [f64; JOINT_OUTPUT_COUNT],
    /// Each output's running rms.
    pub running_rms: [f64; JOINT_OUTPUT_COUNT],
}

/// The ten joint outputs followed sample by sample: the model in f64 from rest, each
/// output's running rms, and from the end of the warm-up its overall rms, its largest
/// running rms and its largest excursion. One pass, so a report can take its chart series
/// from the same run that gives its table.
pub struct JointTracker {
    realization: DiscreteModal<f64, JOINT_OUTPUT_COUNT>,
    state: ModalState<f64>,
    sample_rate_hz: f64,
    alpha: f64,
    /// Samples of the warm-up: they only prime the running rms.
    warmup_samples: usize,
    samples: usize,
    sum2: [f64; JOINT_OUTPUT_COUNT],
    ms: [f64; JOINT_OUTPUT_COUNT],
    max_ms: [f64; JOINT_OUTPUT_COUNT],
    peak: [(f64, usize); JOINT_OUTPUT_COUNT],
    /// The outputs at the last sample, m or rad.
    now: [f64; JOINT_OUTPUT_COUNT],
}

impl JointTracker {
    /// A tracker of `params`'s joints at `sample_rate_hz`, from rest, with the head's
    /// running-rms time constant and warm-up (`exposure`), as the device's joint exposure.
    pub fn new(
        params: &ModelParams,
        sample_rate_hz: f64,
        exposure: &ExposureSettings,
    ) -> Result<Self> {
        let realization = Model::new(params)
            .and_then(|m| m.realization(sample_rate_hz, &JointOutput::ALL))
            .map_err(|e| anyhow!("the model does not discretize at {sample_rate_hz} Hz: {e}"))?;
        Ok(Self {
            realization,
            state: ModalState::default(),
            sample_rate_hz,
            alpha: running_rms_gain(f64::from(exposure.config.running_tau_s), sample_rate_hz),
            warmup_samples: exposure.warmup_samples as usize,
            samples: 0,
            sum2: [0.0; JOINT_OUTPUT_COUNT],
            ms: [0.0; JOINT_OUTPUT_COUNT],
            max_ms: [0.0; JOINT_OUTPUT_COUNT],
            peak: [(0.0, 0); JOINT_OUTPUT_COUNT],
            now: [0.0; JOINT_OUTPUT_COUNT],
        })
    }

    /// Takes the next support acceleration (x, y, z, m/s^2).
    pub fn step(&mut self, platform_m_s2: [f64; 3]) {
        let y = self.realization.step(&mut self.state, platform_m_s2);
        self.now = y;
        let k = self.samples;
        let settled = k >= self.warmup_samples;
        for (o, v) in y.iter().enumerate() {
            let v2 = v * v;
            self.ms[o] += self.alpha * (v2 - self.ms[o]);
            if settled {
                self.sum2[o] += v2;
                self.max_ms[o] = self.max_ms[o].max(self.ms[o]);
                if v.abs() > self.peak[o].0 {
                    self.peak[o] = (v.abs(), k);
                }
            }
        }
        self.samples += 1;
    }

    /// The outputs and their running rms at the last sample, in display units.
    pub fn sample(&self) -> JointSample {
        JointSample {
            outputs: self.outputs_display(),
            running_rms: self.running_rms_display(),
        }
    }

    /// Each output at the last sample, in its display unit (mm or degrees), in
    /// [`JointOutput::ALL`]'s order.
    pub fn outputs_display(&self) -> [f64; JOINT_OUTPUT_COUNT] {
        let mut out = [0.0; JOINT_OUTPUT_COUNT];
        for (v, output) in out.iter_mut().zip(JointOutput::ALL) {
            *v = display_unit(output).1 * self.now[output.index()];
        }
        out
    }

    /// Each output's running rms now, in its display unit (mm or degrees), in
    /// [`JointOutput::ALL`]'s order.
    pub fn running_rms_display(&self) -> [f64; JOINT_OUTPUT_COUNT] {
        let mut out = [0.0; JOINT_OUTPUT_COUNT];
        for (v, output) in out.iter_mut().zip(JointOutput::ALL) {
            *v = display_unit(output).1 * self.ms[output.index()].sqrt();
        }
        out
    }

    /// The statistics over every sample taken after the warm-up.
    pub fn report(&self) -> Vec<JointReport> {
        let n = self.samples.saturating_sub(self.warmup_samples).max(1) as f64;
        JointOutput::ALL
            .iter()
            .map(|&output| {
                let o = output.index();
                let (unit, scale) = display_unit(output);
                JointReport {
                    output: output.name(),
                    unit,
                    rms: scale * (self.sum2[o] / n).sqrt(),
                    max_running_rms: scale * self.max_ms[o].sqrt(),
                    largest_excursion: scale * self.peak[o].0,
                    largest_excursion_at_s: self.peak[o].1 as f64 / self.sample_rate_hz,
                }
            })
            .collect()
    }
}

/// The section of `supine exposure`'s table.
pub fn joints_text(joints: &[JointReport]) -> String {
    let mut s = String::from(
        "\nneck and lower back (predicted joint motion; no standard sets limits for a supine patient):\n",
    );
    s += &format!(
        "  {:<12} {:>5} {:>10} {:>16} {:>18} {:>8}\n",
        "output", "unit", "rms", "max running rms", "largest excursion", "at_s"
    );
    for j in joints {
        s += &format!(
            "  {:<12} {:>5} {:>10.4} {:>16.4} {:>18.4} {:>8.3}\n",
            j.output,
            j.unit,
            j.rms,
            j.max_running_rms,
            j.largest_excursion,
            j.largest_excursion_at_s
        );
    }
    s
}
