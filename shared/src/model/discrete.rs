//! The device realization: the continuous model discretized with a first-order (triangle)
//! hold, in block-diagonal modal form.
//!
//! Each reachable mode becomes a 2-state block driven by one input axis. A complex pair
//! lambda = s + j w is stored as the real rotation-scaling block of e^(lambda T); two real
//! poles of one subsystem share a diagonal block. Per sample and block this costs 6
//! multiply-adds for the state and 2 per output, against about 1,500 for a dense 36-state
//! form. States are kept in delta form (x += (Phi - I) x + g u) so that f32 keeps its
//! precision for poles near z = 1 at high sample rates.
//!
//! First-order hold: with u linear between samples, the exact update of a mode
//! z' = lambda z + g u is z[k+1] = phi z[k] + g (gamma0 u[k] + gamma1 u[k+1]), with
//! phi = e^(lambda T), gamma1 = T E2(lambda T), gamma0 = T (E1(lambda T) - E2(lambda T)),
//! E1(s) = (e^s - 1)/s, E2(s) = (e^s - 1 - s)/s^2. Shifting the state by gamma1 g u[k] makes
//! it causal with a feedthrough term: w[k+1] = phi w[k] + (phi gamma1 + gamma0) g u[k],
//! y[k] = Re(c w[k]) + c gamma1 g u[k].

use core::f64::consts::PI;
use core::fmt::Debug;
use core::ops::{Add, Mul, Sub};

use nalgebra::Complex;
use serde::{Deserialize, Serialize};

use super::ModelError;
use super::geometry::Axis;
use super::modal::{ModalAnalysis, ModalComponent, Subsystem, modulus};
use super::response::Output;

/// Blocks a realization can hold: 15 reachable modes in this model, plus slack.
pub const MAX_BLOCKS: usize = 16;

/// Lowest sample rate the device supports, Hz.
pub const MIN_SAMPLE_RATE_HZ: f64 = 100.0;
/// Highest sample rate the device supports, Hz.
pub const MAX_SAMPLE_RATE_HZ: f64 = 2000.0;
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
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(bound(
    serialize = "T: Serialize, [[T; 2]; NY]: Serialize",
    deserialize = "T: Deserialize<'de>, [[T; 2]; NY]: Deserialize<'de>"
))]
pub struct ModalBlock<T, const NY: usize> {
    /// Phi - I over one sample, row-major.
    pub transition_minus_identity: [[T; 2]; 2],
    /// The support axis that drives the block.
    pub input_axis: Axis,
    /// State increment per m/s^2 of input.
    pub input_gain: [T; 2],
    /// Output rows (m/s^2 per unit state).
    pub output: [[T; 2]; NY],
}

impl<T: Scalar, const NY: usize> ModalBlock<T, NY> {
    const EMPTY: Self = Self {
        transition_minus_identity: [[T::ZERO; 2]; 2],
        input_axis: Axis::X,
        input_gain: [T::ZERO; 2],
        output: [[T::ZERO; 2]; NY],
    };
}

/// A discrete-time realization from the three support accelerations to NY outputs.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(bound(
    serialize = "T: Serialize, [[T; 2]; NY]: Serialize, [[T; 3]; NY]: Serialize",
    deserialize = "T: Deserialize<'de>, [[T; 2]; NY]: Deserialize<'de>, [[T; 3]; NY]: Deserialize<'de>"
))]
pub struct DiscreteModal<T, const NY: usize> {
    /// The rate this realization was built for, Hz.
    pub sample_rate_hz: f32,
    /// Direct input-to-output term from the first-order hold, per output and input axis.
    pub feedthrough: [[T; 3]; NY],
    /// The modal blocks; only the first `block_count` are used.
    pub blocks: [ModalBlock<T, NY>; MAX_BLOCKS],
    /// How many blocks are in use.
    pub block_count: u8,
}

