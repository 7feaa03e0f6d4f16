//! The predicted neck and lower-back motion of a ride (`docs/exposure.md`, "Neck and lower
//! back"): per joint output its overall rms, the largest 1 s running rms and the largest
//! excursion, with when it happened.
//!
//! No standard sets limits for a supine patient's spinal motion, so these are reported,
//! not judged. The model runs in f64 at the evaluation rate from rest, as the head's does.

use anyhow::{Result, anyhow};
use serde::Serialize;
use supine_core::model::{
    JOINT_OUTPUT_COUNT, JointOutput, JointUnit, ModalState, Model, ModelParams,
};

/// Time constant of the running rms, s: the one ISO 2631-1 uses for the head's (MTVV).
pub const RUNNING_RMS_TAU_S: f64 = 1.0;

/// One joint output over a ride, in display units (mm or degrees).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct JointReport {
    /// The output, e.g. `neck_z`.
    pub output: &'static str,
    /// `mm` or `deg`.
    pub unit: &'static str,
    /// Rms over the whole ride (mean included: a steady deflection is motion too).
    pub rms: f64,
    /// Largest running rms (exponential, tau = 1 s).
    pub max_running_rms: f64,
    /// Largest |value|.
    pub largest_excursion: f64,
    /// When the largest excursion happened, s from the ride's start.
    pub largest_excursion_at_s: f64,
}

/// Display unit and the factor from the model's SI value to it.
fn display_unit(output: JointOutput) -> (&'static str, f64) {
    match output.unit() {
        JointUnit::Metre => ("mm", 1e3),
        JointUnit::Radian => ("deg", 180.0 / core::f64::consts::PI),
    }
}

/// The ten joint outputs' statistics for the support acceleration `platform_m_s2` (x, y,
/// z per sample) at `sample_rate_hz`, from rest.
pub fn joint_motion(
    params: &ModelParams,
    sample_rate_hz: f64,
    platform_m_s2: &[[f64; 3]],
) -> Result<Vec<JointReport>> {
    let realization = Model::new(params)
        .and_then(|m| m.realization(sample_rate_hz, &JointOutput::ALL))
        .map_err(|e| anyhow!("the model does not discretize at {sample_rate_hz} Hz: {e}"))?;
    let alpha = -(-1.0 / (RUNNING_RMS_TAU_S * sample_rate_hz)).exp_m1();
    let mut state = ModalState::<f64>::default();
    let mut sum2 = [0.0; JOINT_OUTPUT_COUNT];
    let mut ms = [0.0; JOINT_OUTPUT_COUNT];
    let mut max_ms = [0.0_f64; JOINT_OUTPUT_COUNT];
    let mut peak = [(0.0_f64, 0usize); JOINT_OUTPUT_COUNT];
    for (k, u) in platform_m_s2.iter().enumerate() {
        let y = realization.step(&mut state, *u);
        for o in 0..JOINT_OUTPUT_COUNT {
            let v2 = y[o] * y[o];
            sum2[o] += v2;
            ms[o] += alpha * (v2 - ms[o]);
            max_ms[o] = max_ms[o].max(ms[o]);
            if y[o].abs() > peak[o].0 {
                peak[o] = (y[o].abs(), k);
            }
        }
    }
    let n = platform_m_s2.len().max(1) as f64;
    Ok(JointOutput::ALL
        .iter()
        .map(|&output| {
            let o = output.index();
            let (unit, scale) = display_unit(output);
            JointReport {
                output: output.name(),
                unit,
                rms: scale * (sum2[o] / n).sqrt(),
                max_running_rms: scale * max_ms[o].sqrt(),
                largest_excursion: scale * peak[o].0,
                largest_excursion_at_s: peak[o].1 as f64 / sample_rate_hz,
            }
        })
        .collect())
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
