//! The device realization: the continuous model discretized with a first-order (triangle)
//! hold, in block-diagonal modal form.
//!
//! Each reachable mode becomes a 2-state block driven by one input axis. A complex pair
//! lambda = s + j w is stored as the real rotation-scaling block of e^(lambda T); two real
//! poles of one subsystem share a diagonal block. Each block's states are then scaled (a
//! 2x2 similarity T = [g0 -g1; g1 g0]) so that the input enters the first state with unit
//! gain: the input costs one addition instead of two multiply-adds, a pair block keeps its
//! rotation-scaling form, and the realization's response is unchanged.
//!
//! The blocks are grouped by the axis that drives them, and each group keeps only the
//! output rows its modes reach: in this geometry x reaches head x, y reaches head y, and z
//! (vertical and pitch) reaches head x and z, so 6 of the 9 rows per block a dense form
//! would carry are zero. The device's 15 blocks then cost 106 multiply-adds per sample
//! (4 per block for the state, 2 per block and row, 1 per row for the direct term),
//! against 159 with dense rows and about 1,500 for a dense 36-state form. States are kept
//! in delta form (x += (Phi - I) x + e1 u) so that f32 keeps its precision for poles near
//! z = 1 at high sample rates.
//!
//! First-order hold: with u linear between samples, the exact update of a mode
//! z' = lambda z + g u is z[k+1] = phi z\[k\] + g (gamma0 u\[k\] + gamma1 u[k+1]), with
//! phi = e^(lambda T), gamma1 = T E2(lambda T), gamma0 = T (E1(lambda T) - E2(lambda T)),
//! E1(s) = (e^s - 1)/s, E2(s) = (e^s - 1 - s)/s^2. Shifting the state by gamma1 g u\[k\] makes
//! it causal with a feedthrough term: w[k+1] = phi w\[k\] + (phi gamma1 + gamma0) g u\[k\],
//! y\[k\] = Re(c w\[k\]) + c gamma1 g u\[k\].

use core::f64::consts::PI;
use core::fmt::Debug;
use core::ops::{Add, Mul, Sub};

use nalgebra::Complex;
use serde::{Deserialize, Serialize};

use super::ModelError;
use super::channel::ModalOutput;
use super::geometry::Axis;
use super::modal::{ModalAnalysis, ModalComponent, Subsystem, modulus};
use crate::gain_bound::ModalBound;
use crate::sample_rate::SampleRate;

/// Blocks a realization can hold: 15 reachable modes in this model, plus slack.
pub const MAX_BLOCKS: usize = 16;

/// The device's default sample rate, Hz: ISO 8041-grade weighting up to 80 Hz needs it.
pub const DEFAULT_SAMPLE_RATE_HZ: f64 = 500.0;

/// The arithmetic a realization runs in: f32 on the device, f64 for the host's reference.
pub trait Scalar:
    Copy + PartialEq + Debug + Add<Output = Self> + Sub<Output = Self> + Mul<Output = Self>
{
    /// Zero.
    const ZERO: Self;
    /// Rounds from f64.
    fn from_f64(value: f64) -> Self;
    /// Widens to f64.
    fn to_f64(self) -> f64;
}

impl Scalar for f32 {
    const ZERO: Self = 0.0;
    fn from_f64(value: f64) -> Self {
        value as f32
    }
    fn to_f64(self) -> f64 {
        f64::from(self)
    }
}

impl Scalar for f64 {
    const ZERO: Self = 0.0;
    fn from_f64(value: f64) -> Self {
        value
    }
    fn to_f64(self) -> f64 {
        self
    }
}

/// One 2-state block of the realization.
///
/// `repr(C)`: the device's step loads a block's coefficients in one instruction
/// (`fpu_loops`), so their order in memory is part of the type.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(bound(
    serialize = "T: Serialize, [[T; 2]; NY]: Serialize",
    deserialize = "T: Deserialize<'de>, [[T; 2]; NY]: Deserialize<'de>"
))]
pub struct ModalBlock<T, const NY: usize> {
    /// Phi - I over one sample, row-major.
    pub transition_minus_identity: [[T; 2]; 2],
    /// Output rows (m/s^2 per unit state): row i feeds output `outputs[i]` of the block's
    /// group; rows from the group's `output_count` on are zero.
    pub output: [[T; 2]; NY],
}

