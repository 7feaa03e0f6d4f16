//! Streaming ISO 2631-1 evaluation of the predicted head acceleration: per axis and as the
//! vector sum, the running rms (exponential, tau = 1 s), its maximum (MTVV), the vibration
//! dose value (VDV), the overall weighted rms, the peak and the crest factor, in constant
//! memory and f32 on the per-sample path.
//!
//! # Quantities (all in the weighted domain, `a(t)` in m/s^2, `T` the evaluated time)
//! - running mean square `ms[n] = ms[n-1] + (1 - alpha)(a^2[n] - ms[n-1])`,
//!   `alpha = exp(-1/(fs tau))`; running rms `= sqrt(ms)`; MTVV `= max_n sqrt(ms[n])`.
//! - overall rms `a_w = sqrt(sum a^2 / N)`; VDV `= (sum a^4 / fs)^(1/4)` in m/s^1.75, not
//!   divided by time; peak `= max |a|`; crest factor `= peak / a_w`.
//! - vector sum `a_v(t)^2 = sum_i (k_i a_i(t))^2`, and every vector quantity above is
//!   taken on that time history. Its mean square, overall rms and running ms are the sums
//!   of the axes' (the averages are linear). Its VDV is `(integral a_v^4 dt)^(1/4)`,
//!   which is at least the root-sum-of-fourth-powers of the axis VDVs: the conservative
//!   choice for a patient alert.
//! - The basic (rms) method is not enough when the crest factor exceeds 9, when
//!   `MTVV / a_w > 1.5` or when `VDV / (a_w T^(1/4)) > 1.75` ([`AdditionalMethods`]).
//!
//! # Validity
//! The 0.4 Hz band-limiting high-pass rings for seconds after the filter starts from rest
//! (time constant `1/(zeta w1)` = 0.56 s; 1 % after about 2.6 s), so the first
//! `warmup_s` seconds (default 5 s) only prime the filters and the running rms: MTVV,
//! VDV, overall rms, peak and crest factor count from the end of the warm-up, and every
//! reported value says whether it is [`valid`](ExposureValues::valid) yet.
//!
//! # Cost
//! Per sample: the three weighting filters, one multiply-add per running mean square,
//! and f32 sums that fold into f64 totals every [`BLOCK_SAMPLES`] samples (so an
//! 8-hour dose keeps full precision without f64 arithmetic per sample). No division, no
//! transcendental function and no square root per sample: the alert stage compares the
//! mean square and the fourth-power dose with squared thresholds. Square and fourth
//! roots are taken only in [`ExposureSettings::values`], when values are reported.
//!
//! Counted in QEMU (mps2-an386, `-icount shift=0`, rustc 1.95, opt-level 3, fat LTO,
//! `target-cpu=cortex-m4`; instructions, not cycles), default mapping at 500 Hz after
//! the warm-up: [`ExposureSettings::step_block`] with 32 samples plus
//! [`AlertSettings::step_block`](crate::alerts::AlertSettings::step_block) about 203
//! instructions per sample (221 with blocks of 16; 224 with Wk on two axes); the
//! per-sample [`ExposureSettings::step`] plus `AlertSettings::step` about 340, because
//! every filter memory and accumulator goes through memory on each call.

use core::fmt;

use serde::{Deserialize, Serialize};

use crate::sample_rate::SampleRate;
use crate::weighting::{WeightingError, WeightingKind, WeightingSettings, WeightingState};

/// Crest factor above which ISO 2631-1 says the basic rms method may underestimate.
pub const CREST_FACTOR_LIMIT: f32 = 9.0;
/// `MTVV / a_w` above which the running-rms method is to be used as well (ISO 2631-1 6.3.3).
pub const MTVV_RATIO_LIMIT: f32 = 1.5;
/// `VDV / (a_w T^(1/4))` above which the fourth-power method is to be used as well.
pub const VDV_RATIO_LIMIT: f32 = 1.75;
/// Samples summed in f32 before the partial sums fold into the f64 totals.
pub const BLOCK_SAMPLES: u32 = 256;
/// Longest accepted warm-up, s (a typo of 5000 s should not silence a monitor for an hour).
pub const MAX_WARMUP_S: f32 = 120.0;

