//! Alerts on joint motion: a joint output's running rms above its threshold, or its largest
//! excursion above its own, as time-stamped raise and clear events ([`AlertEvent::Joint`]).
//!
//! # No default thresholds
//! No standard sets limits for the motion of a supine patient's neck or lower back, and
//! the studies of immobilized transport measured motion, not harm (`docs/exposure.md`,
//! "Joint-motion alerts"). So none are shipped: with no threshold set (the default) there
//! is no joint alert, and a medical director sets them per mission in the parameter file's
//! `[device.joint_alerts]`.
//!
//! # Rules
//! - Running rms (the joint exposure's, tau as the head's): raised once it has been at or
//!   above its threshold for `raise_dwell_s`, cleared once it has been below
//!   `(1 - hysteresis)` of it for `clear_dwell_s`, as the head's levels.
//! - Largest excursion: raised at the first reading whose |value| is above its threshold.
//!   The largest excursion never decreases, so, like a VDV level, it lasts until the
//!   evaluation restarts.
//!
//! The joint outputs are read every `decimation`-th sample (`crate::joint_exposure`), so
//! dwell times count readings, not samples.
//!
//! # Cost
//! With no threshold set, one test of two masks per reading. Per watched output, a reading
//! costs one or two f32 comparisons against precomputed squared thresholds; a square root
//! only when an event is sent.

use core::fmt;

use serde::{Deserialize, Serialize};

use super::{AlertConfig, AlertError, MAX_DWELL_S};
use crate::fpu::sqrt_f32;
use crate::model::JOINT_OUTPUT_COUNT;
use crate::sample_rate::SampleRate;

/// What a joint alert is about, and its value when it changed (m for a translation, rad
/// for a rotation: the output's own unit).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum JointCriterion {
    /// The output's running rms (tau as the head's).
    RunningRms {
        /// Its value at the change, m or rad.
        value_m_or_rad: f32,
    },
    /// The output's largest absolute value since the evaluation started.
    Excursion {
        /// Its value at the raise, m or rad.
        value_m_or_rad: f32,
    },
}

impl JointCriterion {
    /// Lower-case name (`running-rms`, `excursion`).
    pub const fn name(&self) -> &'static str {
        match self {
            JointCriterion::RunningRms { .. } => "running-rms",
            JointCriterion::Excursion { .. } => "excursion",
        }
    }

    /// The value at the change, m or rad.
    pub const fn value_m_or_rad(&self) -> f32 {
        match *self {
            JointCriterion::RunningRms { value_m_or_rad }
            | JointCriterion::Excursion { value_m_or_rad } => value_m_or_rad,
        }
    }
}

impl fmt::Display for JointCriterion {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} {}", self.name(), self.value_m_or_rad())
    }
}

/// Joint-motion alert thresholds as carried in the parameter blob (SI units).
///
/// Thresholds are per output read, in the order telemetry lists the values
/// ([`packed_order`](crate::joint_exposure::packed_order) of the readout's outputs); 0
/// means no threshold, and a position past the outputs read must hold 0.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct JointAlertConfig {
    /// Running-rms threshold per output read, m or rad (0: none).
    pub running_rms_m_or_rad: [f32; JOINT_OUTPUT_COUNT],
    /// Largest-excursion threshold per output read, m or rad (0: none).
    pub excursion_m_or_rad: [f32; JOINT_OUTPUT_COUNT],
    /// A running-rms alert clears below `(1 - hysteresis)` times its threshold (0..=0.9).
    pub hysteresis: f32,
    /// How long the running rms must stay at or above its threshold before the alert is
    /// raised, s.
    pub raise_dwell_s: f32,
    /// How long it must stay below the clear threshold before the alert clears, s.
    pub clear_dwell_s: f32,
}