impl<T: Scalar, const NY: usize> ModalBlock<T, NY> {
    const EMPTY: Self = Self {
        transition_minus_identity: [[T::ZERO; 2]; 2],
        output: [[T::ZERO; 2]; NY],
    };
}

/// The blocks one support axis drives, and the outputs they reach.
///
/// Physics makes most of a dense output matrix zero (x drives only x responses, y only
/// y, z the z and pitch responses), so each group lists the outputs it feeds and its
/// blocks carry only those rows, packed first.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(bound(
    serialize = "T: Serialize, [T; NY]: Serialize, [u8; NY]: Serialize",
    deserialize = "T: Deserialize<'de>, [T; NY]: Deserialize<'de>, [u8; NY]: Deserialize<'de>"
))]
pub struct ModalGroup<T, const NY: usize> {
    /// Blocks in this group: the next `block_count` after the previous groups'.
    pub block_count: u8,
    /// Outputs this group feeds; the first `output_count` entries of `outputs` count.
    pub output_count: u8,
    /// Output index (into the realization's outputs) of each packed row.
    pub outputs: [u8; NY],
    /// Direct term from the first-order hold, per packed row (output per m/s^2 of input).
    pub feedthrough: [T; NY],
}

impl<T: Scalar, const NY: usize> ModalGroup<T, NY> {
    const EMPTY: Self = Self {
        block_count: 0,
        output_count: 0,
        outputs: [0; NY],
        feedthrough: [T::ZERO; NY],
    };

    /// The output indices of the packed rows.
    pub fn outputs(&self) -> &[u8] {
        &self.outputs[..usize::from(self.output_count).min(NY)]
    }
}

/// A discrete-time realization from the three support accelerations to NY outputs, for
/// the sample rate it was built at (which the parameter blob stores beside it, once).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(bound(
    serialize = "T: Serialize, [[T; 2]; NY]: Serialize, [T; NY]: Serialize, [u8; NY]: Serialize",
    deserialize = "T: Scalar + Deserialize<'de>, [T; NY]: Deserialize<'de>, [u8; NY]: Deserialize<'de>"
))]
pub struct DiscreteModal<T, const NY: usize> {
    /// One group per support axis, in x, y, z order; their blocks follow each other.
    pub groups: [ModalGroup<T, NY>; 3],
    /// The modal blocks; only the first `block_count` are used.
    #[serde(with = "flat_blocks")]
    pub blocks: [ModalBlock<T, NY>; MAX_BLOCKS],
    /// How many blocks are in use (the groups' counts add up to it).
    pub block_count: u8,
}

/// What the firmware runs: head x, y, z in f32.
pub type DeviceRealization = DiscreteModal<f32, 3>;

/// What a realization can make of input bounded by 1 m/s^2 on each axis
/// ([`DiscreteModal::amplification`]); scale by the input bound.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RealizationAmplification<const NY: usize> {
    /// Bound on any block state's Euclidean norm.
    pub state: f32,
    /// Bound on each output's magnitude.
    pub outputs: [f32; NY],
}

/// The running state of a realization: two numbers per block.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ModalState<T> {
    /// Block states in delta form.
    pub blocks: [[T; 2]; MAX_BLOCKS],
}

impl<T: Scalar> Default for ModalState<T> {
    fn default() -> Self {
        Self {
            blocks: [[T::ZERO; 2]; MAX_BLOCKS],
        }
    }
}

/// Why a realization is unfit to run.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RealizationError {
    /// More blocks than [`MAX_BLOCKS`].
    TooManyBlocks,
    /// The groups do not add up to the blocks, name an output twice or out of range, or
    /// an unused row or direct term is not zero.
    Layout,
    /// A coefficient is NaN or infinite.
    NotFinite,
    /// A block has a pole on or outside the unit circle.
    Unstable,
}