/// The weighting and vector-sum factor `k` applied to one head axis. In a parameter file
/// the weighting is required (the defaults differ by axis) and `k` defaults to 1.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "file-form", serde(deny_unknown_fields))]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct AxisWeighting {
    /// Frequency weighting for this axis.
    pub kind: WeightingKind,
    /// Multiplying factor `k` in the vector sum (1 for recumbent persons), dimensionless.
    #[cfg_attr(feature = "file-form", serde(default = "AxisWeighting::recumbent_k"))]
    pub k: f32,
}

impl AxisWeighting {
    /// The factor `k` of every axis of a recumbent person: 1.
    const fn recumbent_k() -> f32 {
        1.0
    }
}

/// Which weighting goes on which predicted head axis (litter/body axes of the head).
///
/// Axes: `x` longitudinal toward the head, `y` lateral, `z` vertical up. For a supine
/// patient the vehicle's vertical is the body's x axis (back to chest), and ISO 2631-1
/// weights a recumbent person's vertical under the head with Wj and both horizontal axes
/// with Wd, all with `k = 1`. Applying Wj to the *predicted head* acceleration (rather
/// than to a measurement on the support under the head) is this product's choice:
/// [`AxisMapping::SUPINE_HEAD`]. An axis a parameter file leaves out keeps its default.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "file-form", serde(default, deny_unknown_fields))]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct AxisMapping {
    /// Head x: longitudinal (along the litter, toward the head).
    pub x: AxisWeighting,
    /// Head y: lateral.
    pub y: AxisWeighting,
    /// Head z: vertical up (the supine body's back-to-chest axis).
    pub z: AxisWeighting,
}

impl AxisMapping {
    /// The default for a supine patient's head: Wd, Wd, Wj on x, y, z; `k = 1` everywhere.
    pub const SUPINE_HEAD: AxisMapping = AxisMapping {
        x: AxisWeighting {
            kind: WeightingKind::Wd,
            k: AxisWeighting::recumbent_k(),
        },
        y: AxisWeighting {
            kind: WeightingKind::Wd,
            k: AxisWeighting::recumbent_k(),
        },
        z: AxisWeighting {
            kind: WeightingKind::Wj,
            k: AxisWeighting::recumbent_k(),
        },
    };

    /// The three axes in x, y, z order.
    pub const fn axes(&self) -> [AxisWeighting; 3] {
        [self.x, self.y, self.z]
    }
}

impl Default for AxisMapping {
    fn default() -> Self {
        Self::SUPINE_HEAD
    }
}

/// The evaluation's configuration as carried in the parameter blob (SI units); a parameter
/// file's `[device.exposure]`, where a key left out keeps its [`DEFAULT`](Self::DEFAULT).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "file-form", serde(default, deny_unknown_fields))]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ExposureConfig {
    /// Weighting and `k` per head axis.
    pub axes: AxisMapping,
    /// Running-rms integration time constant, s (ISO 2631-1: 1 s).
    pub running_tau_s: f32,
    /// Time after start during which values are not yet valid, s (0..=120).
    pub warmup_s: f32,
}

impl ExposureConfig {
    /// Supine head mapping, tau = 1 s, 5 s warm-up.
    pub const DEFAULT: ExposureConfig = ExposureConfig {
        axes: AxisMapping::SUPINE_HEAD,
        running_tau_s: 1.0,
        warmup_s: 5.0,
    };
}

impl ExposureConfig {
    /// The numbers a configuration must hold at `sample_rate`, whether it is about to be
    /// built or was read from a blob: finite positive axis factors, a running-rms time
    /// constant of at least two samples, a warm-up within 0..=120 s.
    fn check(&self, sample_rate: SampleRate) -> Result<(), ExposureError> {
        if !self
            .axes
            .axes()
            .iter()
            .all(|a| a.k.is_finite() && a.k > 0.0)
        {
            return Err(ExposureError::AxisFactor);
        }
        let tau = self.running_tau_s as f64;
        if !(tau.is_finite() && tau * sample_rate.hz_f64() >= 2.0) {
            return Err(ExposureError::TimeConstant);
        }
        if !(self.warmup_s.is_finite() && (0.0..=MAX_WARMUP_S).contains(&self.warmup_s)) {
            return Err(ExposureError::Warmup);
        }
        Ok(())
    }
}

