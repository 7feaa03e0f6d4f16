//! The joint outputs on the device: extra output rows read from the head realization's
//! own states, so the joints cost no state and no update, only their multiply-adds, and
//! only when they are read.
//!
//! Every mode that moves a joint also moves the head (both presets; checked when the
//! readout is built), so the head realization's blocks already carry the states the joint
//! outputs need. The readout is built from one realization of the head and joint outputs
//! together ([`DEVICE_CHANNELS`]) and keeps the joint rows: per axis group, at most
//! [`MAX_JOINT_ROWS`] rows (x drives the two x translations; y the two y translations and
//! the two bendings about z; z the two z translations and the two flexions about y).
//! Reading them costs per group one multiply-add per row for the direct term and two per
//! block and row: 118 for all ten outputs of the presets' 15 blocks.

use nalgebra::Complex;

use super::ModelError;
use super::channel::{DEVICE_CHANNELS, DEVICE_OUTPUT_COUNT, FIRST_DEVICE_JOINT};
use super::discrete::{
    DiscreteModal, MAX_BLOCKS, ModalBlock, ModalGroup, ModalState, RealizationError,
};
use super::joints::{JOINT_OUTPUT_COUNT, JointOutput};
use super::modal::ModalAnalysis;

/// Most joint rows one axis group reads.
pub const MAX_JOINT_ROWS: usize = 4;

/// The joint rows of one axis group.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ReadoutGroup {
    /// Rows in use: the first `row_count` of `outputs`, `feedthrough` and each block's rows.
    pub row_count: u8,
    /// The joint output (index into [`JointOutput::ALL`]) of each row.
    pub outputs: [u8; MAX_JOINT_ROWS],
    /// Direct term per row, m or rad per m/s^2.
    pub feedthrough: [f32; MAX_JOINT_ROWS],
}

impl ReadoutGroup {
    const EMPTY: Self = Self {
        row_count: 0,
        outputs: [0; MAX_JOINT_ROWS],
        feedthrough: [0.0; MAX_JOINT_ROWS],
    };

    /// The joint outputs of the rows in use.
    pub fn outputs(&self) -> &[u8] {
        &self.outputs[..usize::from(self.row_count).min(MAX_JOINT_ROWS)]
    }
}

/// The joint outputs a blob asks for, as rows over the head realization's blocks.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct JointReadout {
    /// One group per support axis, x, y, z, over the head realization's groups of blocks.
    pub groups: [ReadoutGroup; 3],
    /// Per block, its rows (m or rad per unit state); rows past the group's count are zero.
    pub rows: [[[f32; 2]; MAX_JOINT_ROWS]; MAX_BLOCKS],
}

/// Encoded and decoded by hand, in loops, as exactly the bytes serde's derive gives for
/// the fields in order (each group's row count, outputs and direct terms, then the rows
/// block by block; postcard writes a fixed-size array as its elements in order, and
/// `shared/tests/model_joints.rs` checks the bytes). The derived code is unrolled per
/// element: for these 155 numbers about 1.5 KiB of the device's flash in the blob decoder.
mod wire {
    use core::fmt;

    use serde::de::{Error, SeqAccess, Visitor};
    use serde::ser::SerializeTuple;
    use serde::{Deserialize, Deserializer, Serialize, Serializer};

    use super::{JointReadout, MAX_BLOCKS, MAX_JOINT_ROWS};

    const LEN: usize = 3 * (1 + 2 * MAX_JOINT_ROWS) + MAX_BLOCKS * MAX_JOINT_ROWS * 2;

    impl Serialize for JointReadout {
        fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
            let mut tuple = serializer.serialize_tuple(LEN)?;
            for g in &self.groups {
                tuple.serialize_element(&g.row_count)?;
                for o in &g.outputs {
                    tuple.serialize_element(o)?;
                }
                for d in &g.feedthrough {
                    tuple.serialize_element(d)?;
                }
            }
            for v in self.rows.iter().flatten().flatten() {
                tuple.serialize_element(v)?;
            }
            tuple.end()
        }
    }

    struct ReadoutVisitor;

    /// The next element, or an error naming how many came before.
    fn next<'de, T: Deserialize<'de>, A: SeqAccess<'de>>(
        seq: &mut A,
        k: &mut usize,
    ) -> Result<T, A::Error> {
        let v = seq
            .next_element()?
            .ok_or_else(|| A::Error::invalid_length(*k, &ReadoutVisitor))?;
        *k += 1;
        Ok(v)
    }

    impl<'de> Visitor<'de> for ReadoutVisitor {
        type Value = JointReadout;

        fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
            f.write_str("the joint readout")
        }

        fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<JointReadout, A::Error> {
            let mut r = JointReadout::NONE;
            let mut k = 0;
            for g in &mut r.groups {
                g.row_count = next(&mut seq, &mut k)?;
                for o in &mut g.outputs {
                    *o = next(&mut seq, &mut k)?;
                }
                for d in &mut g.feedthrough {
                    *d = next(&mut seq, &mut k)?;
                }
            }
            for v in r.rows.iter_mut().flatten().flatten() {
                *v = next(&mut seq, &mut k)?;
            }
            Ok(r)
        }
    }

    impl<'de> Deserialize<'de> for JointReadout {
        fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
            deserializer.deserialize_tuple(LEN, ReadoutVisitor)
        }
    }
}