impl core::fmt::Display for RealizationError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            RealizationError::TooManyBlocks => "more modal blocks than the device holds",
            RealizationError::Layout => "block groups and output rows are inconsistent",
            RealizationError::NotFinite => "a coefficient is not a finite number",
            RealizationError::Unstable => "a discrete pole lies on or outside the unit circle",
        })
    }
}

impl core::error::Error for RealizationError {}

impl DeviceRealization {
    /// [`step`](DiscreteModal::step) as the device runs it: on the Cortex-M4F the groups
    /// of one or two rows (all of them in this model) go through `fpu_loops`, the same
    /// operations in the same order, so the same bits; elsewhere `step` itself. Compiled in
    /// this crate at its opt-level (the rest of the image is built for size, the
    /// workspace's `Cargo.toml`), for the pipeline and for the self-test to time.
    #[inline(never)]
    pub fn step_device(&self, state: &mut ModalState<f32>, input_m_s2: [f32; 3]) -> [f32; 3] {
        self.step_inline(state, input_m_s2)
    }

    /// [`step_device`](Self::step_device), inlined where it is called: the pipeline's
    /// per-sample loop, which then keeps the outputs in registers and pays no call.
    #[inline(always)]
    pub fn step_inline(&self, state: &mut ModalState<f32>, input_m_s2: [f32; 3]) -> [f32; 3] {
        #[cfg(all(target_arch = "arm", target_abi = "eabihf"))]
        {
            use super::fpu_loops::advance;
            self.step_groups(state, input_m_s2, |group, blocks, states, u, y| match group
                .output_count
            {
                0 => {}
                1 => group.add_rows(advance::<1>(group, blocks, states, u), y),
                2 => group.add_rows(advance::<2>(group, blocks, states, u), y),
                _ => group.run::<3>(blocks, states, u, y),
            })
        }
        #[cfg(not(all(target_arch = "arm", target_abi = "eabihf")))]
        {
            self.step(state, input_m_s2)
        }
    }
}

impl<T: Scalar, const NY: usize> DiscreteModal<T, NY> {
    /// Advances one sample: returns the outputs at this sample (m/s^2) from the support
    /// acceleration at this sample (m/s^2, x, y, z) and moves the state on.
    ///
    /// Cannot fail: the realization was checked when it was built or loaded.
    #[inline]
    pub fn step(&self, state: &mut ModalState<T>, input_m_s2: [T; 3]) -> [T; NY] {
        self.step_groups(state, input_m_s2, |group, blocks, states, u, y| {
            // The accumulators live in registers when their count is known at compile
            // time: one row (x and y groups) or two (z: vertical and pitch) on the device.
            match group.output_count {
                0 => {}
                1 => group.run::<1>(blocks, states, u, y),
                2 => group.run::<2>(blocks, states, u, y),
                _ => group.run::<NY>(blocks, states, u, y),
            }
        })
    }

    /// One sample: each group's blocks and states (sliced alike) go to `run` with the
    /// group's input and the outputs to add to.
    #[inline(always)]
    fn step_groups(
        &self,
        state: &mut ModalState<T>,
        input_m_s2: [T; 3],
        mut run: impl FnMut(&ModalGroup<T, NY>, &[ModalBlock<T, NY>], &mut [[T; 2]], T, &mut [T; NY]),
    ) -> [T; NY] {
        let mut y = [T::ZERO; NY];
        let mut first = 0;
        for (group, u) in self.groups.iter().zip(input_m_s2) {
            let end = (first + usize::from(group.block_count)).min(self.used_blocks());
            let blocks = self.blocks.get(first..end).unwrap_or(&[]);
            let states = state.blocks.get_mut(first..end).unwrap_or(&mut []);
            first = end;
            run(group, blocks, states, u, &mut y);
        }
        y
    }

    /// Multiply-adds per sample: per group, one per output for the direct term; per block
    /// 4 for the state (the input is one addition) and 2 per output row of its group.
    pub fn multiply_adds_per_sample(&self) -> usize {
        self.groups
            .iter()
            .map(|g| {
                let (blocks, rows) = (usize::from(g.block_count), g.outputs().len());
                rows + blocks * (4 + 2 * rows)
            })
            .sum()
    }