/// What the firmware runs: head x, y, z in f32.
pub type DeviceRealization = DiscreteModal<f32, 3>;

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
    /// A coefficient is NaN or infinite.
    NotFinite,
    /// A block has a pole on or outside the unit circle.
    Unstable,
    /// The sample rate is outside 100..=2000 Hz.
    SampleRate,
}

impl core::fmt::Display for RealizationError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            RealizationError::TooManyBlocks => "more modal blocks than the device holds",
            RealizationError::NotFinite => "a coefficient is not a finite number",
            RealizationError::Unstable => "a discrete pole lies on or outside the unit circle",
            RealizationError::SampleRate => "sample rate outside 100..=2000 Hz",
        })
    }
}

impl core::error::Error for RealizationError {}

impl<T: Scalar, const NY: usize> DiscreteModal<T, NY> {
    /// Advances one sample: returns the outputs at this sample (m/s^2) from the support
    /// acceleration at this sample (m/s^2, x, y, z) and moves the state on.
    ///
    /// Cannot fail: the realization was checked when it was built or loaded.
    #[inline]
    pub fn step(&self, state: &mut ModalState<T>, input_m_s2: [T; 3]) -> [T; NY] {
        let mut y = [T::ZERO; NY];
        for (out, d) in y.iter_mut().zip(self.feedthrough.iter()) {
            *out = d[0] * input_m_s2[0] + d[1] * input_m_s2[1] + d[2] * input_m_s2[2];
        }
        let used = usize::from(self.block_count).min(MAX_BLOCKS);
        for (block, x) in self.blocks[..used].iter().zip(state.blocks.iter_mut()) {
            let [x0, x1] = *x;
            for (out, c) in y.iter_mut().zip(block.output.iter()) {
                *out = *out + c[0] * x0 + c[1] * x1;
            }
            let u = input_m_s2[block.input_axis as usize];
            let d = &block.transition_minus_identity;
            let g = &block.input_gain;
            *x = [
                x0 + (d[0][0] * x0 + d[0][1] * x1 + g[0] * u),
                x1 + (d[1][0] * x0 + d[1][1] * x1 + g[1] * u),
            ];
        }
        y
    }

    /// Multiply-adds per sample: 3 per output for the feedthrough, and per block 6 for the
    /// state and 2 per output.
    pub fn multiply_adds_per_sample(&self) -> usize {
        3 * NY + usize::from(self.block_count) * (6 + 2 * NY)
    }

    /// The blocks in use.
    pub fn active_blocks(&self) -> &[ModalBlock<T, NY>] {
        &self.blocks[..usize::from(self.block_count).min(MAX_BLOCKS)]
    }

    /// Checks what a loaded realization must satisfy before it runs: block count, finite
    /// coefficients, sample rate, and every block's poles strictly inside the unit circle.
    ///
    /// With Phi = I + D, the Jury conditions for z^2 - tr(Phi) z + det(Phi) read
    /// det D > 0, tr D + det D < 0 and 4 + 2 tr D + det D > 0, which stay precise for poles
    /// close to z = 1.
    pub fn check(&self) -> Result<(), RealizationError> {
        if usize::from(self.block_count) > MAX_BLOCKS {
            return Err(RealizationError::TooManyBlocks);
        }
        let fs = f64::from(self.sample_rate_hz);
        if !(MIN_SAMPLE_RATE_HZ..=MAX_SAMPLE_RATE_HZ).contains(&fs) {
            return Err(RealizationError::SampleRate);
        }
        let finite = |v: T| v.to_f64().is_finite();
        if !self.feedthrough.iter().flatten().all(|&v| finite(v)) {
            return Err(RealizationError::NotFinite);
        }
        for block in self.active_blocks() {
            let coefficients = block
                .transition_minus_identity
                .iter()
                .flatten()
                .chain(block.input_gain.iter())
                .chain(block.output.iter().flatten());
            if !coefficients.into_iter().all(|&v| finite(v)) {
                return Err(RealizationError::NotFinite);
            }
            let d = block
                .transition_minus_identity
                .map(|row| row.map(T::to_f64));
            let trace = d[0][0] + d[1][1];
            let det = d[0][0] * d[1][1] - d[0][1] * d[1][0];
            if !(det > 0.0 && trace + det < 0.0 && 4.0 + 2.0 * trace + det > 0.0) {
                return Err(RealizationError::Unstable);
            }
        }
        Ok(())
    }

