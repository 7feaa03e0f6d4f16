//! The device's processing chain, one call per batch of samples: sensor checks, the model,
//! weighting and exposure, alerts, and the telemetry they produce.
//!
//! The firmware runs this and so does the host's reference, so their numbers can only
//! differ where the host deliberately computes in f64. Samples go through in blocks of
//! [`BLOCK_LEN`]: the exposure and alert stages keep their memories in registers across a
//! block, which is what meets the device's instruction budget; the results are bit for
//! bit those of one sample at a time, so how a stream is cut into batches never matters.

use heapless::Vec;
use serde::{Deserialize, Serialize};

use crate::alerts::{AlertEvent, AlertState, FaultFlags, JointAlertState, Level, SensorCheckState};
use crate::blob::DeviceParams;
use crate::exposure::{ExposureSample, ExposureState};
use crate::fpu::sqrt_f32;
use crate::input_resolution::{INPUT_STEP_M_S2, counts_f32};
use crate::joint_exposure::{JointExposureState, JointValues, running_gain};
use crate::model::{JOINT_OUTPUT_COUNT, ModalState};

/// Samples per block on the device (32 ms at 500 Hz, far below the alert dwell times).
pub const BLOCK_LEN: usize = 16;

/// Events one block can raise at most: every fault edge on every sample, and a level
/// change per sample.
const MAX_BLOCK_EVENTS: usize = 5 * BLOCK_LEN;

/// What the pipeline produces, in sample order.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PipelineOutput {
    /// An alert edge, stamped with its sample index.
    Alert(AlertEvent),
    /// The telemetry of one sample (every `decimation`-th sample).
    Telemetry(Telemetry),
}

/// What a block hands to its report ([`DeviceParams::report`]): its samples' indices,
/// head accelerations, exposure and joint readings, and its events by kind.
struct Records<'a, const N: usize> {
    indices: &'a [u32; N],
    head: &'a [[f32; 3]; N],
    exposure: &'a [ExposureSample; N],
    faults: &'a [AlertEvent],
    levels: &'a [AlertEvent],
    joints: &'a [[f32; JOINT_OUTPUT_COUNT]],
    joint_count: usize,
    /// Samples at the block's start still in the head's warm-up, which the joints' own
    /// exposure and alerts wait for too.
    warmup_left: usize,
    joint_gain: f32,
    decimation: u16,
}

/// One telemetry record: what the device reports about one sample (the protocol sends it
/// as [`DeviceToHost::Telemetry`](crate::protocol::DeviceToHost::Telemetry)).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Telemetry {
    /// Index of the input sample this describes.
    pub sample_index: u32,
    /// Predicted head acceleration x, y, z (litter axes), m/s^2.
    pub head_acc_m_s2: [f32; 3],
    /// Frequency-weighted running rms (tau = 1 s) per axis, m/s^2.
    pub running_rms_m_s2: [f32; 3],
    /// Vector sum of the weighted running rms, m/s^2.
    pub vector_running_rms_m_s2: f32,
    /// Vibration dose value of the vector sum so far, m/s^1.75.
    pub vdv_m_s175: f32,
    /// Current exposure alert level.
    pub alert_level: Level,
    /// Active sensor faults.
    pub fault_flags: FaultFlags,
    /// Whether the weighting has settled and the exposure values mean something yet.
    pub valid: bool,
    /// The joint outputs the parameters read, at this sample (m or rad; in
    /// [`packed_order`](crate::joint_exposure::packed_order), the others left out).
    pub joints: JointValues,
}

/// The running memory of the whole chain: constant size, no heap.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PipelineState {
    model: ModalState<f32>,
    exposure: ExposureState,
    joints: JointExposureState,
    alerts: AlertState,
    joint_alerts: JointAlertState,
    sensors: SensorCheckState,
    /// Last finite input as the model got it (whole input-resolution counts, as f32),
    /// held in place of a non-finite one so NaN never enters a filter.
    last_input_counts: [f32; 3],
    /// The model's input for the last [`BLOCK_LEN`] samples, in input-resolution counts:
    /// a ring, the next slot at `recent_at`. What the device streams on request.
    recent_inputs: [[i16; 3]; BLOCK_LEN],
    recent_at: usize,
    /// Alert level and active faults as of the last processed sample.
    level: Level,
    faults: FaultFlags,
    /// Samples until the next telemetry record.
    telemetry_countdown: u16,
    /// Samples processed since start.
    processed: u32,
}

