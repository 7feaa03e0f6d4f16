//! Alerts: exposure levels (advisory, warning, alarm) from the running rms and the VDV of
//! the head's vector sum, with hysteresis and dwell; and sensor faults (non-finite
//! sample, saturation, stuck sensor, gap in sample indices); and, in [`joint`], alerts on
//! the neck's and lower back's motion, on thresholds a medical director sets (none by
//! default). All report time-stamped raise and clear events ([`AlertEvent`]), stamped
//! with the sample index.
//!
//! # Default thresholds, and what they rest on
//! ISO 2631-1 gives **no** health or comfort method for recumbent persons. The defaults
//! below borrow the seated scales and apply them to the predicted head acceleration of a
//! supine patient: they are extrapolations, a starting point to be set per mission in the
//! parameter blob, not limits established for patients.
//! - Running rms (1 s, vector sum), from the comfort scale of ISO 2631-1 Annex C, each at
//!   the lower edge of a band: advisory 0.5 m/s^2 ("fairly uncomfortable"), warning
//!   0.8 m/s^2 ("uncomfortable"), alarm 1.25 m/s^2 ("very uncomfortable").
//! - VDV (vector sum, since start), from the health guidance caution zone of ISO 2631-1
//!   Annex B: advisory 8.5 m/s^1.75 (entering the zone), warning 17 m/s^1.75 (leaving it:
//!   health risks likely); alarm 21 m/s^1.75, the daily exposure limit value of Directive
//!   2002/44/EC for the crew, as a ceiling no patient should exceed either.
//! - A running-rms level clears when the running rms falls below `(1 - hysteresis)` of
//!   its threshold (default 20 %); it is raised after the condition held `raise_dwell_s`
//!   (0.5 s) and lowered after `clear_dwell_s` (5 s). The VDV never decreases, so a
//!   VDV level lasts until the evaluation restarts.
//!
//! # Cost
//! Per sample, the level check is a few f32 comparisons with precomputed squared (rms)
//! and fourth-power (VDV) thresholds; no square roots.

use core::fmt;

use enumset::{EnumSet, EnumSetType};
use serde::{Deserialize, Serialize};

use crate::exposure::ExposureSample;
use crate::fpu::sqrt_f32;
use crate::input_resolution::INPUT_RANGE_M_S2;
use crate::sample_rate::SampleRate;

pub mod joint;

pub use joint::{JointAlertConfig, JointAlertSettings, JointAlertState, JointCriterion};

/// Standard gravity in f32, m/s^2, for full scales quoted in g: the one definition is
/// [`crate::mounting::STANDARD_GRAVITY_M_S2`].
const STANDARD_GRAVITY_M_S2: f32 = crate::mounting::STANDARD_GRAVITY_M_S2 as f32;
/// Longest accepted dwell or stuck time, s.
pub const MAX_DWELL_S: f32 = 600.0;

/// Exposure alert level, ordered from `Normal` to `Alarm`. Its name ([`Level::name`]) is
/// what every output says (JSON, CSV, report): serde spells it the same, and on the wire
/// (postcard) it is the variant's index, so the names cost no bytes there.
#[derive(
    Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize,
)]
#[serde(rename_all = "lowercase")]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Level {
    /// Below every threshold.
    #[default]
    Normal = 0,
    /// First threshold crossed.
    Advisory = 1,
    /// Second threshold crossed.
    Warning = 2,
    /// Third threshold crossed.
    Alarm = 3,
}

impl Level {
    /// Every level, in rising order (index `i` is the level `i as u8`).
    pub const ALL: [Level; 4] = [Level::Normal, Level::Advisory, Level::Warning, Level::Alarm];
    /// The levels above `Normal`, in rising order (index `i` uses thresholds `[i]`).
    pub const RAISED: [Level; 3] = [Level::Advisory, Level::Warning, Level::Alarm];

    /// The level named `name` ([`Level::name`]), if any.
    pub fn from_name(name: &str) -> Option<Level> {
        Level::ALL.into_iter().find(|l| l.name() == name)
    }

    const fn from_index(i: usize) -> Level {
        match i {
            0 => Level::Normal,
            1 => Level::Advisory,
            2 => Level::Warning,
            _ => Level::Alarm,
        }
    }

    /// Lower-case name (`normal`, `advisory`, `warning`, `alarm`).
    pub const fn name(self) -> &'static str {
        match self {
            Level::Normal => "normal",
            Level::Advisory => "advisory",
            Level::Warning => "warning",
            Level::Alarm => "alarm",
        }
    }
}