impl Default for ExposureConfig {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// Why an exposure configuration was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ExposureError {
    /// A weighting could not be built, or a stored one is unsound (coefficients, gain).
    Weighting(WeightingError),
    /// A vector-sum factor `k` is not finite and positive.
    AxisFactor,
    /// The running-rms time constant is not finite and positive, or under two samples.
    TimeConstant,
    /// The warm-up is not finite or outside 0..=120 s.
    Warmup,
    /// Stored settings differ from what their own config and the sample rate give.
    Mismatch,
}

impl fmt::Display for ExposureError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ExposureError::Weighting(e) => write!(f, "exposure: {e}"),
            ExposureError::AxisFactor => {
                f.write_str("exposure: axis factor k must be finite and positive")
            }
            ExposureError::TimeConstant => f.write_str(
                "exposure: running-rms time constant must be finite and at least two samples",
            ),
            ExposureError::Warmup => f.write_str("exposure: warm-up must be within 0..=120 s"),
            ExposureError::Mismatch => f.write_str(
                "exposure: stored settings do not match their configuration; rebuild them",
            ),
        }
    }
}

impl core::error::Error for ExposureError {
    fn source(&self) -> Option<&(dyn core::error::Error + 'static)> {
        match self {
            ExposureError::Weighting(e) => Some(e),
            _ => None,
        }
    }
}

impl From<WeightingError> for ExposureError {
    fn from(e: WeightingError) -> Self {
        ExposureError::Weighting(e)
    }
}

/// The running mean square's update gain per sample, `1 - exp(-1/(fs tau))`, for a time
/// constant `tau_s` at `sample_rate_hz`: the one formula for the head's running rms here
/// and the host's f64 joint statistics (`supine_host::exposure::joints`).
pub fn running_rms_gain(tau_s: f64, sample_rate_hz: f64) -> f64 {
    -libm::expm1(-1.0 / (sample_rate_hz * tau_s))
}

/// Everything the per-sample evaluation needs, precomputed for one sample rate (which the
/// parameter blob stores once, beside these settings).
///
/// Each axis filter carries its `k` in its gain, so the per-sample path never multiplies
/// by `k`; per-axis reports divide it out again.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct ExposureSettings {
    /// The configuration these settings were built from.
    pub config: ExposureConfig,
    /// Weighting per axis (x, y, z), gain multiplied by that axis' `k`.
    pub weighting: [WeightingSettings; 3],
    /// `1 - alpha = 1 - exp(-1/(fs tau))`, the running mean square's update gain.
    pub running_gain: f32,
    /// Sample period `1/fs`, s.
    pub sample_period_s: f32,
    /// Warm-up length in samples.
    pub warmup_samples: u32,
}

/// Per-sample output of the evaluation: what the alert stage compares with its thresholds.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ExposureSample {
    /// Running mean square of the vector sum, (m/s^2)^2 (its square root is the running rms).
    pub running_ms_m2_s4: f32,
    /// Running mean square of each axis' weighted signal times its `k`, (m/s^2)^2.
    pub axis_ms_m2_s4: [f32; 3],
    /// Fourth-power dose of the vector sum so far, `integral a_v^4 dt` in m^4/s^7 (VDV^4).
    pub vdv4_m4_s7: f32,
    /// The warm-up is over and both numbers mean what they say.
    pub valid: bool,
}

/// Running memory of the evaluation: constant size, no heap.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ExposureState {
    weighting: [WeightingState; 3],
    acc: Accumulators,
    totals: Totals,
    /// Sample index of the last sample.
    last_index: u32,
}

/// The f32 part of the state that every sample touches (kept in registers over a block).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct Accumulators {
    /// Running mean square per axis, of `k a_w`.
    ms: [f32; 3],
    /// Largest running mean square, per axis and for the vector sum.
    max_ms: [f32; 4],
    /// Largest squared sample, per axis and for the vector sum.
    peak_sq: [f32; 4],
    /// f32 partial sums of `a^2` per axis, since the last fold.
    block_sq: [f32; 3],
    /// f32 partial sums of `a^4` per axis and of `a_v^4`, since the last fold.
    block_q: [f32; 4],
    /// Samples in the partial sums.
    block_n: u32,
    /// Warm-up samples seen (stops at the warm-up length).
    samples: u32,
    /// `totals.q[3]` as f32, for the per-sample dose given to the alerts.
    total_q_v: f32,
}