impl JointReadout {
    /// Reads no joint output.
    pub const NONE: Self = Self {
        groups: [ReadoutGroup::EMPTY; 3],
        rows: [[[0.0; 2]; MAX_JOINT_ROWS]; MAX_BLOCKS],
    };

    /// Builds the readout of `wanted` for the head realization `head` (which must be the
    /// one [`Model::device_realization`](super::Model::device_realization) gives at
    /// `sample_rate_hz`): from one realization of the head and joint outputs together,
    /// whose blocks must be the head's, bit for bit.
    pub fn new(
        analysis: &ModalAnalysis,
        sample_rate_hz: f64,
        head: &DiscreteModal<f32, 3>,
        wanted: &[JointOutput],
    ) -> Result<Self, ModelError> {
        let both: DiscreteModal<f64, DEVICE_OUTPUT_COUNT> =
            DiscreteModal::from_modal(analysis, sample_rate_hz, &DEVICE_CHANNELS)?;
        let both: DiscreteModal<f32, DEVICE_OUTPUT_COUNT> = both.cast();
        let same_blocks = both.block_count == head.block_count
            && both
                .groups
                .iter()
                .zip(&head.groups)
                .all(|(a, b)| a.block_count == b.block_count)
            && both
                .active_blocks()
                .iter()
                .zip(head.active_blocks())
                .all(|(a, b)| a.transition_minus_identity == b.transition_minus_identity);
        if !same_blocks {
            return Err(ModelError::Realization(RealizationError::Layout));
        }
        let mut readout = Self::NONE;
        let wanted_index = |o: u8| {
            usize::from(o)
                .checked_sub(FIRST_DEVICE_JOINT)
                .filter(|j| wanted.iter().any(|w| w.index() == *j))
        };
        let mut first = 0;
        for (slot, group) in readout.groups.iter_mut().zip(&both.groups) {
            let end = first + usize::from(group.block_count);
            for (packed, &o) in group.outputs().iter().enumerate() {
                let Some(joint) = wanted_index(o) else {
                    continue;
                };
                let r = usize::from(slot.row_count);
                if r >= MAX_JOINT_ROWS {
                    return Err(ModelError::Realization(RealizationError::Layout));
                }
                slot.outputs[r] = joint as u8;
                slot.feedthrough[r] = group.feedthrough[packed];
                for (rows, block) in readout.rows[first..end]
                    .iter_mut()
                    .zip(&both.blocks[first..end])
                {
                    rows[r] = block.output[packed];
                }
                slot.row_count += 1;
            }
            first = end;
        }
        readout.check().map_err(ModelError::Realization)?;
        Ok(readout)
    }

    /// Checks a loaded readout against the head realization it reads: rows within bounds,
    /// each joint output in the group its input axis drives and in [`JointOutput::ALL`]
    /// order there (so at most once), every coefficient finite (the rows not in use are
    /// never read, and zero as built).
    pub fn check(&self) -> Result<(), RealizationError> {
        for (axis, group) in self.groups.iter().enumerate() {
            if usize::from(group.row_count) > MAX_JOINT_ROWS {
                return Err(RealizationError::Layout);
            }
            let mut next = 0;
            for &o in group.outputs() {
                let fits = JointOutput::ALL
                    .get(usize::from(o))
                    .is_some_and(|j| j.input_axis().index() == axis);
                if !fits || o < next {
                    return Err(RealizationError::Layout);
                }
                next = o + 1;
            }
        }
        // A sum of the coefficients' magnitudes: NaN or infinite if any one is.
        if self.amplification(1.0, 1.0).is_finite() {
            Ok(())
        } else {
            Err(RealizationError::NotFinite)
        }
    }