impl Default for PipelineState {
    fn default() -> Self {
        Self::new()
    }
}

impl PipelineState {
    /// At rest, before the first sample.
    pub const fn new() -> Self {
        Self {
            model: ModalState {
                blocks: [[0.0; 2]; crate::model::discrete::MAX_BLOCKS],
            },
            exposure: ExposureState::new(),
            joints: JointExposureState::new(),
            alerts: AlertState::new(),
            joint_alerts: JointAlertState::new(),
            sensors: SensorCheckState::new(),
            last_input_counts: [0.0; 3],
            recent_inputs: [[0; 3]; BLOCK_LEN],
            recent_at: 0,
            level: Level::Normal,
            faults: FaultFlags::empty(),
            telemetry_countdown: 0,
            processed: 0,
        }
    }

    /// The model's inputs for the raw samples `raw`, m/s^2, into `out`: each sample
    /// clipped and rounded to the input resolution, or the last finite one in place of one
    /// that is not; their counts go to the ring of recent inputs. A block at a time and out
    /// of line: both block sizes' copies of the pipeline share one loop, and its call
    /// costs once per block, not per sample.
    #[inline(never)]
    fn take_inputs(&mut self, raw: &[[f32; 3]], full_scale_m_s2: f32, out: &mut [[f32; 3]]) {
        let mut last = self.last_input_counts;
        let mut at = self.recent_at;
        for (x, o) in raw.iter().zip(out) {
            if x.iter().all(|v| v.is_finite()) {
                last = x.map(|v| counts_f32(v, full_scale_m_s2));
            }
            *o = last.map(|c| c * INPUT_STEP_M_S2);
            if let Some(slot) = self.recent_inputs.get_mut(at) {
                *slot = last.map(|c| c as i32 as i16);
            }
            at = (at + 1) % BLOCK_LEN;
        }
        self.last_input_counts = last;
        self.recent_at = at;
    }

    /// The model's input for the last `out.len()` samples processed (at most
    /// [`BLOCK_LEN`]), oldest first, in input-resolution counts
    /// ([`crate::input_resolution::to_m_s2`] gives m/s^2): after the hold of a non-finite
    /// sample, the clips and the rounding. The device streams them on request, read after
    /// each call of [`DeviceParams::process`] with at most [`BLOCK_LEN`] samples.
    pub fn recent_inputs(&self, out: &mut [[i16; 3]]) {
        let n = out.len().min(BLOCK_LEN);
        let mut at = (self.recent_at + BLOCK_LEN - n) % BLOCK_LEN;
        for o in out.iter_mut().take(n) {
            if let Some(&c) = self.recent_inputs.get(at) {
                *o = c;
            }
            at = (at + 1) % BLOCK_LEN;
        }
    }

    /// Samples processed since start.
    pub const fn processed(&self) -> u32 {
        self.processed
    }

    /// The current exposure alert level.
    pub const fn level(&self) -> Level {
        self.level
    }

    /// The exposure state, for full reports ([`crate::exposure::ExposureSettings::values`]).
    pub const fn exposure(&self) -> &ExposureState {
        &self.exposure
    }

    /// The joint outputs' running mean square and largest excursion.
    pub const fn joints(&self) -> &JointExposureState {
        &self.joints
    }

    /// Which joint-motion alerts are raised.
    pub const fn joint_alerts(&self) -> &JointAlertState {
        &self.joint_alerts
    }
}

