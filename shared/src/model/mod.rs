//! The biodynamic model of a supine human (Wang & Rahmatalla 2013), as
//! `docs/model.md` specifies it: 3 rigid segments, 18 DOFs, joints and contacts
//! as spring-dampers, transmissibility, the motion inside the two joints, the
//! relative-coordinate state space, modal analysis and the device's discretized
//! realization.
//!
//! Analysis runs in f64 (host, build scripts); the device runs only [`DeviceRealization`].

pub mod assembly;
pub mod channel;
pub mod discrete;
#[cfg(all(target_arch = "arm", target_abi = "eabihf"))]
mod fpu_loops;
pub mod geometry;
pub mod joints;
pub mod modal;
pub mod params;
pub mod readout;
pub mod response;
pub mod state_space;

use core::fmt;

use crate::sample_rate::SampleRateError;

pub use assembly::SystemMatrices;
pub use channel::{Channel, DEVICE_CHANNELS, DEVICE_OUTPUT_COUNT, ModalOutput};
pub use discrete::{
    DEFAULT_SAMPLE_RATE_HZ, DeviceRealization, DiscreteModal, ModalBlock, ModalGroup, ModalState,
    RealizationAmplification, RealizationError, Scalar,
};
pub use geometry::{Axis, Segment, Subject};
pub use joints::{JOINT_OUTPUT_COUNT, JointComponent, JointOutput, JointUnit};
pub use modal::{ModalAnalysis, ModalComponent, Subsystem};
pub use params::{ModelParams, ParamError, ParamId, Preset};
pub use readout::{JointReadout, MAX_JOINT_ROWS};
pub use response::{JointResponse, Output, Transmissibility};
pub use state_space::StateSpace;

/// Why the model could not be built or analysed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ModelError {
    /// A parameter failed validation.
    Params(ParamError),
    /// A linear system had no unique solution (cannot happen for validated parameters).
    Singular,
    /// The eigen-decomposition of a subsystem failed its accuracy check (repeated modes).
    DefectiveModes(Subsystem),
    /// More reachable modes than the device realization holds.
    TooManyModes,
    /// The sample rate is outside the supported range
    /// ([`SampleRate`](crate::sample_rate::SampleRate)).
    SampleRate,
    /// The rounded realization failed its own check.
    Realization(RealizationError),
}

impl fmt::Display for ModelError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ModelError::Params(e) => e.fmt(f),
            ModelError::Singular => f.write_str("the model's equations are singular"),
            ModelError::DefectiveModes(s) => {
                write!(
                    f,
                    "the {s} subsystem has repeated modes that cannot be separated"
                )
            }
            ModelError::TooManyModes => f.write_str("more modes than the device realization holds"),
            ModelError::SampleRate => SampleRateError.fmt(f),
            ModelError::Realization(e) => write!(f, "device realization: {e}"),
        }
    }
}

impl core::error::Error for ModelError {}

impl From<ParamError> for ModelError {
    fn from(e: ParamError) -> Self {
        ModelError::Params(e)
    }
}

/// A validated model with everything derived from its parameters.
#[derive(Clone, Debug, PartialEq)]
pub struct Model {
    /// The parameters it was built from.
    pub params: ModelParams,
    /// M, C, K, G, R.
    pub matrices: SystemMatrices,
    /// The relative-coordinate state space.
    pub state_space: StateSpace,
    /// Modes per subsystem.
    pub modes: ModalAnalysis,
}

impl Model {
    /// Validates the parameters and derives the matrices, state space and modes.
    pub fn new(params: &ModelParams) -> Result<Self, ModelError> {
        params.validate()?;
        let matrices = SystemMatrices::assemble(params);
        let state_space = StateSpace::new(&matrices);
        let modes = ModalAnalysis::new(&state_space)?;
        Ok(Self {
            params: *params,
            matrices,
            state_space,
            modes,
        })
    }

    /// The realization of `outputs` at `sample_rate_hz` in f64 (the host's reference).
    pub fn realization<C: ModalOutput, const NY: usize>(
        &self,
        sample_rate_hz: f64,
        outputs: &[C; NY],
    ) -> Result<DiscreteModal<f64, NY>, ModelError> {
        DiscreteModal::from_modal(&self.modes, sample_rate_hz, outputs)
    }

    /// What the device runs: the head outputs in f32, checked for stability after rounding.
    pub fn device_realization(&self, sample_rate_hz: f64) -> Result<DeviceRealization, ModelError> {
        let device: DeviceRealization = self.realization(sample_rate_hz, &Output::HEAD)?.cast();
        device.check().map_err(ModelError::Realization)?;
        Ok(device)
    }

    /// What the device reads of the joints: `wanted` over the head realization `head`
    /// (from [`device_realization`](Self::device_realization) at the same rate).
    pub fn device_joint_readout(
        &self,
        sample_rate_hz: f64,
        head: &DeviceRealization,
        wanted: &[JointOutput],
    ) -> Result<JointReadout, ModelError> {
        JointReadout::new(&self.modes, sample_rate_hz, head, wanted)
    }
}

/// The device realization and its readout of every joint output, for a parameter set at a
/// sample rate (host and build time).
pub fn device_model(
    params: &ModelParams,
    sample_rate_hz: f64,
) -> Result<(DeviceRealization, JointReadout), ModelError> {
    let model = Model::new(params)?;
    let head = model.device_realization(sample_rate_hz)?;
    let joints = model.device_joint_readout(sample_rate_hz, &head, &JointOutput::ALL)?;
    Ok((head, joints))
}

/// The device realization for a parameter set at a sample rate (host and build time).
pub fn device_realization(
    params: &ModelParams,
    sample_rate_hz: f64,
) -> Result<DeviceRealization, ModelError> {
    Model::new(params)?.device_realization(sample_rate_hz)
}