impl fmt::Display for Level {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// A fault of the accelerometer stream. Its declaration order is its bit in
/// [`FaultFlags`]: changing it changes the wire format.
// EnumSetType also derives Clone, Copy, PartialEq and Eq.
#[derive(Debug, Hash, Serialize, Deserialize, EnumSetType)]
#[serde(rename_all = "kebab-case")]
#[enumset(repr = "u8", serialize_deny_unknown)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum SensorFault {
    /// A sample is NaN or infinite.
    NonFinite,
    /// A sample's magnitude reached the configured full scale.
    Saturated,
    /// An axis repeated exactly the same value for `stuck_after_s`.
    Stuck,
    /// A sample index did not follow the previous one (lost, repeated or reordered samples).
    IndexGap,
}

impl SensorFault {
    /// All faults, in bit order.
    pub const ALL: [SensorFault; 4] = [
        SensorFault::NonFinite,
        SensorFault::Saturated,
        SensorFault::Stuck,
        SensorFault::IndexGap,
    ];

    /// Lower-case name (`non-finite`, `saturated`, `stuck`, `index-gap`).
    pub const fn name(self) -> &'static str {
        match self {
            SensorFault::NonFinite => "non-finite",
            SensorFault::Saturated => "saturated",
            SensorFault::Stuck => "stuck",
            SensorFault::IndexGap => "index-gap",
        }
    }
}

impl fmt::Display for SensorFault {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// A set of active sensor faults, one bit per [`SensorFault`] (bit `n` for the `n`th of
/// [`SensorFault::ALL`]). The device, the telemetry and the host share it; on the wire it
/// is that byte ([`as_repr`](EnumSet::as_repr)), and a byte with a bit no fault owns does
/// not decode.
pub type FaultFlags = EnumSet<SensorFault>;

/// The exposure value that changed a level, at the sample of the change: so that an alert
/// says why it was raised, not only that it was.
///
/// A raise names the running rms when it alone reaches the new level's threshold, else the
/// VDV. A drop always names the running rms: the VDV never decreases, so only a falling
/// running rms lowers a level. The value is computed exactly as the telemetry's
/// `vector_running_rms_m_s2` or `vdv_m_s175` of the same sample.
///
/// Serde names the variants as [`Criterion::name`] does (`running-rms`, `vdv`); on the
/// wire (postcard) a variant is its index.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Criterion {
    /// The 1 s running rms of the head's vector sum.
    RunningRms {
        /// Its value at the change, m/s^2.
        value_m_s2: f32,
    },
    /// The VDV of the head's vector sum since the evaluation started.
    Vdv {
        /// Its value at the change, m/s^1.75.
        value_m_s175: f32,
    },
}

impl Criterion {
    /// Lower-case name (`running-rms`, `vdv`).
    pub const fn name(&self) -> &'static str {
        match self {
            Criterion::RunningRms { .. } => "running-rms",
            Criterion::Vdv { .. } => "vdv",
        }
    }

    /// The value at the change, in [`unit`](Self::unit).
    pub const fn value(&self) -> f32 {
        match *self {
            Criterion::RunningRms { value_m_s2 } => value_m_s2,
            Criterion::Vdv { value_m_s175 } => value_m_s175,
        }
    }

    /// Unit of [`value`](Self::value): `m/s^2` or `m/s^1.75`.
    pub const fn unit(&self) -> &'static str {
        match self {
            Criterion::RunningRms { .. } => "m/s^2",
            Criterion::Vdv { .. } => "m/s^1.75",
        }
    }
}

impl fmt::Display for Criterion {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} {} {}", self.name(), self.value(), self.unit())
    }
}

/// A time-stamped alert edge.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum AlertEvent {
    /// The exposure level changed (raised when `to > from`, cleared otherwise).
    Level {
        /// Level before.
        from: Level,
        /// Level after.
        to: Level,
        /// What caused the change, and its value then.
        criterion: Criterion,
        /// Sample index at which the change took effect (after the dwell).
        at_sample: u32,
    },
    /// A sensor fault started (`active`) or ended.
    Fault {
        /// Which fault.
        fault: SensorFault,
        /// `true` when raised, `false` when cleared.
        active: bool,
        /// Sample index at which the fault was detected (raise) or cleared.
        at_sample: u32,
    },
    /// A joint-motion alert was raised or cleared (module [`joint`]).
    Joint {
        /// Which joint output: its index in
        /// [`JointOutput::ALL`](crate::model::JointOutput::ALL).
        output: u8,
        /// What crossed its threshold, and its value then (m or rad).
        criterion: JointCriterion,
        /// `true` when raised, `false` when cleared.
        raised: bool,
        /// Sample index of the joint reading that changed it.
        at_sample: u32,
    },
}

