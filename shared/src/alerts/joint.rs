//! Alerts on joint motion: a joint output's running rms above its threshold, or its largest
//! excursion above its own, as time-stamped raise and clear events ([`AlertEvent::Joint`](crate::alerts::AlertEvent::Joint)).
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
//! costs a multiplication or two (the squared threshold) and a comparison; a square root
//! only when an event is sent.

use core::fmt;

use serde::{Deserialize, Serialize};

use super::{AlertConfig, AlertError, samples_of};
use crate::fpu::sqrt_f32;
use crate::model::JOINT_OUTPUT_COUNT;
use crate::sample_rate::SampleRate;

/// What a joint alert is about, and its value when it changed (m for a translation, rad
/// for a rotation: the output's own unit). Serde names the variants as
/// [`JointCriterion::name`] does; on the wire (postcard) a variant is its index.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
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
    #[serde(with = "thresholds_serde")]
    pub running_rms_m_or_rad: [f32; JOINT_OUTPUT_COUNT],
    /// Largest-excursion threshold per output read, m or rad (0: none).
    #[serde(with = "thresholds_serde")]
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

/// The joint alerts' settings for one sample rate and reading interval: the thresholds
/// as configured (the squares the running mean square is compared with are taken per
/// reading, one multiplication each: storing them would add 80 bytes to the blob and to
/// each copy of the parameters in the device's RAM), dwells in readings, and which
/// outputs are watched.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct JointAlertSettings {
    /// The configuration these settings were built from.
    pub config: JointAlertConfig,
    /// `(1 - hysteresis)^2`: a squared running-rms threshold times this is where the alert
    /// clears, m^2 or rad^2.
    pub clear_factor: f32,
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

/// Readings in `t_s` when the joints are read every `decimation`-th sample at `fs`: the
/// samples in it, rounded to whole readings, at least one. In integers: an f64 division
/// would add a kilobyte of soft-float code to the device.
fn readings_of(t_s: f32, fs: f64, decimation: u16) -> Result<u32, AlertError> {
    let samples = samples_of(t_s, fs)?;
    let d = u32::from(decimation.max(1));
    Ok(((samples + d / 2) / d).max(1))
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
        // Loops bounded by the outputs read, not by a constant: the device validates every
        // blob it loads, and a loop of ten unrolled costs it a kilobyte of flash. A
        // comparison with infinity refuses NaN (every comparison with it is false).
        let (rms, excursion) = (&config.running_rms_m_or_rad, &config.excursion_m_or_rad);
        let read = outputs_read.min(JOINT_OUTPUT_COUNT);
        let (mut rms_watched, mut excursion_watched) = (0u16, 0u16);
        for k in 0..read {
            let (t, e) = (rms[k], excursion[k]);
            if !((0.0..f32::INFINITY).contains(&t) && (0.0..f32::INFINITY).contains(&e)) {
                return Err(AlertError::JointThresholds);
            }
            rms_watched |= u16::from(t != 0.0) << k;
            excursion_watched |= u16::from(e != 0.0) << k;
        }
        for k in read..JOINT_OUTPUT_COUNT {
            if rms[k] != 0.0 || excursion[k] != 0.0 {
                return Err(AlertError::JointThresholds);
            }
        }
        if !(config.hysteresis.is_finite() && (0.0..=0.9).contains(&config.hysteresis)) {
            return Err(AlertError::Hysteresis);
        }
        let c = 1.0 - config.hysteresis;
        Ok(Self {
            config,
            clear_factor: c * c,
            raise_dwell_readings: readings_of(config.raise_dwell_s, fs, decimation)?,
            clear_dwell_readings: readings_of(config.clear_dwell_s, fs, decimation)?,
            rms_watched,
            excursion_watched,
        })
    }

    /// Checks stored settings (from a parameter blob) by rebuilding them from their config.
    pub fn validate(
        &self,
        sample_rate: SampleRate,
        decimation: u16,
        outputs_read: usize,
    ) -> Result<(), AlertError> {
        // The config is checked by `new`; only what it derives can differ.
        let rebuilt = Self::new(self.config, sample_rate, decimation, outputs_read)?;
        let derived = |s: &Self| {
            (
                s.clear_factor.to_bits(),
                s.raise_dwell_readings,
                s.clear_dwell_readings,
                s.rms_watched,
                s.excursion_watched,
            )
        };
        if derived(&rebuilt) == derived(self) {
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
            let t = self.config.running_rms_m_or_rad[k];
            let raise_ms = t * t;
            let called = if raised {
                ms < raise_ms * self.clear_factor
            } else {
                ms >= raise_ms
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

    /// The numbers of the configuration besides its thresholds (which
    /// [`new`](Self::new) checks), for the blob's check that all are finite.
    pub fn scalars(&self) -> [f32; 4] {
        let c = &self.config;
        [
            c.hysteresis,
            c.raise_dwell_s,
            c.clear_dwell_s,
            self.clear_factor,
        ]
    }
}

/// A table of thresholds encoded exactly as serde encodes `[f32; 10]` (a tuple of ten),
/// decoded in a loop: serde's own array decoder repeats its code per element, which cost
/// the device a kilobyte of flash for the two tables.
mod thresholds_serde {
    use core::fmt;

    use serde::de::{Error, SeqAccess, Visitor};
    use serde::ser::SerializeTuple;
    use serde::{Deserializer, Serializer};

    use crate::model::JOINT_OUTPUT_COUNT;

    type Table = [f32; JOINT_OUTPUT_COUNT];

    pub fn serialize<S: Serializer>(table: &Table, serializer: S) -> Result<S::Ok, S::Error> {
        let mut tuple = serializer.serialize_tuple(JOINT_OUTPUT_COUNT)?;
        for v in table {
            tuple.serialize_element(v)?;
        }
        tuple.end()
    }

    struct TableVisitor;

    impl<'de> Visitor<'de> for TableVisitor {
        type Value = Table;

        fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
            f.write_str("ten joint thresholds")
        }

        fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Table, A::Error> {
            let mut table = [0.0; JOINT_OUTPUT_COUNT];
            for (k, slot) in table.iter_mut().enumerate() {
                *slot = seq
                    .next_element()?
                    .ok_or_else(|| A::Error::invalid_length(k, &self))?;
            }
            Ok(table)
        }
    }

    pub fn deserialize<'de, D: Deserializer<'de>>(deserializer: D) -> Result<Table, D::Error> {
        deserializer.deserialize_tuple(JOINT_OUTPUT_COUNT, TableVisitor)
    }
}

#[cfg(test)]
mod tests;
