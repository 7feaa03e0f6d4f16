//! The device pipeline over a ride, one sample at a time (what `supine exposure`, the
//! report and its band run).

use anyhow::{Result, bail};
use supine_core::alerts::{AlertEvent, Level};
use supine_core::blob::{DeviceParams, TelemetryConfig};
use supine_core::exposure::ExposureValues;
use supine_core::pipeline::{PipelineOutput, PipelineState, Telemetry};

use crate::exposure::joints::{JointReport, JointSample, JointTracker};
use crate::exposure::timed_event::TimedEvent;

/// Samples handed to the device pipeline per call (bounds the chunk buffer).
const CHUNK_SAMPLES: usize = 8 * 1024;
/// Most alert events a report lists: a sensor fault that comes and goes on every sample
/// would otherwise grow the list with the ride; the rest are counted, not kept.
pub const MAX_LISTED_EVENTS: usize = 1000;

/// What [`ModelRun`] shows its observer, in the pipeline's order: an alert event, then
/// each sample.
pub enum Step<'a> {
    /// An alert event (before the telemetry of its sample).
    Alert(&'a AlertEvent),
    /// A sample's telemetry, its input (x, y, z at the evaluation's rate) and the
    /// joints after it.
    Sample {
        /// The pipeline's telemetry of the sample.
        telemetry: &'a Telemetry,
        /// The sample's platform input, m/s^2.
        input_m_s2: [f64; 3],
        /// The joints after the sample, when tracked.
        joints: Option<&'a JointSample>,
    },
}

/// The device pipeline over a ride, one sample at a time: [`DeviceParams::process`] in
/// f32 on chunks of `CHUNK_SAMPLES` with sample indices `0, 1, ...`, exactly what the
/// device computes, and beside it what `supine exposure` reports: the alert timeline (its
/// first [`MAX_LISTED_EVENTS`] events), the platform's unweighted mean squares, and the
/// joints when tracked. The joints (the model in f64, independent of the device's f32
/// pipeline) are run over each chunk on a thread of their own while the pipeline runs,
/// and the observer is shown both in the pipeline's order after. Memory: the pipeline
/// state and one chunk of inputs, outputs and joint samples.
pub struct ModelRun {
    params: DeviceParams,
    state: PipelineState,
    start_s: f64,
    chunk: Vec<[f64; 3]>,
    indices: Vec<u32>,
    samples_f32: Vec<[f32; 3]>,
    taken: usize,
    events: Vec<TimedEvent>,
    events_omitted: usize,
    max_level: Level,
    platform_sum2: [f64; 3],
    joints: Option<JointTracker>,
    outputs: Vec<PipelineOutput>,
    joint_samples: Vec<JointSample>,
}

/// What a [`ModelRun`] found over the whole ride.
pub struct RunOutcome {
    /// The exposure values of the final state.
    pub values: ExposureValues,
    /// The listed events.
    pub events: Vec<TimedEvent>,
    /// Events not listed.
    pub events_omitted: usize,
    /// Highest level reached.
    pub max_level: Level,
    /// The level after the last sample.
    pub final_level: Level,
    /// Samples taken.
    pub samples: usize,
    /// Unweighted rms of the platform x, y, z, m/s^2.
    pub platform_rms_m_s2: [f64; 3],
    /// The joints' statistics, when tracked.
    pub joints: Vec<JointReport>,
}

impl ModelRun {
    /// A run of `params` from a fresh state (the first sample at `start_s` in the ride's
    /// time), with `joints` tracked beside it if given.
    pub fn new(params: &DeviceParams, joints: Option<JointTracker>, start_s: f64) -> Self {
        // Every sample's telemetry for the observer. The head's values and events do not
        // depend on it; the joint outputs are then read on every sample, their alerts'
        // dwells rebuilt for that (the same parameters with every sample are valid).
        let params = params
            .with_telemetry(TelemetryConfig::EVERY_SAMPLE)
            .unwrap_or(*params);
        Self {
            params,
            state: PipelineState::new(),
            start_s,
            chunk: Vec::with_capacity(CHUNK_SAMPLES),
            indices: Vec::with_capacity(CHUNK_SAMPLES),
            samples_f32: Vec::with_capacity(CHUNK_SAMPLES),
            taken: 0,
            events: Vec::new(),
            events_omitted: 0,
            max_level: Level::Normal,
            platform_sum2: [0.0; 3],
            joints,
            outputs: Vec::with_capacity(CHUNK_SAMPLES),
            joint_samples: Vec::with_capacity(CHUNK_SAMPLES),
        }
    }