impl AlertEvent {
    /// The sample index the event is stamped with.
    pub const fn at_sample(&self) -> u32 {
        match *self {
            AlertEvent::Level { at_sample, .. }
            | AlertEvent::Fault { at_sample, .. }
            | AlertEvent::Joint { at_sample, .. } => at_sample,
        }
    }

    /// What changed the level (`None` for a sensor fault, which is its own cause, and for
    /// a joint alert: [`joint_criterion`](Self::joint_criterion)).
    pub const fn criterion(&self) -> Option<Criterion> {
        match *self {
            AlertEvent::Level { criterion, .. } => Some(criterion),
            AlertEvent::Fault { .. } | AlertEvent::Joint { .. } => None,
        }
    }

    /// A joint alert's output and criterion (`None` for the other events).
    pub fn joint_criterion(&self) -> Option<(crate::model::JointOutput, JointCriterion)> {
        match *self {
            AlertEvent::Joint {
                output, criterion, ..
            } => crate::model::JointOutput::ALL
                .get(usize::from(output))
                .map(|o| (*o, criterion)),
            _ => None,
        }
    }

    /// The event raises (rather than clears) an alert.
    pub fn is_raise(&self) -> bool {
        match *self {
            AlertEvent::Level { from, to, .. } => to > from,
            AlertEvent::Fault { active, .. } => active,
            AlertEvent::Joint { raised, .. } => raised,
        }
    }

    /// Time of the event in seconds from sample 0, at `sample_rate_hz`.
    pub fn at_s(&self, sample_rate_hz: f32) -> f64 {
        self.at_sample() as f64 / sample_rate_hz as f64
    }
}

/// Why an alert or sensor-check configuration was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum AlertError {
    /// A threshold is not finite and positive, or the three are not strictly increasing.
    Thresholds,
    /// The hysteresis fraction is not within 0..=0.9.
    Hysteresis,
    /// A dwell, stuck or clear time is not finite or outside 0..=600 s.
    Time,
    /// The full scale is not finite, positive and at most
    /// [`SensorCheckConfig::MAX_FULL_SCALE_M_S2`].
    FullScale,
    /// A joint-motion threshold is negative or not finite, or set for an output the
    /// device does not read.
    JointThresholds,
}

impl fmt::Display for AlertError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            AlertError::Thresholds => {
                "alert thresholds must be finite, positive and strictly increasing"
            }
            AlertError::Hysteresis => "alert hysteresis must be within 0..=0.9",
            AlertError::Time => "alert dwell and sensor times must be within 0..=600 s",
            AlertError::FullScale => "sensor full scale must be positive and at most 400 g",
            AlertError::JointThresholds => {
                "joint alert thresholds must be finite and positive, for outputs the device reads"
            }
        })
    }
}

impl core::error::Error for AlertError {}

/// Exposure alert configuration as carried in the parameter blob (SI units); a parameter
/// file's `[device.alerts]`, where a key left out keeps its [`DEFAULT`](Self::DEFAULT).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "file-form", serde(default, deny_unknown_fields))]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct AlertConfig {
    /// Running-rms thresholds of the vector sum for advisory, warning, alarm, m/s^2.
    pub running_rms_m_s2: [f32; 3],
    /// VDV thresholds of the vector sum for advisory, warning, alarm, m/s^1.75.
    pub vdv_m_s175: [f32; 3],
    /// A running-rms level clears below `(1 - hysteresis)` times its threshold (0..=0.9).
    pub hysteresis: f32,
    /// How long a higher level must be called for before it is raised, s.
    pub raise_dwell_s: f32,
    /// How long a lower level must be called for before the level drops, s.
    pub clear_dwell_s: f32,
}