    fn used_blocks(&self) -> usize {
        usize::from(self.block_count).min(MAX_BLOCKS)
    }

    /// The blocks in use.
    pub fn active_blocks(&self) -> &[ModalBlock<T, NY>] {
        &self.blocks[..self.used_blocks()]
    }

    /// Each group with its blocks and the support axis that drives them.
    pub fn grouped_blocks(
        &self,
    ) -> impl Iterator<Item = (Axis, &ModalGroup<T, NY>, &[ModalBlock<T, NY>])> {
        let mut first = 0;
        Axis::ALL
            .into_iter()
            .zip(self.groups.iter())
            .map(move |(axis, group)| {
                let end = (first + usize::from(group.block_count)).min(self.used_blocks());
                let blocks = self.blocks.get(first..end).unwrap_or(&[]);
                first = end;
                (axis, group, blocks)
            })
    }

    /// Checks what a loaded realization must satisfy before it runs: block count, layout
    /// of groups and rows, finite coefficients, and every block's poles inside the unit
    /// circle with the margin [`amplification`](Self::amplification) needs (computed from
    /// D = Phi - I, so it stays precise for poles close to z = 1).
    pub fn check(&self) -> Result<(), RealizationError> {
        if usize::from(self.block_count) > MAX_BLOCKS {
            return Err(RealizationError::TooManyBlocks);
        }
        let finite = |v: &T| v.to_f64().is_finite();
        let group_values = self.groups.iter().flat_map(|g| g.feedthrough.iter());
        // Every stored block, the unused ones too: a NaN anywhere in a blob is refused
        // (found by the blob fuzzer: an unused block's NaN passed and broke round trips).
        let block_values = self.blocks.iter().flat_map(|b| {
            b.transition_minus_identity
                .iter()
                .chain(b.output.iter())
                .flatten()
        });
        if !group_values.chain(block_values).all(finite) {
            return Err(RealizationError::NotFinite);
        }
        let grouped: usize = self.groups.iter().map(|g| usize::from(g.block_count)).sum();
        if grouped != usize::from(self.block_count) {
            return Err(RealizationError::Layout);
        }
        for (_, group, blocks) in self.grouped_blocks() {
            let rows = usize::from(group.output_count);
            let mut seen = [false; NY];
            for &o in group.outputs() {
                match seen.get_mut(usize::from(o)) {
                    Some(s) if !*s => *s = true,
                    _ => return Err(RealizationError::Layout),
                }
            }
            let unused_zero = rows <= NY
                && group.feedthrough[rows..].iter().all(|&v| v == T::ZERO)
                && blocks
                    .iter()
                    .all(|b| b.output[rows..].iter().flatten().all(|&v| v == T::ZERO));
            if !unused_zero {
                return Err(RealizationError::Layout);
            }
        }
        // Stability and its margin in one test: the gain bound exists only if every pole
        // lies inside the unit circle, no closer to it than the bound allows.
        if self.amplification().is_none() {
            return Err(RealizationError::Unstable);
        }
        Ok(())
    }

    /// Bounds on what input within `input_bound` (per axis, any sign) can make of the
    /// block states (largest Euclidean norm of any block's state) and of each output, in
    /// f32 (the device's arithmetic); `None` when a block is too slow or resonant to bound
    /// ([`crate::gain_bound::MAX_POLE_SUM`]). The blob validator compares them with what
    /// f32 can hold.
    pub fn amplification(&self) -> Option<RealizationAmplification<NY>> {
        let mut bound = RealizationAmplification {
            state: 0.0,
            outputs: [0.0; NY],
        };
        let to_f32 = |v: T| v.to_f64() as f32;
        let mut first = 0;
        for group in &self.groups {
            let rows = group.outputs();
            let end = (first + usize::from(group.block_count)).min(self.used_blocks());
            let mut gains = [0.0f32; NY];
            for (gain, &direct) in gains.iter_mut().zip(&group.feedthrough) {
                *gain = to_f32(direct).abs();
            }
            for block in self.blocks.get(first..end).unwrap_or(&[]) {
                let d = block.transition_minus_identity.map(|r| r.map(to_f32));
                // The input enters the first state with unit gain (module doc).
                let modes = ModalBound::new(d, [1.0, 0.0])?;
                let state = modes.state();
                // Comparisons, not f32::max: no library call on the device.
                if state > bound.state {
                    bound.state = state;
                }
                for (gain, row) in gains.iter_mut().zip(&block.output).take(rows.len()) {
                    *gain += modes.output(row.map(to_f32));
                }
            }
            for (&o, gain) in rows.iter().zip(gains) {
                if let Some(out) = bound.outputs.get_mut(usize::from(o)) {
                    *out += gain;
                }
            }
            first = end;
        }
        let finite = bound.state.is_finite() && bound.outputs.iter().all(|v| v.is_finite());
        finite.then_some(bound)
    }