    /// Takes the next platform sample (x, y, z, m/s^2); `observe` sees the pipeline's
    /// outputs as each chunk is run.
    pub fn push(&mut self, input_m_s2: [f64; 3], observe: &mut impl FnMut(Step<'_>)) -> Result<()> {
        if self.taken >= u32::MAX as usize {
            bail!(
                "more than {} samples: more than the device's 32-bit sample index",
                u32::MAX
            );
        }
        for (sum, v) in self.platform_sum2.iter_mut().zip(input_m_s2) {
            *sum += v * v;
        }
        self.chunk.push(input_m_s2);
        self.taken += 1;
        if self.chunk.len() == CHUNK_SAMPLES {
            self.flush(observe);
        }
        Ok(())
    }

    fn flush(&mut self, observe: &mut impl FnMut(Step<'_>)) {
        if self.chunk.is_empty() {
            return;
        }
        let first = (self.taken - self.chunk.len()) as u32;
        self.indices.clear();
        self.indices
            .extend((0..self.chunk.len() as u32).map(|k| first + k));
        self.samples_f32.clear();
        self.samples_f32
            .extend(self.chunk.iter().map(|u| u.map(|v| v as f32)));
        let fs = self.params.sample_rate_hz() as f64;
        let Self {
            params,
            state,
            start_s,
            chunk,
            indices,
            samples_f32,
            events,
            events_omitted,
            max_level,
            joints,
            outputs,
            joint_samples,
            ..
        } = self;
        outputs.clear();
        joint_samples.clear();
        let track = |joints: &mut JointTracker, samples: &mut Vec<JointSample>| {
            for &input_m_s2 in chunk.iter() {
                joints.step(input_m_s2);
                samples.push(joints.sample());
            }
        };
        let run = |state: &mut PipelineState, outputs: &mut Vec<PipelineOutput>| {
            params.process(state, indices, samples_f32, |out| outputs.push(out))
        };
        match joints.as_mut() {
            Some(j) => {
                rayon::join(|| track(j, joint_samples), || run(state, outputs));
            }
            None => run(state, outputs),
        }
        for out in outputs.drain(..) {
            match out {
                PipelineOutput::Alert(e) => {
                    if let AlertEvent::Level { to, .. } = e {
                        *max_level = (*max_level).max(to);
                    }
                    if events.len() < MAX_LISTED_EVENTS {
                        events.push(TimedEvent::new(&e, *start_s, fs));
                    } else {
                        *events_omitted += 1;
                    }
                    observe(Step::Alert(&e));
                }
                PipelineOutput::Telemetry(t) => {
                    let k = (t.sample_index - first) as usize;
                    observe(Step::Sample {
                        telemetry: &t,
                        input_m_s2: chunk[k],
                        joints: joint_samples.get(k),
                    });
                }
            }
        }
        self.chunk.clear();
    }

    /// Runs what is left and gives the values of the final state.
    pub fn finish(mut self, observe: &mut impl FnMut(Step<'_>)) -> RunOutcome {
        self.flush(observe);
        let n = self.taken;
        let values = self
            .params
            .exposure
            .values(self.params.sample_rate, self.state.exposure());
        RunOutcome {
            values,
            events: self.events,
            events_omitted: self.events_omitted,
            max_level: self.max_level,
            final_level: self.state.level(),
            samples: n,
            platform_rms_m_s2: self
                .platform_sum2
                .map(|s| if n == 0 { 0.0 } else { (s / n as f64).sqrt() }),
            joints: self.joints.map(|j| j.report()).unwrap_or_default(),
        }
    }
}