impl AlertConfig {
    /// Extrapolated defaults for a recumbent patient (see the module documentation).
    pub const DEFAULT: AlertConfig = AlertConfig {
        running_rms_m_s2: [0.5, 0.8, 1.25],
        vdv_m_s175: [8.5, 17.0, 21.0],
        hysteresis: 0.2,
        raise_dwell_s: 0.5,
        clear_dwell_s: 5.0,
    };
}

impl Default for AlertConfig {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// Samples in `t_s` at `fs`, at least one (`t_s` finite, within 0..=[`MAX_DWELL_S`]).
pub(crate) fn samples_of(t_s: f32, fs: f64) -> Result<u32, AlertError> {
    if t_s.is_finite() && (0.0..=MAX_DWELL_S).contains(&t_s) {
        Ok((libm::round(t_s as f64 * fs) as u32).max(1))
    } else {
        Err(AlertError::Time)
    }
}

fn increasing_positive(t: &[f32; 3]) -> bool {
    t.iter().all(|x| x.is_finite() && *x > 0.0) && t[0] < t[1] && t[1] < t[2]
}

/// The exposure-level state machine's precomputed thresholds, for one sample rate.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct AlertSettings {
    /// The configuration these settings were built from.
    pub config: AlertConfig,
    /// Squared running-rms raise thresholds, (m/s^2)^2.
    pub raise_ms_m2_s4: [f32; 3],
    /// Squared running-rms clear thresholds `((1 - h) threshold)^2`, (m/s^2)^2.
    pub clear_ms_m2_s4: [f32; 3],
    /// Fourth powers of the VDV thresholds, m^4/s^7.
    pub vdv4_m4_s7: [f32; 3],
    /// Raise dwell, samples (at least 1).
    pub raise_dwell_samples: u32,
    /// Clear dwell, samples (at least 1).
    pub clear_dwell_samples: u32,
}

/// Running state of the exposure-level state machine.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct AlertState {
    level: Level,
    /// Direction of the pending change: +1 up, -1 down, 0 none.
    pending_dir: i8,
    /// Consecutive samples the pending change has been called for.
    pending_samples: u32,
}

impl AlertState {
    /// Level `Normal`, nothing pending.
    pub const fn new() -> Self {
        Self {
            level: Level::Normal,
            pending_dir: 0,
            pending_samples: 0,
        }
    }

    /// The current level.
    pub const fn level(&self) -> Level {
        self.level
    }
}

impl AlertSettings {
    /// Validates `config` and precomputes thresholds for `sample_rate`.
    pub fn new(config: AlertConfig, sample_rate: SampleRate) -> Result<Self, AlertError> {
        let fs = sample_rate.hz_f64();
        if !(increasing_positive(&config.running_rms_m_s2)
            && increasing_positive(&config.vdv_m_s175))
        {
            return Err(AlertError::Thresholds);
        }
        if !(config.hysteresis.is_finite() && (0.0..=0.9).contains(&config.hysteresis)) {
            return Err(AlertError::Hysteresis);
        }
        let raise_dwell_samples = samples_of(config.raise_dwell_s, fs)?;
        let clear_dwell_samples = samples_of(config.clear_dwell_s, fs)?;
        let h = 1.0 - config.hysteresis as f64;
        let rms = config.running_rms_m_s2.map(|t| t as f64);
        Ok(Self {
            config,
            raise_ms_m2_s4: rms.map(|t| (t * t) as f32),
            clear_ms_m2_s4: rms.map(|t| (h * h * t * t) as f32),
            vdv4_m4_s7: config.vdv_m_s175.map(|t| {
                let t = t as f64;
                (t * t * t * t) as f32
            }),
            raise_dwell_samples,
            clear_dwell_samples,
        })
    }

    /// Checks stored settings (from a parameter blob, built for `sample_rate`) by
    /// rebuilding them from their config.
    pub fn validate(&self, sample_rate: SampleRate) -> Result<(), AlertError> {
        if Self::new(self.config, sample_rate)? == *self {
            Ok(())
        } else {
            Err(AlertError::Thresholds)
        }
    }

    /// Highest level whose threshold `ms` or `vdv4` reaches (rms thresholds from `ms_table`).
    #[inline(always)]
    fn level_for(&self, ms_table: &[f32; 3], ms: f32, vdv4: f32) -> Level {
        let mut i = 3;
        while i > 0 {
            if ms >= ms_table[i - 1] || vdv4 >= self.vdv4_m4_s7[i - 1] {
                break;
            }
            i -= 1;
        }
        Level::from_index(i)
    }