impl Accumulators {
    const ZERO: Accumulators = Accumulators {
        ms: [0.0; 3],
        max_ms: [0.0; 4],
        peak_sq: [0.0; 4],
        block_sq: [0.0; 3],
        block_q: [0.0; 4],
        block_n: 0,
        samples: 0,
        total_q_v: 0.0,
    };
}

/// The f64 totals, touched once per [`BLOCK_SAMPLES`] samples.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct Totals {
    sq: [f64; 3],
    q: [f64; 4],
    /// Full blocks folded in.
    blocks: u32,
}

impl ExposureState {
    /// A fresh evaluation: filters at rest, all sums zero.
    pub const fn new() -> Self {
        Self {
            weighting: [WeightingState::new(); 3],
            acc: Accumulators::ZERO,
            totals: Totals {
                sq: [0.0; 3],
                q: [0.0; 4],
                blocks: 0,
            },
            last_index: 0,
        }
    }
}

/// Which ISO 2631-1 criteria call for methods beyond the basic rms.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct AdditionalMethods {
    /// Crest factor above 9.
    pub crest_factor: bool,
    /// `MTVV / a_w` above 1.5.
    pub mtvv_ratio: bool,
    /// `VDV / (a_w T^(1/4))` above 1.75.
    pub vdv_ratio: bool,
}

impl AdditionalMethods {
    /// Any of the three criteria is met.
    pub const fn any(&self) -> bool {
        self.crest_factor || self.mtvv_ratio || self.vdv_ratio
    }
}

/// The evaluation of one axis (or of the vector sum), weighted, SI units.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct AxisValues {
    /// Current running rms (tau = `running_tau_s`), m/s^2.
    pub running_rms_m_s2: f32,
    /// Maximum transient vibration value: the largest running rms so far, m/s^2.
    pub mtvv_m_s2: f32,
    /// Vibration dose value `(integral a^4 dt)^(1/4)`, m/s^1.75.
    pub vdv_m_s175: f32,
    /// Overall weighted rms since the warm-up ended, m/s^2.
    pub rms_m_s2: f32,
    /// Largest |weighted acceleration| since the warm-up ended, m/s^2.
    pub peak_m_s2: f32,
    /// `peak / rms` (0 while the rms is 0).
    pub crest_factor: f32,
    /// `MTVV / rms` (0 while the rms is 0).
    pub mtvv_ratio: f32,
    /// `VDV / (rms T^(1/4))` (0 while the rms or T is 0).
    pub vdv_ratio: f32,
    /// Which criteria call for the additional methods.
    pub additional: AdditionalMethods,
}

/// A report of the whole evaluation.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ExposureValues {
    /// Head x, y, z.
    pub axes: [AxisValues; 3],
    /// The vector sum `a_v`.
    pub vector: AxisValues,
    /// Evaluated time `T` (after the warm-up), s.
    pub duration_s: f32,
    /// Sample index of the last sample evaluated.
    pub at_sample: u32,
    /// The warm-up is over: every value above means what it says.
    pub valid: bool,
}

impl ExposureSettings {
    /// Builds the evaluation for `sample_rate`; validates `config`.
    pub fn new(config: ExposureConfig, sample_rate: SampleRate) -> Result<Self, ExposureError> {
        config.check(sample_rate)?;
        let axes = config.axes.axes();
        let mut weighting = [WeightingSettings::new(axes[0].kind, sample_rate)?; 3];
        for (w, a) in weighting.iter_mut().zip(axes.iter()) {
            *w = WeightingSettings::new(a.kind, sample_rate)?.scaled(a.k);
        }
        let fs = sample_rate.hz_f64();
        let running_gain = running_rms_gain(config.running_tau_s as f64, fs) as f32;
        let warmup_samples = libm::round(config.warmup_s as f64 * fs) as u32;
        let sample_period_s = (1.0 / fs) as f32;
        Ok(Self {
            config,
            weighting,
            running_gain,
            sample_period_s,
            warmup_samples,
        })
    }

