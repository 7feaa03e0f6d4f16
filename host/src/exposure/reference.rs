//! The host's reference for the device: what the firmware must produce for given inputs.
//!
//! Two references, for two questions:
//! - [`pipeline`] runs the device's own chain (`DeviceParams::process`, f32) on the host.
//!   The device runs the same code on the same f32 inputs, so its telemetry and alert
//!   events are expected bit for bit; exposure is compared at 1e-3 relative to leave room
//!   for a compiler that fuses differently.
//! - [`head_f64`] steps the model's f64 realization (before rounding to f32): the accuracy
//!   reference for the predicted head acceleration (1e-4 m/s^2 max abs over a minute);
//!   [`joints_f64`] the same for the joint outputs.

use anyhow::{Result, anyhow};
use supine_core::alerts::AlertEvent;
use supine_core::blob::DeviceParams;
use supine_core::input_resolution::{INPUT_RANGE_M_S2, quantize_m_s2};
use supine_core::model::{
    DiscreteModal, JOINT_OUTPUT_COUNT, JointOutput, ModalState, Model, ModelParams, Output,
};
use supine_core::pipeline::{BLOCK_LEN, PipelineOutput, PipelineState};
use supine_core::protocol::Telemetry;

/// What the pipeline produced for a stream: telemetry and alert events in order.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PipelineRun {
    /// Telemetry records (every `decimation`-th sample).
    pub telemetry: Vec<Telemetry>,
    /// Alert edges, in the order raised.
    pub events: Vec<AlertEvent>,
    /// The input the model got, per sample, in input-resolution counts
    /// (`supine_core::input_resolution`).
    pub input_counts: Vec<[i16; 3]>,
}

/// Runs `params`' device pipeline on samples `input_m_s2` (litter axes, gravity removed)
/// with sample indices `indices`, from rest.
pub fn pipeline(params: &DeviceParams, indices: &[u32], input_m_s2: &[[f32; 3]]) -> PipelineRun {
    let mut state = PipelineState::new();
    let mut run = PipelineRun::default();
    // A block per call, as the device runs it, so that each block's inputs can be read
    // back (the results do not depend on how the stream is cut).
    for (i, x) in indices.chunks(BLOCK_LEN).zip(input_m_s2.chunks(BLOCK_LEN)) {
        params.process(&mut state, i, x, |out| match out {
            PipelineOutput::Telemetry(t) => run.telemetry.push(t),
            PipelineOutput::Alert(e) => run.events.push(e),
        });
        let at = run.input_counts.len();
        run.input_counts.resize(at + i.len(), [0; 3]);
        state.recent_inputs(&mut run.input_counts[at..]);
    }
    run
}

/// The head acceleration (x, y, z, m/s^2) of the f64 model at `sample_rate_hz` for each
/// input sample, from rest ([`HeadF64`]).
pub fn head_f64(
    params: &ModelParams,
    sample_rate_hz: f64,
    input_m_s2: &[[f32; 3]],
) -> Result<Vec<[f64; 3]>> {
    let mut model = HeadF64::new(params, sample_rate_hz)?;
    Ok(input_m_s2.iter().map(|&x| model.step(x)).collect())
}

/// The f64 model's head, one sample at a time from rest. Each sample is first rounded to
/// the device's input resolution (and clipped to its range, not to a sensor's full
/// scale), as the device's pipeline does, then widened exactly to f64: the two models
/// then see the same input, and differ only by the device's f32 arithmetic.
pub struct HeadF64 {
    realization: DiscreteModal<f64, 3>,
    state: ModalState<f64>,
}

impl HeadF64 {
    /// The model of `params` at `sample_rate_hz`, at rest.
    pub fn new(params: &ModelParams, sample_rate_hz: f64) -> Result<Self> {
        let realization = Model::new(params)
            .and_then(|model| model.realization(sample_rate_hz, &Output::HEAD))
            .map_err(|e| anyhow!("the model does not discretize at {sample_rate_hz} Hz: {e}"))?;
        Ok(Self {
            realization,
            state: ModalState::default(),
        })
    }

    /// The head acceleration after input sample `x` (litter axes, m/s^2).
    pub fn step(&mut self, x: [f32; 3]) -> [f64; 3] {
        let x = quantize_m_s2(x, INPUT_RANGE_M_S2);
        self.realization.step(&mut self.state, x.map(f64::from))
    }
}

/// The ten joint outputs (m or rad, [`JointOutput::ALL`] order) of the f64 model at
/// `sample_rate_hz` for each input sample (rounded to the input resolution as the device's, then widened exactly), from rest: the
/// accuracy reference for the device's joint values.
pub fn joints_f64(
    params: &ModelParams,
    sample_rate_hz: f64,
    input_m_s2: &[[f32; 3]],
) -> Result<Vec<[f64; JOINT_OUTPUT_COUNT]>> {
    let realization = Model::new(params)
        .and_then(|model| model.realization(sample_rate_hz, &JointOutput::ALL))
        .map_err(|e| anyhow!("the model does not discretize at {sample_rate_hz} Hz: {e}"))?;
    let mut state = ModalState::<f64>::default();
    Ok(input_m_s2
        .iter()
        .map(|&x| {
            let x = quantize_m_s2(x, INPUT_RANGE_M_S2);
            realization.step(&mut state, x.map(f64::from))
        })
        .collect())
}