    /// One sample of the exposure stage's output; returns the level change, if any.
    ///
    /// While the exposure is not valid (warm-up) the level holds and nothing is pending.
    #[inline]
    pub fn step(
        &self,
        state: &mut AlertState,
        exposure: &ExposureSample,
        sample_index: u32,
    ) -> Option<AlertEvent> {
        if !exposure.valid {
            state.pending_dir = 0;
            state.pending_samples = 0;
            return None;
        }
        let (ms, vdv4) = (exposure.running_ms_m2_s4, exposure.vdv4_m4_s7);
        // Fast path, the usual case: neither the next level up nor the clear threshold
        // of the current level is reached (thresholds increase with the level).
        let lvl = state.level as usize;
        let up_called = lvl < 3 && (ms >= self.raise_ms_m2_s4[lvl] || vdv4 >= self.vdv4_m4_s7[lvl]);
        let down_called =
            lvl > 0 && ms < self.clear_ms_m2_s4[lvl - 1] && vdv4 < self.vdv4_m4_s7[lvl - 1];
        if !up_called && !down_called {
            state.pending_dir = 0;
            state.pending_samples = 0;
            return None;
        }
        let up = self.level_for(&self.raise_ms_m2_s4, ms, vdv4);
        let target = if up > state.level {
            up
        } else {
            let hold = self.level_for(&self.clear_ms_m2_s4, ms, vdv4);
            if hold < state.level {
                hold
            } else {
                state.level
            }
        };
        if target == state.level {
            state.pending_dir = 0;
            state.pending_samples = 0;
            return None;
        }
        let dir: i8 = if target > state.level { 1 } else { -1 };
        if dir != state.pending_dir {
            state.pending_dir = dir;
            state.pending_samples = 0;
        }
        state.pending_samples += 1;
        let need = if dir > 0 {
            self.raise_dwell_samples
        } else {
            self.clear_dwell_samples
        };
        if state.pending_samples < need {
            return None;
        }
        let from = state.level;
        state.level = target;
        state.pending_dir = 0;
        state.pending_samples = 0;
        // Only when an event is sent: one or two square roots, as the telemetry takes them.
        // A raise has `target >= 1`; `||` keeps a drop from indexing.
        let criterion = if dir < 0 || ms >= self.raise_ms_m2_s4[target as usize - 1] {
            Criterion::RunningRms {
                value_m_s2: sqrt_f32(ms),
            }
        } else {
            Criterion::Vdv {
                value_m_s175: sqrt_f32(sqrt_f32(vdv4)),
            }
        };
        Some(AlertEvent::Level {
            from,
            to: target,
            criterion,
            at_sample: sample_index,
        })
    }

    /// `N` consecutive outputs of [`ExposureSettings::step_block`](crate::exposure::ExposureSettings::step_block)
    /// (indices `first_index..first_index + N`); calls `on_event` for each level change.
    ///
    /// Same events and state, bit for bit, as `N` calls of [`step`](Self::step): while
    /// nothing is pending, samples that call for no change are skipped with two or three
    /// comparisons against the current level's thresholds, held in registers.
    #[inline]
    pub fn step_block<const N: usize>(
        &self,
        state: &mut AlertState,
        exposure: &[ExposureSample; N],
        first_index: u32,
        mut on_event: impl FnMut(AlertEvent),
    ) {
        let mut n = 0;
        while n < N {
            if state.pending_dir == 0 {
                let lvl = state.level as usize;
                let (up_ms, up_q) = if lvl < 3 {
                    (self.raise_ms_m2_s4[lvl], self.vdv4_m4_s7[lvl])
                } else {
                    (f32::INFINITY, f32::INFINITY)
                };
                let (down_ms, down_q) = if lvl > 0 {
                    (self.clear_ms_m2_s4[lvl - 1], self.vdv4_m4_s7[lvl - 1])
                } else {
                    (f32::NEG_INFINITY, f32::NEG_INFINITY)
                };
                while n < N {
                    let e = &exposure[n];
                    let (ms, q) = (e.running_ms_m2_s4, e.vdv4_m4_s7);
                    let called = ms >= up_ms || q >= up_q || (ms < down_ms && q < down_q);
                    if e.valid && called {
                        break;
                    }
                    n += 1;
                }
                if n == N {
                    break;
                }
            }
            if let Some(event) = self.step(state, &exposure[n], first_index.wrapping_add(n as u32))
            {
                on_event(event);
            }
            n += 1;
        }
    }
}