    /// The readout of those of its outputs that `mask` names (bit `i` for
    /// [`JointOutput::ALL`]`[i]`), over the head realization `head` it reads: their rows,
    /// in the same order, the rest zero. What [`new`](Self::new) builds for that
    /// selection, without the modal analysis (the host tests compare every mask); the
    /// device's self-test takes every selection's shape from the readout it ships.
    pub fn select(&self, head: &DiscreteModal<f32, 3>, mask: u16) -> Self {
        let mut out = Self::NONE;
        let mut first = 0;
        for ((slot, group), head_group) in out.groups.iter_mut().zip(&self.groups).zip(&head.groups)
        {
            let end = (first + usize::from(head_group.block_count)).min(MAX_BLOCKS);
            for (r, &o) in group.outputs().iter().enumerate() {
                if mask & 1u16.checked_shl(u32::from(o)).unwrap_or(0) == 0 {
                    continue;
                }
                let k = usize::from(slot.row_count);
                slot.outputs[k] = o;
                slot.feedthrough[k] = group.feedthrough[r];
                for (to, from) in out.rows[first..end].iter_mut().zip(&self.rows[first..end]) {
                    to[k] = from[r];
                }
                slot.row_count += 1;
            }
            first = end;
        }
        out
    }

    /// The outputs it reads, as a mask (bit `i` for [`JointOutput::ALL`]`[i]`).
    pub fn mask(&self) -> u16 {
        self.groups
            .iter()
            .flat_map(|g| g.outputs())
            .fold(0, |m, &o| m | 1u16.checked_shl(u32::from(o)).unwrap_or(0))
    }

    /// A bound on every output's magnitude when each block state's Euclidean norm is at
    /// most `state` and each input at most `input` (m/s^2): what the blob's check of
    /// overflow needs ([`crate::blob::DeviceParams::validate`]). The sum over every
    /// coefficient, the rows not in use too: looser than any one output's bound, NaN or
    /// infinite if any coefficient is, and one short loop on the device.
    pub fn amplification(&self, state: f32, input: f32) -> f32 {
        let direct: f32 = self
            .groups
            .iter()
            .flat_map(|g| g.feedthrough)
            .map(f32::abs)
            .sum();
        let rows: f32 = self.rows.iter().flatten().flatten().map(|c| c.abs()).sum();
        direct * input + rows * state
    }

    /// The output (its index in [`JointOutput::ALL`]) read `k`th, in
    /// [`packed_outputs`](Self::packed_outputs) order.
    pub fn packed_output(&self, k: usize) -> Option<u8> {
        let mut k = k;
        for group in &self.groups {
            let outputs = group.outputs();
            match outputs.get(k) {
                Some(&o) => return Some(o),
                None => k -= outputs.len(),
            }
        }
        None
    }

    /// How many outputs it reads.
    pub fn output_count(&self) -> usize {
        self.groups.iter().map(|g| g.outputs().len()).sum()
    }

    /// Whether it reads joint output `output`.
    pub fn reads(&self, output: JointOutput) -> bool {
        self.groups
            .iter()
            .any(|g| g.outputs().contains(&(output.index() as u8)))
    }

    /// The joint outputs (m or rad, [`JointOutput::ALL`] order; zero where not read) at the
    /// sample whose input is `input_m_s2`, from the state `head` holds *before* that
    /// sample's step (the outputs `head.step` would return alongside, for the head).
    pub fn read(
        &self,
        head: &DiscreteModal<f32, 3>,
        state: &ModalState<f32>,
        input_m_s2: [f32; 3],
    ) -> [f32; JOINT_OUTPUT_COUNT] {
        let mut packed = [0.0; JOINT_OUTPUT_COUNT];
        let count = self.read_packed(head, state, input_m_s2, &mut packed);
        let mut y = [0.0; JOINT_OUTPUT_COUNT];
        for (o, v) in self.packed_outputs().zip(&packed[..count]) {
            if let Some(out) = y.get_mut(usize::from(o)) {
                *out = *v;
            }
        }
        y
    }