    /// The discrete frequency response D + sum C (zI - Phi)^-1 e1 at z = e^(j 2 pi f / fs),
    /// per output (rows) and input axis (columns), computed in f64; `sample_rate_hz` is
    /// the rate the realization was built at.
    pub fn frequency_response(&self, sample_rate_hz: f64, freq_hz: f64) -> [[Complex<f64>; 3]; NY] {
        let theta = 2.0 * PI * freq_hz / sample_rate_hz;
        let z = Complex::new(libm::cos(theta), libm::sin(theta));
        let mut h = [[Complex::new(0.0, 0.0); 3]; NY];
        for (axis, group, blocks) in self.grouped_blocks() {
            // Row i of the group's blocks feeds output outputs[i].
            let mut packed = [Complex::new(0.0, 0.0); NY];
            for (cell, d) in packed.iter_mut().zip(group.feedthrough.iter()) {
                *cell = Complex::new(d.to_f64(), 0.0);
            }
            for block in blocks {
                let d = block.transition_minus_identity.map(|r| r.map(T::to_f64));
                // (zI - Phi) = (z - 1) I - D, inverted as a 2x2.
                let zm1 = z - 1.0;
                let (a, b, c, e) = (zm1 - d[0][0], -d[0][1], -d[1][0], zm1 - d[1][1]);
                let det = a * e - b * c;
                // (zI - Phi)^-1 e1: the input enters the first state.
                let (s0, s1) = (e / det, -c / det);
                for (cell, out) in packed.iter_mut().zip(block.output.iter()) {
                    *cell += s0 * out[0].to_f64() + s1 * out[1].to_f64();
                }
            }
            for (&o, value) in group.outputs().iter().zip(packed) {
                if let Some(row) = h.get_mut(usize::from(o)) {
                    row[axis.index()] += value;
                }
            }
        }
        h
    }

    /// The same realization in another arithmetic (f64 reference to f32 device).
    pub fn cast<U: Scalar>(&self) -> DiscreteModal<U, NY> {
        let conv = |v: T| U::from_f64(v.to_f64());
        DiscreteModal {
            groups: self.groups.map(|g| ModalGroup {
                block_count: g.block_count,
                output_count: g.output_count,
                outputs: g.outputs,
                feedthrough: g.feedthrough.map(conv),
            }),
            blocks: self.blocks.map(|b| ModalBlock {
                transition_minus_identity: b.transition_minus_identity.map(|r| r.map(conv)),
                output: b.output.map(|r| r.map(conv)),
            }),
            block_count: self.block_count,
        }
    }
}

impl<T: Scalar, const NY: usize> ModalGroup<T, NY> {
    /// Runs this group's blocks on input `u` and adds their outputs, with K packed rows.
    #[inline(always)]
    fn run<const K: usize>(
        &self,
        blocks: &[ModalBlock<T, NY>],
        states: &mut [[T; 2]],
        u: T,
        y: &mut [T; NY],
    ) {
        let mut acc: [T; K] =
            core::array::from_fn(|i| self.feedthrough.get(i).map_or(T::ZERO, |&d| d * u));
        for (block, x) in blocks.iter().zip(states.iter_mut()) {
            let [x0, x1] = *x;
            for (a, c) in acc.iter_mut().zip(block.output.iter()) {
                *a = *a + c[0] * x0 + c[1] * x1;
            }
            let d = &block.transition_minus_identity;
            *x = [
                x0 + (d[0][0] * x0 + d[0][1] * x1 + u),
                x1 + (d[1][0] * x0 + d[1][1] * x1),
            ];
        }
        self.add_rows(acc, y);
    }