/// Sensor-fault check configuration (SI units), for the litter accelerometer's samples; a
/// parameter file's `[device.sensor_checks]`, where a key left out keeps its
/// [`DEFAULT`](Self::DEFAULT).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "file-form", serde(default, deny_unknown_fields))]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SensorCheckConfig {
    /// |sample| at or above this is saturation, m/s^2 (set a little below the range).
    pub full_scale_m_s2: f32,
    /// An axis repeating exactly the same value this long is stuck, s.
    pub stuck_after_s: f32,
    /// A fault clears after this long without it, s.
    pub clear_after_s: f32,
}

impl SensorCheckConfig {
    /// Full scale 16 g, stuck after 1 s of identical values, clear after 1 s fault-free.
    pub const DEFAULT: SensorCheckConfig = SensorCheckConfig {
        full_scale_m_s2: 16.0 * STANDARD_GRAVITY_M_S2,
        stuck_after_s: 1.0,
        clear_after_s: 1.0,
    };

    /// Largest full scale accepted, m/s^2 (400 g, the widest MEMS accelerometers). The
    /// pipeline clamps every sample to the full scale before the model, so this bounds
    /// what the model and the exposure's squares and fourth powers can ever see: with it,
    /// no finite sample can overflow their f32 state (docs/exposure.md#sensor-faults).
    pub const MAX_FULL_SCALE_M_S2: f32 = 400.0 * STANDARD_GRAVITY_M_S2;

    /// |sample| at or above this is saturation, m/s^2: the full scale, or the device's
    /// input range if smaller, since the pipeline clips every input to both
    /// (docs/exposure.md#input-resolution).
    #[inline(always)]
    pub fn saturation_m_s2(&self) -> f32 {
        // A comparison, not f32::min: no NaN handling (validation refuses a NaN full
        // scale) and no libm call on the device.
        if self.full_scale_m_s2 < INPUT_RANGE_M_S2 {
            self.full_scale_m_s2
        } else {
            INPUT_RANGE_M_S2
        }
    }
}

impl Default for SensorCheckConfig {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// The sensor-fault check's precomputed limits, for one sample rate (which the parameter
/// blob stores once, beside these settings).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct SensorCheckSettings {
    /// The configuration these settings were built from.
    pub config: SensorCheckConfig,
    /// Identical samples (per axis) after which the axis is stuck.
    pub stuck_after_samples: u32,
    /// Fault-free samples after which a fault clears.
    pub clear_after_samples: u32,
}

/// Running state of the sensor-fault check.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SensorCheckState {
    /// Active faults.
    active: FaultFlags,
    /// Fault-free samples since each fault was last seen.
    good_run: [u32; 4],
    last_bits: [u32; 3],
    unchanged: [u32; 3],
    last_index: u32,
    started: bool,
}

impl SensorCheckState {
    /// No fault active, no sample seen.
    pub const fn new() -> Self {
        Self {
            active: FaultFlags::empty(),
            good_run: [0; 4],
            last_bits: [0; 3],
            unchanged: [0; 3],
            last_index: 0,
            started: false,
        }
    }

    /// The active faults.
    pub fn active(&self) -> FaultFlags {
        self.active
    }
}

/// Up to one raise or clear per fault kind, from one sample.
pub type SensorEvents = heapless::Vec<AlertEvent, 4>;

impl SensorCheckSettings {
    /// Validates `config` and converts its times to samples at `sample_rate`.
    pub fn new(config: SensorCheckConfig, sample_rate: SampleRate) -> Result<Self, AlertError> {
        let fs = sample_rate.hz_f64();
        let full_scale = config.full_scale_m_s2;
        if !(full_scale > 0.0 && full_scale <= SensorCheckConfig::MAX_FULL_SCALE_M_S2) {
            return Err(AlertError::FullScale);
        }
        Ok(Self {
            config,
            stuck_after_samples: samples_of(config.stuck_after_s, fs)?,
            clear_after_samples: samples_of(config.clear_after_s, fs)?,
        })
    }

    /// Checks stored settings (from a parameter blob, built for `sample_rate`) by
    /// rebuilding them from their config.
    pub fn validate(&self, sample_rate: SampleRate) -> Result<(), AlertError> {
        if Self::new(self.config, sample_rate)? == *self {
            Ok(())
        } else {
            Err(AlertError::Time)
        }
    }

