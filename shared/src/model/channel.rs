//! What a realization can output: a sensor's acceleration or a joint's motion, each a
//! linear function of the model's states, so each mode carries a gain for it.

use core::f64::consts::PI;
use core::fmt;

use nalgebra::Complex;

use super::joints::{JOINT_OUTPUT_COUNT, JointOutput};
use super::modal::{ModalAnalysis, ModalComponent};
use super::response::{JointResponse, Output};

/// An output whose response is a sum over the model's modes.
pub trait ModalOutput: Copy {
    /// The mode's output gain for this output (its contribution is gain times the modal
    /// state).
    fn modal_gain(self, mode: &ModalComponent) -> Complex<f64>;
}

impl ModalOutput for Output {
    fn modal_gain(self, mode: &ModalComponent) -> Complex<f64> {
        mode.output_gain[self.index()]
    }
}

impl ModalOutput for JointOutput {
    fn modal_gain(self, mode: &ModalComponent) -> Complex<f64> {
        mode.joint_gain[self.index()]
    }
}

/// A sensor acceleration (m/s^2) or a joint motion (m or rad).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Channel {
    /// A sensor point's acceleration.
    Sensor(Output),
    /// A joint's relative motion.
    Joint(JointOutput),
}

impl ModalOutput for Channel {
    fn modal_gain(self, mode: &ModalComponent) -> Complex<f64> {
        match self {
            Channel::Sensor(o) => o.modal_gain(mode),
            Channel::Joint(j) => j.modal_gain(mode),
        }
    }
}

impl Channel {
    /// Its column name, e.g. `head_x` or `neck_ry`.
    pub const fn name(self) -> &'static str {
        match self {
            Channel::Sensor(o) => o.name(),
            Channel::Joint(j) => j.name(),
        }
    }
}

impl fmt::Display for Channel {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// Outputs of the device's realization: the head's three, then the ten joint outputs.
pub const DEVICE_OUTPUT_COUNT: usize = 3 + JOINT_OUTPUT_COUNT;

/// The device's outputs in realization order: head x, y, z, then [`JointOutput::ALL`].
pub const DEVICE_CHANNELS: [Channel; DEVICE_OUTPUT_COUNT] = {
    let mut all = [Channel::Sensor(Output::HEAD[0]); DEVICE_OUTPUT_COUNT];
    let mut k = 0;
    while k < DEVICE_OUTPUT_COUNT {
        all[k] = if k < 3 {
            Channel::Sensor(Output::HEAD[k])
        } else {
            Channel::Joint(JointOutput::ALL[k - 3])
        };
        k += 1;
    }
    all
};

/// Index of the first joint output among [`DEVICE_CHANNELS`].
pub const FIRST_DEVICE_JOINT: usize = 3;

impl ModalAnalysis {
    /// The response of each of `outputs` to each input axis at `freq_hz`, summed over the
    /// reachable modes.
    pub fn response_of<C: ModalOutput, const N: usize>(
        &self,
        outputs: &[C; N],
        freq_hz: f64,
    ) -> [[Complex<f64>; 3]; N] {
        let jw = Complex::new(0.0, 2.0 * PI * freq_hz);
        let mut h = [[Complex::new(0.0, 0.0); 3]; N];
        for m in self.components.iter().filter(|m| m.reachable) {
            let Some(axis) = m.subsystem.input_axis() else {
                continue;
            };
            for (row, output) in h.iter_mut().zip(outputs) {
                let c = output.modal_gain(m);
                let mut term = c * m.input_gain / (jw - m.eigenvalue);
                if m.is_pair {
                    term += c.conj() * m.input_gain.conj() / (jw - m.eigenvalue.conj());
                }
                row[axis.index()] += term;
            }
        }
        h
    }

    /// The joint response as the sum of modal contributions: equals the direct solution.
    pub fn joint_response(&self, freq_hz: f64) -> JointResponse {
        let h = self.response_of(&JointOutput::ALL, freq_hz);
        JointResponse::from_fn(|o, k| h[o][k])
    }
}