    /// Adds the K packed rows' sums `acc` to the outputs they feed.
    #[inline(always)]
    fn add_rows<const K: usize>(&self, acc: [T; K], y: &mut [T; NY]) {
        for (&o, a) in self.outputs().iter().zip(acc) {
            if let Some(out) = y.get_mut(usize::from(o)) {
                *out = *out + a;
            }
        }
    }
}

impl<const NY: usize> DiscreteModal<f64, NY> {
    /// Discretizes the reachable modes that show in `outputs` at `sample_rate_hz` with a
    /// first-order hold. The rate is taken in f64 as given (a simulation may run at any
    /// rate the device supports, not only at f32 values).
    pub fn from_modal<C: ModalOutput>(
        analysis: &ModalAnalysis,
        sample_rate_hz: f64,
        outputs: &[C; NY],
    ) -> Result<Self, ModelError> {
        if !SampleRate::supports_hz(sample_rate_hz) {
            return Err(ModelError::SampleRate);
        }
        let period_s = 1.0 / sample_rate_hz;
        let mut realization = Self {
            groups: [ModalGroup::EMPTY; 3],
            blocks: [ModalBlock::EMPTY; MAX_BLOCKS],
            block_count: 0,
        };
        let relevant = |m: &&ModalComponent| {
            m.reachable
                && m.subsystem.input_axis().is_some()
                && outputs.iter().any(|o| modulus(o.modal_gain(m)) > 0.0)
        };
        // Each output's largest modal gain: outputs differ in units (m/s^2, m, rad), so
        // whether a mode reaches one is judged against that output's own scale.
        let scale: [f64; NY] = core::array::from_fn(|o| {
            analysis
                .components
                .iter()
                .filter(relevant)
                .map(|m| modulus(outputs[o].modal_gain(m) * m.input_gain))
                .fold(0.0, f64::max)
        });
        // Whether mode m reaches output o (an index into `outputs`) at all.
        let reaches = |m: &ModalComponent, o: usize| {
            modulus(outputs[o].modal_gain(m) * m.input_gain) > 1e-12 * scale[o]
        };
        for subsystem in Subsystem::ALL {
            let Some(axis) = subsystem.input_axis() else {
                continue;
            };
            let modes = || {
                analysis
                    .components
                    .iter()
                    .filter(relevant)
                    .filter(move |m| m.subsystem == subsystem && (0..NY).any(|o| reaches(m, o)))
            };
            let group = &mut realization.groups[axis.index()];
            for o in (0..NY).filter(|&o| modes().any(|m| reaches(m, o))) {
                group.outputs[usize::from(group.output_count)] = o as u8;
                group.output_count += 1;
            }
            let rows = *group;
            let mut pending_real: Option<DiscreteMode<NY>> = None;
            for m in modes() {
                let mode = DiscreteMode::new(m, period_s, outputs);
                let group = &mut realization.groups[axis.index()];
                for (cell, &o) in group.feedthrough.iter_mut().zip(rows.outputs()) {
                    *cell += mode.feedthrough[usize::from(o)];
                }
                let block = if m.is_pair {
                    Some(mode.pair_block())
                } else if let Some(first) = pending_real.take() {
                    Some(DiscreteMode::real_block(&first, Some(&mode)))
                } else {
                    pending_real = Some(mode);
                    None
                };
                if let Some(block) = block {
                    realization.push(axis, rows.pack(block))?;
                }
            }
            if let Some(first) = pending_real {
                realization.push(axis, rows.pack(DiscreteMode::real_block(&first, None)))?;
            }
        }
        Ok(realization)
    }