    /// One raw sample (m/s^2, three axes) with its index; returns the fault edges it causes.
    #[inline]
    pub fn step(
        &self,
        state: &mut SensorCheckState,
        sample_m_s2: [f32; 3],
        sample_index: u32,
    ) -> SensorEvents {
        let mut bad = FaultFlags::empty();
        let saturation = self.config.saturation_m_s2();
        for (i, &x) in sample_m_s2.iter().enumerate() {
            // One comparison catches NaN, infinities and saturation: NaN compares false.
            #[allow(clippy::neg_cmp_op_on_partial_ord)]
            if !(x.abs() < saturation) {
                bad |= if x.is_finite() {
                    SensorFault::Saturated
                } else {
                    SensorFault::NonFinite
                };
            }
            let bits = x.to_bits();
            if bits == state.last_bits[i] && state.started {
                state.unchanged[i] = state.unchanged[i].saturating_add(1);
                if state.unchanged[i] >= self.stuck_after_samples {
                    bad |= SensorFault::Stuck;
                }
            } else {
                state.unchanged[i] = 0;
                state.last_bits[i] = bits;
            }
        }
        if state.started && sample_index != state.last_index.wrapping_add(1) {
            bad |= SensorFault::IndexGap;
        }
        state.last_index = sample_index;
        state.started = true;
        let mut events = SensorEvents::new();
        if bad.is_empty() && state.active.is_empty() {
            return events;
        }
        for fault in SensorFault::ALL {
            let k = fault as usize;
            if bad.contains(fault) {
                state.good_run[k] = 0;
                if state.active.insert(fault) {
                    let _ = events.push(AlertEvent::Fault {
                        fault,
                        active: true,
                        at_sample: sample_index,
                    });
                }
            } else if state.active.contains(fault) {
                state.good_run[k] += 1;
                if state.good_run[k] >= self.clear_after_samples {
                    state.active.remove(fault);
                    let _ = events.push(AlertEvent::Fault {
                        fault,
                        active: false,
                        at_sample: sample_index,
                    });
                }
            }
        }
        events
    }

    /// `N` raw samples with their indices; calls `on_event` for each fault edge.
    ///
    /// Same events and state as `N` calls of [`step`](Self::step): while no fault is
    /// active, healthy samples (finite, inside full scale, each index one more than the
    /// last, no axis near the stuck limit) are handled with the check's memories in
    /// registers; anything else goes through `step`.
    #[inline]
    pub fn step_block<const N: usize>(
        &self,
        state: &mut SensorCheckState,
        samples_m_s2: &[[f32; 3]; N],
        sample_indices: &[u32; N],
        mut on_event: impl FnMut(AlertEvent),
    ) {
        let full_scale = self.config.saturation_m_s2();
        let stuck = self.stuck_after_samples;
        let mut n = 0;
        while n < N {
            if state.active.is_empty() && state.started {
                let (mut last, mut unchanged, mut last_index) =
                    (state.last_bits, state.unchanged, state.last_index);
                while n < N {
                    let (x, index) = (samples_m_s2[n], sample_indices[n]);
                    let bits = x.map(f32::to_bits);
                    // Decide first, update after: a sample that needs `step` leaves the
                    // memories as they were. `unchanged + 1 < stuck` also rules out overflow.
                    let gap = index != last_index.wrapping_add(1);
                    let in_range = (x[0].abs() < full_scale)
                        & (x[1].abs() < full_scale)
                        & (x[2].abs() < full_scale);
                    let same = [bits[0] == last[0], bits[1] == last[1], bits[2] == last[2]];
                    let near_stuck = (same[0] & (unchanged[0] + 1 >= stuck))
                        | (same[1] & (unchanged[1] + 1 >= stuck))
                        | (same[2] & (unchanged[2] + 1 >= stuck));
                    if gap | !in_range | near_stuck {
                        break;
                    }
                    for i in 0..3 {
                        unchanged[i] = if same[i] { unchanged[i] + 1 } else { 0 };
                    }
                    last = bits;
                    last_index = index;
                    n += 1;
                }
                (state.last_bits, state.unchanged, state.last_index) =
                    (last, unchanged, last_index);
                if n == N {
                    break;
                }
            }
            for event in self.step(state, samples_m_s2[n], sample_indices[n]) {
                on_event(event);
            }
            n += 1;
        }
    }
}

#[cfg(test)]
mod tests;