    /// The discrete frequency response D + sum C (zI - Phi)^-1 g at z = e^(j 2 pi f / fs),
    /// per output (rows) and input axis (columns), computed in f64.
    pub fn frequency_response(&self, freq_hz: f64) -> [[Complex<f64>; 3]; NY] {
        let theta = 2.0 * PI * freq_hz / f64::from(self.sample_rate_hz);
        let z = Complex::new(libm::cos(theta), libm::sin(theta));
        let mut h = [[Complex::new(0.0, 0.0); 3]; NY];
        for (row, d) in h.iter_mut().zip(self.feedthrough.iter()) {
            for (cell, v) in row.iter_mut().zip(d.iter()) {
                *cell = Complex::new(v.to_f64(), 0.0);
            }
        }
        for block in self.active_blocks() {
            let d = block.transition_minus_identity.map(|r| r.map(T::to_f64));
            // (zI - Phi) = (z - 1) I - D, inverted as a 2x2.
            let zm1 = z - 1.0;
            let (a, b, c, e) = (zm1 - d[0][0], -d[0][1], -d[1][0], zm1 - d[1][1]);
            let det = a * e - b * c;
            let g = block.input_gain.map(T::to_f64);
            let s0 = (e * g[0] - b * g[1]) / det;
            let s1 = (a * g[1] - c * g[0]) / det;
            for (row, out) in h.iter_mut().zip(block.output.iter()) {
                row[block.input_axis as usize] += s0 * out[0].to_f64() + s1 * out[1].to_f64();
            }
        }
        h
    }

    /// The same realization in another arithmetic (f64 reference to f32 device).
    pub fn cast<U: Scalar>(&self) -> DiscreteModal<U, NY> {
        let conv = |v: T| U::from_f64(v.to_f64());
        let mut blocks = [ModalBlock::<U, NY>::EMPTY; MAX_BLOCKS];
        for (dst, src) in blocks.iter_mut().zip(self.blocks.iter()) {
            *dst = ModalBlock {
                transition_minus_identity: src.transition_minus_identity.map(|r| r.map(conv)),
                input_axis: src.input_axis,
                input_gain: src.input_gain.map(conv),
                output: src.output.map(|r| r.map(conv)),
            };
        }
        DiscreteModal {
            sample_rate_hz: self.sample_rate_hz,
            feedthrough: self.feedthrough.map(|r| r.map(conv)),
            blocks,
            block_count: self.block_count,
        }
    }
}