    /// The outputs read, in the order [`read_packed`](Self::read_packed) gives them: by
    /// driving axis (x, y, z), in [`JointOutput::ALL`] order within an axis.
    pub fn packed_outputs(&self) -> impl Iterator<Item = u8> + '_ {
        self.groups.iter().flat_map(|g| g.outputs().iter().copied())
    }

    /// [`read`](Self::read), packed: the outputs read, in
    /// [`packed_outputs`](Self::packed_outputs) order, written to the start of `out`;
    /// returns how many. What the device runs, once per telemetry record: out of line
    /// and in loops over the rows in use, so it costs its flash once. On the Cortex-M4F
    /// the loops are `fpu_loops`' assembly.
    #[inline(never)]
    pub fn read_packed(
        &self,
        head: &DiscreteModal<f32, 3>,
        state: &ModalState<f32>,
        input_m_s2: [f32; 3],
        out: &mut [f32; JOINT_OUTPUT_COUNT],
    ) -> usize {
        self.read_packed_by::<false>(head, state, input_m_s2, out)
    }

    /// [`read_packed`](Self::read_packed), its loops the Rust definition if `DEFINITION`
    /// (on every target), else the device's (`fpu_loops`' assembly on the Cortex-M4F).
    /// The definition is what the assembly must equal bit for bit, compiled beside it in
    /// the device's self-test to compare (`firmware/src/bin/selftest.rs`).
    #[inline(always)]
    pub fn read_packed_by<const DEFINITION: bool>(
        &self,
        head: &DiscreteModal<f32, 3>,
        state: &ModalState<f32>,
        input_m_s2: [f32; 3],
        out: &mut [f32; JOINT_OUTPUT_COUNT],
    ) -> usize {
        let mut count = 0;
        let mut first = 0;
        for ((group, head_group), u) in self.groups.iter().zip(&head.groups).zip(input_m_s2) {
            let end = (first + usize::from(head_group.block_count)).min(MAX_BLOCKS);
            let rows = usize::from(group.row_count).min(MAX_JOINT_ROWS);
            let (Some(block_rows), Some(states), Some(out)) = (
                self.rows.get(first..end),
                state.blocks.get(first..end),
                out.get_mut(count..count + rows),
            ) else {
                break;
            };
            // One copy of the loop per row count: its accumulators then stay in registers
            // and it is loads and multiply-adds only; a group read by none costs nothing.
            let d = &group.feedthrough;
            let (x, b) = (block_rows, states);
            match out {
                [] => {}
                [a] => *a = accumulate::<1, DEFINITION>(d, u, x, b)[0],
                [a, c] => [*a, *c] = accumulate::<2, DEFINITION>(d, u, x, b),
                [a, c, e] => [*a, *c, *e] = accumulate::<3, DEFINITION>(d, u, x, b),
                [a, c, e, f] => {
                    [*a, *c, *e, *f] = accumulate::<MAX_JOINT_ROWS, DEFINITION>(d, u, x, b);
                }
                // `rows` is at most MAX_JOINT_ROWS.
                _ => {}
            }
            count += rows;
            first = end;
        }
        count
    }

    /// The discrete frequency response of the joint outputs read (rows in
    /// [`JointOutput::ALL`] order, zero where not read; columns input x, y, z), in f64.
    pub fn frequency_response(
        &self,
        head: &DiscreteModal<f32, 3>,
        sample_rate_hz: f64,
        freq_hz: f64,
    ) -> [[Complex<f64>; 3]; JOINT_OUTPUT_COUNT] {
        // The head realization's blocks with these rows: its own response routine.
        let mut joined: DiscreteModal<f32, MAX_JOINT_ROWS> = DiscreteModal {
            groups: core::array::from_fn(|_| ModalGroup {
                block_count: 0,
                output_count: 0,
                outputs: [0; MAX_JOINT_ROWS],
                feedthrough: [0.0; MAX_JOINT_ROWS],
            }),
            blocks: core::array::from_fn(|b| ModalBlock {
                transition_minus_identity: head.blocks[b].transition_minus_identity,
                output: self.rows[b],
            }),
            block_count: head.block_count,
        };
        for ((g, own), head_group) in joined.groups.iter_mut().zip(&self.groups).zip(&head.groups) {
            g.block_count = head_group.block_count;
            g.output_count = own.row_count;
            g.outputs = core::array::from_fn(|r| r as u8);
            g.feedthrough = own.feedthrough;
        }
        let packed = joined.frequency_response(sample_rate_hz, freq_hz);
        let mut h = [[Complex::new(0.0, 0.0); 3]; JOINT_OUTPUT_COUNT];
        for (axis, group) in self.groups.iter().enumerate() {
            for (r, &o) in group.outputs().iter().enumerate() {
                if let Some(row) = h.get_mut(usize::from(o)) {
                    row[axis] = packed[r][axis];
                }
            }
        }
        h
    }
}

/// The first `R` rows of one axis group at a sample: the direct term times the input `u`
/// plus each block's rows (`block_rows`) times its state (`states`). On the Cortex-M4F
/// `fpu_loops::accumulate` runs the same operations in the same order, unless
/// `DEFINITION` asks for the Rust definition itself.
#[inline(always)]
fn accumulate<const R: usize, const DEFINITION: bool>(
    feedthrough: &[f32; MAX_JOINT_ROWS],
    u: f32,
    block_rows: &[[[f32; 2]; MAX_JOINT_ROWS]],
    states: &[[f32; 2]],
) -> [f32; R] {
    #[cfg(all(target_arch = "arm", target_abi = "eabihf"))]
    if !DEFINITION {
        return super::fpu_loops::accumulate(feedthrough, u, block_rows, states);
    }
    let mut acc: [f32; R] = core::array::from_fn(|r| feedthrough[r % MAX_JOINT_ROWS] * u);
    for (c, x) in block_rows.iter().zip(states) {
        for (a, c) in acc.iter_mut().zip(c) {
            *a += c[0] * x[0] + c[1] * x[1];
        }
    }
    acc
}