impl DeviceParams {
    /// Runs consecutive samples (litter-frame support acceleration, m/s^2, with their sample
    /// indices; both slices the same length) and hands every output to `emit` in order.
    pub fn process(
        &self,
        state: &mut PipelineState,
        indices: &[u32],
        input_m_s2: &[[f32; 3]],
        mut emit: impl FnMut(PipelineOutput),
    ) {
        let n = indices.len().min(input_m_s2.len());
        let (indices, input_m_s2) = (&indices[..n], &input_m_s2[..n]);
        let mut idx_blocks = indices.chunks_exact(BLOCK_LEN);
        let mut in_blocks = input_m_s2.chunks_exact(BLOCK_LEN);
        for (idx, inp) in (&mut idx_blocks).zip(&mut in_blocks) {
            if let (Ok(idx), Ok(inp)) = (idx.try_into(), inp.try_into()) {
                self.process_full_block(state, idx, inp, &mut emit);
            }
        }
        for (&i, &x) in idx_blocks.remainder().iter().zip(in_blocks.remainder()) {
            self.process_one(state, i, x, &mut emit);
        }
    }

    /// The exposure stage of a block of head accelerations (`head_m_s2`, the first at sample
    /// `first`): the exposure's and the alerts' `step_block`, as the pipeline runs them,
    /// compiled in this crate at its opt-level, for the self-test to time.
    #[inline(never)]
    pub fn exposure_stage(
        &self,
        exposure: &mut ExposureState,
        alerts: &mut AlertState,
        head_m_s2: &[[f32; 3]; BLOCK_LEN],
        first: u32,
        samples: &mut [ExposureSample; BLOCK_LEN],
        emit: &mut dyn FnMut(AlertEvent),
    ) {
        self.exposure
            .step_block(exposure, head_m_s2, first, samples);
        self.alerts.step_block(alerts, samples, first, emit);
    }

    /// [`process_block`](Self::process_block) of [`BLOCK_LEN`] samples, compiled once, in
    /// this crate, whatever the caller's `emit`: the device builds this crate for speed and
    /// the rest of its image for size (the workspace's `Cargo.toml`), and the per-sample
    /// path must not take the caller's level. An output costs one indirect call.
    #[inline(never)]
    fn process_full_block(
        &self,
        state: &mut PipelineState,
        indices: &[u32; BLOCK_LEN],
        input_m_s2: &[[f32; 3]; BLOCK_LEN],
        emit: &mut dyn FnMut(PipelineOutput),
    ) {
        self.process_block::<BLOCK_LEN>(state, indices, input_m_s2, &mut |o| emit(o));
    }

    /// [`process_block`](Self::process_block) of one sample (the end of a partial block),
    /// compiled once here, as [`process_full_block`](Self::process_full_block).
    #[inline(never)]
    fn process_one(
        &self,
        state: &mut PipelineState,
        index: u32,
        input_m_s2: [f32; 3],
        emit: &mut dyn FnMut(PipelineOutput),
    ) {
        self.process_block::<1>(state, &[index], &[input_m_s2], &mut |o| emit(o));
    }

