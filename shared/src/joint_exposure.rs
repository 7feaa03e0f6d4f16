//! The device's exposure of the joint outputs (neck and lower-back motion): for each output
//! its running rms (the head's exponential form and time constant, see [`crate::exposure`])
//! and its largest absolute excursion since the head's warm-up ended (the running rms is
//! primed during it, as the head's), and the compact list of values that telemetry and
//! status carry.
//!
//! The joint outputs are read on the samples telemetry reports (every `decimation`-th),
//! not on every sample: all ten cost about 790 instructions per reading, more than the
//! model step itself, which on every sample would add about 80 % to the pipeline's cost
//! (BENCHMARKS.md). Their motion lies below about 20 Hz, so the running mean square of
//! those samples is the same average with the gain of the longer step, `1 - alpha^D`;
//! the excursion misses the true peak by at most
//! `1 - cos(pi f D / fs)` of a sine at `f` (`docs/exposure.md`, "Joint motion").

use core::fmt;

use serde::de::{Error, SeqAccess, Visitor};
use serde::ser::SerializeSeq;
use serde::{Deserialize, Deserializer, Serialize, Serializer};

use crate::fpu::sqrt_f32;
use crate::model::{Axis, JOINT_OUTPUT_COUNT, JointOutput};

/// The values of the joint outputs a device reads, in the readout's packed order
/// ([`packed_order`]), the outputs it does not read left out (m for translations, rad for
/// rotations).
///
/// On the wire exactly a `heapless::Vec<f32, 10>` (postcard: a varint count, then the
/// values), so a device that reads no joint output pays one byte per record; kept as a
/// fixed array here so that records stay `Copy`.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct JointValues {
    len: u8,
    values: [f32; JOINT_OUTPUT_COUNT],
}

impl JointValues {
    /// No values.
    pub const EMPTY: Self = Self {
        len: 0,
        values: [0.0; JOINT_OUTPUT_COUNT],
    };

    /// The first `count` of `values` (all ten if `count` is larger).
    pub fn packed(count: usize, values: [f32; JOINT_OUTPUT_COUNT]) -> Self {
        Self {
            len: count.min(JOINT_OUTPUT_COUNT) as u8,
            values,
        }
    }

    /// From a list of at most ten values (`None` if longer).
    pub fn from_slice(values: &[f32]) -> Option<Self> {
        let mut out = Self::EMPTY;
        out.values.get_mut(..values.len())?.copy_from_slice(values);
        out.len = values.len() as u8;
        Some(out)
    }

    /// The values.
    pub fn as_slice(&self) -> &[f32] {
        &self.values[..usize::from(self.len).min(JOINT_OUTPUT_COUNT)]
    }

    /// Their sum: finite only if every value is (NaN and infinities propagate).
    #[inline]
    pub fn sum(&self) -> f32 {
        self.as_slice().iter().sum()
    }
}

impl Serialize for JointValues {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        let values = self.as_slice();
        let mut seq = serializer.serialize_seq(Some(values.len()))?;
        for v in values {
            seq.serialize_element(v)?;
        }
        seq.end()
    }
}

struct JointValuesVisitor;

impl<'de> Visitor<'de> for JointValuesVisitor {
    type Value = JointValues;

    fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("at most ten joint output values")
    }

    fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<JointValues, A::Error> {
        let mut out = JointValues::EMPTY;
        while let Some(v) = seq.next_element()? {
            let Some(slot) = out.values.get_mut(usize::from(out.len)) else {
                return Err(A::Error::invalid_length(JOINT_OUTPUT_COUNT + 1, &self));
            };
            *slot = v;
            out.len += 1;
        }
        Ok(out)
    }
}

impl<'de> Deserialize<'de> for JointValues {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        deserializer.deserialize_seq(JointValuesVisitor)
    }
}

/// Running memory of the joint exposure: per output read (in packed order) the running
/// mean square and the largest excursion.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct JointExposureState {
    /// Running mean square, m^2 or rad^2.
    ms: [f32; JOINT_OUTPUT_COUNT],
    /// Largest absolute value since the warm-up, m or rad.
    peak: [f32; JOINT_OUTPUT_COUNT],
}

impl JointExposureState {
    /// At rest: nothing seen yet.
    pub const fn new() -> Self {
        Self {
            ms: [0.0; JOINT_OUTPUT_COUNT],
            peak: [0.0; JOINT_OUTPUT_COUNT],
        }
    }

    /// One reading of the outputs read (`y`, m or rad, packed), `gain` the running mean
    /// square's update gain over the step since the last reading ([`running_gain`]).
    /// `settled`: the reading is past the head's warm-up. Before it a reading only primes
    /// the running mean square, as the head's: the model's start-up transient (a ride
    /// that starts in motion, a pipeline restarted mid-ride by an upload) is not motion
    /// of the ride and must not become its largest excursion.
    #[inline(never)]
    pub fn step(&mut self, gain: f32, y: &[f32], settled: bool) {
        let n = y.len().min(JOINT_OUTPUT_COUNT);
        for (ms, &v) in self.ms[..n].iter_mut().zip(&y[..n]) {
            *ms += gain * (v * v - *ms);
        }
        if settled {
            for (peak, &v) in self.peak[..n].iter_mut().zip(&y[..n]) {
                let a = v.abs();
                *peak = if a > *peak { a } else { *peak };
            }
        }
    }

    /// Running mean square of the first `count` outputs, m^2 or rad^2.
    pub fn mean_square(&self, count: usize) -> &[f32] {
        &self.ms[..count.min(JOINT_OUTPUT_COUNT)]
    }

    /// Running rms of the first `count` outputs, m or rad.
    pub fn running_rms(&self, count: usize) -> JointValues {
        let mut out = JointValues::packed(count, [0.0; JOINT_OUTPUT_COUNT]);
        for (r, &ms) in out.values.iter_mut().zip(self.mean_square(count)) {
            *r = sqrt_f32(ms);
        }
        out
    }

    /// Largest absolute value of the first `count` outputs since the warm-up, m or rad,
    /// as a slice.
    pub fn peaks(&self, count: usize) -> &[f32] {
        &self.peak[..count.min(JOINT_OUTPUT_COUNT)]
    }

    /// Largest absolute value of the first `count` outputs since the warm-up, m or rad.
    pub fn largest_excursion(&self, count: usize) -> JointValues {
        JointValues::packed(count, self.peak)
    }
}

/// The running mean square's update gain over `samples` samples, from the per-sample gain
/// `per_sample` (`1 - alpha`): `1 - alpha^samples`, by repeated squaring (16 steps at
/// most), so no exponential is needed on the device.
pub fn running_gain(per_sample: f32, samples: u16) -> f32 {
    let (mut base, mut n, mut power) = (1.0 - per_sample, samples, 1.0f32);
    while n > 0 {
        if n & 1 != 0 {
            power *= base;
        }
        base *= base;
        n >>= 1;
    }
    1.0 - power
}

/// The joint outputs in `mask` (bit `i` for [`JointOutput::ALL`]`[i]`, as the greeting
/// sends it) in the order telemetry and status list their values: by the support axis
/// that drives them (x, y, z), in [`JointOutput::ALL`] order within an axis (the
/// readout's rows, [`JointReadout::packed_outputs`](crate::model::JointReadout::packed_outputs)).
pub fn packed_order(mask: u16) -> impl Iterator<Item = JointOutput> {
    Axis::ALL.into_iter().flat_map(move |axis| {
        JointOutput::ALL
            .into_iter()
            .filter(move |o| o.input_axis() == axis && mask & (1 << o.index()) != 0)
    })
}