    /// Checks stored settings (from a parameter blob, built for `sample_rate`) before use:
    /// every filter finite and stable, the axes sharing one band limiting, the kinds and
    /// factors matching the config, the integration constants in range.
    pub fn validate(&self, sample_rate: SampleRate) -> Result<(), ExposureError> {
        // Structural checks only: redesigning the filters here would pull the whole f64
        // design (tan, exp, cos in software) into the device image. The blob's CRC and
        // signature vouch that the coefficients are the host's; this vouches they are sane.
        self.config.check(sample_rate)?;
        let fs = sample_rate.hz();
        let band = &self.weighting[0].band;
        for (w, axis) in self.weighting.iter().zip(self.config.axes.axes()) {
            w.validate_gain(axis.k)?;
            if w.kind != axis.kind || w.band != *band {
                return Err(ExposureError::Mismatch);
            }
        }
        if !(self.running_gain > 0.0 && self.running_gain < 1.0) {
            return Err(ExposureError::TimeConstant);
        }
        let period_error = self.sample_period_s * fs - 1.0;
        if period_error.is_nan() || period_error.abs() >= 1e-4 {
            return Err(ExposureError::Mismatch);
        }
        if self.warmup_samples as f32 > MAX_WARMUP_S * fs {
            return Err(ExposureError::Warmup);
        }
        Ok(())
    }

    /// Samples of the warm-up still to come in `state`: the next sample's
    /// [`ExposureSample::valid`] is false while this is not zero. The joints' exposure
    /// waits for the same warm-up (`crate::pipeline`).
    #[inline]
    pub fn warmup_left(&self, state: &ExposureState) -> u32 {
        self.warmup_samples.saturating_sub(state.acc.samples)
    }

    /// One sample of predicted head acceleration (m/s^2, head x, y, z, at the design rate).
    ///
    /// Never fails: a non-finite input propagates into the values (the sensor check in
    /// [`crate::alerts`] reports it); call [`ExposureState::new`] to restart afterwards.
    /// Same results, bit for bit, as [`step_block`](Self::step_block) with one sample.
    #[inline]
    pub fn step(
        &self,
        state: &mut ExposureState,
        head_acc_m_s2: [f32; 3],
        sample_index: u32,
    ) -> ExposureSample {
        let mut out = [ExposureSample::default()];
        self.step_block(state, &[head_acc_m_s2], sample_index, &mut out);
        out[0]
    }

    /// `N` consecutive samples at once (indices `first_index..first_index + N`), writing
    /// one [`ExposureSample`] per sample into `out`: the same arithmetic as `N` calls of
    /// [`step`](Self::step), bit for bit, with far fewer loads and stores. Each axis'
    /// filter runs over the whole block with its coefficients and memories in registers,
    /// then the statistics run with their accumulators in registers. This is the form
    /// that meets the per-sample instruction budget on the Cortex-M4F (blocks of 16 to 32
    /// samples; the latency added is far below the alert dwell times).
    // Parallel arrays indexed by axis read more plainly than zipped iterators.
    #[allow(clippy::needless_range_loop)]
    #[inline]
    pub fn step_block<const N: usize>(
        &self,
        state: &mut ExposureState,
        head_acc_m_s2: &[[f32; 3]; N],
        first_index: u32,
        out: &mut [ExposureSample; N],
    ) {
        // All three weightings share their band limiting at one rate (checked on
        // construction and by `validate`): one copy of those coefficients serves all axes.
        let band = &self.weighting[0].band;
        let mut a = [[0.0f32; N]; 3];
        for i in 0..3 {
            let w = &self.weighting[i];
            let mut ws = state.weighting[i];
            for n in 0..N {
                a[i][n] = w.step_with_band(band, &mut ws, head_acc_m_s2[n][i]);
            }
            state.weighting[i] = ws;
        }
        // Locals, not fields: nothing takes their address, so they live in registers.
        let Accumulators {
            mut ms,
            mut max_ms,
            mut peak_sq,
            mut block_sq,
            mut block_q,
            mut block_n,
            mut samples,
            mut total_q_v,
        } = state.acc;
        let (gain, dt) = (self.running_gain, self.sample_period_s);
        // The warm-up samples of this block come first, in a loop of their own, so the
        // steady-state loop below carries no warm-up test.
        let warm = (self.warmup_left(state) as usize).min(N);
        for n in 0..warm {
            for i in 0..3 {
                ms[i] += gain * (a[i][n] * a[i][n] - ms[i]);
            }
            out[n] = ExposureSample {
                running_ms_m2_s4: ms[0] + ms[1] + ms[2],
                axis_ms_m2_s4: ms,
                vdv4_m4_s7: 0.0,
                valid: false,
            };
        }
        samples += warm as u32;
        for n in warm..N {
            let a2 = [a[0][n] * a[0][n], a[1][n] * a[1][n], a[2][n] * a[2][n]];
            for i in 0..3 {
                ms[i] += gain * (a2[i] - ms[i]);
            }
            let ms_v = ms[0] + ms[1] + ms[2];
            let av2 = a2[0] + a2[1] + a2[2];
            for i in 0..3 {
                block_sq[i] += a2[i];
                block_q[i] += a2[i] * a2[i];
                if ms[i] > max_ms[i] {
                    max_ms[i] = ms[i];
                }
                if a2[i] > peak_sq[i] {
                    peak_sq[i] = a2[i];
                }
            }
            block_q[3] += av2 * av2;
            if ms_v > max_ms[3] {
                max_ms[3] = ms_v;
            }
            if av2 > peak_sq[3] {
                peak_sq[3] = av2;
            }
            block_n += 1;
            if block_n >= BLOCK_SAMPLES {
                let [s0, s1, s2] = block_sq;
                let [q0, q1, q2, q3] = block_q;
                total_q_v = fold(s0, s1, s2, q0, q1, q2, q3, total_q_v, &mut state.totals);
                block_sq = [0.0; 3];
                block_q = [0.0; 4];
                block_n = 0;
            }
            out[n] = ExposureSample {
                running_ms_m2_s4: ms_v,
                axis_ms_m2_s4: ms,
                vdv4_m4_s7: (total_q_v + block_q[3]) * dt,
                valid: true,
            };
        }
        state.acc = Accumulators {
            ms,
            max_ms,
            peak_sq,
            block_sq,
            block_q,
            block_n,
            samples,
            total_q_v,
        };
        state.last_index = first_index.wrapping_add(N as u32).wrapping_sub(1);
    }