impl JointAlertConfig {
    /// No threshold (the default: none is shipped), the head's hysteresis and dwell.
    pub const NONE: JointAlertConfig = JointAlertConfig {
        running_rms_m_or_rad: [0.0; JOINT_OUTPUT_COUNT],
        excursion_m_or_rad: [0.0; JOINT_OUTPUT_COUNT],
        hysteresis: AlertConfig::DEFAULT.hysteresis,
        raise_dwell_s: AlertConfig::DEFAULT.raise_dwell_s,
        clear_dwell_s: AlertConfig::DEFAULT.clear_dwell_s,
    };
}

impl Default for JointAlertConfig {
    fn default() -> Self {
        Self::NONE
    }
}

/// The joint alerts' precomputed thresholds, for one sample rate and reading interval.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct JointAlertSettings {
    /// The configuration these settings were built from.
    pub config: JointAlertConfig,
    /// Squared running-rms raise thresholds, m^2 or rad^2 (0 where none).
    pub raise_ms: [f32; JOINT_OUTPUT_COUNT],
    /// Squared clear thresholds `((1 - h) threshold)^2`, m^2 or rad^2 (0 where none).
    pub clear_ms: [f32; JOINT_OUTPUT_COUNT],
    /// Raise dwell, readings of the joint outputs (at least 1).
    pub raise_dwell_readings: u32,
    /// Clear dwell, readings (at least 1).
    pub clear_dwell_readings: u32,
    /// Bit `k`: output `k` (packed order) has a running-rms threshold.
    pub rms_watched: u16,
    /// Bit `k`: output `k` has an excursion threshold.
    pub excursion_watched: u16,
}

/// Running state of the joint alerts.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct JointAlertState {
    /// Bit `k`: output `k`'s running-rms alert is raised.
    rms_raised: u16,
    /// Bit `k`: output `k`'s excursion alert has been raised (it stays).
    excursion_raised: u16,
    /// Consecutive readings output `k`'s pending change has been called for.
    pending_readings: [u32; JOINT_OUTPUT_COUNT],
}

impl JointAlertState {
    /// Nothing raised, nothing pending.
    pub const fn new() -> Self {
        Self {
            rms_raised: 0,
            excursion_raised: 0,
            pending_readings: [0; JOINT_OUTPUT_COUNT],
        }
    }

    /// Bit `k`: output `k`'s (packed order) running-rms alert is raised.
    pub const fn rms_raised(&self) -> u16 {
        self.rms_raised
    }

    /// Bit `k`: output `k`'s excursion alert has been raised.
    pub const fn excursion_raised(&self) -> u16 {
        self.excursion_raised
    }
}

/// Readings in `t_s` when the joints are read every `decimation`-th sample at `fs`, at
/// least one.
fn readings_of(t_s: f32, fs: f64, decimation: u16) -> Result<u32, AlertError> {
    if t_s.is_finite() && (0.0..=MAX_DWELL_S).contains(&t_s) {
        let per_s = fs / f64::from(decimation.max(1));
        Ok((libm::round(t_s as f64 * per_s) as u32).max(1))
    } else {
        Err(AlertError::Time)
    }
}

/// Bit `k` set where `thresholds[k]` is set (not 0).
fn set_mask(thresholds: &[f32; JOINT_OUTPUT_COUNT]) -> u16 {
    thresholds
        .iter()
        .enumerate()
        .fold(0, |m, (k, &t)| if t != 0.0 { m | (1 << k) } else { m })
}