    /// One block of exactly `N` samples (`N` at most [`BLOCK_LEN`]).
    pub fn process_block<const N: usize>(
        &self,
        state: &mut PipelineState,
        indices: &[u32; N],
        input_m_s2: &[[f32; 3]; N],
        emit: &mut impl FnMut(PipelineOutput),
    ) {
        let mut events: Vec<AlertEvent, MAX_BLOCK_EVENTS> = Vec::new();
        self.sensor_checks
            .step_block(&mut state.sensors, input_m_s2, indices, |e| {
                let _ = events.push(e);
            });
        // The model's input, then (in place) its output, per sample.
        let mut head = [[0.0f32; 3]; N];
        // A non-finite sample is replaced by the last good one; a finite one is clipped to
        // the full scale, as the sensor itself would, and to the input range, and rounded
        // to the input resolution: a sample no sensor can produce (1e30 m/s^2) must not
        // overflow the model's and the exposure's f32 state, and the model must get
        // exactly what the input stream can carry. Both clips raise their fault
        // (non-finite, saturated) in the sensor checks above.
        state.take_inputs(
            input_m_s2,
            self.sensor_checks.config.full_scale_m_s2,
            &mut head,
        );
        // The joint outputs are read on the samples telemetry reports (module
        // `joint_exposure`): their values, in sample order, for the records below. Their
        // exposure is stepped at once, unless joint alerts are set: then it is stepped
        // with the alerts at the records below, so that a joint alert is sent in sample
        // order with the others, with no buffer of its own. Both wait for the head's
        // warm-up: the block's first `warmup_left` samples are in it.
        let warmup_left = self.exposure.warmup_left(&state.exposure) as usize;
        let decimation = self.telemetry.decimation.max(1);
        let joint_gain = running_gain(self.exposure.running_gain, decimation);
        let mut countdown = state.telemetry_countdown;
        let mut joints: Vec<[f32; JOINT_OUTPUT_COUNT], N> = Vec::new();
        let mut joint_count = 0;
        for (n, h) in head.iter_mut().enumerate() {
            if countdown == 0 {
                countdown = decimation;
                if joints.push([0.0; JOINT_OUTPUT_COUNT]).is_ok()
                    && let Some(y) = joints.last_mut()
                {
                    let settled = n >= warmup_left;
                    joint_count = self.read_joints(state, joint_gain, *h, settled, y);
                }
            }
            countdown -= 1;
            // Inlined in the full block's loop (the per-sample path); a call from the
            // one-sample copy, which runs only at the end of a stream, to spare flash.
            *h = if N == BLOCK_LEN {
                self.realization.step_inline(&mut state.model, *h)
            } else {
                self.realization.step_device(&mut state.model, *h)
            };
        }
        let mut exposure = [ExposureSample::default(); N];
        let first = indices[0];
        self.exposure
            .step_block(&mut state.exposure, &head, first, &mut exposure);
        let fault_events = events.len();
        self.alerts
            .step_block(&mut state.alerts, &exposure, first, |e| {
                // Stamp with the sample's real index (the block may span a gap in indices).
                let e = match e {
                    AlertEvent::Level {
                        from,
                        to,
                        criterion,
                        at_sample,
                    } => {
                        let n = at_sample.wrapping_sub(first) as usize;
                        AlertEvent::Level {
                            from,
                            to,
                            criterion,
                            at_sample: indices.get(n).copied().unwrap_or(at_sample),
                        }
                    }
                    other => other,
                };
                let _ = events.push(e);
            });
        // Fault edges and level changes each come in sample order; merge them by sample.
        let (faults, levels) = events.split_at(fault_events);
        let records = Records {
            indices,
            head: &head,
            exposure: &exposure,
            faults,
            levels,
            joints: &joints,
            joint_count,
            warmup_left,
            joint_gain,
            decimation,
        };
        // Two copies of the loop below for full blocks, the device's path: with no joint
        // threshold set, its copy has no trace of the joint alerts (a call in it, even
        // never taken, cost every sample about 20 instructions of registers saved and
        // reloaded). A partial block (the end of a batch) takes the one copy with them.
        if N == BLOCK_LEN && !self.joint_alerts.watches_any() {
            self.report::<N, false>(state, &records, emit);
        } else {
            self.report::<N, true>(state, &records, emit);
        }
    }

    /// The block's events and telemetry records, in sample order: per sample its fault
    /// edges, its level change, then (on a joint reading, with `JOINT_ALERTS`) the joint
    /// alerts it raises or clears, then its record.
    #[inline(always)]
    fn report<const N: usize, const JOINT_ALERTS: bool>(
        &self,
        state: &mut PipelineState,
        r: &Records<'_, N>,
        emit: &mut impl FnMut(PipelineOutput),
    ) {
        let mut reported = r.joints.iter();
        let (mut fi, mut li) = (0, 0);
        for (n, &index) in r.indices.iter().enumerate() {
            while let Some(e) = r.faults.get(fi).filter(|e| e.at_sample() == index) {
                if let AlertEvent::Fault { fault, active, .. } = *e {
                    if active {
                        state.faults.insert(fault);
                    } else {
                        state.faults.remove(fault);
                    }
                }
                emit(PipelineOutput::Alert(*e));
                fi += 1;
            }
            while let Some(e) = r.levels.get(li).filter(|e| e.at_sample() == index) {
                if let AlertEvent::Level { to, .. } = e {
                    state.level = *to;
                }
                emit(PipelineOutput::Alert(*e));
                li += 1;
            }
            state.processed = state.processed.wrapping_add(1);
            if state.telemetry_countdown == 0 {
                state.telemetry_countdown = r.decimation;
                let joints = reported.next().map_or(JointValues::EMPTY, |y| {
                    let y_read = &y[..r.joint_count.min(JOINT_OUTPUT_COUNT)];
                    if JOINT_ALERTS {
                        let emit: &mut dyn FnMut(PipelineOutput) = &mut *emit;
                        let settled = n >= r.warmup_left;
                        self.step_joint_alerts(state, r.joint_gain, y_read, index, settled, emit);
                    }
                    JointValues::packed(r.joint_count, *y)
                });
                emit(PipelineOutput::Telemetry(self.telemetry_of(
                    index,
                    r.head[n],
                    &r.exposure[n],
                    joints,
                    state,
                )));
            }
            state.telemetry_countdown -= 1;
        }
    }