    /// The current values, per axis and for the vector sum (square and fourth roots here);
    /// `sample_rate` is the rate these settings were built for.
    #[allow(clippy::needless_range_loop)]
    pub fn values(&self, sample_rate: SampleRate, state: &ExposureState) -> ExposureValues {
        let dt = 1.0 / sample_rate.hz_f64();
        let (acc, totals) = (&state.acc, &state.totals);
        let n = totals.blocks as f64 * BLOCK_SAMPLES as f64 + acc.block_n as f64;
        let duration = n * dt;
        let sq = |i: usize| totals.sq[i] + acc.block_sq[i] as f64;
        let q = |i: usize| totals.q[i] + acc.block_q[i] as f64;
        let axes = self.config.axes.axes();
        let mut out = ExposureValues {
            duration_s: duration as f32,
            at_sample: state.last_index,
            valid: acc.samples >= self.warmup_samples && n > 0.0,
            ..ExposureValues::default()
        };
        for i in 0..3 {
            let k = axes[i].k as f64;
            out.axes[i] = axis_values(
                acc.ms[i] as f64 / (k * k),
                acc.max_ms[i] as f64 / (k * k),
                sq(i) / (k * k),
                q(i) / (k * k * k * k),
                acc.peak_sq[i] as f64 / (k * k),
                n,
                dt,
            );
        }
        let ms_v = acc.ms.iter().map(|&m| m as f64).sum::<f64>();
        out.vector = axis_values(
            ms_v,
            acc.max_ms[3] as f64,
            sq(0) + sq(1) + sq(2),
            q(3),
            acc.peak_sq[3] as f64,
            n,
            dt,
        );
        out
    }
}