    fn push(&mut self, axis: Axis, block: ModalBlock<f64, NY>) -> Result<(), ModelError> {
        let slot = self
            .blocks
            .get_mut(usize::from(self.block_count))
            .ok_or(ModelError::TooManyModes)?;
        *slot = block;
        self.block_count += 1;
        self.groups[axis.index()].block_count += 1;
        Ok(())
    }
}

impl<const NY: usize> ModalGroup<f64, NY> {
    /// The block with its output rows packed: row i holds output `outputs[i]`.
    fn pack(&self, dense: ModalBlock<f64, NY>) -> ModalBlock<f64, NY> {
        let mut output = [[0.0; 2]; NY];
        for (row, &o) in output.iter_mut().zip(self.outputs()) {
            *row = dense.output[usize::from(o)];
        }
        ModalBlock {
            transition_minus_identity: dense.transition_minus_identity,
            output,
        }
    }
}

/// One mode's first-order-hold coefficients before packing into a block.
struct DiscreteMode<const NY: usize> {
    phi: Complex<f64>,
    input_gain: Complex<f64>,
    output_gain: [Complex<f64>; NY],
    feedthrough: [f64; NY],
}

impl<const NY: usize> DiscreteMode<NY> {
    fn new<C: ModalOutput>(m: &ModalComponent, period_s: f64, outputs: &[C; NY]) -> Self {
        let s = m.eigenvalue * period_s;
        let (phi, e1, e2) = hold_integrals(s);
        let gamma1 = e2 * period_s;
        let gamma0 = (e1 - e2) * period_s;
        let c = outputs.map(|o| o.modal_gain(m));
        // A pair contributes twice the real part of one member.
        let weight = if m.is_pair { 2.0 } else { 1.0 };
        Self {
            phi,
            input_gain: (phi * gamma1 + gamma0) * m.input_gain,
            output_gain: c.map(|ci| ci * weight),
            feedthrough: c.map(|ci| weight * (ci * gamma1 * m.input_gain).re),
        }
    }

    /// Real form of a complex mode, scaled to unit input gain: with w = g v,
    /// v' = phi v + u and y = Re(c g v) = Re(c g) v0 - Im(c g) v1 for v = v0 + j v1.
    fn pair_block(&self) -> ModalBlock<f64, NY> {
        let g = self.input_gain;
        ModalBlock {
            transition_minus_identity: [
                [self.phi.re - 1.0, -self.phi.im],
                [self.phi.im, self.phi.re - 1.0],
            ],
            output: self.output_gain.map(|c| {
                let cg = c * g;
                [cg.re, -cg.im]
            }),
        }
    }

    /// Two real poles side by side (a lone one gets an idle partner: Phi = 0, no gain),
    /// scaled to unit input gain by s = T v, T = [g1 -g2; g2 g1], which maps e1 to the
    /// gains g: v' = T^-1 (Phi - I) T v + v + e1 u and y = C T v. T is invertible because
    /// a block is only built for a mode the input reaches (g1 != 0).
    fn real_block(first: &Self, second: Option<&Self>) -> ModalBlock<f64, NY> {
        let (phi2, gain2) = second.map_or((0.0, 0.0), |m| (m.phi.re, m.input_gain.re));
        let (g1, g2) = (first.input_gain.re, gain2);
        let (d1, d2) = (first.phi.re - 1.0, phi2 - 1.0);
        let det = g1 * g1 + g2 * g2;
        // T^-1 diag(d1, d2) T, with T^-1 = [g1 g2; -g2 g1] / det.
        let transition_minus_identity = [
            [
                (g1 * g1 * d1 + g2 * g2 * d2) / det,
                g1 * g2 * (d2 - d1) / det,
            ],
            [
                g1 * g2 * (d2 - d1) / det,
                (g2 * g2 * d1 + g1 * g1 * d2) / det,
            ],
        ];
        ModalBlock {
            transition_minus_identity,
            output: core::array::from_fn(|o| {
                let c1 = first.output_gain[o].re;
                let c2 = second.map_or(0.0, |m| m.output_gain[o].re);
                [c1 * g1 + c2 * g2, c2 * g1 - c1 * g2]
            }),
        }
    }
}