    /// The joint outputs read (packed into `y`; returns how many) at the sample about to
    /// be stepped, taken into their exposure with `gain` (`settled`: past the warm-up)
    /// unless joint alerts are set ([`step_joint_alerts`](Self::step_joint_alerts) does
    /// it then). Out of line: the pipeline is compiled for two block lengths, and this
    /// need not be twice in flash.
    #[inline(never)]
    fn read_joints(
        &self,
        state: &mut PipelineState,
        gain: f32,
        input_m_s2: [f32; 3],
        settled: bool,
        y: &mut [f32; JOINT_OUTPUT_COUNT],
    ) -> usize {
        let count = self
            .joints
            .read_packed(&self.realization, &state.model, input_m_s2, y);
        if !self.joint_alerts.watches_any() {
            state.joints.step(gain, &y[..count], settled);
        }
        count
    }

    /// With joint alerts set: one reading `y` (packed) of the joint outputs, at sample
    /// `index`, taken into their exposure with `gain`, then, once `settled` (past the
    /// warm-up), into their alerts, whose events go to `emit`: during the warm-up they
    /// hold, nothing pending, as the head's levels. Out of line, as
    /// [`read_joints`](Self::read_joints).
    #[inline(never)]
    fn step_joint_alerts(
        &self,
        state: &mut PipelineState,
        gain: f32,
        y: &[f32],
        index: u32,
        settled: bool,
        emit: &mut dyn FnMut(PipelineOutput),
    ) {
        state.joints.step(gain, y, settled);
        if !settled {
            return;
        }
        let count = y.len();
        self.joint_alerts.step(
            &mut state.joint_alerts,
            state.joints.mean_square(count),
            state.joints.peaks(count),
            |k, criterion, raised| {
                let output = self.joints.packed_output(k).unwrap_or(u8::MAX);
                emit(PipelineOutput::Alert(AlertEvent::Joint {
                    output,
                    criterion,
                    raised,
                    at_sample: index,
                }));
            },
        );
    }

    fn telemetry_of(
        &self,
        sample_index: u32,
        head_acc_m_s2: [f32; 3],
        exposure: &ExposureSample,
        joints: JointValues,
        state: &PipelineState,
    ) -> Telemetry {
        let k = self.exposure.config.axes.axes().map(|a| a.k);
        let running = |i: usize| sqrt_f32(exposure.axis_ms_m2_s4[i]) / k[i];
        let t = Telemetry {
            sample_index,
            head_acc_m_s2,
            running_rms_m_s2: [running(0), running(1), running(2)],
            vector_running_rms_m_s2: sqrt_f32(exposure.running_ms_m2_s4),
            vdv_m_s175: sqrt_f32(sqrt_f32(exposure.vdv4_m4_s7)),
            alert_level: state.level,
            fault_flags: state.faults,
            valid: exposure.valid,
            joints,
        };
        // Belt and braces: a value that is not finite is never reported as valid. The sum is
        // finite only if every term is (NaN and infinities propagate; an overflow of the sum
        // alone would only err towards not valid), and costs a few additions, not a branch
        // per value, per record.
        let [h0, h1, h2] = t.head_acc_m_s2;
        let [r0, r1, r2] = t.running_rms_m_s2;
        let finite = (h0
            + h1
            + h2
            + r0
            + r1
            + r2
            + t.vector_running_rms_m_s2
            + t.vdv_m_s175
            + t.joints.sum())
        .is_finite();
        Telemetry {
            valid: t.valid && finite,
            ..t
        }
    }
}