/// Adds the f32 block sums (`s*`: a^2 per axis, `q*`: a^4 per axis and a_v^4) into the
/// f64 totals, every [`BLOCK_SAMPLES`] samples, and returns the vector's fourth-power
/// total as f32 for the per-sample dose. Scalars, not arrays, so that the caller's
/// accumulators stay in registers.
///
/// The dose never falls: within a block the per-sample dose `(total + block sum) dt` only
/// grows (f32 addition and multiplication round monotonically), and the total returned
/// here is at least `previous + q3` as the last sample computed it in f32, which the f64
/// total rounded to f32 can be one step below. Below [`DOSE_TOTAL_CAP`] (no real dose
/// comes near it) it therefore never falls, at no cost per sample (`docs/exposure.md`).
#[cold]
#[inline(never)]
#[allow(clippy::too_many_arguments)]
fn fold(
    s0: f32,
    s1: f32,
    s2: f32,
    q0: f32,
    q1: f32,
    q2: f32,
    q3: f32,
    previous: f32,
    totals: &mut Totals,
) -> f32 {
    for (t, b) in totals.sq.iter_mut().zip([s0, s1, s2]) {
        *t += b as f64;
    }
    for (t, b) in totals.q.iter_mut().zip([q0, q1, q2, q3]) {
        *t += b as f64;
    }
    totals.blocks = totals.blocks.saturating_add(1);
    // Capped so that adding a block's sum and scaling by dt stays finite however long the
    // run (a blob's gains are bounded so that a block's sum is under 1e36); no real dose
    // comes near it.
    let total = totals.q[3];
    // Comparisons, not f64::min/max: no NaN to handle, and no soft-float call on the device.
    let rounded = (if total > DOSE_TOTAL_CAP {
        DOSE_TOTAL_CAP
    } else {
        total
    }) as f32;
    let reported = previous + q3;
    if reported > rounded && (reported as f64) <= DOSE_TOTAL_CAP {
        reported
    } else {
        rounded
    }
}

/// Largest fourth-power total handed to f32 (half of `f32::MAX`).
const DOSE_TOTAL_CAP: f64 = f32::MAX as f64 / 2.0;

/// Derived values from the sums: `ms` running mean square, `sum_sq = sum a^2`,
/// `sum_q = sum a^4`, `n` samples of `dt` seconds.
fn axis_values(
    ms: f64,
    max_ms: f64,
    sum_sq: f64,
    sum_q: f64,
    peak_sq: f64,
    n: f64,
    dt: f64,
) -> AxisValues {
    let rms = if n > 0.0 { libm::sqrt(sum_sq / n) } else { 0.0 };
    let vdv = libm::sqrt(libm::sqrt(sum_q * dt));
    let mtvv = libm::sqrt(max_ms);
    let peak = libm::sqrt(peak_sq);
    let t = n * dt;
    let ratio = |num: f64, den: f64| if den > 0.0 { num / den } else { 0.0 };
    let crest = ratio(peak, rms);
    let mtvv_ratio = ratio(mtvv, rms);
    let vdv_ratio = ratio(vdv, rms * libm::sqrt(libm::sqrt(t)));
    AxisValues {
        running_rms_m_s2: libm::sqrt(ms) as f32,
        mtvv_m_s2: mtvv as f32,
        vdv_m_s175: vdv as f32,
        rms_m_s2: rms as f32,
        peak_m_s2: peak as f32,
        crest_factor: crest as f32,
        mtvv_ratio: mtvv_ratio as f32,
        vdv_ratio: vdv_ratio as f32,
        additional: AdditionalMethods {
            crest_factor: crest > CREST_FACTOR_LIMIT as f64,
            mtvv_ratio: mtvv_ratio > MTVV_RATIO_LIMIT as f64,
            vdv_ratio: vdv_ratio > VDV_RATIO_LIMIT as f64,
        },
    }
}

/// The VDV of exposures in sequence (the legs of a mission), m/s^1.75: ISO 2631-1 adds
/// the fourth powers, `(sum VDV_i^4)^(1/4)`, because the VDV is the fourth root of an
/// integral over time. In f64: the host combines reported values, the device never does.
pub fn combined_vdv_m_s175(vdv_m_s175: &[f64]) -> f64 {
    let sum: f64 = vdv_m_s175.iter().map(|v| (v * v) * (v * v)).sum();
    libm::pow(sum, 0.25)
}

/// The rms of exposures in sequence, m/s^2: energy-equivalent, as ISO 2631-1 combines
/// periods of different magnitude, `sqrt(sum a_i^2 T_i / sum T_i)` over `(a_i, T_i)`
/// pairs of rms (m/s^2) and evaluated duration (s). Zero when no time was evaluated.
pub fn combined_rms_m_s2(rms_and_duration: &[(f64, f64)]) -> f64 {
    let total_s: f64 = rms_and_duration.iter().map(|(_, t)| t).sum();
    if total_s <= 0.0 {
        return 0.0;
    }
    libm::sqrt(rms_and_duration.iter().map(|(a, t)| a * a * t).sum::<f64>() / total_s)
}

#[cfg(test)]
mod tests;