impl JointAlertSettings {
    /// Validates `config` for `outputs_read` joint outputs, read every `decimation`-th
    /// sample at `sample_rate`, and precomputes its thresholds and dwells.
    pub fn new(
        config: JointAlertConfig,
        sample_rate: SampleRate,
        decimation: u16,
        outputs_read: usize,
    ) -> Result<Self, AlertError> {
        let fs = sample_rate.hz_f64();
        let thresholds = config
            .running_rms_m_or_rad
            .iter()
            .chain(&config.excursion_m_or_rad);
        let fine = thresholds.clone().all(|t| t.is_finite() && *t >= 0.0);
        let set = set_mask(&config.running_rms_m_or_rad) | set_mask(&config.excursion_m_or_rad);
        if !fine || set >> outputs_read.min(JOINT_OUTPUT_COUNT) != 0 {
            return Err(AlertError::JointThresholds);
        }
        if !(config.hysteresis.is_finite() && (0.0..=0.9).contains(&config.hysteresis)) {
            return Err(AlertError::Hysteresis);
        }
        let h = 1.0 - config.hysteresis as f64;
        let rms = config.running_rms_m_or_rad.map(|t| t as f64);
        Ok(Self {
            config,
            raise_ms: rms.map(|t| (t * t) as f32),
            clear_ms: rms.map(|t| (h * h * t * t) as f32),
            raise_dwell_readings: readings_of(config.raise_dwell_s, fs, decimation)?,
            clear_dwell_readings: readings_of(config.clear_dwell_s, fs, decimation)?,
            rms_watched: set_mask(&config.running_rms_m_or_rad),
            excursion_watched: set_mask(&config.excursion_m_or_rad),
        })
    }

    /// Checks stored settings (from a parameter blob) by rebuilding them from their config.
    pub fn validate(
        &self,
        sample_rate: SampleRate,
        decimation: u16,
        outputs_read: usize,
    ) -> Result<(), AlertError> {
        if Self::new(self.config, sample_rate, decimation, outputs_read)? == *self {
            Ok(())
        } else {
            Err(AlertError::JointThresholds)
        }
    }

    /// Whether any threshold is set: with none, the pipeline skips [`step`](Self::step).
    #[inline(always)]
    pub const fn watches_any(&self) -> bool {
        self.rms_watched | self.excursion_watched != 0
    }

    /// One reading of the joint exposure: `mean_square` and `largest_excursion` of the
    /// outputs read (packed order, m^2 or rad^2 and m or rad) after this reading's step.
    /// Calls `on_event(k, criterion, raised)` for each change of output `k` (packed order),
    /// running-rms alerts first, in output order.
    pub fn step(
        &self,
        state: &mut JointAlertState,
        mean_square: &[f32],
        largest_excursion: &[f32],
        mut on_event: impl FnMut(usize, JointCriterion, bool),
    ) {
        let mut watched = self.rms_watched;
        while watched != 0 {
            let k = watched.trailing_zeros() as usize;
            watched &= watched - 1;
            let (Some(&ms), Some(pending)) =
                (mean_square.get(k), state.pending_readings.get_mut(k))
            else {
                continue;
            };
            let bit = 1 << k;
            let raised = state.rms_raised & bit != 0;
            let called = if raised {
                ms < self.clear_ms[k]
            } else {
                ms >= self.raise_ms[k]
            };
            if !called {
                *pending = 0;
                continue;
            }
            *pending += 1;
            let need = if raised {
                self.clear_dwell_readings
            } else {
                self.raise_dwell_readings
            };
            if *pending >= need {
                *pending = 0;
                state.rms_raised ^= bit;
                let value_m_or_rad = sqrt_f32(ms);
                on_event(k, JointCriterion::RunningRms { value_m_or_rad }, !raised);
            }
        }
        let mut watched = self.excursion_watched & !state.excursion_raised;
        while watched != 0 {
            let k = watched.trailing_zeros() as usize;
            watched &= watched - 1;
            let Some(&peak) = largest_excursion.get(k) else {
                continue;
            };
            if peak > self.config.excursion_m_or_rad[k] {
                state.excursion_raised |= 1 << k;
                let criterion = JointCriterion::Excursion {
                    value_m_or_rad: peak,
                };
                on_event(k, criterion, true);
            }
        }
    }

    /// Every number of the configuration and the tables derived from it (for the blob's
    /// check that all are finite).
    pub fn numbers(&self) -> impl Iterator<Item = f32> + '_ {
        let c = &self.config;
        c.running_rms_m_or_rad
            .iter()
            .chain(&c.excursion_m_or_rad)
            .chain(&self.raise_ms)
            .chain(&self.clear_ms)
            .copied()
            .chain([c.hysteresis, c.raise_dwell_s, c.clear_dwell_s])
    }
}

#[cfg(test)]
mod tests;