/// phi = e^s, E1 = (e^s - 1)/s and E2 = (e^s - 1 - s)/s^2 for complex s, accurate near 0.
pub fn hold_integrals(s: Complex<f64>) -> (Complex<f64>, Complex<f64>, Complex<f64>) {
    let (sin_b, cos_b) = (libm::sin(s.im), libm::cos(s.im));
    let ea = libm::exp(s.re);
    let phi = Complex::new(ea * cos_b, ea * sin_b);
    if modulus(s) < 1e-2 {
        // Taylor series to s^4: relative truncation error below 1e-12.
        let s2 = s * s;
        let s3 = s2 * s;
        let s4 = s2 * s2;
        let e1 = 1.0 + s / 2.0 + s2 / 6.0 + s3 / 24.0 + s4 / 120.0;
        let e2 = 0.5 + s / 6.0 + s2 / 24.0 + s3 / 120.0 + s4 / 720.0;
        return (phi, e1, e2);
    }
    // e^s - 1 without cancellation: expm1(a) cos b - 2 sin^2(b/2) + j e^a sin b.
    let half = libm::sin(s.im / 2.0);
    let em1 = Complex::new(libm::expm1(s.re) * cos_b - 2.0 * half * half, ea * sin_b);
    let e1 = em1 / s;
    let e2 = (em1 - s) / (s * s);
    (phi, e1, e2)
}

/// The blocks as one tuple of their numbers (per block its transition, then its rows),
/// encoded and decoded in a loop: serde's derived code for the nested arrays is unrolled
/// per element, kilobytes of the device's flash in the blob decoder. The bytes are the
/// derived encoding's (postcard writes a fixed-size array as its elements in order; the
/// golden blob checks it).
mod flat_blocks {
    use core::fmt;
    use core::marker::PhantomData;

    use serde::de::{Error, SeqAccess, Visitor};
    use serde::ser::SerializeTuple;
    use serde::{Deserialize, Deserializer, Serialize, Serializer};

    use super::{MAX_BLOCKS, ModalBlock, Scalar};

    fn numbers<T, const NY: usize>(block: &ModalBlock<T, NY>) -> impl Iterator<Item = &T> {
        block
            .transition_minus_identity
            .iter()
            .flatten()
            .chain(block.output.iter().flatten())
    }

    pub fn serialize<S: Serializer, T: Serialize, const NY: usize>(
        blocks: &[ModalBlock<T, NY>; MAX_BLOCKS],
        serializer: S,
    ) -> Result<S::Ok, S::Error> {
        let mut tuple = serializer.serialize_tuple(MAX_BLOCKS * (4 + 2 * NY))?;
        for v in blocks.iter().flat_map(numbers) {
            tuple.serialize_element(v)?;
        }
        tuple.end()
    }

    struct BlocksVisitor<T, const NY: usize>(PhantomData<T>);

    impl<'de, T: Scalar + Deserialize<'de>, const NY: usize> Visitor<'de> for BlocksVisitor<T, NY> {
        type Value = [ModalBlock<T, NY>; MAX_BLOCKS];

        fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
            f.write_str("the realization's blocks")
        }

        fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Self::Value, A::Error> {
            let mut blocks = [ModalBlock::<T, NY>::EMPTY; MAX_BLOCKS];
            let mut k = 0;
            for block in &mut blocks {
                let cells = block
                    .transition_minus_identity
                    .iter_mut()
                    .flatten()
                    .chain(block.output.iter_mut().flatten());
                for v in cells {
                    *v = seq
                        .next_element()?
                        .ok_or_else(|| A::Error::invalid_length(k, &self))?;
                    k += 1;
                }
            }
            Ok(blocks)
        }
    }

    pub fn deserialize<'de, D: Deserializer<'de>, T: Scalar + Deserialize<'de>, const NY: usize>(
        deserializer: D,
    ) -> Result<[ModalBlock<T, NY>; MAX_BLOCKS], D::Error> {
        deserializer.deserialize_tuple(
            MAX_BLOCKS * (4 + 2 * NY),
            BlocksVisitor::<T, NY>(PhantomData),
        )
    }
}