impl<const NY: usize> DiscreteModal<f64, NY> {
    /// Discretizes the reachable modes that show in `outputs` at `sample_rate_hz` with a
    /// first-order hold.
    pub fn from_modal(
        analysis: &ModalAnalysis,
        sample_rate_hz: f64,
        outputs: &[Output; NY],
    ) -> Result<Self, ModelError> {
        if !(MIN_SAMPLE_RATE_HZ..=MAX_SAMPLE_RATE_HZ).contains(&sample_rate_hz) {
            return Err(ModelError::SampleRate);
        }
        let period_s = 1.0 / sample_rate_hz;
        let mut realization = Self {
            sample_rate_hz: sample_rate_hz as f32,
            feedthrough: [[0.0; 3]; NY],
            blocks: [ModalBlock::EMPTY; MAX_BLOCKS],
            block_count: 0,
        };
        let relevant = |m: &&ModalComponent| {
            m.reachable
                && m.subsystem.input_axis().is_some()
                && outputs
                    .iter()
                    .any(|o| modulus(m.output_gain[o.index()]) > 0.0)
        };
        let scale = analysis
            .components
            .iter()
            .filter(relevant)
            .flat_map(|m| {
                outputs
                    .iter()
                    .map(move |o| modulus(m.output_gain[o.index()] * m.input_gain))
            })
            .fold(0.0, f64::max);
        let shows = |m: &ModalComponent| {
            outputs
                .iter()
                .any(|o| modulus(m.output_gain[o.index()] * m.input_gain) > 1e-12 * scale)
        };
        for subsystem in Subsystem::ALL {
            let Some(axis) = subsystem.input_axis() else {
                continue;
            };
            let mut pending_real: Option<DiscreteMode<NY>> = None;
            let modes = analysis
                .components
                .iter()
                .filter(relevant)
                .filter(|m| m.subsystem == subsystem && shows(m));
            for m in modes {
                let mode = DiscreteMode::new(m, period_s, outputs);
                for (row, d) in realization
                    .feedthrough
                    .iter_mut()
                    .zip(mode.feedthrough.iter())
                {
                    row[axis.index()] += d;
                }
                let block = if m.is_pair {
                    Some(mode.pair_block(axis))
                } else if let Some(first) = pending_real.take() {
                    Some(DiscreteMode::real_block(axis, &first, Some(&mode)))
                } else {
                    pending_real = Some(mode);
                    None
                };
                if let Some(block) = block {
                    realization.push(block)?;
                }
            }
            if let Some(first) = pending_real {
                realization.push(DiscreteMode::real_block(axis, &first, None))?;
            }
        }
        Ok(realization)
    }

    fn push(&mut self, block: ModalBlock<f64, NY>) -> Result<(), ModelError> {
        let slot = self
            .blocks
            .get_mut(usize::from(self.block_count))
            .ok_or(ModelError::TooManyModes)?;
        *slot = block;
        self.block_count += 1;
        Ok(())
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
    fn new(m: &ModalComponent, period_s: f64, outputs: &[Output; NY]) -> Self {
        let s = m.eigenvalue * period_s;
        let (phi, e1, e2) = hold_integrals(s);
        let gamma1 = e2 * period_s;
        let gamma0 = (e1 - e2) * period_s;
        let c = outputs.map(|o| m.output_gain[o.index()]);
        // A pair contributes twice the real part of one member.
        let weight = if m.is_pair { 2.0 } else { 1.0 };
        Self {
            phi,
            input_gain: (phi * gamma1 + gamma0) * m.input_gain,
            output_gain: c.map(|ci| ci * weight),
            feedthrough: c.map(|ci| weight * (ci * gamma1 * m.input_gain).re),
        }
    }

    /// Real form of a complex mode: w = s0 + j s1, y = Re(c w) = Re c s0 - Im c s1.
    fn pair_block(&self, axis: Axis) -> ModalBlock<f64, NY> {
        ModalBlock {
            transition_minus_identity: [
                [self.phi.re - 1.0, -self.phi.im],
                [self.phi.im, self.phi.re - 1.0],
            ],
            input_axis: axis,
            input_gain: [self.input_gain.re, self.input_gain.im],
            output: self.output_gain.map(|c| [c.re, -c.im]),
        }
    }

    /// Two real poles side by side; a lone one gets an idle partner (Phi = 0, no gain).
    fn real_block(axis: Axis, first: &Self, second: Option<&Self>) -> ModalBlock<f64, NY> {
        let (phi2, gain2) = second.map_or((0.0, 0.0), |m| (m.phi.re, m.input_gain.re));
        ModalBlock {
            transition_minus_identity: [[first.phi.re - 1.0, 0.0], [0.0, phi2 - 1.0]],
            input_axis: axis,
            input_gain: [first.input_gain.re, gain2],
            output: core::array::from_fn(|o| {
                [
                    first.output_gain[o].re,
                    second.map_or(0.0, |m| m.output_gain[o].re),
                ]
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
